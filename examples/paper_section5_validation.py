"""Paper Sect. 5: validate the stiffness estimation on the dummy bearing of known stiffness.

The dummy bearing's FE model bounds its stiffness to 31.14e6 ... 34.12e6 N/m. This script runs the
dummy-bearing measurements of the bundled campaign (k_MS calibrated on the steel disk first),
prints k_TB per load level and repeat, and draws the paper's Fig. 9 (estimates against the FE
bounds) into ``<out>/fig9_dummy_validation.png``.

Run from anywhere::

    python examples/paper_section5_validation.py --out examples-out
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

from ema_rig.campaign import load_campaign, run
from ema_rig.plot.campaign import plot_validation

DATA = Path(__file__).resolve().parents[1] / "data"


def main() -> None:
    ap = argparse.ArgumentParser(description="dummy-bearing validation (paper Sect. 5)")
    ap.add_argument("--out", default="examples-out", help="output folder")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)

    cfg = load_campaign(DATA / "campaign.toml")
    dummy = tuple(m for m in cfg.measurements if m.bearing == "dummy")
    cfg = dataclasses.replace(cfg, measurements=dummy, title="Dummy bearing validation")
    result = run(cfg, out_dir=out / "section5", report=False)

    info = cfg.bearings["dummy"]
    print(f"k_MS from the steel disk: {result.k_MS / 1e6:.2f} MN/m")
    print(f"FE bounds: {info.k_lower / 1e6:.2f} ... {info.k_upper / 1e6:.2f} MN/m")
    print(f"{'load [N]':>9} {'repeat':>6} {'k_TB [MN/m]':>12} {'± [MN/m]':>9} {'f_H [Hz]':>9}  inside")
    for r in result.rows:
        if r["status"] != "ok":
            print(f"{r['radial_load']:9.0f} {r['repeat']:6d}  error: {r['error']}")
            continue
        inside = info.k_lower <= r["k_TB"] <= info.k_upper
        print(f"{r['radial_load']:9.0f} {r['repeat']:6d} {r['k_TB'] / 1e6:12.2f} {r['k_TB_std'] / 1e6:9.2f} "
              f"{r['housing_freq']:9.1f}  {'yes' if inside else 'NO'}")
    fig = plot_validation(result.rows, "dummy", info)
    path = out / "fig9_dummy_validation.png"
    fig.savefig(path, dpi=120)
    print(f"figure: {path}")


if __name__ == "__main__":
    main()
