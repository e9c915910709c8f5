"""The bearing's damping from the identified housing pole, through the 3DOF model.

The paper's reference method (Kraus et al. 1987) measures stiffness *and* damping; the 3DOF
model's housing mode carries both. With the bearing an impedance ``Z_TB(s)`` in series with the
(real) mounting stiffness ``k_MS``, the model's characteristic equation at the identified pole
``s`` has the same closed form as the stiffness inversion (:mod:`ema_rig.rig.inversion`), now in
complex arithmetic::

    k_TB+MS(s) = -1 / (e^T (K0 + s^2 M)^-1 e),    Z_TB(s) = 1 / (1 / k_TB+MS(s) - 1 / k_MS)

with ``e = [1, -1, 0]`` and ``s = 2 pi f (-zeta + j sqrt(1 - zeta^2))`` from the identified
``|lambda| / 2 pi`` and damping ratio. One complex equation gives two real unknowns:

* viscous dashpot in parallel with ``k_TB``: ``Z = k_TB + c_TB s``, so
  ``c_TB = Im Z / Im s`` and ``k_TB = Re Z - c_TB Re s``;
* hysteretic bearing: ``Z = k_TB (1 + j eta)``, so ``k_TB = Re Z`` and ``eta = Im Z / Re Z``.

Each is quoted also in the other's terms at the housing mode (``eta = c_TB w / k_TB``).
Everything else in the model is undamped: read with all of the mode's damping, damping elsewhere
that moves with the housing mode (air springs, the frame, the housing's own material) is
attributed to the bearing, so ``c_TB`` is an upper bound of the bearing's own damping on a rig
with damped surroundings (``kind`` ``'upper bound'``). Where the housing mode's spindle/housing
phase measures the bearing's share ``phi`` of the damping
(:func:`ema_rig.rig.uncertainty.assess_housing_mode`, its "damping location"), the pole is read with
``phi zeta`` in the bearing, the rest leaving ``|lambda|`` alone, and ``c_TB`` is a measurement
whose std carries the share's (``kind`` ``'measured'``): the share's noise (measured) and, since the
phase reads the share only as a lower bound, the span up to 1 (model form, ``share_model_std``).

Functions
---------
bearing_impedance
    ``Z_TB(s)`` [N/m] at an identified pole.
bearing_damping
    ``c_TB`` and the loss factor with their standard uncertainties.
c_tb_kind, c_tb_text
    What a row's ``c_TB`` is, and ``c_TB`` as one line of text, its kind said (the CLI, the report
    and the figures).

Classes
-------
BearingDamping
    Frozen result.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..config import MODEL_KEYS, ModelParams
from ..errors import InversionError
from ..literals import DampingKind, DampingModel
from .inversion import housing_freq_from_k_tb_ms, model_mode_at
from .model import mass_matrix, series_stiffness, stiffness_matrix

__all__ = ["BEARING_DAMPING_MODELS", "C_TB_KINDS", "BearingDamping", "bearing_damped_mass_factor", "bearing_damping",
           "bearing_impedance",
           "bearing_mode_phase", "bearing_reading_freq", "c_tb_kind", "c_tb_text"]

BEARING_DAMPING_MODELS: tuple[str, ...] = ("viscous", "hysteretic")
"""Bearing damping models: a dashpot in parallel with ``k_TB``, or ``k_TB (1 + j eta)``."""

C_TB_KINDS: dict[DampingKind, str] = {
    "measured": "the bearing's share of the housing mode's damping measured from its spindle/housing phase, "
                "a lower bound (damping in the spindle's support lowers that phase): its std covers the span "
                "up to all of it",
    "upper bound": "all of the housing mode's damping read as the bearing's (its location not measured)",
}
"""What ``c_TB`` is, per ``BearingDamping.kind``: a measurement, or an upper bound whose std is the
bound's own (it does not cover the damping that sits elsewhere)."""

_E = np.array([1.0, -1.0, 0.0])


def _pole(natural_freq: float, damping_ratio: float) -> complex:
    w = 2.0 * math.pi * float(natural_freq)
    z = float(damping_ratio)
    return complex(-z * w, w * math.sqrt(max(1.0 - z * z, 0.0)))


def bearing_impedance(natural_freq: float, damping_ratio: float, params: ModelParams,
                      k_MS: float | None = None) -> complex:
    """Complex bearing stiffness ``Z_TB(s)`` [N/m] that puts the 3DOF model's pole at ``s``.

    Parameters
    ----------
    natural_freq : float
        Identified ``|lambda| / 2 pi`` of the housing mode [Hz].
    damping_ratio : float
        Identified ``-Re(lambda) / |lambda|``, in [0, 1).
    params : ModelParams
        Rig parameters (undamped elsewhere).
    k_MS : float, optional
        Mounting stiffness [N/m]; default ``params.k_MS``.

    Returns
    -------
    complex
        ``Z_TB`` [N/m]; the real part near ``k_TB``, the imaginary part the damping.

    Raises
    ------
    InversionError
        When no finite bearing impedance puts the pole there (``k_TB+MS(s) = k_MS``).
    """
    s = _pole(natural_freq, damping_ratio)
    kms = params.k_MS if k_MS is None else float(k_MS)
    a = stiffness_matrix(params, 0.0).astype(complex) + s * s * mass_matrix(params)
    k_c = -1.0 / complex(_E @ np.linalg.solve(a, _E.astype(complex)))
    d = 1.0 / k_c - 1.0 / kms
    if d == 0 or not np.isfinite(d):
        raise InversionError(f"no finite bearing impedance for the pole at {natural_freq:.2f} Hz")
    return complex(1.0 / d)


def bearing_mode_phase(natural_freq: float, damping_ratio: float, params: ModelParams) -> float:
    """Phase [rad] of the spindle/housing amplitude ratio ``x_S / x_H`` of the 3DOF housing mode with
    all of its damping in the bearing.

    At the identified pole ``s`` the bearing + mounting element is ``k_TB+MS(s)``
    (:func:`bearing_impedance` in series with ``k_MS``); the mode shape solves
    ``(K0 + k_TB+MS(s) e e^T + s^2 M) x = 0`` with ``x_H = 1``. A proportionally damped mode is
    real (phase 0); a dashpot in the bearing alone, in series with ``k_MS``, makes it complex by
    about the bearing's loss angle times the spindle's share of the element's deflection.

    Parameters
    ----------
    natural_freq : float
        Identified ``|lambda| / 2 pi`` of the housing mode [Hz].
    damping_ratio : float
        Identified damping ratio.
    params : ModelParams
        Rig parameters.

    Returns
    -------
    float
        ``arg(x_S / x_H)`` [rad].

    Examples
    --------
    >>> from ema_rig.config import ModelParams
    >>> p = ModelParams(2.566, 2.8, 205.0, 114e6, 650e3, 348e6, 180e3)
    >>> round(math.degrees(bearing_mode_phase(626.0, 0.02, p)), 2)
    2.94
    """
    s = _pole(natural_freq, damping_ratio)
    k_c = 1.0 / (1.0 / bearing_impedance(natural_freq, damping_ratio, params) + 1.0 / params.k_MS)
    a = stiffness_matrix(params, 0.0).astype(complex) + k_c * np.outer(_E, _E) + s * s * mass_matrix(params)
    x = np.linalg.solve(a[1:, 1:], -a[1:, 0])
    return float(np.angle(x[0]))


def bearing_reading_freq(natural_freq: float, damping_ratio: float, params: ModelParams,
                         model: DampingModel = "viscous") -> float | None:
    """Housing frequency [Hz] whose undamped inversion gives the bearing's complex reading of a pole.

    ``k_TB`` of the pole read with its damping in the bearing (``_read``: the real part of
    ``Z_TB`` for ``model``), put back in series with ``k_MS`` and through the undamped 3DOF model
    (:func:`ema_rig.rig.inversion.housing_freq_from_k_tb_ms`), so that the stiffness budget, which
    inverts a frequency, carries it unchanged. ``damping_ratio = 0`` gives ``natural_freq``.

    Parameters
    ----------
    natural_freq : float
        ``|lambda| / 2 pi`` of the housing mode [Hz].
    damping_ratio : float
        The damping ratio read as the bearing's (a share of the identified one).
    params : ModelParams
        Rig parameters (``k_MS`` the one used for ``k_TB``).
    model : {'viscous', 'hysteretic'}
        Bearing damping model.

    Returns
    -------
    float or None
        None when the reading gives no positive stiffness.
    """
    k = _read(natural_freq, damping_ratio, params, model)[0]
    if not (math.isfinite(k) and k > 0):
        return None
    return float(housing_freq_from_k_tb_ms(series_stiffness(k, params.k_MS), params))


def bearing_damped_mass_factor(natural_freq: float, damping_ratio: float, params: ModelParams) -> float:
    """How much a modal fit's driving-point mass reads off at a pole damped by a bearing dashpot.

    A modal fit reads the effective modal mass ``1 / (2 w_d |R|)`` from the driving-point residue
    ``R`` (:func:`ema_rig.identification.modal.effective_mass`): exact for proportional damping. A
    dashpot in parallel with ``k_TB``, in series with ``k_MS``, is a frequency-dependent element
    ``Z(s)``; the residue ``1 / (d/ds 1/H)`` then carries ``Z'(s)``, which is not the damping the pole
    shows, and the mass reads low by O(zeta^2) (the 3DOF model, k_TB 9.4e7 N/m, zeta 11.7 %: -7.3 %; on
    the study's truths the identified mass was -7.1 %). The factor is that reading of the 3DOF model
    whose pole is at ``s`` with all of ``damping_ratio`` in the bearing (:func:`bearing_impedance`),
    over the undamped model's effective mass at ``|lambda|``: divide a measured mass by it.

    Parameters
    ----------
    natural_freq : float
        ``|lambda| / 2 pi`` [Hz] of the housing mode.
    damping_ratio : float
        The bearing's part of its damping ratio (the share read by the phase times the identified one).
    params : ModelParams
        Rig parameters.

    Returns
    -------
    float
        The factor (1 at zero damping); 1 where the reading is not defined (no finite impedance).

    Examples
    --------
    >>> from ema_rig.config import ModelParams
    >>> p = ModelParams(2.566, 2.8, 205.0, 114e6, 650e3, 348e6, 180e3)
    >>> round(bearing_damped_mass_factor(694.58, 0.1165, p), 3), bearing_damped_mass_factor(626.0, 0.0, p)
    (0.927, 1.0)
    """
    if not damping_ratio > 0:
        return 1.0
    try:
        k, c, _ = _read(natural_freq, damping_ratio, params, "viscous")
    except InversionError:
        return 1.0
    s = _pole(natural_freq, damping_ratio)
    k0, mm = stiffness_matrix(params, 0.0).astype(complex), mass_matrix(params)
    f0 = np.zeros(3, dtype=complex)
    f0[0] = 1.0

    def inv_h(x: complex) -> complex:  # 1 / driving-point receptance of the damped model at x
        z = 1.0 / (1.0 / (k + c * x) + 1.0 / params.k_MS)
        return 1.0 / complex(np.linalg.solve(k0 + z * np.outer(_E, _E) + x * x * mm, f0)[0])

    h = 1e-5 * abs(s)
    residue = 1.0 / ((inv_h(s + h) - inv_h(s - h)) / (2 * h))
    info = model_mode_at(params, natural_freq)
    if info is None or not (info.modal_mass > 0 and abs(residue) > 0):
        return 1.0
    return float(1.0 / (2.0 * s.imag * abs(residue)) / info.modal_mass)


def _read(natural_freq: float, damping_ratio: float, params: ModelParams, model: str) -> tuple[float, float, float]:
    """(k_TB [N/m], c_TB [N s/m], eta) of one reading of the pole."""
    z = bearing_impedance(natural_freq, damping_ratio, params)
    s = _pole(natural_freq, damping_ratio)
    if model == "viscous":
        c = z.imag / s.imag
        k = z.real - c * s.real
        w = abs(s)
        return k, c, c * w / k
    k = z.real
    eta = z.imag / z.real
    return k, eta * k / abs(s), eta


@dataclass(frozen=True, slots=True)
class BearingDamping:
    """Damping of the test bearing from the housing mode.

    Attributes
    ----------
    model : str
        ``'viscous'`` (dashpot in parallel with ``k_TB``) or ``'hysteretic'`` (``k_TB (1 + j eta)``).
    c_TB, c_TB_std : float
        Viscous damping coefficient [N s/m] and its standard uncertainty (for the hysteretic
        model the equivalent ``eta k_TB / w`` at the housing mode).
    loss_factor, loss_factor_std : float
        Loss factor ``eta`` (dimensionless) and its std (for the viscous model ``c_TB w / k_TB``).
    k_TB : float
        Bearing stiffness of this complex reading [N/m] (beside the headline ``k_TB``, which
        inverts the undamped frequency).
    c_TB_std_measured : float
        The part of ``c_TB_std`` from the identified frequency and damping ratio (and the
        bearing's measured share of it) [N s/m].
    kind : str
        ``'measured'`` (read with the bearing's measured share of the damping, ``c_TB_std``
        carrying the share's std) or ``'upper bound'`` (read with all of it; ``c_TB_std`` is the
        bound's own std and does not cover damping that sits elsewhere): :data:`C_TB_KINDS`.
    share, share_std : float or None
        The bearing's share of the housing mode's damping used and its std (None: the upper bound).
    c_TB_upper, c_TB_upper_std : float
        The upper bound (all of the damping in the bearing) [N s/m] and its own std: ``c_TB`` and
        ``c_TB_std`` where ``kind`` is ``'upper bound'``; NaN when not given.
    """

    model: str
    c_TB: float
    c_TB_std: float
    loss_factor: float
    loss_factor_std: float
    k_TB: float
    c_TB_std_measured: float
    kind: DampingKind = "upper bound"
    share: float | None = None
    share_std: float | None = None
    c_TB_upper: float = math.nan
    c_TB_upper_std: float = math.nan

    def to_dict(self) -> dict[str, Any]:
        """Plain dict for JSON (``c_TB``, ``c_TB_std``, ``c_TB_kind``, ``loss_factor``, ``loss_factor_std`` ...)."""
        return {"bearing_damping_model": self.model, "c_TB": self.c_TB, "c_TB_std": self.c_TB_std,
                "c_TB_std_measured": self.c_TB_std_measured, "c_TB_kind": self.kind,
                "c_TB_note": C_TB_KINDS[self.kind], "damping_share": self.share,
                "damping_share_std": self.share_std, "c_TB_upper": self.c_TB_upper,
                "c_TB_upper_std": self.c_TB_upper_std, "loss_factor": self.loss_factor,
                "loss_factor_std": self.loss_factor_std, "k_TB_complex": self.k_TB}


def c_tb_kind(row: Mapping[str, Any]) -> DampingKind:
    """``c_TB_kind`` of a result or campaign row: its own, else its ``detail``'s; one without any is
    from before the kind existed, when every ``c_TB`` was the upper bound.

    Parameters
    ----------
    row : mapping
        A stiffness JSON document or a campaign row (``c_TB_kind`` or ``detail['c_TB_kind']``).

    Returns
    -------
    {'measured', 'upper bound'}
    """
    kind = row.get("c_TB_kind") or (row.get("detail") or {}).get("c_TB_kind")
    return "measured" if kind == "measured" else "upper bound"


def c_tb_text(c_TB: float, c_TB_std: float, kind: DampingKind | str | None, *, upper: float | None = None,
              upper_std: float | None = None, pm: str = "+/-", unit: str = "N s/m") -> str:
    """``c_TB`` as one line of text, its kind said: the one label of the CLI, the report and the figures.

    Parameters
    ----------
    c_TB, c_TB_std : float
        Bearing damping [N s/m] and its std.
    kind : str or None
        ``BearingDamping.kind``; None (a result written before the kind existed) reads as an
        upper bound, which every ``c_TB`` was then.
    upper, upper_std : float, optional
        The upper bound and its own std beside a measured ``c_TB`` (``c_TB_upper``); not printed
        when missing or not finite.
    pm, unit : str
        Plus-minus sign and unit as the caller prints them.

    Returns
    -------
    str
        ``'c_TB 1020 +/- 213 N s/m (measured; upper bound 1121 +/- 21.3)'`` or ``'c_TB <= 1121
        N s/m (upper bound, the bound's own std 21.3)'``.

    Examples
    --------
    >>> c_tb_text(1121.4, 21.3, "upper bound")
    "c_TB <= 1121 N s/m (upper bound, the bound's own std 21.3)"
    >>> c_tb_text(1020.0, 213.0, "measured", upper=1121.4, upper_std=21.3)
    'c_TB 1020 +/- 213 N s/m (measured; upper bound 1121 +/- 21.3)'
    """
    if kind == "measured":
        bound = ""
        if upper is not None and upper_std is not None and math.isfinite(upper) and math.isfinite(upper_std):
            bound = f"; upper bound {upper:.4g} {pm} {upper_std:.3g}"
        return f"c_TB {c_TB:.4g} {pm} {c_TB_std:.3g} {unit} (measured{bound})"
    return f"c_TB <= {c_TB:.4g} {unit} (upper bound, the bound's own std {c_TB_std:.3g})"


def bearing_damping(
    natural_freq: float,
    damping_ratio: float,
    params: ModelParams,
    *,
    natural_freq_std: float = 0.0,
    damping_ratio_std: float = 0.0,
    rel_unc: Mapping[str, float] | None = None,
    model: DampingModel = "viscous",
    share: float | None = None,
    share_std: float = 0.0,
    share_model_std: float = 0.0,
) -> BearingDamping:
    """Bearing damping ``c_TB`` and loss factor with standard uncertainties.

    The stds propagate (linearised, central differences of relative step 1e-4, inputs
    uncorrelated) the identified ``natural_freq_std`` and ``damping_ratio_std`` (measured),
    the bearing's measured ``share_std`` (measured), its ``share_model_std`` (model form) and the
    relative tolerances of the model parameters in ``rel_unc`` (missing names: none).

    Without ``share`` the pole is read with all of its damping in the bearing: an upper bound
    (``kind`` ``'upper bound'``). With it, ``share * damping_ratio`` is the bearing's (the rest,
    proportional, leaves ``|lambda|`` alone; as :func:`bearing_reading_freq` reads ``k_TB``):
    ``kind`` ``'measured'``.

    Parameters
    ----------
    natural_freq : float
        Identified ``|lambda| / 2 pi`` of the housing mode [Hz].
    damping_ratio : float
        Its identified damping ratio.
    params : ModelParams
        Rig parameters (``k_MS`` the one used for ``k_TB``).
    natural_freq_std, damping_ratio_std : float
        Their measured standard uncertainties [Hz], [-].
    rel_unc : mapping, optional
        Relative standard uncertainty per model parameter name.
    model : {'viscous', 'hysteretic'}
        Bearing damping model.
    share : float, optional
        The bearing's measured share of the damping, in [0, 1]; None: all of it (upper bound).
    share_std : float
        Its standard uncertainty from the measurement (the phase's noise): in ``c_TB_std_measured``.
    share_model_std : float
        Its model-form standard uncertainty (where in its span the share lies,
        :class:`ema_rig.rig.uncertainty.DampingLocation`): in ``c_TB_std``, not in
        ``c_TB_std_measured``.

    Returns
    -------
    BearingDamping

    Raises
    ------
    ValueError
        For an unknown ``model`` or a ``share`` outside [0, 1].
    InversionError
        When the pole gives no finite bearing impedance.

    Examples
    --------
    >>> from ema_rig.config import ModelParams
    >>> p = ModelParams(2.566, 2.8, 205.0, 114e6, 650e3, 348e6, 180e3)
    >>> d = bearing_damping(626.0, 0.02, p)
    >>> round(d.c_TB), round(d.loss_factor, 4)
    (1393, 0.0768)
    """
    if model not in BEARING_DAMPING_MODELS:
        raise ValueError(f"model must be one of {BEARING_DAMPING_MODELS}, got {model!r}")
    if share is not None and not 0.0 <= share <= 1.0:
        raise ValueError(f"share must be in [0, 1], got {share!r}")
    phi = 1.0 if share is None else float(share)
    f, z = float(natural_freq), phi * float(damping_ratio)
    # d/d(share) of a reading at share * zeta is zeta d/d(zeta): the share's std is one more std of the
    # damping ratio read as the bearing's, independent of the identified one
    z_std = math.hypot(phi * float(damping_ratio_std), float(damping_ratio) * float(share_std if share is not None
                                                                                   else 0.0))
    k, c, eta = _read(f, z, params, model)
    h = 1e-4
    var_m = {"c": 0.0, "eta": 0.0}
    var_a = {"c": 0.0, "eta": 0.0}

    def add(var: dict[str, float], plus: tuple[float, float, float], minus: tuple[float, float, float],
            step: float, u: float) -> None:
        dc = (plus[1] - minus[1]) / (2 * step) * u
        de = (plus[2] - minus[2]) / (2 * step) * u
        var["c"] += dc * dc
        var["eta"] += de * de

    if natural_freq_std > 0:
        add(var_m, _read(f * (1 + h), z, params, model), _read(f * (1 - h), z, params, model), f * h,
            float(natural_freq_std))
    z_model_std = float(damping_ratio) * float(share_model_std if share is not None else 0.0)
    if z_std > 0 or z_model_std > 0:
        dz = max(z * h, 1e-7)
        lo = max(z - dz, 0.0)  # one-sided at zero damping
        plus_z, minus_z, step_z = _read(f, z + dz, params, model), _read(f, lo, params, model), (z + dz - lo) / 2
        if z_std > 0:
            add(var_m, plus_z, minus_z, step_z, z_std)
        if z_model_std > 0:
            add(var_a, plus_z, minus_z, step_z, z_model_std)
    for name, u in (rel_unc or {}).items():
        if name not in MODEL_KEYS or not u:
            continue
        v = float(getattr(params, name))
        plus = _read(f, z, replace(params, **{name: v * (1 + h)}), model)
        minus = _read(f, z, replace(params, **{name: v * (1 - h)}), model)
        add(var_a, plus, minus, h, float(u))  # relative step against relative tolerance
    c_std = math.sqrt(var_m["c"] + var_a["c"])
    upper, upper_std = c, c_std
    if share is not None:  # the all-in-the-bearing reading beside the measurement
        b = bearing_damping(natural_freq, damping_ratio, params, natural_freq_std=natural_freq_std,
                            damping_ratio_std=damping_ratio_std, rel_unc=rel_unc, model=model)
        upper, upper_std = b.c_TB, b.c_TB_std
    return BearingDamping(model=model, c_TB=float(c), c_TB_std=c_std, loss_factor=float(eta),
                          loss_factor_std=math.sqrt(var_m["eta"] + var_a["eta"]), k_TB=float(k),
                          c_TB_std_measured=math.sqrt(var_m["c"]),
                          kind="upper bound" if share is None else "measured", share=share,
                          share_std=None if share is None else math.hypot(share_std, share_model_std), c_TB_upper=float(upper),
                          c_TB_upper_std=float(upper_std))
