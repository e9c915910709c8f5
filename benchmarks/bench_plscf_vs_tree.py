"""Benchmark: ``plscf`` of this tree against another tree on the data of ``bench_plscf.py``, paired.

Two long-lived worker processes, one per tree (``PYTHONPATH`` and working directory at each), one
BLAS thread each. Each builds the one- and two-reference data of ``bench_plscf.make_arrays`` once
and, on request, times ``plscf(data, max_order=N, orders=2, 4, .., N)``: wall and CPU time of the
process (``time.process_time``: with one BLAS thread the work of the call, without the time slices
other processes take on a shared machine). The parent asks them in alternating order (A B, B A,
...) so load drifts stay out of the ratio, and compares the two trees' poles of every order as
sets (each pole to its nearest partner; stable and unstable poles apart).

Run: ``python benchmarks/bench_plscf_vs_tree.py --baseline /tmp/old [--repeat 9] [--cases 1:50,2:50,2:40a]`` with the
baseline a checkout of the reference commit (``git archive f95e2e5 | tar -x -C /tmp/old``).
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _timing import ask_worker, close_workers, git_head  # benchmarks/_timing.py, beside this script

REPO = Path(__file__).resolve().parent.parent
CASES = [(1, 50), (1, 100), (1, 200), (2, 50), (2, 100), (2, 200)]

WORKER = r"""
import sys, time
sys.path.insert(0, sys.argv[1])
from bench_plscf import ema_data, make_arrays
import numpy as np
from threadpoolctl import threadpool_limits
import ema_rig
from ema_rig.identification import plscf
data = {n_in: ema_data(*make_arrays(n_in)[:2]) for n_in in (1, 2)}
with threadpool_limits(limits=1, user_api="blas"):
    plscf(data[2], max_order=10)
    print("ready", ema_rig.__file__, flush=True)
    for line in sys.stdin:
        n_in, mo, out = line.split()
        every = mo.endswith("a")  # every order 1..N (the default orders of several references)
        mo = mo.rstrip("a")
        t0, c0 = time.perf_counter(), time.process_time()
        ps = plscf(data[int(n_in)], max_order=int(mo), orders=range(1 if every else 2, int(mo) + 1, 1 if every else 2))
        wall, cpu = time.perf_counter() - t0, time.process_time() - c0
        if out != "-":  # written before the answer: the parent reads it next
            np.savez(out, order=ps.order, pole=ps.pole, fallbacks=ps.meta["fallbacks"])
        print(f"{wall:.6f} {cpu:.6f}", flush=True)
"""


def set_distance(a: dict[str, np.ndarray], b: dict[str, np.ndarray]) -> tuple[float, float, bool]:
    """Largest relative distance of a pole of ``a`` to its nearest pole of ``b`` at the same order
    (stable, unstable), and whether every order has the same number of poles."""
    worst = [0.0, 0.0]
    same = True
    for n in np.unique(a["order"]):
        pa, pb = a["pole"][a["order"] == n], b["pole"][b["order"] == n]
        same &= pa.size == pb.size
        if pa.size and pb.size:
            d = np.abs(pa[:, None] - pb[None, :]).min(axis=1) / np.abs(pa)
            for k, sel in enumerate((pa.real < 0, pa.real >= 0)):
                worst[k] = max(worst[k], float(d[sel].max(initial=0.0)))
    return worst[0], worst[1], bool(same)


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").split("\n")[0])
    ap.add_argument("--baseline", required=True, type=Path)
    ap.add_argument("--repeat", type=int, default=9, help="alternating pairs per case (default 9; 5 at N = 200)")
    ap.add_argument("--cases", default=",".join(f"{a}:{b}" for a, b in CASES),
                    help="references:max order, comma-separated; 'Na': every order 1..N (default all: %(default)s)")
    args = ap.parse_args()
    cases = [(int(a), b) for a, b in (c.split(":") for c in args.cases.split(","))]  # b: "N" or "Na" (every order)
    trees = {"new": REPO, "old": args.baseline.resolve()}
    one = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    procs = {tag: subprocess.Popen([sys.executable, "-c", WORKER, str(REPO / "benchmarks")], text=True,
                                   stdin=subprocess.PIPE, stdout=subprocess.PIPE, cwd=str(tree),
                                   env=dict(os.environ, PYTHONPATH=str(tree), **one))
             for tag, tree in trees.items()}
    for tag, p in procs.items():
        assert p.stdout is not None
        ready, where = p.stdout.readline().split()
        assert ready == "ready" and Path(where).resolve().is_relative_to(trees[tag]), (tag, where)

    def ask(tag: str, n_in: int, mo: str, out: str = "-") -> tuple[float, float]:
        return ask_worker(procs[tag], f"{n_in} {mo} {out}")

    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}: new = {REPO} @ {git_head(REPO)}, "
          f"old = {args.baseline}; {os.cpu_count()} cores, BLAS 1 thread, load average {os.getloadavg()[0]:.1f}")
    print("plscf on bench_plscf.py's data (8 outputs x 4000 lines), even orders 2..N (Na: every order 1..N); median (min-max) of alternating")
    print("calls; new/old per pair; poles: largest relative distance of a new pole to the nearest old one, same order")
    print(f"{'refs':>4} {'N':>4} {'kind':>4} | {'old [ms]':>22} | {'new [ms]':>22} | {'new/old':>18} | poles stable / unstable, counts")
    with tempfile.TemporaryDirectory() as tmp:
        for n_in, mo in cases:
            files = {tag: str(Path(tmp) / f"{tag}.npz") for tag in procs}
            for tag in procs:
                ask(tag, n_in, mo, files[tag])  # untimed: the poles, and caches warm
            pa, pb = (dict(np.load(files[t])) for t in ("new", "old"))
            stable, unstable, same = set_distance(pa, pb)
            t: dict[str, list[tuple[float, float]]] = {"old": [], "new": []}
            for i in range(args.repeat if int(mo.rstrip("a")) < 200 else max(3, args.repeat // 2)):
                for tag in (("old", "new") if i % 2 == 0 else ("new", "old")):
                    t[tag].append(ask(tag, n_in, mo))

            def fmt(x: list[float], scale: float = 1e3, f: str = ".2f") -> str:
                return f"{statistics.median(x) * scale:{f}} ({min(x) * scale:{f}}-{max(x) * scale:{f}})"

            for k, kind in ((1, "cpu"), (0, "wall")):
                old, new = ([x[k] for x in t[tag]] for tag in ("old", "new"))
                ratio = [b / a for a, b in zip(old, new, strict=True)]
                poles = (f"{stable:.1e} / {unstable:.1e}, {'equal' if same else 'DIFFER'}; fallbacks "
                         f"{int(pb['fallbacks'])} -> {int(pa['fallbacks'])}") if k == 1 else ""
                print(f"{n_in:>4} {mo:>4} {kind:>4} | {fmt(old):>22} | {fmt(new):>22} | {fmt(ratio, 1.0):>18} | {poles}",
                      flush=True)
    print(f"# load average at the end {os.getloadavg()[0]:.1f}")
    close_workers(procs.values())


if __name__ == "__main__":
    main()
