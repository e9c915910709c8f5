"""Every parameter of every public function and class is documented in its numpydoc docstring.

python-control's habit (``control/tests/docstrings_test.py``): for each name in the ``__all__`` of
each public module of ema_rig (no ``_`` in the module path; the command modules are the CLI's
internals), every parameter of its signature (``self``, ``*args``, ``**kwargs`` and ``_private``
ones aside) must appear in the docstring's ``Parameters``, ``Other Parameters`` or, for a
dataclass, ``Attributes`` section (``a, b : float`` documents both).

``UNDOCUMENTED`` is the backlog found when the test was written (issue 21); it may only shrink:
an entry that becomes fully documented fails the test until it is removed from the list.
"""

from __future__ import annotations

import importlib
import inspect
import re
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_layers import _modules  # noqa: E402  (the one list of ema_rig's modules)

_SECTION = re.compile(r"^(\s*)(Parameters|Other Parameters|Attributes)\n\1-{3,}\n", re.M)

# the backlog of 2026-11-24 (issue 21): public callables with at least one undocumented parameter
UNDOCUMENTED: frozenset[str] = frozenset({
    "ema_rig.identification.noise.segment_edges",  # new in issue 18 (merged 21:35), to document there
    "ema_rig.campaign.drilldown.figure_key",
    "ema_rig.campaign.drilldown.png_bytes",
    "ema_rig.campaign.outputs.write_if_changed",
    "ema_rig.campaign.result.csv_header",
    "ema_rig.campaign.result.summary_rows",
    "ema_rig.campaign.runner.check_out_folder",
    "ema_rig.campaign.runner.file_digest",
    "ema_rig.campaign.runner.make_pool",
    "ema_rig.campaign.runner.task_key",
    "ema_rig.identification.crosscheck.CrossCheckRow",
    "ema_rig.identification.crosscheck.PeerMode",
    "ema_rig.identification.diagnose.diagnose_frf",
    "ema_rig.identification.identification.default_order_cap",
    "ema_rig.identification.identification.transpose_layout",
    "ema_rig.identification.judge.shape_mpc",
    "ema_rig.identification.plscf.check_data",
    "ema_rig.identification.plscf.default_max_order",
    "ema_rig.identification.stabilization.cluster_poles",
    "ema_rig.identification.stabilization.resolve_selection",
    "ema_rig.io.uff.UFFFile",
    "ema_rig.io.uff.UFFRecord",
    "ema_rig.plot.campaign.measured_std",
    "ema_rig.plot.campaign.figure_stem",
    "ema_rig.plot.campaign.plot_repeatability",
    "ema_rig.plot.campaign.plot_speed_effect",
    "ema_rig.plot.campaign.plot_validation",
    "ema_rig.plot.rig.save_figure",
    "ema_rig.plot.rig.short_reason",
    "ema_rig.plot.stabilization.StabilizationPlot",
    "ema_rig.report.anchor",
    "ema_rig.report.write_report",
    "ema_rig.report.write_report_if_changed",
    "ema_rig.rig.candidates.find_dof",
    "ema_rig.rig.fit.measured_housing_mass",
    "ema_rig.rig.stiffness.default_band",
    "ema_rig.rig.stiffness.mode_source",
    "ema_rig.rig.uncertainty.defaults_note",
    "ema_rig.rig.uncertainty.measured_freq_std",
    "ema_rig.rig.uncertainty.sensitivities",
})


def documented_names(doc: str | None) -> set[str]:
    """The parameter names a numpydoc docstring documents (Parameters / Other Parameters / Attributes)."""
    text = inspect.cleandoc(doc or "")
    names: set[str] = set()
    for m in _SECTION.finditer(text):
        indent = m.group(1)
        lines = text[m.end():].split("\n")
        for k, line in enumerate(lines):
            if not line.strip():
                continue
            if line.startswith(indent + " "):
                continue  # a description line
            if k + 1 < len(lines) and re.fullmatch(r"-{3,}", lines[k + 1].strip()):
                break  # the next section's title
            head = line.strip().split(" : ")[0].rstrip(":")
            names.update(n.strip().lstrip("*") for n in re.split(r",\s*", head))
    return names


def _public_callables() -> list[tuple[str, object]]:
    out = []
    for mod in _modules():
        if any(part.startswith("_") for part in mod.split(".")) or mod.startswith("ema_rig.commands"):
            continue
        m = importlib.import_module(mod)
        for name in getattr(m, "__all__", ()):
            obj = getattr(m, name, None)
            if getattr(obj, "__module__", None) == mod and (inspect.isfunction(obj) or inspect.isclass(obj)):
                out.append((f"{mod}.{name}", obj))
    return out


def missing_parameters(obj: object) -> list[str]:
    """The parameters of ``obj``'s signature its docstring does not document."""
    try:
        sig = inspect.signature(obj)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return []
    params = [p for p, v in sig.parameters.items()
              if p not in ("self", "cls") and not p.startswith("_") and v.kind not in (v.VAR_POSITIONAL, v.VAR_KEYWORD)]
    documented = documented_names(inspect.getdoc(obj) if inspect.isclass(obj) else obj.__doc__)
    return [p for p in params if p not in documented]


def test_the_parser_reads_numpydoc() -> None:
    doc = """Summary.

    Parameters
    ----------
    a, b : float
        Two.
    c : int, optional
        Three
        lines : not a parameter.

    Returns
    -------
    d : float
    """
    assert documented_names(doc) == {"a", "b", "c"}


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_every_public_parameter_is_documented() -> None:
    bad, fixed = [], []
    for qn, obj in _public_callables():
        miss = missing_parameters(obj)
        if miss and qn not in UNDOCUMENTED:
            bad.append(f"{qn}: {', '.join(miss)}")
        if not miss and qn in UNDOCUMENTED:
            fixed.append(qn)
    assert not bad, "parameters missing from the docstring's Parameters section:\n" + "\n".join(bad)
    assert not fixed, "documented now: remove from UNDOCUMENTED in tests/test_docstrings.py:\n" + "\n".join(fixed)
