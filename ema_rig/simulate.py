"""Synthetic rig measurements with a known truth.

The simulated FRFs are what the rig's accelerometers (roles and axes from the rig file) would
record for a force from the radial shaker (and optionally the axial one):

- the three modes of the 3DOF model (:mod:`ema_rig.rig.model`): radial housing sensors measure
  ``x_H``, radial spindle sensors ``x_S``, the radial reference drives ``m_H``. With
  ``extra_modes=False``, ``misalignment_deg=0`` and ``noise=0`` the radial FRFs are exactly the
  3DOF model's;
- optionally (``appendage``) a small flexible part of the housing (a load arm, a cover) on its own
  spring: the radial dynamics become 4DOF and the housing mode couples to the appendage's;
- every sensor is mounted slightly askew (seeded, a few degrees by default): it measures
  ``cos(a)`` of the motion along its axis plus ``sin`` of the two transverse components (the
  housing's or spindle's motion along the other axes, taken as the mean over that group's
  sensors), so a radial housing sensor sees the lateral, axial and tilt modes too;
- the modes the model lacks, as additional modal contributions (they do not move the 3DOF poles):
  rig rigid-body modes 5.9-16.4 Hz, housing tilt modes below 150 Hz (radial housing sensors out
  of phase), the spindle's first mode at 287 Hz, the housing axial mode near 300 Hz, a lateral
  housing mode, flexible frame/housing modes from 663/695 Hz (irregular shapes, large effective
  mass at the driving point) and the spindle axial mode at 1012 Hz;
- when rotating (``speed_hz``), narrow, nearly undamped lines at multiples of the shaft speed;
- complex, seeded, relative noise.

Every contribution is a viscously, proportionally damped mode ``psi_o psi_i / (w_r^2 - w^2 +
2 j zeta_r w_r w)`` with mass-normalised shapes, so ``|lambda_r| / 2 pi`` is exactly the stated
natural frequency and the FRF matrix is reciprocal. The extra modes' shapes are fixed (a fixed
internal seed); ``seed`` only changes the noise and the harmonic lines.

Functions
---------
simulate_measurement
    Build a :class:`Simulation` (FRFData in SI accelerance + truth).
write_measurement
    Write it as UFF58 (ASCII or binary, m/s^2 or g) with ``<file>.truth.json`` beside it.
truth_path
    Where the truth of a measurement file is stored.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import Any, cast

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from . import _atomic
from .config import RigConfig, Sensor
from .dof import DOF
from .frf import FRFData
from .io.uff import write_uff58
from .rig.model import HOUSING, SPINDLE, RigModel, modal_frf, series_stiffness

DEFAULT_DAMPING: Mapping[str, float] = MappingProxyType(
    {
        "frame": 0.03,  # 3DOF mode 1: frame on the bushings
        "housing_radial": 0.02,  # 3DOF mode 2: housing on k_TB+MS
        "spindle_bending": 0.01,  # 3DOF mode 3
        "rigid_body": 0.03,
        "housing_tilt": 0.02,
        "spindle_first": 0.015,
        "housing_axial": 0.02,
        "housing_lateral": 0.02,
        "flexible": 0.015,
        "spindle_axial": 0.01,
        "harmonic": 2e-4,
        "appendage": 0.015,
    }
)
"""Modal damping ratio per mode kind (plausible for a bolted steel rig, 0.5-3 %)."""

_SHAPE_SEED = 20140601  # fixed: the extra modes' shapes do not change with the noise seed
_CROSS_AXIS = 0.02  # cross-axis sensitivity: lateral/axial sensors see 2 % of the radial motion
_RIGID_FREQS = (5.9, 7.7, 9.8, 12.9, 16.4)  # Hz (the sixth rigid-body mode is the 3DOF frame mode)
_TILT_FREQS = (112.0, 138.0)
_FLEX_FREQS = (663.0, 695.0, 742.0, 801.0, 846.0, 958.0, 1063.0, 1188.0, 1342.0, 1495.0, 1640.0, 1785.0)
_MOUNT_SEED = 19700101  # fixed: each sensor's misalignment does not change with the noise seed
DEFAULT_MISALIGNMENT_DEG = 3.0
"""Standard deviation [deg] of each sensor's seeded tilt towards each of its two transverse axes."""
_LATERAL_RATIO = 0.88  # lateral housing mode: unloaded direction, a bit softer than radial


@dataclass(frozen=True, slots=True)
class Simulation:
    """A synthetic measurement and its truth.

    Attributes
    ----------
    data : FRFData
        Accelerance [m/s^2/N], outputs = the rig's sensors with sign-corrected (+) DOFs,
        inputs = the references.
    truth : mapping
        ``k_TB`` (inf for a rigid disk: null in the JSON, with ``rigid_disk`` true), ``k_MS``,
        ``k_TB_MS`` [N/m], ``f_H`` and ``f_spindle`` (3DOF housing and
        spindle-bending natural frequencies, Hz, without the appendage), ``misalignment_deg``
        (per sensor: the two tilt angles [deg]), ``appendage`` (null or ``mass`` [kg], ``freq``
        [Hz] uncoupled), ``housing_damping``, ``housing_effective_mass``
        [kg], ``speed_hz``, ``noise``, ``seed``, ``extra_modes`` and ``modes``: one dict per
        contribution with ``kind``, ``natural_freq`` [Hz], ``damping_ratio`` and
        ``effective_mass_dp`` [kg] (at the radial driving point).
    """

    data: FRFData
    truth: Mapping[str, Any] = field(default_factory=dict)

    def truth_dict(self) -> dict[str, Any]:
        """The truth as a plain (JSON-ready) dict."""
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in self.truth.items()}


# ----------------------------------------------------------------------------- shapes
def _group_index(sensors: Sequence[Sensor]) -> list[tuple[int, int]]:
    """Per sensor: (index within its role/axis group, group size)."""
    counts: dict[tuple[str, str], int] = {}
    idx = []
    for s in sensors:
        key = (s.role, s.axis)
        idx.append(counts.get(key, 0))
        counts[key] = counts.get(key, 0) + 1
    return [(i, counts[(s.role, s.axis)]) for i, s in zip(idx, sensors, strict=True)]


def _tilt_pattern(i: int, n: int, which: int) -> float:
    """Out-of-phase pattern over the radial housing sensors (first sensor = 1)."""
    if n <= 1:
        return 1.0
    if which == 0:  # rocking about one axis: 1 ... -1
        return 1.0 - 2.0 * i / (n - 1)
    return (-1.0) ** i * (1.0 - 0.3 * i / (n - 1))  # alternating: 1, -0.85, 0.7


def _extra_modes(sensors: Sequence[Sensor], f_H: float, damping: Mapping[str, float]) -> list[dict[str, Any]]:
    """The modes the 3DOF model lacks: kind, frequency, damping and shape over the sensors."""
    rng = np.random.default_rng(_SHAPE_SEED)
    gi = _group_index(sensors)
    n = len(sensors)
    modes: list[dict[str, Any]] = []

    def add(kind: str, freq: float, shape: NDArray[np.float64]) -> None:
        modes.append({"kind": kind, "natural_freq": float(freq), "damping_ratio": float(damping[kind]), "shape": shape})

    for f in _RIGID_FREQS:
        # whole rig moving on its bushings: every sensor, effective masses of hundreds of kg
        add("rigid_body", f, rng.uniform(-1.0, 1.0, n) / math.sqrt(600.0))
    for w, f in enumerate(_TILT_FREQS):
        sh = np.zeros(n)
        for j, (s, (i, m)) in enumerate(zip(sensors, gi, strict=True)):
            if s.role == "housing" and s.axis == "radial":
                sh[j] = _tilt_pattern(i, m, w)
            elif s.role == "housing":
                sh[j] = 0.3 if s.axis == ("lateral" if w else "axial") else 0.1
            else:
                sh[j] = 0.05
        add("housing_tilt", f, sh / math.sqrt(40.0))
    sh = np.zeros(n)
    for j, (s, (i, m)) in enumerate(zip(sensors, gi, strict=True)):
        if s.role == "spindle" and s.axis == "radial":
            sh[j] = 1.0 - 1.55 * i / max(m - 1, 1)  # front and back of the shaft out of phase
        elif s.role == "spindle":
            sh[j] = 0.1
        elif s.axis == "radial":
            sh[j] = 0.05
        else:
            sh[j] = 0.02
    add("spindle_first", 287.0, sh / math.sqrt(1.5))
    sh = np.array(
        [
            1.0 if (s.role, s.axis) == ("housing", "axial")
            else 0.3 if s.axis == "axial"
            else 0.05 * (-1.0) ** i if s.axis == "radial"
            else 0.05
            for s, (i, _) in zip(sensors, gi, strict=True)
        ]
    )
    add("housing_axial", 302.0, sh / math.sqrt(3.0))
    sh = np.array(
        [
            1.0 if (s.role, s.axis) == ("housing", "lateral")
            else 0.04 * (-1.0) ** i if s.axis == "radial"
            else 0.05
            for s, (i, _) in zip(sensors, gi, strict=True)
        ]
    )
    add("housing_lateral", _LATERAL_RATIO * f_H, sh / math.sqrt(2.8))
    for f in _FLEX_FREQS:
        # irregular shapes, effective masses 8-80 kg at the housing sensors; frame and housing
        # modes move the spindle less
        sh = rng.normal(0.0, 1.0, n) / np.sqrt(rng.uniform(8.0, 80.0, n))
        sh *= np.array([1.0 if s.role == "housing" else 0.3 for s in sensors])
        add("flexible", f, sh)
    sh = np.array(
        [
            1.0 if (s.role, s.axis) == ("spindle", "axial")
            else 0.2 if s.axis == "axial"
            else 0.03
            for s in sensors
        ]
    )
    add("spindle_axial", 1012.0, sh / math.sqrt(2.0))
    return modes


def _sensor_index(sensors: Sequence[Sensor], dof: DOF) -> int | None:
    for j, s in enumerate(sensors):
        if s.dof.same_axis(dof):
            return j
    return None


def _driving_point(modes: list[dict[str, Any]], j_dp: int) -> None:
    """Large effective masses at the radial driving point for the modes the model lacks.

    Flexible modes 60-200 kg (many times the housing mode's 2.64 kg; their summed
    static compliance then stays a few per cent of the bearing's); tilt modes 500 kg
    and the spindle's first mode ~600 kg (the shaker acts near the housing's centre line, so the
    tilt modes are weakly excited and their mass lines leave the driving-point FRF above 150 Hz
    close to the 3DOF model's, as the paper's Fig. 7 shows).
    """
    rng = np.random.default_rng(_SHAPE_SEED + 1)
    for m in modes:
        if m["kind"] == "flexible":
            m["shape"][j_dp] = rng.choice([-1.0, 1.0]) / math.sqrt(rng.uniform(60.0, 200.0))
        elif m["kind"] == "housing_tilt":
            m["shape"][j_dp] = 1.0 / math.sqrt(500.0)
        elif m["kind"] == "spindle_first":
            m["shape"][j_dp] = 1.0 / math.sqrt(600.0)


def _misalignment(points: Sequence[Sensor], std_deg: float) -> NDArray[np.float64]:
    """Per point: the two seeded tilt angles [rad] towards its transverse axes, shape (n, 2)."""
    rng = np.random.default_rng(_MOUNT_SEED)
    return cast("NDArray[np.float64]", np.deg2rad(std_deg) * rng.normal(size=(len(points), 2)))


def _askew(points: Sequence[Sensor], psi: NDArray[np.float64], tilt: NDArray[np.float64]) -> NDArray[np.float64]:
    """What misaligned sensors measure: ``cos`` of their own axis plus ``sin`` of the other two.

    The motion of a role (housing or spindle) along an axis is the mean of the mode shape over
    that role's sensors along that axis (none: no motion seen), shape (n_pts, n_modes).
    """
    axes = ("radial", "lateral", "axial")
    means: dict[tuple[str, str], NDArray[np.float64]] = {}
    for role in {p.role for p in points}:
        for ax in axes:
            rows = [j for j, p in enumerate(points) if (p.role, p.axis) == (role, ax)]
            means[(role, ax)] = psi[rows].mean(axis=0) if rows else np.zeros(psi.shape[1])
    out = np.empty_like(psi)
    for j, p in enumerate(points):
        a, b = tilt[j]
        others = [ax for ax in axes if ax != p.axis]
        out[j] = (
            math.cos(math.hypot(a, b)) * psi[j]
            + math.sin(a) * means[(p.role, others[0])]
            + math.sin(b) * means[(p.role, others[1])]
        )
    return out


def _radial_modes(
    model: RigModel, appendage: tuple[float, float] | None
) -> tuple[NDArray[np.float64], NDArray[np.float64], list[str]]:
    """Radial modes: natural frequencies [Hz], mass-normalised shapes over (x_H, x_S) and kinds.

    Without an appendage these are the 3DOF model's three modes. With one (mass ``m_a`` [kg] on a
    spring tuned to ``f_a`` [Hz] alone, attached to ``m_H``), the 4DOF problem is solved; the
    spindle mode is the one with the largest spindle kinetic energy, and of the two others above
    the frame mode the one with more housing energy is labelled the housing mode.
    """
    if appendage is None:
        phi = model.mode_shapes
        return np.asarray(model.natural_freq, dtype=np.float64), phi[[HOUSING, SPINDLE]], [
            "frame",
            "housing_radial",
            "spindle_bending",
        ]
    m_a, f_a = appendage
    k_a = m_a * (2.0 * math.pi * f_a) ** 2
    m3, k3 = model.mass_matrix(), model.stiffness_matrix()
    mm = np.zeros((4, 4))
    kk = np.zeros((4, 4))
    mm[:3, :3], kk[:3, :3] = m3, k3
    mm[3, 3] = m_a
    kk[HOUSING, HOUSING] += k_a
    kk[HOUSING, 3] = kk[3, HOUSING] = -k_a
    kk[3, 3] = k_a
    lam, vec = scipy.linalg.eigh(kk, mm)  # mass-normalised eigenvectors
    fn = np.sqrt(np.maximum(lam, 0.0)) / (2.0 * math.pi)
    kinds = ["frame", "", "", ""]
    rest = [1, 2, 3]
    e_s = [mm[SPINDLE, SPINDLE] * vec[SPINDLE, r] ** 2 for r in rest]
    i_s = rest.pop(int(np.argmax(e_s)))
    kinds[i_s] = "spindle_bending"
    e_h = [mm[HOUSING, HOUSING] * vec[HOUSING, r] ** 2 for r in rest]
    kinds[rest[int(np.argmax(e_h))]] = "housing_radial"
    kinds[rest[int(np.argmin(e_h))]] = "appendage"
    return fn, vec[[HOUSING, SPINDLE]], kinds


# ----------------------------------------------------------------------------- main
def simulate_measurement(
    rig: RigConfig,
    *,
    k_tb: float,
    freq: ArrayLike | None = None,
    noise: float = 0.01,
    seed: int = 0,
    speed_hz: float | None = None,
    speed_rpm: float | None = None,
    extra_modes: bool = True,
    references: Sequence[str] | None = None,
    damping: Mapping[str, float] | None = None,
    n_harmonics: int = 12,
    harmonic_level: float = 0.5,
    misalignment_deg: float = DEFAULT_MISALIGNMENT_DEG,
    appendage: tuple[float, float] | None = None,
) -> Simulation:
    """Synthetic FRFs of the rig with a bearing of stiffness ``k_tb``.

    Parameters
    ----------
    rig : RigConfig
        Rig file: model parameters (Table 1), sensors (role, axis) and references.
    k_tb : float
        True bearing stiffness [N/m], > 0; ``math.inf`` = a rigid steel disk (housing mode at
        ``k_TB+MS = k_MS``, ≈ 897 Hz with Table 1).
    freq : array_like, shape (n_freq,), optional
        Frequency lines [Hz]; default 0-2000 Hz every 0.5 Hz (4001 lines).
    noise : float, optional
        Relative complex noise level (std of ``|dH| / |H|``), default 0.01; 0 = exact.
    seed : int, optional
        Seed of the noise and of the harmonic lines' amplitudes and phases.
    speed_hz : float, optional
        Shaft speed [Hz] (rpm / 60); adds lines at ``k * speed_hz``, k = 1..n_harmonics.
    speed_rpm : float, optional
        The shaft speed in rpm, as the campaign file and the CLI take it (give one of the two;
        0 = not rotating).
    extra_modes : bool, optional
        Add the modes the 3DOF model lacks (default True).
    references : sequence of {'radial', 'axial'}, optional
        Which shakers drive the structure; 'axial' needs ``rig.axial``. Default: every reference
        of the rig file (radial, and axial when given), so that ``read_uff58(path, rig=rig)``
        finds all of them.
    damping : mapping, optional
        Damping ratio per mode kind, overriding :data:`DEFAULT_DAMPING`.
    n_harmonics : int, optional
        Number of shaft-speed harmonics (those above the last line are dropped).
    harmonic_level : float, optional
        Peak of the first harmonic line relative to the local FRF magnitude (decays as 1/sqrt(k)).
    misalignment_deg : float, optional
        Standard deviation [deg] of each sensor's seeded mounting tilt towards each transverse
        axis (default :data:`DEFAULT_MISALIGNMENT_DEG`; 0 = every sensor exactly along its axis).
        The shaker forces stay along their axes.
    appendage : (float, float), optional
        A small flexible part of the housing: its mass [kg] and its uncoupled natural frequency
        [Hz] (on a spring to ``m_H``). The housing mode then couples to it; the truth's ``k_TB``
        and ``f_H`` stay those of the bearing and the 3DOF model.

    Returns
    -------
    Simulation

    Raises
    ------
    ValueError
        For a non-positive stiffness, bad noise level, negative seed, unknown reference or mode
        kind.
    """
    k_tb = float(k_tb)
    if not k_tb > 0 or math.isnan(k_tb):
        raise ValueError(f"k_tb must be a positive stiffness [N/m] (inf = steel disk), got {k_tb!r}")
    if not (math.isfinite(noise) and noise >= 0):
        raise ValueError(f"noise must be a finite relative level >= 0, got {noise!r}")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be an integer >= 0, got {seed!r}")
    if speed_rpm is not None:
        if speed_hz is not None:
            raise ValueError("give the shaft speed once: speed_rpm or speed_hz, not both")
        if not (math.isfinite(speed_rpm) and speed_rpm >= 0):
            raise ValueError(f"speed_rpm must be a finite shaft speed >= 0 [rpm], got {speed_rpm!r}")
        speed_hz = speed_rpm / 60.0 if speed_rpm > 0 else None
    if speed_hz is not None and not (math.isfinite(speed_hz) and speed_hz > 0):
        raise ValueError(f"speed_hz must be a positive shaft speed [Hz], got {speed_hz!r}")
    damp = dict(DEFAULT_DAMPING)
    for k, v in (damping or {}).items():
        if k not in damp:
            raise ValueError(f"unknown mode kind {k!r} in damping; allowed: {', '.join(damp)}")
        damp[k] = float(v)
    if not (math.isfinite(misalignment_deg) and 0.0 <= misalignment_deg <= 20.0):
        raise ValueError(f"misalignment_deg must be within 0..20 degrees, got {misalignment_deg!r}")
    if appendage is not None:
        m_a, f_a = (float(x) for x in appendage)
        if not (m_a > 0 and math.isfinite(m_a) and f_a > 0 and math.isfinite(f_a)):
            raise ValueError(f"appendage must be (mass [kg] > 0, frequency [Hz] > 0), got {appendage!r}")
        appendage = (m_a, f_a)
    f = np.arange(0.0, 2000.0 + 0.25, 0.5) if freq is None else np.asarray(freq, dtype=np.float64)

    if references is None:
        references = ("radial",) if rig.axial is None else ("radial", "axial")
    refs: list[DOF] = []
    for r in references:
        if r == "radial":
            refs.append(rig.radial)
        elif r == "axial":
            if rig.axial is None:
                raise ValueError("references includes 'axial' but the rig file has no excitation.axial")
            refs.append(rig.axial)
        else:
            raise ValueError(f"references must be 'radial' and/or 'axial', got {r!r}")

    params = rig.model
    k_c = series_stiffness(k_tb, params.k_MS)
    model = RigModel(params, k_c)
    sensors = list(rig.sensors)
    # the radial driving point: a sensor at the reference DOF, else a virtual radial housing point
    points = list(sensors)
    ref_idx = []
    for d in refs:
        j = _sensor_index(sensors, d)
        if j is None:
            axis = "radial" if d == rig.radial else "axial"
            points.append(Sensor(d, "housing", axis))
            j = len(points) - 1
        ref_idx.append(j)
    n_pts = len(points)

    # --- radial modes (3DOF, or 4DOF with the appendage) at every point
    fn_r, phi, kinds = _radial_modes(model, appendage)
    shapes3 = np.zeros((n_pts, len(kinds)))
    for j, s in enumerate(points):
        row = phi[0] if s.role == "housing" else phi[1]
        shapes3[j] = row if s.axis == "radial" else _CROSS_AXIS * row
    z3 = np.array([damp[k] for k in kinds])
    fn_all = [*fn_r]
    z_all = [*z3]
    shapes_all = [shapes3[:, r] for r in range(len(kinds))]
    kinds = list(kinds)
    if extra_modes:
        extras = _extra_modes(points, model.housing_freq, damp)
        _driving_point(extras, ref_idx[0])
        for m in extras:
            fn_all.append(m["natural_freq"])
            z_all.append(m["damping_ratio"])
            shapes_all.append(m["shape"])
            kinds.append(m["kind"])
    fn = np.array(fn_all)
    zz = np.array(z_all)
    psi = np.array(shapes_all).T  # (n_pts, n_modes)
    out_idx = list(range(len(sensors)))
    tilt = _misalignment(points, misalignment_deg)
    psi_out = _askew(points, psi, tilt)[out_idx]  # what the (askew) sensors measure
    h = modal_frf(f, fn, psi_out, psi[ref_idx], zz, frf_form="accelerance")

    rng = np.random.default_rng(seed)
    harmonics: list[dict[str, Any]] = []
    if speed_hz is not None:
        w = 2.0 * np.pi * f
        zh = damp["harmonic"]
        for order in range(1, int(n_harmonics) + 1):
            fk = order * speed_hz
            if fk >= f[-1]:
                break
            wk = 2.0 * np.pi * fk
            line = 2j * zh * wk * w / (wk**2 - w**2 + 2j * zh * wk * w)  # peak 1 at fk
            local = np.abs(modal_frf([fk], fn, psi_out, psi[ref_idx], zz, frf_form="accelerance")[:, :, 0])
            amp = harmonic_level / math.sqrt(order) * rng.uniform(0.3, 1.0, local.shape)
            phase = np.exp(2j * np.pi * rng.uniform(size=local.shape))
            h = h + (amp * local * phase)[:, :, None] * line[None, None, :]
            harmonics.append({"kind": "harmonic", "natural_freq": fk, "damping_ratio": zh, "order": order})

    if noise > 0:
        shape = h.shape
        n1 = (rng.normal(size=shape) + 1j * rng.normal(size=shape)) / math.sqrt(2.0)
        n2 = (rng.normal(size=shape) + 1j * rng.normal(size=shape)) / math.sqrt(2.0)
        rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=2, keepdims=True))
        # relative noise plus a small floor (1/20 of the level times the channel RMS)
        h = h + noise * (np.abs(h) * n1 + 0.05 * rms * n2)
        if f[0] == 0.0:
            h[:, :, 0] = 0.0  # accelerance is exactly 0 at 0 Hz

    data = FRFData(
        f,
        h,
        tuple(s.dof.positive() for s in sensors),
        tuple(d.positive() for d in refs),
        frf_form="accelerance",
        roles=tuple(s.role for s in sensors),
        axes=tuple(s.axis for s in sensors),
        meta={"source": "ema_rig.simulate", "k_TB": k_tb, "seed": seed, "noise": noise},
    )
    j_dp = ref_idx[0]
    mode_list: list[dict[str, Any]] = []
    for im, kind in enumerate(kinds):
        p = psi[j_dp, im]
        mode_list.append(
            {
                "kind": kind,
                "natural_freq": float(fn[im]),
                "damping_ratio": float(zz[im]),
                "effective_mass_dp": float(1.0 / p**2) if p != 0 else math.inf,
            }
        )
    mode_list += harmonics
    mode_list.sort(key=lambda m: m["natural_freq"])
    truth = {
        "k_TB": k_tb,  # inf (rigid disk) is written as null in JSON; see "rigid_disk"
        "rigid_disk": math.isinf(k_tb),
        "k_MS": params.k_MS,
        "k_TB_MS": k_c,
        "f_H": model.housing_freq,
        "f_spindle": model.spindle_freq,
        "housing_damping": float(damp["housing_radial"]),
        "housing_effective_mass": model.effective_mass(),
        "natural_freq_3dof": [float(x) for x in model.natural_freq],
        "speed_hz": speed_hz,
        "noise": float(noise),
        "seed": int(seed),
        "extra_modes": bool(extra_modes),
        "misalignment_deg": [[round(float(x), 6) for x in np.rad2deg(t)] for t in tilt[: len(sensors)]],
        "appendage": None if appendage is None else {"mass": appendage[0], "freq": appendage[1]},
        "references": [str(d) for d in refs],
        "model": params.as_dict(),
        "modes": mode_list,
    }
    return Simulation(data=data, truth=MappingProxyType(truth))


def truth_path(path: str | PathLike[str]) -> Path:
    """The truth file of a measurement: ``<file>.truth.json`` beside it (``m.uff.truth.json``).

    Parameters
    ----------
    path : str or path-like
        The measurement file.

    Returns
    -------
    Path
    """
    p = Path(path)
    return p.with_name(p.name + ".truth.json")


def planted_k_tb(path: str | PathLike[str]) -> float | None:
    """The bearing stiffness [N/m] planted in a simulated measurement, from its truth file.

    Parameters
    ----------
    path : str or path-like
        A measurement file; its truth is ``<file>.truth.json`` beside it (:func:`truth_path`).

    Returns
    -------
    float or None
        ``k_TB`` of the truth (inf for the rigid disk); None when there is no truth file (a real
        measurement).

    Raises
    ------
    ValueError
        When a truth file exists but is not a JSON object with a numeric ``k_TB`` (or null for the
        disk), naming the file.
    """
    tp = truth_path(path)
    if not tp.is_file():
        return None
    try:
        doc = json.loads(tp.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ValueError(f"{tp}: unreadable truth file ({exc})") from exc
    k = doc.get("k_TB", "missing") if isinstance(doc, dict) else "missing"
    if k is None:
        return math.inf
    if isinstance(k, bool) or not isinstance(k, (int, float)):
        raise ValueError(f"{tp}: truth file without a numeric k_TB")
    return float(k)


def write_measurement(
    sim: Simulation,
    path: str | PathLike[str],
    *,
    binary: bool = False,
    accel_unit: str = "m/s^2",
    rig: RigConfig | None = None,
    double: bool = True,
) -> Path:
    """Write a simulation as UFF58 and its truth as ``<file>.truth.json`` (both atomically).

    Parameters
    ----------
    sim : Simulation
    path : str or path-like
        UFF file to write.
    binary : bool, optional
        58b binary instead of ASCII.
    accel_unit : {'m/s^2', 'g'}, optional
        Unit of the written accelerations.
    rig : RigConfig, optional
        With a rig, sensors mounted along a negative axis (``13-Y``) are written with their signed
        DOF and flipped values, as a real acquisition would record them.
    double : bool, optional
        Double precision (default); False writes single precision (smaller files).

    Returns
    -------
    Path
        The UFF file written.
    """
    p = Path(path)
    write_uff58(p, sim.data, binary=binary, double=double, accel_unit=accel_unit, rig=rig)
    truth = sim.truth_dict()
    truth.update({"file": p.name, "binary": bool(binary), "accel_unit": accel_unit, "double": bool(double)})
    try:
        _atomic.write_json(truth_path(p), truth)
    except BaseException:
        p.unlink(missing_ok=True)  # a measurement without its truth (or with an old one) is worse than none
        raise
    return p


__all__ = ["DEFAULT_DAMPING", "DEFAULT_MISALIGNMENT_DEG", "Simulation", "planted_k_tb", "simulate_measurement", "truth_path", "write_measurement"]
