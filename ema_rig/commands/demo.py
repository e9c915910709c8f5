"""demo: run the bundled campaign in data/ end to end (table, figures, HTML report)."""

from __future__ import annotations

import argparse
import os
import stat
from pathlib import Path

from .._atomic import make_folder, write_text
from ..errors import EmaRigError
from . import _args
from .campaign import run_campaign

#: A campaign (see ``campaign``): its finished outputs stay when a later step fails.
OUTPUTS_ON_FAILURE = True


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig demo``."""
    parser.add_argument("-o", "--out", default="ema-rig-demo", metavar="DIR",
                        help="output folder (default: ./ema-rig-demo)")
    parser.add_argument("--data", default=None, metavar="DIR",
                        help="folder holding campaign.toml (default: ./data, else the source tree's data/)")
    parser.add_argument("--jobs", "-j", type=_args.positive_int, default=min(4, os.cpu_count() or 1), metavar="N",
                        help="parallel worker processes (default: the machine's cores, at most 4)")
    parser.add_argument("--force", action="store_true", help="recompute measurements even if unchanged")


def find_data_dir(explicit: str | None = None) -> Path | None:
    """The folder with the bundled ``campaign.toml``, or None.

    Looks in ``explicit`` (an error if it has no campaign), then ``./data``, then the ``data/``
    folder of the source tree.
    """
    if explicit:
        if not (Path(explicit) / "campaign.toml").is_file():
            raise EmaRigError("no campaign.toml in this folder", file=explicit)
        return Path(explicit)
    for c in (Path.cwd() / "data", Path(__file__).resolve().parents[2] / "data"):
        if (c / "campaign.toml").is_file() and (c / "rig.toml").is_file():
            return c
    return None


#: File that marks a folder as made by ``ema-rig demo`` (it may write there again).
MARKER = ".ema-rig-demo"


def claim_folder(out: str | os.PathLike[str]) -> Path:
    """Make sure ``out`` is a folder ``demo`` may write into: new, empty, or made by demo before.

    A new or empty folder gets the marker file :data:`MARKER`; a folder with anything else in it
    and no marker is the user's and is refused, so the demo never writes (or regenerates its
    data) over a user's files.

    Raises
    ------
    EmaRigError
        Naming the folder.
    """
    out = Path(out)
    existed = os.path.lexists(out)
    make_folder(out)
    marker = out / MARKER
    try:
        mode = os.lstat(marker).st_mode
    except FileNotFoundError:
        mode = None
    if mode is not None and stat.S_ISREG(mode):
        return out
    if mode is None and existed:
        with os.scandir(out) as entries:
            existed = any(True for _ in entries)
    if mode is not None or existed:
        raise EmaRigError("folder is not empty and was not made by 'ema-rig demo' (no regular "
                          f"{MARKER} marker file in it); demo writes only into a new or empty folder "
                          "or its own: choose another -o", file=out)
    write_text(marker, "made by 'ema-rig demo': it may write here again\n")
    return out


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig demo``."""
    data = find_data_dir(args.data)
    claim_folder(args.out)
    if data is None:  # installed without the source tree: regenerate the (seeded) bundled data
        from ..demo_data import generate

        data = Path(args.out) / "data"
        print(f"ema-rig demo: no bundled data/ here; generating the seeded campaign into {data}")
        generate(data)
    print(f"ema-rig demo: bundled campaign {data / 'campaign.toml'} -> {args.out}")
    return run_campaign(str(data / "campaign.toml"), args.out, args.jobs, args.force)
