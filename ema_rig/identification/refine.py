"""Maximum-likelihood refinement of a modal model, with confidence bounds on every mode.

Functions
---------
refine
    Weighted nonlinear least-squares (Gaussian maximum-likelihood) fit of poles, residues and
    residual terms to the FRFs of the band, started from a PolyMAX/LSFD
    :class:`~ema_rig.identification.modal.ModalModel`; covariance from the Fisher information.

Classes
-------
Refinement
    Frozen result: refined model, standard deviations, noise source, convergence and cost.

Notes
-----
Model (receptance form, data of form ``p``; the convention of
:mod:`ema_rig.identification.modal`)::

    H_c(w) = (j w)^p [ sum_r ( R_rc / (j w - l_r) + conj(R_rc) / (j w - conj(l_r)) )
                       + LR_c / (j w)^2 + UR_c ]

for every channel ``c`` (output, input pair). Under complex Gaussian noise of known variance
``v_ci`` on every line ``i`` the likelihood is maximised by minimising

    chi2 = sum_c sum_i |H_c(w_i) - H_meas,c(w_i)|^2 / (v_ci / 2)

(the real and imaginary parts each carry ``v/2``). The residues and residual terms enter
linearly: for fixed poles they are the weighted LSFD solution of each channel, so only the
``2 n_modes`` pole parameters are iterated (variable projection, Golub & Pereyra 1973, with
Kaufman's 1975 Jacobian ``J = P_perp dA/dtheta x``). At the optimum ``J^T J`` is exactly the
Schur complement of the full Fisher information on the poles, so ``(J^T J)^-1`` is the marginal
covariance of the poles with the residues estimated jointly; the residues' covariance follows
from the same blocks. Natural frequency and damping ratio standard deviations follow by the
delta method. The covariance is multiplied by ``s^2 = chi2 / (N - P)`` (``N`` real equations,
``P`` real parameters) when the noise level was estimated, and by ``max(1, s^2)`` when it was
given or came from coherence and averages, so a model that does not fit the data to its noise
level reports wider bounds rather than narrower ones.

scipy's ``least_squares`` iterates the poles. The channels are accumulated in chunks into the
Gauss-Newton quantities ``J^T J`` and ``J^T r``, and the optimiser sees an equivalent
``(2 n_modes + 1)``-row system (``r' = (||r||, 0...)``, ``J'^T J' = J^T J``, ``J'^T r' = J^T r``)
with the same cost, gradient and Gauss-Newton model, so memory does not grow with the number of
outputs.

The standard deviations describe the noise only. Model error (a mode just outside the band
that the residual terms cannot represent, an unmodelled line in the band, a mode PolyMAX did not
select) biases the estimates without necessarily raising the residual; with low noise and many
lines such a bias can be several standard deviations. A misfit near a band edge and a residual
above the stated noise are reported in ``warnings``; a band that keeps modes outside it at a
distance of several half-power bandwidths from its edges avoids the first cause.

Noise: see :mod:`ema_rig.identification.noise`. Without a given variance, the weights are
refined in rounds (fit, re-estimate the variance from the new model, fit again).

References: Pintelon & Schoukens, *System Identification: A Frequency Domain Approach*, 2nd ed.
2012 (ch. 9, Gaussian ML in the frequency domain and its Fisher-information covariance);
Guillaume, Verboven, Vanlanduit et al. (2003), "A poly-reference implementation of the
least-squares complex frequency-domain estimator" (the PolyMAX start values).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._blas import single_threaded
from ..errors import IdentificationError
from ..frf import FORM_POWER as _FORM_POWER
from ..frf import FRFData
from .modal import ModalModel, modal_basis, pole_columns
from .noise import NoiseModel, check_coherence, coherence_variance, fit_noise_model
from .plscf import check_data, source_of


@dataclass(frozen=True, slots=True, eq=False)
class Refinement:
    """Result of :func:`refine`.

    Parameters
    ----------
    model : ModalModel
        Refined modal model (the input model unchanged when ``converged`` is False), modes in
        the order of the input model (sorted by natural frequency).
    natural_freq_std, damping_ratio_std : ndarray, shape (n_modes,)
        Standard deviations of natural frequency [Hz] and damping ratio [-]; NaN for a mode kept
        at its PolyMAX pole and for all modes when the refinement fell back.
    pole_cov : ndarray, shape (n_modes, 2, 2)
        Covariance of (Re, Im) of each pole [rad^2/s^2]; NaN on fall-back.
    residue_std : ndarray, shape (n_modes, n_out, n_in)
        Standard deviation of each complex residue, ``sqrt(var Re + var Im)``; NaN on fall-back.
    noise : NoiseModel
        Variance of every line of the band used as weights, and its source.
    converged : bool
        True when the fit converged and passed the checks (stable poles, inside the band, order
        kept, Fisher information invertible).
    reason : str
        Why it converged (scipy's message) or why it fell back to the input model.
    cost : float
        ``chi2`` at the returned parameters (weighted sum of squares, unit variance scale).
    chi2_red : float
        ``chi2 / (N - P)``: about 1 when model and noise description agree with the data.
    n_iter : int
        Function evaluations of the optimiser, summed over the noise rounds.
    initial : ModalModel
        The model the refinement started from.
    refined : ndarray of bool, shape (n_modes,), optional
        Which poles were refined; the others were kept at their PolyMAX value (NaN standard
        deviations, the reason in ``warnings``). None on fall-back.
    warnings : tuple of str
        One-line caveats (clipped coherence, large moves, poor fit ...).
    """

    model: ModalModel
    natural_freq_std: NDArray[np.float64]
    damping_ratio_std: NDArray[np.float64]
    pole_cov: NDArray[np.float64]
    residue_std: NDArray[np.float64]
    noise: NoiseModel
    converged: bool
    reason: str
    cost: float
    chi2_red: float
    n_iter: int
    initial: ModalModel
    refined: NDArray[np.bool_] | None = None
    warnings: tuple[str, ...] = ()

    @property
    def noise_source(self) -> str:
        """Where the line variances came from (see :class:`~ema_rig.identification.noise.NoiseModel`)."""
        return self.noise.source

    @property
    def natural_freq(self) -> NDArray[np.float64]:
        """Natural frequencies of :attr:`model` [Hz], shape (n_modes,)."""
        return self.model.natural_freq

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """Damping ratios of :attr:`model` [-], shape (n_modes,)."""
        return self.model.damping_ratio

    def to_records(self) -> list[dict[str, Any]]:
        """One dict per mode: frequency, damping and their standard deviations."""
        return [
            {
                "natural_freq": float(f),
                "damping_ratio": float(z),
                "natural_freq_std": float(sf),
                "damping_ratio_std": float(sz),
            }
            for f, z, sf, sz in zip(
                self.natural_freq, self.damping_ratio, self.natural_freq_std, self.damping_ratio_std, strict=True
            )
        ]


@dataclass(frozen=True, slots=True)
class _Value:
    """The projected problem at one ``theta``: cost, linear parameters, model."""

    theta: NDArray[np.float64]
    cost: float
    x: NDArray[np.float64]  # (n_chan, n_lin) residues (Re, Im), lower and upper residual
    model: NDArray[np.complex128]  # (n_chan, n_freq) unweighted model FRF
    chol: tuple[Any, ...]  # per channel: (Cholesky factor, column scale) of the weighted Gram matrix


class _Problem:
    """Weighted variable-projection problem: poles nonlinear, residues and residuals linear.

    Every channel ``c`` has its own line weights ``w_ci = sqrt(2 / v_ci)`` and so its own weighted
    LSFD normal equations (real and imaginary parts of the lines stacked); they are solved by
    Cholesky after column equilibration (LAPACK QR of many tall, thin matrices is far slower and
    the equilibrated Gram matrix of an LSFD basis is well conditioned).
    """

    def __init__(
        self,
        jw: NDArray[np.complex128],
        power: int,
        y: NDArray[np.complex128],
        lam0: NDArray[np.complex128],
        free: NDArray[np.bool_],
        residuals: bool,
    ) -> None:
        self.jw = jw
        self.power = power
        self.y = y  # (n_chan, n_freq)
        self.yr = np.concatenate([y.real, y.imag], axis=1)  # (n_chan, 2 n_freq)
        self.lam0 = lam0  # (n_modes,) start poles; the frozen ones stay there
        self.free = np.flatnonzero(free)  # modes whose poles are refined
        self.scale = np.abs(lam0[self.free])  # rad/s per unit of theta
        self.residuals = residuals
        self.n_modes = lam0.size
        self.n_lin = 2 * self.n_modes + (2 if residuals else 0)
        self.w = np.ones(self.yr.shape)  # sqrt(2 / variance) on the stacked rows
        self._gn_last: tuple[bytes, tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None

    def theta0(self) -> NDArray[np.float64]:
        lam = self.lam0[self.free] / self.scale
        theta = np.empty(2 * lam.size)
        theta[0::2], theta[1::2] = lam.real, lam.imag
        return theta

    def set_variance(self, var: NDArray[np.float64]) -> None:
        w = np.sqrt(2.0 / var)
        self.w = np.concatenate([w, w], axis=1)
        self._gn_last = None

    def poles(self, theta: NDArray[np.float64]) -> NDArray[np.complex128]:
        """All poles [rad/s]: the refined ones from ``theta``, the frozen ones at their start."""
        lam = self.lam0.copy()
        lam[self.free] = self.scale * (theta[0::2] + 1j * theta[1::2])
        return lam

    def _basis(self, theta: NDArray[np.float64]) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        """LSFD basis (n_freq, n_lin) and pole-derivative functions of the free modes (n_freq, 2 n_free).

        Both from the modal kernel (:func:`~ema_rig.identification.modal.modal_basis`,
        :func:`~ema_rig.identification.modal.pole_columns` with ``order=2``).
        """
        lam = self.poles(theta)
        basis = modal_basis(self.jw, lam, self.power, residuals=self.residuals)
        pos2, neg2 = pole_columns(self.jw, lam[self.free], self.power, order=2)
        return basis, np.concatenate([pos2, neg2], axis=1)

    @staticmethod
    def _stack(z: NDArray[np.complex128]) -> NDArray[np.float64]:
        return np.concatenate([z.real, z.imag], axis=0)

    def _deriv(self, f: NDArray[np.complex128], x: NDArray[np.float64]) -> NDArray[np.complex128]:
        """Derivative of one channel's model w.r.t. theta, (n_freq, 2 n_free).

        ``d/dRe(l_r) = s_r (R P2_r + conj(R) N2_r)``, ``d/dIm(l_r) = j s_r (R P2_r - conj(R) N2_r)``
        with ``P2_r = (jw)^p / (jw - l_r)^2``, ``N2_r = (jw)^p / (jw - conj(l_r))^2``.
        """
        nm, fr = self.n_modes, self.free
        res = (x[fr] + 1j * x[nm + fr]) * self.scale
        nf = fr.size
        dp = f[:, :nf] * res
        dn = f[:, nf:] * res.conj()
        out = np.empty((f.shape[0], 2 * nf), np.complex128)
        out[:, 0::2] = dp + dn
        out[:, 1::2] = 1j * (dp - dn)
        return out

    def value(self, theta: NDArray[np.float64]) -> _Value:
        """Weighted LSFD of every channel at the poles of ``theta``."""
        import scipy.linalg

        b, _ = self._basis(theta)
        br = self._stack(b)
        n_chan = self.y.shape[0]
        x = np.empty((n_chan, self.n_lin))
        cost = 0.0
        chol = []
        for c in range(n_chan):
            a = self.w[c][:, None] * br
            yw = self.w[c] * self.yr[c]
            g = a.T @ a
            d = np.sqrt(np.diag(g))
            d = np.where(d > 0, d, 1.0)
            cf = scipy.linalg.cho_factor(g / np.outer(d, d), check_finite=False)
            x[c] = scipy.linalg.cho_solve(cf, (a.T @ yw) / d, check_finite=False) / d
            r = a @ x[c] - yw
            cost += float(r @ r)
            chol.append((cf, d))
        return _Value(theta, cost, x, x @ b.T, tuple(chol))

    def _channels(self, val: _Value) -> Any:
        """Per channel: weighted basis A, residual r, A^T V, G^-1 A^T V, V, G^-1 (callable)."""
        import scipy.linalg

        b, f = self._basis(val.theta)
        br = self._stack(b)
        for c in range(self.y.shape[0]):
            cf, d = val.chol[c]

            def gsolve(rhs: NDArray[np.float64], cf: Any = cf, d: NDArray[np.float64] = d) -> NDArray[np.float64]:
                return cast("NDArray[np.float64]", scipy.linalg.cho_solve(cf, rhs / d[:, None], check_finite=False) / d[:, None])

            a = self.w[c][:, None] * br
            r = a @ val.x[c] - self.w[c] * self.yr[c]
            v = self.w[c][:, None] * self._stack(self._deriv(f, val.x[c]))
            atv = a.T @ v
            yield a, r, atv, gsolve(atv), v, gsolve

    def gauss_newton(self, val: _Value, exact: bool = False) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``J^T J`` and ``J^T r`` of Kaufman's Jacobian ``J = P_perp V``.

        ``exact`` forms ``P_perp V`` explicitly (no cancellation: for the covariance); otherwise
        ``V^T V - (A^T V)^T G^-1 A^T V`` (for the iterations). ``J^T r = V^T r`` as ``A^T r = 0``.
        """
        key = val.theta.tobytes() + bytes([exact])
        if self._gn_last is not None and self._gn_last[0] == key:
            return self._gn_last[1]
        nt = 2 * self.free.size
        hess = np.zeros((nt, nt))
        grad = np.zeros(nt)
        for a, r, atv, m, v, _ in self._channels(val):
            if exact:
                pv = v - a @ m
                hess += pv.T @ pv
            else:
                hess += v.T @ v - atv.T @ m
            grad += v.T @ r
        self._gn_last = (key, (0.5 * (hess + hess.T), grad))
        return self._gn_last[1]

    def second_order(
        self, val: _Value, cov_theta: NDArray[np.float64]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Mean leverage of every line (n_chan, n_freq) and residue variances (n_chan, n_modes).

        ``cov_theta`` is the pole covariance in units of the weights (``(J^T J)^-1``).
        """
        n_chan, n_f = self.y.shape
        nm = self.n_modes
        lev = np.empty((n_chan, n_f))
        res_var = np.empty((n_chan, nm))
        eye = np.eye(self.n_lin)
        for c, (a, _, _, m, v, gsolve) in enumerate(self._channels(val)):
            pv = v - a @ m
            ginv = gsolve(eye)
            h = np.sum((a @ ginv) * a, axis=1) + np.sum((pv @ cov_theta) * pv, axis=1)
            lev[c] = 0.5 * (h[:n_f] + h[n_f:])
            dg = np.diag(ginv + m @ cov_theta @ m.T)
            res_var[c] = dg[:nm] + dg[nm : 2 * nm]
        return lev, res_var


def _gn_solve(prob: _Problem, theta0: NDArray[np.float64], max_nfev: int, final: bool) -> tuple[Any, _Value]:
    """least_squares on the compressed Gauss-Newton system; returns scipy's result and the value."""
    from scipy.optimize import least_squares

    cache: dict[bytes, _Value] = {}

    def ev(th: NDArray[np.float64]) -> _Value:
        key = th.tobytes()
        if key not in cache:
            if len(cache) > 4:
                cache.clear()
            cache[key] = prob.value(np.array(th))
        return cache[key]

    nt = theta0.size

    def fun(th: NDArray[np.float64]) -> NDArray[np.float64]:
        out = np.zeros(nt + 1)
        out[0] = np.sqrt(ev(th).cost)
        return out

    def jac(th: NDArray[np.float64]) -> NDArray[np.float64]:
        val = ev(th)
        hess, grad = prob.gauss_newton(val)
        rho = np.sqrt(val.cost)
        j = np.zeros((nt + 1, nt))
        if rho > 0:
            j[0] = grad / rho
            rest = hess - np.outer(j[0], j[0])
        else:
            rest = hess
        vals, vecs = np.linalg.eigh(0.5 * (rest + rest.T))
        j[1:] = (vecs * np.sqrt(np.clip(vals, 0.0, None))).T
        return j

    tol = (1e-10, 1e-8) if final else (1e-6, 1e-6)
    sol = least_squares(
        fun, theta0, jac=jac, method="trf", x_scale="jac", ftol=tol[0], xtol=tol[1], gtol=tol[0], max_nfev=max_nfev
    )
    return sol, ev(sol.x)


def _line_index(full: FRFData, cut: FRFData) -> NDArray[np.intp]:
    return np.searchsorted(full.freq, cut.freq)


def _input_noise(
    data: FRFData, cut: FRFData, idx: NDArray[np.intp], variance: ArrayLike | None, coherence: ArrayLike | None,
    n_averages: float | None, src: str | None,
) -> tuple[NDArray[np.float64] | None, NDArray[np.float64] | None, float | None, list[str]]:
    """Variance or coherence of the band lines (n_chan, n_freq) from the arguments or the data."""
    notes: list[str] = []
    n_chan = cut.n_out * cut.n_in
    if variance is None:
        variance = getattr(data, "variance", None)
    if variance is not None:
        var = np.asarray(variance, dtype=np.float64)
        if var.shape != data.shape:
            raise IdentificationError(f"variance has shape {var.shape}, the FRFs {data.shape}", file=src)
        var = var[:, :, idx].reshape(n_chan, -1)
        if not np.all(np.isfinite(var)) or np.any(var <= 0):
            raise IdentificationError("variance must be finite and > 0 on every line of the band", file=src)
        return var, None, None, notes
    if coherence is None:
        coherence = getattr(data, "coherence", None)
    if coherence is None:
        return None, None, None, notes
    coh, cnotes = check_coherence(coherence, data.shape, file=src)
    notes += list(cnotes)
    coh = coh[:, :, idx].reshape(n_chan, -1)
    if n_averages is None:
        n_avg = getattr(data, "n_averages", None)
        n_averages = float(n_avg) if n_avg else None
    if n_averages is not None and not n_averages >= 1:
        raise IdentificationError(f"n_averages must be >= 1, got {n_averages!r}", file=src)
    if np.any(coh <= 0):
        notes.append(f"coherence is 0 at {int(np.sum(coh <= 0))} lines of the band; they carry no weight")
    return None, coh, n_averages, notes


def _fallback(
    initial: ModalModel, noise: NoiseModel, reason: str, n_iter: int, cost: float, chi2_red: float,
    warnings: list[str],
) -> Refinement:
    nm = initial.n_modes
    nan = np.full(nm, np.nan)
    return Refinement(
        model=initial,
        natural_freq_std=nan,
        damping_ratio_std=nan.copy(),
        pole_cov=np.full((nm, 2, 2), np.nan),
        residue_std=np.full(initial.residues.shape, np.nan),
        noise=noise,
        converged=False,
        reason=reason,
        cost=cost,
        chi2_red=chi2_red,
        n_iter=n_iter,
        initial=initial,
        warnings=tuple(warnings),
    )


def refine(
    data: FRFData,
    model: ModalModel,
    *,
    band: tuple[float, float] | None = None,
    variance: ArrayLike | None = None,
    coherence: ArrayLike | None = None,
    n_averages: float | None = None,
    residuals: bool = True,
    noise_rounds: int = 2,
    max_nfev: int = 60,
) -> Refinement:
    """Refine a modal model by weighted nonlinear least squares (Gaussian maximum likelihood).

    Parameters
    ----------
    data : FRFData
        Measured FRFs, shape (n_out, n_in, n_freq), with the DOFs of ``model``.
    model : ModalModel
        Start values (PolyMAX poles with LSFD residues, e.g. ``identify(...).modes``).
    band : (float, float), optional
        Band [Hz] of the fit (default ``model.band``).
    variance : array_like, shape (n_out, n_in, n_freq), optional
        Complex variance ``E|e|^2`` of every line [FRF unit^2]. Default: ``data.variance`` if the
        data carry one, else from coherence, else estimated.
    coherence : array_like, shape (n_out, n_in, n_freq), optional
        Ordinary coherence 0..1 of every line (default ``data.coherence`` when present).
    n_averages : float, optional
        Number of averages of the coherence/H1 estimate (default ``data.n_averages``). Without it the coherence gives the shape of the variance and
        its level is estimated from the residual.
    residuals : bool, optional
        Fit lower and upper residual terms (default True).
    noise_rounds : int, optional
        Fits, each with weights re-estimated from the previous one, when the noise level is not
        known (default 2).
    max_nfev : int, optional
        Function evaluations per fit (default 60).

    Returns
    -------
    Refinement
        ``converged`` False (with ``reason``) returns the input model and NaN standard
        deviations.

    Raises
    ------
    IdentificationError
        DOFs of data and model differ, a bad variance/coherence array, or fewer equations than
        parameters.

    Examples
    --------
    >>> import numpy as np
    >>> from ema_rig.frf import FRFData
    >>> from ema_rig.identification import lsfd
    >>> f = np.linspace(50.0, 150.0, 201)
    >>> jw = 2j * np.pi * f
    >>> lam = 2 * np.pi * 100 * (-0.02 + 1j * np.sqrt(1 - 0.02**2))
    >>> h = (1e-3j / (jw - lam) - 1e-3j / (jw - lam.conjugate()))[None, None]
    >>> noise = 1e-8 * np.exp(2j * np.pi * np.random.default_rng(0).random(f.size))
    >>> data = FRFData(f, h + noise, ["1+Y"], ["1+Y"], frf_form="receptance")
    >>> start = lsfd(data, [lam * 1.01])
    >>> ref = refine(data, start)
    >>> ref.converged, ref.noise_source, round(float(ref.natural_freq[0]), 3)
    (True, 'estimated', 100.0)
    >>> bool(abs(ref.natural_freq[0] - 100.0) < 2 * ref.natural_freq_std[0])
    True
    """
    if not isinstance(model, ModalModel):
        raise TypeError(f"model must be a ModalModel, got {type(model).__name__}")
    with single_threaded():  # many small products: threads only add hand-off time
        return _refine(data, model, band, variance, coherence, n_averages, residuals, noise_rounds, max_nfev)


def _refine(
    data: FRFData, model: ModalModel, band: tuple[float, float] | None, variance: ArrayLike | None,
    coherence: ArrayLike | None, n_averages: float | None, residuals: bool, noise_rounds: int, max_nfev: int,
) -> Refinement:
    src = source_of(data) if isinstance(data, FRFData) else None
    if isinstance(data, FRFData) and (data.out_dofs != model.out_dofs or data.in_dofs != model.in_dofs):
        raise IdentificationError("the modal model was fitted to other DOFs than these data", file=src)
    if band is None:
        lo = max(float(model.band[0]), float(data.freq[0]))
        hi = min(float(model.band[1]), float(data.freq[-1]))
        band = (lo, hi)
    cut = check_data(data, band)
    if model.n_modes == 0:
        raise IdentificationError("nothing to refine: the modal model has no mode", file=src)
    idx = _line_index(data, cut)
    power = _FORM_POWER[cut.frf_form]
    freq = cut.freq
    if residuals and freq[0] == 0.0:
        # the lower-residual column (jw)^p / (jw)^2 is singular (p < 2) or 0/0 (p = 2) at 0 Hz
        freq, idx = freq[1:], idx[1:]
    given_var, coh, n_avg, warns = _input_noise(data, cut, idx, variance, coherence, n_averages, src)
    n_chan = cut.n_out * cut.n_in
    y = data.frf[:, :, idx].reshape(n_chan, -1)
    jw = np.asarray(2j * np.pi * freq, dtype=np.complex128)
    lam0 = np.asarray(model.poles, dtype=np.complex128)
    n_lin = 2 * lam0.size + (2 if residuals else 0)
    n_eq = 2 * y.size
    n_par = 2 * lam0.size + n_chan * n_lin
    if n_eq <= n_par:
        raise IdentificationError(
            f"refinement: {n_eq} real equations cannot determine {n_par} parameters "
            f"({lam0.size} modes, {n_chan} channels, {freq.size} lines)",
            file=src,
        )
    dof = n_eq - n_par
    fband = (float(freq[0]), float(freq[-1]))

    def as_noise(var: NDArray[np.float64], source: str) -> NoiseModel:
        return NoiseModel(var.reshape(cut.n_out, cut.n_in, -1), source, n_avg if coh is not None else None, tuple(warns))

    # a mode whose refinement fails (unstable, out of the band, jumps to another mode ...) is
    # frozen at its PolyMAX pole and the others are refined again
    free = np.ones(lam0.size, bool)
    frozen_why: dict[int, str] = {}
    for _attempt in range(min(lam0.size, 6)):
        prob = _Problem(jw, power, y, lam0, free, residuals)
        try:
            fit = _fit(prob, y, given_var, coh, n_avg, noise_rounds, max_nfev)
        except (np.linalg.LinAlgError, ValueError) as exc:
            return _fallback(model, as_noise(np.ones(y.shape), "estimated"), f"refinement failed: {exc}", 0,
                             float("nan"), float("nan"), warns)
        sol, e, var, source, n_iter, hess = fit
        chi2 = float(e.cost)
        chi2_red = chi2 / dof
        noise = as_noise(var, source)
        lam = prob.poles(sol.x)
        cov_u = inv_psd(hess)
        bad = _bad_modes(lam, lam0, prob.free, fband, float(np.median(np.diff(freq))), hess if cov_u is None else None)
        if sol.status <= 0 and not bad:
            return _fallback(model, noise, f"no convergence within {max_nfev} evaluations", n_iter, chi2, chi2_red,
                             warns)
        if not bad:
            break
        # freeze the worst one (the others may be pulled back once it no longer wanders)
        worst = max(bad, key=lambda r: bad[r][0])
        frozen_why[worst] = bad[worst][1]
        free[worst] = False
        if not free.any():
            return _fallback(model, noise, "; ".join(f"mode {r + 1}: {w}" for r, w in sorted(frozen_why.items())),
                             n_iter, chi2, chi2_red, warns)
    else:
        return _fallback(model, noise, "modes kept failing the checks after freezing "
                         + "; ".join(f"mode {r + 1}: {w}" for r, w in sorted(frozen_why.items())),
                         n_iter, chi2, chi2_red, warns)
    assert cov_u is not None
    for r, why in sorted(frozen_why.items()):
        warns.append(f"mode {r + 1} ({abs(lam0[r]) / (2 * np.pi):.6g} Hz) kept at its PolyMAX pole: {why}")
    s2 = chi2_red if source in ("estimated", "coherence-scaled") else max(1.0, chi2_red)
    if source in ("given", "coherence") and chi2_red > 2.0:
        warns.append(
            f"the fit residual is {chi2_red:.3g} times the stated noise (model error or "
            "underestimated noise); the bounds are widened by this factor"
        )
    cov_theta = cov_u * s2
    _, res_var = prob.second_order(e, cov_u)
    nm = lam.size
    res_std = np.sqrt(res_var * s2).T.reshape(nm, cut.n_out, cut.n_in)
    # (Re, Im) covariance in rad/s, then the delta method; NaN for frozen modes
    pole_cov = np.full((nm, 2, 2), np.nan)
    fn_std = np.full(nm, np.nan)
    z_std = np.full(nm, np.nan)
    for i, r in enumerate(prob.free.tolist()):
        c = cov_theta[2 * i : 2 * i + 2, 2 * i : 2 * i + 2] * prob.scale[i] ** 2
        pole_cov[r] = c
        sig, wd = lam[r].real, lam[r].imag
        mod = abs(lam[r])
        g_f = np.array([sig, wd]) / (2 * np.pi * mod)
        g_z = np.array([-(wd**2), sig * wd]) / mod**3
        fn_std[r] = np.sqrt(max(float(g_f @ c @ g_f), 0.0))
        z_std[r] = np.sqrt(max(float(g_z @ c @ g_z), 0.0))
    if not (np.all(np.isfinite(fn_std[free])) and np.all(np.isfinite(z_std[free]))):
        return _fallback(model, noise, "non-finite standard deviation", n_iter, chi2, chi2_red, warns)
    warns += _edge_misfit(np.abs(e.model - y) ** 2 / var, freq)
    fn0, fn1 = np.abs(lam0) / (2 * np.pi), np.abs(lam) / (2 * np.pi)
    moved = free & (np.abs(fn1 - fn0) > np.maximum(-lam0.real / (4 * np.pi), 4 * np.nan_to_num(fn_std)))
    for r in np.flatnonzero(moved).tolist():
        warns.append(
            f"mode {r + 1} moved from {fn0[r]:.6g} to {fn1[r]:.6g} Hz in the refinement "
            "(more than half its half-power half-bandwidth)"
        )
    x = e.x
    residues = (x[:, :nm] + 1j * x[:, nm : 2 * nm]).T.reshape(nm, cut.n_out, cut.n_in)
    if residuals:
        lower = x[:, 2 * nm].reshape(cut.n_out, cut.n_in).astype(np.complex128)
        upper = x[:, 2 * nm + 1].reshape(cut.n_out, cut.n_in).astype(np.complex128)
    else:
        lower = upper = np.zeros((cut.n_out, cut.n_in), np.complex128)
    num = np.linalg.norm(e.model - y, axis=1)
    den = np.linalg.norm(y, axis=1)
    fit_error = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0).reshape(cut.n_out, cut.n_in)
    meta = dict(model.meta)
    meta.update(
        {
            "method": "ml-refinement",
            "polymax_poles": [[float(p.real), float(p.imag)] for p in lam0],
            "refined": [bool(v) for v in free],
            "noise_source": source,
            "chi2_red": chi2_red,
            "residuals": bool(residuals),
        }
    )
    refined = replace(
        model,
        poles=lam,
        residues=residues,
        lower_residual=lower,
        upper_residual=upper,
        band=fband,
        fit_error=fit_error,
        meta=meta,
    )
    return Refinement(
        model=refined,
        natural_freq_std=fn_std,
        damping_ratio_std=z_std,
        pole_cov=pole_cov,
        residue_std=res_std,
        noise=noise,
        converged=True,
        reason=str(sol.message),
        cost=chi2,
        chi2_red=chi2_red,
        n_iter=n_iter,
        initial=model,
        refined=free.copy(),
        warnings=tuple(warns),
    )


def _edge_misfit(z: NDArray[np.float64], freq: NDArray[np.float64]) -> list[str]:
    """Warnings when the fit is poor next to a band edge (a mode just outside the band).

    ``z`` is ``|residual|^2 / variance`` of every line (n_chan, n_freq), 1 on average for a model
    that fits to the noise. Residual terms stand for far-away modes only; a mode just outside
    the band leaves a misfit near that edge and biases the nearest modes by more than their
    (noise-only) standard deviations.
    """
    n = freq.size
    k = max(5, n // 20)
    out = []
    for name, sl in (("lower", slice(0, k)), ("upper", slice(n - k, n))):
        chi = float(np.mean(z[:, sl]))
        if chi > 3.0:
            where = f"({freq[sl][0]:.6g}..{freq[sl][-1]:.6g} Hz: residual {chi:.3g} times the noise)"
            if name == "lower" and n > 1 and freq[0] <= 2 * (freq[1] - freq[0]):
                # the band starts at the first lines above 0 Hz: nothing lies below it to move away from
                out.append(
                    f"the model misses the data at the start of the band, next to 0 Hz {where}: content no mode "
                    "represents (modes too lightly damped or too close for the line spacing, a DC offset, drift "
                    "or a sensor's high-pass); the modes nearest it may be biased beyond their standard "
                    "deviations: start the band above it"
                )
                continue
            out.append(
                f"the model misses the data near the {name} band edge {where}, probably a mode just outside the "
                "band; the modes nearest that edge may be biased beyond their standard deviations: move the edge "
                "away from it"
            )
    return out


def _fit(
    prob: _Problem, y: NDArray[np.complex128], given_var: NDArray[np.float64] | None,
    coh: NDArray[np.float64] | None, n_avg: float | None, noise_rounds: int, max_nfev: int,
) -> tuple[Any, _Value, NDArray[np.float64], str, int, NDArray[np.float64]]:
    """Noise rounds of weighted fits: (scipy result, value, variance, source, evaluations, J^T J)."""
    theta = prob.theta0()
    n_iter = 0
    # start values of the weights, from the unweighted LSFD at the PolyMAX poles
    e = prob.value(theta)
    resid2, model2 = np.abs(e.model - y) ** 2, np.abs(e.model) ** 2
    if given_var is not None:
        source, var, rounds = "given", given_var, 1
    elif coh is not None:
        source = "coherence" if n_avg is not None else "coherence-scaled"
        var = _coherence_var(coh, model2, n_avg, resid2, None)
        rounds = 2
    else:
        source = "estimated"
        var = fit_noise_model(resid2, model2)[2]
        rounds = max(1, noise_rounds)
    sol: Any = None
    for k in range(rounds):
        prob.set_variance(var)
        final = k == rounds - 1
        if prob.free.size == 0:
            break
        sol, e = _gn_solve(prob, theta, max_nfev, final)
        n_iter += int(sol.nfev)
        theta = sol.x
        if final:
            break
        # re-estimate the weights from the new model (and the leverage of its lines)
        resid2, model2 = np.abs(e.model - y) ** 2, np.abs(e.model) ** 2
        if source == "coherence":
            var = _coherence_var(coh, model2, n_avg, resid2, None)  # type: ignore[arg-type]
            continue
        cov = inv_psd(prob.gauss_newton(e)[0])
        lev = None if cov is None else prob.second_order(e, cov)[0]
        if source == "estimated":
            var = fit_noise_model(resid2, model2, lev)[2]
        else:  # coherence-scaled
            var = _coherence_var(coh, model2, None, resid2, lev)  # type: ignore[arg-type]
    return sol, e, var, source, n_iter, prob.gauss_newton(e, exact=True)[0]


def _bad_modes(
    lam: NDArray[np.complex128], lam0: NDArray[np.complex128], free: NDArray[np.intp], band: tuple[float, float],
    df: float, singular_hess: NDArray[np.float64] | None,
) -> dict[int, tuple[float, str]]:
    """Refined modes that cannot be accepted: severity and reason (empty when all are fine).

    A mode may move by its PolyMAX half-power half-bandwidth, or two line spacings ``df`` when
    that is larger; further means it left for another feature of the data.
    """
    fn, fn0 = np.abs(lam) / (2 * np.pi), np.abs(lam0) / (2 * np.pi)
    hbw0 = np.maximum(-lam0.real / (2 * np.pi), 2 * df)  # allowed move [Hz]
    bad: dict[int, tuple[float, str]] = {}
    inf = float("inf")
    for r in free.tolist():
        if not np.isfinite(lam[r]):
            bad[r] = (inf, "the refined pole is not finite")
        elif lam[r].real >= 0:
            bad[r] = (inf, f"the refinement made it unstable (to {fn[r]:.6g} Hz, damping ratio <= 0)")
        elif not band[0] <= fn[r] <= band[1]:
            bad[r] = (inf, f"the refinement moved it out of the band {band[0]:g}..{band[1]:g} Hz (to {fn[r]:.6g} Hz)")
        elif abs(fn[r] - fn0[r]) > hbw0[r]:
            bad[r] = (abs(fn[r] - fn0[r]) / hbw0[r],
                      f"the refinement moved it to {fn[r]:.6g} Hz, further than its half-power "
                      f"half-bandwidth or two lines ({hbw0[r]:.3g} Hz): not the same mode")
    if not bad:
        order = np.argsort(fn, kind="stable")
        if np.any(order != np.arange(fn.size)) or np.any(np.diff(fn[order]) <= 0):
            # the free mode that moved most (in half-bandwidths) is the one that jumped
            mv = np.abs(fn - fn0) / np.maximum(hbw0, 1e-300)
            r = int(free[np.argmax(mv[free])])
            bad[r] = (1.0, f"the refinement moved it to {fn[r]:.6g} Hz, past a neighbouring mode")
    if not bad and singular_hess is not None:
        d = np.sqrt(np.abs(np.diag(singular_hess)))
        d = np.where(d > 0, d, 1.0)
        vals, vecs = np.linalg.eigh(singular_hess / np.outer(d, d))
        weight = vecs[:, 0] ** 2
        r = int(free[np.argmax(weight[0::2] + weight[1::2])])
        bad[r] = (1.0, "its pole is not identifiable from these data (singular Fisher information)")
    return bad


def _coherence_var(
    coh: NDArray[np.float64], model_abs2: NDArray[np.float64], n_avg: float | None, resid_abs2: NDArray[np.float64],
    leverage: NDArray[np.float64] | None,
) -> NDArray[np.float64]:
    """Line variances from coherence; without ``n_avg`` the level is the ML scale of the residual."""
    # n_d - 1: the exact mean of the H1 error for random excitation (Bendat & Piersol, table 9.6;
    # the first-order formula with n_d is low by n_d / (n_d - 1))
    shape = coherence_variance(model_abs2, coh, max(n_avg - 1.0, 1.0) if n_avg else 1.0)
    finite = np.isfinite(shape) & (shape > 0)
    floor = 1e-12 * (np.max(shape[finite]) if np.any(finite) else 1.0)
    shape = np.where(np.isfinite(shape), np.maximum(shape, floor), 1e30 * floor)
    if n_avg is not None:
        return shape
    z = resid_abs2
    if leverage is not None:
        z = z / (1.0 - np.clip(leverage, 0.0, 0.95))
    kappa = float(np.mean(z[finite] / shape[finite])) if np.any(finite) else 1.0
    return shape * max(kappa, 1e-300)


def inv_psd(h: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """Inverse of a symmetric positive definite matrix (scaled Cholesky), None when singular."""
    d = np.sqrt(np.abs(np.diag(h)))
    if not np.all(d > 0) or not np.all(np.isfinite(h)):
        return None
    hs = h / np.outer(d, d)
    try:
        c = np.linalg.cholesky(hs)
    except np.linalg.LinAlgError:
        return None
    if np.min(np.abs(np.diag(c))) ** 2 < 1e-13:
        return None
    ci = np.linalg.inv(c)
    return cast("NDArray[np.float64] | None", (ci.T @ ci) / np.outer(d, d))


__all__ = ["Refinement", "refine"]
