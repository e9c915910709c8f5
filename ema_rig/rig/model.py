"""The 3DOF radial model of the bearing test rig (paper Sect. 4, Fig. 6, Table 1).

Topology (one vertical displacement per mass, DOF order ``[x_H, x_S, x_F]``)::

    ground --k_B-- m_F ;  m_F --k_AS-- m_H ;  m_F --k_S-- m_S ;  m_S --k_TB+MS-- m_H

The radial shaker force acts on the housing mass ``m_H``. ``k_TB+MS`` is the test bearing
``k_TB`` in series with the mounting system ``k_MS``. With Table 1 and ``k_TB+MS = 4.397e7`` N/m
the model has natural frequencies 4.66 / 626.0 / 1907.2 Hz (paper: 4.7 / 626 / 1908 Hz).

Functions
---------
mass_matrix, stiffness_matrix
    The 3x3 matrices of the model.
series_stiffness, k_tb_from_series
    ``k_TB+MS = 1 / (1/k_TB + 1/k_MS)`` and back.

Classes
-------
RigModel
    Frozen model for one ``k_TB+MS``: natural frequencies, mass-normalised mode shapes, FRFs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from numpy.typing import ArrayLike, NDArray

from ..config import ModelParams
from ..dof import DOF
from ..frf import FORM_POWER, FRFData, frf_unit
from ..literals import FrfForm

DOF_NAMES: tuple[str, ...] = ("H", "S", "F")
"""Names of the model's DOFs: housing, spindle, frame (in matrix order)."""

HOUSING, SPINDLE, FRAME = 0, 1, 2
HOUSING_MODE = 1
"""Index (0-based, by increasing frequency) of the housing radial mode (m_H on k_TB+MS)."""
SPINDLE_MODE = 2
"""Index of the spindle bending mode (m_S on k_S, exciting the bearing)."""


def series_stiffness(k_TB: float, k_MS: float) -> float:
    """Series combination ``k_TB+MS = 1 / (1/k_TB + 1/k_MS)`` [N/m].

    Parameters
    ----------
    k_TB : float
        Test-bearing stiffness [N/m], > 0; ``inf`` (a rigid disk) gives ``k_MS``.
    k_MS : float
        Mounting-system stiffness [N/m], > 0.

    Returns
    -------
    float
        Combined stiffness [N/m].
    """
    if not k_TB > 0 or not k_MS > 0:
        raise ValueError(f"stiffnesses must be positive, got k_TB={k_TB!r}, k_MS={k_MS!r}")
    if math.isinf(k_TB):
        return float(k_MS)
    return 1.0 / (1.0 / k_TB + 1.0 / k_MS)


def k_tb_from_series(k_TB_MS: float, k_MS: float) -> float:
    """Bearing stiffness from the series stiffness: ``k_TB = 1 / (1/k_TB+MS - 1/k_MS)`` [N/m].

    Parameters
    ----------
    k_TB_MS : float
        Combined bearing + mounting stiffness [N/m], ``0 < k_TB_MS < k_MS``.
    k_MS : float
        Mounting-system stiffness [N/m].

    Returns
    -------
    float
        ``k_TB`` [N/m].

    Raises
    ------
    ValueError
        If ``k_TB_MS`` is not in ``(0, k_MS)``: the bearing stiffness would not be positive.
    """
    if not 0 < k_TB_MS < k_MS:
        raise ValueError(
            f"k_TB+MS = {k_TB_MS:.6g} N/m must lie in (0, k_MS = {k_MS:.6g} N/m) for a positive "
            "bearing stiffness"
        )
    return 1.0 / (1.0 / k_TB_MS - 1.0 / k_MS)


def mass_matrix(params: ModelParams) -> NDArray[np.float64]:
    """Mass matrix ``diag(m_H, m_S, m_F)`` [kg], shape (3, 3).

    Parameters
    ----------
    params : ModelParams
        The rig model (masses in kg).

    Returns
    -------
    ndarray, shape (3, 3), float64
    """
    return np.diag([params.m_H, params.m_S, params.m_F]).astype(np.float64)


def stiffness_matrix(params: ModelParams, k_TB_MS: float) -> NDArray[np.float64]:
    """Stiffness matrix [N/m], shape (3, 3), DOF order ``[x_H, x_S, x_F]``.

    Parameters
    ----------
    params : ModelParams
        Rig parameters (Table 1).
    k_TB_MS : float
        Combined bearing + mounting stiffness [N/m]; 0 gives ``K0``, the matrix without the
        bearing spring.
    """
    k, ka, ks, kb = float(k_TB_MS), params.k_AS, params.k_S, params.k_B
    return np.array(
        [
            [ka + k, -k, -ka],
            [-k, k + ks, -ks],
            [-ka, -ks, ka + ks + kb],
        ],
        dtype=np.float64,
    )


def _as_damping(damping_ratio: float | ArrayLike, n: int) -> NDArray[np.float64]:
    z = np.broadcast_to(np.asarray(damping_ratio, dtype=np.float64), (n,)).copy()
    if np.any(z < 0) or np.any(z >= 1) or not np.all(np.isfinite(z)):
        raise ValueError(f"damping_ratio must be in [0, 1), got {damping_ratio!r}")
    return z


def modal_frf(
    freq: ArrayLike,
    natural_freq: ArrayLike,
    shapes_out: ArrayLike,
    shapes_in: ArrayLike,
    damping_ratio: float | ArrayLike,
    *,
    frf_form: FrfForm = "receptance",
) -> NDArray[np.complex128]:
    """FRF matrix of a proportionally (modally) damped system by modal superposition.

    ``H_rec(w) = sum_r psi_out,r psi_in,r^T / (w_r^2 - w^2 + 2 j zeta_r w_r w)``; the poles are
    ``-zeta_r w_r +- j w_r sqrt(1 - zeta_r^2)`` so ``|lambda_r| = w_r`` exactly.

    Parameters
    ----------
    freq : array_like, shape (n_freq,)
        Frequencies [Hz].
    natural_freq : array_like, shape (n_modes,)
        Undamped natural frequencies [Hz].
    shapes_out : array_like, shape (n_out, n_modes)
        Mass-normalised mode shapes at the outputs [1/sqrt(kg)].
    shapes_in : array_like, shape (n_in, n_modes)
        Mass-normalised mode shapes at the inputs [1/sqrt(kg)].
    damping_ratio : float or array_like, shape (n_modes,)
        Modal damping ratios.
    frf_form : {'receptance', 'mobility', 'accelerance'}
        Output form.

    Returns
    -------
    ndarray, shape (n_out, n_in, n_freq), complex
        FRFs in SI units of ``frf_form``.
    """
    frf_unit(frf_form)
    f = np.asarray(freq, dtype=np.float64)
    wr = 2.0 * np.pi * np.asarray(natural_freq, dtype=np.float64)
    po = np.asarray(shapes_out)
    pi = np.asarray(shapes_in)
    z = _as_damping(damping_ratio, wr.size)
    w = 2.0 * np.pi * f
    denom = wr[:, None] ** 2 - w[None, :] ** 2 + 2j * z[:, None] * wr[:, None] * w[None, :]
    h = np.einsum("or,ir,rf->oif", po, pi, 1.0 / denom)
    p = FORM_POWER[frf_form]
    if p:
        h = h * (1j * w) ** p
    return np.asarray(h, dtype=np.complex128)


@dataclass(frozen=True, slots=True)
class RigModel:
    """The 3DOF rig model for one combined bearing + mounting stiffness.

    Parameters
    ----------
    params : ModelParams
        Rig parameters (paper Table 1), SI units.
    k_TB_MS : float
        Combined stiffness ``k_TB+MS`` [N/m], > 0.

    Attributes
    ----------
    natural_freq : ndarray, shape (3,)
        Undamped natural frequencies [Hz], increasing: frame, housing, spindle mode.
    mode_shapes : ndarray, shape (3, 3)
        Mass-normalised mode shapes [1/sqrt(kg)], one column per mode, rows ``[x_H, x_S, x_F]``;
        each column's sign is chosen so the housing entry is >= 0.

    Examples
    --------
    >>> from ema_rig.config import ModelParams
    >>> p = ModelParams(2.566, 2.8, 205.0, 114e6, 650e3, 348e6, 180e3)
    >>> [round(float(f), 2) for f in RigModel(p, 4.397e7).natural_freq]
    [4.66, 626.02, 1907.25]
    """

    params: ModelParams
    k_TB_MS: float
    natural_freq: NDArray[np.float64] = field(init=False, repr=False)
    mode_shapes: NDArray[np.float64] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        k = float(self.k_TB_MS)
        if not (math.isfinite(k) and k > 0):
            raise ValueError(f"k_TB_MS must be a finite positive stiffness [N/m], got {self.k_TB_MS!r}")
        object.__setattr__(self, "k_TB_MS", k)
        lam, vec = scipy.linalg.eigh(self.stiffness_matrix(), self.mass_matrix())
        # eigh(K, M) returns M-orthonormal vectors: vec.T @ M @ vec = I
        sign = np.where(vec[HOUSING] < 0, -1.0, 1.0)
        vec = vec * sign
        fn = np.sqrt(np.clip(lam, 0.0, None)) / (2.0 * np.pi)
        fn.setflags(write=False)
        vec.setflags(write=False)
        object.__setattr__(self, "natural_freq", fn)
        object.__setattr__(self, "mode_shapes", vec)

    @classmethod
    def from_k_tb(cls, params: ModelParams, k_TB: float) -> RigModel:
        """Model with bearing stiffness ``k_TB`` [N/m] in series with ``params.k_MS``."""
        return cls(params, series_stiffness(k_TB, params.k_MS))

    @property
    def k_TB(self) -> float:
        """Bearing stiffness [N/m] implied by ``k_TB_MS`` and ``params.k_MS`` (inf if equal)."""
        if self.k_TB_MS >= self.params.k_MS:
            return math.inf
        return k_tb_from_series(self.k_TB_MS, self.params.k_MS)

    def mass_matrix(self) -> NDArray[np.float64]:
        """Mass matrix [kg], shape (3, 3)."""
        return mass_matrix(self.params)

    def stiffness_matrix(self, k_TB_MS: float | None = None) -> NDArray[np.float64]:
        """Stiffness matrix [N/m], shape (3, 3); ``k_TB_MS`` overrides the model's value."""
        return stiffness_matrix(self.params, self.k_TB_MS if k_TB_MS is None else k_TB_MS)

    @property
    def housing_freq(self) -> float:
        """Natural frequency of the housing radial mode [Hz]."""
        return float(self.natural_freq[HOUSING_MODE])

    @property
    def spindle_freq(self) -> float:
        """Natural frequency of the spindle bending mode [Hz]."""
        return float(self.natural_freq[SPINDLE_MODE])

    def effective_mass(self, mode: int = HOUSING_MODE, dof: int = HOUSING) -> float:
        """Effective modal mass of a mode at a DOF: ``1 / phi[dof, mode]^2`` [kg].

        At the housing driving point this is what LSFD on the radial driving-point FRF gives
        (≈ 2.64 kg for the housing mode with Table 1 at 626 Hz).
        """
        phi = float(self.mode_shapes[dof, mode])
        return math.inf if phi == 0.0 else 1.0 / phi**2

    def frf(
        self,
        freq: ArrayLike,
        *,
        damping_ratio: float | ArrayLike = 0.0,
        frf_form: FrfForm = "receptance",
        outputs: Sequence[int] = (HOUSING, SPINDLE, FRAME),
    ) -> NDArray[np.complex128]:
        """FRFs for a force on the housing mass, by modal superposition.

        Parameters
        ----------
        freq : array_like, shape (n_freq,)
            Frequencies [Hz].
        damping_ratio : float or array_like, shape (3,)
            Modal damping ratio of each mode (proportional damping); 0 = undamped.
        frf_form : {'receptance', 'mobility', 'accelerance'}
            Output form (SI: m/N, m/s/N, m/s^2/N).
        outputs : sequence of int
            Model DOFs to return (0 = housing, 1 = spindle, 2 = frame).

        Returns
        -------
        ndarray, shape (len(outputs), n_freq), complex
        """
        phi = self.mode_shapes
        h = modal_frf(
            freq,
            self.natural_freq,
            phi[list(outputs)],
            phi[[HOUSING]],
            damping_ratio,
            frf_form=frf_form,
        )
        return h[:, 0, :]

    def frf_data(
        self,
        freq: ArrayLike,
        *,
        damping_ratio: float | ArrayLike = 0.0,
        frf_form: FrfForm = "accelerance",
        housing_dof: str = "1+Y",
        spindle_dof: str = "2+Y",
    ) -> FRFData:
        """Housing and spindle FRFs (force on the housing) as an :class:`FRFData`.

        Parameters
        ----------
        freq : array_like, shape (n_freq,)
            Frequencies [Hz], >= 0, increasing.
        damping_ratio : float or array_like, shape (3,)
            Modal damping ratios.
        frf_form : str
            Default 'accelerance'.
        housing_dof, spindle_dof : str
            DOF labels of the two outputs; the housing DOF is also the input.

        Returns
        -------
        FRFData
            Two outputs (roles housing, spindle; axis radial), one input.
        """
        h = self.frf(freq, damping_ratio=damping_ratio, frf_form=frf_form, outputs=(HOUSING, SPINDLE))
        return FRFData(
            np.asarray(freq, dtype=np.float64),
            h[:, None, :],
            (DOF.parse(housing_dof), DOF.parse(spindle_dof)),
            (DOF.parse(housing_dof),),
            frf_form=frf_form,
            roles=("housing", "spindle"),
            axes=("radial", "radial"),
            meta={"source": "ema_rig.rig.model.RigModel", "k_TB_MS": self.k_TB_MS},
        )

    def to_dict(self) -> dict[str, object]:
        """Parameters, ``k_TB_MS``, natural frequencies [Hz] and housing effective mass [kg]."""
        return {
            **self.params.as_dict(),
            "k_TB_MS": self.k_TB_MS,
            "k_TB": self.k_TB,
            "natural_freq": [float(f) for f in self.natural_freq],
            "housing_effective_mass": self.effective_mass(),
        }


__all__ = [
    "DOF_NAMES",
    "FRAME",
    "HOUSING",
    "HOUSING_MODE",
    "RigModel",
    "SPINDLE",
    "SPINDLE_MODE",
    "k_tb_from_series",
    "mass_matrix",
    "modal_frf",
    "series_stiffness",
    "stiffness_matrix",
]
