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

from _timing import ask_worker, close_workers, git_head  # benchmarks/_timing.py, beside this script

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


def _spread(x: list[float], f: str = ".3f") -> str:
    return f"{statistics.median(x):{f}} ({min(x):{f}}-{max(x):{f}})"


def _worker(tree: Path, synth: Path) -> subprocess.Popen[str]:
    """A worker on ``tree`` (its own ``ema_rig``, one BLAS thread), started and ready for requests."""
    one = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    # cwd=tree: ``python -c`` puts the working directory first on sys.path, before PYTHONPATH
    proc = subprocess.Popen([sys.executable, "-c", WORKER, str(tree), str(synth)], text=True, stdin=subprocess.PIPE,
                            stdout=subprocess.PIPE, cwd=str(tree), env=dict(os.environ, PYTHONPATH=str(tree), **one))
    assert proc.stdout is not None
    word, where = proc.stdout.readline().split()
    if word != "ready" or not Path(where).resolve().is_relative_to(tree):
        raise SystemExit(f"the worker on {tree} imported ema_rig from {where}")
    return proc


def _digest(proc: subprocess.Popen[str], case: str) -> list[float]:
    assert proc.stdin is not None and proc.stdout is not None
    proc.stdin.write(f"digest {case}\n")
    proc.stdin.flush()
    return [float(v) for v in proc.stdout.readline().split()]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", required=True, type=Path)
    ap.add_argument("--repeat", type=int, default=9)
    ap.add_argument("--cases", default="256,rig", help="comma-separated subset of 256,rig")
    args = ap.parse_args()
    sys.path.insert(0, str(REPO))  # the synthetic file written by this tree's ema_rig
    from bench_refine import synthetic_256  # benchmarks/bench_refine.py, beside this script

    with tempfile.TemporaryDirectory() as tmp:
        synth = Path(tmp) / "synthetic_256.uff"
        synthetic_256(synth)
        new, old = _worker(REPO, synth), _worker(args.baseline.resolve(), synth)
        print(f"# {time.strftime('%Y-%m-%dT%H:%MZ', time.gmtime())}: new = {REPO} @ {git_head(REPO)}, "
              f"old = {args.baseline} @ {git_head(args.baseline)}; {os.cpu_count()} cores; one BLAS thread; "
              f"load average at start {os.getloadavg()[0]:.1f}")
        print(f"{'ML stage of':10s} {'':5s} {'old [s]':>22s} {'new [s]':>22s} {'new/old':>18s}")
        for case in args.cases.split(","):
            pairs = zip(_digest(old, case), _digest(new, case), strict=True)
            worst = max((abs(x - y) / abs(x) for x, y in pairs if x != 0), default=0.0)
            times: list[tuple[tuple[float, float], tuple[float, float]]] = []
            for i in range(args.repeat):
                if i % 2 == 0:
                    t_old = ask_worker(old, case)
                    times.append((t_old, ask_worker(new, case)))
                else:
                    t_new = ask_worker(new, case)
                    times.append((ask_worker(old, case), t_new))
            for k, kind in enumerate(("wall", "cpu")):
                o, n = [x[0][k] for x in times], [x[1][k] for x in times]
                print(f"{case:10s} {kind:5s} {_spread(o):>22s} {_spread(n):>22s} "
                      f"{_spread([b / a for a, b in zip(o, n, strict=True)], '.2f'):>18s}  "
                      f"(load average now {os.getloadavg()[0]:.1f})", flush=True)
            print(f"{case:10s} the two trees' |pole|, sigma_f, sigma_zeta differ by at most {worst:.1e} relative")
        close_workers([new, old])


if __name__ == "__main__":
    main()
