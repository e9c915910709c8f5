"""Test helper: a lumped M, K, C system with exactly known modal parameters.

The system is built from its modal model (``from_modal``) so that natural frequencies,
damping ratios and mass-normalised mode shapes are chosen exactly; its FRFs are then computed
by solving ``(K - w^2 M + j w C) X = F`` at every line (no modal truncation), and its poles
from the state-space eigenproblem, independently of the modal construction.

Classes
-------
LumpedSystem
    M, K, C matrices; ``poles``, ``natural_freq``, ``damping_ratio``, ``mode_shapes``, ``frf``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from ema_rig.dof import DOF
from ema_rig.frf import FRFData


@dataclass(frozen=True)
class LumpedSystem:
    """A viscously damped lumped system ``M x'' + C x' + K x = f``.

    Parameters
    ----------
    M, K, C : ndarray, shape (n_dof, n_dof)
        Mass [kg], stiffness [N/m] and damping [N s/m] matrices.
    dofs : tuple of DOF, length n_dof
        Label of every coordinate.
    """

    M: NDArray[np.float64]
    K: NDArray[np.float64]
    C: NDArray[np.float64]
    dofs: tuple[DOF, ...]

    @classmethod
    def from_modal(
        cls,
        natural_freq: Sequence[float],
        damping_ratio: Sequence[float],
        shapes: NDArray[np.float64],
        dofs: Sequence[str | DOF] | None = None,
    ) -> LumpedSystem:
        """Build M, K, C that have exactly these modes (classical damping).

        Parameters
        ----------
        natural_freq : sequence of float, length n
            Undamped natural frequencies [Hz].
        damping_ratio : sequence of float, length n
            Modal damping ratios [-].
        shapes : ndarray, shape (n, n)
            Mass-normalised real mode shapes, one per ROW (must be invertible).
        dofs : sequence of str or DOF, optional
            Labels (default ``"1+Y", "2+Y", ...``).
        """
        wn = 2 * np.pi * np.asarray(natural_freq, float)
        z = np.asarray(damping_ratio, float)
        phi = np.asarray(shapes, float).T  # columns = modes
        pinv = np.linalg.inv(phi)
        M = pinv.T @ pinv
        K = pinv.T @ np.diag(wn**2) @ pinv
        C = pinv.T @ np.diag(2 * z * wn) @ pinv
        n = len(wn)
        labels = tuple(DOF.parse(d) if isinstance(d, str) else d for d in (dofs or [f"{i + 1}+Y" for i in range(n)]))
        sym = lambda a: 0.5 * (a + a.T)  # noqa: E731
        return cls(sym(M), sym(K), sym(C), labels)

    @property
    def n_dof(self) -> int:
        """Number of coordinates."""
        return self.M.shape[0]

    def _state_eig(self) -> tuple[NDArray[np.complex128], NDArray[np.complex128]]:
        n = self.n_dof
        a = np.zeros((2 * n, 2 * n))
        minv = np.linalg.inv(self.M)
        a[:n, n:] = np.eye(n)
        a[n:, :n] = -minv @ self.K
        a[n:, n:] = -minv @ self.C
        lam, vec = np.linalg.eig(a)
        keep = lam.imag > 0
        lam, vec = lam[keep], vec[:n, keep]
        order = np.argsort(np.abs(lam))
        return lam[order], vec[:, order]

    @property
    def poles(self) -> NDArray[np.complex128]:
        """Exact poles [rad/s], Im > 0, sorted by natural frequency, shape (n_modes,)."""
        return self._state_eig()[0]

    @property
    def natural_freq(self) -> NDArray[np.float64]:
        """``|lambda| / 2 pi`` [Hz], shape (n_modes,)."""
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """``-Re(lambda) / |lambda|``, shape (n_modes,)."""
        p = self.poles
        return -p.real / np.abs(p)

    @property
    def mode_shapes(self) -> NDArray[np.complex128]:
        """Complex mode shapes (arbitrary scale), one per row, shape (n_modes, n_dof)."""
        return self._state_eig()[1].T

    def normal_modes(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Undamped natural frequencies [Hz] and mass-normalised shapes (rows), from eigh(K, M)."""
        from scipy.linalg import eigh

        w2, v = eigh(self.K, self.M)
        return np.sqrt(w2) / (2 * np.pi), v.T

    def frf(
        self,
        freq: NDArray[np.float64],
        *,
        outputs: Sequence[int] | None = None,
        inputs: Sequence[int] = (0,),
        frf_form: str = "accelerance",
        noise: float = 0.0,
        rng: np.random.Generator | None = None,
    ) -> FRFData:
        """Exact FRFs of the system (direct solve per line).

        Parameters
        ----------
        freq : ndarray, shape (n_freq,)
            Lines [Hz].
        outputs, inputs : sequence of int
            Indices of the response and reference coordinates (default: all outputs, input 0).
        frf_form : str
            'accelerance', 'mobility' or 'receptance'.
        noise : float
            Relative complex Gaussian noise: std = ``noise`` times each FRF's RMS over the band.
        rng : numpy.random.Generator
            Required when ``noise > 0``.
        """
        f = np.asarray(freq, float)
        outs = list(range(self.n_dof)) if outputs is None else list(outputs)
        ins = list(inputs)
        w = 2 * np.pi * f
        dyn = self.K[None] - (w**2)[:, None, None] * self.M[None] + 1j * w[:, None, None] * self.C[None]
        rhs = np.zeros((self.n_dof, len(ins)))
        rhs[ins, np.arange(len(ins))] = 1.0
        x = np.linalg.solve(dyn, np.broadcast_to(rhs, (f.size, *rhs.shape)))  # (n_freq, n_dof, n_in)
        h = np.moveaxis(x[:, outs, :], 0, 2)
        p = {"receptance": 0, "mobility": 1, "accelerance": 2}[frf_form]
        h = h * (1j * w) ** p
        if noise > 0:
            if rng is None:
                raise ValueError("rng is required with noise > 0")
            rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=2, keepdims=True))
            h = h + noise * rms * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
        return FRFData(
            f, h, [self.dofs[i] for i in outs], [self.dofs[i] for i in ins], frf_form=frf_form
        )


def five_mode_system(*, close_pair: bool = True) -> LumpedSystem:
    """Six coordinates, six modes in 100..900 Hz; modes 3 and 4 are 1 % apart.

    Mode 4 (at 1.01 x mode 3) has a node at coordinate 0 (the first reference), so a
    single-reference test at coordinate 0 cannot see it; a second reference at coordinate 1
    excites it strongly. Without ``close_pair`` mode 4 is moved to 560 Hz.
    """
    fn = [120.0, 230.0, 410.0, 414.1 if close_pair else 560.0, 640.0, 830.0]
    zeta = [0.010, 0.020, 0.008, 0.012, 0.015, 0.025]
    shapes = np.array(
        [
            [0.30, 0.25, 0.20, 0.15, 0.10, 0.05],
            [0.25, 0.10, -0.15, -0.20, 0.05, 0.30],
            [0.30, -0.05, 0.25, -0.20, 0.15, -0.10],
            [0.00, 0.35, -0.10, 0.05, 0.30, 0.15],
            [0.20, -0.25, -0.05, 0.30, -0.15, 0.10],
            [0.15, -0.10, 0.30, 0.10, -0.25, -0.20],
        ]
    )
    return LumpedSystem.from_modal(fn, zeta, shapes, [f"{i + 11}+Y" for i in range(6)])
