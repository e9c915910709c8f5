"""Benchmark: the campaign figures of the bundled demo drawn by this process alone or shared with an idle pool, paired.

The end of a ``--jobs 2`` campaign: every measurement is done and the pool idle; this process
draws the campaign figures (6 in the demo) and writes the report. Each run is a fresh interpreter
that takes the demo's rows from a results folder computed once beforehand (no identification in
the timed part), sets the per-measurement figures off (only the campaign figures and the report
are written), does the pool's warm-up (:func:`ema_rig.plot._render.warm_up`), forks a pool of two
workers, and times ``write_outputs`` into a fresh folder: with the pool (``shared``: a worker
draws every other figure) or without it (``alone``). Reported per run: the wall time of
``write_outputs`` and the CPU time it took in this process and in the pool's workers; the two
settings alternate. Medians at the end.

Run from the repository root::

    python benchmarks/bench_campaign_figures_pool.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_CHILD = r"""
import dataclasses, json, os, resource, sys, time
from ema_rig.campaign import run
from ema_rig.campaign.runner import make_pool
from ema_rig.campaign.drilldown import DPI
from ema_rig.campaign.outputs import write_outputs
from ema_rig.plot._render import warm_up
cached, out, setting = sys.argv[1], sys.argv[2], sys.argv[3]
result = run("data/campaign.toml", out_dir=cached, jobs=1, report=False)  # rows from the folder
assert result.computed == 0, result.computed
result = dataclasses.replace(result, config=dataclasses.replace(result.config, measurement_figures=False))
warm_up(DPI)
pool = make_pool(2)
pool.submit(int).result()  # the workers forked and idle, as at the end of a campaign
def cpu(who):
    r = resource.getrusage(who)
    return r.ru_utime + r.ru_stime
c0, k0, t0 = cpu(resource.RUSAGE_SELF), cpu(resource.RUSAGE_CHILDREN), time.perf_counter()
write_outputs(result, out, executor=pool if setting == "shared" else None)
wall, mine = time.perf_counter() - t0, cpu(resource.RUSAGE_SELF) - c0
pool.shutdown()
print(json.dumps({"wall": wall, "cpu_self": mine, "cpu_workers": cpu(resource.RUSAGE_CHILDREN) - k0}))
"""


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="pairs (default 3)")
    args = ap.parse_args()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1"}
    runs: dict[str, list[dict[str, float]]] = {"alone": [], "shared": []}
    with tempfile.TemporaryDirectory() as tmp:
        cached = Path(tmp) / "cached"
        subprocess.run([sys.executable, "-c", "from ema_rig.campaign import run; "
                        f"run('data/campaign.toml', out_dir={str(cached)!r}, jobs=2, report=False)"],
                       cwd=ROOT, env=env, check=True, capture_output=True)
        print(f"bundled demo's campaign figures + report, pool of 2 idle; load {os.getloadavg()[0]:.1f}")
        for r in range(args.rounds):
            for setting in (("alone", "shared") if r % 2 == 0 else ("shared", "alone")):
                out = Path(tmp) / f"out{r}{setting}"
                p = subprocess.run([sys.executable, "-c", _CHILD, str(cached), str(out), setting], cwd=ROOT, env=env,
                                   check=True, capture_output=True, text=True)
                d = json.loads(p.stdout.strip().splitlines()[-1])
                runs[setting].append(d)
                print(f"  round {r + 1} {setting:6s}: wall {d['wall']:.2f} s, CPU this process {d['cpu_self']:.2f} s, "
                      f"workers {d['cpu_workers']:.2f} s, load {os.getloadavg()[0]:.1f}")
    for s, ds in runs.items():
        print(f"{s:6s} median: wall {statistics.median(d['wall'] for d in ds):.2f} s, CPU "
              f"{statistics.median(d['cpu_self'] + d['cpu_workers'] for d in ds):.2f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
