"""Hand-built modal models of the paper's rig for the matching and stiffness tests.

Modes are given by natural frequency, damping ratio and a mass-normalised shape on the eight
sensors; residues follow ``R_r = phi phi_ref^T / (2 j w_d)``, so every candidate's truth is known.
"""

from __future__ import annotations

import numpy as np

from ema_rig.identification.modal import ModalModel
from ema_rig.rig.matching import model_mode_at

# outputs in the rig's sensor order, sign-corrected (13-Y appears as 13+Y)
OUT = ("11+Y", "12+Y", "13+Y", "14+Z", "15+X", "21+Y", "22+Y", "23+X")
ROLES = ("housing",) * 5 + ("spindle",) * 3
AXES = ("radial", "radial", "radial", "lateral", "axial", "radial", "radial", "axial")
INP = ("11+Y", "15+X")


def modal(modes, *, out_dofs=OUT, in_dofs=INP, roles=ROLES, axes=AXES, ref_rows=(0, 4)) -> ModalModel:
    """ModalModel from (natural_freq Hz, damping_ratio, mass-normalised shape over OUT)."""
    poles, res = [], []
    for fn, z, phi in modes:
        wn = 2 * np.pi * fn
        lam = -z * wn + 1j * wn * np.sqrt(1 - z**2)
        phi = np.asarray(phi, dtype=complex)
        ref = phi[list(ref_rows)]
        poles.append(lam)
        res.append(np.outer(phi, ref) / (2j * lam.imag))
    order = np.argsort(np.abs(poles))
    n_out, n_in = len(out_dofs), len(in_dofs)
    return ModalModel(
        poles=np.array(poles)[order],
        residues=np.array(res)[order],
        lower_residual=np.zeros((n_out, n_in), complex),
        upper_residual=np.zeros((n_out, n_in), complex),
        out_dofs=out_dofs,
        in_dofs=in_dofs,
        roles=roles,
        axes=axes,
    )


def housing_shape(params, fn: float, *, mass_factor: float = 1.0) -> np.ndarray:
    """The 3DOF model's housing-mode shape at fn on the 8 sensors (small cross-axis motion)."""
    info = model_mode_at(params, fn)
    a = 1.0 / np.sqrt(info.modal_mass * mass_factor)
    return np.array([a, a, a, 0.03 * a, 0.02 * a, info.spindle_ratio * a, info.spindle_ratio * a, 0.01 * a])


def rig_modes(params, f_h: float = 626.0) -> list[tuple[float, float, np.ndarray]]:
    """A realistic set: the housing mode plus every mode the 3DOF model lacks."""
    h = housing_shape(params, f_h)
    info = model_mode_at(params, f_h)
    b = 1.0 / np.sqrt(info.spindle_modal_mass)
    return [
        (120.0, 0.02, np.array([0.3, -0.3, 0.05, 0.02, 0.01, 0.01, 0.01, 0.0])),  # tilt
        (287.0, 0.015, np.array([0.01, 0.01, 0.01, 0.0, 0.0, 0.4, 0.3, 0.01])),  # spindle 1st
        (300.0, 0.02, np.array([0.02, 0.02, 0.02, 0.01, 0.5, 0.01, 0.01, 0.3])),  # housing axial
        (410.0, 0.02, np.array([0.05, 0.04, 0.05, 0.5, 0.01, 0.0, 0.0, 0.0])),  # lateral
        (f_h, 0.02, h),
        (f_h + 37.0, 0.01, h / np.sqrt(12.0)),  # flexible frame: housing-like, 12x the mass
        (1012.0, 0.01, np.array([0.01, 0.01, 0.01, 0.0, 0.1, 0.0, 0.0, 0.5])),  # spindle axial
        (info.spindle_freq * 1.003, 0.01, np.array([b, b, b, 0, 0, info.spindle_mode_ratio * b,
                                                     info.spindle_mode_ratio * b, 0.05 * b])),
    ]


def damping_term_by_hand(params, f_abs: float, zeta: float) -> float:
    """Relative std of the k_TB budget's damping-model term where the phase does not place the damping
    (oracle, written out here): rectangular, half-width the wider of ``1 - sqrt(1 - 2 zeta^2)``
    (viscous vs hysteretic proportional) and the shift to the pole read with all of its damping in
    the bearing. That reading: the complex bearing ``Z`` (in series with ``k_MS``) that zeroes
    ``det(K0 + k_c e e^T + s^2 M)`` at the pole ``s``, found by ``scipy.optimize.fsolve``; its
    stiffness ``Re Z - Re s Im Z / Im s`` (dashpot) or ``Re Z`` (hysteretic) in series with ``k_MS``
    and through the 3DOF eigenvalues (``scipy.linalg.eigvalsh``) gives the frequency."""
    import math

    import scipy.linalg
    import scipy.optimize

    p = params
    w = 2 * math.pi * f_abs
    s = complex(-zeta * w, w * math.sqrt(1 - zeta**2))
    mm = np.diag([p.m_H, p.m_S, p.m_F])

    def kmat(k: complex) -> np.ndarray:
        ka, ks, kb = p.k_AS, p.k_S, p.k_B
        return np.array([[ka + k, -k, -ka], [-k, k + ks, -ks], [-ka, -ks, ka + ks + kb]], dtype=complex)

    def resid(x: np.ndarray) -> list[float]:
        z = complex(x[0], x[1]) * 1e7
        d = np.linalg.det((kmat(1 / (1 / z + 1 / p.k_MS)) + s * s * mm) / 1e8)
        return [d.real, d.imag]

    k_guess = 1 / (1 / (mm[0, 0] * w * w) - 1 / p.k_MS)
    zr, zi = scipy.optimize.fsolve(resid, [k_guess / 1e7, 2 * zeta * k_guess / 1e7], xtol=1e-13)
    z = complex(zr, zi) * 1e7
    half = 1 - math.sqrt(1 - 2 * zeta**2)
    for k in (z.real - s.real * z.imag / s.imag, z.real):
        lam = scipy.linalg.eigvalsh(kmat(1 / (1 / k + 1 / p.k_MS)).real, mm)
        f_b = math.sqrt(lam[1]) / (2 * math.pi)
        half = max(half, abs(math.log(f_b / f_abs)))
    return half / math.sqrt(3)
