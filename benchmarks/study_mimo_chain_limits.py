"""Study: what the two-reference pLSCF at order 50 could still give up, stage by stage (issue 22).

The target of issue 22 (``bench_plscf.py``'s two-reference rows, sdypy stacked / ema_rig >= 1.5 at
max order 50, one BLAS thread) needs ~27 % off a 12-13 ms call whose batched Aberth chain
(:func:`ema_rig.identification._roots.aberth_chain`) is about half. Measured here, on the bench
data (8 outputs x 2 references x 4000 lines, even orders 2..N), CPU time with BLAS on one thread:

1. **The unstable poles are part of the answer.** Of the chain's roots ~85 % are noise roots
   outside the unit circle (``|z|`` 1.05-1.1); :func:`~ema_rig.identification.plscf._poles_of_orders`
   keeps every root with ``Im > 0`` in the band, stable or not, and the ``PoleSet`` carries them
   (``Re lambda >= 0``, participation NaN; the stabilization chart draws them as ``o``). Counted
   on the ``PoleSet`` of the call.
2. **Early stop of the noise roots** (the chain replayed with a wrapped ``_chain_ratio``): a root
   outside the unit circle whose Newton inclusion disk (radius ``d |p / p'|``, a disk that holds
   a root of the degree-d polynomial) lies outside the circle with a margin of half its distance
   to it (``disk``), or whose Newton ratio is below ``1e-6 |z|`` / ``1e-3 |z|``, counts as
   accepted where it stands. The library's final test of each order (``_checked``: Vieta's sum
   of the roots) is switched off for the replay (inexact roots fail it: every order would fall
   back to the eigenvalues). Paired alternating replays against the library's chain: CPU time,
   root-sweeps, sweeps, the largest relative distance of the stable and of the unstable roots
   to the library's, and whether the count of roots outside the unit circle is the same.
3. **Lag sums** by the inverse real FFT of length ``2 (n - 1)`` (7998 = 2 3 31 43) against a
   length of small primes (8000) and against the direct real product with a cosine / sine table
   of lags 0..N built from two short tables of the exact angles (lag ``8 a + b``).
4. **The per-order solves**: ``_solve_order`` replayed on the call's reduced matrices; a line
   through CPU time against ``c^3`` (``c`` the matrix size) separates the fixed cost per call.

Run: ``python benchmarks/study_mimo_chain_limits.py [--max-order N] [--repeat R]`` (default 50, 15).
"""

from __future__ import annotations

import argparse
import importlib
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from bench_plscf import blas_threads, call_ema, ema_data, make_arrays  # beside this script

_roots = importlib.import_module("ema_rig.identification._roots")
_plscf = importlib.import_module("ema_rig.identification.plscf")


def _cpu(fn: Callable[[], Any]) -> float:
    t0 = time.thread_time()
    fn()
    return time.thread_time() - t0


def _record(data: Any, max_order: int) -> tuple[Any, list[Any], list[Any]]:
    """One call with the chain's arguments and the reduced matrices of ``_solve_order`` recorded."""
    chains: list[Any] = []
    solves: list[Any] = []
    chain0, solve0 = _plscf.aberth_chain, _plscf._solve_order

    def chain(coefs: list[Any], start: Any) -> Any:
        chains.append((list(coefs), start.copy()))
        return chain0(coefs, start)

    def solve(m: Any, n: int, n_in: int) -> Any:
        solves.append((m.copy(), n, n_in))
        return solve0(m, n, n_in)

    _plscf.aberth_chain, _plscf._solve_order = chain, solve
    try:
        ps = call_ema(data, max_order, even=True)
    finally:
        _plscf.aberth_chain, _plscf._solve_order = chain0, solve0
    return ps, chains, solves


def _early_chain(coefs: list[Any], start: Any, rule: str | float) -> tuple[list[Any], int, int]:
    """The chain with the noise roots stopped early (``rule``: 'disk' or a Newton-ratio bound)."""
    deg = np.array([c.size - 1 for c in coefs])
    ratio0, checked0 = _roots._chain_ratio, _roots._checked
    count = [0, 0]

    def ratio(*a: Any, **k: Any) -> Any:
        r, small = ratio0(*a, **k)
        uo, cuts, z, test = a[5], a[6], a[7], a[8]
        count[0] += 1
        count[1] += z.size
        az = np.abs(z)
        tested = np.repeat(test, np.diff(cuts))
        if rule == "disk":
            cert = deg[np.repeat(uo, np.diff(cuts))] * np.abs(r) < 0.5 * (az - 1.0)
        else:
            cert = np.abs(r) < float(rule) * az
        return r, small | (tested & (az > 1.0) & cert)

    _roots._chain_ratio, _roots._checked = ratio, lambda c, z: z
    try:
        out = _roots.aberth_chain(coefs, start)
    finally:
        _roots._chain_ratio, _roots._checked = ratio0, checked0
    return out, count[0], count[1]


def _lag_tables(n: int, p: int) -> tuple[Any, Any]:
    """cos / sin of the exact angles ``pi k l / (n - 1)``, lines k < n, lags l <= p: two short tables."""
    nf = 2 * (n - 1)
    base = np.exp(1j * np.pi * np.arange(nf) / (n - 1))
    k = np.arange(n)
    lo = base[np.multiply.outer(k, np.arange(8)) % nf]
    hi = base[np.multiply.outer(k, np.arange(0, p + 8, 8)) % nf]
    e = (hi[:, :, None] * lo[:, None, :]).reshape(n, -1)[:, : p + 1]
    return np.ascontiguousarray(e.real), np.ascontiguousarray(e.imag)


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--max-order", type=int, default=50)
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args()
    top, rep = args.max_order, args.repeat
    freq, h, _ = make_arrays(2)
    data = ema_data(freq, h)
    with blas_threads(1):
        ps, chains, solves = _record(data, top)
        print(f"two-reference pLSCF of bench_plscf.py, even orders 2..{top}, BLAS 1 thread, CPU ms, "
              f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
        unstable = ps.pole.real >= 0
        print(f"\n1. PoleSet: {len(ps)} poles, {int(unstable.sum())} unstable ({unstable.mean():.0%}; "
              f"order {top}: {int(unstable[ps.order == top].sum())} of {int((ps.order == top).sum())})")

        if chains:
            coefs, start = chains[0]
            ref = _roots.aberth_chain(coefs, start)
            print(f"\n2. chain of degrees {coefs[0].size - 1}-{coefs[-1].size - 1} ({len(coefs)} polynomials), "
                  f"paired alternating replays ({rep}): min / median ms")
            print(f"{'rule':>6} {'library':>13} {'early':>13} {'root-sweeps':>12} {'sweeps':>7} "
                  f"{'stable err':>10} {'unstable err':>12} {'outside counts':>14}")
            base = _early_chain(coefs, start, 0.0)  # rule 0: nothing stops early (counts only)
            print(f"{'-':>6} {'':>13} {'':>13} {base[2]:>12} {base[1]:>7}")
            for rule in ("disk", 1e-3, 1e-6):
                t_lib, t_new = [], []
                for _ in range(rep):
                    t_lib.append(_cpu(lambda: _roots.aberth_chain(coefs, start)))
                    t_new.append(_cpu(lambda rule=rule: _early_chain(coefs, start, rule)))
                out, sweeps, root_sweeps = _early_chain(coefs, start, rule)
                e_s = e_u = 0.0
                same = True
                for a, b in zip(ref, out, strict=True):
                    if a is None or b is None:
                        continue
                    d = np.abs(a[:, None] - b[None, :]).min(axis=1) / np.abs(a)
                    e_s = max(e_s, float(d[np.abs(a) < 1].max(initial=0.0)))
                    e_u = max(e_u, float(d[np.abs(a) > 1].max(initial=0.0)))
                    same &= bool(np.sum(np.abs(a) > 1) == np.sum(np.abs(b) > 1))
                print(f"{rule!s:>6} {min(t_lib) * 1e3:6.2f}/{np.median(t_lib) * 1e3:6.2f} "
                      f"{min(t_new) * 1e3:6.2f}/{np.median(t_new) * 1e3:6.2f} {root_sweeps:>12} {sweeps:>7} "
                      f"{e_s:>10.1e} {e_u:>12.1e} {'equal' if same else 'DIFFER':>14}")

        n = freq.size
        x = h.reshape(-1, n)
        c_tab, s_tab = _lag_tables(n, top)
        xr, xi = np.ascontiguousarray(x.real), np.ascontiguousarray(x.imag)
        t = {name: min(_cpu(fn) for _ in range(rep)) * 1e3 for name, fn in (
            ("irfft 2(n-1)", lambda: np.fft.irfft(x, n=2 * (n - 1), axis=-1)),
            ("irfft 8000", lambda: np.fft.irfft(x, n=8000, axis=-1)),
            ("tables", lambda: _lag_tables(n, top)),
            ("real products", lambda: (xr @ c_tab, xi @ s_tab)),
        )}
        print(f"\n3. lag sums of the {x.shape[0]} FRF channels, {n} lines, lags -{top}..{top} (min of {rep}):")
        for name, v in t.items():
            print(f"   {name:<15} {v:6.2f} ms")
        print(f"   direct (tables + products) {t['tables'] + t['real products']:.2f} ms against the FFT's "
              f"{t['irfft 2(n-1)']:.2f} ms")

        size = np.array([m.shape[0] for m, _, _ in solves], dtype=float)
        cost = np.array([min(_cpu(lambda s=s: _plscf._solve_order(*s)) for _ in range(rep)) for s in solves]) * 1e3
        slope, fixed = np.polyfit(size**3, cost, 1)
        print(f"\n4. _solve_order, {len(solves)} orders (matrix size {int(size[0])}-{int(size[-1])}): "
              f"{cost.sum():.2f} ms; fit {fixed * 1e3:.1f} us per call + {slope * 1e9:.2f} ns x c^3: "
              f"{fixed * len(solves):.2f} ms fixed")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
