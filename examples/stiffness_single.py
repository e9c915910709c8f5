"""One measurement, step by step: k_MS from the steel disk, k_TB of a bearing, the paper's Fig. 7.

By default the two measurements are simulated (a steel-disk run and a 6302 at 1 kN, with noise
and every mode the 3DOF model lacks) into the output folder; pass your own files instead::

    python examples/stiffness_single.py --out examples-out
    python examples/stiffness_single.py --rig data/rig.toml --disk data/disk.uff --file data/x.uff

Every step is a plain function returning a frozen result: identification, matching (each
candidate mode with the reason it was kept or rejected), inversion with its uncertainty budget.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

from ema_rig.config import load_rig
from ema_rig.io.uff import read_uff58
from ema_rig.plot.rig import plot_rig_fit, save_figure
from ema_rig.rig.stiffness import calibrate, estimate_stiffness

REPO_RIG = Path(__file__).resolve().parents[1] / "data" / "rig.toml"  # the paper's rig, 8 sensors


def simulate_inputs(out: Path) -> tuple[Path, Path, Path]:
    """Write a rig file, a steel-disk run and a bearing run (k_TB = 92 MN/m, 1500 rpm)."""
    from ema_rig.simulate import simulate_measurement, write_measurement

    rig_path = REPO_RIG
    rig = load_rig(rig_path)
    disk = write_measurement(simulate_measurement(rig, k_tb=math.inf, noise=0.01, seed=1), out / "disk.uff", rig=rig)
    sim = simulate_measurement(rig, k_tb=92e6, noise=0.01, seed=2, speed_hz=25.0)
    meas = write_measurement(sim, out / "bearing_1kN_1500rpm.uff", rig=rig)
    print(f"simulated: true k_TB = {sim.truth['k_TB'] / 1e6:.2f} MN/m, housing mode {sim.truth['f_H']:.2f} Hz")
    return rig_path, disk, meas


def main() -> None:
    ap = argparse.ArgumentParser(description="k_MS calibration, k_TB and Fig. 7 for one measurement")
    ap.add_argument("--out", default="examples-out", help="output folder")
    ap.add_argument("--rig", help="rig file (default: simulate everything)")
    ap.add_argument("--disk", help="steel-disk UFF58 file")
    ap.add_argument("--file", help="bearing UFF58 file")
    ap.add_argument("--rpm", type=float, default=None, help="shaft speed of --file [rpm]")
    args = ap.parse_args()
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    if args.rig and args.disk and args.file:
        rig_path, disk_path, meas_path = Path(args.rig), Path(args.disk), Path(args.file)
        speed_hz = None if not args.rpm else args.rpm / 60.0
    else:
        rig_path, disk_path, meas_path = simulate_inputs(out)
        speed_hz = 25.0
    rig = load_rig(rig_path)

    # 1. k_MS from the steel disk (the disk is taken as rigid, as in the paper)
    cal = calibrate(read_uff58(disk_path, rig=rig).with_meta(file=str(disk_path)), rig)
    print(f"steel disk: housing mode {cal.housing_mode['natural_freq']:.2f} Hz -> "
          f"k_MS = {cal.k_MS / 1e6:.2f} ± {cal.k_MS_std / 1e6:.2f} MN/m")

    # 2. k_TB of the bearing with the calibrated k_MS
    data = read_uff58(meas_path, rig=rig).with_meta(file=str(meas_path))
    res = estimate_stiffness(data, rig, k_ms=cal.k_MS, k_ms_std=cal.k_MS_std, speed_hz=speed_hz)
    hm = res.housing_mode
    print(f"bearing:    housing mode {hm['natural_freq']:.2f} Hz (damping {100 * hm['damping_ratio']:.2f} %, "
          f"modal mass {hm['modal_mass']:.2f} kg, model {hm['model_modal_mass']:.2f} kg)")
    print(f"            k_TB = {res.k_TB / 1e6:.2f} ± {res.k_TB_std / 1e6:.2f} MN/m (1 sigma)")
    print("            uncertainty budget: " + ", ".join(
        f"{k} {100 * v:.0f} %" for k, v in sorted(res.uncertainty_budget.items(), key=lambda kv: -kv[1]) if v > 0.01))
    if res.spindle_mode is not None:
        print(f"            spindle bending mode {res.spindle_mode['natural_freq']:.1f} Hz")
    print("candidate modes:")
    for c in res.candidates:
        print(f"  {c['natural_freq']:8.1f} Hz  {c['status']:<8} {c['reason']}")

    # 3. the paper's Fig. 7: measured FRFs against the 3DOF model, 150-700 Hz
    p = plot_rig_fit(data, res, rig)
    save_figure(p.figure, out / "fig7_frf_vs_model.png")
    print(f"figure: {out / 'fig7_frf_vs_model.png'}")


if __name__ == "__main__":
    main()
