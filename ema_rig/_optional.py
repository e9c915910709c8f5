"""Optional dependencies: one helper that names the extra to install."""

from __future__ import annotations

import importlib
from types import ModuleType


def import_optional(module: str, *, extra: str) -> ModuleType:
    """Import an optional module or raise an ImportError naming the ema-rig extra.

    Parameters
    ----------
    module : str
        Module to import, e.g. ``"pandas"``.
    extra : str
        The extra of ema-rig that installs it, e.g. ``"pandas"``.

    Raises
    ------
    ImportError
        ``"... needs pandas: pip install 'ema-rig[pandas]'"``.
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ImportError(
            f"this feature needs the optional package {module!r}: pip install 'ema-rig[{extra}]'"
        ) from exc
