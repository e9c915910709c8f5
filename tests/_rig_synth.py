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
