"""Benchmark: the bundled campaign's wall time with this tree against another tree (issue 18).

Each run is what a user waits for: a fresh process ``python -m ema_rig.cli campaign
data/campaign.toml -o DIR --force`` (defaults otherwise: report and figures included) into a new
temporary folder, with ``PYTHONPATH`` pointing at one tree and that tree's own ``data/`` (the
bundled data must be the same in both: checked by hash). Runs alternate (old new, new old, ...)
so that a busy period of the shared machine hits both; reported as median [min-max] per tree, the
median and range of the per-pair ratios, and the load average before and after every pair.

Run: ``python benchmarks/bench_campaign_vs_tree.py --baseline /tmp/old [--repeat 5]`` where the
baseline is a checkout of the reference commit (``git worktree add /tmp/old 5424261``).
"""

from __future__ import annotations

import argparse
import hashlib
import os
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent


def _data_hash(tree: Path) -> str:
    h = hashlib.sha256()
    for p in sorted((tree / "data").glob("*")):
        if p.suffix in (".uff", ".toml", ".json", ".csv"):
            h.update(p.name.encode())
            h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _run(tree: Path, out: Path) -> tuple[float, float]:
    """Wall time and CPU time (user + system of the process and its workers) [s] of one campaign."""
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "ema_rig.cli", "campaign", str(tree / "data" / "campaign.toml"),
                    "-o", str(out), "--force"], cwd=tree, env=env, check=True, capture_output=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", required=True, type=Path)
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    old, new = args.baseline.resolve(), REPO
    same = _data_hash(old) == _data_hash(new)
    print(f"campaign wall time, new = {new} vs old = {old}; bundled data identical: {same}")
    if not same:
        raise SystemExit("the two trees bundle different data: no like-for-like comparison")
    t: dict[str, list[float]] = {"old": [], "new": []}
    cpu: dict[str, list[float]] = {"old": [], "new": []}
    with tempfile.TemporaryDirectory() as tmp:
        for i in range(args.repeat):
            load0 = os.getloadavg()[0]
            for tag in (("old", "new") if i % 2 == 0 else ("new", "old")):
                tree = old if tag == "old" else new
                wall, c = _run(tree, Path(tmp) / f"{tag}_{i}")
                t[tag].append(wall)
                cpu[tag].append(c)
            print(f"pair {i + 1}: old {t['old'][-1]:.1f} s, new {t['new'][-1]:.1f} s, "
                  f"ratio {t['new'][-1] / t['old'][-1]:.2f}; CPU old {cpu['old'][-1]:.1f} s, new {cpu['new'][-1]:.1f} s, "
                  f"ratio {cpu['new'][-1] / cpu['old'][-1]:.2f}; load average {load0:.1f} -> {os.getloadavg()[0]:.1f}",
                  flush=True)
    ratio = [b / a for a, b in zip(t["old"], t["new"], strict=True)]
    cratio = [b / a for a, b in zip(cpu["old"], cpu["new"], strict=True)]

    def fmt(x: list[float], f: str = ".1f") -> str:
        return f"{statistics.median(x):{f}} [{min(x):{f}}-{max(x):{f}}]"

    print(f"wall: old {fmt(t['old'])} s, new {fmt(t['new'])} s, new/old {fmt(ratio, '.2f')} (median [range] of "
          f"{args.repeat} pairs)")
    print(f"CPU:  old {fmt(cpu['old'])} s, new {fmt(cpu['new'])} s, new/old {fmt(cratio, '.2f')}")


if __name__ == "__main__":
    main()
