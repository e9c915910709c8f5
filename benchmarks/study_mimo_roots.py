"""Study: can the two-reference root step go faster than the warm-started Aberth iteration? (issue 22)

The two-reference pLSCF of ``bench_plscf.py`` (8 outputs x 2 references x 4000 lines, every even
order 2..N) spends most of its time finding the 2n roots of ``det A(z)`` at each order n
(``profile_plscf_mimo.py``). This study replays the root step on the bench data, order by
order from the same coefficients, and measures three ideas against the library's path (companion
eigenvalues below degree 64, then :func:`ema_rig.identification._roots.aberth` warm-started from
the previous order's roots), CPU time per order (fastest of ``--repeat``), BLAS on one thread:

1. **Warm start from farther back.** The roots of order n started from those of order n - 2k
   (k = 1 is the library): Aberth sweeps per order. If the distance hardly matters, orders could
   be rooted together (batched) from one older start.
2. **Companion eigenvalues against Aberth** per degree (where the threshold belongs).
3. **Conjugate-symmetric Aberth** (study code below): the polynomial is real, so only one root of
   each conjugate pair is iterated, its mirror counting in the repulsion sums (half the
   evaluations and half the repulsion sums per sweep), real roots iterated on the real axis. A
   symmetric set cannot change its number of real roots, and on these denominators it changes
   at about half of the orders (pairs splitting into two real roots near ``z = +-1`` and back),
   so when a few guesses are left unconverged they are finished as free guesses from the roots
   of the deflated polynomial. Every root is accepted by the library's rounding-level test and
   the roots of an order are checked against the companion eigenvalues.
4. **The same number of poles.** At order n the two-reference model has 2n poles, sdypy-EMA's
   stacked scalar model n: the whole call (CPU, median of ``--repeat``) of ema_rig on the even
   orders 2..N and 2..N/2 (as many poles as sdypy's top order) against sdypy-EMA on 2..N.

Run: ``python benchmarks/study_mimo_roots.py [--max-order N] [--repeat R]`` (default 100, 5).
"""

from __future__ import annotations

import argparse
import importlib
import sys
import time
from collections.abc import Callable
from typing import Any, cast

import numpy as np
from bench_plscf import (  # beside this script
    blas_threads,
    call_ema,
    call_sdypy,
    ema_data,
    import_sdypy,
    make_arrays,
)
from numpy.typing import NDArray

_roots = importlib.import_module("ema_rig.identification._roots")
_plscf = importlib.import_module("ema_rig.identification.plscf")
_Prepared = tuple[NDArray[np.float64], NDArray[np.float64]]
_prepare, _ratio_prepared, _repulsion = _roots._prepare, _roots._ratio_prepared, _roots._repulsion
_STALE = _roots._STALE
_checked = _roots._checked

# ----------------------------------------------------------------- conjugate-symmetric Aberth (study)
def warm_start_conj(prev: NDArray[np.complex128], n_roots: int) -> tuple[NDArray[np.complex128], NDArray[np.complex128]] | None:
    """Initial guesses for :func:`aberth_conj` from the previous order's roots ``prev``.

    Returns ``(upper, free)`` with ``2 upper.size + free.size == n_roots``: the previous roots
    in the upper half plane at least :data:`_AXIS_ANGLE` from the real axis (each stands for a
    conjugate pair), the previous roots near or on the axis as free guesses (rotated by a tiny
    angle so that no two are conjugate, as :func:`warm_start`), and the new roots as pairs
    spread over the upper half of the circle of radius 1.1 (one free point more for an odd
    count). None when ``prev`` holds more roots than ``n_roots`` (the caller then uses
    :func:`warm_start`).
    """
    real = np.abs(prev.imag) <= 1e-10 * np.abs(prev)
    upper = prev[~real & (prev.imag > 0)]
    free = prev[real].real
    m = n_roots - 2 * upper.size - free.size
    if m < 0 or m % 2:
        return None
    k = np.arange(m // 2)
    new = 1.1 * np.exp(1j * np.pi * (k + 0.5) / max(m // 2, 1))
    return np.concatenate([upper, new]).astype(np.complex128), free.astype(float)


def aberth_conj(c: NDArray[np.float64], upper: NDArray[np.complex128], real: NDArray[np.float64], *,
                maxiter: int = 60) -> NDArray[np.complex128] | None:
    """All roots of the REAL polynomial ``sum_j c_j z^j``, iterating one root of each conjugate pair.

    Parameters
    ----------
    c : ndarray, shape (N + 1,)
        Real coefficients ``c_0 .. c_N``.
    upper : ndarray, shape (q,), complex
        Initial guesses in the upper half plane, each standing for the pair ``(u, conj u)``.
    real : ndarray, shape (N - 2 q,), float
        Initial guesses for the real roots.
    maxiter : int, optional
        Sweeps at most, in all.

    Returns
    -------
    ndarray, shape (N,), complex, or None
        The pairs' roots, their conjugates and the real roots; None when the iteration does not
        converge within ``maxiter`` sweeps or the roots fail the checks of :func:`aberth` (the
        caller then uses :func:`aberth` or the companion eigenvalues).

    Notes
    -----
    The roots of a real polynomial are real or come in conjugate pairs, and the Aberth-Ehrlich
    iteration of :func:`aberth` started from a conjugate-symmetric set of guesses (pairs and
    real points) stays symmetric: the conjugate of a guess moves as the conjugate of its move,
    a real guess stays real. So only one guess of each pair is iterated, its conjugate counting
    in every repulsion sum: half the evaluations of ``p`` and ``p'`` and half the repulsion sums
    per sweep, the same iteration. Every iterated root is accepted by the same rounding-level
    test, with the same reuse of the repulsion sums. A symmetric set cannot change its number
    of real roots, so when the guesses hold the wrong number (the real roots of consecutive
    pLSCF orders come and go in pairs near ``z = +-1``), the iteration stalls with real guesses
    or pairs left over: after :data:`_STALL` sweeps without an accepted root, the two closest
    leftover real guesses become a pair, or else the leftover pair nearest the axis becomes two
    real guesses, and the iteration continues (the accepted roots pass the test again at once).
    """
    n = c.size - 1
    if n < 1 or 2 * upper.size + real.size != n or c[-1] == 0 or not np.all(np.isfinite(c)):
        return None
    c = np.asarray(c, dtype=float)
    j = np.arange(1, n + 1)
    pre = _prepare(c, c[1:] * j)
    cr = c[::-1]
    pre_rev = _prepare(cr, cr[1:] * j)
    u = np.asarray(upper, dtype=np.complex128)
    v = np.asarray(real, dtype=float)
    x, done, used = _conj_sweeps(pre, pre_rev, n, u, v, maxiter)
    q = u.size
    # the guesses left: free guesses (a pair as two, off its symmetry), the accepted roots fixed
    left = np.flatnonzero(~done)
    lu, lv = left[left < q], left[left >= q]
    fixed = np.concatenate([x[:q][done[:q]], x[:q][done[:q]].conj(), x[q:][done[q:]]])
    rest = _deflated_guesses(c, fixed, np.concatenate([x[lu], x[lu].conj(), x[lv]]))
    if rest.size:
        rest = _free_sweeps(pre, pre_rev, n, fixed, rest, maxiter - used)
        if rest is None:
            return None
    return cast("NDArray[np.complex128] | None", _checked(c, np.concatenate([fixed, rest])))


#: :func:`aberth_conj` ends its symmetric sweeps once at most ``_STALL_LEFT`` guesses are left, or
#: after ``_STALL`` sweeps in a row without an accepted root (a wrong number of real guesses leaves
#: 1-4 guesses that cannot converge; measured on the pLSCF denominators of
#: benchmarks/bench_plscf.py), and finishes the rest as free guesses.
_STALL = 2
_STALL_LEFT = 4


def _deflated_guesses(c: NDArray[Any], fixed: NDArray[Any], z0: NDArray[Any]) -> NDArray[Any]:
    """Guesses for the ``k = z0.size`` roots of ``p`` that are not among the accepted roots ``fixed``.

    ``g(z) = p(z) / prod_j (z - fixed_j)`` is a polynomial of degree ``k`` whose roots are those
    left; its coefficients are interpolated (one FFT) from its values at ``k + 1`` points on
    a circle of radius ``rho`` (twice the largest modulus of ``z0``, at least 2: away from the
    roots near the unit circle, which keeps the values and the fit well conditioned), with
    every factor and power scaled by ``rho`` (no overflow at degree 200), and its roots found
    as companion eigenvalues. They are only starting points (the Aberth sweeps that follow accept a
    root on ``p`` itself); the guesses ``z0`` rotated by a tiny angle are returned when the fit
    is not finite.
    """
    k = z0.size
    fallback = z0 * np.exp(1e-3j)
    if k == 0:
        return fallback
    rho = max(2.0, 2.0 * float(np.abs(z0).max()))
    m = k + 1
    e = np.exp(2j * np.pi * (np.arange(m) + 0.5) / m)  # t / rho
    with np.errstate(all="ignore"):
        pw = np.empty((m, c.size), dtype=np.complex128)
        pw[:, 0] = 1.0
        pw[:, 1:] = e[:, None]
        np.multiply.accumulate(pw, axis=1, out=pw)
        # p(t) / rho^N = sum_j c_j rho^(j - N) e^j;  prod_j (t - r_j) / rho^(N - k)
        scale = rho ** (np.arange(c.size) - (c.size - 1.0))
        g = (pw @ (c * scale)) / np.prod(e[:, None] - fixed[None, :] / rho, axis=1)
        # interpolation on the k + 1 points: a_j = mean_l g_l e_l^-j (g / rho^k in powers of z / rho)
        a = np.fft.fft(g) * (np.exp(-1j * np.pi * np.arange(m) / m) / m)
        if not np.all(np.isfinite(a)) or a[-1] == 0:
            return fallback
        comp = np.zeros((k, k), dtype=np.complex128)
        comp[0] = -a[-2::-1] / a[-1]
        comp[np.arange(1, k), np.arange(k - 1)] = 1.0
        z = np.linalg.eigvals(comp) * rho
    if z.size != k or not np.all(np.isfinite(z)):
        return fallback
    return cast("NDArray[Any]", z * np.exp(1e-9j))


def _free_sweeps(pre: _Prepared, pre_rev: _Prepared, n: int, fixed: NDArray[Any], z0: NDArray[Any],
                 maxiter: int) -> NDArray[Any] | None:
    """Aberth sweeps (as :func:`aberth`) of the guesses ``z0`` with the accepted roots ``fixed``
    held in place in the repulsion sums; the roots, or None without convergence."""
    z = np.concatenate([fixed, z0])
    act = np.arange(fixed.size, z.size)
    s_prev = np.full(z.size, np.nan, dtype=np.complex128)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(maxiter):
            r, small = _ratio_prepared(pre, pre_rev, n, z[act], True)
            if small.any():
                act, r = act[~small], r[~small]
                if act.size == 0:
                    return z[fixed.size :]
            za = z[act]
            s = s_prev[act]
            fresh = np.flatnonzero(~(np.abs(r * s) < _STALE))
            if fresh.size:
                s[fresh] = _repulsion(za[fresh], act[fresh], z)
            s_prev[act] = s
            w = r / (1.0 - r * s)
            ok = np.isfinite(w)
            z[act[ok]] = za[ok] - w[ok]
    return None


def _conj_sweeps(pre: _Prepared, pre_rev: _Prepared, n: int, u: NDArray[Any], v: NDArray[Any],
                 maxiter: int) -> tuple[NDArray[Any], NDArray[Any], int]:
    """The symmetric sweeps of :func:`aberth_conj` for pairs ``u`` and real guesses ``v``.

    Returns the iterated roots ``[u, v]`` (complex), which of them are accepted, and the sweeps
    used; stops once at most :data:`_STALL_LEFT` guesses are left unaccepted, or when
    :data:`_STALL` sweeps in a row accept none.
    """
    q = u.size
    x = np.concatenate([u, v + 0j])
    pos = np.concatenate([np.arange(q), 2 * q + np.arange(v.size)])  # places in the full set
    act = np.arange(x.size)
    s_prev = np.full(x.size, np.nan, dtype=np.complex128)
    quiet = 0
    it = 0
    with np.errstate(divide="ignore", invalid="ignore"):
        while it < maxiter:
            # the warm start moved with the coefficients: no test before one correction
            r, small = _ratio_prepared(pre, pre_rev, n, x[act], it > 0)
            it += 1
            if small.any():
                quiet = 0
                act, r = act[~small], r[~small]
            elif act.size < x.size:
                quiet += 1
            if act.size <= _STALL_LEFT or quiet >= _STALL:
                break
            xa = x[act]
            stale = np.abs(r * s_prev[act]) < _STALE
            s = s_prev[act]
            fresh = np.flatnonzero(~stale)
            if fresh.size:
                full = np.concatenate([x[:q], x[:q].conj(), x[q:]])
                s[fresh] = _repulsion(xa[fresh], pos[act[fresh]], full)
            s_prev[act] = s
            w = r / (1.0 - r * s)
            ok = np.isfinite(w)
            idx = act[ok]
            new = xa[ok] - w[ok]
            pair = idx < q
            # a real guess stays real (the imaginary parts of its sums cancel but for rounding);
            # a pair's representative that crossed the axis is the same pair by its other root
            # (its repulsion sum, now the conjugate one, is summed afresh)
            new[~pair] = new[~pair].real
            flip = pair & (new.imag < 0)
            new[flip] = new[flip].conj()
            x[idx] = new
            s_prev[idx[flip]] = np.nan
    done = np.ones(x.size, dtype=bool)
    done[act] = False
    return x, done, it



# ------------------------------------------------------------------------------------ the study
def _orders(max_order: int) -> tuple[dict[int, NDArray[Any]], dict[int, NDArray[Any]], dict[int, NDArray[Any]]]:
    """Per even order: the alpha_0 = I coefficient blocks, det coefficients and companion roots."""
    freq, h, _ = make_arrays(2)
    eng = _plscf.PlscfEngine(_plscf.check_data(ema_data(freq, h), None), max_order)
    eng._blocks(max_order)
    for _, rows in eng._row_blocks(0, max_order):
        eng._P = _plscf._add_gram(eng._P, rows.reshape(-1, rows.shape[2]))
    lows, coefs, roots = {}, {}, {}
    for n in range(2, max_order + 1, 2):
        c = (n + 1) * 2
        lows[n], _ = _plscf._solve_order(eng._T[:c, :c] - eng._P[:c, :c], n, 2)
        coefs[n] = _roots.det_coefficients(lows[n])
        roots[n] = _plscf._roots_eig(lows[n])
    return lows, coefs, roots


def _cpu(fn: Callable[[], Any], repeat: int) -> float:
    best = np.inf
    for _ in range(repeat):
        t0 = time.thread_time()
        fn()
        best = min(best, time.thread_time() - t0)
    return float(best)


def _same_roots(a: NDArray[Any] | None, b: NDArray[Any]) -> float:
    """Largest distance from a root of either set to the other set, relative to its modulus."""
    if a is None:
        return np.inf
    d1 = np.abs(a[:, None] - b[None, :]).min(axis=1) / np.abs(a)
    d2 = np.abs(b[:, None] - a[None, :]).min(axis=1) / np.abs(b)
    return float(max(d1.max(), d2.max()))


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--max-order", type=int, default=100)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    top, rep = args.max_order, args.repeat
    with blas_threads(1):
        lows, coefs, roots = _orders(top)
        big = [n for n in range(2, top + 1, 2) if 2 * n >= 64 and n - 2 in roots]
        sweeps: list[int] = []
        orig = _roots._ratio_prepared

        def counting(*a: Any) -> Any:
            sweeps.append(1)
            return orig(*a)

        print(f"two-reference denominators of bench_plscf.py, even orders 2..{top}, BLAS 1 thread, "
              f"CPU time per order (fastest of {rep}), {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
        print("\n1. Aberth sweeps per order when started from the roots of order n - 2k (orders of degree >= 64)")
        _roots._ratio_prepared = counting
        try:
            for k in (1, 2, 4, 8, 12):
                per = []
                for n in big:
                    if n - 2 * k < 2:
                        continue
                    sweeps.clear()
                    _roots.aberth(coefs[n], _roots.warm_start(roots[n - 2 * k], 2 * n))
                    per.append(len(sweeps))
                print(f"   k = {k:2d}: sweeps mean {np.mean(per):5.1f}, max {max(per):3d} ({len(per)} orders)")
        finally:
            _roots._ratio_prepared = orig

        print("\n2./3. per order [ms]: companion eigenvalues, library Aberth (warm start n - 2), conjugate-symmetric Aberth;"
              "\n      worst relative distance of the symmetric roots to the eigenvalues")
        print(f"{'order':>6} {'degree':>6} {'eig':>8} {'aberth':>8} {'conj':>8} {'conj/aberth':>11} {'real roots':>11} {'dist':>9}")
        tot = np.zeros(3)
        for n in range(2, top + 1, 2):
            t_eig = _cpu(lambda n=n: _plscf._roots_eig(lows[n]), rep)
            if n not in big:
                if n % 10 == 0:
                    print(f"{n:6d} {2 * n:6d} {t_eig * 1e3:8.3f}")
                continue
            ws = _roots.warm_start(roots[n - 2], 2 * n)
            cs = warm_start_conj(roots[n - 2], 2 * n)
            assert cs is not None
            t_ab = _cpu(lambda n=n, ws=ws: _roots.aberth(coefs[n], ws), rep)
            t_cj = _cpu(lambda n=n, cs=cs: aberth_conj(coefs[n], *cs), rep)
            dist = _same_roots(aberth_conj(coefs[n], *cs), roots[n])
            tot += (t_eig, t_ab, t_cj)
            n_real = f"{int(np.sum(roots[n - 2].imag == 0))}->{int(np.sum(roots[n].imag == 0))}"
            print(f"{n:6d} {2 * n:6d} {t_eig * 1e3:8.3f} {t_ab * 1e3:8.3f} {t_cj * 1e3:8.3f} {t_cj / t_ab:11.2f} "
                  f"{n_real:>11} {dist:9.1e}")
        print(f"{'sum':>13} {tot[0] * 1e3:8.2f} {tot[1] * 1e3:8.2f} {tot[2] * 1e3:8.2f} {tot[2] / tot[1]:11.2f}"
              f"   (orders of degree >= 64)")

        print("\n4. whole calls [ms CPU, median]: ema_rig two references on 2..N (2N poles at the top) and on 2..N/2 (N poles),"
              "\n   sdypy-EMA on the 16 FRFs stacked, 2..N (N poles); ratio = sdypy / ema_rig")
        import_sdypy()
        freq, h, _ = make_arrays(2)
        data, h1 = ema_data(freq, h), h.reshape(16, -1)
        call_ema(data, 10, even=True)
        call_sdypy(freq, h1, 10)
        for big_n in (50, 100, 200):
            if big_n > top:
                break
            calls: list[Callable[[], Any]] = [
                lambda n=big_n: call_ema(data, n, even=True), lambda n=big_n: call_ema(data, n // 2, even=True),
                lambda n=big_n: call_sdypy(freq, h1, n)]
            t = [[_cpu(f, 1) for _ in range(rep)] for f in calls]
            a, b, c = (float(np.median(x)) for x in t)
            print(f"   N = {big_n:3d}: ema_rig 2..N {a * 1e3:7.1f}, 2..N/2 {b * 1e3:7.1f}, sdypy {c * 1e3:7.1f}; "
                  f"ratio {c / a:5.2f} (same order) / {c / b:5.2f} (same number of poles)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
