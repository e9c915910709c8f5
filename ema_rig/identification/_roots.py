"""Warm-started polynomial roots for a sequence of model orders (Aberth-Ehrlich iteration).

The poles of consecutive pLSCF orders are mostly the same: the physical ones barely move and
the mathematical ones shift a little. Starting the simultaneous Aberth-Ehrlich iteration from
the previous order's roots finds all roots of the next order in a handful of O(N^2) sweeps,
several times faster than the O(N^3) QR iteration on the companion matrix. Every root is
accepted only when its backward error is at rounding level (the stopping rule of MPSolve);
when an order does not converge within the iteration limit, the caller falls back to the
companion-matrix eigenvalues, so the result never depends on the warm start.

How a sweep is kept cheap: only the roots not yet accepted are iterated (an accepted root
keeps its place in the others' repulsion sums); ``p`` and ``p'`` are evaluated from two short
tables of powers (``x^i``, ``i < b``, and ``x^(b k)``, ``b ~ sqrt(N)``) and the coefficients cut
into blocks, one real matrix product for all blocks, never the full ``(N + 1) x m`` table of
powers; the rounding bound is formed only where the Newton ratio is small; and where the
Newton ratio times the repulsion sum is already below :data:`_STALE`, the correction reuses
the previous sweep's repulsion sum (its change alters the step only at second order), so the
O(N^2) sums are recomputed only for the roots still far from convergence.

At the degrees where a sweep costs more in fixed per-call work than in arithmetic (pLSCF: one
reference, degrees 48-200 when the orders reach 64; two references 64-200),
:func:`aberth_chain` roots a whole run of orders in ONE batch of
sweeps: each order starts from the iterate of the order below after one sweep (not from its
converged roots: the unstable roots of consecutive pLSCF orders differ by ~3e-2 relative
anyway; up to degree 100, where a sweep's cost is mostly fixed, up to five orders start in the
same sweep, each from the start of the one before, so the chain ends fewer sweeps after its
last start), and each sweep evaluates and corrects the active roots of every started order
together, so the fixed cost of a sweep is paid once for ~10 orders instead of once per order.

The first sweep's repulsion sums, the largest of the O(N^2) work (every root is far from
converged, none can reuse an old sum), are not summed where they are already known: an order
rooted on its own starts from the previous order's roots, whose sums among themselves are
``p''/(2 p')`` of the previous polynomial (:func:`aberth_warm`, one evaluation per root); in a
chain, an order that starts at the iterate of the order below takes that order's sums of the
same sweep (:func:`_chain_reuse`). Only the new start points' terms are added.

A reused repulsion sum does not see an approximation that has come close since: two can then
settle on one root, and the root they leave free is never found. An order still iterating after
:data:`_STALL` sweeps is therefore searched for such twins once; the later of each pair restarts
elsewhere, and from then on that order's sums are all formed afresh (:func:`_part_twins`).

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


#: Points from which :func:`_block_powers` forms each power row by one vectorised product
#: instead of one ``multiply.accumulate`` call (crossover measured with complex points at
#: degrees 64, 130 and 200: 64-110 points).
_ROW_PRODUCTS = 80


def _block_powers(x: NDArray[Any], n: int) -> tuple[NDArray[Any], NDArray[Any]]:
    """``x**i`` for ``i < b`` (shape (b, x.size)) and ``x**(b k)`` for ``k < K`` (shape (K, x.size)).

    ``b = isqrt(n) + 1`` and ``K = ceil((n + 1) / b)``: every power ``x**j``, ``j <= n``, is
    the product of one row of each, so each has at most ``b + K ~ 2 sqrt(n)`` rounded factors
    (instead of ``n`` in a running product). Both come from short running products, one row
    per power, vectorised over ``x``. From :data:`_ROW_PRODUCTS` points on, one multiplication of
    two rows per power (``~2 sqrt(n)`` vectorised products): numpy's ``multiply.accumulate``
    along the rows of a complex array takes 2.5-6x longer for the same products at 150-1000
    points of degree 50-200, but less below ~100 points (one call instead of ``2 sqrt(n)``).
    """
    m = x.size
    b = max(1, math.isqrt(n) + 1)
    k = -(-(n + 1) // b)
    if m < _ROW_PRODUCTS:
        base = np.empty((b, m), dtype=x.dtype)
        base[0] = 1.0
        if b > 1:
            base[1:] = x
            np.multiply.accumulate(base[1:], axis=0, out=base[1:])
        big = np.empty((k, m), dtype=x.dtype)
        big[0] = 1.0
        if k > 1:
            big[1:] = base[b - 1] * x
            np.multiply.accumulate(big[1:], axis=0, out=big[1:])
        return base, big
    base = np.empty((b, m), dtype=x.dtype)
    base[0] = 1.0
    if b > 1:
        base[1] = x
        for i in range(2, b):
            np.multiply(base[i - 1], x, out=base[i])
    big = np.empty((k, m), dtype=x.dtype)
    big[0] = 1.0
    if k > 1:
        np.multiply(base[b - 1], x, out=big[1])
        for i in range(2, k):
            np.multiply(big[i - 1], big[1], out=big[i])
    return base, big


def powers(x: NDArray[Any], n: int) -> NDArray[Any]:
    """``x**j`` for ``j = 0..n``, shape (n + 1, x.size), in blocks of about ``sqrt(n)`` powers.

    Every power is the product of one row of each of the two short tables of
    :func:`_block_powers`: half the time of a running product over all ``n`` powers at degree
    150-200, with the same rounding (each power has at most ``2 sqrt(n)`` rounded factors
    instead of ``n``).
    """
    base, big = _block_powers(x, n)
    out = np.empty((big.shape[0], base.shape[0], x.size), dtype=x.dtype)
    np.multiply(big[:, None, :], base[None, :, :], out=out)
    return out.reshape(-1, x.size)[: n + 1]


_Prepared = tuple[NDArray[np.float64], NDArray[np.float64]]


def _prepare(coef: NDArray[Any], dcoef: NDArray[Any]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The coefficients of p and p' cut into the blocks of :func:`_block_powers`.

    Returns ``(blocks, abs_blocks)``: shape (2 K, b), rows ``k`` holding ``c_(b k) .. c_(b k + b - 1)``
    of p (first K rows) and of p' (last K rows), zero-padded; and the moduli of p's blocks,
    shape (K, b).
    """
    n = coef.size - 1
    b = max(1, math.isqrt(n) + 1)
    k = -(-(n + 1) // b)
    st = np.zeros((2, k * b))
    st[0, : n + 1] = coef
    st[1, :n] = dcoef
    return st.reshape(2 * k, b), np.abs(st[0]).reshape(k, b)


def _prepare_both(c: NDArray[Any]) -> tuple[_Prepared, _Prepared]:
    """:func:`_prepare` of ``p = sum_j c_j z^j`` and p', and of the reversed polynomial
    ``q(y) = y^N p(1/y)`` and q' (the arguments of :func:`_ratio_prepared`)."""
    j = np.arange(1, c.size)
    cr = c[::-1]
    return _prepare(c, c[1:] * j), _prepare(cr, cr[1:] * j)


def _ratio(c: NDArray[Any], dc: NDArray[Any], cr: NDArray[Any], dcr: NDArray[Any], z: NDArray[Any],
           test: bool = True) -> tuple[NDArray[Any], NDArray[Any]]:
    """Newton ratio p(z) / p'(z) and a flag "p(z) is at rounding level" for every z.

    Inside the unit circle p is evaluated directly, outside through the reversed polynomial
    ``q(y) = y^N p(1/y)``, so no power of z exceeds 1 in modulus. ``p`` and ``p'`` are evaluated
    without forming every power: with the two tables of :func:`_block_powers`,
    ``p(x) = sum_k x^(b k) sum_i c_(b k + i) x^i``, the inner sums of every block of p and p'
    in one real matrix product (complex powers viewed as pairs of reals), so the work arrays
    hold ``~2 sqrt(N)`` rows instead of ``N + 1``. The flag's bound (the polynomial of the
    coefficients' moduli at ``|z|``, from the moduli of the same tables) is computed only where
    the Newton ratio is below :data:`_NEAR` of ``|z|`` (and ``test`` is True): farther from a
    root (or from a cluster of roots, where ``p'`` is small as well) ``p`` is not at rounding
    level, and the flag is False.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        return _ratio_prepared(_prepare(c, dc), _prepare(cr, dcr), c.size - 1, z, test)


def _ratio_prepared(pre: _Prepared, pre_rev: _Prepared, n: int, z: NDArray[Any], test: bool) -> tuple[NDArray[Any], NDArray[Any]]:
    """:func:`_ratio` from the blocked coefficients of p and of the reversed polynomial
    (:func:`_prepare`); the caller silences division warnings (a root may make p' or q zero)."""
    az = np.abs(z)
    # direct evaluation everywhere while the powers stay far from overflow (one pass);
    # otherwise the roots outside the unit circle go through the reversed polynomial
    if not (az.size and n * math.log10(max(float(az.max()), 1.0)) > 150):
        return _ratio_part(pre, n, z, az, False, test)
    r = np.empty(z.size, dtype=np.complex128)
    small = np.zeros(z.size, dtype=bool)
    inside = az <= 1.0
    for idx, coef, flip in ((np.flatnonzero(inside), pre, False), (np.flatnonzero(~inside), pre_rev, True)):
        if idx.size:
            r[idx], small[idx] = _ratio_part(coef, n, z[idx], az[idx], flip, test)
    return r, small


def _ratio_part(pre: _Prepared, n: int, z: NDArray[Any], az: NDArray[Any], flip: bool,
                test: bool) -> tuple[NDArray[Any], NDArray[Any]]:
    x = 1.0 / z if flip else z
    base, big = _block_powers(x, n)
    blocks, abs_blocks = pre
    inner = (blocks @ base.view(np.float64)).view(np.complex128).reshape(2, big.shape[0], x.size)
    inner *= big
    p, dp = inner.sum(axis=1)  # p and p' (or q and q')
    # outside: p'(z) / p(z) = N y - y^2 q'(y) / q(y)
    r = p / dp if not flip else 1.0 / (n * x - x * x * dp / p)
    small = np.zeros(z.size, dtype=bool)
    if test:
        near = np.flatnonzero(~(np.abs(r) > _NEAR * az))  # NaN (p = p' = 0) counts as near
        tol = 4.0 * n * _EPS
        # the bound sum_j |c_j| |x|^j is at most sum_j |c_j| max(1, |x|)^N: a root whose p exceeds
        # that limit's rounding level fails the test without the bound (the same flags, fewer
        # evaluations of the bound: most roots near convergence are not yet at rounding level)
        near = near[np.abs(p[near]) <= tol * abs_blocks.sum() * np.maximum(np.abs(x[near]), 1.0) ** n]
        if near.size:
            bound = ((abs_blocks @ np.abs(base[:, near])) * np.abs(big[:, near])).sum(axis=0)
            small[near] = np.abs(p[near]) <= tol * bound
    return r, small


#: Below this ``|r s|`` (Newton ratio times repulsion sum) a root's correction reuses the
#: repulsion sum of the previous sweep (see :func:`aberth`). The step ``r / (1 - r s)`` then
#: errs by ``~|r s| |ds / s|`` relative; on the pLSCF denominators of benchmarks/bench_plscf.py
#: (one and two references, orders 64-200) 1e-3 saved 18 % of the time with no order left
#: unconverged, while 1e-2 and 1e-1 left orders to the eigenvalue fallback.
_STALE = 1e-3

#: Elements of one block of the repulsion sums (256 kB of complex numbers; measured on the
#: pLSCF denominators of benchmarks/bench_plscf.py: blocks of 2048-4096 elements took 2-14 %
#: more time).
_REPULSION_BLOCK = 16384

#: Sweeps after which an order still iterating is searched for two approximations on one root
#: (see :func:`_part_twins`); from then on its repulsion sums are all formed afresh. On the pLSCF
#: denominators of benchmarks/bench_plscf.py (one and two references, max orders 100 and 200,
#: chained and one by one) every order converged within 15 sweeps (the smallest ``maxiter``
#: that roots it), except the two-reference order 60 at max order 100: a reused repulsion sum
#: had let two approximations settle on one root, and the order ran into the 60-sweep limit
#: and the companion fallback (with the twins parted here: 23 sweeps, no fallback).
_STALL = 16

#: Relative distance below which two approximations of a root set count as one: two that settled
#: on one simple root agree to its round-off (6e-14 for the twins above), while the two roots of
#: a true double root are resolved only to ~sqrt(eps) ~ 1e-8 and stay apart; the pLSCF
#: denominators' roots are ~1e-2 apart (relative) on the bench data.
_TWIN = 1e-10


def later_twins(z: NDArray[np.complex128]) -> NDArray[np.bool_]:
    """The later member of every pair of coincident approximations (:data:`_TWIN`) in each row of ``z``.

    ``z`` has shape (..., m); returns a mask of the same shape. A NaN entry is never a twin.
    """
    d = np.abs(z[..., :, None] - z[..., None, :])
    return cast("NDArray[np.bool_]", np.triu(d <= _TWIN * np.abs(z)[..., :, None], 1).any(axis=-2))


#: The rounding level of the acceptance test of a root of a degree-N polynomial is ``N`` times this
#: (``|p(z)| <= 4 N eps sum_j |c_j| |z|^j``, as in :func:`_ratio`).
ROUNDING_PER_DEGREE = 4.0 * _EPS


def _part_twins(z: NDArray[np.complex128], turn: int) -> NDArray[np.intp]:
    """Move the later member of every pair of coincident approximations in ``z`` (in place).

    A repulsion sum reused from an earlier sweep (:data:`_STALE`) does not see an approximation
    that has since come close; two can then converge on one root, each accepted, and the root
    they leave free is never found (the order runs to ``maxiter`` and falls back). The moved
    approximations restart on a circle of radius 1.1 (as the new points of :func:`warm_start`),
    turned by the golden angle per call. Returns their indices (to iterate again).
    """
    moved = np.flatnonzero(later_twins(z))
    if moved.size:
        k = np.arange(moved.size)
        z[moved] = 1.1 * np.exp(1j * (0.7 + 2.399963 * turn + 2 * np.pi * (k + 0.5) / moved.size))
    return moved


def _repulsion(zr: NDArray[Any], ir: NDArray[Any], z: NDArray[Any]) -> NDArray[Any]:
    """``sum_{j != ir[i]} 1 / (zr[i] - z[j])`` for the roots ``zr = z[ir]`` (Aberth's correction term).

    In blocks of rows, so that the ``(rows, z.size)`` temporaries stay small. The caller
    silences division warnings (two coincident approximations give an infinite sum).
    """
    m, n = zr.size, z.size
    out = np.empty(m, dtype=np.complex128)
    step = max(1, _REPULSION_BLOCK // max(n, 1))
    for a in range(0, m, step):
        b = min(a + step, m)
        d = np.subtract.outer(zr[a:b], z)
        d[np.arange(b - a), ir[a:b]] = 1.0
        np.reciprocal(d, out=d)
        out[a:b] = d.sum(axis=1) - 1.0  # without the diagonal's 1/1
    return out


def aberth(c: NDArray[np.float64], z0: NDArray[np.complex128], *, maxiter: int = 60,
           s0: NDArray[np.complex128] | None = None) -> NDArray[np.complex128] | None:
    """All roots of ``sum_j c_j z^j`` from initial guesses ``z0`` (one per root).

    Only the roots not yet accepted are iterated (their sweeps vectorised over that active set);
    an accepted root stays where it is and keeps its part in the others' repulsion sums. A
    root is accepted when its backward error is at rounding level (the test of
    :func:`_ratio`), and only then. Returns None when the iteration does not converge within
    ``maxiter`` sweeps (the caller then uses an eigenvalue method). ``s0`` (shape (N,)), when
    given, holds the repulsion sums ``sum_{j != i} 1 / (z0_i - z0_j)`` of the start, used by
    the first sweep instead of summing them (:func:`aberth_warm`).
    """
    n = c.size - 1
    if n < 1 or z0.size != n or c[-1] == 0 or not np.all(np.isfinite(c)):
        return None
    c = np.asarray(c, dtype=float)
    pre, pre_rev = _prepare_both(c)  # p and p'; q(y) = y^N p(1/y) and q'
    z = np.asarray(z0, dtype=np.complex128).copy()
    act = np.arange(n)  # roots still iterating
    s_prev = np.full(n, np.nan, dtype=np.complex128)  # each root's last repulsion sum
    with np.errstate(divide="ignore", invalid="ignore"):
        for it in range(maxiter):
            # the warm start moved with the coefficients: no root is at rounding level before
            # the first correction, so the first sweep skips the test
            r, small = _ratio_prepared(pre, pre_rev, n, z[act], it > 0)
            # a root whose backward error is at rounding level is done: no correction for it
            if small.any():
                keep = ~small
                act, r = act[keep], r[keep]
                if act.size == 0:
                    break
            za = z[act]
            # Aberth's correction r / (1 - r s): where r s is already small, the repulsion s of
            # the previous sweep changes the step only at second order (the roots have moved
            # little since): reuse it, and sum afresh only where it matters
            if it == 0 and s0 is not None:
                s = s0[act]  # the start's sums, given
            else:
                # NaN (no previous sum) compares False; after a stall every sum is formed afresh
                stale = np.abs(r * s_prev[act]) < (_STALE if it < _STALL else 0.0)
                s = s_prev[act]
                fresh = np.flatnonzero(~stale)
                if fresh.size:
                    s[fresh] = _repulsion(za[fresh], act[fresh], z)
            s_prev[act] = s
            w = r / (1.0 - r * s)
            ok = np.isfinite(w)
            z[act[ok]] = za[ok] - w[ok]
            if it + 1 == _STALL:
                # still iterating: part approximations that settled on one root
                act = np.union1d(act, _part_twins(z, 0))
    if act.size:
        return None
    # two approximations on one root would leave another root unfound: _checked tests the sum of
    # the roots (Vieta) and that no two coincide
    return _checked(c, z)


def self_repulsion(coef: NDArray[np.float64], roots: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """``sum_{j != i} 1 / (z_i - z_j)`` over ALL the roots ``z`` of ``sum_j c_j z^j``, at each root.

    At a simple root of p, ``p(z) = p'(z_i) (z - z_i) + p''(z_i) (z - z_i)^2 / 2 + ...`` and the
    sum equals ``p''(z_i) / (2 p'(z_i))``: one evaluation of p' and p'' per root (the blocked
    kernel of :func:`_ratio`, on the reversed polynomial outside the unit circle) instead of
    N - 1 reciprocals. ``roots`` must be all N roots, to the accuracy the caller needs.
    """
    n = coef.size - 1
    d1 = coef[1:] * np.arange(1, n + 1)  # p'
    if n < 2:
        return np.zeros(roots.size, dtype=np.complex128)
    with np.errstate(divide="ignore", invalid="ignore"):
        r, _ = _ratio_prepared(*_prepare_both(d1), n - 1, roots, False)
        return cast("NDArray[np.complex128]", 0.5 / r)  # p'' / (2 p')


def aberth_warm(c: NDArray[np.float64], prev_coef: NDArray[np.float64], prev: NDArray[np.complex128], *,
                maxiter: int = 60) -> NDArray[np.complex128] | None:
    """:func:`aberth` of ``c`` started from :func:`warm_start` of ``prev``, all roots of ``prev_coef``.

    The first sweep's repulsion sums come from the previous polynomial: among the previous
    roots (turned by the warm start's angle, which scales every difference alike) they are
    :func:`self_repulsion` of ``prev_coef``; only the terms of the new start points are summed
    (``m (N - m)`` and ``m N`` reciprocals for ``m`` new points instead of ``N^2``). The
    iteration and its acceptance are those of :func:`aberth`; the first sweep's sums differ from
    summed ones by the accuracy of ``prev`` (their round-off), which changes a step only at
    second order. When ``prev`` is not the whole root set of ``prev_coef`` the sums are formed
    as in :func:`aberth`.
    """
    n = c.size - 1
    z0 = warm_start(prev, n)
    k = prev.size
    if k != prev_coef.size - 1 or k > n or k == 0:
        return aberth(c, z0, maxiter=maxiter)
    s0 = np.empty(n, dtype=np.complex128)
    with np.errstate(divide="ignore", invalid="ignore"):
        s0[:k] = self_repulsion(prev_coef, prev) / _TURN
        if k < n:
            new = z0[k:]
            s0[:k] += (1.0 / (z0[:k, None] - new[None, :])).sum(axis=1)
            s0[k:] = _repulsion(new, np.arange(k, n), z0)
    if not np.all(np.isfinite(s0)):
        return aberth(c, z0, maxiter=maxiter)
    return aberth(c, z0, maxiter=maxiter, s0=s0)


#: Sweeps an order of :func:`aberth_chain` runs alone before the next order starts from its
#: iterate. The roots of consecutive pLSCF orders differ by ~3e-2 relative (the unstable,
#: noise-fitting roots re-arrange; measured on the denominators of benchmarks/bench_plscf.py,
#: orders 64-100), while one sweep already brings the iterate within ~1e-2 of its own roots: a
#: later start gains nothing, and every sweep of delay adds one to the batch's sweep count.
_CHAIN_LAG = 1

#: Polynomials of :func:`aberth_chain` started in one sweep (each from the start of the one before
#: it), while their degree is at most :data:`_CHAIN_GROUP_MAX_DEGREE`. At such degrees a sweep
#: costs mostly the fixed cost of its array operations, paid once for every started polynomial,
#: and a chain that starts one polynomial per sweep ends a whole staggering of sweeps after its
#: last start; above, the work per root dominates and a start from an iterate that has had a
#: sweep saves more of it. Measured on the recorded chains of benchmarks/bench_plscf.py (CPU min
#: of 9 alternating runs, BLAS one thread; one start per sweep against groups of 5 up to degree
#: 100): two references max order 50 (degrees 64-100) 8.78 -> 7.20 ms (21 -> 14 sweeps), one
#: reference max order 100 (48-100) 18.2 -> 13.1 ms (37 -> 18 sweeps), max order 200 one
#: reference 71.9 -> 65.9 ms, two references 40.4 -> 37.2 ms, two references max order 100
#: (64-200) 39.8 -> 41.3 ms; no order fell back to the eigenvalues. Groups of 5 up to degree 80
#: or 120 gained less or lost at 200; groups of 3 let two approximations settle on one root in
#: three of these chains (an order ran to ``maxiter`` and its eigenvalue fallback).
_CHAIN_GROUP = 5
_CHAIN_GROUP_MAX_DEGREE = 100

#: Padding of the root table of :func:`aberth_chain` beyond an order's degree: its reciprocal
#: distance to any root (~1e-300) vanishes from every repulsion sum, and stays finite.
_FAR = 1e300


def coefficient_blocks(coef: NDArray[Any]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Coefficients of scalar polynomials and of their derivatives in the blocks of :func:`_block_powers`.

    Parameters
    ----------
    coef : ndarray, shape (k, n + 1)
        ``c_0 .. c_n`` of each of k real polynomials (zero-padded above a lower degree: the
        padding changes neither p nor p').

    Returns
    -------
    blocks : ndarray, shape (k, 2 K, b)
        Rows ``j < K`` hold ``c_(b j) .. c_(b j + b - 1)`` of p, rows ``K + j`` the same of p'
        (``b = isqrt(n) + 1``, ``K = ceil((n + 1) / b)``, zero-padded), as :func:`_prepare`.
    abs_blocks : ndarray, shape (k, K, b)
        The moduli of p's blocks (the rounding bound of the acceptance test).
    """
    k, n1 = coef.shape
    n = n1 - 1
    b = max(1, math.isqrt(n) + 1)
    kb = -(-n1 // b)
    st = np.zeros((k, 2, kb * b))
    st[:, 0, :n1] = coef
    st[:, 1, :n] = coef[:, 1:] * np.arange(1, n1)
    return st.reshape(k, 2 * kb, b), np.abs(st[:, 0]).reshape(k, kb, b)


def eval_blocked(blocks: NDArray[Any], n: int, owner: NDArray[Any], z: NDArray[Any]) -> tuple[NDArray[Any], NDArray[Any]]:
    """``p(z)`` and ``p'(z)`` of polynomial ``owner[r]`` (degree <= n) at each ``z[r]``, directly.

    ``blocks`` from :func:`coefficient_blocks`. Every power is the product of one row of each of
    the two short tables of :func:`_block_powers` (``~2 sqrt(n)`` rounded factors): the inner
    sums of all blocks of every root in one stack of real products, no ``(n_z, n + 1)`` table of
    powers. Meant for ``|z| <= 1`` (no reversed polynomial: powers of larger roots may
    overflow).
    """
    base, big = _block_powers(z, n)  # (b, n_z), (K, n_z)
    kb = big.shape[0]
    pairs = np.ascontiguousarray(base.T).view(np.float64).reshape(z.size, base.shape[0], 2)
    inner = np.matmul(blocks[owner], pairs).view(np.complex128)[:, :, 0]  # (n_z, 2K)
    inner[:, :kb] *= big.T
    inner[:, kb:] *= big.T
    return inner[:, :kb].sum(axis=1), inner[:, kb:].sum(axis=1)


def aberth_chain(coefs: list[NDArray[np.float64]], start: NDArray[np.complex128], *,
                 maxiter: int = 60) -> list[NDArray[np.complex128] | None]:
    """All roots of a sequence of polynomials of rising degree, each warm-started from the last.

    Parameters
    ----------
    coefs : list of ndarray, each shape (d_i + 1,)
        Real coefficients ``c_0 .. c_d`` of each polynomial, ``d_0 < d_1 < ...``.
    start : ndarray, shape (<= d_0,), complex
        Roots of a polynomial below the first (its warm start, :func:`warm_start`).
    maxiter : int, optional
        Sweeps allowed per polynomial.

    Returns
    -------
    list
        Per polynomial its ``d_i`` roots, or None where the iteration did not converge (the
        caller then uses an eigenvalue method).

    Notes
    -----
    The same iteration and acceptance rule as :func:`aberth` (a root is accepted when its
    backward error is at rounding level, then frozen and kept in the repulsion sums; the
    set passes the checks of :func:`aberth`), run on all polynomials at once: polynomial
    ``i + 1`` starts from the iterate of polynomial ``i`` after :data:`_CHAIN_LAG` sweeps
    (plus the new roots of :func:`warm_start`), and every sweep evaluates the active roots of
    every started polynomial in one batch, so the fixed cost of a sweep is paid once for
    several orders (:func:`_chain_ratio`); the repulsion sums run over the roots of the same
    polynomial (a padded table, :data:`_FAR` beyond each degree).
    """
    k = len(coefs)
    deg = np.array([c.size - 1 for c in coefs])
    out: list[NDArray[np.complex128] | None] = [None] * k
    if k == 0:
        return out
    if np.any(np.diff(deg) <= 0) or deg[0] < 1:
        raise ValueError(f"degrees must rise, got {deg.tolist()}")
    n = int(deg.max())
    padded = np.zeros((k, n + 1))
    for i, c in enumerate(coefs):
        padded[i, : c.size] = c
    abs_sums = np.abs(padded).sum(axis=1)  # the bound's upper limit (_chain_ratio)
    layout = (0, 0)  # (b, K) of the blocks below
    blocks = abs_blocks = np.zeros((0, 0, 0))
    table = np.full((k, n), _FAR, dtype=np.complex128)  # roots of polynomial i in row i
    flat = table.reshape(-1)
    s_prev = np.full(k * n, np.nan, dtype=np.complex128)
    sweeps = np.zeros(k, dtype=int)
    state = np.zeros(k, dtype=int)  # 0 waiting, 1 iterating, 2 finished
    nxt = 0  # the next polynomial to start (k: all started)
    pending = np.zeros(k * n, dtype=bool)  # roots still iterating (flat index)
    bad = ~np.array([c[-1] != 0 and bool(np.all(np.isfinite(c))) for c in coefs])
    prepared: dict[int, tuple[_Prepared, _Prepared]] = {}  # of the polynomials evaluated apart (_chain_ratio)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        while True:
            # start the next polynomial from the iterate of the one before
            copied = -1  # the last polynomial started in this sweep at the iterate (start) of the one before
            started = 0
            while nxt < k and (nxt == 0 or state[nxt - 1] == 2 or sweeps[nxt - 1] >= _CHAIN_LAG
                               or (0 < started < _CHAIN_GROUP and deg[nxt] <= _CHAIN_GROUP_MAX_DEGREE)):
                if bad[nxt]:
                    state[nxt] = 2
                else:
                    if nxt == 0 or bad[nxt - 1]:
                        z0 = warm_start(start, int(deg[nxt]))
                    else:
                        z0 = _extend(table[nxt - 1, : deg[nxt - 1]], int(deg[nxt]), nxt)
                        copied = nxt
                    table[nxt, : deg[nxt]] = z0
                    pending[nxt * n : nxt * n + deg[nxt]] = True
                    state[nxt] = 1
                nxt += 1
                started += 1
            act = np.flatnonzero(pending)
            if act.size == 0:
                if np.all(state == 2):
                    break
                continue  # only polynomials not yet started remain: start the next
            own = act // n
            z = flat[act]
            # the active roots are grouped by polynomial (flat order): slices of each
            cuts = np.concatenate([[0], np.flatnonzero(own[1:] != own[:-1]) + 1, [act.size]])
            uo = own[cuts[:-1]]
            # the active polynomials' blocks, cut for the highest ACTIVE degree (not the chain's):
            # the sweeps of the lower orders form shorter tables of powers and fewer products.
            # The blocks of one layout (b, K) are formed when it begins, for every polynomial up
            # to the highest degree that has it (zeros above a polynomial's degree change nothing)
            na = int(deg[uo].max())
            bw = math.isqrt(na) + 1
            if (bw, -(-(na + 1) // bw)) != layout:
                layout = (bw, -(-(na + 1) // bw))
                top = min(n, bw * layout[1] - 1)
                blocks, abs_blocks = coefficient_blocks(padded[: int(np.searchsorted(deg, top, side="right")), : top + 1])
            r, small = _chain_ratio(blocks, abs_blocks, coefs, deg, na, uo, cuts, z, sweeps[uo] > 0, prepared,
                                    own, abs_sums)
            if small.any():
                pending[act[small]] = False
                keep = ~small
                act, own, r, z = act[keep], own[keep], r[keep], z[keep]
            if act.size:
                # after a stall (below) every sum of that polynomial is formed afresh
                stale = (np.abs(r * s_prev[act]) < _STALE) & (sweeps[own] < _STALL)
                s = s_prev[act]
                fresh = np.flatnonzero(~stale)
                if fresh.size:
                    width = int(deg[own].max())  # no root of these polynomials beyond this column
                    fa = act[fresh]
                    # a polynomial started in this sweep holds the iterate of the one before: where
                    # that one's sum is formed in this sweep (same points, same set of others), the
                    # new one's is it plus the terms of the new start points (_chain_reuse)
                    same, src = _chain_reuse(fa, n, copied, int(deg[copied - 1]) if copied > 0 else 0)
                    direct = np.ones(fresh.size, dtype=bool)
                    direct[same] = False
                    fd = fresh[direct]
                    s[fd] = _chain_repulsion(z[fd], act[fd] % n, table[:, :width], own[fd])
                    if same.size:
                        zc = z[fresh[same]]
                        new = table[copied, int(deg[copied - 1]) : int(deg[copied])]
                        s[fresh[same]] = s[fresh[src]] + (1.0 / (zc[:, None] - new[None, :])).sum(axis=1)
                s_prev[act] = s
                w = r / (1.0 - r * s)
                ok = np.isfinite(w)
                flat[act[ok]] = z[ok] - w[ok]
            live = state == 1
            sweeps[live] += 1
            left = np.bincount(act // n, minlength=k)  # roots still iterating per polynomial
            for i in np.flatnonzero(live & (left > 0) & (sweeps == _STALL)).tolist():
                # still iterating: part approximations that settled on one root
                moved = _part_twins(table[i, : deg[i]], i)
                pending[i * n + moved] = True
                left[i] += moved.size
            for i in np.flatnonzero(live & ((left == 0) | (sweeps >= maxiter))).tolist():
                state[i] = 2
                if left[i] == 0:
                    out[i] = _checked(coefs[i], table[i, : deg[i]].copy())
                else:  # not converged: None (the caller's eigenvalue fallback)
                    pending[i * n : i * n + deg[i]] = False
    return out


def _chain_reuse(fa: NDArray[Any], n: int, copied: int, d_old: int) -> tuple[NDArray[np.intp], NDArray[np.intp]]:
    """Which repulsion sums of a chain sweep can be taken from the polynomial before.

    ``fa`` (ascending flat indices ``polynomial * n + position``) are the roots whose sums the
    sweep forms; polynomial ``copied`` (or none, -1) started in this sweep with its first
    ``d_old`` roots at the iterate of polynomial ``copied - 1``. Returns ``(same, src)``: the
    entries of ``fa`` of those roots whose counterpart (index ``- n``) is in ``fa`` too, and
    the entries of the counterparts.
    """
    if copied < 1:
        return np.zeros(0, dtype=np.intp), np.zeros(0, dtype=np.intp)
    cand = np.flatnonzero((fa // n == copied) & (fa % n < d_old))
    src = fa[cand] - n
    at = np.minimum(np.searchsorted(fa, src), fa.size - 1)
    ok = fa[at] == src
    return cand[ok], at[ok]


#: Roots near convergence per polynomial from which :func:`_chain_ratio` forms their rounding
#: bound by one product per polynomial rather than one over blocks gathered per root: a product
#: call costs ~3 us, the gather ~0.2 us per root at the blocks of degree 100-200 (one thread).
#: On the recorded chains of benchmarks/bench_plscf.py (CPU, 31-41 alternating runs against
#: 4ff7088): products per polynomial always made the two-reference chain of degrees 64-100 (ten
#: orders started in two sweeps) 5-9 % slower, with this crossover 2 % (4: 4 %); the
#: one-reference chain of degrees 48-200 13-16 % faster either way.
_BOUND_GROUP = 16


def _chain_ratio(blocks: NDArray[Any], abs_blocks: NDArray[Any], coefs: list[NDArray[Any]], deg: NDArray[Any],
                 n: int, uo: NDArray[Any], cuts: NDArray[Any], z: NDArray[Any],
                 test: NDArray[Any], prepared: dict[int, tuple[_Prepared, _Prepared]],
                 own: NDArray[Any] | None = None, abs_sums: NDArray[Any] | None = None) -> tuple[NDArray[Any], NDArray[Any]]:
    """Newton ratio and rounding flag (as :func:`_ratio`) of the roots ``z``, grouped by polynomial.

    ``z[cuts[t]:cuts[t + 1]]`` are roots of polynomial ``uo[t]``, tested where ``test[t]``;
    ``blocks[uo[t]]`` and ``abs_blocks[uo[t]]`` are its blocks (:func:`coefficient_blocks` at
    degree ``n``, at least the degree of every polynomial ``uo``). The
    two power tables are formed once for all roots; each polynomial's blocks multiply its own
    slice (one small real matrix product per polynomial, written in place), and the rounding
    bound of the roots near convergence likewise (one product per polynomial, no per-root copy
    of its blocks). Direct evaluation wherever no power can overflow (as
    :func:`_ratio_prepared`); the roots whose powers may (``d log10 |z| > 150``) go through
    :func:`_ratio_prepared` on their polynomial's reversed coefficients (:func:`_prepare_both`,
    formed once per polynomial and kept in ``prepared``, polynomial index -> blocks, for the
    sweeps that follow), the polynomial's other roots keep their direct values.
    ``own`` (the polynomial of each root) and ``abs_sums`` (``sum_j |c_j|`` of every polynomial),
    when the caller holds them, spare forming them again.

    A sweep of :func:`aberth_chain` evaluates a few hundred roots of ~10 polynomials: its cost is
    mostly the fixed cost of the array operations, so the overflow test per polynomial is made
    only when the largest root of all could overflow the highest degree.
    """
    az = np.abs(z)
    risky = None  # the polynomials with roots whose powers may overflow
    counts = np.diff(cuts)
    if z.size and float(deg[uo].max()) * math.log10(max(float(az.max()), 1.0)) > 150:
        own = np.repeat(uo, counts) if own is None else own
        over = deg[own] * np.log10(np.maximum(az, 1.0)) > 150  # the roots
        risky = np.logical_or.reduceat(over, cuts[:-1])
    base, big = _block_powers(z, n)
    kb = big.shape[0]
    basef = base.view(np.float64)  # (b, 2 m): real and imaginary parts side by side
    inner = np.empty((2 * kb, z.size), dtype=np.complex128)
    innerf = inner.view(np.float64)
    cl = cuts.tolist()
    for t, i in enumerate(uo.tolist()):
        a, b = 2 * cl[t], 2 * cl[t + 1]
        np.matmul(blocks[i], basef[:, a:b], out=innerf[:, a:b])
    inner[:kb] *= big
    inner[kb:] *= big
    p = inner[:kb].sum(axis=0)
    r = p / inner[kb:].sum(axis=0)
    small = np.zeros(z.size, dtype=bool)
    near = np.flatnonzero(~(np.abs(r) > _NEAR * az))  # NaN (p = p' = 0) counts as near
    if not test.all():
        near = near[np.repeat(test, counts)[near]]
    if risky is not None:  # those roots are tested below, on the reversed polynomial
        near = near[~over[near]]
    if near.size:
        own = (np.repeat(uo, counts) if own is None else own)[near]
        if abs_sums is None:
            abs_sums = abs_blocks.sum(axis=(1, 2))
        # first against the bound's upper limit (see _ratio_part): only the roots that pass it
        # go on to the bound itself
        dn = deg[own]
        tol = 4.0 * _EPS * dn
        pn = np.abs(p[near])
        cand = pn <= tol * abs_sums[own] * np.maximum(az[near], 1.0) ** dn
        near, own, tol, pn = near[cand], own[cand], tol[cand], pn[cand]
        if near.size:
            ab = np.abs(base[:, near])
            gc = np.flatnonzero(own[1:] != own[:-1]).tolist() if near.size >= _BOUND_GROUP else None
            if gc is not None and near.size >= _BOUND_GROUP * (len(gc) + 1):
                # the roots stay grouped by polynomial: one real product with each polynomial's
                # blocks (no gathered copy of the blocks per root)
                terms = np.empty((big.shape[0], near.size))
                for a, b in zip([0, *[g + 1 for g in gc]], [*[g + 1 for g in gc], near.size], strict=True):
                    np.matmul(abs_blocks[own[a]], ab[:, a:b], out=terms[:, a:b])
            else:  # few roots per polynomial: one product over the gathered blocks
                terms = np.einsum("mkb,bm->km", abs_blocks[own], ab)
            terms *= np.abs(big[:, near])
            small[near] = pn <= tol * terms.sum(axis=0)
    if risky is not None:
        for u in np.flatnonzero(risky).tolist():
            # the roots of this polynomial whose powers may overflow: on its reversed polynomial
            # (as _ratio_prepared: outside the unit circle); the others keep the direct values
            a, b = cl[u], cl[u + 1]
            i = int(uo[u])
            sel = a + np.flatnonzero(over[a:b])
            if i not in prepared:
                prepared[i] = _prepare_both(coefs[i])
            r[sel], small[sel] = _ratio_prepared(*prepared[i], int(deg[i]), z[sel], bool(test[u]))
    return r, small


def _chain_repulsion(zr: NDArray[Any], pos: NDArray[Any], table: NDArray[Any], own: NDArray[Any]) -> NDArray[Any]:
    """``sum_{j != pos[i]} 1 / (zr[i] - table[own[i], j])``, in blocks of rows (see :func:`_repulsion`).

    In real arithmetic, ``1 / d = conj(d) / |d|^2`` on the real and imaginary parts apart: one
    real reciprocal per term where numpy's complex reciprocal takes a branching (Smith) division
    (800 x 100 terms, one thread: 0.40 against 0.69 ms with the gather and the subtraction).
    The sums differ from the complex division's by a few ulps. A padding entry :data:`_FAR`
    contributes 0 (``|d|^2`` overflows to inf), a coincident pair makes the sum non-finite, as
    the complex division does.
    """
    m, n = zr.size, table.shape[1]
    if m:  # the parts of the rows in use only (a chain's table holds every polynomial)
        o0 = int(own.min())
        table, own = table[o0 : int(own.max()) + 1], own - o0
    tr, ti = np.ascontiguousarray(table.real), np.ascontiguousarray(table.imag)
    out = np.empty(m, dtype=np.complex128)
    step = max(1, _REPULSION_BLOCK // max(n, 1))
    for a in range(0, m, step):
        b = min(a + step, m)
        rows = np.arange(b - a)
        dr = np.take(tr, own[a:b], axis=0)
        np.subtract(zr.real[a:b, None], dr, out=dr)
        di = np.take(ti, own[a:b], axis=0)
        np.subtract(zr.imag[a:b, None], di, out=di)
        dr[rows, pos[a:b]] = 1.0  # the root's own term: 1 / 1, taken off below
        di[rows, pos[a:b]] = 0.0
        q = np.multiply(dr, dr)
        q += np.multiply(di, di)
        np.reciprocal(q, out=q)  # 1 / |d|^2
        out.real[a:b] = np.einsum("ij,ij->i", dr, q) - 1.0  # without the own term's 1
        out.imag[a:b] = -np.einsum("ij,ij->i", di, q)
    return out


def _extend(prev: NDArray[np.complex128], n_roots: int, turn: int) -> NDArray[np.complex128]:
    """Start of polynomial ``turn`` of a chain: the iterate ``prev`` of the one before (already not
    conjugate-symmetric) and new points spread on a circle as in :func:`warm_start`, turned by
    the golden angle per polynomial (the previous polynomial's new roots may not have left
    their own start points yet: two start points must not coincide)."""
    m = n_roots - prev.size
    k = np.arange(m)
    new = 1.1 * np.exp(1j * (0.4 + 2.399963 * turn + 2 * np.pi * (k + 0.5) / max(m, 1)))
    return cast("NDArray[np.complex128]", np.concatenate([prev, new]))


def vieta_ok(c_next: Any, c_lead: Any, total: Any, abs_total: Any) -> Any:
    """Whether root sets have the sum of the roots of their polynomials (Vieta), elementwise.

    ``total`` and ``abs_total`` are the sum of a set's roots and of their moduli, ``c_lead`` and
    ``c_next`` the polynomial's coefficients of degree ``N`` and ``N - 1`` (scalars or arrays):
    the sum must be ``-c_next / c_lead`` within ``1e-8`` of the moduli's sum (a lost or doubled
    root moves it by a root's size; round-off by ~N eps). A non-finite root fails.
    """
    vieta = -c_next / c_lead
    with np.errstate(invalid="ignore"):
        return np.isfinite(abs_total) & (np.abs(total - vieta) <= 1e-8 * (abs_total + np.abs(vieta)))


def _checked(c: NDArray[Any], z: NDArray[np.complex128]) -> NDArray[np.complex128] | None:
    """``z`` if finite, with the sum of the roots of ``c`` (Vieta) and no two coincident; else None."""
    if not np.all(np.isfinite(z)) or not vieta_ok(c[-2], c[-1], z.sum(), np.abs(z).sum()):
        return None
    zs = np.sort_complex(z)
    if np.any(np.abs(np.diff(zs)) <= 1e-12 * np.abs(zs[1:])):
        return None
    return z


#: The turn of :func:`warm_start`'s guesses off conjugate symmetry.
_TURN = np.exp(1e-3j)


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
    return cast("NDArray[np.complex128]", np.concatenate([prev, new]) * _TURN)


__all__ = ["ROUNDING_PER_DEGREE", "aberth", "aberth_chain", "aberth_warm", "coefficient_blocks", "det_coefficients",
           "eval_blocked", "later_twins", "self_repulsion", "vieta_ok", "warm_start"]
