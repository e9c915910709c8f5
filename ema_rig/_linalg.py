"""Thin factorizations of tall matrices, the same numbers as numpy's and SciPy's, called more cheaply.

The identification fits many small least-squares problems (a few thousand rows, a few dozen columns):
LSFD's basis, the completeness test's local fits, the local ML's projections. :func:`thin_qr` calls
LAPACK's geqrf/orgqr without SciPy's workspace queries; :func:`thin_svd` is ``numpy.linalg.svd``'s
path for a tall matrix (LAPACK gesdd: QR first, then the SVD of R, Q times its singular vectors)
with the QR factored by :func:`thin_qr`: the same numbers to the bit, in 80-85 % of the time on a
few thousand rows (the gesdd call spends the rest on its workspace queries and blocked calls).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
from numpy.typing import NDArray

#: Columns up to which LAPACK's QR runs unblocked whatever its workspace (its block size is 32): the
#: factors of :func:`thin_qr` are then those of any caller of geqrf/orgqr, LAPACK's own gesdd included.
_UNBLOCKED_COLUMNS = 32


#: Values (rows x columns) from which :func:`thin_svd` factors the QR itself: below, its two extra calls' Python
#: overhead (~10 us each) eats the gain (one BLAS thread, 2026-12-08: 240 x 10 0.039 -> 0.046 ms, 400 x 16
#: 0.108 -> 0.105 ms, 1562 x 26 0.68 -> 0.57 ms, 3400 x 30 1.78 -> 1.44 ms). A work-size rule (the numbers are the
#: same either way).
_QR_FIRST_MIN_VALUES = 10_000

#: LAPACK gesdd scales a matrix whose largest entry ``anrm`` is below ``SMLNUM = sqrt(dlamch('S')) / dlamch('P')``
#: (``2**-459``, ~7e-139) or above ``BIGNUM = 1 / SMLNUM`` before it factors it (dgesdd.f, "Scale A if max element
#: outside range [SMLNUM,BIGNUM]"), the whole ``a`` before its QR: then :func:`thin_svd`, which factors the
#: unscaled ``a``, rounds differently (1e-15 relative in ``s``, 1e-13 in ``u``). ``s[0]`` bounds ``anrm``
#: (``s[0] / sqrt(m n) <= anrm <= s[0]``): outside ``[SMLNUM sqrt(m n), BIGNUM]`` (a factor 2 of margin each side
#: for the rounding of ``s[0]``) numpy's call is taken instead.
_GESDD_SMLNUM = 2.0**-459
_GESDD_BIGNUM = 2.0**459


def thin_qr(a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Reduced QR factors of ``a`` (LAPACK geqrf/orgqr, as ``numpy.linalg.qr``).

    Up to 32 columns LAPACK's unblocked code runs whatever the workspace (its block size is 32),
    so the two routines are called directly, without SciPy's workspace queries: the same factors
    to the bit as ``scipy.linalg.qr(mode="economic")``, which takes the wider ones.

    Parameters
    ----------
    a : ndarray, shape (m, k), float64

    Returns
    -------
    q : ndarray, shape (m, min(m, k))
        Orthonormal columns.
    r : ndarray, shape (min(m, k), k)
        Upper triangular.
    """
    k = a.shape[1]
    if k > _UNBLOCKED_COLUMNS or a.shape[0] < k:
        q, r = scipy.linalg.qr(a, mode="economic", check_finite=False)
        return q, r
    qr, tau, _, info = scipy.linalg.lapack.dgeqrf(a)
    if info != 0:
        raise np.linalg.LinAlgError(f"dgeqrf: info {info}")
    r = np.triu(qr[:k])
    q, _, info = scipy.linalg.lapack.dorgqr(qr, tau, overwrite_a=True)
    if info != 0:
        raise np.linalg.LinAlgError(f"dorgqr: info {info}")
    return q, r


def thin_svd(
    a: NDArray[np.float64],
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """``numpy.linalg.svd(a, full_matrices=False)`` of a real matrix, the same numbers.

    For a tall ``a`` (at least twice as many rows as columns, at most 32 columns, at least
    :data:`_QR_FIRST_MIN_VALUES` values) LAPACK's gesdd
    factors ``a = Q R`` first and takes the SVD of ``R`` (its path for ``m >= 11 n / 6``); here the QR
    is :func:`thin_qr` (unblocked, as gesdd runs it for these widths), the SVD of ``R`` numpy's, and
    ``U = Q U_R`` one column-major dgemm, as gesdd forms it. Any other shape, a matrix that gesdd scales first
    (:data:`_GESDD_SMLNUM`) and a non-finite ``a`` (whose ``R`` fails to converge; numpy's call returns NaN for an
    infinite entry): numpy's call.

    Parameters
    ----------
    a : ndarray, shape (m, n), float64

    Returns
    -------
    u : ndarray, shape (m, min(m, n))
    s : ndarray, shape (min(m, n),)
        Singular values, decreasing.
    vt : ndarray, shape (min(m, n), n)
    """
    m, n = a.shape
    if n == 0 or n > _UNBLOCKED_COLUMNS or m < 2 * n or m * n < _QR_FIRST_MIN_VALUES:
        u0, s0, vt0 = np.linalg.svd(a, full_matrices=False)
        return u0, s0, vt0
    try:
        q, r = thin_qr(a)
        ur, s, vt = np.linalg.svd(r)
    except np.linalg.LinAlgError:  # a non-finite a: numpy's call raises or returns what it returns
        u0, s0, vt0 = np.linalg.svd(a, full_matrices=False)
        return u0, s0, vt0
    # gesdd scales this a first: its numbers are numpy's call's
    if not 2.0 * _GESDD_SMLNUM * np.sqrt(m * n) <= s[0] <= 0.5 * _GESDD_BIGNUM:
        u0, s0, vt0 = np.linalg.svd(a, full_matrices=False)
        return u0, s0, vt0
    # gesdd's product Q U_R: BLAS dgemm on the column-major factors (numpy's ``q @ ur`` takes the row-major
    # route, whose kernel rounds differently), returned row-major as numpy returns U
    u: NDArray[np.float64] = np.ascontiguousarray(scipy.linalg.blas.dgemm(1.0, q, ur))
    return u, s, vt


__all__ = ["thin_qr", "thin_svd"]
