"""The local ML's segment problem against plainly written least squares (issue 22: its restructured arithmetic).

:meth:`ema_rig.identification.ml._Segment.evaluate` forms the variable-projection cost, its gradient
and Gauss-Newton matrix through factored matrix products, and :func:`ema_rig.identification.ml._lm`
stops by a relative-offset test. The oracles here are independent of that code: the pole columns
written out from the modal model, ``numpy.linalg.lstsq`` for the projection, central finite
differences for the derivatives, and ``scipy.optimize.least_squares`` for the minimum.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
from scipy.optimize import least_squares

from ema_rig.identification.criteria import ML_CRITERIA
from ema_rig.identification.ml import _lm, _Segment

POWER = 1  # mobility: the (j w)^p factor of the model is exercised


def _problem(n_chan: int, seed: int = 3) -> tuple[_Segment, np.ndarray, np.ndarray]:
    """Two close modes (100, 103 Hz, 1 % damping) and a far one (150 Hz, a fixed tail) on 90-115 Hz,
    ``n_chan`` channels, white noise of 1 % of the peak: the segment and its start and true pole parameters."""
    rng = np.random.default_rng(seed)
    f = np.arange(90.0, 115.0, 0.25)
    jw = 2j * np.pi * f
    lam = np.array([-2 * np.pi * 1.0 + 2j * np.pi * 100.0, -2 * np.pi * 1.5 + 2j * np.pi * 103.0])
    far = np.array([-2 * np.pi * 2.0 + 2j * np.pi * 150.0])
    poles = np.concatenate([lam, far])
    res = (rng.standard_normal((3, n_chan)) + 1j * rng.standard_normal((3, n_chan))) * 50.0
    h = sum(jw[:, None] ** POWER * (res[r] / (jw[:, None] - poles[r]) + res[r].conj() / (jw[:, None] - poles[r].conj()))
            for r in range(3))
    h = h + 0.01 * np.max(np.abs(h)) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    yw = np.concatenate([h.real, h.imag], axis=0)
    w = np.ones(f.size)
    lam0 = lam * (1.0 + 0.002 * np.array([1.0 - 1.0j, -1.0 + 0.5j]))  # a PolyMAX-like start
    seg = _Segment(jw, POWER, yw, w, lam0, 4, far, (np.zeros(1), np.ones(1)), ML_CRITERIA.basis_rcond)
    return seg, seg.theta(lam0), seg.theta(lam)


def _columns(seg: _Segment, theta: np.ndarray) -> np.ndarray:
    """The weighted real columns of the segment's model at ``theta``, written out: per pole the
    columns of Re R and Im R of ``(j w)^p (R / (j w - l) + conj(R) / (j w - conj(l)))``, then the
    segment's fixed background basis."""
    lam = seg.scale * (theta[0::2] + 1j * theta[1::2])
    jw = seg.jw[:, None]
    pos, neg = jw**POWER / (jw - lam), jw**POWER / (jw - lam.conj())
    cols = np.empty((jw.size, 2 * lam.size), complex)
    cols[:, 0::2], cols[:, 1::2] = pos + neg, 1j * pos - 1j * neg
    a = np.concatenate([cols.real, cols.imag], axis=0) * seg.ww
    return np.concatenate([a, seg.fixed], axis=1)


def _sd_at(seg: _Segment, ref: object) -> np.ndarray:
    """Standard deviations ``sqrt(diag(s^2 (J^T J)^-1))`` of the pole parameters at a ``least_squares`` result ``ref``
    (``s^2`` its cost over the residual degrees of freedom)."""
    jac, r = np.asarray(ref.jac), np.asarray(ref.fun)  # type: ignore[attr-defined]
    dof = r.size - seg.L * seg.yw.shape[1] - jac.shape[1]
    return np.asarray(np.sqrt(np.diag(float(r @ r) / dof * np.linalg.inv(jac.T @ jac))))


def _residual(seg: _Segment, theta: np.ndarray) -> np.ndarray:
    """The variable-projection residual (data - model at the least-squares linear parameters), flattened."""
    a = _columns(seg, theta)
    x = np.linalg.lstsq(a, seg.yw, rcond=None)[0]
    return np.asarray(seg.yw - a @ x).ravel()


def _cost(seg: _Segment, theta: np.ndarray) -> float:
    r = _residual(seg, theta)
    return float(r @ r)


@pytest.mark.parametrize("n_chan", [1, 3])
def test_evaluate_matches_plain_least_squares_and_finite_differences(n_chan: int):
    seg, th0, _ = _problem(n_chan)
    out = seg.evaluate(th0)
    cost = float(out["cost"])
    # the projection: the same residual norm as lstsq on the written-out columns (rounding of a
    # well-conditioned projection, ~1e-12 of the cost)
    assert cost == pytest.approx(_cost(seg, th0), rel=1e-9)
    # the gradient: d cost / d theta = 2 J^T r (grad is J^T r of r = model - data); central
    # differences at h = 1e-6 of a parameter of order 1 carry a truncation of ~h^2 and a rounding
    # of ~eps cost / h, both ~1e-8 of the gradient's scale
    k = th0.size
    fd = np.empty(k)
    hstep = 1e-6
    for i in range(k):
        e = np.zeros(k)
        e[i] = hstep
        fd[i] = (_cost(seg, th0 + e) - _cost(seg, th0 - e)) / (2 * hstep)
    grad = np.asarray(out["grad"])
    assert np.max(np.abs(2 * grad - fd)) <= 1e-6 * np.max(np.abs(fd))
    # the Gauss-Newton matrix: Kaufman's J^T J, J_k = P_perp (d A / d theta_k) x, with d A / d theta_k
    # by central differences of the written-out columns and P_perp, x from lstsq
    a = _columns(seg, th0)
    x = np.linalg.lstsq(a, seg.yw, rcond=None)[0]
    qa = np.linalg.qr(a)[0]
    jac = np.empty((seg.yw.size, k))
    for i in range(k):
        e = np.zeros(k)
        e[i] = hstep
        da = (_columns(seg, th0 + e) - _columns(seg, th0 - e)) / (2 * hstep)
        v = da @ x
        jac[:, i] = (v - qa @ (qa.T @ v)).ravel()
    hess = np.asarray(out["hess"])
    assert np.max(np.abs(hess - jac.T @ jac)) <= 1e-6 * np.max(np.abs(jac.T @ jac))
    # a cost-only evaluation completed later gives the same numbers as one full evaluation
    part = seg.evaluate(th0, cost_only=True)
    assert "hess" not in part and float(part["cost"]) == cost
    full = seg.evaluate(th0, prev=part)
    assert np.array_equal(np.asarray(full["hess"]), hess) and np.array_equal(np.asarray(full["grad"]), grad)


@pytest.mark.parametrize("n_chan", [1, 3])
def test_lm_reaches_the_least_squares_minimum(n_chan: int):
    seg, th0, th_true = _problem(n_chan)
    theta, n_eval, last = _lm(seg, th0, np.ones(seg.m, bool), ML_CRITERIA)
    assert last is not None and 1 < n_eval < ML_CRITERIA.max_iter
    ref = least_squares(lambda t: _residual(seg, t), th0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    # the two minima in units of the estimate's standard deviation s^2 (J^T J)^-1 (J at the minimum):
    # the step stop (MLCriteria.lm_step_sigma 0.05, Numerical Recipes 15.5.2) leaves a Gauss-Newton step of
    # at most 0.05 sigma per parameter, the distance to the minimum to first order (the relative-offset stop,
    # lm_offset 0.001, at most sqrt(P) 0.001 = 0.002 sigma); 0.05 sigma is far below any change a user sees
    sd = _sd_at(seg, ref)
    assert np.max(np.abs(theta - ref.x) / sd) <= ML_CRITERIA.lm_step_sigma
    # and the estimate is the truth within its uncertainty (the problem is well posed: 4 sigma)
    assert np.max(np.abs(theta - th_true) / sd) < 4.0


@pytest.mark.parametrize("n_chan", [1, 3])
def test_lm_step_stop_ends_within_its_fraction_of_sigma(n_chan: int):
    """The step stop (``MLCriteria.lm_step_sigma``) spends fewer evaluations than iterating to rounding and ends
    within that fraction of each parameter's standard deviation of the minimum (``least_squares`` to 1e-15, an
    independent optimiser). Fails on 23abb6b (no ``lm_step_sigma``)."""
    seg, th0, _ = _problem(n_chan)
    free = np.ones(seg.m, bool)
    theta, n_eval, _ = _lm(seg, th0, free, ML_CRITERIA)
    theta_r, n_eval_r, _ = _lm(seg, th0, free, replace(ML_CRITERIA, lm_step_sigma=0.0))  # the stop switched off
    assert n_eval < n_eval_r
    ref = least_squares(lambda t: _residual(seg, t), th0, method="lm", xtol=1e-15, ftol=1e-15, gtol=1e-15)
    sd = _sd_at(seg, ref)
    # iterated on, the estimate reaches the minimum (to the relative-offset stop's 0.002 sigma, 0.01 here)
    assert np.max(np.abs(theta_r - ref.x) / sd) < 0.01
    # the step stop: within lm_step_sigma of it (the Gauss-Newton step is the distance to first order)
    assert np.max(np.abs(theta - ref.x) / sd) <= ML_CRITERIA.lm_step_sigma
