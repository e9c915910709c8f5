"""stiffness: bearing stiffness k_TB of the mounted bearing from its housing mode."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from .._atomic import commit_staged, write_json
from .._text import std_text
from ..config import load_rig
from ..errors import EmaRigError, MatchingError
from . import _args


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig stiffness``."""
    parser.add_argument("file", metavar="FILE", help="UFF58 measurement (FRFs of the eight sensors)")
    parser.add_argument("--rig", required=True, metavar="R", help="rig file (TOML; see README, 'The rig file')")
    parser.add_argument("--k-ms", type=_args.mounting_stiffness, default=None, metavar="V",
                        help="mounting stiffness k_MS [N/m] from 'ema-rig calibrate' (default: the rig file's)")
    parser.add_argument("--k-ms-std", type=_args.nonneg_float, default=None, metavar="V",
                        help="standard uncertainty of k_MS [N/m] (default: the rig file's relative value)")
    parser.add_argument("--speed", type=_args.shaft_speed, default=None, metavar="RPM",
                        help="shaft speed in rpm when the bearing rotates (rejects harmonic lines)")
    parser.add_argument("--band", type=_args.finite_float, nargs=2, action=_args.BandAction, default=None,
                        metavar=("LO", "HI"),
                        help="identification band of the housing mode [Hz] (default: rig file, else 150 1000)")
    parser.add_argument("--max-order", type=_args.model_order, default=None, metavar="N", help="maximum PolyMAX order")
    parser.add_argument("--selection", default=None, metavar="JSON",
                        help="replay a saved mode selection (picked with PolePicker, or 'modes --save-selection') "
                             "instead of the automatic identification; the housing mode is matched among its modes")
    _args.add_units_argument(parser)
    parser.add_argument("--no-spindle", action="store_true",
                        help="skip the identification of the spindle bending mode (faster)")
    parser.add_argument("--fit", action="store_true",
                        help="also fit k_TB+MS, k_S, m_S, m_F to the FRFs in 150-700 Hz (paper Fig. 7)")
    parser.add_argument("--damping-model", choices=("viscous", "hysteretic"), default="viscous",
                        help="which undamped frequency the identified pole stands for (default viscous: "
                             "|lambda|); the difference enters the budget as a model-form term. Also the "
                             "bearing's damping model: a dashpot c_TB in parallel with k_TB (viscous) or "
                             "k_TB (1 + j loss factor) (hysteretic)")
    parser.add_argument("--json", default=None, metavar="OUT",
                        help="write the result as JSON (on a refused match: the error and every candidate)")
    parser.add_argument("--plot", default=None, metavar="PNG",
                        help="measured FRFs against the 3DOF model, 150-700 Hz (paper Fig. 7)")


def summary(res: Any) -> str:
    """Readable multi-line summary of a StiffnessResult."""
    hm, sm = res.housing_mode, res.spindle_mode
    sd = hm.get("natural_freq_std")
    from ..rig.damping import c_tb_text  # numpy: not at the CLI's start-up

    lines = [
        f"file          {res.file or '-'}",
        f"housing mode  {hm['natural_freq']:.2f}{_args.pm(sd)} Hz"
        + ("" if getattr(res, "mode_source", "auto") == "auto" else f" (from a {res.mode_source})")
        + f", damping {100 * hm['damping_ratio']:.2f}{_args.pm(hm.get('damping_ratio_std'), 100)} %"
        + (f", modal mass {hm['modal_mass']:.2f} kg (model {hm['model_modal_mass']:.2f})"
           if hm.get("modal_mass") is not None else ""),
        "spindle mode  " + ("not found" if sm is None else
                            f"{sm['natural_freq']:.1f}{_args.pm(sm.get('natural_freq_std'))} Hz, damping "
                            f"{100 * sm['damping_ratio']:.2f}{_args.pm(sm.get('damping_ratio_std'), 100)} %"),
        f"k_MS          {res.k_MS / 1e6:.2f} MN/m",
        f"k_TB+MS       {res.k_TB_MS / 1e6:.3f} MN/m",
        f"k_TB          {res.k_TB / 1e6:.3f} +/- {std_text(res.k_TB_std_measured / 1e6)} (measured) "
        f"+/- {std_text(res.k_TB_std / 1e6)} (total) MN/m (1 sigma, {std_text(100 * res.k_TB_std_measured / res.k_TB)} % / "
        f"{std_text(100 * res.k_TB_std / res.k_TB)} %)",
        "3DOF inv.     " + ("outside the model's range" if res.inversion_3dof is None else
                            f"k_TB {res.inversion_3dof['k_TB'] / 1e6:.3f} MN/m at {res.inversion_3dof['freq']:.2f} Hz "
                            "(identified frequency, rig-file m_H, no correction)"),
        "housing mass  " + _mass(getattr(res, "housing_mass", None)),
        "housing body  " + _rigid(res.rigid_body),
        "bearing damp. " + ("not available" if res.damping is None else
                            c_tb_text(res.c_TB, res.c_TB_std, res.damping.kind, upper=res.damping.c_TB_upper,
                                      upper_std=res.damping.c_TB_upper_std) + ", loss factor "
                            f"{res.loss_factor:.4f}{_args.pm(res.loss_factor_std)} ({res.damping.model} bearing)"),
        "budget        " + ", ".join(
            f"{t.name} {100 * t.share:.0f} % [{t.kind}]" for t in res.uncertainty.terms if t.share >= 0.005),
        f"candidates    {len(res.candidates)} modes considered:",
    ]
    if res.fit is not None:
        ft = res.fit
        lines.insert(-1, f"model fit     150-700 Hz: k_TB+MS {ft.k_TB_MS / 1e6:.3f} MN/m, k_S {ft.params.k_S / 1e6:.0f} "
                         f"MN/m, m_S {ft.params.m_S:.2f} kg, m_F {ft.params.m_F:.0f} kg, "
                         f"rms log error {ft.residual_rms:.3f}")
    for c in res.candidates:
        lines.append(f"  {c['natural_freq']:8.1f} Hz  {c['status']:<8}  {c['reason']}")
    return "\n".join(lines)


def _mass(hm: Any) -> str:
    """One line: m_H measured from the driving-point modal mass beside the rig file's, and which was used."""
    if hm is None:
        return "not measured (no clean housing mode at a radial driving point)"
    return (f"measured {hm.measured:.4g}{_args.pm(hm.measured_std)} kg, rig file {hm.rig_file:.4g} kg "
            f"({100 * (hm.measured / hm.rig_file - 1):+.1f} %); used: {hm.source}")


def _rigid(rb: Any) -> str:
    """One line: axial, cross and tilt stiffness of the housing on its bearing, or why not."""
    if rb is None:
        return "-"
    parts = []
    if rb.axial_stiffness is not None:
        parts.append(f"axial {rb.axial_stiffness / 1e6:.3g}{_args.pm(rb.axial_stiffness_std, 1e-6)} MN/m "
                     f"({rb.axial_freq:.1f} Hz)")
    if rb.cross_stiffness is not None:
        parts.append(f"radial-{rb.cross_axis} cross {rb.cross_stiffness / 1e6:.3g}"
                     f"{_args.pm(rb.cross_stiffness_std, 1e-6)} MN/m")
    tilts = getattr(rb, "tilt", ())
    for t in tilts:
        parts.append(f"tilt about {t.axis} {t.stiffness / 1e3:.4g}{_args.pm(t.stiffness_std, 1e-3)} kN m/rad "
                     f"({t.freq:.1f} Hz, I {1e6 * t.inertia:.4g} kg mm^2)")
    if len(tilts) < 2:
        why = [r.split(": ", 1)[-1] for r in getattr(rb, "reasons", ()) if r.startswith("tilt stiffness")]
        parts.append("tilt " + ("not identifiable" if not tilts else
                                f"about {'z' if tilts[0].axis == 'x' else 'x'} not identifiable")
                     + (f" ({'; '.join(why)})" if why else ""))
    return ", ".join(parts)


def print_caveats(res: Any) -> None:
    """One stderr line per warning (``warning: ...``) and per note (``note: ...``)."""
    for w in res.warnings:
        print(f"warning: {res.file or '-'}: {w}", file=sys.stderr)
    for n in res.notes:
        print(f"note: {res.file or '-'}: {n}", file=sys.stderr)


def _warn_idle_speed(speed_rpm: float | None, res: Any) -> None:
    """A ``warning:`` line when ``--speed`` can change nothing: its shaft frequency lies above every band
    identified, so no shaft harmonic falls in one (the option's only use is to reject harmonic lines)."""
    if not speed_rpm:
        return
    tops = [b[1] for b in (res.band, getattr(res, "spindle_band", None)) if b is not None]
    if tops and speed_rpm / 60.0 > max(tops):
        print(f"warning: {res.file or '-'}: --speed {speed_rpm:g} rpm: the shaft frequency {speed_rpm / 60.0:.6g} Hz "
              f"lies above the identified band (up to {max(tops):g} Hz): no shaft harmonic falls in it and the "
              "speed changes nothing (is it in rpm?)", file=sys.stderr)


def write_refusal(path: str, file: str, exc: Any) -> None:
    """JSON of a refused match: the one-line error, every candidate, empty warnings."""
    write_json(path, {"file": str(file), "error": exc.message, "warnings": [],
                      "candidates": [dict(c) for c in exc.candidates]})
    commit_staged()  # the refusal is this run's answer: kept although the command fails



def io_paths(args: argparse.Namespace) -> tuple[list[tuple[str, str | None]], list[tuple[str, str | None]], tuple[str, ...]]:
    """The command's input and output files and the labels of its figures (checked before it runs)."""
    return ([("FILE", args.file), ("--rig", args.rig)],
            [("--json", args.json), ("--plot", args.plot)], ("--plot",))


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig stiffness``."""
    from ..io.uff import read_uff58
    from ..rig.stiffness import estimate_stiffness

    if args.speed is not None and not args.speed >= 0:
        raise EmaRigError(f"--speed must be >= 0 rpm, got {args.speed:g}", file=args.file)
    if args.max_order is not None and args.max_order < 2:
        raise EmaRigError(f"--max-order must be >= 2, got {args.max_order}", file=args.file)
    rig = load_rig(args.rig)
    data = read_uff58(args.file, rig=rig, units=args.units)
    data = data.with_meta(file=str(args.file))
    try:
        res = estimate_stiffness(
            data, rig, k_ms=args.k_ms, k_ms_std=args.k_ms_std, speed_rpm=args.speed, selection=args.selection,
            band=None if args.band is None else tuple(args.band), max_order=args.max_order,
            spindle=not args.no_spindle, fit=args.fit, progress=True, damping_model=args.damping_model,
        )
    except MatchingError as exc:
        if args.json:
            write_refusal(args.json, args.file, exc)
        raise
    print(summary(res))
    print_caveats(res)
    _args.note_clipped_band(args.band, res.band, res.file or args.file)
    _warn_idle_speed(args.speed, res)
    if args.json:
        write_json(args.json, res.to_dict())
        print(f"wrote {args.json}")
    if args.plot:
        from ..plot.rig import plot_rig_fit, save_figure

        p = plot_rig_fit(data, res, rig)
        save_figure(p.figure, args.plot)
        print(f"wrote {args.plot}")
    return 0
