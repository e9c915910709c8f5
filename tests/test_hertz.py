"""Tests of the Hertzian ball-bearing stiffness estimate (DESIGN §4)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from ema_rig.rig.hertz import BEARING_6302, BallBearingGeometry, ball_bearing_radial_stiffness


def test_6302_matches_design_values():
    k = ball_bearing_radial_stiffness(np.array([500.0, 1000.0, 1500.0]))
    # DESIGN §4 quotes 7.3e7 / 9.2e7 / 1.05e8 N/m (rounded, estimate): 3 % tolerance
    assert_allclose(k, [7.3e7, 9.2e7, 1.05e8], rtol=0.03)
    # and the power law 9.15e6 F^(1/3)
    assert_allclose(k, 9.15e6 * np.cbrt([500.0, 1000.0, 1500.0]), rtol=0.01)


def test_cube_root_law_and_ball_position():
    k1, k8 = ball_bearing_radial_stiffness(125.0), ball_bearing_radial_stiffness(1000.0)
    assert_allclose(k8 / k1, 2.0, rtol=1e-12)  # (1000/125)^(1/3) = 2 exactly
    # discrete ball positions scatter around the Stribeck average by about 1 %
    ks = [ball_bearing_radial_stiffness(1000.0, ball_angle=a) for a in np.linspace(0, 2 * np.pi / 7, 7)]
    assert_allclose(ks, ball_bearing_radial_stiffness(1000.0), rtol=0.015)
    assert np.ptp(ks) > 0  # the ball configuration matters


def test_tighter_groove_is_stiffer_and_bad_input():
    tight = BallBearingGeometry(inner_conformity=0.51, outer_conformity=0.51)
    assert ball_bearing_radial_stiffness(1000.0, tight) > ball_bearing_radial_stiffness(1000.0, BEARING_6302)
    with pytest.raises(ValueError):
        ball_bearing_radial_stiffness(-1.0)
    with pytest.raises(ValueError):
        BallBearingGeometry(inner_conformity=0.5)


# --------------------------------------------------------------------------- any deep-groove bearing
def _exact_point_contact_constant(rx: float, ry: float, e1: float, nu1: float, e2: float, nu2: float) -> float:
    """``K = Q / delta^1.5`` [N/m^1.5] from Hertz's exact elliptic-integral solution (Johnson, Contact
    Mechanics, sect. 4.2), independent of the Hamrock-Brewe curve fits in ema_rig.rig.hertz."""
    from scipy.optimize import brentq
    from scipy.special import ellipe, ellipk

    e_star = 1.0 / ((1 - nu1**2) / e1 + (1 - nu2**2) / e2)
    big, small = 1.0 / (2 * rx), 1.0 / (2 * ry)  # relative curvatures: B (rolling) > A (transverse)

    def ratio(m: float) -> float:  # B/A as a function of e^2 = 1 - (b/a)^2
        return ((1.0 / (1.0 - m)) * ellipe(m) - ellipk(m)) / (ellipk(m) - ellipe(m))

    m = brentq(lambda m: ratio(m) - big / small, 1e-12, 1 - 1e-12, xtol=1e-15)
    q = 1.0  # N; delta ~ Q^(2/3) exactly, so one load gives the constant
    a = (3 * q * (ellipk(m) - ellipe(m)) / (2 * np.pi * e_star * m * small)) ** (1 / 3)  # major semi-axis
    b = a * np.sqrt(1 - m)
    p0 = 3 * q / (2 * np.pi * a * b)
    delta = p0 * b * ellipk(m) / e_star
    return q / delta**1.5


def _hand_radial_stiffness(load: float, z: int, d: float, dm: float, f: float, e: float, nu: float) -> float:
    """k_r of a zero-clearance deep-groove bearing by hand: exact Hertz contacts in series, Stribeck."""
    from scipy.integrate import quad

    # curvature radii from the geometry: ball radius d/2, raceway radii (dm -/+ d)/2, groove radius f d
    rx_i = 1.0 / (2 / d + 2 / (dm - d))
    rx_o = 1.0 / (2 / d - 2 / (dm + d))
    ry = 1.0 / (2 / d - 1 / (f * d))
    k_i = _exact_point_contact_constant(rx_i, ry, e, nu, e, nu)
    k_o = _exact_point_contact_constant(rx_o, ry, e, nu, e, nu)
    k_n = 1.0 / (k_i ** (-2 / 3) + k_o ** (-2 / 3)) ** 1.5
    # F = Z K_n delta^1.5 J, J = (1/2 pi) int cos^2.5 over the loaded half (numerical quadrature)
    j = quad(lambda p: np.cos(p) ** 2.5, -np.pi / 2, np.pi / 2)[0] / (2 * np.pi)
    delta = (load / (z * k_n * j)) ** (2 / 3)
    return 1.5 * load / delta


def test_6205_from_its_own_geometry_against_a_hand_calculation():
    # 6205: 9 balls of 7.938 mm (5/16 in) on a 38.5 mm pitch circle (bore 25 mm, outside 52 mm), steel
    g = BallBearingGeometry(n_balls=9, ball_diameter=7.938e-3, pitch_diameter=38.5e-3)
    loads = np.array([300.0, 1000.0, 3000.0])
    hand = [_hand_radial_stiffness(f, 9, 7.938e-3, 38.5e-3, 0.52, 208e9, 0.3) for f in loads]
    # Hamrock-Brewe's fits of the ellipticity and elliptic integrals are good to ~1-2 % in delta at
    # this curvature ratio (Ry/Rx ~ 25); observed 0.76 %, tolerance 1.5 %
    assert_allclose(ball_bearing_radial_stiffness(loads, g), hand, rtol=0.015)
    # the same hand calculation for the 6302 (the geometry of the campaign example) agrees as well
    assert_allclose(ball_bearing_radial_stiffness(1000.0), _hand_radial_stiffness(1000.0, 7, 7.938e-3, 28.5e-3,
                                                                                  0.52, 208e9, 0.3), rtol=0.015)
    # more balls on a larger circle: stiffer than the 6302 (k ~ Z^(2/3) at equal contacts)
    assert ball_bearing_radial_stiffness(1000.0, g) > ball_bearing_radial_stiffness(1000.0)


def test_clearance_and_hybrid_materials():
    g0 = BallBearingGeometry()
    tiny = BallBearingGeometry(clearance=1e-10)
    # a vanishing clearance gives the closed form (continuous and discrete ball positions)
    assert_allclose(ball_bearing_radial_stiffness(1000.0, tiny), ball_bearing_radial_stiffness(1000.0, g0), rtol=1e-5)
    assert_allclose(ball_bearing_radial_stiffness(1000.0, tiny, ball_angle=0.2),
                    ball_bearing_radial_stiffness(1000.0, g0, ball_angle=0.2), rtol=1e-5)
    # a clearance loads fewer balls: softer, and most so at small loads (clearance ~ the deflection)
    loose = BallBearingGeometry(clearance=20e-6)
    r_small = ball_bearing_radial_stiffness(50.0, loose) / ball_bearing_radial_stiffness(50.0, g0)
    r_large = ball_bearing_radial_stiffness(3000.0, loose) / ball_bearing_radial_stiffness(3000.0, g0)
    assert r_small < r_large < 1.0
    # hybrid bearing: silicon-nitride balls (310 GPa, 0.26) make the contact stiffer: E' rises
    hybrid = BallBearingGeometry(ball_youngs_modulus=310e9, ball_poisson_ratio=0.26)
    e_ratio = hybrid.effective_modulus / g0.effective_modulus
    # k ~ K_n^(2/3) ~ E'^(2/3): the stiffness ratio follows the modulus ratio exactly
    assert_allclose(ball_bearing_radial_stiffness(1000.0, hybrid) / ball_bearing_radial_stiffness(1000.0, g0),
                    e_ratio ** (2 / 3), rtol=1e-12)
    # E' = 2 / ((1 - nu1^2)/E1 + (1 - nu2^2)/E2), by hand: 263.3 GPa against 228.6 GPa for steel on steel
    assert_allclose(e_ratio, 2 / ((1 - 0.3**2) / 208e9 + (1 - 0.26**2) / 310e9) / (208e9 / (1 - 0.3**2)), rtol=1e-12)
    with pytest.raises(ValueError, match="do not fit"):
        BallBearingGeometry(n_balls=20, ball_diameter=7.938e-3, pitch_diameter=28.5e-3)


def _campaign(tmp_path, rig_file, bearing_table: str):
    from ema_rig.campaign import load_campaign

    text = (f'rig = "{rig_file.name}"\n{bearing_table}\n[[measurement]]\nfile = "m.uff"\nbearing = "6205"\n'
            "radial_load = 1000.0\n")
    (tmp_path / "campaign.toml").write_text(text, encoding="utf-8")
    return load_campaign(tmp_path / "campaign.toml")


def test_campaign_bearing_geometry(tmp_path, rig_file):
    from ema_rig.errors import ConfigError
    from ema_rig.plot.campaign import plot_k_vs_load

    cfg = _campaign(tmp_path, rig_file, "[bearings.6205]\nn_balls = 9\nball_diameter = 7.938e-3\n"
                                        "pitch_diameter = 38.5e-3\nclearance = 10e-6")
    info = cfg.bearings["6205"]
    assert info.hertz and info.geometry == BallBearingGeometry(n_balls=9, ball_diameter=7.938e-3,
                                                               pitch_diameter=38.5e-3, clearance=10e-6)
    # the curve drawn is that geometry's, labelled as an estimate with the geometry
    rows = [{"bearing": "6205", "status": "ok", "radial_load": f, "speed": 600.0, "k_TB": 9e7, "k_TB_std": 1e6}
            for f in (500.0, 1500.0)]
    ax = plot_k_vs_load(rows, "6205", info=info).axes[0]
    line = next(ln for ln in ax.get_lines() if "Hertz estimate" in ln.get_label())
    assert "9 balls" in line.get_label()
    x, y = line.get_data()
    assert_allclose(y, ball_bearing_radial_stiffness(x, info.geometry) / 1e6, rtol=1e-12)
    # 6302 keeps its built-in geometry; any other bearing needs its own
    six = _campaign(tmp_path, rig_file, "[bearings.6302]\nhertz = true")
    assert six.bearings["6302"].geometry == BEARING_6302
    assert not _campaign(tmp_path, rig_file, "[bearings.6205]\nlabel = 'x'").bearings["6205"].hertz
    bad = [
        ("[bearings.6205]\nhertz = true", "bearings.6205.hertz", "geometry"),
        ("[bearings.6205]\nn_balls = 9\nball_diameter = 7.938e-3", "bearings.6205.pitch_diameter", "missing"),
        ("[bearings.6205]\nn_balls = 9.0\nball_diameter = 7.938e-3\npitch_diameter = 38.5e-3",
         "bearings.6205.n_balls", "integer"),
        ("[bearings.6205]\nn_balls = 9\nball_diameter = 7.938\npitch_diameter = 38.5", "bearings.6205.ball_diameter",
         "metres"),
        ("[bearings.6205]\nn_balls = 9\nball_diameter = 7.938e-3\npitch_diameter = 38.5e-3\npoisson_ratio = 0.6",
         "bearings.6205.poisson_ratio", "0.5"),
        ("[bearings.6205]\nn_balls = 30\nball_diameter = 7.938e-3\npitch_diameter = 38.5e-3",
         "bearings.6205", "do not fit"),
        ("[bearings.6205]\nballs = 9", "bearings.6205.balls", "unknown key"),
    ]
    for table, key, what in bad:
        with pytest.raises(ConfigError) as err:
            _campaign(tmp_path, rig_file, table)
        assert err.value.key == key and what in str(err.value), (table, str(err.value))
