"""Warm-started polynomial roots for a sequence of model orders (Aberth-Ehrlich iteration).

The poles of consecutive pLSCF orders are mostly the same: the physical ones barely move and
the mathematical ones shift a little. Starting the simultaneous Aberth-Ehrlich iteration from
the previous order's roots finds all roots of the next order in a handful of O(N^2) sweeps,
several times faster than the O(N^3) QR iteration on the companion matrix. Every root is
accepted only when its backward error is at rounding level (the stopping rule of MPSolve);
when an order does not converge within the iteration limit, the caller falls back to the
companion-matrix eigenvalues, so the result never depends on the warm start.

References
----------
.. [1] O. Aberth, "Iteration methods for finding all zeros of a polynomial simultaneously",
   Math. Comp. 27 (1973) 339-344.
.. [2] D. A. Bini, "Numerical computation of polynomial zeros by means of Aberth's method",
   Numer. Algorithms 13 (1996) 179-200.
"""

from __future__ import annotations

import math
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

_EPS = np.finfo(float).eps
#: Newton ratio |p / p'| relative to |z| below which the rounding-level test of p is made (a root
#: at rounding level has a ratio of ~N eps times its condition number; 1e-4 leaves condition
#: numbers up to ~1e9 tested at once, and a worse-conditioned root is tested once it has moved
#: that close).
_NEAR = 1e-4


def det_coefficients(alpha: NDArray[np.float64]) -> NDArray[np.float64]:
    """Coefficients of ``det A(z)`` for ``A(z) = sum_j alpha_j z^j``.

    Parameters
    ----------
    alpha : ndarray, shape (n + 1, n_in, n_in)
        Real coefficient blocks.

    Returns
    -------
    ndarray, shape (n * n_in + 1,)
        ``c_0 .. c_N`` of ``det A(z) = sum_j c_j z^j`` (N = n n_in). Two references: the
        exact products ``a00 a11 - a01 a10`` of the entry polynomials (two convolutions, each
        coefficient rounded relative to its own terms); more: interpolated from the values at
        N + 1 points on the unit circle (two FFTs, well conditioned).
    """
    n1, n_in, _ = alpha.shape
    if n_in == 1:
        return alpha[:, 0, 0].astype(float).copy()
    if n_in == 2:
        a = np.asarray(alpha, dtype=float)
        return cast("NDArray[np.float64]", np.convolve(a[:, 0, 0], a[:, 1, 1]) - np.convolve(a[:, 0, 1], a[:, 1, 0]))
    deg = (n1 - 1) * n_in
    k = deg + 1
    vals = np.fft.fft(alpha, n=k, axis=0)  # A(exp(-2 pi i m / k)), shape (k, n_in, n_in)
    d = np.linalg.det(vals)
    return np.fft.ifft(d).real * 1.0


def powers(x: NDArray[Any], n: int) -> NDArray[Any]:
    """``x**j`` for ``j = 0..n``, shape (n + 1, x.size), in blocks of about ``sqrt(n)`` powers.

    The first block ``x^0 .. x^(b-1)`` and the block starts ``x^0, x^b, x^2b ...`` come from two
    short running products (one row per power, vectorised over ``x``), every power from one
    product of the two: half the time of a running product over all ``n`` powers at degree
    150-200, with the same rounding (each power has at most ``2 sqrt(n)`` rounded factors
    instead of ``n``).
    """
    m = x.size
    b = max(1, math.isqrt(n) + 1)
    k = -(-(n + 1) // b)
    base = np.empty((b, m), dtype=x.dtype)
    base[0] = 1.0
    if b > 1:
        base[1:] = x
        np.cumprod(base[1:], axis=0, out=base[1:])
    big = np.empty((k, m), dtype=x.dtype)
    big[0] = 1.0
    if k > 1:
        big[1:] = base[b - 1] * x
        np.cumprod(big[1:], axis=0, out=big[1:])
    out = np.empty((k, b, m), dtype=x.dtype)
    np.multiply(big[:, None, :], base[None, :, :], out=out)
    return out.reshape(k * b, m)[: n + 1]


def _ratio(c: NDArray[Any], dc: NDArray[Any], cr: NDArray[Any], dcr: NDArray[Any], z: NDArray[Any]) -> tuple[NDArray[Any], NDArray[Any]]:
    """Newton ratio p(z) / p'(z) and a flag "p(z) is at rounding level" for every z.

    Inside the unit circle p is evaluated directly, outside through the reversed polynomial
    ``q(y) = y^N p(1/y)``, so no power of z exceeds 1 in modulus. The flag's bound (the
    polynomial of the coefficients' moduli at ``|z|``) is computed only where the Newton ratio
    is below :data:`_NEAR` of ``|z|``: farther from a root (or from a cluster of roots, where
    ``p'`` is small as well) ``p`` is not at rounding level, and the flag is False.
    """
    n = c.size - 1
    r = np.empty(z.size, dtype=np.complex128)
    small = np.empty(z.size, dtype=bool)
    az = np.abs(z)
    # direct evaluation everywhere while the powers stay far from overflow (one pass);
    # otherwise the roots outside the unit circle go through the reversed polynomial
    inside = az <= 1.0 if az.size and n * np.log10(max(az.max(), 1.0)) > 150 else np.ones(z.size, bool)
    for mask, coef, dcoef, flip in ((inside, c, dc, False), (~inside, cr, dcr, True)):
        if not mask.any():
            continue
        x = z[mask] if not flip else 1.0 / z[mask]
        pw = powers(x, n)  # (n + 1, x.size)
        p = coef @ pw
        dp = dcoef @ pw[:-1]
        with np.errstate(divide="ignore", invalid="ignore"):
            # outside: p'(z) / p(z) = N y - y^2 q'(y) / q(y)
            rm = p / dp if not flip else 1.0 / (n * x - x * x * dp / p)
            near = ~(np.abs(rm) > _NEAR * np.abs(z[mask]))  # NaN (p = p' = 0) counts as near
        r[mask] = rm
        flag = np.zeros(x.size, dtype=bool)
        if near.any():
            # |x^j| = |x|^j: the bound from real powers (no modulus of the complex powers)
            pa = powers(np.abs(x[near]), n)
            flag[near] = np.abs(p[near]) <= 4.0 * n * _EPS * (np.abs(coef) @ pa)
        small[mask] = flag
    return r, small


def aberth(c: NDArray[np.float64], z0: NDArray[np.complex128], *, maxiter: int = 60) -> NDArray[np.complex128] | None:
    """All roots of ``sum_j c_j z^j`` from initial guesses ``z0`` (one per root).

    Returns None when the iteration does not converge (the caller then uses an eigenvalue
    method).
    """
    n = c.size - 1
    if n < 1 or z0.size != n or c[-1] == 0 or not np.all(np.isfinite(c)):
        return None
    c = np.asarray(c, dtype=float)
    j = np.arange(1, n + 1)
    dc = c[1:] * j  # coefficients of p'
    cr = c[::-1].copy()
    dcr = cr[1:] * j  # coefficients of q'
    z = np.asarray(z0, dtype=np.complex128).copy()
    act = np.arange(n)  # roots still iterating
    for _ in range(maxiter):
        r, small = _ratio(c, dc, cr, dcr, z[act])
        # a root whose backward error is at rounding level is done: no correction for it
        act, r = act[~small], r[~small]
        if act.size == 0:
            break
        za = z[act]
        diff = za[:, None] - z[None, :]
        diff[np.arange(act.size), act] = 1.0
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (1.0 / diff).sum(axis=1) - 1.0  # without the diagonal's 1/1
            w = r / (1.0 - r * s)
        ok = np.isfinite(w)
        z[act[ok]] = za[ok] - w[ok]
        # also done: a correction at rounding level
        act = act[~(ok & (np.abs(w) <= 4.0 * _EPS * np.abs(za)))]
        if act.size == 0:
            break
    if act.size:
        _, small = _ratio(c, dc, cr, dcr, z[act])
        if not small.all():
            return None
    if not np.all(np.isfinite(z)):
        return None
    # two approximations on one root would leave another root unfound: check the sum of the
    # roots (Vieta) and that no two coincide
    vieta = -c[-2] / c[-1]
    if abs(z.sum() - vieta) > 1e-8 * (np.abs(z).sum() + abs(vieta)):
        return None
    zs = np.sort_complex(z)
    if np.any(np.abs(np.diff(zs)) <= 1e-12 * np.abs(zs[1:])):
        return None
    return z


def warm_start(prev: NDArray[np.complex128], n_roots: int) -> NDArray[np.complex128]:
    """Initial guesses: the previous order's roots plus new points spread on a circle.

    The guesses are rotated by a tiny angle so that they are not conjugate-symmetric (Aberth's
    iteration would otherwise keep every pair symmetric).
    """
    m = n_roots - prev.size
    if m < 0:
        prev = prev[np.argsort(np.abs(np.abs(prev) - 1.0))][:n_roots]
        m = 0
    k = np.arange(m)
    new = 1.1 * np.exp(1j * (0.4 + 2 * np.pi * (k + 0.5) / max(m, 1)))
    return cast("NDArray[np.complex128]", np.concatenate([prev, new]) * np.exp(1e-3j))


__all__ = ["aberth", "det_coefficients", "warm_start"]
