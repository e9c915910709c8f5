"""Tests of the maximum-likelihood refinement (ema_rig.identification.refine) and the noise models.

The truth comes from ``_mck_truth`` (numpy/scipy only: state-space eigenvalues of M, C, K and a
direct solve for the FRFs), from a Monte Carlo H1 analyser, and from real measurements (the
change of a mode between two bands).
"""

from __future__ import annotations

import _mck_truth as mt
import numpy as np
import pytest

from ema_rig.errors import IdentificationError
from ema_rig.frf import FRFData
from ema_rig.identification import identify
from ema_rig.identification.noise import check_coherence, coherence_variance, fit_noise_model
from ema_rig.identification.refine import refine


def _data(t: mt.Truth) -> FRFData:
    return FRFData(t.freq, t.frf, t.out_dofs, t.in_dofs, meta={"source": "synthetic.uff"})


def test_coherence_variance_matches_monte_carlo_h1():
    # an H1 analyser: n averages of X = H F + N; the spread of H1 over many records against
    # (1 - g2) / (n g2) |H|^2. The exact mean of s^2 / sum|F|^2 is s^2 / (n - 1), so the
    # first-order formula is low by n / (n - 1) (6.7 % for n = 16): tolerance 10 %.
    rng = np.random.default_rng(7)
    n_avg, n_rec, h, s = 16, 6000, 0.8 - 0.3j, 0.5
    f = (rng.standard_normal((n_rec, n_avg)) + 1j * rng.standard_normal((n_rec, n_avg))) / np.sqrt(2)
    noise = s * (rng.standard_normal((n_rec, n_avg)) + 1j * rng.standard_normal((n_rec, n_avg))) / np.sqrt(2)
    x = h * f + noise
    h1 = np.sum(x * f.conj(), axis=1) / np.sum(np.abs(f) ** 2, axis=1)
    g2 = abs(h) ** 2 / (abs(h) ** 2 + s**2)
    predicted = coherence_variance(abs(h) ** 2, g2, n_avg)
    assert np.mean(np.abs(h1 - h) ** 2) == pytest.approx(predicted, rel=0.10)


def test_noise_model_recovers_floor_and_relative_part():
    # exponential |e|^2 with mean a + b |H|^2 (complex Gaussian noise): ML within 10 % on 6000 lines
    rng = np.random.default_rng(3)
    u = np.exp(rng.uniform(-7.0, 5.0, (2, 6000)))
    a_true, b_true = np.array([1e-3, 5e-4]), np.array([0.01, 0.0025])
    z = (a_true[:, None] + b_true[:, None] * u) * rng.exponential(size=u.shape)
    a, b, var = fit_noise_model(z, u)
    np.testing.assert_allclose(a, a_true, rtol=0.1)
    np.testing.assert_allclose(b, b_true, rtol=0.1)
    assert np.all(var > 0)


def test_coherence_above_one_is_clipped_with_a_note():
    coh = np.full((1, 1, 5), 0.9)
    coh[0, 0, 2] = 1.25  # analysers write this (vt_case1 does)
    out, notes = check_coherence(coh, (1, 1, 5), file="x.uff")
    assert out.max() == 1.0 and len(notes) == 1 and "clipped" in notes[0]
    with pytest.raises(IdentificationError, match="x.uff: coherence has shape"):
        check_coherence(coh, (2, 1, 5), file="x.uff")


# ------------------------------------------------------------------ coverage (small version)
# Full study: benchmarks/coverage_refine.py (8 configurations x 20 seeds). Here 2 x 12 data sets.
_CONFIGS = (
    dict(noise=0.05, proportional=True, n_in=1, coherence=False),
    dict(noise=0.05, floor_rel=0.005, proportional=False, n_in=2, coherence=True),
)


@pytest.fixture(scope="module")
def coverage_runs():
    runs = []
    for i, cfg in enumerate(_CONFIGS):
        cfg = dict(cfg)
        use_coh = cfg.pop("coherence")
        est = []
        for seed in range(12):
            t = mt.make(500 + 100 * i + seed, **cfg)
            data = _data(t)
            ident = identify(data)
            kw = {"coherence": t.coherence, "n_averages": t.n_averages} if use_coh else {}
            ref = refine(data, ident.modes, **kw)
            assert ref.converged, ref.reason
            assert ref.noise_source == ("coherence" if use_coh else "estimated")
            row = []
            for lam in t.poles:  # nearest identified mode to each true one
                f0 = abs(lam) / (2 * np.pi)
                k = int(np.argmin(np.abs(ref.natural_freq - f0)))
                assert abs(ref.natural_freq[k] - f0) < 0.004 * f0, "a true mode was not identified"
                row.append((ref.natural_freq[k], ref.damping_ratio[k], ref.natural_freq_std[k],
                            ref.damping_ratio_std[k], ident.damping_ratio[k], ident.natural_freq[k],
                            ident.natural_freq_std[k], ident.damping_ratio_std[k]))
            est.append(row)
        runs.append((np.array(est), t.natural_freq, t.damping_ratio))  # (seed, mode, 8)
    return runs


def test_two_sigma_intervals_cover_the_state_space_truth(coverage_runs):
    # >= 90 % of (mode, seed) pairs inside +-2 sigma for frequency and damping (the bar;
    # benchmarks/coverage_refine.py: 96 % / 95 % on 796 pairs), here 2 configurations x 12 seeds x 5 modes
    hit_f, hit_z = [], []
    for est, fn, zeta in coverage_runs:
        hit_f.append(np.abs(est[:, :, 0] - fn) <= 2 * est[:, :, 2])
        hit_z.append(np.abs(est[:, :, 1] - zeta) <= 2 * est[:, :, 3])
    assert np.mean(hit_f) >= 0.9
    assert np.mean(hit_z) >= 0.9


def test_reported_sigma_matches_scatter_over_seeds(coverage_runs):
    # an interval that covers because it is huge fails here. Pooled over the modes of a
    # configuration (60 pairs), the errors in units of the reported sigma have a spread within
    # 1.5x of 1; per mode (12 seeds only, the sample std itself scatters by ~20 %) the median
    # sigma is within 3x of the scatter. The full study (20 seeds) gives 0.70 .. 1.47 per mode
    # (without the one data set where PolyMAX missed a mode and the refinement warned of the misfit).
    for est, fn, zeta in coverage_runs:
        for col, scol, truth in ((0, 2, fn), (1, 3, zeta)):
            z = (est[:, :, col] - truth) / est[:, :, scol]
            assert 1 / 1.5 < np.sqrt(np.mean(z**2)) < 1.5
            ratio = np.median(est[:, :, scol], axis=0) / np.std(est[:, :, col], axis=0, ddof=1)
            assert np.all((ratio > 1 / 3) & (ratio < 3.0)), ratio


def test_no_pLSCF_damping_bias_in_the_default_or_the_refinement(coverage_runs):
    # at 5 % proportional noise pLSCF underestimates the damping of the close pair's second mode
    # by ~18 % (benchmarks/coverage_refine.py). The default estimate of identify (local ML, issue
    # 18) and the refinement both keep the mean error below 3 % (12 seeds; measured < 1.5 %).
    est, _, zeta = coverage_runs[0]
    bias_default = np.mean(est[:, :, 4], axis=0) / zeta - 1
    bias_ml = np.mean(est[:, :, 1], axis=0) / zeta - 1
    assert np.all(np.abs(bias_default) < 0.03), bias_default
    assert np.all(np.abs(bias_ml) < 0.03), bias_ml


def test_default_two_sigma_covers_the_state_space_truth(coverage_runs):
    # identify's default +-2 sigma (local ML, robust covariance) covers the truth for >= 90 %
    # of the (mode, seed) pairs in f and in zeta, and is not huge: rms z within 1.6x of 1
    for est, fn, zeta in coverage_runs:
        zf = (est[:, :, 5] - fn) / est[:, :, 6]
        zz = (est[:, :, 4] - zeta) / est[:, :, 7]
        assert np.mean(np.abs(zf) <= 2) >= 0.9 and np.mean(np.abs(zz) <= 2) >= 0.9, (zf, zz)
        assert 1 / 1.6 < np.sqrt(np.mean(zf**2)) < 1.6 and 1 / 1.6 < np.sqrt(np.mean(zz**2)) < 1.6


# ------------------------------------------------------------------ behaviour
def test_fall_back_keeps_polymax_values_with_a_reason():
    t = mt.make(1, noise=0.03)
    data = _data(t)
    ident = identify(data)
    ref = refine(data, ident.modes, max_nfev=1)
    assert not ref.converged and "no convergence" in ref.reason
    assert ref.model is ident.modes
    assert np.all(np.isnan(ref.natural_freq_std)) and np.all(np.isnan(ref.damping_ratio_std))


def test_given_variance_and_bad_inputs():
    t = mt.make(2, noise=0.02, outputs=(0, 1, 2))
    data = _data(t)
    ident = identify(data)
    ref = refine(data, ident.modes, variance=t.variance)
    assert ref.converged and ref.noise_source == "given"
    # the true variance: chi2 / (N - P) is 1 within its sampling spread (N ~ 5500)
    assert ref.chi2_red == pytest.approx(1.0, abs=0.06)
    with pytest.raises(IdentificationError, match="synthetic.uff: variance has shape"):
        refine(data, ident.modes, variance=t.variance[:, :, :-1])
    with pytest.raises(IdentificationError, match="synthetic.uff: coherence contains NaN"):
        refine(data, ident.modes, coherence=np.full(t.frf.shape, np.nan))
    with pytest.raises(IdentificationError, match="n_averages must be >= 1"):
        refine(data, ident.modes, coherence=t.coherence, n_averages=0.5)
    other = FRFData(t.freq, t.frf[:2], t.out_dofs[:2], t.in_dofs)
    with pytest.raises(IdentificationError, match="other DOFs"):
        refine(other, ident.modes)


def test_identify_refine_hook_replaces_modes_and_sigmas():
    t = mt.make(3, noise=0.03, outputs=(0, 1, 2, 3))
    data = _data(t)
    plain = identify(data)
    ident = identify(data, refine=True)
    ref = ident.refinement
    assert ref is not None and ref.converged
    np.testing.assert_array_equal(ident.natural_freq_std, ref.natural_freq_std)
    np.testing.assert_array_equal(ident.natural_freq, ref.natural_freq)
    recs = ident.to_records()
    assert all(r["n_poles"] is not None for r in recs)  # still mapped to the PolyMAX selection
    # the refined sigma of every mode is smaller than the pLSCF cluster spread would suggest
    # is not asserted: it is the truth that counts (coverage tests above)
    assert plain.refinement is None


# ------------------------------------------------------------------ real data
def _band_pair(data, bands, **kw):
    out = []
    for band in bands:
        ident = identify(data, band=band)
        ref = refine(data, ident.modes, **kw)
        assert ref.converged, ref.reason
        out.append(ref)
    return out


def test_real_dam_modes_move_less_than_two_sigma_between_bands(real_frf_dir):
    from ema_rig.io.uff import read_uff58

    data = read_uff58(real_frf_dir / "dam0.unv")
    a, b = _band_pair(data, [(1.5, 6.0), (2.0, 6.0)])
    assert a.model.n_modes == b.model.n_modes == 7
    df = np.abs(a.natural_freq - b.natural_freq)
    assert np.all(df <= 2 * np.maximum(a.natural_freq_std, b.natural_freq_std)), (df, a.natural_freq_std)


def test_real_vt_case1_212hz_between_bands(real_frf_dir):
    from ema_rig.io.uff import read_uff, read_uff58

    path = real_frf_dir / "vt_case1_full.uff"
    data = read_uff58(path)
    coh = np.asarray(read_uff(path).records[3].y, float)[None, None, :]  # dataset 3: coherence
    for kw in ({}, {"coherence": coh}):
        a, b = _band_pair(data, [(150.0, 260.0), (180.0, 240.0)], **kw)
        ka, kb = int(np.argmin(np.abs(a.natural_freq - 212.1))), int(np.argmin(np.abs(b.natural_freq - 212.1)))
        # published 212.09 Hz, peers 212.07-212.09 Hz
        assert abs(a.natural_freq[ka] - 212.08) < 0.02
        dfr = abs(a.natural_freq[ka] - b.natural_freq[kb])
        assert dfr <= 2 * max(a.natural_freq_std[ka], b.natural_freq_std[kb])
