"""The walkthrough notebook (issue 20): runs from any folder (nbclient, a kernel started in tmp_path),
its picks drive k_TB, the tracked-replay warnings are shown, every number of its text is one the run
prints, and the committed copy carries its outputs (the charts are visible on the repository page)."""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "walkthrough.ipynb"
_NUMBER = re.compile(r"(?<![\w.])(\d+(?:\.\d+)?)\s?(Hz|N|rpm|%)(?![\w/])")


def _outputs(nb) -> str:
    return "\n".join(o.get("text", "") + str(o.get("data", {}).get("text/plain", ""))
                     for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", ()))


def _numbers_of_the_text_are_printed(nb) -> None:
    """Each number with a unit in the markdown is printed by the code, to the digits the text gives."""
    out = _outputs(nb)
    printed = [float(v) for v in re.findall(r"(?<![\w.])(\d+(?:\.\d+)?)", out)]
    text = "\n".join(c.source for c in nb.cells if c.cell_type == "markdown")
    found = _NUMBER.findall(text)
    assert found, "the text quotes no number?"
    for value, unit in found:
        digits = len(value.split(".")[1]) if "." in value else 0
        half = 0.5 * 10.0**-digits
        assert any(abs(p - float(value)) <= half + 1e-9 for p in printed), f"text says {value} {unit}, the run does not"


def _housing_modes_quoted_are_the_runs(nb) -> None:
    """"587.6 Hz at 500 N instead of 626.2 Hz at 1000 N": each is the housing mode printed for that load."""
    out = _outputs(nb)
    text = "\n".join(c.source for c in nb.cells if c.cell_type == "markdown")
    quoted = re.findall(r"(\d+(?:\.\d+)?) Hz at (\d+) N", text)
    assert quoted
    pick = re.search(r"housing mode (\d+\.\d) Hz \(pick\)", out).group(1)  # type: ignore[union-attr]
    at500 = re.search(r"b6302_500N_1200rpm .* housing mode (\d+\.\d) Hz", out).group(1)  # type: ignore[union-attr]
    for f, load in quoted:  # to the digits the text gives ("551 Hz at 500 N" was wrong: the run gives 587.6)
        half = 0.5 * 10.0 ** -(len(f.split(".")[1]) if "." in f else 0)
        assert abs(float(f) - float({"1000": pick, "500": at500}[load])) <= half + 1e-9, (f, load)


def _images(nb) -> int:
    return sum("image/png" in o.get("data", {}) for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", ()))


def test_walkthrough_runs_from_any_folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    for c in nb.cells:  # run it fresh: the committed outputs must not be what is checked here
        if c.cell_type == "code":
            c.outputs = []
    monkeypatch.setenv("MPLBACKEND", "Agg")  # headless: no ipympl widget, the picks are made by calls
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # what the notebook writes stays in the test's folder
    # ema_rig importable (as when installed), the kernel started in a folder far from the source tree
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(NOTEBOOK.parents[1]),
                                                                    os.environ.get("PYTHONPATH")])))
    run_dir = tmp_path / "elsewhere"
    run_dir.mkdir()
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(run_dir)}})
    client.execute()  # raises CellExecutionError, with the cell and the traceback, on any failure
    text = _outputs(nb)
    assert "modes selected" in text and "wrote modes.json" in text
    # the picks drive k_TB, and the source of each housing mode is said
    assert re.search(r"k_TB = \d+\.\d\d ± \S+ \(meas\.\) ± \S+ \(total\) MN/m", text)
    assert "(pick)" in text and "(replay)" in text and "(tracked replay)" in text
    # the warnings the text promises are shown, not hidden
    assert "check it on the chart" in text
    for mid in ("b6302_1000N_1200rpm_r2", "b6302_1000N_600rpm", "b6302_1000N_1800rpm", "b6302_500N_1200rpm"):
        assert any(line.startswith(mid) and " rpm: housing mode " in line for line in text.splitlines()), mid
    assert _images(nb) >= 2  # the picking chart and the replayed 500 N chart
    _numbers_of_the_text_are_printed(nb)
    _housing_modes_quoted_are_the_runs(nb)
    # the committed outputs are the current code's (not a stale run): every k_TB and housing mode
    # printed, to within the last printed digit (the ML estimates move in far lower digits across BLAS)
    committed = _outputs(nbformat.read(NOTEBOOK, as_version=4))
    for pattern, tol in ((r"k_TB = (\d+\.\d\d)", 0.011), (r"housing mode (\d+\.\d) Hz", 0.11)):
        now, then = re.findall(pattern, text), re.findall(pattern, committed)
        assert len(now) == len(then) >= 5, (now, then)
        assert all(abs(float(a) - float(b)) <= tol for a, b in zip(now, then, strict=True)), (now, then)
    # and the measured sigma of the pick's k_TB to its first digit (a stale run said 0.22 for 0.0061)
    now, then = (float(re.search(r"± (\S+) \(meas\.\)", t).group(1)) for t in (text, committed))  # type: ignore[union-attr]
    assert abs(now / then - 1.0) < 0.2, (now, then)
    assert [p.name for p in tmp_path.glob("ema-rig-walkthrough-*/*")] != []
    assert list(run_dir.iterdir()) == []  # nothing written where it was started


def test_committed_notebook_shows_its_outputs() -> None:
    nbformat = pytest.importorskip("nbformat")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    assert _images(nb) >= 2  # figures visible on the repository page
    assert NOTEBOOK.stat().st_size < 600_000  # two charts at screen resolution, not a data dump
    text = _outputs(nb)
    assert "check it on the chart" in text and "(pick)" in text
    assert "/work/" not in text and "/home/" not in text and "/tmp/" not in text  # no developer paths
    _numbers_of_the_text_are_printed(nb)
    _housing_modes_quoted_are_the_runs(nb)
