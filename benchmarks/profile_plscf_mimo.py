"""Where the two-reference pLSCF time goes: CPU time per stage of ``plscf`` on the bench data.

Data and call as in ``bench_plscf.py``'s two-reference rows (8 outputs x 2 references x 4000
lines, every even order 2..N, BLAS limited to one thread). Each stage function of
``ema_rig.identification.plscf`` is wrapped by a timer for the duration of the run (thread CPU
time, ``time.thread_time``, which a busy shared machine inflates less than wall time); the
fastest of ``--repeat`` calls is listed. Nested stages (the Newton polish and the participation
factors inside the pole assembly) are indented; "other" is the call's time outside the listed
top-level stages.

``--per-order`` adds, for the fastest call at the highest N, the CPU time of the stages that run
once per order (the solve and the root step), as microseconds per order over bands of orders:
where each millisecond of an order goes as the order grows.

``--sweeps`` adds, for the highest N, the batched Aberth chain of that call (``aberth_chain``, recorded
and replayed alone ``--repeat`` times, the fastest kept): per sweep the roots still iterating and the
CPU time until the next sweep's evaluation, and a least-squares line through them: the fixed cost of
a sweep (array calls whatever the number of roots) and the cost per root and sweep. The chain's
time is about ``sweeps x fixed + root-sweeps x per root``: which of the two a change must cut.

``--refs 1`` profiles the one-reference rows of ``bench_plscf.py`` the same way (the per-order
table's orders are then the degrees as well; its "warm_start" row is empty there).

Run: ``python benchmarks/profile_plscf_mimo.py [--repeat N] [--per-order] [--sweeps] [--refs 1|2] [ORDER ...]`` (default 50 100 200).
"""

from __future__ import annotations

import argparse
import collections
import importlib
import sys
import time
from collections.abc import Callable
from typing import Any

import numpy as np
from bench_plscf import blas_threads, call_ema, ema_data, make_arrays  # beside this script

#: (stage, nested) in the order the engine runs them
STAGES = [
    ("check_data", False), ("_lag_sums", False), ("_order_limit", False), ("_reduced_factor", False),
    ("_q_rows", False), ("_add_gram", False), ("_solve_order", False), ("det_coefficients", False),
    ("warm_start", False), ("aberth", False), ("aberth_warm", False), ("aberth_chain", False), ("_roots_eig", False), ("_poles_of_orders", False),
    ("_refine_many", True), ("_participation_many", True),
]

#: stages run once per order, with the model order each call is for (from its arguments; the root
#: finders' give the degree, divided by the references in ``main``)
PER_ORDER: dict[str, Callable[..., int]] = {
    "_solve_order": lambda m, n, n_in: int(n),
    "det_coefficients": lambda alpha: int(alpha.shape[0]) - 1,
    "warm_start": lambda prev, n_roots: int(n_roots),  # the degree: the order times the references
    "aberth": lambda c, z0, **k: int(c.size) - 1,
    "aberth_warm": lambda c, *a, **k: int(c.size) - 1,
    "_roots_eig": lambda low: int(low.shape[0]) - 1,
}
#: the stages whose PER_ORDER value is a degree
BY_DEGREE = {"warm_start", "aberth", "aberth_warm"}
#: bands of orders for the per-order table (degree 2n < 64: companion eigenvalues; above: Aberth)
BANDS = [(2, 30), (32, 50), (52, 100), (102, 150), (152, 200)]


def sweep_table(data: Any, max_order: int, repeat: int) -> None:
    """Per sweep of the batched Aberth chain of ``plscf(data, max_order=max_order)``: roots and CPU time.

    The chain call is recorded during one ``plscf`` call and replayed alone; each sweep is timed from
    its evaluation (``_chain_ratio``) to the next sweep's (the last to the chain's end), thread CPU,
    the fastest of ``repeat`` replays. The line ``time = fixed + per_root x roots`` is fitted by least
    squares over the sweeps.
    """
    mod = importlib.import_module("ema_rig.identification.plscf")
    roots = importlib.import_module("ema_rig.identification._roots")
    calls: list[tuple[list[Any], Any]] = []
    chain0 = mod.aberth_chain

    def record(coefs: list[Any], start: Any) -> Any:
        calls.append((list(coefs), start.copy()))
        return chain0(coefs, start)

    mod.aberth_chain = record
    try:
        call_ema(data, max_order, even=True)
    finally:
        mod.aberth_chain = chain0
    if not calls:
        print(f"\nN={max_order}: no batched chain (every order by companion eigenvalues or one by one)")
        return
    coefs, start = calls[0]
    ratio0 = roots._chain_ratio
    marks: list[tuple[float, int]] = []

    def mark(*a: Any, **k: Any) -> Any:
        marks.append((time.thread_time(), int(a[7].size)))  # a[7]: the roots evaluated in this sweep
        return ratio0(*a, **k)

    best: tuple[float, list[tuple[float, int]], float] | None = None
    roots._chain_ratio = mark
    try:
        for _ in range(repeat):
            marks.clear()
            t0 = time.thread_time()
            roots.aberth_chain(coefs, start)
            t1 = time.thread_time()
            if best is None or t1 - t0 < best[0]:
                best = (t1 - t0, list(marks), t1)
    finally:
        roots._chain_ratio = ratio0
    assert best is not None
    total, m, t_end = best
    active = np.array([a for _, a in m], dtype=float)
    times = np.diff([t for t, _ in m] + [t_end])
    per_root, fixed = np.polyfit(active, times, 1)
    degs = [c.size - 1 for c in coefs]
    print(f"\nbatched chain at N={max_order}: {len(degs)} polynomials of degree {degs[0]}-{degs[-1]}, {active.size} sweeps, "
          f"{int(active.sum())} root-sweeps ({active.sum() / sum(degs):.1f} per root), {total * 1e3:.2f} ms CPU "
          f"(fastest of {repeat} replays)")
    print("sweep   roots    ms")
    for i, (a, t) in enumerate(zip(active, times, strict=True)):
        print(f"{i + 1:>5} {int(a):>7} {t * 1e3:>5.2f}")
    print(f"fit: {fixed * 1e3:.3f} ms fixed per sweep + {per_root * 1e6:.2f} us per root and sweep: "
          f"{active.size * fixed * 1e3:.2f} ms fixed, {active.sum() * per_root * 1e3:.2f} ms per root of the {total * 1e3:.2f} ms")


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("orders", nargs="*", type=int, default=[50, 100, 200])
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--per-order", action="store_true", help="microseconds per order of the per-order stages")
    ap.add_argument("--sweeps", action="store_true", help="per sweep of the batched chain at the highest N: roots, CPU time, fit")
    ap.add_argument("--refs", type=int, choices=(1, 2), default=2, help="references (default 2; 1: bench_plscf's main rows)")
    args = ap.parse_args()
    mod = importlib.import_module("ema_rig.identification.plscf")
    spent: dict[str, float] = collections.defaultdict(float)
    by_order: dict[tuple[str, int], float] = collections.defaultdict(float)

    def timed(name: str, fn: Callable[..., Any]) -> Callable[..., Any]:
        def run(*a: Any, **k: Any) -> Any:
            t0 = time.thread_time()
            try:
                return fn(*a, **k)
            finally:
                dt = time.thread_time() - t0
                spent[name] += dt
                if name in PER_ORDER:
                    o = PER_ORDER[name](*a, **k)
                    by_order[name, o // args.refs if name in BY_DEGREE else o] += dt
        return run

    names = [n for n, _ in STAGES if hasattr(mod, n)]
    originals = {n: getattr(mod, n) for n in names}
    freq, h, _ = make_arrays(args.refs)
    data = ema_data(freq, h)
    print(f"{('one', 'two')[args.refs - 1]}-reference pLSCF, 8 x {args.refs} x {freq.size} lines, even orders 2..N, BLAS 1 thread, "
          f"CPU ms per stage (fastest of {args.repeat} calls), {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
    try:
        for n in names:
            setattr(mod, n, timed(n, originals[n]))
        rows: dict[int, tuple[float, dict[str, float]]] = {}
        per_order: dict[tuple[str, int], float] = {}
        with blas_threads(1):
            call_ema(data, 10, even=True)
            for mo in args.orders:
                best: tuple[float, dict[str, float]] | None = None
                for _ in range(args.repeat):
                    spent.clear()
                    by_order.clear()
                    t0 = time.thread_time()
                    ps = call_ema(data, mo, even=True)
                    total = time.thread_time() - t0
                    if best is None or total < best[0]:
                        best = (total, dict(spent))
                        if mo == max(args.orders):
                            per_order = dict(by_order)
                assert best is not None
                rows[mo] = best
                rows[mo][1]["_aberth_orders"] = float(ps.meta["aberth_orders"])
    finally:
        for n, fn in originals.items():
            setattr(mod, n, fn)
    head = f"{'stage':<22}" + "".join(f"{'N=' + str(mo):>16}" for mo in args.orders)
    print(head)
    print("-" * len(head))
    for n, nested in STAGES:
        if n not in names:
            continue
        label = ("  " if nested else "") + n
        cells = "".join(f"{rows[mo][1].get(n, 0.0) * 1e3:9.2f} {rows[mo][1].get(n, 0.0) / rows[mo][0]:5.0%}" for mo in args.orders)
        print(f"{label:<22}{cells}")
    other = [rows[mo][0] - sum(v for k, v in rows[mo][1].items() if k in names and not dict(STAGES)[k]) for mo in args.orders]
    print(f"{'other':<22}" + "".join(f"{o * 1e3:9.2f} {o / rows[mo][0]:5.0%}" for o, mo in zip(other, args.orders, strict=True)))
    print(f"{'total':<22}" + "".join(f"{rows[mo][0] * 1e3:9.2f} {'':>5}" for mo in args.orders))
    print(f"{'orders by Aberth':<22}" + "".join(f"{int(rows[mo][1]['_aberth_orders']):>9d} {'':>5}" for mo in args.orders))
    print(f"{'solved orders':<22}" + "".join(f"{mo // 2:>9d} {'':>5}" for mo in args.orders))
    if args.per_order:
        top = max(args.orders)
        bands = [(a, min(b, top)) for a, b in BANDS if a <= top]
        print(f"\nper order at N={top}: CPU microseconds per order (mean over the band's even orders; same call)")
        head = f"{'stage':<22}" + "".join(f"{f'{a}-{b}':>12}" for a, b in bands)
        print(head)
        print("-" * len(head))
        for name in PER_ORDER:
            cells = []
            for a, b in bands:
                n_ord = len(range(a, b + 1, 2))
                tot = sum(v for (st, o), v in per_order.items() if st == name and a <= o <= b)
                cells.append(f"{tot / n_ord * 1e6:12.0f}")
            print(f"{name:<22}" + "".join(cells))
        sums = []
        for a, b in bands:
            n_ord = len(range(a, b + 1, 2))
            sums.append(sum(v for (_, o), v in per_order.items() if a <= o <= b) / n_ord * 1e6)
        print(f"{'sum':<22}" + "".join(f"{v:12.0f}" for v in sums))
    if args.sweeps:
        with blas_threads(1):
            sweep_table(data, max(args.orders), args.repeat)
    return 0


if __name__ == "__main__":
    sys.exit(main())
