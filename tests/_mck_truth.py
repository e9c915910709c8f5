"""Seeded FRF data sets of lumped M, C, K systems with exact poles, written without ema_rig.

Only numpy and scipy are used here, so the truth (state-space eigenvalues of ``M, C, K``) and the
FRFs (a direct solve of ``(K - w^2 M + j w C) X = F`` at every line) are independent of the code
they check. Used by ``tests/test_refine.py`` and ``benchmarks/coverage_refine.py``.

Noise is complex circular Gaussian on every FRF line, as an H1 analyser sees it: standard
deviation ``sqrt(p^2 |H|^2 + floor^2)`` (``p`` relative, ``floor`` an additive level equal to
``floor_rel`` times the channel's RMS |H|). The matching ordinary coherence for ``n_averages``
averages follows from ``var = (1 - g2) / (n g2) |H|^2``: ``g2 = |H|^2 / (|H|^2 + n var)``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

# six coordinates; modes 3 and 4 are 1 % apart; one mode far above the band (residual term)
BASE_FREQ = (95.0, 170.0, 290.0, 292.9, 430.0, 2400.0)
BASE_DAMPING = (0.012, 0.02, 0.008, 0.011, 0.015, 0.02)
SHAPES = np.array(  # mass-normalised real shapes, one per row (six coordinates)
    [
        [0.30, 0.26, 0.21, 0.15, 0.10, 0.05],
        [0.26, 0.12, -0.14, -0.22, 0.06, 0.28],
        [0.28, -0.06, 0.25, -0.20, 0.16, -0.10],
        [0.22, 0.33, -0.10, 0.06, 0.30, 0.15],
        [0.20, -0.25, -0.06, 0.30, -0.15, 0.12],
        [0.15, -0.10, 0.30, 0.10, -0.25, -0.20],
    ]
)
BAND = (60.0, 520.0)


@dataclass(frozen=True)
class Truth:
    """A data set and its exact modes.

    Parameters
    ----------
    freq : ndarray, shape (n_freq,)
        Lines [Hz].
    frf : ndarray, shape (n_out, n_in, n_freq), complex
        Noisy accelerance [m/s^2/N].
    exact : ndarray, same shape
        Noise-free accelerance.
    variance : ndarray, shape (n_out, n_in, n_freq)
        True complex noise variance ``E|e|^2`` of every line.
    coherence : ndarray, shape (n_out, n_in, n_freq)
        Ordinary coherence matching ``variance`` for ``n_averages`` averages.
    n_averages : int
    poles : ndarray, shape (n_modes,), complex
        State-space eigenvalues with Im > 0 inside ``band``, sorted by |pole| [rad/s].
    out_dofs, in_dofs : list of str
    band : (float, float)
    """

    freq: np.ndarray
    frf: np.ndarray
    exact: np.ndarray
    variance: np.ndarray
    coherence: np.ndarray
    n_averages: int
    poles: np.ndarray
    out_dofs: list[str]
    in_dofs: list[str]
    band: tuple[float, float]

    @property
    def natural_freq(self) -> np.ndarray:
        return np.abs(self.poles) / (2 * np.pi)

    @property
    def damping_ratio(self) -> np.ndarray:
        return -self.poles.real / np.abs(self.poles)


def mck(*, proportional: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """M, C, K of the six-coordinate system; non-proportional damping adds two local dashpots."""
    wn = 2 * np.pi * np.asarray(BASE_FREQ)
    z = np.asarray(BASE_DAMPING)
    pinv = np.linalg.inv(SHAPES.T)
    m = pinv.T @ pinv
    k = pinv.T @ np.diag(wn**2) @ pinv
    c = pinv.T @ np.diag(2 * z * wn) @ pinv
    if not proportional:
        # dashpots between coordinates 0-3 and 2-4: damping of modes 2-4 up by 20-80 %, shapes of
        # the close pair complex (phase scatter 20-30 degrees)
        for a, b, cd in ((0, 3, 0.012 * c[0, 0]), (2, 4, 0.008 * c[2, 2])):
            e = np.zeros(6)
            e[a], e[b] = 1.0, -1.0
            c = c + cd * np.outer(e, e)
    sym = lambda x: 0.5 * (x + x.T)  # noqa: E731
    return sym(m), sym(c), sym(k)


def exact_poles(m: np.ndarray, c: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Eigenvalues of the first-order form, Im > 0, sorted by modulus [rad/s]."""
    n = m.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    lam = scipy.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    return lam[np.argsort(np.abs(lam))]


def make(
    seed: int,
    *,
    noise: float = 0.03,
    floor_rel: float = 0.0,
    proportional: bool = True,
    n_in: int = 1,
    n_averages: int = 30,
    df: float = 0.5,
    outputs: tuple[int, ...] = (0, 1, 2, 3, 4, 5),
) -> Truth:
    """One seeded data set (accelerance, band :data:`BAND`, line spacing ``df``)."""
    rng = np.random.default_rng(seed)
    m, c, k = mck(proportional=proportional)
    freq = np.arange(BAND[0], BAND[1] + df / 2, df)
    w = 2 * np.pi * freq
    refs = [0, 3][:n_in]
    dyn = k[None] - (w**2)[:, None, None] * m[None] + 1j * w[:, None, None] * c[None]
    rhs = np.zeros((6, n_in))
    rhs[refs, np.arange(n_in)] = 1.0
    x = np.linalg.solve(dyn, np.broadcast_to(rhs, (freq.size, 6, n_in)))
    h = np.moveaxis(x[:, list(outputs), :], 0, 2) * (1j * w) ** 2
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=2, keepdims=True))
    var = noise**2 * np.abs(h) ** 2 + (floor_rel * rms) ** 2
    e = np.sqrt(var / 2) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    coh = np.abs(h) ** 2 / (np.abs(h) ** 2 + n_averages * var)
    lam = exact_poles(m, c, k)
    fn = np.abs(lam) / (2 * np.pi)
    lam = lam[(fn > BAND[0]) & (fn < BAND[1])]
    dofs = [f"{i + 1}+Y" for i in range(6)]
    return Truth(
        freq=freq,
        frf=h + e,
        exact=h,
        variance=var,
        coherence=coh,
        n_averages=n_averages,
        poles=lam,
        out_dofs=[dofs[i] for i in outputs],
        in_dofs=[dofs[i] for i in refs],
        band=BAND,
    )
