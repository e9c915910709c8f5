"""Package-level API: no import side effects, every public name resolves."""

from __future__ import annotations

import subprocess
import sys

import ema_rig


def test_import_has_no_pyplot_or_sdypy() -> None:
    # a fresh interpreter: other tests may already have imported pyplot in this one
    # numpy installs its own filters on import; snapshot after the dependencies are loaded
    code = (
        "import sys, warnings, numpy, scipy.linalg; f = list(warnings.filters); "
        "import ema_rig, ema_rig.cli; "
        "ema_rig.cli.build_parser(); "
        "bad = [m for m in ('matplotlib.pyplot', 'sdypy', 'sdypy.EMA') if m in sys.modules]; "
        "assert not bad, bad; assert warnings.filters == f, 'warning filters changed'"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_all_names_resolve() -> None:
    for name in ema_rig.__all__:
        assert getattr(ema_rig, name) is not None, name
