"""Paper Sect. 6: stiffness of the 6302 under different operational conditions.

Runs the 6302 measurements of the bundled campaign and reproduces the paper's three analyses:
k_TB versus radial load (Table 2, with the Hertzian estimate), versus speed (Table 3) and rotating
versus non-rotating at three shaft positions (Table 4, the paper notes a mean decrease of 8.8 %
when the bearing rotates). Figures go to ``<out>/``.

Run from anywhere::

    python examples/paper_section6_conditions.py --out examples-out
"""

from __future__ import annotations

import argparse
import dataclasses
import math
from collections import defaultdict
from pathlib import Path

from ema_rig.campaign import load_campaign, run
from ema_rig.plot.campaign import plot_k_vs_load, plot_rotating_vs_static, plot_speed_effect

DATA = Path(__file__).resolve().parents[1] / "data"


def main() -> None:
    ap = argparse.ArgumentParser(description="6302 stiffness versus load, speed, rotation (paper Sect. 6)")
    ap.add_argument("--out", default="examples-out", help="output folder")
    ap.add_argument("--jobs", type=int, default=1)
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    cfg = load_campaign(DATA / "campaign.toml")
    meas = tuple(m for m in cfg.measurements if m.bearing == "6302")
    cfg = dataclasses.replace(cfg, measurements=meas, title="6302 operational conditions")
    result = run(cfg, out_dir=out / "section6", jobs=args.jobs, report=False)
    rows = [r for r in result.rows if r["status"] == "ok"]

    print("Table 2 - k_TB versus radial load (rotating):")
    by_load = defaultdict(list)
    for r in rows:
        if r["speed"] > 0:
            by_load[r["radial_load"]].append(r["k_TB"])
    for load in sorted(by_load):
        ks = by_load[load]
        print(f"  {load:7.0f} N: {sum(ks) / len(ks) / 1e6:7.2f} MN/m  ({len(ks)} measurements)")

    print("Table 3 - k_TB versus speed:")
    for r in sorted((r for r in rows if r["speed"] > 0), key=lambda r: (r["radial_load"], r["speed"])):
        print(f"  {r['radial_load']:7.0f} N {r['speed']:6.0f} rpm: {r['k_TB'] / 1e6:7.2f} ± {r['k_TB_std'] / 1e6:.2f} MN/m")

    print("Table 4 - non-rotating, shaft positions:")
    for r in rows:
        if r["speed"] <= 0:
            pos = r["shaft_position"]
            print(f"  position {pos if math.isfinite(pos) else float('nan'):5.0f} deg: {r['k_TB'] / 1e6:7.2f} MN/m")

    info = cfg.bearings.get("6302")
    figs = {
        "k_vs_load_6302.png": plot_k_vs_load(result.rows, "6302", info=info),
        "speed_6302.png": plot_speed_effect(result.rows, "6302"),
    }
    fig, change = plot_rotating_vs_static(result.rows, "6302")
    figs["rotating_vs_static_6302.png"] = fig
    print(f"mean change rotating vs non-rotating: {change:+.1f} % (paper: -8.8 %)")
    for name, f in figs.items():
        f.savefig(out / name, dpi=120)
        print(f"figure: {out / name}")


if __name__ == "__main__":
    main()
