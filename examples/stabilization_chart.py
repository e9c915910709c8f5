"""Stabilization chart of a rig-like measurement, written to a PNG (headless).

Reads a UFF58 file of the bearing test rig (default: the bundled
``data/b6302_1000N_1200rpm.uff`` with ``data/rig.toml``; with ``--simulate`` a fresh synthetic
two-shaker measurement is written first), identifies the modes in 150-1000 Hz with PolyMAX,
and draws the chart: poles by stabilization status over frequency and model order, the sum of
FRFs behind them, the automatically selected modes marked with their frequency.

Run::

    python examples/stabilization_chart.py [-o chart.png] [--simulate] [--cmif]
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

REPO = Path(__file__).resolve().parent.parent


def simulated_file(tmp: Path) -> tuple[Path, Path]:
    """A synthetic measurement with the radial and the axial shaker (k_TB = 7.157e7 N/m)."""
    from ema_rig.config import load_rig
    from ema_rig.simulate import simulate_measurement, write_measurement

    text = (REPO / "data" / "rig.toml").read_text(encoding="utf-8")
    text = text.replace('radial = "11+Y"', 'radial = "11+Y"\naxial = "15+X"', 1)
    rig_path = tmp / "rig.toml"
    rig_path.write_text(text, encoding="utf-8")
    rig = load_rig(rig_path)
    sim = simulate_measurement(rig, k_tb=7.157e7, noise=0.01, seed=3)
    path = write_measurement(sim, tmp / "two_shakers.uff", rig=rig)
    return path, rig_path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default="examples-out", help="output folder")
    ap.add_argument("--simulate", action="store_true", help="write and use a two-shaker synthetic file")
    ap.add_argument("--cmif", action="store_true", help="CMIF instead of the sum of FRFs")
    args = ap.parse_args()

    from ema_rig._atomic import atomic_path
    from ema_rig.config import load_rig
    from ema_rig.identification import identify
    from ema_rig.io.uff import read_uff58
    from ema_rig.plot.stabilization import plot_stabilization

    with tempfile.TemporaryDirectory() as tmpdir:
        if args.simulate:
            uff, rig_path = simulated_file(Path(tmpdir))
        else:
            uff, rig_path = REPO / "data" / "b6302_1000N_1200rpm.uff", REPO / "data" / "rig.toml"
        rig = load_rig(rig_path)
        data = read_uff58(uff, rig=rig)
        band = rig.identification.get("band", (150.0, 1000.0))
        ident = identify(data, band=band)
        chart = plot_stabilization(
            ident.stabilization,
            data.band(band[0] - 50.0, band[1] + 50.0),
            selection=ident.selection,
            indicator="cmif" if args.cmif else "sum",
            show_unstable=True,
            title=f"{uff.name}: {data.n_out} outputs x {data.n_in} reference(s), PolyMAX {band[0]:g}-{band[1]:g} Hz",
        )
        output = Path(args.out) / ("stabilization_chart_2ref.png" if args.simulate else "stabilization_chart.png")
        with atomic_path(output) as tmp:
            chart.figure.savefig(tmp, dpi=130)
    print(f"wrote {output}")
    for rec in ident.to_records():
        mass = ", ".join(f"{k}: {v:.3g} kg" for k, v in rec["modal_mass"].items())
        print(
            f"  {rec['natural_freq']:8.2f} Hz  zeta {100 * rec['damping_ratio']:.2f} %  "
            f"(+/- {rec['natural_freq_std']:.3f} Hz over {rec['n_poles']} orders)  MPC {rec['mpc']:.3f}  {mass}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
