"""Independent rig truths for the k_TB tests: the paper's radial dynamics solved directly.

Nothing here uses ``ema_rig.simulate`` or ``ema_rig.rig.model``: the mass and stiffness matrices
are written out below, the FRFs come from a direct solve of ``(K - w^2 M + j w C)^-1`` (or
``K (1 + j eta)`` for hysteretic damping) at every line, and the measurement is written to UFF58
through ``ema_rig.io.uff.write_uff58`` and read back by the code under test.

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
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from ema_rig.dof import DOF
from ema_rig.frf import FRFData

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

    @property
    def k_TB_MS(self) -> float:
        return 1.0 / (1.0 / self.k_TB + 1.0 / self.params["k_MS"])

    def matrices(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Mass and stiffness matrices (12 x 12; coordinate 11 inert without an appendage)."""
        p = self.params
        m_a = self.appendage_fraction * p["m_H"]
        n = 12
        m = np.zeros((n, n))
        k = np.zeros((n, n))
        m[0, 0] = p["m_H"] - m_a
        m[1, 1] = p["m_S"]
        m[2, 2] = p["m_F"]
        kt = self.k_TB_MS
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
        return m, k

    def observation(self) -> NDArray[np.float64]:
        """Sensor readings per coordinate, shape (8, 12), misaligned directions."""
        rng = np.random.default_rng(1000 + self.seed)
        c = np.zeros((len(OUT), 12))
        for s, name in enumerate(OUT):
            nominal = _AXIS[name[-1]]
            a = np.deg2rad(self.misalign_deg) * rng.standard_normal(2)
            others = [v for v in _AXIS.values() if not np.array_equal(v, nominal)]
            d = nominal + a[0] * others[0] + a[1] * others[1]
            d /= np.linalg.norm(d)
            if name in _POS:
                rx, ry, rz = _POS[name]
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

    def frf(self, freq: NDArray[np.float64]) -> NDArray[np.complex128]:
        """Accelerance [m/s^2/N] of every sensor for the radial shaker, shape (8, n_freq)."""
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


def _eigh(k: NDArray[np.float64], m: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Generalised symmetric eigenproblem by Cholesky (M = L L^T), mass-normalised vectors."""
    l_ = np.linalg.cholesky(m)
    li = np.linalg.inv(l_)
    lam, v = np.linalg.eigh(li @ k @ li.T)
    return lam, li.T @ v


def measurement(
    truth: RigTruth,
    freq: NDArray[np.float64],
    *,
    noise: float = 0.02,
    floor: float = 1e-4,
    drop: tuple[str, ...] = (),
    flip: tuple[str, ...] = (),
    scale: float = 1.0,
) -> FRFData:
    """Noisy FRFData (outputs in :data:`OUT` order minus ``drop``; one reference 11+Y).

    ``noise`` is the relative std of complex Gaussian noise on each line, ``floor`` an additive
    floor relative to the median magnitude of the channel; ``flip`` reverses the sign of sensors
    (a wrongly mounted or wired accelerometer) and ``scale`` multiplies every value (1 / g: a file
    in g read as m/s^2).
    """
    rng = np.random.default_rng(truth.seed)
    h = truth.frf(freq)
    mag = np.abs(h)
    floor_abs = floor * np.median(mag, axis=1, keepdims=True)
    sd = noise * mag + floor_abs
    h = h + sd * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / math.sqrt(2)
    keep = [i for i, d in enumerate(OUT) if d not in drop]
    for d in flip:
        h[OUT.index(d)] *= -1.0
    roles = ("housing",) * 5 + ("spindle",) * 3
    axes = ("radial", "radial", "radial", "lateral", "axial", "radial", "radial", "axial")
    return FRFData(
        freq.astype(np.float64),
        (scale * h[keep])[:, None, :],
        tuple(DOF.parse(OUT[i]) for i in keep),
        (DOF.parse("11+Y"),),
        frf_form="accelerance",
        roles=tuple(roles[i] for i in keep),
        axes=tuple(axes[i] for i in keep),
    )


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


def rig_text(params: dict[str, float] | None = None, *, drop: tuple[str, ...] = ()) -> str:
    """Rig file (TOML) for the truth's nominal parameters, without the sensors in ``drop``."""
    text = RIG_TOML.format(**(params or TABLE1))
    for dof, role, axis in _SENSORS:
        if dof.replace("-", "+") in drop:
            continue
        text += f'\n[[sensor]]\ndof = "{dof}"\nrole = "{role}"\naxis = "{axis}"\n'
    return text


def write_case(tmp: Path, name: str, truth: RigTruth, freq: NDArray[np.float64], **kw: object) -> tuple[Path, Path]:
    """Write ``name.uff`` and ``name.toml`` (the rig file) into ``tmp``; return both paths."""
    from ema_rig.config import load_rig
    from ema_rig.io.uff import write_uff58

    drop = tuple(kw.get("drop", ()))  # type: ignore[arg-type]
    rig_path = tmp / f"{name}.toml"
    rig_path.write_text(rig_text(drop=drop), encoding="utf-8")
    rig = load_rig(rig_path)
    data = measurement(truth, freq, **kw)  # type: ignore[arg-type]
    uff = tmp / f"{name}.uff"
    write_uff58(uff, data, binary=True, rig=rig)
    return uff, rig_path
