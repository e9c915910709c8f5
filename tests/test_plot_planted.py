"""The rotating-vs-static figure: a recovered planted value on synthetic data, a measurement otherwise."""

from __future__ import annotations

import json
import math

import pytest

from ema_rig.plot.campaign import plot_rotating_vs_static
from ema_rig.simulate import planted_k_tb


def _row(i, speed, k):
    return {"id": f"m{i}", "bearing": "b", "status": "ok", "speed": speed, "radial_load": 1000.0,
            "shaft_position": math.nan, "repeat": 1, "k_TB": k, "k_TB_std": 0.01 * k}


ROWS = [_row(0, 0.0, 80e6), _row(1, 0.0, 82e6), _row(2, 1200.0, 72e6), _row(3, 2400.0, 74e6)]


def test_real_campaign_is_a_measurement():
    fig, change = plot_rotating_vs_static(ROWS, "b")
    # (73 / 81 - 1) = -9.88 %, by hand
    assert change == pytest.approx(100 * (73 / 81 - 1), rel=1e-12)
    title = fig.axes[0].get_title()
    assert "measured mean change -9.9 %" in title and "planted" not in title


def test_synthetic_campaign_says_recovered_and_planted():
    planted = {"m0": 80e6, "m1": 80e6, "m2": 70e6, "m3": 70e6}  # planted change: -12.5 %
    fig, _ = plot_rotating_vs_static(ROWS, "b", planted=planted)
    title = fig.axes[0].get_title()
    assert "-9.9 % recovered" in title and "planted in the synthetic data: -12.5 %" in title
    assert "measured" not in title
    # one measurement without a truth: the comparison is not purely synthetic -> a measurement
    fig, _ = plot_rotating_vs_static(ROWS, "b", planted={k: v for k, v in planted.items() if k != "m3"})
    assert "measured mean change" in fig.axes[0].get_title()


def test_planted_k_tb_reads_the_truth_beside_the_file(tmp_path):
    f = tmp_path / "a.uff"
    assert planted_k_tb(f) is None  # real measurement: no truth file
    (tmp_path / "a.uff.truth.json").write_text(json.dumps({"k_TB": 7.1e7}))
    assert planted_k_tb(f) == 7.1e7
    (tmp_path / "a.uff.truth.json").write_text(json.dumps({"k_TB": None, "rigid_disk": True}))
    assert planted_k_tb(f) == math.inf
    (tmp_path / "a.uff.truth.json").write_text("{not json")
    with pytest.raises(ValueError, match=r"a\.uff\.truth\.json"):
        planted_k_tb(f)
    (tmp_path / "a.uff.truth.json").write_text(json.dumps({"k_TB": "stiff"}))
    with pytest.raises(ValueError, match="numeric k_TB"):
        planted_k_tb(f)
