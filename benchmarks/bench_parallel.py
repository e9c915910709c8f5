"""Campaign parallelism end to end: ``ema-rig campaign --jobs 1`` against ``--jobs 2``, paired.

Run from the repository root::

    python benchmarks/bench_parallel.py [--pairs 5] [--tree OTHER_SOURCE_TREE ...] [--dask]

Each round runs the command line (a fresh interpreter: start-up, imports, calibration, the
measurements, table, figures and report, with ``--force``) once per configuration, in an order
that alternates between rounds (A B, B A, ...), so a change of machine load hits both alike. For
each configuration: the median wall time with its min-max, and the CPU time of the processes
(user + system, children included); then the ratio ``--jobs 1 / --jobs 2`` of each round, as a
median with its min-max. The load average is printed before and after: on a busy machine the
ratios spread and the medians mean less.

``--tree`` adds source trees (e.g. an older checkout, ``git archive <commit> | tar -x -C DIR``)
run through ``PYTHONPATH`` in the same rounds, so a before/after comparison is paired too.
``--dask`` adds the campaign through a ``dask.distributed.LocalCluster`` (2 worker processes, 1
thread each, cluster start-up included) to the rounds.

``--cpu-path`` estimates instead what the wall times would be on an idle machine, from CPU times,
which another session's load changes far less than wall times (Linux shares the cores between
sessions, so on a busy machine a second worker process of one session gains little wall time):
each phase's CPU time is measured (import, calibration, every measurement, the outputs; with
``--jobs 2`` also the output process's preload beside the calibration) and the critical path is
``import + max(calibration, preload) + LPT schedule of the measurements on 2 workers + outputs``,
where the outputs phase, when the pool draws the per-measurement figures, is the larger of their
LPT schedule and (this process's outputs + the figures) / 2; against the sum of all of them for
``--jobs 1``.
"""

from __future__ import annotations

import argparse
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGN = ROOT / "data" / "campaign.toml"

_DASK = """
import sys
from distributed import Client, LocalCluster
from ema_rig.campaign import run
with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0") as cl, Client(cl) as c:
    res = run(sys.argv[1], out_dir=sys.argv[2], executor=c.get_executor(), force=True)
sys.exit(0 if res.n_failed == 0 else 3)
"""


_CPU_PATH = """
import json, sys, time
C = time.process_time
c0 = C()
import ema_rig.campaign.runner as R
import ema_rig.campaign.outputs as O
rec = {"import": C() - c0}
log = sys.argv[2] + ".tasks"

def pm(t, _orig=R.process_measurement):
    c = C(); r = _orig(t)
    with open(log, "a") as fh:
        fh.write(json.dumps([t.kind, C() - c]) + "\\n")
    return r

def wo(result, out, _orig=O.write_outputs, **kw):
    c = C(); files = _orig(result, out, **kw)
    with open(log, "a") as fh:
        fh.write(json.dumps(["outputs", C() - c]) + "\\n")
    return files

R.process_measurement, O.write_outputs = pm, wo
try:
    import ema_rig.campaign.drilldown as D

    def mf(*a, _orig=D.measurement_figures, **kw):
        c = C(); r = _orig(*a, **kw)
        with open(log, "a") as fh:
            fh.write(json.dumps(["drill", C() - c]) + "\\n")
        return r

    D.measurement_figures = mf
except ImportError:  # a tree without the per-measurement figures
    pass
if hasattr(R, "_preload_outputs"):
    def pl(_orig=R._preload_outputs):
        c = C(); _orig()
        with open(log, "a") as fh:
            fh.write(json.dumps(["preload", C() - c]) + "\\n")
    R._preload_outputs = pl
R.run(sys.argv[1], out_dir=sys.argv[2], jobs=int(sys.argv[3]), force=True)
tasks = [json.loads(line) for line in open(log)]
rec["tasks"] = tasks
print(json.dumps(rec))
"""


def _lpt(times: list[float], workers: int) -> float:
    """Makespan of the longest-first schedule of ``times`` on ``workers``."""
    load = [0.0] * workers
    for t in sorted(times, reverse=True):
        load[load.index(min(load))] += t
    return max(load)


def _cpu_path(tree: Path, campaign: str, jobs: int, out: Path) -> float:
    """The CPU-time critical path of one run (see the module docstring)."""
    import json

    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    proc = subprocess.run([sys.executable, "-c", _CPU_PATH, campaign, str(out), str(jobs)], env=env,
                          capture_output=True, text=True, cwd=tree)
    if proc.returncode != 0:
        raise SystemExit(f"cpu path run failed:\n{proc.stderr[-2000:]}")
    rec = json.loads(proc.stdout.strip().splitlines()[-1])
    by: dict[str, list[float]] = {}
    for kind, seconds in rec["tasks"]:
        by.setdefault(kind, []).append(seconds)
    calib, outputs = sum(by.get("calibration", [])), sum(by.get("outputs", []))
    meas, drill = by.get("measurement", []), by.get("drill", [])
    if jobs == 1:  # everything in one process (the outputs include the per-measurement figures)
        return rec["import"] + calib + sum(meas) + outputs + sum(by.get("preload", []))
    if _drawn_in_parent(outputs, drill):
        out_phase = outputs
    else:  # the pool draws the per-measurement figures while this process draws the rest
        out_phase = max(_lpt(drill, jobs), (outputs + sum(drill)) / jobs, outputs)
    return rec["import"] + max(calib, sum(by.get("preload", []))) + _lpt(meas, jobs) + out_phase


def _drawn_in_parent(outputs: float, drill: list[float]) -> bool:
    """Whether the per-measurement figures' CPU time is inside the parent's outputs time (older trees)."""
    return bool(drill) and outputs >= 0.9 * sum(drill)


def _once(tree: Path, argv: list[str], out: Path) -> tuple[float, float]:
    """Wall and CPU seconds (children included) of one command in a fresh interpreter."""
    env = {**os.environ, "PYTHONPATH": str(tree), "MPLBACKEND": "Agg"}
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    # run in the tree: `python -m` and `-c` put the working directory first on sys.path
    proc = subprocess.run([sys.executable, *argv, str(out)], env=env, capture_output=True, text=True, cwd=tree)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    if proc.returncode not in (0,):
        raise SystemExit(f"{argv} failed ({proc.returncode}):\n{proc.stderr[-2000:]}")
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    return wall, cpu


def _fmt(xs: list[float]) -> str:
    return f"{statistics.median(xs):6.2f} ({min(xs):.2f}-{max(xs):.2f})"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=5, help="rounds (default 5)")
    ap.add_argument("--campaign", default=str(CAMPAIGN), type=lambda p: str(Path(p).resolve()))
    ap.add_argument("--tree", action="append", default=[], help="another source tree to compare")
    ap.add_argument("--dask", action="store_true", help="also run through a 2-process LocalCluster")
    ap.add_argument("--cpu-path", action="store_true", help="critical path from CPU times instead")
    args = ap.parse_args()
    if args.cpu_path:
        _main_cpu_path(args)
        return

    trees = [("this", ROOT)] + [(Path(t).name, Path(t).resolve()) for t in args.tree]
    configs: list[tuple[str, Path, list[str]]] = []
    for name, tree in trees:
        for jobs in (1, 2):
            cli = ["-m", "ema_rig.cli", "campaign", args.campaign, "--jobs", str(jobs), "--force", "-o"]
            configs.append((f"{name} --jobs {jobs}", tree, cli))
    if args.dask:
        configs.append(("this dask 2 procs", ROOT, ["-c", _DASK, args.campaign]))

    print(f"campaign {args.campaign}, {os.cpu_count()} cores, load average before "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    wall: dict[str, list[float]] = {c[0]: [] for c in configs}
    cpu: dict[str, list[float]] = {c[0]: [] for c in configs}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.pairs):
            order = configs if r % 2 == 0 else configs[::-1]
            for label, tree, argv in order:
                # a fresh folder each time: a folder from a previous round would reuse its figures
                w, c = _once(tree, argv, Path(tmp) / f"{label.replace(' ', '_')}_{r}")
                wall[label].append(w)
                cpu[label].append(c)
    print(f"load average after {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'configuration':<24} {'wall s, median (min-max)':>26} {'CPU s, median (min-max)':>26}")
    for label, _, _ in configs:
        print(f"{label:<24} {_fmt(wall[label]):>26} {_fmt(cpu[label]):>26}")
    for name, _ in trees:
        ratios = [a / b for a, b in zip(wall[f"{name} --jobs 1"], wall[f"{name} --jobs 2"], strict=True)]
        print(f"{name}: --jobs 1 / --jobs 2 per round: {_fmt(ratios)}  (goal >= 1.7)")
    if args.dask:
        ratios = [a / b for a, b in zip(wall["this --jobs 1"], wall["this dask 2 procs"], strict=True)]
        print(f"this: --jobs 1 / dask 2 processes per round: {_fmt(ratios)}")


def _main_cpu_path(args: argparse.Namespace) -> None:
    trees = [("this", ROOT)] + [(Path(t).name, Path(t).resolve()) for t in args.tree]
    print(f"campaign {args.campaign}: critical path from CPU times, {args.pairs} rounds, load average "
          f"before {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    est: dict[tuple[str, int], list[float]] = {(n, j): [] for n, _ in trees for j in (1, 2)}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.pairs):
            for name, tree in trees if r % 2 == 0 else trees[::-1]:
                for jobs in (1, 2) if r % 2 == 0 else (2, 1):
                    out = Path(tmp) / f"{name}_{jobs}_{r}"
                    est[name, jobs].append(_cpu_path(tree, args.campaign, jobs, out))
    print(f"load average after {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    for name, _ in trees:
        ratios = [a / b for a, b in zip(est[name, 1], est[name, 2], strict=True)]
        print(f"{name:<10} --jobs 1 {_fmt(est[name, 1])} s  --jobs 2 {_fmt(est[name, 2])} s  "
              f"ratio per round {_fmt(ratios)}  (goal >= 1.7)")


if __name__ == "__main__":
    main()
