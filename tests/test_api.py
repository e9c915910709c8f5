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


def test_every_module_all_resolves_and_is_documented() -> None:
    import importlib
    import inspect
    import pkgutil

    missing = []
    for info in pkgutil.walk_packages(ema_rig.__path__, "ema_rig."):
        mod = importlib.import_module(info.name)
        assert mod.__doc__, f"{info.name} has no module docstring"
        for name in getattr(mod, "__all__", []):
            obj = getattr(mod, name)  # AttributeError = a stale __all__ entry
            if (inspect.isfunction(obj) or inspect.isclass(obj)) and not inspect.getdoc(obj):
                missing.append(f"{info.name}.{name}")
    assert not missing, f"public names without a docstring: {missing}"
