"""Tests of the housing-mode inversion, k_MS calibration, uncertainty and model fit (DESIGN §4)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from numpy.testing import assert_allclose

from ema_rig.config import ModelParams
from ema_rig.errors import InversionError
from ema_rig.rig.inversion import (
    calibrate_k_ms,
    fit_rig,
    housing_freq_bounds,
    housing_freq_from_k_tb_ms,
    k_tb_from_housing_freq,
    k_tb_ms_from_housing_freq,
)
from ema_rig.rig.model import RigModel, series_stiffness
from ema_rig.rig.uncertainty import sensitivities, stiffness_uncertainty, undamped_freq

TABLE1 = ModelParams(m_H=2.566, m_S=2.8, m_F=205.0, k_MS=114e6, k_AS=650e3, k_S=348e6, k_B=180e3)


def test_paper_point_626_hz():
    # DESIGN §4: 626 Hz -> k_TB+MS = 4.397e7, k_TB = 7.157e7 N/m (4 digits quoted)
    assert_allclose(k_tb_ms_from_housing_freq(626.0, TABLE1), 4.397e7, rtol=2e-4)
    assert_allclose(k_tb_from_housing_freq(626.0, TABLE1), 7.157e7, rtol=2e-4)


@pytest.mark.parametrize("f_H", [85.0, 150.0, 483.9, 626.0, 897.0, 1100.0, 1250.0])
def test_closed_form_agrees_with_root_finder(f_H):
    a = k_tb_ms_from_housing_freq(f_H, TABLE1, method="closed")
    b = k_tb_ms_from_housing_freq(f_H, TABLE1, method="root")
    # same equation solved two ways: agreement to 1e-9 (the brief's requirement)
    assert_allclose(a, b, rtol=1e-9)


def test_round_trip_on_exact_model():
    for k_tb in (2e7, 31.14e6, 7.157e7, 1.05e8):
        f_H = RigModel.from_k_tb(TABLE1, k_tb).housing_freq
        # exact data in, exact stiffness out (eigh accuracy ~1e-13): rtol 1e-6
        assert_allclose(k_tb_from_housing_freq(f_H, TABLE1), k_tb, rtol=1e-6)
        assert_allclose(k_tb_from_housing_freq(f_H, TABLE1, method="root"), k_tb, rtol=1e-6)


def test_valid_range_computed_from_parameters():
    lo, hi = housing_freq_bounds(TABLE1)
    _, hi_tb = housing_freq_bounds(TABLE1, bearing=True)
    # DESIGN §4 quotes 80.6 / 1299.6 / 897.35 Hz
    assert_allclose([lo, hi, hi_tb], [80.6, 1299.6, 897.35], atol=0.05)
    # the bounds follow the parameters: a heavier housing lowers both limits
    lo2, hi2 = housing_freq_bounds(replace(TABLE1, m_H=2 * TABLE1.m_H))
    assert lo2 < lo and hi2 < hi


@pytest.mark.parametrize("f_H", [10.0, 80.0, 1300.0, 1500.0, 2500.0, -5.0, math.nan])
def test_outside_range_is_error_never_negative(f_H):
    with pytest.raises(InversionError, match="valid range"):
        k_tb_ms_from_housing_freq(f_H, TABLE1)
    with pytest.raises(InversionError):
        k_tb_from_housing_freq(f_H, TABLE1)


@pytest.mark.parametrize("f_H", [897.4, 950.0, 1200.0])
def test_bearing_stiffer_than_rigid_is_error(f_H):
    # k_TB+MS > 0 here but exceeds k_MS: k_TB would be negative -> error naming the range
    assert k_tb_ms_from_housing_freq(f_H, TABLE1) > TABLE1.k_MS
    with pytest.raises(InversionError, match="897.35 Hz"):
        k_tb_from_housing_freq(f_H, TABLE1)


def test_just_inside_range_is_positive():
    lo, hi = housing_freq_bounds(TABLE1, bearing=True)
    assert k_tb_from_housing_freq(lo * (1 + 1e-6), TABLE1) > 0
    assert k_tb_from_housing_freq(hi * (1 - 1e-6), TABLE1) > 1e9  # approaching rigid


def test_dummy_bearing_fe_bounds_map_to_frequencies():
    # DESIGN §4: FE bounds 31.14e6 ... 34.12e6 N/m <=> housing mode 483.9 ... 499.6 Hz
    f_lo = RigModel.from_k_tb(TABLE1, 31.14e6).housing_freq
    f_hi = RigModel.from_k_tb(TABLE1, 34.12e6).housing_freq
    assert_allclose([f_lo, f_hi], [483.9, 499.6], atol=0.05)
    assert_allclose(k_tb_from_housing_freq(483.9, TABLE1), 31.14e6, rtol=2e-4)
    assert_allclose(k_tb_from_housing_freq(499.6, TABLE1), 34.12e6, rtol=2e-4)


def _rel_change(name, factor=1.01):
    k0 = k_tb_from_housing_freq(626.0, TABLE1)
    if name == "f_H":
        return k_tb_from_housing_freq(626.0 * factor, TABLE1) / k0 - 1
    p = replace(TABLE1, **{name: getattr(TABLE1, name) * factor})
    return k_tb_from_housing_freq(626.0, p) / k0 - 1


def test_design_sensitivities():
    s = sensitivities(626.0, TABLE1)
    # DESIGN §4 (±0.02 on the coefficients): 3.84 per f_H, -0.62 k_MS, -0.26 k_S; m_H quoted as
    # the effect of a +1 % step (+1.88 %), the derivative is 1.864
    assert_allclose(s["f_H"], 3.84, atol=0.02)
    assert_allclose(s["m_H"], 1.88, atol=0.02)
    assert_allclose(s["k_MS"], -0.62, atol=0.02)
    assert_allclose(s["k_S"], -0.26, atol=0.02)
    assert_allclose(100 * _rel_change("m_H"), 1.88, atol=0.02)
    assert_allclose(100 * _rel_change("k_MS"), -0.62, atol=0.02)
    assert_allclose(100 * _rel_change("k_S"), -0.26, atol=0.02)
    # 1 Hz at 626 Hz -> 0.61 %
    assert_allclose(100 * _rel_change("f_H", 627.0 / 626.0), 0.61, atol=0.02)


def test_uncertainty_budget_combines_in_quadrature():
    rel = {"m_H": 0.005, "k_MS": 0.0, "k_S": 0.02, "m_S": 0.0, "m_F": 0.0, "k_AS": 0.0, "k_B": 0.0}
    u = stiffness_uncertainty(626.0, 1.0, TABLE1, rel)
    s = sensitivities(626.0, TABLE1)
    expected = u.k_TB * math.sqrt((s["f_H"] / 626.0) ** 2 + (s["m_H"] * 0.005) ** 2 + (s["k_S"] * 0.02) ** 2)
    assert_allclose(u.k_TB_std, expected, rtol=1e-12)  # quadrature sum, exact arithmetic
    assert_allclose(sum(u.shares.values()), 1.0, rtol=1e-12)
    # the m_H term (1.86 * 0.5 % = 0.93 %) dominates 1 Hz (0.61 %) and k_S (0.52 %)
    assert u.terms[0].name == "m_H"
    assert_allclose(u.shares["f_H"], (s["f_H"] / 626.0) ** 2 / (expected / u.k_TB) ** 2, rtol=1e-9)
    # a k_MS std from the calibration replaces the relative default
    u2 = stiffness_uncertainty(626.0, 0.0, TABLE1, rel, k_MS_std=1.14e6)
    assert_allclose(u2.sensitivities["k_MS"] * 0.01 * u2.k_TB, -dict((t.name, t.std) for t in u2.terms)["k_MS"], rtol=1e-9)


def test_uncertainty_defaults_and_errors():
    u = stiffness_uncertainty(626.0, 0.5, TABLE1)
    # every parameter carries a default; total relative std between 1 % and 3 % at 626 Hz
    assert {t.name for t in u.terms} == {"f_H", "m_H", "m_S", "m_F", "k_MS", "k_AS", "k_S", "k_B"}
    assert 0.01 < u.k_TB_std / u.k_TB < 0.03
    with pytest.raises(InversionError):
        stiffness_uncertainty(1000.0, 1.0, TABLE1)
    with pytest.raises(ValueError, match="unknown parameter"):
        stiffness_uncertainty(626.0, 1.0, TABLE1, {"m_X": 0.1})


def test_k_ms_calibration_from_disk():
    f_disk = RigModel(TABLE1, TABLE1.k_MS).housing_freq  # rigid disk: k_TB+MS = k_MS
    cal = calibrate_k_ms(f_disk, TABLE1, f_disk_std=1.0)
    assert_allclose(cal.k_MS, 114e6, rtol=1e-9)  # exact inversion
    # std from the slope: d ln k / d ln f at ~897 Hz, numerically from the closed form
    slope = (k_tb_ms_from_housing_freq(f_disk + 0.01, TABLE1) - k_tb_ms_from_housing_freq(f_disk - 0.01, TABLE1)) / 0.02
    assert_allclose(cal.k_MS_std_measured, slope * 1.0, rtol=1e-5)
    # disk assumed rigid: the model-form term (1/10)/sqrt(3) of k_MS joins the measured one
    assert_allclose(cal.disk_std, 114e6 * 0.1 / math.sqrt(3), rtol=1e-9)
    assert_allclose(cal.k_MS_std, math.hypot(slope, 114e6 * 0.1 / math.sqrt(3)), rtol=1e-5)
    # a disk of finite stiffness (10 x k_MS) in series: measured frequency is lower, k_MS the same
    k_disk = 1.14e9
    f2 = RigModel(TABLE1, series_stiffness(k_disk, TABLE1.k_MS)).housing_freq
    assert f2 < f_disk
    known = calibrate_k_ms(f2, TABLE1, k_disk=k_disk, k_disk_std=0.1 * k_disk)
    assert_allclose(known.k_MS, 114e6, rtol=1e-9)
    # d k_MS / d k_disk = -(k_MS / k_disk)^2 = -0.01: 10 % of k_disk -> 0.1 % of k_MS
    assert_allclose(known.disk_std, 0.01 * 0.1 * k_disk, rtol=1e-9)
    # the paper's rigid-disk assumption with a disk only 10x stiffer: -9.1 % but within 2 sigma
    rigid = calibrate_k_ms(f2, TABLE1)
    assert_allclose(rigid.k_MS, series_stiffness(k_disk, 114e6), rtol=1e-9)
    z = (114e6 - rigid.k_MS) / rigid.k_MS_std
    assert 1.5 < z < 2.0  # sqrt(3) * 1/1.1 ... the edge of the assumed range, not beyond 2 sigma
    with pytest.raises(InversionError):
        calibrate_k_ms(1400.0, TABLE1)


def test_forward_helper():
    assert_allclose(housing_freq_from_k_tb_ms(4.397e7, TABLE1), 626.0, rtol=1e-4)


def test_fit_rig_recovers_perturbed_parameters():
    truth = replace(TABLE1, k_S=360e6, m_S=2.7)
    k_true = 4.2e7
    m = RigModel(truth, k_true)
    z = np.array([0.02, 0.015, 0.01])
    f = np.arange(150.0, 700.5, 1.0)
    h = m.frf(f, damping_ratio=z, frf_form="accelerance", outputs=(0, 1))
    fit = fit_rig(f, h[0], h[1], TABLE1, k_TB_MS=3.8e7, damping_ratio=(0.02, 0.03, 0.01),
                  spindle_freq=m.spindle_freq, fit=("k_TB_MS", "k_S", "m_S"), prior_rel_std=math.inf)
    # noise-free data and the right model, no prior: the fit lands on the truth (optimiser tolerance)
    assert_allclose(fit.k_TB_MS, k_true, rtol=1e-4)
    assert_allclose(fit.damping_ratio[1], 0.015, rtol=1e-3)
    assert_allclose(fit.natural_freq, m.natural_freq, rtol=1e-4)
    assert fit.residual_rms < 1e-5
    rows = {r["name"]: r for r in fit.to_records()}
    assert_allclose(rows["k_TB_MS"]["fitted"], k_true, rtol=1e-4)


def test_fit_rig_on_simulated_rig_with_extra_modes(rig_file):
    from ema_rig.config import load_rig
    from ema_rig.simulate import simulate_measurement

    rig = load_rig(rig_file)
    sim = simulate_measurement(rig, k_tb=7.16e7, seed=1, references=("radial",))
    d = sim.data
    fit = fit_rig(d.freq, d.sel(out="11+Y").frf[0, 0], d.sel(out="21+Y").frf[0, 0], rig.model,
                  f_housing=sim.truth["f_H"], spindle_freq=sim.truth["f_spindle"])
    # modes the model lacks (287 Hz spindle, 300 Hz axial, flexible) and 1 % noise: the robust,
    # frequency-anchored fit stays within 2 % of the true k_TB+MS and 0.2 % of both frequencies
    assert abs(fit.k_TB_MS / sim.truth["k_TB_MS"] - 1) < 0.02
    assert_allclose(fit.natural_freq[1:], [sim.truth["f_H"], sim.truth["f_spindle"]], rtol=2e-3)
    assert fit.success and fit.residual_rms < 0.3


@pytest.mark.parametrize("zeta", [0.0, 0.02, 0.1, 0.3])
def test_undamped_freq_against_complex_eigenvalues(zeta):
    # oracle: the poles of a single DOF solved directly, m s^2 + k (1 + j eta) = 0 (hysteretic)
    # and m s^2 + c s + k = 0 (viscous); the identified quantities are |s| / 2 pi and -Re s / |s|
    m, k = 2.566, 4.0e7
    f0 = math.sqrt(k / m) / (2 * math.pi)
    eta = math.tan(2 * math.asin(zeta))
    s_h = 1j * math.sqrt(k / m) * np.sqrt(1 + 1j * eta)
    s_h = complex(s_h if s_h.imag > 0 else -s_h)
    f_abs, z_id = abs(s_h) / (2 * math.pi), -s_h.real / abs(s_h)
    assert z_id == pytest.approx(zeta, abs=1e-12)
    f_hyst, u = undamped_freq(f_abs, z_id, "hysteretic")
    assert f_hyst == pytest.approx(f0, rel=1e-12)
    # the viscous reading of the same pole is off by exactly the term's half-width delta
    f_visc, _ = undamped_freq(f_abs, z_id, "viscous")
    assert f_visc / f0 - 1 == pytest.approx(1 / math.sqrt(1 - 2 * zeta**2) - 1, rel=1e-9)
    assert u * math.sqrt(3) == pytest.approx(1 - math.sqrt(1 - 2 * zeta**2), rel=1e-12)
    c = 2 * zeta * math.sqrt(k * m)
    s_v = np.roots([m, c, k])
    s_v = complex(s_v[np.argmax(s_v.imag)])
    assert undamped_freq(abs(s_v) / (2 * math.pi), -s_v.real / abs(s_v))[0] == pytest.approx(f0, rel=1e-12)
    with pytest.raises(ValueError):
        undamped_freq(f_abs, z_id, "coulomb")


def test_budget_kinds_and_model_form_terms():
    # every parameter from the rig file except k_B (default 10 %), plus a 0.5 % model-form term
    rel = {k: 0.0 for k in ("m_H", "m_S", "m_F", "k_MS", "k_AS", "k_S")}
    u = stiffness_uncertainty(626.0, 0.626, TABLE1, rel, model_form={"neighbour": 0.005})
    kinds = {t.name: t.kind for t in u.terms}
    assert kinds["f_H"] == "measured" and kinds["m_H"] == "assumed (rig file)"
    assert kinds["k_B"] == "assumed (default)" and kinds["neighbour"] == "model form"
    assert u.defaults_used == ("k_B",)
    # measured: S_f * 0.1 % = 0.384 %; model form: S_f * 0.5 % (same sensitivity as f_H)
    s_f = sensitivities(626.0, TABLE1)["f_H"]
    assert u.k_TB_std_measured / u.k_TB == pytest.approx(s_f * 1e-3, rel=1e-9)
    assert u.term("neighbour").std / u.k_TB == pytest.approx(s_f * 5e-3, rel=1e-9)
    assert u.k_TB_std == pytest.approx(math.sqrt(sum(t.std**2 for t in u.terms)), rel=1e-12)
    assert u.std_of("model form") == pytest.approx(u.term("neighbour").std, rel=1e-12)
    with pytest.raises(ValueError, match="clashes"):
        stiffness_uncertainty(626.0, 0.6, TABLE1, model_form={"m_H": 0.01})
