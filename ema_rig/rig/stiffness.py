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
4. :func:`ema_rig.rig.uncertainty.assess_housing_mode` decides which frequency to invert and which model-form terms
   and warnings the result carries (the rule below);
5. :func:`ema_rig.rig.uncertainty.stiffness_uncertainty` inverts it for ``k_TB`` and propagates
   the identified frequency std (``'measured'``: the mode's ``natural_freq_std`` from the
   identification), the rig parameter tolerances (``'assumed (rig file)'``, or
   ``'assumed (default)'`` with a note when the rig file has no ``[uncertainty]`` entry), the
   ``k_MS`` std, and the model-form terms.

The uncertainty is a standard uncertainty (1 sigma); ``k_TB +- 2 k_TB_std`` is the ~95 %
interval under a normal assumption. ``k_TB_std_measured`` holds the terms the data measured: the
identified frequency, and ``m_H`` where the inversion used the measured housing mass.

The rule
--------
**A k_TB reported without a warning lies within 2 k_TB_std of the truth.** Ambiguity is never
resolved silently; it is either covered by a stated model-form term *and* a warning, or refused:

* no radial driving-point FRF: the effective modal mass comes from the radial housing transfer
  FRFs (rigid housing); warning; refused with that reason when no mode qualifies;
* several modes pass the housing criteria: warning and a term covering them; refused when they
  lie more than :data:`MAX_ALTERNATIVE_SPREAD` apart;
* a mode with radial housing motion within a few half-power bandwidths: warning and a coupling
  term; when the housing mode lacks participation that in-phase, housing-like partners carry
  (a split housing mass: an appendage, a load arm), the uncoupled frequency is recovered from
  the group's driving-point compliance and the result placed between both readings;
* effective modal mass off the model's by more than 10 %: warning and a term ``|ln r| / 4``;
* the housing mode on lines coarse against its half-power band (under
  ``MatchCriteria.min_bandwidth_resolutions`` Hann resolution bandwidths): the driving-point mass's std
  carries the resolution bias, and where a pole lies inside one resolution bandwidth or the mass is off,
  a warning names the leakage and the line spacing that resolves the mode;
* a ``k_TB`` whose 2-sigma interval reaches 0 (:data:`~ema_rig.rig.uncertainty.UNRESOLVED_SIGMAS`): warning
  that the measurement does not resolve it (a bearing far stiffer than the mounting system);
* damping: the declared model (viscous default) gives the undamped frequency; the
  viscous/hysteretic difference is always in the budget (no warning);
* issue 19, what the measured evidence resolves (notes, terms; warnings only where it cannot):
  the driving-point modal mass measured with its std (:mod:`ema_rig.rig.fit`) against the
  model's — bounding close neighbours, measuring ``m_H`` (with a second, force-chain-free
  measurement from the housing mode's spindle/housing ratio), a warning naming both masses
  outside the tolerance; a cross-axis coupled partner
  (two-mode reduction); two modes sharing the housing's radial motion (the 4DOF split-housing
  fit). The plain 3DOF inversion is kept beside the result (``inversion_3dof``); the bearing's
  damping ``c_TB``/loss factor (measured with the bearing's share of the housing mode's damping
  where its spindle/housing phase gives one, else the all-in-the-bearing upper bound, said so:
  ``c_TB_kind``) and the housing's axial and cross stiffness are reported with stds;
* calibration with the disk assumed rigid: a model-form term of 5.8 % in ``k_MS_std`` (note).

Refusals are one line (at most 300 characters) naming the likely cause (polarity of a named
sensor, units, missing driving point); every candidate with its metrics is in the JSON.
"""

from __future__ import annotations

import logging
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from .._text import std_text
from ..config import RigConfig
from ..errors import EmaRigError, IdentificationError, InversionError, band_error
from ..frf import FRFData
from ..identification import Identification, Selection, identify
from ..literals import DampingModel
from .candidates import find_dof, harmonic_bands
from .damping import BearingDamping, bearing_damping
from .fit import HousingMass, HousingRigidBody, housing_rigid_body, housing_tilt
from .inversion import (
    DISK_STIFFNESS_RATIO,
    KmsCalibration,
    RigFit,
    calibrate_k_ms,
    fit_rig,
    k_tb_from_housing_freq,
    model_mode_at,
)
from .matched_mode import MatchedMode
from .matching import MATCH_CRITERIA, MatchResult, match_modes
from .uncertainty import (
    DEFAULT_REL_UNCERTAINTY,
    MASS_WARN_RATIO,
    StiffnessUncertainty,
    assess_housing_mode,
    calibration_parameter_std,
    defaults_note,
    measured_freq_std,
    stiffness_uncertainty,
    unresolved_warning,
)

__all__ = [
    "CalibrationResult",
    "StiffnessResult",
    "calibrate",
    "default_band",
    "estimate_stiffness",
    "mode_source",
]

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
        raise band_error(lo, hi, flo, fhi, file=_file_of(data))
    return lo2, hi2


def _file_of(data: FRFData) -> str | None:
    """The measurement file of ``data``: ``meta['file']``, else ``meta['source']`` if it is a file.

    The first look of :func:`estimate_stiffness` and :func:`calibrate` at their data: anything but
    an :class:`FRFData` (e.g. the file's path) is a ``TypeError`` that says how to read it.
    """
    if not isinstance(data, FRFData):
        raise TypeError(f"data must be an FRFData (read the file with read_uff58(path, rig=rig)), "
                        f"got {type(data).__name__}")
    v = data.meta.get("file")
    if isinstance(v, str) and v:
        return v
    v = data.meta.get("source")
    if isinstance(v, str) and v and Path(v).is_file():
        return v
    return None


def _identify(data: FRFData, band: tuple[float, float], max_order: int | None, progress: bool,
              rig: RigConfig, speed_hz: float | None = None) -> Any:
    """PolyMAX (and, when the rig file's ``[identification] refine`` is true, the ML refinement).

    With the shaft speed ``speed_hz`` [Hz] the lines matching calls harmonics
    (:func:`~ema_rig.rig.candidates.harmonic_bands` with :data:`MATCH_CRITERIA`) are left out of the
    split test's own-lines test (``identify(harmonic_bands=...)``).
    """
    cfg = rig.identification
    if cfg.get("n_averages") is not None:
        data = data.replace(n_averages=float(cfg["n_averages"]))
    c = MATCH_CRITERIA
    harmonics = (() if speed_hz is None
                 else harmonic_bands(band, speed_hz, c.harmonic_freq_tol, c.harmonic_min_order, c.harmonic_max_chance))
    return identify(data, band=band, max_order=max_order, progress=progress, refine=bool(cfg.get("refine", False)),
                    harmonic_bands=harmonics)


def _max_order(rig: RigConfig, max_order: int | None) -> int | None:
    return max_order if max_order is not None else rig.identification.get("max_order")


def _mode_with_std(mode: MatchedMode, ident: Any, index: int | None) -> MatchedMode:
    """The matched mode with the identification's ``natural_freq_std`` and ``damping_ratio_std``."""
    out: dict[str, float] = {}
    for key in ("natural_freq_std", "damping_ratio_std"):
        arr = getattr(ident, key, None)
        if mode.get(key) is None and arr is not None and index is not None and 0 <= index < len(arr):
            out[key] = float(arr[index])
    return mode.with_entries(**out)


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
    ident: Any = None,
) -> tuple[Any, Any, MatchResult, tuple[float, float], tuple[float, float] | None]:
    mo = _max_order(rig, max_order)
    if ident is not None:  # the caller's modes (a pick, a replayed selection)
        b = (float(ident.band[0]), float(ident.band[1]))
    else:
        b = default_band(data, rig, band)
        try:
            ident = _identify(data, b, mo, progress, rig, speed_hz)
        except EmaRigError as exc:
            if exc.file is None and file is not None:
                exc.file = file
            raise
    m = match_modes(ident.modes, rig, natural_freq_std=ident.natural_freq_std, speed_hz=speed_hz, file=file)
    s_ident, s_band = None, None
    if spindle and m.spindle_mode is None:
        info = model_mode_at(rig.model, m.housing_mode["natural_freq"])
        if info is not None:
            c = MATCH_CRITERIA
            lo = (1.0 - c.spindle_freq_tol) * info.spindle_freq
            hi = min((1.0 + c.spindle_freq_tol) * info.spindle_freq, float(data.freq[-1]))
            # only worth it when the band reaches past the predicted mode and lies beyond the first
            if hi > info.spindle_freq * (1.0 + c.spindle_search_margin) and lo > b[1] * c.spindle_search_min_fraction:
                s_band = (lo, hi)
                try:
                    s_ident = _identify(data, s_band, mo, progress, rig, speed_hz)
                except EmaRigError as exc:
                    logger.info("spindle band %.0f-%.0f Hz not identified: %s", lo, hi, exc)
                    s_ident = None
                if s_ident is not None:
                    m = match_modes(
                        ident.modes, rig, natural_freq_std=ident.natural_freq_std, speed_hz=speed_hz,
                        spindle_modes=s_ident.modes, file=file,
                    )
    return ident, s_ident, m, b, s_band


#: What ``StiffnessResult.mode_source`` says for each provenance of the housing mode's selection.
MODE_SOURCES: dict[str, str] = {"auto": "replay", "manual": "pick", "near": "replay", "tracked": "tracked replay"}


def mode_source(ident: Any, natural_freq: float) -> str:
    """Where the mode at ``natural_freq`` [Hz] of a given identification came from.

    ``"pick"`` (picked by hand on these data), ``"replay"`` (a saved selection found again, exactly
    or within the replay window) or ``"tracked replay"`` (a saved mode matched by frequency order
    only: check it on the chart); the selected mode nearest in frequency decides.
    """
    modes = getattr(getattr(ident, "selection", None), "modes", ())
    if not modes:
        return "replay"
    best = min(modes, key=lambda sm: abs(sm.natural_freq - natural_freq))
    return MODE_SOURCES.get(best.provenance, "replay")


def _speed_hz(speed_hz: float | None, speed_rpm: float | None, file: str | None) -> float | None:
    """The shaft speed [Hz] from ``speed_hz`` or ``speed_rpm`` (not both)."""
    if speed_rpm is None:
        return speed_hz
    if speed_hz is not None:
        raise ValueError("give speed_hz or speed_rpm, not both")
    if not (math.isfinite(speed_rpm) and speed_rpm >= 0):
        raise InversionError(f"speed_rpm must be finite and >= 0 [rpm], got {speed_rpm!r}", file=file)
    return speed_rpm / 60.0 if speed_rpm > 0 else None


def _given_identification(data: FRFData, rig: RigConfig, identification: Any, selection: Any,
                          band: tuple[float, float] | None, max_order: int | None, progress: bool,
                          file: str | None) -> Any:
    """The identification the caller gave, or ``selection`` replayed on ``data``; None for automatic."""
    if identification is not None and selection is not None:
        raise ValueError("give identification or selection, not both")
    if identification is not None:
        if not hasattr(identification, "modes") or not hasattr(identification, "band"):
            raise TypeError(f"identification must be an Identification, got {type(identification).__name__}")
        return identification
    if selection is None:
        return None

    if hasattr(selection, "modes") and hasattr(selection, "stabilization"):  # an Identification
        raise TypeError("selection must be a Selection or the path of its JSON file; "
                        "give an Identification as identification=")
    if not isinstance(selection, Selection):
        selection = Selection.from_json(selection)  # a path; a bad file raises naming it
    cfg = rig.identification
    if cfg.get("n_averages") is not None:
        data = data.replace(n_averages=float(cfg["n_averages"]))
    try:
        return identify(data, band=band, max_order=max_order, selection=selection, progress=progress,
                        refine=bool(cfg.get("refine", False)))
    except EmaRigError as exc:
        exc.file = exc.file or file
        raise


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
    housing_mode : MatchedMode
        ``natural_freq`` [Hz, ``|lambda|/2 pi``], ``damping_ratio``, ``natural_freq_std``,
        ``modal_mass`` ... of the matched housing mode (typed; also read as a mapping).
    spindle_mode : MatchedMode or None
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
    k_TB_std_measured : float
        The part of ``k_TB_std`` from the terms of kind ``'measured'`` [N/m]: the identified
        housing frequency, and ``m_H`` where the measured housing mass was used
        (``housing_mass.source == 'measured'``); ``k_TB_std`` adds the rig-file tolerances and
        model-form terms.
    inverted_freq : float
        The frequency inverted [Hz]: the undamped frequency for ``damping_model`` (and, with
        coupled neighbours, the recovered uncoupled one); ``housing_mode['natural_freq']`` stays
        the identified ``|lambda| / 2 pi``.
    damping_model : str
        Declared damping model (``'viscous'`` or ``'hysteretic'``).
    warnings : tuple of str
        One-line caveats; without any, ``k_TB`` lies within 2 ``k_TB_std`` of the truth.
    notes : tuple of str
        One-line information that is not a caveat (default tolerances applied).
    mode_source : str
        Where the housing mode came from: ``"auto"`` (automatic identification), ``"pick"``,
        ``"replay"`` or ``"tracked replay"`` (see :func:`mode_source`).
    damping : BearingDamping or None
        The bearing's damping ``c_TB`` [N s/m] and loss factor from the housing pole
        (:func:`ema_rig.rig.damping.bearing_damping`, model ``damping_model``): read with the
        bearing's measured share of the damping where the assessment's damping location gives
        one (``kind`` ``'measured'``), else with all of it (``'upper bound'``); None when the
        pole gives no finite bearing impedance.
    inversion_3dof : dict or None
        The plain 3DOF inversion for comparison: ``freq`` [Hz] (the identified undamped
        frequency) and ``k_TB`` [N/m] with the rig file's ``m_H``, without the corrections the
        measured evidence made (cross-axis coupling, appendage, measured ``m_H``); None when that
        frequency is outside the model's range.
    rigid_body : HousingRigidBody or None
        Axial and cross stiffness of the housing on its bearing with stds, or why not
        (:func:`ema_rig.rig.fit.housing_rigid_body`).
    housing_mass : HousingMass or None
        ``m_H`` measured from the driving-point modal mass with its std, the rig file's, and which
        the inversion used (:class:`ema_rig.rig.fit.HousingMass`); None without a clean housing
        mode at a radial driving point.
    damping_partners : tuple of int
        Indices (in ``identification.modes``) of the modes whose damping ``c_TB`` reads together with
        the housing mode's (their damping trace): the strongly mixed pair's partner, or the modes
        sharing the radial housing motion; empty where the housing mode is read alone.
    """

    k_TB: float
    k_TB_std: float
    k_TB_MS: float
    k_TB_MS_std: float
    k_MS: float
    k_MS_std: float | None
    housing_mode: MatchedMode
    spindle_mode: MatchedMode | None
    uncertainty_budget: dict[str, float]
    uncertainty: StiffnessUncertainty
    match: MatchResult
    identification: Identification | None = field(default=None, repr=False)
    spindle_identification: Identification | None = field(default=None, repr=False)
    band: tuple[float, float] | None = None
    spindle_band: tuple[float, float] | None = None
    speed_hz: float | None = None
    file: str | None = None
    fit: RigFit | None = field(default=None, repr=False)
    k_TB_std_measured: float = 0.0
    inverted_freq: float = math.nan
    damping_model: DampingModel = "viscous"
    warnings: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    damping: BearingDamping | None = None
    inversion_3dof: dict[str, float] | None = None
    rigid_body: HousingRigidBody | None = None
    housing_mass: HousingMass | None = None
    damping_partners: tuple[int, ...] = ()

    @property
    def c_TB(self) -> float:
        """Bearing damping coefficient [N s/m] (NaN when not available)."""
        return math.nan if self.damping is None else float(self.damping.c_TB)

    @property
    def c_TB_std(self) -> float:
        """Its standard uncertainty [N s/m] (NaN when not available)."""
        return math.nan if self.damping is None else float(self.damping.c_TB_std)

    @property
    def loss_factor(self) -> float:
        """Bearing loss factor ``eta`` (NaN when not available)."""
        return math.nan if self.damping is None else float(self.damping.loss_factor)

    @property
    def loss_factor_std(self) -> float:
        """Its standard uncertainty (NaN when not available)."""
        return math.nan if self.damping is None else float(self.damping.loss_factor_std)

    mode_source: str = "auto"

    def __str__(self) -> str:
        """``k_TB = 71.7 ± 0.1 (meas.) ± 2.7 (total) MN/m`` and the housing mode, one line each."""
        hm = self.housing_mode
        lines = [f"k_TB = {self.k_TB / 1e6:.2f} ± {self.k_TB_std_measured / 1e6:.2g} (meas.) "
                 f"± {self.k_TB_std / 1e6:.2g} (total) MN/m",
                 f"housing mode {hm.get('natural_freq', math.nan):.1f} Hz ({self.mode_source}), "
                 f"k_MS = {self.k_MS / 1e6:.1f} MN/m"]
        return "\n".join([*lines, *(f"warning: {w}" for w in self.warnings)])

    def __repr__(self) -> str:
        """k_TB with its measured and total standard uncertainty, the housing mode, the warnings."""
        hm = self.housing_mode
        lines = [f"StiffnessResult(k_TB = {self.k_TB / 1e6:.3f} MN/m ± {std_text(self.k_TB_std_measured / 1e6)} measured "
                 f"± {std_text(self.k_TB_std / 1e6)} total; housing mode {hm.get('natural_freq', math.nan):.2f} Hz; "
                 f"file {self.file})"]
        return "\n".join([*lines, *(f"  warning: {w}" for w in self.warnings)])

    @property
    def candidates(self) -> list[dict[str, Any]]:
        """Every mode considered by the matching, with metrics and reason."""
        return [c.to_dict() for c in self.match.candidates]

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
            "k_TB_std_measured": self.k_TB_std_measured,
            "k_TB_std_by_kind": self.uncertainty.to_dict()["k_TB_std_by_kind"],
            "k_TB_MS": self.k_TB_MS,
            "k_TB_MS_std": self.k_TB_MS_std,
            "k_MS": self.k_MS,
            "k_MS_std": self.k_MS_std,
            "inverted_freq": self.inverted_freq,
            "damping_model": self.damping_model,
            "mode_source": self.mode_source,
            "warnings": list(self.warnings),
            "notes": list(self.notes),
            "housing_mode": dict(self.housing_mode),
            "spindle_mode": None if self.spindle_mode is None else dict(self.spindle_mode),
            "uncertainty_budget": dict(self.uncertainty_budget),
            "uncertainty_terms": self.uncertainty.to_records(),
            "band": None if self.band is None else list(self.band),
            "spindle_band": None if self.spindle_band is None else list(self.spindle_band),
            "speed_hz": self.speed_hz,
            "candidates": [c.to_dict() for c in self.match.candidates],
            "fit": None if self.fit is None else self.fit.to_dict(),
            **_damping_keys(self.damping),
            "inversion_3dof": None if self.inversion_3dof is None else dict(self.inversion_3dof),
            "housing_rigid_body": None if self.rigid_body is None else self.rigid_body.to_dict(),
            "housing_mass": None if self.housing_mass is None else self.housing_mass.to_dict(),
            "mixed_partner": self._mode_entry(self.match.mixed_partner),
            "c_TB_partners": [self._mode_entry(i) for i in self.damping_partners],
        }

    def _mode_entry(self, index: int | None) -> dict[str, Any] | None:
        """``{index, natural_freq [Hz], damping_ratio}`` of identified mode ``index`` (None when absent)."""
        if index is None or self.identification is None:
            return None
        modes = self.identification.modes
        return {"index": int(index), "natural_freq": float(modes.natural_freq[index]),
                "damping_ratio": float(modes.damping_ratio[index])}


def _damping_keys(d: Any) -> dict[str, Any]:
    """``c_TB``, ``c_TB_std``, ``c_TB_kind``, ``loss_factor``, ``loss_factor_std`` ... (null when not available)."""
    if d is None:
        return {"c_TB": None, "c_TB_std": None, "loss_factor": None, "loss_factor_std": None,
                "bearing_damping_model": None, "c_TB_kind": None}
    return {k: v for k, v in d.to_dict().items() if k != "k_TB_complex"}


@dataclass(frozen=True, slots=True, eq=False)
class CalibrationResult:
    """Mounting stiffness from a steel-disk measurement.

    Attributes
    ----------
    k_MS, k_MS_std : float
        Mounting stiffness and its total standard uncertainty [N/m]: the identified frequency, the
        model-form terms, the disk (assumed rigid, or its given std) and the rig file's parameter
        tolerances (``k_MS_std_rig``).
    k_TB_MS : float
        Combined stiffness from the disk frequency [N/m].
    k_disk : float or None
        Disk stiffness put in series [N/m] (None: rigid disk, the paper's assumption).
    housing_mode : MatchedMode
        The matched housing mode with the disk (``natural_freq``, ``damping_ratio``, ...).
    calibration : KmsCalibration
    match : MatchResult
    identification : Identification
    band : tuple of float
    file : str or None
    k_MS_std_measured : float
        The part of ``k_MS_std`` from the identified frequency alone [N/m].
    warnings : tuple of str
        One-line caveats (as for :class:`StiffnessResult`).
    notes : tuple of str
        Information (the rigid-disk model-form term when no disk stiffness is given).
    k_MS_std_rig : float
        The part of ``k_MS_std`` from the rig file's parameter tolerances [N/m]
        (:func:`~ema_rig.rig.uncertainty.calibration_parameter_std`); ``k_MS_std`` is the root sum of
        squares of it and ``calibration.k_MS_std`` (frequency, model form, disk).
    """

    k_MS: float
    k_MS_std: float
    k_TB_MS: float
    k_disk: float | None
    housing_mode: MatchedMode
    calibration: KmsCalibration
    match: MatchResult
    identification: Identification | None = field(default=None, repr=False)
    band: tuple[float, float] | None = None
    file: str | None = None
    k_MS_std_measured: float = 0.0
    warnings: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    k_MS_std_rig: float = 0.0

    def __str__(self) -> str:
        """``k_MS = 114.0 ± 0.05 (meas.) ± 6.6 (total) MN/m`` and the warnings, one line each."""
        lines = [f"k_MS = {self.k_MS / 1e6:.2f} ± {self.k_MS_std_measured / 1e6:.2g} (meas.) "
                 f"± {self.k_MS_std / 1e6:.2g} (total) MN/m",
                 f"housing mode {self.housing_mode.get('natural_freq', math.nan):.1f} Hz with the steel disk"]
        return "\n".join([*lines, *(f"warning: {w}" for w in self.warnings)])

    def __repr__(self) -> str:
        """k_MS with its measured and total standard uncertainty and the warnings."""
        lines = [f"CalibrationResult(k_MS = {self.k_MS / 1e6:.3f} MN/m ± {std_text(self.k_MS_std_measured / 1e6)} measured "
                 f"± {std_text(self.k_MS_std / 1e6)} total; file {self.file})"]
        return "\n".join([*lines, *(f"  warning: {w}" for w in self.warnings)])

    @property
    def candidates(self) -> list[dict[str, Any]]:
        """Every mode considered by the matching."""
        return [c.to_dict() for c in self.match.candidates]

    def to_dict(self) -> dict[str, Any]:
        """JSON of ``ema-rig calibrate`` (DESIGN §3.2: ``k_MS``, ``k_MS_std``, ``housing_mode``)."""
        return {
            "file": self.file,
            "k_MS": self.k_MS,
            "k_MS_std": self.k_MS_std,
            "k_MS_std_measured": self.k_MS_std_measured,
            "k_MS_std_rig": self.k_MS_std_rig,
            "calibration": self.calibration.to_dict(),
            "warnings": list(self.warnings),
            "notes": list(self.notes),
            "k_TB_MS": self.k_TB_MS,
            "k_disk": self.k_disk,
            "housing_mode": dict(self.housing_mode),
            "spindle_mode": None if self.match.spindle_mode is None else dict(self.match.spindle_mode),
            "band": None if self.band is None else list(self.band),
            "candidates": [c.to_dict() for c in self.match.candidates],
        }


# --------------------------------------------------------------------------- pipeline
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
    damping_model: DampingModel = "viscous",
    identification: Any = None,
    selection: Any = None,
    speed_rpm: float | None = None,
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
    speed_rpm : float, optional
        The same in rpm (as the command line and campaign files give it); give one of the two.
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
    damping_model : {'viscous', 'hysteretic'}, optional
        Declared damping model: which undamped frequency the identified pole stands for
        (:func:`ema_rig.rig.uncertainty.undamped_freq`; the difference enters the budget).
    identification : Identification, optional
        Use these modes (e.g. ``identify(data, selection=picker.selection)``) instead of the
        automatic identification; the housing mode is matched among them.
    selection : Selection or path, optional
        A mode selection (e.g. picked with :class:`~ema_rig.plot.picker.PolePicker` and saved
        with ``Selection.to_json``), replayed on ``data`` (exactly on the data it was picked on,
        else by nearest frequency or tracked by frequency order, with a warning); give either
        ``identification`` or ``selection``. ``mode_source`` of the result says which.

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
    file = _file_of(data)
    speed_hz = _speed_hz(speed_hz, speed_rpm, file)
    ident_in = _given_identification(data, rig, identification, selection, band, max_order, progress, file)
    kms = rig.model.k_MS if k_ms is None else float(k_ms)
    if not (math.isfinite(kms) and kms > 0):
        raise InversionError(f"k_MS must be a finite positive stiffness [N/m], got {k_ms!r}", file=file)
    if k_ms_std is not None and not (math.isfinite(k_ms_std) and k_ms_std >= 0):
        raise InversionError(f"k_MS std must be finite and >= 0 [N/m], got {k_ms_std!r}", file=file)
    ident, s_ident, m, b, s_band = _identify_and_match(
        data, rig, band=band, max_order=max_order, speed_hz=speed_hz, spindle=spindle,
        progress=progress, file=file, ident=ident_in,
    )
    # the assessment sees the identification's pole std (the driving-point mass fit held at the
    # identified pole carries its damping ratio's std)
    m_std = replace(m, housing_mode=_mode_with_std(m.housing_mode, ident, m.housing_index))
    asm = assess_housing_mode(m_std, ident.modes, rig, damping_model=damping_model, file=file, data=data)
    source = mode_source(ident, float(m.housing_mode["natural_freq"])) if ident_in is not None else "auto"
    f_h = asm.inverted_freq
    f_std = measured_freq_std(m)
    unknown = [] if math.isfinite(f_std) else [
        "the housing mode's standard uncertainty is unknown (see the identification warnings), so "
        "k_TB_std_measured and k_TB_std are NaN"]
    params = replace(rig.model, k_MS=kms)
    rel_unc = dict(rig.uncertainty)
    if asm.m_H is not None:
        params = replace(params, m_H=float(asm.m_H))
    if asm.m_H_rel_std is not None:
        rel_unc["m_H"] = float(asm.m_H_rel_std)
    hmass = asm.housing_mass
    budget_unc = dict(rel_unc)
    if asm.m_H_budget is not None:
        budget_unc["m_H"] = float(asm.m_H_budget[0])
    id_warns, id_notes = _identification_caveats(ident, m, asm)
    try:
        unc = stiffness_uncertainty(f_h, f_std if not unknown else 0.0, params, budget_unc, k_MS_std=k_ms_std,
                                    model_form=asm.model_form,
                                    measured=("m_H",) if hmass is not None and hmass.used is not None else (),
                                    shared=None if asm.m_H_budget is None else asm.m_H_budget[1])
    except InversionError as exc:
        exc.file = exc.file or file
        raise
    k_tb = float(unc.k_TB)
    if not (math.isfinite(k_tb) and k_tb > 0):  # pragma: no cover - guarded by the inversion
        raise InversionError(f"no positive bearing stiffness from {f_h:.2f} Hz", file=file)
    budget = {t.name: float(t.share) for t in unc.terms}
    rig_fit = _fit(data, rig, params, m) if fit else None
    hm_std = _mode_with_std(m.housing_mode, ident, m.housing_index)
    inv3 = _plain_inversion(asm.undamped_freq, replace(rig.model, k_MS=kms))
    rigid = _rigid_body(m, asm, params, rel_unc, ident.modes, rig)
    hm_damp = hm_std
    pair_note: tuple[str, ...] = ()
    group = _damping_group(m, asm, ident.modes.natural_freq)
    if group:
        cross = asm.cross_axis
        mixed = cross is not None
        hm_damp, trace = _uncoupled_pole(hm_std, ident, group, f_h if cross is None else cross.uncoupled_freq,
                                         mixing=None if cross is None else (cross.mixing, cross.mixing_std))
        fs = ", ".join(f"{float(ident.modes.natural_freq[i]):.1f}" for i in group)
        how = ("their damping trace" if cross is None or trace is None else
               f"the pair's damping split by its mixing {100 * cross.mixing:.0f} % (their damping trace, "
               f"{100 * trace:.2f} %, bounds it)")
        pair_note = (f"bearing damping read from the {'pair coupled through the bearing' if mixed else 'modes sharing the radial housing motion'}"
                     f" (with {fs} Hz): the uncoupled housing mode's damping ratio "
                     f"{100 * hm_damp.damping_ratio:.2f} % from {how}; the housing mode's own "
                     f"{100 * hm_std.damping_ratio:.2f} %",)
    damping = _bearing_damping(hm_damp, params, rel_unc, k_ms_std, damping_model, asm.damping_location)
    return StiffnessResult(
        k_TB=k_tb,
        k_TB_std=float(unc.k_TB_std) if not unknown else math.nan,
        k_TB_MS=float(unc.k_TB_MS),
        k_TB_MS_std=float(unc.k_TB_MS_std),
        k_MS=kms,
        k_MS_std=None if k_ms_std is None else float(k_ms_std),
        housing_mode=hm_std.with_entries(source=source),
        spindle_mode=None if m.spindle_mode is None else _mode_with_std(
            m.spindle_mode, ident if m.spindle_source == "modes" else s_ident, m.spindle_index),
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
        k_TB_std_measured=float(unc.k_TB_std_measured) if not unknown else math.nan,
        inverted_freq=float(f_h),
        damping_model=damping_model,
        warnings=asm.warnings + tuple(unknown) + tuple(unresolved_warning(k_tb, float(unc.k_TB_std), kms))
        + tuple(f"identification: {w}" for w in id_warns),
        notes=asm.notes + pair_note + tuple(defaults_note(unc)) + tuple(f"identification: {w}" for w in id_notes),
        mode_source=source,
        damping=damping,
        inversion_3dof=inv3,
        rigid_body=rigid,
        housing_mass=hmass,
        damping_partners=group,
    )


_HELD = re.compile(r"^mode at ([0-9.eE+-]+) Hz held at its PolyMAX pole")
_EDGE = re.compile(r"^mode at ([0-9.eE+-]+) Hz sits at the band edge")


def _identification_caveats(ident: Any, m: MatchResult, asm: Any) -> tuple[list[str], list[str]]:
    """The identification's warnings split into caveats of ``k_TB`` and notes.

    A mode held at its PolyMAX pole by the ML estimate (``std_kind`` ``'held'``) that the result
    does not use (not the housing mode, an alternative, a neighbour given a term, or a corrected
    cross-axis partner) leaves ``k_TB`` and its std as they are (the held pole's uncertainty is
    propagated to the free poles of its segment): its warning is a note of this result. So does
    a mode at the band edge that the result does not use: the edge biases that mode's own
    estimate, and a mode close enough to move the housing mode's is a neighbour (used).
    """
    kinds = tuple(getattr(ident, "std_kind", ()) or ())
    fn = [float(f) for f in ident.modes.natural_freq]
    used = {m.housing_index, *m.alternatives, *m.neighbours}
    cross = getattr(asm, "cross_axis", None)
    if cross is not None:
        used.add(min(range(len(fn)), key=lambda i: abs(fn[i] - cross.partner_freq)))
    warns: list[str] = []
    notes: list[str] = []
    for w in ident.warnings:
        held = _HELD.match(w)
        hit = held or _EDGE.match(w)
        idx = None
        if hit is not None and (held is None or len(kinds) == len(fn)):
            f_w = float(hit.group(1))  # the message gives 6 significant digits
            near = [i for i in range(len(fn))
                    if (held is None or kinds[i] == "held") and abs(fn[i] - f_w) <= 1e-5 * f_w]
            idx = near[0] if len(near) == 1 else None
        (notes if idx is not None and idx not in used else warns).append(w)
    return warns, notes


def _rigid_body(m: MatchResult, asm: Any, params: Any, rel_unc: dict[str, float], modes: Any, rig: Any) -> Any:
    """:func:`ema_rig.rig.fit.housing_rigid_body` of this measurement (None outside the model), with
    the tilt stiffness where the rig file gives the sensors' positions and the rotary inertia."""
    info = model_mode_at(params, asm.inverted_freq)
    if info is None:
        return None
    cands = [c for c in m.candidates if c.source == "modes"]
    tilt = None
    if getattr(rig, "rotary_inertia", None) is not None:
        tilt = housing_tilt(modes, rig, cands, m.housing_index, params.m_H)
    return housing_rigid_body(cands, params.m_H, float(rel_unc.get("m_H", DEFAULT_REL_UNCERTAINTY["m_H"])),
                              info.modal_mass, asm.cross_axis, asm.undamped_freq, tilt=tilt)


def _plain_inversion(f0: float, params: Any) -> dict[str, float] | None:
    """``k_TB`` of the plain 3DOF inversion at ``f0`` (None outside the model's range)."""
    try:
        return {"freq": float(f0), "k_TB": float(k_tb_from_housing_freq(f0, params))}
    except InversionError:
        return None


def _damping_group(m: MatchResult, asm: Any, freqs: Any) -> tuple[int, ...]:
    """The identified modes that share the housing's radial motion, and with it the bearing's damping.

    The strongly mixed pair's partner (``m.mixed_partner``) or the cross-axis partner of a corrected
    bearing cross coupling (``asm.cross_axis``: the identified mode nearest its frequency); else the
    modes the assessment found to
    share the radial housing motion (``asm.sharing``: a part on its own spring fitted with the housing,
    or the split-mass group); else, where the housing mode's effective modal mass exceeds the model's by
    more than :data:`~ema_rig.rig.uncertainty.MASS_WARN_RATIO` (``asm.mass_ratio``: the mode holds only
    part of the housing's participation, so only part of the bearing's damping), its alternatives and
    close neighbours that move the radial housing sensors (``m.alternatives``, ``m.neighbours``); else
    none (the housing mode holds all of it).

    Parameters
    ----------
    m : MatchResult
        The matching (partner, alternatives, neighbours: indices into the identified modes).
    asm : Assessment
        The housing mode's assessment (``cross_axis``, ``sharing``, ``mass_ratio``).
    freqs : array_like
        The identified modes' natural frequencies [Hz].

    Returns
    -------
    tuple of int
        Indices of the partners in the identified modes, sorted; empty when the mode is read alone.
    """
    if m.mixed_partner is not None:
        return (int(m.mixed_partner),)
    cross = getattr(asm, "cross_axis", None)
    if cross is not None and len(freqs):
        return (min(range(len(freqs)), key=lambda i: abs(float(freqs[i]) - float(cross.partner_freq))),)
    group = set(getattr(asm, "sharing", ()) or ())
    ratio = getattr(asm, "mass_ratio", None)
    if not group and ratio is not None and math.isfinite(float(ratio)) and float(ratio) > MASS_WARN_RATIO:
        group = {int(i) for i in (*m.alternatives, *m.neighbours)}
    return tuple(sorted(group - {int(m.housing_index)}))


def _uncoupled_pole(hm: MatchedMode, ident: Any, partners: tuple[int, ...], f_u: float, *,
                    mixing: tuple[float, float] | None = None) -> tuple[MatchedMode, float | None]:
    """The radial housing mode shared with other modes, as the bearing's damping reads it.

    In mass-normalised coordinates the group's damping matrix is the uncoupled one (housing
    ``2 zeta_h w_h``, the partners' own motions ``c_p >= 0``) turned by the mixing; its trace is
    kept: ``sum_i 2 zeta_i w_i = 2 zeta_h w_h + sum_p c_p``. So ``sum_i zeta_i f_i / f_u`` bounds the
    uncoupled housing mode's damping ratio from above (exact for undamped partners), where the housing
    mode's own ``zeta_1`` holds only its share of the housing's damping: a strongly mixed pair (the
    housing's lateral motion), or a frame part / appendage that shares the radial housing motion.

    Where the pair's mixing ``t^2 = tan^2(theta)`` is measured (a cross-axis pair: two independent
    amplitude ratios), the diagonal of the turned matrix splits it: ``zeta_1 f_1 = cos^2 a + sin^2 b``,
    ``zeta_2 f_2 = sin^2 a + cos^2 b`` (``a = zeta_h f_u``, ``b`` the partner's own), so
    ``a = (zeta_1 f_1 - t^2 zeta_2 f_2) / (1 - t^2)``, at most the trace (``b >= 0``). It is first order
    in the damping: the turned matrix's off-diagonal ``beta = sin cos (a - b)`` couples the two close
    poles, which moves each one's damping by ``beta^2 (d_1 - d_2) / ((f_2 - f_1)^2 + (d_1 - d_2)^2)``
    (``d_i = zeta_i f_i``; the second-order term of the pair's 2x2 eigenvalues): that term, times
    ``(1 + t^2) / (1 - t^2)``, is a std of the split beside the modes' and the mixing's.

    Parameters
    ----------
    hm : MatchedMode
        The identified housing mode (frequency [Hz], damping ratio and their stds).
    ident : Identification
        The identification holding the partners (``modes``, ``damping_ratio_std``).
    partners : tuple of int
        The partners' indices in ``ident.modes``.
    f_u : float
        The group's uncoupled housing frequency [Hz].
    mixing : (float, float), optional
        The pair's measured mixing ``t^2`` and its std (one partner only); None: the trace.

    Returns
    -------
    MatchedMode
        ``hm`` at ``f_u`` with that damping ratio and its std (every mode's std, the mixing's and the
        split's second-order term, independent).
    float or None
        The trace's damping ratio (the bound) where the pair was split; else None.
    """
    f1, z1 = float(hm["natural_freq"]), float(hm["damping_ratio"])
    s1 = float(hm.get("damping_ratio_std") or 0.0)
    arr = getattr(ident, "damping_ratio_std", None)
    rows = [(f1, z1, s1)]
    for j in partners:
        s2 = float(arr[j]) if arr is not None and math.isfinite(float(arr[j])) else 0.0
        rows.append((float(ident.modes.natural_freq[j]), float(ident.modes.damping_ratio[j]), s2))
    trace = sum(f * z for f, z, _ in rows)
    trace_std = math.sqrt(sum((f * s) ** 2 for f, _, s in rows))
    t2, u2 = (math.nan, math.nan) if mixing is None else (float(mixing[0]), float(mixing[1]))
    if len(rows) == 2 and 0.0 <= t2 < 1.0:
        (fa, za, sa), (fb, zb, sb) = rows
        split = (za * fa - t2 * zb * fb) / (1.0 - t2)
        if 0.0 < split <= trace:
            du = (za * fa - zb * fb) / (1.0 - t2) ** 2 * (u2 if math.isfinite(u2) else 0.0)
            # the dropped coupling: the turned matrix's off-diagonal beta = sin cos (a - b) moves each
            # mode's damping by beta^2 (d_1 - d_2) / (df^2 + (d_1 - d_2)^2) at second order (the pair's
            # 2x2 eigenvalues, d_i = zeta_i f_i, df = f_2 - f_1), the split by (1 + t^2) / (1 - t^2) that
            part = (zb * fb - t2 * za * fa) / (1.0 - t2)  # b, the partner's own
            beta2 = t2 / (1.0 + t2) ** 2 * (split - part) ** 2
            dd = za * fa - zb * fb
            den = (fb - fa) ** 2 + dd**2
            second = beta2 * abs(dd) / den * (1.0 + t2) / (1.0 - t2) if den > 0 else math.inf
            std = math.sqrt((fa * sa / (1.0 - t2)) ** 2 + (t2 * fb * sb / (1.0 - t2)) ** 2 + du**2 + second**2)
            return (hm.with_entries(natural_freq=f_u, damping_ratio=split / f_u, damping_ratio_std=std / f_u),
                    trace / f_u)
    return hm.with_entries(natural_freq=f_u, damping_ratio=trace / f_u, damping_ratio_std=trace_std / f_u), None


def _bearing_damping(hm: Mapping[str, Any], params: Any, rel_unc: dict[str, float], k_ms_std: float | None,
                     damping_model: DampingModel, location: Any = None) -> Any:
    """:func:`ema_rig.rig.damping.bearing_damping` of the housing mode (None when not invertible): read
    with the bearing's measured share of the damping where ``location``
    (:class:`ema_rig.rig.uncertainty.DampingLocation`) gives one (a measurement), else with all of it
    (an upper bound)."""
    rel = {**DEFAULT_REL_UNCERTAINTY, **rel_unc}
    if k_ms_std is not None:
        rel["k_MS"] = float(k_ms_std) / params.k_MS

    def std(key: str) -> float:
        v = hm.get(key)
        return float(v) if v is not None and math.isfinite(float(v)) else 0.0

    try:
        return bearing_damping(float(hm["natural_freq"]), float(hm["damping_ratio"]), params,
                               natural_freq_std=std("natural_freq_std"), damping_ratio_std=std("damping_ratio_std"),
                               rel_unc=rel, model=damping_model,
                               share=None if location is None else float(location.share),
                               share_std=0.0 if location is None else float(location.share_std),
                               share_model_std=0.0 if location is None else float(location.share_span_std))
    except (InversionError, ValueError, ZeroDivisionError) as exc:
        logger.info("bearing damping not available: %s", exc)
        return None


def _fit(data: FRFData, rig: RigConfig, params: Any, m: MatchResult) -> Any:
    """Fit the 3DOF model to the radial driving-point and mean spindle FRFs (150–700 Hz)."""
    q = find_dof(data.in_dofs, rig.radial)
    p = find_dof(data.out_dofs, rig.radial)
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
    k_disk_std: float | None = None,
    damping_model: DampingModel = "viscous",
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
        Finite disk stiffness [N/m], in series (e.g. from FE); default: the rig file's
        ``[calibration] k_disk``, else assumed rigid, with a model-form term
        (:func:`ema_rig.rig.inversion.calibrate_k_ms`).
    k_disk_std : float, optional
        Standard uncertainty of ``k_disk`` [N/m]; default: the rig file's ``k_disk_std`` when
        ``k_disk`` is the rig file's (or not given), else 0.
    damping_model : {'viscous', 'hysteretic'}, optional
        Declared damping model (see :func:`estimate_stiffness`).
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
    file = _file_of(data)
    if band is None:
        band = rig.identification.get("k_MS_band")
    if k_disk is None:
        k_disk = rig.k_disk
    if k_disk_std is None and k_disk is not None and k_disk == rig.k_disk:
        k_disk_std = rig.k_disk_std
    ident, _, m, b, _ = _identify_and_match(
        data, rig, band=band, max_order=max_order, speed_hz=None, spindle=False,
        progress=progress, file=file,
    )
    asm = assess_housing_mode(m, ident.modes, rig, damping_model=damping_model, file=file, bearing=False)
    id_warns, id_notes = _identification_caveats(ident, m, asm)
    f_d = asm.inverted_freq
    # measured and model-form frequency terms act on k_TB+MS through the same slope
    f_meas = measured_freq_std(m)  # NaN when unknown: the k_MS uncertainties are then NaN too
    u_f = math.hypot(f_meas / f_d, *asm.model_form.values())
    try:
        cal = calibrate_k_ms(f_d, rig.model, f_disk_std=0.0 if math.isnan(u_f) else u_f * f_d, k_disk=k_disk,
                             k_disk_std=k_disk_std)
        meas = (math.nan if math.isnan(f_meas) else
                calibrate_k_ms(f_d, rig.model, f_disk_std=f_meas, k_disk=k_disk).k_MS_std_measured)
        # the frequency std given above also carries the model-form terms: its k_MS_std_measured is
        # the measured part alone, the same number as the result's own (JSON `calibration` block)
        cal = replace(cal, k_MS_std_measured=float(meas))
        # the rig file's tolerances move k_MS too (it is read through the 3DOF model): part of its total
        by_param = calibration_parameter_std(f_d, rig.model, rig.uncertainty, k_disk=k_disk)
    except InversionError as exc:
        exc.file = exc.file or file
        raise
    notes = []
    u_rig = math.sqrt(sum(v * v for v in by_param.values()))
    if u_rig > 0:
        top = sorted(by_param.items(), key=lambda kv: -kv[1])[:3]
        notes.append(f"the rig file's tolerances put {100 * u_rig / cal.k_MS:.2g} % into k_MS (read through the 3DOF "
                     "model: " + ", ".join(f"{n} {100 * v / cal.k_MS:.2g} %" for n, v in top) + "), in its total")
    disk_warns: tuple[str, ...] = ()
    if k_disk is None:
        notes.append(
            f"steel disk assumed rigid (paper: at least 10x k_MS): k_MS may be up to 10 % low; "
            f"model-form term {100 * cal.disk_std / cal.k_MS:.1f} % in k_MS_std (give the disk stiffness)"
        )
    elif k_disk < DISK_STIFFNESS_RATIO * cal.k_MS:
        # 1/k_MS = 1/k_TB+MS - 1/k_disk: d ln k_MS / d ln k_disk = k_MS / k_disk, > 1/10 for a disk softer than
        # the paper's; a k_disk typed one zero short (1.5e8 for 1.5e9) quadruples k_MS without a word
        disk_warns = (
            f"the steel disk ({k_disk:.4g} N/m) is only {k_disk / cal.k_MS:.2g}x the k_MS it gives, not the paper's "
            f"at least {DISK_STIFFNESS_RATIO:g}x: k_MS rests on k_disk (1 % in k_disk is "
            f"{cal.k_MS / k_disk:.2g} % in k_MS)"
            + ("" if k_disk_std else "; k_disk_std is not given, so none of that is in k_MS_std"),
        )
    return CalibrationResult(
        k_MS=float(cal.k_MS),
        k_MS_std=float(math.hypot(cal.k_MS_std, u_rig)) if not math.isnan(f_meas) else math.nan,
        k_TB_MS=float(cal.k_TB_MS),
        k_MS_std_rig=float(u_rig),
        k_disk=None if k_disk is None else float(k_disk),
        housing_mode=_mode_with_std(m.housing_mode, ident, m.housing_index),
        calibration=cal,
        match=m,
        identification=ident,
        band=b,
        file=file,
        k_MS_std_measured=float(meas),
        warnings=asm.warnings + disk_warns + ((
            "the housing mode's standard uncertainty is unknown (see the identification warnings), so "
            "k_MS_std_measured and k_MS_std are NaN",) if math.isnan(f_meas) else ())
        + tuple(f"identification: {w}" for w in id_warns),
        notes=(*notes, *(f"identification: {w}" for w in id_notes)),
    )
