"""simulate: write a synthetic rig measurement (UFF58) with its truth beside it.

Example: ``ema-rig simulate --rig rig.toml --k-tb 7.16e7 -o m.uff --speed 1500 --binary --units g``
writes ``m.uff`` and ``m.uff.truth.json``.
"""

from __future__ import annotations

import argparse

from ..config import load_rig
from ..errors import EmaRigError
from . import _args

MAX_LINES = 200_001
"""Most frequency lines ``simulate`` writes (0.01 Hz over 2000 Hz; a few hundred MB in memory)."""


def _accel_unit(text: str) -> str:
    key = text.strip().lower().replace(" ", "").replace("²", "^2")
    if key in ("g", "gn"):
        return "g"
    if key in ("m/s^2", "m/s2", "ms-2", "m/s**2", "si"):
        return "m/s^2"
    raise argparse.ArgumentTypeError(f"unit must be 'm/s^2' or 'g', got {text!r}")


_NOISE = _args.number(float, lo=0.0, hi=10.0)  # 10 = noise ten times the FRF: no signal left


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig simulate``."""
    parser.add_argument("--rig", required=True, help="rig file (TOML): model, sensors, references")
    parser.add_argument("--k-tb", required=True, type=_args.positive_stiffness, metavar="V",
                        help="true bearing stiffness [N/m]; 'inf' simulates the steel disk")
    parser.add_argument("-o", "--output", required=True, metavar="FILE", help="UFF58 file to write")
    parser.add_argument("--noise", type=_NOISE, nargs="?", const=0.01, default=0.01, metavar="LEVEL",
                        help="relative complex noise level (default 0.01; 0 = noise-free)")
    parser.add_argument("--seed", type=_args.nonneg_int, default=0, help="noise seed (default 0)")
    parser.add_argument("--speed", type=_args.shaft_speed, default=0.0, metavar="RPM",
                        help="shaft speed [rpm]; > 0 adds lines at multiples of the speed")
    parser.add_argument("--binary", action="store_true", help="write binary 58b datasets")
    parser.add_argument("--single", action="store_true", help="single precision (smaller files)")
    parser.add_argument("--units", type=_accel_unit, default="m/s^2", metavar="{m/s^2,g}",
                        help="acceleration unit written (default m/s^2)")
    parser.add_argument("--radial-only", action="store_true",
                        help="drive only the radial shaker (default: every reference of the rig file)")
    parser.add_argument("--no-extra-modes", action="store_true",
                        help="only the 3DOF model's modes (no tilt, axial, flexible ... modes)")
    parser.add_argument("--fmax", type=_args.positive_float, default=2000.0, help="last frequency line [Hz] (default 2000)")
    parser.add_argument("--df", type=_args.positive_float, default=0.5, help="frequency resolution [Hz] (default 0.5)")



def io_paths(args: argparse.Namespace) -> tuple[list[tuple[str, str | None]], list[tuple[str, str | None]]]:
    """The command's input and output files (checked against each other before it runs)."""
    return ([("--rig", args.rig)],
            [("-o", args.output), ("-o (truth)", f"{args.output}.truth.json")])


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig simulate``."""
    import numpy as np

    from ..simulate import simulate_measurement, truth_path, write_measurement

    # every option is range-checked by argparse; what is left is how many lines they make
    span = args.fmax / args.df  # lines after the one at 0 Hz (inf when df is tiny)
    if not 2.0 <= span + 0.5 < MAX_LINES:
        raise EmaRigError(f"--fmax {args.fmax:g} with --df {args.df:g} gives {span + 1:.4g} frequency lines; "
                          f"need 3..{MAX_LINES}", file=args.output)
    n_lines = int(span + 0.5) + 1
    rig = load_rig(args.rig)
    freq = np.arange(n_lines) * args.df
    refs = ("radial",) if args.radial_only else None
    try:
        sim = simulate_measurement(
            rig,
            k_tb=args.k_tb,
            freq=freq,
            noise=args.noise,
            seed=args.seed,
            speed_hz=args.speed / 60.0 if args.speed > 0 else None,
            extra_modes=not args.no_extra_modes,
            references=refs,
        )
    except ValueError as exc:  # the options are checked: what is left comes from the rig file
        raise EmaRigError(str(exc), file=args.rig) from None
    path = write_measurement(sim, args.output, binary=args.binary, accel_unit=args.units, rig=rig,
                             double=not args.single)
    t = sim.truth
    print(f"{path}: k_TB = {t['k_TB']:.6g} N/m, k_TB+MS = {t['k_TB_MS']:.6g} N/m, housing mode "
          f"{t['f_H']:.2f} Hz; truth in {truth_path(path).name}")
    return 0
