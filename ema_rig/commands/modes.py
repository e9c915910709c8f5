"""modes: the physical modes of a measurement, selected automatically from the PolyMAX stabilization."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig modes``."""
    from ._ident_args import add_identification_arguments

    add_identification_arguments(parser)
    parser.add_argument("--json", default=None, metavar="OUT", help="write the modes as JSON")
    parser.add_argument("--save-selection", default=None, metavar="JSON",
                        help="write the selection (replayable with --selection)")
    parser.add_argument("--plot", default=None, metavar="PNG",
                        help="draw measured vs synthesised FRFs (png, svg or pdf)")
    parser.add_argument("--crosscheck", action="store_true",
                        help="also run sdypy-EMA's LSCF on the same band and print a per-mode agreement table")


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig modes``."""
    import numpy as np

    from ._ident_args import load_and_identify, print_warnings

    data, ident = load_and_identify(args)
    records = ident.to_records()
    drive = [str(d) for d in ident.modes.in_dofs if d in ident.modes.out_dofs]
    fit = ident.fit_error
    print(f"file   {args.file}")
    print(f"data   {data.n_out} outputs x {data.n_in} reference(s), band {ident.band[0]:g}-{ident.band[1]:g} Hz, "
          f"orders {min(ident.poles.orders)}-{max(ident.poles.orders)} "
          f"({'converged' if ident.converged else 'NOT converged'}), "
          f"synthesis error median {100 * float(np.median(fit)):.1f} %, max {100 * float(np.max(fit)):.1f} %")
    for note in ident.notes:
        print(f"note   {note}")
    head = (f"{'f_n [Hz]':>10} {'+/- [Hz]':>9} {'zeta [%]':>9} {'+/- [%]':>8} {'MPC':>6} {'poles':>5} "
            f"{'orders':>9}")
    head += "".join(f" {'m_eff ' + d + ' [kg]':>17}" for d in drive)
    print(head)
    for r in records:
        span = f"{r['order_min']}-{r['order_max']}" if r["order_min"] else "-"
        line = (f"{r['natural_freq']:>10.2f} {r['natural_freq_std']:>9.3f} {100 * r['damping_ratio']:>9.3f} "
                f"{100 * r['damping_ratio_std']:>8.3f} {r['mpc']:>6.3f} {r['n_poles'] or 0:>5d} {span:>9}")
        line += "".join(f" {r['modal_mass'][d]:>17.4g}" for d in drive)
        print(line)
    rejected = [c for c in ident.candidates if not c.accepted and c.mode.n_poles >= 4]
    if rejected:
        print(f"rejected candidates ({len(rejected)} stable at 4 or more orders):")
        for c in rejected:
            print(f"  {c.natural_freq:>10.2f} Hz  zeta {100 * c.damping_ratio:.2f} %  {c.reason}")
    print_warnings(ident)
    if args.crosscheck:
        from ..identification.crosscheck import crosscheck

        print(crosscheck(data, ident).table())
    if args.json:
        from .._atomic import write_json

        doc = {
            "file": str(args.file),
            "band": list(ident.band),
            "max_order": int(max(ident.poles.orders)),
            "converged": bool(ident.converged),
            "transposed": bool(ident.transposed),
            "in_dofs": [str(d) for d in ident.modes.in_dofs],
            "out_dofs": [str(d) for d in ident.modes.out_dofs],
            "modes": records,
            "candidates": [c.to_dict() for c in ident.candidates],
            "fit_error": fit.tolist(),
            "fit_error_median": float(np.median(fit)),
            "warnings": list(ident.warnings),
            "notes": list(ident.notes),
            "selection": ident.selection.to_dict(),
        }
        write_json(args.json, doc)
        print(f"wrote {args.json}")
    if args.plot:
        from .._atomic import atomic_path
        from ..plot.synthesis import plot_synthesis

        chart = plot_synthesis(data, ident.modes)
        with atomic_path(args.plot) as tmp:
            chart.figure.savefig(tmp, dpi=110)
        print(f"wrote {args.plot}")
    if args.save_selection:
        ident.selection.to_json(args.save_selection)
        print(f"wrote {args.save_selection}")
    return 0
