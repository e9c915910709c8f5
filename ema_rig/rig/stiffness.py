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

1. PolyMAX identification (:func:`ema_rig.identify.identify`) in the housing band (default the
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
    from ..identify import identify

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
def _freq_std(m: MatchResult) -> float:
    s = m.housing_mode.get("natural_freq_std")
    return 0.0 if s is None or not math.isfinite(s) else float(s)


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
    params = replace(rig.model, k_MS=kms)
    try:
        unc = stiffness_uncertainty(f_h, _freq_std(m), params, dict(rig.uncertainty), k_MS_std=k_ms_std)
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
    try:
        cal = calibrate_k_ms(f_d, rig.model, f_disk_std=_freq_std(m), k_disk=k_disk)
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
