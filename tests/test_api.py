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


# What each top-level name IS, and where the package docstring says it comes from. Written out
# by hand (not derived from ema_rig._LAZY), so a wrong lazy table or a sub-package that shadows a
# function fails here.
_FUNCTIONS = {
    "load_rig": "ema_rig.config",
    "read_uff58": "ema_rig.io.uff",
    "write_uff58": "ema_rig.io.uff",
    "identify": "ema_rig.identification",
    "estimate_stiffness": "ema_rig.rig.stiffness",
    "calibrate": "ema_rig.rig.stiffness",
    "load_campaign": "ema_rig.campaign",
    "run_campaign": "ema_rig.campaign:run",
}
_CLASSES = {"FRFData": "ema_rig.frf", "DOF": "ema_rig.dof", "RigConfig": "ema_rig.config"}
_ERRORS = ("ConfigError", "IdentificationError", "InversionError", "MatchingError", "UFFError")
_WARNINGS = ("IdentificationWarning", "UnitWarning")


def _home(spec: str, name: str) -> object:
    import importlib

    mod, _, attr = spec.partition(":")
    return getattr(importlib.import_module(mod), attr or name)


def test_every_top_level_name_is_what_it_says() -> None:
    import inspect

    listed = set(_FUNCTIONS) | set(_CLASSES) | set(_ERRORS) | set(_WARNINGS) | {"EmaRigError", "__version__"}
    assert set(ema_rig.__all__) == listed  # a new public name needs a line above
    for name, spec in _FUNCTIONS.items():
        obj = getattr(ema_rig, name)
        assert inspect.isfunction(obj), f"ema_rig.{name} is {obj!r}, not a function"
        assert obj is _home(spec, name), name
    for name, spec in _CLASSES.items():
        obj = getattr(ema_rig, name)
        assert inspect.isclass(obj) and obj is _home(spec, name), name
    assert issubclass(ema_rig.EmaRigError, Exception)
    for name in _ERRORS:
        assert issubclass(getattr(ema_rig, name), ema_rig.EmaRigError), name
    for name in _WARNINGS:
        assert issubclass(getattr(ema_rig, name), UserWarning), name
    assert isinstance(ema_rig.__version__, str) and ema_rig.__version__
    # the main steps take what the pipeline hands them
    assert list(inspect.signature(ema_rig.identify).parameters)[0] == "data"
    assert list(inspect.signature(ema_rig.estimate_stiffness).parameters)[:2] == ["data", "rig"]
    assert list(inspect.signature(ema_rig.read_uff58).parameters)[0] == "path"


def test_no_top_level_name_is_also_a_submodule() -> None:
    # ema_rig.identify used to be both the function and a sub-package: importing the sub-package
    # replaced the function on the package (issue 8, item 9)
    import pkgutil

    submodules = {m.name for m in pkgutil.iter_modules(ema_rig.__path__)}
    assert not submodules & set(ema_rig.__all__), submodules & set(ema_rig.__all__)


def test_identify_stays_the_function_after_importing_the_subpackage() -> None:
    # a fresh interpreter, in the README's import order, then every sub-module of identification
    code = (
        "import inspect, pkgutil, importlib\n"
        "from ema_rig import identify as first\n"
        "import ema_rig.identification.plscf\n"
        "from ema_rig.identification import identify as home\n"
        "import ema_rig.identification as pkg\n"
        "for m in pkgutil.iter_modules(pkg.__path__): importlib.import_module('ema_rig.identification.' + m.name)\n"
        "from ema_rig import identify\n"
        "import ema_rig\n"
        "assert inspect.isfunction(identify), identify\n"
        "assert identify is first is home is ema_rig.identify\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_dir_shows_the_lazy_names() -> None:
    names = dir(ema_rig)
    assert set(ema_rig.__all__) <= set(names)
    assert names == sorted(names)


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


def test_result_reprs_are_short():
    """Notebook printing: a result's repr is a summary (one line per mode), not its arrays."""
    from pathlib import Path

    from ema_rig import identify, load_rig
    from ema_rig.io.uff import read_uff58
    from ema_rig.rig.stiffness import estimate_stiffness

    data_dir = Path(__file__).resolve().parent.parent / "data"
    rig = load_rig(data_dir / "rig.toml")
    data = read_uff58(data_dir / "b6302_1000N_1200rpm.uff", rig=rig)
    ident = identify(data, band=(150.0, 1000.0))
    res = estimate_stiffness(data, rig)
    for obj, limit in ((ident, 120 * (ident.modes.n_modes + 2)), (ident.modes, 400), (ident.poles, 200),
                       (ident.stabilization, 300), (res, 600), (res.match, 200)):
        text = repr(obj)
        assert len(text) < limit, (type(obj).__name__, len(text))
    assert "MN/m" in repr(res) and "measured" in repr(res)
    assert f"{ident.modes.n_modes} modes" in repr(ident)
    assert "<table>" in ident._repr_html_()
