"""The per-measurement stiffness pipeline: identify, match, invert (paper Sect. 4–5).

Functions
---------
estimate_stiffness
    FRFs of one measurement with the test bearing mounted -> ``k_TB`` with its uncertainty.
calibrate
    FRFs of a steel-disk measurement -> the mounting stiffness ``k_MS``.

Classes
-------
StiffnessResult, CalibrationResult
    Frozen results with ``to_dict()`` (the JSON of ``ema-rig stiffness`` / ``calibrate``,
    DESIGN §3.2).

Notes
-----
Steps of :func:`estimate_stiffness`:

1. PolyMAX identification (:func:`ema_rig.identification.identify`) in the housing band (default the
   rig file's ``[identification] band``, else 150–1000 Hz clipped to the data);
2. :func:`ema_rig.rig.matching.match_modes` picks the radial housing mode by shape and scale;
3. when the data reach it, a second identification in a band around the spindle bending mode
   the model predicts (±20 %), matched by shape (reported, not used for ``k_TB``);
4. :func:`ema_rig.rig.inversion.stiffness_uncertainty` inverts the housing frequency for
   ``k_TB`` and propagates the identified frequency spread, the rig parameter tolerances
   (``[uncertainty]`` of the rig file, defaults otherwise) and the ``k_MS`` std.

The uncertainty is a standard uncertainty (1 sigma); ``k_TB +- 2 k_TB_std`` is the ~95 %
interval under a normal assumption.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any

from ..config import RigConfig
from ..errors import EmaRigError, IdentificationError, InversionError
from ..frf import FRFData
from .matching import MatchResult, match_modes, model_mode_at

__all__ = ["CalibrationResult", "StiffnessResult", "calibrate", "estimate_stiffness", "default_band"]

logger = logging.getLogger(__name__)

DEFAULT_BAND: tuple[float, float] = (150.0, 1000.0)
"""Housing band [Hz] when neither the caller nor the rig file gives one (paper's rig: the
housing mode lies at 484–900 Hz for the dummy bearing ... steel disk)."""


def default_band(data: FRFData, rig: RigConfig, band: tuple[float, float] | None = None) -> tuple[float, float]:
    """The identification band: ``band``, else the rig file's, else 150–1000 Hz; clipped to the data.

    Raises
    ------
    IdentificationError
        If the band holds no data.
    """
    b = band if band is not None else rig.identification.get("band", DEFAULT_BAND)
    lo, hi = float(b[0]), float(b[1])
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo < hi):
        raise IdentificationError(f"band must satisfy 0 <= lo < hi (Hz), got {lo:g}..{hi:g}")
    flo, fhi = float(data.freq[0]), float(data.freq[-1])
    lo2, hi2 = max(lo, flo), min(hi, fhi)
    if hi2 <= lo2:
        raise IdentificationError(
            f"band {lo:g}..{hi:g} Hz lies outside the data ({flo:g}..{fhi:g} Hz)",
            file=_file_of(data),
        )
    return lo2, hi2


def _file_of(data: FRFData) -> str | None:
    """The measurement file of ``data``: ``meta['file']``, else ``meta['source']`` if it is a file."""
    from pathlib import Path

    v = data.meta.get("file")
    if isinstance(v, str) and v:
        return v
    v = data.meta.get("source")
    if isinstance(v, str) and v and Path(v).is_file():
        return v
    return None


def _identify(data: FRFData, band: tuple[float, float], max_order: int | None, progress: bool) -> Any:
    from ..identification import identify

    return identify(data, band=band, max_order=max_order, progress=progress)


def _max_order(rig: RigConfig, max_order: int | None) -> int | None:
    return max_order if max_order is not None else rig.identification.get("max_order")


def _identify_and_match(
    data: FRFData,
    rig: RigConfig,
    *,
    band: tuple[float, float] | None,
    max_order: int | None,
    speed_hz: float | None,
    spindle: bool,
    progress: bool,
    file: str | None,
) -> tuple[Any, Any, MatchResult, tuple[float, float], tuple[float, float] | None]:
    b = default_band(data, rig, band)
    mo = _max_order(rig, max_order)
    try:
        ident = _identify(data, b, mo, progress)
    except EmaRigError as exc:
        if exc.file is None and file is not None:
            exc.file = file
        raise
    m = match_modes(ident.modes, rig, natural_freq_std=ident.natural_freq_std, speed_hz=speed_hz, file=file)
    s_ident, s_band = None, None
    if spindle and m.spindle_mode is None:
        info = model_mode_at(rig.model, m.housing_mode["natural_freq"])
        if info is not None:
            lo, hi = 0.8 * info.spindle_freq, min(1.2 * info.spindle_freq, float(data.freq[-1]))
            # only worth it when the band reaches past the predicted mode and lies beyond the first
            if hi > info.spindle_freq * 1.02 and lo > b[1] * 0.5:
                s_band = (lo, hi)
                try:
                    s_ident = _identify(data, s_band, mo, progress)
                except EmaRigError as exc:
                    logger.info("spindle band %.0f-%.0f Hz not identified: %s", lo, hi, exc)
                    s_ident = None
                if s_ident is not None:
                    m = match_modes(
                        ident.modes, rig, natural_freq_std=ident.natural_freq_std, speed_hz=speed_hz,
                        spindle_modes=s_ident.modes, file=file,
                    )
    return ident, s_ident, m, b, s_band


# --------------------------------------------------------------------------- results
@dataclass(frozen=True, slots=True, eq=False)
class StiffnessResult:
    """Bearing stiffness of one measurement.

    Attributes
    ----------
    k_TB, k_TB_std : float
        Bearing stiffness and its standard uncertainty (1 sigma) [N/m].
    k_TB_MS, k_TB_MS_std : float
        Combined bearing + mounting stiffness and its std (terms other than k_MS) [N/m].
    k_MS, k_MS_std : float
        Mounting stiffness used and its std [N/m] (std None when the rig file's relative value
        or the default applies).
    housing_mode : dict
        ``natural_freq`` [Hz, ``|lambda|/2 pi``], ``damping_ratio``, ``natural_freq_std``,
        ``modal_mass`` ... of the matched housing mode.
    spindle_mode : dict or None
        ``natural_freq``, ``damping_ratio`` of the spindle bending mode, or None.
    uncertainty_budget : dict
        Variance share per input (``f_H`` and the model parameters); shares sum to 1.
    uncertainty : StiffnessUncertainty
        The full budget (sensitivities, input uncertainties).
    match : MatchResult
        Every candidate mode with the reason it was kept or rejected.
    identification, spindle_identification : Identification or None
        The PolyMAX results (stabilization, modal model) of the housing and the spindle band.
    band, spindle_band : tuple of float or None
        Identification bands [Hz].
    speed_hz : float or None
        Shaft speed used to reject harmonics [Hz].
    file : str or None
        Measurement file.
    fit : RigFit or None
        The 3DOF model fitted to the measured FRFs in 150–700 Hz (``fit=True``); reported
        beside, not used for, ``k_TB``.
    """

    k_TB: float
    k_TB_std: float
    k_TB_MS: float
    k_TB_MS_std: float
    k_MS: float
    k_MS_std: float | None
    housing_mode: dict[str, Any]
    spindle_mode: dict[str, Any] | None
    uncertainty_budget: dict[str, float]
    uncertainty: Any
    match: MatchResult
    identification: Any = field(default=None, repr=False)
    spindle_identification: Any = field(default=None, repr=False)
    band: tuple[float, float] | None = None
    spindle_band: tuple[float, float] | None = None
    speed_hz: float | None = None
    file: str | None = None
    fit: Any = field(default=None, repr=False)

    @property
    def candidates(self) -> list[dict[str, Any]]:
        """Every mode considered by the matching, with metrics and reason."""
        return self.match.candidates

    def interval(self, coverage: float = 0.95) -> tuple[float, float]:
        """Two-sided interval ``k_TB +- z sigma`` [N/m] for a normal ``coverage`` (0.95 -> z = 1.96)."""
        from scipy.stats import norm

        z = float(norm.ppf(0.5 + coverage / 2))
        return self.k_TB - z * self.k_TB_std, self.k_TB + z * self.k_TB_std

    def to_dict(self) -> dict[str, Any]:
        """JSON of ``ema-rig stiffness`` (DESIGN §3.2 keys plus the budget and candidates)."""
        return {
            "file": self.file,
            "k_TB": self.k_TB,
            "k_TB_std": self.k_TB_std,
            "k_TB_MS": self.k_TB_MS,
            "k_TB_MS_std": self.k_TB_MS_std,
            "k_MS": self.k_MS,
            "k_MS_std": self.k_MS_std,
            "housing_mode": dict(self.housing_mode),
            "spindle_mode": None if self.spindle_mode is None else dict(self.spindle_mode),
            "uncertainty_budget": dict(self.uncertainty_budget),
            "uncertainty_terms": self.uncertainty.to_records(),
            "band": None if self.band is None else list(self.band),
            "spindle_band": None if self.spindle_band is None else list(self.spindle_band),
            "speed_hz": self.speed_hz,
            "candidates": [dict(c) for c in self.match.candidates],
            "fit": None if self.fit is None else self.fit.to_dict(),
        }


@dataclass(frozen=True, slots=True, eq=False)
class CalibrationResult:
    """Mounting stiffness from a steel-disk measurement.

    Attributes
    ----------
    k_MS, k_MS_std : float
        Mounting stiffness and its standard uncertainty from the frequency spread [N/m].
    k_TB_MS : float
        Combined stiffness from the disk frequency [N/m].
    k_disk : float or None
        Disk stiffness put in series [N/m] (None: rigid disk, the paper's assumption).
    housing_mode : dict
        The matched housing mode with the disk (``natural_freq``, ``damping_ratio``, ...).
    calibration : KmsCalibration
    match : MatchResult
    identification : Identification
    band : tuple of float
    file : str or None
    """

    k_MS: float
    k_MS_std: float
    k_TB_MS: float
    k_disk: float | None
    housing_mode: dict[str, Any]
    calibration: Any
    match: MatchResult
    identification: Any = field(default=None, repr=False)
    band: tuple[float, float] | None = None
    file: str | None = None

    @property
    def candidates(self) -> list[dict[str, Any]]:
        """Every mode considered by the matching."""
        return self.match.candidates

    def to_dict(self) -> dict[str, Any]:
        """JSON of ``ema-rig calibrate`` (DESIGN §3.2: ``k_MS``, ``k_MS_std``, ``housing_mode``)."""
        return {
            "file": self.file,
            "k_MS": self.k_MS,
            "k_MS_std": self.k_MS_std,
            "k_TB_MS": self.k_TB_MS,
            "k_disk": self.k_disk,
            "housing_mode": dict(self.housing_mode),
            "spindle_mode": None if self.match.spindle_mode is None else dict(self.match.spindle_mode),
            "band": None if self.band is None else list(self.band),
            "candidates": [dict(c) for c in self.match.candidates],
        }


# --------------------------------------------------------------------------- pipeline
def _combine_freq_std(data: FRFData, ident: Any, m: MatchResult, rig: RigConfig) -> tuple[float, MatchResult]:
    """Standard uncertainty of the housing frequency [Hz] and the match with it recorded.

    ``sqrt(s_cluster^2 + s_noise^2)``: the spread of the housing mode's stable poles across model
    orders (from the identification) and the statistical std from the FRF noise
    (:func:`local_freq_std`). On simulated data with 1-2 % noise the cluster spread dominates and
    is conservative (it exceeds the actual scatter of the estimate several times).
    """
    s = m.housing_mode.get("natural_freq_std")
    s_cluster = 0.0 if s is None or not math.isfinite(s) else float(s)
    try:
        s_noise = local_freq_std(data, ident.modes, m.housing_index, rig)
    except (ValueError, IndexError, KeyError, ArithmeticError) as exc:  # pragma: no cover - defensive
        logger.info("local frequency std not computed: %s", exc)
        s_noise = 0.0
    from dataclasses import replace

    total = math.hypot(s_cluster, s_noise)
    hm = dict(m.housing_mode, natural_freq_std=total, natural_freq_std_cluster=s_cluster,
              natural_freq_std_noise=s_noise)
    return total, replace(m, housing_mode=hm)


def local_freq_std(data: FRFData, modes: Any, index: int, rig: RigConfig, *, width: float = 3.0) -> float:
    """Statistical standard uncertainty [Hz] of one mode's natural frequency from the FRF noise.

    A local Gauss-Newton linearisation around the identified mode: the other modes of ``modes``
    are subtracted from the data; in ``f_n (1 +- width * 2 zeta)`` the radial housing and spindle
    channels of the radial reference are modelled by the mode (pole and one residue per channel)
    plus a constant per channel. With relative noise (weights ``1/|H|``) estimated per channel
    from the residual, the covariance ``s^2 (J^T J)^-1`` gives the std of ``|lambda| / 2 pi``.

    Parameters
    ----------
    data : FRFData
        The measurement.
    modes : ModalModel
        Identified modes (from the same data).
    index : int
        The mode of interest.
    rig : RigConfig
        Sensor roles/axes and the radial reference.
    width : float, optional
        Half-width of the local band in half-power bandwidths (default 3).

    Returns
    -------
    float
        Standard uncertainty [Hz]; 0.0 when it cannot be computed (too few lines, no channel).
    """
    import numpy as np

    lam = complex(modes.poles[index])
    fn = abs(lam) / (2 * np.pi)
    z = max(-lam.real / abs(lam), 1e-4)
    half = max(width * 2 * z * fn, 2.5 * (data.freq[1] - data.freq[0]) if data.n_freq > 1 else 0.0)
    sel = (data.freq >= fn - half) & (data.freq <= fn + half) & (data.freq > 0)
    ref = rig.radial.positive()
    q = next((j for j, d in enumerate(data.in_dofs) if d.positive() == ref), None)
    rows = [i for i in range(data.n_out) if data.axes[i] == "radial" and data.roles[i] in ("housing", "spindle")]
    if q is None or not rows or sel.sum() < 6:
        return 0.0
    f = data.freq[sel]
    jw = 1j * 2 * np.pi * f
    power = {"receptance": 0, "mobility": 1, "accelerance": 2}[data.frf_form]
    others = [r for r in range(modes.n_modes) if r != index]
    # data minus the other modes (receptance form of the identified model, then back to the form)
    h_meas = data.frf[rows][:, q][:, sel]
    if others:
        lo_ = modes.poles[others]
        res_o = modes.residues[others][:, :, :]
        p_idx = [modes.out_dofs.index(data.out_dofs[i]) if data.out_dofs[i] in modes.out_dofs else -1 for i in rows]
        q_m = next((j for j, d in enumerate(modes.in_dofs) if d.positive() == ref), None)
        if q_m is None or min(p_idx) < 0:
            return 0.0
        ro = res_o[:, p_idx, q_m]  # (n_others, n_rows)
        h_o = (ro.T[:, :, None] / (jw[None, None, :] - lo_[None, :, None])
               + ro.conj().T[:, :, None] / (jw[None, None, :] - lo_.conj()[None, :, None])).sum(axis=1)
        h_meas = h_meas - h_o * jw**power
    a = 1.0 / (jw - lam)
    b = 1.0 / (jw - np.conj(lam))
    g = jw**power
    n_r, n_f = len(rows), f.size
    # linear least squares for residue (complex) and constant (complex) per channel at the pole
    jac_cols = []
    resid = []
    for k in range(n_r):
        h = h_meas[k]
        # real unknowns: Re R, Im R, Re c, Im c;  model = g (R a + R* b) + c
        cols = [g * (a + b), 1j * g * (a - b), np.ones(n_f), 1j * np.ones(n_f)]
        A = np.stack(cols, axis=1)
        Ar = np.vstack([A.real, A.imag])
        x, *_ = np.linalg.lstsq(Ar, np.concatenate([h.real, h.imag]), rcond=None)
        r_c = x[0] + 1j * x[1]
        model = A @ x
        w = 1.0 / np.maximum(np.abs(model), 1e-300)
        resid.append((h - model) * w)
        # derivatives with respect to sigma = Re(lam) and wd = Im(lam)
        da = a**2  # d a / d lam
        db = b**2  # d b / d conj(lam)
        d_sigma = g * (r_c * da + np.conj(r_c) * db)
        d_wd = g * (1j * r_c * da - 1j * np.conj(r_c) * db)
        jac_cols.append((A, d_sigma, d_wd, w))
    # assemble the full real Jacobian: [sigma, wd, (4 per channel)]
    n_p = 2 + 4 * n_r
    J = np.zeros((2 * n_r * n_f, n_p))
    sig2 = []
    for k, (A, ds, dw, w) in enumerate(jac_cols):
        r0, r1 = 2 * k * n_f, 2 * (k + 1) * n_f
        blk = np.zeros((n_f, n_p), dtype=complex)
        blk[:, 0] = ds * w
        blk[:, 1] = dw * w
        blk[:, 2 + 4 * k: 6 + 4 * k] = A * w[:, None]
        J[r0:r1] = np.vstack([blk.real, blk.imag])
        rk = resid[k]
        dof = max(2 * n_f - 4 - 2.0 / n_r, 1.0)
        sig2.append(float(np.sum(rk.real**2 + rk.imag**2)) / dof)
    # weight each channel by its own noise level
    for k in range(n_r):
        J[2 * k * n_f: 2 * (k + 1) * n_f] /= math.sqrt(max(sig2[k], 1e-300))
    try:
        cov = np.linalg.pinv(J.T @ J)
    except np.linalg.LinAlgError:
        return 0.0
    grad = np.zeros(n_p)
    grad[0], grad[1] = lam.real / abs(lam), lam.imag / abs(lam)
    var = float(grad @ cov[:, :] @ grad)
    return math.sqrt(max(var, 0.0)) / (2 * math.pi)


def estimate_stiffness(
    data: FRFData,
    rig: RigConfig,
    *,
    k_ms: float | None = None,
    k_ms_std: float | None = None,
    speed_hz: float | None = None,
    band: tuple[float, float] | None = None,
    max_order: int | None = None,
    spindle: bool = True,
    fit: bool = False,
    progress: bool = False,
) -> StiffnessResult:
    """Bearing stiffness ``k_TB`` of one measurement, with its uncertainty.

    Parameters
    ----------
    data : FRFData
        FRFs of the eight sensors for the radial (and optionally axial) shaker, with sensor roles
        and axes (``read_uff58(path, rig=rig)``).
    rig : RigConfig
        Rig model parameters, sensors, uncertainty and identification defaults.
    k_ms : float, optional
        Mounting stiffness [N/m] from a steel-disk calibration; default ``rig.model.k_MS``.
    k_ms_std : float, optional
        Its standard uncertainty [N/m]; default the rig file's relative ``k_MS`` uncertainty.
    speed_hz : float, optional
        Shaft speed [Hz] when the bearing rotates (harmonic lines are rejected).
    band : (float, float), optional
        Housing identification band [Hz]; default the rig file's, else 150–1000 Hz.
    max_order : int, optional
        Maximum model order of PolyMAX; default the rig file's / the identifier's.
    spindle : bool, optional
        Also identify the spindle bending mode in its own band when the data reach it
        (default True; costs a second identification).
    fit : bool, optional
        Also fit ``k_TB+MS``, ``k_S``, ``m_S``, ``m_F`` and the housing damping to the measured
        driving-point and spindle FRFs in 150–700 Hz (paper Sect. 4, Fig. 7; default False).
    progress : bool, optional
        Progress bar of the identification.

    Returns
    -------
    StiffnessResult

    Raises
    ------
    IdentificationError
        No stable pole in the band, bad band.
    MatchingError
        No identified mode is the radial housing mode (the error lists every candidate).
    InversionError
        The housing frequency gives no positive ``k_TB`` (outside the valid range, or above the
        mode with a rigid bearing for this ``k_MS``).
    """
    from dataclasses import replace

    from .inversion import stiffness_uncertainty

    file = _file_of(data)
    kms = rig.model.k_MS if k_ms is None else float(k_ms)
    if not (math.isfinite(kms) and kms > 0):
        raise InversionError(f"k_MS must be a finite positive stiffness [N/m], got {k_ms!r}", file=file)
    if k_ms_std is not None and not (math.isfinite(k_ms_std) and k_ms_std >= 0):
        raise InversionError(f"k_MS std must be finite and >= 0 [N/m], got {k_ms_std!r}", file=file)
    ident, s_ident, m, b, s_band = _identify_and_match(
        data, rig, band=band, max_order=max_order, speed_hz=speed_hz, spindle=spindle,
        progress=progress, file=file,
    )
    f_h = float(m.housing_mode["natural_freq"])
    f_std, m = _combine_freq_std(data, ident, m, rig)
    params = replace(rig.model, k_MS=kms)
    try:
        unc = stiffness_uncertainty(f_h, f_std, params, dict(rig.uncertainty), k_MS_std=k_ms_std)
    except InversionError as exc:
        exc.file = exc.file or file
        raise
    k_tb = float(unc.k_TB)
    if not (math.isfinite(k_tb) and k_tb > 0):  # pragma: no cover - guarded by the inversion
        raise InversionError(f"no positive bearing stiffness from {f_h:.2f} Hz", file=file)
    budget = {t.name: float(t.share) for t in unc.terms}
    rig_fit = _fit(data, rig, params, m) if fit else None
    return StiffnessResult(
        k_TB=k_tb,
        k_TB_std=float(unc.k_TB_std),
        k_TB_MS=float(unc.k_TB_MS),
        k_TB_MS_std=float(unc.k_TB_MS_std),
        k_MS=kms,
        k_MS_std=None if k_ms_std is None else float(k_ms_std),
        housing_mode=dict(m.housing_mode),
        spindle_mode=None if m.spindle_mode is None else dict(m.spindle_mode),
        uncertainty_budget=budget,
        uncertainty=unc,
        match=m,
        identification=ident,
        spindle_identification=s_ident,
        band=b,
        spindle_band=s_band,
        speed_hz=speed_hz,
        file=file,
        fit=rig_fit,
    )


def _fit(data: FRFData, rig: RigConfig, params: Any, m: MatchResult) -> Any:
    """Fit the 3DOF model to the radial driving-point and mean spindle FRFs (150–700 Hz)."""
    from .inversion import fit_rig

    ref = rig.radial.positive()
    q = next((j for j, d in enumerate(data.in_dofs) if d.positive() == ref), None)
    p = next((i for i, d in enumerate(data.out_dofs) if d.positive() == ref), None)
    if q is None or p is None:
        return None
    s_idx = [i for i in range(data.n_out) if data.roles[i] == "spindle" and data.axes[i] == "radial"]
    h_s = data.frf[s_idx, q].mean(axis=0) if s_idx else None
    sm = m.spindle_mode
    z_s = float(sm["damping_ratio"]) if sm else 0.01
    try:
        return fit_rig(
            data.freq, data.frf[p, q], h_s, params,
            f_housing=float(m.housing_mode["natural_freq"]),
            damping_ratio=[0.03, float(m.housing_mode["damping_ratio"]), z_s],
            frf_form=data.frf_form,
            spindle_freq=None if sm is None else float(sm["natural_freq"]),
        )
    except ValueError as exc:
        logger.info("model fit skipped: %s", exc)
        return None


def calibrate(
    data: FRFData,
    rig: RigConfig,
    *,
    k_disk: float | None = None,
    band: tuple[float, float] | None = None,
    max_order: int | None = None,
    progress: bool = False,
) -> CalibrationResult:
    """Mounting stiffness ``k_MS`` from a steel-disk measurement (paper Sect. 4).

    The housing mode with the disk (~897 Hz on the paper's rig) is inverted for ``k_TB+MS``; the
    disk is rigid (``k_MS = k_TB+MS``, the paper's assumption) unless ``k_disk`` is given.

    Parameters
    ----------
    data : FRFData
        FRFs of the steel-disk measurement.
    rig : RigConfig
        Rig parameters (their ``k_MS`` is not used).
    k_disk : float, optional
        Finite disk stiffness [N/m], in series.
    band : (float, float), optional
        Identification band [Hz]; default the rig file's ``k_MS_band``, else its ``band``, else
        150–1000 Hz.
    max_order : int, optional
        PolyMAX maximum order.
    progress : bool, optional
        Progress bar of the identification.

    Returns
    -------
    CalibrationResult

    Raises
    ------
    IdentificationError, MatchingError, InversionError
    """
    from .inversion import calibrate_k_ms

    file = _file_of(data)
    if band is None:
        band = rig.identification.get("k_MS_band")
    ident, _, m, b, _ = _identify_and_match(
        data, rig, band=band, max_order=max_order, speed_hz=None, spindle=False,
        progress=progress, file=file,
    )
    f_d = float(m.housing_mode["natural_freq"])
    f_std, m = _combine_freq_std(data, ident, m, rig)
    try:
        cal = calibrate_k_ms(f_d, rig.model, f_disk_std=f_std, k_disk=k_disk)
    except InversionError as exc:
        exc.file = exc.file or file
        raise
    return CalibrationResult(
        k_MS=float(cal.k_MS),
        k_MS_std=float(cal.k_MS_std),
        k_TB_MS=float(cal.k_TB_MS),
        k_disk=None if k_disk is None else float(k_disk),
        housing_mode=dict(m.housing_mode),
        calibration=cal,
        match=m,
        identification=ident,
        band=b,
        file=file,
    )
