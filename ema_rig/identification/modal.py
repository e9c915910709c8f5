"""The modal model and the one modal kernel: pole-residue columns, synthesis, modal mass, participation.

Functions
---------
pole_columns
    ``(j w)^p / (j w - lambda)^k`` and its conjugate-pole partner, optionally averaged over the
    spectral window an averaged FRF estimate is smoothed with: the pole terms (``k = 1``) and
    their derivatives w.r.t. the pole (``k = 2``) of every fit (LSFD, judgement, completeness,
    local ML, refinement, the rig's driving-point mass).
residual_columns
    The lower- and upper-residual columns ``(j w)^(p-2)`` and ``(j w)^p``.
modal_basis
    The complex basis of the modal model (``Re R_r``, ``Im R_r`` columns, residual terms).
pole_residue_basis
    The same basis, real, with unit-norm columns, as LSFD, the judgement and the completeness
    test solve it.
synthesize_frf
    FRFs of poles, residues and residual terms (what :meth:`ModalModel.synthesize` returns).
shape_products
    ``phi_p phi_q = 2 j w_d R_pq`` of every mode and channel: the participation of a mode in a
    channel [1/kg] (mass-normalised shapes).
effective_mass
    Effective modal mass ``1 / |phi_p|^2`` at a driving point from its residue and pole [kg].

Classes
-------
ModalModel
    Frozen result of LSFD (:func:`ema_rig.identification.lsfd.lsfd`): everything needed to synthesise
    FRFs, compare shapes and scale modes.

Notes
-----
Convention (receptance form, ``w = 2 pi f`` rad/s)::

    H_rec(w) = sum_r [ R_r / (j w - lambda_r) + conj(R_r) / (j w - conj(lambda_r)) ]
               + LR / (j w)^2 + UR

and ``H_form(w) = (j w)^p H_rec(w)`` with p = 0, 1, 2 for receptance, mobility, accelerance.
``LR`` (lower residual, 1/kg) stands for modes below the band, ``UR`` (upper residual, m/N) for
modes above it. For a viscously damped, proportionally damped structure
``R_r = phi_r phi_r^T / (2 j w_d,r)`` with ``phi_r`` mass-normalised and ``w_d,r = Im(lambda_r)``.

*Spectral window.* An FRF estimated by averaging windowed segments (Welch, H1) is, for a flat force
spectrum, the true FRF smoothed by the power spectral window of the time window:
``E[H1](w) = integral K(nu) H(w - nu) dnu`` (Schmidt 1985; Bendat & Piersol, *Random Data*, 4th ed.
2010, sect. 8.5). This is a physical difference, not a numerical one: near a lightly damped peak the
smoothed FRF is lower and wider than the FRF (leakage), so a model fitted without it reports too
much damping. :func:`pole_columns` takes the window as a quadrature ``(nu, weights)``
(:func:`ema_rig.identification.ml.window_kernel`): every column, the factor ``(j w)^p`` included, is
then the weighted sum of its values at ``w - nu_m``. Without a window (``None``) the columns are the
FRF's own; a one-node window at 0 gives the same numbers.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..dof import DOF, as_dof
from ..frf import FORM_POWER as _FORM_POWER
from ..frf import FRFData
from ..literals import FrfForm


@dataclass(frozen=True, slots=True, eq=False)
class ModalModel:
    """Identified modes of a measurement.

    Parameters
    ----------
    poles : ndarray, shape (n_modes,), complex
        Poles ``lambda_r`` in rad/s with ``Im > 0``, sorted by natural frequency.
    residues : ndarray, shape (n_modes, n_out, n_in), complex
        Receptance residues ``R_r`` [m/N * rad/s].
    lower_residual : ndarray, shape (n_out, n_in), complex
        ``LR`` [1/kg], coefficient of ``1/(j w)^2`` in the receptance.
    upper_residual : ndarray, shape (n_out, n_in), complex
        ``UR`` [m/N], constant receptance term.
    out_dofs, in_dofs : tuple of DOF
        Response and reference DOFs (sign-corrected).
    roles, axes : tuple of str or None, length n_out
        Sensor role and axis of each output (from the rig file).
    frf_form : str
        Form of the data the model was fitted to (used by :meth:`synthesize` by default).
    band : tuple of float
        Frequency band (Hz) of the fit.
    fit_error : ndarray, shape (n_out, n_in)
        Relative fit error per channel, ``||H_meas - H_syn|| / ||H_meas||`` over the band.
    meta : mapping
        Provenance (orders, selection, ...).
    """

    poles: NDArray[np.complex128]
    residues: NDArray[np.complex128]
    lower_residual: NDArray[np.complex128]
    upper_residual: NDArray[np.complex128]
    out_dofs: tuple[DOF, ...]
    in_dofs: tuple[DOF, ...]
    roles: tuple[str | None, ...] = ()
    axes: tuple[str | None, ...] = ()
    frf_form: FrfForm = "accelerance"
    band: tuple[float, float] = (0.0, np.inf)
    fit_error: NDArray[np.float64] | None = None
    meta: Mapping[str, Any] = field(default_factory=dict)

    def __repr__(self) -> str:
        f = ", ".join(f"{v:.4g}" for v in self.natural_freq[:12])
        more = ", ..." if self.n_modes > 12 else ""
        return (f"ModalModel({self.n_modes} modes at [{f}{more}] Hz, {len(self.out_dofs)} outputs x "
                f"{len(self.in_dofs)} references, {self.frf_form})")

    def __post_init__(self) -> None:
        poles = np.atleast_1d(np.asarray(self.poles, dtype=np.complex128)).copy()
        res = np.asarray(self.residues, dtype=np.complex128).copy()
        n_out, n_in = len(self.out_dofs), len(self.in_dofs)
        if res.shape != (poles.size, n_out, n_in):
            raise ValueError(
                f"residues must have shape (n_modes, n_out, n_in) = {(poles.size, n_out, n_in)}, got {res.shape}"
            )
        for name in ("lower_residual", "upper_residual"):
            arr = np.asarray(getattr(self, name), dtype=np.complex128).copy()
            if arr.shape != (n_out, n_in):
                raise ValueError(f"{name} must have shape (n_out, n_in) = {(n_out, n_in)}, got {arr.shape}")
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        poles.setflags(write=False)
        res.setflags(write=False)
        object.__setattr__(self, "poles", poles)
        object.__setattr__(self, "residues", res)
        object.__setattr__(self, "out_dofs", tuple(as_dof(d) for d in self.out_dofs))
        object.__setattr__(self, "in_dofs", tuple(as_dof(d) for d in self.in_dofs))
        object.__setattr__(self, "roles", tuple(self.roles) if self.roles else (None,) * n_out)
        object.__setattr__(self, "axes", tuple(self.axes) if self.axes else (None,) * n_out)
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))

    @property
    def n_modes(self) -> int:
        """Number of modes."""
        return int(self.poles.size)

    @property
    def natural_freq(self) -> NDArray[np.float64]:
        """Undamped natural frequencies ``|lambda| / 2 pi`` [Hz], shape (n_modes,)."""
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """Damping ratios ``-Re(lambda) / |lambda|`` [-], shape (n_modes,)."""
        return -self.poles.real / np.abs(self.poles)

    def _ref_index(self, reference: DOF | str | None) -> int:
        if reference is None:
            return 0
        d = as_dof(reference)
        if d not in self.in_dofs:
            raise KeyError(f"reference {d} not in model ({[str(x) for x in self.in_dofs]})")
        return self.in_dofs.index(d)

    def mode_shapes(self, reference: DOF | str | None = None) -> NDArray[np.complex128]:
        """Mode shapes, mass-normalised where the reference has a driving point.

        Parameters
        ----------
        reference : DOF or str, optional
            Reference whose residue column gives the shapes (default: the first).

        Returns
        -------
        ndarray, shape (n_modes, n_out), complex
            ``phi_r`` such that ``R_r[:, q] = phi_r * phi_r[q] / (2 j w_d)``. When the reference
            DOF is not also an output, the shapes are the residue columns scaled to unit
            maximum modulus (not mass-normalised).
        """
        q = self._ref_index(reference)
        col = self.residues[:, :, q]  # (n_modes, n_out)
        ref = self.in_dofs[q]
        if ref in self.out_dofs:
            p = self.out_dofs.index(ref)
            a = shape_products(self.poles, col[:, p])  # = phi_p^2
            with np.errstate(divide="ignore", invalid="ignore"):
                return shape_products(self.poles, col) / np.sqrt(a)[:, None]
        peak = np.max(np.abs(col), axis=1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            return col / np.where(peak > 0, peak, 1.0)

    def modal_mass(self, dof: DOF | str) -> NDArray[np.float64]:
        """Effective modal mass at a driving point [kg], shape (n_modes,).

        ``m_eff,r = 1 / |phi_r[p]|^2 = 1 / (2 w_d,r |R_r[p, p]|)`` (:func:`effective_mass`): the
        mass of a single-DOF oscillator that gives the same resonance peak at the driving point
        ``dof`` (which must be both a response and a reference DOF).
        """
        d = as_dof(dof)
        if d not in self.out_dofs or d not in self.in_dofs:
            raise KeyError(f"{d} is not a driving point (needs to be a response and a reference DOF)")
        p, q = self.out_dofs.index(d), self.in_dofs.index(d)
        return effective_mass(self.poles, self.residues[:, p, q])

    def synthesize(self, freq: NDArray[np.float64], *, frf_form: FrfForm | None = None,
                   residuals: bool = True) -> FRFData:
        """Synthesise FRFs from the modal model.

        Parameters
        ----------
        freq : array_like, shape (n_freq,)
            Frequencies in Hz.
        frf_form : str, optional
            Output form (default: the form the model was fitted to).
        residuals : bool, optional
            Include the lower and upper residual terms (default True).

        Returns
        -------
        FRFData
        """
        form = frf_form or self.frf_form
        f = np.asarray(freq, dtype=np.float64)
        h = synthesize_frf(f, self.poles, self.residues, self.lower_residual if residuals else None,
                           self.upper_residual if residuals else None, _FORM_POWER[form])
        return FRFData(f, h, self.out_dofs, self.in_dofs, frf_form=form, roles=self.roles, axes=self.axes)

    def line_error(self, data: FRFData) -> NDArray[np.float64]:
        """Median over the band's lines of the relative error ``|H - H_syn| / |H|``, per channel.

        Unlike :attr:`fit_error` (a norm over the band, set by its largest peak), every line
        counts alike: a misfit between the peaks cannot hide behind a well-fitted resonance.

        Parameters
        ----------
        data : FRFData
            Measured FRFs holding the model's DOFs (any form; converted to the model's).

        Returns
        -------
        ndarray, shape (n_out, n_in)
            Dimensionless; NaN where the band has no line with a finite, non-zero FRF.
        """
        lo, hi = float(self.band[0]), float(self.band[1])
        meas = data.sel(out=list(self.out_dofs), inp=list(self.in_dofs)).to_form(self.frf_form)
        keep = (meas.freq >= lo) & (meas.freq <= hi) if np.isfinite(lo) and np.isfinite(hi) else np.ones(meas.freq.size, bool)
        m = meas.frf[:, :, keep]
        syn = self.synthesize(meas.freq[keep]).frf
        with np.errstate(divide="ignore", invalid="ignore"):
            rel = np.abs(m - syn) / np.abs(m)
        rel = np.where(np.isfinite(rel), rel, np.nan)
        out = np.full(m.shape[:2], np.nan)
        for i, j in np.ndindex(*out.shape):
            if np.any(np.isfinite(rel[i, j])):
                out[i, j] = float(np.nanmedian(rel[i, j]))
        return out

    def to_records(self) -> list[dict[str, Any]]:
        """One dict per mode: ``natural_freq`` (Hz), ``damping_ratio``, ``pole`` (re, im)."""
        return [
            {
                "natural_freq": float(fn),
                "damping_ratio": float(z),
                "pole_real": float(p.real),
                "pole_imag": float(p.imag),
            }
            for fn, z, p in zip(self.natural_freq, self.damping_ratio, self.poles, strict=True)
        ]


#: A spectral window as a quadrature: offsets ``nu`` [rad/s] and weights (sum 1), each shape (n_nodes,).
SpectralWindow = tuple[NDArray[np.float64], NDArray[np.float64]]


def _inverse_powers(jw: NDArray[np.complex128], lam: NDArray[np.complex128], order: int
                    ) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """``1 / (jw - lam)^order`` and ``1 / (jw - conj(lam))^order``, shape (n_freq, n_poles)."""
    pos = 1.0 / (jw[:, None] - lam[None, :])
    neg = 1.0 / (jw[:, None] - lam.conj()[None, :])
    if order != 1:
        pos, neg = pos**order, neg**order
    return pos, neg


def pole_columns(
    jw: NDArray[np.complex128],
    lam: NDArray[np.complex128],
    power: int,
    *,
    order: int = 1,
    window: SpectralWindow | None = None,
) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """The pole terms of the modal model: ``(j w)^p / (j w - lambda)^k`` and ``(j w)^p / (j w - conj(lambda))^k``.

    ``k = 1`` gives the columns a residue multiplies; ``k = 2`` their derivative w.r.t. the pole
    (``d/d lambda [1 / (j w - lambda)] = 1 / (j w - lambda)^2``), which the ML estimates iterate with.

    Parameters
    ----------
    jw : ndarray, shape (n_freq,), complex
        ``j w`` of the lines [rad/s].
    lam : ndarray, shape (n_poles,), complex
        Poles [rad/s], one of each conjugate pair.
    power : int
        Form power ``p`` of the data (0 receptance, 1 mobility, 2 accelerance).
    order : int, optional
        Power ``k`` of the pole factor (1, default; 2 for the derivative).
    window : (ndarray, ndarray) or None, optional
        Spectral window quadrature ``(nu [rad/s], weights)`` (see the module notes): the columns
        are ``sum_m weights_m f(w - nu_m)``; None for the FRF's own columns.

    Returns
    -------
    pos, neg : ndarray, shape (n_freq, n_poles), complex
        Columns of ``lambda`` and of ``conj(lambda)``.
    """
    if window is None:
        fac = jw**power
        pos, neg = _inverse_powers(jw, lam, order)
        return fac[:, None] * pos, fac[:, None] * neg
    nu, kw = window
    grid = _common_grid(jw, nu)
    if grid is not None:
        return _windowed_on_grid(jw, lam, power, order, kw, *grid)
    jwn = jw[:, None] - 1j * nu[None, :]  # (n_freq, n_nodes)
    facn = (jwn**power) * kw[None, :]
    pos = np.einsum("in,inr->ir", facn, 1.0 / (jwn[:, :, None] - lam) ** order)
    neg = np.einsum("in,inr->ir", facn, 1.0 / (jwn[:, :, None] - lam.conj()) ** order)
    return pos, neg


#: Relative tolerance of :func:`_common_grid`: line spacings and node offsets on one grid to this.
_GRID_RTOL = 1e-9


def _common_grid(jw: NDArray[np.complex128], nu: NDArray[np.float64]) -> tuple[int, NDArray[np.intp]] | None:
    """``(q, k)`` when every ``w_i - nu_m`` lies on one grid of step ``dw / q`` (``dw`` the uniform line
    step, node ``m`` at ``k_m`` fine steps: ``nu_m = k_m dw / q``, ``k`` consecutive), else None.

    A spectral window's quadrature on a grid of ``1/q`` line steps
    (:func:`~ema_rig.identification.ml.window_kernel`: ``q = 8``) over uniformly spaced lines has
    ``q (n_freq - 1) + n_nodes`` distinct points instead of ``n_freq n_nodes``.
    """
    n = jw.size
    if n < 2 or nu.size < 2:
        return None
    w = jw.imag
    dw = (w[-1] - w[0]) / (n - 1)
    if not dw > 0 or np.any(np.abs(np.diff(w) - dw) > _GRID_RTOL * dw):
        return None
    step = (nu[1] - nu[0]) / dw  # consecutive nodes: 1 / q line steps apart
    if not step > 0:
        return None
    q = int(round(1.0 / step))
    if q < 1 or abs(q * step - 1.0) > _GRID_RTOL:
        return None
    k = nu * (q / dw)
    kk = np.round(k).astype(np.intp)
    if (np.all(np.abs(k - kk) <= _GRID_RTOL * max(float(np.max(np.abs(k))), 1.0))
            and np.array_equal(kk, np.arange(kk[0], kk[0] + kk.size))):
        return q, kk
    return None


def _windowed_on_grid(jw: NDArray[np.complex128], lam: NDArray[np.complex128], power: int, order: int,
                      kw: NDArray[np.float64], q: int, k: NDArray[np.intp]
                      ) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """The window-averaged columns of :func:`pole_columns` on the common grid of :func:`_common_grid`.

    Line ``i`` minus node ``m`` is fine point ``q i - k_m``: the column is a correlation of the weights
    with the values on the fine grid, taken at every ``q``-th point (the same sums, formed once per point).
    """
    n = jw.size
    w0, dw = jw[0].imag, (jw[-1].imag - jw[0].imag) / (n - 1)
    k0, k1 = int(k[0]), int(k[-1])
    # fine points j = q i - k_m, from -k1 (i = 0, last node) to q (n - 1) - k0
    xf = 1j * (w0 + np.arange(-k1, q * (n - 1) - k0 + 1) * (dw / q))
    fac = xf**power
    out = []
    for pole in (lam, lam.conj()):
        g = fac[:, None] * (1.0 / (xf[:, None] - pole[None, :]) ** order)  # (n_fine, n_poles)
        gv = g.view(np.float64).reshape(g.shape[0], -1)  # (n_fine, 2 n_poles): Re, Im interleaved
        # window of line i: fine points q i - k1 .. q i - k0, i.e. offsets 0 .. k1 - k0 from q i - k1
        win = np.lib.stride_tricks.sliding_window_view(gv, k1 - k0 + 1, axis=0)[::q]  # (n, 2 n_poles, n_nodes)
        col = np.einsum("irl,l->ir", win, kw[::-1])  # node m at offset k1 - k_m
        out.append(np.ascontiguousarray(col).view(np.complex128))
    return out[0], out[1]


def residual_columns(jw: NDArray[np.complex128], power: int) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
    """Lower- and upper-residual columns ``(j w)^(p-2)`` and ``(j w)^p``.

    Parameters
    ----------
    jw : ndarray, shape (n_freq,), complex
        ``j w`` of the lines [rad/s].
    power : int
        Form power ``p`` of the data (0 receptance, 1 mobility, 2 accelerance).

    Returns
    -------
    lower, upper : ndarray, shape (n_freq,), complex
        The lower one is infinite at 0 Hz unless ``p = 2`` (a true pole of the receptance there).
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        lr = jw ** (power - 2) if power >= 2 else 1.0 / jw ** (2 - power)
    return lr, jw**power


def modal_basis(
    jw: NDArray[np.complex128],
    lam: NDArray[np.complex128],
    power: int,
    *,
    residuals: bool = True,
    window: SpectralWindow | None = None,
) -> NDArray[np.complex128]:
    """The complex basis of the modal model, one column per real unknown.

    Column ``r`` is ``P_r + N_r`` (the real part of ``R_r`` multiplies it), column ``n_poles + r``
    ``j (P_r - N_r)`` (its imaginary part), with ``(P_r, N_r)`` of :func:`pole_columns`; then the
    lower- and upper-residual columns of :func:`residual_columns` (real unknowns).

    Parameters
    ----------
    jw : ndarray, shape (n_freq,), complex
        ``j w`` [rad/s].
    lam : ndarray, shape (n_poles,), complex
        Poles [rad/s], ``Im > 0``, in the column order wanted.
    power : int
        Form power of the data.
    residuals : bool, optional
        Append the two residual columns (default True).
    window : (ndarray, ndarray) or None, optional
        Spectral window quadrature (:func:`pole_columns`); the residual columns are the FRF's own.

    Returns
    -------
    ndarray, shape (n_freq, 2 n_poles [+ 2]), complex
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        if window is None:
            # (j w)^p factored out of the pair: the same columns, one rounding fewer
            fac = (jw**power)[:, None]
            pos, neg = _inverse_powers(jw, lam, 1)
            cols: list[NDArray[Any]] = [fac * (pos + neg), fac * (1j * pos - 1j * neg)]
        else:
            pos, neg = pole_columns(jw, lam, power, window=window)
            cols = [pos + neg, 1j * (pos - neg)]
        if residuals:
            lr, ur = residual_columns(jw, power)
            cols += [lr[:, None], ur[:, None]]
    return np.concatenate(cols, axis=1)


def pole_basis_with_derivative(
    jw: NDArray[np.complex128],
    lam: NDArray[np.complex128],
    power: int,
    *,
    window: SpectralWindow | None = None,
) -> tuple[NDArray[np.complex128], NDArray[np.complex128], NDArray[np.complex128]]:
    """:func:`modal_basis` without residual terms and the ``k = 2`` :func:`pole_columns` of the same poles.

    The same numbers as the two calls; without a window the inverse powers are formed once (an
    iterative estimate of the poles needs both at every evaluation).

    Parameters
    ----------
    jw, lam, power, window
        As for :func:`pole_columns`.

    Returns
    -------
    basis : ndarray, shape (n_freq, 2 n_poles), complex
        ``modal_basis(jw, lam, power, residuals=False, window=window)``.
    pos2, neg2 : ndarray, shape (n_freq, n_poles), complex
        ``pole_columns(jw, lam, power, order=2, window=window)``.
    """
    if window is not None:
        pos2, neg2 = pole_columns(jw, lam, power, order=2, window=window)
        return modal_basis(jw, lam, power, residuals=False, window=window), pos2, neg2
    with np.errstate(divide="ignore", invalid="ignore"):
        fac = (jw**power)[:, None]
        pos, neg = _inverse_powers(jw, lam, 1)
        basis = np.concatenate([fac * (pos + neg), fac * (1j * pos - 1j * neg)], axis=1)
        return basis, fac * pos**2, fac * neg**2


def synthesize_frf(
    freq: NDArray[np.float64],
    poles: NDArray[np.complex128],
    residues: NDArray[np.complex128],
    lower_residual: NDArray[np.complex128] | None,
    upper_residual: NDArray[np.complex128] | None,
    power: int,
) -> NDArray[np.complex128]:
    """FRFs of a modal model (the convention of the module notes).

    Parameters
    ----------
    freq : ndarray, shape (n_freq,)
        Lines [Hz].
    poles : ndarray, shape (n_modes,), complex
        Poles [rad/s], ``Im > 0``.
    residues : ndarray, shape (n_modes, n_out, n_in), complex
        Receptance residues [m/N rad/s].
    lower_residual, upper_residual : ndarray, shape (n_out, n_in), or None
        ``LR`` [1/kg] and ``UR`` [m/N]; None leaves the term out.
    power : int
        Form power of the result (0 receptance, 1 mobility, 2 accelerance).

    Returns
    -------
    ndarray, shape (n_out, n_in, n_freq), complex
        SI units of the form. A zero lower residual adds nothing, also at 0 Hz.
    """
    jw = np.asarray(1j * 2 * np.pi * np.asarray(freq, dtype=np.float64), dtype=np.complex128)
    lam = np.asarray(poles, dtype=np.complex128)
    res = np.asarray(residues, dtype=np.complex128)
    pos, neg = _inverse_powers(jw, lam, 1)
    pos, neg = np.ascontiguousarray(pos.T), np.ascontiguousarray(neg.T)  # (n_modes, n_freq)
    h = np.einsum("rij,rk->ijk", res, pos) + np.einsum("rij,rk->ijk", res.conj(), neg)
    lr, fac = residual_columns(jw, power)
    h = h * fac
    if lower_residual is not None:
        low = np.asarray(lower_residual, dtype=np.complex128)[:, :, None]
        with np.errstate(invalid="ignore"):
            lr_term = low * lr  # inf x residual at 0 Hz: not a number
        h = h + np.where(low == 0, 0.0, lr_term)
    if upper_residual is not None:
        h = h + np.asarray(upper_residual, dtype=np.complex128)[:, :, None] * fac
    return np.asarray(h, dtype=np.complex128)


def shape_products(poles: NDArray[np.complex128], residues: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """``phi_p phi_q = 2 j w_d R_pq``: the participation of every mode in every channel [1/kg].

    For mass-normalised shapes of a proportionally damped structure ``R_r = phi_r phi_r^T / (2 j w_d,r)``
    (module notes), so this is the product of the two DOFs' modal amplitudes; its modulus is the
    channel's participation whatever the sign convention of the DOFs.

    Parameters
    ----------
    poles : ndarray, shape (n_modes,), complex
        Poles [rad/s]; ``w_d = |Im lambda|``.
    residues : ndarray, shape (n_modes, ...), complex
        Receptance residues [m/N rad/s] (any trailing channel axes).

    Returns
    -------
    ndarray, same shape as ``residues``, complex
    """
    res = np.asarray(residues, dtype=np.complex128)
    wd = np.abs(np.asarray(poles, dtype=np.complex128).imag).reshape((-1,) + (1,) * (res.ndim - 1))
    return np.asarray(2j * wd * res, dtype=np.complex128)


def effective_mass(poles: NDArray[np.complex128], residues_pp: NDArray[np.complex128]) -> NDArray[np.float64]:
    """Effective modal mass at a driving point, ``1 / |phi_p|^2 = 1 / (2 w_d |R_pp|)`` [kg].

    The mass of a single-DOF oscillator with the same resonance peak at that DOF; the measured
    counterpart of :meth:`~ema_rig.rig.model.RigModel.effective_mass` of the rig model.

    Parameters
    ----------
    poles : ndarray, shape (n_modes,), complex
        Poles [rad/s].
    residues_pp : ndarray, shape (n_modes,), complex
        Driving-point receptance residues [m/N rad/s].

    Returns
    -------
    ndarray, shape (n_modes,)
        inf where the residue is 0.
    """
    with np.errstate(divide="ignore"):
        return np.asarray(1.0 / np.abs(shape_products(poles, residues_pp)), dtype=np.float64)


def pole_residue_basis(
    f: NDArray[np.float64], lam: NDArray[np.complex128], p: int, *, residuals: bool = True,
    pole_columns: NDArray[np.complex128] | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The pole-residue basis of the modal model, real, with unit-norm columns, and the column norms.

    One definition of the kernel shared by LSFD (:func:`~ema_rig.identification.lsfd.lsfd`), the
    judgement of candidates (:func:`~ema_rig.identification.judge.judge_clusters`) and the
    completeness test of :func:`~ema_rig.identification.identification.identify`: column ``r`` of
    the complex basis is ``(j w)^p / (j w - lambda_r) + (j w)^p / (j w - conj(lambda_r))`` (the
    real part of ``R_r``), column ``n_modes + r`` the same with ``j`` and ``-j`` (its imaginary
    part), then ``(j w)^(p-2)`` (lower residual) and ``(j w)^p`` (upper residual).

    Parameters
    ----------
    f : ndarray, shape (n_freq,)
        Lines [Hz] (0 Hz already dropped when the basis is singular there).
    lam : ndarray, shape (n_modes,), complex
        Poles [rad/s], ``Im > 0``, in the column order wanted.
    p : int
        Form power of the data (0 receptance, 1 mobility, 2 accelerance).
    residuals : bool
        Append the lower and upper residual columns.
    pole_columns : ndarray, shape (n_freq, 2 n_modes), complex, optional
        :func:`modal_basis` of ``lam`` on ``f`` without residual columns, when the caller has it (the
        same numbers: its columns are formed elementwise).

    Returns
    -------
    a : ndarray, shape (2 n_freq, n_unknown)
        Rows (Re, Im) interleaved per line, as a complex FRF row viewed as float64; columns
        ``Re R_r`` (n_modes), ``Im R_r`` (n_modes), then ``LR``, ``UR``; each of unit norm.
    scale : ndarray, shape (n_unknown,)
        Column norms (1 for an all-zero column): unknowns of ``a`` divided by ``scale`` are
        the physical ones.
    """
    jw = np.asarray(2j * np.pi * f, dtype=np.complex128)
    if pole_columns is None:
        basis = modal_basis(jw, lam, p, residuals=residuals)  # (n_freq, n_unknown) complex
    elif residuals:
        with np.errstate(divide="ignore", invalid="ignore"):
            lr, ur = residual_columns(jw, p)
        basis = np.concatenate([pole_columns, lr[:, None], ur[:, None]], axis=1)  # modal_basis's concatenation
    else:
        basis = pole_columns
    return unit_real_basis(basis)


def unit_real_basis(basis: NDArray[np.complex128]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The real basis of :func:`pole_residue_basis` from the complex one (:func:`modal_basis`'s columns).

    Parameters
    ----------
    basis : ndarray, shape (n_freq, n_unknown), complex
        Complex columns, one per real unknown (e.g. :func:`modal_basis` on some lines, or its rows and
        columns for a subset of the lines and poles: the same numbers as formed there).

    Returns
    -------
    a : ndarray, shape (2 n_freq, n_unknown)
        Rows (Re, Im) interleaved per line, each column of unit norm.
    scale : ndarray, shape (n_unknown,)
        Column norms (1 for an all-zero column).
    """
    n_f, n_unk = basis.shape
    a = basis.view(np.float64).reshape(n_f, n_unk, 2).transpose(0, 2, 1).reshape(2 * n_f, n_unk)
    scale = np.sqrt(np.einsum("kj,kj->j", a, a))
    scale = np.where(scale > 0, scale, 1.0)
    return a / scale, scale


__all__ = ["ModalModel", "SpectralWindow", "effective_mass", "modal_basis", "pole_basis_with_derivative", "pole_columns",
           "pole_residue_basis", "residual_columns", "shape_products", "synthesize_frf", "unit_real_basis"]
