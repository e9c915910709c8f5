"""demo: run the bundled campaign in data/ end to end (table, figures, HTML report)."""

from __future__ import annotations

import argparse
import os

from . import _args


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig demo``."""
    parser.add_argument("-o", "--out", default="ema-rig-demo", metavar="DIR",
                        help="output folder (default: ./ema-rig-demo)")
    parser.add_argument("--data", default=None, metavar="DIR",
                        help="folder holding campaign.toml (default: ./data, else the source tree's data/)")
    parser.add_argument("--jobs", "-j", type=_args.positive_int, default=min(4, os.cpu_count() or 1), metavar="N",
                        help="parallel worker processes (default: the machine's cores, at most 4)")
    parser.add_argument("--force", action="store_true", help="recompute measurements even if unchanged")


def find_data_dir(explicit: str | None = None):
    """The folder with the bundled ``campaign.toml``, or None.

    Looks in ``explicit`` (an error if it has no campaign), then ``./data``, then the ``data/``
    folder of the source tree.
    """
    from pathlib import Path

    from ..errors import EmaRigError

    if explicit:
        if not (Path(explicit) / "campaign.toml").is_file():
            raise EmaRigError("no campaign.toml in this folder", file=explicit)
        return Path(explicit)
    for c in (Path.cwd() / "data", Path(__file__).resolve().parents[2] / "data"):
        if (c / "campaign.toml").is_file() and (c / "rig.toml").is_file():
            return c
    return None


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig demo``."""
    from pathlib import Path

    from .campaign import run_campaign

    data = find_data_dir(args.data)
    if data is None:  # installed without the source tree: regenerate the (seeded) bundled data
        from ..demo_data import generate

        data = Path(args.out) / "data"
        print(f"ema-rig demo: no bundled data/ here; generating the seeded campaign into {data}")
        generate(data)
    print(f"ema-rig demo: bundled campaign {data / 'campaign.toml'} -> {args.out}")
    return run_campaign(str(data / "campaign.toml"), args.out, args.jobs, args.force)
