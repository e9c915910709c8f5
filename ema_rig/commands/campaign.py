"""campaign: a whole campaign from its TOML file: table, figures and an HTML report."""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

from .._text import std_text
from ..campaign import load_campaign
from ..campaign import run as run_files
from ..cli import EXIT_ERROR, EXIT_OK, EXIT_PARTIAL
from ..errors import EmaRigError
from . import _args

#: Finished rows, figures and the report stay when a later row fails (the runner manages its folder).
OUTPUTS_ON_FAILURE = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig campaign``."""
    parser.add_argument("campaign", metavar="CAMPAIGN.toml", help="campaign file")
    parser.add_argument("-o", "--out", default=None, metavar="DIR",
                        help="output folder (default: <campaign stem>-out beside the campaign file)")
    parser.add_argument("--jobs", "-j", type=_args.positive_int, default=1, metavar="N",
                        help="parallel worker processes (default 1)")
    parser.add_argument("--force", action="store_true", help="recompute measurements even if unchanged")


def _cell(v: Any, kind: str) -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return "-"
    if kind == "MN":
        return f"{v / 1e6:.2f}"
    if kind == "MN±":  # an uncertainty: two significant digits, never a rounded 0.00
        return std_text(v / 1e6)
    if kind == "f":
        return f"{v:.1f}"
    if kind == "g":
        return f"{v:g}"
    if kind == "n":
        return str(len(v)) if isinstance(v, (list, tuple)) else "-"
    return str(v)


def print_table(result: Any) -> None:
    """Print the campaign table (k_TB in MN/m) to stdout."""
    cols = [("id", "id", "s"), ("bearing", "bearing", "s"), ("load N", "radial_load", "g"),
            ("rpm", "speed", "g"), ("pos", "shaft_position", "g"), ("rep", "repeat", "g"),
            ("k_TB MN/m", "k_TB", "MN"), ("± meas.", "k_TB_std_measured", "MN±"), ("± total", "k_TB_std", "MN±"),
            ("f_H Hz", "housing_freq", "f"), ("warn", "warnings", "n"), ("status", "status", "s")]
    table = [[h for h, _, _ in cols]]
    errors = []
    warned = []
    for r in result.rows:
        table.append([_cell(r.get(k), kind) for _, k, kind in cols])
        if r["status"] != "ok":
            errors.append(f"  {r['id']}: {r['error']}")
        warned += [f"  {r['id']}: {w}" for w in (r.get("warnings") or ())]
    widths = [max(len(row[i]) for row in table) for i in range(len(cols))]
    for j, row in enumerate(table):
        print("  ".join(c.rjust(w) if cols[i][2] != "s" else c.ljust(w) for i, (c, w) in enumerate(zip(row, widths, strict=True))))
        if j == 0:
            print("  ".join("-" * w for w in widths))
    print("± meas.: from the identified housing frequency (and the housing mass where the measured one was used); "
          "± total: with the rig-file tolerances and model-form terms (one standard uncertainty)")
    if warned:
        print("warnings:")
        print("\n".join(warned))
    if errors:
        print("failed measurements:")
        print("\n".join(errors))


def run_campaign(campaign: str, out: str | None, jobs: int, force: bool) -> int:
    """Run a campaign file and print the outcome; shared by ``campaign`` and ``demo``."""
    if jobs < 1:
        raise EmaRigError(f"--jobs must be >= 1, got {jobs}", file=campaign)
    cfg = load_campaign(campaign)
    out_dir = Path(out) if out else Path(campaign).with_name(Path(campaign).stem + "-out")
    result = run_files(cfg, out_dir=out_dir, jobs=jobs, force=force, progress=True)
    print_table(result)
    calibrated = result.calibration is not None and result.calibration.get("status") == "ok"
    k_ms_std = "" if not result.k_MS_std else f" ± {std_text(result.k_MS_std / 1e6)} (total)"
    print(f"\n{len(result.rows) - result.n_failed}/{len(result.rows)} measurements ok "
          f"({result.computed} computed, {result.reused} reused); k_MS = {result.k_MS / 1e6:.2f}{k_ms_std} MN/m "
          f"({'steel-disk calibration' if calibrated else 'rig file'})")
    per_measurement = [k for k in result.files if "/" in k]  # "<id>/<kind>": one line for them all
    for kind, path in result.files.items():
        if "/" not in kind:
            print(f"  {kind:<24} {path}")
    if per_measurement:
        print(f"  {'measurement figures':<24} {len(per_measurement)} in {out_dir / 'measurements'}")
    if result.calibration is not None and result.calibration.get("status") != "ok":
        print(f"error: {campaign}: calibration failed: {result.calibration.get('error')}", file=sys.stderr)
        return EXIT_PARTIAL
    if result.n_failed == len(result.rows):
        print(f"error: {campaign}: every measurement failed", file=sys.stderr)
        return EXIT_ERROR
    if result.n_failed:
        print(f"error: {campaign}: {result.n_failed} of {len(result.rows)} measurements failed "
              "(partial failure)", file=sys.stderr)
        return EXIT_PARTIAL
    return EXIT_OK


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig campaign``."""
    return run_campaign(args.campaign, args.out, args.jobs, args.force)
