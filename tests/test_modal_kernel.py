"""The one modal kernel (identification/modal.py) against independent oracles, and its users.

Oracle: an exact M, C, K system (proportional damping), whose receptance is ``solve(K - w^2 M + j w C)``
line by line (numpy), and whose poles and mass-normalised shapes come from ``scipy.linalg.eigh(K, M)``.
The users (LSFD's real basis, the local ML's window-averaged columns, the refinement's basis and
derivatives) are checked against the pole-residue formula written out here, so a change of any of
them that is more than round-off fails.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from ema_rig.identification.ml import _Segment, window_kernel
from ema_rig.identification.modal import (
    ModalModel,
    effective_mass,
    modal_basis,
    pole_columns,
    pole_residue_basis,
    shape_products,
    synthesize_frf,
)
from ema_rig.identification.refine import _Problem


def _mck() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A 3-DOF chain (kg, N/m) with proportional damping C = a M + b K (N s/m)."""
    m = np.diag([2.0, 1.5, 3.0])
    k = np.array([[4.0e6, -1.5e6, 0.0], [-1.5e6, 3.0e6, -1.5e6], [0.0, -1.5e6, 2.5e6]])
    return m, 2.0 * m + 4e-6 * k, k


def _modes(m: np.ndarray, c: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Poles (rad/s, Im > 0) and mass-normalised real shapes (columns) of the proportional system."""
    w2, phi = scipy.linalg.eigh(k, m)  # phi^T M phi = I
    wn = np.sqrt(w2)
    zeta = np.diag(phi.T @ c @ phi) / (2 * wn)
    lam = -zeta * wn + 1j * wn * np.sqrt(1 - zeta**2)
    return lam, phi


@pytest.mark.parametrize("power", [0, 1, 2])
def test_synthesis_equals_the_exact_receptance_of_m_c_k(power):
    m, c, k = _mck()
    lam, phi = _modes(m, c, k)
    # R_r = phi phi^T / (2 j w_d) (proportional damping: exact, no approximation)
    res = np.einsum("pr,qr->rpq", phi, phi) / (2j * lam.imag)[:, None, None]
    freq = np.linspace(1.0, 1.3 * np.abs(lam).max() / (2 * np.pi), 700)
    syn = synthesize_frf(freq, lam, res, None, None, power)
    w = 2 * np.pi * freq
    exact = np.stack([(1j * wi) ** power * np.linalg.solve(k - wi**2 * m + 1j * wi * c, np.eye(3)) for wi in w],
                     axis=-1)
    # both are exact: the difference is round-off of two solves (condition <= 1 / zeta ~ 1e3 at the peaks)
    np.testing.assert_allclose(syn, exact, rtol=1e-10, atol=1e-12 * np.abs(exact).max())
    # the complex basis with these residues' (Re, Im) as unknowns gives the same FRFs
    jw = 2j * np.pi * freq
    a = modal_basis(jw, lam, power, residuals=False)
    x = np.concatenate([res.real, res.imag], axis=0)  # (2 n_modes, 3, 3)
    np.testing.assert_allclose(np.einsum("kr,rpq->pqk", a, x), exact, rtol=1e-10,
                               atol=1e-12 * np.abs(exact).max())


def test_shape_products_and_driving_point_mass_against_eigh():
    m, c, k = _mck()
    lam, phi = _modes(m, c, k)
    res = np.einsum("pr,qr->rpq", phi, phi) / (2j * lam.imag)[:, None, None]
    prod = shape_products(lam, res)
    # 2 j w_d R = phi_p phi_q: real, the products of the mass-normalised shapes (round-off only)
    np.testing.assert_allclose(prod, np.einsum("pr,qr->rpq", phi, phi), rtol=1e-12, atol=1e-15)
    for p in range(3):
        np.testing.assert_allclose(effective_mass(lam, res[:, p, p]), 1.0 / phi[p] ** 2, rtol=1e-12)
    # the model's mass and shapes are the kernel's
    model = ModalModel(lam, res, np.zeros((3, 3)), np.zeros((3, 3)), ["1+X", "2+X", "3+X"], ["1+X", "2+X", "3+X"],
                       frf_form="receptance")
    np.testing.assert_allclose(model.modal_mass("2+X"), 1.0 / phi[1] ** 2, rtol=1e-12)
    shapes = model.mode_shapes("1+X")  # (n_modes, n_out), sign fixed by the driving point
    np.testing.assert_allclose(np.abs(shapes), np.abs(phi.T), rtol=1e-12)
    np.testing.assert_allclose(model.synthesize(np.array([50.0, 300.0])).frf,
                               synthesize_frf(np.array([50.0, 300.0]), lam, res, np.zeros((3, 3)), np.zeros((3, 3)), 0),
                               rtol=0, atol=0)


def test_pole_derivative_is_the_derivative_of_the_columns():
    lam = np.array([-3.0 + 2 * np.pi * 150j, -20.0 + 2 * np.pi * 400j])
    jw = 2j * np.pi * np.linspace(100.0, 450.0, 300)
    for window in (None, window_kernel("hann", 1024, 0.5)):
        d_pos, d_neg = pole_columns(jw, lam, 2, order=2, window=window)
        h = 1e-5 * np.abs(lam)  # central difference: error ~ (h / |jw - lam|)^2 <= 1e-5 relative here
        up, _ = pole_columns(jw, lam + h, 2, window=window)
        dn, _ = pole_columns(jw, lam - h, 2, window=window)
        np.testing.assert_allclose(d_pos, (up - dn) / (2 * h), rtol=2e-5)
        _, up_c = pole_columns(jw, lam + h, 2, window=window)  # conj(lam + h) = conj(lam) + h
        _, dn_c = pole_columns(jw, lam - h, 2, window=window)
        np.testing.assert_allclose(d_neg, (up_c - dn_c) / (2 * h), rtol=2e-5)


def test_window_quadrature_is_the_average_of_shifted_columns():
    lam = np.array([-2.0 + 2 * np.pi * 200j])
    jw = 2j * np.pi * np.linspace(180.0, 220.0, 41)
    nu, kw = window_kernel("hann", 1024, 1.25)
    pos, neg = pole_columns(jw, lam, 2, window=(nu, kw))
    # the smoothed FRF column written out: sum_m K_m (j(w - nu_m))^2 / (j(w - nu_m) - lam)
    want = sum(kw_m * (jw - 1j * nu_m) ** 2 / (jw - 1j * nu_m - lam[0]) for nu_m, kw_m in zip(nu, kw, strict=True))
    np.testing.assert_allclose(pos[:, 0], want, rtol=1e-12)
    # a one-node window at 0 is no window (the ML's identity kernel)
    one = pole_columns(jw, lam, 2, window=window_kernel(None, None, 1.25))
    plain = pole_columns(jw, lam, 2)
    np.testing.assert_allclose(one[0], plain[0], rtol=1e-15)
    np.testing.assert_allclose(one[1], plain[1], rtol=1e-15)
    # leakage is physical: the Hann-smoothed peak of a 0.16 % damped mode is lower than the FRF's
    assert np.abs(pos[20, 0]) < 0.9 * np.abs(plain[0][20, 0])


def _columns(jw: np.ndarray, lam: np.ndarray, p: int) -> np.ndarray:
    """The pole-residue columns written out: Re R and Im R of each pole, then (jw)^(p-2) and (jw)^p."""
    pos = jw[:, None] ** p / (jw[:, None] - lam[None, :])
    neg = jw[:, None] ** p / (jw[:, None] - lam.conj()[None, :])
    return np.concatenate([pos + neg, 1j * (pos - neg), (jw ** (p - 2))[:, None], (jw**p)[:, None]], axis=1)


def test_lsfd_ml_and_refine_use_the_same_columns():
    lam = np.array([-4.0 + 2 * np.pi * 120j, -9.0 + 2 * np.pi * 135j, -30.0 + 2 * np.pi * 300j])
    f = np.linspace(100.0, 320.0, 221)
    jw = 2j * np.pi * f
    want = _columns(jw, lam, 2)
    # LSFD / judgement / completeness: the real basis, rows (Re, Im) interleaved per line, unit columns
    a, scale = pole_residue_basis(f, lam, 2)
    got = (a * scale)[0::2] + 1j * (a * scale)[1::2]
    np.testing.assert_allclose(got, want, rtol=1e-13)
    # refinement: basis and the derivative columns of its free poles
    prob = _Problem(jw, 2, np.zeros((1, f.size), complex), lam, np.array([True, False, True]), True)
    basis, deriv = prob._basis(prob.theta0())
    np.testing.assert_allclose(basis, want, rtol=1e-13)
    fr = lam[[0, 2]]
    want_d = np.concatenate([jw[:, None] ** 2 / (jw[:, None] - fr) ** 2, jw[:, None] ** 2 / (jw[:, None] - fr.conj()) ** 2],
                            axis=1)
    np.testing.assert_allclose(deriv, want_d, rtol=1e-13)
    # local ML, without and with the Hann window of the processing: Re/Im interleaved per pole
    for kernel in (window_kernel(None, None, 1.0), window_kernel("hann", 1024, 1.0)):
        seg = _Segment(jw, 2, np.zeros((2 * f.size, 1)), np.ones(f.size), lam, 0, np.zeros(0, complex), kernel, 1e-12)
        cols = seg._cols(lam)
        nu, kw = kernel
        sm = sum(k_m * _columns(jw - 1j * n_m, lam, 2)[:, :6] for n_m, k_m in zip(nu, kw, strict=True))
        np.testing.assert_allclose(cols[:, 0::2], sm[:, :3], rtol=1e-12)
        np.testing.assert_allclose(cols[:, 1::2], sm[:, 3:], rtol=1e-12)


def test_reported_model_scores_the_given_unweighted_fit_without_refitting(monkeypatch):
    """``_lsfd_noise_weighted(..., unweighted=)``: the unweighted LSFD ``identify`` already made is scored by
    its synthesis, not fitted again; the per-channel choice and the result are those of the refit."""
    import sys

    from ema_rig.frf import FRFData
    from ema_rig.identification.lsfd import _lsfd_checked, _lsfd_noise_weighted

    lsfd_mod = sys.modules["ema_rig.identification.lsfd"]  # the package's `lsfd` is the function

    rng = np.random.default_rng(11)
    m, c, k = _mck()
    lam, phi = _modes(m, c, k)
    res = (phi * phi[0][None, :]).T[:, :, None] / (2j * lam.imag)[:, None, None]  # driving point 1+X
    freq = np.linspace(20.0, 500.0, 800)
    h = synthesize_frf(freq, lam, res, None, None, 2)
    # channel 0: noise as stated; channels 1, 2: 20x the stated level on the skirts (the weights then
    # spread a misfit, and the unweighted fit is kept there)
    var = (0.02 * np.abs(h)) ** 2 + (1e-3 * np.abs(h).max()) ** 2
    noise = np.sqrt(var / 2) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    noise[1:] *= np.where(np.abs(h[1:]) < 0.3 * np.abs(h[1:]).max(axis=-1, keepdims=True), 20.0, 1.0)
    data = FRFData(freq, h + noise, ["1+X", "2+X", "3+X"], ["1+X"], frf_form="accelerance")
    un = _lsfd_checked(data, lam)
    refit = _lsfd_noise_weighted(data, lam, var, unweighted=None)
    calls = []
    real_fit = lsfd_mod._fit
    monkeypatch.setattr(lsfd_mod, "_fit", lambda *a, **kw: calls.append(kw) or real_fit(*a, **kw))
    reused = _lsfd_noise_weighted(data, lam, var, unweighted=un)
    assert len(calls) == 1 and calls[0].get("variance") is not None  # the weighted fit only
    assert reused.meta["weighted"] == refit.meta["weighted"]
    assert refit.meta["weighted"] not in ("3 of 3 channels", "0 of 3 channels"), refit.meta["weighted"]
    # the same two fits, chosen alike: equal to round-off of the synthesis (measured 0)
    np.testing.assert_allclose(reused.residues, refit.residues, rtol=1e-12, atol=0)
    np.testing.assert_allclose(reused.fit_error, refit.fit_error, rtol=1e-12)
