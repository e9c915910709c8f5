"""frf: FRFs and coherence (UFF58) from force and response time histories.

Reads the time histories of a UFF file (dataset 58, function type 1; ordinate type 13 = force,
12/11/8 = response), estimates H1, H2 or Hv with the chosen window and averaging, and writes one
FRF dataset (function type 4) per (response, force) pair followed by one coherence dataset
(function type 6) per pair, atomically. A DOF written several times is several records
(impacts), averaged.
"""

from __future__ import annotations

import argparse

_IMPULSIVE_CREST = 8.0


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig frf``."""
    parser.add_argument("file", metavar="TIME.uff", help="UFF file with force and response time histories")
    parser.add_argument("-o", "--output", required=True, metavar="FRF.uff",
                        help="output UFF file (FRF and coherence datasets)")
    parser.add_argument("--estimator", default="H1", choices=("H1", "H2", "Hv"),
                        help="H1 (noise on the response; default), H2 (noise on the force) or Hv")
    parser.add_argument("--window", default=None, metavar="W",
                        help="hann, rect, force, exponential, impact (force window on the force, "
                             "exponential on both) or any scipy.signal window name; default: impact "
                             "when the force is a blow (crest factor > 8), else hann")
    parser.add_argument("--segment", type=int, default=None, metavar="N",
                        help="samples per segment (FFT length); default: the whole record for rect "
                             "and impact windows, a quarter of it otherwise")
    parser.add_argument("--overlap", type=float, default=None, metavar="F",
                        help="overlap of consecutive segments, 0 <= F < 1 (default 0.5 for tapered "
                             "windows, 0 for rect and impact windows)")
    parser.add_argument("--force-width", type=float, default=None, metavar="S",
                        help="force window length in seconds (default: 1/10 of the segment)")
    parser.add_argument("--exp-end", type=float, default=0.01, metavar="V",
                        help="exponential window value at the end of the segment (default 0.01)")
    parser.add_argument("--rig", metavar="R", help="rig file (TOML): sensors, signs and excitations")
    parser.add_argument("--binary", action="store_true", help="write the FRFs as binary 58b")


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig frf``."""
    import warnings

    import numpy as np

    from .._atomic import atomic_path
    from ..errors import IdentificationWarning, UFFError, UnitWarning
    from ..io._uff58_coherence import coherence_bytes
    from ..io._uff_write import date_id
    from ..io.time_data import read_time_uff
    from ..io.uff import write_uff58
    from ..spectral import estimate_frf

    rig = None
    if args.rig:
        from ..config import load_rig

        rig = load_rig(args.rig)
    td = read_time_uff(args.file, rig=rig)
    window = args.window
    if window is None:
        f0 = td.force[0] - td.force[0].mean(axis=-1, keepdims=True)
        crest = float(np.abs(f0).max() / max(float(np.sqrt(np.mean(f0**2))), np.finfo(float).tiny))
        # a random or periodic force has a crest factor below ~5; a hammer blow far above
        window = "impact" if crest > _IMPULSIVE_CREST else "hann"
        print(f"window {window} (force crest factor {crest:.3g}; --window to choose)")
    try:
        est = estimate_frf(
            td.force, td.response, td.fs, in_dofs=td.in_dofs, out_dofs=td.out_dofs, frf_form=td.frf_form,
            estimator=args.estimator, window=window, segment=args.segment, overlap=args.overlap,
            force_width=args.force_width, exp_end=args.exp_end,
            meta={"source": td.source, "time_datasets": dict(td.datasets), "notes": list(td.notes)},
        )
    except ValueError as exc:
        raise UFFError(str(exc), file=args.file) from None
    data = est.frf
    date = date_id()
    coh = b"".join(
        coherence_bytes(data.freq, est.coherence[i, j], response=o, reference=q,
                        ids=(f"{o} / {q} coherence", "ema_rig", date, f"averages: {est.n_averages}", "NONE"))
        for i, o in enumerate(data.out_dofs) for j, q in enumerate(data.in_dofs)
    )
    assumed = any("no unit label" in n for n in td.notes)
    with atomic_path(args.output) as tmp:
        # an assumed unit is never written as if it were the file's label
        write_uff58(tmp, data, binary=args.binary, rig=rig, labelled=not assumed)
        with open(tmp, "ab") as fh:
            fh.write(coh)
    print(f"file   {args.file}: {td!r}")
    print(f"frf    {est.estimator}, {est.window} window, {est.n_averages} average(s) of {est.segment} samples "
          f"(overlap {est.overlap:g}), {data.n_freq} lines {data.freq[0]:g}-{data.freq[-1]:g} Hz, "
          f"{data.frf_form}")
    for i, o in enumerate(data.out_dofs):
        for j, q in enumerate(data.in_dofs):
            c = est.coherence[i, j]
            print(f"  {o} / {q}: coherence median {np.median(c):.3f}, min {c.min():.3f}")
    for note in td.notes:
        print(f"note   {note}")
    if assumed:
        warnings.warn(f"{args.file}: time histories without unit labels: force taken as N and response as SI "
                      f"({data.unit_str}); the FRF file carries no unit label either (give its unit with --units "
                      "when reading it)", UnitWarning, stacklevel=1)
    for w in est.warnings:
        warnings.warn(f"{args.file}: {w}", IdentificationWarning, stacklevel=1)
    print(f"wrote {args.output}")
    return 0
