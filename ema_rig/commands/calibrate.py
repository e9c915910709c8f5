"""calibrate: mounting-system stiffness k_MS from a steel-disk measurement."""

from __future__ import annotations

import argparse

from .._atomic import write_json
from .._text import std_text
from ..config import load_rig
from ..errors import EmaRigError, MatchingError
from . import _args
from .stiffness import print_caveats, write_refusal


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig calibrate``."""
    parser.add_argument("file", metavar="DISK_FILE", help="UFF58 measurement with the steel disk mounted")
    parser.add_argument("--rig", required=True, metavar="R", help="rig file (TOML; see README, 'The rig file')")
    _args.add_units_argument(parser)
    parser.add_argument("--k-disk", type=_args.positive_float, default=None, metavar="V",
                        help="finite disk stiffness [N/m] in series (default: the rig file's [calibration] "
                             "k_disk, else rigid, as the paper)")
    parser.add_argument("--k-disk-std", type=_args.nonneg_float, default=None, metavar="V",
                        help="standard uncertainty of --k-disk [N/m]")
    parser.add_argument("--damping-model", choices=("viscous", "hysteretic"), default="viscous",
                        help="which undamped frequency the identified pole stands for (default viscous)")
    parser.add_argument("--band", type=_args.finite_float, nargs=2, action=_args.BandAction, default=None,
                        metavar=("LO", "HI"),
                        help="identification band [Hz] (default: rig file k_MS_band / band, else 150 1000)")
    parser.add_argument("--max-order", type=_args.model_order, default=None, metavar="N", help="maximum PolyMAX order")
    parser.add_argument("--json", default=None, metavar="OUT", help="write the result as JSON")
    parser.add_argument("--plot", default=None, metavar="PNG",
                        help="measured FRFs against the 3DOF model with the disk, 150-1000 Hz")



def io_paths(args: argparse.Namespace) -> tuple[list[tuple[str, str | None]], list[tuple[str, str | None]], tuple[str, ...]]:
    """The command's input and output files and the labels of its figures (checked before it runs)."""
    return ([("DISK_FILE", args.file), ("--rig", args.rig)],
            [("--json", args.json), ("--plot", args.plot)], ("--plot",))


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig calibrate``."""
    from ..io.uff import read_uff58
    from ..rig.stiffness import calibrate

    if args.k_disk is not None and not args.k_disk > 0:
        raise EmaRigError(f"--k-disk must be a positive stiffness [N/m], got {args.k_disk:g}", file=args.file)
    if args.max_order is not None and args.max_order < 2:
        raise EmaRigError(f"--max-order must be >= 2, got {args.max_order}", file=args.file)
    rig = load_rig(args.rig)
    data = read_uff58(args.file, rig=rig, units=args.units).with_meta(file=str(args.file))
    if args.k_disk_std is not None and args.k_disk is None:
        raise EmaRigError("--k-disk-std needs --k-disk", file=args.file)
    try:
        res = calibrate(data, rig, k_disk=args.k_disk, k_disk_std=args.k_disk_std,
                        band=None if args.band is None else tuple(args.band), max_order=args.max_order,
                        damping_model=args.damping_model)
    except MatchingError as exc:
        if args.json:
            write_refusal(args.json, args.file, exc)
        raise
    hm = res.housing_mode
    sd = hm.get("natural_freq_std")
    print(f"file          {res.file or '-'}")
    print(f"housing mode  {hm['natural_freq']:.2f}{_args.pm(sd)} Hz, damping "
          f"{100 * hm['damping_ratio']:.2f}{_args.pm(hm.get('damping_ratio_std'), 100)} % (steel disk)")
    print(f"k_MS          {res.k_MS / 1e6:.3f} +/- {std_text(res.k_MS_std_measured / 1e6)} (measured) "
          f"+/- {std_text(res.k_MS_std / 1e6)} (total) MN/m (1 sigma)"
          + (", disk assumed rigid" if res.k_disk is None else f", disk {res.k_disk / 1e6:.0f} MN/m in series"))
    print(f"rig file k_MS {rig.model.k_MS / 1e6:.2f} MN/m; use --k-ms {res.k_MS:.6g} --k-ms-std "
          f"{res.k_MS_std:.3g} with 'ema-rig stiffness'")
    print_caveats(res)
    _args.note_clipped_band(args.band, res.band, res.file or args.file)
    if args.json:
        write_json(args.json, res.to_dict())
        print(f"wrote {args.json}")
    if args.plot:
        from ..plot.rig import plot_rig_fit, save_figure

        p = plot_rig_fit(data, res, rig, band=(150.0, 1000.0))
        save_figure(p.figure, args.plot)
        print(f"wrote {args.plot}")
    return 0
