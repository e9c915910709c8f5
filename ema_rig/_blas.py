"""Run small dense linear algebra single-threaded, through threadpoolctl.

The pLSCF kernels call LAPACK on many small matrices (companion eigenvalues, Cholesky factors of
at most a few hundred rows). A multi-threaded BLAS gains nothing there and, on a busy machine or
with several campaign workers on two cores, loses up to an order of magnitude to thread
hand-offs. :func:`single_threaded` limits the BLAS thread pools to one thread for the duration
of a block and restores the previous setting afterwards (threadpoolctl's ``limit``; the setting
is per process, so a concurrent caller in another thread may briefly see it too).
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from contextlib import contextmanager
from functools import lru_cache
from typing import Any


@lru_cache(maxsize=1)
def _controller() -> Any:
    import scipy.linalg  # noqa: F401  (load scipy's BLAS before threadpoolctl looks for libraries)
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


#: Per thread: how many :func:`single_threaded` blocks are open (an inner block inside an outer
#: one of the same thread changes nothing and skips threadpoolctl's ~15-30 us of set and restore).
_open = threading.local()


@contextmanager
def single_threaded() -> Iterator[None]:
    """Limit the BLAS libraries to one thread for the duration of the block.

    A block nested in another of the same thread leaves the limit to the outer one.
    """
    depth = getattr(_open, "depth", 0)
    _open.depth = depth + 1
    try:
        if depth:
            yield
        else:
            with _controller().limit(limits=1, user_api="blas"):
                yield
    finally:
        _open.depth = depth


@contextmanager
def in_callers_limit() -> Iterator[None]:
    """For a task another thread runs inside the caller's :func:`single_threaded` block (joined before
    the block ends): the blocks the task opens leave the limit to the caller's, so the limit is set and
    restored by one thread only (a restore from the second thread after the caller's would keep it)."""
    depth = getattr(_open, "depth", 0)
    _open.depth = depth + 1
    try:
        yield
    finally:
        _open.depth = depth


__all__ = ["in_callers_limit", "single_threaded"]
