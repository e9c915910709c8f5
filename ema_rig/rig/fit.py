"""Measured evidence of the housing on its bearing beyond the housing frequency.

Functions
---------
driving_point_mass
    The housing mode's effective modal mass at the radial driving point with its standard
    uncertainty, from a local least-squares fit of the driving-point FRF at the identified poles.
cross_axis_correction
    The uncoupled radial housing frequency when a bearing cross stiffness couples the housing's
    radial motion to its axial or lateral rigid-body motion (two-mode reduction).
housing_rigid_body
    Axial and cross stiffness of the housing on its bearing from the identified modes.
housing_tilt
    Tilt stiffness per axis from the identified tilt modes, the sensors' positions and the
    declared rotary inertia.
centre_mass_factor
    Driving-point to housing-centre modal mass of the housing mode (the housing's tilt in it).
fit_split_housing
    ``k_TB+MS`` and an appendage fitted to the two modes that share the housing's radial motion.
measured_housing_mass
    ``m_H`` from the identified housing frequency and driving-point modal mass through the 3DOF
    model (where the force chain is trusted).
housing_mass_from_ratio
    ``m_H`` from the identified housing frequency and the housing mode's spindle/housing amplitude
    ratio through the 3DOF model: no force chain, only relative accelerometer calibration.

Classes
-------
DrivingPointMass, CrossAxisCorrection, SplitHousingFit
    Frozen results.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from .._blas import single_threaded
from ..config import ModelParams
from ..frf import FORM_POWER as _FORM_POWER
from ..frf import FRFData
from ..identification.modal import effective_mass, modal_basis, shape_products
from ..literals import FrfForm
from .inversion import k_tb_ms_from_housing_freq, model_mode_at
from .matching import MATCH_CRITERIA, CrossAxisCorrection, cross_axis_correction
from .model import mass_matrix, stiffness_matrix

__all__ = [
    "CrossAxisCorrection",
    "DrivingPointMass",
    "HousingMass",
    "NeighbourPairFit",
    "HousingRigidBody",
    "RadialLayout",
    "ShapePhase",
    "SplitHousingFit",
    "TiltStiffness",
    "centre_mass_factor",
    "radial_spread",
    "fit_split_housing",
    "housing_inertia",
    "housing_tilt",
    "radial_layout",
    "spindle_phase",
    "housing_rigid_body",
    "cross_axis_correction",
    "driving_point_mass",
    "fit_housing_pair",
    "housing_mass_from_ratio",
    "measured_housing_mass",
    "RatioHousingMass",
]


@dataclass(frozen=True, slots=True)
class DrivingPointMass:
    """Effective modal mass of one mode at the driving point.

    Attributes
    ----------
    modal_mass, modal_mass_std : float
        ``1 / (2 w_d |R_pp|)`` [kg] and its standard uncertainty from the fit residual [kg].
    n_lines : int
        Spectral lines used.
    n_poles : int
        Identified poles fitted together (the mode and its neighbours).
    pole : complex or None
        The mode's pole [rad/s] re-estimated on the driving point (``free_pole``), else None.
    """

    modal_mass: float
    modal_mass_std: float
    n_lines: int
    n_poles: int
    pole: complex | None = None


def _local_columns(jw: NDArray[np.complex128], w: NDArray[np.float64], lam: NDArray[np.complex128]
                   ) -> NDArray[np.complex128]:
    """Receptance columns of a local modal fit, shape (n_freq, 2 n_poles + 4).

    The modal kernel's columns (:func:`~ema_rig.identification.modal.modal_basis`) interleaved per
    pole (``Re R_r``, ``Im R_r``), then the modes outside the lines: a complex constant and a complex
    ``1 / w^2`` term. ``jw`` = ``1j * w`` [rad/s], ``lam`` the poles [rad/s].
    """
    pc = modal_basis(jw, lam, 0, residuals=False)
    cols = np.empty((jw.size, 2 * lam.size + 4), dtype=complex)
    cols[:, 0 : 2 * lam.size : 2], cols[:, 1 : 2 * lam.size : 2] = pc[:, : lam.size], pc[:, lam.size :]
    cols[:, 2 * lam.size :] = np.stack([np.ones_like(jw), 1j * np.ones_like(jw), 1 / w**2 + 0j, 1j / w**2], axis=1)
    return cols


def _local_band(freq: NDArray[np.float64], frf: NDArray[np.complex128], p: NDArray[np.complex128], index: int,
                frf_form: FrfForm, window: float, pole_window: float
                ) -> tuple[NDArray[np.float64], NDArray[np.complex128], NDArray[np.float64], NDArray[np.float64],
                           list[int]] | None:
    """The local fit's lines around mode ``index`` of one channel: ``(w, jw, wt, y, near)``, or None.

    ``w`` [rad/s] the lines within ``+-window`` of the mode (None below 20 of them), ``wt`` the
    ``1 / |H|`` weights of the receptance there, ``y`` the weighted receptance as (Re, Im) stacked,
    ``near`` the indices of the poles within ``+-pole_window`` (they enter with their own residues).
    Shared by :func:`driving_point_mass` and :func:`_local_residue`.
    """
    f0 = abs(p[index]) / (2 * math.pi)
    sel = (freq > f0 * (1 - window)) & (freq < f0 * (1 + window)) & (freq > 0)
    w = 2 * math.pi * np.asarray(freq, dtype=float)[sel]
    if w.size < 20:
        return None
    jw = 1j * w
    h = np.asarray(frf)[sel] / jw ** _FORM_POWER[frf_form]
    near = [r for r in range(p.size) if abs(abs(p[r]) / (2 * math.pi) / f0 - 1) < pole_window]
    wt = 1.0 / np.maximum(np.abs(h), 1e-300)
    y = np.concatenate([(h * wt).real, (h * wt).imag])
    return w, jw, wt, y, near


def driving_point_mass(
    freq: NDArray[np.float64],
    frf: NDArray[np.complex128],
    poles: NDArray[np.complex128],
    index: int,
    *,
    frf_form: FrfForm = "accelerance",
    window: float = 0.10,
    pole_window: float = 0.40,
    free_pole: bool = False,
) -> DrivingPointMass | None:
    """Effective modal mass of mode ``index`` at the driving point, with its std.

    Fits the driving-point receptance on the lines within ``+-window`` of the mode by the
    identified poles within ``+-pole_window`` (each pole pair ``R / (jw - s) + R* / (jw - s*)`` with a free complex
    residue ``R``) plus a complex constant and a complex ``1 / w^2`` term for the modes outside,
    weighted by ``1 / |H|`` (relative noise). Linear least squares: the residue's covariance is
    ``s^2 (A^T W A)^-1`` with ``s^2`` the weighted residual variance, so the std is measured from
    the data's scatter about the modal model.

    Parameters
    ----------
    freq : ndarray, shape (n_freq,)
        Frequencies [Hz].
    frf : ndarray, shape (n_freq,), complex
        Driving-point FRF in ``frf_form`` (SI).
    poles : ndarray, shape (n_modes,), complex
        Identified poles [rad/s] (upper half plane).
    index : int
        The mode whose mass is wanted.
    frf_form : {'receptance', 'mobility', 'accelerance'}
    window : float
        Relative half-width of the band of lines around the mode.
    pole_window : float
        Identified poles within this relative distance enter the fit with their own residues.
    free_pole : bool
        Also re-estimate the mode's own pole (natural frequency and damping ratio) on these lines
        (the neighbours' stay at their identified poles; variable projection,
        ``scipy.optimize.least_squares``): the residue magnitude and the damping trade against
        each other at the peak, so a damping ratio held at an identified value that is off by its
        own std biases the mass by as much; the joint fit's covariance carries that correlation
        into ``modal_mass_std``.

    Returns
    -------
    DrivingPointMass or None
        None when the band holds too few lines.
    """
    p = np.asarray(poles, dtype=complex).copy()
    band = _local_band(freq, frf, p, index, frf_form, window, pole_window)
    if band is None:
        return None
    w, jw, wt, y, near = band
    k = near.index(index)

    # the free pole: the mode's own (freeing the neighbours' too on one channel is ill-conditioned:
    # close modes trade residues; measured on the issue-19 truths, masses 10 % off)
    free = [index]

    def design(sv: dict[int, complex]) -> NDArray[np.float64]:
        # the modal kernel's receptance columns (Re R_r, Im R_r of each pole), interleaved per pole
        lam = np.array([sv.get(r, p[r]) for r in near], dtype=complex)
        a_mat = _local_columns(jw, w, lam) * wt[:, None]
        return np.concatenate([a_mat.real, a_mat.imag])

    def poles_of(x: NDArray[np.float64]) -> dict[int, complex]:  # x = (ln w_n, damping ratio) per free pole
        out = {}
        for j, r in enumerate(free):
            wn, z = math.exp(float(x[2 * j])), float(x[2 * j + 1])
            out[r] = complex(-z * wn, wn * math.sqrt(max(1.0 - z * z, 0.0)))
        return out

    x0 = np.concatenate([[math.log(abs(p[r])), -p[r].real / abs(p[r])] for r in free])
    n_x = x0.size if free_pole else 0
    if free_pole:
        from scipy.optimize import least_squares

        def vp(x: NDArray[np.float64]) -> NDArray[np.float64]:  # variable projection
            a_real = design(poles_of(x))
            c, *_ = np.linalg.lstsq(a_real, y, rcond=None)
            return y - a_real @ c

        scale = np.concatenate([[1e-3, max(x0[2 * j + 1], 1e-4) * 0.1] for j in range(len(free))])
        sol = least_squares(vp, x0, x_scale=scale, method="lm", xtol=1e-12, ftol=1e-12, max_nfev=400)
        ok = sol.success and bool(np.all((sol.x[1::2] > 0) & (sol.x[1::2] < 0.5)))
        x_hat = sol.x if ok else x0
    else:
        x_hat = x0
    s_hat = poles_of(x_hat)
    a_real = design(s_hat)
    coef, *_ = np.linalg.lstsq(a_real, y, rcond=None)
    resid = y - a_real @ coef
    dof = y.size - coef.size - n_x
    if dof <= 0:
        return None
    s2 = float(resid @ resid) / dof
    # Jacobian of the model in (pole parameters, linear coefficients); covariance s^2 (J^T J)^-1
    jac = a_real
    if free_pole:
        cols_x = []
        for i in range(n_x):
            dx = np.zeros(n_x)
            dx[i] = 1e-7 * (1.0 if i % 2 == 0 else max(x_hat[i], 1e-4))
            cols_x.append((design(poles_of(x_hat + dx)) @ coef - design(poles_of(x_hat - dx)) @ coef) / (2 * dx[i]))
        jac = np.column_stack([*cols_x, a_real])
    cov = s2 * np.linalg.pinv(jac.T @ jac)

    def mass_of(theta: NDArray[np.float64]) -> float:
        re, im = theta[n_x + 2 * k], theta[n_x + 2 * k + 1]
        lam = poles_of(theta[:n_x])[index] if free_pole else p[index]
        return float(effective_mass(np.array([lam]), np.array([complex(re, im)]))[0])

    theta = np.concatenate([x_hat[:n_x], coef])
    if not math.hypot(coef[2 * k], coef[2 * k + 1]) > 0:
        return None
    mass = mass_of(theta)
    grad = np.zeros(theta.size)
    for i in [*range(min(n_x, 2)), n_x + 2 * k, n_x + 2 * k + 1]:
        d = np.zeros(theta.size)
        d[i] = 1e-6 * max(abs(theta[i]), 1e-12)
        grad[i] = (mass_of(theta + d) - mass_of(theta - d)) / (2 * d[i])
    mass_std = math.sqrt(max(float(grad @ cov @ grad), 0.0))
    return DrivingPointMass(modal_mass=mass, modal_mass_std=mass_std, n_lines=int(w.size),
                            n_poles=len(near), pole=s_hat[index] if free_pole else None)


def driving_point_mass_of(data: FRFData, p: int, q: int, poles: NDArray[np.complex128], index: int
                          ) -> DrivingPointMass | None:
    """:func:`driving_point_mass` on ``data.frf[p, q]``."""
    return driving_point_mass(data.freq, data.frf[p, q], poles, index, frf_form=data.frf_form)


def _local_residue(freq: NDArray[np.float64], frf: NDArray[np.complex128], poles: NDArray[np.complex128], index: int,
                   frf_form: FrfForm, window: float = 0.10, pole_window: float = 0.40
                   ) -> tuple[complex, NDArray[np.float64]] | None:
    """Residue of mode ``index`` on one channel and the covariance of its (Re, Im), shape (2, 2).

    The local fit of :func:`driving_point_mass` with every identified pole held (linear least
    squares, weighted by ``1 / |H|``; covariance ``s^2 (A^T W A)^-1``); None on too few lines."""
    p = np.asarray(poles, dtype=complex)
    band = _local_band(freq, frf, p, index, frf_form, window, pole_window)
    if band is None:
        return None
    w, jw, wt, y, near = band
    a_c = _local_columns(jw, w, p[near]) * wt[:, None]
    a_real = np.concatenate([a_c.real, a_c.imag])
    coef, *_ = np.linalg.lstsq(a_real, y, rcond=None)
    dof = y.size - coef.size
    if dof <= 0:
        return None
    resid = y - a_real @ coef
    cov = float(resid @ resid) / dof * np.linalg.pinv(a_real.T @ a_real)
    k = 2 * near.index(index)
    return complex(coef[k], coef[k + 1]), np.asarray(cov[k:k + 2, k:k + 2], dtype=np.float64)


@dataclass(frozen=True, slots=True)
class ShapePhase:
    """Phase of the spindle's radial motion against the driving point's in one mode.

    Attributes
    ----------
    phase : float
        ``arg(mean_s R_s / R_p)`` [rad]: the spindle radial sensors' residues (sign as mounted)
        over the driving point's; 0 or pi for a real (proportionally damped) mode.
    phase_std : float
        Its standard uncertainty from the local fits' residual scatter [rad] (channels independent).
    n_spindle : int
        Spindle radial sensors used.
    """

    phase: float
    phase_std: float
    n_spindle: int


def spindle_phase(data: FRFData, p: int, q: int, spindle: list[int], poles: NDArray[np.complex128], index: int
                  ) -> ShapePhase | None:
    """Phase of the spindle/housing amplitude ratio of mode ``index`` with its std (:class:`ShapePhase`).

    Each channel's residue is fitted locally at the identified poles (:func:`_local_residue`); the
    ratio's phase error is ``Im(dR_s / R_s) - Im(dR_p / R_p)`` to first order.

    Parameters
    ----------
    data : FRFData
    p, q : int
        Driving-point output and input indices.
    spindle : list of int
        Output indices of the spindle's radial sensors.
    poles : ndarray, shape (n_modes,), complex
        Identified poles [rad/s].
    index : int
        The mode.

    Returns
    -------
    ShapePhase or None
        None without spindle sensors or when a channel's fit has too few lines.
    """
    if not spindle:
        return None
    fits = []
    for c in (p, *spindle):
        r = _local_residue(data.freq, data.frf[c, q], poles, index, data.frf_form)
        if r is None:
            return None
        sgn = float(data.out_dofs[c].sign)
        fits.append((sgn * r[0], r[1]))
    r_p, c_p = fits[0]
    r_s = sum(f[0] for f in fits[1:]) / len(spindle)
    c_s = sum(f[1] for f in fits[1:]) / len(spindle) ** 2
    if not (abs(r_p) > 0 and abs(r_s) > 0):
        return None

    def grad(x: complex) -> NDArray[np.float64]:  # d Im(dX / X) / d(Re X, Im X)
        return np.array([-x.imag, x.real]) / abs(x) ** 2

    var = float(grad(r_s) @ c_s @ grad(r_s) + grad(r_p) @ c_p @ grad(r_p))
    return ShapePhase(phase=float(np.angle(r_s / r_p)), phase_std=math.sqrt(max(var, 0.0)), n_spindle=len(spindle))


@dataclass(frozen=True, slots=True)
class HousingMass:
    """The housing's mass measured from its driving-point modal mass, beside the rig file's.

    Attributes
    ----------
    measured, measured_std : float
        ``m_H`` [kg] for which the 3DOF model at the inverted frequency has the measured modal mass
        (:func:`measured_housing_mass`; it includes whatever sits on the housing), and its std
        (fit and force chain) [kg].
    rig_file : float
        The rig file's ``m_H`` with the declared masses [kg].
    used : float or None
        The ``m_H`` the inversion used [kg] when not the rig file's (None: the rig file's).
    used_rel_std : float or None
        Its relative std (None: the rig file's tolerance as stated).
    modal_mass, modal_mass_std : float
        The driving-point modal mass and its std [kg] (local fit with the pole free).
    force_chain : float
        Relative std of the FRF scale applied.
    force_chain_stated : bool
        The rig file states it (``[uncertainty] force_chain``); else the default.
    agrees : bool
        The rig file's ``m_H`` agrees with the data within one sigma of its own tolerance and the
        fit's std (:data:`ema_rig.rig.uncertainty.MASS_AGREE_SIGMAS`).
    source : str
        What the inversion used: ``'rig file'``, ``'combined'`` (rig file and measurement by
        inverse variance, force chain stated, or not stated where the effective mass is more than
        10 % off and the measurement, read twice, is the more precise), ``'rig file, tolerance
        widened'`` (the discrepancy
        is smaller than the measurement's std) or ``'measured'``.
    by_shape, by_shape_std : float or None
        ``m_H`` [kg] from the housing mode's spindle/housing ratio (:func:`housing_mass_from_ratio`,
        no force chain) and its std, when it entered ``measured`` (None: not available or not
        consistent with the modal mass); ``measured`` then combines both.
    """

    measured: float
    measured_std: float
    rig_file: float
    used: float | None
    used_rel_std: float | None
    modal_mass: float
    modal_mass_std: float
    force_chain: float
    force_chain_stated: bool
    agrees: bool
    source: str = "rig file"
    by_shape: float | None = None
    by_shape_std: float | None = None

    def to_dict(self) -> dict[str, object]:
        """Plain dict for JSON (masses in kg)."""
        return {"m_H_measured": self.measured, "m_H_measured_std": self.measured_std, "m_H_rig_file": self.rig_file,
                "m_H_used": self.rig_file if self.used is None else self.used,
                "m_H_used_std": None if self.used_rel_std is None else
                (self.rig_file if self.used is None else self.used) * self.used_rel_std,
                "source": self.source,
                "relative_difference": self.measured / self.rig_file - 1, "agrees_with_rig_file": self.agrees,
                "modal_mass": self.modal_mass, "modal_mass_std": self.modal_mass_std,
                "force_chain": self.force_chain, "force_chain_stated": self.force_chain_stated,
                "m_H_from_shape": self.by_shape, "m_H_from_shape_std": self.by_shape_std}


def measured_housing_mass(f_h: float, modal_mass: float, params: ModelParams) -> float | None:
    """``m_H`` [kg] for which the 3DOF model, inverted at ``f_h``, has the measured driving-point
    effective modal mass (fixed point; the effective mass is nearly proportional to ``m_H``)."""
    m_h = params.m_H
    for _ in range(50):
        info = model_mode_at(replace(params, m_H=m_h), f_h)
        if info is None or not info.modal_mass > 0:
            return None
        new = m_h * modal_mass / info.modal_mass
        if abs(new - m_h) < 1e-10 * m_h:
            return new
        m_h = new
    return m_h



@dataclass(frozen=True, slots=True)
class RatioHousingMass:
    """``m_H`` measured from the housing mode's shape (:func:`housing_mass_from_ratio`).

    Attributes
    ----------
    m_H, rel_std : float
        Housing mass [kg] and its relative standard uncertainty (the ratio's and the other model
        parameters' tolerances, linearised).
    k_TB_MS : float
        The bearing + mounting stiffness [N/m] the same shape gives.
    ratio, ratio_rel_std : float
        The spindle/housing amplitude ratio used and its relative std.
    sensitivity : dict
        ``d ln m_H / d ln x`` for the ratio (``'ratio'``) and every model parameter but ``m_H``.
    """

    m_H: float
    rel_std: float
    k_TB_MS: float
    ratio: float
    ratio_rel_std: float
    sensitivity: dict[str, float]


def _mass_from_ratio(f_h: float, ratio: float, params: ModelParams) -> tuple[float, float]:
    """``(m_H, k_TB+MS)`` of the 3DOF model whose housing mode at ``f_h`` has ``x_S / x_H = ratio``.

    The eigenvector ``(1, r, x_F)`` at ``lam = (2 pi f_h)^2``: the frame row gives ``x_F``, the
    spindle row ``k_TB+MS`` and the housing row ``m_H`` (closed form, no ``m_H`` on the way)."""
    lam = (2 * math.pi * f_h) ** 2
    p = params
    x_f = (p.k_AS + p.k_S * ratio) / (p.k_B + p.k_AS + p.k_S - lam * p.m_F)
    k_c = ((p.k_S - lam * p.m_S) * ratio - p.k_S * x_f) / (1.0 - ratio)
    return (p.k_AS * (1.0 - x_f) + k_c * (1.0 - ratio)) / lam, k_c


def housing_mass_from_ratio(f_h: float, ratio: float, params: ModelParams, rel_unc: dict[str, float],
                            ratio_rel_std: float) -> RatioHousingMass | None:
    """``m_H`` from the housing frequency and the spindle/housing amplitude ratio of its mode.

    In the 3DOF model the housing mode's shape ``x_S / x_H`` at a given frequency depends on
    ``k_TB+MS``, ``k_S``, ``m_S`` and the frame, not on ``m_H``; with the frequency it fixes both
    ``k_TB+MS`` and ``m_H`` (:func:`_mass_from_ratio`). Unlike the driving-point modal mass this
    needs no force chain, only the accelerometers' relative calibration, but it leans on the rig
    file's ``k_S`` (``d ln m_H / d ln k_S ~ 1.1`` at 626 Hz on Table 1), so the two measurements
    of ``m_H`` have independent errors of similar size.

    Parameters
    ----------
    f_h : float
        Undamped housing frequency [Hz].
    ratio : float
        Signed spindle/housing amplitude ratio of the housing mode (``0 < ratio < 1``).
    params : ModelParams
        Rig parameters (``m_H`` and ``k_MS`` are not used).
    rel_unc : dict
        Relative standard uncertainty per model parameter (missing: 0).
    ratio_rel_std : float
        Relative standard uncertainty of the ratio.

    Returns
    -------
    RatioHousingMass or None
        None outside ``0 < ratio < 1`` or when the model gives no positive mass or stiffness.
    """
    if not (0.0 < ratio < 1.0 and f_h > 0):
        return None
    m_h, k_c = _mass_from_ratio(f_h, ratio, params)
    if not (m_h > 0 and k_c > 0 and math.isfinite(m_h)):
        return None
    h = 1e-5
    sens = {"ratio": (math.log(_mass_from_ratio(f_h, ratio * (1 + h), params)[0])
                      - math.log(_mass_from_ratio(f_h, ratio * (1 - h), params)[0])) / (2 * h)}
    for name in ("m_S", "m_F", "k_AS", "k_S", "k_B"):
        v = getattr(params, name)
        hi = _mass_from_ratio(f_h, ratio, replace(params, **{name: v * (1 + h)}))[0]
        lo = _mass_from_ratio(f_h, ratio, replace(params, **{name: v * (1 - h)}))[0]
        if not (hi > 0 and lo > 0):
            return None
        sens[name] = (math.log(hi) - math.log(lo)) / (2 * h)
    var = (sens["ratio"] * ratio_rel_std) ** 2 + sum(
        (sens[n] * float(rel_unc.get(n, 0.0))) ** 2 for n in sens if n != "ratio")
    return RatioHousingMass(m_H=float(m_h), rel_std=math.sqrt(var), k_TB_MS=float(k_c), ratio=float(ratio),
                            ratio_rel_std=float(ratio_rel_std), sensitivity=sens)


@dataclass(frozen=True, slots=True)
class SplitHousingFit:
    """The housing with an appendage (a load arm, a flexible part) fitted to two measured modes.

    Attributes
    ----------
    k_TB_MS, k_TB_MS_std : float
        Combined bearing + mounting stiffness and its standard uncertainty [N/m].
    appendage_mass, appendage_mass_std : float
        Mass of the part on its own spring [kg] (out of ``m_H``).
    appendage_freq : float
        Its natural frequency on that spring alone [Hz].
    force_chain_scale : float
        Fitted scale of the measured modal masses (1 = the force chain as calibrated).
    chi2 : float
        Sum of squared normalised residuals (1 degree of freedom).
    force_chain_scale_std : float
        Relative std of the scale from the two modal masses alone (the prior removed; ``inf``
        when they do not inform it): how well the masses test the rig file's ``m_H``.
    """

    k_TB_MS: float
    k_TB_MS_std: float
    appendage_mass: float
    appendage_mass_std: float
    appendage_freq: float
    force_chain_scale: float
    chi2: float
    force_chain_scale_std: float = math.inf


def _split_modes(params: ModelParams, k_c: float, m_a: float, k_a: float) -> tuple[NDArray[np.float64],
                                                                                    NDArray[np.float64]]:
    """Natural frequencies [Hz] and driving-point effective masses [kg] of the 4DOF housing model."""
    import scipy.linalg

    m = np.zeros((4, 4))
    k = np.zeros((4, 4))
    m[:3, :3] = mass_matrix(replace(params, m_H=params.m_H - m_a))
    k[:3, :3] = stiffness_matrix(params, k_c)
    m[3, 3] = m_a
    k[0, 0] += k_a
    k[3, 3] += k_a
    k[0, 3] = k[3, 0] = -k_a
    lam, vec = scipy.linalg.eigh(k, m)
    with np.errstate(divide="ignore"):
        return np.sqrt(np.clip(lam, 0, None)) / (2 * math.pi), 1.0 / vec[0] ** 2


def fit_split_housing(params: ModelParams, freqs: tuple[float, float], freq_std: tuple[float, float],
                      masses: tuple[float, float], mass_std: tuple[float, float], force_chain: float
                      ) -> SplitHousingFit | None:
    """Fit ``k_TB+MS`` and an appendage (mass ``m_a`` out of ``m_H`` on a spring ``k_a``) to two modes.

    The 3DOF model with the housing split into its main body and an appendage has two modes
    where the housing moves radially; their frequencies and driving-point effective masses (four
    data) fix ``k_TB+MS``, ``m_a``, ``k_a`` and a common scale of the measured masses (the force
    chain, with its prior ``N(1, force_chain^2)``). Weighted least squares on log residuals
    (``scipy.optimize.least_squares``); the covariance is ``(J^T J)^-1`` at the solution (the
    residuals are normalised), so ``k_TB_MS_std`` carries the frequency and mass stds and the
    force chain. ``m_H`` and the other parameters are fixed here (their tolerances enter the
    k_TB budget through the equivalent frequency).

    Parameters
    ----------
    params : ModelParams
    freqs, freq_std : (float, float)
        Undamped frequencies of the two modes and their stds [Hz] (housing mode first).
    masses, mass_std : (float, float)
        Their driving-point effective masses and stds [kg].
    force_chain : float
        Relative std of the FRF scale.

    Returns
    -------
    SplitHousingFit or None
        None when the fit does not converge to two modes near the measured ones.
    """
    from scipy.optimize import least_squares

    f = np.asarray(freqs, dtype=float)
    fs = np.maximum(np.asarray(freq_std, dtype=float), 1e-6 * f)
    mm = np.asarray(masses, dtype=float)
    ms = np.asarray(mass_std, dtype=float)

    def model(x: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        if not np.all(np.abs(x[:3]) < 50.0):  # exp would leave the physical range (and overflow)
            raise ValueError("parameters out of range")
        k_c, m_a, k_a = np.exp(x[:3])
        if not m_a < 0.5 * params.m_H:
            raise ValueError("appendage heavier than half the housing")
        fr, me = _split_modes(params, float(k_c), float(m_a), float(k_a))
        idx = [int(np.argmin(np.abs(np.log(fr / fi)))) for fi in f]
        return fr[idx], me[idx]

    def resid(x: NDArray[np.float64]) -> NDArray[np.float64]:
        try:
            fr, me = model(x)
        except (ValueError, np.linalg.LinAlgError, FloatingPointError):
            return np.full(5, 1e3)
        scale = math.exp(min(max(float(x[3]), -5.0), 5.0))
        return np.concatenate([np.log(fr / f) * f / fs, np.log(me * scale / mm) * mm / ms,
                               [x[3] / max(force_chain, 1e-6)]])

    try:
        k0 = k_tb_ms_from_housing_freq(float(np.sqrt(f[0] * f[1])), params)
    except Exception:  # noqa: BLE001 - outside the 3DOF range: no start
        return None
    best = None
    for frac in (0.01, 0.03, 0.08):
        m_a0 = frac * params.m_H
        x0 = np.log([k0, m_a0, m_a0 * (2 * math.pi * f[1]) ** 2, 1.0])
        x0[3] = 0.0
        with np.errstate(all="ignore"):
            sol = least_squares(resid, x0, method="lm", xtol=1e-12, ftol=1e-12, max_nfev=400)
        if best is None or sol.cost < best.cost:
            best = sol
    if best is None or not best.success:
        return None
    chi2 = float(2 * best.cost)
    try:
        cov = np.linalg.inv(best.jac.T @ best.jac)
    except np.linalg.LinAlgError:
        return None
    k_c, m_a, k_a = np.exp(best.x[:3])
    fr, _ = model(best.x)
    if np.any(np.abs(np.log(fr / f)) > 0.05):
        return None
    # posterior precision of ln(scale) = the masses' + the prior's: remove the prior's
    prec_data = 1.0 / max(float(cov[3, 3]), 1e-300) - 1.0 / max(force_chain, 1e-6) ** 2
    scale_std = 1.0 / math.sqrt(prec_data) if prec_data > 0 else math.inf
    return SplitHousingFit(
        k_TB_MS=float(k_c), k_TB_MS_std=float(k_c * math.sqrt(max(cov[0, 0], 0.0))),
        appendage_mass=float(m_a), appendage_mass_std=float(m_a * math.sqrt(max(cov[1, 1], 0.0))),
        appendage_freq=float(math.sqrt(k_a / m_a) / (2 * math.pi)), force_chain_scale=float(math.exp(best.x[3])),
        chi2=chi2, force_chain_scale_std=scale_std,
    )


@dataclass(frozen=True, slots=True)
class HousingRigidBody:
    """The housing's other rigid-body stiffnesses on its bearing, where the sensors see them.

    Attributes
    ----------
    axial_stiffness, axial_stiffness_std : float or None
        ``m_x (2 pi f_ax)^2`` [N/m] of the housing's axial mode (uncoupled from a corrected
        radial-axial cross coupling) and its std; None when no axial mode is identified.
    axial_freq : float or None
        The axial mode's (uncoupled) frequency [Hz].
    cross_stiffness, cross_stiffness_std : float or None
        Magnitude of the radial-axial or radial-lateral cross stiffness [N/m] from a corrected
        coupling (two-mode reduction), and its std; None without one.
    cross_axis : str or None
        ``'axial'`` or ``'lateral'``.
    reasons : tuple of str
        Why a stiffness is not reported (tilt: no rotary inertia in the rig file, sensors on one
        line, or the tilt modes below the band).
    tilt : tuple of TiltStiffness
        The tilt stiffness about each axis identified (:func:`housing_tilt`).
    """

    axial_stiffness: float | None
    axial_stiffness_std: float | None
    axial_freq: float | None
    cross_stiffness: float | None
    cross_stiffness_std: float | None
    cross_axis: str | None
    reasons: tuple[str, ...] = ()
    tilt: tuple[TiltStiffness, ...] = ()

    def tilt_about(self, axis: str) -> TiltStiffness | None:
        """The tilt stiffness about ``'x'`` or ``'z'``, or None when not identified."""
        return next((t for t in self.tilt if t.axis == axis), None)

    def to_dict(self) -> dict[str, object]:
        """Plain dict for JSON (``tilt_stiffness``: None, or per axis ``'x'``/``'z'`` a dict or None)."""
        tilt = None if not self.tilt else {ax: (None if (t := self.tilt_about(ax)) is None else t.to_dict())
                                           for ax in ("x", "z")}
        return {"axial_stiffness": self.axial_stiffness, "axial_stiffness_std": self.axial_stiffness_std,
                "axial_freq": self.axial_freq, "cross_stiffness": self.cross_stiffness,
                "cross_stiffness_std": self.cross_stiffness_std, "cross_axis": self.cross_axis,
                "tilt_stiffness": tilt, "unidentifiable": list(self.reasons)}


AXIAL_MODE_RATIO = 3.0
"""A mode whose axial housing motion is at least this many times its mean radial housing motion is
the housing's axial rigid-body mode (the radial shaker excites it through misalignment only)."""


def housing_rigid_body(candidates: list[Any], m_x: float, m_x_rel_std: float, m_eff: float,
                       cross: CrossAxisCorrection | None, housing_freq: float, *,
                       tilt: tuple[dict[str, TiltStiffness], list[str]] | None = None) -> HousingRigidBody:
    """Axial and cross stiffness of the housing on its bearing from the identified modes.

    The axial stiffness is ``m_x w_ax^2`` of the mode that moves the housing's axial sensors
    most (at least :data:`AXIAL_MODE_RATIO` times its radial motion, highest participation); with
    a corrected radial-axial coupling that mode is the partner and its uncoupled eigenvalue
    ``sin^2(t) w_1^2 + cos^2(t) w_2^2`` is used. The cross stiffness of a corrected coupling is the
    off-diagonal term of the two-mode reduction, ``sin t cos t |w_2^2 - w_1^2| sqrt(m_eff m_x)``.
    Stds: identified frequency std and the ``m_x`` tolerance; the coupling's mixing std.

    Parameters
    ----------
    candidates : list of Candidate
        Every identified mode with its shape metrics (:attr:`MatchResult.candidates`).
    m_x : float
        The housing's mass in axial translation [kg] (effective ``m_H``).
    m_x_rel_std : float
        Its relative standard uncertainty.
    m_eff : float
        Model effective modal mass of the radial housing mode [kg].
    cross : CrossAxisCorrection or None
        The corrected coupling, if any.
    housing_freq : float
        Identified housing frequency [Hz].
    tilt : (dict, list of str), optional
        :func:`housing_tilt`'s result (None: tilt not attempted, the reason says why).

    Returns
    -------
    HousingRigidBody
    """
    reasons = (["tilt stiffness: the rig file gives no rotary inertia of the housing and the tilt modes lie "
                "below the identification band"] if tilt is None else list(tilt[1]))
    ax = [c for c in candidates if getattr(c, "axial_ratio", None) is not None
          and c.axial_ratio >= AXIAL_MODE_RATIO and abs(c.natural_freq - housing_freq) > 1e-9]
    k_ax = k_ax_std = f_ax = None
    if cross is not None and cross.axis == "axial":
        t2 = cross.mixing
        w1, w2 = (2 * math.pi * housing_freq) ** 2, (2 * math.pi * cross.partner_freq) ** 2
        lam = (t2 * w1 + w2) / (1 + t2)
        f_ax = math.sqrt(lam) / (2 * math.pi)
        part = next((c for c in ax if abs(c.natural_freq - cross.partner_freq) < 1e-9), None)
        sf = (part.natural_freq_std if part is not None and part.natural_freq_std else 0.0) / cross.partner_freq
        k_ax = m_x * lam
        k_ax_std = k_ax * math.hypot(2 * sf, m_x_rel_std, 2 * cross.rel_std)
    elif ax:
        best = max(ax, key=lambda c: c.participation or 0.0)
        f_ax = best.natural_freq
        sf = (best.natural_freq_std or 0.0) / f_ax
        k_ax = m_x * (2 * math.pi * f_ax) ** 2
        k_ax_std = k_ax * math.hypot(2 * sf, m_x_rel_std)
    else:
        reasons.append("axial stiffness: no mode moves the housing's axial sensors most (no axial sensor, or "
                       "the axial mode lies outside the band)")
    k_x = k_x_std = None
    if cross is not None:
        t2 = cross.mixing
        w1, w2 = (2 * math.pi * housing_freq) ** 2, (2 * math.pi * cross.partner_freq) ** 2
        # sin t cos t = sqrt(t2) / (1 + t2) with t2 = tan^2 t
        k_x = math.sqrt(t2) / (1 + t2) * abs(w2 - w1) * math.sqrt(m_eff * m_x)
        # the mixing's std: from the frequency correction's relative std through d f_u / d t2
        d = abs(w2 - w1) / (1 + t2) ** 2 / (2 * (2 * math.pi * cross.uncoupled_freq) ** 2)
        u_t2 = cross.rel_std / d if d > 0 else 0.0
        k_x_std = k_x * math.hypot(u_t2 / (2 * t2) if t2 > 0 else 0.0, m_x_rel_std / 2)
    else:
        reasons.append("cross stiffness: no radial-axial or radial-lateral coupling beyond sensor misalignment")
    return HousingRigidBody(axial_stiffness=k_ax, axial_stiffness_std=k_ax_std, axial_freq=f_ax,
                            cross_stiffness=k_x, cross_stiffness_std=k_x_std,
                            cross_axis=None if cross is None else cross.axis, reasons=tuple(reasons),
                            tilt=() if tilt is None else tuple(tilt[0][ax] for ax in ("x", "z") if ax in tilt[0]))


TILT_MIN_SHARE = 0.5
"""A mode is the housing's tilt about an axis when that tilt holds more than half of the housing's
rigid-body kinetic energy seen by its radial sensors (translation and both tilts): the axis it
moves most, by definition."""

TILT_INERTIA_RATIO = 3.0
"""A tilt mode's modal rotary inertia (measured from its rigid-body shape and driving-point residue)
must lie within this factor of the declared one. On the issue-19 tilt truths (40 runs, 80 tilt
modes) the tilt modes give 0.80-1.36 times the declared inertia (the driving point's 2 deg
misalignment reads the housing's lateral motion in a tilt), while the ovalisation and flexible
housing modes read as 'tilts' of 6-70 times it: the factor sits near their geometric middle."""

TILT_MIN_SPREAD = 0.1
"""The radial housing sensors' (x, z) offsets must span a plane: the smaller singular value of the
centred offsets at least this fraction of the larger. Below, a reading error of
:data:`ema_rig.rig.uncertainty.CROSS_AXIS_RATIO_STD` (3.5 %) moves the tilt ratio by more than 35 %:
the sensors see one combination of the two tilts."""


@dataclass(frozen=True, slots=True)
class RadialLayout:
    """The radial housing sensors with declared positions, as a rigid-body observation.

    Attributes
    ----------
    outputs : tuple of int
        Their indices in the modal model's outputs.
    matrix : ndarray, shape (n_sensors, 3)
        Reading per rigid-body coordinate ``(y_H, th_X, th_Z)``: ``[1, -z, x]`` [1, m, m].
    driving_point : ndarray, shape (3,) or None
        The same row for the radial driving point (None: its position is not declared).
    spans_plane : bool
        The sensors' (x, z) offsets span a plane (:data:`TILT_MIN_SPREAD`): both tilts are seen.
        Otherwise they lie on one line and see one combination of the tilts (the reading of a
        point on that line, e.g. the centre when the line passes through it, is still estimable).
    """

    outputs: tuple[int, ...]
    matrix: NDArray[np.float64]
    driving_point: NDArray[np.float64] | None
    spans_plane: bool = True


def _row(pos: tuple[float, float, float]) -> NDArray[np.float64]:
    """Radial (y) reading of a point on the rigid housing per ``(y_H, th_X, th_Z)``: ``y + x th_Z - z th_X``."""
    return np.array([1.0, -pos[2], pos[0]])


def radial_layout(out_dofs: Any, rig: Any) -> tuple[RadialLayout | None, str]:
    """The rigid-body observation of the radial housing sensors, or None with the reason.

    Parameters
    ----------
    out_dofs : sequence of DOF
        Output DOFs of the modal model.
    rig : RigConfig
        Sensor roles, axes and positions; the radial reference.

    Returns
    -------
    (RadialLayout or None, str)
        None when fewer than three radial housing sensors have a position; the reason when they
        do not see both tilts (``spans_plane`` False) or cannot be used at all, else ``''``.
    """
    idx, rows = [], []
    for i, d in enumerate(out_dofs):
        s = rig.sensor_for(d)
        if s is not None and s.role == "housing" and s.axis == "radial" and s.position is not None:
            idx.append(i)
            rows.append(_row(s.position))
    if len(idx) < 3:
        return None, (f"{len(idx)} radial housing sensor(s) with a declared position (3 needed: [[sensor]] "
                      "position)")
    a = np.array(rows)
    off = a[:, 1:] - a[:, 1:].mean(axis=0)
    sv = np.linalg.svd(off, compute_uv=False)
    plane = bool(sv[0] > 0 and sv[1] >= TILT_MIN_SPREAD * sv[0])
    dp = rig.sensor_for(rig.radial)
    lay = RadialLayout(tuple(idx), a, None if dp is None or dp.position is None else _row(dp.position), plane)
    return lay, "" if plane else ("the radial housing sensors lie on one line: they see one combination of the "
                                  "two tilts")


@dataclass(frozen=True, slots=True)
class TiltStiffness:
    """The housing's tilt stiffness about one axis from its tilt mode.

    Attributes
    ----------
    axis : str
        ``'x'`` (axial axis) or ``'z'`` (lateral axis).
    stiffness, stiffness_std : float
        ``I (2 pi f)^2`` [N m/rad] and its standard uncertainty (measured and assumed).
    stiffness_std_measured : float
        The part from the identified frequency alone [N m/rad].
    freq, freq_std : float
        The tilt mode's natural frequency and its std [Hz].
    inertia, inertia_std : float
        The rotary inertia used [kg m^2]: the rig file's ``[housing]`` value plus ``m r^2`` of the
        attached masses with a position, and its std.
    modal_inertia : float
        The mode's rotary inertia measured from its shape and driving-point residue [kg m^2] (a check).
    share : float
        The tilt's share of the housing's rigid-body kinetic energy in the mode.
    """

    axis: str
    stiffness: float
    stiffness_std: float
    stiffness_std_measured: float
    freq: float
    freq_std: float
    inertia: float
    inertia_std: float
    modal_inertia: float
    share: float

    def to_dict(self) -> dict[str, object]:
        """Plain dict for JSON (N m/rad, Hz, kg m^2)."""
        return {"stiffness": self.stiffness, "stiffness_std": self.stiffness_std,
                "stiffness_std_measured": self.stiffness_std_measured, "freq": self.freq, "freq_std": self.freq_std,
                "inertia": self.inertia, "inertia_std": self.inertia_std, "modal_inertia": self.modal_inertia,
                "share": self.share}


def housing_inertia(rig: Any, axis: str) -> tuple[float, float] | None:
    """Rotary inertia of the housing with its attached masses about ``axis`` (``'x'`` or ``'z'``).

    The rig file's ``[housing]`` inertia plus ``m r_perp^2`` of every mass on the housing with a
    position (``r_perp^2 = y^2 + z^2`` about x, ``x^2 + y^2`` about z); stds in quadrature.

    Parameters
    ----------
    rig : RigConfig
        ``[housing]`` inertia and the attached masses.
    axis : {'x', 'z'}
        The tilt axis.

    Returns
    -------
    (float, float) or None
        ``(inertia, std)`` [kg m^2]; None when the rig file states no inertia about ``axis``.
    """
    ri = getattr(rig, "rotary_inertia", None)
    base = None if ri is None else ri.about(axis)
    if base is None:
        return None
    i0, var = base[0], base[1] ** 2
    for a in getattr(rig, "added_masses", ()):
        if a.body != "housing" or a.position is None:
            continue
        x, y, z = a.position
        r2 = y * y + z * z if axis == "x" else x * x + y * y
        i0 += a.mass * r2
        var += (a.mass_std * r2) ** 2
    return i0, math.sqrt(var)


def _rigid_shape(modes: Any, r: int, q: int, lay: RadialLayout) -> NDArray[np.complex128]:
    """``(y_H, th_X, th_Z)`` of mode ``r`` times the reference's modal amplitude (least squares)."""
    # phi_p phi_q (the modal kernel's shape products): only moduli and relative phases are used
    col = shape_products(modes.poles[r:r + 1], modes.residues[r:r + 1, list(lay.outputs), q])[0]
    g, *_ = np.linalg.lstsq(lay.matrix.astype(complex), col, rcond=None)
    return cast("NDArray[np.complex128]", g)


def housing_tilt(modes: Any, rig: Any, candidates: list[Any], housing_index: int, m_h: float
                 ) -> tuple[dict[str, TiltStiffness], list[str]]:
    """Tilt stiffness of the housing per axis from its identified tilt modes.

    Each identified mode's radial housing residues (driving-point reference) are fitted by the
    housing's rigid-body motion ``(y_H, th_X, th_Z)`` at the sensors' declared positions. The tilt
    mode about an axis is the mode whose tilt holds most of the kinetic energy
    ``m_H |y|^2 + I_x |th_X|^2 + I_z |th_Z|^2`` (at least :data:`TILT_MIN_SHARE`) and whose modal
    inertia ``phi_q^2 / th^2`` (from the same fit at the driving point) lies within
    :data:`TILT_INERTIA_RATIO` of the declared one; its stiffness is ``I (2 pi f_n)^2`` with
    ``I`` from :func:`housing_inertia`. Std: the identified frequency (measured) and the inertia's
    tolerance (assumed).

    Parameters
    ----------
    modes : ModalModel
        Identified modes (residues for the radial reference).
    rig : RigConfig
        Sensor positions, the radial reference, ``[housing]`` inertia, attached masses.
    candidates : list of Candidate
        The same modes' candidates (frequency and its std; ``source == 'modes'``).
    housing_index : int
        The radial housing mode (never a tilt mode).
    m_h : float
        Housing mass with its attached masses [kg].

    Returns
    -------
    (dict, list of str)
        ``{'x': TiltStiffness, 'z': ...}`` for the axes identified, and the reasons for the others.
    """
    out: dict[str, TiltStiffness] = {}
    inertia = {ax: housing_inertia(rig, ax) for ax in ("x", "z")}
    lay, why = radial_layout(modes.out_dofs, rig)
    missing = [ax for ax in ("x", "z") if inertia[ax] is None]
    reasons: list[str] = []
    if lay is None or lay.driving_point is None or not lay.spans_plane:
        why = why or "the radial driving point has no declared position"
        return out, [f"tilt stiffness: {why}"]
    if missing:
        reasons.append(f"tilt stiffness about {' and '.join(missing)}: the rig file gives no rotary inertia of the "
                       f"housing ([housing] inertia_{missing[0]})")
    q = next((j for j, d in enumerate(modes.in_dofs) if d.same_axis(rig.radial)), None)
    if q is None:
        return out, [*reasons, "tilt stiffness: no radial reference among the identified modes"]
    best: dict[str, tuple[float, TiltStiffness]] = {}
    for c in candidates:
        if c.index == housing_index or not c.natural_freq > 0:
            continue
        g = _rigid_shape(modes, c.index, q, lay)
        phi_q2 = abs(complex(lay.driving_point @ g))
        ins = {ax: (inertia[ax] or (0.0, 0.0))[0] for ax in ("x", "z")}
        e = np.array([m_h * abs(g[0]) ** 2, ins["x"] * abs(g[1]) ** 2, ins["z"] * abs(g[2]) ** 2])
        if not e.sum() > 0 or not phi_q2 > 0:
            continue
        for j, ax in ((1, "x"), (2, "z")):
            inert = inertia[ax]
            share = float(e[j] / e.sum())
            if inert is None or share < TILT_MIN_SHARE:
                continue
            i_modal = phi_q2 / abs(g[j]) ** 2
            if abs(math.log(i_modal / inert[0])) > math.log(TILT_INERTIA_RATIO):
                continue
            f = float(c.natural_freq)
            sf = float(c.natural_freq_std) if c.natural_freq_std is not None and math.isfinite(c.natural_freq_std) \
                else 0.0
            k = inert[0] * (2 * math.pi * f) ** 2
            u_meas = 2 * sf / f
            u_tot = math.hypot(u_meas, inert[1] / inert[0])
            t = TiltStiffness(axis=ax, stiffness=k, stiffness_std=k * u_tot, stiffness_std_measured=k * u_meas,
                              freq=f, freq_std=sf, inertia=inert[0], inertia_std=inert[1], modal_inertia=float(i_modal),
                              share=share)
            if ax not in best or share > best[ax][0]:
                best[ax] = (share, t)
    for ax in ("x", "z"):
        if ax in best:
            out[ax] = best[ax][1]
        elif ax not in missing:
            reasons.append(
                f"tilt stiffness about {ax}: no identified mode tilts the housing about {ax} (over "
                f"{100 * TILT_MIN_SHARE:.0f} % of its rigid-body motion) with a modal inertia within x/"
                f"{TILT_INERTIA_RATIO:g} of the declared one (the tilt mode outside the band?)")
    return out, reasons


def centre_mass_factor(modes: Any, rig: Any, index: int, rel_std: float) -> tuple[float, float] | None:
    """``(phi_dp / phi_centre)^2`` of mode ``index`` and its relative std, from the radial sensors.

    The 3DOF model's housing is a point at the housing's centre; a driving point off the centre
    also reads the housing's tilt in the mode (off-centre attached masses tilt it), so the
    driving-point modal mass ``1 / phi_dp^2`` is not the centre's ``1 / phi_c^2``. The rigid-body
    fit of the radial housing residues (:func:`radial_layout`) gives ``phi_c / phi_dp``.

    Parameters
    ----------
    modes : ModalModel
        Identified modes.
    rig : RigConfig
        Sensor positions and the radial reference.
    index : int
        The housing mode.
    rel_std : float
        Relative standard uncertainty of each radial residue [-] (propagated linearly).

    Returns
    -------
    (float, float) or None
        The factor that turns the driving-point modal mass into the centre's, and its relative std;
        None without three positioned radial housing sensors and the driving point's position,
        or when the centre's or the driving point's reading is not estimable from them (sensors
        on one line that misses the centre).
    """
    lay, _ = radial_layout(modes.out_dofs, rig)
    q = next((j for j, d in enumerate(modes.in_dofs) if d.same_axis(rig.radial)), None)
    if lay is None or lay.driving_point is None or q is None:
        return None
    # sensors on one line: the rigid motion is rank 2, and a reading is estimable only on that line
    pinv = np.linalg.pinv(lay.matrix, rcond=1e-9)
    proj = pinv @ lay.matrix
    centre = np.array([1.0, 0.0, 0.0])
    for row in (centre, lay.driving_point):
        if np.linalg.norm(row - row @ proj) > 1e-6 * np.linalg.norm(row):
            return None
    # phi_p phi_q (the modal kernel's shape products): only moduli and relative phases are used
    col = shape_products(modes.poles[index:index + 1], modes.residues[index:index + 1, list(lay.outputs), q])[0]
    ref = col[int(np.argmax(np.abs(col)))]
    r = np.real(col * np.conj(ref) / abs(ref))
    g = pinv @ r
    dp = float(lay.driving_point @ g)
    if not (g[0] > 0 and dp > 0) and not (g[0] < 0 and dp < 0):
        return None
    ratio = dp / float(g[0])
    # d ratio / d r_i = (a_dp . P_i) / y - dp P_0i / y^2
    grad = (lay.driving_point @ pinv) / g[0] - dp * pinv[0] / g[0] ** 2
    u = float(np.sqrt(np.sum((grad * rel_std * np.abs(r)) ** 2))) / abs(ratio)
    return ratio**2, 2 * u


def radial_spread(modes: Any, rig: Any, index: int) -> float | None:
    """Relative spread ``(max - min) / mean`` of the radial housing sensors' readings of mode ``index``.

    The readings are the radial housing residues for the radial reference, projected on the
    largest one's phase. For a rigid radial translation they agree (to the sensors' misalignment
    and calibration); a housing that tilts in the mode reads differently at each sensor.

    Parameters
    ----------
    modes : ModalModel
        Identified modes.
    rig : RigConfig
        Sensor roles and axes, the radial reference.
    index : int
        The mode.

    Returns
    -------
    float or None
        None with fewer than two radial housing sensors or without the radial reference.
    """
    idx = [i for i, d in enumerate(modes.out_dofs)
           if (s := rig.sensor_for(d)) is not None and s.role == "housing" and s.axis == "radial"]
    q = next((j for j, d in enumerate(modes.in_dofs) if d.same_axis(rig.radial)), None)
    if len(idx) < 2 or q is None:
        return None
    col = np.asarray(modes.residues[index, idx, q], dtype=complex)
    ref = col[int(np.argmax(np.abs(col)))]
    r = np.real(col * np.conj(ref) / abs(ref))
    mean = float(np.mean(r))
    return float((np.max(r) - np.min(r)) / abs(mean)) if mean != 0 else None



@dataclass(frozen=True, slots=True)
class NeighbourPairFit:
    """The housing mode fitted on every channel jointly with the close modes the model does not hold.

    Attributes
    ----------
    modal_mass, modal_mass_std : float
        The housing mode's driving-point effective modal mass ``1 / (2 w_d |R_pp|)`` [kg] and its
        standard uncertainty from the joint fit's Fisher information (every free pole and every
        residue: the trade between the pair is in it) [kg].
    pole : complex
        The housing mode's pole re-estimated by the joint fit [rad/s].
    neighbour_poles : tuple of complex
        The neighbours' poles re-estimated by the same fit [rad/s].
    neighbour_masses : tuple of float
        Their driving-point effective modal masses [kg].
    correlation : float
        Largest ``|rho|`` between the housing mode's driving-point modal mass and a neighbour's
        (joint covariance): how strongly the data trade one for the other (information; the
        marginal ``modal_mass_std`` already carries it).
    chi2_dof : float
        Weighted residual ``chi2 / dof`` (1 with the per-channel noise level estimated from it).
    n_lines, n_channels, n_free : int
        Spectral lines, channels and free poles of the fit.
    resolved : bool
        The fit measures the housing mode's modal mass beside its neighbours:
        ``modal_mass_std / modal_mass <= MatchCriteria.pair_max_mass_std``.
    """

    modal_mass: float
    modal_mass_std: float
    pole: complex
    neighbour_poles: tuple[complex, ...]
    neighbour_masses: tuple[float, ...]
    correlation: float
    chi2_dof: float
    n_lines: int
    n_channels: int
    n_free: int
    resolved: bool


def fit_housing_pair(
    freq: NDArray[np.float64],
    frf: NDArray[np.complex128],
    poles: NDArray[np.complex128],
    index: int,
    neighbours: tuple[int, ...] | list[int],
    driving_point: int,
    *,
    frf_form: FrfForm = "accelerance",
    window: float = 0.30,
    criteria: Any = None,
) -> NeighbourPairFit | None:
    """Fit the housing mode and its close neighbours jointly on every channel of one reference.

    A mode the rig model does not hold (a flexible frame or housing mode) a few half-power
    bandwidths from the housing mode biases a fit of the driving point alone at the identified
    poles: the two pole shapes are nearly collinear there, so a pole held off by its own std moves
    the split of the pair's residue (measured on the issue-19 truths: the 663 Hz frame mode beside
    a 656.5 Hz housing mode, driving-point modal mass +3.9 % at z 3.2). Here every pole inside the
    fitted lines (the housing mode, its neighbours and any other identified mode there) is
    re-estimated from all channels at once, with complex residues and residual terms per
    channel. Model per channel ``o``::

        H_o(w) / (jw)^k = sum_r R_or / (jw - s_r) + R_or* / (jw - s_r*) + A_o + B_o / w^2

    Identified poles within ``+-2 window`` enter (outside the lines held at their identified
    values). Variable projection (``scipy.optimize.least_squares`` on the free poles' ``ln w_n``
    and damping ratios; residues by linear least squares). Noise model: relative, ``var = b_o
    |H_o|^2`` per channel (the FRF noise of an H1 estimate is proportional to ``|H|``; Bendat &
    Piersol, table 9.6), ``b_o`` estimated by maximum likelihood from the channel's residual and the
    fit repeated with those weights. Covariance: the inverse Fisher information ``(J^T J)^-1`` of
    every free pole and residue in the whitened problem.

    Parameters
    ----------
    freq : ndarray, shape (n_freq,)
        Frequencies [Hz].
    frf : ndarray, shape (n_out, n_freq), complex
        FRFs of every output for the radial reference, in ``frf_form`` (SI).
    poles : ndarray, shape (n_modes,), complex
        Identified poles [rad/s] (upper half plane): start values.
    index : int
        The housing mode.
    neighbours : sequence of int
        The close modes (always free, also when outside the lines).
    driving_point : int
        Row of ``frf`` that is the driving point.
    frf_form : {'receptance', 'mobility', 'accelerance'}
    window : float
        Relative half-width of the band of lines around the housing mode (widened to hold each
        neighbour with four half-power bandwidths each side). 0.3: on the issue-19 viscous-bearing
        truths (20 seeds) the modal mass's z against the truth's has rms 1.1 (max 2.2); at 0.1 the
        pair's poles are too loose (seed 8: +/- 4.2 %).
    criteria : MatchCriteria, optional
        ``pair_max_mass_std`` (default :data:`ema_rig.rig.matching.MATCH_CRITERIA`).

    Returns
    -------
    NeighbourPairFit or None
        None when the band holds too few lines, a free pole leaves its neighbourhood or the housing
        mode's residue vanishes.
    """
    with single_threaded():  # many small least-squares solves: BLAS threads only add hand-off time
        return _fit_housing_pair(freq, frf, poles, index, neighbours, driving_point, frf_form=frf_form,
                                 window=window, criteria=criteria)


def _fit_housing_pair(
    freq: NDArray[np.float64],
    frf: NDArray[np.complex128],
    poles: NDArray[np.complex128],
    index: int,
    neighbours: tuple[int, ...] | list[int],
    driving_point: int,
    *,
    frf_form: FrfForm,
    window: float,
    criteria: Any,
) -> NeighbourPairFit | None:
    """:func:`fit_housing_pair`'s body (run with single-threaded BLAS)."""
    from scipy.optimize import least_squares

    if criteria is None:
        criteria = MATCH_CRITERIA
    p = np.asarray(poles, dtype=complex).copy()
    fn = np.abs(p) / (2 * math.pi)
    zeta = -p.real / np.maximum(np.abs(p), 1e-300)
    f0 = float(fn[index])
    nb = [int(i) for i in neighbours if int(i) != index]
    lo, hi = f0 * (1 - window), f0 * (1 + window)
    for r in nb:
        lo, hi = min(lo, fn[r] * (1 - 4 * zeta[r])), max(hi, fn[r] * (1 + 4 * zeta[r]))
    fq = np.asarray(freq, dtype=float)
    sel = (fq > lo) & (fq < hi) & (fq > 0)
    w = 2 * math.pi * fq[sel]
    if w.size < 20:
        return None
    jw = np.asarray(1j * w, dtype=np.complex128)
    h = np.asarray(frf)[:, sel] / jw[None, :] ** _FORM_POWER[frf_form]
    n_out = h.shape[0]
    free = [index, *nb, *[r for r in range(p.size) if r != index and r not in nb and lo < fn[r] < hi]]
    near = sorted({r for r in range(p.size) if abs(fn[r] / f0 - 1) < 2 * window} | set(free))
    wt = 1.0 / np.maximum(np.abs(h), 1e-300)
    n_lin = 2 * len(near) + 4

    def basis(sv: dict[int, complex]) -> NDArray[np.complex128]:
        return _local_columns(jw, w, np.array([sv.get(r, p[r]) for r in near], dtype=complex))

    def poles_of(x: NDArray[np.float64]) -> dict[int, complex]:  # x = (ln w_n, damping ratio) per free pole
        out = {}
        for j, r in enumerate(free):
            wn, z = math.exp(float(x[2 * j])), float(x[2 * j + 1])
            out[r] = complex(-z * wn, wn * math.sqrt(max(1.0 - z * z, 0.0)))
        return out

    def blocks(b: NDArray[np.complex128], o: int, chw: NDArray[np.float64]) -> NDArray[np.float64]:
        a = b * (wt[o] * chw[o])[:, None]
        return np.concatenate([a.real, a.imag])

    def solve(x: NDArray[np.float64], chw: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        b = basis(poles_of(x))
        coefs, res = [], []
        for o in range(n_out):
            ar = blocks(b, o, chw)
            yo = np.concatenate([(h[o] * wt[o] * chw[o]).real, (h[o] * wt[o] * chw[o]).imag])
            c, *_ = np.linalg.lstsq(ar, yo, rcond=None)
            coefs.append(c)
            res.append(yo - ar @ c)
        return np.array(coefs), np.concatenate(res)

    x0 = np.concatenate([[math.log(abs(p[r])), zeta[r]] for r in free])
    scale = np.concatenate([[1e-3, max(float(zeta[r]), 1e-4) * 0.1] for r in free])
    chw = np.ones(n_out)
    x_hat = x0
    m2 = 2 * w.size
    for _ in range(2):  # equal relative weights, then each channel's noise level from its residual
        with np.errstate(all="ignore"):
            sol = least_squares(lambda x, c=chw: solve(x, c)[1], x_hat, x_scale=scale, method="lm",
                                xtol=1e-12, ftol=1e-12, max_nfev=100 * x0.size)
        if not (np.all(np.isfinite(sol.x)) and np.all((sol.x[1::2] > 0) & (sol.x[1::2] < 0.5))):
            return None
        x_hat = sol.x
        _, res = solve(x_hat, chw)
        s2 = np.array([float(res[o * m2:(o + 1) * m2] @ res[o * m2:(o + 1) * m2]) for o in range(n_out)])
        chw = chw / np.sqrt(np.maximum(s2 / max(m2 - n_lin - x0.size / n_out, 1.0), 1e-300))
    sv = poles_of(x_hat)
    for r in free:  # a free pole that wandered off by more than its half-power bandwidth is another mode
        if abs(abs(sv[r]) / abs(p[r]) - 1) > max(float(zeta[r]), 1e-3):
            return None
    coefs, res = solve(x_hat, chw)
    n_x = x_hat.size
    dof = res.size - n_x - coefs.size
    if dof <= 0:
        return None
    chi2_dof = float(res @ res) / dof
    # Jacobian of the whitened model in (free pole parameters, every channel's linear coefficients)
    jac = np.zeros((res.size, n_x + coefs.size))
    b = basis(sv)
    for o in range(n_out):
        jac[o * m2:(o + 1) * m2, n_x + o * n_lin:n_x + (o + 1) * n_lin] = blocks(b, o, chw)
    for i in range(n_x):
        dx = np.zeros(n_x)
        dx[i] = 1e-7 * (1.0 if i % 2 == 0 else max(x_hat[i], 1e-4))
        db = basis(poles_of(x_hat + dx)) - basis(poles_of(x_hat - dx))
        for o in range(n_out):
            d = (db @ coefs[o]) * (wt[o] * chw[o]) / (2 * dx[i])
            jac[o * m2:(o + 1) * m2, i] = np.concatenate([d.real, d.imag])
    try:
        cov = chi2_dof * np.linalg.inv(jac.T @ jac)
    except np.linalg.LinAlgError:
        return None

    def mass_and_grad(r: int) -> tuple[float, NDArray[np.float64]]:
        k = near.index(r)
        ci = n_x + driving_point * n_lin + 2 * k
        re, im = coefs[driving_point][2 * k], coefs[driving_point][2 * k + 1]
        amp = math.hypot(re, im)
        g = np.zeros(n_x + coefs.size)
        if not amp > 0:
            return math.inf, g
        mass = 1.0 / (2 * sv[r].imag * amp)
        g[ci], g[ci + 1] = -mass * re / amp**2, -mass * im / amp**2
        j = free.index(r)  # w_d = w_n sqrt(1 - z^2)
        z = float(x_hat[2 * j + 1])
        g[2 * j] = -mass
        g[2 * j + 1] = mass * z / max(1 - z * z, 1e-12)
        return mass, g

    m_h, g_h = mass_and_grad(index)
    var_h = float(g_h @ cov @ g_h)
    if not (math.isfinite(m_h) and m_h > 0 and var_h >= 0):
        return None
    rho, n_masses = 0.0, []
    for r in nb:
        m_n, g_n = mass_and_grad(r)
        n_masses.append(float(m_n))
        var_n = float(g_n @ cov @ g_n)
        if var_h > 0 and var_n > 0:
            rho = max(rho, abs(float(g_h @ cov @ g_n)) / math.sqrt(var_h * var_n))
    std_h = math.sqrt(var_h)
    return NeighbourPairFit(modal_mass=float(m_h), modal_mass_std=std_h, pole=sv[index],
                            neighbour_poles=tuple(sv[r] for r in nb), neighbour_masses=tuple(n_masses),
                            correlation=float(rho), chi2_dof=chi2_dof, n_lines=int(w.size), n_channels=n_out,
                            n_free=len(free), resolved=bool(std_h / m_h <= criteria.pair_max_mass_std))


def fit_housing_pair_of(data: FRFData, p: int, q: int, poles: NDArray[np.complex128], index: int,
                        neighbours: tuple[int, ...] | list[int]) -> NeighbourPairFit | None:
    """:func:`fit_housing_pair` on every output of ``data`` for reference ``q`` (driving point ``p``)."""
    return fit_housing_pair(data.freq, data.frf[:, q], poles, index, neighbours, p, frf_form=data.frf_form)
