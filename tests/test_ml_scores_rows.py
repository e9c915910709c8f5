"""The local ML's per-line scores and ``J^T S J`` against the Jacobian formed by finite differences.

``_Segment._scores`` never forms the Jacobian of the residual: it works from the distinct
coefficient rows of the 2m pole parameters (one product per distinct row and line, not per
parameter and row). Oracle, independent of that algebra: the Jacobian of the variable-projection
residual (Kaufman's form, the one the module uses) ``J_k = (I - Q Q^T) dA/dtheta_k x``, with
``dA/dtheta_k`` the central finite difference of the segment's weighted pole columns, ``x`` the
least-squares coefficients from ``numpy.linalg.lstsq`` and ``Q`` from ``numpy.linalg.qr``; then the
scores, ``J^T S J`` (channel covariance from the leverage-corrected residuals, line correlations
``rho`` within the Re and the Im rows) and the chi-square straight from their definitions in the
module's docstrings. Both code paths are covered: many channels (``C >= 4m``: the products of the
distinct rows) and few (the Jacobian as an array), with a noise profile per line and channel and
without one.
"""

from __future__ import annotations

import numpy as np
import pytest

from ema_rig.identification.ml import _Segment, _stack

RHO = (4.0 / 9.0, 1.0 / 36.0)  # the Hann window's line correlations (HANN_LINE_CORRELATION)


def _segment(n_chan: int, seed: int) -> tuple[_Segment, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    f = np.linspace(90.0, 130.0, 61)
    jw = 2j * np.pi * f
    lam = 2 * np.pi * np.array([-1.5 + 104.0j, -2.0 + 112.0j])
    res = rng.standard_normal((2, n_chan)) + 1j * rng.standard_normal((2, n_chan))
    h = sum(res[r][None, :] / (jw[:, None] - lam[r]) + np.conj(res[r])[None, :] / (jw[:, None] - np.conj(lam[r]))
            for r in range(2))
    h = h + 1e-3 * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    w = 1.0 + 0.3 * np.cos(np.linspace(0.0, 3.0, f.size))  # a line profile of the weights
    yw = _stack(h) * np.concatenate([w, w])[:, None]
    others = np.array([2 * np.pi * (-3.0 + 160.0j)])
    seg = _Segment(jw, 0, yw, w, lam, 2, others, (np.zeros(1), np.ones(1)), 1e-12)
    theta = seg.theta(lam * (1 + 2e-3 * (1 + 1j)))  # off the minimum: scores that do not cancel
    nv = np.exp(rng.uniform(-0.5, 0.5, (f.size, n_chan)))  # noise variance per line and channel
    return seg, theta, nv


def _pole_columns(seg: _Segment, theta: np.ndarray) -> np.ndarray:
    """The weighted pole columns (2n, 2m), Re R_r and Im R_r of each pole, unnormalised."""
    return np.asarray(_stack(seg._cols(seg.poles(theta))) * seg.ww)


def _oracle(seg: _Segment, theta: np.ndarray, rho: tuple[float, ...], nv: np.ndarray | None
            ) -> tuple[np.ndarray, np.ndarray, float]:
    n2, n_c = seg.yw.shape
    n, k = n2 // 2, theta.size
    a = np.concatenate([_pole_columns(seg, theta), seg.fixed], axis=1)
    x = np.linalg.lstsq(a, seg.yw, rcond=None)[0][:k]
    q = np.linalg.qr(a)[0]
    e = seg.yw - q @ (q.T @ seg.yw)
    jac = np.empty((k, n2, n_c))
    for p in range(k):
        h = 1e-6 * max(abs(theta[p]), 1.0)
        tp, tm = theta.copy(), theta.copy()
        tp[p] += h
        tm[p] -= h
        da = (_pole_columns(seg, tp) - _pole_columns(seg, tm)) / (2 * h)
        v = da @ x
        jac[p] = v - q @ (q.T @ v)
    lev = np.minimum(np.sum(q * q, axis=1), 0.9)
    el = e / np.sqrt(1.0 - lev)[:, None]
    row = np.einsum("krc,rc->kr", jac, el)
    scores = row[:, :n] + row[:, n:]
    sp = np.ones((n2, n_c)) if nv is None else np.sqrt(np.concatenate([nv, nv]))
    et = el / sp
    sigma = et.T @ et / n2
    js = jac * sp[None]
    jcj = np.zeros((k, k))
    for r in range(n2):
        jcj += js[:, r] @ sigma @ js[:, r].T
    for d, rl in enumerate(rho, start=1):
        for r in range(n2):
            if (r % n) + d < n:  # r and r + d in the same half (Re rows, Im rows)
                g = js[:, r] @ sigma @ js[:, r + d].T
                jcj += rl * (g + g.T)
    return scores, jcj, float(np.sum(et * et))


@pytest.mark.parametrize(("n_chan", "rho", "noise"), [(12, RHO, True), (12, (), False), (3, RHO, True), (3, (), False)])
def test_scores_match_the_finite_difference_jacobian(n_chan: int, rho: tuple[float, ...], noise: bool) -> None:
    seg, theta, nv = _segment(n_chan, seed=n_chan)
    assert (n_chan >= 4 * seg.m) == (n_chan == 12)  # both paths of _scores
    out = seg.evaluate(theta, scores=True, rho=rho, noise_var=nv if noise else None)
    scores, jcj, chi2 = _oracle(seg, theta, rho, nv if noise else None)
    sc = np.asarray(out["line_scores"])
    # the code's J is the derivative of the model, the oracle's too: the same sign. Central differences
    # with a relative step 1e-6 are exact to ~1e-9 of the largest entry here (third derivative of
    # 1 / (jw - lambda) over a step of 1e-4 rad/s); 1e-6 leaves room for the lstsq/QR rounding
    assert np.max(np.abs(sc - scores)) <= 1e-6 * np.max(np.abs(scores))
    assert np.max(np.abs(np.asarray(out["jcj"]) - jcj)) <= 1e-6 * np.max(np.abs(jcj))
    # no derivative in the chi-square: rounding only
    assert float(out["chi2_noise"]) == pytest.approx(chi2, rel=1e-10)
