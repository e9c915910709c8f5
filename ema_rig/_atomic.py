"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or an error half-way never leaves a half-written output file.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from os import PathLike
from pathlib import Path
from typing import Any


@contextmanager
def atomic_path(path: str | PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    The temporary file keeps the target's suffix, so writers that pick a format from the
    suffix (``savefig``) behave the same. On error the temporary file is removed.
    """
    target = Path(path)
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        why = "a file is in the way" if isinstance(exc, (FileExistsError, NotADirectoryError)) else exc.strerror
        raise _about(exc, target, f"cannot create the folder {target.parent} ({why or exc})") from exc
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".tmp{target.suffix}", dir=target.parent)
    except OSError as exc:
        raise _about(exc, target, exc.strerror or str(exc)) from exc
    os.close(fd)
    tmp_path = Path(tmp)
    os.chmod(tmp_path, 0o644)  # mkstemp makes 0600; outputs are ordinary readable files
    try:
        yield tmp_path
        os.replace(tmp_path, target)
    except OSError as exc:  # disk full, permissions ...: name the output, not the temporary file
        tmp_path.unlink(missing_ok=True)
        if exc.errno is None or (exc.filename is not None and str(exc.filename) != str(tmp_path)):
            raise  # about another file (the writer's own input, say): keep its name
        raise _about(exc, target, exc.strerror or str(exc)) from exc
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise


def _about(exc: OSError, target: Path, text: str) -> OSError:
    """An OSError with ``exc``'s errno (hence its subclass) and ``text``, naming ``target``."""
    return OSError(exc.errno, text, str(target))


def write_text(path: str | PathLike[str], text: str) -> None:
    """Write UTF-8 text atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")


def write_bytes(path: str | PathLike[str], data: bytes) -> None:
    """Write bytes atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def write_json(path: str | PathLike[str], obj: Any) -> None:
    """Write an object as indented JSON atomically (NaN is written as null)."""
    write_text(path, json.dumps(_clean(obj), indent=2, allow_nan=False) + "\n")


def _clean(obj: Any) -> Any:
    """Make numpy scalars/arrays and non-finite floats JSON-safe."""
    import math

    import numpy as np

    if isinstance(obj, dict):
        return {str(k): _clean(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_clean(v) for v in obj]
    if isinstance(obj, np.ndarray):
        return _clean(obj.tolist())
    if isinstance(obj, np.generic):
        return _clean(obj.item())
    if isinstance(obj, float):
        return obj if math.isfinite(obj) else None
    if isinstance(obj, complex):
        return {"re": _clean(obj.real), "im": _clean(obj.imag)}
    if isinstance(obj, PathLike):
        return os.fspath(obj)
    return obj
