"""Compare a campaign table with the bundled truth: ``python examples/check_demo_truth.py OUT/campaign.csv``.

Prints each measurement's k_TB error against ``data/truth.csv`` and exits 1 when one exceeds
0.1 % (the bundled campaign's promise, README "Demo"), carries a warning, or has no truth.
"""

from __future__ import annotations

import csv
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent.parent / "data"
LIMIT = 1e-3


def main(argv: list[str]) -> int:
    """Check ``argv[0]`` (a campaign.csv with k_TB in N/m); 0 when all are within 0.1 %."""
    if len(argv) != 1:
        sys.stderr.write("usage: python examples/check_demo_truth.py OUT/campaign.csv\n")
        return 2
    with open(HERE / "truth.csv", newline="", encoding="utf-8") as fh:
        truth = {r["id"]: float(r["k_TB"]) for r in csv.DictReader(fh)}
    with open(argv[0], newline="", encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    worst, bad = 0.0, 0
    for r in rows:
        if r["id"] not in truth:
            sys.stdout.write(f"{r['id']}: no truth\n")
            bad += 1
            continue
        err = float(r["k_TB [N/m]"]) / truth[r["id"]] - 1.0
        worst = max(worst, abs(err))
        bad += abs(err) > LIMIT or err != err
        warned = (r.get("warnings") or "").strip()
        bad += bool(warned)  # the demo promises results without caveats
        sys.stdout.write(f"{r['id']:28s} {100 * err:+.4f} %{'  warning: ' + warned if warned else ''}\n")
    sys.stdout.write(f"max |k_TB error| = {100 * worst:.4f} % over {len(rows)} measurements\n")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
