"""Run small dense linear algebra single-threaded (OpenBLAS thread-local setting).

The pLSCF kernels call LAPACK on many small matrices (companion eigenvalues, Cholesky
factors of at most a few hundred rows). Multi-threaded OpenBLAS gains nothing there and, on a
busy machine, loses up to an order of magnitude to thread hand-offs. :func:`single_threaded`
sets OpenBLAS's *thread-local* thread count (``openblas_set_num_threads_local``, OpenBLAS >=
0.3.27) to 1 for the calling thread and restores it afterwards, so other threads and the rest
of the process are not affected. Where that symbol is not available (other BLAS vendors), it
does nothing.
"""

from __future__ import annotations

import ctypes
import os
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from functools import lru_cache
from pathlib import Path


@lru_cache(maxsize=1)
def _setters() -> tuple[Callable[[int], int], ...]:
    paths: set[str] = set()
    try:
        with open("/proc/self/maps", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                part = line.split()
                if part and "openblas" in part[-1].lower() and ".so" in part[-1]:
                    paths.add(part[-1])
    except OSError:
        pass
    if not paths:  # not Linux: look beside numpy / scipy
        import numpy

        for pkg in ("numpy", "scipy"):
            libdir = Path(numpy.__file__).parent.parent / f"{pkg}.libs"
            if libdir.is_dir():
                paths.update(str(p) for p in libdir.glob("*openblas*"))
    out = []
    for p in sorted(paths):
        if not os.path.exists(p):
            continue
        try:
            lib = ctypes.CDLL(p)
            fn = lib.openblas_set_num_threads_local
        except (OSError, AttributeError):
            continue
        fn.argtypes = [ctypes.c_int]
        fn.restype = ctypes.c_int
        out.append(fn)
    return tuple(out)


@contextmanager
def single_threaded() -> Iterator[None]:
    """Limit OpenBLAS to one thread in the calling thread for the duration of the block."""
    try:
        import scipy.linalg  # noqa: F401  (make sure scipy's OpenBLAS is loaded too)

        setters = _setters()
    except Exception:  # pragma: no cover - best effort only
        setters = ()
    old = []
    for fn in setters:
        try:
            old.append((fn, fn(1)))
        except Exception:  # pragma: no cover
            continue
    try:
        yield
    finally:
        for fn, n in reversed(old):
            try:
                fn(n)
            except Exception:  # pragma: no cover
                pass


__all__ = ["single_threaded"]
