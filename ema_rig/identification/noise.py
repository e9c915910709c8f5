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
segment_misfit
    Is the residual of a modal model consistent with the noise estimate? A chi-square test per
    band segment and channel with its degrees of freedom (Bonferroni over the tests).

Classes
-------
NoiseModel
    Frozen result: the variance array, where it came from and what was assumed.
MisfitTest
    Frozen result of :func:`segment_misfit`: segments, statistics, which ones fail.

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

from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._linalg import thin_svd
from ..errors import IdentificationError
from .criteria import COMPLETENESS_CRITERIA, CompletenessCriteria
from .modal import modal_basis, unit_real_basis

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
    resid_abs2: ArrayLike, model_abs2: ArrayLike, leverage: ArrayLike | None = None, *,
    mask: ArrayLike | None = None,
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
    mask : array_like of bool, shape (n_chan, n_freq), optional
        Lines of each channel the fit uses (default all); the variance is returned for all.

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
    a logarithmic grid (the profile is not convex in general: the grid picks the basin), then by a
    bracketed Newton iteration between the grid neighbours of the best point (derivatives in
    closed form; it reaches the minimum to rounding, where the golden-section search it replaced
    stopped within 1e-7 of it, at a third of the cost). Bounds of the profile from sums over bins
    of ``|H|^2`` (convexity: tangent and chord per bin) exclude the grid points that cannot be the
    minimum, and only the others (one or two per channel, typically) are evaluated in double
    precision: the best grid point is the one the full double-precision grid gives. Channels are
    independent and processed in blocks that stay in the processor cache; with :data:`_NOISE_THREADS` above 1
    (default 1), from :data:`_NOISE_THREAD_MIN_VALUES` values, in blocks of :data:`_NOISE_THREAD_BLOCK`
    channels two at a time in threads (per-channel arithmetic: the result is the one-thread result to the bit).

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
    if mask is not None and np.all(mask):
        mask = None  # every line: the same sums as without a mask, without forming the weights
    if mask is None:  # every line: the weights 1 change no value
        cnt = np.full(n_chan, max(float(z.shape[1]), 1.0))
        um = (np.sum(u, axis=1) / cnt)[:, None]
        wz = z
        unw = un = u / np.where(um > 0, um, 1.0)
    else:
        wts = np.asarray(mask, dtype=np.float64)
        cnt = np.maximum(wts.sum(axis=1), 1.0)
        um = (np.sum(wts * u, axis=1) / cnt)[:, None]
        un = u / np.where(um > 0, um, 1.0)
        # lines left out weigh nothing in either sum: their z and |H|^2 set to 0 (shape 1, log 0)
        wz = wts * z
        unw = np.where(wts > 0, un, 0.0)
    grid = np.concatenate([[0.0], np.logspace(-4.0, 8.0, 49)])
    threads = z.size >= _NOISE_THREAD_MIN_VALUES  # a work-size rule: the same on any machine
    s_g, t_g, nll, best = _noise_grid(wz, unw, cnt, grid, threads)
    # the minimum between the neighbours of the best grid point, in log q
    lg = np.log10(np.where(grid > 0, grid, 1e-5))
    lo = lg[np.maximum(best - 1, 0)]
    hi = lg[np.minimum(best + 1, grid.size - 1)]
    q_m, s_m, t_m = _noise_refine(wz, unw, cnt, lo, hi, threads=threads)
    f_m = np.log(s_m) + t_m
    rows = np.arange(n_chan)
    better = f_m < nll[rows, best]
    q = np.where(better, q_m, grid[best])
    s = np.where(better, s_m, s_g[rows, best])
    a = s
    b = s * q / np.where(um[:, 0] > 0, um[:, 0], 1.0)
    var = b[:, None] * u
    var += a[:, None]
    return a, b, np.maximum(var, 1e-300, out=var)


#: Channels evaluated together by the noise fit's loops: their lines stay in the processor cache.
_NOISE_BLOCK = 32

#: Channels per block when :func:`_blocks` runs in threads: each numpy call of a block then lasts long enough
#: (~0.2 ms on 1801 lines) that the threads gain more than the interpreter lock's hand-offs cost (below
#: ~0.3 ms two threads lose, ``benchmarks/study_gil_handoff.py``); measured with :data:`_NOISE_THREAD_MIN_VALUES`.
_NOISE_THREAD_BLOCK = 128

#: Threads of :func:`_blocks` (fixed: the partition into blocks, not the machine, decides the work): 1, the
#: blocks in the calling thread. Since the bin sums by ``np.bincount`` and Newton's early end the fit's blocks
#: of :data:`_NOISE_THREAD_BLOCK` channels are bound by memory traffic (1.8 MB per array, beyond the cache),
#: so two threads share the bandwidth instead of the work. Measured 2026-12-08 (``chrt -f 10``, 2 cores, load
#: 9-10, one BLAS thread): the two 256-output fits of ``benchmarks/bench_noise_threads.py`` 53.7 ms wall and
#: CPU in one thread, 57.0 ms wall / 91.7 ms CPU in two; inside the default ``identify`` on the 256-output
#: file (30 alternating calls) 198.7 ms wall / 252.7 ms CPU with one, 197.8 / 285.8 with two
#: (``benchmarks/results/issue18_wide_s_wide14.txt``). The pool (two threads) stays for callers that set it.
_NOISE_THREADS = 1

#: Values (channels x lines) of a noise fit from which :func:`_blocks` runs its blocks in threads, in blocks of
#: :data:`_NOISE_THREAD_BLOCK`. Measured on the two 256-output fits of the default ``identify`` on the 256 x 1801
#: file of ``bench_refine.py`` (``benchmarks/bench_noise_threads.py``, 2026-12-07, 2 cores, one BLAS thread as
#: inside identify's ML stage, ``chrt -f 10``, load 12-14): one thread, blocks of 32, 97-103 ms wall; two
#: threads, blocks of 128, 70-75 ms wall (+25 % CPU); two threads, blocks of 32, 96-108 ms (their numpy calls,
#: ~50 us each, lose the time they gain on the interpreter lock's hand-offs). The 19-channel refit
#: (34 000 values) stays in one thread. A work-size rule: the same on any machine. It applies when
#: :data:`_NOISE_THREADS` is above 1 (by default not: measured again after the fit became twice as fast, there).
_NOISE_THREAD_MIN_VALUES = 400_000


def _blocks(fn: Callable[[int, int], None], n: int, threads: bool) -> None:
    """Call ``fn(i0, i1)`` for the blocks ``[i0, i1)`` of ``_NOISE_BLOCK`` items of ``0..n``.

    With ``threads`` (the fit holds at least :data:`_NOISE_THREAD_MIN_VALUES` values) and more than
    :data:`_NOISE_THREAD_BLOCK` items, blocks of that size run in a pool of ``_NOISE_THREADS`` threads
    (numpy releases the interpreter lock in its loops over the lines). Every block writes only its own
    rows, each computed by the same operations whatever block holds it (per-row reductions), so the
    result does not depend on the block size, the number of threads, their scheduling or the load of
    the machine, to the bit. The caller's ``np.errstate`` applies in the threads.
    """
    two = threads and _NOISE_THREADS > 1 and n > _NOISE_THREAD_BLOCK
    size = _NOISE_THREAD_BLOCK if two else _NOISE_BLOCK
    spans = [(i0, min(i0 + size, n)) for i0 in range(0, n, size)]
    if not two:
        for i0, i1 in spans:
            fn(i0, i1)
        return
    err = np.geterr()  # the caller's floating-point error handling holds in the threads too

    def run(i0: int, i1: int) -> None:
        with np.errstate(**err):
            fn(i0, i1)

    with ThreadPoolExecutor(_NOISE_THREADS, thread_name_prefix="ema-rig-noise") as pool:
        for done in [pool.submit(run, i0, i1) for i0, i1 in spans]:
            done.result()  # re-raises an error of the block


#: FRF values (lines x channels) of a :func:`segment_misfit` from which its segments' local fits run in
#: two threads: a value no data reach, so off. Below ~1 ms of fits a thread's start and hand-off cost more than
#: they save; above, in the default ``identify`` the test runs beside the caller's ML uncertainties and LSFD
#: (a second thread already), so a third only shares the two cores: measured on the 256-output file of
#: ``bench_refine.py`` (461 000 values, 30 alternating calls, ``chrt -f 10``, one BLAS thread, 2026-12-08)
#: 188.9 ms wall / 238.7 ms CPU with the test's two threads, 179.1 / 229.9 with one
#: (``benchmarks/results/issue18_wide_s_wide14.txt``). The two threads stay for callers that set it.
_MISFIT_THREAD_MIN_VALUES = 10**15


def _segments_in_two(fn: Callable[[int], None], work: NDArray[np.int64]) -> None:
    """Call ``fn(s)`` for every segment ``s`` (``work``: its size, shape (n_seg,)).

    From :data:`_MISFIT_THREAD_MIN_VALUES` in all, the segments are cut once where the cumulative
    work reaches half of it; the later part runs in a second thread. Each call writes only its own
    segment's lines, by the same operations in either thread: the result does not depend on the
    threads, their scheduling or the load, to the bit. The caller's ``np.errstate`` holds in both.
    """
    n = work.size
    if n < 2 or int(np.sum(work)) < _MISFIT_THREAD_MIN_VALUES:
        for s_i in range(n):
            fn(s_i)
        return
    cut = int(np.clip(np.searchsorted(np.cumsum(work), 0.5 * float(np.sum(work))) + 1, 1, n - 1))
    err = np.geterr()

    def later() -> None:
        with np.errstate(**err):
            for s_i in range(cut, n):
                fn(s_i)

    with ThreadPoolExecutor(1, thread_name_prefix="ema-rig-misfit") as pool:
        done = pool.submit(later)
        for s_i in range(cut):
            fn(s_i)
        done.result()  # re-raises an error of the later segments


def _noise_profile(wz: NDArray[np.float64], unw: NDArray[np.float64], cnt: NDArray[np.float64],
                   q: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Level ``s`` (> 0) and ``mean ln(1 + q |H|^2 / m)`` of every channel at its ratio ``q``, shape (n_chan,).

    The negative log-likelihood of :func:`fit_noise_model` profiled over the level is ``ln s + t``.
    """
    shape = q[:, None] * unw
    shape += 1.0
    s = np.sum(wz / shape, axis=1) / cnt
    np.log(shape, out=shape)
    t = np.sum(shape, axis=1) / cnt
    return np.where(s > 0, s, 1e-300), t


def _noise_grid(wz: NDArray[np.float64], unw: NDArray[np.float64], cnt: NDArray[np.float64],
                grid: NDArray[np.float64], threads: bool = False) -> tuple[NDArray[np.float64], ...]:
    """The best point of the profile on ``grid`` per channel, and the profile there.

    Lower and upper bounds of the profile at every grid point from binned sums
    (:func:`_noise_bounds`) leave the points where the minimum can lie; those are evaluated in
    double precision exactly as a full evaluation would, and the best of them is the best grid
    point (every other point's lower bound exceeds a value the profile reaches). ``threads``: the
    blocks of :func:`_blocks` in threads (the fit's work-size rule, :data:`_NOISE_THREAD_MIN_VALUES`).

    Returns
    -------
    s, t, nll : ndarray, shape (n_chan, n_grid)
        Level, log term and profile ``ln s + t`` (NaN where not evaluated in double precision).
    best : ndarray of int, shape (n_chan,)
        Index of the smallest profile value (the first of equal ones).
    """
    n_chan, n_g = wz.shape[0], grid.size
    # a channel with a NaN or inf line has no best point (its fit is NaN, as a full grid gives)
    finite = np.isfinite(np.sum(wz, axis=1)) & np.isfinite(np.sum(unw, axis=1))
    cand = _noise_bounds(wz, unw, cnt, grid, threads) & finite[:, None]
    s_g = np.full((n_chan, n_g), np.nan)
    t_g = np.full((n_chan, n_g), np.nan)
    rows, cols = np.nonzero(cand)

    def one(k0: int, k1: int) -> None:
        r, c = rows[k0:k1], cols[k0:k1]
        s_g[r, c], t_g[r, c] = _noise_profile(wz[r], unw[r], cnt[r], grid[c])

    _blocks(one, rows.size, threads)
    nll = np.log(s_g) + t_g
    best = np.argmin(np.where(np.isfinite(nll), nll, np.inf), axis=1)
    return s_g, t_g, nll, best


#: Sub-bins per octave of ``|H|^2 / m`` in :func:`_noise_bounds` (a power of 2: exact bin edges).
_BOUND_BINS = 4

#: Octaves below the largest ``|H|^2 / m`` that :func:`_noise_bounds` bins; smaller values share one
#: bin from 0 (there ``q |H|^2 / m < 1e8 * 2**-60``: the bounds are exact to rounding).
_BOUND_OCTAVES = 60


def _bin_sums(wz: NDArray[np.float64], unw: NDArray[np.float64], e_lo: int, n_b: int
              ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Per-bin sums of :func:`_noise_bounds`: ``(z, z u, z / u)`` and ``(1, u, 1 / u, ln u)``.

    Returns arrays of shape (n_chan, 3 n_b) and (n_chan, 4 n_b), the sums side by side; bin 0 holds
    the lines with ``u = 0`` (only ``z`` summed), bin 1 those below ``2**(e_lo - 1)``.
    """
    n_chan = wz.shape[0]
    kb = _BOUND_BINS
    pos = unw > 0
    all_pos = bool(np.all(pos))
    # bin of a positive u = mant 2**ex (mant in [0.5, 1), np.frexp): kb (ex - e_lo) + floor(2 kb mant) - kb + 2.
    # For a normal double of biased exponent E and mantissa bits M, ex = E - 1022 and floor(2 kb mant) =
    # kb + (the top log2(kb) bits of M), so kb ex + floor(2 kb mant) = (bits >> (52 - log2 kb)) - kb 1022 + kb:
    # the same integer read off the bits (subnormals, 0 and negative values land below bin 1, as with frexp)
    shift = 52 - (kb.bit_length() - 1)
    idx = np.right_shift(unw.view(np.int64), shift).astype(np.intp, copy=False)
    first = np.arange(n_chan, dtype=np.intp) * n_b
    idx += (first - (kb * 1022 - kb) - (kb * e_lo + kb - 2))[:, None]
    np.maximum(idx, (first + 1)[:, None], out=idx)  # values below the binned octaves: bin 1
    if not all_pos:
        np.copyto(idx, np.broadcast_to(first[:, None], idx.shape), where=~pos)
    m = n_chan * n_b
    n_v = idx.size
    flat = idx.ravel()
    # the summands of every line, one row each (contiguous): z, z u, z / u, u, 1 / u, ln u; v = 1 / u and
    # ln u of the positive u (0 where u = 0: those lines are in bin 0, whose sums for t, the line count
    # included, the bounds do not use)
    w3 = np.empty((6, n_chan, unw.shape[1]))
    w3[0] = wz
    np.multiply(wz, unw, out=w3[1])
    if all_pos:
        np.divide(1.0, unw, out=w3[4])
        np.log(unw, out=w3[5])
    else:
        np.divide(1.0, np.where(pos, unw, np.inf), out=w3[4])
        np.log(np.where(pos, unw, 1.0), out=w3[5])
    np.multiply(wz, w3[4], out=w3[2])
    w3[3] = unw
    w = w3.reshape(6, n_v)
    # each sum adds its lines' summands into their bins in line order (np.bincount)
    sums = np.empty((7, m))
    sums[3] = np.bincount(flat, minlength=m)  # the line count
    for k, row in enumerate((0, 1, 2, 4, 5, 6)):
        sums[row] = np.bincount(flat, w[k], minlength=m)
    sums3 = sums.reshape(7, n_chan, n_b).transpose(1, 0, 2)
    st_s = sums3[:, :3].reshape(n_chan, 3 * n_b)
    st_t = sums3[:, 3:].reshape(n_chan, 4 * n_b)
    return st_s, st_t


def _bin_coefficients(lo: NDArray[np.float64], hi: NDArray[np.float64], grid: NDArray[np.float64]
                      ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The coefficients of :func:`_noise_bounds`' linear bounds for bins ``[lo, hi]`` of ``u``, each shape (n_bins,).

    Returns arrays of shape (n_bins, 3, 2 n_grid) and (n_bins, 4, 2 n_grid): per bin the rows that
    multiply its sums ``(z, z u, z / u)`` and ``(1, u, 1 / u, ln u)``, the lower bounds at the grid
    points, then the upper ones. A bin's coefficients depend on its edges and the grid alone.
    """
    lo_, hi_, q = lo[:, None], hi[:, None], grid[None, :]
    n_b, n_g = lo.size, grid.size
    mid = 0.5 * (lo_ + hi_)
    qm = 1.0 + q * mid
    den = (1.0 + q * lo_) * (1.0 + q * hi_)
    wdt = np.where(hi_ > lo_, hi_ - lo_, 1.0)
    zero = np.zeros((n_b, n_g))
    # in u (where q u <= 1 at the bin's centre): 1 / (1 + q u) convex, ln(1 + q u) concave; lower
    # bound of s the tangent at the centre, upper the chord; of t the chord, upper the tangent
    su_lo = ((1.0 + 2.0 * q * mid) / qm**2, -q / qm**2)
    su_hi = ((1.0 + q * lo_ + q * hi_) / den, -q / den)
    h_sl = (np.log1p(q * hi_) - np.log1p(q * lo_)) / wdt
    tu_lo = (np.log1p(q * lo_) - lo_ * h_sl, h_sl)
    tu_hi = (np.log1p(q * mid) - mid * (q / qm), q / qm)
    # in v = 1 / u (where q u > 1): 1 / (1 + q u) = v / (q + v) and ln(1 + q u) = ln u + ln(q + v),
    # both concave in v: lower bounds the chord on [1 / hi, 1 / lo], upper the tangent at the centre
    va, vb = 1.0 / np.where(hi_ > 0, hi_, 1.0), 1.0 / np.where(lo_ > 0, lo_, 1.0)
    vm = 0.5 * (va + vb)
    dq = (q + va) * (q + vb)
    sv_lo = (va * vb / dq, q / dq)
    sv_hi = (vm**2 / (q + vm) ** 2, q / (q + vm) ** 2)
    p_sl = (np.log(q + vb) - np.log(q + va)) / np.where(vb > va, vb - va, 1.0)
    tv_lo = (np.log(q + va) - va * p_sl, p_sl)
    tv_hi = (np.log(q + vm) - vm / (q + vm), 1.0 / (q + vm))
    use_v = (q * mid > 1.0) & (lo_ > 0)
    one = np.ones((n_b, n_g))

    def coef(c_u: tuple[NDArray[np.float64], ...], c_v: tuple[NDArray[np.float64], ...], with_log: bool
             ) -> NDArray[np.float64]:
        rows_ = [np.where(use_v, c_v[0], c_u[0]), np.where(use_v, zero, c_u[1]), np.where(use_v, c_v[1], zero)]
        if with_log:
            rows_.append(np.where(use_v, one, zero))
        return np.stack(rows_, axis=1)

    c_s = np.concatenate([coef(su_lo, sv_lo, False), coef(su_hi, sv_hi, False)], axis=2)
    c_t = np.concatenate([coef(tu_lo, tv_lo, True), coef(tu_hi, tv_hi, True)], axis=2)
    return c_s, c_t


#: The coefficients of :func:`_bin_coefficients` already formed, by (grid, octave): an octave's ``_BOUND_BINS``
#: bins (key its exponent) or the bin below the binned octaves (key ``("below", e_lo)``). They depend on the
#: grid and the bin edges alone (fixed binary fractions), so a value taken from here is the one formed anew,
#: to the bit; at most :data:`_BOUND_CACHE_SIZE` entries (22 kB each) are kept.
_BOUND_CACHE: dict[tuple[bytes, int | tuple[str, int]], tuple[NDArray[np.float64], NDArray[np.float64]]] = {}

#: Entries of :data:`_BOUND_CACHE` (octaves x grids) at most: a fit touches e_hi - e_lo + 2 <= 62 of them.
_BOUND_CACHE_SIZE = 512


def _bound_coefficients(e_lo: int, e_hi: int, grid: NDArray[np.float64]
                        ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The matrices of :func:`_noise_bounds`' two products, shape (3 n_b, 2 n_grid) and (4 n_b, 2 n_grid).

    Rows ``k n_b + b`` multiply sum ``k`` of bin ``b`` (bin 0: ``u = 0``, only ``z`` enters; bin 1:
    ``0 < u < 2**(e_lo - 1)``; then ``_BOUND_BINS`` per octave ``e_lo..e_hi``), columns the lower
    bounds at the grid points, then the upper ones. The bins' coefficients are formed once per octave
    (:data:`_BOUND_CACHE`): those of the octaves the lines of one fit share with another's are not formed
    again (the completeness test fits the noise of all channels, then of those whose lines it left out).
    """
    kb = _BOUND_BINS
    g_key = grid.tobytes()
    keys: list[int | tuple[str, int]] = [("below", e_lo), *range(e_lo, e_hi + 1)]
    # the entries this call uses, held here: another thread may empty the cache meanwhile
    have = {k: hit for k in keys if (hit := _BOUND_CACHE.get((g_key, k))) is not None}
    missing = [k for k in keys if k not in have]
    if missing:
        frac = np.arange(kb) / (2 * kb) + 0.5
        lo_l: list[NDArray[np.float64]] = []
        hi_l: list[NDArray[np.float64]] = []
        for k in missing:
            if isinstance(k, tuple):
                lo_l.append(np.zeros(1))
                hi_l.append(np.array([np.ldexp(0.5, e_lo)]))
            else:
                lo_l.append(np.ldexp(frac, k))
                hi_l.append(np.ldexp(frac + 0.5 / kb, k))
        c_s, c_t = _bin_coefficients(np.concatenate(lo_l), np.concatenate(hi_l), grid)
        c_s.setflags(write=False)  # shared by later fits
        c_t.setflags(write=False)
        if len(_BOUND_CACHE) + len(missing) > _BOUND_CACHE_SIZE:
            _BOUND_CACHE.clear()
        i = 0
        for k, lo_k in zip(missing, lo_l, strict=True):
            have[k] = _BOUND_CACHE[(g_key, k)] = (c_s[i:i + lo_k.size], c_t[i:i + lo_k.size])
            i += lo_k.size
    n_g = grid.size
    # bin 0 (u = 0): exactly z in s; no line in t
    first_s = np.zeros((1, 3, 2 * n_g))
    first_s[0, 0] = 1.0
    parts = [have[k] for k in keys]
    c_s = np.concatenate([first_s, *(p[0] for p in parts)])
    c_t = np.concatenate([np.zeros((1, 4, 2 * n_g)), *(p[1] for p in parts)])
    n_b = c_s.shape[0]
    return c_s.transpose(1, 0, 2).reshape(3 * n_b, 2 * n_g), c_t.transpose(1, 0, 2).reshape(4 * n_b, 2 * n_g)


def _noise_bounds(wz: NDArray[np.float64], unw: NDArray[np.float64], cnt: NDArray[np.float64],
                  grid: NDArray[np.float64], threads: bool = False) -> NDArray[np.bool_]:
    """The grid points at which a channel's profile can be smallest, shape (n_chan, n_grid), bool
    (``threads``: the bin sums' blocks in threads, see :func:`_blocks`).

    The lines of each channel are binned by ``u = |H|^2 / m`` (``_BOUND_BINS`` bins per octave,
    edges exact binary fractions); per bin the sums of ``z``, ``z u``, ``z / u`` and of ``1``,
    ``u``, ``1 / u``, ``ln u`` are formed once (:func:`_bin_sums`). Where ``q u <= 1`` at the
    bin's centre, ``1 / (1 + q u)`` is convex in ``u`` and ``ln(1 + q u)`` concave; where
    ``q u > 1``, ``1 / (1 + q u) = v / (q + v)`` and ``ln(1 + q u) - ln u = ln(q + v)`` are
    concave in ``v = 1 / u``. On a bin each function lies between its tangent at the bin's centre
    and its chord, both linear in ``u`` (or ``v``), so the binned sums give a lower and an upper
    bound of the profile ``ln s + t`` at every grid point (two matrix products, no pass over the
    lines). The bounds differ by second order in the bin width, most where ``q u ~ 1`` (of order
    1e-4 of the profile where the lines lie far from it, e.g. the flat profile of proportional
    noise at large ``q``). A point whose lower bound exceeds the smallest upper bound of its
    channel (plus 1e-9 for rounding) cannot be the minimum of the profile evaluated in double
    precision, which is off by less than 1e-12; lines with ``u = 0`` enter exactly.

    Rounding: the terms of the sums for ``s`` are positive or (the tangent in ``u``) at most four
    times their positive sum per bin, so the products are exact to 1e-12 relative and the bounds
    of ``s`` are widened by 1e-10 relative; the terms for ``t`` (logarithms below 100 in
    magnitude) are exact to 1e-13 per line and the bounds of the mean ``t`` widened by 1e-10.
    """
    n_chan, n_l = wz.shape
    n_g = grid.size
    kb = _BOUND_BINS
    u_max = float(np.max(unw)) if unw.size else 0.0
    # the bounds need z >= 0 and finite |H|^2 (else every point stays: the full grid, as before)
    if not n_l or u_max <= 0 or not np.isfinite(u_max) or not bool(np.all(wz >= 0)):
        return np.ones((n_chan, n_g), bool)
    e_hi = int(np.frexp(u_max)[1])
    e_min = int(np.frexp(np.min(unw, where=unw > 0, initial=u_max))[1])
    e_lo = max(e_min, e_hi - _BOUND_OCTAVES)
    n_b = 2 + (e_hi - e_lo + 1) * kb  # bin 0: u = 0, bin 1: 0 < u < 2**(e_lo - 1), then kb per octave
    st_s = np.empty((n_chan, 3 * n_b))
    st_t = np.empty((n_chan, 4 * n_b))
    def sums(i0: int, i1: int) -> None:
        st_s[i0:i1], st_t[i0:i1] = _bin_sums(wz[i0:i1], unw[i0:i1], e_lo, n_b)

    _blocks(sums, n_chan, threads)
    c_s, c_t = _bound_coefficients(e_lo, e_hi, grid)
    s_b = st_s @ c_s  # (n_chan, 2 n_g): lower | upper
    t_b = st_t @ c_t
    tol = 1e-10
    cn = cnt[:, None]
    with np.errstate(divide="ignore", invalid="ignore"):
        f_lo = np.log(s_b[:, :n_g] * (1.0 - tol) / cn) + t_b[:, :n_g] / cn - tol
        f_hi = np.log(s_b[:, n_g:] * (1.0 + tol) / cn) + t_b[:, n_g:] / cn + tol
    f_hi = np.where(np.isnan(f_hi), np.inf, f_hi)
    top = np.min(f_hi, axis=1)
    alive = np.logical_not(f_lo > (top + 1e-9 * (1.0 + np.abs(top)))[:, None])  # NaN stays alive
    return np.asarray(alive, dtype=bool)


def _noise_refine(wz: NDArray[np.float64], unw: NDArray[np.float64], cnt: NDArray[np.float64],
                  lo: NDArray[np.float64], hi: NDArray[np.float64], max_iter: int = 60, *, threads: bool = False
                  ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """The ratio ``q`` of a local minimum of the profile between ``10**lo`` and ``10**hi``, shape (n_chan,),
    and the level ``s`` and log term ``t`` there (:func:`_noise_profile`, block by block while the
    lines are in the cache).

    Newton's method on the profile's derivative in ``x = ln q`` (first and second derivative in
    closed form, no logarithms), kept inside a bracket where the derivative changes sign from
    negative to positive (bisection when a step leaves it): it converges to the minimum to rounding
    in a few steps. A channel without such a bracket takes the end the profile falls towards (the
    caller keeps the best grid point when that is lower). Stops after a step below :data:`_NEWTON_DONE` inside
    the bracket, when the step is below 1e-13 or the bracket narrower than 1e-12 in ``x``, after ``max_iter``
    steps at most (a work limit).
    ``threads``: the blocks in threads (see :func:`_blocks`).
    """
    ln10 = np.log(10.0)
    q, s, t = np.empty(wz.shape[0]), np.empty(wz.shape[0]), np.empty(wz.shape[0])

    def one(i0: int, i1: int) -> None:
        x = _newton_block(wz[i0:i1], unw[i0:i1], cnt[i0:i1], lo[i0:i1] * ln10, hi[i0:i1] * ln10, max_iter)
        q[i0:i1] = np.exp(x)
        s[i0:i1], t[i0:i1] = _noise_profile(wz[i0:i1], unw[i0:i1], cnt[i0:i1], q[i0:i1])

    _blocks(one, wz.shape[0], threads)
    return q, s, t


#: A Newton step of :func:`_newton_block` (in ``x = ln q``) below this, taken inside the bracket, ends the channel's
#: iteration: Newton's method converges quadratically near a simple minimum (Dennis & Schnabel, *Numerical Methods
#: for Unconstrained Optimization*, 1983, thm. 2.4.3: error after a step of size ``d`` of order ``d**2``), so the
#: step that follows would be ~1e-14, below the rounding of the derivative sums; measured on the noise fits of the
#: 256-output file of ``bench_refine.py``: the variance within 3e-12 (relative) of the iteration to a step below
#: 1e-13, one to two passes over the lines fewer per channel.
_NEWTON_DONE = 1e-7


def _newton_block(wz: NDArray[np.float64], unw: NDArray[np.float64], cnt: NDArray[np.float64],
                  a: NDArray[np.float64], b: NDArray[np.float64], max_iter: int) -> NDArray[np.float64]:
    """:func:`_noise_refine` of a block of channels, in ``x = ln q`` (bracket ``a``..``b``)."""

    n_b, n_l = wz.shape
    r_buf, t_buf, w_buf, u_buf = (np.empty((n_b, n_l)) for _ in range(4))

    def derivs(x: NDArray[np.float64], rows: NDArray[np.intp], second: bool = True
               ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        # f = ln S + T with S = sum wz r, r = 1 / (1 + q u), T = mean ln(1 + q u); t = 1 - r = dT_i/dx
        # (the arithmetic of every line as before, in buffers reused from call to call)
        k = rows.size
        full = k == n_b
        r, t, wr = r_buf[:k], t_buf[:k], w_buf[:k]
        np.multiply(np.exp(x)[:, None], unw if full else unw[rows], out=r)
        r += 1.0
        np.divide(1.0, r, out=r)  # 1 / r: the same numbers as np.reciprocal, in the vectorised division loop
        np.subtract(1.0, r, out=t)
        np.multiply(wz if full else wz[rows], r, out=wr)
        c = cnt if full else cnt[rows]
        s0 = np.sum(wr, axis=1)
        wr *= t
        s1 = -np.sum(wr, axis=1)
        t1 = np.sum(t, axis=1) / c
        s0 = np.where(s0 > 0, s0, 1e-300)
        if not second:
            return s1 / s0 + t1, np.zeros(0)
        v = u_buf[:k]
        np.multiply(2.0, t, out=v)
        v -= 1.0
        np.multiply(wr, v, out=v)
        s2 = np.sum(v, axis=1)
        t *= r
        t2 = np.sum(t, axis=1) / c
        return s1 / s0 + t1, s2 / s0 - (s1 / s0) ** 2 + t2

    rows = np.arange(wz.shape[0])
    g_a, _ = derivs(a, rows, False)
    g_b, _ = derivs(b, rows, False)
    ok = (g_a < 0) & (g_b > 0)
    x = np.where(ok, 0.5 * (a + b), np.where(g_a < 0, b, a))
    act = np.flatnonzero(ok)
    lo_x, hi_x = a.copy(), b.copy()
    for _ in range(max_iter):
        if act.size == 0:
            break
        g, h = derivs(x[act], act)
        lo_x[act] = np.where(g < 0, x[act], lo_x[act])
        hi_x[act] = np.where(g > 0, x[act], hi_x[act])
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.where(h > 0, -g / h, np.inf)
        xn = x[act] + step
        inside = np.isfinite(xn) & (xn > lo_x[act]) & (xn < hi_x[act])
        xn = np.where(inside, xn, 0.5 * (lo_x[act] + hi_x[act]))
        # a zero derivative or a step below rounding: x is the minimum (kept, not bisected)
        stay = (g == 0) | (np.abs(step) < 1e-13)
        x[act] = np.where(stay, x[act], xn)
        # a Newton step below _NEWTON_DONE inside the bracket: the error after it is of its square (quadratic
        # convergence), below rounding
        done = stay | (inside & (np.abs(step) < _NEWTON_DONE))
        act = act[~(done | (hi_x[act] - lo_x[act] < 1e-12))]
    return x


@dataclass(frozen=True, slots=True, eq=False)
class MisfitTest:
    """Result of :func:`segment_misfit`, one entry per band segment.

    Parameters
    ----------
    freq_lower, freq_upper : ndarray, shape (n_seg,)
        First and last line of each segment [Hz].
    ratio : ndarray, shape (n_seg,)
        ``chi2 / dof`` of the segment over all channels (about 1 when the model explains the data
        to the noise estimate).
    worst_ratio : ndarray, shape (n_seg,)
        The largest per-channel ``chi2 / dof`` of the segment.
    p_value : ndarray, shape (n_seg,)
        Smallest p-value of the segment's tests (all channels pooled, each channel), unadjusted.
    dof : ndarray, shape (n_seg,)
        Degrees of freedom of the pooled test.
    failed : ndarray of bool, shape (n_seg,)
        A test of the segment has ``p < alpha`` and its ratio is at least ``misfit_ratio``.
    alpha : float
        Level of each single test (family-wise ``p_value`` / number of tests).
    noise_source : str
        ``'coherence'`` or ``'estimated'`` (``a + b |H|^2`` per channel fitted to the residual, its
        level per channel the median over the segments).
    edge : ndarray of bool, shape (n_seg,)
        Failing segments at a band edge without a mode of their own or whose excess lies mostly in
        their outer half: a mode outside the band (not counted in ``failed``).
    variance : ndarray, shape (n_out * n_in, n_freq), or None
        The noise variance tested against (``inf`` where a line carries no information).
    """

    freq_lower: NDArray[np.float64]
    freq_upper: NDArray[np.float64]
    ratio: NDArray[np.float64]
    worst_ratio: NDArray[np.float64]
    p_value: NDArray[np.float64]
    dof: NDArray[np.float64]
    failed: NDArray[np.bool_]
    alpha: float
    noise_source: str
    edge: NDArray[np.bool_] = field(default_factory=lambda: np.zeros(0, bool))
    variance: NDArray[np.float64] | None = field(default=None, repr=False)

    @property
    def passed(self) -> bool:
        """True when no segment fails."""
        return not bool(np.any(self.failed))

    def failing(self) -> list[tuple[float, float]]:
        """``(freq_lower, freq_upper)`` [Hz] of every failing segment."""
        return [(float(a), float(b)) for a, b, f in zip(self.freq_lower, self.freq_upper, self.failed, strict=True)
                if f]

    def describe(self, which: str = "failed") -> str:
        """The failing (``which='failed'``) or edge segments in one clause (frequencies and ratios)."""
        flags = self.failed if which == "failed" else self.edge
        parts = [f"{a:.6g}..{b:.6g} Hz (residual {max(r, w):.3g} x the noise)"
                 for a, b, r, w, f in zip(self.freq_lower, self.freq_upper, self.ratio, self.worst_ratio,
                                          flags, strict=True) if f]
        return ", ".join(parts)


def segment_edges(freq: NDArray[np.float64], natural_freq: ArrayLike, damping_ratio: ArrayLike, *,
                  criteria: CompletenessCriteria = COMPLETENESS_CRITERIA, chained: bool = True) -> NDArray[np.intp]:
    """Line indices where the band segments start, shape (n_seg + 1,) (the last is ``n_freq``).

    Each mode gets a core of the lines within ``segment_hbw`` half-power half-bandwidths
    ``zeta f_n`` of its natural frequency (at least ``min_segment_lines`` lines); modes whose
    natural frequencies lie inside each other's core share one, other neighbours' cores are cut at
    the midpoint between them. The lines between cores are cut into equal segments no wider than
    the median core. With ``chained=False`` a mode joins a core only when it lies inside the core of
    every mode already in it (``True``: of the nearest one, so that a chain of modes, each inside its
    neighbour's core, makes one segment of any length).
    """
    f = np.asarray(freq, dtype=np.float64)
    n = f.size
    df = float(np.median(np.diff(f))) if n > 1 else 1.0
    fn = np.atleast_1d(np.asarray(natural_freq, dtype=np.float64))
    zeta = np.atleast_1d(np.asarray(damping_ratio, dtype=np.float64))
    order = np.argsort(fn)
    fn, zeta = fn[order], zeta[order]
    half_a = np.maximum(criteria.segment_hbw * np.maximum(np.abs(zeta) * fn, df), 0.5 * criteria.min_segment_lines * df)
    # the scalar arithmetic below in Python floats (the same IEEE operations as on numpy's scalars, at a
    # tenth of their cost)
    fl, half = fn.tolist(), half_a.tolist()
    groups: list[list[int]] = []
    for k in range(fn.size):
        if groups and all(fl[k] - fl[j] < max(half[k], half[j]) for j in groups[-1][-1 if chained else 0:]):
            groups[-1].append(k)
        else:
            groups.append([k])
    lo = [min(fl[g[0]] - half[g[0]], min(fl[i] - half[i] for i in g)) for g in groups]
    hi = [max(fl[i] + half[i] for i in g) for g in groups]
    centre_lo = [fl[g[0]] for g in groups]
    centre_hi = [fl[g[-1]] for g in groups]
    # where the cores' ends fall among the lines (searchsorted: 0..n)
    ends = np.searchsorted(f, [
        x for j in range(len(groups)) for x in (
            lo[j] if j == 0 else max(lo[j], 0.5 * (centre_hi[j - 1] + centre_lo[j])),
            hi[j] if j == len(groups) - 1 else min(hi[j], 0.5 * (centre_hi[j] + centre_lo[j + 1])))],
        "left").tolist()
    cores: list[tuple[int, int]] = []
    for j in range(len(groups)):
        i0, i1 = ends[2 * j], ends[2 * j + 1]
        if cores:
            i0 = max(i0, cores[-1][1])
        if i1 > i0:
            cores.append((i0, i1))
    width = max(int(np.median([b - a for a, b in cores])) if cores else n, criteria.min_segment_lines)
    edges = [0]
    for a, b in [*cores, (n, n)]:
        gap = a - edges[-1]
        if gap > 0:
            k = int(np.ceil(gap / width))
            edges += [edges[-1] + int(round(gap * (j + 1) / k)) for j in range(k)]
        if b > edges[-1]:
            edges.append(b)
    out = sorted(set(edges))
    # a segment too short for its local fit joins its shorter neighbour
    while len(out) > 2:
        sizes = np.diff(out)
        j = int(np.argmin(sizes))
        if sizes[j] >= criteria.min_segment_lines:
            break
        if j == 0:
            del out[1]
        elif j == len(sizes) - 1:
            del out[-2]
        else:
            del out[j if sizes[j - 1] <= sizes[j + 1] else j + 1]
    return np.asarray(out, dtype=np.intp)


def segment_pole_columns(freq: ArrayLike, poles: ArrayLike, power: int) -> NDArray[np.complex128] | None:
    """The pole columns of ``poles`` on every line, as :func:`segment_misfit` forms them (its ``pole_columns``).

    :func:`~ema_rig.identification.modal.modal_basis` without residual terms at ``j 2 pi freq``.

    Parameters
    ----------
    freq : array_like, shape (n_freq,)
        Lines [Hz].
    poles : array_like, shape (n_modes,), complex
        Poles [rad/s].
    power : int
        Power of ``j omega`` of the FRF form (0 receptance, 1 mobility, 2 accelerance).

    Returns
    -------
    ndarray, shape (n_freq, 2 n_modes), complex, or None
        None without a pole.
    """
    lam = np.atleast_1d(np.asarray(poles, dtype=np.complex128))
    if not lam.size:
        return None
    jw = np.asarray(2j * np.pi * np.asarray(freq, dtype=np.float64), dtype=np.complex128)
    return modal_basis(jw, lam, power, residuals=False)


#: The local fits of :func:`segment_misfit` by segment, for a later call on the same lines and poles (its
#: ``segment_fits``): key (the poles' bytes, number of lines, first line, line after the last), value
#: (|residual|^2 and |model|^2 of the segment's lines, shape (n_chan, lines), the fit's real parameters per
#: channel, the lines fitted, the segment's own modes).
SegmentFits = dict[tuple[bytes, int, int, int], tuple[NDArray[np.float64], NDArray[np.float64], float, float, float]]


def segment_misfit(
    freq: NDArray[np.float64],
    frf: NDArray[np.complex128],
    poles: ArrayLike,
    *,
    power: int = 2,
    coherence: NDArray[np.float64] | None = None,
    n_averages: float | None = None,
    variance: NDArray[np.float64] | None = None,
    edges: ArrayLike | None = None,
    criteria: CompletenessCriteria = COMPLETENESS_CRITERIA,
    pole_columns: NDArray[np.complex128] | None = None,
    segment_fits: SegmentFits | None = None,
) -> MisfitTest:
    """Do given poles explain the FRFs to the noise? A chi-square test per band segment and channel.

    Each segment (:func:`segment_edges`) is fitted on its own lines by least squares with the
    pole-residue basis (:func:`~ema_rig.identification.modal.pole_residue_basis`) of the poles in
    and next to it (residues free per channel) and a complex polynomial of degree up to
    ``criteria.poly_degree`` per channel that stands for the modes farther away and outside the
    band; the residual is compared with the noise estimate. A local misfit around a peak is then a
    mode the poles lack, not the compromise of one global fit.

    Parameters
    ----------
    freq : ndarray, shape (n_freq,)
        Lines [Hz].
    frf : ndarray, shape (n_out, n_in, n_freq), complex
        Measured FRFs.
    poles : array_like, shape (n_modes,), complex
        The model's poles [rad/s], ``Im > 0``: they set the segments and the local fits.
    power : int, optional
        Form of the FRFs: 0 receptance, 1 mobility, 2 accelerance (default).
    coherence : ndarray, shape (n_out, n_in, n_freq), optional
        Ordinary coherence; with it the noise variance is :func:`coherence_variance` of the model
        with ``n_d - 1`` averages (an H1 estimate from random excitation; ``n_averages`` unknown: 1).
        Without it the noise is ``a + b |H|^2`` per channel (:func:`fit_noise_model`) fitted to the
        residual, the failing (channel, segment) blocks left out and the fit repeated (at most
        three times).
    n_averages : float, optional
        Averages of the FRF estimate.
    variance : ndarray, shape (n_out * n_in, n_freq), optional
        A noise variance to test against (e.g. the ``variance`` of an earlier test of the full
        model, to ask whether a mode is needed); default estimated as above.
    edges : array_like of int, optional
        Line indices where the segments start, ending with ``n_freq`` (default
        :func:`segment_edges` of the poles).
    criteria : CompletenessCriteria, optional
        Level, misfit ratio and segment width (:data:`~ema_rig.identification.criteria.COMPLETENESS_CRITERIA`).
    pole_columns : ndarray, shape (n_freq, 2 n_modes), complex, optional
        :func:`~ema_rig.identification.modal.modal_basis` of ``poles`` on ``freq`` without residual columns,
        when the caller has it (e.g. its rows of a larger set of lines: the same numbers); default formed here.
    segment_fits : dict, optional
        The local fits of an earlier call on the same ``freq``, ``frf``, ``power``, ``pole_columns`` and
        criteria (:data:`SegmentFits`): a segment of the same lines and poles is taken from it instead of
        being fitted again (the same numbers), and the segments fitted here are added to it.

    Returns
    -------
    MisfitTest

    Notes
    -----
    For complex Gaussian errors of variance ``v`` per line, ``2 |e|^2 / v`` is chi-square with 2
    dof. A segment of ``L`` lines and ``C`` channels whose local fit holds ``P`` real parameters per
    channel (2 per pole, ``2 (degree + 1)`` for the polynomial) and ``m`` modes of its own (their
    poles, 2 each, were estimated on these lines) gives ``chi2 = sum 2 |e|^2 / v`` with
    ``(2 L - P) C - 2 m`` dof, one channel ``2 L - P``. A test fails when
    ``p < alpha = p_value / (n_seg (C + 1))`` (Bonferroni) and its ``chi2 / dof`` is at least
    ``misfit_ratio``.
    """
    # the chi-square survival function itself (scipy.stats.chi2.sf is this after its argument checks,
    # which cost a third of a small test's time; dof >= 1 and statistics >= 0 here)
    from scipy.special import chdtrc

    f = np.asarray(freq, dtype=np.float64)
    y = np.asarray(frf).reshape(-1, f.size)
    lam = np.atleast_1d(np.asarray(poles, dtype=np.complex128))
    fn = np.abs(lam) / (2 * np.pi)
    ok = np.all(np.isfinite(y), axis=0) & (f > 0 if power < 2 else np.ones(f.size, bool))
    n_chan = y.shape[0]
    edges = (segment_edges(f, fn, -lam.real / np.maximum(np.abs(lam), 1e-300), criteria=criteria)
             if edges is None else np.asarray(edges, dtype=np.intp))
    n_seg = edges.size - 1
    # the pole columns on every line, formed once: each segment's fit takes its lines' rows and its poles'
    # columns (the numbers pole_residue_basis forms on those lines, before the columns are scaled)
    if pole_columns is None:
        pole_columns = segment_pole_columns(f, lam, power)
    # |residual|^2 and |model|^2 of every line (0 on lines left out), formed segment by segment
    resid2 = np.zeros(y.shape)
    model2 = np.zeros(y.shape)
    n_par = np.zeros(n_seg)  # real parameters per channel of each segment's local fit
    lines = np.zeros(n_seg)
    m_seg = np.zeros(n_seg)

    poles_key = lam.tobytes()

    def fit_segment(s_i: int) -> None:
        i0, i1 = int(edges[s_i]), int(edges[s_i + 1])
        key = (poles_key, f.size, i0, i1)
        known = None if segment_fits is None else segment_fits.get(key)
        if known is not None:  # the same local fit, formed by an earlier call
            resid2[:, i0:i1], model2[:, i0:i1], n_par[s_i], lines[s_i], m_seg[s_i] = known
            return
        fit_lines(s_i, i0, i1)
        if segment_fits is not None:  # views of this call's arrays, never written after the fits
            segment_fits[key] = (resid2[:, i0:i1], model2[:, i0:i1], n_par[s_i], lines[s_i], m_seg[s_i])

    def fit_lines(s_i: int, i0: int, i1: int) -> None:
        sel = np.arange(i0, i1)[ok[i0:i1]]
        n_l = sel.size
        idx: NDArray[np.intp] | slice = slice(i0, i1) if n_l == i1 - i0 else sel
        lines[s_i] = n_l
        if n_l == 0:
            return
        # the modes of the segment and of its neighbourhood (one segment width each side), nearest
        # first, as many as the lines carry with the polynomial; the rest the polynomial stands for
        lo, hi = f[sel[0]], f[sel[-1]]
        width = max(hi - lo, 0.0)
        near = np.flatnonzero((fn >= lo - width) & (fn <= hi + width))
        near = near[np.argsort(np.abs(fn[near] - 0.5 * (lo + hi)), kind="stable")]
        deg = max(min(criteria.poly_degree, n_l // 4 - 1), -1)
        n_max = max((2 * n_l - 2 * (deg + 1) - 8) // 2, 0)
        near = np.sort(near[:n_max])
        m_seg[s_i] = int(np.sum((fn >= lo) & (fn <= hi)))
        cols = []
        if near.size and pole_columns is not None:
            cb = np.ascontiguousarray(pole_columns[idx][:, np.concatenate([near, lam.size + near])])
            cols.append(unit_real_basis(cb)[0])
        if deg >= 0:
            x = f[idx] - 0.5 * (lo + hi)
            x = x / max(float(np.max(np.abs(x))), 1e-300)
            v = np.vander(x, deg + 1, increasing=True)  # (n_l, deg + 1)
            poly = np.zeros((2 * n_l, 2 * (deg + 1)))
            poly[0::2, : deg + 1] = v
            poly[1::2, deg + 1 :] = v
            cols.append(poly)
        yv = np.ascontiguousarray(y[:, idx]).view(np.float64)  # (n_chan, 2 n_l), Re/Im interleaved
        if cols:
            basis = np.concatenate(cols, axis=1)
            u, sv, _vt = thin_svd(basis)  # numpy's SVD, the same numbers
            keep = sv > np.finfo(float).eps * max(basis.shape) * sv[0]
            q = u[:, keep]
            fit = (yv @ q) @ q.T
            n_par[s_i] = int(keep.sum())
        else:
            fit = np.zeros_like(yv)
        model2[:, idx] = np.abs(fit.view(np.complex128)) ** 2
        fit -= yv
        resid2[:, idx] = np.abs(fit.view(np.complex128)) ** 2  # |y - fit| = |fit - y|

    _segments_in_two(fit_segment, np.diff(edges) * n_chan)

    dof_c = np.maximum(2 * lines - n_par, 1.0)  # per channel
    alpha = criteria.p_value / max(n_seg * (n_chan + 1), 1)

    def test(var: NDArray[np.float64], known: tuple[NDArray[np.float64], NDArray[np.float64]] | None = None
             ) -> tuple[NDArray[np.float64], ...]:
        # lines with an infinite variance carry no information: neither statistic nor dof;
        # known: chi2 and p-value per channel and segment already formed with every ok line
        if known is None:
            use = ok & np.isfinite(var)
            z = np.where(use, 2.0 * resid2 / np.where(use, var, 1.0), 0.0)
            chi_c = np.add.reduceat(z, edges[:-1], axis=1)  # (n_chan, n_seg)
            n_l = np.add.reduceat(use.astype(np.float64), edges[:-1], axis=1)
            d_c = np.maximum(2 * n_l - n_par, 1.0)
            p_c = chdtrc(d_c, chi_c)
        else:
            chi_c, p_c = known
            n_l = np.broadcast_to(lines, chi_c.shape)
            d_c = np.broadcast_to(dof_c, chi_c.shape)
        d_p = np.maximum(np.sum(2 * n_l - n_par, axis=0) - 2 * m_seg, 1.0)
        chi_p = chi_c.sum(axis=0)
        r_c, r_p = chi_c / d_c, chi_p / d_p
        p_p = chdtrc(d_p, chi_p)
        fail = ((p_p < alpha) & (r_p >= criteria.misfit_ratio)) | np.any(
            (p_c < alpha) & (r_c >= criteria.misfit_ratio), axis=0)
        return (r_p, r_c.max(axis=0), np.minimum(p_p, p_c.min(axis=0)), np.asarray(fail, dtype=bool), d_p)

    if variance is not None:
        var = np.asarray(variance, dtype=np.float64).reshape(n_chan, -1)
        source = "given"
        r_p, r_w, p, fail, dof_p = test(var)
    elif coherence is not None:
        coh = np.asarray(coherence, dtype=np.float64).reshape(n_chan, -1)
        n_d = float(max(n_averages - 1, 1)) if n_averages else 1.0
        cv = coherence_variance(model2, coh, n_d)
        # a coherence of 1 (an analyser writes 1, or more, where it has no estimate) carries no
        # information on the noise: such lines are left out of the test
        good = np.isfinite(cv) & (cv > 0) & (coh < 1.0)
        floor = 1e-12 * (float(np.max(cv[good])) if np.any(good) else 1.0)
        var = np.where(good, np.maximum(cv, floor), np.inf)
        source = "coherence"
        r_p, r_w, p, fail, dof_p = test(var)
    else:
        # a + b |H|^2 per channel fitted to the residual; the (channel, segment) blocks that fail are
        # left out and the fit repeated (at most three times): a missing mode or a neighbour outside
        # the band must not raise the noise estimate of the other lines
        source = "estimated"
        use = np.broadcast_to(ok, resid2.shape).copy()
        a, b = np.zeros(n_chan), np.zeros(n_chan)
        var = np.empty(resid2.shape)
        chi_c, p_c = np.empty((n_chan, n_seg)), np.empty((n_chan, n_seg))
        redo = np.arange(n_chan)
        for _ in range(3):
            # the fit is per channel: only the channels whose lines changed are fitted again, and
            # only their variance (a + b |H|^2, floored at 1e-300), chi2 and p-values are formed anew
            rows: NDArray[np.intp] | slice = slice(None) if redo.size == n_chan else redo
            a[redo], b[redo], var[rows] = fit_noise_model(resid2[rows], model2[rows], mask=use[rows])
            z = np.where(ok, 2.0 * resid2[rows] / var[rows], 0.0)
            chi_c[rows] = np.add.reduceat(z, edges[:-1], axis=1)
            p_c[rows] = chdtrc(dof_c, chi_c[rows])
            bad = (p_c < alpha) & (chi_c / dof_c >= criteria.misfit_ratio)
            keep = ok & np.logical_not(np.repeat(bad, np.diff(edges), axis=1))
            if np.array_equal(keep, use) or keep.sum(axis=1).min() < 8:
                break
            redo = np.flatnonzero(np.any(keep != use, axis=1))
            use = keep
        r_p, r_w, p, fail, dof_p = test(var, (chi_c, p_c) if bool(np.all(np.isfinite(var))) else None)
    # a failing segment at a band edge without a mode of its own, or whose excess lies mostly in its
    # outer half, comes from a mode outside the band (the polynomial of the local fit stands only
    # for modes far from the segment, not for the steep skirt of one just beyond the edge)
    edge = np.zeros(n_seg, bool)
    w = np.zeros(0)
    for s_i in (0, n_seg - 1):
        if not fail[s_i]:
            continue
        if w.size == 0:  # formed only for a failing edge segment
            w = np.where(ok & np.isfinite(var), 2.0 * resid2 / np.where(np.isfinite(var), var, 1.0), 0.0).sum(axis=0)
        i0, i1 = int(edges[s_i]), int(edges[s_i + 1])
        mid = (i0 + i1) // 2
        outer, inner = (w[i0:mid], w[mid:i1]) if s_i == 0 else (w[mid:i1], w[i0:mid])
        # ... unless its excess peaks inside the segment: a mode in the band, not a skirt from beyond
        k = min(criteria.edge_peak_lines, i1 - i0)
        rim = w[i0:i0 + k] if s_i == 0 else w[i1 - k:i1]
        peak_inside = bool(w[i0:i1].size) and float(np.max(w[i0:i1])) > float(np.max(rim))
        if (m_seg[s_i] == 0 or outer.sum() > inner.sum()) and not peak_inside:
            edge[s_i] = True
    fail = fail & ~edge
    return MisfitTest(f[edges[:-1]], f[edges[1:] - 1], r_p, r_w, p, dof_p, fail, float(alpha), source, edge, var)


__all__ = ["COHERENCE_MAX", "NOISE_SOURCES", "MisfitTest", "NoiseModel", "SegmentFits", "check_coherence", "coherence_variance",
           "fit_noise_model", "segment_edges", "segment_misfit", "segment_pole_columns"]
