"""Benchmark: the default ``identify`` of this tree against another tree (issue 18: ML by default).

Two long-lived worker processes, one per tree (``PYTHONPATH`` pointing at each), each load the
data once and time ``identify(data, band=...)`` at the defaults on request; the parent asks them
in alternating order (A B, B A, ...) so load drifts of the machine stay out of the ratio. Data:

* the bundled rig file ``data/b6302_1000N_1200rpm.uff`` with ``data/rig.toml``, 150-1000 Hz;
* the 256-output synthetic file of ``bench_refine.py`` (8 modes, 1 % proportional noise), 100-1000 Hz;
* with ``--many-modes``, also ``uff-corpus/ufffiles_frf.unv`` of ``$EMA_RIG_SHARED`` (one FRF, 41 modes:
  segments of up to 29 modes on ~1000 lines), 20-780 Hz and the whole file (the local ML's
  evaluations dominate there);
* with ``--split-data``, also ``real-frf/dam0.unv`` of ``$EMA_RIG_SHARED`` (26 outputs, 1-12 Hz: most modes'
  own lines exceed the noise, so ``CompletenessCriteria.split_misfit`` refits each locally) and the
  bundled ``data/disk.uff`` at its default band (0-2000 Hz, 8 outputs: the 789.7 / 801.0 Hz pair).

``--cases rig,dam0`` runs only those (names: rig, 256, band, whole, dam0, disk).

Run: ``python benchmarks/bench_default_ml.py --baseline /tmp/old [--repeat 7] [--one-thread] [--many-modes]
[--split-data] [--cases ...]``
where the baseline is a checkout of the reference commit (``git worktree add /tmp/old 8d99d0c``).
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
from ema_rig.config import load_rig
from ema_rig.identification import identify
from ema_rig.io.uff import read_uff58
repo, synth, shared, real = sys.argv[1], sys.argv[2], sys.argv[3], sys.argv[4]
cases = {"rig": (read_uff58(repo + "/data/b6302_1000N_1200rpm.uff", rig=load_rig(repo + "/data/rig.toml")),
                 (150.0, 1000.0)),
         "256": (read_uff58(synth), (100.0, 1000.0))}
for d, b in cases.values():
    identify(d, band=b)
if shared:
    frf = read_uff58(shared + "/uff-corpus/ufffiles_frf.unv")
    cases["band"], cases["whole"] = (frf, (20.0, 780.0)), (frf, None)
    identify(frf, band=(50.0, 150.0))  # warm-up: a few modes
if real:
    cases["dam0"] = (read_uff58(real + "/real-frf/dam0.unv"), (1.0, 12.0))
    cases["disk"] = (read_uff58(repo + "/data/disk.uff"), None)
    identify(cases["dam0"][0], band=(2.0, 6.0))  # warm-up
import ema_rig
print("ready", ema_rig.__file__, flush=True)
for line in sys.stdin:
    d, b = cases[line.strip()]
    t0, c0 = time.perf_counter(), time.process_time()
    identify(d, band=b)
    print(f"{time.perf_counter() - t0:.6f} {time.process_time() - c0:.6f}", flush=True)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", required=True, type=Path)
    ap.add_argument("--repeat", type=int, default=7)
    ap.add_argument("--one-thread", action="store_true", help="one BLAS thread in both workers")
    ap.add_argument("--many-modes", action="store_true",
                    help="also ufffiles_frf of $EMA_RIG_SHARED (default /work/shared), 20-780 Hz and whole")
    ap.add_argument("--split-data", action="store_true",
                    help="also dam0 of $EMA_RIG_SHARED (default /work/shared) at 1-12 Hz and data/disk.uff")
    ap.add_argument("--cases", default="", help="comma-separated subset: rig,256,band,whole,dam0,disk")
    args = ap.parse_args()
    shared = os.environ.get("EMA_RIG_SHARED", "/work/shared") if args.many_modes else ""
    if shared and not Path(shared, "uff-corpus", "ufffiles_frf.unv").is_file():
        raise SystemExit(f"no {shared}/uff-corpus/ufffiles_frf.unv (set EMA_RIG_SHARED)")
    real = os.environ.get("EMA_RIG_SHARED", "/work/shared") if args.split_data else ""
    if real and not Path(real, "real-frf", "dam0.unv").is_file():
        raise SystemExit(f"no {real}/real-frf/dam0.unv (set EMA_RIG_SHARED)")
    sys.path.insert(0, str(REPO / "benchmarks"))

    with tempfile.TemporaryDirectory() as tmp:
        synth = Path(tmp) / "synthetic_256.uff"
        env = dict(os.environ, PYTHONPATH=str(REPO))
        subprocess.run([sys.executable, "-c", "import sys; sys.path.insert(0, sys.argv[1]); "
                        "from bench_refine import synthetic_256; from pathlib import Path; "
                        "synthetic_256(Path(sys.argv[2]))", str(REPO / "benchmarks"), str(synth)],
                       env=env, check=True)
        procs = {}
        for tag, tree in (("new", REPO), ("old", args.baseline.resolve())):
            # cwd=tree: ``python -c`` puts the working directory first on sys.path, before PYTHONPATH
            # (run from this repository's root, both workers would import this tree)
            procs[tag] = subprocess.Popen([sys.executable, "-c", WORKER, str(REPO), str(synth), shared, real], text=True,
                                          stdin=subprocess.PIPE, stdout=subprocess.PIPE, cwd=str(tree),
                                          env=dict(os.environ, PYTHONPATH=str(tree),
                                                   **({"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
                                                       "MKL_NUM_THREADS": "1"} if args.one_thread else {})))
        for tag, p in procs.items():
            assert p.stdout is not None
            ready, where = p.stdout.readline().split()
            tree = REPO if tag == "new" else args.baseline.resolve()
            assert ready == "ready" and Path(where).resolve().is_relative_to(tree), (tag, where)
            print(f"{tag}: ema_rig from {where}")

        def ask(tag: str, case: str) -> tuple[float, float]:
            return ask_worker(procs[tag], case)

        print(f"# {time.strftime('%Y-%m-%dT%H:%MZ', time.gmtime())}: new = {REPO} @ {git_head(REPO)}, "
              f"old = {args.baseline} @ {git_head(args.baseline)}; {os.cpu_count()} cores")
        print(f"baseline {args.baseline}; BLAS threads: {'1' if args.one_thread else 'default'}; "
              f"OPENBLAS_CORETYPE={os.environ.get('OPENBLAS_CORETYPE', '(default)')}; "
              f"load average at start {os.getloadavg()[0]:.1f}")
        print(f"{'data':28s} {'':5s} {'old identify [s]':>22s} {'new identify [s]':>22s} {'new/old':>18s}")
        names = [("rig", "rig file (8 out, 1701 lines)"), ("256", "256 outputs (1801 lines)")]
        if shared:
            names += [("band", "ufffiles_frf 20-780 Hz"), ("whole", "ufffiles_frf whole file")]
        if real:
            names += [("dam0", "dam0 1-12 Hz (26 out)"), ("disk", "disk.uff 0-2000 Hz (8 out)")]
        if args.cases:
            wanted = args.cases.split(",")
            names = [x for x in names if x[0] in wanted]
        for case, name in names:
            t: dict[str, list[tuple[float, float]]] = {"old": [], "new": []}
            for i in range(args.repeat):
                for tag in (("old", "new") if i % 2 == 0 else ("new", "old")):
                    t[tag].append(ask(tag, case))

            def fmt(x: list[float], f: str = ".3f") -> str:
                return f"{statistics.median(x):{f}} ({min(x):{f}}-{max(x):{f}})"

            # wall time, and the CPU time of the process (all its threads): on a busy machine the
            # wall time mostly measures waiting for a core, the CPU time the work
            for k, kind in ((0, "wall"), (1, "cpu")):
                old = [x[k] for x in t["old"]]
                new = [x[k] for x in t["new"]]
                ratio = [b / a for a, b in zip(old, new, strict=True)]
                print(f"{name:28s} {kind:5s} {fmt(old):>22s} {fmt(new):>22s} {fmt(ratio, '.2f'):>18s}"
                      f"  (load average now {os.getloadavg()[0]:.1f})", flush=True)
        for p in procs.values():
            assert p.stdin is not None
            p.stdin.close()
            p.wait()


if __name__ == "__main__":
    main()
