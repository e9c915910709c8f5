"""Benchmark: the default ``identify`` of ufffiles_frf (one FRF, ~40 modes 0-800 Hz) in several trees.

For each tree a fresh process (``PYTHONPATH`` and working directory that tree) reads
``../shared/uff-corpus/ufffiles_frf.unv``, warms up on 50-150 Hz (imports, first calls), then
times ``identify(data)`` at the defaults over the whole band: wall and CPU time of the process,
number of modes. Trees alternate in order from one repetition to the next; the load average is
printed before and after each run. Issue 18: the speed of the default ML estimate.

Run: ``python benchmarks/bench_ufffiles_frf.py TREE [TREE ...] [--repeat 1]`` (this tree when none).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

CODE = """
import time, warnings
warnings.simplefilter("ignore")
from ema_rig.identification import identify
from ema_rig.io.uff import read_uff58
d = read_uff58(SHARED + "/uff-corpus/ufffiles_frf.unv")
try:
    identify(d, band=(50.0, 150.0))
except Exception:
    pass
t, c = time.perf_counter(), time.process_time()
r = identify(d)
print(f"{time.perf_counter() - t:.2f} {time.process_time() - c:.2f} {len(r.natural_freq)}")
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("trees", nargs="*", type=Path)
    ap.add_argument("--repeat", type=int, default=1)
    args = ap.parse_args()
    shared = Path(os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared"))
    if not (shared / "uff-corpus" / "ufffiles_frf.unv").is_file():
        raise SystemExit(f"no {shared}/uff-corpus/ufffiles_frf.unv (set EMA_RIG_SHARED)")
    trees = [t.resolve() for t in args.trees] or [REPO]
    print(f"# {time.strftime('%Y-%m-%dT%H:%MZ', time.gmtime())}: ufffiles_frf, identify at the defaults, "
          f"{os.cpu_count()} cores")
    for rep in range(args.repeat):
        for tree in trees if rep % 2 == 0 else trees[::-1]:
            commit = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"], capture_output=True,
                                    text=True).stdout.strip() or "?"
            load0 = os.getloadavg()[0]
            out = subprocess.run([sys.executable, "-c", f"SHARED = {str(shared)!r}\n" + CODE], cwd=tree,
                                 env=dict(os.environ, PYTHONPATH=str(tree)), capture_output=True, text=True)
            if out.returncode:
                print(f"{tree} @ {commit}: failed: {out.stderr.strip().splitlines()[-1:]}")
                continue
            wall, cpu, n = out.stdout.split()
            print(f"{str(tree):28s} @ {commit:8s} wall {float(wall):7.2f} s  CPU {float(cpu):7.2f} s  modes {n:>3s}  "
                  f"load {load0:.1f} -> {os.getloadavg()[0]:.1f}", flush=True)


if __name__ == "__main__":
    main()
