"""LSFD modal constants, residual terms, mass normalisation, MAC and MPC."""

from __future__ import annotations

import numpy as np
import pytest
from lumped import five_mode_system

from ema_rig.errors import IdentificationError
from ema_rig.identification import identify, lsfd, mac, mpc

FREQ = np.arange(0.0, 1000.5, 0.5)


@pytest.fixture(scope="module")
def system():
    return five_mode_system()


@pytest.mark.parametrize("form", ["accelerance", "receptance"])
def test_exact_poles_give_mass_normalised_shapes(system, form):
    data = system.frf(FREQ, inputs=(0, 1), frf_form=form)
    model = lsfd(data, system.poles, band=(5.0, 1000.0))
    wn, phi = system.normal_modes()
    # exact poles, noise-free data: the modal model reproduces the FRFs to round-off
    assert model.fit_error.max() < 1e-8
    for ref, q in (("11+Y", 0), ("12+Y", 1)):
        shapes = model.mode_shapes(ref)
        for r in range(6):
            # a node at the driving point cannot scale that mode; the node comes out of eigh as
            # round-off (7e-13 with one OpenBLAS kernel, -2.4e-12 with another), every real component
            # of these shapes is >= 0.05: relative cut 1e-9 of the mode's largest amplitude
            if abs(phi[r, q]) < 1e-9 * np.abs(phi[r]).max():
                continue
            assert mac(shapes[r], phi[r])[0, 0] > 0.999999
            # mass normalisation: amplitudes, not only the shape (classical damping: real)
            np.testing.assert_allclose(np.abs(shapes[r]), np.abs(phi[r]), rtol=1e-6, atol=1e-9)
    # effective modal mass at the driving point = 1 / phi_p^2 (mode 3 has a node at 11+Y)
    m11 = model.modal_mass("11+Y")
    vis = np.abs(phi[:, 0]) > 1e-6
    np.testing.assert_allclose(m11[vis], 1 / phi[vis, 0] ** 2, rtol=1e-6)
    assert m11[3] > 1e6


def test_residuals_absorb_out_of_band_modes(system):
    data = system.frf(FREQ, inputs=(0,))
    band_poles = system.poles[[2, 4]]  # 410 and 640 Hz inside 300..700 Hz
    with_res = lsfd(data, band_poles, band=(300, 700))
    without = lsfd(data, band_poles, band=(300, 700), residuals=False)
    # the modes at 120/230 Hz (below) and 830 Hz (above) act as mass and stiffness lines
    assert with_res.fit_error.max() < 0.2 * without.fit_error.max()
    assert np.all(with_res.lower_residual.real != 0) and np.all(with_res.upper_residual.real != 0)
    _, phi = system.normal_modes()
    m = with_res.modal_mass("11+Y")
    # the residual terms keep the in-band modal masses within 1 % (the 830 Hz mode, 2.5 %
    # damped and only 130 Hz above the band, is not quite a constant upper residual)
    np.testing.assert_allclose(m, 1 / phi[[2, 4], 0] ** 2, rtol=1e-2)
    syn = with_res.synthesize(data.band(300, 700).freq)
    assert syn.frf.shape == (6, 1, data.band(300, 700).n_freq)
    err = np.linalg.norm(syn.frf - data.band(300, 700).frf) / np.linalg.norm(data.band(300, 700).frf)
    np.testing.assert_allclose(err, np.linalg.norm(with_res.fit_error[:, 0] * np.linalg.norm(
        data.band(300, 700).frf[:, 0], axis=1)) / np.linalg.norm(data.band(300, 700).frf), rtol=1e-6)


def test_identify_modes_noise_free_and_noisy(system):
    _, phi = system.normal_modes()
    # noisy: the 410 Hz mode is weakest at 12+Y (phi = -0.05, 400 kg effective mass), so its
    # driving-point residue is the least certain (2 %)
    # (shapes at the default ML poles: noisy MAC measured >= 0.9988)
    for noise, mac_min, mass_rtol in ((0.0, 0.999999, 1e-6), (0.01, 0.998, 2e-2)):
        rng = np.random.default_rng(7)
        ident = identify(system.frf(FREQ, inputs=(0, 1), noise=noise, rng=rng))
        order = np.argsort(ident.natural_freq)
        shapes = ident.modes.mode_shapes("12+Y")[order]
        m12 = ident.modes.modal_mass("12+Y")[order]
        for r in range(6):
            assert mac(shapes[r], phi[r])[0, 0] > mac_min
        # the weak 410 Hz mode (1 % from 414 Hz) at 12+Y follows the pair's pole estimates: with the
        # default ML poles (each within 1.1 sigma) its mass is off by 14.5 %, the others by < 2 %
        tol = np.full(6, mass_rtol)
        tol[2] = max(mass_rtol, 0.2 if noise else 0.0)
        np.testing.assert_array_less(np.abs(m12 * phi[:, 1] ** 2 - 1), tol)
        # classically damped system: real (monophase) shapes (the weak 410 Hz one measured 0.9975)
        assert np.all(mpc(shapes) > 0.995)
        rec = ident.to_records()
        assert {"natural_freq", "damping_ratio", "natural_freq_std", "damping_ratio_std", "mpc"} <= set(rec[0])


def test_mac_and_mpc_values():
    a = np.array([[1.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    np.testing.assert_allclose(mac(a), [[1.0, 0.5], [0.5, 1.0]], rtol=1e-12)
    # complex scale does not change the MAC
    np.testing.assert_allclose(mac(a[1] * (2 - 3j), a[1]), [[1.0]], rtol=1e-12)
    assert mac([0, 0, 0], a).tolist() == [[0.0, 0.0]]
    np.testing.assert_allclose(mpc([[1, -2, 3], [1, 1j, 0]]), [1.0, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match="same number of DOFs"):
        mac(a, [1, 2])


def test_bad_poles(system):
    data = system.frf(FREQ)
    with pytest.raises(IdentificationError, match="Im > 0"):
        lsfd(data, [-1 - 100j])
    with pytest.raises(IdentificationError, match="at least one pole"):
        lsfd(data, [])


@pytest.mark.crosscheck
def test_mac_matches_sdypy():
    import matplotlib

    matplotlib.use("Agg")
    from sdypy import EMA

    rng = np.random.default_rng(3)
    a = rng.standard_normal((6, 4))
    b = rng.standard_normal((6, 3))
    # sdypy-EMA takes shapes as columns (its loop warns on complex input; real shapes suffice)
    np.testing.assert_allclose(mac(a.T, b.T), EMA.MAC(a, b), rtol=1e-12)
