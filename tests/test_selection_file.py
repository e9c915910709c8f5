"""A hand-edited or foreign mode-selection JSON (``--selection``) is refused by name, never a traceback.

The smoke review (benchmarks/results/smoke_b1a9ba2.txt, part F) fed ``stiffness --selection`` with
mutations of a saved selection: a top-level list or string, a mode that is not an object, an order
of 1e400 (JSON's inf) ended in an AttributeError / OverflowError traceback; a band written as a
string ran as the band '1'..'5' Hz; a NaN pole, a negative or NaN frequency and a max order of -5
ran on silently; an empty mode list failed with 'LSFD needs at least one pole'. Each must be one ``error: <file>: not a valid mode selection: ...`` line.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import pytest

from ema_rig.cli import main
from ema_rig.errors import IdentificationError
from ema_rig.identification.stabilization import SelectedMode, Selection


def _valid() -> dict[str, Any]:
    """A selection as ``to_json`` writes it: one mode at 626 Hz, zeta 2 %, band 150-1000 Hz."""
    wn = 2 * math.pi * 626.0
    mode = SelectedMode(order=38, index=3, pole=complex(-0.02 * wn, wn * math.sqrt(1 - 0.02**2)),
                        natural_freq=626.0, damping_ratio=0.02, natural_freq_std=0.01,
                        damping_ratio_std=1e-4, n_poles=20, participation=(1 + 0j,))
    sel = Selection(modes=(mode,), band=(150.0, 1000.0), max_order=64, in_dofs=("11+Y",))
    return json.loads(sel.to_json())


def _set(path: tuple[Any, ...], value: Any) -> Any:
    def mutate(d: dict[str, Any]) -> Any:
        target: Any = d
        for k in path[:-1]:
            target = target[k]
        target[path[-1]] = value
        return d
    return mutate


MUTATIONS = {
    "top-level list": lambda d: [d],
    "top-level string": lambda d: "sel",
    "mode not an object": _set(("modes", 0), [1, 2]),
    "modes an object": _set(("modes",), {"a": 1}),
    "order 1e400": _set(("modes", 0, "order"), 1e400),
    "n_poles 1e400": _set(("modes", 0, "n_poles"), 1e400),
    "max_order 1e400": _set(("max_order",), 1e400),
    "band a string": _set(("band",), "150-1000"),
    "band of three": _set(("band",), [150.0, 500.0, 1000.0]),
    "band reversed": _set(("band",), [1000.0, 150.0]),
    "band NaN": _set(("band",), [float("nan"), 1000.0]),
    "max_order -5": _set(("max_order",), -5),
    "pole NaN": _set(("modes", 0, "pole"), [float("nan"), float("nan")]),
    "pole below the axis": _set(("modes", 0, "pole"), [-78.7, -3932.0]),
    "natural_freq negative": _set(("modes", 0, "natural_freq"), -626.0),
    "natural_freq NaN": _set(("modes", 0, "natural_freq"), float("nan")),
    "damping inf": _set(("modes", 0, "damping_ratio"), float("inf")),
    "tolerance not a number": _set(("tolerances", "freq_tol"), "x"),
    "in_dofs a number": _set(("in_dofs",), 5),
    "no mode": _set(("modes",), []),
}


def test_the_valid_selection_reads_back() -> None:
    """The unmutated document is read (the mutations below are what breaks it)."""
    sel = Selection.from_json(json.dumps(_valid()))
    assert sel.band == (150.0, 1000.0) and sel.modes[0].natural_freq == 626.0


@pytest.mark.parametrize("kind", sorted(MUTATIONS))
def test_broken_selection_refused_by_name(kind: str, tmp_path: Path) -> None:
    p = tmp_path / "sel.json"
    p.write_text(json.dumps(MUTATIONS[kind](_valid())), encoding="utf-8")  # NaN/inf as JSON's NaN/Infinity
    with pytest.raises(IdentificationError, match="not a valid mode selection") as info:
        Selection.from_json(p)
    assert info.value.file == str(p)


def test_cli_one_error_line_for_a_list(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Through the CLI: exit 1, one error line naming the selection file (was an AttributeError traceback)."""
    p = tmp_path / "sel.json"
    p.write_text("[]", encoding="utf-8")
    measurement = Path(__file__).resolve().parent.parent / "data" / "dummy_200N_r1.uff"
    code = main(["modes", str(measurement), "--selection", str(p)])
    err = capsys.readouterr().err
    assert code == 1 and err.startswith(f"error: {p}: not a valid mode selection"), err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1
