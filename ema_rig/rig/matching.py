"""Match identified modes to the 3DOF rig model: which mode is the radial housing mode?

The identified band around the housing mode (150–1000 Hz on the paper's rig) holds far more
modes than the 3DOF model has: housing tilt modes, the spindle's first bending mode (287 Hz), the
housing axial mode (~300 Hz), a lateral housing mode, flexible frame and housing modes (from
663/695 Hz), the spindle axial mode (~1012 Hz) and, on a rotating bearing, nearly undamped lines
at multiples of the shaft speed. This module tells them apart by shape, scale and frequency
(DESIGN §4).

Functions
---------
match_modes
    Pick the radial housing mode (and the spindle bending mode) from a :class:`ModalModel`.
model_mode_at
    The 3DOF model's housing-mode shape, modal mass and spindle mode when its housing mode is
    tuned to a given frequency (defined in :mod:`ema_rig.rig.inversion`; re-exported here).
model_valid_range
    Housing-mode frequency range in which the 3DOF model gives ``k_TB+MS > 0``.

Classes
-------
MatchCriteria
    Thresholds of the matching evidence (all documented, all adjustable).
MatchResult
    The chosen modes and every candidate with its metrics and the reason it was kept or
    rejected.

Notes
-----
Evidence used for each candidate mode ``r`` (shapes from the radial reference's residue column,
mass-normalised at the radial driving point, sign-corrected DOFs):

* **frequency**: inside the model's valid range (``k_TB+MS > 0``) or a user range;
* **harmonic** (rotating bearing only): ``|f - k f_shaft|`` small and damping tiny;
* **in-phase radial housing motion**: ``cos`` of the phase between every radial housing sensor
  and the driving point close to +1 (a tilt mode moves them out of phase);
* **similar radial housing amplitudes**: rigid translation of the housing mass;
* **cross-axis motion**: lateral and axial housing sensors small against the radial ones
  (otherwise a lateral or axial mode). Where no mode passes, a mode failing only by it (and by
  the modal mass the mixing raises) is the radial housing mode strongly mixed with a cross-axis
  partner when an identified partner's ratio tells the same mixing
  (:func:`cross_axis_correction`) and the mode holds the larger radial share: a bearing cross
  coupling beside a lateral or axial housing mode; else the refusal names the mixed pair and why;
* **spindle/housing ratio**: the spindle radial sensors' signed motion relative to the housing,
  compared with the 3DOF model's ``phi_S / phi_H`` at the candidate's frequency (≈ 0.11 at
  626 Hz); a spindle mode moves the spindle far more;
* **effective modal mass** at the radial driving point ``1 / |phi_p|^2`` against the model's
  housing-mode value at the candidate's frequency (≈ 2.64 kg at 626 Hz); a flexible frame mode's
  is many times larger.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..config import ModelParams, RigConfig
from ..errors import MatchingError
from ..identification.criteria import WINDOW_ENBW
from ..identification.modal import ModalModel, shape_products
from .candidates import Candidate, find_dof, measure_candidates
from .failures import Failure
from .inversion import ModelModeInfo, housing_freq_bounds, model_mode_at
from .matched_mode import MatchedMode

__all__ = [
    "Candidate",
    "MATCH_CRITERIA",
    "MatchCriteria",
    "MatchResult",
    "ModelModeInfo",
    "match_modes",
    "model_mode_at",
    "model_valid_range",
]


def model_valid_range(params: ModelParams) -> tuple[float, float]:
    """Housing-mode frequencies [Hz] for which the 3DOF model gives ``k_TB+MS > 0``.

    80.6 Hz and 1299.6 Hz on Table 1 (see :func:`ema_rig.rig.inversion.housing_freq_bounds`).

    Parameters
    ----------
    params : ModelParams

    Returns
    -------
    (float, float)
        Lower and upper limit in Hz (both excluded).
    """
    return housing_freq_bounds(params)


# --------------------------------------------------------------------------- criteria
@dataclass(frozen=True, slots=True)
class MatchCriteria:
    """Thresholds of the matching evidence (the rig stage's criteria object), each with its source.

    Every threshold of the rig stage (candidates, matching, the stiffness command's spindle search)
    lives here; :meth:`sources` lists the source of each. "Convention" marks a value that no
    measurement or publication fixes (kept as it was; a reviewer may set it otherwise).

    Attributes
    ----------
    min_phase_cos : float
        Minimum ``cos`` of the phase angle between every radial housing sensor and the radial
        driving point (0.2 = within 78 degrees: a close mode makes shapes complex). Below: tilt mode.
        Source: DESIGN.md sect. 4 (a translation moves the radial housing sensors in phase, cos 1;
        a tilt out of phase, cos < 0); the margin to 0 is a convention (0.5 before commit e1efe87).
    min_amplitude_ratio : float
        Minimum ``min |phi| / max |phi|`` over the radial housing sensors (rigid translation).
        Source: DESIGN.md sect. 4 ("similar amplitude"); 0.5 is a convention.
    max_cross_axis_ratio : float
        Maximum lateral or axial housing amplitude relative to the mean radial housing amplitude.
        Source: DESIGN.md sect. 4 (axial and lateral modes live in the axial and lateral sensors,
        ratio > 1); 0.5 is a convention.
    spindle_ratio_tol : float
        Allowed absolute deviation of the measured spindle/housing ratio from the model's,
        ``|r - r_model| <= spindle_ratio_tol + spindle_ratio_rel_tol |r_model|``. Source: the
        model's ratio, about 0.1 at 626 Hz (DESIGN.md sect. 4); the widths are a convention.
    spindle_ratio_rel_tol : float
        The relative part of that allowance (0.5). Convention.
    mass_ratio_range : (float, float)
        Allowed range of measured / model effective modal mass at the radial driving point.
        Source: DESIGN.md sect. 4 (the housing mode's mass is close to the model's, 2.64 kg at
        626 Hz; a flexible frame mode's many times larger, 12x in ``tests/test_matching.py``);
        the factor 2 either way is a convention.
    units_hint_log_tol : float
        A driving-point mass ratio within ``exp(+-units_hint_log_tol)`` of g (or 1/g) earns the
        hint that the file's units may be g read as m/s^2 (only a hint in the message; 0.25,
        +-28 %, a convention well inside the factor 9.81).
    harmonic_freq_tol : float
        Relative tolerance of ``|f - k f_shaft| / f`` for a line to count as a harmonic
        (widened to ``harmonic_sigmas`` identified standard deviations when those are known).
        Convention (2e-3).
    harmonic_sigmas : float
        Standard deviations of the identified frequency within which a line is a harmonic
        (3: two-sided p = 0.0027 for a normal estimate).
    harmonic_min_order : float
        Lines below this multiple of the shaft speed are never harmonics (0.5: below the first
        harmonic by more than the spacing of harmonics). Convention.
    harmonic_max_damping : float
        A harmonic line is nearly undamped: damping ratio below this. Convention (5e-3).
    harmonic_max_chance : float
        A lightly damped mode inside a harmonic's window is called a harmonic only when a mode at
        a random frequency would fall inside a window with at most this probability: the covered
        fraction ``2 tol_hz / f_shaft`` (:func:`~ema_rig.rig.candidates.harmonic_chance`). Above it
        (low shaft speeds: every frequency above ``250 f_shaft`` is inside a window) the window is
        no evidence, the mode stays a candidate and the match warns once when such a mode is the
        housing mode, an alternative or a close neighbour. Source: a harmonic line lies inside a
        window with certainty, a mode at a random frequency with this chance, so the window's
        likelihood ratio (Bayes factor) is ``1 / chance``; 1/3 asks for a factor of at least 3,
        Jeffreys' "substantial" evidence (H. Jeffreys, *Theory of Probability*, 3rd ed. 1961,
        App. B; "positive" in Kass & Raftery, JASA 90, 1995). The damping (below
        ``harmonic_max_damping``) is the other half of the evidence, so no stricter level is asked.
    driving_point_min_cos : float
        The housing mode's driving-point modal constant ``2 j w_d R_pp = phi_p^2`` is real and
        positive for a real mode (with the response and the reference written with one sign;
        negative with opposite signs). When the ``cos`` of its phase from the expected sign is below
        this (0: the constant has the opposite sign, more than 90 degrees off), the match warns of a
        reversed excitation or driving-point polarity, which flips every FRF and leaves every other
        check blind. Source: definition (the sign of ``phi_p^2``); only the housing mode is used:
        weakly participating modes' constants have noisy phases (85, -107, 122 degrees at 287, 301
        and 410 Hz on a ``tests/rig_truth.py`` rig, the housing mode's 0).
    polarity_min_cos : float
        A reversed sensor is suspected when flipping its sign makes every radial housing sensor
        in phase to this ``cos`` (0.9, within 26 degrees) with similar amplitudes. Convention.
    spindle_freq_tol : float
        Relative window around the model's spindle-mode frequency in which the spindle bending
        mode is looked for (also the band the stiffness command identifies it in). Source: paper
        sect. 2-3: the design FE model put the housing mode at 530 Hz, measured at 626 Hz (-15 %):
        a model-to-measurement difference of that size; +-20 %.
    min_spindle_ratio : float
        A spindle bending mode moves the spindle radial sensors at least this many times more
        than the housing, in anti-phase. Source: definition (ratio 1 is where the spindle starts
        to move more than the housing; paper Fig. 4: the housing mode moves the housing, the
        spindle modes the shaft).
    max_spindle_axial_ratio : float
        Axial spindle motion above this multiple of the radial is an axial mode, not the bending
        mode. Source: definition (paper sect. 2: the shaft's axial rigid-body mode at 1012 Hz).
    spindle_search_margin, spindle_search_min_fraction : float
        The stiffness command looks for the spindle mode in a band of its own only when the data
        reach past the predicted mode by ``spindle_search_margin`` (2 %) and that band starts above
        ``spindle_search_min_fraction`` (0.5) of the housing band's top. Convention.
    neighbour_bandwidths : float
        A mode closer to the housing mode than this many (mean) half-power bandwidths
        ``(zeta_1 f_1 + zeta_2 f_2)`` is a close neighbour (coupled, or able to bias it).
        Convention (3).
    neighbour_participation : float
        ... when its radial housing participation is at least this fraction of the housing
        mode's. Convention (0.1).
    pair_max_mass_std : float
        The housing mode fitted jointly with its close neighbours on every channel
        (:func:`ema_rig.rig.fit.fit_housing_pair`) resolves the pair when the relative std of its
        driving-point modal mass is at most this (0.03). Source: the mass is ``1 / |R|``, whose
        linearised std holds while the second-order bias ``(std / m)^2`` stays below the 0.1 %
        the modal mass can resolve (:data:`ema_rig.rig.uncertainty.MASS_RESOLUTION`):
        ``sqrt(1e-3) = 0.032``. Beyond, the pair is not resolved and the one-channel mass with the
        widened m_H tolerance (or a warning) stays.
    cross_axis_ratio_std : float
        Standard uncertainty of a measured cross-axis / radial amplitude ratio (0.035). Source: an
        accelerometer mounted within 2 degrees reads sin(2 deg) = 0.035 of the motion across its axis.
    mixed_pair_max_mixing : float
        Where no mode passes, a mode failing only by its cross-axis motion (and by its modal mass,
        which the mixing raises by ``1 + t^2``) is the radial housing mode mixed with a cross-axis
        partner when an identified partner tells the same mixing ``t^2`` (two independent ratios
        within 3 sigma, :func:`cross_axis_correction`) and ``t^2`` is at most this (1): the mode
        keeps at least half of the radial housing motion of the pair. Source: definition (of the
        two modes sharing one radial housing motion, the radial housing mode is the one holding the
        larger share; at exactly 1 either reading gives the same uncoupled frequency).
    resolution_lines : float
        Resolution bandwidth of a measured spectrum in lines (1.5): the equivalent noise bandwidth
        of a Hann window, the window of random excitation (F. J. Harris, "On the use of windows for
        harmonic analysis with the discrete Fourier transform", Proc. IEEE 66(1), 1978, Table 1:
        1.50 bins). Two poles closer than this are not resolved by the spectrum.
    min_bandwidth_resolutions : float
        A resonance is resolved when its half-power bandwidth ``2 zeta f`` spans at least this many
        resolution bandwidths (4). Source: the resolution bias of a windowed spectrum at a resonance
        peak is ``-(1/3) (B_e / B_r)^2`` (J. S. Bendat & A. G. Piersol, *Random Data*, 4th ed. 2010,
        ch. 8, resolution bias), -2 % at ``B_e = B_r / 4``, their guideline; below, leakage smears
        the peak, and a modal fit splits it into poles about a line apart
        (``benchmarks/results/study_unseen_truths_r_truth13.txt``, Hann-windowed truths).
    """

    min_phase_cos: float = 0.2
    min_amplitude_ratio: float = 0.5
    max_cross_axis_ratio: float = 0.5
    spindle_ratio_tol: float = 0.15
    mass_ratio_range: tuple[float, float] = (0.5, 2.0)
    harmonic_freq_tol: float = 2e-3
    harmonic_max_damping: float = 5e-3
    spindle_freq_tol: float = 0.2
    min_spindle_ratio: float = 1.0
    neighbour_bandwidths: float = 3.0
    neighbour_participation: float = 0.1
    spindle_ratio_rel_tol: float = 0.5
    units_hint_log_tol: float = 0.25
    harmonic_sigmas: float = 3.0
    harmonic_min_order: float = 0.5
    polarity_min_cos: float = 0.9
    max_spindle_axial_ratio: float = 1.0
    spindle_search_margin: float = 0.02
    spindle_search_min_fraction: float = 0.5
    pair_max_mass_std: float = 0.03
    cross_axis_ratio_std: float = 0.035
    mixed_pair_max_mixing: float = 1.0
    harmonic_max_chance: float = 1.0 / 3.0
    driving_point_min_cos: float = 0.0
    resolution_lines: float = WINDOW_ENBW["hann"]
    min_bandwidth_resolutions: float = 4.0

    def sources(self) -> dict[str, str]:
        """The source of every threshold, by field name (see the class docstring)."""
        conv = "convention (no measurement or publication fixes it)"
        return {
            "min_phase_cos": "DESIGN.md sect. 4: translation in phase, tilt out of phase; margin " + conv,
            "min_amplitude_ratio": "DESIGN.md sect. 4 'similar amplitude'; 0.5 " + conv,
            "max_cross_axis_ratio": "DESIGN.md sect. 4: axial/lateral modes live in those sensors; 0.5 " + conv,
            "spindle_ratio_tol": "model spindle/housing ratio ~0.1 at 626 Hz (DESIGN.md sect. 4); width " + conv,
            "spindle_ratio_rel_tol": conv,
            "mass_ratio_range": "DESIGN.md sect. 4: housing mass ~ model's (2.64 kg), frame modes many times; "
                                "factor 2 " + conv,
            "units_hint_log_tol": "a message hint only, well inside the factor g = 9.81; " + conv,
            "harmonic_freq_tol": conv,
            "harmonic_sigmas": "3 sigma: two-sided p = 0.0027 for a normal frequency estimate",
            "harmonic_min_order": conv,
            "harmonic_max_damping": conv,
            "harmonic_max_chance": "Bayes factor >= 3 of the window (Jeffreys 1961, App. B, 'substantial'; Kass & "
                                   "Raftery 1995): a harmonic is inside a window with certainty, a mode at a random "
                                   "frequency with the covered fraction 2 tol / f_shaft",
            "driving_point_min_cos": "definition: a real mode's driving-point modal constant phi_p^2 is positive "
                                     "(cos 0: the opposite sign)",
            "polarity_min_cos": conv,
            "spindle_freq_tol": "paper sect. 2-3: FE housing mode 530 Hz vs measured 626 Hz (-15 %)",
            "min_spindle_ratio": "definition: the spindle moves more than the housing (paper Fig. 4)",
            "max_spindle_axial_ratio": "definition: axial motion dominates (paper sect. 2, axial mode 1012 Hz)",
            "spindle_search_margin": conv,
            "spindle_search_min_fraction": conv,
            "neighbour_bandwidths": conv,
            "neighbour_participation": conv,
            "pair_max_mass_std": "linearised std of 1 / |R| valid while its bias (std / m)^2 <= MASS_RESOLUTION "
                                 "(0.1 %): sqrt(1e-3) = 0.032",
            "cross_axis_ratio_std": "a sensor mounted within 2 degrees: sin(2 deg) = 0.035 of the cross motion",
            "mixed_pair_max_mixing": "definition: the radial housing mode holds the larger radial share of the pair",
            "resolution_lines": "equivalent noise bandwidth of a Hann window, 1.50 bins (Harris, Proc. IEEE 66(1), "
                                "1978, Table 1)",
            "min_bandwidth_resolutions": "resolution bias of a windowed resonance peak -(1/3) (B_e / B_r)^2, -2 % at "
                                         "B_e = B_r / 4 (Bendat & Piersol, Random Data, 4th ed. 2010, ch. 8)",
        }


#: The default criteria of the rig stage.
MATCH_CRITERIA = MatchCriteria()


# --------------------------------------------------------------------------- result
@dataclass(frozen=True, slots=True)
class MatchResult:
    """Which identified mode is the radial housing mode (and the spindle bending mode).

    Attributes
    ----------
    housing_index : int
        Index of the housing mode in the matched :class:`ModalModel`.
    housing_mode : MatchedMode
        ``natural_freq`` [Hz] (``|lambda| / 2 pi``), ``damping_ratio``, ``natural_freq_std``
        (Hz or None), ``modal_mass`` [kg], ``model_modal_mass`` [kg].
    spindle_index : int or None
        Index of the spindle bending mode in the model it was found in (``spindle_source``).
    spindle_mode : MatchedMode or None
        ``natural_freq``, ``damping_ratio`` of the spindle bending mode, or None when absent.
    spindle_source : str or None
        ``'modes'`` or ``'spindle_modes'``: which ModalModel holds the spindle mode.
    candidates : tuple of Candidate
        Every mode considered (sorted by frequency): metrics, ``status`` (``'housing'``,
        ``'spindle'``, ``'rejected'``) and ``reason``.
    valid_range : (float, float)
        The housing-frequency range searched [Hz].
    driving_point : bool
        True when the radial driving-point FRF was identified (effective modal masses from it);
        False: masses estimated from the radial housing transfer FRFs (rigid housing assumed).
    alternatives : tuple of int
        Indices of the other modes that pass every housing criterion.
    neighbours : tuple of int
        Indices of the modes within :attr:`MatchCriteria.neighbour_bandwidths` half-power
        bandwidths of the housing mode that move the radial housing sensors (housing
        participation at least :attr:`MatchCriteria.neighbour_participation` of its own).
    participation : tuple of float
        Radial housing participation of every mode, ``mean_p |phi_p phi_q|`` over the radial
        housing sensors ``p`` (``q`` the radial reference) [1/kg]: ``1 / m_eff`` for a rigid
        housing.
    warnings : tuple of str
        One-line caveats found while matching (missing driving point, several modes passing,
        a sensor whose polarity looks reversed).
    mixed_partner : int or None
        Where the housing mode was matched as one of a strongly mixed pair (it moves the
        cross-axis sensors beyond :attr:`MatchCriteria.max_cross_axis_ratio`, an identified
        partner tells the same mixing): the partner's index; else None.
    """

    housing_index: int
    housing_mode: MatchedMode
    spindle_index: int | None
    spindle_mode: MatchedMode | None
    spindle_source: str | None
    candidates: tuple[Candidate, ...] = ()
    valid_range: tuple[float, float] = (0.0, math.inf)
    driving_point: bool = True
    alternatives: tuple[int, ...] = ()
    neighbours: tuple[int, ...] = ()
    participation: tuple[float, ...] = ()
    warnings: tuple[str, ...] = ()
    mixed_partner: int | None = None

    def __repr__(self) -> str:
        hm: Mapping[str, Any] = self.housing_mode or {}
        return (f"MatchResult(housing mode {hm.get('natural_freq', float('nan')):.2f} Hz, "
                f"{len(self.candidates)} candidates)")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: ``housing_mode``, ``spindle_mode``, ``candidates``, ``valid_range``."""
        return {
            "housing_mode": dict(self.housing_mode),
            "spindle_mode": None if self.spindle_mode is None else dict(self.spindle_mode),
            "candidates": [c.to_dict() for c in self.candidates],
            "valid_range": list(self.valid_range),
            "driving_point": self.driving_point,
            "warnings": list(self.warnings),
        }


# --------------------------------------------------------------------------- helpers

@dataclass(frozen=True, slots=True)
class CrossAxisCorrection:
    """Uncoupled radial housing frequency from a cross-coupled partner mode.

    Attributes
    ----------
    axis : str
        ``'axial'`` or ``'lateral'``.
    ratio : float
        The housing mode's cross-axis / radial housing amplitude ratio.
    partner_freq : float
        The partner mode's frequency [Hz].
    partner_ratio : float
        The partner's radial / cross-axis amplitude ratio (``~ ratio`` for a two-mode coupling).
    mixing : float
        ``t^2 = ratio^2 m_x / m_eff``: the partner's share over the housing's in the mode.
    uncoupled_freq, rel_std : float
        Uncoupled housing frequency [Hz] and its relative standard uncertainty.
    consistent : bool
        Both ratios give the same mixing within 3 sigma (a two-mode coupling).
    mixing_std : float
        Standard uncertainty of ``mixing`` (the two ratios' estimates combined by inverse variance);
        NaN when not given.
    """

    axis: str
    ratio: float
    partner_freq: float
    partner_ratio: float
    mixing: float
    uncoupled_freq: float
    rel_std: float
    consistent: bool = True
    mixing_std: float = math.nan


def cross_axis_correction(f_h: float, ratio: float, partner_freq: float, partner_ratio: float,
                          m_cross: float, m_eff: float, *, ratio_std: float, partner_ratio_std: float,
                          axis: str) -> CrossAxisCorrection:
    """Two-mode reduction of a bearing cross stiffness.

    The housing mode ``1`` and its partner ``2`` (the housing's axial or lateral rigid-body
    mode) are, in mass-normalised coordinates, ``cos(t) h + sin(t) p`` and ``-sin(t) h + cos(t) p``
    of the uncoupled radial housing mode ``h`` (driving-point effective mass ``m_eff``) and the
    uncoupled cross-axis mode ``p`` (mass ``m_cross``). Mode 1's cross-axis / radial amplitude
    ratio is ``tan(t) sqrt(m_eff / m_cross)`` and mode 2's radial / cross-axis ratio
    ``tan(t) sqrt(m_cross / m_eff)``: two estimates of ``tan(t)^2``, combined by inverse variance.
    The uncoupled eigenvalue is ``cos^2(t) w_1^2 + sin^2(t) w_2^2`` (exact for two modes).

    Parameters
    ----------
    f_h : float
        Identified housing frequency [Hz].
    ratio : float
        Its cross-axis / radial housing amplitude ratio.
    partner_freq : float
        Partner frequency [Hz].
    partner_ratio : float
        The partner's radial / cross-axis amplitude ratio.
    m_cross, m_eff : float
        Housing mass along the cross axis and the model's radial effective modal mass [kg].
    ratio_std, partner_ratio_std : float
        Standard uncertainties of both ratios (sensor misalignment, cross-axis sensitivity).
    axis : str
        ``'axial'`` or ``'lateral'``.

    Returns
    -------
    CrossAxisCorrection
        ``consistent`` False when the two estimates of the mixing differ by more than 3 sigma.
    """
    q = m_cross / m_eff
    t1, u1 = ratio**2 * q, 2 * ratio * ratio_std * q
    t2, u2 = partner_ratio**2 / q, 2 * partner_ratio * partner_ratio_std / q
    w1, w2 = 1 / max(u1, 1e-12) ** 2, 1 / max(u2, 1e-12) ** 2
    t = (w1 * t1 + w2 * t2) / (w1 + w2)
    u_t = 1 / math.sqrt(w1 + w2)
    consistent = abs(t1 - t2) <= 3 * math.hypot(u1, u2)

    def fu(x: float) -> float:
        x = max(x, 0.0)
        return math.sqrt((f_h**2 + x * partner_freq**2) / (1 + x))

    f_u = fu(t)
    rel = abs(math.log(fu(t + u_t) / fu(t - u_t))) / 2
    return CrossAxisCorrection(axis=axis, ratio=ratio, partner_freq=partner_freq, partner_ratio=partner_ratio,
                               mixing=t, uncoupled_freq=f_u, rel_std=rel, consistent=consistent,
                               mixing_std=u_t)


def cross_axis_partner(f_h: float, ratio: float, cands: list[Candidate], key: str, m_cross: float, m_eff: float,
                       *, min_ratio: float, n_radial: int, ratio_std: float, axis: str,
                       exclude: int | None = None) -> CrossAxisCorrection | None:
    """The identified partner of a cross-coupled housing mode, read through :func:`cross_axis_correction`.

    The partner is a mode moving the cross-axis sensors relatively more than the housing mode does
    (``key`` above ``max(ratio, min_ratio)``); of several, the one whose radial / cross-axis ratio
    tells the housing mode's mixing most nearly.

    Parameters
    ----------
    f_h, ratio : float
        The housing mode's frequency [Hz] and its cross-axis / radial housing amplitude ratio.
    cands : list of Candidate
        The identified modes.
    key : str
        ``'axial_ratio'`` or ``'lateral_ratio'``.
    m_cross, m_eff : float
        Housing mass along the cross axis and the model's radial effective modal mass [kg].
    min_ratio : float
        The partner's cross-axis / radial ratio exceeds this too.
    n_radial : int
        Radial housing sensors (the partner's ratio averages over them).
    ratio_std : float
        Standard uncertainty of one measured ratio (sensor misalignment).
    axis : str
        ``'axial'`` or ``'lateral'``.
    exclude : int, optional
        Index of the housing mode itself.

    Returns
    -------
    CrossAxisCorrection or None
        None when no mode qualifies as the partner.
    """
    trials = [cross_axis_correction(
        f_h, ratio, c.natural_freq, 1.0 / float(getattr(c, key)), m_cross, m_eff, ratio_std=ratio_std,
        partner_ratio_std=ratio_std / math.sqrt(max(n_radial, 1)), axis=axis)
        for c in cands if c.index != exclude and getattr(c, key) is not None
        and getattr(c, key) > max(ratio, min_ratio)]
    if not trials:
        return None
    return min(trials, key=lambda x: abs(math.log(max(x.ratio**2 * m_cross / m_eff, 1e-12)
                                                  / max(x.partner_ratio**2 * m_eff / m_cross, 1e-12))))


def _fmt(x: float | None, spec: str = ".3g") -> str:
    return "n/a" if x is None or not np.isfinite(x) else format(x, spec)


def _clean(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


def _score(c: Candidate) -> float:
    """Closeness to the model's housing mode: effective mass, in-phase and similar radial motion."""
    s = 0.0 if c.mass_ratio is None else abs(math.log(c.mass_ratio))
    return s + (1.0 - (c.radial_phase_cos or 1.0)) + (1.0 - (c.radial_amplitude_ratio or 1.0))


# --------------------------------------------------------------------------- main
def match_modes(
    modes: ModalModel,
    rig: RigConfig,
    *,
    natural_freq_std: NDArray[np.float64] | None = None,
    speed_hz: float | None = None,
    expected: tuple[float, float] | None = None,
    spindle_modes: ModalModel | None = None,
    criteria: MatchCriteria | None = None,
    file: str | None = None,
) -> MatchResult:
    """Pick the radial housing mode and the spindle bending mode by shape, scale and frequency.

    Parameters
    ----------
    modes : ModalModel
        Identified modes of a measurement in the housing band; needs the radial shaker's
        reference, and preferably its driving-point response (mass-normalised shapes; without
        it the effective mass comes from the radial housing transfer FRFs, with a warning).
    rig : RigConfig
        Sensor roles and axes, the radial reference, the 3DOF model parameters.
    natural_freq_std : ndarray, shape (n_modes,), optional
        Standard uncertainty of each identified natural frequency [Hz] (reported, and widens
        the harmonic tolerance).
    speed_hz : float, optional
        Shaft speed [Hz] of a rotating bearing; enables the rejection of harmonic lines.
    expected : (float, float), optional
        Housing-mode frequency range [Hz]; default (and at most) the model's valid range
        (:func:`model_valid_range`).
    spindle_modes : ModalModel, optional
        Modes identified in a separate band around the spindle bending mode (~1908 Hz); when
        None the spindle mode is looked for in ``modes``.
    criteria : MatchCriteria, optional
        Thresholds (default :class:`MatchCriteria()`).
    file : str, optional
        Measurement file, for error messages.

    Returns
    -------
    MatchResult

    Raises
    ------
    MatchingError
        When no mode passes the housing-mode criteria: one short line naming the likely cause;
        ``candidates`` lists every mode with its metrics and reasons.
    """
    crit = criteria or MatchCriteria()
    params = rig.model
    lo, hi = model_valid_range(params)
    if expected is not None:
        lo, hi = max(lo, float(expected[0])), min(hi, float(expected[1]))
    if speed_hz is not None and not (np.isfinite(speed_hz) and speed_hz > 0):
        speed_hz = None
    if natural_freq_std is not None:
        natural_freq_std = np.asarray(natural_freq_std, dtype=float)
        if natural_freq_std.shape != (modes.n_modes,):
            raise ValueError(
                f"natural_freq_std must have shape ({modes.n_modes},), got {natural_freq_std.shape}"
            )

    def measure(mm: ModalModel, source: str, nf_std: NDArray[np.float64] | None) -> list[Candidate]:
        return measure_candidates(mm, rig, source, nf_std, speed_hz, harmonic_freq_tol=crit.harmonic_freq_tol,
                                  harmonic_max_damping=crit.harmonic_max_damping,
                                  min_amplitude_ratio=crit.min_amplitude_ratio, harmonic_sigmas=crit.harmonic_sigmas,
                                  harmonic_min_order=crit.harmonic_min_order, polarity_min_cos=crit.polarity_min_cos,
                                  harmonic_max_chance=crit.harmonic_max_chance)

    cands = [_judge_housing(c, params, lo, hi, crit) for c in measure(modes, "modes", natural_freq_std)]
    passing = [c for c in cands if not c.failures]
    mixed: dict[int, CrossAxisCorrection] = {}
    if not passing:
        # no clean housing mode: the radial housing mode strongly mixed with a cross-axis partner
        # (a bearing cross coupling near a lateral or axial housing mode) still is the housing mode;
        # the budget inverts the pair's uncoupled frequency (ema_rig.rig.uncertainty.assess)
        pairs = {c.index: _mixed_pair(c, cands, params, rig, crit) for c in cands}
        mixed = {i: p for i, p in pairs.items() if p is not None and _pair_holds(cands[i], p, crit)}
        passing = [c for c in cands if c.index in mixed]
    if not passing:
        raise MatchingError(_refusal(cands, lo, hi, rig, crit), candidates=[c.to_dict() for c in cands],
                            file=file)
    best = min(passing, key=_score)
    hi_idx = best.index
    info = model_mode_at(params, best.natural_freq)
    assert info is not None  # a passing candidate lies inside the model's range
    mixed_partner = None
    if hi_idx in mixed:
        pm = mixed[hi_idx]
        mixed_partner = min((c for c in cands if c.index != hi_idx),
                            key=lambda c: abs(c.natural_freq - pm.partner_freq)).index
        share = 1.0 / (1.0 + pm.mixing)
        cands[hi_idx] = replace(best, status="housing", failures=(), reason=(
            f"radial housing mode mixed with the {pm.axis} mode at {pm.partner_freq:.1f} Hz (radial housing "
            f"shares {100 * share:.0f} %/{100 * (1 - share):.0f} %, both modes' ratios tell mixing "
            f"{100 * pm.mixing:.0f} %): bearing cross coupling"))
    else:
        cands[hi_idx] = replace(best, status="housing", reason="radial housing mode: " + best.reason)
    for c in passing:
        if c is not best:
            cands[c.index] = replace(c, reason=(
                f"passes the housing criteria but {best.natural_freq:.1f} Hz matches better "
                f"(score {_score(c):.3f} vs {_score(best):.3f})"))
    housing = MatchedMode.from_mapping({
        "natural_freq": float(modes.natural_freq[hi_idx]),
        "damping_ratio": float(modes.damping_ratio[hi_idx]),
        "natural_freq_std": best.natural_freq_std,
        "modal_mass": best.modal_mass,
        "modal_mass_source": best.mass_source,
        "model_modal_mass": info.modal_mass,
        "spindle_ratio": best.spindle_ratio,
        "model_spindle_ratio": info.spindle_ratio,
        "axial_ratio": best.axial_ratio,
        "lateral_ratio": best.lateral_ratio,
    })
    warns: list[str] = []
    has_dp = find_dof(modes.out_dofs, rig.radial.positive()) is not None
    if not has_dp:
        warns.append(
            f"no radial driving-point FRF ({rig.radial}): effective modal mass estimated from the "
            "radial housing transfer FRFs (rigid housing assumed); the housing mode rests on shape"
        )
    else:
        pol = _driving_point_polarity(modes, hi_idx, rig, crit)
        if pol:
            warns.append(pol)
    alts = tuple(c.index for c in passing if c is not best)
    if alts:
        fs = ", ".join(f"{modes.natural_freq[i]:.1f}" for i in alts)
        warns.append(
            f"{len(alts) + 1} modes pass the housing criteria: chose {best.natural_freq:.1f} Hz "
            f"(closest effective modal mass) over {fs} Hz"
        )
    # another mode that would be a clean radial translation with one sensor flipped (its
    # ``polarity_suspect``, kept in the candidates) is no caveat here: the chosen housing mode moves
    # every radial housing sensor in phase (``min_phase_cos``), which a reversed sensor would not; such
    # a mode is a shape of its own (an ovalisation-like mode: the driving point against the other two
    # radial sensors; r_truth12's second housing mode, seed 46, warned "check the polarity of 11+Y")
    part = tuple(float(c.participation or 0.0) for c in cands)
    f_h, z_h = best.natural_freq, best.damping_ratio
    neigh = tuple(
        c.index for c in cands
        if c.index != hi_idx and c.harmonic is None and part[hi_idx] > 0
        and part[c.index] >= crit.neighbour_participation * part[hi_idx]
        and abs(c.natural_freq - f_h) <= crit.neighbour_bandwidths * max(c.damping_ratio * c.natural_freq
                                                                         + z_h * f_h, 1e-9)
    )

    amb = _ambiguous_harmonics(cands, (hi_idx, *alts, *neigh), speed_hz, crit)
    if amb:
        warns.append(amb)

    # ---- spindle bending mode, predicted by the model tuned to the housing mode
    extra: list[Candidate] = []
    if spindle_modes is None:
        pool = [c for c in cands if c.index != hi_idx]
    else:
        extra = measure(spindle_modes, "spindle_modes", None)
        pool = list(extra)
    verdict = {id(c): _judge_spindle(c, info, crit) for c in pool}
    sp_pass = [c for c in pool if verdict[id(c)][0]]
    sbest = min(sp_pass, key=lambda c: abs(c.natural_freq / info.spindle_freq - 1.0)) if sp_pass else None

    def spindle_verdict(c: Candidate) -> Candidate:
        ok, why = verdict[id(c)]
        if c is sbest:
            return replace(c, status="spindle", reason=(
                f"spindle bending mode: spindle/housing {_fmt(c.spindle_ratio, '.2f')} "
                f"(model {info.spindle_mode_ratio:.2f}), {c.natural_freq:.1f} Hz near the "
                f"model's {info.spindle_freq:.1f} Hz"))
        if ok:
            assert sbest is not None
            return replace(c, status="rejected",
                           reason=f"spindle-like but {sbest.natural_freq:.1f} Hz is closer to the model")
        if c.source == "spindle_modes":
            return replace(c, status="rejected", reason="not the spindle mode: " + why)
        if abs(c.natural_freq / info.spindle_freq - 1.0) <= crit.spindle_freq_tol:
            # a housing-rejected mode near the spindle prediction: say why it is not that either
            return replace(c, reason=c.reason + "; not the spindle mode: " + why)
        return c

    if spindle_modes is None:
        cands = [spindle_verdict(c) if c.index != hi_idx else c for c in cands]
    else:
        extra = [spindle_verdict(c) for c in extra]
    spindle = None
    if sbest is not None:
        src = modes if sbest.source == "modes" else spindle_modes
        assert src is not None
        spindle = MatchedMode.from_mapping({
            "natural_freq": float(src.natural_freq[sbest.index]),
            "damping_ratio": float(src.damping_ratio[sbest.index]),
            "model_natural_freq": info.spindle_freq,
        })
    return MatchResult(
        housing_index=int(hi_idx),
        housing_mode=housing,
        spindle_index=None if sbest is None else sbest.index,
        spindle_mode=spindle,
        spindle_source=None if sbest is None else sbest.source,
        candidates=tuple(sorted(cands + extra, key=lambda c: c.natural_freq)),
        valid_range=(lo, hi),
        driving_point=has_dp,
        alternatives=alts,
        neighbours=neigh,
        participation=part,
        warnings=tuple(warns),
        mixed_partner=mixed_partner,
    )


def _driving_point_polarity(modes: ModalModel, index: int, rig: RigConfig, crit: MatchCriteria) -> str | None:
    """A warning when the housing mode's driving-point modal constant has the wrong sign, else None.

    ``2 j w_d R_pp = phi_p^2`` (:func:`~ema_rig.identification.modal.shape_products`) is positive for
    a real mode when the response and the reference DOF are written with one sign (negative with
    opposite signs). Its ``cos`` of the phase from that sign below ``crit.driving_point_min_cos``:
    the excitation (or the driving-point sensor) polarity is reversed, every FRF flipped.
    """
    ref = rig.radial.positive()
    p, q = find_dof(modes.out_dofs, ref), find_dof(modes.in_dofs, ref)
    if p is None or q is None:
        return None
    a = complex(shape_products(modes.poles[index:index + 1], modes.residues[index:index + 1, p, q])[0])
    sign = 1.0 if modes.out_dofs[p] == modes.in_dofs[q] else -1.0
    if not (abs(a) > 0 and math.isfinite(abs(a))):
        return None
    cos = sign * a.real / abs(a)
    if cos >= crit.driving_point_min_cos:
        return None
    return (f"the housing mode's driving-point modal constant at {modes.out_dofs[p]} / {modes.in_dofs[q]} is "
            f"negative (phase {math.degrees(math.atan2(sign * a.imag, sign * a.real)):.0f} deg from positive): "
            f"check the polarity of the excitation (rig file: {rig.radial}; reversed, it flips every FRF) and of the "
            "driving-point sensor (k_TB does not depend on the sign)")


def _ambiguous_harmonics(cands: list[Candidate], used: tuple[int, ...], speed_hz: float | None,
                         crit: MatchCriteria) -> str | None:
    """One warning for the measurement when a mode the result uses sits in a harmonic's window that is no evidence.

    ``used``: the housing mode, the passing alternatives and the close neighbours (indices into
    ``cands``). Their ``harmonic_ambiguous`` (:func:`~ema_rig.rig.candidates.measure_candidates`) marks
    a lightly damped mode inside a window where the windows cover more than
    ``crit.harmonic_max_chance`` of the frequency axis: kept as a mode, though a harmonic line there
    could not be told apart. None when no used mode is marked (every normal run).
    """
    hit = [cands[i] for i in used if cands[i].harmonic_ambiguous is not None]
    if not hit or speed_hz is None:
        return None
    desc = ", ".join(f"{c.natural_freq:.1f} Hz (damping {100 * c.damping_ratio:.2f} %, near {c.harmonic_ambiguous} x)"
                     for c in hit)
    return (f"shaft speed {speed_hz:.3g} Hz: the harmonic windows (+-{100 * crit.harmonic_freq_tol:.1f} % of the "
            f"frequency) cover more than {100 * crit.harmonic_max_chance:.0f} % of the frequency axis, so a mode's "
            f"place on a harmonic is no evidence of a harmonic line; kept as modes: {desc} - check they are not "
            "shaft harmonics (e.g. a measurement at another speed)")


MAX_MESSAGE = 300
"""Longest refusal line [characters]; the full candidate list goes to the JSON."""


def _short(msg: str) -> str:
    return msg if len(msg) <= MAX_MESSAGE else msg[: MAX_MESSAGE - 3] + "..."


def _mixed_pair(c: Candidate, cands: list[Candidate], params: ModelParams, rig: RigConfig,
                crit: MatchCriteria) -> CrossAxisCorrection | None:
    """Candidate ``c`` read as the radial housing mode mixed with a cross-axis partner, or None.

    Only for a mode inside the model's range whose failures are its cross-axis motion (one axis)
    and at most its modal mass; the partner from :func:`cross_axis_partner` (harmonic lines
    excluded), not yet judged (:func:`_pair_holds`).
    """
    kinds = {str(getattr(f, "kind", "")) for f in c.failures}  # Failure texts (plain str from old JSON)
    cross = kinds & {"lateral", "axial"}
    if len(cross) != 1 or not kinds <= {"lateral", "axial", "mass"} or c.model_modal_mass is None:
        return None
    axis = next(iter(cross))
    other = "axial_ratio" if axis == "lateral" else "lateral_ratio"
    if (getattr(c, other) or 0.0) > crit.max_cross_axis_ratio:
        return None
    n_rad = sum(1 for se in rig.sensors if se.role == "housing" and se.axis == "radial")
    pool = [p for p in cands if p.harmonic is None]
    return cross_axis_partner(c.natural_freq, float(getattr(c, f"{axis}_ratio")), pool, f"{axis}_ratio", params.m_H,
                              c.model_modal_mass, min_ratio=crit.max_cross_axis_ratio, n_radial=n_rad,
                              ratio_std=crit.cross_axis_ratio_std, axis=axis, exclude=c.index)


def _pair_holds(c: Candidate, pair: CrossAxisCorrection, crit: MatchCriteria) -> bool:
    """Whether the mixed pair is a two-mode coupling of which ``c`` is the radial housing mode.

    Both ratios tell the same mixing, ``c`` holds the larger radial share
    (:attr:`MatchCriteria.mixed_pair_max_mixing`) and its modal mass over ``1 + t^2`` is the model's.
    """
    lo_m, hi_m = crit.mass_ratio_range
    return (pair.consistent and pair.mixing <= crit.mixed_pair_max_mixing
            and (c.mass_ratio is None or lo_m <= c.mass_ratio / (1.0 + pair.mixing) <= hi_m))


def _refusal(cands: list[Candidate], lo: float, hi: float, rig: RigConfig, crit: MatchCriteria) -> str:
    """One short line: why no mode is the housing mode, naming the most likely cause."""
    inside = [c for c in cands if lo < c.natural_freq < hi]
    head = f"no identified mode matches the radial housing mode ({lo:.0f}-{hi:.0f} Hz, {len(cands)} candidates)"
    if not inside:
        return head + "; none in range"

    def closeness(c: Candidate) -> float:
        return (0.0 if c.mass_ratio is None else abs(math.log(c.mass_ratio))) + 0.5 * len(c.failures)

    nearest = min(inside, key=closeness)
    if all(c.mass_source != "driving point" for c in inside):
        return _short(f"{head}; no radial driving point ({rig.radial}): without it the shapes do not single "
                      f"out the housing mode; nearest {nearest.natural_freq:.1f} Hz: {nearest.failures[0]}")
    sus = [c for c in inside if c.polarity_suspect]
    units = [c for c in inside if any(getattr(f, "kind", None) == "mass units" for f in c.failures)]
    if sus:
        c = sus[0]
        cause = (f"{c.natural_freq:.1f} Hz is a clean translation with {c.polarity_suspect} reversed: "
                 "check its polarity")
    elif units:
        c = units[0]
        cause = f"{c.natural_freq:.1f} Hz: " + next(f for f in c.failures if getattr(f, "kind", None) == "mass units")
    else:
        cause = f"nearest {nearest.natural_freq:.1f} Hz: {nearest.failures[0]}"
        # the partner named: the closest mode in frequency moving the cross-axis sensors more
        key = next((f"{k}_ratio" for k in ("lateral", "axial") if k in {getattr(f, "kind", "") for f in
                                                                          nearest.failures}), "")
        more = [p for p in cands if p.index != nearest.index and key and (getattr(p, key) or 0.0)
                > max(float(getattr(nearest, key) or 0.0), crit.max_cross_axis_ratio)]
        pool = [nearest, *([min(more, key=lambda p: abs(p.natural_freq - nearest.natural_freq))] if more else [])]
        pair = _mixed_pair(nearest, pool, rig.model, rig, crit)
        if pair is not None:  # the true reason: a mixed pair that is no two-mode coupling
            why = ("the two modes' ratios tell different mixings" if not pair.consistent else
                   f"mixing {100 * pair.mixing:.0f} %: the partner holds the larger radial share"
                   if pair.mixing > crit.mixed_pair_max_mixing else
                   "its modal mass over the mixing is not the model's")
            cause = (f"the radial housing mode is mixed with the {pair.axis} mode at {pair.partner_freq:.1f} Hz "
                     f"({pair.axis}/radial {pair.ratio:.2f} at {nearest.natural_freq:.1f} Hz, radial/{pair.axis} "
                     f"{pair.partner_ratio:.2f} there) but {why}")
    return _short(f"{head}; {cause}")


def _judge_housing(c: Candidate, params: ModelParams, lo: float, hi: float, crit: MatchCriteria) -> Candidate:
    """The candidate with its housing-criteria failures, model comparison and reason."""
    fails: list[Failure] = []
    fn = c.natural_freq
    info = model_mode_at(params, fn) if lo < fn < hi else None
    if info is None:
        fails.append(Failure("range", f"outside the housing-mode range {lo:.1f}-{hi:.1f} Hz of the 3DOF model"))
    if c.harmonic is not None:
        fails.append(Failure("harmonic", f"harmonic line {c.harmonic} x shaft speed (damping {c.damping_ratio:.2e})"))
    if not c.radial_sensors:
        fails.append(Failure("no radial sensor", "no radial housing sensor in the data"))
    elif c.radial_phase_cos is None:
        fails.append(Failure("no radial motion", "no radial housing motion"))
    else:
        sr = c.spindle_ratio
        if info is not None and sr is not None:
            tol = crit.spindle_ratio_tol + crit.spindle_ratio_rel_tol * abs(info.spindle_ratio)
            if abs(sr - info.spindle_ratio) > tol:
                kind = "spindle mode: " if abs(sr) > crit.min_spindle_ratio else ""
                fails.append(Failure("spindle ratio",
                                     f"{kind}spindle/housing ratio {sr:.2f}, model {info.spindle_ratio:.2f} (+/- {tol:.2f})"))
        lat, ax = c.lateral_ratio, c.axial_ratio
        if lat is not None and lat > crit.max_cross_axis_ratio and lat >= (ax or 0.0):
            fails.append(Failure("lateral", f"lateral mode (lateral/radial housing motion {lat:.2f})"))
        elif ax is not None and ax > crit.max_cross_axis_ratio:
            fails.append(Failure("axial", f"axial mode (axial/radial motion {ax:.2f})"))
        if c.radial_phase_cos < crit.min_phase_cos:
            fails.append(Failure("tilt", f"tilt: radial housing sensors out of phase (min cos {c.radial_phase_cos:.2f})"))
        if (c.radial_amplitude_ratio or 0.0) < crit.min_amplitude_ratio:
            fails.append(Failure("amplitude",
                f"radial housing amplitudes differ (min/max {_fmt(c.radial_amplitude_ratio, '.2f')}):"
                " not a rigid radial translation"
            ))
    ratio = None
    if info is not None and c.modal_mass is not None:
        ratio = c.modal_mass / info.modal_mass
        lo_m, hi_m = crit.mass_ratio_range
        if not lo_m <= ratio <= hi_m:
            hint = ""
            g = 9.80665
            # a units hint only for a driving-point mass of a mode that is the housing mode's in
            # every other way
            dp = c.mass_source == "driving point"
            if dp and not fails and abs(math.log(ratio / g)) < crit.units_hint_log_tol:
                hint = ": accelerations in g read as m/s^2? check the file's units"
            elif dp and not fails and abs(math.log(ratio * g)) < crit.units_hint_log_tol:
                hint = ": off by a factor g? check the file's units"
            fails.append(Failure("mass units" if hint else "mass",
                f"effective modal mass {c.modal_mass:.3g} kg, model {info.modal_mass:.3g} kg "
                f"(ratio {ratio:.2g}, allowed {lo_m:g}-{hi_m:g}){hint}"
            ))
    sus = c.polarity_suspect
    if sus and len(fails) == 1 and fails[0].kind == "tilt":
        # out of phase is the only objection, and one sign flip makes a clean translation
        fails[0] = Failure("tilt",
            f"radial housing sensors out of phase (min cos {c.radial_phase_cos:.2f}) but a clean "
            f"translation with {sus} reversed: check the polarity (sign) of {sus}"
        )
    else:
        sus = None
    if fails:
        reason = "; ".join(fails)
    else:
        assert info is not None and c.radial_phase_cos is not None
        ev = [f"radial housing sensors in phase (min cos {c.radial_phase_cos:.2f})",
              f"amplitude ratio {_fmt(c.radial_amplitude_ratio, '.2f')}"]
        if c.spindle_ratio is not None:
            ev.append(f"spindle/housing {c.spindle_ratio:.3f} (model {info.spindle_ratio:.3f})")
        if ratio is not None:
            ev.append(f"modal mass {c.modal_mass:.3g} kg (model {info.modal_mass:.3g} kg)")
        reason = ", ".join(ev)
    return replace(
        c, status="rejected", reason=reason, failures=tuple(fails), polarity_suspect=sus,
        model_modal_mass=None if info is None else info.modal_mass,
        model_spindle_ratio=None if info is None else info.spindle_ratio, mass_ratio=ratio,
    )


def _judge_spindle(c: Candidate, info: ModelModeInfo, crit: MatchCriteria) -> tuple[bool, str]:
    """Is candidate ``c`` the spindle bending mode predicted by ``info``?"""
    fails = []
    fn = c.natural_freq
    rel = fn / info.spindle_freq - 1.0
    if abs(rel) > crit.spindle_freq_tol:
        fails.append(
            f"{fn:.1f} Hz is {100 * rel:+.0f} % from the model's spindle mode {info.spindle_freq:.1f} Hz"
        )
    if c.harmonic is not None:
        fails.append(f"harmonic line {c.harmonic} x shaft speed")
    sr = c.spindle_ratio
    if sr is None:
        fails.append("no spindle radial sensor")
    elif not sr <= -crit.min_spindle_ratio:
        fails.append(
            f"spindle/housing ratio {sr:.2f}: the spindle bending mode moves the spindle "
            f"in anti-phase and more than the housing (model {info.spindle_mode_ratio:.2f})"
        )
    sa = c.spindle_axial_ratio
    if sa is not None and sa > crit.max_spindle_axial_ratio:
        fails.append(f"axial spindle motion dominates (axial/radial {sa:.2f})")
    return (not fails), "; ".join(fails)
