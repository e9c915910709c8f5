"""stabilization: draw the PolyMAX stabilization chart of a measurement."""

from __future__ import annotations

import argparse
from pathlib import Path

from .._atomic import atomic_path
from ._ident_args import add_identification_arguments, load_and_identify, print_warnings


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig stabilization``."""
    add_identification_arguments(parser)
    parser.add_argument("-o", "--output", required=True, metavar="CHART",
                        help="chart file: .png, .svg or .pdf")
    parser.add_argument("--cmif", action="store_true", help="draw the CMIF instead of the sum of FRFs")
    parser.add_argument("--show-unstable", action="store_true", help="also draw the unstable (mathematical) poles")
    parser.add_argument("--colors", default="default", choices=("default", "viridis", "high-contrast"),
                        help="colour scheme")



def io_paths(args: argparse.Namespace) -> tuple[list[tuple[str, str | None]], list[tuple[str, str | None]], tuple[str, ...]]:
    """The command's input and output files and the labels of its figures (checked before it runs)."""
    return ([("FILE", args.file), ("--rig", args.rig), ("--selection", args.selection)],
            [("-o", args.output)], ("-o",))


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig stabilization``."""
    suffix = Path(args.output).suffix.lower()  # a figure format: checked by io_paths before the run
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..plot.stabilization import plot_stabilization

    data, ident = load_and_identify(args)
    print_warnings(ident, args.file)
    lo, hi = ident.band
    margin = 0.05 * (hi - lo)
    shown = data.band(max(lo - margin, data.freq[0]), min(hi + margin, data.freq[-1]))
    chart = plot_stabilization(
        ident.stabilization, shown, selection=ident.selection, mode_freq=ident.natural_freq, indicator="cmif" if args.cmif else "sum",
        show_unstable=args.show_unstable, color_scheme=args.colors, candidates=ident.candidates,
        title=f"{Path(args.file).name}: PolyMAX {lo:g}-{hi:g} Hz, {data.n_out} x {data.n_in}"
              + (" (transposed)" if ident.transposed else "")
              + f", orders to {max(ident.poles.orders)}: mode set "
              + ("converged" if ident.converged else "NOT converged"),
    )
    try:
        with atomic_path(args.output) as tmp:
            chart.figure.savefig(tmp, dpi=130, format=suffix[1:])
    finally:
        plt.close(chart.figure)
    print(f"{len(ident.selection)} modes: " + ", ".join(f"{f:.1f}" for f in ident.natural_freq) + " Hz")
    print(f"wrote {args.output}")
    return 0
