"""Test fixtures written by pyuff, the independent UFF writer the reader is checked against."""

from __future__ import annotations

import contextlib
import io
from pathlib import Path


def write_with_pyuff(path: Path, sets: list[dict]) -> Path:
    """Write pyuff dataset dicts to ``path`` (pyuff's progress chatter silenced); returns ``path``."""
    import pyuff

    with contextlib.redirect_stdout(io.StringIO()):
        pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path
