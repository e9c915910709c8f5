"""Campaign throughput: measurements per second on the bundled campaign, --jobs 1 against --jobs 2.

Run from the repository root::

    python benchmarks/bench_campaign.py [--repeat N]

Each configuration runs the whole bundled campaign (data/campaign.toml) from scratch (``force``)
into a temporary folder, without the report (the figures and HTML are written once at the end and
do not scale with the jobs); the best of ``--repeat`` runs is reported. Goal: speed-up >= 1.7x on
2 cores.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from ema_rig.campaign import load_campaign, run

DATA = Path(__file__).resolve().parents[1] / "data" / "campaign.toml"


def _time(cfg, jobs: int, repeat: int) -> tuple[float, int]:
    best = float("inf")
    n_ok = 0
    for _ in range(repeat):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            res = run(cfg, out_dir=tmp, jobs=jobs, force=True, report=False)
            best = min(best, time.perf_counter() - t0)
            n_ok = len(res.rows) - res.n_failed
    return best, n_ok


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=2)
    ap.add_argument("--campaign", default=str(DATA))
    args = ap.parse_args()
    cfg = load_campaign(args.campaign)
    n = len(cfg.measurements)
    print(f"campaign: {args.campaign} ({n} measurements), cores: {os.cpu_count()}")
    results = {}
    for jobs in (1, 2):
        t, n_ok = _time(cfg, jobs, args.repeat)
        results[jobs] = t
        print(f"--jobs {jobs}: {t:7.2f} s  {n / t:6.2f} measurements/s  ({n_ok}/{n} ok)")
    print(f"speed-up --jobs 2 / --jobs 1: {results[1] / results[2]:.2f}x (goal >= 1.7x)")


if __name__ == "__main__":
    main()
