"""--jobs 2 with the report: the pool also draws the per-measurement figures; same outputs as --jobs 1."""

from __future__ import annotations

from pathlib import Path

import pytest
from _campaigns import simulated_6302_campaign

from ema_rig.campaign import run


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory: pytest.TempPathFactory, rig_toml_text: str) -> Path:
    """Two simulated 6302 measurements with the per-measurement figures on (the default)."""
    return simulated_6302_campaign(tmp_path_factory.mktemp("par"), rig_toml_text, {"p400": 6.1e7, "p800": 6.8e7},
                                   seed=50)


def test_jobs_2_outputs_match_jobs_1(campaign_dir: Path, tmp_path: Path) -> None:
    serial = run(campaign_dir / "campaign.toml", out_dir=tmp_path / "j1", jobs=1)
    par = run(campaign_dir / "campaign.toml", out_dir=tmp_path / "j2", jobs=2)
    assert [r["k_TB"] for r in par.rows] == [r["k_TB"] for r in serial.rows]  # the same bits
    assert sorted(par.files) == sorted(serial.files)
    drawn = sorted(k for k in par.files if "/" in k)  # "<id>/<kind>": drawn by the pool's workers
    assert len(drawn) >= 4, drawn  # two measurements, at least two figures each
    for k in drawn:
        # the same drawing in another process: the same PNG
        assert par.files[k].read_bytes() == serial.files[k].read_bytes(), k
    # the report embeds them all: the same length (it also carries the run's date and times)
    html1 = (tmp_path / "j1" / "report.html").read_text()
    html2 = (tmp_path / "j2" / "report.html").read_text()
    assert html2.count("data:image/png;base64,") == html1.count("data:image/png;base64,") >= len(drawn)
