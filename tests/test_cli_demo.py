"""``ema-rig demo``: the README's main job, also where no bundled data/ folder exists."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from ema_rig import demo_data
from ema_rig.cli import EXIT_OK, main
from ema_rig.commands import demo


def test_demo_regenerates_data_when_installed_without_source_tree(tmp_path: Path, monkeypatch) -> None:
    full = demo_data.plan()
    # two dummy-bearing runs keep the test fast; the generator and the runner are the real ones
    monkeypatch.setattr(demo_data, "plan", lambda: full[:2])
    monkeypatch.setattr(demo, "find_data_dir", lambda explicit=None: None)
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out)]) == EXIT_OK
    rows = list(csv.DictReader((out / "campaign.csv").read_text().splitlines()))
    assert [r["id"] for r in rows] == ["dummy_200N_r1", "dummy_200N_r2"]
    for r in rows:
        # the dummy's true stiffness at 200 N is 32.09e6 N/m (ema_rig.demo_data.K_DUMMY)
        assert float(r["k_TB [N/m]"]) == pytest.approx(demo_data.K_DUMMY[200.0], rel=0.01)
        assert demo_data.K_DUMMY[200.0] > 31.14e6 and float(r["k_TB [N/m]"]) < 34.12e6  # inside the FE bounds
    assert (out / "report.html").stat().st_size > 10_000 and (out / "data" / "disk.uff").is_file()
    # nothing left behind (issue 20): no lock, no temporary; only the figure manifest and demo's mark
    hidden = sorted(str(p.relative_to(out)) for p in out.rglob("*") if p.name.startswith(".") or ".tmp" in p.name)
    assert hidden == [".ema-rig-demo", ".ema-rig-figures.json"], hidden


def test_demo_data_option_must_hold_a_campaign(tmp_path: Path, capsys) -> None:
    assert main(["demo", "--data", str(tmp_path), "-o", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "campaign.toml" in err and err.count("\n") == 1
