"""k_TB against independent rig truths (issue 11): within 2 sigma, or warned, or refused.

The truths come from ``tests/rig_truth.py`` (the paper's 3DOF radial dynamics plus a rigid
housing, tilt / flexible / frame modes and an optional appendage, solved directly; not
``ema_rig.simulate`` nor ``ema_rig.rig.model``). Each measurement goes through UFF58, PolyMAX,
matching and inversion. The rule under test (DESIGN §3.2): a k_TB reported without a warning lies
within 2 standard uncertainties of the truth. One seed per class keeps the runtime small;
``benchmarks/study_ktb_truths.py`` runs many.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from _rig_synth import damping_term_by_hand
from rig_truth import G, RigTruth, write_case

from ema_rig.cli import main
from ema_rig.config import load_rig
from ema_rig.errors import EmaRigError, MatchingError
from ema_rig.io.uff import read_uff58
from ema_rig.rig import stiffness as st

pytest.importorskip("ema_rig.identification")

FREQ = np.arange(0.0, 1100.25, 0.5)


def _estimate(tmp_path, name, truth, **kw):
    uff, rig_path = write_case(tmp_path, name, truth, FREQ, **kw)
    rig = load_rig(rig_path)
    return st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)


def _z(res, truth):
    return (res.k_TB - truth.k_TB) / res.k_TB_std


def test_baseline_within_2_sigma_without_warning(tmp_path):
    truth = RigTruth(k_TB=71.57e6, seed=3)
    res = _estimate(tmp_path, "base", truth)
    assert res.warnings == ()
    # 2 % noise, 2 % damping, no close mode: the identified frequency is good to ~0.05 Hz, so the
    # estimate is far inside its (parameter-dominated, 1.7 %) sigma
    assert abs(_z(res, truth)) < 0.5
    assert res.k_TB == pytest.approx(truth.k_TB, rel=1e-3)
    # the measured part is the identification term alone, much smaller than the total
    assert 0 < res.k_TB_std_measured < 0.2 * res.k_TB_std


def test_no_driving_point_close_tilt_is_refused(tmp_path):
    # main picked the 867 Hz ovalisation mode here: +1300 % with a small +-
    truth = RigTruth(tilt_x_freq=626.0 * 1.002, seed=1)
    with pytest.raises(MatchingError) as ei:
        _estimate(tmp_path, "nodp", truth, drop=("11+Y",))
    msg = ei.value.message
    assert "no radial driving point (11+Y)" in msg and len(msg) <= 300


def test_frame_mode_6_hz_below_warns_and_covers(tmp_path):
    truth = RigTruth(k_TB=93e6, flex_frame_freq=663.0, seed=2)
    for drop in ((), ("11+Y",)):
        res = _estimate(tmp_path, "frame" + str(len(drop)), truth, drop=drop)
        if drop:
            # without the driving point nothing bounds the coupling: a warning
            assert res.warnings, "a frame mode a few Hz from the housing mode must be reported"
        else:
            # with it, the measured modal mass bounds the leak into the neighbour (issue 19): a
            # note naming the neighbour and its term instead of a warning. Since the identification
            # finds the housing mode beside the frame mode (issue 18: 667.28 Hz, truth 667.32 Hz;
            # main merged both into 663.9 Hz), the frame mode is its own mode and the rig reports
            # the driving-point mass the coupling lowers (-8.9 %) in a note instead
            assert res.warnings or any("bounds the coupling" in n or "housing mass measured" in n
                                       for n in res.notes)
        assert abs(_z(res, truth)) < 2.0


@pytest.mark.parametrize("k_tb, fraction", [(100e6, 0.01), (150e6, 0.02)])
def test_housing_appendage_recovered_within_sigma(tmp_path, k_tb, fraction):
    # a small flexible part of the housing (1-2 % of m_H) tuned to 695 Hz: on main -20 ... +40 %
    truth = RigTruth(k_TB=k_tb, appendage_fraction=fraction, flex_housing_freq=820.0,
                     flex_frame_freq=600.0, seed=4)
    res = _estimate(tmp_path, "app", truth)
    # issue 19: the housing with an appendage is fitted to both modes' frequencies and
    # driving-point masses (4DOF model): resolved, a note instead of a warning (was +-20 % hedged)
    assert any("appendage fitted" in n for n in res.notes)
    assert "split housing fit" in res.uncertainty.shares
    assert res.warnings == () and abs(_z(res, truth)) < 1.5
    assert abs(res.k_TB / truth.k_TB - 1) < 0.01


def test_soft_disk_calibration_never_shrinks_the_uncertainty(tmp_path):
    disk = RigTruth(k_TB=10 * 114e6, seed=5)  # the paper's "at least a factor 10"
    uff, rig_path = write_case(tmp_path, "disk", disk, FREQ)
    rig = load_rig(rig_path)
    cal = st.calibrate(read_uff58(uff, rig=rig), rig)
    # rigid-disk reading: k_MS low by 1/11 = 9.1 %; the model-form term (10 %/sqrt 3 = 5.8 %)
    # keeps the truth inside 2 sigma, and the calibration is less certain than the rig file's 2 %
    assert cal.k_MS / 114e6 - 1 == pytest.approx(-1 / 11, abs=3e-3)
    assert abs(cal.k_MS - 114e6) / cal.k_MS_std < 2.0
    assert cal.k_MS_std / cal.k_MS > 0.02 > cal.k_MS_std_measured / cal.k_MS
    assert any("assumed rigid" in n for n in cal.notes)
    truth = RigTruth(k_TB=71.57e6, seed=6)
    uff2, _ = write_case(tmp_path, "bearing", truth, FREQ)
    res = st.estimate_stiffness(read_uff58(uff2, rig=rig), rig, k_ms=cal.k_MS, k_ms_std=cal.k_MS_std,
                                spindle=False)
    assert res.warnings == () and abs(_z(res, truth)) < 2.0
    # with the disk's own (FE) stiffness the series compliance removes the bias
    cal2 = st.calibrate(read_uff58(uff, rig=rig), rig, k_disk=10 * 114e6, k_disk_std=0.5e9)
    assert cal2.k_MS == pytest.approx(114e6, rel=2e-3)


def test_hysteretic_damping_within_2_sigma(tmp_path):
    # K (1 + j eta) with zeta_eq 10 %: |lambda| is 1 % above the undamped frequency (+3.9 % in k_TB)
    truth = RigTruth(zeta=0.10, damping="hysteretic", seed=0)
    res = _estimate(tmp_path, "hyst", truth)
    assert abs(_z(res, truth)) < 2.0
    # declared: inverted at |lambda| sqrt(1 - 2 zeta^2), the bias nearly gone
    uff, rig_path = write_case(tmp_path, "hyst2", truth, FREQ)
    rig = load_rig(rig_path)
    res_h = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False, damping_model="hysteretic")
    assert abs(res_h.k_TB / truth.k_TB - 1) < abs(res.k_TB / truth.k_TB - 1)
    assert res_h.inverted_freq < res_h.housing_mode["natural_freq"]
    # the phase does not place the damping (hysteretic everywhere: a real mode), so the term spans the
    # declared model's alternatives and the all-in-the-bearing reading (0.63 % -> 1.86 % here)
    zeta = res.housing_mode["damping_ratio"]
    expected = damping_term_by_hand(load_rig(rig_path).model, res.housing_mode["natural_freq"], zeta)
    assert res.uncertainty.term("damping model").rel_input == pytest.approx(expected, rel=1e-9)


def test_reversed_sensor_names_its_polarity(tmp_path):
    truth = RigTruth(seed=7)
    with pytest.raises(MatchingError) as ei:
        _estimate(tmp_path, "flip", truth, flip=("12+Y",))
    assert "12+Y" in ei.value.message and "polarity" in ei.value.message
    assert len(str(ei.value)) <= 300 + len(str(ei.value.file))


def test_file_in_g_names_units(tmp_path):
    truth = RigTruth(seed=8)
    with pytest.raises(MatchingError) as ei:
        _estimate(tmp_path, "g", truth, scale=1 / G)
    assert "units" in ei.value.message and "ratio 9.8" in ei.value.message


def test_cli_warnings_on_stderr_and_json(tmp_path, capsys):
    truth = RigTruth(k_TB=93e6, flex_frame_freq=663.0, seed=2)
    # without the driving point the close frame mode stays a warning
    uff, rig_path = write_case(tmp_path, "frame", truth, FREQ, drop=("11+Y",))
    out = tmp_path / "res.json"
    code = main(["stiffness", str(uff), "--rig", str(rig_path), "--no-spindle", "--json", str(out)])
    cap = capsys.readouterr()
    assert code == 0
    doc = json.loads(out.read_text())
    lines = [x for x in cap.err.splitlines() if x.startswith("warning:")]
    assert doc["warnings"] and len(lines) == len(doc["warnings"])
    assert all(len(x) < 400 for x in lines)
    assert "(measured)" in cap.out and "(total)" in cap.out
    assert doc["k_TB_std_measured"] < doc["k_TB_std"]
    assert {"measured", "assumed (rig file)", "model form"} <= set(doc["k_TB_std_by_kind"])


def test_cli_refusal_writes_json_and_one_line(tmp_path, capsys):
    uff, rig_path = write_case(tmp_path, "flip", RigTruth(seed=7), FREQ, flip=("12+Y",))
    out = tmp_path / "res.json"
    code = main(["stiffness", str(uff), "--rig", str(rig_path), "--no-spindle", "--json", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and err.count("\n") == 1 and err.startswith("error: ")
    doc = json.loads(out.read_text())
    assert doc["candidates"] and "polarity" in doc["error"] and doc["warnings"] == []


def test_default_tolerances_are_a_note(tmp_path, capsys):
    uff, rig_path = write_case(tmp_path, "base", RigTruth(seed=3), FREQ)
    text = rig_path.read_text()
    rig_path.write_text(text[: text.index("[uncertainty]")] + text[text.index("[[sensor]]"):])
    code = main(["stiffness", str(uff), "--rig", str(rig_path), "--no-spindle"])
    err = capsys.readouterr().err
    assert code == 0
    assert "note:" in err and "default tolerances" in err and "m_H 0.5 %" in err
    assert "warning:" not in err


def test_pipeline_errors_are_ema_rig_errors(tmp_path):
    # sanity of the harness: a file with every radial housing sensor gone cannot be matched
    with pytest.raises(EmaRigError):
        _estimate(tmp_path, "none", RigTruth(seed=9), drop=("11+Y", "12+Y", "13+Y"))


def test_band_edge_mode_the_result_does_not_use_is_a_note(tmp_path):
    # The ovalisation mode moved to 990 Hz, 10 Hz below the band's top (150..1000 Hz): the
    # identification flags its own estimate as edge-biased, but k_TB (housing mode at 626 Hz, far
    # from it) is exact. On ea76aec that flag was a k_TB warning on every such file (a study
    # family warned on 8 of 8 right answers, study_unseen_truths.txt); it is a note now.
    truth = RigTruth(oval_freq=990.0, seed=3)
    res = _estimate(tmp_path, "edge", truth)
    assert res.warnings == ()
    assert any("sits at the band edge" in n for n in res.notes)
    assert abs(_z(res, truth)) < 0.5



def test_disk_calibration_total_holds_the_rig_files_tolerances(tmp_path):
    """k_MS is read through the 3DOF model, so the rig file's parameter tolerances move it too.

    The bundled steel-disk measurement (``data/disk.uff``, planted k_MS 114 MN/m, its truth file) with
    the disk's stiffness stated (1e12 N/m: rigid, so no disk model-form term) and a rig file whose m_H is
    0.5 % high, one standard uncertainty of its stated tolerance: k_MS reads ~0.7 % high
    (d ln k_MS / d ln m_H = 1.4 at 897 Hz). On 4bc189d the printed total was 0.07 % (frequency and its
    model-form terms only): z ~ 10. The total now carries the tolerances (1.4 % on this rig: k_S 2 %
    and m_H 0.5 % dominate)."""
    repo = Path(__file__).resolve().parent.parent
    truth = json.loads((repo / "data" / "disk.uff.truth.json").read_text(encoding="utf-8"))
    text = (repo / "data" / "rig.toml").read_text(encoding="utf-8")
    m_h = truth["model"]["m_H"]
    assert f"m_H = {m_h}" in text
    rig_path = tmp_path / "rig.toml"
    rig_path.write_text(text.replace(f"m_H = {m_h}", f"m_H = {m_h * 1.005:.6f}", 1), encoding="utf-8")
    rig = load_rig(rig_path)
    cal = st.calibrate(read_uff58(repo / "data" / "disk.uff", rig=rig), rig, k_disk=1e12)
    k_true = truth["k_MS"]
    assert 0.004 < cal.k_MS / k_true - 1 < 0.010  # the off m_H, read through the model
    assert abs(cal.k_MS - k_true) < 2.0 * cal.k_MS_std
    assert 0.01 < cal.k_MS_std_rig / cal.k_MS < 0.02
    assert cal.k_MS_std == pytest.approx(math.hypot(cal.calibration.k_MS_std, cal.k_MS_std_rig), rel=1e-12)
    assert cal.to_dict()["k_MS_std_rig"] == cal.k_MS_std_rig
    assert any("rig file's tolerances" in n for n in cal.notes)
