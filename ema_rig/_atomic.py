"""Atomic file output: write to a temporary file beside the target, then rename.

A crash or an error half-way never leaves a half-written output file. An OS error (disk full,
permission denied) names the output file, not the temporary one. Temporary files left by a
killed process are recognised by their name and removed by :func:`remove_temporaries`;
:func:`folder_lock` keeps a second run out of an output folder in use. While a command runs
under :func:`removing_temporaries_on_signal`, SIGTERM, SIGHUP and SIGINT remove the temporary
files (and the lock file) of this process before it dies. :func:`check_outputs` refuses, before
anything is computed or written, an output that is one of the inputs, a folder, in a folder that
cannot be made, or a figure of an unknown format. Within :func:`all_or_nothing` the outputs are
renamed into place together when the block succeeds, and none is when it fails.
"""

from __future__ import annotations

import json
import math
import os
import re
import signal
import stat
import sys
import tempfile
import threading
from collections.abc import Collection, Iterable, Iterator, Mapping
from contextlib import contextmanager
from contextvars import ContextVar
from os import PathLike
from pathlib import Path
from typing import Any

from .errors import EmaRigError

#: Name of a temporary file made by :func:`atomic_path`: ``.<target>.<8 random>.tmp<suffix>``.
_TEMP_NAME = re.compile(r"^\..+\.[A-Za-z0-9_]{8}\.tmp(\.[^.]*)?$")
#: Files of this process to remove if it is told to stop (temporaries, held lock files): path -> pid.
_ACTIVE: dict[str, int] = {}
#: Descriptors of the folder locks this process holds (a forked worker must close its copies).
_LOCK_FDS: set[int] = set()
#: Inside :func:`all_or_nothing`: the written temporaries waiting for their rename, (temporary, target).
_STAGED: ContextVar[list[tuple[Path, Path]] | None] = ContextVar("_STAGED", default=None)
#: Figure formats every command writes (the suffix picks the format; matplotlib's savefig).
FIGURE_FORMATS = (".png", ".svg", ".pdf")


def _track(path: Path) -> None:
    _ACTIVE[os.fspath(path)] = os.getpid()


def _untrack(path: Path) -> None:
    _ACTIVE.pop(os.fspath(path), None)


def make_folder(folder: str | PathLike[str]) -> Path:
    """Create ``folder`` (and its parents) unless it exists; an error says what is in the way.

    Raises
    ------
    OSError
        Naming the folder: a dangling symbolic link ("a symbolic link to the missing ..."), a file
        in the way, or the operating system's reason (permission ...).
    """
    d = Path(folder)
    try:
        d.mkdir(parents=True, exist_ok=True)
    except (FileExistsError, NotADirectoryError) as exc:
        bad = next((p for p in (d, *d.parents) if os.path.lexists(p) and not p.is_dir()), d)
        raise OSError(exc.errno, f"cannot create the folder {d} ({_in_the_way(bad)})", str(d)) from None
    except OSError as exc:
        raise _about(exc, d, f"cannot create the folder {d} ({exc.strerror or exc})") from exc
    return d


def _in_the_way(bad: Path) -> str:
    """What keeps a folder from being made: ``bad``, the existing non-folder on its path."""
    if bad.is_symlink():
        return f"{bad} is a symbolic link to the missing {os.readlink(bad)}: remove it or create its target"
    return "a file is in the way"


@contextmanager
def atomic_path(path: str | PathLike[str]) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it onto ``path`` if the block succeeds.

    The temporary file keeps the target's suffix, so writers that pick a format from the
    suffix (``savefig``) behave the same. On error the temporary file is removed; an
    :class:`OSError` (disk full, permission denied ...) is re-raised naming ``path``. Inside
    :func:`all_or_nothing` the rename waits for the end of that block.
    """
    target = Path(path)
    try:
        make_folder(target.parent)
    except OSError as exc:
        raise OSError(exc.errno, exc.strerror, str(target)) from None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=f".tmp{target.suffix}", dir=target.parent)
    except OSError as exc:
        raise _about(exc, target, exc.strerror or str(exc)) from exc
    tmp_path = Path(tmp)
    _track(tmp_path)  # removed by the signal handler if the process is told to stop meanwhile
    os.close(fd)
    staged = False
    try:
        os.chmod(tmp_path, 0o644)  # mkstemp makes 0600; outputs are ordinary readable files
        yield tmp_path
        pending = _STAGED.get()
        if pending is not None and os.fspath(target) not in _ACTIVE:  # a write into our own temporary: now
            pending.append((tmp_path, target))
            staged = True  # still tracked: a signal removes it
            return
        os.replace(tmp_path, target)
    except OSError as exc:  # disk full, permissions ...: name the output, not the temporary file
        tmp_path.unlink(missing_ok=True)
        if exc.errno is None or (exc.filename is not None and str(exc.filename) != str(tmp_path)):
            raise  # about another file (the writer's own input, say): keep its name
        raise _about(exc, target, exc.strerror or str(exc)) from exc
    except BaseException:
        tmp_path.unlink(missing_ok=True)
        raise
    finally:
        if not staged:
            _untrack(tmp_path)


@contextmanager
def all_or_nothing(discarded: list[Path] | None = None) -> Iterator[None]:
    """Within the block, :func:`atomic_path` outputs are renamed into place only when it succeeds.

    A command with several outputs (``--json`` and ``--plot``) that fails after writing one of
    them leaves none: the written temporaries are removed when the block raises, and renamed
    onto their targets, in the order written, when it ends normally. :func:`commit_staged` renames
    what is written so far (an output meant to survive a failure: a refusal JSON).

    Parameters
    ----------
    discarded : list of Path, optional
        Receives the targets whose written temporaries were removed because the block raised
        (what the command may already have reported as written).
    """
    pending: list[tuple[Path, Path]] = []
    token = _STAGED.set(pending)
    try:
        yield
    except BaseException:
        for tmp, target in pending:
            tmp.unlink(missing_ok=True)
            _untrack(tmp)
            if discarded is not None:
                discarded.append(target)
        raise
    finally:
        _STAGED.reset(token)
    _rename_all(pending)


def commit_staged() -> None:
    """Rename the outputs staged so far by :func:`all_or_nothing` (nothing outside such a block)."""
    pending = _STAGED.get()
    if pending:
        _rename_all(pending)


def _rename_all(pending: list[tuple[Path, Path]]) -> None:
    """Rename each staged temporary onto its target; on an error remove the rest and name the target."""
    while pending:
        tmp, target = pending.pop(0)
        try:
            os.replace(tmp, target)
        except OSError as exc:
            for t, _ in [(tmp, target), *pending]:
                t.unlink(missing_ok=True)
                _untrack(t)
            pending.clear()
            raise _about(exc, target, exc.strerror or str(exc)) from exc
        _untrack(tmp)


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
    leaves the folder locked. The lock file is opened without following a symbolic link and
    without blocking (``O_NOFOLLOW | O_NONBLOCK``) and used only when it is a regular file with one
    link, so a planted link, FIFO or hard link is refused and its target is never touched. It is
    removed when the block ends (a run that waited on the removed file sees that and tries again).

    Raises
    ------
    FolderBusyError
        When another process (or another run in this process) holds the lock; the message
        names the folder and the holder's process id.
    EmaRigError
        When ``folder/name`` exists but is not a regular file of its own (naming it).
    """
    d = make_folder(folder)
    lock = d / name
    for _ in range(100):  # a run that finished removed the file we opened: open the new one
        fd = _open_lock(lock)
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
            if not _same_file(fd, lock):
                continue  # removed (and maybe made again) by the run that held it
            os.ftruncate(fd, 0)
            os.write(fd, f"{os.getpid()}\n".encode("ascii"))
            _track(lock)
            _LOCK_FDS.add(fd)
            try:
                yield lock
            finally:
                _LOCK_FDS.discard(fd)
                _untrack(lock)
                if _same_file(fd, lock):
                    lock.unlink(missing_ok=True)  # still holding the lock: no other run uses this file
            return
        finally:
            os.close(fd)  # closing the descriptor releases the lock
    raise FolderBusyError("output folder's lock file keeps changing; is another program removing it?", file=d)


def close_inherited_locks() -> None:
    """In a forked child: close the copies of the parent's lock descriptors.

    ``flock`` belongs to the open file, which a fork shares: a pool worker that kept its copy
    would hold the output folder locked after its parent was killed, until the worker died too.
    """
    for fd in list(_LOCK_FDS):
        try:
            os.close(fd)
        except OSError:
            pass
    _LOCK_FDS.clear()


def _open_lock(lock: Path) -> int:
    """Open (or create) the lock file; refuse anything but a regular file with one link."""
    flags = (os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
             | getattr(os, "O_CLOEXEC", 0))
    planted = "ema-rig's lock must be a regular file it makes itself; remove it"
    try:
        fd = os.open(lock, flags, 0o644)
    except OSError as exc:
        if os.path.islink(lock):
            target = os.readlink(lock)
            missing = "" if os.path.exists(lock) else "missing "
            raise EmaRigError(f"is a symbolic link (to the {missing}{target}), not ema-rig's lock file; "
                              f"{planted}", file=lock) from None
        raise _about(exc, lock, exc.strerror or str(exc)) from exc
    st = os.fstat(fd)
    if not stat.S_ISREG(st.st_mode) or st.st_nlink != 1:
        os.close(fd)
        what = ("a hard link to another file" if stat.S_ISREG(st.st_mode)
                else "a FIFO" if stat.S_ISFIFO(st.st_mode) else "not a regular file")
        raise EmaRigError(f"is {what}, not ema-rig's lock file; {planted}", file=lock)
    return fd


def _same_file(fd: int, path: Path) -> bool:
    """True when ``path`` (not followed) is still the file open as ``fd``."""
    try:
        st = os.lstat(path)
    except OSError:
        return False
    own = os.fstat(fd)
    return (st.st_dev, st.st_ino) == (own.st_dev, own.st_ino)


def _lock_fd(fd: int) -> None:
    if sys.platform == "win32":  # pragma: no cover - Windows
        import msvcrt

        msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
    else:
        import fcntl

        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)


_SIGNALS = tuple(getattr(signal, n) for n in ("SIGTERM", "SIGHUP", "SIGINT") if hasattr(signal, n))


def remove_active_files() -> list[str]:
    """Remove the temporary files (and lock files) this process is writing or holding now.

    Only the entries made by this very process are removed: a forked worker inherits the
    parent's list but must never remove the parent's files.
    """
    pid = os.getpid()
    gone = []
    for path, owner in list(_ACTIVE.items()):
        if owner == pid:
            try:
                os.unlink(path)
                gone.append(path)
            except OSError:
                pass
            _ACTIVE.pop(path, None)
    return gone


def _on_signal(signum: int, frame: Any) -> None:
    """Remove this process's temporaries, then die of the signal as if unhandled."""
    remove_active_files()
    if signum == getattr(signal, "SIGINT", None):
        raise KeyboardInterrupt  # the command's own clean-up runs; exit code 130
    signal.signal(signum, signal.SIG_DFL)
    os.kill(os.getpid(), signum)  # the conventional exit status (128 + signum) for the caller


@contextmanager
def removing_temporaries_on_signal() -> Iterator[None]:
    """Within the block, SIGTERM/SIGHUP/SIGINT first remove this process's temporary files.

    SIGTERM and SIGHUP then end the process by the same signal (exit status 128 + signal);
    SIGINT raises :class:`KeyboardInterrupt`. The previous handlers are restored on exit. Does
    nothing outside the main thread (only it may set signal handlers); a signal that is ignored
    when the block starts (``nohup``) stays ignored.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    # a signal the caller ignores (nohup: SIGHUP; a background job: SIGINT) stays ignored
    old = {s: h for s in _SIGNALS if (h := signal.getsignal(s)) is not signal.SIG_IGN}
    for s in old:
        signal.signal(s, _on_signal)
    try:
        yield
    finally:
        for s, h in old.items():
            signal.signal(s, h if h is not None else signal.SIG_DFL)


class OutputIsInputError(EmaRigError):
    """An output file of a command is one of its inputs, or two outputs are one file."""


def _identities(path: str | PathLike[str]) -> set[tuple[Any, ...]]:
    """The resolved absolute path of a file and, when it exists, its (device, inode)."""
    ids: set[tuple[Any, ...]] = {("path", os.path.realpath(os.path.abspath(os.fspath(path))))}
    try:
        st = os.stat(path)
        ids.add(("inode", st.st_dev, st.st_ino))
    except OSError:
        pass
    return ids


class OutputPathError(EmaRigError):
    """An output path that cannot be written: a folder, under a file, or a figure of unknown format."""


def check_output_path(label: str, path: str | PathLike[str], *, figure: bool = False) -> None:
    """Refuse, before anything is computed, an output path that cannot be written.

    Parameters
    ----------
    label : str
        The option that names the output (``"--plot"``), for the message.
    path : str or path-like
        The output file.
    figure : bool, optional
        The output is a figure: its suffix must be one of :data:`FIGURE_FORMATS`.

    Raises
    ------
    OutputPathError
        Naming the output: it is a folder, its folder cannot be made (a file or a dangling
        symbolic link is in the way) or is not writable, or a figure's suffix is not a format.
    """
    p = Path(os.path.abspath(os.fspath(path)))
    if figure and p.suffix.lower() not in FIGURE_FORMATS:
        raise OutputPathError(f"{label} must end in {', '.join(FIGURE_FORMATS)} (the figure format), "
                              f"got {p.name!r}", file=path)
    if p.is_dir():
        raise OutputPathError(f"{label} names a folder; give a file name", file=path)
    why = _folder_blocker(p.parent)
    if why is not None:
        raise OutputPathError(why if why.startswith("cannot") else f"{label}: {why}", file=path)


def check_output_folder(folder: str | PathLike[str]) -> None:
    """Refuse, before anything is computed, an output folder that cannot be made or written.

    Raises
    ------
    OutputPathError
        Naming the folder: a file or a dangling symbolic link is in the way, or it is not writable.
    """
    why = _folder_blocker(Path(os.path.abspath(os.fspath(folder))))
    if why is not None:
        raise OutputPathError(why, file=folder)


def _folder_blocker(d: Path) -> str | None:
    """Why the absolute folder ``d`` cannot be made or written into (None when it can)."""
    top = next(p for p in (d, *d.parents) if os.path.lexists(p))  # the root always exists
    if not top.is_dir():  # the words of make_folder, which would fail the same way after the run
        return f"cannot create the folder {d} ({_in_the_way(top)})"
    if not os.access(top, os.W_OK | os.X_OK):
        return f"the folder {top} is not writable"
    return None


def check_outputs(inputs: Mapping[str, str | PathLike[str] | None] | Iterable[tuple[str, Any]],
                  outputs: Mapping[str, str | PathLike[str] | None] | Iterable[tuple[str, Any]],
                  figures: Collection[str] = ()) -> None:
    """Refuse, before anything is written, an output that is an input, another output, or unwritable.

    Two paths are the same file when they name the same inode (hard links, symbolic links,
    ``./x`` and ``x``) or, for an output not yet made, the same path once resolved. Each output
    is also checked by :func:`check_output_path`.

    Parameters
    ----------
    inputs, outputs : mapping or iterable of (label, path)
        ``label`` names the option in the message (``"FILE"``, ``"--json"``); None paths are skipped.
    figures : collection of str, optional
        The labels of the outputs that are figures (their suffix must be a figure format).

    Raises
    ------
    OutputIsInputError
        Naming the output file and what it collides with.
    OutputPathError
        Naming an output that cannot be written.
    """
    ins = [(k, v) for k, v in (inputs.items() if isinstance(inputs, Mapping) else inputs) if v is not None]
    outs = [(k, v) for k, v in (outputs.items() if isinstance(outputs, Mapping) else outputs) if v is not None]
    seen: dict[tuple[Any, ...], tuple[str, Any, str]] = {}
    for label, path in ins:
        for ident in _identities(path):
            seen.setdefault(ident, (label, path, "input"))
    for label, path in outs:
        idents = _identities(path)
        hit = next((seen[i] for i in idents if i in seen), None)
        if hit is not None:
            other, opath, kind = hit
            if kind == "input":
                raise OutputIsInputError(f"{label} would overwrite the input {other} ({opath}); "
                                         "refusing to write over an input: choose another output file", file=path)
            raise OutputIsInputError(f"{label} and {other} are the same output file; give each its own",
                                     file=path)
        seen.update({i: (label, path, "output") for i in idents})
    for label, path in outs:  # after the collisions: overwriting an input is the graver mistake
        check_output_path(label, path, figure=label in figures)


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
