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


# ---- noise-weighted LSFD (issue 18, build 5): the maximum-likelihood residues for given poles ----


def _direct_weighted_residues(data, poles, variance):
    """Residues by an explicit per-channel weighted least squares (numpy lstsq), built here from the
    model's definition: columns (jw)^2/(jw - l) + (jw)^2/(jw - conj l) and j(...) - j(...), LR, UR."""
    jw = 2j * np.pi * data.freq
    cols = []
    for lam in poles:
        pos, neg = jw**2 / (jw - lam), jw**2 / (jw - np.conj(lam))
        cols.append(pos + neg)
    for lam in poles:
        pos, neg = jw**2 / (jw - lam), jw**2 / (jw - np.conj(lam))
        cols.append(1j * pos - 1j * neg)
    cols += [np.ones_like(jw), jw**2]
    basis = np.stack(cols, axis=1)
    n_m = len(poles)
    out = np.empty((n_m, data.n_out, data.n_in), complex)
    for o in range(data.n_out):
        for i in range(data.n_in):
            w = 1.0 / np.sqrt(np.broadcast_to(variance, data.frf.shape)[o, i])
            a = np.concatenate([(basis * w[:, None]).real, (basis * w[:, None]).imag])
            y = np.concatenate([(data.frf[o, i] * w).real, (data.frf[o, i] * w).imag])
            x = np.linalg.lstsq(a, y, rcond=None)[0]
            out[:, o, i] = x[:n_m] + 1j * x[n_m : 2 * n_m]
    return out


def _mck_data(seed, *, p, floor, coherence=False):
    from _mck_truth import make

    from ema_rig.frf import FRFData

    t = make(seed, noise=p, floor_rel=floor)
    data = FRFData(t.freq, t.frf, t.out_dofs, t.in_dofs, frf_form="accelerance",
                   coherence=t.coherence if coherence else None, n_averages=t.n_averages if coherence else None)
    return t, data


def _exact_residues(t):
    """phi_r[o] phi_r[0] / (2 j w_d): the truth of the classically damped M, C, K set (shapes SHAPES)."""
    from _mck_truth import BASE_FREQ, SHAPES

    idx = [int(np.argmin(np.abs(np.asarray(BASE_FREQ) - f))) for f in t.natural_freq]
    phi = SHAPES[idx]
    return (phi[:, :, None] * phi[:, None, :1]) / (2j * t.poles.imag)[:, None, None]


def test_weighted_lsfd_is_the_weighted_least_squares_solution():
    t, data = _mck_data(0, p=0.03, floor=0.01)
    rng = np.random.default_rng(5)
    # per channel (no common profile): the batched SVD path against an explicit lstsq per channel
    var = t.variance * rng.uniform(0.5, 2.0, t.variance.shape)
    m = lsfd(data, t.poles, variance=var)
    assert m.meta["weighted"] == "per channel"
    # both solve the same full-rank problem; they differ by rounding only (measured 3e-12)
    np.testing.assert_allclose(m.residues, _direct_weighted_residues(data, t.poles, var), rtol=1e-8)
    # more channels (18) than unknowns (12): the normal matrices through the lines' outer products
    from ema_rig.frf import FRFData

    many = FRFData(t.freq, np.concatenate([t.frf, 1.5 * t.frf[::-1], -t.frf]), [f"{k}+Y" for k in range(1, 19)],
                   t.in_dofs, frf_form="accelerance")
    var18 = np.concatenate([var, 2.25 * var[::-1] * rng.uniform(0.5, 2.0, var.shape), var[::-1]])
    np.testing.assert_allclose(lsfd(many, t.poles, variance=var18).residues,
                               _direct_weighted_residues(many, t.poles, var18), rtol=1e-8)
    # one line profile times a channel scale: the shared factorization, same answer as the lstsq
    prof = t.variance[0, 0] * np.arange(1, 7)[:, None, None]
    m2 = lsfd(data, t.poles, variance=prof)
    assert m2.meta["weighted"] == "line profile"
    np.testing.assert_allclose(m2.residues, _direct_weighted_residues(data, t.poles, prof), rtol=1e-8)
    # a constant variance is the unweighted fit; the fit error stays the unweighted relative norm
    m3, m0 = lsfd(data, t.poles, variance=np.full(data.n_freq, 4.0)), lsfd(data, t.poles)
    np.testing.assert_allclose(m3.residues, m0.residues, rtol=1e-9)
    np.testing.assert_allclose(m3.fit_error, m0.fit_error, rtol=1e-9)
    np.testing.assert_allclose(
        m.fit_error[:, 0],
        np.linalg.norm(data.frf - m.synthesize(data.freq).frf, axis=2)[:, 0] / np.linalg.norm(data.frf, axis=2)[:, 0],
        rtol=1e-9)


def test_weighted_residues_against_the_exact_ones():
    """Proportional + floor noise: the peak lines' noise no longer sets the residues.

    Exact poles (LSFD alone), 8 seeds, 2 % proportional + 1 % floor noise. Measured rms relative
    residue errors (modes 95, 170, 290, 292.9, 430 Hz): unweighted 0.44/0.37/0.92/1.06/0.23 %,
    weighted by the identification's own noise estimate 0.23/0.22/0.73/0.84/0.17 %, equal to the
    weights of the true variance (the ML) to 2 digits (benchmarks/study_lsfd_weights.py).
    """
    from ema_rig.identification.criteria import COMPLETENESS_CRITERIA
    from ema_rig.identification.identification import _misfit

    err = {"unweighted": [], "weighted": [], "oracle": []}
    for seed in range(8):
        t, data = _mck_data(seed, p=0.02, floor=0.01)
        truth = _exact_residues(t)
        fits = {"unweighted": lsfd(data, t.poles),
                "weighted": lsfd(data, t.poles, variance=_misfit(data, lsfd(data, t.poles), COMPLETENESS_CRITERIA).variance.reshape(data.frf.shape)),
                "oracle": lsfd(data, t.poles, variance=t.variance)}
        for k, m in fits.items():
            err[k].append(np.linalg.norm((m.residues - truth)[:, :, 0], axis=1) / np.linalg.norm(truth[:, :, 0], axis=1))
    rms = {k: np.sqrt(np.mean(np.square(v), axis=0)) for k, v in err.items()}
    # the estimated noise weights are as good as the true ones (ML): within 10 % per mode
    np.testing.assert_allclose(rms["weighted"], rms["oracle"], rtol=0.1)
    # better for every mode; the isolated modes by > 1.5x (measured 1.4-1.9x: 95 Hz 1.9x, 170 Hz 1.7x,
    # 430 Hz 1.35x), the close pair by 1.25x at least (their errors follow from the pair's poles' overlap)
    assert np.all(rms["weighted"] < rms["unweighted"])
    assert rms["unweighted"][0] > 1.5 * rms["weighted"][0] and rms["unweighted"][1] > 1.5 * rms["weighted"][1]
    # absolute level: a 2 % relative noise over a few hundred lines (measured <= 0.84 %)
    assert np.all(rms["weighted"] < 0.012)


def test_weighted_lsfd_floor_noise_changes_nothing():
    # additive floor only: the noise estimate is one level per channel, plain least squares is the ML
    from ema_rig.identification.criteria import COMPLETENESS_CRITERIA
    from ema_rig.identification.identification import _misfit

    t, data = _mck_data(3, p=0.0, floor=0.02)
    var = _misfit(data, lsfd(data, t.poles), COMPLETENESS_CRITERIA).variance.reshape(data.frf.shape)
    m = lsfd(data, t.poles, variance=var)
    # the estimate's proportional part comes out near 0 (not exactly: the residues move by at most
    # 3.5e-4 relative, measured, a fifth of their error against the truth, 0.2 %)
    np.testing.assert_allclose(m.residues, lsfd(data, t.poles).residues, rtol=2e-3)


def test_identify_reports_the_noise_weighted_residues():
    # the pipeline: identify's model against the exact residues, and the unweighted fit at its poles
    # (measured over 10 seeds: 95/170 Hz modes 0.47/0.42 % -> 0.22/0.23 %)
    e_ws, e_us = [], []
    for seed in range(4):
        t, data = _mck_data(seed, p=0.02, floor=0.01, coherence=True)
        ident = identify(data)
        # the model holds (the completeness test passes): the weighted fit is kept per channel unless
        # its median noise-normalised residual is above the unweighted one (by chance: 3-6 of 6 kept, measured)
        assert ident.residual_test.passed and ident.modes.meta["weighted"].endswith(" of 6 channels")
        assert int(ident.modes.meta["weighted"].split()[0]) >= 3
        assert ident.modes.n_modes == t.poles.size
        truth = _exact_residues(t)
        e_w = np.linalg.norm((ident.modes.residues - truth)[:, :, 0], axis=1) / np.linalg.norm(truth[:, :, 0], axis=1)
        u = lsfd(data, ident.modes.poles)
        e_u = np.linalg.norm((u.residues - truth)[:, :, 0], axis=1) / np.linalg.norm(truth[:, :, 0], axis=1)
        e_ws.append(e_w)
        e_us.append(e_u)
    ratio = np.sqrt(np.mean(np.square(e_ws), axis=0) / np.mean(np.square(e_us), axis=0))
    # every mode better (rms error ratio reported / unweighted, measured 0.50, 0.63, 0.83, 0.77, 0.74);
    # the isolated 95/170 Hz modes clearly (< 0.75)
    assert np.all(ratio < 1.0) and np.all(ratio[:2] < 0.75)


def test_weighted_lsfd_bad_variance(system):
    data = system.frf(FREQ)
    with pytest.raises(IdentificationError, match="variance has shape"):
        lsfd(data, system.poles[:2], variance=np.ones(7))
    with pytest.raises(IdentificationError, match="must be > 0"):
        lsfd(data, system.poles[:2], variance=np.zeros(FREQ.size))
    with pytest.raises(IdentificationError, match="must be > 0"):
        lsfd(data, system.poles[:2], variance=np.full(FREQ.size, np.nan))
    with pytest.raises(IdentificationError, match="inf at every line"):
        lsfd(data, system.poles[:2], variance=np.full(FREQ.size, np.inf))
    # the band cuts the variance like the data; inf gives a line no weight
    var = np.ones(FREQ.size)
    var[FREQ > 700] = np.inf
    cut = lsfd(data, system.poles[:3], band=(50.0, 700.0))
    np.testing.assert_allclose(lsfd(data, system.poles[:3], band=(50.0, 1000.0), variance=var).residues,
                               cut.residues, rtol=1e-8)


def test_vt_case1_synthesis_follows_every_line(real_frf_dir):
    """vt_case1 (one FRF, 0-500 Hz, coherence 0.3 at the 212 Hz peak): the unweighted LSFD let the
    lines of the 1e4-high peak set the residues: antiresonances near 80 and 170 Hz where the data
    have none (synthesis 0.14x the data there), median per-line error 66 %. Weighted: 43 %."""
    from ema_rig.io.uff import read_uff58

    d = read_uff58(real_frf_dir / "vt_case1_full.uff")
    ident = identify(d)
    data = d.band(*ident.band)
    assert float(ident.modes.line_error(data)[0, 0]) < 0.5  # measured 0.431 (unweighted 0.655)
    syn = ident.modes.synthesize(data.freq).frf[0, 0]
    ratio = np.abs(syn) / np.abs(data.frf[0, 0])
    for lo, hi in ((70.0, 90.0), (160.0, 175.0)):
        s = (data.freq >= lo) & (data.freq <= hi)
        # no antiresonance of the model where the data have none: within 0.6..1.6x at every line
        # (measured 0.77..1.37; unweighted down to 0.14)
        assert 0.6 < ratio[s].min() and ratio[s].max() < 1.6
