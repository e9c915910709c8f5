"""frf: FRFs and coherence (UFF58) from force and response time histories.

Reads the time histories of a UFF file (dataset 58, function type 1; ordinate type 13 = force,
12/11/8 = response), estimates H1, H2 or Hv with the chosen window and averaging, and writes one
FRF dataset (function type 4) per (response, force) pair followed by one coherence dataset
(function type 6) per pair, atomically. A DOF written several times is several records
(impacts), averaged.
"""

from __future__ import annotations

import argparse
import warnings
from dataclasses import replace
from typing import Any

from .._atomic import atomic_path
from ..config import load_rig
from ..errors import IdentificationWarning, UFFError, UnitWarning
from ..io import _uff_1858
from ..processing import ANTI_ALIAS_FRACTION, ProcessingHistory, usable_band, window_code
from ._args import nonneg_float, number, positive_float, positive_int

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
    parser.add_argument("--segment", type=positive_int, default=None, metavar="N",
                        help="samples per segment (FFT length); default: the whole record for rect "
                             "and impact windows, a quarter of it (at most 2^20) otherwise")
    parser.add_argument("--overlap", type=nonneg_float, default=None, metavar="F",
                        help="overlap of consecutive segments, 0 <= F < 1 (default 0.5 for tapered "
                             "windows, 0 for rect and impact windows)")
    parser.add_argument("--force-width", type=positive_float, default=None, metavar="S",
                        help="force window length in seconds (default: 1/10 of the segment)")
    parser.add_argument("--exp-end", type=number(float, lo=0.0, lo_open=True, hi=1.0), default=0.01, metavar="V",
                        help="exponential window value at the end of the segment (default 0.01)")
    parser.add_argument("--rig", metavar="R", help="rig file (TOML): sensors, signs and excitations")
    parser.add_argument("--binary", action="store_true", help="write the FRFs as binary 58b")



def io_paths(args: argparse.Namespace) -> tuple[list[tuple[str, str | None]], list[tuple[str, str | None]]]:
    """The command's input and output files (checked against each other before it runs)."""
    return ([("TIME.uff", args.file), ("--rig", args.rig)],
            [("-o", args.output)])
def _crest(force: object) -> float:
    """Crest factor (peak / RMS about each channel's mean) of forces (n_in, n_samples), in blocks (no copy)."""
    import numpy as np

    a = np.asarray(force, dtype=np.float64)
    peak, sq = 0.0, 0.0
    with np.errstate(over="ignore", invalid="ignore"):  # values near the float limit: an inf RMS gives 0
        for ch in a:
            mean = float(ch.mean())
            for k in range(0, ch.size, 1 << 20):
                b = ch[k : k + (1 << 20)] - mean
                peak = max(peak, float(np.abs(b).max(initial=0.0)))
                sq += float(b @ b)
        return peak / max(float(np.sqrt(sq / max(a.size, 1))), np.finfo(float).tiny)


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig frf``."""
    import numpy as np

    from ..io._uff58_coherence import coherence_bytes
    from ..io._uff_write import date_id
    from ..io.time_data import read_time_uff
    from ..io.uff import write_uff58
    from ..spectral import estimate_frf

    rig = None
    if args.rig:
        rig = load_rig(args.rig)
    td = read_time_uff(args.file, rig=rig)
    window = args.window
    if window is None:
        crest = _crest(td.force[0])
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
    td_text, td_notes, td_fs, td_warnings = repr(td), td.notes, td.fs, td.warnings
    del td  # the time records (views of the file's bytes) are not needed for writing: free them
    date = date_id()
    # issue 18: the processing history travels with the FRFs as dataset 1858 (one before each 58)
    history = _history(est, td_fs)
    n_frf = data.n_out * data.n_in
    coh = b"".join(
        _uff_1858.dataset_bytes(history, record=n_frf + 1 + i * data.n_in + j)
        + coherence_bytes(data.freq, est.coherence[i, j], response=o, reference=q,
                          ids=(f"{o} / {q} coherence", "ema_rig", date, f"averages: {est.n_averages}", "NONE"))
        for i, o in enumerate(data.out_dofs) for j, q in enumerate(data.in_dofs)
    )
    assumed = any("no unit label and no dataset 164" in n for n in td_notes)
    with atomic_path(args.output) as tmp:
        # an assumed unit is never written as if it were the file's label
        write_uff58(tmp, data, binary=args.binary, rig=rig, history=history, labelled=not assumed)
        with open(tmp, "ab") as fh:
            fh.write(coh)
    print(f"file   {args.file}: {td_text}")
    print(f"frf    {est.estimator}, {est.window} window, {est.n_averages} average(s) of {est.segment} samples "
          f"(overlap {est.overlap:g}), {data.n_freq} lines {data.freq[0]:g}-{data.freq[-1]:g} Hz, "
          f"{data.frf_form}")
    for i, o in enumerate(data.out_dofs):
        for j, q in enumerate(data.in_dofs):
            c = est.coherence[i, j]
            print(f"  {o} / {q}: coherence median {np.median(c):.3f}, min {c.min():.3f}")
    for note in td_notes:
        print(f"note   {note}")
    if assumed:
        warnings.warn(f"{args.file}: time histories without unit labels or dataset 164: force taken as N and response as SI "
                      f"({data.unit_str}); the FRF file carries no unit label either (give its unit with --units "
                      "when reading it)", UnitWarning, stacklevel=1)
    for w in td_warnings:  # the rig and the file disagree on a sign: as read_uff58's meta["warnings"]
        warnings.warn(f"{args.file}: {w}", UnitWarning, stacklevel=1)
    for w in est.warnings:
        warnings.warn(f"{args.file}: {w}", IdentificationWarning, stacklevel=1)
    print(f"band   usable up to {history.band[1]:g} Hz ({ANTI_ALIAS_FRACTION:g} x fs/2, the anti-alias limit), "
          "written with the window and averaging as dataset 1858 (ema-rig modes stays in that band and removes "
          "an exponential window's damping)")
    print(f"wrote {args.output}")
    return 0


def _history(est: Any, fs: float) -> Any:
    """The :class:`~ema_rig.processing.ProcessingHistory` of an estimate (band: up to the anti-alias limit)."""
    h = ProcessingHistory(
        window=est.window, window_code=window_code(est.window), exp_decay=float(est.added_damping),
        n_samples=int(est.segment), n_averages=int(est.n_averages), overlap=float(est.overlap),
        estimator=est.estimator, fs=float(fs), source="ema_rig frf",
    )
    hi = usable_band(h)
    assert hi is not None  # fs is known
    return replace(h, band=(float(est.frf.freq[0]), min(hi, float(est.frf.freq[-1]))))
