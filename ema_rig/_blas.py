"""Run small dense linear algebra single-threaded, through threadpoolctl.

The pLSCF kernels call LAPACK on many small matrices (companion eigenvalues, Cholesky factors of
at most a few hundred rows). A multi-threaded BLAS gains nothing there and, on a busy machine or
with several campaign workers on two cores, loses up to an order of magnitude to thread
hand-offs. :func:`single_threaded` limits the BLAS thread pools to one thread for the duration
of a block and restores the previous setting afterwards (threadpoolctl's ``limit``; the setting
is per process, so a concurrent caller in another thread may briefly see it too).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from functools import lru_cache
from typing import Any


@lru_cache(maxsize=1)
def _controller() -> Any:
    import scipy.linalg  # noqa: F401  (load scipy's BLAS before threadpoolctl looks for libraries)
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@contextmanager
def single_threaded() -> Iterator[None]:
    """Limit the BLAS libraries to one thread for the duration of the block."""
    with _controller().limit(limits=1, user_api="blas"):
        yield


__all__ = ["single_threaded"]
