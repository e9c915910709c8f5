"""Tests of the 3DOF rig model (paper Table 1, DESIGN §4)."""

from __future__ import annotations

import numpy as np
import pytest
from numpy.testing import assert_allclose

from ema_rig.config import ModelParams
from ema_rig.rig.model import (
    RigModel,
    k_tb_from_series,
    mass_matrix,
    series_stiffness,
    stiffness_matrix,
)

TABLE1 = ModelParams(m_H=2.566, m_S=2.8, m_F=205.0, k_MS=114e6, k_AS=650e3, k_S=348e6, k_B=180e3)
K_TB_MS_626 = 4.397e7


def test_three_natural_frequencies_match_paper():
    m = RigModel(TABLE1, K_TB_MS_626)
    # DESIGN §4 quotes 4.66 / 626.0 / 1907.2 Hz to 3-4 digits: rtol 1e-3 covers the rounding
    assert_allclose(m.natural_freq, [4.66, 626.0, 1907.2], rtol=1e-3)
    # tighter against an independent computation: the roots of det(K - w^2 M) = 0
    lam = np.sort(np.linalg.eigvals(np.linalg.solve(mass_matrix(TABLE1), stiffness_matrix(TABLE1, K_TB_MS_626))).real)
    assert_allclose(m.natural_freq, np.sqrt(lam) / (2 * np.pi), rtol=1e-10)
    assert_allclose(m.housing_freq, 626.0217, atol=1e-3)  # own value, 4 decimals


def test_mode_shapes_mass_normalised_and_housing_effective_mass():
    m = RigModel(TABLE1, K_TB_MS_626)
    phi = m.mode_shapes
    # eigh(K, M) vectors are M-orthonormal and diagonalise K to w^2 (float64 accuracy)
    assert_allclose(phi.T @ m.mass_matrix() @ phi, np.eye(3), atol=1e-12)
    assert_allclose(phi.T @ m.stiffness_matrix() @ phi, np.diag((2 * np.pi * m.natural_freq) ** 2), rtol=1e-10, atol=1e-3)
    # DESIGN §4: housing-mode effective mass at the driving point ≈ 2.64 kg, spindle/housing ≈ 0.1
    assert_allclose(m.effective_mass(), 2.64, atol=0.01)
    assert 0.08 < phi[1, 1] / phi[0, 1] < 0.14


def test_frf_static_limit_and_resonance():
    m = RigModel(TABLE1, K_TB_MS_626)
    h = m.frf([0.0], damping_ratio=0.0)
    # receptance at 0 Hz equals K^-1 (column of the force DOF)
    assert_allclose(h[:, 0].real, np.linalg.inv(m.stiffness_matrix())[:, 0], rtol=1e-9)
    # at the housing resonance a damped mode's response is dominated by phi^2 / (2 j zeta w^2)
    z = 0.01
    w = 2 * np.pi * m.housing_freq
    hr = m.frf([m.housing_freq], damping_ratio=z)[0, 0]
    expected = m.mode_shapes[0, 1] ** 2 / (2j * z * w**2)
    assert abs(hr - expected) / abs(expected) < 0.01  # other modes contribute < 1 %
    # accelerance = -(w^2) receptance
    acc = m.frf([300.0], damping_ratio=z, frf_form="accelerance")
    rec = m.frf([300.0], damping_ratio=z)
    assert_allclose(acc, -((2 * np.pi * 300.0) ** 2) * rec, rtol=1e-12)


def test_series_helpers_round_trip():
    k = series_stiffness(71.568e6, 114e6)
    assert_allclose(k, 1 / (1 / 71.568e6 + 1 / 114e6), rtol=1e-14)
    assert_allclose(k_tb_from_series(k, 114e6), 71.568e6, rtol=1e-12)
    assert series_stiffness(np.inf, 114e6) == 114e6  # rigid disk
    with pytest.raises(ValueError, match="k_MS"):
        k_tb_from_series(120e6, 114e6)  # stiffer than the mounting: no positive k_TB
    with pytest.raises(ValueError):
        RigModel(TABLE1, -1.0)


def test_from_k_tb_gives_paper_bearing_stiffness():
    m = RigModel.from_k_tb(TABLE1, 7.157e7)
    # DESIGN §4: k_TB = 7.157e7 N/m ⇔ k_TB+MS = 4.397e7 N/m ⇔ 626 Hz (4 digits quoted)
    assert_allclose(m.k_TB_MS, 4.397e7, rtol=2e-4)
    assert_allclose(m.housing_freq, 626.0, rtol=2e-4)
    d = m.frf_data(np.linspace(0, 1000, 11), damping_ratio=0.02)
    assert d.shape == (2, 1, 11) and d.roles == ("housing", "spindle")
