"""Seeded truths for the generic identification (issue 18), written without ema_rig.

Only numpy and scipy: M, C, K from chosen natural frequencies, damping ratios and real
mass-normalised shapes (``M = P^-T P^-1``, ``K = P^-T diag(w^2) P^-1``, ``C = P^-T diag(2 zeta w) P^-1``),
local dashpots where the damping is non-proportional; the truth poles are the eigenvalues of the
first-order form and the FRFs a direct solve of ``(K - w^2 M + j w C) x = f`` at every line. Noise
is complex circular Gaussian per line, ``sqrt(p^2 |H|^2 + floor^2)``, with the coherence that matches
it for ``n_averages`` averages (``g2 = |H|^2 / (|H|^2 + n var)``). Used by
``benchmarks/study_generic_truths.py`` (the families are listed there) and ``tests/test_generic_truths.py``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from _mck_truth import exact_poles
from numpy.typing import NDArray

G = 9.80665


@dataclass(frozen=True)
class Case:
    """One data set and its truth.

    Parameters
    ----------
    freq : ndarray, shape (n_freq,)
        Lines [Hz].
    frf : ndarray, shape (n_out, n_in, n_freq), complex
        Noisy FRF in ``form`` (SI, or g for the ``g`` family).
    coherence : ndarray or None, shape (n_out, n_in, n_freq)
    n_averages : int or None
    poles : ndarray, shape (n_modes,), complex
        Truth poles with Im > 0 inside the band [rad/s].
    form : str
    band : (float, float)
    """

    freq: NDArray[np.float64]
    frf: NDArray[np.complex128]
    coherence: NDArray[np.float64] | None
    n_averages: int | None
    poles: NDArray[np.complex128]
    form: str
    band: tuple[float, float]


def modal_mck(fn: NDArray[np.float64], zeta: NDArray[np.float64], shapes: NDArray[np.float64]
              ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """M, C, K from natural frequencies [Hz], damping ratios and mass-normalised shapes (one per row)."""
    w = 2 * np.pi * fn
    pinv = np.linalg.inv(shapes.T)
    m = pinv.T @ pinv
    k = pinv.T @ np.diag(w**2) @ pinv
    c = pinv.T @ np.diag(2 * zeta * w) @ pinv
    sym = lambda x: 0.5 * (x + x.T)  # noqa: E731
    return sym(m), sym(c), sym(k)


def solve_frf(m: NDArray[np.float64], c: NDArray[np.float64], k: NDArray[np.float64], freq: NDArray[np.float64],
              outs: list[int], refs: list[int], form: str) -> NDArray[np.complex128]:
    """Exact FRF (n_out, n_in, n_freq) by a direct solve per line."""
    w = 2 * np.pi * freq
    n = m.shape[0]
    dyn = k[None] - (w**2)[:, None, None] * m[None] + 1j * w[:, None, None] * c[None]
    rhs = np.zeros((n, len(refs)))
    rhs[refs, np.arange(len(refs))] = 1.0
    x = np.linalg.solve(dyn, np.broadcast_to(rhs, (freq.size, n, len(refs))))
    h = np.moveaxis(x[:, outs, :], 0, 2)
    power = {"receptance": 0, "mobility": 1, "accelerance": 2}[form]
    return np.asarray(h * (1j * w) ** power, np.complex128)


def random_shapes(rng: np.random.Generator, n: int) -> NDArray[np.float64]:
    """Well-conditioned random real shapes (n, n), one per row."""
    while True:
        p = rng.uniform(-1.0, 1.0, (n, n)) * 0.3
        if np.linalg.cond(p) < 12:
            return p


def add_noise(rng: np.random.Generator, h: NDArray[np.complex128], p: float, floor_rel: float, n_avg: int,
              chan_gain: NDArray[np.float64] | None = None
              ) -> tuple[NDArray[np.complex128], NDArray[np.float64]]:
    """Noisy FRF and the matching coherence; ``chan_gain`` scales the signal only (floor kept)."""
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=2, keepdims=True))
    floor = floor_rel * np.sqrt(np.mean(rms**2))  # one floor for all channels (same sensor noise)
    if chan_gain is not None:
        h = h * chan_gain[:, None, None]
    var = p**2 * np.abs(h) ** 2 + floor**2
    e = np.sqrt(var / 2) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    coh = np.abs(h) ** 2 / (np.abs(h) ** 2 + n_avg * var)
    return h + e, coh


def _in_band(lam: NDArray[np.complex128], band: tuple[float, float]) -> NDArray[np.complex128]:
    fn = np.abs(lam) / (2 * np.pi)
    return lam[(fn > band[0]) & (fn < band[1])]


def base(seed: int, *, n_modes: int = 6, band: tuple[float, float] = (50.0, 550.0), form: str = "accelerance",
         proportional: bool = True, dashpot: float = 0.01, refs: tuple[int, ...] = (0,), pair: float | None = None,
         extra: NDArray[np.float64] | None = None, chan_gain: NDArray[np.float64] | None = None,
         dead: int | None = None, df: float = 0.5, noise: float = 0.02, floor_rel: float = 0.002,
         n_avg: int = 30, fn: NDArray[np.float64] | None = None, zeta: NDArray[np.float64] | None = None,
         rigid: int = 0) -> Case:
    """A seeded truth: ``n_modes`` modes spread over the band (plus ``extra`` out-of-band ones)."""
    rng = np.random.default_rng(seed)
    if fn is None:
        edges = np.linspace(band[0], band[1], n_modes + 2)[1:-1]
        step = (band[1] - band[0]) / (n_modes + 1)
        fn = edges + rng.uniform(-0.25, 0.25, n_modes) * step
        if pair is not None:  # mode 3 a near-repeated twin of mode 2
            fn[3] = fn[2] * (1 + pair)
    if zeta is None:
        zeta = rng.uniform(0.005, 0.02, fn.size)
    fn = np.sort(fn)
    if extra is not None:
        fn = np.concatenate([fn, extra])
        zeta = np.concatenate([zeta, rng.uniform(0.005, 0.02, extra.size)])
    n = fn.size + rigid
    shapes = random_shapes(rng, n)
    f_all = np.concatenate([np.full(rigid, 0.0), fn])
    z_all = np.concatenate([np.zeros(rigid), zeta])
    m, c, k = modal_mck(f_all, z_all, shapes)
    if not proportional:  # two local dashpots between coordinates: complex modes
        # dashpot 0.01: zeta up to ~20 %, 8 of 60 modes (seeds 0-9) with MPC below 0.9; 0.05: zeta up to ~60 %
        for a, b, scale in ((0, 2, dashpot), (1, 3, 0.8 * dashpot)):
            e = np.zeros(n)
            e[a], e[b] = 1.0, -1.0
            c = c + scale * np.sqrt(k[a, a] * m[a, a]) * np.outer(e, e)
    freq = np.arange(band[0], band[1] + df / 2, df)
    outs = list(range(n))
    h = solve_frf(m, c, k, freq, outs, list(refs), form)
    gain = chan_gain
    hn, coh = add_noise(rng, h, noise, floor_rel, n_avg, gain)
    if dead is not None:  # a disconnected channel: the noise floor only
        rms = np.sqrt(np.mean(np.abs(h) ** 2))
        sd = floor_rel * rms
        hn[dead] = sd / np.sqrt(2) * (rng.standard_normal(hn[dead].shape) + 1j * rng.standard_normal(hn[dead].shape))
        coh[dead] = 1.0 / (1.0 + n_avg * 1.0)  # no correlated part: coherence near 1/n
    lam = _in_band(exact_poles(m, c, k), band)
    return Case(freq, hn, coh, n_avg, lam, form, band)


def drift(seed: int, *, n_avg: int = 30, stiffness_drift: float = 0.01, noise: float = 0.02, floor_rel: float = 0.002,
          band: tuple[float, float] = (50.0, 550.0), df: float = 0.5) -> Case:
    """Six modes whose stiffness grows linearly by ``stiffness_drift`` over ``n_avg`` averages, H1 and coherence.

    Each average has its own random force spectrum ``F_i`` (complex Gaussian per line: periodic random
    excitation, no leakage) and response ``X_i = H_i F_i + E_i`` with ``H_i`` of the system at that
    average's stiffness ``K (1 + stiffness_drift i / (n_avg - 1))`` and ``E_i`` response noise independent
    of the force (H1's model), of standard deviation ``sqrt(noise^2 |H_i|^2 + floor^2)`` (``floor`` =
    ``floor_rel`` times the RMS of the first average's |H|); ``H1 = sum F_i^* X_i / sum |F_i|^2``, the coherence from the same
    sums. The truth is the system at the mean stiffness ``K (1 + stiffness_drift / 2)``.
    """
    rng = np.random.default_rng(seed)
    edges = np.linspace(band[0], band[1], 8)[1:-1]
    fn = edges + rng.uniform(-0.25, 0.25, 6) * (band[1] - band[0]) / 7
    zeta = rng.uniform(0.005, 0.02, 6)
    m, c, k = modal_mck(np.sort(fn), zeta, random_shapes(rng, 6))
    freq = np.arange(band[0], band[1] + df / 2, df)
    gxf = np.zeros((6, 1, freq.size), np.complex128)
    gxx = np.zeros((6, 1, freq.size))
    gff = np.zeros(freq.size)
    for i in range(n_avg):
        h = solve_frf(m, c, k * (1 + stiffness_drift * i / (n_avg - 1)), freq, list(range(6)), [0], "accelerance")
        f = (rng.standard_normal(freq.size) + 1j * rng.standard_normal(freq.size)) / np.sqrt(2)
        if i == 0:
            floor = floor_rel * np.sqrt(np.mean(np.abs(h) ** 2))
        sd = np.sqrt((noise * np.abs(h)) ** 2 + floor**2)  # independent of this average's force (H1's model)
        x = h * f + sd * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
        gxf += x * np.conj(f)
        gxx += np.abs(x) ** 2
        gff += np.abs(f) ** 2
    h1 = gxf / gff
    coh = np.abs(gxf) ** 2 / (gxx * gff)
    lam = _in_band(exact_poles(m, c, k * (1 + stiffness_drift / 2)), band)
    return Case(freq, h1, np.minimum(coh, 1.0), n_avg, lam, "accelerance", band)


def families() -> dict[str, Callable[[int], Case]]:
    """Name -> seeded truth builder."""

    def dense(seed: int) -> Case:
        rng = np.random.default_rng(10_000 + seed)
        n, band = 15, (100.0, 400.0)
        mu = rng.uniform(0.3, 1.0)  # modal overlap factor 2 zeta f / spacing
        fn = np.linspace(130.0, 370.0, n) + rng.uniform(-3.0, 3.0, n)
        spacing = (370.0 - 130.0) / (n - 1)
        zeta = mu * spacing / (2 * fn) * rng.uniform(0.8, 1.2, n)
        return base(seed, band=band, fn=fn, zeta=zeta)

    def outside(seed: int) -> Case:
        rng = np.random.default_rng(20_000 + seed)
        return base(seed, extra=np.array([550.0 * (1 + rng.uniform(0.02, 0.04))]))

    def pair(p: float, refs: tuple[int, ...]) -> Callable[[int], Case]:
        def make(seed: int) -> Case:
            rng = np.random.default_rng(30_000 + seed)
            return base(seed, pair=rng.uniform(0.001, 0.005), refs=refs)
        return make

    def weak(seed: int) -> Case:
        g = np.ones(6)
        g[2] = 0.01
        return base(seed, chan_gain=g)

    def to_g(seed: int) -> Case:
        c = base(seed)
        return Case(c.freq, c.frf / G, c.coherence, c.n_averages, c.poles, c.form, c.band)

    def nocoh(seed: int) -> Case:
        c = base(seed)
        return Case(c.freq, c.frf, None, None, c.poles, c.form, c.band)

    return {
        "clean": lambda s: base(s),
        "complex": lambda s: base(s, proportional=False),
        "complex5": lambda s: base(s, proportional=False, dashpot=0.05),
        "pair1": pair(0.003, (0,)),
        "pair2": pair(0.003, (0, 3)),
        "dense": dense,
        "outside": outside,
        "rigid": lambda s: base(s, band=(2.0, 550.0), rigid=2),
        "dead": lambda s: base(s, dead=2),
        "weak": weak,
        "receptance": lambda s: base(s, form="receptance"),
        "mobility": lambda s: base(s, form="mobility"),
        "g": to_g,
        "nocoh": nocoh,
        "steady": lambda s: drift(s, stiffness_drift=0.0),
        "drift": drift,
    }


def match(case: Case, f: NDArray[np.float64], sf: NDArray[np.float64]) -> list[int | None]:
    """Index of the true mode each identified mode is matched to (None: no support)."""
    ft = np.abs(case.poles) / (2 * np.pi)
    zt = -case.poles.real / np.abs(case.poles)
    df = float(case.freq[1] - case.freq[0])
    out: list[int | None] = []
    for fi, si in zip(f, sf, strict=True):
        j = int(np.argmin(np.abs(ft - fi)))
        gap = np.min(np.abs(np.delete(ft, j) - ft[j])) / 2 if ft.size > 1 else np.inf
        tol = max(5 * (si if np.isfinite(si) else 0.0), 0.25 * 2 * zt[j] * ft[j], 0.3 * df)
        out.append(j if abs(fi - ft[j]) <= min(tol, gap) else None)
    return out


