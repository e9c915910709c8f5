"""Cold start: the command line imports a heavy package only when the command uses it.

Each check runs a fresh interpreter (other tests have imported everything in this one) and lists
the heavy packages found in ``sys.modules`` afterwards.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"
HEAVY = ("numpy", "scipy", "matplotlib", "pandas", "dask", "distributed", "tqdm", "threadpoolctl", "sdypy")


def _heavy_after(code: str) -> list[str]:
    """The heavy top-level packages imported after running ``code`` in a fresh interpreter."""
    probe = (f"{code}\nimport json, sys\n"
             f"print(json.dumps(sorted({{m.split('.')[0] for m in sys.modules}} & set({HEAVY!r}))))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), *sys.path])}
    out = subprocess.run([sys.executable, "-c", probe], env=env, capture_output=True, text=True, check=True,
                         cwd=ROOT).stdout
    return json.loads(out.strip().splitlines()[-1])


def test_cli_import_and_parser_are_light() -> None:
    # `ema-rig --help`, a usage error and every command's start-up: argparse, nothing numerical
    code = "import ema_rig, ema_rig.cli, ema_rig.campaign\nema_rig.cli.build_parser()"
    assert _heavy_after(code) == []
    # the lazy names still resolve, importing what they need
    assert _heavy_after("import ema_rig\nema_rig.FRFData") == ["numpy"]


def test_inspect_reads_a_file_without_scipy_or_plotting() -> None:
    code = (f"from ema_rig.cli import main\n"
            f"assert main(['inspect', {str(DATA / 'disk.uff')!r}, '--rig', {str(DATA / 'rig.toml')!r}]) == 0")
    assert _heavy_after(code) == ["numpy"]
