"""Campaign throughput: the bundled campaign with --jobs 1 against --jobs 2, paired, and where
--jobs 2 loses against ideal.

Run from the repository root::

    python benchmarks/bench_campaign.py [--repeat N] [--cli N]

In-process runs (``ema_rig.campaign.run``): every run computes the whole bundled campaign
(data/campaign.toml) from scratch (``force=True``) into a fresh temporary folder, without the
report (figures and HTML are written once at the end and do not scale with the jobs). One untimed
run of each setting comes first and is reported apart (``first``: imports, the first BLAS call);
then ``--repeat`` pairs run interleaved (1 2, 2 1, 1 2, ...) so a busy period on the shared
machine hits both settings; reported as median [min-max] and the median of the per-pair ratios.
Goal: speed-up >= 1.7x on 2 cores.

Where the time goes (medians over the timed runs of each setting), from the completion times the
progress callback sees in the parent and the per-measurement ``elapsed_s`` the workers record:

* ``head``: start of ``run`` to the first completion minus that measurement's own time; that is
  the serial part before the measurements run in parallel (calibration on the steel disk in the
  parent, cache keys, worker start-up);
* ``body``: first to last completion plus the first measurement's time;
* ``tail``: last completion to the return of ``run`` (pool shut-down, table);
* ``work``: sum of the per-measurement times (in the workers); with 2 workers it grows when the
  two share the cores with each other and with everything else on the machine;
* ``ideal``: head(jobs 1) + work(jobs 1) / 2, what perfect splitting of the measurements would
  give; ``lost`` lists the gap by cause.
* ``cpu``: CPU seconds of the run, parent and pool workers (``getrusage``). Unlike the wall times
  it hardly depends on what else runs on the machine, so on a busy machine it tells whether
  ``--jobs 2`` costs more work (CPU ratio) and what a quiet machine would allow: the CPU of
  --jobs 1 over the serial head plus half of the rest of --jobs 2's CPU (the head taken at the
  CPU share of the --jobs 1 run).

With ``--cli N`` the same comparison is also made N times with the command line
(``ema-rig campaign data/campaign.toml --out DIR --jobs J --force``, a fresh process each time,
interleaved), i.e. what a user waits for, imports and report included.
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
from typing import Any

from ema_rig.campaign import CampaignConfig, load_campaign, run

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data" / "campaign.toml"


def _one_run(cfg: CampaignConfig, jobs: int) -> dict[str, Any]:
    """One run from scratch; the time split into head, body, tail and the worker time."""
    done_at: list[float] = []

    def progress(done: int, total: int) -> None:
        done_at.append(time.perf_counter())

    with tempfile.TemporaryDirectory() as tmp:
        c0 = _cpu()
        t0 = time.perf_counter()
        res = run(cfg, out_dir=tmp, jobs=jobs, force=True, report=False, progress=progress)
        t1 = time.perf_counter()
        cpu = _cpu() - c0
    elapsed = [float(r["elapsed_s"]) for r in res.rows]
    n_ok = len(res.rows) - res.n_failed
    # the first completion is some measurement; its own time is unknown from the parent, so the
    # shortest per-measurement time is taken off (head is then an upper bound of the serial part)
    first_own = min(elapsed) if elapsed else 0.0
    head = (done_at[0] - t0) - first_own if done_at else t1 - t0
    body = (done_at[-1] - done_at[0]) + first_own if done_at else 0.0
    tail = t1 - done_at[-1] if done_at else 0.0
    return {"total": t1 - t0, "head": head, "body": body, "tail": tail, "work": sum(elapsed), "cpu": cpu,
            "n_ok": n_ok}


def _cpu() -> float:
    """CPU seconds (user + system) of this process and of its reaped children (the pool's workers,
    reaped when ``run`` shuts its pool down)."""
    own = resource.getrusage(resource.RUSAGE_SELF)
    kids = resource.getrusage(resource.RUSAGE_CHILDREN)
    return own.ru_utime + own.ru_stime + kids.ru_utime + kids.ru_stime


def _stat(xs: list[float]) -> str:
    return f"{statistics.median(xs):6.2f} [{min(xs):.2f}-{max(xs):.2f}]"


def _cli_runs(campaign: str, repeat: int) -> dict[int, list[float]]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.setdefault("MPLBACKEND", "Agg")
    times: dict[int, list[float]] = {1: [], 2: []}
    for k in range(repeat):
        for jobs in (1, 2) if k % 2 == 0 else (2, 1):
            with tempfile.TemporaryDirectory() as tmp:
                cmd = [sys.executable, "-c", "import sys; from ema_rig.cli import main; sys.exit(main())",
                       "campaign", campaign, "--out", tmp, "--jobs", str(jobs), "--force"]
                t0 = time.perf_counter()
                proc = subprocess.run(cmd, env=env, capture_output=True, text=True)
                times[jobs].append(time.perf_counter() - t0)
                if proc.returncode != 0:
                    raise SystemExit(f"ema-rig campaign --jobs {jobs} failed: {proc.stderr.strip()[-300:]}")
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="timed pairs (default 5)")
    ap.add_argument("--cli", type=int, default=0, metavar="N", help="also N paired runs of the CLI")
    ap.add_argument("--campaign", default=str(DATA))
    args = ap.parse_args()
    cfg = load_campaign(args.campaign)
    n = len(cfg.measurements)
    print(f"bench_campaign {time.strftime('%Y-%m-%d %H:%M %Z')}  campaign: {args.campaign} ({n} measurements)  "
          f"cores: {os.cpu_count()}  load {os.getloadavg()[0]:.1f}")
    first = {jobs: _one_run(cfg, jobs)["total"] for jobs in (1, 2)}
    runs: dict[int, list[dict[str, Any]]] = {1: [], 2: []}
    ratios = []
    for k in range(args.repeat):
        pair = {}
        for jobs in (1, 2) if k % 2 == 0 else (2, 1):
            r = _one_run(cfg, jobs)
            runs[jobs].append(r)
            pair[jobs] = r["total"]
        ratios.append(pair[1] / pair[2])
    print(f"in-process, force, no report; first run apart, then {args.repeat} interleaved pairs, "
          "median [min-max] in s:")
    print(f"{'':9} {'first':>6} {'total':>20} {'head':>20} {'body':>20} {'tail':>20} {'work':>20} {'cpu':>20}  ok")
    for jobs in (1, 2):
        rs = runs[jobs]
        cells = " ".join(f"{_stat([r[k] for r in rs]):>20}" for k in ("total", "head", "body", "tail", "work", "cpu"))
        print(f"--jobs {jobs}  {first[jobs]:6.2f} {cells}  {rs[-1]['n_ok']}/{n}")
    med = {j: {k: statistics.median(r[k] for r in runs[j]) for k in runs[j][0]} for j in (1, 2)}
    speed = statistics.median(ratios)
    print(f"speed-up --jobs 2 / --jobs 1: {speed:.2f}x median of pairs [{min(ratios):.2f}-{max(ratios):.2f}] "
          f"(goal >= 1.7x: {'met' if speed >= 1.7 else 'NOT met'})")
    ideal = med[1]["head"] + med[1]["work"] / 2
    j2 = med[2]
    print(f"ideal --jobs 2 (serial head + work of --jobs 1 split in two): {ideal:.2f} s -> "
          f"{med[1]['total'] / ideal:.2f}x at best with this head; measured {j2['total']:.2f} s")
    print("lost against a perfect split of the --jobs 1 run:")
    print(f"  serial head (calibration in the parent, set-up): {j2['head']:.2f} s of {j2['total']:.2f} s "
          f"(--jobs 1: {med[1]['head']:.2f} s)")
    print(f"  slower measurements in 2 workers (work {j2['work']:.2f} s vs {med[1]['work']:.2f} s): "
          f"{(j2['work'] - med[1]['work']) / 2:+.2f} s")
    print(f"  uneven end (body - work/2): {j2['body'] - j2['work'] / 2:+.2f} s;  tail: {j2['tail']:.2f} s "
          f"(--jobs 1: {med[1]['tail']:.2f} s)")
    c1, c2 = med[1]["cpu"], med[2]["cpu"]
    print(f"CPU per run: --jobs 1 {c1:.2f} s, --jobs 2 {c2:.2f} s ({c2 / c1:.2f}x); wall of --jobs 1 / its CPU "
          f"{med[1]['total'] / c1:.2f} (> 1: the run waited for a core; on a quiet machine ~1)")
    head_cpu = med[1]["head"] * min(1.0, c1 / med[1]["total"])  # the serial part, at the run's CPU share
    quiet = c1 / (head_cpu + (c2 - head_cpu) / 2)
    print(f"speed-up a quiet 2-core machine would allow from these CPU times (serial head scaled the same way): "
          f"~{quiet:.2f}x")
    if args.cli:
        t = _cli_runs(args.campaign, args.cli)
        r = [a / b for a, b in zip(t[1], t[2], strict=True)]
        print(f"CLI (fresh process, report included), {args.cli} interleaved pairs: --jobs 1 {_stat(t[1])} s, "
              f"--jobs 2 {_stat(t[2])} s, speed-up {statistics.median(r):.2f}x [{min(r):.2f}-{max(r):.2f}]")


if __name__ == "__main__":
    main()
