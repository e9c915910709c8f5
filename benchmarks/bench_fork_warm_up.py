"""Benchmark: a pool's figure warm-up done once before the fork against once per worker, paired.

What ``--jobs 2`` pays for the figures' one-time work (matplotlib's imports, the mathtext grammar,
font lookups; :func:`ema_rig.plot._render.warm_up`). Each run is a fresh interpreter that, like the
campaign runner, first identifies one bundled measurement itself (the calibration's place: the
numerical stack imported and warm), then either calls ``warm_up`` (``warm``) or not (``cold``),
forks a pool of two workers that each compute the measurement and draw its three report figures,
and finally imports what its own campaign figures need. CPU seconds of the figure side: the
parent's warm-up, each worker's figures (``process_time`` in the worker) and the parent's later
imports. The two settings alternate (cold warm, warm cold, ...). Reported: each run and the medians.

Run from the repository root::

    python benchmarks/bench_fork_warm_up.py [--rounds 3]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

_CHILD = r"""
import json, sys, time
from concurrent.futures import ProcessPoolExecutor
from ema_rig.campaign import MeasurementTask, drilldown, load_campaign, runner
warm = sys.argv[1] == "warm"
cfg = load_campaign("data/campaign.toml")
m = cfg.measurements[0]
task = MeasurementTask(kind="measurement", file=m.file, rig=cfg.rig, k_ms=cfg.rig.model.k_MS, k_ms_std=None,
                       speed_hz=m.speed / 60.0 if m.speed > 0 else None, band=cfg.band, max_order=cfg.max_order,
                       selection=None)
def work(task, m, cfg):
    row, comp = runner._process(task)
    c = time.process_time()
    drilldown.measurement_figures(m, row, cfg, k_ms=cfg.rig.model.k_MS, k_ms_std=None, computed=comp)
    return time.process_time() - c
runner._process(task)  # the calibration's place: the identification imported and warm
c = time.process_time()
if warm:
    from ema_rig.plot._render import warm_up
    warm_up(drilldown.DPI)
parent_warm = time.process_time() - c
with ProcessPoolExecutor(2) as ex:
    workers = [f.result() for f in [ex.submit(work, task, m, cfg) for _ in range(2)]]
c = time.process_time()
import matplotlib.backends.backend_agg, matplotlib.figure  # the campaign figures' needs
later = time.process_time() - c
print(json.dumps({"parent_warm": parent_warm, "workers": workers, "later": later,
                  "total": parent_warm + sum(workers) + later}))
"""


def one(setting: str) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "MPLBACKEND": "Agg", "OPENBLAS_NUM_THREADS": "1"}
    out = subprocess.run([sys.executable, "-c", _CHILD, setting], cwd=ROOT, env=env, capture_output=True, text=True,
                         check=True)
    doc: dict[str, float] = json.loads(out.stdout.strip().splitlines()[-1])
    return doc


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="pairs (default 3)")
    args = ap.parse_args()
    runs: dict[str, list[float]] = {"cold": [], "warm": []}
    print(f"figure-side CPU [s] of a 2-worker pool, load {os.getloadavg()[0]:.1f}")
    for r in range(args.rounds):
        for setting in (("cold", "warm") if r % 2 == 0 else ("warm", "cold")):
            d = one(setting)
            runs[setting].append(d["total"])
            print(f"  round {r + 1} {setting}: parent warm-up {d['parent_warm']:.2f}, worker figures "
                  f"{d['workers'][0]:.2f} + {d['workers'][1]:.2f}, parent imports later {d['later']:.2f}, "
                  f"total {d['total']:.2f}")
    cold, warm = statistics.median(runs["cold"]), statistics.median(runs["warm"])
    print(f"median total: cold {cold:.2f}, warm {warm:.2f} (saved {cold - warm:.2f} s CPU); load "
          f"{os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
