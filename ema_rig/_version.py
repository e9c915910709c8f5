"""The installed version of ema_rig, looked up once and only when asked for.

``importlib.metadata`` costs ~40 ms, so :func:`version` imports it on its first call; the lower
layers (cache keys, figure stamps, the report) call it instead of importing the package facade.
"""

from __future__ import annotations

import functools


@functools.cache
def version() -> str:
    """The version of the installed ``ema-rig`` distribution, or ``"0.0.0+unknown"`` in a source tree.

    Returns
    -------
    str
        The version string (PEP 440).
    """
    from importlib.metadata import PackageNotFoundError
    from importlib.metadata import version as dist_version

    try:
        return dist_version("ema-rig")
    except PackageNotFoundError:  # running from a source tree that is not installed
        return "0.0.0+unknown"
