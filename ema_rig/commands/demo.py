"""demo: run the bundled campaign in data/ end to end (table, figures, HTML report)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig demo``."""
    parser.add_argument("-o", "--out", default="ema-rig-demo", metavar="DIR",
                        help="output folder (default: ./ema-rig-demo)")
    parser.add_argument("--data", default=None, metavar="DIR",
                        help="folder holding campaign.toml (default: ./data, else the source tree's data/)")
    parser.add_argument("--jobs", "-j", type=int, default=1, metavar="N", help="parallel worker processes")
    parser.add_argument("--force", action="store_true", help="recompute measurements even if unchanged")


def find_data_dir(explicit: str | None = None):
    """The folder with the bundled ``campaign.toml``.

    Looks in ``explicit``, then ``./data``, then the ``data/`` folder of the source tree.
    """
    from pathlib import Path

    from ..errors import EmaRigError

    candidates = [Path(explicit)] if explicit else [Path.cwd() / "data", Path(__file__).resolve().parents[2] / "data"]
    for c in candidates:
        if (c / "campaign.toml").is_file():
            return c
    raise EmaRigError(
        "bundled campaign.toml not found; run from the repository root or pass --data DIR",
        file=str(candidates[0]),
    )


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig demo``."""
    from .campaign import run_campaign

    data = find_data_dir(args.data)
    print(f"ema-rig demo: bundled campaign {data / 'campaign.toml'} -> {args.out}")
    return run_campaign(str(data / "campaign.toml"), args.out, args.jobs, args.force)
