"""The whole identification of one measurement: pLSCF -> stabilization -> judgement -> LSFD.

Functions
---------
identify
    What the stiffness pipeline and the campaign call for every measurement: the model order
    grows (reusing the leading blocks of one pLSCF estimate) until the judged mode set converges.
default_order_cap
    Default cap on the model order.
transpose_layout
    The same FRFs with references and responses exchanged (reciprocity).

Classes
-------
Identification
    Frozen result: pole set, stabilization data, selection, modal model, per-mode spread,
    every candidate with its verdict, convergence, warnings and notes.
"""

from __future__ import annotations

import html
import os
import warnings as _warnings
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from .._blas import in_callers_limit, single_threaded
from .._threads import Job
from ..errors import IdentificationError
from ..frf import FORM_POWER as _FORM_POWER
from ..frf import FRFData
from ..processing import processing_history, usable_band
from .criteria import (
    ML_CRITERIA,
    RESULT_CRITERIA,
    WINDOW_ENBW,
    CompletenessCriteria,
    IdentificationCriteria,
    ResultCriteria,
    StabilizationCriteria,
)
from .diagnose import diagnose_frf, noise_only_outputs, noisier_outputs
from .judge import Candidate, _fit, judge_clusters, shape_mpc
from .lsfd import LsfdBasis, _lsfd_checked, _lsfd_noise_weighted, model_order
from .mac import mac
from .ml import LocalML, StagedML, local_ml_staged
from .modal import ModalModel
from .noise import MisfitTest, SegmentFits, segment_edges, segment_misfit, segment_pole_columns
from .plscf import PlscfEngine, PoleSet, check_data, default_max_order, source_of
from .refine import Refinement
from .refine import refine as refine_model
from .stabilization import (
    SelectedMode,
    Selection,
    StabilizationData,
    cluster_poles,
    resolve_selection,
    stabilize,
)
from .window_damping import processing_band, remove_window_damping

#: What every printed ± of a mode is (CLI, JSON, notebook, report say the same).
STD_LABEL = "measured: one standard uncertainty of the ML estimate (robust covariance)"

#: Median synthesis error above which an identification is flagged as a poor fit
#: (:attr:`~ema_rig.identification.criteria.ResultCriteria.poor_fit`, with its source).
POOR_FIT = RESULT_CRITERIA.poor_fit


@dataclass(frozen=True, slots=True, eq=False)
class Identification:
    """Result of :func:`identify`.

    Parameters
    ----------
    poles : PoleSet
        Poles of every model order.
    stabilization : StabilizationData
        The same rows with their status letters.
    selection : Selection
        The physical modes (automatic, replayed or hand-picked).
    modes : ModalModel
        LSFD on the band with the selection's representative poles (sorted by frequency).
    natural_freq_std, damping_ratio_std : ndarray, shape (n_modes,)
        Spread of the natural frequency [Hz] and damping ratio across each mode's cluster,
        aligned with ``modes``.
    band : tuple of float
        Band [Hz] of the identification.
    candidates : tuple of Candidate
        Every cluster of stable poles with its verdict and reason (accepted ones are the
        automatic selection; empty for a replayed selection).
    converged : bool
        True when the selected mode set was the same over the last span of model orders.
    warnings : tuple of str
        One line per reason to distrust the result (poor fit, no convergence, mode at the
        band edge, ...).
    notes : tuple of str
        What was done besides the plain chain (band clipped, order capped, transposed layout).
    transposed : bool
        True when the poles were estimated on the transposed layout (reciprocity: the
        references as outputs), because the data had more references than outputs.
    refinement : Refinement or None
        The maximum-likelihood refinement when ``identify(..., refine=True)``; when it converged,
        ``modes`` is its model and the standard deviations are its Fisher-information ones.
    natural_freq_spread, damping_ratio_spread : ndarray, shape (n_modes,)
        Spread of each mode's pole cluster across the model orders: a diagnostic of the
        stabilization chart, never an uncertainty (empty when not available).
    std_kind : tuple of str
        What each mode's ``natural_freq_std`` / ``damping_ratio_std`` is: ``"ml"`` (measured
        standard uncertainty of the ML estimate, robust covariance), ``"held"`` (mode kept at its
        PolyMAX pole; the ML uncertainty at that pole), ``"none"`` (NaN, the warning says why).
    residual_test : MisfitTest or None
        The completeness test of the final model: the residual against the noise estimate per
        band segment and channel (:func:`~ema_rig.identification.noise.segment_misfit`); None for
        a replayed selection.
    """

    poles: PoleSet
    stabilization: StabilizationData
    selection: Selection
    modes: ModalModel
    natural_freq_std: NDArray[np.float64]
    damping_ratio_std: NDArray[np.float64]
    band: tuple[float, float]
    candidates: tuple[Candidate, ...] = ()
    converged: bool = True
    warnings: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    transposed: bool = False
    refinement: Refinement | None = None
    natural_freq_spread: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    damping_ratio_spread: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    std_kind: tuple[str, ...] = ()
    residual_test: MisfitTest | None = None

    def __repr__(self) -> str:
        """One line per mode, not the arrays (a notebook prints this)."""
        head = (f"Identification({self.modes.n_modes} modes, band {self.band[0]:g}-{self.band[1]:g} Hz, "
                f"{'converged' if self.converged else 'NOT converged'}"
                f"{', ML-refined' if self.refinement is not None and self.refinement.converged else ''}, "
                f"{len(self.warnings)} warning(s))")
        head += f"\n  ± = {self.std_label}"
        rows = [f"  {f:10.3f} Hz ± {sf:.3g}   zeta {100 * z:6.3f} % ± {100 * sz:.2g}"
                for f, sf, z, sz in zip(self.natural_freq, self.natural_freq_std, self.damping_ratio,
                                        self.damping_ratio_std, strict=True)]
        return "\n".join([head, *rows, *(f"  warning: {w}" for w in self.warnings)])

    def _repr_html_(self) -> str:
        rows = "".join(
            f"<tr><td>{f:.3f}</td><td>{sf:.3g}</td><td>{100 * z:.3f}</td><td>{100 * sz:.2g}</td></tr>"
            for f, sf, z, sz in zip(self.natural_freq, self.natural_freq_std, self.damping_ratio,
                                    self.damping_ratio_std, strict=True))
        warns = "".join(f"<li>{html.escape(w)}</li>" for w in self.warnings)
        return (f"<p><b>Identification</b>: {self.modes.n_modes} modes, band {self.band[0]:g}–{self.band[1]:g} Hz, "
                f"{'converged' if self.converged else '<b>not converged</b>'}; ± = {html.escape(self.std_label)}</p>"
                "<table><tr><th>f_n [Hz]</th><th>± [Hz]</th><th>ζ [%]</th><th>± [%]</th></tr>"
                f"{rows}</table>" + (f"<ul>{warns}</ul>" if warns else ""))

    @property
    def std_label(self) -> str:
        """What ``natural_freq_std`` / ``damping_ratio_std`` are (printed beside every ±)."""
        if self.refinement is not None and self.refinement.converged:
            return ("measured: one standard uncertainty, Fisher information of the global ML refinement "
                    "(noise only); modes it could not refine: " + STD_LABEL.removeprefix("measured: "))
        return STD_LABEL

    @property
    def fit_error(self) -> NDArray[np.float64]:
        """Relative synthesis error per channel ``||H - H_syn|| / ||H||``, shape (n_out, n_in)."""
        fe = self.modes.fit_error
        return np.zeros((len(self.modes.out_dofs), len(self.modes.in_dofs))) if fe is None else fe

    @property
    def natural_freq(self) -> NDArray[np.float64]:
        """Natural frequencies of the modal model [Hz], shape (n_modes,)."""
        return self.modes.natural_freq

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """Damping ratios of the modal model, shape (n_modes,)."""
        return self.modes.damping_ratio

    def best_reference(self) -> NDArray[np.intp]:
        """Index (into ``modes.in_dofs``) of the reference that excites each mode best, shape (n_modes,)."""
        mm = self.modes
        drive = [q for q, d in enumerate(mm.in_dofs) if d in mm.out_dofs]
        if drive:
            mass = np.stack([mm.modal_mass(mm.in_dofs[q]) for q in drive], axis=1)
            return cast("NDArray[np.intp]", np.asarray(drive)[np.argmin(mass, axis=1)])
        col = np.linalg.norm(mm.residues, axis=1)  # (n_modes, n_in)
        return cast("NDArray[np.intp]", np.argmax(col, axis=1))

    def best_shapes(self) -> NDArray[np.complex128]:
        """Each mode's shape from its best reference (mass-normalised at a driving point), (n_modes, n_out)."""
        mm = self.modes
        best = self.best_reference()
        out = np.empty((mm.n_modes, len(mm.out_dofs)), np.complex128)
        for q in np.unique(best):
            shapes = mm.mode_shapes(mm.in_dofs[q])
            out[best == q] = shapes[best == q]
        return out

    def to_records(self) -> list[dict[str, Any]]:
        """One dict per mode: frequency, damping, their spread, MPC, provenance, fit error.

        ``modal_mass`` holds the effective modal mass [kg] at every driving point (reference
        DOF that is also a response DOF), keyed by DOF string. ``mpc`` is computed on each
        mode's residues along the longer axis of the measurement (the outputs of the strongest
        reference, or the references of the strongest output for a roving-hammer layout).
        ``order_min`` .. ``order_max`` are the model orders over which the mode is stable.
        """
        mm = self.modes
        mpcs = shape_mpc(mm.residues)
        drive = [d for d in mm.in_dofs if d in mm.out_dofs]
        masses = {str(d): mm.modal_mass(d) for d in drive}
        modes_by_pole = {m.pole: m for m in self.selection.modes}
        # a refined model keeps the PolyMAX pole of each mode in meta (same order)
        start = [complex(*p) for p in mm.meta.get("polymax_poles", [])] or [complex(p) for p in mm.poles]
        out = []
        spread_f = self.natural_freq_spread if self.natural_freq_spread.size == mm.n_modes else None
        spread_z = self.damping_ratio_spread if self.damping_ratio_spread.size == mm.n_modes else None
        for k in range(mm.n_modes):
            sel: SelectedMode | None = modes_by_pole.get(start[k])
            out.append(
                {
                    "natural_freq": float(mm.natural_freq[k]),
                    "damping_ratio": float(mm.damping_ratio[k]),
                    "natural_freq_std": float(self.natural_freq_std[k]),
                    "damping_ratio_std": float(self.damping_ratio_std[k]),
                    "mpc": float(mpcs[k]),
                    "n_poles": int(sel.n_poles) if sel else None,
                    "order": int(sel.order) if sel else None,
                    "provenance": sel.provenance if sel else None,
                    "modal_mass": {d: float(v[k]) for d, v in masses.items()},
                    "participation": [[float(c.real), float(c.imag)] for c in sel.participation] if sel else [],
                    "order_min": int(sel.order_min) if sel else None,
                    "order_max": int(sel.order_max) if sel else None,
                    "std_kind": self.std_kind[k] if len(self.std_kind) == mm.n_modes else None,
                    "natural_freq_spread": None if spread_f is None else float(spread_f[k]),
                    "damping_ratio_spread": None if spread_z is None else float(spread_z[k]),
                }
            )
        return out


def default_order_cap(n_in: int) -> int:
    """Default cap on the model order for ``n_in`` references: four times :func:`default_max_order`."""
    return 4 * default_max_order(n_in)


def _clip_band(data: FRFData, band: tuple[float, float] | None) -> tuple[tuple[float, float] | None, list[str]]:
    """Clip a band that exceeds the data by less than one frequency step (with a note)."""
    if band is None:
        return None, []
    try:
        lo, hi = float(band[0]), float(band[1])
    except (TypeError, ValueError, IndexError):
        return band, []  # check_data explains
    f0, f1 = float(data.freq[0]), float(data.freq[-1])
    step = float(np.median(np.diff(data.freq))) if data.n_freq > 1 else 0.0
    notes = []
    if f0 - step <= lo < f0:
        notes.append(f"band start {lo:g} Hz clipped to the first line {f0:g} Hz")
        lo = f0
    if f1 < hi <= f1 + step:
        notes.append(f"band end {hi:g} Hz clipped to the last line {f1:g} Hz")
        hi = f1
    return (lo, hi), notes


def transpose_layout(data: FRFData) -> FRFData:
    """The same FRFs with references and responses exchanged (reciprocity ``H_pq = H_qp``).

    Roles and axes, which describe the outputs, are dropped.
    """
    return FRFData(data.freq, np.swapaxes(data.frf, 0, 1), data.in_dofs, data.out_dofs,
                   frf_form=data.frf_form, meta=data.meta)


def _same_modes(a: Sequence[SelectedMode], b: Sequence[SelectedMode]) -> bool:
    """Same number of modes, each frequency of ``a`` matched in ``b`` within the spread."""
    if len(a) != len(b):
        return False
    for ma, mb in zip(a, b, strict=True):
        tol = max(3.0 * max(ma.natural_freq_std, mb.natural_freq_std), 1e-3 * ma.natural_freq)
        if abs(ma.natural_freq - mb.natural_freq) > tol:
            return False
    return True


def _edge_warnings(model: ModalModel, band: tuple[float, float], crit: ResultCriteria = RESULT_CRITERIA) -> list[str]:
    lo, hi = band
    out = []
    for fn, zeta in zip(model.natural_freq.tolist(), model.damping_ratio.tolist(), strict=True):
        margin = max(crit.edge_hbw * zeta * fn, crit.edge_band_share * (hi - lo))
        if fn - lo < margin or hi - fn < margin:
            out.append(f"mode at {fn:.6g} Hz sits at the band edge ({lo:g}..{hi:g} Hz): "
                       "its estimate may be biased; widen the band")
    return out


def _beyond_the_band(data: FRFData, band: tuple[float, float] | None) -> str:
    """What lies above the band's upper end: the end of the usable (analyser) band, of the data, or more data."""
    hi = float(data.freq[-1]) if band is None else min(float(band[1]), float(data.freq[-1]))
    df = float(np.median(np.diff(data.freq))) if data.freq.size > 1 else 0.0
    hist = processing_history(data)
    top = usable_band(hist)
    if top is not None and hist is not None and hi >= top - df:
        return f"above the analyser band ({top:g} Hz, {hist.source}): these FRFs cannot resolve it"
    if hi >= float(data.freq[-1]) - df:
        return f"above the last line of the data ({float(data.freq[-1]):g} Hz)"
    return "widen the band to include it"


def _edge_magnitude(data: FRFData, crit: ResultCriteria) -> NDArray[np.float64]:
    """The magnitude :func:`_skirt_warnings` and :func:`_low_edge` test, shape (n_freq,): rms over the channels,
    running median of ``crit.skirt_lines`` lines."""
    from scipy.ndimage import median_filter

    mag: NDArray[np.float64] = median_filter(np.sqrt(np.mean(np.abs(data.frf) ** 2, axis=(0, 1))),
                                             size=int(crit.skirt_lines), mode="nearest")
    return mag


def _skirt_warnings(data: FRFData, model: ModalModel, crit: ResultCriteria, beyond: str,
                    mag: NDArray[np.float64] | None = None) -> list[str]:
    """A warning when the FRFs rise towards the upper band edge as the skirt of a mode above the band does.

    Above the highest mode (beyond ``edge_hbw`` half-power half-bandwidths), the lines from the minimum
    of the magnitude (rms over the channels, running median of ``skirt_lines``) to the band's end are
    tested: a rise more than ``skirt_rise`` times the upper residual's ``(f_edge / f_min)^p`` with a
    median relative synthesis error above ``poor_fit`` there. ``data`` are cut to the band; ``mag`` their
    :func:`_edge_magnitude` when the caller has it.
    """
    f = data.freq
    n_s = int(crit.skirt_lines)
    if model.n_modes == 0 or f.size < 2 * n_s:
        return []
    r = int(np.argmax(model.natural_freq))
    start = int(np.searchsorted(f, model.natural_freq[r] * (1 + crit.edge_hbw * model.damping_ratio[r])))
    if start > f.size - n_s:
        return []
    mag = _edge_magnitude(data, crit) if mag is None else mag
    i = start + int(np.argmin(mag[start:]))
    if f.size - i < n_s or not mag[i] > 0 or not f[i] > 0:
        return []
    rise = float(mag[-1] / mag[i])
    ur_rise = float((f[-1] / f[i]) ** _FORM_POWER[data.frf_form])
    if rise <= crit.skirt_rise * ur_rise:
        return []  # (the synthesis error is tested only for a rise)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(data.frf[:, :, i:] - model.synthesize(f[i:]).frf) / np.abs(data.frf[:, :, i:])
    err = float(np.nanmedian(np.where(np.isfinite(rel), rel, np.nan))) if np.any(np.isfinite(rel)) else 0.0
    if rise <= crit.skirt_rise * ur_rise or not err > crit.poor_fit:
        return []
    return [f"the FRFs rise {rise:.3g}x from {f[i]:.6g} Hz to the band's end at {f[-1]:.6g} Hz (the upper residual "
            f"only {ur_rise:.3g}x) and the modal model misses them by {100 * err:.0f} % there (median over the lines): "
            f"the skirt of a mode above the band, not reported ({beyond}); the residual terms stand only for modes "
            "far from the band, so the synthesis and the residues near that edge are biased"]


def _low_edge(data: FRFData, model: ModalModel, crit: ResultCriteria,
              mag: NDArray[np.float64] | None = None) -> tuple[float, str] | None:
    """Where the band should start, and why, when the FRFs fall from the lower band edge more than the
    lower residual can (the mirror of :func:`_skirt_warnings`); None when they do not.

    Below the lowest mode (beyond ``edge_hbw`` half-power half-bandwidths), the lines from the band's
    start to the minimum of the magnitude (rms over the channels, running median of ``skirt_lines``)
    are tested: a fall more than ``skirt_rise`` times the lower residual's own ``(f_min / f_start)^(2 - p)``
    with a median relative synthesis error above ``poor_fit`` there. At 0 Hz that is the DC line (an
    offset, drift, or a sensor's high-pass), which no mode or residual term represents and which
    biases the whole fit. ``data`` are cut to the band; ``mag`` their :func:`_edge_magnitude` when the
    caller has it. Returns the frequency of that minimum [Hz] and the finding.
    """
    f = data.freq
    n_s = int(crit.skirt_lines)
    if model.n_modes == 0 or f.size < 2 * n_s:
        return None
    r = int(np.argmin(model.natural_freq))
    stop = int(np.searchsorted(f, model.natural_freq[r] * (1 - crit.edge_hbw * model.damping_ratio[r])))
    if stop < n_s:
        return None
    mag = _edge_magnitude(data, crit) if mag is None else mag
    i = int(np.argmin(mag[:stop]))
    if i < n_s or not mag[i] > 0:
        return None
    fall = float(mag[0] / mag[i])
    p = _FORM_POWER[data.frf_form]
    if f[0] > 0:
        lr_fall = float((f[i] / f[0]) ** (2 - p))
    else:  # at 0 Hz the lower residual of mobility or receptance is infinite: it can follow any fall
        lr_fall = 1.0 if p == 2 else float("inf")
    if fall <= crit.skirt_rise * lr_fall:
        return None  # (the synthesis error is tested only for a fall)
    with np.errstate(divide="ignore", invalid="ignore"):
        rel = np.abs(data.frf[:, :, : i + 1] - model.synthesize(f[: i + 1]).frf) / np.abs(data.frf[:, :, : i + 1])
    err = float(np.nanmedian(np.where(np.isfinite(rel), rel, np.nan))) if np.any(np.isfinite(rel)) else 0.0
    if fall <= crit.skirt_rise * lr_fall or not err > crit.poor_fit:
        return None
    return float(f[i]), (f"the FRFs fall {fall:.3g}x from the band's start at {f[0]:.6g} Hz to {f[i]:.6g} Hz (the lower residual "
            f"only {lr_fall:.3g}x) and the modal model misses them by {100 * err:.0f} % there (median over the "
            "lines): low-frequency content no mode or residual term represents (near 0 Hz: a DC offset, drift or a "
            "sensor's high-pass), which biases the whole fit")


#: FRF values (channels x lines) from which :func:`identify` forms the data's findings
#: (:func:`~ema_rig.identification.diagnose.diagnose_frf`, ~10 ns a value) in a second thread while the
#: modes are estimated: below, they cost less than a thread's start. A work-size rule: the same on any machine.
_DIAGNOSE_THREAD_MIN_LINES = 100_000


def identify(
    data: FRFData,
    *,
    band: tuple[float, float] | None = None,
    max_order: int | None = None,
    freq_tol: float | None = None,
    damping_tol: float | None = None,
    mac_tol: float | None = None,
    selection: Selection | None = None,
    near_tol: float = 0.03,
    residuals: bool = True,
    progress: bool = False,
    time_budget: float | None = None,
    transpose: bool | None = None,
    refine: bool = False,
    criteria: IdentificationCriteria | None = None,
    harmonic_bands: Sequence[tuple[float, float]] = (),
) -> Identification:
    """Identify the physical modes of a measurement in a band.

    The model order grows from :func:`~ema_rig.identification.plscf.default_max_order` in
    steps of a quarter of it until the automatically selected mode set is the same (same
    number of modes, frequencies within three standard deviations of their cluster, at least
    0.1 %) at two orders one step apart, up to the cap ``max_order``. The mode set is then
    complete when the residual of its model (LSFD at the ML poles) is consistent with the noise
    estimate in every band segment and channel (:func:`~ema_rig.identification.noise.segment_misfit`,
    a chi-square test with its degrees of freedom). Where a segment fails, a rejected candidate
    in it is added when the lines near it need it (a local misfit around a peak is a missing mode:
    a nested F test on those lines, the model re-estimated there with and without it, so two
    bands holding the lines decide alike). An accepted mode whose ML estimate moved to between
    its PolyMAX pole and a rejected cluster beside it is tested the same way, 2 modes against 1
    (``CompletenessCriteria.split_sigmas``). A failing segment without any candidate cluster makes the order grow
    by one more span (``CompletenessCriteria.max_extra_steps``) when that changes the modes in the
    failing segments; a segment fails here also when the lines of a core of its modes (modes each
    inside every other's core, not a chain) exceed the noise, and the higher order's verdicts are
    taken in the failing segments only (elsewhere the mode set had converged). Segments that still fail are named: in a warning when the order cap stopped
    the growth, else in a note (a higher order changed nothing there). Only work limits (orders, evaluations) stop a loop, never the clock:
    the same data give the same result on any machine and load.
    Every cluster of stable poles is judged (:func:`~ema_rig.identification.judge.judge_clusters`);
    the accepted ones are fitted by LSFD on the data as measured. The poles are estimated without
    the outputs whose phase is that of noise alone (a dead sensor:
    :func:`~ema_rig.identification.diagnose.noise_only_outputs`) and, with coherence, those whose
    relative noise is beyond the break-even of PolyMAX's equal (``1 / rms``) weights
    (:func:`~ema_rig.identification.diagnose.noisier_outputs`); a note names them.

    Parameters
    ----------
    data : FRFData
        FRFs, shape (n_out, n_in, n_freq).
    band : (float, float), optional
        ``(freq_lower, freq_upper)`` [Hz]; default the whole data. A band that exceeds the
        data by less than one frequency step is clipped to the data (with a note).
    max_order : int, optional
        Cap on the model order (default :func:`default_order_cap`: 256 for one reference,
        160 for several). Reduced, with a note, to the largest order the band's lines allow
        (fewer than half the lines; ``R`` positive definite, which a gap in the lines limits).
    freq_tol, damping_tol, mac_tol : float, optional
        Stabilization tolerances (defaults 1 %, 5 %, 2 %), see
        :func:`~ema_rig.identification.stabilization.stabilize`.
    selection : Selection, optional
        A saved selection to replay (:func:`~ema_rig.identification.stabilization.resolve_selection`:
        exact on the same data, nearest mode within ``near_tol`` on other data); its band and
        maximum order are used unless ``band`` / ``max_order`` are given (no order growth).
    near_tol : float, optional
        Relative frequency window for replaying a selection on other data (default 0.03).
    residuals : bool, optional
        LSFD with lower and upper residuals (default True).
    progress : bool, optional
        Progress bar over the model orders.
    time_budget : float, optional
        Deprecated and ignored (a wall-clock budget made the result depend on the machine's
        load); the order cap ``max_order`` is the work limit.
    transpose : bool, optional
        Estimate the poles on the transposed layout (reciprocity). Default: when the data have
        more references than outputs (roving hammer), which gives the estimator more outputs.
    refine : bool, optional
        Refine the modal model by maximum likelihood
        (:func:`~ema_rig.identification.refine.refine`, using ``data.coherence`` when present) and
        report its Fisher-information standard deviations (default False). When it does not
        converge, the PolyMAX model and cluster spreads are kept with an
        :class:`~ema_rig.errors.IdentificationWarning` giving the reason.
    criteria : IdentificationCriteria, optional
        The thresholds of every stage with their sources
        (:class:`~ema_rig.identification.criteria.IdentificationCriteria`); ``freq_tol``,
        ``damping_tol``, ``mac_tol`` given replace the fields of its ``stabilization``.
    harmonic_bands : sequence of (float, float), optional
        Frequency intervals ``(f_lo, f_hi)`` [Hz] that hold known sharp lines which are no modes of
        the structure (the shaft harmonics of a rotating bearing:
        :func:`ema_rig.rig.candidates.harmonic_bands`). The split test's own-lines chi-square test
        (``CompletenessCriteria.split_misfit``) leaves the lines inside them out, with its degrees of
        freedom reduced by theirs. Default none: every line counts.

    Returns
    -------
    Identification

    Raises
    ------
    IdentificationError
        Band outside the data, an all-zero FRF, NaN/inf values, a cap below the smallest
        order, no stable pole in the band, no physical mode, or a replayed mode not found.

    Examples
    --------
    >>> import numpy as np
    >>> from ema_rig.frf import FRFData
    >>> f = np.arange(0.0, 400.5, 0.5)
    >>> jw = 2j * np.pi * f
    >>> lam = -0.01 * 2 * np.pi * 150 + 2j * np.pi * 150 * np.sqrt(1 - 0.01**2)
    >>> h = (1 / (jw - lam) + 1 / (jw - lam.conjugate()))[None, None] / (4j * np.pi * 150)
    >>> ident = identify(FRFData(f, h, ["1+Y"], ["1+Y"], frf_form="receptance"), band=(50, 350))
    >>> ident.natural_freq.round(5), ident.damping_ratio.round(6)
    (array([150.]), array([0.01]))
    """
    if time_budget is not None:
        _warnings.warn("identify(time_budget=...) is deprecated and ignored: the order growth stops at the "
                       "order cap (max_order) only, so the result does not depend on the machine's load",
                       DeprecationWarning, stacklevel=2)
    if any(not (np.isfinite(lo) and np.isfinite(hi) and lo <= hi) for lo, hi in harmonic_bands):
        raise ValueError(f"harmonic_bands must be finite (f_lo, f_hi) pairs with f_lo <= f_hi, got {harmonic_bands!r}")
    if selection is not None and not isinstance(selection, Selection):
        raise TypeError(f"selection must be a Selection, got {type(selection).__name__}")
    crit = IdentificationCriteria() if criteria is None else criteria
    if not isinstance(crit, IdentificationCriteria):
        raise TypeError(f"criteria must be an IdentificationCriteria, got {type(crit).__name__}")
    tols = {k: v for k, v in (("freq_tol", freq_tol), ("damping_tol", damping_tol), ("mac_tol", mac_tol))
            if v is not None}
    stab_crit: StabilizationCriteria = replace(crit.stabilization, **tols) if tols else crit.stabilization
    if selection is not None:
        # replay: the selection's band and order unless given explicitly
        band = selection.band if band is None else band
        max_order = selection.max_order if max_order is None and selection.max_order >= 1 else max_order
    src = source_of(data)
    # no band given: the whole data, unless its low lines hold what no model represents (_low_edge)
    default_band, measured = band is None, data
    band, hist_notes = processing_band(data, band)  # issue 18: the usable (anti-alias) band
    band, notes = _clip_band(data, band)
    notes = hist_notes + notes
    if data.meta.get("units_assumed"):  # read_uff58: the file states no units (m_eff [kg] etc. rest on SI)
        notes.append(f"units: {data.meta['units_assumed']}; effective masses [kg], residues and mode shapes "
                     "are in SI only if the file is")
    beyond = _beyond_the_band(data, band)
    data = check_data(data, band)
    # what makes the FRFs themselves suspect (phase noise, coherence at the peak) depends on the data
    # alone: on many channels a second thread forms it meanwhile (joined below: the same findings)
    findings: Job[list[str]] | None = None
    if data.frf.size >= _DIAGNOSE_THREAD_MIN_LINES:
        side = ThreadPoolExecutor(1)
        findings = Job(partial(diagnose_frf, data), side)
        side.shutdown(wait=False)  # its thread ends once the findings are formed
    # caveats the reader attached to the data (e.g. coherence above 1 clipped) travel with the result
    warnings: list[str] = [f"data: {w}" for w in data.meta.get("warnings", ()) if isinstance(w, str)]
    transposed = (data.n_in > data.n_out) if transpose is None else bool(transpose)
    if selection is not None and selection.in_dofs:
        # a replayed selection fixes the layout its participation vectors belong to
        transposed = tuple(str(d) for d in data.out_dofs) == selection.in_dofs and data.n_in != data.n_out
    work = transpose_layout(data) if transposed else data
    if transposed:
        notes.append(f"poles estimated on the transposed layout ({work.n_out} outputs x {work.n_in} reference(s), "
                     "reciprocity) because the data have more references than outputs")
    n_in = work.n_in
    min_order = 2 if n_in == 1 else 1
    explicit = max_order is not None
    cap = int(max_order) if explicit else default_order_cap(n_in)  # type: ignore[arg-type]
    if cap < min_order:
        raise IdentificationError(
            f"max_order={cap} is below the smallest useful order {min_order} for {n_in} reference(s) "
            "(order 1 of a single reference has no complex pole pair)", file=src)
    line_cap = (work.n_freq - 1) // 2
    if cap > line_cap:
        if explicit or line_cap < default_max_order(n_in):
            notes.append(f"max_order reduced from {cap} to {line_cap}: the band holds {work.n_freq} lines "
                         f"(the order must stay below half the number of lines)")
        cap = line_cap
    if cap < min_order:
        raise IdentificationError(f"only {work.n_freq} lines in the band: too few for any model order", file=src)
    step = 2 if n_in == 1 else 1
    # PolyMAX weights each output by 1 / rms: a dead channel's noise would weigh as much as another's resonances
    # and a channel far noisier than the others adds more noise than information
    dead = noise_only_outputs(work, stab_crit.noise_only_p)
    dead &= ~dead.all()  # none is left out when every output looks like noise
    # the break-even among the outputs the fit keeps: at least two of them stay
    noisy = noisier_outputs(work, stab_crit.noisier_output, dead)
    if dead.any() or noisy.any():
        left_out = [f"{', '.join(str(work.out_dofs[o]) for o in np.flatnonzero(x))} ({w})" for x, w in (
            (dead, f"its phase is that of noise alone: binomial test of the phase jumps, p > {stab_crit.noise_only_p:g}"),
            (noisy, "its relative noise from the coherence above the break-even of an equally weighted fit"))
            if x.any()]
        notes.append(f"poles estimated without {'; '.join(left_out)}; the residues are fitted on every channel")
        engine = PlscfEngine(work.sel(out=[work.out_dofs[o] for o in np.flatnonzero(~(dead | noisy))]), cap)
    else:
        engine = PlscfEngine(work, cap)
    if engine.order_limit < cap:
        if engine.order_limit < min_order:
            raise IdentificationError(
                f"the lines of {work.freq[0]:g}..{work.freq[-1]:g} Hz support no model order (the basis matrix "
                "R is singular: a gap or very uneven spacing in the frequency lines?); choose a band without gaps",
                file=src)
        notes.append(f"max_order reduced from {cap} to {engine.order_limit}: the band's lines leave the basis "
                     "matrix R singular above it (a gap or very uneven spacing in the frequency lines)")
        cap = engine.order_limit

    def orders_to(n: int) -> list[int]:
        return list(range(step, n + 1, step)) or [n]

    def stabilized(n: int) -> StabilizationData:
        return stabilize(engine.poles(orders_to(n), progress=progress), criteria=stab_crit)

    candidates: tuple[Candidate, ...] = ()
    converged = True
    fitted: _Fitted | None = None
    residual_test: MisfitTest | None = None
    if selection is not None:
        stab = stabilized(cap)
        _require_stable(stab, cap, src, data, low_cap=n_in if explicit and cap < default_max_order(n_in) else None)
        try:
            sel = resolve_selection(stab, selection, tol=near_tol, source=src)
        except IdentificationError as exc:
            raise IdentificationError(exc.message, file=src) from None
        warnings += [f"mode at {m.natural_freq:.2f} Hz tracked from the replayed selection by frequency order "
                     f"(no mode within {100 * near_tol:g} % of a selected one): check it on the chart"
                     for m in sel.modes if m.provenance == "tracked"]
        warnings += _picks_not_found(selection, sel, src)
    else:
        # grow the order until the accepted mode set holds over one span of orders
        start = min(default_max_order(n_in), cap)
        span = max(2 * step, (start // 4) // step * step)
        prev_n = max(start - span, min_order)
        n = start
        prev: list[SelectedMode] | None = None
        history = []
        prev_order = prev_n
        judged_basis: list[LsfdBasis] = []  # the judgement's last LSFD basis: the fit of the accepted modes takes it over
        while True:
            stab = stabilized(n)
            clusters = cluster_poles(stab, criteria=stab_crit)
            judged_basis.clear()
            candidates = judge_clusters(stab, data, clusters=clusters, criteria=crit.judge, basis_out=judged_basis)
            cur = [c.mode for c in candidates if c.accepted]
            history.append(f"{n}: {len(cur)}")
            if prev is None:
                # the orders up to prev_n are a leading part of the same estimate (same status
                # letters, and the first rows of the pole set). When exactly the modes accepted
                # now already pass the stability rules there (the same clusters cut to those
                # orders), the LSFD verdicts, which judge the same modes, are taken over.
                early = _up_to(stab, prev_n)
                k = len(early)
                cut = [r[r < k] for r in clusters if np.any(r < k)]
                prev = [c.mode for c in judge_clusters(early, data, fit=False, clusters=cut, criteria=crit.judge)
                        if c.accepted]
                if not _same_modes(prev, cur):
                    prev = [c.mode for c in judge_clusters(early, data, criteria=crit.judge) if c.accepted]
            converged = bool(cur) and _same_modes(prev, cur)
            if converged or n >= cap:
                break
            prev, prev_order, n = cur, n, min(n + span, cap)
        _require_stable(stab, n, src, data, low_cap=n_in if explicit and cap < default_max_order(n_in) else None)
        notes.append(f"model order grown to {n} (modes per order: {', '.join(history)}); "
                     + ("the mode set converged" if converged else "the mode set did NOT converge"))
        # ---- complete: the residual of the model consistent with the noise in every segment ----
        if cur:
            judged, judged_c = cur, candidates
            done = _complete(data, cur, candidates, residuals, crit, judged_basis[0] if judged_basis else None)
            cur, candidates, fitted = done.modes, done.candidates, done.fitted
            step_i = tried = 0
            last_fail = done.test.failing()
            fails = _failing_locally(data, done, crit.completeness)

            def uncovered(d: _Completed, fails: list[tuple[float, float]]) -> bool:
                """A failing segment without any candidate cluster: only a higher order can add one."""
                return any(not any(a <= c.natural_freq <= b for c in d.candidates) for a, b in fails)

            while (fails and uncovered(done, fails) and n < cap
                   and step_i < crit.completeness.max_extra_steps):
                step_i += 1
                n_new = tried = min(n + span, cap)
                stab_new = stabilized(n_new)
                clusters = cluster_poles(stab_new, criteria=stab_crit)
                judged_basis.clear()
                cand_new = judge_clusters(stab_new, data, clusters=clusters, criteria=crit.judge, basis_out=judged_basis)
                history.append(f"{n_new}: {sum(c.accepted for c in cand_new)}")

                def inside(x: float, fails: list[tuple[float, float]] = fails) -> bool:
                    return any(a <= x <= b for a, b in fails)

                def where_failing(ms: list[SelectedMode]) -> list[SelectedMode]:
                    return [m for m in _unique_modes(ms) if inside(m.natural_freq)]

                # the higher order decides where the residual exceeds the noise; elsewhere the mode
                # set had converged, and the verdicts of the lower order stand
                cand_new = tuple(sorted([c for c in cand_new if inside(c.natural_freq)]
                                        + [c for c in judged_c if not inside(c.natural_freq)],
                                        key=lambda c: c.natural_freq))
                acc = [c.mode for c in cand_new if c.accepted]
                if not acc or _same_modes(where_failing(acc), where_failing(judged)):
                    break  # the higher order changed nothing where the residual exceeds the noise
                judged, judged_c = acc, cand_new
                trial = _complete(data, acc, cand_new, residuals, crit, judged_basis[0] if judged_basis else None)
                n, stab = n_new, stab_new
                changed = not _same_modes(trial.modes, cur) or trial.test.failing() != last_fail
                cur, candidates, done, fitted = trial.modes, trial.candidates, trial, trial.fitted
                if not changed:
                    break
                last_fail = done.test.failing()
                fails = _failing_locally(data, done, crit.completeness)
            done = _one_line(data, _split(data, done, residuals, crit, harmonic_bands), residuals, crit)
            done = _leakage_merged(data, done, residuals, crit)
            cur, candidates, fitted = done.modes, done.candidates, done.fitted
            warnings += list(done.merged)
            if done.split:
                notes.append("modes the ML had merged into one, split where the lines near them need both (nested F "
                             "test): " + ", ".join(done.split))
            if done.added:
                notes.append("missing modes added where the residual exceeded the noise: "
                             + ", ".join(f"{f:.6g} Hz" for f in done.added))
            if done.dropped:
                notes.append("weak modes the data do not need (the residual stays consistent with the noise "
                             "without them) left out: " + ", ".join(f"{f:.6g} Hz" for f in done.dropped))
            if step_i:
                notes.append(f"model orders up to {tried} tried while the residual exceeded the noise estimate "
                             f"(modes per order: {', '.join(history)}); the modes of order {n} kept")
            if not done.test.passed:
                noise = {"estimated": "noise estimated per channel", "given": "given noise"}.get(
                    done.test.noise_source, f"noise from the {done.test.noise_source}")
                msg = (f"the residual exceeds the {noise} (chi-square test, "
                       f"p < {crit.completeness.p_value:g} over {done.test.failed.size} segments) in "
                       f"{done.test.describe()}")
                if n >= cap:  # stopped by the order cap: a mode may be missing
                    warnings.append(msg + f" up to the order cap {cap}: a mode may be missing there or the model "
                                    "does not fit")
                else:  # a higher order changed nothing there: no mode the estimator sees is missing
                    notes.append(msg + "; a higher order changed no mode there (the model does not fit the "
                                 "data to the noise: check the chart)")
            if done.test.edge.any():
                notes.append(f"the residual exceeds the noise at the band edge in {done.test.describe('edge')}: "
                             "a mode just outside the band (the residual terms stand only for modes far from it)")
            residual_test = done.test
        if not converged:
            warnings.append(f"the mode set did not converge up to order {n} (stopped by the order cap): "
                            f"{len(prev or [])} modes at order {prev_order}, {len(cur)} at order {n}")
        sel = Selection(modes=tuple(cur), band=stab.band, max_order=n,
                        tolerances=dict(stab.tolerances),
                        in_dofs=tuple(str(d) for d in work.in_dofs), source=src)
        if len(sel) == 0:
            rejected = "; ".join(f"{c.natural_freq:.5g} Hz: {c.reason}" for c in candidates[:6])
            raise IdentificationError(
                f"no physical mode in the band {stab.band[0]:g}..{stab.band[1]:g} Hz up to order {n}"
                + (f" (candidates rejected: {rejected})" if rejected else "") + _why(data),
                file=src,
            )
    # one LSFD pole per mode; sorted by |pole| so the spreads align with the modal model
    modes = _unique_modes(sel.modes)
    if fitted is None:
        fitted = _fit_modes(data, modes, residuals)
    model, ml, polymax, basis = fitted[:4]
    model = _reported_model(data, model, residual_test, crit.completeness, residuals, basis)
    warnings += list(ml.warnings)
    meta = dict(model.meta)
    meta.update({"max_order": int(max(stab.orders)), "selection": sel.to_dict(), "transposed": transposed,
                 "polymax_poles": polymax, "method": "ml-local", "std": STD_LABEL})
    model = replace(model, meta=meta)
    fit = model.fit_error if model.fit_error is not None else np.zeros((1, 1))
    med = float(np.median(fit))
    if med > crit.result.poor_fit:
        warnings.append(f"poor fit: median synthesis error {100 * med:.0f} % over {fit.size} channel(s) "
                        f"(above {100 * crit.result.poor_fit:.0f} %); modes may be missing or the data noisy")
    warnings += _edge_warnings(model, stab.band, crit.result)
    mag = _edge_magnitude(data, crit.result)  # the magnitude both edge tests read
    warnings += _skirt_warnings(data, model, crit.result, beyond, mag)
    low = _low_edge(data, model, crit.result, mag)
    if low is not None and not default_band:
        hi_f = stab.band[1]
        warnings.append(f"{low[1]}; start the band above it, e.g. band=({low[0]:.3g}, {hi_f:.6g}) Hz "
                        f"(--band {low[0]:.3g} {hi_f:.6g})")
    elif low is not None:  # the default band: start it there (explicit, so once) and say why
        again = identify(measured, band=(low[0], stab.band[1]), max_order=max_order, freq_tol=freq_tol,
                         damping_tol=damping_tol, mac_tol=mac_tol, near_tol=near_tol, residuals=residuals,
                         progress=progress, transpose=transpose, refine=refine, criteria=criteria)
        why = (f"the default band starts at {low[0]:.6g} Hz, not at the data's first line {stab.band[0]:.6g} Hz: "
               f"over {stab.band[0]:g}..{stab.band[1]:g} Hz {low[1]}")
        return replace(again, notes=(why,) + tuple(again.notes))
    # what makes the FRFs themselves suspect (coherence at the peak, phase noise): the same caveats
    # from the API as from the command line
    found = diagnose_frf(data) if findings is None else findings.result()
    warnings += [f"data: {f}" for f in found if f"data: {f}" not in warnings]
    ident = Identification(
        poles=stab.poles,
        stabilization=stab,
        selection=sel,
        modes=model,
        natural_freq_std=ml.natural_freq_std,
        damping_ratio_std=ml.damping_ratio_std,
        natural_freq_spread=np.array([m.natural_freq_std for m in modes]),
        damping_ratio_spread=np.array([m.damping_ratio_std for m in modes]),
        # a standard deviation that could not be formed (NaN) is no "ml" or "held" one, whatever the fit did
        std_kind=tuple(k if np.isfinite(sf) and np.isfinite(sz) else "none"
                       for k, sf, sz in zip(ml.kind, ml.natural_freq_std, ml.damping_ratio_std, strict=True)),
        residual_test=residual_test,
        band=stab.band,
        candidates=candidates,
        converged=converged,
        warnings=tuple(warnings),
        notes=tuple(notes),
        transposed=transposed,
    )
    # ---- optional maximum-likelihood refinement (issue 10) ----
    if refine:
        ident = _refined(ident, data)
    return cast("Identification", remove_window_damping(ident, data))  # issue 18: an exponential window's damping


#: The LSFD model at the ML poles, the local ML, the PolyMAX poles (re, im), the LSFD basis of the
#: model (:class:`~ema_rig.identification.lsfd.LsfdBasis`, for the weighted residues at the same poles), the
#: model's pole columns on every line (:func:`_pole_columns`, formed for its completeness test; None: not formed)
#: and that test's local fits by segment (:data:`~ema_rig.identification.noise.SegmentFits`; None: not formed).
_Fitted = tuple[ModalModel, LocalML, list[list[float]], LsfdBasis | None, NDArray[np.complex128] | None,
                SegmentFits | None]
#: the local refits of one stage, keyed by (poles, lines) (:func:`_refit_on`): the stage's tests repeat some
_Refits = dict[tuple[bytes, bytes], NDArray[np.complex128] | None]


@dataclass(frozen=True, slots=True)
class _Completed:
    """The accepted modes after the completeness test, their fit and test, the modes added [Hz]."""

    modes: list[SelectedMode]
    candidates: tuple[Candidate, ...]
    fitted: _Fitted
    test: MisfitTest
    added: tuple[float, ...]
    dropped: tuple[float, ...] = ()
    split: tuple[str, ...] = ()
    merged: tuple[str, ...] = ()


def _unique_modes(modes: Sequence[SelectedMode]) -> list[SelectedMode]:
    """One mode per pole, sorted by ``|pole|`` (the order of the modal model)."""
    unique: dict[complex, SelectedMode] = {}
    for m in sorted(modes, key=lambda m: abs(m.pole)):
        unique.setdefault(m.pole, m)
    return list(unique.values())


def _fit_modes(data: FRFData, modes: Sequence[SelectedMode], residuals: bool,
               test: tuple[CompletenessCriteria, list[MisfitTest]] | None = None,
               basis: LsfdBasis | None = None) -> _Fitted:
    """LSFD at the modes' PolyMAX poles, the local ML, LSFD at the ML poles; the PolyMAX poles (re, im)
    and the basis of the returned LSFD model (for the weighted residues at its poles).

    With ``test`` (criteria, a list) the completeness test of the returned model (:func:`_misfit`) is
    appended to the list: it needs the ML poles only (not the LSFD at them), so it is formed beside that
    fit and while a second thread may still form the ML's scores and covariances (the same numbers as
    after them). ``basis``: an LSFD basis and factor formed before (the judgement's last fit), taken over
    when it belongs to the modes' PolyMAX poles (the same numbers).
    """
    syn = np.empty_like(data.frf, dtype=np.complex128)  # the LSFD model's FRFs on the data's lines
    # data checked by identify
    bases: list[LsfdBasis] = []
    model = _lsfd_checked(data, [m.pole for m in modes], residuals=residuals, model_out=syn, basis_out=bases,
                          basis=basis)
    polymax = [[float(p.real), float(p.imag)] for p in model.poles]
    # one BLAS thread throughout: the threads below use the other core
    with single_threaded():
        # ---- the default estimate: ML on the lines near the modes, robust standard uncertainty ----
        staged = _local_ml_staged(data, model, syn)
        # the poles are final: the LSFD model at them and its completeness test need nothing else of the
        # ML, and neither needs the other (the test takes the poles alone, in the model's order), so on
        # large data a second thread starts on the test (the longer task) while this one joins the ML's
        # uncertainties, then takes the LSFD back when the thread has not started it yet (pure tasks,
        # joined here in a fixed order: the same numbers whichever thread runs what, and when)
        side = ThreadPoolExecutor(1) if data.frf.size >= _AT_POLES_THREAD_MIN_VALUES else None
        err = np.geterr()  # the caller's floating-point error handling holds in the thread too
        start, start_basis = model, (bases[0] if bases else None)
        poles = staged.poles
        cc = None if test is None else test[0]

        # the model's poles and their columns on every line, formed once: the test takes them, and the LSFD at
        # those poles its basis (kept for the later tests at these poles)
        lam = _model_poles(start, poles)
        cols = _pole_columns(data, lam)

        def lsfd_at() -> tuple[ModalModel, LsfdBasis | None]:
            with in_callers_limit(), np.errstate(**err):
                return _lsfd_at(data, start, start_basis, poles, residuals, cols)

        def misfit_at(crit: CompletenessCriteria
                      ) -> tuple[MisfitTest, NDArray[np.complex128] | None, SegmentFits]:
            with in_callers_limit(), np.errstate(**err):
                fits: SegmentFits = {}  # the local fits of its segments (the cores of _failing_locally)
                return _misfit_at(data, lam, crit, cols, fits), cols, fits

        tested_job = None if cc is None else Job(partial(misfit_at, cc), side)
        fit_job = Job(lsfd_at, side, later=True)
        if side is not None:
            side.shutdown(wait=False)  # its thread ends once the tasks are done (or taken back)
        ml = staged.finish()
        model, basis = fit_job.result()
        tested, columns, fits = (None, None, None) if tested_job is None else tested_job.result()
    if test is not None and tested is not None:
        test[1].append(tested)
    return model, ml, polymax, basis, columns, fits


#: FRF values (channels x lines) from which :func:`_fit_modes` hands the completeness test at the ML poles
#: (and the LSFD at them, unless the caller takes it back first) to a second thread while it joins the ML's
#: uncertainties. Below (the bundled rig file:
#: 13 600 values) both sides are small numpy calls that hold the interpreter lock, so the thread only adds
#: hand-offs (measured: rig file 0.055 -> 0.059 s wall, same tasks in the caller). Above, the two threads
#: are these two: the test's own second thread and the ML's are off (``noise._MISFIT_THREAD_MIN_VALUES``,
#: ``ml._THREAD_MIN_EQUATIONS``). A work-size rule: the same on any machine.
_AT_POLES_THREAD_MIN_VALUES = 100_000


def _model_poles(model: ModalModel, poles: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """The poles of the LSFD model at ``poles`` (:func:`_lsfd_at`), without the fit: ``model``'s when they are
    its poles, else in the order an LSFD model holds them (:func:`~ema_rig.identification.lsfd.model_order`)."""
    return model.poles if not np.any(poles != model.poles) else model_order(poles)


def _lsfd_at(data: FRFData, model: ModalModel, basis: LsfdBasis | None, poles: NDArray[np.complex128],
             residuals: bool, columns: NDArray[np.complex128] | None = None) -> tuple[ModalModel, LsfdBasis | None]:
    """The LSFD model at ``poles`` and its basis (``model`` and its ``basis`` when they are its poles);
    ``columns`` the :func:`_pole_columns` of ``_model_poles(model, poles)`` when the caller has them."""
    if np.any(poles != model.poles):
        bases: list[LsfdBasis] = []
        model = _lsfd_checked(data, poles, residuals=residuals, basis_out=bases, pole_columns=columns)
        basis = bases[0] if bases else None
    return model, basis


def _fit_tested(data: FRFData, modes: Sequence[SelectedMode], residuals: bool, cc: CompletenessCriteria,
                basis: LsfdBasis | None = None) -> tuple[_Fitted, MisfitTest]:
    """:func:`_fit_modes` and the completeness test of its model (:func:`_misfit`), formed alongside
    (``basis``: as for :func:`_fit_modes`)."""
    out: list[MisfitTest] = []
    fitted = _fit_modes(data, modes, residuals, (cc, out), basis)
    return fitted, out[0]


def _reported_model(data: FRFData, model: ModalModel, test: MisfitTest | None, cc: CompletenessCriteria,
                    residuals: bool, basis: LsfdBasis | None = None) -> ModalModel:
    """The residues ``identify`` reports: LSFD at the (ML) poles of ``model`` weighted by the noise.

    The noise variance of every line is the completeness test's (``test``, of these poles; formed
    here when None): from local fits, so no misfit of the global model is in it. Per channel the
    weighted fit (the maximum-likelihood residues) is kept unless the model errs there
    (:func:`~ema_rig.identification.lsfd._lsfd_noise_weighted`). When the test fails inside the band
    (a mode missing, or a noise model that does not hold), weights would spread that misfit over the
    band: the unweighted fit, set by the resonances, is kept.
    """
    if test is None:
        test = _misfit(data, model, cc)
    if not test.passed or test.variance is None:
        return replace(model, meta={**model.meta, "weighted": "no (the residual exceeds the noise inside the band)"})
    # a channel without a finite variance anywhere (a coherence of 1 everywhere: no estimate) keeps equal weights
    var = np.where(np.all(~np.isfinite(test.variance), axis=1, keepdims=True), 1.0, test.variance)
    return _lsfd_noise_weighted(data, model.poles, var.reshape(data.frf.shape), residuals=residuals, unweighted=model,
                                basis=basis)


def _misfit(data: FRFData, model: ModalModel, crit: CompletenessCriteria) -> MisfitTest:
    """:func:`~ema_rig.identification.noise.segment_misfit` of ``model`` on ``data`` (cut to the band)."""
    return _misfit_at(data, model.poles, crit)


def _misfit_at(data: FRFData, poles: NDArray[np.complex128], crit: CompletenessCriteria,
               columns: NDArray[np.complex128] | None = None, fits: SegmentFits | None = None) -> MisfitTest:
    """:func:`_misfit` of the model with the poles ``poles`` (shape (n_modes,) [rad/s], in the model's order);
    ``columns`` their :func:`_pole_columns` when the caller has them; ``fits`` receives the local fits of the
    test's segments (``segment_misfit(segment_fits=...)``)."""
    with single_threaded():  # many small factorizations: threads only add hand-off time
        return segment_misfit(data.freq, data.frf, poles, power=_FORM_POWER[data.frf_form],
                              coherence=data.coherence, n_averages=data.n_averages, criteria=crit,
                              pole_columns=columns, segment_fits=fits)


def _pole_columns(data: FRFData, poles: NDArray[np.complex128]) -> NDArray[np.complex128] | None:
    """The pole columns of ``poles`` on every line of ``data``, shape (n_freq, 2 n_modes), complex (None without a
    pole): :func:`~ema_rig.identification.noise.segment_pole_columns` at the data's FRF form, the columns
    :func:`~ema_rig.identification.noise.segment_misfit` forms for them (its ``pole_columns``)."""
    return segment_pole_columns(data.freq, poles, _FORM_POWER[data.frf_form])


def _failing_locally(data: FRFData, done: _Completed, cc: CompletenessCriteria) -> list[tuple[float, float]]:
    """The failing segments of ``done``'s test and the lines of the modes' own cores that fail, ``(lo, hi)`` [Hz].

    A core holds modes each inside the core of every other
    (:func:`~ema_rig.identification.noise.segment_edges` with ``chained=False``), tested against the
    noise variance of ``done.test`` (Bonferroni over those segments): a chain of modes each inside its
    neighbour's core makes one segment of the test (its noise estimate), in which a local misfit
    around a peak is diluted over lines the model fits (ufffiles_frf 79.95-719.55 Hz: 522-719.5 Hz,
    400 lines at 1.59 x the noise, while 686-714 Hz is 3.9 x it).
    """
    fails = done.test.failing()
    if done.test.variance is None:
        return fails
    lam = done.fitted[0].poles
    fn, zeta = np.abs(lam) / (2 * np.pi), -lam.real / np.maximum(np.abs(lam), 1e-300)
    edges = segment_edges(data.freq, fn, zeta, criteria=cc, chained=False)
    # ``done.test`` is the test of these poles on the default, chained, segments of the data's lines: its
    # segments' first lines and the end are those edges
    chained = np.append(np.searchsorted(data.freq, done.test.freq_lower), data.freq.size)
    if np.array_equal(edges, chained):
        # no chain: the cores are the test's own segments, so the same local fits against the same variance
        # fail exactly where it fails
        return fails
    n_chan = data.n_out * data.n_in
    with single_threaded():
        # the pole columns of the test, at the same poles, and the local fits of its segments: a core that is
        # one of them is not fitted again (the same numbers)
        t = segment_misfit(data.freq, data.frf.reshape(n_chan, -1), lam, power=_FORM_POWER[data.frf_form],
                           variance=done.test.variance, edges=edges, criteria=cc,
                           pole_columns=done.fitted[4], segment_fits=done.fitted[5])
    return fails + [(a, b) for a, b in t.failing() if not any(lo <= a and b <= hi for lo, hi in fails)]


def _complete(data: FRFData, modes: list[SelectedMode], candidates: tuple[Candidate, ...], residuals: bool,
              crit: IdentificationCriteria, basis: LsfdBasis | None = None) -> _Completed:
    """Test the accepted modes' residual per segment; in a failing segment add a rejected candidate.

    A candidate lying in a failing segment (a cluster stable at ``min_poles`` orders at least,
    rejected for anything but its damping or the band) is added when the lines near it support
    it: a nested F test of the model's poles there with it against without it, both re-estimated
    by the local ML (:func:`_local_f`, ``CompletenessCriteria.local_p``, Bonferroni over the
    candidates tested on those lines). The evidence is that of the lines near the candidate only,
    so two bands that hold them decide alike (the global F test of the judge divides by a noise
    estimate and a candidate count of the whole band). With ``local_evidence=False`` the old rule:
    the global F test (:meth:`~ema_rig.identification.criteria.JudgeCriteria.support_threshold`)
    and the segment passing the residual test with it. The strongest candidates (most poles) are
    tried first, at most ``max_added`` per segment. ``basis``: the judgement's last LSFD basis
    (:func:`_fit_modes`).
    """
    cc = crit.completeness
    modes = _unique_modes(modes)
    fitted, test = _fit_tested(data, modes, residuals, cc, basis)
    added: list[float] = []
    feats = _ml_features(data, modes, fitted[1], crit) if cc.local_evidence and cc.ml_features else []
    # the segments to search: the failing ones, and those put down to a mode beyond the band edge when the
    # ML located a feature inside the band there (its lines then decide, as for any missing mode)
    where = [(lo, hi, False) for lo, hi in test.failing()] + [
        (float(a), float(b), True) for a, b, e in zip(test.freq_lower, test.freq_upper, test.edge, strict=True)
        if e and any(a <= c.natural_freq <= b for c in feats)]
    if not where:
        return _parsimonious(data, _Completed(modes, candidates, fitted, test, ()), list(fitted[0].poles),
                             residuals, crit)
    n_clusters = len(candidates)
    cands = [*candidates, *feats]
    accepted_poles = {m.pole for m in modes}
    model_poles = list(fitted[0].poles)
    n_chan = data.n_out * data.n_in
    f = data.freq
    df = float(np.median(np.diff(f))) if f.size > 1 else 0.0
    memo: _Refits = {}  # the local refits made here: a feature ranked by its local F is then tested on the same lines

    for lo, hi, at_edge in where:
        pool = [i for i, c in enumerate(cands[:n_clusters]) if not at_edge and not c.accepted
                and lo <= c.natural_freq <= hi and c.mode.pole not in accepted_poles
                and 0 < c.damping_ratio <= crit.judge.max_damping
                and c.mode.n_poles >= crit.judge.min_poles and "outside the band" not in c.reason]
        pool.sort(key=lambda i: (-cands[i].mode.n_poles, cands[i].natural_freq))
        # then the feature the ML found in the segment with the largest local F
        pool_f = _by_local_f(data, model_poles, cands, [n_clusters + j for j, c in enumerate(feats)
                                                        if lo <= c.natural_freq <= hi], test.variance, cc, memo)[:1]
        pool += pool_f  # every candidate of the segment is a look of the local tests (Bonferroni)
        n_added = 0
        for i in pool[: 2 * cc.max_added] + [i for i in pool_f if i not in pool[: 2 * cc.max_added]]:
            if n_added >= cc.max_added:
                break
            c = cands[i]
            # within a tenth of a model mode's half-power band (as the lines resolve it: at least one
            # line spacing, as in ml.py) it is that mode: the judge's duplicate distance
            # (JudgeCriteria.dup_shape_mac); no data resolve two poles so close
            lam_m = np.asarray(model_poles, dtype=np.complex128)
            f_m, z_m = np.abs(lam_m) / (2 * np.pi), -lam_m.real / np.maximum(np.abs(lam_m), 1e-300)
            if np.any(np.abs(c.natural_freq - f_m) < 0.1 * np.maximum(2 * np.maximum(z_m, 1e-4) * f_m, df)):
                continue
            trial = _unique_modes([*modes, c.mode])
            if cc.local_evidence:
                # the evidence of the lines near it alone (the same in any band that holds them)
                sl = _local_lines(f, c, cc, df)
                res = (_nested_test(data, model_poles, c.mode.pole, sl, test.variance, cc,
                                    [cands[j].natural_freq for j in pool], memo)
                       if int(sl.sum()) >= cc.min_segment_lines and test.variance is not None else None)
                if res is None:
                    continue
                stat, need, q, dof_l, n_looks = res
                if not stat >= need:
                    continue
                out = (None if test.variance is None else  # checked above: res is None without it
                       _peak_line_out(data, model_poles, c, sl, test.variance, cc, [cands[j].natural_freq for j in pool],
                                      memo))
                if out is not None:
                    cands[i] = replace(c, reason=(f"{c.reason}; not a missing mode: its local evidence (F = {stat:.3g} >= "
                                                  f"{need:.3g}) rests on one line, {out}"))
                    continue
                why = (f"nested F test on the lines {f[sl][0]:.6g}..{f[sl][-1]:.6g} Hz: F = {stat:.3g} >= {need:.3g} "
                       f"with {q:.0f}, {dof_l:.0f} dof, {n_looks} candidate(s) tested there")
                sup_k = stat
            else:
                poles = np.array([m.pole for m in trial])
                k = int(np.flatnonzero(poles == c.mode.pole)[0])
                with single_threaded():
                    _res, sup, _shr, dof = _fit(data, poles)
                need = float(crit.judge.support_threshold(n_chan, float(dof[k]), len(pool)))
                if not sup[k] >= need:
                    continue
                # does the segment pass with it? the local test around it, against the same noise
                if not _passes_with(data, [*model_poles, c.mode.pole], lo, hi, test, cc, refine=True):
                    continue
                why = f"F = {sup[k]:.3g} >= {need:.3g} with {2 * n_chan}, {dof[k]:.0f} dof"
                sup_k = float(sup[k])
            modes = trial
            model_poles.append(c.mode.pole)
            accepted_poles.add(c.mode.pole)
            cands[i] = replace(c, accepted=True, support=sup_k,
                               reason=(f"physical: a missing mode (the residual near it was above the noise"
                                       f"{' in a segment at the band edge, the feature inside the band' if at_edge else ''}; "
                                       f"{why}; before: {c.reason})"))
            added.append(c.natural_freq)
            n_added += 1
    # a feature the lines did not need is no candidate of the result (it was never a cluster)
    kept = cands[:n_clusters] + [c for c in cands[n_clusters:] if c.accepted]
    return _parsimonious(data, _Completed(modes, tuple(kept), fitted, test, tuple(added)), model_poles,
                         residuals, crit)


def _ml_features(data: FRFData, modes: Sequence[SelectedMode], ml: LocalML,
                 crit: IdentificationCriteria) -> list[Candidate]:
    """Candidates of missing modes at the features the local ML found (``CompletenessCriteria.ml_features``).

    A mode the ML held at its PolyMAX pole because its fit moved it, inside its own lines, further
    than ``MLCriteria.move_hbw`` half-power half-bandwidths (``LocalML.moved_to``) marks a feature of
    the data that the model lacks: on those lines one pole there explained more than one pole at the
    mode's own stable cluster. The pole it moved to (inside the band, damping below
    ``JudgeCriteria.max_damping``) is a candidate (``n_poles`` 0: no cluster of its own), one per
    place: within a tenth of a half-power band of one already listed it is that one. A place within
    ``MLCriteria.move_hbw`` half-power half-bandwidths (at least two line spacings) of another mode of
    the model is that mode's own feature, not another one: the same distance that made the held
    pole's move "another feature" (:func:`~ema_rig.identification.ml.local_ml`), read from the mode
    it lands on (dam0 1.5-6 Hz: the 5.12 Hz mode moved to 4.667 Hz, 0.035 Hz from the 4.632 Hz mode,
    whose half-power half-bandwidth is 0.041 Hz; added, the pair is one mode to the band's full ML,
    :func:`~ema_rig.identification.refine.refine`).
    """
    if ml.moved_to is None:
        return []
    f = data.freq
    df = float(np.median(np.diff(f))) if f.size > 1 else 0.0
    near_mode = np.maximum(ML_CRITERIA.move_hbw * (-ml.poles.real) / (2 * np.pi), 2 * df)
    fn_model = np.abs(ml.poles) / (2 * np.pi)
    out: list[Candidate] = []
    for k, lam in enumerate(ml.moved_to):
        if not np.isfinite(lam) or k >= len(modes):
            continue
        fn, zeta = abs(lam) / (2 * np.pi), -lam.real / abs(lam)
        if not (f[0] < fn < f[-1] and 0 < zeta <= crit.judge.max_damping):
            continue
        if any(abs(fn - c.natural_freq) < 0.1 * 2 * max(zeta, c.damping_ratio) * fn for c in out):
            continue
        if np.any((np.abs(fn_model - fn) <= near_mode) & (np.arange(fn_model.size) != k)):
            continue
        m = modes[k]
        out.append(Candidate(replace(m, pole=complex(lam), natural_freq=float(fn), damping_ratio=float(zeta),
                                     natural_freq_std=0.0, damping_ratio_std=0.0, n_poles=0, order_min=0,
                                     order_max=0),
                             accepted=False,
                             reason=(f"a feature of the data the ML found: its fit moved the mode at "
                                     f"{m.natural_freq:.6g} Hz to {fn:.6g} Hz, beyond its half-power half-bandwidth")))
    return out


def _by_local_f(data: FRFData, null: Sequence[complex], cands: Sequence[Candidate], idx: Sequence[int],
                variance: NDArray[np.float64] | None, cc: CompletenessCriteria,
                memo: _Refits | None = None) -> list[int]:
    """``idx`` (into ``cands``) ordered by their local F statistic over the poles ``null`` (:func:`_nested_test`
    on :func:`_local_lines`), largest first; those whose fit fails last, by frequency. ``memo``: refits
    already made (:func:`_refit_on`)."""
    if len(idx) < 2 or variance is None:
        return list(idx)
    f = data.freq
    score = {}
    for i in idx:
        res = _nested_test(data, null, cands[i].mode.pole, _local_lines(f, cands[i], cc), variance, cc, (), memo)
        score[i] = -np.inf if res is None else res[0]
    return sorted(idx, key=lambda i: (-score[i], cands[i].natural_freq))


def _passes_with(data: FRFData, poles: Sequence[complex], lo: float, hi: float, test: MisfitTest,
                 cc: CompletenessCriteria, *, refine: bool = False, alone: bool = False) -> bool:
    """Whether the segment ``lo..hi`` [Hz] passes with ``poles``, tested on its neighbourhood (one
    segment width each side) against the noise variance of ``test``; with ``alone`` the segment
    itself as one segment (its lines and width unchanged by the poles).

    With ``refine`` the poles inside the neighbourhood are first re-estimated there by the local
    ML (started at the given poles): a candidate's PolyMAX pole is a start value, not its estimate.
    """
    if test.variance is None:
        return False
    f = data.freq
    width = 0.0 if alone else hi - lo
    sl = (f >= lo - width) & (f <= hi + width)
    n_chan = data.n_out * data.n_in
    lam = np.asarray(poles, dtype=np.complex128)
    if refine:
        refit = _refit_on(data, lam, sl)
        if refit is None:
            return False
        lam = refit
    coh = None if data.coherence is None else data.coherence.reshape(n_chan, -1)[:, sl]
    with single_threaded():
        t = segment_misfit(f[sl], data.frf.reshape(n_chan, -1)[:, sl], lam,
                           power=_FORM_POWER[data.frf_form], variance=test.variance[:, sl], coherence=coh,
                           edges=[0, int(sl.sum())] if alone else None, criteria=cc)
    mid = 0.5 * (lo + hi)
    # the slice's ends are no band edges: an "edge" failure there is a failure
    bad = t.failed | t.edge
    return not bool(np.any(bad & (t.freq_lower <= mid) & (mid <= t.freq_upper)))


def _refit_on(data: FRFData, poles: NDArray[np.complex128], sl: NDArray[np.bool_],
              memo: _Refits | None = None) -> NDArray[np.complex128] | None:
    """``poles`` with those inside the lines ``sl`` re-estimated there by the local ML (LSFD start);
    None when the fit fails. A pole's PolyMAX value is a start value, not its estimate.

    Only the ML's poles are formed (:func:`_local_ml_staged` without its ``finish``: the poles are the
    same numbers, its uncertainties are not needed here). ``memo``: the refits already made on the
    same data (keyed by the poles and the lines; one stage, :func:`_split` or :func:`_complete`), a
    repeated one is taken from it.
    """
    lam = np.asarray(poles, dtype=np.complex128)
    key = (lam.tobytes(), np.packbits(sl).tobytes() + sl.size.to_bytes(8, "little"))
    if memo is not None and key in memo:
        hit = memo[key]
        return None if hit is None else hit.copy()
    f = data.freq
    fn = np.abs(lam) / (2 * np.pi)
    inside = (fn >= f[sl][0]) & (fn <= f[sl][-1])
    idx = np.flatnonzero(sl)
    part = data.replace(freq=f[sl], frf=data.frf[:, :, sl],
                        coherence=None if data.coherence is None else data.coherence[:, :, sl])
    out: NDArray[np.complex128] | None = lam
    if inside.any() and 2 * idx.size > 2 * int(inside.sum()) + 2:
        try:
            model = _lsfd_checked(part, lam[inside], residuals=True)
            with single_threaded():  # many small products: threads only add hand-off time
                ml_poles = _local_ml_staged(part, model, second_thread=False).poles
        except (IdentificationError, np.linalg.LinAlgError, ValueError):
            ml_poles = None
        if ml_poles is None:
            out = None
        elif np.all(np.isfinite(ml_poles)) and np.all(ml_poles.imag > 0):
            out = lam.copy()
            out[np.flatnonzero(inside)] = ml_poles
    if memo is not None:
        memo[key] = None if out is None else out.copy()
    return out


def _local_lines(f: NDArray[np.float64], c: Candidate, cc: CompletenessCriteria, df: float | None = None
                 ) -> NDArray[np.bool_]:
    """The lines of candidate ``c``'s own evidence: within ``local_hbw`` half-power half-bandwidths of
    it, at least ``min_segment_lines / 2`` lines each side (set by the candidate, not by the band).
    ``df``: the median line spacing of ``f`` [Hz] when the caller has it (0 for a single line)."""
    if df is None:
        df = float(np.median(np.diff(f))) if f.size > 1 else 0.0
    half = max(cc.local_hbw * c.damping_ratio * c.natural_freq, 0.5 * cc.min_segment_lines * df)
    sel: NDArray[np.bool_] = (f >= c.natural_freq - half) & (f <= c.natural_freq + half)
    return sel


def _peak_line_out(data: FRFData, null: Sequence[complex], c: Candidate, sl: NDArray[np.bool_],
                   variance: NDArray[np.float64], cc: CompletenessCriteria, looks: Sequence[float],
                   memo: _Refits | None = None) -> str | None:
    """Why candidate ``c``'s local evidence on the lines ``sl`` rests on the line nearest to it alone, or None.

    The nested test of :func:`_nested_test` again without that line
    (``CompletenessCriteria.peak_line_out``): a pole and its residues can zero any one line, so a
    misfit of one line is no evidence of a mode; a real mode, however light, shows on its skirt too.
    ``memo``: refits already made (:func:`_refit_on`).
    """
    if not cc.peak_line_out:
        return None
    idx = np.flatnonzero(sl)
    j = int(idx[np.argmin(np.abs(data.freq[idx] - c.natural_freq))])
    sl_out = sl.copy()
    sl_out[j] = False
    res = _nested_test(data, null, c.mode.pole, sl_out, variance, cc, looks, memo)
    if res is not None and res[0] >= res[1]:
        return None
    tail = "the fit failed" if res is None else f"F = {res[0]:.3g} < {res[1]:.3g} with {res[2]:.0f}, {res[3]:.0f} dof"
    return f"without the line at {data.freq[j]:.6g} Hz {tail}"


def _nested_test(data: FRFData, null: Sequence[complex], pole: complex, sl: NDArray[np.bool_],
                 variance: NDArray[np.float64], cc: CompletenessCriteria, looks: Sequence[float],
                 memo: _Refits | None = None) -> tuple[float, float, float, float, int] | None:
    """The local test of one more mode ``pole`` over the poles ``null`` on the lines ``sl``.

    Returns ``(F, threshold, q, dof, n_looks)``: :func:`_local_f`'s statistic and the F quantile at
    ``cc.local_p`` Bonferroni-corrected over the ``n_looks`` candidate frequencies of ``looks``
    [Hz] that lie on those lines (the candidates tested there); None when a fit fails. ``memo``:
    refits already made (:func:`_refit_on`; the null's refit is the same for every candidate on the lines).
    """
    from scipy.stats import f as f_dist

    fl = data.freq[sl]
    n_looks = sum(1 for fc in looks if fl[0] <= fc <= fl[-1])
    res = _local_f(data, null, [*null, pole], sl, variance, cc, memo)
    if res is None:
        return None
    stat, q, dof = res
    return stat, float(f_dist.isf(cc.local_p / max(n_looks, 1), q, dof)), q, dof, n_looks


def _local_f(data: FRFData, null: Sequence[complex], alt: Sequence[complex], sl: NDArray[np.bool_],
             variance: NDArray[np.float64], cc: CompletenessCriteria,
             memo: _Refits | None = None) -> tuple[float, float, float] | None:
    """The F statistic of the extra mode of ``alt`` over ``null`` on the lines ``sl``: (F, q, dof).

    Each pole set is re-estimated on the lines by the local ML (:func:`_refit_on`), then fitted
    there with residues free per channel and the local polynomial
    (:func:`~ema_rig.identification.noise.segment_misfit`, the lines as one segment, weighted by
    ``variance``). ``F = ((chi2_0 - chi2_1) / q) / (chi2_1 / dof)`` with ``q = dof_0 - dof``
    (the extra mode's pole and residues) and ``dof`` the alternative's residual degrees of freedom:
    a scale error of the noise estimate cancels. None when a fit fails. ``memo``: refits already
    made (:func:`_refit_on`).
    """
    f = data.freq
    n_chan = data.n_out * data.n_in
    n = int(sl.sum())
    coh = None if data.coherence is None else data.coherence.reshape(n_chan, -1)[:, sl]

    def chi2(lam: NDArray[np.complex128]) -> tuple[float, float]:
        with single_threaded():
            t = segment_misfit(f[sl], data.frf.reshape(n_chan, -1)[:, sl], lam, power=_FORM_POWER[data.frf_form],
                               variance=variance[:, sl], coherence=coh, edges=[0, n], criteria=cc)
        return float(t.ratio[0] * t.dof[0]), float(t.dof[0])

    lam0 = np.asarray(null, dtype=np.complex128)
    ref0 = _refit_on(data, lam0, sl, memo)
    (c0, d0), best0 = chi2(lam0), lam0
    if ref0 is not None:
        c_r, d_r = chi2(ref0)
        if c_r <= c0:
            (c0, d0), best0 = (c_r, d_r), ref0
    # the alternative re-estimated from its start, or the null's best poles with the extra pole at its
    # start (nested: never worse than the null), whichever fits better
    lam1 = np.asarray(alt, dtype=np.complex128)
    extra = np.asarray([p for p in alt if p not in set(null)], dtype=np.complex128)
    ref1 = _refit_on(data, lam1, sl, memo)
    tries = [np.concatenate([best0, extra])] + ([ref1] if ref1 is not None else [])
    c1, d1 = min(chi2(lam) for lam in tries)
    q = d0 - d1
    if not (q > 0 and c1 > 0 and np.isfinite(c0) and np.isfinite(c1)):
        return None
    return ((c0 - c1) / q) / (c1 / d1), q, d1


def _split(data: FRFData, done: _Completed, residuals: bool, crit: IdentificationCriteria,
           harmonic_bands: Sequence[tuple[float, float]] = ()) -> _Completed:
    """Two modes where the ML put one between them: a nested F test of 2 modes against 1 on the same lines.

    An accepted mode whose ML estimate moved from its PolyMAX pole towards a rejected candidate
    cluster, to between the two, within its local lines (``CompletenessCriteria.local_hbw`` half-power half-bandwidths,
    the candidate stable at ``JudgeCriteria.min_poles`` orders at least, rejected for its support in
    the global fit or as a duplicate) by more than ``split_sigmas`` of its ML standard uncertainty
    stands for two features of the data: the candidate is tested on its own lines, the model's
    poles there with it against without it (:func:`_local_f`, the test of a missing mode, also
    without its peak line: :func:`_peak_line_out`). The
    global F test had judged it with the band's noise estimate and candidate count; this decision
    uses the lines near the two only, so two bands holding them decide alike.

    With ``CompletenessCriteria.split_misfit`` (data of ``split_min_channels`` channels or more) an
    accepted mode whose own lines exceed the noise is also tested without a cluster beside it
    (:func:`_split_start`: the second pole started one half-power half-bandwidth beside it;
    data/disk.uff at 0-2000 Hz, 789.7 and 801.0 Hz). That second mode is undone when the band's
    ML cannot hold it or its segment still fails after the refit (the misfit was the model's error,
    not a missing mode). The lines inside ``harmonic_bands`` [Hz] (known shaft harmonics) are left
    out of the own lines' chi-square tests.
    """
    cc, jc = crit.completeness, crit.judge
    if not cc.local_evidence or done.test.variance is None or not done.modes:
        return done

    f = data.freq
    ml = done.fitted[1]
    modes = list(done.modes)
    cands = list(done.candidates)
    current = [complex(p) for p in ml.poles]
    model = list(current)
    df = float(np.median(np.diff(f))) if f.size > 1 else 0.0  # the line spacing of every _local_lines below
    added: list[str] = []
    pool = [i for i, c in enumerate(cands) if not c.accepted and c.mode.n_poles >= jc.min_poles
            and 0 < c.damping_ratio <= jc.max_damping and f[0] < c.natural_freq < f[-1]
            and c.reason.startswith(("negligible contribution", "duplicate of"))]
    by_pole = {m.pole: m for m in modes}
    split_k: set[int] = set()  # the modes split beside a rejected cluster
    memo: _Refits = {}  # the local refits made here: the tests below repeat some (the null's, each start's)
    for k, p_start in enumerate(complex(*p) for p in done.fitted[2]):
        m = by_pole.get(p_start)
        if m is None or ml.kind[k] != "ml" or not np.isfinite(ml.natural_freq_std[k]) or ml.natural_freq_std[k] <= 0:
            continue
        f_pm, f_ml = m.natural_freq, abs(current[k]) / (2 * np.pi)
        moved = f_ml - f_pm
        if abs(moved) <= cc.split_sigmas * float(ml.natural_freq_std[k]):
            continue
        half = cc.local_hbw * m.damping_ratio * m.natural_freq
        # the ML estimate lies between the PolyMAX pole and the cluster: one pole for two features
        near = [i for i in pool if abs(cands[i].natural_freq - f_pm) <= half
                and min(f_pm, cands[i].natural_freq) < f_ml < max(f_pm, cands[i].natural_freq)]
        if not near:
            continue
        i = max(near, key=lambda j: (cands[j].mode.n_poles, -abs(cands[j].natural_freq - f_pm)))
        c = cands[i]
        sl = _local_lines(f, c, cc, df)
        if int(sl.sum()) < cc.min_segment_lines:
            continue
        res = _nested_test(data, model, c.mode.pole, sl, done.test.variance, cc, [cands[j].natural_freq for j in pool],
                           memo)
        if res is None:
            continue
        stat, need, q, dof_l, n_looks = res
        if not stat >= need or _peak_line_out(data, model, c, sl, done.test.variance, cc,
                                              [cands[j].natural_freq for j in pool], memo) is not None:
            continue
        model.append(c.mode.pole)
        pool.remove(i)
        cands[i] = replace(c, accepted=True, support=stat, reason=(
            f"physical: the ML moved {m.natural_freq:.6g} Hz by {moved:+.3g} Hz towards it ({abs(moved) / float(ml.natural_freq_std[k]):.1f} "
            f"sigma), and the lines near it need both (nested F test on {f[sl][0]:.6g}..{f[sl][-1]:.6g} Hz: "
            f"F = {stat:.3g} >= {need:.3g} with {q:.0f}, {dof_l:.0f} dof, {n_looks} candidate(s) tested there; "
            f"before: {c.reason})"))
        added.append(f"{c.natural_freq:.6g} Hz beside {m.natural_freq:.6g} Hz")
        modes.append(c.mode)
        split_k.add(k)
    n_cluster_split = len(added)
    at_misfit: list[tuple[float, SelectedMode]] = []  # (the split mode's ML frequency [Hz], the second mode)
    if cc.split_misfit and data.n_out * data.n_in >= cc.split_min_channels:
        cols: tuple[int, NDArray[np.complex128] | None] | None = None  # the model's pole columns on every line
        harmonic = np.zeros(f.size, dtype=bool)  # the lines of known shaft harmonics
        for lo, hi in harmonic_bands:
            harmonic |= (f >= lo) & (f <= hi)
        with single_threaded():  # one BLAS limit for the tests of every mode below (each sets its own otherwise)
            for k, p_start in enumerate(complex(*p) for p in done.fitted[2]):
                m = by_pole.get(p_start)
                if m is None or k in split_k or ml.kind[k] != "ml":
                    continue
                if cols is None or cols[0] != len(model):  # the model grows by the modes split off
                    lam_m, known = np.asarray(model, dtype=np.complex128), done.fitted[4]
                    # the test's columns when the model's poles are the test's, in its order (the same numbers)
                    cols = (len(model), known if known is not None and np.array_equal(lam_m, done.fitted[0].poles)
                            else _pole_columns(data, lam_m))
                c_new = _split_start(data, model, k, m, done.test, cc, memo, cols[1], harmonic, df)
                if c_new is None:
                    continue
                c, stat, need, q, dof_l, sl = c_new
                model.append(c.mode.pole)
                cands.append(replace(c, support=stat, reason=(
                    f"physical: the lines of {m.natural_freq:.6g} Hz exceed the noise and need two modes there "
                    f"(nested F test on {f[sl][0]:.6g}..{f[sl][-1]:.6g} Hz, the second pole started one half-power "
                    f"half-bandwidth beside the ML estimate: F = {stat:.3g} >= {need:.3g} with {q:.0f}, {dof_l:.0f} dof, "
                    f"2 starts tested)")))
                added.append(f"a second mode started at {c.natural_freq:.6g} Hz beside {m.natural_freq:.6g} Hz (its lines "
                             "exceed the noise)")
                modes.append(c.mode)
                at_misfit.append((abs(current[k]) / (2 * np.pi), c.mode))
    if not added:
        return done
    modes = _unique_modes(modes)
    fitted, test = _fit_tested(data, modes, residuals, cc)
    # a second mode at a misfit stays only when the band's model with it is consistent with the noise
    # there: a segment that still fails is the model's error, not a missing mode (b6302 at 2400 rpm: a
    # shaft harmonic 7 Hz below the 287 Hz mode; dam0),
    # and only when the ML of the whole band holds it (a start value the ML cannot hold is not determined by
    # the data as a mode: the rule of _parsimonious for a missing mode)
    fails = test.failing()
    held = {x.pole for j, x in enumerate(modes) if fitted[1].kind[j] == "held"}
    still = {x.pole for fk, x in at_misfit if x.pole in held or any(lo <= fk <= hi for lo, hi in fails)}
    if still:
        keep = [i for i, (fk, x) in enumerate(at_misfit) if x.pole not in still]
        added = added[:n_cluster_split] + [added[n_cluster_split + i] for i in keep]
        cands = [c for c in cands if c.mode.pole not in still]
        modes = [x for x in modes if x.pole not in still]
        if not added:
            return done
        fitted, test = _fit_tested(data, modes, residuals, cc)
    return replace(done, modes=modes, candidates=tuple(cands), fitted=fitted, test=test, split=tuple(added))


def _split_start(data: FRFData, model: Sequence[complex], k: int, m: SelectedMode, test: MisfitTest,
                 cc: CompletenessCriteria, memo: _Refits | None = None,
                 model_columns: NDArray[np.complex128] | None = None, harmonic: NDArray[np.bool_] | None = None,
                 df: float | None = None) -> tuple[Candidate, float, float, float, float, NDArray[np.bool_]] | None:
    """A second mode beside the model's mode ``k`` (accepted mode ``m``) whose own lines misfit, or None.

    The lines of the mode (:func:`_local_lines` at its ML pole) fail the chi-square test of the
    residual against the noise variance of ``test`` (the model's poles, the lines as one segment):
    the one pole there stands for more than one feature of the data. The mode's own lines decide,
    not the band's segment holding it, so two bands holding those lines decide alike (dam0 at 1-12
    and 2-12.4 Hz: 7.12 Hz in a failing segment in the one, in a passing one in the other).

    A second pole is started one half-power half-bandwidth ``zeta f_n`` below and above the ML
    estimate (where two modes of that damping begin to be resolved). The two poles, re-estimated on
    those lines (:func:`_refit_on`), must explain them to the noise (the same chi-square test
    passes): a misfit that one more pole does not remove is the model's error (real data: leakage,
    nonlinearity), no missing mode. Then the nested F test on those lines (:func:`_nested_test`,
    Bonferroni over the two starts), also without the peak line (:func:`_peak_line_out`). Returns
    the candidate of the larger F that passes, with ``(F, threshold, q, dof, lines)``. Own lines
    that reach the band's first or last line are not tested: a misfit there may be the skirt of a
    mode beyond the edge, which those lines cannot tell from a second mode. ``memo``: refits already
    made (:func:`_refit_on`; the nested test repeats each start's refit and the null's). ``model_columns``:
    :func:`~ema_rig.identification.modal.modal_basis` of ``model`` on the data's lines without residual
    columns, when the caller has it. ``harmonic``, shape (n_freq,): lines of known shaft harmonics,
    left out of the two chi-square tests (a harmonic's sharp line is a feature no pole of the
    structure explains; their degrees of freedom count the lines kept); the refits and the F tests
    take every own line (on the lines kept, the local ML took 1.5-3x the CPU time: rig file 1800
    rpm, 1526-2000 Hz). ``df``: the median line spacing [Hz] when the caller has it (:func:`_local_lines`).
    """
    var = test.variance
    if var is None:
        return None
    f = data.freq
    lam = complex(model[k])
    fn, zeta = abs(lam) / (2 * np.pi), -lam.real / abs(lam)
    if not 0 < zeta:
        return None
    own = Candidate(replace(m, pole=lam, natural_freq=fn, damping_ratio=zeta), accepted=False, reason="")
    sl = _local_lines(f, own, cc, df)
    # own lines cut by the band's edge: their misfit may be the skirt of a mode beyond the edge, which
    # the lines cannot tell from a second mode (the band-edge rule of segment_misfit)
    if bool(sl[0]) or bool(sl[-1]):
        return None
    # the chi-square tests leave the harmonics' lines out (the refits and F tests take them all)
    sc = sl if harmonic is None else sl & ~harmonic
    n = int(sc.sum())
    if n < cc.min_segment_lines:
        return None
    n_chan = data.n_out * data.n_in
    coh = None if data.coherence is None else data.coherence.reshape(n_chan, -1)[:, sc]

    def fails(poles: NDArray[np.complex128], columns: NDArray[np.complex128] | None = None) -> bool:
        # the chi-square test of the lines as one segment
        with single_threaded():
            t = segment_misfit(f[sc], data.frf.reshape(n_chan, -1)[:, sc], poles, power=_FORM_POWER[data.frf_form],
                               variance=var[:, sc], coherence=coh, edges=[0, n], criteria=cc,
                               pole_columns=None if columns is None else columns[sc])
        return bool(t.failed[0])

    if not fails(np.asarray(model, dtype=np.complex128), model_columns):
        return None
    starts = [fn * (1 - zeta), fn * (1 + zeta)]
    best = None
    for fs in starts:
        w = 2 * np.pi * fs
        pole = complex(-zeta * w, w * np.sqrt(1 - zeta * zeta))
        c = Candidate(replace(m, pole=pole, natural_freq=float(fs), damping_ratio=float(zeta), natural_freq_std=0.0,
                              damping_ratio_std=0.0, n_poles=0, order_min=0, order_max=0), accepted=True, reason="")
        # the misfit is a missing mode only when the two poles explain the lines to the noise (first: the
        # cheapest of the tests, and the one a model error fails)
        alt = _refit_on(data, np.asarray([*model, pole], dtype=np.complex128), sl, memo)
        if alt is None or fails(alt):
            continue
        res = _nested_test(data, model, pole, sl, var, cc, starts, memo)
        if res is None or not res[0] >= res[1] or (best is not None and res[0] <= best[1]):
            continue
        if _peak_line_out(data, model, c, sl, var, cc, starts, memo) is not None:
            continue
        best = (c, *res[:4], sl)
    return best


def _one_line(data: FRFData, done: _Completed, residuals: bool, crit: IdentificationCriteria) -> _Completed:
    """``done`` without the accepted modes whose evidence rests on one line (``CompletenessCriteria.peak_line_out``).

    Only a mode whose ML half-power band ``2 zeta f_n`` is narrower than a line spacing can rest on
    one line; such a mode is tested on the lines near it (:func:`_local_lines`), the model's other
    poles with it against without it (:func:`_nested_test`), once without the line nearest to it
    (:func:`_peak_line_out`): when the lines without that one do not need it, it is dropped.
    """
    cc = crit.completeness
    var = done.test.variance
    f = data.freq
    if not cc.peak_line_out or var is None or f.size < 2 or not done.modes:
        return done
    df = float(np.median(np.diff(f)))
    ml = done.fitted[1]
    by_pole = {c.mode.pole: i for i, c in enumerate(done.candidates)}
    cands = list(done.candidates)
    drop: set[complex] = set()
    for k, m in enumerate(done.modes):
        lam = complex(ml.poles[k])
        i = by_pole.get(m.pole)
        if i is None or ml.kind[k] != "ml" or not -lam.real / np.pi < df:
            continue
        c = cands[i]
        c_ml = replace(c, mode=replace(c.mode, pole=lam, natural_freq=abs(lam) / (2 * np.pi),
                                       damping_ratio=-lam.real / abs(lam)))
        sl = _local_lines(f, c_ml, cc, df)
        if int(sl.sum()) < cc.min_segment_lines:
            continue
        others = [complex(p) for j, p in enumerate(ml.poles) if j != k]
        out = _peak_line_out(data, others, c_ml, sl, var, cc, [c_ml.mode.natural_freq])
        if out is None:
            continue
        drop.add(m.pole)
        cands[i] = replace(c, accepted=False, reason=(
            f"not resolved by the lines: its ML half-power band ({-lam.real / np.pi:.3g} Hz) is narrower than a line "
            f"spacing ({df:g} Hz) and the lines near it need it only with the line nearest to it ({out}); before: "
            f"{c.reason}"))
    if not drop:
        return done
    modes = [m for m in done.modes if m.pole not in drop]
    fitted, test = _fit_tested(data, modes, residuals, cc)
    gone = tuple(f"{cands[by_pole[p]].natural_freq:.6g} Hz beside" for p in drop)
    return replace(done, modes=modes, candidates=tuple(cands), fitted=fitted, test=test,
                   split=tuple(x for x in done.split if not any(g in x for g in gone)),
                   added=tuple(a for a in done.added if not any(abs(a - cands[by_pole[p]].natural_freq) < 1e-9
                                                                  for p in drop)))


def _leakage_merged(data: FRFData, done: _Completed, residuals: bool, crit: IdentificationCriteria) -> _Completed:
    """``done`` with each group of accepted modes the spectrum cannot tell apart reported as one mode.

    Accepted modes whose ML natural frequencies lie closer than one resolution bandwidth of the
    spectrum (``CompletenessCriteria.resolution_lines`` line spacings where the window is Hann or not
    recorded, else the named window's :data:`~ema_rig.identification.criteria.WINDOW_ENBW`), each to
    the next, with the same shape (MAC of their residues over every output and reference above
    ``CompletenessCriteria.resolution_mac``) are one group: a windowed spectrum smears one lightly
    damped mode over about its resolution bandwidth, and its leakage is fitted as poles about a line
    apart. Of each group the mode with the largest residue (Frobenius norm) is kept and the model
    refitted without the others (its ML then fits the one pole to the lines the group held); a
    message per group names the resolution and the line spacing that would resolve the modes. Not
    done on fewer than ``CompletenessCriteria.split_min_channels`` channels (outputs x references):
    the residues of one channel have one shape.
    """
    cc = crit.completeness
    f = data.freq
    model, ml = done.fitted[0], done.fitted[1]
    n_chan = model.residues.shape[1] * model.residues.shape[2]
    if (f.size < 2 or len(done.modes) < 2 or model.residues.shape[0] != len(done.modes)
            or n_chan < cc.split_min_channels):
        return done  # one channel's residues have one shape: its MAC cannot tell one mode from two
    df = float(np.median(np.diff(f)))
    window = data.meta.get("window")
    enbw = WINDOW_ENBW.get(str(window).lower(), cc.resolution_lines) if window else cc.resolution_lines
    fn = np.abs(np.asarray(ml.poles)) / (2 * np.pi)
    res = model.residues.reshape(len(done.modes), -1)
    norm = np.linalg.norm(res, axis=1)
    order = np.argsort(fn)
    groups: list[list[int]] = [[int(order[0])]]
    for a, b in zip(order[:-1], order[1:], strict=True):
        same = float(mac(res[a], res[b])[0, 0]) > cc.resolution_mac
        if fn[b] - fn[a] < enbw * df and same:
            groups[-1].append(int(b))
        else:
            groups.append([int(b)])
    groups = [g for g in groups if len(g) > 1]
    if not groups:
        return done
    by_pole = {c.mode.pole: i for i, c in enumerate(done.candidates)}
    cands = list(done.candidates)
    drop: set[complex] = set()
    msgs = []
    for g in groups:
        keep = max(g, key=lambda k: float(norm[k]))
        for k in g:
            if k == keep:
                continue
            drop.add(done.modes[k].pole)
            if (i := by_pole.get(done.modes[k].pole)) is not None:
                cands[i] = replace(cands[i], accepted=False, reason=(
                    f"leakage of {fn[keep]:.6g} Hz: {abs(fn[k] - fn[keep]) / df:.2f} lines from it with the same shape "
                    f"(MAC > {cc.resolution_mac:g}), inside the spectrum's resolution bandwidth ({enbw:g} lines)"))
        span = float(fn[g].max() - fn[g].min())
        msgs.append(f"{len(g)} modes at {', '.join(f'{fn[k]:.6g}' for k in sorted(g, key=lambda k: fn[k]))} Hz, "
                    f"{span / df:.2f} lines apart with the same shape (MAC > {cc.resolution_mac:g}), reported as one mode "
                    f"({fn[keep]:.6g} Hz before the refit): the spectrum's resolution bandwidth is {enbw:g} lines of "
                    f"{df:g} Hz ({'the Hann window assumed: no window recorded' if not window else f'window {window}'}), "
                    f"and leakage of a windowed spectrum splits one lightly damped mode into poles about a line apart; "
                    f"lines of at most {span / enbw:.3g} Hz would resolve two modes that far apart")
    modes = [m for m in done.modes if m.pole not in drop]
    try:
        fitted, test = _fit_tested(data, modes, residuals, cc)
    except IdentificationError:  # the refit failed (its ML left the band): the modes as fitted, the caveat said
        return replace(done, merged=tuple(x.replace("reported as one mode", "NOT refitted as one mode (the refit "
                                                    "failed), each reported") for x in msgs))
    gone = [m.natural_freq for m in done.modes if m.pole in drop]  # their PolyMAX frequencies, as the notes name them
    return replace(done, modes=modes, candidates=tuple(cands), fitted=fitted, test=test, merged=tuple(msgs),
                   added=tuple(a for a in done.added if not any(abs(a - v) < 1e-9 for v in gone)),
                   split=tuple(x for x in done.split if not any(f"{v:.6g} Hz beside" in x for v in gone)))


def _unresolved(modes: Sequence[SelectedMode], ml: LocalML, f: NDArray[np.float64],
                crit: IdentificationCriteria) -> list[tuple[SelectedMode, SelectedMode]]:
    """Pairs (lesser, stronger) of ``modes`` (aligned with ``ml``) that the ML does not resolve.

    Two ML estimates (neither held at its PolyMAX pole: a held pole is no ML estimate, and its
    propagated uncertainty says nothing about resolution) within three times their summed ML
    standard uncertainties and within the stronger's half-power half-bandwidth (at least a line
    spacing: modes further apart are resolved by the lines themselves), participation MAC above
    ``JudgeCriteria.dup_participation_mac`` (the judge's duplicate rule, with the ML uncertainty in
    place of the order spread), are one: the weaker cluster (fewer poles) is the lesser.
    """
    fn_ml = np.abs(ml.poles) / (2 * np.pi)
    df = float(np.median(np.diff(f))) if f.size > 1 else 0.0
    dup: set[complex] = set()
    out = []
    for a in range(len(modes)):
        for b in range(a + 1, len(modes)):
            ma, mb = modes[a], modes[b]
            s_ab = float(ml.natural_freq_std[a] + ml.natural_freq_std[b])
            if ma.pole in dup or mb.pole in dup or not np.isfinite(s_ab) or ml.kind[a] == "held" or ml.kind[b] == "held":
                continue
            hb = max(float(-ml.poles[a].real if ma.n_poles >= mb.n_poles else -ml.poles[b].real) / (2 * np.pi), df)
            if abs(fn_ml[a] - fn_ml[b]) <= min(3 * s_ab, hb) and float(
                    mac(np.array(ma.participation), np.array(mb.participation))[0, 0]) > crit.judge.dup_participation_mac:
                lesser, stronger = (mb, ma) if ma.n_poles >= mb.n_poles else (ma, mb)
                dup.add(lesser.pole)
                out.append((lesser, stronger))
    return out


def _parsimonious(data: FRFData, done: _Completed, poles: list[complex], residuals: bool,
                  crit: IdentificationCriteria) -> _Completed:
    """Drop weak modes the data do not need, then fit the final set once (LSFD and local ML).

    ``poles`` are the current poles (the ML poles of ``done.fitted`` plus the PolyMAX poles of
    modes added since). A mode whose own term is less than ``JudgeCriteria.weak_peak_share`` of
    the FRF near it is tested: its segment is fitted without its pole and tested against the
    noise variance of the full model's test; when it passes, the mode is dropped (weakest first;
    one local test per weak mode, a work limit). Not done when the noise level is unknown (a
    coherence without the number of averages).
    """
    cc = crit.completeness
    var = done.test.variance if cc.drop_weak else None
    if done.test.noise_source == "coherence" and data.n_averages is None:
        var = None  # the coherence without the number of averages gives the noise's shape, not its level
    cands = list(done.candidates)
    modes = list(done.modes)
    dropped: list[float] = []
    by_pole = {c.mode.pole: i for i, c in enumerate(cands)}
    weak = [i for m in modes if (i := by_pole.get(m.pole)) is not None and cands[i].accepted
            and np.isfinite(cands[i].peak_share) and cands[i].peak_share < crit.judge.weak_peak_share]
    weak.sort(key=lambda i: cands[i].peak_share)
    f = data.freq
    for i in weak if var is not None else []:
        c = cands[i]
        k = int(np.argmin(np.abs(np.abs(np.asarray(poles)) - abs(c.mode.pole))))  # its current pole
        fk = abs(poles[k]) / (2 * np.pi)
        seg = np.flatnonzero((done.test.freq_lower <= fk) & (fk <= done.test.freq_upper))
        others = [p for j, p in enumerate(poles) if j != k]
        if seg.size == 0 or not others:
            continue
        lo, hi = float(done.test.freq_lower[seg[0]]), float(done.test.freq_upper[seg[0]])
        if lo >= hi or not np.any((f >= lo) & (f <= hi)):
            continue
        if _passes_with(data, others, lo, hi, done.test, cc, alone=True):
            modes = [m for m in modes if m.pole != c.mode.pole]
            poles = others
            cands[i] = replace(c, accepted=False, reason=(
                f"not needed by the data: without it the residual near {fk:.6g} Hz stays consistent with the "
                f"noise estimate (its own term {100 * c.peak_share:.0f} % of the FRF near it)"))
            dropped.append(fk)
    # the model's completeness test comes with each refit (:func:`_fit_tested`); None: not refitted
    fitted, test = _fit_tested(data, modes, residuals, cc) if dropped or done.added else (done.fitted, None)
    ml = fitted[1]
    dup: set[complex] = set()
    for lesser, stronger in _unresolved(modes, ml, f, crit):
        dup.add(lesser.pole)
        i = by_pole.get(lesser.pole)
        if i is not None:
            cands[i] = replace(cands[i], accepted=False, reason=(
                f"duplicate of {stronger.natural_freq:.6g} Hz: the ML does not resolve the two "
                f"(within 3 x their summed uncertainty, participation MAC > {crit.judge.dup_participation_mac:g})"))
    if dup:
        modes = [m for m in modes if m.pole not in dup]
        fitted, test = _fit_tested(data, modes, residuals, cc)
    elif not dropped and not done.added:
        return done
    # a missing mode is added as a start value: when the ML of the whole band cannot hold it (it
    # leaves its half-power band or turns unstable), the data do not determine it as a mode
    added = {c.mode.pole: i for i, c in enumerate(cands) if c.accepted and c.reason.startswith("physical: a missing mode")}
    lost = [m for j, m in enumerate(modes) if m.pole in added and fitted[1].kind[j] == "held"]
    if lost:
        gone = {cands[added[m.pole]].natural_freq for m in lost}
        for m in lost:
            i = added[m.pole]
            cands[i] = replace(cands[i], accepted=False, reason=(
                f"not determined by the data: added as a missing mode, but the ML fit could not hold it "
                f"(before: {cands[i].reason})"))
        modes = [m for m in modes if m.pole not in {x.pole for x in lost}]
        fitted, test = _fit_tested(data, modes, residuals, cc)
        done = replace(done, added=tuple(f for f in done.added if f not in gone))
    if test is None:
        test = _misfit(data, fitted[0], cc)
    return _Completed(modes, tuple(cands), fitted, test, done.added, tuple(dropped))


def _local_ml_staged(data: FRFData, model: ModalModel, syn: NDArray[np.complex128] | None = None, *,
                     second_thread: bool = True) -> StagedML:
    """:func:`~ema_rig.identification.ml.local_ml_staged` started at the LSFD model's poles (data cut to the band;
    call it on one BLAS thread: many small products, threads only add hand-off time); ``syn`` the model's FRFs on
    the data's lines when the fit gave them (``_lsfd_checked(model_out=...)``), ``second_thread`` as there."""
    if syn is None:
        syn = model.synthesize(data.freq).frf
    syn = np.where(np.isfinite(syn), syn, data.frf)  # a lower residual is infinite at 0 Hz
    return local_ml_staged(data, model.poles, syn, second_thread=second_thread)


def _refined(ident: Identification, data: FRFData) -> Identification:
    """``ident`` with the ML-refined modes and their standard deviations, or unchanged with a warning."""
    ref = refine_model(data, ident.modes)
    # the caveats travel in Identification.warnings (the CLI prints each once), not as Python warnings
    if not ref.converged:
        return replace(ident, refinement=ref, warnings=ident.warnings + (
            f"ML refinement fell back to the default estimate ({ref.reason}); the standard deviations are "
            "the default (local ML) ones",))
    carried = []
    for w in ref.warnings:
        if "kept at its PolyMAX pole" in w:
            w += " (its standard deviations are the default ML ones)"
        carried.append(w)
    # modes kept at their PolyMAX pole keep the default (local ML) uncertainty
    meta = dict(ref.model.meta)
    if "polymax_poles" in ident.modes.meta:  # the selection's poles, for to_records
        meta["polymax_poles"] = ident.modes.meta["polymax_poles"]
    return replace(
        ident,
        modes=replace(ref.model, meta=meta),
        natural_freq_std=np.where(np.isnan(ref.natural_freq_std), ident.natural_freq_std, ref.natural_freq_std),
        damping_ratio_std=np.where(np.isnan(ref.damping_ratio_std), ident.damping_ratio_std, ref.damping_ratio_std),
        refinement=ref,
        warnings=ident.warnings + tuple(carried),
    )


def _up_to(stab: StabilizationData, n: int) -> StabilizationData:
    """The rows of ``stab`` of the orders up to ``n`` (their status letters do not depend on later orders)."""
    ps = stab.poles
    keep = ps.order <= n  # a prefix: the pole set is stored order by order, ascending
    sub = PoleSet(order=ps.order[keep], pole=ps.pole[keep], participation=ps.participation[keep], band=ps.band,
                  in_dofs=ps.in_dofs, orders=tuple(o for o in ps.orders if o <= n), meta=ps.meta)
    return StabilizationData(sub, stab.status[keep], stab.tolerances)


def _why(data: FRFData) -> str:
    """What in the FRFs makes them untrustworthy (phase, coherence), as a clause for a refusal."""
    findings = diagnose_frf(data)
    return ("; the measurement itself is suspect: " + "; ".join(findings)) if findings else ""


#: Clause of the refusal when a user's order cap stopped the search below the default cap.
LOW_CAP_HINT = "the order cap may be too low"


def _picks_not_found(selection: Selection, resolved: Selection, src: str | None) -> list[str]:
    """A warning when poles picked by hand on these very data are not found again.

    A selection replays exactly (provenance kept) on the data it was made on and by nearest
    frequency elsewhere (:func:`~ema_rig.identification.stabilization.resolve_selection`). When the
    selection names this file as its source but a hand-picked pole is not among its poles, the file
    (or the band or order) changed since the pick: the mode used is the nearest one found, not the
    pole the user chose, and a number computed from it carries this line.

    Returns
    -------
    list of str
        One line, or none (other data, no hand pick, or every pick found exactly).
    """
    if selection.source is None or src is None:
        return []
    try:
        same = os.path.realpath(selection.source) == os.path.realpath(src)
    except (OSError, ValueError):
        return []
    kept = {(m.order, m.index, m.pole) for m in resolved.modes if m.provenance == "manual"}
    lost = [m for m in selection.modes if m.provenance == "manual" and (m.order, m.index, m.pole) not in kept]
    if not same or not lost:
        return []
    freqs = ", ".join(f"{m.natural_freq:.2f}" for m in lost)
    return [f"the selection was picked by hand on this file, but its pole(s) at {freqs} Hz are not among this "
            "identification's poles (the file, or the band or order, changed since the pick): replayed by the "
            "nearest mode instead; pick again on the chart"]


def _require_stable(stab: StabilizationData, n: int, src: str | None, data: FRFData, *,
                    low_cap: int | None = None) -> None:
    """Refuse a stabilization without a stable pole up to order ``n``.

    ``low_cap`` is the number of references when the caller capped the order below the order
    the default search starts at (:func:`~ema_rig.identification.plscf.default_max_order`): the
    refusal then blames the cap and says to raise it, not the measurement (the default order
    finds modes that a cap of 3 cannot). A cap at or above that start leaves the measurement
    to blame, as without a cap.
    """
    n_stable = int(np.sum(np.isin(stab.status, ["s", "d", "v", "f"])))
    if n_stable == 0:
        fband = stab.band
        why = (f"; {LOW_CAP_HINT}: max_order={n} is below the order {default_max_order(low_cap)} the default "
               f"search starts at (default cap {default_order_cap(low_cap)}), raise it"
               if low_cap is not None else _why(data))
        raise IdentificationError(
            f"no stable pole in the band {fband[0]:g}..{fband[1]:g} Hz up to order {n} "
            f"({len(stab)} poles, {int(np.sum(stab.unstable))} of them unstable)" + why,
            file=src,
        )


__all__ = ["Identification", "default_order_cap", "identify", "transpose_layout"]
