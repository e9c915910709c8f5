"""The modal model: poles, residues, residual terms and derived mode shapes.

Functions
---------
pole_residue_basis
    The real pole-residue basis (with residual terms) that LSFD, the judgement and the
    completeness test fit the FRFs with: one definition of the modal kernel.

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
            wd = self.poles.imag
            a = col[:, p] * 2j * wd  # = phi_p^2
            with np.errstate(divide="ignore", invalid="ignore"):
                phi_p = np.sqrt(a)
                scale = 2j * wd / phi_p
            return col * scale[:, None]
        peak = np.max(np.abs(col), axis=1, keepdims=True)
        with np.errstate(divide="ignore", invalid="ignore"):
            return col / np.where(peak > 0, peak, 1.0)

    def modal_mass(self, dof: DOF | str) -> NDArray[np.float64]:
        """Effective modal mass at a driving point [kg], shape (n_modes,).

        ``m_eff,r = 1 / |phi_r[p]|^2 = 1 / (2 w_d,r |R_r[p, p]|)``: the mass of a single-DOF
        oscillator that gives the same resonance peak at the driving point ``dof`` (which must
        be both a response and a reference DOF).
        """
        d = as_dof(dof)
        if d not in self.out_dofs or d not in self.in_dofs:
            raise KeyError(f"{d} is not a driving point (needs to be a response and a reference DOF)")
        p, q = self.out_dofs.index(d), self.in_dofs.index(d)
        with np.errstate(divide="ignore"):
            return 1.0 / (2.0 * self.poles.imag * np.abs(self.residues[:, p, q]))

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
        jw = 1j * 2 * np.pi * f
        lam = self.poles[:, None]
        basis = 1.0 / (jw[None, :] - lam)  # (n_modes, n_freq)
        basis_c = 1.0 / (jw[None, :] - lam.conj())
        h = np.einsum("rij,rk->ijk", self.residues, basis) + np.einsum(
            "rij,rk->ijk", self.residues.conj(), basis_c
        )
        p = _FORM_POWER[form]
        fac = np.ones_like(jw)
        for _ in range(p):
            fac = fac * jw
        h = h * fac
        if residuals:
            # LR (j w)^(p-2): finite at 0 Hz for accelerance (p = 2), a true pole there otherwise
            with np.errstate(divide="ignore", invalid="ignore"):
                lr = np.ones_like(jw) if p == 2 else fac / (jw * jw)
                lr_term = self.lower_residual[:, :, None] * lr  # inf x residual at 0 Hz: not a number
            lr_term = np.where(self.lower_residual[:, :, None] == 0, 0.0, lr_term)
            h = h + lr_term + self.upper_residual[:, :, None] * fac
        return FRFData(f, h, self.out_dofs, self.in_dofs, frf_form=form, roles=self.roles, axes=self.axes)

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


def pole_residue_basis(
    f: NDArray[np.float64], lam: NDArray[np.complex128], p: int, *, residuals: bool = True
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

    Returns
    -------
    a : ndarray, shape (2 n_freq, n_unknown)
        Rows (Re, Im) interleaved per line, as a complex FRF row viewed as float64; columns
        ``Re R_r`` (n_modes), ``Im R_r`` (n_modes), then ``LR``, ``UR``; each of unit norm.
    scale : ndarray, shape (n_unknown,)
        Column norms (1 for an all-zero column): unknowns of ``a`` divided by ``scale`` are
        the physical ones.
    """
    jw = 2j * np.pi * f
    with np.errstate(divide="ignore", invalid="ignore"):
        fac = jw**p
        pos = 1.0 / (jw[:, None] - lam[None, :])
        neg = 1.0 / (jw[:, None] - lam.conj()[None, :])
        cols: list[NDArray[Any]] = [fac[:, None] * (pos + neg), fac[:, None] * (1j * pos - 1j * neg)]
        if residuals:
            lr = jw ** (p - 2) if p >= 2 else 1.0 / jw ** (2 - p)
            cols += [lr[:, None], fac[:, None]]
    basis = np.concatenate(cols, axis=1)  # (n_freq, n_unknown) complex
    n_f, n_unk = basis.shape
    a = basis.view(np.float64).reshape(n_f, n_unk, 2).transpose(0, 2, 1).reshape(2 * n_f, n_unk)
    scale = np.sqrt(np.einsum("kj,kj->j", a, a))
    scale = np.where(scale > 0, scale, 1.0)
    return a / scale, scale


__all__ = ["ModalModel", "pole_residue_basis"]
