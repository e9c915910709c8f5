"""Tests of the synthetic rig measurements (ema_rig.simulate)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from numpy.testing import assert_allclose

from ema_rig.config import load_rig
from ema_rig.dof import DOF
from ema_rig.rig.model import RigModel
from ema_rig.simulate import simulate_measurement, truth_path

K_TB = 7.157e7  # N/m, the paper's 6302 at 626 Hz


@pytest.fixture
def rig(rig_file):
    return load_rig(rig_file)


def _exact(rig, k_tb, freq):
    m = RigModel.from_k_tb(rig.model, k_tb)
    return m, m.frf(freq, damping_ratio=[0.03, 0.02, 0.01], frf_form="accelerance", outputs=(0, 1))


def test_truth_is_the_3dof_model(rig):
    sim = simulate_measurement(rig, k_tb=K_TB)
    m = RigModel.from_k_tb(rig.model, K_TB)
    # the truth's housing frequency is the 3DOF model's (same eigh computation)
    assert_allclose(sim.truth["f_H"], m.housing_freq, rtol=1e-12)
    assert_allclose(sim.truth["f_H"], 626.0, atol=0.05)  # DESIGN §4: 7.157e7 N/m <-> 626 Hz
    assert_allclose(sim.truth["k_TB_MS"], 4.397e7, rtol=2e-4)
    kinds = {mo["kind"] for mo in sim.truth["modes"]}
    assert {"housing_radial", "housing_tilt", "spindle_first", "housing_axial", "housing_lateral",
            "flexible", "spindle_axial", "rigid_body"} <= kinds
    d = sim.data
    # default: both references of the rig file
    assert d.shape == (8, 2, 4001) and d.freq[-1] == 2000.0 and d.frf_form == "accelerance"
    assert DOF.parse("13+Y") in d.out_dofs  # sign-corrected DOFs
    assert d.in_dofs == (DOF.parse("11+Y"), DOF.parse("15+X"))
    assert simulate_measurement(rig, k_tb=K_TB, references=("radial",)).data.n_in == 1
    # DESIGN §4: housing-mode effective mass ≈ 2.64 kg; flexible modes many times larger
    assert_allclose(sim.truth["housing_effective_mass"], 2.64, atol=0.01)
    flex = [mo["effective_mass_dp"] for mo in sim.truth["modes"] if mo["kind"] == "flexible"]
    assert min(flex) > 5 * 2.64


def test_radial_dynamics_exactly_3dof_without_extras(rig):
    sim = simulate_measurement(rig, k_tb=K_TB, noise=0.0, extra_modes=False, misalignment_deg=0.0)
    _, h = _exact(rig, K_TB, sim.data.freq)
    d = sim.data
    # same modal sum: equal to rounding
    for dof in ("11+Y", "12+Y", "13+Y"):
        assert_allclose(d.sel(out=dof).frf[0, 0], h[0], rtol=1e-12, atol=1e-12)
    for dof in ("21+Y", "22+Y"):
        assert_allclose(d.sel(out=dof).frf[0, 0], h[1], rtol=1e-12, atol=1e-12)


def test_askew_radial_sensors_do_not_see_exactly_x_h(rig):
    # default: every sensor tilted by its seeded angles (a, b) towards its two transverse axes.
    # Without the extra modes, the housing only moves radially; the lateral and axial housing
    # sensors see 2 % of x_H (cross-axis), so radial housing sensor j measures
    # cos(hypot(a, b)) x_H + 0.02 (sin a + sin b) x_H: a gain, not x_H itself
    sim = simulate_measurement(rig, k_tb=K_TB, noise=0.0, extra_modes=False)
    _, h = _exact(rig, K_TB, sim.data.freq)
    tilt = np.deg2rad(np.array(sim.truth["misalignment_deg"]))
    assert 1.0 < np.degrees(np.abs(tilt)).max() < 12.0  # "a few degrees"
    k = 600  # 300 Hz
    for j, dof in enumerate(("11+Y", "12+Y", "13+Y")):
        a, b = tilt[j]
        gain = math.cos(math.hypot(a, b)) + 0.02 * (math.sin(a) + math.sin(b))
        got = sim.data.sel(out=dof).frf[0, 0, k] / h[0, k]
        assert_allclose(got, gain, rtol=1e-8)  # the truth stores the angles to 1e-6 degree
        assert abs(got - 1.0) > 1e-4  # not exactly x_H
    # with the extra modes, a radial housing sensor also sees the lateral housing mode (0.88 f_H)
    # through its tilt: the askew sensor's FRF differs from the aligned one's there by > 1 %
    full = simulate_measurement(rig, k_tb=K_TB, noise=0.0)
    straight = simulate_measurement(rig, k_tb=K_TB, noise=0.0, misalignment_deg=0.0)
    i = np.searchsorted(full.data.freq, 0.88 * full.truth["f_H"])
    d = np.abs(full.data.frf[1, 0, i] / straight.data.frf[1, 0, i] - 1.0)
    assert d > 0.01


def test_appendage_couples_to_the_housing_mode(rig):
    # a 50 g appendage (2 % of m_H) tuned 1 % above the housing mode: the 4DOF poles, found here
    # by brentq on det(K - w^2 M) of matrices written out by hand, are the simulator's, and the
    # housing mode splits into two peaks the 3DOF model cannot explain
    from scipy.optimize import brentq

    p = rig.model
    f_h = RigModel.from_k_tb(p, K_TB).housing_freq
    m_a, f_a = 0.05, 1.01 * f_h
    k_a = m_a * (2 * math.pi * f_a) ** 2
    kc = 1.0 / (1.0 / K_TB + 1.0 / p.k_MS)
    kk = np.array(
        [
            [p.k_AS + kc + k_a, -kc, -p.k_AS, -k_a],
            [-kc, kc + p.k_S, -p.k_S, 0.0],
            [-p.k_AS, -p.k_S, p.k_AS + p.k_S + p.k_B, 0.0],
            [-k_a, 0.0, 0.0, k_a],
        ]
    )
    mm = np.diag([p.m_H, p.m_S, p.m_F, m_a])

    def det(f):
        return np.linalg.det(kk - (2 * math.pi * f) ** 2 * mm)

    lo = brentq(det, 0.8 * f_h, min(f_h, f_a) - 1e-6)
    hi = brentq(det, max(f_h, f_a) + 1e-6, 1.2 * f_h)
    sim = simulate_measurement(rig, k_tb=K_TB, noise=0.0, extra_modes=False, appendage=(m_a, f_a))
    got = sorted(m["natural_freq"] for m in sim.truth["modes"] if m["kind"] in ("housing_radial", "appendage"))
    assert_allclose(got, [lo, hi], rtol=1e-9)
    # the split is several Hz wide (coupled, not a small perturbation) and the truth stays the bearing's
    assert hi - lo > 0.05 * f_h
    assert sim.truth["k_TB"] == K_TB and sim.truth["appendage"] == {"mass": m_a, "freq": f_a}
    # both poles show in the driving point: two peaks near f_H
    f = sim.data.freq
    mag = np.abs(sim.data.frf[0, 0])
    for fr in (lo, hi):
        band = (f > fr - 3) & (f < fr + 3)
        assert mag[band].max() > 3 * mag[np.searchsorted(f, 0.5 * (lo + hi))]
    with pytest.raises(ValueError, match="appendage"):
        simulate_measurement(rig, k_tb=K_TB, appendage=(-1.0, 600.0))
    with pytest.raises(ValueError, match="misalignment_deg"):
        simulate_measurement(rig, k_tb=K_TB, misalignment_deg=float("nan"))


def test_driving_point_near_housing_mode_within_noise(rig):
    sim = simulate_measurement(rig, k_tb=K_TB, noise=0.01, seed=4, extra_modes=False)
    _, h = _exact(rig, K_TB, sim.data.freq)
    band = (sim.data.freq > 560) & (sim.data.freq < 690)
    rel = np.abs(sim.data.frf[0, 0, band] / h[0, band] - 1)
    # 1 % complex relative noise (+ a 5 % floor of it): RMS deviation ≈ 1 %, never > 5 sigma
    assert 0.007 < np.sqrt(np.mean(rel**2)) < 0.013
    assert rel.max() < 0.05


def test_extra_modes_leave_the_housing_peak_alone(rig):
    plain = simulate_measurement(rig, k_tb=K_TB, noise=0.0, extra_modes=False).data
    full = simulate_measurement(rig, k_tb=K_TB, noise=0.0).data
    near = (plain.freq > 615) & (plain.freq < 637)
    rel = np.abs(full.frf[0, 0, near] / plain.frf[0, 0, near] - 1)
    # the extra modes are far away or have large mass at the driving point: < 3 % at the peak
    assert rel.max() < 0.03
    # the magnitude peak moves by at most one line (0.5 Hz): the pole itself is the 3DOF one
    fp = plain.freq[near]
    assert abs(fp[np.argmax(np.abs(full.frf[0, 0, near]))] - fp[np.argmax(np.abs(plain.frf[0, 0, near]))]) <= 0.5
    # but the extra modes are there: the axial driving point shows the 302 Hz axial mode ...
    ax = full.sel(out="15+X", inp="15+X").frf[0, 0]
    i302, i250 = np.searchsorted(full.freq, [302.0, 250.0])
    assert abs(ax[i302]) > 10 * abs(ax[i250])
    # ... and the tilt modes move the radial housing sensors out of phase (112 Hz)
    i = np.searchsorted(full.freq, 112.0)
    tilt = full.frf[:, 0, i] - plain.frf[:, 0, i]
    assert np.real(tilt[0] * np.conj(tilt[2])) < 0  # 11+Y against 13+Y


def test_harmonic_lines_at_multiples_of_speed(rig):
    still = simulate_measurement(rig, k_tb=K_TB, noise=0.0)
    rot = simulate_measurement(rig, k_tb=K_TB, noise=0.0, speed_hz=25.0, seed=1)
    diff = np.abs(rot.data.frf - still.data.frf)[0, 0]
    f = still.data.freq
    lines = [mo["natural_freq"] for mo in rot.truth["modes"] if mo["kind"] == "harmonic"]
    assert_allclose(lines, 25.0 * np.arange(1, 13))  # 12 harmonics by default
    for fk in lines:
        i = np.searchsorted(f, fk)
        # narrow: the line's excess at f_k is > 5 x that one line (0.5 Hz) away
        assert diff[i] > 5 * max(diff[i - 1], diff[i + 1]), fk
        assert diff[i] > 0.01 * abs(still.data.frf[0, 0, i])
    assert all(mo["damping_ratio"] < 1e-3 for mo in rot.truth["modes"] if mo["kind"] == "harmonic")


def test_seeded_reproducibility(rig):
    a = simulate_measurement(rig, k_tb=K_TB, seed=7, speed_hz=20.0)
    b = simulate_measurement(rig, k_tb=K_TB, seed=7, speed_hz=20.0)
    c = simulate_measurement(rig, k_tb=K_TB, seed=8, speed_hz=20.0)
    assert np.array_equal(a.data.frf, b.data.frf)  # bit-identical
    assert not np.array_equal(a.data.frf, c.data.frf)
    # the shapes of the extra modes do not depend on the seed: noise-free runs agree
    n1 = simulate_measurement(rig, k_tb=K_TB, seed=1, noise=0.0)
    n2 = simulate_measurement(rig, k_tb=K_TB, seed=2, noise=0.0)
    assert np.array_equal(n1.data.frf, n2.data.frf)


def test_steel_disk_and_two_references(rig):
    # aligned sensors: an askew accelerometer measures another direction than the shaker drives,
    # so the measured cross FRFs are reciprocal only with misalignment_deg=0
    disk = simulate_measurement(rig, k_tb=math.inf, noise=0.0, references=("radial", "axial"), misalignment_deg=0.0)
    # DESIGN §4: rigid bearing -> k_TB+MS = k_MS -> housing mode at 897.35 Hz
    assert_allclose(disk.truth["f_H"], 897.35, atol=0.01)
    d = disk.data
    assert d.shape == (8, 2, 4001) and d.in_dofs == (DOF.parse("11+Y"), DOF.parse("15+X"))
    # modal superposition with symmetric shapes: reciprocal, H(11Y,15X) = H(15X,11Y)
    assert_allclose(d.sel(out="11+Y", inp="15+X").frf, d.sel(out="15+X", inp="11+Y").frf, rtol=1e-12)


def test_bad_input(rig_toml_text, tmp_path, rig):
    with pytest.raises(ValueError, match="k_tb"):
        simulate_measurement(rig, k_tb=-1.0)
    with pytest.raises(ValueError, match="damping"):
        simulate_measurement(rig, k_tb=K_TB, damping={"wobble": 0.1})
    # a negative seed was numpy's "expected non-negative integer", which the CLI blamed on the rig
    for seed in (-1, 1.5, True):
        with pytest.raises(ValueError, match="seed must be an integer >= 0"):
            simulate_measurement(rig, k_tb=K_TB, seed=seed)
    with pytest.raises(ValueError, match="speed_hz"):
        simulate_measurement(rig, k_tb=K_TB, speed_hz=math.nan)
    text = rig_toml_text.replace('axial = "15+X"\n\n[[sensor]]', "\n[[sensor]]", 1)
    (tmp_path / "r2.toml").write_text(text)
    with pytest.raises(ValueError, match="axial"):
        simulate_measurement(load_rig(tmp_path / "r2.toml"), k_tb=K_TB, references=("axial",))


def test_write_and_read_back(rig, rig_file, tmp_path):
    uff = pytest.importorskip("ema_rig.io.uff")
    from ema_rig.cli import main
    from ema_rig.simulate import write_measurement

    sim = simulate_measurement(rig, k_tb=K_TB, seed=3, speed_hz=10.0)
    for binary, unit in ((False, "g"), (True, "m/s^2")):
        p = write_measurement(sim, tmp_path / f"m_{int(binary)}.uff", binary=binary, accel_unit=unit, rig=rig)
        back = uff.read_uff58(p, rig=rig)
        assert back.out_dofs == sim.data.out_dofs
        # double precision round trip (ASCII keeps ~13 significant digits)
        assert_allclose(back.frf, sim.data.frf, rtol=1e-9, atol=1e-12 * np.abs(sim.data.frf).max())
        truth = json.loads(truth_path(p).read_text())
        assert_allclose(truth["f_H"], sim.truth["f_H"], rtol=1e-15)
    out = tmp_path / "cli.uff"
    code = main(["simulate", "--rig", str(rig_file), "--k-tb", "3.2e7", "-o", str(out), "--seed", "2",
                 "--binary", "--units", "g", "--speed", "600"])
    assert code == 0 and out.exists()
    t = json.loads(truth_path(out).read_text())
    assert t["k_TB"] == 3.2e7 and t["speed_hz"] == 10.0
    assert_allclose(t["f_H"], RigModel.from_k_tb(rig.model, 3.2e7).housing_freq, rtol=1e-12)


def _local_pole(freq, h, f0, half=25.0):
    """Natural frequency [Hz] of one pole pair fitted (linear LS, Levy) to ``h`` within ``f0 ± half``."""
    sel = (freq > f0 - half) & (freq < f0 + half)
    s, hh = 1j * freq[sel] / f0, h[sel]
    a = np.column_stack([-hh * s, -hh] + [s**k for k in range(4)])  # H (s^2 + b1 s + b0) = poly(s)
    a2, y2 = np.vstack([a.real, a.imag]), np.concatenate([(hh * s**2).real, (hh * s**2).imag])
    b1, b0 = np.linalg.lstsq(a2, y2, rcond=None)[0][:2]
    return f0 * math.sqrt(b0)  # |lambda| = sqrt(b0) in units of f0


@pytest.mark.parametrize("k_tb, speed", [(32.09e6, None), (7.16e7, 20.0), (8.18e7, 40.0)])
def test_honest_local_identification_within_1_percent(rig, k_tb, speed):
    from ema_rig.rig.inversion import k_tb_from_housing_freq

    sim = simulate_measurement(rig, k_tb=k_tb, seed=5, speed_hz=speed)
    d = sim.data.sel(out=["11+Y", "12+Y", "13+Y"], inp="11+Y").to_form("receptance")
    f0 = sim.truth["f_H"]
    f_est = np.mean([_local_pole(d.freq, d.frf[i, 0], f0) for i in range(3)])
    # all extra modes, harmonics and 1 % noise: a crude one-pole local fit still gives k_TB
    # within 0.3 % (the brief asks for 1 % from an honest identification)
    assert abs(k_tb_from_housing_freq(f_est, rig.model) / k_tb - 1) < 0.003


@pytest.mark.parametrize(("mass_frac", "f_a"), [(0.01, 600.0), (0.01, 660.0), (0.02, 640.0)])
def test_appendage_obeys_the_k_tb_rule(rig, mass_frac, f_a):
    # issue 11 rule on the simulator's own coupling (askew sensors, extra modes, 1 % noise): a
    # 1-2 % appendage of the housing within 5 % of the 626 Hz housing mode biases the inversion by
    # 5-11 %; the result must then carry a warning and lie within 2 sigma, or be refused
    from ema_rig.errors import EmaRigError
    from ema_rig.rig.stiffness import estimate_stiffness

    sim = simulate_measurement(rig, k_tb=K_TB, seed=3, appendage=(mass_frac * rig.model.m_H, f_a))
    try:
        res = estimate_stiffness(sim.data, rig)
    except EmaRigError as exc:
        assert str(exc)  # refused, with a reason
        return
    z = (res.k_TB - K_TB) / res.k_TB_std
    assert abs(z) <= 2.0, (res.k_TB, res.k_TB_std)
    if abs(res.k_TB / K_TB - 1) > 0.01:
        # said: a warning, or (issue 19) the split-housing fit resolved it with a stated m_H term
        assert (any("share the radial housing motion" in w for w in res.warnings)
                or any("appendage fitted" in n for n in res.notes)), (res.warnings, res.notes)
