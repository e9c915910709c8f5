"""The evidence about each identified mode that matching weighs (DESIGN §4).

Functions
---------
measure_candidates
    Shape, scale and harmonic metrics of every mode of a :class:`ModalModel`, no decision yet.
harmonic_order
    Order of the shaft-speed harmonic at a frequency, or None: the one rule of "a harmonic line".
harmonic_chance
    Chance that a mode at a random frequency falls inside a harmonic's window: when it is not
    small the window is no evidence of a harmonic.
harmonic_bands
    The frequency intervals that rule calls harmonic in a band (the lines identify leaves out of
    the split test's own-lines test).
find_dof
    Index of the DOF with a target's node and axis (sign ignored): "does this DOF match that
    sensor", the one definition matching uses.

Classes
-------
Candidate
    Frozen record of one mode: its metrics, and (after judging) its status and reason.

Notes
-----
Shapes come from the radial reference's residue column, mass-normalised at the radial driving
point. The effective modal mass at the driving point is :meth:`ModalModel.modal_mass`
(``1 / (2 w_d |R_pp|)``); without a driving-point FRF the radial housing *participation*
``mean_p |2 w_d R_pq|`` over the radial housing sensors stands in for ``1 / m_eff`` (the housing
is rigid in its radial mode, so every radial housing sensor moves like the driving point).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..config import RigConfig
from ..dof import DOF
from ..errors import MatchingError
from ..identification.modal import ModalModel, effective_mass, shape_products

__all__ = ["Candidate", "find_dof", "harmonic_bands", "harmonic_chance", "harmonic_order", "measure_candidates", "sensor_groups"]


@dataclass(frozen=True, slots=True)
class Candidate:
    """One identified mode as a candidate for the housing (or spindle) mode.

    Attributes
    ----------
    index : int
        Index of the mode in its :class:`ModalModel`.
    source : str
        ``'modes'`` (housing band) or ``'spindle_modes'`` (spindle band).
    natural_freq : float
        ``|lambda| / 2 pi`` [Hz].
    damping_ratio : float
        ``-Re(lambda) / |lambda|``.
    natural_freq_std : float or None
        Standard uncertainty of the natural frequency [Hz] from the identification.
    status : str
        ``'housing'``, ``'spindle'`` or ``'rejected'``.
    reason : str
        Why it was kept or rejected (``'; '``-separated when several).
    failures : tuple of str
        The housing criteria it fails (empty: it passes them all).
    radial_sensors : bool
        The data have radial housing sensors (else the shape metrics are None).
    radial_phase_cos : float or None
        Smallest ``cos`` of the phase between a radial housing sensor and the reference one.
    radial_amplitude_ratio : float or None
        ``min |phi| / max |phi|`` over the radial housing sensors.
    lateral_ratio, axial_ratio : float or None
        Largest lateral / axial housing amplitude over the mean radial housing amplitude.
    spindle_ratio : float or None
        Signed spindle / housing radial motion.
    spindle_axial_ratio : float or None
        Axial over radial spindle motion.
    polarity_suspect : str or None
        The radial housing sensor whose reversal would make this shape a clean translation (set
        only when phase is the sole objection).
    modal_mass : float or None
        Effective modal mass at the radial driving point [kg] (``mass_source`` says how).
    mass_source : str or None
        ``'driving point'`` or ``'radial housing transfer FRFs'``.
    participation : float or None
        Radial housing participation ``mean_p |phi_p phi_q|`` [1/kg].
    harmonic : int or None
        Order of the shaft-speed harmonic this line sits on (rotating bearing).
    harmonic_ambiguous : int or None
        Order of the harmonic whose window this lightly damped mode sits in when the windows
        cover so much of the frequency axis (:func:`harmonic_chance` above
        ``MatchCriteria.harmonic_max_chance``, low shaft speeds) that a mode at any frequency would
        sit in one: not taken as a harmonic (``harmonic`` is None), and matching warns.
    model_modal_mass, model_spindle_ratio : float or None
        The 3DOF model's housing mode tuned to this frequency (None outside its range).
    mass_ratio : float or None
        ``modal_mass / model_modal_mass``.
    """

    index: int
    source: str
    natural_freq: float
    damping_ratio: float
    natural_freq_std: float | None
    status: str = "rejected"
    reason: str = ""
    failures: tuple[str, ...] = ()
    radial_sensors: bool = False
    radial_phase_cos: float | None = None
    radial_amplitude_ratio: float | None = None
    lateral_ratio: float | None = None
    axial_ratio: float | None = None
    spindle_ratio: float | None = None
    spindle_axial_ratio: float | None = None
    polarity_suspect: str | None = None
    modal_mass: float | None = None
    mass_source: str | None = None
    participation: float | None = None
    harmonic: int | None = None
    harmonic_ambiguous: int | None = None
    model_modal_mass: float | None = None
    model_spindle_ratio: float | None = None
    mass_ratio: float | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict (the ``candidates`` entries of ``ema-rig stiffness --json``)."""
        d = asdict(self)
        d["failures"] = list(self.failures)
        return d

    @property
    def passes_but_mass(self) -> bool:
        """Passes every housing criterion except, perhaps, the effective modal mass."""
        return all(getattr(f, "kind", None) in ("mass", "mass units") for f in self.failures)


def find_dof(dofs: tuple[DOF, ...], target: DOF) -> int | None:
    """Index of the first DOF with ``target``'s node and axis (sign ignored), or None."""
    for i, d in enumerate(dofs):
        if d.same_axis(target):
            return i
    return None


def _clean(x: float | None) -> float | None:
    return None if x is None or not np.isfinite(x) else float(x)


def sensor_groups(modes: ModalModel, rig: RigConfig) -> dict[tuple[str, str], list[int]]:
    """Output indices per (role, axis), from the model's roles/axes or the rig's sensor list.

    Parameters
    ----------
    modes : ModalModel
        Identified modes (their outputs, roles and axes).
    rig : RigConfig
        The rig file, for outputs the data name no role of.

    Returns
    -------
    dict
        ``(role, axis) -> [output index, ...]``, e.g. ``("spindle", "radial")``.
    """
    groups: dict[tuple[str, str], list[int]] = {}
    for i, d in enumerate(modes.out_dofs):
        role, axis = modes.roles[i], modes.axes[i]
        if role is None or axis is None:
            s = rig.sensor_for(d)
            if s is None:
                continue
            role, axis = s.role, s.axis
        groups.setdefault((role, axis), []).append(i)
    return groups


def _shape_metrics(phi: NDArray[np.complex128], p: int | None, g: dict[tuple[str, str], list[int]]
                   ) -> dict[str, float | None]:
    """Phase, amplitude, cross-axis and spindle metrics of one shape."""
    h_rad = g.get(("housing", "radial"), [])
    h_lat = g.get(("housing", "lateral"), [])
    h_ax = g.get(("housing", "axial"), [])
    s_rad = g.get(("spindle", "radial"), [])
    s_ax = g.get(("spindle", "axial"), [])
    with np.errstate(divide="ignore", invalid="ignore"):
        a = phi[h_rad]
        pref = p if p is not None and p in h_rad else h_rad[int(np.argmax(np.abs(a)))]
        ph_ref = phi[pref]
        aref = abs(ph_ref)
        amp_h = float(np.mean(np.abs(a)))
        cos = np.real(a * np.conj(ph_ref)) / (np.abs(a) * aref)
        out: dict[str, float | None] = {
            "radial_phase_cos": _clean(float(np.min(cos))),
            "radial_amplitude_ratio": _clean(float(np.min(np.abs(a)) / np.max(np.abs(a)))),
            "lateral_ratio": _clean(float(np.max(np.abs(phi[h_lat])) / amp_h)) if h_lat else None,
            "axial_ratio": _clean(float(np.max(np.abs(phi[h_ax])) / amp_h)) if h_ax else None,
            "spindle_ratio": None,
            "spindle_axial_ratio": None,
        }
        if s_rad:
            # signed: projection on the housing reference's phase
            proj = np.real(phi[s_rad] * np.conj(ph_ref)) / aref
            out["spindle_ratio"] = _clean(float(np.mean(proj)) / amp_h)
            if s_ax:
                out["spindle_axial_ratio"] = _clean(float(np.max(np.abs(phi[s_ax])) / np.mean(np.abs(phi[s_rad]))))
    return out


def _polarity_suspect(phi: NDArray[np.complex128], p: int | None, h_rad: list[int],
                      out_dofs: tuple[DOF, ...], min_amplitude_ratio: float, min_cos: float = 0.9) -> str | None:
    """The radial housing sensor whose sign flip would make a tilt-like shape a clean translation.

    A rigid radial translation moves every radial housing sensor in phase with similar
    amplitude; a tilt mode moves them out of phase *and* with different amplitudes (a sensor near
    the tilt axis hardly moves). When flipping exactly one sensor gives in-phase motion
    (``cos >= min_cos``, :attr:`MatchCriteria.polarity_min_cos`) with similar amplitudes, that
    sensor's polarity is the likely cause.
    """
    a = np.asarray(phi[h_rad], dtype=complex)
    if len(h_rad) < 2 or not np.all(np.abs(a) > 0):
        return None
    pref = h_rad.index(p) if p is not None and p in h_rad else int(np.argmax(np.abs(a)))

    def clean(v: NDArray[np.complex128]) -> bool:
        cos = np.real(v * np.conj(v[pref])) / (np.abs(v) * abs(v[pref]))
        amp = np.min(np.abs(v)) / np.max(np.abs(v))
        return bool(np.min(cos) >= min_cos and amp >= min_amplitude_ratio)

    if clean(a):
        return None
    hits = []
    for i in range(len(h_rad)):
        b = a.copy()
        b[i] = -b[i]
        if clean(b):
            hits.append(i)
    if len(h_rad) == 2:
        # two sensors: out of phase is a tilt or a reversed sensor; name both
        return " or ".join(str(out_dofs[h_rad[i]]) for i in range(2)) if hits else None
    return str(out_dofs[h_rad[hits[0]]]) if len(hits) == 1 else None


def harmonic_order(freq: float, speed_hz: float, tol_hz: float, min_order: float) -> int | None:
    """Order ``k`` of the shaft-speed harmonic at ``freq`` [Hz], or None.

    ``freq`` is the harmonic ``k = max(1, round(freq / speed_hz))`` when ``|freq - k speed_hz| <= tol_hz``
    and ``freq >= min_order * speed_hz``. A mode is a harmonic line when this holds and its damping
    is tiny (:func:`measure_candidates`); a line of the FRF when this holds (:func:`harmonic_bands`).

    Parameters
    ----------
    freq : float
        Frequency [Hz] of a mode or a line.
    speed_hz : float
        Shaft speed [Hz], positive.
    tol_hz : float
        Tolerance [Hz]: ``MatchCriteria.harmonic_freq_tol * freq``, widened to ``harmonic_sigmas``
        standard deviations of an identified frequency.
    min_order : float
        ``MatchCriteria.harmonic_min_order``: below ``min_order * speed_hz`` nothing is a harmonic.

    Returns
    -------
    int or None
    """
    if freq < min_order * speed_hz:
        return None
    k = max(1, round(freq / speed_hz))
    return int(k) if abs(freq - k * speed_hz) <= tol_hz else None


def harmonic_chance(speed_hz: float, tol_hz: float) -> float:
    """Chance that a mode at a random frequency lies inside a harmonic's window of ``+-tol_hz``.

    The windows ``k speed_hz +- tol_hz`` cover the fraction ``2 tol_hz / speed_hz`` of the
    frequency axis near the mode (capped at 1: overlapping windows cover everything). A mode
    inside a window is evidence of a harmonic line only when this chance is small (matching
    compares it with ``MatchCriteria.harmonic_max_chance``); at low shaft speeds it reaches 1
    (``tol_hz = 2e-3 f``: every frequency above ``250 speed_hz``).

    Parameters
    ----------
    speed_hz : float
        Shaft speed [Hz], positive.
    tol_hz : float
        Half-width [Hz] of the window at the mode (:func:`harmonic_order`'s ``tol_hz``).

    Returns
    -------
    float
        The covered fraction, in [0, 1].
    """
    return min(1.0, 2.0 * tol_hz / speed_hz)


def harmonic_bands(band: tuple[float, float], speed_hz: float, freq_tol: float,
                   min_order: float, max_chance: float = 1.0) -> tuple[tuple[float, float], ...]:
    """The intervals [Hz] of ``band`` that :func:`harmonic_order` calls shaft harmonics.

    With the relative tolerance ``tol_hz = freq_tol * f`` of a line (no frequency uncertainty), the
    harmonic ``k`` holds the frequencies ``f`` with ``|f - k speed_hz| <= freq_tol f``:
    ``k speed_hz / (1 + freq_tol) <= f <= k speed_hz / (1 - freq_tol)`` (``freq_tol < 1 / (2 k + 1)``,
    so ``round(f / speed_hz) = k`` there), above ``min_order * speed_hz``.

    Only the harmonics whose windows are evidence are listed: :func:`harmonic_chance` at the
    harmonic (``2 freq_tol k``) at most ``max_chance``, the rule by which matching calls a mode a
    harmonic line (one rule for modes and lines). Above that order (``k > max_chance / (2 freq_tol)``,
    83 with the defaults) the windows cover so much of the axis that a line's place on one says
    nothing; leaving them out would leave the split test's own-lines test no line at low shaft
    speeds (every line above ``250 speed_hz`` is inside a window), so they stay in the test.

    Parameters
    ----------
    band : (float, float)
        ``(freq_lower, freq_upper)`` [Hz].
    speed_hz : float
        Shaft speed [Hz], positive.
    freq_tol : float
        ``MatchCriteria.harmonic_freq_tol`` (relative).
    min_order : float
        ``MatchCriteria.harmonic_min_order``.
    max_chance : float, optional
        ``MatchCriteria.harmonic_max_chance``; 1 (default) lists every harmonic.

    Returns
    -------
    tuple of (float, float)
        ``(f_lo, f_hi)`` [Hz] per harmonic that overlaps ``band``, in frequency order.
    """
    if not speed_hz > 0:
        raise ValueError(f"speed_hz must be a positive shaft speed [Hz], got {speed_hz!r}")
    out = []
    for k in range(1, int(band[1] * (1 + freq_tol) / speed_hz) + 1):
        if harmonic_chance(speed_hz, freq_tol * k * speed_hz) > max_chance:
            break  # and every higher order: the chance grows with k
        lo, hi = max(k * speed_hz / (1 + freq_tol), min_order * speed_hz), k * speed_hz / (1 - freq_tol)
        if lo <= hi and hi >= band[0] and lo <= band[1]:
            out.append((float(lo), float(hi)))
    return tuple(out)


def measure_candidates(
    modes: ModalModel,
    rig: RigConfig,
    source: str,
    natural_freq_std: NDArray[np.float64] | None,
    speed_hz: float | None,
    *,
    harmonic_freq_tol: float,
    harmonic_max_damping: float,
    min_amplitude_ratio: float,
    harmonic_sigmas: float = 3.0,
    harmonic_min_order: float = 0.5,
    polarity_min_cos: float = 0.9,
    harmonic_max_chance: float = 1.0 / 3.0,
) -> list[Candidate]:
    """Shape, scale and harmonic metrics of every mode (status ``'rejected'``, no reason yet).

    Parameters
    ----------
    modes : ModalModel
        Identified modes with the radial reference.
    rig : RigConfig
        Sensor roles and axes, the radial reference.
    source : str
        Label of ``modes`` (``'modes'`` or ``'spindle_modes'``).
    natural_freq_std : ndarray, shape (n_modes,), or None
        Identified frequency std [Hz] (widens the harmonic tolerance).
    speed_hz : float or None
        Shaft speed [Hz] of a rotating bearing.
    harmonic_freq_tol, harmonic_max_damping, min_amplitude_ratio : float
        See :class:`ema_rig.rig.matching.MatchCriteria`.
    harmonic_sigmas, harmonic_min_order, polarity_min_cos, harmonic_max_chance : float, optional
        See :class:`ema_rig.rig.matching.MatchCriteria` (defaults: its defaults). A lightly damped
        mode inside a harmonic's window is a harmonic only when :func:`harmonic_chance` is at most
        ``harmonic_max_chance``; else its ``harmonic_ambiguous`` holds the order.

    Returns
    -------
    list of Candidate, one per mode in model order

    Raises
    ------
    MatchingError
        If the modes lack the radial reference.
    """
    ref = rig.radial.positive()
    q = find_dof(modes.in_dofs, ref)
    p = find_dof(modes.out_dofs, ref)
    if q is None:
        raise MatchingError(
            f"the identified modes have no radial reference {rig.radial} "
            f"(references: {[str(d) for d in modes.in_dofs]})"
        )
    groups = sensor_groups(modes, rig)
    h_rad = groups.get(("housing", "radial"), [])
    shapes = modes.mode_shapes(modes.in_dofs[q])
    part = (np.mean(np.abs(shape_products(modes.poles, modes.residues[:, h_rad, q])), axis=1) if h_rad
            else np.zeros(modes.n_modes))
    mass: NDArray[np.float64] | None
    if p is not None:
        if modes.out_dofs[p] == modes.in_dofs[q]:
            mass = modes.modal_mass(modes.in_dofs[q])
        else:  # written with opposite signs: |R_pp| is sign-free, the same 1 / (2 w_d |R_pp|)
            mass = effective_mass(modes.poles, modes.residues[:, p, q])
        mass_source: str | None = "driving point"
    elif h_rad:
        with np.errstate(divide="ignore"):
            mass = 1.0 / part
        mass_source = "radial housing transfer FRFs"
    else:
        mass, mass_source = None, None
    out = []
    for r in range(modes.n_modes):
        fn, z = float(modes.natural_freq[r]), float(modes.damping_ratio[r])
        sd = None if natural_freq_std is None else _clean(float(natural_freq_std[r]))
        harmonic = ambiguous = None
        if speed_hz is not None and z < harmonic_max_damping:
            tol = harmonic_freq_tol * fn if sd is None else max(harmonic_freq_tol * fn, harmonic_sigmas * sd)
            harmonic = harmonic_order(fn, speed_hz, tol, harmonic_min_order)
            if harmonic is not None and harmonic_chance(speed_hz, tol) > harmonic_max_chance:
                # a mode anywhere would sit in some window this often: no evidence of a harmonic
                harmonic, ambiguous = None, harmonic
        metrics: dict[str, Any] = {}
        if h_rad:
            metrics = dict(_shape_metrics(shapes[r], p, groups))
            metrics["polarity_suspect"] = _polarity_suspect(shapes[r], p, h_rad, modes.out_dofs,
                                                            min_amplitude_ratio, polarity_min_cos)
        out.append(Candidate(
            index=r, source=source, natural_freq=fn, damping_ratio=z, natural_freq_std=sd,
            radial_sensors=bool(h_rad), modal_mass=None if mass is None else _clean(float(mass[r])),
            mass_source=mass_source, participation=_clean(float(part[r])), harmonic=harmonic,
            harmonic_ambiguous=ambiguous, **metrics,
        ))
    return out
