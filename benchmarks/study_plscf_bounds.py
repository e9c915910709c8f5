"""Study: how far the pLSCF points of issue 22 can go with the root finders as they are.

On the data and calls of ``bench_plscf.py`` (8 outputs x 4000 lines, every even order 2..N, BLAS
limited to one thread, CPU time ``time.process_time``, the fastest of ``--repeat`` calls of each
part, the parts of one row timed alternately in the same minutes):

1. **Speed against sdypy-EMA.** The root-finding calls of one ``plscf`` call are recorded (the
   companion matrix of every order below the Aberth degrees, the batched Aberth chain above) and
   replayed alone: the LAPACK ``dgeev`` calls on the same companion matrices (nothing but the
   QR iteration LAPACK does), and the chain. ``sdypy / roots`` is the ratio ``plscf`` would reach
   if everything but these root finders (lag sums, solves, polish, bookkeeping) cost nothing.
2. **The root step against its floor** (``bench_plscf.py``'s definition: ONE evaluation of p and
   p' at the final roots of every order, per order). An Aberth iteration that certifies its roots,
   started from the previous order's roots (most ~4e-3 to 3e-2 away, relative), needs two
   corrections (cubic convergence takes ~4e-3 to ~1e-7, not yet rounding level, then below it)
   and one more evaluation that certifies the result: three evaluation passes, i.e. three floors,
   before any repulsion sum. With the second correction reusing the first one's sums (as the
   ``_STALE`` rule does), at least one repulsion pass (``sum_j 1 / (z_i - z_j)`` at every root of
   every order of the chain) is added: ``3 + rep / eval`` is a lower limit of the chain's step /
   floor, whatever the implementation of the sweeps (the chain can take a new order's first sums
   from the order below, so the limit without any repulsion pass, 3.0, is the absolute one).
   ``whole step`` is the limit of the whole root step / floor of ``bench_plscf.py``: the orders
   below the chain at their ``dgeev`` time (``eval eig`` their floor), the chain at ``3 eval + rep``.

Run: ``python benchmarks/study_plscf_bounds.py [--repeat 7]``.
"""

from __future__ import annotations

import argparse
import importlib
import os
import time
from collections.abc import Callable
from typing import Any

import bench_plscf as bp  # beside this script: its data, calls and BLAS limit
import numpy as np


def fastest(fns: dict[str, Callable[[], Any]], repeat: int) -> dict[str, float]:
    """The fastest CPU time [s] of each callable over ``repeat`` rounds, the callables alternating."""
    best = dict.fromkeys(fns, float("inf"))
    names = list(fns)
    for i in range(repeat):
        for name in names if i % 2 == 0 else names[::-1]:
            t0 = time.process_time()
            fns[name]()
            best[name] = min(best[name], time.process_time() - t0)
    return best


def record_roots(data: Any, max_order: int) -> tuple[list[np.ndarray], list[tuple[np.ndarray, np.ndarray]],
                                                     list[tuple[list[np.ndarray], np.ndarray]]]:
    """(companion matrices rooted by ``dgeev``, their (det coefficients, roots), chains (coefficients,
    start)) of one ``plscf`` call."""
    mod = importlib.import_module("ema_rig.identification.plscf")
    comps: list[np.ndarray] = []
    eig_roots: list[tuple[np.ndarray, np.ndarray]] = []
    chains: list[tuple[list[np.ndarray], np.ndarray]] = []
    eig0, chain0 = mod._roots_eig, mod.aberth_chain

    def rec_eig(low: np.ndarray) -> Any:
        comps.append(mod._companion(low[::-1]))
        z = eig0(low)
        eig_roots.append((mod.det_coefficients(low), z))
        return z

    def rec_chain(coefs: list[np.ndarray], start: np.ndarray, **kw: Any) -> Any:
        chains.append((coefs, start))
        return chain0(coefs, start, **kw)

    mod._roots_eig, mod.aberth_chain = rec_eig, rec_chain
    try:
        bp.call_ema(data, max_order, even=True)
    finally:
        mod._roots_eig, mod.aberth_chain = eig0, chain0
    return comps, eig_roots, chains


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    from scipy.linalg.lapack import dgeev

    from ema_rig.identification._roots import _ratio, _repulsion, aberth_chain

    bp.import_sdypy()
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average {os.getloadavg()[0]:.1f}, "
          f"BLAS 1 thread, CPU ms, fastest of {args.repeat} alternating rounds")
    print(f"{'refs':>4} {'N':>4} | {'plscf':>7} {'sdypy':>7} {'ratio':>6} | {'dgeev':>7} {'chain':>7} {'roots':>7} "
          f"{'sdypy/roots':>11} | {'eval eig':>8} {'eval':>6} {'rep':>6} {'3+rep/eval':>10} {'whole step':>10}")
    with bp.blas_threads(1):
        for n_in, mo in ((1, 50), (1, 100), (1, 200), (2, 50), (2, 100)):
            freq, h, _ = bp.make_arrays(n_in)
            data = bp.ema_data(freq, h)
            h1 = h.reshape(-1, freq.size)  # two references: the 16 FRFs stacked as one reference
            comps, eig_roots, chains = record_roots(data, mo)
            finals = [aberth_chain(c, s) for c, s in chains]

            def eig_all(comps: list[np.ndarray] = comps) -> None:
                for c in comps:
                    dgeev(c, compute_vl=0, compute_vr=0, overwrite_a=0)

            def chain_all(chains: list[tuple[list[np.ndarray], np.ndarray]] = chains) -> None:
                for c, s in chains:
                    aberth_chain(c, s)

            def one_eval(pairs: list[tuple[np.ndarray, np.ndarray]]) -> None:
                for c, z in pairs:  # as bench_plscf.py's floor
                    j = np.arange(1, c.size)
                    cr = c[::-1].copy()
                    _ratio(c, c[1:] * j, cr, cr[1:] * j, z)

            chain_pairs = [(c, z) for (coefs, _), found in zip(chains, finals, strict=True)
                           for c, z in zip(coefs, found, strict=True)]

            def rep_pass(finals: list[Any] = finals) -> None:
                for found in finals:
                    for z in found:
                        _repulsion(z, np.arange(z.size), z)

            t = fastest({"plscf": lambda d=data, m=mo: bp.call_ema(d, m, even=True),
                         "sdypy": lambda f=freq, x=h1, m=mo: bp.call_sdypy(f, x, m),
                         "dgeev": eig_all, "chain": chain_all, "eval": lambda p=chain_pairs: one_eval(p),
                         "eval_eig": lambda p=eig_roots: one_eval(p), "rep": rep_pass}, args.repeat)
            roots = t["dgeev"] + t["chain"]
            lim = f"{3 + t['rep'] / t['eval']:10.1f}" if chains else f"{'-':>10}"
            # the whole root step: the companion orders at their dgeev time, the chain at its limit
            whole = (t["dgeev"] + 3 * t["eval"] + t["rep"] * bool(chains)) / (t["eval_eig"] + t["eval"])
            print(f"{n_in:>4} {mo:>4} | {t['plscf'] * 1e3:7.2f} {t['sdypy'] * 1e3:7.2f} {t['sdypy'] / t['plscf']:6.2f} | "
                  f"{t['dgeev'] * 1e3:7.2f} {t['chain'] * 1e3:7.2f} {roots * 1e3:7.2f} {t['sdypy'] / roots:11.2f} | "
                  f"{t['eval_eig'] * 1e3:8.2f} {t['eval'] * 1e3:6.2f} {t['rep'] * 1e3:6.2f} {lim} {whole:10.1f}", flush=True)
    print(f"# load average at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
