"""modes: the physical modes of a measurement, selected automatically from the PolyMAX stabilization."""

from __future__ import annotations

import argparse
from typing import Any

from .._atomic import atomic_path, check_outputs, write_json
from ..errors import EmaRigError
from ..processing import processing_history
from ._ident_args import add_identification_arguments, load_and_identify, print_warnings


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig modes``."""
    add_identification_arguments(parser)
    parser.add_argument("--json", default=None, metavar="OUT", help="write the modes as JSON")
    parser.add_argument("--save-selection", default=None, metavar="JSON",
                        help="write the selection (replayable with --selection)")
    parser.add_argument("--plot", default=None, metavar="PNG",
                        help="draw measured vs synthesised FRFs (png, svg or pdf)")
    parser.add_argument("--crosscheck", action="store_true",
                        help="also run sdypy-EMA's LSCF on the same band and print a per-mode agreement table")
    parser.add_argument("--uff55", default=None, metavar="OUT",
                        help="write the modes as UFF dataset 55 (complex mode shapes) for other modal tools")
    parser.add_argument("--geometry", default=None, metavar="UFF",
                        help="test geometry (UFF datasets 15/2411 nodes, 82 trace lines) for --shapes")
    parser.add_argument("--shapes", default=None, metavar="PREFIX",
                        help="draw each mode shape to PREFIX_<n>.png (3D on --geometry, else bars per DOF)")
    parser.add_argument("--automac", default=None, metavar="PNG", help="draw the AutoMAC matrix of the modes")



def io_paths(args: argparse.Namespace) -> tuple[list[tuple[str, str | None]], list[tuple[str, str | None]], tuple[str, ...]]:
    """The command's input and output files and the labels of its figures (checked before it runs).

    ``--shapes PREFIX`` stands for its first figure ``PREFIX_1.png`` (the others share its folder).
    """
    return ([("FILE", args.file), ("--rig", args.rig), ("--selection", args.selection), ("--geometry", args.geometry)],
            [("--json", args.json), ("--save-selection", args.save_selection), ("--plot", args.plot), ("--uff55", args.uff55), ("--automac", args.automac),
             ("--shapes", args.shapes and f"{args.shapes}_1.png")],
            ("--plot", "--automac", "--shapes"))


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig modes``."""
    import numpy as np

    from ..identification.window_damping import with_window_damping
    from ..mode_shapes import mode_shapes_records

    geometry = None
    if args.geometry:  # read before the identification: a wrong file is refused in a second, not after it
        from ..io.geometry import read_geometry

        geometry = read_geometry(args.geometry)

    def writable(data: Any) -> None:  # what --uff55 cannot hold, refused before the identification
        if args.uff55:
            from ..io.uff55 import check_uff55_dofs

            try:
                check_uff55_dofs(data.out_dofs)
            except ValueError as exc:
                raise EmaRigError(f"--uff55: {exc}", file=args.file) from None

    data, ident = load_and_identify(args, before=writable)
    if args.shapes:  # PREFIX_<n>.png: known once the modes are; checked before anything is written

        ins, outs, figures = io_paths(args)
        check_outputs(ins, [o for o in outs if o[0] != "--shapes"] + [("--shapes", f"{args.shapes}_{k + 1}.png") for k in range(ident.modes.n_modes)],
                      figures)
    records = ident.to_records()
    for rec, shp in zip(records, mode_shapes_records(ident.modes), strict=True):
        rec["mode_shape"] = {k: shp[k] for k in ("reference", "normalisation", "unit", "shape")}
    drive = [str(d) for d in ident.modes.in_dofs if d in ident.modes.out_dofs]
    fit = ident.fit_error
    line_err = with_window_damping(ident.modes).line_error(data)  # against the FRFs as measured (windowed)
    print(f"file   {args.file}")
    print(f"data   {data.n_out} outputs x {data.n_in} reference(s), band {ident.band[0]:g}-{ident.band[1]:g} Hz, "
          f"orders {min(ident.poles.orders)}-{max(ident.poles.orders)} "
          f"({'converged' if ident.converged else 'NOT converged'}), "
          f"synthesis error median {100 * float(np.median(fit)):.1f} %, max {100 * float(np.max(fit)):.1f} %, "
          f"per line (median over the lines) {100 * float(np.nanmedian(line_err)):.0f} %")
    for note in ident.notes:
        print(f"note   {note}")
    ref = ident.refinement
    if ref is not None and ref.converged:
        print(f"note   ML refinement converged; noise from {ref.noise_source}; +/- from the Fisher information "
              "(noise only, not model error); modes it could not refine keep the default uncertainty")
    elif ref is not None:
        print(f"note   ML refinement fell back to the default estimate ({ref.reason})")
    print(f"note   +/- = {ident.std_label} (the order spread on the chart is no uncertainty)")
    head = (f"{'f_n [Hz]':>10} {'+/- [Hz]':>9} {'zeta [%]':>9} {'+/- [%]':>8} {'MPC':>6} {'poles':>5} "
            f"{'orders':>9}")
    head += "".join(f" {'m_eff ' + d + ' [kg]':>17}" for d in drive)
    print(head)
    for r in records:
        span = f"{r['order_min']}-{r['order_max']}" if r["order_min"] else "-"
        line = (f"{r['natural_freq']:>10.3f} {r['natural_freq_std']:>9.2g} {100 * r['damping_ratio']:>9.3f} "
                f"{100 * r['damping_ratio_std']:>8.2g} {r['mpc']:>6.3f} {r['n_poles'] or 0:>5d} {span:>9}")
        line += "".join(f" {r['modal_mass'][d]:>17.4g}" for d in drive)
        print(line)
    rejected = [c for c in ident.candidates if not c.accepted and c.mode.n_poles >= 4]
    if rejected:
        print(f"rejected candidates ({len(rejected)} stable at 4 or more orders):")
        for c in rejected:
            print(f"  {c.natural_freq:>10.2f} Hz  zeta {100 * c.damping_ratio:.2f} %  {c.reason}")
    print_warnings(ident, args.file)
    cross = None
    if args.crosscheck:
        from ..identification.crosscheck import crosscheck

        cross = crosscheck(data, ident)
        print(cross.table())
    if args.json:
        doc = {
            "file": str(args.file),
            "band": list(ident.band),
            "max_order": int(max(ident.poles.orders)),
            "converged": bool(ident.converged),
            "transposed": bool(ident.transposed),
            "in_dofs": [str(d) for d in ident.modes.in_dofs],
            "out_dofs": [str(d) for d in ident.modes.out_dofs],
            "modes": records,
            "std": ident.std_label,
            "candidates": [c.to_dict() for c in ident.candidates],
            "fit_error": fit.tolist(),
            "fit_error_median": float(np.median(fit)),
            "line_error": [[None if not np.isfinite(v) else float(v) for v in row] for row in line_err],
            "warnings": list(ident.warnings),
            "notes": list(ident.notes),
            "refinement": None if ref is None else {
                "converged": bool(ref.converged), "reason": ref.reason, "noise_source": ref.noise_source,
                "chi2_red": float(ref.chi2_red), "n_iter": int(ref.n_iter),
            },
            "selection": ident.selection.to_dict(),
            "processing": _processing(data),  # issue 18: window, averages, usable band (dataset 1858)
        }
        if cross is not None:  # issue 18: the flags and the peer's extra modes, for scripts
            doc["crosscheck"] = cross.to_dict()
        write_json(args.json, doc)
        print(f"wrote {args.json}")
    if args.plot:
        from ..plot.synthesis import plot_synthesis

        chart = plot_synthesis(data, ident.modes)
        with atomic_path(args.plot) as tmp:
            chart.figure.savefig(tmp, dpi=110)
        print(f"wrote {args.plot}")
    if args.uff55:
        from ..io.uff55 import write_uff55

        write_uff55(args.uff55, ident.modes, name=f"ema_rig modes of {args.file}")
        print(f"wrote {args.uff55}")
    if args.automac:
        from ..plot.shapes import plot_automac

        am = plot_automac(ident.modes)
        with atomic_path(args.automac) as tmp:
            am.figure.savefig(tmp, dpi=110)
        print(f"wrote {args.automac}")
    if args.shapes:
        from ..plot.shapes import plot_mode_shape

        if geometry is not None:
            from ..io.geometry import match_notes

            for note in match_notes(geometry, ident.modes.out_dofs):
                print(f"note   geometry {args.geometry}: {note}")
        for k in range(ident.modes.n_modes):
            out = f"{args.shapes}_{k + 1}.png"
            sp = plot_mode_shape(ident.modes, k, geometry=geometry)
            with atomic_path(out) as tmp:
                sp.figure.savefig(tmp, dpi=110)
            print(f"wrote {out}")
    if args.save_selection:
        ident.selection.to_json(args.save_selection)
        print(f"wrote {args.save_selection}")
    return 0


def _processing(data: object) -> dict[str, object] | None:
    """The data's processing history as JSON (None when the file records none)."""
    hist = processing_history(data)
    return None if hist is None else hist.to_dict()
