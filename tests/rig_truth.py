"""Independent rig truths for the k_TB tests: the paper's radial dynamics solved directly.

Nothing here imports ema_rig: the mass and stiffness matrices are written out below, the FRFs
come from a direct solve of ``(K - w^2 M + j w C)^-1`` (or ``K (1 + j eta)`` for hysteretic
damping) at every line, and the measurement is written to UFF58 by pyuff and read back by the
code under test.

Beyond the paper's model the truth can hold: a bearing cross stiffness coupling the housing's
radial deflection to its axial or lateral rigid-body motion (``cross_axis``, ``cross_leak``),
accelerometer masses at the sensor positions (``sensor_mass``, declared in the rig file or not),
a rig file whose ``m_H`` is off (``file_m_H_factor``), an appendage, flexible frame and housing
modes anywhere, and the bearing's own damping (``damping='bearing_viscous'``: a dashpot ``c_TB``
in parallel with ``k_TB``; ``'bearing_hysteretic'``: ``k_TB (1 + j eta_TB)``; both in series with
``k_MS``, everything else in the radial chain undamped but a 5 % bushing dashpot).

Generalised coordinates (SI, metres / radians)::

    0 y_H    housing radial translation (main body, m_H - m_a)
    1 x_S    spindle radial (m_S)               } the paper's 3DOF radial model:
    2 x_F    frame (m_F)                        } k_B, k_AS, k_S, k_TB+MS (Fig. 6)
    3 th_X   housing tilt about the shaft axis  (moves radial sensors with their lateral offset)
    4 th_Z   housing tilt about the lateral axis (moves radial sensors with their axial offset)
    5 z_H    housing lateral translation
    6 x_H    housing axial translation
    7 s_1    spindle first bending mode (287 Hz)
    8 q_fh   flexible housing mode (695 Hz)
    9 q_ff   flexible frame mode (663 Hz)
    10 q_ov  housing ovalisation (867 Hz): the driving point against the other two radial sensors
    11 y_a   optional appendage on the housing (a load arm), on a spring to y_H

The housing is a rigid body for coordinates 0 and 3-6; each accelerometer reads its point's
motion along its own, slightly misaligned, direction. The radial shaker pushes at the driving
point along its sensor's direction (reciprocity: the force column is the driving-point row of
the observation matrix), so every participation is physically consistent.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

G = 9.80665

# paper Table 1
TABLE1 = {"m_H": 2.566, "m_S": 2.8, "m_F": 205.0, "k_MS": 114e6, "k_AS": 650e3, "k_S": 348e6, "k_B": 180e3}

OUT = ("11+Y", "12+Y", "13+Y", "14+Z", "15+X", "21+Y", "22+Y", "23+X")
"""Outputs, sign-corrected (the rig file mounts 13 along -Y; write_uff58(rig=...) handles it)."""

# sensor positions on the housing relative to its centre of mass [m] (x axial, y radial, z lateral)
_POS = {
    "11+Y": (0.004, 0.045, 0.008),
    "12+Y": (0.020, 0.045, 0.040),
    "13+Y": (-0.020, 0.045, -0.040),
    "14+Z": (0.0, 0.0, 0.05),
    "15+X": (0.03, 0.02, 0.0),
}
_AXIS = {"X": np.array([1.0, 0.0, 0.0]), "Y": np.array([0.0, 1.0, 0.0]), "Z": np.array([0.0, 0.0, 1.0])}

# flexible-mode patterns along each sensor's axis (housing 11..15, spindle 21, 22, 23)
_FLEX_HOUSING = np.array([1.0, -0.6, 0.3, 0.8, 0.2, 0.05, 0.05, 0.02])
_FLEX_FRAME = np.array([0.3, 0.3, 0.3, 0.1, 0.1, 0.2, 0.2, 0.05])
_OVAL = np.array([-1.0, 1.0, 1.0, 0.1, 0.0, 0.0, 0.0, 0.0])
_SPINDLE1 = np.array([0.02, 0.02, 0.02, 0.0, 0.0, 1.0, 0.8, 0.05])


@dataclass
class RigTruth:
    """Everything that defines one synthetic measurement (defaults: the paper's rig at 626 Hz).

    Frequencies in Hz, masses in kg, stiffnesses in N/m; ``zeta`` is the modal damping ratio of
    every mode (viscous, per mode), ``eta`` a loss factor for ``damping='hysteretic'``.
    """

    k_TB: float = 71.57e6
    params: dict[str, float] = field(default_factory=lambda: dict(TABLE1))
    tilt_x_freq: float = 118.0
    tilt_z_freq: float = 141.0
    lateral_freq: float = 410.0
    axial_freq: float = 301.0
    spindle1_freq: float = 287.0
    flex_housing_freq: float = 695.0
    flex_frame_freq: float = 663.0
    oval_freq: float = 867.0
    tilt_inertia_radius: float = 0.03
    flex_housing_mass: float = 30.0  # effective mass at the driving point
    flex_frame_mass: float = 2.7  # generalised (pattern 0.3 at the driving point: ~30 kg there)
    oval_mass: float = 25.0
    appendage_fraction: float = 0.0  # of m_H
    appendage_freq: float = 695.0
    zeta: float = 0.02
    damping: str = "modal"  # 'modal' | 'hysteretic' | 'dashpot' (modal + a bearing dashpot)
    dashpot_zeta: float = 0.0  # extra ζ of the housing mode from the bearing dashpot
    misalign_deg: float = 2.0
    seed: int = 0
    cross_axis: str = ""  # '' | 'axial' | 'lateral': bearing cross stiffness to that housing motion
    cross_leak: float = 0.0  # share of the housing mode's kinetic energy in the partner coordinate
    sensor_mass: float = 0.0  # kg on each of the five housing sensors, at its position
    declare_sensor_masses: bool = True  # the rig file lists them
    file_m_H_factor: float = 1.0  # the rig file's m_H / the truth's
    file_force_chain: float | None = None  # [uncertainty] force_chain in the rig file (None: absent)
    c_TB: float = 0.0  # N s/m, damping='bearing_viscous'
    eta_TB: float = 0.0  # loss factor, damping='bearing_hysteretic'
    # bearing-damped truths: stiffness-proportional damping beta K0 of the structure (every spring but
    # the bearing element), beta = 2 structural_zeta / (2 pi 600 Hz): zeta at 600 Hz of a mode of K0
    structural_zeta: float = 0.0

    @property
    def k_TB_MS(self) -> float:
        return 1.0 / (1.0 / self.k_TB + 1.0 / self.params["k_MS"])

    def sensor_positions(self) -> dict[str, tuple[float, float, float]]:
        """Housing sensor positions [m] from the housing's centre of mass (x axial, y radial, z lateral)."""
        return _POS

    def rig_file_text(self, params: dict[str, float], drop: tuple[str, ...]) -> str:
        """The rig file of this truth (:func:`rig_text` with its declared sensor masses and force chain)."""
        return rig_text(params, drop=drop, sensor_mass=self.sensor_mass if self.declare_sensor_masses else 0.0,
                        force_chain=self.file_force_chain)

    def matrices(self, k_bearing: float | None = None) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Mass and stiffness matrices (12 x 12; coordinate 11 inert without an appendage).

        ``k_bearing`` replaces ``k_TB+MS`` between y_H and x_S (0: the matrix without it).
        """
        p = self.params
        m_a = self.appendage_fraction * p["m_H"]
        n = 12
        m = np.zeros((n, n))
        k = np.zeros((n, n))
        m[0, 0] = p["m_H"] - m_a
        m[1, 1] = p["m_S"]
        m[2, 2] = p["m_F"]
        kt = self.k_TB_MS if k_bearing is None else k_bearing
        # ground -k_B- F ; F -k_AS- H ; F -k_S- S ; S -k_TB+MS- H
        for i, j, kk in ((0, 2, p["k_AS"]), (1, 2, p["k_S"]), (0, 1, kt)):
            k[i, i] += kk
            k[j, j] += kk
            k[i, j] -= kk
            k[j, i] -= kk
        k[2, 2] += p["k_B"]
        inertia = p["m_H"] * self.tilt_inertia_radius**2
        extra = {
            3: (inertia, self.tilt_x_freq),
            4: (inertia, self.tilt_z_freq),
            5: (p["m_H"], self.lateral_freq),
            6: (p["m_H"], self.axial_freq),
            7: (1.0, self.spindle1_freq),
            8: (self.flex_housing_mass, self.flex_housing_freq),
            9: (self.flex_frame_mass, self.flex_frame_freq),
            10: (self.oval_mass, self.oval_freq),
        }
        for i, (mi, fi) in extra.items():
            m[i, i] = mi
            k[i, i] = mi * (2 * math.pi * fi) ** 2
        if m_a > 0:
            ka = m_a * (2 * math.pi * self.appendage_freq) ** 2
            m[11, 11] = m_a
            k[0, 0] += ka
            k[11, 11] += ka
            k[0, 11] -= ka
            k[11, 0] -= ka
        else:
            m[11, 11], k[11, 11] = 1.0, 1.0  # inert, unobserved, unforced
        if self.sensor_mass > 0:  # point masses on the rigid housing: M += m T^T T
            for r in self.sensor_positions().values():
                t = _rigid_point(r)
                m += self.sensor_mass * t.T @ t
        if self.cross_axis:
            k += self._cross_k() * _cross_pattern(self.cross_axis)
        return m, k

    def _cross_k(self) -> float:
        """Cross stiffness [N/m] giving the housing mode ``cross_leak`` of its energy in the partner."""
        if not self.cross_leak > 0:
            return 0.0
        from scipy.optimize import brentq

        pat = _cross_pattern(self.cross_axis)
        trial = replace(self, cross_axis="")
        m, k0 = trial.matrices()

        def leak(kc: float) -> float:
            lam, phi = _eigh(k0 + kc * pat, m)
            h = _housing_index(lam, phi, m)
            i = 6 if self.cross_axis == "axial" else 5
            return float(m[i, i] * phi[i, h] ** 2) - self.cross_leak

        hi = 0.3 * self.k_TB_MS
        return float(brentq(leak, 0.0, hi, xtol=1.0))

    def observation(self) -> NDArray[np.float64]:
        """Sensor readings per coordinate, shape (8, 12), misaligned directions."""
        rng = np.random.default_rng(1000 + self.seed)
        c = np.zeros((len(OUT), 12))
        pos = self.sensor_positions()
        for s, name in enumerate(OUT):
            nominal = _AXIS[name[-1]]
            a = np.deg2rad(self.misalign_deg) * rng.standard_normal(2)
            others = [v for v in _AXIS.values() if not np.array_equal(v, nominal)]
            d = nominal + a[0] * others[0] + a[1] * others[1]
            d /= np.linalg.norm(d)
            if name in pos:
                rx, ry, rz = pos[name]
                # rigid housing: u = [x_H, y_H, z_H] + th x r, th = (th_X, 0, th_Z)
                c[s, 0] = d[1]  # y_H
                c[s, 6] = d[0]  # x_H
                c[s, 5] = d[2]  # z_H
                c[s, 3] = d[1] * (-rz) + d[2] * ry  # th_X
                c[s, 4] = d[0] * (-ry) + d[1] * rx  # th_Z
            else:  # spindle sensors: radial spindle motion x_S along Y, frame motion negligible
                c[s, 1] = d[1]
            c[s, 7] = _SPINDLE1[s]
            c[s, 8] = _FLEX_HOUSING[s]
            c[s, 9] = _FLEX_FRAME[s]
            c[s, 10] = _OVAL[s]
        return c

    def housing_freq(self) -> float:
        """Undamped natural frequency [Hz] of the housing's radial mode of this truth."""
        m, k = self.matrices()
        lam, phi = _eigh(k, m)
        return float(math.sqrt(lam[_housing_index(lam, phi, m)]) / (2 * math.pi))

    def bearing_impedance(self, om: float) -> complex:
        """Bearing (with its dashpot or loss) in series with k_MS [N/m] at ``om`` rad/s."""
        kms = self.params["k_MS"]
        if self.damping == "bearing_viscous":
            z = self.k_TB + 1j * om * self.c_TB
        elif self.damping == "bearing_hysteretic":
            z = self.k_TB * (1 + 1j * self.eta_TB)
        else:
            return complex(self.k_TB_MS)
        return complex(1.0 / (1.0 / z + 1.0 / kms))

    def frf(self, freq: NDArray[np.float64]) -> NDArray[np.complex128]:
        """Accelerance [m/s^2/N] of every sensor for the radial shaker, shape (8, n_freq)."""
        if self.damping in ("bearing_viscous", "bearing_hysteretic"):
            return self._frf_bearing(freq)
        m, k = self.matrices()
        c_obs = self.observation()
        b = c_obs[0]  # force along the driving-point sensor's direction, at its point
        # modal damping matrix with exactly zeta per mode: C = M Phi diag(2 zeta w) Phi^T M
        lam, phi = _eigh(k, m)
        w = np.sqrt(np.clip(lam, 0.0, None))
        damp = m @ phi @ np.diag(2 * self.zeta * w) @ phi.T @ m
        stiff = k.astype(complex)
        if self.damping == "hysteretic":
            eta = math.tan(2 * math.asin(self.zeta))  # zeta = sin(atan(eta) / 2)
            stiff = k * (1 + 1j * eta)
            damp = np.zeros_like(m)
        elif self.damping == "dashpot":
            # a dashpot across the bearing (y_H - x_S), sized for dashpot_zeta on a lone housing
            cb = 2 * self.dashpot_zeta * math.sqrt(self.k_TB_MS * self.params["m_H"])
            e = np.zeros(12)
            e[0], e[1] = 1.0, -1.0
            damp = damp + cb * np.outer(e, e)
        elif self.damping != "modal":
            raise ValueError(self.damping)
        out = np.empty((len(OUT), freq.size), complex)
        for i, f in enumerate(freq):
            om = 2 * math.pi * f
            x = np.linalg.solve(stiff - om**2 * m + 1j * om * damp, b)
            out[:, i] = -(om**2) * (c_obs @ x)
        return out


    def bearing_truth_damping(self) -> NDArray[np.float64]:
        """Damping matrix [N s/m] of a bearing-damped truth without the bearing element: a dashpot to
        ground with ``zeta`` on every coordinate but the radial chain's, 5 % on the bushings, and
        ``structural_zeta`` stiffness-proportional on the structure."""
        m, k0 = self.matrices(k_bearing=0.0)
        damp = np.zeros_like(m)
        for i in range(3, 12):
            damp[i, i] = 2 * self.zeta * math.sqrt(k0[i, i] * m[i, i]) if k0[i, i] > 0 else 0.0
        damp[2, 2] += 2 * 0.05 * math.sqrt(self.params["k_B"] * self.params["m_F"])
        return damp + 2 * self.structural_zeta / (2 * math.pi * 600.0) * k0

    def _frf_bearing(self, freq: NDArray[np.float64]) -> NDArray[np.complex128]:
        """Only the bearing damps the radial chain (plus a 5 % dashpot on the bushings and the
        structure's ``structural_zeta``); every other coordinate has its own dashpot to ground with
        ``zeta`` at its own frequency (:meth:`bearing_truth_damping`)."""
        m, k0 = self.matrices(k_bearing=0.0)
        c_obs = self.observation()
        b = c_obs[0]
        damp = self.bearing_truth_damping()
        e = np.zeros(12)
        e[0], e[1] = 1.0, -1.0
        out = np.empty((len(OUT), freq.size), complex)
        for i, f in enumerate(freq):
            om = 2 * math.pi * f
            a = k0 + self.bearing_impedance(om) * np.outer(e, e) - om**2 * m + 1j * om * damp
            out[:, i] = -(om**2) * (c_obs @ np.linalg.solve(a, b))
        return out

    def housing_pole(self) -> complex:
        """The housing mode's complex eigenvalue [rad/s] of a bearing-damped truth, by a Newton
        iteration on ``det(K(s) + s C + s^2 M)`` started at the undamped mode (oracle for c_TB)."""
        m, k = self.matrices()
        lam, phi = _eigh(k, m)
        h = _housing_index(lam, phi, m)
        m0, k0 = self.matrices(k_bearing=0.0)
        damp = self.bearing_truth_damping()
        e = np.zeros(12)
        e[0], e[1] = 1.0, -1.0

        def smallest(s: complex) -> complex:
            # the bearing impedance as a function of s (om = s / j)
            a = k0 + self.bearing_impedance(complex(s / 1j)) * np.outer(e, e) + s * damp + s * s * m0  # type: ignore[arg-type]
            ev = np.linalg.eigvals(np.linalg.solve(m0, a))
            return complex(ev[np.argmin(np.abs(ev))])

        s = 1j * math.sqrt(lam[h])
        for _ in range(50):  # secant on the eigenvalue of the pencil closest to zero
            d = 1e-6 * abs(s)
            f0, f1 = smallest(s), smallest(s + d)
            step = f0 * d / (f1 - f0)
            s = s - step
            if abs(step) < 1e-12 * abs(s):
                break
        return complex(s)


# issue 19 (tilt): the three radial housing sensors off any line through the centre (their (x, z)
# offsets span both tilts) and a driving point off the centre in x and z (it excites both tilts)
_POS_TILT = {
    "11+Y": (0.010, 0.045, 0.015),
    "12+Y": (0.030, 0.045, -0.035),
    "13+Y": (-0.025, 0.045, -0.030),
    "14+Z": (0.0, 0.0, 0.05),
    "15+X": (0.03, 0.02, 0.0),
}


@dataclass
class TiltRigTruth(RigTruth):
    """A rig whose housing sensors see both tilts, with the tilt modes inside the analysis band.

    The physics is :class:`RigTruth`'s (same coordinates, matrices and FRFs); only the housing
    sensors sit elsewhere (:data:`_POS_TILT`: the radial ones not on one line through the centre)
    and the tilt modes lie at 170-270 Hz instead of below 150 Hz. The rig file states every housing
    sensor's position and the housing's rotary inertia ``m_H r^2`` about x and z (``[housing]``)
    with the relative tolerance ``inertia_rel_std`` (the truth's inertia is exact).
    """

    tilt_x_freq: float = 190.0
    tilt_z_freq: float = 245.0
    inertia_rel_std: float = 0.03

    def sensor_positions(self) -> dict[str, tuple[float, float, float]]:
        """Housing sensor positions [m] (:data:`_POS_TILT`)."""
        return _POS_TILT

    def rotary_inertia(self) -> float:
        """The bare housing's rotary inertia about x and about z [kg m^2] (the same for both)."""
        return self.params["m_H"] * self.tilt_inertia_radius**2

    def tilt_stiffness(self) -> tuple[float, float]:
        """The truth's tilt stiffness about x and about z [N m/rad]: the diagonal of ``K`` for th_X, th_Z."""
        i0 = self.rotary_inertia()
        return i0 * (2 * math.pi * self.tilt_x_freq) ** 2, i0 * (2 * math.pi * self.tilt_z_freq) ** 2

    def rig_file_text(self, params: dict[str, float], drop: tuple[str, ...]) -> str:
        """The rig file: every housing sensor's position and the ``[housing]`` rotary inertia."""
        i0 = self.rotary_inertia()
        u = self.inertia_rel_std * i0
        return rig_text(params, drop=drop, sensor_mass=self.sensor_mass if self.declare_sensor_masses else 0.0,
                        force_chain=self.file_force_chain, positions=_POS_TILT, inertia=(i0, u, i0, u))


def _rigid_point(r: tuple[float, float, float]) -> NDArray[np.float64]:
    """Displacement (x, y, z) of a point at ``r`` on the rigid housing per coordinate, shape (3, 12)."""
    rx, ry, rz = r
    t = np.zeros((3, 12))
    t[0, 6], t[0, 4] = 1.0, -ry
    t[1, 0], t[1, 4], t[1, 3] = 1.0, rx, -rz
    t[2, 5], t[2, 3] = 1.0, ry
    return t


def _cross_pattern(axis: str) -> NDArray[np.float64]:
    """Unit bearing cross stiffness between the radial deflection (y_H - x_S) and the housing's
    axial (x_H) or lateral (z_H) translation, shape (12, 12)."""
    if axis not in ("axial", "lateral"):
        raise ValueError(f"cross_axis must be 'axial' or 'lateral', got {axis!r}")
    er = np.zeros(12)
    er[0], er[1] = 1.0, -1.0
    ep = np.zeros(12)
    ep[6 if axis == "axial" else 5] = 1.0
    return np.outer(er, ep) + np.outer(ep, er)


def _housing_index(lam: NDArray[np.float64], phi: NDArray[np.float64], m: NDArray[np.float64]) -> int:
    """The mode with most kinetic energy in the housing's radial translation (y_H), 150-1300 Hz."""
    f = np.sqrt(np.clip(lam, 0, None)) / (2 * math.pi)
    share = m[0, 0] * phi[0] ** 2
    share = np.where((f > 150) & (f < 1300), share, -1.0)
    return int(np.argmax(share))


def _eigh(k: NDArray[np.float64], m: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Generalised symmetric eigenproblem by Cholesky (M = L L^T), mass-normalised vectors."""
    l_ = np.linalg.cholesky(m)
    li = np.linalg.inv(l_)
    lam, v = np.linalg.eigh(li @ k @ li.T)
    return lam, li.T @ v


def hann_leaked_frf(truth: RigTruth, freq: NDArray[np.float64], sub: int = 16, half: int = 8) -> NDArray[np.complex128]:
    """Expected H1 of a Hann-windowed random test with records of ``1 / df`` s, shape (8, n_freq).

    With white excitation the cross- and auto-spectra are the true ones averaged over the window's
    spectral power ``|W(f - nu)|^2`` (Bendat & Piersol, *Random Data*, 4th ed. 2010, ch. 8:
    resolution bias), so ``H1(f) = sum_nu H(nu) |W(f - nu)|^2 / sum_nu |W(f - nu)|^2``. ``W`` is the
    Hann window's spectrum, ``sinc(x) + (sinc(x - 1) + sinc(x + 1)) / 2`` with ``x`` in lines, on a
    grid of ``df / sub`` over ``+-half`` lines; ``H(-nu) = conj H(nu)``. ``freq`` uniform from 0."""
    df = float(freq[1] - freq[0])
    nu = np.arange(-half * sub, (freq.size - 1) * sub + half * sub + 1) * (df / sub)
    h_pos = truth.frf(np.abs(nu))
    h_fine = np.where(nu < 0, np.conj(h_pos), h_pos)
    x = np.arange(-half * sub, half * sub + 1) / sub
    w = np.sinc(x) + 0.5 * np.sinc(x - 1) + 0.5 * np.sinc(x + 1)
    w2 = w**2 / (w**2).sum()
    out = np.empty((h_fine.shape[0], freq.size), dtype=complex)
    for i in range(freq.size):
        out[:, i] = h_fine[:, i * sub: i * sub + x.size] @ w2
    return out


@dataclass(frozen=True)
class Measurement:
    """Noisy accelerance of the kept sensors for the radial shaker (no ema_rig types).

    ``frf`` shape (n_out, n_freq) [m/s^2/N] along each sensor's positive axis; ``out`` the DOF
    names (``OUT`` order minus the dropped ones)."""

    freq: NDArray[np.float64]
    frf: NDArray[np.complex128]
    out: tuple[str, ...]


def measurement(
    truth: RigTruth,
    freq: NDArray[np.float64],
    *,
    noise: float = 0.02,
    floor: float = 1e-4,
    drop: tuple[str, ...] = (),
    flip: tuple[str, ...] = (),
    scale: float = 1.0,
    hann: bool = False,
) -> Measurement:
    """Noisy FRFs (outputs in :data:`OUT` order minus ``drop``; one reference 11+Y).

    ``noise`` is the relative std of complex Gaussian noise on each line, ``floor`` an additive
    floor relative to the median magnitude of the channel; ``flip`` reverses the sign of sensors
    (a wrongly mounted or wired accelerometer) and ``scale`` multiplies every value (1 / g: a file
    in g read as m/s^2); ``hann`` gives the lines of a Hann-windowed random test (leakage,
    :func:`hann_leaked_frf`) instead of the exact FRF.
    """
    rng = np.random.default_rng(truth.seed)
    h = hann_leaked_frf(truth, freq) if hann else truth.frf(freq)
    mag = np.abs(h)
    floor_abs = floor * np.median(mag, axis=1, keepdims=True)
    sd = noise * mag + floor_abs
    h = h + sd * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / math.sqrt(2)
    keep = [i for i, d in enumerate(OUT) if d not in drop]
    for d in flip:
        h[OUT.index(d)] *= -1.0
    return Measurement(freq.astype(np.float64), scale * h[keep], tuple(OUT[i] for i in keep))


RIG_TOML = """
[model]
m_H = {m_H!r}
m_S = {m_S!r}
m_F = {m_F!r}
k_MS = {k_MS!r}
k_AS = {k_AS!r}
k_S = {k_S!r}
k_B = {k_B!r}

[excitation]
radial = "11+Y"

[uncertainty]
m_H = 0.005
m_S = 0.02
m_F = 0.05
k_MS = 0.02
k_AS = 0.10
k_S = 0.02
k_B = 0.10
"""

_SENSORS = (("11+Y", "housing", "radial"), ("12+Y", "housing", "radial"), ("13-Y", "housing", "radial"),
            ("14+Z", "housing", "lateral"), ("15+X", "housing", "axial"), ("21+Y", "spindle", "radial"),
            ("22+Y", "spindle", "radial"), ("23+X", "spindle", "axial"))


def rig_text(params: dict[str, float] | None = None, *, drop: tuple[str, ...] = (),
             sensor_mass: float = 0.0, force_chain: float | None = None,
             positions: dict[str, tuple[float, float, float]] | None = None,
             inertia: tuple[float, float, float, float] | None = None) -> str:
    """Rig file (TOML) for the truth's nominal parameters, without the sensors in ``drop``;
    ``sensor_mass`` [kg] declared on each housing sensor, with its position; ``force_chain`` the
    stated relative std of the FRF scale (the truth's scale is exact); ``positions`` (default the
    paper-like :data:`_POS`, written only with a sensor mass) written for every housing sensor when
    given; ``inertia`` = ``(I_x, I_x_std, I_z, I_z_std)`` [kg m^2] the ``[housing]`` rotary inertia."""
    text = RIG_TOML.format(**(params or TABLE1))
    if force_chain is not None:
        text += f"force_chain = {force_chain!r}\n"
    if inertia is not None:
        text += (f"\n[housing]\ninertia_x = {inertia[0]!r}\ninertia_x_std = {inertia[1]!r}\n"
                 f"inertia_z = {inertia[2]!r}\ninertia_z_std = {inertia[3]!r}\n")
    for dof, role, axis in _SENSORS:
        if dof.replace("-", "+") in drop:
            continue
        text += f'\n[[sensor]]\ndof = "{dof}"\nrole = "{role}"\naxis = "{axis}"\n'
        pos = (positions or _POS).get(dof.replace("-", "+"))
        if sensor_mass > 0 and pos is not None:
            text += f"mass = {sensor_mass!r}\n"
        if pos is not None and (sensor_mass > 0 or positions is not None):
            text += f"position = [{pos[0]!r}, {pos[1]!r}, {pos[2]!r}]\n"
    return text


_DIR = {"X": 1, "Y": 2, "Z": 3}


def write_uff(path: Path, meas: Measurement, *, binary: bool = False) -> Path:
    """UFF58 of ``meas`` written by pyuff (sensor 13 as mounted, along -Y).

    ASCII by default: pyuff 2.5.8 loses the first 58b set in 'overwrite' mode and leaves its file
    handles open in 'add' mode."""
    import contextlib
    import io
    import warnings

    import pyuff

    sets = []
    for name, h in zip(meas.out, meas.frf, strict=True):
        node, axis = int(name[:-2]), name[-1]
        sign = -1 if name == "13+Y" else 1  # the rig file mounts 13 along -Y
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            sets.append(pyuff.prepare_58(
                binary=int(binary), func_type=4, rsp_node=node, rsp_dir=sign * _DIR[axis], ref_node=11,
                ref_dir=2, ord_data_type=6, abscissa_spacing=1, abscissa_spec_data_type=18,
                abscissa_axis_units_lab="Hz", ordinate_spec_data_type=12, ordinate_axis_units_lab="m/s^2",
                orddenom_spec_data_type=13, orddenom_axis_units_lab="N", data=sign * h, x=meas.freq,
                id1="rig_truth", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
            ))
    with contextlib.redirect_stdout(io.StringIO()):
        pyuff.UFF(str(path)).write_sets(sets, mode="overwrite")
    return path


def tighten_tolerances(rig_path: Path, tol: float = 1e-4) -> None:
    """Set every ``[uncertainty]`` tolerance of the rig file at ``rig_path`` to ``tol``: what is left of
    sigma is what the data carry (the studies' class "rig tolerances 1e-4")."""
    text = rig_path.read_text()
    head, _, tail = text.partition("[uncertainty]\n")
    body, sep, rest = tail.partition("\n\n")
    body = "\n".join(f"{line.split('=')[0].strip()} = {tol}" for line in body.splitlines() if "=" in line)
    rig_path.write_text(head + "[uncertainty]\n" + body + "\n" + sep + rest)


def write_case(tmp: Path, name: str, truth: RigTruth, freq: NDArray[np.float64], **kw: object) -> tuple[Path, Path]:
    """Write ``name.uff`` and ``name.toml`` (the rig file) into ``tmp``; return both paths.

    The rig file holds the nominal parameters with ``m_H`` scaled by ``truth.file_m_H_factor``
    and, when ``truth.declare_sensor_masses``, the sensor masses with their positions."""
    drop = tuple(kw.get("drop", ()))  # type: ignore[arg-type]
    params = dict(truth.params)
    params["m_H"] = params["m_H"] * truth.file_m_H_factor
    rig_path = tmp / f"{name}.toml"
    rig_path.write_text(truth.rig_file_text(params, drop), encoding="utf-8")
    uff = write_uff(tmp / f"{name}.uff", measurement(truth, freq, **kw))  # type: ignore[arg-type]
    return uff, rig_path
