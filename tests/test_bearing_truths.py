"""The bearing beyond the 3DOF inversion (issue 19): attached masses, bearing damping, a bearing
cross stiffness, an off m_H, against the independent truths of ``tests/rig_truth.py`` (which
imports nothing from ema_rig; UFF58 written by pyuff).

One seed per class keeps the runtime small; ``benchmarks/study_bearing_truths.py`` runs the
classes over many seeds and counts silent failures.
"""

from __future__ import annotations

import dataclasses
import json
import math
import re

import numpy as np
import pytest
from rig_truth import TABLE1, RigTruth, measurement, rig_text, write_case, write_uff

from ema_rig.cli import main
from ema_rig.config import ModelParams, load_rig
from ema_rig.errors import ConfigError, MatchingError
from ema_rig.io.uff import read_uff58
from ema_rig.rig import stiffness as st
from ema_rig.rig.damping import bearing_damping

pytest.importorskip("ema_rig.identification")

FREQ = np.arange(0.0, 1100.25, 0.5)
TABLE1_PARAMS = ModelParams(**TABLE1)


def _estimate(tmp_path, name, truth, **kw):
    uff, rig_path = write_case(tmp_path, name, truth, FREQ)
    rig = load_rig(rig_path)
    return st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False, **kw)


def _z(res, truth):
    return (res.k_TB - truth.k_TB) / res.k_TB_std


# ----------------------------------------------------------------------------- rig file
def test_attached_masses_enter_the_model_with_their_tolerance(tmp_path):
    text = rig_text(sensor_mass=0.010) + (
        '\n[[mass]]\nname = "impedance head"\nmass = 0.020\nmass_std = 0.001\non = "housing"\n'
        'position = [0.0, 0.05, 0.0]\n\n[[mass]]\nmass = 0.030\non = "spindle"\n')
    path = tmp_path / "rig.toml"
    path.write_text(text)
    rig = load_rig(path)
    # five 10 g housing sensors + a 20 g head on the housing; 30 g on the spindle
    assert rig.model.m_H == pytest.approx(2.566 + 5 * 0.010 + 0.020, rel=1e-12)
    assert rig.model.m_S == pytest.approx(2.8 + 0.030, rel=1e-12)
    assert rig.declared_model is not None and rig.declared_model.m_H == 2.566
    # u(m_H)^2 = (0.5 % of 2.566)^2 + 5 (10 % of 10 g)^2 + (1 g)^2, relative to the effective mass
    u = math.sqrt((0.005 * 2.566) ** 2 + 5 * 0.001**2 + 0.001**2) / rig.model.m_H
    assert rig.uncertainty["m_H"] == pytest.approx(u, rel=1e-12)
    assert len(rig.added_masses) == 7 and rig.added_masses[0].position == (0.004, 0.045, 0.008)


@pytest.mark.parametrize("table, key", [
    ('[[mass]]\non = "housing"\n', "mass[0].mass"),
    ('[[mass]]\nmass = 0.01\non = "frame"\n', "mass[0].on"),
    ('[[mass]]\nmass = 0.01\non = "housing"\nposition = [0.0, 1.0]\n', "mass[0].position"),
    ('[[mass]]\nmass = -0.01\non = "housing"\n', "mass[0].mass"),
    ('[[mass]]\nmass = 0.01\non = "housing"\ncolour = "red"\n', "mass[0].colour"),
])
def test_bad_mass_tables_name_the_key(tmp_path, table, key):
    path = tmp_path / "rig.toml"
    path.write_text(rig_text() + "\n" + table)
    with pytest.raises(ConfigError) as ei:
        load_rig(path)
    assert key in str(ei.value) and str(path) in str(ei.value)


# ----------------------------------------------------------------------------- damping
def test_bearing_damping_inverts_the_truths_complex_pole():
    # oracle: the truth's housing eigenvalue (complex, bearing impedance in series with k_MS,
    # 5 % bushing dashpot) read back through the 3DOF model; the bushing's damping is the only
    # damping the model does not hold (0.1 % of c_TB here)
    for c in (500.0, 2000.0):
        s = RigTruth(k_TB=70e6, damping="bearing_viscous", c_TB=c).housing_pole()
        d = bearing_damping(abs(s) / (2 * math.pi), -s.real / abs(s), TABLE1_PARAMS)
        assert d.c_TB == pytest.approx(c, rel=2e-3)
        assert d.k_TB == pytest.approx(70e6, rel=1e-5)
    s = RigTruth(k_TB=70e6, damping="bearing_hysteretic", eta_TB=0.1).housing_pole()
    d = bearing_damping(abs(s) / (2 * math.pi), -s.real / abs(s), TABLE1_PARAMS, model="hysteretic")
    assert d.loss_factor == pytest.approx(0.1, rel=1e-3)


def test_viscous_bearing_damping_within_2_sigma(tmp_path):
    truth = RigTruth(k_TB=65e6, damping="bearing_viscous", c_TB=1200.0, seed=3)
    res = _estimate(tmp_path, "visc", truth)
    assert res.warnings == ()
    # c_TB from the identified pole (2 % noise): within 2 sigma. The housing mode's phase measures the
    # bearing's share of the damping (here 100 +/- 26 %: the accelerometers' 0.01 rad against the
    # bearing's ~3 deg), so c_TB is a measurement whose sigma is mostly the share's; the issue-19 target
    # sigma <= 10 % holds for the all-in-the-bearing reading beside it, the upper bound, which on this
    # truth (all of the damping in the bearing but the bushings' 0.1 %) is the dashpot itself
    assert res.damping.kind == "measured"
    assert abs(res.c_TB - 1200.0) <= 2 * res.c_TB_std
    assert res.c_TB_std / res.c_TB <= 0.30
    assert abs(res.damping.c_TB_upper - 1200.0) <= 2 * res.damping.c_TB_upper_std
    assert res.damping.c_TB_upper_std / res.damping.c_TB_upper <= 0.10
    # the equivalent loss factor at the housing mode: eta = c w / k, w = |lambda| (damping._read; the
    # frequency inverted is the pole read with the bearing's share of the damping, not |lambda|)
    w = 2 * math.pi * res.housing_mode["natural_freq"]
    assert res.loss_factor == pytest.approx(res.c_TB * w / res.damping.k_TB, rel=1e-9)


def test_hysteretic_bearing_loss_factor_within_2_sigma(tmp_path):
    truth = RigTruth(k_TB=55e6, damping="bearing_hysteretic", eta_TB=0.08, seed=4)
    res = _estimate(tmp_path, "hyst", truth, damping_model="hysteretic")
    assert abs(res.loss_factor - 0.08) <= 2 * res.loss_factor_std
    assert res.loss_factor_std / res.loss_factor <= 0.10


def test_cli_and_json_carry_the_damping(tmp_path, capsys):
    truth = RigTruth(k_TB=65e6, damping="bearing_viscous", c_TB=1200.0, seed=3)
    uff, rig_path = write_case(tmp_path, "cli", truth, FREQ)
    out = tmp_path / "res.json"
    assert main(["stiffness", str(uff), "--rig", str(rig_path), "--no-spindle", "--json", str(out)]) == 0
    text = capsys.readouterr().out
    assert "c_TB" in text and "housing mass" in text
    doc = json.loads(out.read_text())
    assert {"c_TB", "c_TB_std", "loss_factor", "loss_factor_std"} <= set(doc)
    assert abs(doc["c_TB"] - 1200.0) <= 2 * doc["c_TB_std"]


# ----------------------------------------------------------------------------- coupling
def test_axial_partner_corrected_without_warning(tmp_path):
    # a bearing cross stiffness leaks 7.5 % of the housing mode into its axial rigid-body motion
    # (partner 509 Hz): the plain inversion is 3-4 % off; the two-mode reduction recovers it
    truth = RigTruth(k_TB=57.38e6, cross_axis="axial", axial_freq=508.5, cross_leak=0.075, seed=3)
    res = _estimate(tmp_path, "axial", truth)
    assert any("bearing cross coupling" in n for n in res.notes)
    assert "axial coupling" in res.uncertainty.shares
    assert res.warnings == () and abs(_z(res, truth)) < 2.0
    # the uncorrected reading lies far outside: the correction is doing the work
    assert res.inverted_freq < 0.99 * res.housing_mode["natural_freq"]


def test_lateral_partner_pair_measures_the_housing_mass(tmp_path):
    # 5.9 % of the housing mode in a 417 Hz lateral partner: the housing mode's own driving-point
    # mass is 6 % above the model's, the pair's (1/m_1 + 1/m_2)^-1 is the uncoupled housing's, so
    # m_H keeps its tolerance (issue-19 study, lateral seed 6: sigma 9.3 % with the m_H tolerance
    # widened to the discrepancy, 1.4 % with the pair)
    truth = RigTruth(k_TB=49.731e6, cross_axis="lateral", lateral_freq=416.774, cross_leak=0.05867, seed=6)
    res = _estimate(tmp_path, "lat", truth)
    assert any("bearing cross coupling" in n for n in res.notes)
    assert not any("m_H tolerance widened" in n for n in res.notes)
    assert res.warnings == () and abs(_z(res, truth)) < 2.0
    assert res.k_TB_std / res.k_TB < 0.03


@pytest.mark.parametrize(("lateral_freq", "leak", "seed"), [(635.0, 0.30, 1), (632.0, 0.40, 5)])
def test_strongly_mixed_lateral_pair_is_decoupled(tmp_path, lateral_freq, leak, seed):
    # the housing's lateral mode 1-1.5 % above the radial housing mode, a bearing cross stiffness
    # putting 30-40 % of the housing mode's energy into the lateral motion (r_truth11's "lateral
    # mode 1-2 % from the housing mode"): both modes move the lateral sensors 0.65-0.75x the radial
    # ones, so no mode passed the 0.5 cross-axis criterion and the run was refused ("nearest ...:
    # lateral mode"). The two-mode reduction of the pair gives the uncoupled housing frequency:
    # the truth's k_TB within 2 sigma, no warning (the pair is a resolved result, not a caveat)
    truth = RigTruth(k_TB=71.57e6, cross_axis="lateral", lateral_freq=lateral_freq, cross_leak=leak, seed=seed)
    res = _estimate(tmp_path, "mixed", truth)
    assert res.housing_mode["lateral_ratio"] > 0.5  # the pair is mixed beyond the old criterion
    assert any("bearing cross coupling" in n for n in res.notes)
    assert "lateral coupling" in res.uncertainty.shares
    assert res.warnings == () and abs(_z(res, truth)) < 2.0
    # the identified (mixed) frequency is >1 % below the uncoupled one: read plainly, k_TB would
    # be off by several sigma; the decoupling is doing the work
    assert res.inverted_freq > 1.01 * res.housing_mode["natural_freq"]


def test_mixed_pair_with_a_miscalibrated_lateral_sensor_is_refused_for_its_true_reason(tmp_path):
    # the strongly mixed pair above, the lateral sensor reading twice the truth (a wrong
    # sensitivity): the housing mode's lateral/radial ratio doubles, the partner's radial/lateral
    # halves, so the two tell mixings 16x apart, no two-mode coupling. The refusal names the mixed
    # pair and why (it said "nearest ...: lateral mode" before)
    from scipy.linalg import eigh

    truth = RigTruth(k_TB=71.57e6, cross_axis="lateral", lateral_freq=635.0, cross_leak=0.30, seed=1)
    meas = measurement(truth, FREQ)
    frf = meas.frf.copy()
    frf[meas.out.index("14+Z")] *= 2.0
    uff = write_uff(tmp_path / "gain.uff", dataclasses.replace(meas, frf=frf))
    rig_path = tmp_path / "gain.toml"
    rig_path.write_text(truth.rig_file_text(dict(truth.params), ()), encoding="utf-8")
    rig = load_rig(rig_path)
    with pytest.raises(MatchingError) as exc:
        st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)
    msg = str(exc.value)
    assert "radial housing mode is mixed with the lateral mode at" in msg and "different mixings" in msg
    # the partner named is the truth's lateral-dominated mode of the pair (scipy's eigenvalues of
    # the truth's M, K: the mode with most kinetic energy in z_H), to the identification's 0.5 %
    m, k = truth.matrices()
    lam, phi = eigh(k, m)
    lat = int(np.argmax(m[5, 5] * phi[5] ** 2))
    f_lat = math.sqrt(lam[lat]) / (2 * math.pi)
    named = float(re.search(r"lateral mode at ([0-9.]+) Hz", msg).group(1))
    assert named == pytest.approx(f_lat, rel=5e-3)


def test_unresolved_partner_is_never_silent(tmp_path):
    # partner at 692 Hz merges with the 695 Hz flexible housing mode: no consistent partner
    truth = RigTruth(k_TB=72.65e6, cross_axis="axial", axial_freq=691.85, cross_leak=0.04, seed=4)
    res = _estimate(tmp_path, "merge", truth)
    assert res.warnings or abs(_z(res, truth)) <= 2.0
    assert any("axial sensors" in w for w in res.warnings)


# ----------------------------------------------------------------------------- masses
def test_off_m_h_measured_where_the_force_chain_is_trusted(tmp_path):
    truth = RigTruth(k_TB=66.3e6, file_m_H_factor=1.03, file_force_chain=0.005, seed=2)
    res = _estimate(tmp_path, "mh", truth)
    # outside the rig file's tolerance the data measure m_H: a result (issue 19), not a caveat
    hm = res.housing_mass
    assert hm is not None and not hm.agrees and hm.used == hm.measured
    assert hm.rig_file == pytest.approx(1.03 * 2.566, rel=1e-12)
    # the truth's housing mass (2.566 kg) within 2 sigma; sigma from the fit and the stated 0.5 %
    # force chain: about 0.6 % here (a 10x regression fails)
    assert abs(hm.measured - 2.566) <= 2 * hm.measured_std
    assert hm.measured_std / hm.measured < 0.012
    assert res.warnings == () and any("housing mass measured" in n for n in res.notes)
    doc = res.to_dict()["housing_mass"]
    assert doc["source"] == "measured" and doc["m_H_used"] == pytest.approx(hm.measured, rel=1e-12)
    assert res.uncertainty.term("m_H").kind == "measured"
    assert abs(_z(res, truth)) < 2.0
    assert res.k_TB_std / res.k_TB < 0.03


def test_driving_point_mass_carries_the_identified_damping_std(tmp_path):
    # 17 g sensors on the five housing positions, 0.5 % force chain (seed 7 of the study's sensor
    # classes): the pole re-estimated on the driving point alone gave a mass 2.1 % high at z 2.6;
    # the identified pole (every channel) with its damping ratio's std carried is within 0.3 %
    import rig_truth

    truth = RigTruth(k_TB=80.88e6, sensor_mass=0.01708, file_force_chain=0.005, seed=7)
    m, k = truth.matrices()
    lam, phi = rig_truth._eigh(k, m)
    i = rig_truth._housing_index(lam, phi, m)
    m_true = 1.0 / float(truth.observation()[0] @ phi[:, i]) ** 2  # the truth's driving-point modal mass
    res = _estimate(tmp_path, "dpm", truth)
    hm = res.housing_mass
    assert hm is not None
    assert abs(hm.modal_mass / m_true - 1) < 0.01
    # the measured mass's std holds the identification's damping ratio std and the force chain
    u_z = res.housing_mode["damping_ratio_std"] / res.housing_mode["damping_ratio"]
    assert u_z > 0
    assert hm.measured_std / hm.measured >= math.hypot(u_z, 0.005) * (1 - 1e-9)


def test_off_m_h_untrusted_force_chain_is_measured_with_its_std(tmp_path):
    # without a stated force chain the driving-point mass carries the default 2 % of the FRF scale;
    # the mode's spindle/housing ratio measures m_H a second time without the force chain (k_S 2 %,
    # relative calibration 0.9 %: ~2.7 %), so the combination lies between ~1.5 % and the 2 %
    truth = RigTruth(k_TB=66.3e6, file_m_H_factor=0.97, seed=2)
    res = _estimate(tmp_path, "mh2", truth)
    hm = res.housing_mass
    assert hm is not None and hm.used == hm.measured and not hm.force_chain_stated
    assert abs(hm.measured - 2.566) <= 2 * hm.measured_std
    assert 0.012 <= hm.measured_std / hm.measured < 0.02
    assert any("m_H measured twice" in n for n in res.notes)
    assert res.warnings == () and abs(_z(res, truth)) <= 2.0
    # the 3 % off rig file, inverted as it stands, is 5-6 % off: the measured mass does the work
    assert abs(res.inversion_3dof["k_TB"] / truth.k_TB - 1) > 0.04
    # the report compares the plain 3DOF inversion with the result and gives both masses
    from ema_rig.report import _comparison

    html_ = _comparison(json.loads(json.dumps(res.to_dict())))
    assert "Plain 3DOF inversion" in html_ and "Housing mass from the driving-point modal mass" in html_
    assert "spindle/housing ratio, which alone gives" in html_
    assert "used: measured" in html_


def test_declared_sensor_masses_are_carried(tmp_path):
    truth = RigTruth(k_TB=70e6, sensor_mass=0.015, seed=5)
    res = _estimate(tmp_path, "sens", truth)
    assert res.warnings == () and abs(_z(res, truth)) < 1.0
    # undeclared, the same 75 g (2.9 % of m_H) moves the plain inversion by ~-5 %; the driving-point
    # modal mass measures the housing with its sensors (2.566 + 0.075 kg within 2 sigma)
    truth2 = RigTruth(k_TB=70e6, sensor_mass=0.015, declare_sensor_masses=False, seed=5)
    res2 = _estimate(tmp_path, "sens2", truth2)
    assert res2.inversion_3dof["k_TB"] / truth2.k_TB - 1 < -0.02
    hm = res2.housing_mass
    assert hm is not None and hm.used == hm.measured
    assert abs(hm.measured - (2.566 + 5 * 0.015)) <= 2 * hm.measured_std
    assert res2.warnings == () and abs(_z(res2, truth2)) <= 2.0


# ----------------------------------------------------------------------------- rigid body
def test_axial_and_cross_stiffness_within_2_sigma(tmp_path):
    # the axial sensor 15+X sees the housing's axial rigid-body mode: k_ax = m_H w_ax^2 of the
    # truth's axial coordinate; with a corrected coupling, the cross term of the two-mode reduction
    truth = RigTruth(k_TB=57.38e6, cross_axis="axial", axial_freq=508.5, cross_leak=0.075, seed=3)
    rb = _estimate(tmp_path, "rb", truth).rigid_body
    k_ax = TABLE1["m_H"] * (2 * math.pi * 508.5) ** 2
    assert abs(rb.axial_stiffness - k_ax) <= 2 * rb.axial_stiffness_std
    assert abs(rb.cross_stiffness - truth._cross_k()) <= 2 * rb.cross_stiffness_std
    assert rb.cross_stiffness_std / rb.cross_stiffness < 0.10
    plain = RigTruth(k_TB=71.57e6, seed=3)
    rb2 = _estimate(tmp_path, "rb2", plain).rigid_body
    k_ax2 = TABLE1["m_H"] * (2 * math.pi * 301.0) ** 2
    assert abs(rb2.axial_stiffness - k_ax2) <= 2 * rb2.axial_stiffness_std
    assert rb2.cross_stiffness is None and any("tilt" in r for r in rb2.reasons)


def test_truth_generator_imports_nothing_from_ema_rig():
    # the oracle must stay independent of the code under test (issue 19)
    import ast
    from pathlib import Path

    tree = ast.parse((Path(__file__).parent / "rig_truth.py").read_text(encoding="utf-8"))
    names = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    names += [n.module or "" for n in ast.walk(tree) if isinstance(n, ast.ImportFrom)]
    assert not [m for m in names if m.split(".")[0] == "ema_rig"]


def test_a_held_mode_the_result_does_not_use_is_a_note():
    # the ML estimate holds a mode at its PolyMAX pole (the 301 Hz axial mode beside the 287 Hz
    # spindle mode on seed 2 of every study class): k_TB does not use it, so it is no caveat of
    # k_TB; held housing mode, neighbour or corrected partner stay warnings
    from types import SimpleNamespace

    fn = [300.605, 642.4, 662.8]
    w_held = "mode at 300.605 Hz held at its PolyMAX pole (the ML fit moved it); its ± is ..."
    w_other = "poor fit: median synthesis error 12 %"
    ident = SimpleNamespace(std_kind=("held", "ml", "held"), modes=SimpleNamespace(natural_freq=fn),
                            warnings=(w_held, w_other, "mode at 662.8 Hz held at its PolyMAX pole (x)"))
    m = SimpleNamespace(housing_index=1, alternatives=(), neighbours=(2,))
    warns, notes = st._identification_caveats(ident, m, SimpleNamespace(cross_axis=None))
    assert notes == [w_held] and warns == [w_other, "mode at 662.8 Hz held at its PolyMAX pole (x)"]
    # the same mode as a corrected cross-axis partner: a warning
    asm = SimpleNamespace(cross_axis=SimpleNamespace(partner_freq=300.6))
    warns, notes = st._identification_caveats(ident, m, asm)
    assert notes == [] and w_held in warns


# ----------------------------------------------------------------------------- m_H without the force chain
def test_housing_mass_from_the_mode_shape_against_an_eigen_solution():
    # oracle: the truth's 3DOF chain (rig_truth writes the matrices out; imports nothing from ema_rig)
    # solved by numpy's eigh: its housing mode's frequency and spindle/housing ratio give back m_H and
    # k_TB+MS without the force chain (closed form in ema_rig: eigenvector rows)
    import rig_truth

    from ema_rig.rig.fit import housing_mass_from_ratio

    def mode(params):
        t = RigTruth(k_TB=70e6, params=params)
        m, k = t.matrices()
        ix = np.ix_([0, 1, 2], [0, 1, 2])
        lam, phi = rig_truth._eigh(k[ix], m[ix])
        return math.sqrt(lam[1]) / (2 * math.pi), phi[1, 1] / phi[0, 1], t.k_TB_MS

    for m_h in (2.566, 2.566 * 1.03):
        f, r, k_c = mode(dict(TABLE1, m_H=m_h))
        res = housing_mass_from_ratio(f, r, TABLE1_PARAMS, {"k_S": 0.02}, 0.01)
        assert res is not None
        assert res.m_H == pytest.approx(m_h, rel=1e-9) and res.k_TB_MS == pytest.approx(k_c, rel=1e-9)
    # its k_S sensitivity against the oracle: a truth with k_S 1 % up read with the nominal k_S
    f, r, _ = mode(dict(TABLE1, k_S=1.01 * TABLE1["k_S"]))
    res = housing_mass_from_ratio(f, r, TABLE1_PARAMS, {"k_S": 0.02}, 0.01)
    s_oracle = -math.log(res.m_H / 2.566) / math.log(1.01)
    assert res.sensitivity["k_S"] == pytest.approx(s_oracle, rel=0.02)
    # ~1.2 at 626 Hz: the shape route leans on k_S about as much as the modal mass on the force chain
    assert 0.8 < res.sensitivity["k_S"] < 1.6
    assert res.rel_std == pytest.approx(math.hypot(0.02 * res.sensitivity["k_S"], 0.01 * res.sensitivity["ratio"]),
                                        rel=1e-9)


def test_undeclared_sensor_masses_measured_twice(tmp_path):
    # seed 0 of the study's class: 62 g of undeclared sensors (2.4 % of m_H), force chain not stated
    # (2 %), no sensor positions (the centre's reading within the radial sensors' spread, 1.5 %). The
    # driving-point mass alone measured m_H to 2.6 % (sigma(k_TB) 5.0 %); with the mode's
    # spindle/housing ratio as a second measurement sigma(k_TB) 3.3 %, 3.7 % with the centre's unknown
    # reading shared by both routes (the ratio is read against it once, the modal mass twice: 2.1 % on m_H)
    truth = RigTruth(k_TB=66.339e6, sensor_mass=0.012429, declare_sensor_masses=False, seed=0)
    res = _estimate(tmp_path, "und", truth)
    assert res.warnings == () and abs(_z(res, truth)) <= 2.0
    assert res.k_TB_std / res.k_TB < 0.04
    hm = res.housing_mass
    assert hm is not None and hm.source == "measured"
    assert abs(hm.measured - (2.566 + 5 * 0.012429)) <= 2 * hm.measured_std
    assert hm.measured_std / hm.measured < 0.023
    assert any("m_H measured twice" in n for n in res.notes)
    # both readings in the JSON; the shape's alone within 2 of its sigma of the truth
    doc = json.loads(json.dumps(res.to_dict()))["housing_mass"]
    assert doc["m_H_from_shape"] == pytest.approx(hm.by_shape, rel=1e-12)
    assert abs(hm.by_shape - (2.566 + 5 * 0.012429)) <= 2 * hm.by_shape_std
    # the shape route leans on k_S: its k_TB sensitivity turns positive (-0.24 direct, +0.9 through m_H)
    assert res.uncertainty.term("k_S").sensitivity > 0.3


def test_appendage_inside_the_housing_mass_keeps_its_tolerance(tmp_path):
    # seed 0 of the study's appendage class: 53 g of the 2.566 kg housing on its own spring. Both
    # modal masses agree with the rig file's m_H, so the part is inside it: sigma(k_TB) 2.8 % (the
    # blanket m_a / m_H in the m_H tolerance gave 6.0 %)
    kw = dict(k_TB=129.24e6, appendage_fraction=0.020536, flex_housing_freq=820.0, flex_frame_freq=600.0, seed=0)
    truth = RigTruth(**kw)
    res = _estimate(tmp_path, "app", truth)
    assert res.warnings == () and abs(_z(res, truth)) <= 2.0
    assert res.k_TB_std / res.k_TB < 0.031
    assert any("the appendage is inside m_H" in n for n in res.notes)
    # the same part added to a housing the rig file weighs without it: never silent
    added = RigTruth(**kw, file_m_H_factor=1 - 0.020536)
    res2 = _estimate(tmp_path, "app2", added)
    assert res2.warnings or abs(_z(res2, added)) <= 2.0
    assert not any("the appendage is inside m_H" in n for n in res2.notes)


def test_shape_mass_not_used_beside_a_neighbour(tmp_path):
    # the issue-11 truths' 10 % hysteretic damping, seed 5: beside the 690 Hz mode the housing mode's
    # spindle/housing ratio reads m_H 10.6 % high (the neighbour's shape leaks into it as its residue
    # into the modal mass); combined with the widened rig file's m_H it gave k_TB +15.7 % at z 2.5,
    # silently. Beside a neighbour the ratio is not used: within 2 sigma (or warned)
    truth = RigTruth(zeta=0.10, damping="hysteretic", seed=5)
    res = _estimate(tmp_path, "hyst5", truth)
    assert not any("spindle/housing ratio" in n for n in res.notes)
    assert res.warnings or abs(_z(res, truth)) <= 2.0
    # the shape route alone, for the record. It read m_H 10.6 % high while the identification held one
    # mode at 310 Hz where the truth has two (channels 6-8 peak at 290 Hz, channel 5 at 320 Hz); since
    # a missing mode is decided by the lines near it (issue 18, e_bands3) the 290 Hz mode is found and
    # the shape route reads 2.6 % high: within 5 % (the old 10.6 % fails)
    from ema_rig.rig.uncertainty import _mass_by_shape

    shape = _mass_by_shape(res.housing_mode, res.inverted_freq, load_rig(tmp_path / "hyst5.toml").model,
                           load_rig(tmp_path / "hyst5.toml"))
    assert shape is not None and abs(shape.m_H / 2.566 - 1) < 0.05


def _truth_driving_point_mass(truth: RigTruth, start: complex) -> float:
    """Oracle: the driving-point modal mass ``1 / (2 w_d |R|)`` of a bearing-damped truth's mode near
    ``start``, from its own matrices: the pole by a secant on the dynamic stiffness's smallest
    eigenvalue, the residue by a contour integral of the driving-point receptance around it."""
    m0, k0 = truth.matrices(k_bearing=0.0)
    damp = np.zeros_like(m0)
    for i in range(3, 12):
        damp[i, i] = 2 * truth.zeta * math.sqrt(k0[i, i] * m0[i, i]) if k0[i, i] > 0 else 0.0
    damp[2, 2] += 2 * 0.05 * math.sqrt(truth.params["k_B"] * truth.params["m_F"])
    e = np.zeros(12)
    e[0], e[1] = 1.0, -1.0
    c = truth.observation()[0]

    def dyn(s: complex) -> np.ndarray:
        return k0 + truth.bearing_impedance(complex(s / 1j)) * np.outer(e, e) + s * damp + s * s * m0

    def smallest(s: complex) -> complex:
        ev = np.linalg.eigvals(np.linalg.solve(m0, dyn(s)))
        return complex(ev[np.argmin(np.abs(ev))])

    s = start
    for _ in range(60):
        d = 1e-6 * abs(s)
        f0, f1 = smallest(s), smallest(s + d)
        step = f0 * d / (f1 - f0)
        s -= step
        if abs(step) < 1e-12 * abs(s):
            break
    r = 1e-3 * abs(s)
    pts = s + r * np.exp(2j * np.pi * np.arange(64) / 64)
    res = np.mean([(c @ np.linalg.solve(dyn(z), c)) * (z - s) for z in pts])
    return 1.0 / (2 * s.imag * abs(res))


def test_frame_mode_one_percent_away_is_fitted_as_a_modal_term(tmp_path):
    # issue 19, study seed 8 of the viscous class: the truth's 663 Hz flexible frame mode (a mode the
    # 3DOF model does not hold) sits 1 % above the housing mode (656.7 Hz, c_TB 2333 N s/m, zeta
    # 2.6 %: the pair 0.2 half-power bandwidths apart). The one-channel driving-point fit at the
    # identified poles read the modal mass +3.9 % off the truth's (z 3.2), m_H's tolerance was widened
    # to 3.6 % and sigma(c_TB) was 11.7 %. Fitted jointly with the frame mode on every channel
    # (poles free, residues per channel) the mass is measured (1.7 % here) and the rig file's m_H
    # holds: c_TB within 2 sigma with sigma <= 10 %, k_TB within 2 sigma, no warning.
    truth = RigTruth(k_TB=86.21e6, damping="bearing_viscous", c_TB=2333.3, seed=8)
    res = _estimate(tmp_path, "frame1", truth)
    fn = [float(f) for f in res.identification.modes.natural_freq]
    f_h = res.housing_mode["natural_freq"]
    assert any(0.005 < f / f_h - 1 < 0.015 for f in fn)  # the frame mode identified 1 % above
    assert any("fitted jointly" in n and n.endswith(": used") for n in res.notes)
    assert res.warnings == ()
    assert abs(res.c_TB - 2333.3) <= 2 * res.c_TB_std
    assert res.c_TB_std / res.c_TB <= 0.10
    assert abs(_z(res, truth)) <= 2.0
    # the joint fit's modal mass against the truth's own (oracle: its matrices' pole and residue,
    # 2.648 kg); the one-channel fit at the identified poles read 2.750 +/- 0.032 kg (z 3.2)
    from ema_rig.rig.fit import fit_housing_pair_of

    data = read_uff58(tmp_path / "frame1.uff", rig=load_rig(tmp_path / "frame1.toml"))
    poles = res.identification.modes.poles
    pair = fit_housing_pair_of(data, 0, 0, poles, res.match.housing_index, res.match.neighbours)
    true_mass = _truth_driving_point_mass(truth, complex(poles[res.match.housing_index]))
    assert pair is not None and pair.resolved
    assert abs(pair.modal_mass - true_mass) <= 2 * pair.modal_mass_std
    assert pair.modal_mass_std / pair.modal_mass <= 0.03


@pytest.mark.parametrize("sep_hz, resolved", [(6.5, True), (1.3, False)])
def test_joint_pair_fit_resolves_a_pair_one_percent_apart_not_a_fifth(sep_hz, resolved):
    # oracle: two analytic real modes (650 Hz and 650 + sep_hz, zeta 2 %, half-power bandwidth 26 Hz)
    # with different shapes over six channels, driving-point modal mass of the first 2.6 kg, 2 % noise.
    # 1 % apart (a quarter bandwidth) the joint fit measures the mass (std ~1.3 %, within 2 sigma);
    # 0.2 % apart the split of the pair's residue is not measured (std 5-110 % over seeds 1-5): not
    # resolved (MatchCriteria.pair_max_mass_std)
    from ema_rig.rig.fit import fit_housing_pair
    from ema_rig.rig.matching import MATCH_CRITERIA

    rng = np.random.default_rng(1)
    freq = np.arange(400.0, 900.0, 0.5)
    jw = 2j * np.pi * freq
    poles = np.array([2 * np.pi * 650 * (-0.02 + 1j), 2 * np.pi * (650 + sep_hz) * (-0.02 + 1j)])
    phi = np.array([[1.0, 0.95, 1.05, 0.2, 0.1, 0.3], [0.3, 0.3, 0.3, 0.1, 0.3, 0.2]])  # per mode, per channel
    h = np.zeros((6, freq.size), complex)
    for r in range(2):
        res = phi[r] * phi[r, 0] / (2j * poles[r].imag) / 2.6
        h += res[:, None] / (jw - poles[r]) + np.conj(res)[:, None] / (jw - np.conj(poles[r]))
    h *= jw**2
    h *= 1 + 0.02 * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
    fit = fit_housing_pair(freq, h, poles, 0, [1], 0)
    assert fit is not None and fit.resolved is resolved
    rel = fit.modal_mass_std / fit.modal_mass
    if resolved:
        assert abs(fit.modal_mass - 2.6) <= 2 * fit.modal_mass_std and rel <= 0.02
    else:
        assert rel > MATCH_CRITERIA.pair_max_mass_std


def test_misaligned_sensors_alone_leave_the_housing_mode_clean(tmp_path):
    # seed 5 of the study's m_H-off class at a stated 0.5 % force chain: no cross stiffness in the truth,
    # but its axial and lateral sensors (2 degrees of misalignment) read 0.070 / 0.069 of the radial
    # motion, past a 2-sigma bound: the mode was called not clean, the rig file's 3 % error blamed on a
    # neighbour (warning, sigma 5.1 %). Up to 3 sigma of misalignment the mass measures m_H, with the
    # largest coupling's effect in its std
    truth = RigTruth(k_TB=59.19995e6, file_m_H_factor=1.03, file_force_chain=0.005, seed=5)
    res = _estimate(tmp_path, "mis", truth)
    rho = max(res.housing_mode["axial_ratio"], res.housing_mode["lateral_ratio"])
    assert 0.07 < rho <= 0.105
    assert res.warnings == () and abs(_z(res, truth)) <= 2.0
    hm = res.housing_mass
    assert hm is not None and hm.source == "measured"
    assert abs(hm.measured - 2.566) <= 2 * hm.measured_std
    # sigma(k_TB) from the measured m_H (force chain 0.5 %): ~1.5 % (5.1 % before)
    assert res.k_TB_std / res.k_TB < 0.025


def test_coupling_between_two_and_three_sigma_of_misalignment_is_never_silent(tmp_path):
    # r_review10 (benchmarks/results/study_unseen_truths_fresh_seeds.txt, tight-tolerance class, seeds 12,
    # 16, 20, 21: z +3.1 ... +8.4, silent): a lateral cross stiffness mixing 0.64 % of the housing mode into
    # its 430 Hz partner, sensors aligned, reads a lateral ratio 0.081 (between 2 and 3 sigma of
    # misalignment); the coupling raises the housing mode by ~c^2 / df (k_TB +0.30 %). With rig tolerances of
    # 1e-4 that shift was neither corrected nor in the budget (z +3.4 on 3be4dea and ec07f23); the coupled
    # reading of the identified partner now sits at 1 sigma (a term, no warning)
    truth = RigTruth(k_TB=37e6, cross_axis="lateral", lateral_freq=430.0, cross_leak=0.0064, misalign_deg=0.0,
                     seed=1)
    uff, rig_path = write_case(tmp_path, "hidden", truth, FREQ)
    head, unc = rig_path.read_text(encoding="utf-8").split("[uncertainty]")
    unc = re.sub(r"^(m_H|m_S|m_F|k_MS|k_AS|k_S|k_B) = .*$", r"\1 = 0.0001", unc, flags=re.M)
    rig_path.write_text(head + "[uncertainty]" + unc, encoding="utf-8")
    rig = load_rig(rig_path)
    res = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)
    assert 2 * 0.035 < res.housing_mode["lateral_ratio"] <= 3 * 0.035
    assert res.warnings == () and abs(_z(res, truth)) <= 2.0
    assert any("2-3 sigma of misalignment" in n for n in res.notes)
    # the term is the coupled reading's size, not a blanket widening: sigma below 0.5 % (0.09 % before)
    assert res.k_TB_std / res.k_TB < 0.005


def test_coupling_mass_bound_against_the_truths_coupled_mode():
    # oracle: the truth's eigenvectors (numpy, nothing from ema_rig) with and without a bearing cross
    # stiffness, sensors aligned: the driving-point modal mass rises by t^2 = ratio^2 m_H / m_eff
    # (two-mode mixing) within the second-order terms (2.5 % of t^2 here)
    import rig_truth

    from ema_rig.rig.uncertainty import coupling_mass_std

    for axis, f_p in (("axial", 400.0), ("lateral", 800.0)):
        kw = dict(k_TB=70e6, misalign_deg=0.0, axial_freq=f_p, lateral_freq=f_p)
        got = []
        for truth in (RigTruth(**kw), RigTruth(cross_axis=axis, cross_leak=0.01, **kw)):
            m, k = truth.matrices()
            lam, phi = rig_truth._eigh(k, m)
            i = rig_truth._housing_index(lam, phi, m)
            c = truth.observation()
            cross = c[4 if axis == "axial" else 3] @ phi[:, i]
            got.append((1.0 / float(c[0] @ phi[:, i]) ** 2, abs(float(cross / np.mean(c[:3] @ phi[:, i])))))
        (m0, _), (m1, rho) = got
        t2 = math.sqrt(3.0) * coupling_mass_std(rho, 2.566, m0)
        assert 0.09 < rho < 0.11  # 1 % of the mode's energy in the partner
        assert m1 / m0 - 1 == pytest.approx(t2, rel=0.05)


def test_mass_routes_that_disagree_are_never_silent(tmp_path):
    # issue 11's frame mode 4 Hz below the housing mode at the driving point (seed 4): the identification
    # merges the two, the modal mass reads m_H -8.4 % and the mode's spindle/housing ratio +34 %; the
    # modal mass alone gave k_TB -17 % at z -4.7 without a warning. Two measurements of m_H that
    # disagree beyond 3 sigma say the 3DOF model does not describe the mode alone: warned (or within 2 sigma)
    truth = RigTruth(k_TB=93e6, flex_frame_freq=663.3940264871381, seed=4)
    res = _estimate(tmp_path, "merged", truth)
    assert any("neither measures m_H alone" in n for n in res.notes)
    assert res.housing_mass is None or res.housing_mass.used is None
    assert res.warnings and abs(_z(res, truth)) <= 2.0


def test_shape_weight_with_a_shared_centre_error_against_a_grid():
    # oracle: the variance of ln k_TB written out source by source (numpy, independent of the closed
    # form) and minimised over a grid of weights. Both m_H routes read the housing against the same
    # unknown centre (relative std s of its reading): the modal mass twice, the ratio once
    from types import SimpleNamespace

    from ema_rig.rig.fit import housing_mass_from_ratio
    from ema_rig.rig.uncertainty import DEFAULT_REL_UNCERTAINTY, _shape_weight, sensitivities

    f_h, a_own, s, cal = 626.0, 0.02, 0.009, 0.0091
    rel = dict(DEFAULT_REL_UNCERTAINTY)
    shape = housing_mass_from_ratio(f_h, 0.1, TABLE1_PARAMS, rel, math.hypot(cal, s))
    assert shape is not None
    sens = sensitivities(f_h, TABLE1_PARAMS)
    b = {n: v for n, v in shape.sensitivity.items() if n != "ratio"}
    s_r = shape.sensitivity["ratio"]
    names = ["dp", "centre", "cal", *b]
    dp = np.array([a_own, 2 * s, 0.0] + [0.0] * len(b))  # d ln m_H (driving point) per unit source
    sh = np.array([0.0, s_r * s, s_r * cal] + [b[n] * rel[n] for n in b])  # d ln m_H (shape)
    direct = np.array([0.0, 0.0, 0.0] + [sens[n] * rel[n] for n in b])  # d ln k_TB, the parameters' own path
    ws = np.linspace(0.0, 1.0, 1001)
    var = [float(np.sum((sens["m_H"] * ((1 - w) * dp + w * sh) + direct) ** 2)) for w in ws]
    w_grid = ws[int(np.argmin(var))]
    w, u_own, _ = _shape_weight(f_h, TABLE1_PARAMS, SimpleNamespace(uncertainty=rel), math.hypot(a_own, 2 * s),
                                shape, cov=2 * s_r * s**2)
    assert len(names) == dp.size
    assert abs(w - w_grid) <= 1.5e-3  # the grid's step is 1e-3
    own = (1 - w) * dp[:3] + w * sh[:3]
    assert u_own == pytest.approx(float(np.sqrt(np.sum(own**2))), rel=1e-9)
    # carried, the shared centre raises the combined m_H's own std above the independent reading's
    _, u_ind, _ = _shape_weight(f_h, TABLE1_PARAMS, SimpleNamespace(uncertainty=rel), math.hypot(a_own, 2 * s), shape)
    assert u_own > 1.05 * u_ind
