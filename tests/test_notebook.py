"""The walkthrough notebook runs headless, top to bottom (nbclient, Agg backend)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

NOTEBOOK = Path(__file__).resolve().parents[1] / "examples" / "walkthrough.ipynb"


def test_walkthrough_notebook_executes(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    nbformat = pytest.importorskip("nbformat")
    nbclient = pytest.importorskip("nbclient")
    pytest.importorskip("ipykernel")
    nb = nbformat.read(NOTEBOOK, as_version=4)
    monkeypatch.setenv("MPLBACKEND", "Agg")  # headless: no ipympl widget, the picks are made by calls
    monkeypatch.setenv("TMPDIR", str(tmp_path))  # what the notebook writes stays in the test's folder
    monkeypatch.setenv("PYTHONPATH", os.pathsep.join(filter(None, [str(NOTEBOOK.parents[1]),
                                                                    os.environ.get("PYTHONPATH")])))
    client = nbclient.NotebookClient(nb, timeout=300, kernel_name="python3",
                                     resources={"metadata": {"path": str(NOTEBOOK.parent)}})
    client.execute()  # raises CellExecutionError, with the cell and the traceback, on any failure
    text = "\n".join(o.get("text", "") for c in nb.cells if c.cell_type == "code" for o in c.get("outputs", ()))
    # the steps happened: identification, a selection saved, replayed on three loads, k_TB printed
    assert "modes selected" in text and "wrote modes.json" in text
    assert [p.name for p in tmp_path.glob("ema-rig-walkthrough-*/*")] != []
    # the 1000 N runs at other speeds and the repeat: the saved modes are found again
    for mid in ("b6302_1000N_1200rpm_r2", "b6302_1000N_600rpm", "b6302_1000N_1800rpm"):
        assert any(line.startswith(mid) and " rpm: " in line for line in text.splitlines()), mid
    assert "b6302_500N_1200rpm" in text  # the load change: replayed or reported, the notebook goes on
    assert "k_TB = " in text and "MN/m" in text
