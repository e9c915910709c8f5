"""Generate the bundled synthetic campaign in ``data/`` (seeded, reproducible).

Run from the repository: ``python data/make_data.py``. What it writes is described in
:mod:`ema_rig.demo_data` (steel disk, dummy bearing at 4 loads x 2 repeats, the 6302 under load,
speed and shaft position, the truth beside every file, ``rig.toml`` and ``campaign.toml``).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))  # run from a source checkout without installing

from ema_rig.demo_data import generate  # noqa: E402


def _say(text: str) -> None:
    sys.stdout.write(text + "\n")


def main() -> int:
    """Write every file into ``data/``; prints one line per file."""
    generate(HERE, say=_say)
    total = sum(p.stat().st_size for p in HERE.iterdir() if p.is_file())
    _say(f"{total / 1e6:.2f} MB in {HERE}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
