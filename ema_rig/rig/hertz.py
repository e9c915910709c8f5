"""Analytical radial stiffness of a deep-groove ball bearing (Hertz point contact) — an estimate.

Used only for comparison with the measured ``k_TB``. For a 6302 (7 balls of
7.938 mm on a 28.5 mm pitch diameter, zero clearance, groove conformity 0.52, steel) it gives
``k_r ≈ 9.14e6 F_r^(1/3)`` N/m: 7.3e7 at 500 N, 9.1e7 at 1 kN, 1.05e8 at 1.5 kN. The geometry is
inferred from catalogue ratings, so the result is an **estimate**, not a datum.

Functions
---------
ball_bearing_radial_stiffness
    ``k_r`` [N/m] for a radial load [N] (scalar or array).
radial_stiffness
    The same with the default 6302 geometry (Stribeck average).
hertz_contact_constant
    Load-deflection constant ``K`` of one ball-race point contact, ``Q = K delta^1.5``.

Classes
-------
BallBearingGeometry
    Frozen bearing geometry and material; :data:`BEARING_6302` is the paper's test bearing.

References
----------
T. A. Harris, M. N. Kotzalas, *Essential Concepts of Bearing Technology*, 5th ed., CRC Press,
2006, ch. 6-7 (point contact, Stribeck load distribution).
B. J. Hamrock, D. Brewe, "Simplified solution for stresses and deformations", J. Lubr. Technol.
105 (1983) 171-177 (closed-form approximations of the elliptic integrals).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import cast

import numpy as np
from numpy.typing import ArrayLike, NDArray


@dataclass(frozen=True, slots=True)
class BallBearingGeometry:
    """Deep-groove ball bearing geometry and material (SI units).

    Parameters
    ----------
    n_balls : int
        Number of balls Z.
    ball_diameter : float
        Ball diameter D [m].
    pitch_diameter : float
        Pitch diameter d_m [m].
    inner_conformity, outer_conformity : float
        Groove radius / ball diameter (f_i, f_o), > 0.5; 0.52 is typical.
    youngs_modulus : float
        E of the rings [Pa] (bearing steel 208 GPa); of the balls too unless ``ball_youngs_modulus``.
    poisson_ratio : float
        Poisson ratio of the rings (0.3); of the balls too unless ``ball_poisson_ratio``.
    clearance : float
        Diametral radial clearance P_d [m] (0: the Stribeck closed form ``k ~ F^(1/3)``; > 0:
        fewer balls carry the load and the stiffness is lower at small loads).
    ball_youngs_modulus, ball_poisson_ratio : float or None
        Ball material when it differs from the rings' (e.g. silicon nitride: 310 GPa, 0.26).
    """

    n_balls: int = 7
    ball_diameter: float = 7.938e-3
    pitch_diameter: float = 28.5e-3
    inner_conformity: float = 0.52
    outer_conformity: float = 0.52
    youngs_modulus: float = 208e9
    poisson_ratio: float = 0.3
    clearance: float = 0.0
    ball_youngs_modulus: float | None = None
    ball_poisson_ratio: float | None = None

    def __post_init__(self) -> None:
        if isinstance(self.n_balls, bool) or not isinstance(self.n_balls, int) or self.n_balls < 3:
            raise ValueError(f"n_balls must be an integer >= 3, got {self.n_balls!r}")
        if not 0 < self.ball_diameter < self.pitch_diameter:
            raise ValueError("need 0 < ball_diameter < pitch_diameter")
        if self.n_balls * self.ball_diameter >= math.pi * self.pitch_diameter:
            raise ValueError(f"{self.n_balls} balls of {self.ball_diameter * 1e3:g} mm do not fit on a "
                             f"{self.pitch_diameter * 1e3:g} mm pitch circle")
        if not (self.inner_conformity > 0.5 and self.outer_conformity > 0.5):
            raise ValueError("groove conformities must exceed 0.5")
        if not (math.isfinite(self.clearance) and self.clearance >= 0):
            raise ValueError(f"clearance must be finite and >= 0 m, got {self.clearance!r}")
        for name in ("youngs_modulus", "ball_youngs_modulus"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a finite positive modulus [Pa], got {v!r}")
        for name in ("poisson_ratio", "ball_poisson_ratio"):
            v = getattr(self, name)
            if v is not None and not (0 <= v < 0.5):
                raise ValueError(f"{name} must lie in [0, 0.5), got {v!r}")

    @property
    def effective_modulus(self) -> float:
        """``E' = 2 / ((1 - nu_1^2)/E_1 + (1 - nu_2^2)/E_2)`` [Pa] of the ball-ring contact."""
        e_b = self.youngs_modulus if self.ball_youngs_modulus is None else self.ball_youngs_modulus
        nu_b = self.poisson_ratio if self.ball_poisson_ratio is None else self.ball_poisson_ratio
        return 2.0 / ((1 - self.poisson_ratio**2) / self.youngs_modulus + (1 - nu_b**2) / e_b)

    def describe(self) -> str:
        """One line for legends: balls, diameters, clearance."""
        c = f", clearance {self.clearance * 1e6:g} µm" if self.clearance > 0 else ""
        return (f"{self.n_balls} balls Ø{self.ball_diameter * 1e3:g} mm on Ø{self.pitch_diameter * 1e3:g} mm"
                f"{c}")


BEARING_6302 = BallBearingGeometry()
"""The paper's test bearing, a 6302 (geometry inferred from catalogue ratings: an estimate)."""


def hertz_contact_constant(rx: float, ry: float, e_eff: float) -> float:
    """Load-deflection constant ``K`` [N/m^1.5] of a point contact, ``Q = K delta^1.5``.

    Hamrock-Brewe approximations: ellipticity ``k = 1.0339 (Ry/Rx)^0.636``, elliptic integrals
    ``E ≈ 1.0003 + 0.5968 Rx/Ry`` and ``F ≈ 1.5277 + 0.6023 ln(Ry/Rx)``, and
    ``delta = F [9 / (2 E R) (Q / (pi k E'))^2]^(1/3)`` with ``1/R = 1/Rx + 1/Ry``.

    Parameters
    ----------
    rx, ry : float
        Effective radii of curvature in the rolling and transverse directions [m], ``ry >= rx``.
    e_eff : float
        Effective modulus ``E' = E / (1 - nu^2)`` for two equal materials [Pa].
    """
    r = 1.0 / (1.0 / rx + 1.0 / ry)
    ratio = ry / rx
    k_ell = 1.0339 * ratio**0.636
    e_int = 1.0003 + 0.5968 / ratio
    f_int = 1.5277 + 0.6023 * math.log(ratio)
    c = f_int * (9.0 / (2.0 * e_int * r) / (math.pi * k_ell * e_eff) ** 2) ** (1.0 / 3.0)
    return cast("float", c**-1.5)


def _stribeck_integral() -> float:
    """``J = (1/2 pi) int_{-pi/2}^{pi/2} cos^2.5 psi d psi`` (= 0.2288, zero clearance)."""
    return math.sqrt(math.pi) * math.gamma(1.75) / math.gamma(2.25) / (2.0 * math.pi)


def ball_bearing_radial_stiffness(
    radial_load: float | ArrayLike,
    geometry: BallBearingGeometry = BEARING_6302,
    *,
    ball_angle: float | None = None,
) -> float | NDArray[np.float64]:
    """Radial stiffness ``k_r = dF_r / d delta_r`` [N/m] of a ball bearing (estimate).

    Zero clearance: ``F_r = K_n delta_r^1.5 S`` with ``S = Z J`` (Stribeck, continuous load
    distribution, default) or ``S = sum_j cos^2.5 psi_j`` over loaded balls for a given
    ball position; hence ``k_r = 1.5 K_n^(2/3) S^(2/3) F_r^(1/3)``. ``K_n`` combines the inner
    and outer contacts in series. With a diametral clearance ``P_d`` the ball at ``psi`` is
    compressed by ``delta_r cos psi - P_d / 2`` (when positive); ``F_r(delta_r)`` is solved for
    ``delta_r`` and ``k_r = dF_r / d delta_r`` is evaluated there.

    Parameters
    ----------
    radial_load : float or array_like
        Radial load F_r [N], >= 0.
    geometry : BallBearingGeometry
        Default: :data:`BEARING_6302`.
    ball_angle : float, optional
        Angle [rad] of one ball from the load line; None = the Stribeck average.

    Returns
    -------
    float or ndarray
        ``k_r`` [N/m], same shape as ``radial_load``.

    Examples
    --------
    >>> round(float(ball_bearing_radial_stiffness(1000.0)) / 1e7, 2)
    9.14
    """
    g = geometry
    f = np.asarray(radial_load, dtype=np.float64)
    if np.any(f < 0) or not np.all(np.isfinite(f)):
        raise ValueError("radial_load must be finite and >= 0 N")
    d, gamma = g.ball_diameter, g.ball_diameter / g.pitch_diameter
    e_eff = g.effective_modulus
    k_i = hertz_contact_constant(d / 2 * (1 - gamma), g.inner_conformity * d / (2 * g.inner_conformity - 1), e_eff)
    k_o = hertz_contact_constant(d / 2 * (1 + gamma), g.outer_conformity * d / (2 * g.outer_conformity - 1), e_eff)
    k_n = (k_i ** (-2.0 / 3.0) + k_o ** (-2.0 / 3.0)) ** -1.5
    if g.clearance > 0:
        k = np.array([_stiffness_with_clearance(float(x), k_n, g, ball_angle) for x in f.ravel()]).reshape(f.shape)
        return float(k) if k.ndim == 0 else k
    if ball_angle is None:
        s = g.n_balls * _stribeck_integral()
    else:
        psi = ball_angle + 2.0 * np.pi * np.arange(g.n_balls) / g.n_balls
        c = np.cos(psi)
        s = float(np.sum(np.where(c > 0, c, 0.0) ** 2.5))
    k = 1.5 * k_n ** (2.0 / 3.0) * s ** (2.0 / 3.0) * np.cbrt(f)
    return float(k) if k.ndim == 0 else k


def _stiffness_with_clearance(load: float, k_n: float, g: BallBearingGeometry, ball_angle: float | None) -> float:
    """``dF_r/d delta_r`` [N/m] at ``F_r = load`` with a diametral clearance (see the caller)."""
    from scipy.integrate import quad
    from scipy.optimize import brentq

    c = g.clearance / 2.0
    if load == 0.0:
        return 0.0
    if ball_angle is None:  # continuous (Stribeck) distribution over the loaded arc |psi| < acos(c/delta)
        def force(delta: float) -> float:
            lim = math.acos(min(1.0, c / delta))
            val = quad(lambda p: (delta * math.cos(p) - c) ** 1.5 * math.cos(p), 0.0, lim)[0]
            return cast("float", g.n_balls * k_n * val / math.pi)  # 2 x half arc / (2 pi)

        def stiff(delta: float) -> float:
            lim = math.acos(min(1.0, c / delta))
            val = quad(lambda p: 1.5 * (delta * math.cos(p) - c) ** 0.5 * math.cos(p) ** 2, 0.0, lim)[0]
            return cast("float", g.n_balls * k_n * val / math.pi)
    else:
        cos = np.cos(ball_angle + 2.0 * np.pi * np.arange(g.n_balls) / g.n_balls)

        def force(delta: float) -> float:
            x = np.maximum(delta * cos - c, 0.0)
            return float(k_n * np.sum(x**1.5 * cos))

        def stiff(delta: float) -> float:
            x = np.maximum(delta * cos - c, 0.0)
            return float(k_n * np.sum(1.5 * x**0.5 * cos**2))

    lo, hi = c, c + 1e-6
    while force(hi) < load:
        hi = c + 2.0 * (hi - c)
    delta = brentq(lambda d: force(d) - load, lo, hi, xtol=1e-15, rtol=1e-12)
    return stiff(delta)


def radial_stiffness(
    radial_load: float | ArrayLike, geometry: BallBearingGeometry = BEARING_6302
) -> float | NDArray[np.float64]:
    """Hertzian radial stiffness estimate [N/m] of the 6302 (Stribeck average); see
    :func:`ball_bearing_radial_stiffness`.

    Parameters
    ----------
    radial_load : float or array_like
        Radial load(s) [N].
    geometry : BallBearingGeometry, optional
        The bearing (default the paper's 6302).
    """
    return ball_bearing_radial_stiffness(radial_load, geometry)


__all__ = [
    "BEARING_6302",
    "BallBearingGeometry",
    "ball_bearing_radial_stiffness",
    "hertz_contact_constant",
    "radial_stiffness",
]
