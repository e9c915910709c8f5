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
