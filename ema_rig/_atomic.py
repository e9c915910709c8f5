"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or an error half-way never leaves a half-written output file. An OS error (disk full,
permission denied) names the output file, not the temporary one. Temporary files left by a
killed process are recognised by their name and removed by :func:`remove_temporaries`;
:func:`folder_lock` keeps a second run out of an output folder in use.
"""

from __future__ import annotations

import json
import os
import re
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from os import PathLike
from pathlib import Path
from typing import Any

from .errors import EmaRigError

#: Name of a temporary file made by :func:`atomic_path`: ``.<target>.<8 random>.tmp<suffix>``.
_TEMP_NAME = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp(\.[^.]*)?$")


@contextmanager
def atomic_path(path: str | PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    The temporary file keeps the target's suffix, so writers that pick a format from the
    suffix (``savefig``) behave the same. On error the temporary file is removed; an
    :class:`OSError` (disk full, permission denied ...) is re-raised naming ``path``.
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
    try:
        os.chmod(tmp_path, 0o644)  # mkstemp makes 0600; outputs are ordinary readable files
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


def remove_temporaries(folder: str | PathLike[str]) -> list[Path]:
    """Remove the temporary files a killed writer left in ``folder`` (not recursive).

    Call it only while holding :func:`folder_lock`, so that no writer of ours is active there.

    Returns
    -------
    list of Path
        The files removed.
    """
    removed: list[Path] = []
    try:
        entries = list(os.scandir(folder))
    except FileNotFoundError:
        return removed
    for e in entries:
        if _TEMP_NAME.match(e.name) and e.is_file(follow_symlinks=False):
            Path(e.path).unlink(missing_ok=True)
            removed.append(Path(e.path))
    return removed


class FolderBusyError(EmaRigError):
    """Another process holds the lock of an output folder (``file`` is the folder)."""


@contextmanager
def folder_lock(folder: str | PathLike[str], name: str = ".ema-rig.lock") -> Iterator[Path]:
    """Hold an exclusive, non-blocking lock on ``folder`` for the duration of the block.

    The lock is an OS file lock on ``folder/name`` (``flock`` on POSIX, ``msvcrt.locking`` on
    Windows): the OS releases it when the process dies, even by ``kill -9``, so a crashed run never
    leaves the folder locked. The lock file stays (deleting it would race with a waiting run).

    Raises
    ------
    FolderBusyError
        When another process (or another run in this process) holds the lock; the message
        names the folder and the holder's process id.
    """
    d = Path(folder)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise _about(exc, d, exc.strerror or str(exc)) from exc
    try:
        fd = os.open(d / name, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as exc:
        raise _about(exc, d / name, exc.strerror or str(exc)) from exc
    try:
        try:
            _lock_fd(fd)
        except OSError:
            holder = os.pread(fd, 64, 0).decode("ascii", "replace").strip() if hasattr(os, "pread") else ""
            raise FolderBusyError(
                "output folder is in use by another ema-rig run"
                + (f" (process {holder})" if holder.isdigit() else "")
                + "; wait for it to finish or choose another output folder",
                file=d,
            ) from None
        os.ftruncate(fd, 0)
        os.write(fd, f"{os.getpid()}\n".encode("ascii"))
        yield d / name
    finally:
        os.close(fd)  # closing the descriptor releases the lock


def _lock_fd(fd: int) -> None:
    if sys.platform == "win32":  # pragma: no cover - Windows
        import msvcrt

        msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
    else:
        import fcntl

        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)


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
