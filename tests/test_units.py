"""Units a user reads and types: rpm, the calibration's options to pass on, plot orders and error bars."""

from __future__ import annotations

import math
import re
import shlex
from pathlib import Path

import numpy as np
import pytest

from ema_rig.cli import main

DATA = Path(__file__).resolve().parents[1] / "data"


def test_calibrate_prints_both_options_to_pass_on(capsys: pytest.CaptureFixture[str]) -> None:
    import json

    if not (DATA / "disk.uff").is_file():
        pytest.skip("bundled data absent")
    assert main(["calibrate", str(DATA / "disk.uff"), "--rig", str(DATA / "rig.toml")]) == 0
    out = capsys.readouterr().out
    m = re.search(r"(--k-ms \S+ --k-ms-std \S+)", out)
    assert m, out
    opts = shlex.split(m.group(1))
    k_ms, k_ms_std = float(opts[1]), float(opts[3])
    # the values printed are the calibration's: the same as its JSON to 6 significant digits
    truth = json.loads((DATA / "disk.uff.truth.json").read_text())
    assert k_ms_std > 0 and k_ms == pytest.approx(truth["k_MS"], rel=0.01)  # the simulated k_MS, 1 %
    from ema_rig.cli import build_parser

    args = build_parser().parse_args(["stiffness", "x.uff", "--rig", "r.toml", *opts])
    assert (args.k_ms, args.k_ms_std) == (k_ms, k_ms_std)


def test_simulate_accepts_rpm(rig_file: Path) -> None:
    from ema_rig.config import load_rig
    from ema_rig.simulate import simulate_measurement

    rig = load_rig(rig_file)
    a = simulate_measurement(rig, k_tb=7e7, seed=2, speed_rpm=1500.0)
    b = simulate_measurement(rig, k_tb=7e7, seed=2, speed_hz=25.0)
    np.testing.assert_array_equal(a.data.frf, b.data.frf)  # 1500 rpm = 25 Hz exactly
    still = simulate_measurement(rig, k_tb=7e7, seed=2, speed_rpm=0.0)
    np.testing.assert_array_equal(still.data.frf, simulate_measurement(rig, k_tb=7e7, seed=2).data.frf)
    with pytest.raises(ValueError, match="once"):
        simulate_measurement(rig, k_tb=7e7, speed_rpm=600.0, speed_hz=10.0)
    with pytest.raises(ValueError, match="speed_rpm"):
        simulate_measurement(rig, k_tb=7e7, speed_rpm=-1.0)


def _row(load: float, speed: float, k: float, std: float, f_h_std: float, repeat: int = 1) -> dict:
    return {"bearing": "6302", "status": "ok", "radial_load": load, "speed": speed, "shaft_position": math.nan,
            "repeat": repeat, "k_TB": k, "k_TB_std": std,
            "detail": {"uncertainty_terms": [{"name": "m_H", "std": math.sqrt(std**2 - f_h_std**2)},
                                             {"name": "f_H", "std": f_h_std}]}}


def test_repeatability_sorts_loads_as_numbers() -> None:
    from ema_rig.plot.campaign import plot_repeatability

    rows = [_row(f, 600.0, 7e7 + r * 1e5, 1e6, 1e5, repeat=r) for f in (1000.0, 1500.0, 200.0, 500.0) for r in (1, 2)]
    fig = plot_repeatability(rows)
    assert fig is not None
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert [int(s.split("\n")[1].split(" N")[0]) for s in labels] == [200, 500, 1000, 1500]


def test_speed_error_bars_are_the_measured_uncertainty() -> None:
    from ema_rig.plot.campaign import plot_speed_effect

    # total std 1 MN/m (rig tolerances, common to every speed), measured part 0.1 MN/m
    rows = [_row(1000.0, s, 7.1e7 + 1e5 * i, 1e6, 1e5) for i, s in enumerate((600.0, 1200.0, 1800.0))]
    ax = plot_speed_effect(rows, "6302").axes[0]
    bars = [c for c in ax.collections if c.get_segments()]
    half = {round(float(np.ptp(seg[:, 1])) / 2, 6) for c in bars for seg in c.get_segments()}
    assert half == {0.1}  # MN/m: the f_H term, not the 1 MN/m total
