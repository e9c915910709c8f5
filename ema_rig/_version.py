"""The installed version of ema_rig, looked up once and only when asked for.

``importlib.metadata`` costs ~40 ms, so :func:`version` imports it on its first call; the lower
layers (cache keys, figure stamps, the report) call it instead of importing the package facade.
:func:`code_fingerprint` tells two builds of one version apart (a source tree between releases).
"""

from __future__ import annotations

import functools
import hashlib
from pathlib import Path


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


@functools.cache
def code_fingerprint() -> str:
    """SHA-256 of the package's Python sources (relative names and bytes, in name order).

    The version alone does not change between commits of a source tree or an editable install
    (every commit of 0.1.0 is "0.1.0"): a campaign's cache keyed by it reused results computed by
    older code after an update. Read once per process (88 files, 1.6 MB: ~3 ms) and memoised.

    Returns
    -------
    str
        The hex digest; ``"unreadable"`` when the sources cannot be read (a zipped install), so
        the key then rests on :func:`version` as before.
    """
    root = Path(__file__).resolve().parent
    h = hashlib.sha256()
    try:
        for path in sorted(root.rglob("*.py")):
            h.update(path.relative_to(root).as_posix().encode("utf-8") + b"\0")
            h.update(path.read_bytes() + b"\0")
    except OSError:
        return "unreadable"
    return h.hexdigest()
