"""Options and data loading shared by ``ema-rig modes`` and ``ema-rig stabilization``."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from ..config import load_rig
from ..errors import BandError, EmaRigError, IdentificationError
from . import _args


def add_identification_arguments(parser: argparse.ArgumentParser) -> None:
    """FILE, --rig, --band, --max-order and the selection options."""
    parser.add_argument("file", metavar="FILE", help="UFF58 file with the FRFs")
    parser.add_argument("--rig", default=None, metavar="R",
                        help="rig file (TOML): sensor signs, roles and the default band")
    parser.add_argument("--band", type=_args.finite_float, nargs=2, action=_args.BandAction, default=None,
                        metavar=("LO", "HI"),
                        help="identification band [Hz] (default: the rig file's, else the whole file)")
    parser.add_argument("--max-order", type=_args.model_order, default=None, metavar="N",
                        help="cap on the PolyMAX model order, which grows until the mode set converges "
                             "(default: the rig file's, else 256 for one reference, 160 for several)")
    parser.add_argument("--selection", default=None, metavar="JSON",
                        help="replay a saved mode selection instead of the automatic one")
    _args.add_units_argument(parser)
    parser.add_argument("--refine", action="store_true", default=None,
                        help="maximum-likelihood refinement after PolyMAX: every mode's +/- from the "
                             "Fisher information (noise only, not model error; slower). Default: the rig "
                             "file's [identification] refine, else off")
    parser.add_argument("--averages", type=_args.number(float, lo=1.0), default=None, metavar="N",
                        help="number of averages behind the FRFs and coherence (weights the coherence-based noise of the "
                             "default ML estimate and of --refine; "
                             "default: the rig file's [identification] n_averages)")


def load_and_identify(args: argparse.Namespace,
                      before: Callable[[Any], None] | None = None) -> tuple[Any, Any]:
    """Read the file (with the rig, if given) and run :func:`ema_rig.identification.identify`.

    Returns ``(data, ident)``; ``ident`` carries the identification's warnings plus the data
    findings of :func:`~ema_rig.identification.diagnose.diagnose_file`. A refusal
    (:class:`~ema_rig.errors.IdentificationError`) is re-raised with those findings appended.
    ``before(data)``, when given, runs on the data read and before the identification: a check
    of what the command will need from them (it raises to refuse, before the slow part).
    """
    from ..identification import Selection, identify
    from ..identification.diagnose import diagnose_file
    from ..identification.identification import LOW_CAP_HINT
    from ..io.uff import read_uff58

    if args.max_order is not None and args.max_order < 1:
        raise EmaRigError(f"--max-order must be >= 1, got {args.max_order}", file=args.file)
    rig = load_rig(args.rig) if args.rig else None
    data = read_uff58(args.file, rig=rig, units=args.units)
    data = data.with_meta(file=str(args.file))
    band = tuple(args.band) if args.band is not None else None
    max_order = args.max_order
    if rig is not None:
        ident_cfg = rig.identification
        band = band if band is not None else ident_cfg.get("band")
        max_order = max_order if max_order is not None else ident_cfg.get("max_order")
    refine = getattr(args, "refine", None)
    n_averages = getattr(args, "averages", None)
    if rig is not None:
        refine = refine if refine is not None else rig.identification.get("refine")
        n_averages = n_averages if n_averages is not None else rig.identification.get("n_averages")
    if n_averages is not None:
        data = data.replace(n_averages=float(n_averages))
    selection = Selection.from_json(args.selection) if args.selection else None
    if before is not None:
        before(data)
    try:
        ident = identify(data, band=band, max_order=max_order, selection=selection, progress=True,
                         refine=bool(refine))
    except IdentificationError as exc:
        findings = [f for f in diagnose_file(args.file, data) if f not in exc.message]
        # a wrong band, or an order cap set too low, is not the data's fault
        if LOW_CAP_HINT in exc.message and args.max_order is not None:  # name the option the user gave
            raise IdentificationError(exc.message.replace("max_order=", "--max-order "), file=exc.file) from None
        if not findings or isinstance(exc, BandError) or LOW_CAP_HINT in exc.message:
            raise
        head = "; " if "the measurement itself is suspect" in exc.message else "; the measurement itself is suspect: "
        raise IdentificationError(exc.message + head + "; ".join(findings), file=exc.file) from None
    findings = [f for f in diagnose_file(args.file, data.band(*ident.band)) if f"data: {f}" not in ident.warnings]
    if findings:
        ident = replace(ident, warnings=ident.warnings + tuple(f"data: {f}" for f in findings))
    return data, ident


def print_warnings(ident: Any, file: Any = None) -> None:
    """One ``warning: <file>: …`` line per warning of the identification, on stderr."""
    prefix = f"{file}: " if file else ""
    for w in ident.warnings:
        text = str(w)
        if prefix and text.startswith(prefix):
            text = text[len(prefix):]
        print(f"warning: {prefix}{text}", file=sys.stderr)
