"""Benchmark: the local ML stage of the default ``identify`` alone, this tree against another tree.

The whole ``identify`` on a loaded machine varies by more than the ML stage's share of it; this
times the stage itself. Two long-lived worker processes, one per tree (``PYTHONPATH`` pointing at
each, one BLAS thread), each run ``identify`` once per data set and keep what its ML stage was
given (the data cut to the band, the LSFD start model and its synthesis), then time
``_local_ml_staged(...)`` with its ``finish()`` on request, all in the calling thread
(``second_thread=False``: the same work, no thread hand-off in the CPU time). The parent asks the
workers in alternating order (A B, B A, ...). Each worker also prints a digest of its results (poles,
standard uncertainties) so that a run shows both trees estimated the same.

Data: the 256-output synthetic file of ``bench_refine.py`` (100-1000 Hz) and the bundled rig file
(150-1000 Hz).

Run: ``python benchmarks/bench_ml_stage.py --baseline /tmp/base [--repeat 9] [--cases 256,rig]``
(the baseline a checkout with the same staged ML, e.g. ``git worktree add /tmp/base 06ee910``).
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

from _timing import ask_worker, git_head  # benchmarks/_timing.py, beside this script

REPO = Path(__file__).resolve().parent.parent

WORKER = r"""
import sys, time, warnings
warnings.simplefilter("ignore")
import numpy as np
import ema_rig.identification.identification as idn
from ema_rig.config import load_rig
from ema_rig.identification import identify
from ema_rig.io.uff import read_uff58
repo, synth = sys.argv[1], sys.argv[2]
got = []
inner = idn._local_ml_staged
def keep(data, model, syn=None, **kw):
    if kw.get("second_thread", True):
        got.append((data, model, None if syn is None else syn.copy()))
    return inner(data, model, syn, **kw)
idn._local_ml_staged = keep
cases = {}
for name, d, b in (("rig", read_uff58(repo + "/data/b6302_1000N_1200rpm.uff", rig=load_rig(repo + "/data/rig.toml")),
                    (150.0, 1000.0)), ("256", read_uff58(synth), (100.0, 1000.0))):
    got.clear()
    identify(d, band=b)
    cases[name] = list(got)
idn._local_ml_staged = inner
import ema_rig
print("ready", ema_rig.__file__, flush=True)
for line in sys.stdin:
    name = line.strip()
    if name.startswith("digest "):
        out = [inner(*c, second_thread=False).finish() for c in cases[name[7:]]]
        print(" ".join(f"{v:.15e}" for r in out for v in (*np.abs(r.poles), *r.natural_freq_std, *r.damping_ratio_std)),
              flush=True)
        continue
    t0, c0 = time.perf_counter(), time.process_time()
    for c in cases[name]:
        inner(*c, second_thread=False).finish()
    print(f"{time.perf_counter() - t0:.6f} {time.process_time() - c0:.6f}", flush=True)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", required=True, type=Path)
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--cases", default="256,rig", help="comma-separated subset of 256,rig")
    args = ap.parse_args()
    one = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    with tempfile.TemporaryDirectory() as tmp:
        synth = Path(tmp) / "synthetic_256.uff"
        subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, sys.argv[1]); "
                        "from bench_refine import synthetic_256; from pathlib import Path; "
                        "synthetic_256(Path(sys.argv[2]))", str(REPO / "benchmarks"), str(synth)],
                       env=dict(os.environ, PYTHONPATH=str(REPO)), check=True)
        procs = {}
        for tag, tree in (("new", REPO), ("old", args.baseline.resolve())):
            # cwd=tree: ``python -c`` puts the working directory first on sys.path, before PYTHONPATH
            procs[tag] = subprocess.Popen([sys.executable, "-c", WORKER, str(tree), str(synth)], text=True,
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE, cwd=str(tree),
                                          env=dict(os.environ, PYTHONPATH=str(tree), **one))
        for tag, p in procs.items():
            assert p.stdout is not None
            ready, where = p.stdout.readline().split()
            tree = REPO if tag == "new" else args.baseline.resolve()
            assert ready == "ready" and Path(where).resolve().is_relative_to(tree), (tag, where)
        print(f"# {time.strftime('%Y-%m-%dT%H:%MZ', time.gmtime())}: new = {REPO} @ {git_head(REPO)}, "
              f"old = {args.baseline} @ {git_head(args.baseline)}; {os.cpu_count()} cores; one BLAS thread; "
              f"load average at start {os.getloadavg()[0]:.1f}")
        print(f"{'ML stage of':24s} {'':5s} {'old [s]':>22s} {'new [s]':>22s} {'new/old':>18s}  same estimates")
        for case in args.cases.split(","):
            digests = []
            for tag in ("old", "new"):
                p = procs[tag]
                assert p.stdin is not None and p.stdout is not None
                p.stdin.write(f"digest {case}\n")
                p.stdin.flush()
                digests.append([float(v) for v in p.stdout.readline().split()])
            a, b = digests
            worst = max((abs(x - y) / abs(x) for x, y in zip(a, b, strict=True) if x != 0), default=0.0)
            t: dict[str, list[tuple[float, float]]] = {"old": [], "new": []}
            for i in range(args.repeat):
                for tag in (("old", "new") if i % 2 == 0 else ("new", "old")):
                    t[tag].append(ask_worker(procs[tag], case))

            def fmt(x: list[float], f: str = ".3f") -> str:
                return f"{statistics.median(x):{f}} ({min(x):{f}}-{max(x):{f}})"

            for k, kind in ((0, "wall"), (1, "cpu")):
                old = [x[k] for x in t["old"]]
                new = [x[k] for x in t["new"]]
                ratio = [n / o for o, n in zip(old, new, strict=True)]
                print(f"{case:24s} {kind:5s} {fmt(old):>22s} {fmt(new):>22s} {fmt(ratio, '.2f'):>18s}  "
                      f"worst relative change of |pole|, sigma_f, sigma_zeta {worst:.1e}  "
                      f"(load average now {os.getloadavg()[0]:.1f})", flush=True)
        for p in procs.values():
            assert p.stdin is not None
            p.stdin.close()
            p.wait()


if __name__ == "__main__":
    main()
