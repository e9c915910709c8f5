"""From the housing-mode natural frequency to the bearing stiffness (DESIGN §4, paper Sect. 4-5).

The housing radial mode of the 3DOF model (:mod:`ema_rig.rig.model`) is inverted for the
combined stiffness ``k_TB+MS`` and then, through the series relation with the mounting
stiffness ``k_MS``, for the bearing stiffness ``k_TB``.

Functions
---------
housing_freq_bounds
    Frequency range of the housing mode that gives ``k_TB+MS > 0`` (and ``k_TB > 0``).
housing_freq_from_k_tb_ms
    Forward model: housing-mode natural frequency [Hz] for a given ``k_TB+MS``.
k_tb_ms_from_housing_freq
    Closed form (default) or root finder: ``k_TB+MS`` from the housing frequency.
k_tb_from_housing_freq
    ``k_TB`` from the housing frequency.
calibrate_k_ms
    ``k_MS`` (with its standard uncertainty, the disk's term included) from the steel-disk
    housing mode.
fit_rig
    Least-squares fit of ``k_TB+MS``, ``k_S``, ``m_S``, ``m_F`` to measured FRFs (paper Sect. 4).

Classes
-------
KmsCalibration, RigFit
    Frozen results with ``to_dict()`` / ``to_records()``.

The uncertainty budget of ``k_TB`` is in :mod:`ema_rig.rig.uncertainty`.

Notes
-----
With ``K0`` the stiffness matrix without the bearing spring and ``e = [1, -1, 0]`` (housing minus
spindle), ``K = K0 + k e e^T``. ``det(K - w^2 M) = det(K0 - w^2 M) (1 + k e^T (K0 - w^2 M)^-1 e)``
so ``w`` is a natural frequency exactly when ``k = -1 / (e^T (K0 - w^2 M)^-1 e)``.
By eigenvalue interlacing for this rank-one update, the second eigenvalue (the housing mode)
rises monotonically with ``k`` from the second eigenvalue of ``(K0, M)`` (housing on the air
springs; 80.6 Hz with Table 1) to the second eigenvalue of the system with ``x_H = x_S``
(1299.6 Hz); ``k_TB > 0`` additionally needs ``k_TB+MS < k_MS`` (897.35 Hz with Table 1).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any, cast

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..config import ModelParams
from ..errors import InversionError
from ..literals import KIND_DEFAULT, KIND_MEASURED, KIND_MODEL, KIND_RIG, KINDS, FrfForm
from .model import (
    HOUSING,
    HOUSING_MODE,
    SPINDLE,
    SPINDLE_MODE,
    RigModel,
    k_tb_from_series,
    mass_matrix,
    stiffness_matrix,
)

_E = np.array([1.0, -1.0, 0.0])


# --------------------------------------------------------------------------- forward / bounds
def housing_freq_from_k_tb_ms(k_TB_MS: float, params: ModelParams) -> float:
    """Natural frequency of the housing mode [Hz] for a combined stiffness ``k_TB+MS`` [N/m].

    Parameters
    ----------
    k_TB_MS : float
        Bearing and mounting system in series, ``k_TB+MS`` [N/m].
    params : ModelParams
        The rig model.

    Returns
    -------
    float
        Housing-mode natural frequency [Hz].
    """
    return RigModel(params, k_TB_MS).housing_freq


def _constrained_freqs(params: ModelParams) -> NDArray[np.float64]:
    """Natural frequencies [Hz] with the housing rigidly tied to the spindle (k -> inf)."""
    # DOFs [x_H = x_S, x_F]
    m = np.diag([params.m_H + params.m_S, params.m_F])
    ka, ks, kb = params.k_AS, params.k_S, params.k_B
    k = np.array([[ka + ks, -(ka + ks)], [-(ka + ks), ka + ks + kb]])
    lam = scipy.linalg.eigh(k, m, eigvals_only=True)
    return cast("NDArray[np.float64]", np.sqrt(lam) / (2.0 * np.pi))


def housing_freq_bounds(params: ModelParams, *, bearing: bool = False) -> tuple[float, float]:
    """Housing-mode frequencies [Hz] that give a positive stiffness.

    Parameters
    ----------
    params : ModelParams
        Rig parameters.
    bearing : bool, optional
        False (default): the range for ``k_TB+MS > 0``, from the housing mode without the
        bearing spring to the one with the housing tied to the spindle (80.6 ... 1299.6 Hz with
        Table 1). True: the range for ``k_TB > 0``, whose upper bound is the housing mode with
        ``k_TB+MS = k_MS`` (897.35 Hz with Table 1).

    Returns
    -------
    (float, float)
        Open interval ``(f_lo, f_hi)`` in Hz.
    """
    lam0 = scipy.linalg.eigh(stiffness_matrix(params, 0.0), mass_matrix(params), eigvals_only=True)
    f_lo = float(np.sqrt(lam0[HOUSING_MODE]) / (2.0 * np.pi))
    if bearing:
        f_hi = housing_freq_from_k_tb_ms(params.k_MS, params)
    else:
        f_hi = float(_constrained_freqs(params)[HOUSING_MODE])
    return f_lo, f_hi


def _check_freq(f_H: float, params: ModelParams, what: str = "housing-mode frequency") -> float:
    f = float(f_H)
    lo, hi = housing_freq_bounds(params)
    if not (math.isfinite(f) and lo < f < hi):
        raise InversionError(
            f"{what} {f:.6g} Hz is outside the valid range {lo:.1f} Hz < f_H < {hi:.1f} Hz of the "
            "3DOF model (k_TB+MS > 0); no physical stiffness corresponds to it"
        )
    return f


# --------------------------------------------------------------------------- inversion
def k_tb_ms_closed_form(f_H: float, params: ModelParams) -> float:
    """``k_TB+MS`` [N/m] that puts the housing mode at ``f_H`` [Hz], by the closed form (DESIGN §4).

    ``k_TB+MS = -1 / (e^T (K0 - w^2 M)^-1 e)`` with ``K0`` the stiffness matrix without the
    bearing spring and ``e = [1, -1, 0]``; no range check (see :func:`k_tb_ms_from_housing_freq`).

    Parameters
    ----------
    f_H : float
        Housing-mode frequency [Hz].
    params : ModelParams
        The rig model.

    Returns
    -------
    float
        ``k_TB+MS`` [N/m]; negative outside the model's valid range.
    """
    w2 = (2.0 * np.pi * f_H) ** 2
    a = stiffness_matrix(params, 0.0) - w2 * mass_matrix(params)
    return float(-1.0 / (_E @ np.linalg.solve(a, _E)))


_closed_form = k_tb_ms_closed_form  # the old private name, kept while the branches in flight land


def _root_finder(f_H: float, params: ModelParams) -> float:
    w2 = (2.0 * np.pi * f_H) ** 2
    m = mass_matrix(params)

    def g(log_k: float) -> float:
        lam = scipy.linalg.eigh(stiffness_matrix(params, math.exp(log_k)), m, eigvals_only=True)
        return float(lam[HOUSING_MODE] / w2 - 1.0)

    # the housing eigenvalue rises monotonically in k: bracket in log k
    scale = params.k_S
    lo, hi = math.log(scale * 1e-9), math.log(scale * 1e9)
    import scipy.optimize  # lazy: only the root-finder path needs it (CLI cold start)

    log_k = scipy.optimize.brentq(g, lo, hi, xtol=1e-15, rtol=4 * np.finfo(float).eps, maxiter=500)
    return math.exp(log_k)


def k_tb_ms_from_housing_freq(f_H: float, params: ModelParams, *, method: str = "closed") -> float:
    """Combined stiffness ``k_TB+MS`` [N/m] from the housing-mode natural frequency.

    Parameters
    ----------
    f_H : float
        Undamped natural frequency of the housing radial mode [Hz].
    params : ModelParams
        Rig parameters (``k_MS`` is not used).
    method : {'closed', 'root'}
        'closed': ``k = -1 / (e^T (K0 - w^2 M)^-1 e)``; 'root': ``scipy.optimize.brentq`` on the
        housing eigenvalue of ``(K(k), M)``. Both agree to ~1e-12.

    Returns
    -------
    float
        ``k_TB+MS`` [N/m], > 0.

    Raises
    ------
    InversionError
        If ``f_H`` is outside :func:`housing_freq_bounds` (the stiffness would be negative or
        infinite).

    Examples
    --------
    >>> from ema_rig.config import ModelParams
    >>> p = ModelParams(2.566, 2.8, 205.0, 114e6, 650e3, 348e6, 180e3)
    >>> round(k_tb_ms_from_housing_freq(626.0, p) / 1e6, 2)
    43.97
    """
    f = _check_freq(f_H, params)
    if method == "closed":
        k = k_tb_ms_closed_form(f, params)
    elif method == "root":
        k = _root_finder(f, params)
    else:
        raise ValueError(f"method must be 'closed' or 'root', got {method!r}")
    if not (math.isfinite(k) and k > 0):  # pragma: no cover - excluded by the bounds
        raise InversionError(f"housing-mode frequency {f:.6g} Hz gives no positive k_TB+MS ({k:.6g} N/m)")
    return k


def k_tb_from_housing_freq(
    f_H: float, params: ModelParams, *, k_MS: float | None = None, method: str = "closed"
) -> float:
    """Bearing stiffness ``k_TB`` [N/m] from the housing-mode natural frequency.

    Parameters
    ----------
    f_H : float
        Undamped natural frequency of the housing radial mode [Hz].
    params : ModelParams
        Rig parameters.
    k_MS : float, optional
        Mounting stiffness [N/m] (e.g. from :func:`calibrate_k_ms`); default ``params.k_MS``.
    method : {'closed', 'root'}
        See :func:`k_tb_ms_from_housing_freq`.

    Returns
    -------
    float
        ``k_TB`` [N/m], > 0.

    Raises
    ------
    InversionError
        If ``f_H`` lies outside the range where ``0 < k_TB+MS < k_MS``.
    """
    kms = params.k_MS if k_MS is None else float(k_MS)
    if not (math.isfinite(kms) and kms > 0):
        raise InversionError(f"k_MS must be a finite positive stiffness, got {k_MS!r}")
    p = params if kms == params.k_MS else replace(params, k_MS=kms)
    k = k_tb_ms_from_housing_freq(f_H, p, method=method)
    if k >= kms:
        lo, _ = housing_freq_bounds(p)
        _, hi = housing_freq_bounds(p, bearing=True)
        raise InversionError(
            f"housing-mode frequency {float(f_H):.6g} Hz gives k_TB+MS = {k:.6g} N/m >= k_MS = "
            f"{kms:.6g} N/m, i.e. a bearing stiffer than rigid; k_TB > 0 needs "
            f"{lo:.1f} Hz < f_H < {hi:.2f} Hz (check k_MS / the steel-disk calibration)"
        )
    return k_tb_from_series(k, kms)


def _dk_df(f_H: float, params: ModelParams) -> float:
    """d k_TB+MS / d f_H [N/m/Hz] by a central difference of the closed form."""
    h = 1e-6 * f_H
    return (k_tb_ms_closed_form(f_H + h, params) - k_tb_ms_closed_form(f_H - h, params)) / (2 * h)


# --------------------------------------------------------------------------- k_MS calibration
DISK_STIFFNESS_RATIO: float = 10.0
"""The paper's bound on the steel disk: "at least a factor 10" stiffer than ``k_MS``."""


@dataclass(frozen=True, slots=True)
class KmsCalibration:
    """Mounting-system stiffness from a steel-disk measurement.

    Attributes
    ----------
    k_MS, k_MS_std : float
        Mounting stiffness and its total standard uncertainty [N/m]: the frequency term (``f_disk_std``
        through the slope) and the disk term combined.
    f_disk, f_disk_std : float
        Housing-mode natural frequency with the disk mounted and its std [Hz] (from
        :func:`ema_rig.rig.stiffness.calibrate`: the measured std and the frequency's model-form
        terms combined).
    k_TB_MS : float
        Combined stiffness from the disk frequency [N/m] (= k_MS when the disk is rigid).
    k_disk : float or None
        Disk stiffness put in series [N/m]; None = assumed rigid (the paper's assumption).
    k_disk_std : float or None
        Standard uncertainty of ``k_disk`` [N/m] (None: not given, taken as 0).
    k_MS_std_measured : float
        The part of ``k_MS_std`` from the identified frequency's measured std alone [N/m].
    disk_std : float
        The part from the disk [N/m]: ``k_disk_std`` propagated through the series relation,
        or, with the disk assumed rigid, the model-form term of :func:`calibrate_k_ms`.
    disk_term_kind : str
        ``'assumed (rig file)'`` (a given disk stiffness) or ``'model form'`` (disk assumed
        rigid).
    """

    k_MS: float
    k_MS_std: float
    f_disk: float
    f_disk_std: float
    k_TB_MS: float
    k_disk: float | None = None
    k_disk_std: float | None = None
    k_MS_std_measured: float = 0.0
    disk_std: float = 0.0
    disk_term_kind: str = KIND_MODEL

    def to_dict(self) -> dict[str, Any]:
        """Plain-dict form for JSON."""
        return {
            "k_MS": self.k_MS,
            "k_MS_std": self.k_MS_std,
            "k_MS_std_measured": self.k_MS_std_measured,
            "k_MS_std_disk": self.disk_std,
            "disk_term_kind": self.disk_term_kind,
            "f_disk": self.f_disk,
            "f_disk_std": self.f_disk_std,
            "k_TB_MS": self.k_TB_MS,
            "k_disk": self.k_disk,
            "k_disk_std": self.k_disk_std,
        }


def calibrate_k_ms(
    f_disk: float,
    params: ModelParams,
    *,
    f_disk_std: float = 0.0,
    k_disk: float | None = None,
    k_disk_std: float | None = None,
    disk_ratio: float = DISK_STIFFNESS_RATIO,
) -> KmsCalibration:
    """Mounting stiffness ``k_MS`` from the housing mode with a steel disk mounted.

    The disk sits in series with the mounting system: ``1/k_TB+MS = 1/k_MS + 1/k_disk``.

    * ``k_disk`` given (e.g. from FE): ``1/k_MS = 1/k_TB+MS - 1/k_disk``, and ``k_disk_std``
      propagates with ``d k_MS / d k_disk = -(k_MS / k_disk)^2``.
    * ``k_disk`` unknown: the paper's convention ``k_MS = k_TB+MS`` (disk rigid) is kept, with a
      model-form term for it. With the disk at least ``disk_ratio`` times stiffer than
      ``k_MS`` (paper: 10), ``k_MS / k_TB+MS = 1 + k_MS / k_disk`` lies in
      ``[1, 1 + 1/disk_ratio]``: the uncorrected value is low by between 0 and 10 %. The term
      is the root-mean-square error of that one-sided rectangular spread,
      ``(1 / disk_ratio) / sqrt(3)`` (5.8 % of ``k_MS`` at 10x), so even a disk only 10x
      stiffer lies within 1.7 sigma; the calibration never reports ``k_MS`` tighter than its
      disk assumption allows.

    Parameters
    ----------
    f_disk : float
        Undamped housing-mode natural frequency with the disk [Hz].
    params : ModelParams
        Rig parameters (their ``k_MS`` is ignored).
    f_disk_std : float, optional
        Standard uncertainty of ``f_disk`` [Hz].
    k_disk : float, optional
        Disk stiffness [N/m]; default None (assumed rigid, with the model-form term).
    k_disk_std : float, optional
        Standard uncertainty of ``k_disk`` [N/m].
    disk_ratio : float, optional
        Lower bound of ``k_disk / k_MS`` when ``k_disk`` is unknown (default 10).

    Returns
    -------
    KmsCalibration

    Raises
    ------
    InversionError
        If ``f_disk`` is outside the valid range, or the disk is not stiffer than ``k_TB+MS``.
    """
    f = _check_freq(f_disk, params, "steel-disk housing-mode frequency")
    k = k_tb_ms_closed_form(f, params)
    dk = abs(_dk_df(f, params)) * float(f_disk_std)
    if k_disk is None:
        if not disk_ratio > 0:
            raise ValueError(f"disk_ratio must be > 0, got {disk_ratio!r}")
        kms, meas = k, dk
        disk = k / disk_ratio / math.sqrt(3.0)
        kind = KIND_MODEL
    else:
        kd = float(k_disk)
        if not (kd > k):
            raise InversionError(
                f"disk stiffness {kd:.6g} N/m must exceed k_TB+MS = {k:.6g} N/m from the disk "
                f"frequency {f:.6g} Hz"
            )
        kms = 1.0 / (1.0 / k - 1.0 / kd)
        meas = dk * (kms / k) ** 2  # d kms / d k = (kms / k)^2
        disk = (kms / kd) ** 2 * float(k_disk_std or 0.0)
        kind = KIND_RIG
    return KmsCalibration(
        k_MS=kms,
        k_MS_std=math.hypot(meas, disk),
        f_disk=f,
        f_disk_std=float(f_disk_std),
        k_TB_MS=k,
        k_disk=None if k_disk is None else float(k_disk),
        k_disk_std=None if k_disk_std is None else float(k_disk_std),
        k_MS_std_measured=float(meas),
        disk_std=float(disk),
        disk_term_kind=kind,
    )


# --------------------------------------------------------------------------- model fit
_FIT_KEYS = ("k_TB_MS", "k_S", "m_S", "m_F")


@dataclass(frozen=True, slots=True)
class RigFit:
    """3DOF model fitted to measured FRFs (paper Sect. 4, Fig. 7).

    Attributes
    ----------
    params : ModelParams
        Rig parameters with the fitted ``k_S``, ``m_S``, ``m_F``.
    k_TB_MS : float
        Fitted combined stiffness [N/m].
    damping_ratio : ndarray, shape (3,)
        Modal damping ratios used (the housing one fitted).
    natural_freq : ndarray, shape (3,)
        Natural frequencies of the fitted model [Hz].
    initial : dict
        Starting values of the fitted quantities.
    band : (float, float)
        Fit band [Hz].
    residual_rms : float
        RMS of the driving-point log-magnitude residual over the band (natural-log units;
        0.01 ~ 1 %).
    cost : float
        ``least_squares`` cost (half the sum of squared residuals).
    nfev : int
        Function evaluations.
    success : bool
        Optimiser status.
    message : str
        Optimiser message.
    """

    params: ModelParams
    k_TB_MS: float
    damping_ratio: NDArray[np.float64]
    natural_freq: NDArray[np.float64]
    initial: Mapping[str, float]
    band: tuple[float, float]
    residual_rms: float
    cost: float
    nfev: int
    success: bool
    message: str

    @property
    def model(self) -> RigModel:
        """The fitted :class:`RigModel`."""
        return RigModel(self.params, self.k_TB_MS)

    def to_records(self) -> list[dict[str, Any]]:
        """One row per fitted quantity: name, initial value, fitted value, relative change."""
        fitted = {"k_TB_MS": self.k_TB_MS, "k_S": self.params.k_S, "m_S": self.params.m_S, "m_F": self.params.m_F,
                  "damping_ratio_H": float(self.damping_ratio[HOUSING_MODE])}
        rows = []
        for n, v in fitted.items():
            v0 = self.initial.get(n, math.nan)
            rows.append({"name": n, "initial": v0, "fitted": v, "rel_change": v / v0 - 1.0 if v0 else math.nan})
        return rows

    def to_dict(self) -> dict[str, Any]:
        """Plain-dict form for JSON."""
        return {
            "k_TB_MS": self.k_TB_MS,
            "params": self.params.as_dict(),
            "damping_ratio": [float(z) for z in self.damping_ratio],
            "natural_freq": [float(f) for f in self.natural_freq],
            "band": list(self.band),
            "residual_rms": self.residual_rms,
            "cost": self.cost,
            "nfev": self.nfev,
            "success": self.success,
            "message": self.message,
            "fit": self.to_records(),
        }


def _soft_l1(r: NDArray[np.float64], scale: float) -> NDArray[np.float64]:
    """Residual whose square is the soft-L1 loss ``2 c^2 (sqrt(1 + (r/c)^2) - 1)``."""
    z = r / scale
    return np.sign(r) * scale * np.sqrt(2.0 * (np.sqrt(1.0 + z * z) - 1.0))


def fit_rig(
    freq: ArrayLike,
    frf_housing: ArrayLike,
    frf_spindle: ArrayLike | None,
    params: ModelParams,
    *,
    k_TB_MS: float | None = None,
    f_housing: float | None = None,
    damping_ratio: float | Sequence[float] = 0.02,
    frf_form: FrfForm = "accelerance",
    band: tuple[float, float] = (150.0, 700.0),
    spindle_freq: float | None = None,
    freq_weight: float = 300.0,
    spindle_frf_weight: float = 0.2,
    fit: Sequence[str] = _FIT_KEYS,
    prior_rel_std: float = 0.1,
    bounds_factor: float = 3.0,
    robust_scale: float = 0.1,
) -> RigFit:
    """Fit ``k_TB+MS``, ``k_S``, ``m_S``, ``m_F`` (and the housing damping) to measured FRFs.

    Residuals (all in natural-log units, 0.01 ~ 1 %):

    - log-magnitude differences of the driving-point (housing) FRF over ``band`` and, weighted by
      ``spindle_frf_weight``, of the spindle FRF, through a soft-L1 function of scale
      ``robust_scale`` (measured FRFs hold modes the model lacks — the spindle's 287 Hz mode, the
      300 Hz axial mode, antiresonances filled by other modes — which must not drag the fit);
    - ``freq_weight * ln(f_model / f_measured)`` for the identified housing mode (``f_housing``)
      and spindle bending mode (``spindle_freq``, paper: 1908 Hz) when given: the model is tuned
      to the measured natural frequencies, as in the paper;
    - ``ln(x / x0) / prior_rel_std`` for ``k_S``, ``m_S``, ``m_F``: the FRFs in the band hardly
      determine ``m_F`` (or, alone, ``k_S`` against ``m_S``), so the starting values act as a
      prior.

    Parameters are fitted in log space within a factor ``bounds_factor`` of their starting values
    with :func:`scipy.optimize.least_squares`.

    Parameters
    ----------
    freq : array_like, shape (n_freq,)
        Frequencies [Hz].
    frf_housing : array_like, shape (n_freq,), complex
        Driving-point FRF at the housing (radial), in ``frf_form``.
    frf_spindle : array_like, shape (n_freq,), complex, or None
        Radial spindle FRF for the same force, or None.
    params : ModelParams
        Starting parameters (m_H, k_MS, k_AS, k_B are kept).
    k_TB_MS : float, optional
        Starting value; default from ``f_housing`` by the closed form, else 4e7 N/m.
    f_housing : float, optional
        Identified housing-mode natural frequency [Hz].
    damping_ratio : float or sequence of 3 floats
        Modal damping ratios; the housing-mode one is the starting value of a fitted parameter.
    frf_form : str
        Form of the measured FRFs (default accelerance).
    band : (float, float)
        Fit band [Hz] (paper: 150-700 Hz).
    spindle_freq : float, optional
        Identified spindle bending-mode natural frequency [Hz].
    freq_weight : float
        Weight of the natural-frequency residuals.
    spindle_frf_weight : float
        Weight of the spindle FRF's log-magnitude residuals.
    fit : sequence of str
        Which of ``k_TB_MS, k_S, m_S, m_F`` to fit (others kept).
    prior_rel_std : float
        Relative spread of the prior on ``k_S``, ``m_S``, ``m_F``; ``inf`` removes the prior.
    bounds_factor : float
        Each fitted parameter stays within ``[x0 / bounds_factor, x0 * bounds_factor]``; the
        housing damping ratio within 1e-4 ... 0.3.
    robust_scale : float
        Scale of the soft-L1 function on the magnitude residuals; ``inf`` = plain least squares.

    Returns
    -------
    RigFit
    """
    f = np.asarray(freq, dtype=np.float64)
    sel = (f >= band[0]) & (f <= band[1])
    if sel.sum() < 5:
        raise ValueError(f"band {band[0]:g}..{band[1]:g} Hz holds fewer than 5 lines of the data")
    if not bounds_factor > 1:
        raise ValueError(f"bounds_factor must be > 1, got {bounds_factor!r}")
    fb = f[sel]
    hh = np.asarray(frf_housing)[sel]
    hs = None if frf_spindle is None else np.asarray(frf_spindle)[sel]
    for n in fit:
        if n not in _FIT_KEYS:
            raise ValueError(f"fit entries must be among {_FIT_KEYS}, got {n!r}")
    z0 = np.broadcast_to(np.asarray(damping_ratio, dtype=np.float64), (3,)).copy()
    if k_TB_MS is None:
        k_TB_MS = k_tb_ms_from_housing_freq(f_housing, params) if f_housing is not None else 4e7
    start = {"k_TB_MS": float(k_TB_MS), "k_S": params.k_S, "m_S": params.m_S, "m_F": params.m_F}
    names = list(fit)
    x0 = np.array([math.log(start[n]) for n in names] + [math.log(z0[HOUSING_MODE])])
    with np.errstate(divide="ignore"):
        lh_meas = np.log(np.abs(hh))
        ls_meas = None if hs is None else np.log(np.abs(hs))
    ok_h = np.isfinite(lh_meas)
    ok_s = None if ls_meas is None else np.isfinite(ls_meas)
    prior_idx = [i for i, n in enumerate(names) if n != "k_TB_MS"]
    use_prior = math.isfinite(prior_rel_std) and prior_rel_std > 0 and bool(prior_idx)

    def unpack(x: NDArray[np.float64]) -> tuple[ModelParams, float, NDArray[np.float64]]:
        vals = dict(start)
        vals.update({n: math.exp(v) for n, v in zip(names, x[:-1], strict=True)})
        p = replace(params, k_S=vals["k_S"], m_S=vals["m_S"], m_F=vals["m_F"])
        z = z0.copy()
        z[HOUSING_MODE] = math.exp(x[-1])
        return p, vals["k_TB_MS"], z

    def robust(r: NDArray[np.float64]) -> NDArray[np.float64]:
        return r if not math.isfinite(robust_scale) else _soft_l1(r, robust_scale)

    def magnitude(x: NDArray[np.float64]) -> NDArray[np.float64]:
        p, k, z = unpack(x)
        h = RigModel(p, k).frf(fb, damping_ratio=z, frf_form=frf_form, outputs=(0, 1))
        parts = [np.log(np.abs(h[0][ok_h])) - lh_meas[ok_h]]
        if ls_meas is not None:
            parts.append(spindle_frf_weight * (np.log(np.abs(h[1][ok_s])) - ls_meas[ok_s]))
        return np.concatenate(parts)

    def resid(x: NDArray[np.float64]) -> NDArray[np.float64]:
        p, k, _ = unpack(x)
        parts = [robust(magnitude(x))]
        fn = RigModel(p, k).natural_freq
        if f_housing is not None:
            parts.append(np.array([freq_weight * math.log(fn[HOUSING_MODE] / f_housing)]))
        if spindle_freq is not None:
            parts.append(np.array([freq_weight * math.log(fn[SPINDLE_MODE] / spindle_freq)]))
        if use_prior:
            parts.append((x[prior_idx] - x0[prior_idx]) / prior_rel_std)
        return np.concatenate(parts)

    lb = np.array([v - math.log(bounds_factor) for v in x0[:-1]] + [math.log(1e-4)])
    ub = np.array([v + math.log(bounds_factor) for v in x0[:-1]] + [math.log(0.3)])
    x0 = np.clip(x0, lb + 1e-12, ub - 1e-12)
    import scipy.optimize  # lazy: only the model fit needs it

    res = scipy.optimize.least_squares(resid, x0, method="trf", bounds=(lb, ub))
    p, k, z = unpack(res.x)
    r = magnitude(res.x)
    n_h = int(ok_h.sum())
    rms = float(np.sqrt(np.mean(r[:n_h] ** 2)))
    initial = {**start, "damping_ratio_H": float(z0[HOUSING_MODE])}
    return RigFit(
        params=p,
        k_TB_MS=k,
        damping_ratio=z,
        natural_freq=RigModel(p, k).natural_freq,
        initial=initial,
        band=(float(band[0]), float(band[1])),
        residual_rms=rms,
        cost=float(res.cost),
        nfev=int(res.nfev),
        success=bool(res.success),
        message=str(res.message),
    )



@dataclass(frozen=True, slots=True)
class ModelModeInfo:
    """The 3DOF model with its housing mode tuned to ``natural_freq``.

    Attributes
    ----------
    natural_freq : float
        Housing-mode frequency [Hz] the model was tuned to.
    k_tb_ms : float
        ``k_TB+MS`` [N/m] that puts the housing mode there.
    modal_mass : float
        Effective modal mass of the housing mode at the housing DOF, ``1 / phi_H^2`` [kg].
    spindle_ratio : float
        ``phi_S / phi_H`` of the housing mode (signed).
    spindle_freq : float
        Natural frequency of the model's spindle bending mode [Hz].
    spindle_mode_ratio : float
        ``phi_S / phi_H`` of that spindle mode (signed, large and negative).
    spindle_modal_mass : float
        Effective modal mass of the spindle mode at the housing DOF [kg].
    """

    natural_freq: float
    k_tb_ms: float
    modal_mass: float
    spindle_ratio: float
    spindle_freq: float
    spindle_mode_ratio: float
    spindle_modal_mass: float


def model_mode_at(params: ModelParams, natural_freq: float) -> ModelModeInfo | None:
    """The 3DOF model whose housing mode lies at ``natural_freq``.

    Parameters
    ----------
    params : ModelParams
        Table 1 parameters (``k_MS`` is not used: only ``k_TB+MS`` matters here).
    natural_freq : float
        Housing-mode frequency [Hz].

    Returns
    -------
    ModelModeInfo or None
        None when the frequency is outside :func:`housing_freq_bounds` (no positive stiffness).
    """
    lo, hi = housing_freq_bounds(params)
    if not lo < natural_freq < hi:
        return None
    k = k_tb_ms_from_housing_freq(natural_freq, params)
    model = RigModel(params, k)
    ph, ps = model.mode_shapes[:, HOUSING_MODE], model.mode_shapes[:, SPINDLE_MODE]
    return ModelModeInfo(
        natural_freq=float(natural_freq),
        k_tb_ms=float(k),
        modal_mass=model.effective_mass(HOUSING_MODE, HOUSING),
        spindle_ratio=float(ph[SPINDLE] / ph[HOUSING]),
        spindle_freq=model.spindle_freq,
        spindle_mode_ratio=float(ps[SPINDLE] / ps[HOUSING]),
        spindle_modal_mass=model.effective_mass(SPINDLE_MODE, HOUSING),
    )


__all__ = [
    "DISK_STIFFNESS_RATIO",
    "KINDS",
    "KIND_DEFAULT",
    "KIND_MEASURED",
    "KIND_MODEL",
    "KIND_RIG",
    "KmsCalibration",
    "ModelModeInfo",
    "RigFit",
    "calibrate_k_ms",
    "fit_rig",
    "housing_freq_bounds",
    "housing_freq_from_k_tb_ms",
    "k_tb_from_housing_freq",
    "k_tb_ms_closed_form",
    "k_tb_ms_from_housing_freq",
    "model_mode_at",
]
