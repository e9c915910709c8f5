"""Default maximum-likelihood estimate of every accepted mode, with a robust standard uncertainty.

Functions
---------
local_ml
    Poles of a modal model re-estimated by weighted nonlinear least squares (Gaussian
    maximum likelihood with a separable noise model) on the lines near the modes, with a
    covariance that stays valid when noise model or modal model are not exact.

Classes
-------
LocalML
    Frozen result: poles, covariances, what each mode's uncertainty is, warnings.
MLCriteria
    The frozen thresholds of this stage, each with its source.

Notes
-----
*Structure.* The band is cut into segments: each mode gets the lines within
``window_hbw`` half-power half-bandwidths of its natural frequency (at least ``min_side_lines``
on each side); overlapping windows are merged, so close modes are fitted together. In a
segment every channel ``c`` is modelled as::

    H_c(w) = (j w)^p sum_r ( R_rc / (j w - l_r) + conj(R_rc) / (j w - conj(l_r)) ) + P_c(w)

with ``P_c`` a complex polynomial (degree up to 2) in ``w`` and the tails of the other modes (at
their poles, residues free) standing for what lies outside the segment. Over a few dozen lines
these columns are nearly collinear (condition up to 1e16), so they enter as one orthonormal basis
of their span, cut at the numerical rank and at the noise: a direction along which the start
model's background stays below one noise standard deviation in every channel is dropped
(truncated SVD at the discrepancy level, Hansen 1998). Otherwise the projection, the cost and the
estimate would be set by rounding (they moved by 0.5 sigma between two BLAS kernels on dam0).
The poles ``l_r`` are shared by all channels; residues and polynomial enter linearly and are
eliminated (variable projection, Golub & Pereyra 1973; Kaufman's 1975 Jacobian). The noise weights are separable (a line profile times a channel scale), so the
weighted basis and its QR factor are the same for every channel and the whole problem costs a
few matrix products of the segment's data (BLAS 3), whatever the number of outputs. The
Gauss-Newton matrix of the poles is the Schur complement of the full Fisher information (the
residues estimated jointly). Levenberg-Marquardt iterations, started at the PolyMAX poles, stop
after ``max_iter`` evaluations at most (a work limit: no clock).

*Uncertainty.* Two covariances of the poles are formed and the larger standard deviation of
natural frequency and damping ratio is reported:

* Fisher information scaled by ``s^2 = chi2 / (N - P)`` (the noise level measured by the fit);
* the sandwich (robust, Huber 1967 / White 1980) covariance ``H^-1 (sum_b g_b g_b^T) H^-1``
  with the scores ``g_b`` summed over blocks of adjacent lines and all channels, corrected for
  the degrees of freedom the linear parameters take. It stays valid when the noise is correlated
  between channels (H1: the force noise is common to all of them) and between neighbouring lines
  (window leakage), when the noise weights are wrong, and when the model misses something locally
  (the residuals then carry it into the scores), as long as the blocks are longer than the
  residual's correlation. A model error correlates it over far more lines than the window's main
  lobe (ufffiles_frf 282-719 Hz: lag-1 autocorrelation 0.9, 100 lines), so the block length is
  chosen from the segment's own scores (Andrews 1991 plug-in bandwidth, overlapping blocks:
  ``MLCriteria.block_from_scores``), at least ``block_lines`` and the mode's half-power
  half-bandwidth. What it cannot see: the scores of a converged fit sum to zero, so a model
  error correlated over the whole segment is a bias of the estimate, not a variance of the
  scores (the background basis's model-form part below stands for one such bias).

*Model form.* The background directions a segment keeps are decided against the noise estimate
of the whole band (:meth:`_Segment.keep_supported`), not the segment's own lines alone: two bands
over the same lines can keep different directions (on ``ufffiles_frf`` the band's misfit far from
a segment raised that estimate 7-100x above the segment's own residual). Both bases are reasonable
local models of the same lines, so where the cut dropped directions the poles are estimated on the
whole basis too (started at the cut estimate). The change of natural frequency and damping ratio
between the two, less the part the noise explains (two estimates on the same lines differ by noise
of variance ``var_whole - var_cut`` when the cut model is right: Hausman, Econometrica 46, 1978),
is added in quadrature to the standard uncertainty (and the pole change's outer product, scaled
alike, to the pole covariance): the model-form part of the uncertainty (Draper, J. R. Stat. Soc.
B 57, 1995; the unconditional variance over candidate models of Buckland, Burnham & Augustin,
Biometrics 53, 1997). The estimate itself stays the cut basis's. When the whole-basis fit cannot hold a pole
(it leaves its half-power band), that mode gets no model-form term (``basis_std`` NaN).

A mode that the fit cannot hold (it leaves its half-power band, becomes unstable, passes a
neighbour, or its Fisher information is singular) is held at its PolyMAX pole; its uncertainty
is the robust covariance of the full problem at that pole, and it is propagated to the other
modes of the segment through the coupling block ``dtheta_free / dtheta_held = -H_ff^-1 H_fh``.
When no covariance can be formed the standard deviation is NaN and a warning says why; it is
never set to 0.

References: Pintelon & Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed.
2012, ch. 9 and 19 (ML and its covariance; the sandwich under model errors); Golub & Pereyra,
SIAM J. Numer. Anal. 10 (1973); Kaufman, BIT 15 (1975); White, Econometrica 48 (1980);
Harris, Proc. IEEE 66 (1978) (window main lobes); Golub & Van Loan, *Matrix Computations*, 4th ed.
2013 (numerical rank); Hansen, *Rank-Deficient and Discrete Ill-Posed Problems*, SIAM 1998.
"""

from __future__ import annotations

import copy
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import NDArray

from .._linalg import thin_qr as _qr
from .._linalg import thin_svd
from .._threads import Job
from ..frf import FORM_POWER as _FORM_POWER
from ..frf import FRFData
from .criteria import ML_CRITERIA, MLCriteria
from .modal import SpectralWindow, modal_basis, pole_basis_with_derivative
from .noise import coherence_variance, fit_noise_model
from .refine import inv_psd


@dataclass(frozen=True, slots=True, eq=False)
class LocalML:
    """Result of :func:`local_ml`.

    Parameters
    ----------
    poles : ndarray, shape (n_modes,)
        Estimated poles [rad/s] (a held mode keeps its start pole), same order as the input.
    pole_cov : ndarray, shape (n_modes, 2, 2)
        Covariance of (Re, Im) of each pole [rad^2/s^2] (robust or Fisher, the larger), NaN
        when none could be formed.
    natural_freq_std, damping_ratio_std : ndarray, shape (n_modes,)
        Standard uncertainty of natural frequency [Hz] and damping ratio [-]; NaN (never 0)
        when it could not be formed.
    kind : tuple of str
        Per mode: ``"ml"`` (estimated), ``"held"`` (kept at its PolyMAX pole) or ``"none"``.
    chi2_red : ndarray, shape (n_modes,)
        ``chi2 / (N - P)`` of the mode's segment with the noise weights (about 1 when the
        model explains the data to the noise estimate).
    warnings : tuple of str
        One line per mode whose estimate or uncertainty needs a caveat.
    n_eval : int
        Evaluations summed over the segments.
    robust_std, fisher_std : ndarray, shape (n_modes, 2), optional
        Standard deviations of (natural frequency [Hz], damping ratio [-]) from the robust and
        the Fisher covariance.
    basis_std : ndarray, shape (n_modes, 2), optional
        Model-form part: the change of (natural frequency [Hz], damping ratio [-]) between the
        segment's cut and whole background basis (0 where the cut dropped nothing, NaN where the
        whole-basis fit could not hold the mode), included in ``natural_freq_std`` /
        ``damping_ratio_std``.
    moved_to : ndarray, shape (n_modes,), complex, optional
        Per held mode, the pole [rad/s] the fit had moved it to inside its lines, further than
        ``MLCriteria.move_hbw`` (another feature of the data: a candidate of a missing mode);
        NaN for every other mode.
    """

    poles: NDArray[np.complex128]
    pole_cov: NDArray[np.float64]
    natural_freq_std: NDArray[np.float64]
    damping_ratio_std: NDArray[np.float64]
    kind: tuple[str, ...]
    chi2_red: NDArray[np.float64]
    warnings: tuple[str, ...]
    n_eval: int
    robust_std: NDArray[np.float64] | None = None
    fisher_std: NDArray[np.float64] | None = None
    basis_std: NDArray[np.float64] | None = None
    moved_to: NDArray[np.complex128] | None = None


def _stack(z: NDArray[np.complex128]) -> NDArray[np.float64]:
    return np.concatenate([z.real, z.imag], axis=0)


def _orth_span(a: NDArray[np.float64], rcond: float) -> NDArray[np.float64]:
    """Orthonormal basis, shape (rows, r), of the columns of ``a`` at numerical rank ``rcond``.

    The columns are equilibrated first; singular directions below ``rcond`` times the largest
    singular value are dropped (Golub & Van Loan 2013, sect. 5.4.1). The columns of the result are
    the left singular vectors, by decreasing singular value.
    """
    norm = np.linalg.norm(a, axis=0)
    a = a[:, norm > 0] / norm[norm > 0]
    if a.shape[1] == 0:
        return a
    u, sv, _ = thin_svd(a)
    return np.ascontiguousarray(u[:, sv > rcond * sv[0]])


class _Segment:
    """One segment: lines, weighted data, and the projected problem of its poles."""

    def __init__(self, jw: NDArray[np.complex128], power: int, yw: NDArray[np.float64], w: NDArray[np.float64],
                 lam0: NDArray[np.complex128], n_poly: int, others: NDArray[np.complex128],
                 kernel: SpectralWindow, rcond: float) -> None:
        # quadrature of the spectral window: the model is sum_m K_m H(w - nu_m) (the modal kernel's
        # window, :func:`~ema_rig.identification.modal.pole_columns`); the identity (one node at 0,
        # weight 1: no window known) is the FRF's own columns, formed without the quadrature's sums
        identity = kernel[0].size == 1 and float(kernel[0][0]) == 0.0 and float(kernel[1][0]) == 1.0
        self.window: SpectralWindow | None = None if identity else kernel
        self.power = power
        self.jw = jw
        self.yw = yw  # (2n, C) weighted stacked data
        self.w = w  # (n,) line weights
        self.ww = np.concatenate([w, w])[:, None]  # (2n, 1) the weights of the stacked rows
        self.lam0 = lam0
        self.scale = np.abs(lam0)
        self.m = lam0.size
        # the rows (k, i) of the derivative factors u, flattened, are the rows idx of b = (S_j, D_j) (evaluate)
        self.idx = (2 * np.arange(self.m)[:, None] + np.array([0, 1, 1, 0])[None, :]).ravel()
        self.scale2 = np.repeat(self.scale, 2)[:, None]  # (2m, 1)
        om = jw.imag
        mid, half = 0.5 * (om[0] + om[-1]), max(0.5 * (om[-1] - om[0]), 1e-30)
        u = (om - mid) / half
        poly = []
        for d in range(n_poly // 2):
            poly += [u**d + 0j, 1j * u**d]
        # the band's other modes at their (fixed) poles, residues free: their tails are no polynomial
        if others.size and self.window is None:
            # one call for all: without a window their columns are formed elementwise (the same numbers as
            # one by one; a window's quadrature sums keep one call per pole)
            poly += list(self._cols(np.asarray(others, dtype=np.complex128)).T)
        else:
            for lam in others.tolist():
                b1 = self._cols(np.array([lam]))
                poly += [b1[:, 0], b1[:, 1]]
        # the pole-free columns do not depend on the poles: one orthonormal basis of their weighted
        # span, cut at its numerical rank. Over a few dozen lines the tails of far modes and the
        # polynomial are nearly collinear (condition 1e16 on dam0): a basis of that rank projects the
        # data onto directions set by rounding, so the cost jumps by percent between two evaluations
        # of nearly the same poles (and between two BLAS kernels), and the iterations stop anywhere.
        self.fixed = _orth_span(_stack(np.stack(poly, axis=1)) * np.concatenate([w, w])[:, None], rcond) if poly \
            else np.zeros((2 * om.size, 0))
        self.L = 2 * self.m + self.fixed.shape[1]

    def keep_supported(self, model_w: NDArray[np.float64], noise_sd: NDArray[np.float64], sigmas: float = 1.0) -> None:
        """Keep the background directions along which the start model exceeds the noise.

        Parameters
        ----------
        model_w : ndarray, shape (2n, C)
            The start model (LSFD at the start poles) on the segment's lines, weighted like the data.
        noise_sd : ndarray, shape (C,)
            Noise standard deviation of one weighted real equation, per channel.
        sigmas : float, optional
            Kept when above this many noise standard deviations in some channel
            (:attr:`MLCriteria.background_sigmas`).

        Notes
        -----
        The singular values of the background columns (local polynomial and the other modes' tails)
        fall geometrically (a far mode's tail over a few dozen lines is a power series in
        the line offset), so they set no rank. The start model does: it is the background the data
        support, expanded in the orthonormal directions; a direction along which it stays below one
        noise standard deviation in every channel cannot be resolved by the data and only lets the
        fit absorb noise and the modes' own shape (truncated SVD at the discrepancy level: Hansen,
        *Rank-Deficient and Discrete Ill-Posed Problems*, 1998, ch. 3 and 7).
        """
        n_t = self.fixed.shape[1]
        if n_t == 0:
            return
        cols = self._cols(self.lam0)
        a = np.concatenate([_stack(cols) * self.ww, self.fixed], axis=1)
        # the minimum-norm least-squares coefficients of the background (``lstsq``'s, rank cut at eps max(shape)
        # of the largest singular value) through one SVD of the small basis: only their rows are formed
        u, sv, vt = thin_svd(a)
        rank = sv > np.finfo(float).eps * max(a.shape) * sv[0]
        coef = (vt[rank][:, a.shape[1] - n_t :].T / sv[rank]) @ (u[:, rank].T @ model_w)  # (n_t, C)
        keep = np.any(np.abs(coef) > sigmas * noise_sd[None, :], axis=1)
        self.fixed = np.ascontiguousarray(self.fixed[:, keep])
        self.L = 2 * self.m + self.fixed.shape[1]

    def restore_basis(self, fixed: NDArray[np.float64]) -> None:
        """Set the background directions back to ``fixed`` (shape (2n, n_t), the basis before the cut)."""
        self.fixed = fixed
        self.L = 2 * self.m + self.fixed.shape[1]

    def _cols(self, lam: NDArray[np.complex128]) -> NDArray[np.complex128]:
        """Window-averaged modal basis without residual terms, columns ``Re R_r``, ``Im R_r`` interleaved per pole,
        shape (n, 2 n_poles)."""
        b = modal_basis(self.jw, lam, self.power, residuals=False, window=self.window)
        cols = np.empty_like(b)
        cols[:, 0::2], cols[:, 1::2] = b[:, : lam.size], b[:, lam.size :]
        return cols

    def poles(self, theta: NDArray[np.float64]) -> NDArray[np.complex128]:
        return self.scale * (theta[0::2] + 1j * theta[1::2])

    def theta(self, lam: NDArray[np.complex128]) -> NDArray[np.float64]:
        t = np.empty(2 * self.m)
        t[0::2], t[1::2] = (lam / self.scale).real, (lam / self.scale).imag
        return t

    def evaluate(self, theta: NDArray[np.float64], scores: bool = False, rho: tuple[float, ...] = (),
                 noise_var: NDArray[np.float64] | None = None,
                 prev: dict[str, NDArray[np.float64] | float] | None = None,
                 cost_only: bool = False) -> dict[str, NDArray[np.float64] | float]:
        """Cost, Gauss-Newton matrix and gradient of all 2m pole parameters (and per-line scores).

        ``prev`` is an earlier result of this segment (e.g. the last of :func:`_lm`): when it was
        formed at the same ``theta`` on the same background basis, its projection, residual and
        derivative columns are taken over and only what it lacks is formed; at the same ``theta`` on
        another background basis (the whole-basis fit started at the cut estimate), its pole columns
        (the same numbers).
        With ``cost_only`` the result holds the cost and residual only (``"hess"`` and ``"grad"``
        missing): a trial point of :func:`_lm`, completed by a second call with it as ``prev``
        when it is accepted.
        """
        same = prev is not None and np.array_equal(np.asarray(prev["theta"]), theta)
        if same and prev is not None and prev.get("_fixed") is self.fixed:
            out = dict(prev)
        else:
            out = self._project(theta, prev if same else None)
        if cost_only:
            return out
        if "hess" not in out:
            self._derivatives(out)
        if scores:
            self._scores(out, np.asarray(out["_q"]), np.asarray(out["e"]), np.asarray(out["_bu"]),
                         np.asarray(out["_cs"]), rho, noise_var)
        return out

    def _project(self, theta: NDArray[np.float64], at: dict[str, NDArray[np.float64] | float] | None = None
                 ) -> dict[str, NDArray[np.float64] | float]:
        """Projection of the data on the span of the pole and background columns at ``theta``: the cost,
        the residual and what :meth:`_derivatives` takes from it (see :meth:`evaluate`); ``at`` an earlier
        result at the same ``theta``, whose pole columns are taken over."""
        lam = self.poles(theta)
        if at is None:
            b1, pos2, neg2 = pole_basis_with_derivative(self.jw, lam, self.power, window=self.window)
        else:
            b1 = np.asarray(at["_b1"]).view(np.complex128)
            pos2, neg2 = np.asarray(at["_pos2"]).view(np.complex128), np.asarray(at["_neg2"]).view(np.complex128)
        m, n = lam.size, self.jw.size
        # weighted pole columns (2n, 2m): Re R_r, Im R_r interleaved per pole, the rows (Re, Im) stacked
        a = np.empty((2 * n, 2 * m))
        a[:n, 0::2], a[:n, 1::2], a[n:, 0::2], a[n:, 1::2] = b1.real[:, :m], b1.real[:, m:], b1.imag[:, :m], b1.imag[:, m:]
        a *= self.ww
        d = np.sqrt(np.add.reduce(a * a, 0))  # np.linalg.norm(a, axis=0)'s numbers, without its checks
        d = np.where(d > 0, d, 1.0)
        # the background basis is orthonormal already: only the pole columns' part orthogonal to it
        # (projected out twice, "twice is enough": Giraud et al., Numer. Math. 101, 2005) is
        # factored; its Q and the background are an orthonormal basis of the whole span, its R
        # gives the poles' coefficients
        fx = self.fixed
        a /= d  # a is this call's own array: in place
        if fx.shape[1]:
            a -= fx @ (fx.T @ a)
            a -= fx @ (fx.T @ a)
        q, r = _qr(a)
        q = np.concatenate([q, fx], axis=1)  # (2n, L)
        qty = q.T @ self.yw  # (L, C)
        e = q @ qty
        np.subtract(self.yw, e, out=e)  # residual (2n, C), in place of the model (one array of the data's size less)
        cost = float(np.sum(e * e))
        return {"cost": cost, "e": e, "theta": theta.copy(), "_q": q, "_r": r, "_d": d, "_qty": qty,
                # the pole columns and their second-order ones as float views (re, im interleaved); _fixed: identity
                # of the basis
                "_b1": b1.view(np.float64), "_pos2": pos2.view(np.float64), "_neg2": neg2.view(np.float64),
                "_fixed": self.fixed}

    def _derivatives(self, out: dict[str, NDArray[np.float64] | float]) -> None:
        """Gauss-Newton matrix ``"hess"`` and gradient ``"grad"`` of the cost into ``out`` (a :meth:`_project`)."""
        q, e, d = np.asarray(out["_q"]), np.asarray(out["e"]), np.asarray(out["_d"])
        x = np.linalg.solve(np.asarray(out["_r"]), np.asarray(out["_qty"])[: 2 * self.m]) / d[:, None]  # (2m, C)
        pos2, neg2 = np.asarray(out["_pos2"]).view(np.complex128), np.asarray(out["_neg2"]).view(np.complex128)
        s_fn = pos2 + neg2  # (n, m)
        d_fn = 1j * (pos2 - neg2)
        # V_k = sum_i u_ki c_ki^T (rank 2): d/dRe = s(a S + b D), d/dIm = s(a D - b S), with the rows
        # u_k = (S_j, D_j) for k = 2j and (D_j, S_j) for k = 2j + 1: the 2m distinct rows b = (S_j, D_j)
        k = 2 * self.m
        cs = np.empty((k, 2, x.shape[1]))
        sx = x * self.scale2  # (2m, C): s_j a_j, s_j b_j
        cs[0::2, 0], cs[0::2, 1] = sx[0::2], sx[1::2]
        cs[1::2, 0], cs[1::2, 1] = sx[0::2], -sx[1::2]
        # the sums as matrix products (BLAS 3) of the rows b (the rows (k, i) of u, flattened, are b[idx]),
        # weighted like the data, the rows (Re, Im) of each line stacked
        n = s_fn.shape[0]
        b_u = np.empty((k, 2 * n))
        b_u[0::2, :n], b_u[0::2, n:], b_u[1::2, :n], b_u[1::2, n:] = s_fn.real.T, s_fn.imag.T, d_fn.real.T, d_fn.imag.T
        b_u *= self.ww.T
        idx = self.idx
        c2 = cs.reshape(2 * k, -1)
        qb = b_u @ q  # (2m, L): Q^T b
        g_b = (b_u @ b_u.T - qb @ qb.T)[np.ix_(idx, idx)]
        hess = (g_b * (c2 @ c2.T)).reshape(k, 2, k, 2).sum(axis=(1, 3))
        # J^T r with r = model - data: sum over lines and channels of u E c
        grad = -np.sum(c2 * (b_u @ e)[idx], axis=1).reshape(k, 2).sum(axis=1)
        out["hess"], out["grad"], out["_bu"], out["_cs"], out["_qb"] = 0.5 * (hess + hess.T), grad, b_u, cs, qb

    def _jcj_rows(self, pu: NDArray[np.float64], xw: NDArray[np.float64], et: NDArray[np.float64],
                  rho: tuple[float, ...], dof: int) -> NDArray[np.float64]:
        """``J^T S J`` of :meth:`_scores` through the distinct coefficient rows (many channels).

        ``pu`` (4m, 2n) the projected rows p_ka, ``xw`` (2m, n_l, C) the distinct rows times the noise sd of
        each line (n_l = n, or 1 for equal noise), ``et`` (2n, C) the standardised residuals. With
        ``f_t(i) = xw[t, i] E^T E / dof`` (or ``xw[t, i] E^T``, whichever product is smaller) and
        ``Q_d[t, u, i] = <f_t(i), xw_u(i + d)>`` (resp. ``<f_t(i), f_u(i + d)> / dof``), the lag-d sums are
        ``sum_ab sum_r p_ka[r] p_lb[r + d] sign_ka sign_lb Q_d[t_ka, t_lb, line of r]`` over the rows r of
        either half (Re, Im) for which r + d is in it too.
        """
        k, n2 = 2 * self.m, et.shape[0]
        n, n_l, n_c = n2 // 2, xw.shape[1], et.shape[1]
        flat = xw.reshape(-1, n_c)
        if k * n_l * n2 <= n2 * n_c + k * n_l * n_c:
            left = (flat @ et.T).reshape(k, n_l, n2)  # rows x rows: M_k = J_k E^T of each distinct row
            right = left / dof
        else:
            left = (flat @ ((et.T @ et) / dof)).reshape(k, n_l, n_c)  # channels x channels
            right = xw
        tt = np.tile(_C_ROW, self.m) + 2 * np.repeat(np.arange(self.m), 4)  # the distinct row of each c_ka
        pa = (pu * np.tile(_C_SIGN, self.m)[:, None]).reshape(2 * k, 2, n)

        def pair_sums(d: int) -> NDArray[np.float64]:
            if n_l == 1:
                q = (left[:, 0] @ right[:, 0].T)[tt][:, tt]
                return np.asarray(q * sum(pa[:, h, : n - d] @ pa[:, h, d:].T for h in range(2)), dtype=np.float64)
            q = np.einsum("tis,uis->tui", left[:, : n - d], right[:, d:])[tt][:, tt]
            return np.asarray(sum(np.einsum("ai,bi,abi->ab", pa[:, h, : n - d], pa[:, h, d:], q) for h in range(2)),
                              dtype=np.float64)

        s4 = pair_sums(0)
        for lag, rl in enumerate(rho, start=1):
            if rl != 0.0 and lag < n:
                g = pair_sums(lag)
                s4 = s4 + rl * (g + g.T)
        out: NDArray[np.float64] = s4.reshape(k, 2, k, 2).sum(axis=(1, 3))
        return out

    def _scores(self, out: dict[str, NDArray[np.float64] | float], q: NDArray[np.float64], e: NDArray[np.float64],
                b_u: NDArray[np.float64], cs: NDArray[np.float64], rho: tuple[float, ...],
                noise_var: NDArray[np.float64] | None) -> None:
        """Per-line scores, ``J^T S J`` and the noise chi-square into ``out`` (see :meth:`evaluate`; ``b_u``
        the rows (S_j, D_j) of :meth:`_derivatives`, ``cs`` its factors c_k, shape (2m, 2, C)).

        The Jacobian ``J_k = (I - Q Q^T) V_k`` (2n, C) of each pole parameter is never formed: ``V_k = u_k
        c_k^T`` has rank 2, so ``J_k[r, c] = sum_a p_ka[r] c_ka[c]`` with ``p_ka`` the rows ``u_k`` projected
        off the basis (2m distinct rows ``b_u`` projected once) and ``c_ka`` the coefficient rows; the c_ka
        of the 2m parameters are 2m distinct rows up to sign (``_C_ROW``, ``_C_SIGN``). The weighted
        channel products of the sandwich's ``J^T S J`` are formed once per distinct row and line (the Re
        and Im rows of a line share their noise), not per parameter and row: half the products.
        """
        k = 2 * self.m
        n = self.jw.size
        n_c = e.shape[1]
        # the rows b projected off the span of the basis, (2m, 2n), with Q^T b of :meth:`_derivatives` (the same product)
        qb = out.get("_qb")
        pb = b_u - (b_u @ q if qb is None else np.asarray(qb)) @ q.T
        pu = pb[self.idx]  # (2k, 2n): p_ka of parameter k, factor a (row 2k + a)
        c2 = cs.reshape(2 * k, n_c)  # (2k, C): c_ka
        # residuals corrected for the leverage of the linear parameters (HC2, MacKinnon & White
        # 1985): near a peak the residues take up much of each line's error
        lev = np.minimum(np.sum(q * q, axis=1), 0.9)
        e = e / np.sqrt(1.0 - lev)[:, None]
        # per-line scores sum_c J_k E: sum_a p_ka[r] (E c_ka)[r]
        row = (pu * (e @ c2.T).T).reshape(k, 2, 2 * n).sum(axis=1)
        out["line_scores"] = row[:, :n] + row[:, n:]  # (k, n)
        # J^T S J with S the error covariance: between channels as the residuals show it (pooled
        # over the segment's lines: the common part of H1 errors, force noise and leakage of the
        # same modal transients), between lines as the window makes it (lag l: rho[l-1])
        # a variance profile over the lines that the weights do not remove scales rows
        dof = 2 * n  # the residuals are leverage-corrected
        # the noise standard deviation of each line (the same for its Re and Im rows) and channel
        sp = np.ones((1, n_c)) if noise_var is None else np.sqrt(noise_var)  # (n or 1, C)
        et = e  # standardised in place (the leverage-corrected residual is a copy, not needed beyond here)
        np.divide(e.reshape(2, n, n_c), sp, out=e.reshape(2, n, n_c))
        if n_c >= 2 * k:
            # the distinct coefficient rows (c_ka = _C_SIGN * xs[_C_ROW]) times each line's noise sd, (2m, n_l, C)
            xs = cs[0::2].reshape(k, n_c)
            jcj = self._jcj_rows(pu, xs[:, None, :] * sp[None, :, :], et, rho, dof)
        else:
            # few channels: J_k (scaled by the noise sd) and J_k S as arrays (k, 2n, C); the sums over lines
            # and channels as one matrix product (BLAS 3) of the flattened (k, 2n C)
            jac = np.matmul(pu.reshape(k, 2, 2 * n).transpose(0, 2, 1), cs)
            jac *= np.concatenate([sp, sp]) if sp.shape[0] > 1 else sp
            js = jac @ ((et.T @ et) / dof)
            jcj = js.reshape(k, -1) @ jac.reshape(k, -1).T
            for lag, rl in enumerate(rho, start=1):
                if rl == 0.0 or lag >= n:
                    continue
                for half in (slice(0, n), slice(n, 2 * n)):
                    a_l, b_l = js[:, half][:, :-lag], jac[:, half][:, lag:]
                    g = a_l.reshape(k, -1) @ b_l.reshape(k, -1).T
                    jcj += rl * (g + g.T)
        out["jcj"] = jcj
        out["chi2_noise"] = float(np.sum(et * et))  # leverage-corrected residual / noise model


#: The coefficient rows ``c_ka`` of :meth:`_Segment._scores` for the parameters (Re, Im) of pole j and
#: factors a = 0, 1, as distinct rows ``s_j (a_j, b_j)`` of the residue (``_C_ROW``, offset by 2j) with a sign.
_C_ROW = np.array([0, 1, 0, 1])
_C_SIGN = np.array([1.0, 1.0, 1.0, -1.0])


def _lm(seg: _Segment, theta0: NDArray[np.float64], free: NDArray[np.bool_], crit: MLCriteria,
        start: dict[str, NDArray[np.float64] | float] | None = None
        ) -> tuple[NDArray[np.float64], int, dict[str, NDArray[np.float64] | float] | None]:
    """Levenberg-Marquardt on the free parameters (Gauss-Newton matrix, Marquardt scaling).

    Returns the parameters, the evaluations spent and the last evaluation at them (None when no
    parameter is free), which :meth:`_Segment.evaluate` takes over (``prev``). ``start``: an earlier
    evaluation of the segment, taken over at ``theta0`` as :meth:`_Segment.evaluate` takes ``prev``.

    Convergence: the iterations stop when an accepted step lowers the cost by at most
    ``crit.lm_rtol`` of it, or when the Gauss-Newton model predicts a reduction of at most
    ``crit.lm_pred_rtol`` of it for the next step (the predicted reduction ``-(2 g^T s + s^T H s)`` of the
    cost ``r^T r``: Dennis & Schnabel, *Numerical Methods for Unconstrained Optimization and
    Nonlinear Equations*, SIAM 1996, sect. 6.4 and 7.2; Moré, LNM 630, 1978). Such a step is below
    the float resolution of the cost, so its evaluation is not spent (it saves one evaluation of
    the usual 4-5; the estimates move by rounding only). The iterations stop too when that predicted
    reduction is statistically nothing: the relative offset of Bates & Watts (Technometrics 23, 1981),
    ``sqrt((pred / P) / s^2)`` with ``s^2`` the cost over its residual degrees of freedom, at most
    ``crit.lm_offset``. Without it a segment with a pole the data barely determine crawled along
    that direction up to ``max_iter`` evaluations (cost changes of 1e-8 with steps of 1e-2 on
    ``ufffiles_frf``), rounding deciding each step. And they stop when the next step would move every
    free parameter by at most ``crit.lm_step_sigma`` of its standard deviation (:func:`_within_sigma`,
    Press et al., Numerical Recipes 3rd ed., sect. 15.5.2): a move far inside the estimate's
    uncertainty, not worth an evaluation (from PolyMAX, one of the usual three).

    A trial point's cost is formed alone (:meth:`_Segment.evaluate` with ``cost_only``); its
    derivatives only when the step is taken (the same numbers).
    """
    idx = np.flatnonzero(np.repeat(free, 2))
    theta = theta0.copy()
    if idx.size == 0:
        return theta, 0, None
    cur = seg.evaluate(theta, prev=start)
    n_eval = 1
    mu = 1e-4
    dof = max(seg.yw.size - seg.L * seg.yw.shape[1] - idx.size, 1)  # residual dof: real equations - parameters
    while n_eval < crit.max_iter:
        h, g = np.asarray(cur["hess"]), np.asarray(cur["grad"])
        if idx.size < theta.size:
            h, g = h[np.ix_(idx, idx)], g[idx]
        dg = np.diag(h).copy()
        dg = np.where(dg > 0, dg, 1.0)
        try:
            step = -np.linalg.solve(h + mu * np.diag(dg), g)
        except np.linalg.LinAlgError:
            mu *= 10.0
            n_eval += 1
            continue
        c0 = float(cur["cost"])
        # the cost is half the squared residual's gradient scale: cost(theta + s) ~ cost + 2 g^T s + s^T H s
        # with grad = J^T r and hess = J^T J of the residual r (cost = r^T r)
        pred = -(2.0 * float(g @ step) + float(step @ h @ step))
        if mu <= 1e-4 and 0.0 <= pred <= max(crit.lm_pred_rtol * c0, crit.lm_offset**2 * idx.size * c0 / dof):
            break
        if mu <= 1e-4 and _within_sigma(h, step, c0 / dof, crit.lm_step_sigma):
            break
        trial = theta.copy()
        trial[idx] += step
        new = seg.evaluate(trial, cost_only=True)  # the derivatives only where the step is taken
        n_eval += 1
        c1 = float(new["cost"])
        if np.isfinite(c1) and c1 <= c0:
            theta, cur = trial, seg.evaluate(trial, prev=new)
            mu = max(mu / 5.0, 1e-12)
            if c0 - c1 <= crit.lm_rtol * c0 or np.max(np.abs(step)) < 1e-12:
                break
        elif np.isfinite(c1) and c1 - c0 <= crit.lm_rtol * c0:
            # the step changes the cost by less than its rounding: theta is the minimum to rounding
            # (raising the damping up to 1e8 only repeated evaluations of the same point)
            break
        else:
            mu *= 8.0
            if mu > 1e8:
                break
    return theta, n_eval, cur


def _within_sigma(h: NDArray[np.float64], step: NDArray[np.float64], s2: float, frac: float) -> bool:
    """Whether ``step`` moves every parameter by at most ``frac`` of its standard deviation ``sqrt(s2 (h^-1)_ii)``
    (``h`` the Gauss-Newton matrix ``J^T J``, ``s2`` the residual variance; False for ``frac <= 0`` and where
    the inverse is needed and fails): :attr:`~ema_rig.identification.criteria.MLCriteria.lm_step_sigma`."""
    if frac <= 0.0:
        return False
    lim = frac * frac * s2
    d = np.diag(h)
    # (h^-1)_ii >= 1 / h_ii for a positive definite h: within those bounds the step is within its fraction
    # without the inverse (the usual case far from the minimum is decided by the inverse below)
    if np.all(d > 0) and np.all(step * step * d <= lim):
        return True
    try:
        var = np.diag(np.linalg.inv(h))
    except np.linalg.LinAlgError:
        return False
    return bool(np.all(var > 0) and np.all(step * step <= lim * var))


def _inv(h: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """:func:`~ema_rig.identification.refine.inv_psd`, None for an empty matrix."""
    return None if h.size == 0 else inv_psd(h)


def _windows(fn: NDArray[np.float64], hb: NDArray[np.float64], freq: NDArray[np.float64], crit: MLCriteria
             ) -> list[tuple[int, int, list[int]]]:
    """Line ranges [i0, i1) of the segments and the modes in each (sorted by frequency)."""
    n = freq.size
    spans = []
    for r in np.argsort(fn, kind="stable").tolist():
        i_lo = int(np.searchsorted(freq, fn[r] - crit.window_hbw * hb[r]))
        i_hi = int(np.searchsorted(freq, fn[r] + crit.window_hbw * hb[r], side="right"))
        ic = int(np.searchsorted(freq, fn[r]))
        i_lo = max(0, min(i_lo, ic - crit.min_side_lines))
        i_hi = min(n, max(i_hi, ic + crit.min_side_lines))
        spans.append((i_lo, i_hi, r))
    segs: list[tuple[int, int, list[int]]] = []
    for i_lo, i_hi, r in spans:
        if segs and i_lo < segs[-1][1]:
            a, b, rs = segs[-1]
            segs[-1] = (a, max(b, i_hi), [*rs, r])
        else:
            segs.append((i_lo, i_hi, [r]))
    return segs


#: Correlation of the errors of H1 lines 1 and 2 apart under a Hann window: the windowed DFT
#: coefficients of white noise correlate by -2/3 and 1/6 (``X_k = Y_k/2 - (Y_k-1 + Y_k+1)/4``), and
#: the error of an averaged cross spectrum ``N X*`` by the product of the two, 4/9 and 1/36.
HANN_LINE_CORRELATION = (4.0 / 9.0, 1.0 / 36.0)


def window_kernel(window: object, segment: object, df: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Quadrature of the power spectral window an averaged (Welch) FRF estimate is smoothed with.

    With a flat force spectrum, ``E[H1](w) = integral K(nu) H(w - nu) dnu`` where ``K = |W|^2`` of
    the time window, normalised (Schmidt 1985; Bendat & Piersol 2010, sect. 8.5). For the Hann
    window ``W(b) = 0.5 sinc(b) + 0.25 sinc(b - 1) + 0.25 sinc(b + 1)`` in bins ``b`` of the
    segment; the quadrature spans +-6 bins (sidelobes below -60 dB in power beyond) at 1/8 bin.
    Other windows (or unknown processing) give the identity: one node at 0.

    Returns
    -------
    nu : ndarray
        Offsets [rad/s].
    weights : ndarray
        Quadrature weights (sum 1).
    """
    name = str(window).lower() if window is not None else ""
    if name not in ("hann", "hanning") or not isinstance(segment, (int, np.integer)) or df <= 0:
        return np.zeros(1), np.ones(1)
    b = np.arange(-48, 49) / 8.0
    k = (0.5 * np.sinc(b) + 0.25 * np.sinc(b - 1) + 0.25 * np.sinc(b + 1)) ** 2
    return 2 * np.pi * df * b, k / np.sum(k)


def _separable(var: NDArray[np.float64], lines: bool = True) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Best separable approximation ``var_ci ~ s_c v_i`` in the log domain: (s (C,), v (n,)); with
    ``lines=False`` only ``s`` (the line profile v all ones: equal line weights)."""
    lv = np.log(np.maximum(var, 1e-300))
    a = np.mean(lv, axis=1)
    if not lines:
        return np.exp(a), np.ones(var.shape[1])
    b = np.mean(lv - a[:, None], axis=0)
    return np.exp(a), np.exp(b)


def local_ml(
    data: FRFData,
    poles: NDArray[np.complex128],
    model_frf: NDArray[np.complex128],
    *,
    criteria: MLCriteria = ML_CRITERIA,
) -> LocalML:
    """Re-estimate the poles of a modal model by ML on the lines near the modes.

    Parameters
    ----------
    data : FRFData
        FRFs already cut to the band, shape (n_out, n_in, n_freq); ``data.coherence`` (and
        ``data.n_averages``) set the noise weights when present.
    poles : ndarray, shape (n_modes,)
        Start poles [rad/s] (PolyMAX), one of each conjugate pair, ``Im > 0``.
    model_frf : ndarray, shape (n_out, n_in, n_freq)
        The start model synthesised on the same lines (LSFD at the start poles), for the noise
        estimate ``a + b |H|^2`` per channel when there is no coherence.
    criteria : MLCriteria, optional
        Window, block and work limits (:data:`ML_CRITERIA`).

    Returns
    -------
    LocalML
    """
    return local_ml_staged(data, poles, model_frf, criteria=criteria).finish()


@dataclass(frozen=True, slots=True, eq=False)
class StagedML:
    """:func:`local_ml` in two stages (:func:`local_ml_staged`): the poles, then the rest.

    Parameters
    ----------
    poles : ndarray, shape (n_modes,)
        The estimated poles [rad/s] (final: those of :meth:`finish`'s result, the same numbers).
    finish : callable
        Joins the segments' scores, covariances and model-form fits (a second thread may still be
        forming them) and returns the :class:`LocalML`. Call it once.
    """

    poles: NDArray[np.complex128]
    finish: Callable[[], LocalML]


def local_ml_staged(data: FRFData, poles: NDArray[np.complex128], model_frf: NDArray[np.complex128], *,
                    criteria: MLCriteria = ML_CRITERIA, second_thread: bool = True) -> StagedML:
    """:func:`local_ml` with its poles before its uncertainties (same parameters, same numbers).

    The poles are final once every segment is fitted; the segments' scores, covariances and
    whole-basis fits follow from them alone (on large segments in a second thread). The caller
    may use the poles (e.g. fit and test the model at them) while that work finishes, then joins
    it by :attr:`StagedML.finish`.

    Parameters
    ----------
    data : FRFData
        FRFs already cut to the band, shape (n_out, n_in, n_freq) (as :func:`local_ml`).
    poles : ndarray, shape (n_modes,)
        Start poles [rad/s], one of each conjugate pair, ``Im > 0``.
    model_frf : ndarray, shape (n_out, n_in, n_freq)
        The start model synthesised on the same lines.
    criteria : MLCriteria, optional
        Window, block and work limits (:data:`ML_CRITERIA`).
    second_thread : bool, optional
        Let a second thread form large segments' scores, covariances and whole-basis fits while
        the next segment is fitted (default True; large: :data:`_THREAD_MIN_EQUATIONS`, by default none). False: all of that is formed only when
        :attr:`StagedML.finish` is called (the same numbers), so a caller that needs the poles
        alone and never calls it spends nothing on it.

    Returns
    -------
    StagedML
    """
    lam0 = np.asarray(poles, dtype=np.complex128).ravel()
    nm = lam0.size
    freq = data.freq
    n_chan = data.n_out * data.n_in
    y = data.frf.reshape(n_chan, -1)
    mod = np.asarray(model_frf).reshape(n_chan, -1)
    power = _FORM_POWER[data.frf_form]
    df = float(np.median(np.diff(freq))) if freq.size > 1 else 1.0
    warns: list[str] = []
    # ---- noise variance of every line (n_chan, n_freq), then a separable approximation per segment
    resid2, model2 = np.abs(y - mod), np.abs(mod)
    resid2 **= 2  # in place: the same numbers, two arrays of the data's size less
    model2 **= 2
    coh = data.coherence
    if coh is not None:
        n_avg = data.n_averages
        cv = coherence_variance(model2, coh.reshape(n_chan, -1), float(max(n_avg - 1, 1)) if n_avg else 1.0)
        ok = np.isfinite(cv) & (cv > 0)
        floor = 1e-12 * (float(np.max(cv[ok])) if np.any(ok) else 1.0)
        var = np.where(ok, np.maximum(cv, floor), 1e30 * floor)
        var_cov = fit_noise_model(resid2, model2)[2]
    else:
        var = var_cov = fit_noise_model(resid2, model2)[2]
    # line weights only from a measured noise profile (coherence): a profile fitted to the start
    # model's residual carries its misfit at the peaks and would weight the skirts instead
    weighted_lines = coh is not None
    kernel = window_kernel(data.meta.get("window"), data.meta.get("segment"), df)
    rho = HANN_LINE_CORRELATION if kernel[0].size > 1 else ()
    fn0 = np.abs(lam0) / (2 * np.pi)
    hb0 = np.maximum(-lam0.real / (2 * np.pi), df)
    poles_out = lam0.copy()
    cov_out = np.full((nm, 2, 2), np.nan)
    kind = ["none"] * nm
    chi_out = np.full(nm, np.nan)
    both = np.full((nm, 4), np.nan)  # robust (f, zeta) and Fisher (f, zeta) standard deviations
    basis = np.zeros((nm, 2))  # model-form part (f, zeta): cut vs whole background basis
    went = np.full(nm, np.nan + 0j)  # where the fit moved a held pole inside its lines (another feature)
    n_eval = 0
    jw_all = np.asarray(2j * np.pi * freq, dtype=np.complex128)
    windows = _windows(fn0, hb0, freq, criteria)
    # a second thread for the segments' whole-basis fits where they are large enough to gain from it
    # (numpy releases the GIL in BLAS and ufunc loops); a work-size rule, so the same on any machine
    two = second_thread and any(2 * (i1 - i0) * n_chan >= _THREAD_MIN_EQUATIONS for i0, i1, _ in windows)
    pending: list[tuple[list[int], Job[_Tail], Job[tuple[NDArray[np.complex128], NDArray[np.float64], int]] | None]] = []
    pool = ThreadPoolExecutor(max_workers=1) if two else None
    try:
        for i0, i1, rs in windows:
            rs_arr = np.asarray(rs)
            m = rs_arr.size
            n = i1 - i0
            # the other modes nearest the segment first; drop the farthest, then polynomial terms,
            # while the lines cannot carry them (2n real equations >= 2 L + 8 per channel)
            others = np.delete(np.arange(nm), rs_arr)
            mid = 0.5 * (freq[i0] + freq[i1 - 1])
            others = others[np.argsort(np.abs(fn0[others] - mid), kind="stable")]
            n_poly = 6
            while others.size and 2 * n < 2 * (2 * m + n_poly + 2 * others.size) + 8:
                others = others[:-1]
            while n_poly > 0 and 2 * n < 2 * (2 * m + n_poly) + 8:
                n_poly -= 2
            if 2 * n < 2 * (2 * m + n_poly) + 8:
                few = partial(_Tail, np.nan, [f"mode at {fn0[r]:.6g} Hz: too few lines ({n}) near it for an ML "
                                              "estimate; its uncertainty is unknown (NaN)" for r in rs])
                pending.append((rs, Job(few, None), None))
                continue
            s_c, v_i = _separable(var[:, i0:i1], weighted_lines)
            w = 1.0 / np.sqrt(v_i)
            ww = np.concatenate([w, w])[:, None]
            yw = _stack(y[:, i0:i1].T) * ww / np.sqrt(s_c)[None, :]
            seg = _Segment(jw_all[i0:i1], power, yw, w, lam0[rs_arr], n_poly, np.asarray(poles_out[np.sort(others)], dtype=np.complex128), kernel,
                           criteria.basis_rcond)
            # the background directions the start model uses above the noise (the rest only fit noise)
            nv = (var_cov[:, i0:i1] / s_c[:, None]).T * (w**2)[:, None]
            full_basis = seg.fixed
            seg.keep_supported(_stack(mod[:, i0:i1].T) * ww / np.sqrt(s_c)[None, :],
                               np.sqrt(np.maximum(np.mean(nv, axis=0) / 2.0, 1e-300)), criteria.background_sigmas)
            th0 = seg.theta(lam0[rs_arr])
            free = np.ones(m, bool)
            why: dict[int, str] = {}
            theta = th0
            last: dict[str, NDArray[np.float64] | float] | None = None  # the LM's last evaluation
            for _attempt in range(m + 2):
                theta, k, last = _lm(seg, th0, free, criteria)
                n_eval += k
                bad = _check(seg.poles(theta), lam0[rs_arr], free, (float(freq[i0]), float(freq[i1 - 1])), df,
                             criteria.move_hbw)
                if not bad:
                    break
                if seg.fixed.shape[1] < full_basis.shape[1]:
                    # the cut is a variance saving that holds only when the dropped directions bias
                    # nothing: a pole leaving its half-bandwidth shows that the data need them (the
                    # start model's background misses part of a heavily damped mode's neighbourhood),
                    # so the segment is fitted again on its whole background before any pole is held
                    seg.restore_basis(full_basis)
                    continue
                worst = max(bad, key=lambda j: bad[j][0])
                why[worst] = bad[worst][1]
                if 1.0 < bad[worst][0] < float("inf"):  # moved inside its lines beyond its half-bandwidth
                    went[rs_arr[worst]] = seg.poles(theta)[worst]
                free[worst] = False
                theta = th0
            else:
                theta, free = th0, np.zeros(m, bool)
            held = ~free
            theta = np.where(np.repeat(held, 2), th0, theta)
            # errors correlate over a mode's half-power half-bandwidth (leakage of its transient) and
            # over the window's main lobe: a block spans the larger
            nb = max(1, criteria.block_lines, int(np.ceil(float(np.min(hb0[rs_arr])) / df)))
            # model form: the same lines on the whole background basis, when the cut dropped directions
            n_cut = full_basis.shape[1] - seg.fixed.shape[1]
            # its own problem (a copy of the segment on the whole basis, started at the cut estimate): the next
            # segments need only the cut estimate, so a second thread may fit it meanwhile (fixed work, joined
            # in segment order below: the same numbers whichever thread runs it, and when)
            big = pool if 2 * n * n_chan >= _THREAD_MIN_EQUATIONS else None
            whole: Job[tuple[NDArray[np.complex128], NDArray[np.float64], int]] | None = None
            if free.any() and n_cut > 0:
                whole = Job(partial(_whole_basis, copy.copy(seg), full_basis, theta, free.copy(), lam0[rs_arr],
                                     (float(freq[i0]), float(freq[i1 - 1])), df, criteria, rho, nv, nb, last), big,
                            later=True)
            # the poles are final here (the next segments take them as their fixed neighbours); the
            # scores, covariances and warnings of the segment follow from them alone, so a second
            # thread may form them while the next segment is fitted (joined in segment order in
            # finish; on small segments they are formed there, after the caller used the poles)
            lam = seg.poles(theta)
            for j, r in enumerate(rs):
                poles_out[r] = lam[j]
                kind[r] = "held" if held[j] else "ml"
            tail = Job(partial(_segment_tail, seg, theta, last, held, why, [fn0[r] for r in rs],
                                (float(freq[i0]), float(freq[i1 - 1])), n_chan, nb, rho, nv, criteria), big,
                       later=True)
            n_eval += 1
            pending.append((rs, tail, whole))
    finally:
        if pool is not None:
            pool.shutdown(wait=False)  # its thread ends once the queued work is done (or taken back)
    n_fit = n_eval

    def finish() -> LocalML:
        n_eval = n_fit
        # ---- each segment's scores and covariances, and its whole-basis fit, in segment order ----
        for rs, tail, whole in pending:
            seg_out = tail.result()
            warns.extend(seg_out.warnings)
            chi_out[rs] = seg_out.chi2_red
            if seg_out.cov is not None:
                cov_out[rs], both[rs] = seg_out.cov, seg_out.stds
            if whole is None:
                continue
            d_basis, std_w, k = whole.result()
            n_eval += k
            for j, r in enumerate(rs if seg_out.cov is not None else ()):
                if not np.isfinite(d_basis[j, 0]):
                    basis[r] = np.nan
                elif d_basis[j, 0] != 0:
                    lw, lc = d_basis[j]
                    # the change between two estimates on the same lines carries noise of variance
                    # var_whole - var_cut (Hausman 1978): only the change beyond it is model form
                    dv = np.array([lw.real - lc.real, lw.imag - lc.imag])
                    d2 = np.array([(abs(lw) - abs(lc)) / (2 * np.pi), -lw.real / abs(lw) + lc.real / abs(lc)]) ** 2
                    s_c = np.array([max(both[r, 0], both[r, 2]), max(both[r, 1], both[r, 3])])
                    noise = np.maximum(std_w[j] ** 2 - s_c**2, 0.0)
                    b2 = np.maximum(d2 - noise, 0.0) if np.all(np.isfinite(std_w[j])) else d2
                    basis[r] = np.sqrt(b2)
                    shrink = float(np.sqrt(b2[0] / d2[0])) if d2[0] > 0 else 0.0
                    cov_out[r] = cov_out[r] + np.outer(dv, dv) * shrink**2
        fstd = np.full(nm, np.nan)
        zstd = np.full(nm, np.nan)
        for r in range(nm):
            if np.all(np.isfinite(both[r])):
                # the larger of the robust and the (correlation-aware) Fisher uncertainty, per quantity
                fstd[r], zstd[r] = max(both[r, 0], both[r, 2]), max(both[r, 1], both[r, 3])
                # plus the model-form part of the background basis, in quadrature
                bf, bz = np.nan_to_num(basis[r])
                fstd[r], zstd[r] = float(np.hypot(fstd[r], bf)), float(np.hypot(zstd[r], bz))
        # the float resolution of the fit is the smallest meaningful uncertainty: never 0
        fn = np.abs(poles_out) / (2 * np.pi)
        fstd = np.where(np.isfinite(fstd), np.maximum(fstd, 1e-10 * fn), fstd)
        zstd = np.where(np.isfinite(zstd), np.maximum(zstd, 1e-10), zstd)
        return LocalML(poles_out, cov_out, fstd, zstd, tuple(kind), chi_out, tuple(warns), n_eval,
                       both[:, :2].copy(), both[:, 2:].copy(), basis,
                       np.where(np.array([k == "held" for k in kind]), went, np.nan + 0j))

    return StagedML(poles_out.copy(), finish)


@dataclass(frozen=True, slots=True, eq=False)
class _Tail:
    """What a segment adds to :class:`LocalML` once its poles are fitted (:func:`_segment_tail`).

    ``chi2_red`` the segment's ``chi2 / (N - P)``; ``warnings`` its lines, in order; ``cov``
    (m, 2, 2) the covariance of (Re, Im) of each pole and ``stds`` (m, 4) the robust and Fisher
    standard deviations of (f [Hz], zeta), None when the Fisher information is singular.
    """

    chi2_red: float
    warnings: list[str]
    cov: NDArray[np.float64] | None = None
    stds: NDArray[np.float64] | None = None


def _segment_tail(seg: _Segment, theta: NDArray[np.float64], last: dict[str, NDArray[np.float64] | float] | None,
                  held: NDArray[np.bool_], why: dict[int, str], fn0: list[float], lines: tuple[float, float],
                  n_chan: int, nb: int, rho: tuple[float, ...], nv: NDArray[np.float64], criteria: MLCriteria
                  ) -> _Tail:
    """Scores, covariances and warnings of a fitted segment ``seg`` at its poles ``theta`` (``last`` the
    LM's last evaluation, ``held`` the modes kept at their start, ``why`` the reasons, ``fn0`` their
    start natural frequencies [Hz], ``lines`` the segment's first and last line [Hz], blocks of ``nb``
    lines for the robust covariance, ``rho`` the line correlation, ``nv`` the noise variance of the
    weighted problem, shape (n, C))."""
    n, m = seg.jw.size, seg.m
    free = ~held
    warns: list[str] = []
    # the noise model of every line and channel in the units of the weighted problem: the
    # residual covariance between channels is pooled after standardising by it
    # (the profile a + b |H|^2 fitted to the residuals: coherence also reflects leakage bias
    # at the peaks, which is no random error of the lines)
    full = seg.evaluate(theta, scores=True, rho=rho, noise_var=nv, prev=last)
    hess = np.asarray(full["hess"])
    sc = np.asarray(full["line_scores"])  # (2m, n)
    n_eq, n_lin = 2 * n * n_chan, seg.L * n_chan
    s2 = float(full["cost"]) / max(n_eq - n_lin - 2 * m, 1)
    # is the segment's residual consistent with the noise estimate? (chi^2 test with its dof)
    chi2 = float(full["chi2_noise"])
    dof_t = 2 * n * n_chan
    ratio = chi2 / dof_t
    if ratio >= criteria.misfit_ratio:
        from scipy.stats import chi2 as chi2_dist

        p = float(chi2_dist.sf(chi2, dof_t))
        if p < criteria.misfit_p:
            warns.append(
                f"the model misses the data near {', '.join(f'{f:.6g}' for f in fn0)} Hz "
                f"({lines[0]:.6g}..{lines[1]:.6g} Hz: residual {ratio:.3g} times the noise estimate, "
                f"chi2 test p = {p:.1g} with {dof_t} dof): a mode may be missing there; the ± include "
                "the misfit (robust covariance)")
    # robust meat from the leverage-corrected scores over blocks of lines (length from the data)
    meat = _meat(sc, nb, criteria.block_from_scores)
    hinv = _inv(hess)
    if hinv is None:
        for f in fn0:
            warns.append(f"mode at {f:.6g} Hz: the Fisher information of its segment "
                         f"({lines[0]:.6g}..{lines[1]:.6g} Hz) is singular, so its uncertainty is unknown "
                         "(NaN): the data do not determine the pole")
        return _Tail(s2, warns)
    cov_rob = hinv @ meat @ hinv
    jcj = np.asarray(full["jcj"])
    cov_fis = hinv @ jcj @ hinv
    if held.any() and free.any():
        # free poles: conditional on the held ones, plus the held poles' uncertainty propagated
        fi, hi = np.flatnonzero(np.repeat(free, 2)), np.flatnonzero(np.repeat(held, 2))
        hff = _inv(hess[np.ix_(fi, fi)])
        if hff is not None:
            kmat = -hff @ hess[np.ix_(fi, hi)]
            for cov in (cov_rob, cov_fis):
                mid = meat if cov is cov_rob else jcj
                cond = hff @ mid[np.ix_(fi, fi)] @ hff
                cov[np.ix_(fi, fi)] = cond + kmat @ cov[np.ix_(hi, hi)] @ kmat.T
    lam = seg.poles(theta)
    cov_out = np.empty((m, 2, 2))
    stds = np.empty((m, 4))
    for j in range(m):
        sl = slice(2 * j, 2 * j + 2)
        sj = seg.scale[j] ** 2
        c_r, c_f = cov_rob[sl, sl] * sj, cov_fis[sl, sl] * sj
        cov_out[j] = c_r if _freq_var(lam[j], c_r) >= _freq_var(lam[j], c_f) else c_f
        stds[j] = (*_delta(lam[j], c_r), *_delta(lam[j], c_f))
        if held[j]:
            warns.append(f"mode at {fn0[j]:.6g} Hz held at its PolyMAX pole ({why.get(j, 'not refined')}); "
                         "its ± is the ML uncertainty at that pole, propagated to its neighbours")
    return _Tail(s2, warns, cov_out, stds)


def _whole_basis(seg: _Segment, full_basis: NDArray[np.float64], theta: NDArray[np.float64], free: NDArray[np.bool_],
                 lam0: NDArray[np.complex128], lines: tuple[float, float], df: float, crit: MLCriteria,
                 rho: tuple[float, ...], nv: NDArray[np.float64], nb: int,
                 last: dict[str, NDArray[np.float64] | float] | None = None
                 ) -> tuple[NDArray[np.complex128], NDArray[np.float64], int]:
    """The segment ``seg`` (a copy, changed here) fitted again on its whole background basis ``full_basis``,
    started at its cut estimate ``theta``: per mode (pole on the whole basis, pole on the cut basis),
    NaN where the whole-basis fit cannot hold it (``_check`` against ``lam0``, the lines ``lines`` [Hz]);
    the (f, zeta) standard deviations of that fit (:func:`_basis_stds`, blocks of ``nb`` lines); the
    evaluations spent. Shape (m, 2) each. ``last``: the cut fit's last evaluation (its pole columns are taken over
    where it was formed at ``theta``: the same numbers)."""
    seg.restore_basis(full_basis)
    th_w, k, last_w = _lm(seg, theta, free, crit, last)
    bad_w = _check(seg.poles(th_w), lam0, free, lines, df, crit.move_hbw)
    std_w = _basis_stds(seg, seg.evaluate(th_w, scores=True, rho=rho, noise_var=nv, prev=last_w), th_w, nb,
                        crit.block_from_scores)
    d_basis = np.zeros((seg.m, 2), np.complex128)
    for j in np.flatnonzero(free).tolist():
        # a pole the whole-basis fit cannot hold has left for another feature: no alternative
        # estimate of this mode (basis_std NaN, no model-form part)
        d_basis[j] = (np.nan, np.nan) if j in bad_w else (seg.poles(th_w)[j], seg.poles(theta)[j])
    return d_basis, std_w, k + 1


#: Real equations (lines x 2 x channels) of a segment from which its whole-basis fit and its scores run in a
#: second thread (:func:`local_ml_staged`): a value no segment reaches, so off. The evaluations are mostly small
#: numpy calls that hold the interpreter lock, and beside them the caller fits the next segment (its own small
#: calls) or, in ``identify``, runs the completeness test on the other core: measured on the 256-output file of
#: ``bench_refine.py`` (segments of 18 000 - 138 000 equations, the default ``identify``, 30 alternating calls,
#: ``chrt -f 10``, one BLAS thread, 2026-12-08): 188.9 ms wall / 238.7 ms CPU with the thread from 20 000
#: equations, 175.1 / 227.9 without (``benchmarks/results/issue18_wide_s_wide14.txt``); on the bundled rig file
#: the thread lost too (``benchmarks/results/rig_timing_s_rig12.txt``). The thread stays for callers that set it.
_THREAD_MIN_EQUATIONS = 10**15


def _basis_stds(seg: _Segment, ev: dict[str, NDArray[np.float64] | float], theta: NDArray[np.float64],
                nb: int, from_scores: bool) -> NDArray[np.float64]:
    """(f [Hz], zeta) standard deviations per mode of a segment's fit, shape (m, 2): the larger of the
    robust (blocks of at least ``nb`` lines, :func:`_meat`) and the Fisher covariance, all poles free;
    NaN when singular."""
    hinv = _inv(np.asarray(ev["hess"]))
    out = np.full((seg.m, 2), np.nan)
    if hinv is None:
        return out
    cov_rob = hinv @ _meat(np.asarray(ev["line_scores"]), nb, from_scores) @ hinv
    cov_fis = hinv @ np.asarray(ev["jcj"]) @ hinv
    lam = seg.poles(theta)
    for j in range(seg.m):
        sl, sj = slice(2 * j, 2 * j + 2), seg.scale[j] ** 2
        r_, f_ = _delta(lam[j], cov_rob[sl, sl] * sj), _delta(lam[j], cov_fis[sl, sl] * sj)
        out[j] = max(r_[0], f_[0]), max(r_[1], f_[1])
    return out


def _score_bandwidth(sc: NDArray[np.float64]) -> float:
    """Andrews' (Econometrica 59, 1991, eq. 6.4 and 6.2) AR(1) plug-in bandwidth [lines] of the Bartlett
    kernel for the long-run covariance of the line scores ``sc``, shape (k, n).

    Each score series is standardised and fitted by an AR(1) ``rho_a``; then
    ``alpha(1) = sum 4 rho^2 s^4 / ((1 - rho)^6 (1 + rho)^2) / sum s^4 / (1 - rho)^4`` (``s^2`` the
    innovation variance) and the bandwidth is ``1.1447 (alpha(1) n)^(1/3)``. ``rho`` is kept inside
    +-0.97, a guard against a unit root where the plug-in diverges (not from Andrews; the segment's
    half-line cap of :func:`_meat` bounds the block anyway); 0 for fewer than 3 lines
    or non-finite scores (the covariance is then NaN anyway).
    """
    n = sc.shape[1]
    if n < 3 or not bool(np.all(np.isfinite(sc))):
        return 0.0
    x = sc / np.sqrt(np.maximum(np.mean(sc * sc, axis=1, keepdims=True), np.finfo(float).tiny))
    a0, a1 = x[:, :-1], x[:, 1:]
    rho = np.clip(np.sum(a0 * a1, axis=1) / np.maximum(np.sum(a0 * a0, axis=1), np.finfo(float).tiny), -0.97, 0.97)
    s4 = np.mean((a1 - rho[:, None] * a0) ** 2, axis=1) ** 2
    den = float(np.sum(s4 / (1 - rho) ** 4))
    if not den > 0:
        return 0.0
    alpha = float(np.sum(4 * rho**2 * s4 / ((1 - rho) ** 6 * (1 + rho) ** 2))) / den
    return float(1.1447 * (alpha * n) ** (1.0 / 3.0))


def _meat(sc: NDArray[np.float64], nb: int, from_scores: bool) -> NDArray[np.float64]:
    """The sandwich's meat ``Var(sum of the scores)`` from the line scores ``sc``, shape (k, n) -> (k, k).

    ``from_scores`` False: sums over non-overlapping blocks of ``nb`` lines, small-sample factor
    ``G / (G - 1)`` of the ``G`` blocks (batch means). True: blocks of ``b`` lines, ``b`` the larger of
    ``nb`` and :func:`_score_bandwidth` (at most half the lines), every one of the ``n - b + 1``
    overlapping blocks, scaled by ``n^2 / (b (n - b + 1) (n - b))`` (overlapping batch means, Meketon
    & Schmeiser, Proc. Winter Simulation Conf. 1984: the variance of the mean ``n b / ((n - b + 1)
    (n - b)) sum (mean_j - mean)^2``, times ``n^2``; ``b = 1`` gives ``n / (n - 1) sum s s^T``). The
    scores of a converged fit sum to zero, so blocks as long as the segment would see nothing: the
    cap at half the lines keeps at least two independent blocks' worth of information.
    """
    n = sc.shape[1]
    if not from_scores:
        blocks = np.add.reduceat(sc, np.arange(0, n, nb), axis=1)
        g = blocks.shape[1]
        return np.asarray((blocks @ blocks.T) * (g / max(g - 1, 1)), dtype=np.float64)
    b = int(min(max(nb, int(np.ceil(_score_bandwidth(sc)))), max(n // 2, 1)))
    if b >= n:
        return np.asarray(sc @ sc.T, dtype=np.float64)
    cs = np.concatenate([np.zeros((sc.shape[0], 1)), np.cumsum(sc, axis=1)], axis=1)
    w = cs[:, b:] - cs[:, :-b]  # (k, n - b + 1): the sum of every block of b adjacent lines
    return np.asarray((w @ w.T) * (n * n / (b * (n - b + 1) * (n - b))), dtype=np.float64)


def _freq_var(lam: complex, c: NDArray[np.float64]) -> float:
    return _delta(lam, c)[0] ** 2


def _delta(lam: complex, c: NDArray[np.float64]) -> tuple[float, float]:
    """Standard deviations of natural frequency [Hz] and damping ratio from the (Re, Im) covariance."""
    sig, wd = lam.real, lam.imag
    mod = abs(lam)
    g_f = np.array([sig, wd]) / (2 * np.pi * mod)
    g_z = np.array([-(wd**2), sig * wd]) / mod**3
    return float(np.sqrt(max(float(g_f @ c @ g_f), 0.0))), float(np.sqrt(max(float(g_z @ c @ g_z), 0.0)))


def _check(lam: NDArray[np.complex128], lam0: NDArray[np.complex128], free: NDArray[np.bool_],
           band: tuple[float, float], df: float, move_hbw: float) -> dict[int, tuple[float, str]]:
    """Free modes of a segment that the fit cannot hold: severity and reason."""
    fn, fn0 = np.abs(lam) / (2 * np.pi), np.abs(lam0) / (2 * np.pi)
    allowed = np.maximum(move_hbw * (-lam0.real) / (2 * np.pi), 2 * df)
    bad: dict[int, tuple[float, str]] = {}
    inf = float("inf")
    for r in np.flatnonzero(free).tolist():
        if not np.isfinite(lam[r]):
            bad[r] = (inf, "the ML pole is not finite")
        elif lam[r].real >= 0:
            bad[r] = (inf, "the ML fit made it unstable")
        elif not band[0] <= fn[r] <= band[1]:
            bad[r] = (inf, f"the ML fit moved it out of its lines {band[0]:.6g}..{band[1]:.6g} Hz")
        elif not band[0] <= lam[r].imag / (2 * np.pi) <= band[1]:
            # its resonance (the damped frequency, where the pole's term peaks) left the lines: near critical
            # damping the natural frequency |s| stays inside while the mode no longer oscillates there
            bad[r] = (inf, f"the ML fit moved its damped frequency to {lam[r].imag / (2 * np.pi):.6g} Hz, out of its "
                           f"lines {band[0]:.6g}..{band[1]:.6g} Hz (damping ratio {-lam[r].real / abs(lam[r]):.3g})")
        elif abs(fn[r] - fn0[r]) > allowed[r]:
            bad[r] = (abs(fn[r] - fn0[r]) / allowed[r],
                      f"the ML fit moved it to {fn[r]:.6g} Hz, further than its half-power half-bandwidth")
    if not bad and fn.size > 1 and np.any(np.diff(fn) <= 0):
        mv = np.abs(fn - fn0) / allowed
        r = int(np.flatnonzero(free)[np.argmax(mv[free])])
        bad[r] = (1.0, "the ML fit moved it past a neighbouring mode")
    return bad


__all__ = ["ML_CRITERIA", "LocalML", "MLCriteria", "StagedML", "local_ml", "local_ml_staged"]
