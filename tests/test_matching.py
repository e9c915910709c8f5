"""Matching identified modes to the 3DOF rig model (ema_rig.rig.matching).

The modal models are built by hand from chosen mass-normalised shapes, so the truth of every
candidate (housing, tilt, flexible, axial, spindle, harmonic) is known exactly.
"""

from __future__ import annotations

import numpy as np
import pytest
from _rig_synth import housing_shape as _housing_shape
from _rig_synth import modal as _modal
from _rig_synth import rig_modes as _rig_modes

from ema_rig.config import parse_rig
from ema_rig.errors import MatchingError
from ema_rig.rig.matching import match_modes, model_mode_at, model_valid_range


@pytest.fixture
def rig(rig_toml_text):
    import tomllib

    return parse_rig(tomllib.loads(rig_toml_text))


def test_valid_range_matches_design(rig):
    # DESIGN §4: k_TB+MS > 0 only for 80.6 Hz < f_H < 1299.6 Hz (quoted to 0.1 Hz)
    lo, hi = model_valid_range(rig.model)
    np.testing.assert_allclose([lo, hi], [80.6, 1299.6], atol=0.06)


def test_model_mode_at_626(rig):
    # DESIGN §4: at 626 Hz k_TB+MS = 4.397e7 N/m (4 digits), modal mass ~2.64 kg, S/H ~ 0.1,
    # spindle bending mode at 1907.2 Hz
    info = model_mode_at(rig.model, 626.0)
    np.testing.assert_allclose(info.k_tb_ms, 4.397e7, rtol=5e-4)
    np.testing.assert_allclose(info.modal_mass, 2.64, rtol=5e-3)
    np.testing.assert_allclose(info.spindle_ratio, 0.11, atol=0.01)
    np.testing.assert_allclose(info.spindle_freq, 1907.2, atol=0.1)
    assert model_mode_at(rig.model, 50.0) is None  # below the valid range: no positive stiffness
    assert model_mode_at(rig.model, 1400.0) is None


@pytest.mark.parametrize("f_h", [626.0, 897.0, 490.0])  # paper bearing, steel disk, dummy
def test_picks_housing_and_spindle_modes(rig, f_h):
    mm = _modal(_rig_modes(rig.model, f_h))
    res = match_modes(mm, rig)
    # exact input: the housing mode must be found exactly (rtol 1e-12, float round-off)
    np.testing.assert_allclose(res.housing_mode["natural_freq"], f_h, rtol=1e-12)
    assert res.spindle_mode is not None
    info = model_mode_at(rig.model, f_h)
    np.testing.assert_allclose(res.spindle_mode["natural_freq"], info.spindle_freq * 1.003, rtol=1e-12)
    # every mode is listed with a reason
    assert len(res.candidates) == mm.n_modes
    by_f = {round(c.natural_freq, 1): c for c in res.candidates}
    assert "tilt" in by_f[120.0].reason
    assert "spindle" in by_f[287.0].reason
    assert "axial" in by_f[300.0].reason
    assert "lateral" in by_f[410.0].reason
    assert "modal mass" in by_f[round(f_h + 37.0, 1)].reason
    # typed, frozen records; the JSON form carries the same fields
    assert by_f[120.0].failures and by_f[120.0].to_dict()["reason"] == by_f[120.0].reason
    # the measured effective mass equals the model's (shapes built from it): rtol 1e-9
    np.testing.assert_allclose(res.housing_mode["modal_mass"], info.modal_mass, rtol=1e-9)


def test_tilt_one_percent_away_rejected_by_shape(rig):
    h = _housing_shape(rig.model, 626.0)
    tilt = h.copy()
    tilt[[0, 1, 2]] = h[0] * np.array([1.0, -0.9, 0.2])  # out of phase, same scale
    mm = _modal([(626.0 * 1.01, 0.02, tilt), (626.0, 0.02, h)])
    res = match_modes(mm, rig)
    np.testing.assert_allclose(res.housing_mode["natural_freq"], 626.0, rtol=1e-12)
    c = [c for c in res.candidates if abs(c.natural_freq - 632.26) < 0.1][0]
    assert c.status == "rejected" and "tilt" in c.reason
    # and the tilt mode alone is not accepted: MatchingError listing it with the reason
    with pytest.raises(MatchingError) as ei:
        match_modes(_modal([(626.0 * 1.01, 0.02, tilt)]), rig)
    assert len(ei.value.candidates) == 1 and "tilt" in ei.value.candidates[0]["reason"]


def test_flexible_mode_right_frequency_ten_times_mass_rejected(rig):
    h = _housing_shape(rig.model, 626.0)
    mm = _modal([(626.0, 0.02, h / np.sqrt(10.0))])  # right shape and frequency, 10x modal mass
    with pytest.raises(MatchingError) as ei:
        match_modes(mm, rig)
    c = ei.value.candidates[0]
    # the measured / model mass ratio is exactly 10 (rtol 1e-9, round-off only)
    np.testing.assert_allclose(c["mass_ratio"], 10.0, rtol=1e-9)
    assert "modal mass" in c["reason"] and "626.0 Hz" in str(ei.value)


def test_harmonic_line_rejected_when_rotating(rig):
    speed = 25.0  # Hz = 1500 rpm
    h = _housing_shape(rig.model, 626.0)
    line = _housing_shape(rig.model, 600.0)  # 24 x 25 Hz, forced response at the housing
    mm = _modal([(600.0 + 0.05, 2e-4, line), (626.0, 0.02, h)])
    # non-rotating: the nearly undamped line passes the shape criteria (nothing says otherwise)
    only_line = _modal([(600.05, 2e-4, line)])
    np.testing.assert_allclose(match_modes(only_line, rig).housing_mode["natural_freq"], 600.05, rtol=1e-12)
    # rotating: it is recognised as the 24th harmonic and rejected
    res = match_modes(mm, rig, speed_hz=speed)
    np.testing.assert_allclose(res.housing_mode["natural_freq"], 626.0, rtol=1e-12)
    c = [c for c in res.candidates if c.natural_freq < 610][0]
    assert c.harmonic == 24 and "harmonic" in c.reason
    with pytest.raises(MatchingError, match="harmonic"):
        match_modes(only_line, rig, speed_hz=speed)
    # a well-damped mode at a harmonic frequency is NOT a harmonic line (damping evidence)
    res2 = match_modes(_modal([(625.0, 0.02, h)]), rig, speed_hz=speed)
    np.testing.assert_allclose(res2.housing_mode["natural_freq"], 625.0, rtol=1e-12)


def test_outside_valid_range_listed(rig):
    h = _housing_shape(rig.model, 626.0)
    mm = _modal([(1350.0, 0.02, h), (60.0, 0.02, h)])
    with pytest.raises(MatchingError) as ei:
        match_modes(mm, rig)
    assert all("outside the housing-mode range" in c["reason"] for c in ei.value.candidates)
    assert [round(c["natural_freq"]) for c in ei.value.candidates] == [60, 1350]


def test_spindle_mode_absent_is_none(rig):
    mm = _modal([(626.0, 0.02, _housing_shape(rig.model, 626.0))])
    res = match_modes(mm, rig)
    assert res.spindle_mode is None and res.spindle_index is None
    d = res.to_dict()
    assert d["spindle_mode"] is None and d["housing_mode"]["natural_freq"] == pytest.approx(626.0, rel=1e-12)


def _only_housing(rig, f_h=626.0):
    """The realistic mode set without its housing mode (the test adds its own)."""
    return [m for m in _rig_modes(rig.model, f_h) if abs(m[0] - f_h) > 1e-9]


def test_reversed_sensor_refusal_names_it(rig):
    h = _housing_shape(rig.model, 626.0)
    h[1] = -h[1]  # 12+Y wired the wrong way round
    mm = _modal(_only_housing(rig) + [(626.0, 0.02, h)])
    with pytest.raises(MatchingError) as ei:
        match_modes(mm, rig)
    msg = ei.value.message
    assert "12+Y" in msg and "polarity" in msg and len(msg) <= 300
    (c,) = [c for c in ei.value.candidates if abs(c["natural_freq"] - 626.0) < 1e-6]
    assert c["polarity_suspect"] == "12+Y"


def test_tilt_is_not_a_polarity_suspect(rig):
    # a tilt: one sensor on the axis hardly moves, the other two opposite: no single sign flip fixes it
    tilt = np.array([0.05, 0.3, -0.3, 0.02, 0.01, 0.01, 0.01, 0.0])
    mm = _modal([(626.0, 0.02, tilt)])
    with pytest.raises(MatchingError) as ei:
        match_modes(mm, rig)
    assert "polarity" not in ei.value.message
    assert ei.value.candidates[0]["polarity_suspect"] is None


def test_g_file_refusal_names_units(rig):
    # accelerations in g read as m/s^2: every FRF 9.81x too small, the effective mass 9.81x too large
    h = _housing_shape(rig.model, 626.0, mass_factor=9.80665)
    mm = _modal(_only_housing(rig) + [(626.0, 0.02, h)])
    with pytest.raises(MatchingError) as ei:
        match_modes(mm, rig)
    assert "units" in ei.value.message and "ratio 9.8" in ei.value.message


def test_without_driving_point_mass_from_transfer(rig):
    # outputs without 11+Y: the rigid housing's transfer residues give the same effective mass
    keep = [1, 2, 3, 4, 5, 6, 7]
    modes = [(f, z, phi) for f, z, phi in _rig_modes(rig.model, 626.0)]
    full = _modal(modes)
    mm = type(full)(
        poles=full.poles, residues=full.residues[:, keep], lower_residual=full.lower_residual[keep],
        upper_residual=full.upper_residual[keep], out_dofs=tuple(full.out_dofs[i] for i in keep),
        in_dofs=full.in_dofs, roles=tuple(full.roles[i] for i in keep), axes=tuple(full.axes[i] for i in keep),
    )
    m = match_modes(mm, rig)
    assert not m.driving_point and any("no radial driving-point FRF" in w for w in m.warnings)
    assert m.housing_mode["natural_freq"] == pytest.approx(626.0, rel=1e-12)
    # exact shapes: the transfer estimate equals the model's mass (to rounding)
    assert m.housing_mode["modal_mass"] == pytest.approx(model_mode_at(rig.model, 626.0).modal_mass, rel=1e-9)
    assert m.housing_mode["modal_mass_source"] == "radial housing transfer FRFs"


def test_close_neighbour_with_radial_housing_motion(rig):
    h = _housing_shape(rig.model, 626.0)
    modes = _rig_modes(rig.model, 626.0) + [(632.0, 0.02, h / np.sqrt(4.0))]  # 6 Hz away, 4x the mass
    mm = _modal(modes)
    m = match_modes(mm, rig)
    (j,) = [i for i in range(mm.n_modes) if abs(mm.natural_freq[i] - 632.0) < 1e-6]
    assert j in m.neighbours
    # participation = 1 / m_eff for a rigid housing: the neighbour carries a quarter of the housing's
    assert m.participation[j] / m.participation[m.housing_index] == pytest.approx(0.25, rel=1e-9)


def test_every_rig_threshold_has_a_source_and_the_defaults_are_unchanged():
    """Issue 18 item 5: the rig stage's thresholds live in one frozen criteria object, each with its source."""
    import dataclasses

    from ema_rig.identification.ml import MLCriteria
    from ema_rig.rig.matching import MATCH_CRITERIA, MatchCriteria

    for cls in (MatchCriteria, MLCriteria):
        crit = cls()
        src = crit.sources()
        assert set(src) == {f.name for f in dataclasses.fields(cls)}, cls
        assert all(isinstance(v, str) and len(v) > 10 for v in src.values())
        with pytest.raises(dataclasses.FrozenInstanceError):
            crit.__setattr__(dataclasses.fields(cls)[0].name, 0.0)
    # the values the thresholds had as bare numbers before they moved here (and the old keywords)
    old = MatchCriteria(min_phase_cos=0.2, min_amplitude_ratio=0.5, max_cross_axis_ratio=0.5, spindle_ratio_tol=0.15,
                        mass_ratio_range=(0.5, 2.0), harmonic_freq_tol=2e-3, harmonic_max_damping=5e-3,
                        spindle_freq_tol=0.2, min_spindle_ratio=1.0, neighbour_bandwidths=3.0,
                        neighbour_participation=0.1)
    assert old == MATCH_CRITERIA
    assert (MATCH_CRITERIA.polarity_min_cos, MATCH_CRITERIA.harmonic_sigmas, MATCH_CRITERIA.harmonic_min_order,
            MATCH_CRITERIA.spindle_ratio_rel_tol, MATCH_CRITERIA.units_hint_log_tol,
            MATCH_CRITERIA.max_spindle_axial_ratio, MATCH_CRITERIA.spindle_search_margin,
            MATCH_CRITERIA.spindle_search_min_fraction) == (0.9, 3.0, 0.5, 0.5, 0.25, 1.0, 0.02, 0.5)
