"""inspect: list every dataset of a UFF file (type, DOFs, function type, points, band, units).

Each dataset is shown as ``read`` (exactly the header's num_pts values) or ``refused`` with the
reason. With ``--rig`` the FRF datasets are also assembled with the rig file (roles, signs,
units) and the result is summarised; with ``--json`` the dataset list is written atomically as JSON.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING, Any

from .._atomic import write_json
from ..config import load_rig
from ..errors import EmaRigError, UFFError
from . import _args

if TYPE_CHECKING:
    from ..frf import FRFData

#: The table and ``--json`` are written even when the command exits 1 (a refused dataset).
OUTPUTS_ON_FAILURE = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig inspect``."""
    parser.add_argument("file", metavar="FILE", help="UFF file (dataset 58 / 58b)")
    parser.add_argument("--rig", metavar="R", help="rig file (TOML): also assemble the FRFs with it")
    _args.add_units_argument(parser)
    parser.add_argument("--json", metavar="OUT", help="write the dataset list as JSON")


def _cell(v: object) -> str:
    return "-" if v is None else str(v)


def format_table(report: dict[str, Any]) -> str:
    """The inspect report as a fixed-width text table (one row per dataset)."""
    head = ("#", "type", "function", "response", "reference", "points", "band [Hz or s]", "units", "status")
    rows = []
    for d in report["datasets"]:
        band = d.get("band")
        band_s = f"{band[0]:.6g}..{band[1]:.6g}" if band else "-"
        units = d.get("units") or {}
        if d["type"] == 58:
            u = f"{units.get('ordinate') or '-'} / {units.get('denominator') or '-'} vs {units.get('abscissa') or '-'}"
        elif d["type"] == 164 and units:
            u = str(units.get("unit_description", "-"))
        else:
            u = "-"
        ft = d.get("function_type")
        fn = "-" if ft is None else f"{ft} {d.get('function') or ''}".strip()
        pts = _cell(d["num_pts"]) if d["status"] == "read" else f"({_cell(d.get('num_pts_header'))})"
        status = d["status"] if d["status"] == "read" else f"refused: {d['reason']}"
        typ = "-" if d["type"] is None else f"{d['type']}{'b' if d.get('binary') else ''}"
        rows.append((str(d["index"]), typ, fn, _cell(d["response"]), _cell(d["reference"]),
                     pts, band_s, u, status))
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(head)]
    lines = [report["file"], "  ".join(h.ljust(w) for h, w in zip(head, widths, strict=True)).rstrip()]
    lines.append("  ".join("-" * w for w in widths))
    lines += ["  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in rows]
    n_ref = sum(d["status"] != "read" for d in report["datasets"])
    lines.append(f"{len(rows)} dataset(s), {len(rows) - n_ref} read, {n_ref} refused")
    return "\n".join(lines)


def _coherence_summary(data: FRFData) -> dict[str, Any]:
    """JSON summary of the coherence attached to the FRFs (``attached`` False when none)."""
    coh = data.coherence
    if coh is None:
        return {"attached": False, "datasets": [], "pairs": 0, "of_pairs": data.n_out * data.n_in,
                "min": None, "max": None}
    return {
        "attached": True,
        "datasets": list(data.meta.get("coherence_datasets", ())),
        "pairs": data.n_out * data.n_in,
        "of_pairs": data.n_out * data.n_in,
        "min": float(coh.min()),
        "max": float(coh.max()),
    }


def _coherence_line(c: dict[str, Any], n_avg: float | None) -> str:
    avg = f"; {n_avg:g} averages" if n_avg is not None else "; number of averages not in the file"
    if not c["attached"]:
        return "coherence: none attached"
    ds = ", ".join(str(i) for i in c["datasets"])
    return (f"coherence: attached for {c['pairs']} of {c['of_pairs']} FRFs (dataset(s) {ds}), "
            f"{c['min']:.4g}..{c['max']:.4g} after clipping{avg}")



def io_paths(args: argparse.Namespace) -> tuple[list[tuple[str, str | None]], list[tuple[str, str | None]]]:
    """The command's input and output files (checked against each other before it runs)."""
    return ([("FILE", args.file), ("--rig", args.rig)],
            [("--json", args.json)])


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig inspect``.

    The table goes to stdout (and the JSON to ``--json``) in every case; the exit code is 1, with
    one line on stderr, when a dataset is refused or the FRF datasets cannot be assembled (with
    the rig file when given): duplicate or missing pairs, mismatched axes, units, rig DOFs.
    """
    from ..io.uff import inspect_uff, read_uff58

    rig = load_rig(args.rig) if args.rig else None
    report = inspect_uff(args.file, rig=rig, units=args.units)
    problem: EmaRigError | None = None
    refused = [d for d in report["datasets"] if d["status"] != "read"]
    if refused:
        d = refused[0]
        more = f" (and {len(refused) - 1} more refused)" if len(refused) > 1 else ""
        problem = UFFError(f"refused: {d['reason']}{more}", file=report["file"], dataset=d["index"])
    has_frf = any(d["type"] == 58 and d["function_type"] in (4, None) for d in report["datasets"])
    text = format_table(report)
    if has_frf or rig is not None:
        try:
            data = read_uff58(args.file, rig=rig, units=args.units)
        except EmaRigError as exc:
            problem = problem or exc
        else:
            report["frf"] = {
                "shape": list(data.shape),
                "frf_form": data.frf_form,
                "unit": data.unit_str,
                "out_dofs": [str(d) for d in data.out_dofs],
                "in_dofs": [str(d) for d in data.in_dofs],
                "roles": list(data.roles),
                "axes": list(data.axes),
                "unit_decisions": list(data.meta["unit_decisions"]),
                "sign_flips": list(data.meta["sign_flips"]),
                "ignored_channels": list(data.meta["ignored_channels"]),
                "coherence": _coherence_summary(data),
                "n_averages": data.n_averages,
                "warnings": list(data.meta.get("warnings", ())),
            }
            text += f"\nFRFs{' with rig ' + str(args.rig) if rig else ''}: {data!r}\n  outputs: " + ", ".join(
                str(d) + (f" ({r}, {a})" if r else "")
                for d, r, a in zip(data.out_dofs, data.roles, data.axes, strict=True)
            )
            text += "\n  inputs: " + ", ".join(str(d) for d in data.in_dofs)
            text += "".join(f"\n  units: {u}" for u in data.meta["unit_decisions"])
            text += "".join(f"\n  sign: {s}" for s in data.meta["sign_flips"])
            text += "\n  " + _coherence_line(report["frf"]["coherence"], data.n_averages)
            text += "".join(f"\n  note: {n}" for n in data.meta.get("notes", ()) if "coherence" in n)
            text += "".join(f"\n  warning: {w}" for w in data.meta.get("warnings", ()))
    print(text)
    if args.json:
        write_json(args.json, report)
    if problem is not None:
        raise problem
    return 0
