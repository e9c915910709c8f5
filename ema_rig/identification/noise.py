"""Noise variance of measured FRFs: from coherence, or estimated from the residual of a fit.

Functions
---------
coherence_variance
    Variance of every H1 FRF line from the ordinary coherence and the number of averages.
check_coherence
    Validate a coherence array (shape, finite, 0..1; values above 1 are clipped with a note).
fit_noise_model
    Per-channel noise model ``var = a + b |H|^2`` (additive floor + proportional part), fitted by
    maximum likelihood to leverage-corrected squared residuals.

Classes
-------
NoiseModel
    Frozen result: the variance array, where it came from and what was assumed.

Notes
-----
Variance of an H1 estimate (Bendat & Piersol, *Random Data*, 4th ed. 2010, chapter 9, the
random errors of frequency response estimates summarised in table 9.6): with ``n_d`` independent averages and ordinary coherence ``gamma^2``
the normalised random errors of gain and phase are
``eps[|H|] ~ sqrt(1 - gamma^2) / (|gamma| sqrt(2 n_d))`` and ``std[phase] ~ eps[|H|]`` rad, so
the complex error ``E|H_est - H|^2`` is::

    var(H) ~ (1 - gamma^2) / (n_d gamma^2) * |H|^2

shared equally by the real and imaginary parts. Everywhere in this module ``variance`` means
this complex variance ``E|e|^2`` [FRF unit^2]; each of the real and imaginary parts carries half.

Without coherence the noise is modelled per channel as ``a_c + b_c |H_c(f)|^2``: ``a_c`` is an
additive floor (output sensor noise with a flat force spectrum), ``b_c`` a relative part (input
noise, excitation drift, leakage). Residuals ``e`` of a least-squares fit underestimate the noise
(``E|e_i|^2 = var_i (1 - h_i)`` with ``h_i`` the leverage of line ``i``); :func:`fit_noise_model`
divides by ``1 - h_i`` first, which is how the degrees of freedom spent on the fit are returned.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import IdentificationError

#: Largest coherence used in :func:`coherence_variance`: keeps the variance of a line finite
#: (relative std >= 0.1 % / sqrt(n_averages)) where an analyser writes exactly 1.
COHERENCE_MAX = 1.0 - 1e-6

#: Noise sources, in the order of preference of :func:`ema_rig.identification.refine.refine`.
NOISE_SOURCES = ("given", "coherence", "coherence-scaled", "estimated")


@dataclass(frozen=True, slots=True, eq=False)
class NoiseModel:
    """Variance of every FRF line and where it came from.

    Parameters
    ----------
    variance : ndarray, shape (n_out, n_in, n_freq), float
        Complex variance ``E|e|^2`` of each line [FRF unit^2], > 0.
    source : str
        ``'given'`` (passed by the caller), ``'coherence'`` (coherence and number of averages),
        ``'coherence-scaled'`` (coherence shape, overall level estimated from the residual because
        the number of averages is unknown) or ``'estimated'`` (no coherence: per-channel
        ``a + b |H|^2`` fitted to the residual).
    n_averages : float or None
        Number of averages used with the coherence.
    notes : tuple of str
        What was assumed or corrected (clipped coherence ...), one line each.
    """

    variance: NDArray[np.float64]
    source: str
    n_averages: float | None = None
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.source not in NOISE_SOURCES:
            raise ValueError(f"source must be one of {NOISE_SOURCES}, got {self.source!r}")
        var = np.array(self.variance, dtype=np.float64, copy=True)
        var.setflags(write=False)
        object.__setattr__(self, "variance", var)
        object.__setattr__(self, "notes", tuple(self.notes))


def check_coherence(
    coherence: ArrayLike, shape: tuple[int, int, int], *, file: str | None = None
) -> tuple[NDArray[np.float64], tuple[str, ...]]:
    """Validate an ordinary-coherence array and clip it to 0..1.

    Parameters
    ----------
    coherence : array_like, shape (n_out, n_in, n_freq)
        Ordinary coherence ``gamma^2`` of every FRF line [-].
    shape : (int, int, int)
        Shape of the FRF array it belongs to.
    file : str, optional
        Source file, for messages.

    Returns
    -------
    coherence : ndarray, shape (n_out, n_in, n_freq), float
        Clipped to 0..1.
    notes : tuple of str
        One note when values above 1 (an analyser quirk) or below 0 were clipped.

    Raises
    ------
    IdentificationError
        Wrong shape, complex, NaN or inf values.
    """
    coh = np.asarray(coherence)
    if np.iscomplexobj(coh):
        raise IdentificationError("coherence must be real (ordinary coherence 0..1)", file=file)
    coh = coh.astype(np.float64)
    if coh.shape != tuple(shape):
        raise IdentificationError(f"coherence has shape {coh.shape}, the FRFs {tuple(shape)}", file=file)
    if not np.all(np.isfinite(coh)):
        raise IdentificationError("coherence contains NaN or inf values", file=file)
    notes: list[str] = []
    n_hi, n_lo = int(np.sum(coh > 1.0)), int(np.sum(coh < 0.0))
    if n_hi or n_lo:
        notes.append(
            f"coherence outside 0..1 at {n_hi + n_lo} of {coh.size} lines "
            f"(max {float(coh.max()):.4g}, min {float(coh.min()):.4g}); clipped to 0..1"
        )
    return np.clip(coh, 0.0, 1.0), tuple(notes)


def coherence_variance(
    frf_abs2: ArrayLike, coherence: ArrayLike, n_averages: float = 1.0
) -> NDArray[np.float64]:
    """Complex variance of H1 FRF lines from the coherence (Bendat & Piersol, ch. 9).

    Parameters
    ----------
    frf_abs2 : array_like, shape (...)
        ``|H|^2`` of every line [FRF unit^2] (preferably of a fitted model, so that the weights
        do not depend on the noise of the line itself).
    coherence : array_like, same shape
        Ordinary coherence 0..1; values are limited to :data:`COHERENCE_MAX`.
    n_averages : float, optional
        Number of independent averages ``n_d`` (default 1: the relative shape only).

    Returns
    -------
    ndarray, same shape
        ``(1 - gamma^2) / (n_d gamma^2) * |H|^2`` (``inf`` where the coherence is 0).

    Examples
    --------
    >>> round(float(coherence_variance(4.0, 0.8, n_averages=10)), 12)
    0.1
    """
    if not n_averages > 0:
        raise ValueError(f"n_averages must be > 0, got {n_averages!r}")
    g2 = np.minimum(np.asarray(coherence, dtype=np.float64), COHERENCE_MAX)
    h2 = np.asarray(frf_abs2, dtype=np.float64)
    with np.errstate(divide="ignore"):
        return np.where(g2 > 0, (1.0 - g2) / (n_averages * np.where(g2 > 0, g2, 1.0)) * h2, np.inf)


def fit_noise_model(
    resid_abs2: ArrayLike, model_abs2: ArrayLike, leverage: ArrayLike | None = None
) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """Fit ``var = a + b |H|^2`` per channel to squared residuals (maximum likelihood).

    Parameters
    ----------
    resid_abs2 : array_like, shape (n_chan, n_freq)
        ``|H_meas - H_model|^2`` of every line of every channel.
    model_abs2 : array_like, shape (n_chan, n_freq)
        ``|H_model|^2``.
    leverage : array_like, shape (n_chan, n_freq), optional
        Mean leverage of the real and imaginary rows of each line in the fit that produced the
        residuals, 0..1; the squared residual is divided by ``1 - leverage``.

    Returns
    -------
    a, b : ndarray, shape (n_chan,)
        Additive floor [FRF unit^2] and relative part [-] of the complex variance, >= 0.
    variance : ndarray, shape (n_chan, n_freq)
        ``a + b |H_model|^2``, > 0.

    Notes
    -----
    For complex Gaussian noise ``z = |e|^2 / (1 - h)`` is exponential with mean ``v``; the
    negative log-likelihood ``sum(z / v + ln v)`` is minimised over ``v = s (1 + q |H|^2 / m)``
    (``m`` the channel's mean ``|H|^2``): for a given ratio ``q`` the level ``s`` is the mean of
    ``z / (1 + q |H|^2 / m)``, and ``q`` (0 = pure floor, 1e8 ~ pure proportional) is found on
    a logarithmic grid, then by golden-section search between the grid neighbours of the best
    point. The profile is not convex in general, which is why no local iteration is used.

    Examples
    --------
    >>> rng = np.random.default_rng(1)
    >>> u = np.exp(rng.uniform(-6.0, 4.0, (1, 4000)))
    >>> z = (2e-3 + 0.01 * u) * rng.exponential(size=u.shape)
    >>> a, b, _ = fit_noise_model(z, u)
    >>> bool(abs(a[0] / 2e-3 - 1) < 0.15 and abs(b[0] / 0.01 - 1) < 0.15)
    True
    """
    z = np.asarray(resid_abs2, dtype=np.float64)
    u = np.asarray(model_abs2, dtype=np.float64)
    if leverage is not None:
        lev = np.clip(np.asarray(leverage, dtype=np.float64), 0.0, 0.95)
        z = z / (1.0 - lev)
    n_chan = z.shape[0]
    um = np.mean(u, axis=1, keepdims=True)
    un = u / np.where(um > 0, um, 1.0)

    def profile(q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        shape = 1.0 + q[:, None] * un
        s = np.mean(z / shape, axis=1)
        s = np.where(s > 0, s, 1e-300)
        return np.log(s) + np.mean(np.log(shape), axis=1), s

    grid = np.concatenate([[0.0], np.logspace(-4.0, 8.0, 49)])
    nll = np.stack([profile(np.full(n_chan, q))[0] for q in grid], axis=1)  # (n_chan, n_grid)
    best = np.argmin(nll, axis=1)
    # golden section in log q between the neighbours of the best grid point
    lg = np.log10(np.where(grid > 0, grid, 1e-5))
    lo = lg[np.maximum(best - 1, 0)]
    hi = lg[np.minimum(best + 1, grid.size - 1)]
    gr = (np.sqrt(5.0) - 1.0) / 2.0
    for _ in range(30):
        m1, m2 = hi - gr * (hi - lo), lo + gr * (hi - lo)
        f1, f2 = profile(10.0**m1)[0], profile(10.0**m2)[0]
        left = f1 < f2
        hi = np.where(left, m2, hi)
        lo = np.where(left, lo, m1)
    q_gs = 10.0 ** (0.5 * (lo + hi))
    f_gs = profile(q_gs)[0]
    q = np.where(f_gs < nll[np.arange(n_chan), best], q_gs, grid[best])
    _, s = profile(q)
    a = s
    b = s * q / np.where(um[:, 0] > 0, um[:, 0], 1.0)
    var = a[:, None] + b[:, None] * u
    return a, b, np.maximum(var, 1e-300)


__all__ = ["COHERENCE_MAX", "NOISE_SOURCES", "NoiseModel", "check_coherence", "coherence_variance", "fit_noise_model"]
