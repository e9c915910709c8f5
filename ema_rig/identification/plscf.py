"""PolyMAX: the poly-reference least-squares complex-frequency (pLSCF) estimator.

Functions
---------
plscf
    Poles and participation factors of an :class:`~ema_rig.frf.FRFData` for a range of model
    orders, as a tidy :class:`PoleSet`.

Classes
-------
PoleSet
    One row per pole: ``order``, ``pole`` (rad/s), ``natural_freq`` (Hz), ``damping_ratio``,
    ``participation`` (n_poles, n_in).

Notes
-----
**Model.** Right matrix-fraction model with real coefficients on the basis
``Omega_j(w) = z^j``, ``z = exp(j w' dt)``::

    H_o(w) = B_o(w) A(w)^-1,   A(w) = sum_j alpha_j z^j   (alpha_j: n_in x n_in, real)

**Frequency normalisation.** The band ``[f_lo, f_hi]`` is shifted to start at 0 Hz
(``w' = 2 pi (f - f_lo)``) and scaled onto the whole upper half of the unit circle,
``dt = 1 / (2 (f_hi - f_lo))``, so ``theta_k = w'_k dt`` runs from 0 to pi. On an even grid the
matrix ``R`` is then almost ``n_freq`` times the identity: cond(R) = 1.03 at order 100 and
1.06 at order 200 for 150-1000 Hz of a 0-2000 Hz, 0.5 Hz file, whereas keeping 0 Hz and
dropping the lines below 150 Hz (a gap on the circle) gives 9e8 and 1e17. A pole
``s' = ln(z) / dt`` of the shifted model is the physical pole ``s = s' + j 2 pi f_lo``; of each
conjugate pair only the root with ``Im s' > 0`` maps into the band and is kept.

**Reduced normal equations.** ``R``, ``S_o`` and ``T = sum_o T_o`` are (block) Toeplitz in the
lag ``j - i``; their lag sums come from one FFT per channel (or a vectorised sum on an uneven
grid). ``R = L L^T`` is factored once at the maximum order. Because ``L`` is lower triangular,
the leading rows of ``Q_o = L^-1 S_o`` are the same matrices for every lower order, so
``M_n = T_n - sum_o Q_o[:n+1, :]^T Q_o[:n+1, :]`` is accumulated order by order, the rows of
``Q`` (all outputs) since the last solved order in one symmetric rank update of the lower
triangle — exactly the reduced matrix of order ``n``, without rebuilding.
The rows are made from the lag sums in blocks as they are needed and dropped once added, so
``Q`` (``n_out n_in (n+1)^2`` numbers) is never held whole.
Each output is weighted by the inverse of its RMS over the band.

**Constraint (which coefficient is fixed).** With ``z = exp(+j w dt)``, fixing the LOWEST
coefficient, ``alpha_0 = I``, makes the least-squares solution put the physical poles inside
the unit circle (stable, ``Re s < 0``) and the mathematical poles that absorb noise, edge
effects and out-of-band dynamics outside it (``Re s > 0``, negative damping ratio): about three
quarters of all poles of a noisy rig measurement come out unstable and never count as stable
in :func:`~ema_rig.identification.stabilization.stabilize`, which cleans the chart. (With the basis
``z^-1 = exp(-j w dt)``, as in sdypy-EMA's LSCF, the same choice is the highest-order
coefficient; the opposite choice, ``alpha_n = I`` here, makes nearly every pole stable.) The
price is a noise bias: on noisy data the stable roots of the ``alpha_0 = I`` solution are
about ten times less accurate than those of ``alpha_n = I`` (relative frequency error ~1e-5
against ~1e-6 for a 1 %-damped mode with 1 % noise), because the model can then represent
out-of-band and edge dynamics only with unstable poles. Both solutions come from the same
reduced matrix ``M_n`` (one Cholesky factor, one solve: :func:`_solve_order`), so each stable root of the
``alpha_0 = I`` polynomial is polished by a few Newton steps on ``det A(z)`` of the
``alpha_n = I`` polynomial: the classification of the first, the accuracy of the second, for
one root-finding problem per order.

**Poles and participation factors.** The roots of order ``n`` are those of ``det A(z)``:
eigenvalues of the block companion matrix of the coefficient-reversed, transposed polynomial
(``n n_in`` square; upper Hessenberg for one reference), ``z = 1 / w`` (one reference from degree
20: the stable roots, which barely move from order to order, by Newton's iteration from the
order below and divided out first, so that the QR runs on the quotient of the unstable ones,
:func:`_roots_deflated`); for degrees
``n n_in >= 64`` (one reference: from degree 48 when the orders go on to 64 or beyond; several:
from degree 32 when the orders end at a degree of 64-100) by
default the Aberth-Ehrlich iteration started from the previous order's roots (:mod:`._roots`:
O(N^2) per sweep instead of the O(N^3) QR iteration, same roots to round-off; up to degree
200: all those orders in one batch of sweeps,
:func:`~._roots.aberth_chain`; above it one order at a time, the first sweep's repulsion sums
from the previous order's polynomial, :func:`~._roots.aberth_warm`; an order that does not
converge falls back to the companion eigenvalues). The
participation vector ``l_r`` of pole ``z_r`` is the null vector of ``A(z_r)^T`` (what the last
``n_in`` rows of a companion eigenvector hold), computed directly from the ``n_in x n_in``
matrix, which is cheaper than eigenvectors. All dense algebra runs with single-threaded
BLAS (:mod:`ema_rig._blas`, threadpoolctl); ``root_finder='eig'`` spreads the orders over a thread pool instead.

References
----------
.. [1] B. Peeters, H. Van der Auweraer, P. Guillaume, J. Leuridan, "The PolyMAX frequency-domain
   method: a new standard for modal parameter estimation?", Shock and Vibration 11 (2004).
.. [2] P. Guillaume, P. Verboven, S. Vanlanduit, H. Van der Auweraer, B. Peeters, "A
   poly-reference implementation of the least-squares complex frequency-domain estimator",
   IMAC XXI (2003).
.. [3] P. Verboven, "Frequency-domain system identification for modal analysis", PhD thesis,
   Vrije Universiteit Brussel (2002).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
from collections.abc import Iterable, Iterator, Mapping
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from .._blas import single_threaded
from .._progress import progress_bar
from ..dof import DOF
from ..errors import BandError, IdentificationError, band_error
from ..frf import FRFData
from ._roots import (
    ROUNDING_PER_DEGREE,
    aberth_chain,
    aberth_warm,
    coefficient_blocks,
    det_coefficients,
    eval_blocked,
    later_twins,
    powers,
    vieta_ok,
)

logger = logging.getLogger(__name__)

#: Below this polynomial degree the companion QR is cheaper than the warm-started iteration.
_ABERTH_MIN_DEGREE = 64

#: One reference: when the computed orders reach :data:`_ABERTH_MIN_DEGREE`, the batched chain
#: (:func:`~._roots.aberth_chain`) starts at this degree instead. Alone, the chain of degrees
#: 48-62 costs more than their companion QR (CPU min of 25 alternating runs on the denominators
#: of benchmarks/bench_plscf.py: 3.75 against 3.39 ms up to degree 62, 1.37 against 0.65 ms up
#: to 50), but within a chain that goes on past degree 64 the sweeps it shares pay for it: up
#: to degree 64 3.51 against 4.45 ms (QR to 62, the chain from 64), up to 72 5.19 against
#: 6.16, up to 80 6.38 against 7.60, up to 100 11.3 against 12.5 ms (from 40: 12.5, from 56:
#: 11.5 against 12.1 ms at 100).
_CHAIN_FROM_DEGREE_ONE = 48

#: Several references: when the computed orders reach a degree ``n n_in`` of
#: :data:`_ABERTH_MIN_DEGREE` but not beyond :data:`_CHAIN_LOW_TOP_MIMO`, the chain starts at this
#: degree instead (as :data:`_CHAIN_FROM_DEGREE_ONE`). Measured on the two-reference denominators of
#: benchmarks/bench_plscf.py (whole ``plscf`` calls, thread CPU, BLAS one thread, alternating
#: in one process, 15 calls each, load 4-6, 2026-12-07): even orders to 50, start at degree
#: 64 / 24 / 32 / 40: median 17.0 / 14.6 / 14.5 / 14.5 ms (minima 13.8 / 12.7 / 12.8 / 13.4;
#: a second run 13.0 -> 12.1 ms at 32); every order to 40 (the default orders), median
#: 18.1 / 15.5 / 15.4 / 15.4 ms; even orders to 100 (9 calls) 54.2 / 52.3 / 53.9 / 56.7 and to
#: 200 (5 calls) 237 -> 239 ms at 32: within the noise (the chain is most of those calls
#: anyway). A separate chain for degrees 32-62 (not joined to the one from 64) gained nothing
#: at order 50 (13.0 against 13.0 ms): the gain is the sweeps the joined chain shares. Paired
#: against 4ff7088 in two worker processes (benchmarks/bench_plscf_vs_tree.py, 15 pairs, load 6.5-7.7):
#: every order to 40 17.9 -> 15.3 ms CPU (0.86 per pair), even orders to 50 0.97 and 0.99.
_CHAIN_FROM_DEGREE_MIMO = 32

#: Highest degree of the computed orders for which :data:`_CHAIN_FROM_DEGREE_MIMO` applies: up to
#: degree 100 a chain sweep costs mostly its fixed cost (see :mod:`._roots`), which the lower
#: orders share; above, nothing was gained (orders to 100 and 200 above) and the longer chain
#: 32-200 left one order to the eigenvalue fallback (degree 36 at max order 100 and 200; 40-200
#: none, 48-200 degree 60), while no chain ending at degree <= 100 fell back (two references,
#: bench_plscf data with seeds 0-2, max orders 32-50, even and every order, whole band,
#: 200-1200 and 100-700 Hz: 180 calls, no fallback).
_CHAIN_LOW_TOP_MIMO = 100

#: Up to this degree (of det A: n_in x order) the orders from :data:`_ABERTH_MIN_DEGREE` on are rooted
#: together (:func:`~._roots.aberth_chain`: one batch of sweeps for all orders, each started from
#: the iterate of the order below), above it one order after the other (:func:`~._roots.aberth_warm`):
#: the fixed cost per sweep that the batch shares matters less as the O(N^2) work per order grows.
#: Measured on the denominators of benchmarks/bench_plscf.py (CPU min of alternating runs, BLAS
#: one thread). One reference, both started from the companion roots of the order below:
#: degrees 132-160 12.3 against 15.1 ms, 160-200 20.0 against 21.4 ms, 200-260 39.9 against
#: 38.2 ms (the one-by-one iteration ahead). Two references, whole plscf calls with 130 against
#: 200 (12 alternating calls each, load 7): max order 100 73.3 -> 64.3 ms, 200 263 -> 255 ms
#: (260 instead: 267 ms at 200).
_CHAIN_MAX_DEGREE = 200

#: One reference, root finder ``'aberth'``: the orders rooted by the companion QR from this degree on
#: (below :data:`_ABERTH_MIN_DEGREE`, or below the chain's start) divide their stable roots out first
#: (:func:`_roots_deflated`, all at once from the roots of the order below). On benchmarks/bench_plscf.py's
#: one-reference denominators (even orders to 50; 14 stable roots from order 16 on, 3 at order 12),
#: replayed root steps of degrees D..50 against their companion QR (CPU min of 30 alternating runs,
#: BLAS one thread, 2026-12-08, load ~10): from 14 3.71 against 2.90 ms (the anchor of order 12
#: has 3 stable roots; Newton runs its 8 steps on starts that moved ~1), 16 2.75 / 2.87, 18 2.42 /
#: 2.83, 20 2.65 / 3.22, 24 2.46 / 2.72, 30 2.22 / 2.47, 36 2.01 / 2.03 (at load ~3 an earlier
#: version: 20 2.13 / 2.72, 24 2.10 / 2.60);
#: whole plscf calls at max order 50 (CPU min of 15 alternating calls, load 10): without 6.79 ms,
#: from 16 / 20 / 24 / 30: 6.32 / 5.71 / 5.96 / 6.28 ms; at max order 100 (7 calls) 19.2-20.0 ms
#: for every choice (the chain from degree 48 is most of those calls).
_DEFLATE_FROM_DEGREE = 20

#: Newton steps at most for the stable roots of :func:`_roots_deflated` (they start 1e-7 to 1e-3
#: relative from their root: quadratic convergence reaches round-off in 2-4 steps), and the step,
#: relative to ``|z|``, below which a root stops (the next step would be below round-off: quadratic
#: convergence from an error of 1e-9 leaves ~1e-18).
_DEFLATE_NEWTON = 8
_DEFLATE_STEP = 1e-9

#: Largest Newton step, relative to ``|z|``, that :func:`_roots_deflated` takes to polish a root of a
#: quotient on the undivided polynomial: those roots are within ~1e-13 of the polynomial's
#: (degree 20-50 on the denominators of benchmarks/bench_plscf.py, against 60-digit roots), a
#: step a million times larger is no polish (a root at a cluster), and the root stays.
_DEFLATE_POLISH = 1e-7

#: Default maximum model order for one reference / for several (denominator degree).
DEFAULT_MAX_ORDER = {1: 64}
DEFAULT_MAX_ORDER_MIMO = 40


def default_max_order(n_in: int) -> int:
    """Default maximum model order for ``n_in`` references.

    64 for one reference, 40 for several: enough for the ~10 modes of a 150-1000 Hz band with
    ample overmodelling, and well under a second for the whole stabilization computation. The
    order is not lowered further for three or more references although the companion matrix
    grows as ``order * n_in``: on a wide band (50-2000 Hz, three or four references) orders
    20-26 hold the lowest mode on a plateau biased by 0.1-0.2 % (a dozen times its spread over
    the orders), which a convergence test between two neighbouring orders cannot see; from
    order ~34 on the estimate stays within 2e-4 (``benchmarks/bench_scale.py`` data).
    """
    return DEFAULT_MAX_ORDER.get(n_in, DEFAULT_MAX_ORDER_MIMO)


@dataclass(frozen=True, slots=True, eq=False)
class PoleSet:
    """Poles of every model order in tidy (long) form.

    Parameters
    ----------
    order : ndarray, shape (n_poles,), int
        Model order (denominator degree) of each pole.
    pole : ndarray, shape (n_poles,), complex
        Physical pole ``lambda`` [rad/s], ``Im > 0``.
    participation : ndarray, shape (n_poles, n_in), complex
        Unit-norm participation vector (phase such that the largest entry is real > 0); NaN
        for an unstable pole (``Re lambda >= 0``, never a physical mode: not computed).
    band : tuple of float
        ``(freq_lower, freq_upper)`` [Hz] of the data the poles were estimated on.
    in_dofs : tuple of DOF
        Reference DOFs (columns of ``participation``).
    orders : tuple of int
        The model orders that were computed (ascending).
    meta : mapping
        ``dt`` (s), ``n_freq``, ``constraint``, ``cond_R``.

    Notes
    -----
    ``natural_freq = |lambda| / 2 pi`` [Hz] and ``damping_ratio = -Re(lambda) / |lambda|`` are
    derived columns; unstable (mathematical) poles have a negative damping ratio.
    """

    order: NDArray[np.int64]
    pole: NDArray[np.complex128]
    participation: NDArray[np.complex128]
    band: tuple[float, float]
    in_dofs: tuple[DOF, ...] = ()
    orders: tuple[int, ...] = ()
    meta: Mapping[str, Any] = field(default_factory=dict)
    _fn: NDArray[np.float64] = field(init=False, repr=False, compare=False)
    _zeta: NDArray[np.float64] = field(init=False, repr=False, compare=False)

    def __repr__(self) -> str:
        o = self.orders
        span = f"orders {min(o)}-{max(o)}" if o else "no orders"
        return f"PoleSet({len(self)} poles, {span}, band {self.band[0]:g}-{self.band[1]:g} Hz)"

    def __post_init__(self) -> None:
        order = np.asarray(self.order, dtype=np.int64).reshape(-1).copy()
        pole = np.asarray(self.pole, dtype=np.complex128).reshape(-1).copy()
        part = np.asarray(self.participation, dtype=np.complex128).copy()
        if part.ndim == 1:
            part = part[:, None]
        if not (order.size == pole.size == part.shape[0]):
            raise ValueError(
                f"order, pole and participation need the same number of rows, got "
                f"{order.size}, {pole.size}, {part.shape[0]}"
            )
        for name, arr in (("order", order), ("pole", pole), ("participation", part)):
            arr.setflags(write=False)
            object.__setattr__(self, name, arr)
        object.__setattr__(self, "band", (float(self.band[0]), float(self.band[1])))
        object.__setattr__(self, "in_dofs", tuple(self.in_dofs))
        orders = self.orders or tuple(int(o) for o in np.unique(order))
        object.__setattr__(self, "orders", tuple(int(o) for o in orders))
        object.__setattr__(self, "meta", MappingProxyType(dict(self.meta)))
        # derived columns, computed once (the selection reads them per cluster)
        fn = np.abs(pole) / (2 * np.pi)
        with np.errstate(invalid="ignore", divide="ignore"):
            zeta = -pole.real / np.abs(pole)
        fn.setflags(write=False)
        zeta.setflags(write=False)
        object.__setattr__(self, "_fn", fn)
        object.__setattr__(self, "_zeta", zeta)

    def __len__(self) -> int:
        return int(self.pole.size)

    @property
    def n_in(self) -> int:
        """Number of references (columns of ``participation``)."""
        return int(self.participation.shape[1])

    @property
    def natural_freq(self) -> NDArray[np.float64]:
        """``|lambda| / 2 pi`` [Hz], shape (n_poles,) (read-only)."""
        return self._fn

    @property
    def damping_ratio(self) -> NDArray[np.float64]:
        """``-Re(lambda) / |lambda|`` [-], shape (n_poles,) (read-only)."""
        return self._zeta

    def at_order(self, order: int) -> NDArray[np.intp]:
        """Row indices of the poles of one model order, by increasing frequency."""
        idx = np.flatnonzero(self.order == order)
        return idx[np.argsort(self.natural_freq[idx])]

    def to_records(self) -> list[dict[str, Any]]:
        """One dict per pole: order, natural_freq, damping_ratio, pole_real, pole_imag."""
        return [
            {
                "order": int(o),
                "natural_freq": float(f),
                "damping_ratio": float(z),
                "pole_real": float(p.real),
                "pole_imag": float(p.imag),
            }
            for o, f, z, p in zip(self.order, self.natural_freq, self.damping_ratio, self.pole, strict=True)
        ]


# --------------------------------------------------------------------------- checks
def source_of(data: FRFData) -> str | None:
    """The file an FRFData came from (``meta['source']`` or ``meta['file']``), for messages."""
    src = data.meta.get("source") or data.meta.get("file")
    return str(src) if src else None


def check_data(data: FRFData, band: tuple[float, float] | None) -> FRFData:
    """Validate ``data`` for identification and cut it to ``band``.

    Raises
    ------
    IdentificationError
        Band reversed or outside the data, NaN/inf values, an all-zero FRF, fewer than 8
        lines (a :class:`~ema_rig.errors.BandError` when the data hold 8 but the band does not).
    """
    if not isinstance(data, FRFData):
        raise TypeError(f"data must be an FRFData, got {type(data).__name__}")
    src = source_of(data)
    if band is not None:
        try:
            lo, hi = (float(band[0]), float(band[1]))
        except (TypeError, ValueError, IndexError):
            raise IdentificationError(f"band must be (freq_lower, freq_upper) in Hz, got {band!r}", file=src) from None
        if not (np.isfinite(lo) and np.isfinite(hi)) or hi <= lo:
            raise IdentificationError(f"band must satisfy freq_lower < freq_upper, got {lo:g}..{hi:g} Hz", file=src)
        f0, f1 = float(data.freq[0]), float(data.freq[-1])
        tol = 1e-9 * max(abs(f1), 1.0)
        if lo < f0 - tol or hi > f1 + tol:
            raise band_error(lo, hi, f0, f1, file=src)
        whole = data.n_freq
        data = data.band(lo, hi)
        if data.n_freq < 8 <= whole:  # the band's fault, not the data's: say so (no data diagnosis appended)
            raise BandError(f"only {data.n_freq} frequency lines in the band {lo:g}..{hi:g} Hz; need at least 8 "
                            f"(the data hold {whole} lines over {f0:g}..{f1:g} Hz: widen the band)", file=src)
    if data.n_freq < 8:
        raise IdentificationError(f"only {data.n_freq} frequency lines in the band; need at least 8", file=src)
    frf = data.frf
    # in chunks of outputs (about 8 MB each): no temporary of the data's size
    power = np.empty(frf.shape[:2])
    step = max(1, (8 << 20) // max(frf[0].nbytes, 1))
    for o0 in range(0, frf.shape[0], step):
        blk = frf[o0 : o0 + step]
        power[o0 : o0 + step] = _sum_sq(blk)
        # a NaN or inf value makes its sum non-finite: the values are tested one by one only then
        # (a sum can also overflow from finite values)
        if not np.isfinite(power[o0 : o0 + step]).all() and not np.all(np.isfinite(blk)):
            bad = np.argwhere(~np.isfinite(frf))
            o, i, k = bad[0]
            raise IdentificationError(
                f"FRF contains {len(bad)} NaN/inf values (first: output {data.out_dofs[o]}, "
                f"input {data.in_dofs[i]}, {data.freq[k]:g} Hz)",
                file=src,
            )
    if np.all(power == 0):
        raise IdentificationError("the FRF is zero everywhere in the band", file=src)
    zero_in = np.flatnonzero(np.all(power == 0, axis=0))
    if zero_in.size:
        raise IdentificationError(
            f"every FRF of reference {data.in_dofs[zero_in[0]]} is zero in the band", file=src
        )
    return data


# --------------------------------------------------------------------------- kernels
def _sum_sq(h: NDArray[Any]) -> NDArray[np.float64]:
    """``sum_k |h[..., k]|^2`` over the last axis of a complex array, shape ``h.shape[:-1]``.

    Two real contractions over the real and imaginary views: no temporary of the array's size
    (the squares of the parts would be three), any memory layout; a C-ordered array in ONE
    contraction over its (re, im) pairs (contiguous, half the time of the two strided ones).
    """
    if h.flags.c_contiguous and h.dtype == np.complex128:
        v = h.view(np.float64)
        return cast("NDArray[np.float64]", np.einsum("...k,...k->...", v, v))
    return cast("NDArray[np.float64]", np.einsum("...k,...k->...", h.real, h.real)
                + np.einsum("...k,...k->...", h.imag, h.imag))


def _lag_sums(data: FRFData, p: int) -> tuple[NDArray[Any], NDArray[Any], NDArray[Any], NDArray[Any], float]:
    """Weighted lag sums of R, S_o and T for lags -p..p.

    Returns ``r`` (p+1,) for lags 0..p, ``s`` (n_out, n_in, 2p+1) for lags -p..p,
    ``t`` (n_in, n_in, 2p+1), the output weights (n_out,) and ``dt``: the REAL parts of the
    sums, all the real-coefficient normal equations use.

    The FRF array is never copied whole: the weights are applied to one chunk of outputs at a
    time, and every work array (a chunk of weighted FRFs, its zero-padded FFT, a block of
    exponentials) is held to ``budget`` bytes, an eighth of the data clipped to 8..64 MB, so the
    peak stays near the data size. Equally spaced lines take, per channel, either a zero-padded
    inverse real FFT of length ``2 (n - 1)`` (keeping 2p+1 of its outputs; see below) or the direct sum over the lines
    against a table of exponentials, whichever the operation count below makes cheaper (the
    direct sum wins at low orders: about ``(2p+1) n`` multiply-adds against ``nf log2 nf``
    for the FFT); both use the exact angles ``pi k l / (n - 1)``. Unequally spaced lines
    take the direct sum with ``exp(j theta_k l)``.

    Real part by the inverse real FFT: with ``nf = 2 (n - 1)``, ``nf irfft(x, nf)[l]`` is
    ``Re x_0 + Re x_{n-1} (-1)^l + 2 sum_{k=1}^{n-2} Re(x_k exp(j pi k l / (n - 1)))`` (the
    transform of the Hermitian extension), so ``Re sum_k x_k exp(j pi k l / (n - 1))`` is its
    mean with ``Re x_0 + Re x_{n-1} (-1)^l``: half the work of the complex transform.
    """
    f = data.freq
    n = f.size
    span = float(f[-1] - f[0])
    dt = 1.0 / (2.0 * span)
    h = data.frf
    n_out, n_in, _ = h.shape
    m = 2 * p + 1
    lags = np.arange(-p, p + 1)
    nf = 2 * (n - 1)
    budget = int(min(max(h.nbytes // 8, 8 << 20), 64 << 20))

    def chunks(row_bytes: int) -> list[tuple[int, int]]:
        step = max(1, budget // max(row_bytes, 1))
        return [(o, min(o + step, n_out)) for o in range(0, n_out, step)]

    even = data.is_even
    if n_in == 1 and even and _fft_cheaper(n, p, n_out + 1):
        return _lag_sums_one(h, p, budget, dt)
    # output weights 1 / rms over inputs and lines, without |h|^2 of the whole array
    ms = np.empty(n_out)
    for o0, o1 in chunks(n_in * n * 8):
        blk = h[o0:o1]
        ms[o0:o1] = _sum_sq(blk).sum(axis=1)
    rms = np.sqrt(ms / (n_in * n))
    w = 1.0 / np.where(rms > 0, rms, 1.0)

    if even and p < n - 1 and _fft_cheaper(n, p, n_out * n_in + n_in * n_in):

        def re_sums(x: NDArray[Any]) -> NDArray[Any]:
            return _re_lag_sums(x, p)

        s = np.empty((n_out, n_in, m))
        # sum_o H_o^H H_o per line, its entries a <= b only (the matrix is Hermitian), each from
        # the real and imaginary parts of the weighted FRFs: no conjugate copy, no temporaries
        ia, ib = np.triu_indices(n_in)
        g = np.zeros((ia.size, n), np.complex128)
        for o0, o1 in chunks(n_in * nf * 16):
            if n_in > 1:
                # several references: the weights enter the products and scale the transforms
                # (the lag sums are linear in each output), no weighted copy of the chunk
                hr, hi, w2 = h[o0:o1].real, h[o0:o1].imag, w[o0:o1] ** 2
                for q, (a, b) in enumerate(zip(ia.tolist(), ib.tolist(), strict=True)):
                    # conj(x) y = (xr yr + xi yi) + j (xr yi - xi yr), weighted by w_o^2 over the outputs
                    g[q].real += np.einsum("o,ok,ok->k", w2, hr[:, a], hr[:, b]) + np.einsum("o,ok,ok->k", w2, hi[:, a], hi[:, b])
                    if a != b:
                        g[q].imag += (np.einsum("o,ok,ok->k", w2, hr[:, a], hi[:, b])
                                      - np.einsum("o,ok,ok->k", w2, hi[:, a], hr[:, b]))
                s[o0:o1] = re_sums(h[o0:o1])
                s[o0:o1] *= w[o0:o1, None, None]
                continue
            hw = h[o0:o1] * w[o0:o1, None, None]
            if n_in == 1:  # |H_o|^2 in one contraction over the (re, im) pairs
                hv = np.ascontiguousarray(hw).view(np.float64).reshape(o1 - o0, n, 2)  # a copy only
                # when the FRF array is not C-ordered (the product keeps the input's layout)
                g[0].real += np.einsum("okt,okt->k", hv, hv)
            s[o0:o1] = re_sums(hw)
            del hw
        tu = re_sums(g)  # (pairs, 2p + 1)
        # Re t_ba(l) = Re t_ab(-l): the lower triangle is the upper one with the lags reversed
        t = np.empty((n_in, n_in, m))
        t[ia, ib] = tu
        t[ib, ia] = tu[:, ::-1]
        # R's lags 0..p in closed form: the sum over the lines of cos(pi k l / (n - 1)) is n at
        # l = 0, and for 0 < l < 2 (n - 1) it is (1 + (-1)^l) / 2 (the full period of the
        # Hermitian extension sums to zero; the two end lines remain)
        r = np.zeros(p + 1)
        r[0] = n
        r[2::2] = 1.0
        return r, s, t, w, dt

    s = np.zeros((n_out, n_in, m), np.complex128)
    t = np.zeros((n_in, n_in, m), np.complex128)
    r = np.zeros(p + 1)
    if even:
        table = np.exp(1j * np.pi * np.arange(nf) / (n - 1))  # exact angles pi * (k l mod nf) / (n-1)
    else:
        theta = np.pi * (f - f[0]) / span
    nb = max(1, budget // (m * 16))  # lines per block of exponentials
    for k0 in range(0, n, nb):
        k1 = min(k0 + nb, n)
        if even:
            e = table[np.outer(np.arange(k0, k1), lags) % nf]  # (lines, 2p+1)
        else:
            e = np.exp(1j * np.outer(theta[k0:k1], lags))
        r += e[:, p:].real.sum(axis=0)
        g = np.zeros((n_in, n_in, k1 - k0), np.complex128)
        for o0, o1 in chunks(n_in * (k1 - k0) * 16):
            hw = h[o0:o1, :, k0:k1] * w[o0:o1, None, None]
            g += np.einsum("oak,obk->abk", hw.conj(), hw)
            # one matrix product for the whole chunk (a stack of n_in-row products would read
            # the exponentials once per output)
            s[o0:o1] += (hw.reshape(-1, k1 - k0) @ e).reshape(o1 - o0, n_in, m)
            del hw
        t += g @ e
    return r, s.real.copy(), t.real.copy(), w, dt


def _fft_cheaper(n: int, p: int, n_chan: int) -> bool:
    """Whether the lag sums of ``n_chan`` channels on ``n`` even lines are cheaper by FFT than directly.

    Rough costs in units of one complex multiply-add of a matrix product (measured with one
    BLAS thread at 4 001 and 64 001 lines: a table exponential ~ 50, one unit of a complex
    FFT's nf log2 nf ~ 8), ``nf = 2 (n - 1)``; the inverse real FFT is half a complex one.
    """
    nf = 2 * (n - 1)
    cost_direct = n * (2 * p + 1) * (50.0 + n_chan)
    cost_fft = 4.0 * n_chan * nf * np.log2(max(nf, 2))
    return bool(cost_fft < cost_direct)


def _re_lag_sums(x: NDArray[Any], p: int) -> NDArray[Any]:
    """``Re sum_k x_k exp(j pi k l / (n - 1))`` for ``l = -p..p`` along the last axis (n lines).

    One zero-padded inverse real FFT of length ``nf = 2 (n - 1)`` (see :func:`_lag_sums`),
    shape ``x.shape[:-1] + (2 p + 1,)``; ``x`` may be real or complex.
    """
    n = x.shape[-1]
    nf = 2 * (n - 1)
    lags = np.arange(-p, p + 1)
    sign = np.where(lags % 2 == 0, 1.0, -1.0)  # (-1)^l
    y = np.fft.irfft(x, n=nf, axis=-1)[..., lags % nf] * nf
    y += x[..., :1].real + x[..., -1:].real * sign
    y *= 0.5
    return cast("NDArray[Any]", y)


def _lag_sums_one(h: NDArray[Any], p: int, budget: int, dt: float) -> tuple[NDArray[Any], NDArray[Any], NDArray[Any], NDArray[Any], float]:
    """:func:`_lag_sums` of one reference on evenly spaced lines, by FFT, in ONE pass over the data.

    Per chunk of outputs: ``|H_o|^2`` per line (one contraction over the (re, im) pairs), from it
    the output weight ``w_o = 1 / rms_o`` and ``T``'s sums ``sum_o w_o^2 |H_o|^2``; ``S_o``'s lag
    sums are those of the UNWEIGHTED FRF times ``w_o`` (the sums are linear), so no weighted
    copy of the data is made. Same results as the general path to round-off.
    """
    n_out, _, n = h.shape
    nf = 2 * (n - 1)
    s = np.empty((n_out, 1, 2 * p + 1))
    w = np.empty(n_out)
    g = np.zeros(n)
    step = max(1, budget // (nf * 16))
    for o0 in range(0, n_out, step):
        o1 = min(o0 + step, n_out)
        blk = h[o0:o1, 0]
        hv = np.ascontiguousarray(blk).view(np.float64).reshape(o1 - o0, n, 2)  # a copy only when
        # the FRF array is not C-ordered
        sq = np.square(hv)
        sq = sq[..., 0] + sq[..., 1]  # |H_o|^2, (outputs, lines)
        rms = np.sqrt(sq.sum(axis=1) / n)
        wc = 1.0 / np.where(rms > 0, rms, 1.0)
        w[o0:o1] = wc
        g += (wc * wc) @ sq
        s[o0:o1, 0] = _re_lag_sums(blk, p)
        s[o0:o1, 0] *= wc[:, None]
    # T's lag sums: the real g gives sums even in the lag (the reversal keeps the general path's)
    t = _re_lag_sums(g, p)[None, None, ::-1].copy()
    # R's lags 0..p in closed form (see _lag_sums)
    r = np.zeros(p + 1)
    r[0] = n
    r[2::2] = 1.0
    return r, s, t, w, dt


#: Work budget [bytes] of one block of ``Q`` rows (all outputs): half the FRF data, clipped to
#: 8..64 MB (fewer blocks would hold more; more blocks rebuild rows of ``S`` more often); and of
#: one chunk of ``S``.
_Q_BLOCK_BYTES = 64 << 20
_Q_BLOCK_MIN_BYTES = 8 << 20
_S_CHUNK_BYTES = 2 << 20

#: A last block of ``Q`` rows holding fewer than this share of a block's rows joins the block before it
#: (:meth:`PlscfEngine._row_blocks`): a block of rows ``a..b`` rebuilds rows ``0..b`` of ``S`` (row ``i`` of ``Q``
#: depends on rows ``0..i``), so a sliver costs about as much as a whole block. The blocks then exceed their
#: budget by this share at most. Measured on the 256-output file of ``bench_refine.py`` at order 64 (65 rows, 63
#: per 8 MB block): the engine's CPU 27.8 -> 24.8 ms (median of 20 alternating runs, one BLAS thread), the poles
#: and every answer of ``identify`` the same to the bit (``benchmarks/results/issue18_wide_s_wide14.txt``).
_Q_LAST_BLOCK_SHARE = 1 / 8


#: Smallest relative Cholesky pivot ``L_kk^2 / r_0`` of ``R`` an order may need (see _order_limit).
_R_PIVOT_TOL = 1e-6


def _order_limit(r: NDArray[Any]) -> tuple[int, NDArray[Any] | None]:
    """Highest order ``p`` whose ``R_p`` (lags ``r[:p+1]``, Toeplitz) is safely positive definite.

    Returns ``(p, L)``: ``L`` the lower Cholesky factor of the whole ``R`` (shape (r.size, r.size),
    upper triangle zero) when it is positive definite, else None (:func:`_reduced_factor` takes it
    instead of factoring the same matrix again).

    On evenly spaced lines ``R`` is almost ``n_freq`` times the identity and every order up to
    the cap passes; a gap in the lines (two separate bands) makes it singular from some order
    on: the squared Cholesky pivots ``L_kk^2`` (how much of ``z^k`` on the lines is not a
    combination of the lower powers) then fall geometrically, about halving per order for a
    band split in two, until round-off. An order is allowed while every pivot up to it stays
    above :data:`_R_PIVOT_TOL` times ``r_0``: on such a grid the pivots beyond ~1e-7 already
    differ with the rounding of the lag sums (and the factorisation breaks down a few orders
    later), so the limit sits where it does not depend on rounding. Evenly spaced,
    log-spaced and jittered lines keep every pivot near 1 (no limit).
    """
    from scipy.linalg.lapack import dpotrf

    i = np.arange(r.size)
    c, info = dpotrf(r[np.abs(i[None, :] - i[:, None])], lower=1, clean=1)
    # info = k > 0: the leading minor of size k is not positive definite, rows < k - 1 factored
    n_ok = r.size if info == 0 else max(int(info) - 1, 0)
    piv = np.diag(c)[:n_ok] ** 2 / r[0]
    bad = np.flatnonzero(~(piv >= _R_PIVOT_TOL))
    n_good = n_ok if bad.size == 0 else int(bad[0])
    return n_good - 1, (c if info == 0 else None)


def _reduced_factor(r: NDArray[Any], t: NDArray[Any], p: int,
                    factor: NDArray[Any] | None = None) -> tuple[NDArray[Any], NDArray[Any]]:
    """``T`` of the max order and ``L^-1``, the inverse Cholesky factor of ``R``.

    ``factor``, when given with shape (p+1, p+1), is ``L`` itself (:func:`_order_limit`'s of the
    same lags), not formed again.

    Returns ``T`` shape ((p+1) n_in, (p+1) n_in) and ``Linv`` shape (p+1, p+1), lower
    triangular. On evenly spaced lines ``R`` is almost ``n_freq`` times the identity
    (cond(R) ~ 1.03-1.06, module notes) and the explicit inverse factor agrees with a
    triangular solve to round-off; on lines with a gap (cond(R) up to ~1e8 below the order
    limit) the two differ by ~1e-11 relative, far below the noise of any measured FRF.
    """
    from scipy.linalg.lapack import dpotrf, dtrtri

    n_in = t.shape[0]
    i = np.arange(p + 1)
    lag = i[None, :] - i[:, None] + p  # (i, j) -> (j - i) + p
    # LAPACK directly (the factor and its triangular inverse), without scipy.linalg's wrappers
    if factor is not None and factor.shape == (p + 1, p + 1):
        L, info = factor, 0
    else:
        L, info = dpotrf(r[np.abs(lag - p)], lower=1, clean=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"R is not positive definite (leading minor {info})")
    linv, info = dtrtri(L, lower=1)
    if info != 0:
        raise np.linalg.LinAlgError(f"R's Cholesky factor is singular (pivot {info})")
    # T[(i, a), (j, b)] = Re t_ab(j - i)
    T = t.real[:, :, lag].transpose(2, 0, 3, 1).reshape((p + 1) * n_in, (p + 1) * n_in)
    return T, linv


def _q_rows(s: NDArray[Any], linv: NDArray[Any], p: int, a: int, b: int) -> NDArray[Any]:
    """Rows ``a..b`` of ``Q_o = L^-1 S_o`` for every output, shape (b-a+1, n_out, (p+1) n_in).

    ``S_o[i, (j, c)] = -Re s_oc(j - i)`` is rebuilt from the lag sums ``s`` (n_out, n_in, 2p+1)
    one chunk of outputs at a time (~2 MB), and only its rows ``0..b`` (row ``i`` of ``Q``
    depends on rows ``0..i`` of ``S``): ``Q`` is never held whole, which would take
    ``n_out n_in (p+1)^2 x 8`` bytes (5x a 4 001-line data set at order 200).
    """
    from scipy.linalg.blas import dtrmm

    n_out, n_in, _ = s.shape
    ncol = (p + 1) * n_in
    out = np.empty((b - a + 1, n_out, ncol))
    w = linv[a : b + 1, : b + 1]
    # S[i, o, (j, c)] = -s[o, c, p + j - i]: a window of p + 1 lags starting at lag p - i, taken as
    # strided views of the lag sums (no index arrays) and copied once into the (i, o, j, c) layout
    win = np.lib.stride_tricks.sliding_window_view(s.real.transpose(0, 2, 1), p + 1, axis=1)  # (o, start, c, j)
    rows = win[:, p - b : p + 1][:, ::-1]  # start p - i for i = 0..b: (o, i, c, j)
    step = max(1, _S_CHUNK_BYTES // ((b + 1) * ncol * 8))
    for o0 in range(0, n_out, step):
        o1 = min(o0 + step, n_out)
        S = np.empty((b + 1, o1 - o0, p + 1, n_in))
        np.negative(rows[o0:o1].transpose(1, 0, 3, 2), out=S)
        S2 = S.reshape(b + 1, (o1 - o0) * ncol)
        if a == 0:
            # w = L^-1[:b+1, :b+1] is lower triangular: half the products of a general one
            # (BLAS trmm on the transposes, in place: S2^T w^T = (w S2)^T)
            prod = dtrmm(1.0, w.T, S2.T, side=1, lower=0, trans_a=0, overwrite_b=1).T
        else:
            prod = w @ S2
        out[:, o0:o1] = prod.reshape(b - a + 1, o1 - o0, ncol)
        del S, S2, prod
    return out


def _reduced_blocks(r: NDArray[Any], s: NDArray[Any], t: NDArray[Any], p: int) -> tuple[NDArray[Any], NDArray[Any]]:
    """``T`` and the whole ``Q`` (p+1, n_out, (p+1) n_in) at once (small problems, tests)."""
    T, linv = _reduced_factor(r, t, p)
    return T, _q_rows(s, linv, p, 0, p)


def _solve_order(m: NDArray[Any], n: int, n_in: int) -> tuple[NDArray[Any], NDArray[Any]]:
    """Denominator coefficients of order n under both constraints.

    Returns ``(alpha_low, alpha_high)``, each of shape (n + 1, n_in, n_in) holding
    ``alpha_0 .. alpha_n``: ``alpha_low`` with ``alpha_0 = I``, ``alpha_high`` with
    ``alpha_n = I``. ``m`` is the reduced normal matrix ``M_n``, shape ((n+1) n_in, (n+1) n_in);
    only its lower triangle is read.

    Both come from ONE Cholesky factor ``M = G G^T``: the solution ``theta = [I; x]`` of the
    constraint ``alpha_0 = I`` satisfies ``M theta = E_0 Lambda`` (``E_0`` the first ``n_in``
    columns of I, ``Lambda`` an ``n_in x n_in`` matrix of multipliers), so ``theta = M^-1 E_0``
    normalised to a leading block I; likewise ``alpha_n = I`` from ``M^-1 E_n`` (``E_n`` the
    last ``n_in`` columns). One factorisation and one solve with ``2 n_in`` right-hand sides,
    backward stable for ``M`` as a whole like the two separate Cholesky solves of the
    sub-blocks it replaces, at half their work. When ``M`` is not numerically positive definite
    the sub-blocks are solved apart (:func:`_spd_solve`, least squares as the last resort).
    """
    from scipy.linalg.lapack import dpotrf, dpotrs

    if n_in == 1:
        one = _solve_order_one(m, n)
        if one is not None:
            return one
    eye = np.eye(n_in)
    k = n * n_in
    # the factor of m^T (a Fortran-ordered view: its UPPER triangle is the lower triangle of m, so
    # LAPACK reads m without a transposed copy), as in _solve_order_one
    g, info = dpotrf(m.T, lower=0, clean=0)
    coef = np.empty((2, n + 1, n_in, n_in))  # alpha_low, alpha_high
    low, high = coef[0], coef[1]
    solved = False
    if info == 0:
        e = np.zeros((k + n_in, 2 * n_in), order="F")
        e[:n_in, :n_in] = eye
        e[k:, n_in:] = eye
        u, info = dpotrs(g, e, lower=0, overwrite_b=1)
        if info == 0:
            # the diagonal blocks u[:n_in, :n_in] and u[k:, n_in:] of M^-1 are symmetric positive
            # definite: x_low = u[n_in:, :n_in] u[:n_in, :n_in]^-1, x_high = u[:k, n_in:] u[k:, n_in:]^-1
            # (both k x n_in), from the inverses of the two small pivot blocks, written in place
            with contextlib.suppress(np.linalg.LinAlgError):  # singular pivot block: the fallback below
                inv0 = _inv_small(u[:n_in, :n_in])
                inv1 = _inv_small(u[k:, n_in:])
                np.matmul(u[n_in:, :n_in], inv0, out=low[1:].reshape(k, n_in))
                np.matmul(u[:k, n_in:], inv1, out=high[:n].reshape(k, n_in))
                low[0] = eye
                high[n] = eye
                solved = bool(np.isfinite(coef).all())  # both in one test
    if not solved:
        low[0] = eye
        high[n] = eye
        m = np.tril(m) + np.tril(m, -1).T  # the least-squares fallback reads the whole matrix
        low[1:] = _spd_solve(m[n_in:, n_in:], -m[n_in:, :n_in]).reshape(n, n_in, n_in)
        high[:n] = _spd_solve(m[:k, :k], -m[k:, :k].T).reshape(n, n_in, n_in)
    return low, high


def _inv_small(a: NDArray[Any]) -> NDArray[Any]:
    """Inverse of a small square matrix; 2 x 2 in closed form (no LAPACK call).

    A singular 2 x 2 matrix gives non-finite entries (the caller tests them); larger ones raise
    :class:`numpy.linalg.LinAlgError` as :func:`numpy.linalg.inv`.
    """
    if a.shape == (2, 2):
        # in Python floats (no numpy error state to set: a zero determinant gives inf, and
        # inf or NaN entries follow without an exception)
        (p, q), (r, t) = a.tolist()
        det = p * t - q * r
        d = 1.0 / det if det != 0.0 else math.inf
        return np.array([[t * d, -q * d], [-r * d, p * d]])
    if a.shape == (1, 1):
        with np.errstate(divide="ignore"):
            return 1.0 / a
    return np.linalg.inv(a)


def _solve_order_one(m: NDArray[Any], n: int) -> tuple[NDArray[Any], NDArray[Any]] | None:
    """:func:`_solve_order` for one reference: the same Cholesky solve, without the block algebra.

    ``u = M^-1 [e_0, e_n]`` from one factor; ``alpha_low = u[:, 0] / u[0, 0]`` and
    ``alpha_high = u[:, 1] / u[n, 1]`` (the 1 x 1 pivot blocks of the general case are plain
    divisors). The factor is taken of ``m^T`` (a Fortran-ordered view, its UPPER triangle = the
    lower triangle of ``m``), so LAPACK reads ``m`` in place. Returns None when ``M`` is not
    numerically positive definite (the caller's fallback then solves the sub-blocks apart).
    """
    from scipy.linalg.lapack import dpotrf, dpotrs

    g, info = dpotrf(m.T, lower=0, clean=0)
    if info != 0:
        return None
    e = np.zeros((n + 1, 2), order="F")
    e[0, 0] = 1.0
    e[n, 1] = 1.0
    u, info = dpotrs(g, e, lower=0, overwrite_b=1)
    piv_low, piv_high = u[0, 0], u[n, 1]
    if info != 0 or not (piv_low > 0 and piv_high > 0):
        return None
    u[:, 0] /= piv_low
    u[:, 1] /= piv_high
    if not np.isfinite(u).all():  # both columns in one test
        return None
    u[0, 0] = 1.0
    u[n, 1] = 1.0
    # u is Fortran-ordered: each column is a contiguous (n + 1, 1, 1) view
    return u[:, 0].reshape(n + 1, 1, 1), u[:, 1].reshape(n + 1, 1, 1)


def _add_gram(p: NDArray[Any], q: NDArray[Any]) -> NDArray[Any]:
    """``p + q^T q`` in the LOWER triangle of ``p`` (in place when ``p`` is C-contiguous), returned.

    ``q`` has shape (m, ncol), ``p`` (ncol, ncol). One symmetric rank-m update (BLAS ``dsyrk``)
    for a whole block of rows: half the work of ``q.T @ q`` and one pass over ``p`` instead of
    one per row. The upper triangle of ``p`` is not updated.
    """
    from scipy.linalg.blas import dsyrk

    # a C-contiguous (m, ncol) array is the Fortran array q^T; the upper triangle of the
    # Fortran array p^T is the lower triangle of p
    out = dsyrk(1.0, np.ascontiguousarray(q).T, beta=1.0, c=p.T, trans=0, lower=0, overwrite_c=1)
    return cast("NDArray[Any]", out.T)


def _spd_solve(a: NDArray[Any], b: NDArray[Any]) -> NDArray[Any]:
    """Solve ``a x = b`` for symmetric positive (semi)definite ``a`` (LAPACK posv, lstsq fallback)."""
    from scipy.linalg import lapack, lstsq

    _, x, info = lapack.dposv(a, b, lower=1, overwrite_a=0, overwrite_b=0)
    if info != 0:
        return cast("NDArray[Any]", lstsq(a, b, check_finite=False)[0])
    return cast("NDArray[Any]", x)


def _companion(beta: NDArray[Any]) -> NDArray[Any]:
    """Block companion matrix of the monic matrix polynomial ``sum_j beta_j w^j`` (beta_n = I).

    ``beta`` has shape (n + 1, n_in, n_in) (the last block, I, is not used). The first block
    row is ``-[beta_{n-1}, ..., beta_0]``, identity blocks below the diagonal: upper Hessenberg
    for ``n_in = 1``. Its eigenvectors are ``[l w^{n-1}; ...; l w; l]``.
    """
    n = beta.shape[0] - 1
    n_in = beta.shape[1]
    k = n * n_in
    c = np.zeros((k, k), order="F")  # LAPACK's layout (no copy in _eigvals)
    c[:n_in, :] = -beta[n - 1 :: -1].transpose(1, 0, 2).reshape(n_in, k)
    # the ones at (n_in + i, i): flat index i (k + 1) + n_in of the column-major storage
    c.T.reshape(-1)[n_in : (k - n_in) * (k + 1) : k + 1] = 1.0
    return c


def _eigvals(c: NDArray[Any], *, checked: bool = False) -> NDArray[Any]:
    """Eigenvalues of a real square matrix: LAPACK ``dgeev`` without eigenvectors.

    The routine ``numpy.linalg.eigvals`` calls, with less wrapping (~5 us a call) and the same
    errors (:class:`numpy.linalg.LinAlgError`). The input array is overwritten when it is
    Fortran-ordered. ``checked``: the caller has made sure every entry is finite (a companion
    matrix of finite coefficients), so the matrix is not scanned again.
    """
    from scipy.linalg.lapack import dgeev

    if not checked and not np.isfinite(c).all():
        raise np.linalg.LinAlgError("Array must not contain infs or NaNs")
    wr, wi, _, _, info = dgeev(c, compute_vl=0, compute_vr=0, overwrite_a=1)
    if info != 0:
        raise np.linalg.LinAlgError("Eigenvalues did not converge")
    w = np.empty(wr.size, dtype=np.complex128)  # wr + 1j wi without the temporaries
    w.real = wr
    w.imag = wi
    return w


def _null_vectors(a: NDArray[Any]) -> NDArray[Any]:
    """Unit-norm left null vectors of each ``a[r]`` (n_z, n_in, n_in), largest entry real > 0."""
    n_in = a.shape[1]
    at = np.swapaxes(a, 1, 2)
    if n_in == 2:
        # l orthogonal to the row of larger norm: row (u, v) -> l = (-v, u)
        n0 = np.abs(at[:, 0, 0]) ** 2 + np.abs(at[:, 0, 1]) ** 2
        n1 = np.abs(at[:, 1, 0]) ** 2 + np.abs(at[:, 1, 1]) ** 2
        row = np.where((n0 >= n1)[:, None], at[:, 0, :], at[:, 1, :])
        vec = np.stack([-row[:, 1], row[:, 0]], axis=1)
    else:
        _, _, vh = np.linalg.svd(at)
        vec = vh[:, -1, :].conj()
    norm = np.linalg.norm(vec, axis=1, keepdims=True)
    vec = vec / np.where(norm > 0, norm, 1.0)
    big = np.argmax(np.abs(vec), axis=1)
    ph = vec[np.arange(vec.shape[0]), big]
    with np.errstate(invalid="ignore", divide="ignore"):
        vec = vec * (np.abs(ph) / np.where(ph != 0, ph, 1.0))[:, None]
    return cast("NDArray[Any]", vec)


def _roots_eig(low: NDArray[Any]) -> NDArray[Any]:
    """All roots z of det A_low(z), from the companion matrix of the reversed polynomial."""
    # roots of A_low(z) (alpha_0 = I) are 1 / w with w the roots of the reversed, monic polynomial;
    # the companion matrix holds the coefficients, zeros and ones: finite when they are
    if not np.isfinite(low).all():
        raise np.linalg.LinAlgError("Array must not contain infs or NaNs")
    w = _eigvals(_companion(low[::-1]), checked=True)
    if not w.all():  # dgeev's eigenvalues of a finite matrix are finite; a zero one is a root at infinity
        w = w[w != 0]
    return cast("NDArray[Any]", 1.0 / w)


def _roots_deflated(lows: list[NDArray[Any]], anchor: NDArray[Any]) -> list[NDArray[Any]]:
    """All roots z of several one-reference denominators ``A_low(z)``, the known stable ones divided out first.

    Parameters
    ----------
    lows : list of ndarray, each shape (n + 1, 1, 1)
        ``alpha_low`` (``alpha_0 = 1``) of orders of rising degree ``n``.
    anchor : ndarray, shape (m,), complex
        All roots of an order below the first (its companion eigenvalues).

    Returns
    -------
    list of ndarray, each shape (n,), complex
        The roots of each polynomial (the same set as :func:`_roots_eig`, to round-off).

    Notes
    -----
    The stable roots (``|z| < 1``) of consecutive orders barely move (on the denominators of
    benchmarks/bench_plscf.py 14 roots from order 16 on, 1e-7 to 1e-3 relative per order), while
    the companion QR costs ``~n^3``. Newton's iteration started from the anchor's stable roots
    (upper half plane; the mirror images follow, the polynomials being real) runs on every
    polynomial at once (one blocked evaluation per step, :func:`~._roots.eval_blocked`); a root
    counts only when its residual is at rounding level (the acceptance test of :mod:`._roots`),
    it lies inside the unit circle and apart from the others and their mirror images
    (:func:`~._roots.later_twins`). Those roots
    are divided out from the highest coefficient down (forward deflation: the synthetic division's
    recursion runs with the divided roots, all of modulus below 1, so rounding errors do not grow,
    Wilkinson's rule) in one banded triangular solve, and the companion QR runs on the quotient of
    degree ``n - s`` only; its roots take one Newton step on the undivided polynomial (the division
    costs them accuracy: ~1e-13 relative before, 1e-16 after, against 60-digit roots, where the
    companion QR of the whole polynomial gives 2e-15). The whole set must have the sum of the
    roots (:func:`~._roots.vieta_ok`), else that order takes the companion eigenvalues of the
    whole polynomial, so the result never depends on the start.
    """
    from scipy.linalg.blas import dtbsv

    k = len(lows)
    start = anchor[(np.abs(anchor) < 1.0) & (anchor.imag >= 0)]
    deg = np.array([low.shape[0] - 1 for low in lows])
    n = int(deg.max(initial=0))
    m = start.size
    padded = np.zeros((k, n + 1))
    for i, low in enumerate(lows):
        padded[i, : deg[i] + 1] = low[:, 0, 0]
    if k == 0 or m == 0 or not np.isfinite(padded).all():
        return [_roots_eig(low) for low in lows]
    blocks = coefficient_blocks(padded)[0]
    owner = np.repeat(np.arange(k), m)
    z = np.tile(start, k)
    real = z.imag == 0  # a real start stays real (a real polynomial, real arithmetic)
    act = np.arange(z.size)
    with np.errstate(all="ignore"):
        for _ in range(_DEFLATE_NEWTON):
            p, dp = eval_blocked(blocks, n, owner[act], z[act])
            step = p / dp
            z[act] -= step
            act = act[~(np.abs(step) <= _DEFLATE_STEP * np.abs(z[act]))]
            if act.size == 0:
                break
        # acceptance: the residual at rounding level (as _roots._ratio), the bound from |c_j| at |z|
        fin = np.isfinite(z) & (np.abs(z) < 1.0)
        fin[act] = False
        p, _ = eval_blocked(blocks, n, owner, np.where(fin, z, 0.0))
        bound, _ = eval_blocked(coefficient_blocks(np.abs(padded))[0], n, owner, np.abs(np.where(fin, z, 0.0)) + 0j)
        ok = fin & (np.abs(p) <= ROUNDING_PER_DEGREE * deg[owner] * bound.real)
    z, real = z.reshape(k, m), real.reshape(k, m)
    ok = ok.reshape(k, m) & (real | (z.imag > 0))  # a complex start stays in the upper half plane
    # no root divided out twice: two starts on one root, or a complex root on its mirror image (a
    # real root), among the roots and their mirror images: the later of such a pair is not divided
    mirror = np.where(ok & ~real, z.conj(), np.nan)
    twin = later_twins(np.concatenate([np.where(ok, z, np.nan), mirror], axis=1))
    ok &= ~(twin[:, :m] | twin[:, m:])
    # the divisor of each polynomial, lowest coefficient first: a real factor z - x or a
    # quadratic z^2 - 2 Re(r) z + |r|^2 per root (1 where none)
    s = np.where(ok, np.where(real, 1, 2), 0).sum(axis=1)
    c0 = np.where(ok, np.where(real, -z.real, z.real * z.real + z.imag * z.imag), 1.0)
    c1 = np.where(ok, np.where(real, 1.0, -2.0 * z.real), 0.0)
    c2 = (ok & ~real).astype(float)
    f = np.zeros((k, int(s.max()) + 1))
    f[:, 0] = 1.0
    for j in np.flatnonzero(ok.any(axis=0)).tolist():
        prod = f * c0[:, j, None]
        prod[:, 1:] += f[:, :-1] * c1[:, j, None]
        prod[:, 2:] += f[:, :-2] * c2[:, j, None]
        f = prod
    # the quotients from the highest coefficient down: per order the lower triangular Toeplitz
    # system of f (band storage, f's coefficients highest first on its diagonals), all orders in
    # ONE banded solve (no band reaches from one order's columns into the next's)
    nq = deg - s
    rows = nq + 1
    first = np.concatenate([[0], np.cumsum(rows)[:-1]])
    col = np.repeat(np.arange(k), rows)  # the order of each column
    local = np.arange(col.size) - first[col]
    t = np.arange(int(s.max()) + 1)
    back = s[:, None] - t[None, :]
    fh = np.where(back >= 0, np.take_along_axis(f, np.maximum(back, 0), axis=1), 0.0)  # (k, s_max + 1)
    band = np.asfortranarray(fh[col].T * (local[None, :] + t[:, None] <= nq[col][None, :]))
    q_all = dtbsv(int(s.max()), band, padded[col, deg[col] - local], lower=1)
    ws = []
    for i in range(k):
        q = q_all[first[i] : first[i] + rows[i]]  # highest first
        m_i = int(nq[i])
        # its roots as _roots_eig's: 1 / w, w the companion eigenvalues of the reversed monic polynomial
        if m_i == 0:  # every root divided out
            ws.append(np.zeros(0, dtype=np.complex128))
            continue
        comp = np.zeros((m_i, m_i), order="F")
        comp[0] = q[-2::-1] / -q[-1]
        comp.T.reshape(-1)[1 : (m_i - 1) * (m_i + 1) : m_i + 1] = 1.0
        ws.append(_eigvals(comp, checked=True))
    with np.errstate(all="ignore"):
        zq = 1.0 / np.concatenate(ws)
        # the quotient's roots are ~1e-13 from those of the polynomial (the division rounds its
        # coefficients, and they are worse conditioned in the quotient): one Newton step on the
        # polynomial itself, where no power overflows, brings them to its round-off
        qown = np.repeat(np.arange(k), nq)
        fit = np.flatnonzero(deg[qown] * np.log10(np.maximum(np.abs(zq), 1.0)) <= 150)
        p, dp = eval_blocked(blocks, n, qown[fit], zq[fit])
        step = p / dp
        zq[fit] -= np.where(np.abs(step) <= _DEFLATE_POLISH * np.abs(zq[fit]), step, 0.0)  # NaN: no step
    # each order's roots: its quotient's, the divided ones and their mirror images, in one gather
    rk, rj = np.nonzero(ok)
    cx = ~real[rk, rj]
    pieces = np.concatenate([zq, z[rk, rj], z[rk[cx], rj[cx]].conj()])
    key = np.concatenate([qown * 3, rk * 3 + 1, rk[cx] * 3 + 2])
    every = pieces[np.argsort(key, kind="stable")]
    ends = np.cumsum(deg)
    # the sum of the roots (Vieta) of every order at once
    bounds = np.concatenate([[0], ends[:-1]])
    lead = np.arange(k)
    good = vieta_ok(padded[lead, deg - 1], padded[lead, deg], np.add.reduceat(every, bounds),
                    np.add.reduceat(np.abs(every), bounds))
    return [every[a:b] if g else _roots_eig(low) for a, b, g, low in zip(bounds, ends, good.tolist(), lows, strict=True)]


def _poles_of_orders(
    entries: list[tuple[int, NDArray[Any], NDArray[Any]]], dt: float, f_lo: float
) -> list[tuple[NDArray[Any], NDArray[Any]]]:
    """Physical poles (rad/s, Im > 0) and participation vectors of several orders.

    ``entries`` holds ``(order, alpha_high, z)`` per order, ``z`` all roots of ``det A_low``.
    Of each conjugate pair only the root with ``Im s' > 0`` is kept (real roots, ``z > 0``: no
    oscillation, ``z < 0``: exactly at the band's top, are not modes); each stable root
    (``|z| < 1``) is polished on the ``alpha_n = I`` polynomial (:func:`_refine_many`), and the
    participation vector is computed where a mode can be physical (``Re s < 0``, the test of
    ``StabilizationData.unstable``; NaN otherwise). The polish and the participation vectors of
    every order are evaluated together, one array operation per step instead of several per
    order: the coefficient blocks of each order are padded with zero blocks to the highest
    order, which changes no polynomial.
    """
    nyq = np.pi / dt
    n_in = entries[0][1].shape[1] if entries else 1
    top = max((e[1].shape[0] for e in entries), default=1)
    high = np.zeros((len(entries), top, n_in, n_in))
    for k, (_, h, _) in enumerate(entries):
        high[k, : h.shape[0]] = h
    # the roots of all orders at once: one selection over the concatenated roots
    z_cat = np.concatenate([np.asarray(e[2], dtype=np.complex128) for e in entries]) if entries else np.zeros(0, complex)
    o_cat = np.repeat(np.arange(len(entries)), [np.size(e[2]) for e in entries])
    im = np.angle(z_cat) / dt  # = Im(log z) / dt
    sel = (im > 1e-9 * nyq) & (im < (1 - 1e-9) * nyq) & (z_cat != 0)
    z_all, owner = z_cat[sel], o_cat[sel]
    stable = np.abs(z_all) < 1.0
    if stable.any():
        z_all[stable] = _refine_many(high, owner[stable], z_all[stable])
    with np.errstate(divide="ignore", invalid="ignore"):
        s_all = np.log(z_all) / dt
    part = np.full((z_all.size, n_in), np.nan, dtype=np.complex128)
    phys = s_all.real < 0
    if phys.any():
        part[phys] = _participation_many(high, owner[phys], z_all[phys])
    bounds = np.concatenate([[0], np.cumsum(np.bincount(owner, minlength=len(entries)))])
    return [(s_all[a:b] + 2j * np.pi * f_lo, part[a:b]) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def _eval_many(high: NDArray[Any], owner: NDArray[Any], z: NDArray[Any],
               derivative: bool = True) -> tuple[NDArray[Any], NDArray[Any] | None]:
    """``A(z)`` and ``A'(z)`` of the polynomial ``high[owner[r]]`` at each ``z[r]``: (n_z, n_in, n_in).

    ``A'`` is None when ``derivative`` is False (half the products). In chunks of roots of about
    half a megabyte of powers and gathered coefficients: the roots of every order are many, and
    their powers are never held all at once. The powers come from the blocked tables of
    :func:`~._roots.powers` (vectorised over the roots, at most ``2 sqrt(n)`` rounded factors each).
    """
    n1, n_in = high.shape[1], high.shape[2]
    j = np.arange(n1)
    rows = 4 if derivative else 2
    a = np.empty((z.size, n_in, n_in), dtype=np.complex128)
    da = np.empty_like(a) if derivative else None
    step = max(1, (1 << 19) // (n1 * (n_in * n_in + 4) * 8))
    for r0 in range(0, z.size, step):
        zc = z[r0 : r0 + step]
        v = powers(zc, n1 - 1)  # (n1, chunk)
        # real and imaginary parts of the powers (and of their derivatives) as two (four) real
        # rows per root, times the root's real coefficients: one stack of real products (no
        # complex copy of the gathered coefficients)
        w = np.empty((zc.size, rows, n1))
        w[:, 0], w[:, 1] = v.real.T, v.imag.T
        if da is not None:
            w[:, 2:, 0] = 0.0
            np.multiply(v.real[:-1].T, j[1:], out=w[:, 2, 1:])
            np.multiply(v.imag[:-1].T, j[1:], out=w[:, 3, 1:])
        c = high[owner[r0 : r0 + step]].reshape(zc.size, n1, n_in * n_in)
        res = np.matmul(w, c)  # (chunk, rows, n_in^2)
        a[r0 : r0 + step] = (res[:, 0] + 1j * res[:, 1]).reshape(-1, n_in, n_in)
        if da is not None:
            da[r0 : r0 + step] = (res[:, 2] + 1j * res[:, 3]).reshape(-1, n_in, n_in)
    return a, da


def _refine_many(high: NDArray[Any], owner: NDArray[Any], z: NDArray[Any], iters: int = 3) -> NDArray[Any]:
    """Newton steps on ``det A(z) = 0`` from the starting roots ``z``, ``A = high[owner[r]]`` for root r.

    The step is ``det A / (d det A / dz)`` with the derivative from Jacobi's formula (sum of
    the determinants with one column replaced by the column of ``A'``), which stays finite at
    a root. A root that moves by more than a tenth of its distance to the unit circle is left
    where it started.
    """
    z0 = z.copy()
    zk = z.copy()
    n_in = high.shape[2]
    blocks = coefficient_blocks(high[:, :, 0, 0])[0] if n_in == 1 else None
    for _ in range(iters):
        if blocks is None:
            a, da_ = _eval_many(high, owner, zk)
            da = cast("NDArray[Any]", da_)
        with np.errstate(all="ignore"):
            if blocks is not None:  # one reference: p / p' from the blocked coefficients
                p, dp = eval_blocked(blocks, high.shape[1] - 1, owner, zk)
                step = p / dp
            elif n_in == 2:
                # det A = a00 a11 - a01 a10 and its derivative (product rule), in closed form
                a00, a01, a10, a11 = a[:, 0, 0], a[:, 0, 1], a[:, 1, 0], a[:, 1, 1]
                ddet = da[:, 0, 0] * a11 + a00 * da[:, 1, 1] - da[:, 0, 1] * a10 - a01 * da[:, 1, 0]
                step = (a00 * a11 - a01 * a10) / ddet
            else:
                ddet = np.zeros(zk.size, dtype=np.complex128)
                for i in range(n_in):
                    ai = a.copy()
                    ai[:, :, i] = da[:, :, i]
                    ddet += np.linalg.det(ai)
                step = np.linalg.det(a) / ddet
        step = np.where(np.isfinite(step), step, 0.0)
        zk = zk - step
        if np.all(np.abs(step) <= 1e-12 * np.abs(zk)):
            break
    moved = np.abs(zk - z0)
    bad = ~np.isfinite(zk) | (moved > 0.1 * np.abs(1.0 - np.abs(z0)))
    zk[bad] = z0[bad]
    return zk


def _participation_many(high: NDArray[Any], owner: NDArray[Any], z: NDArray[Any]) -> NDArray[Any]:
    """Unit-norm null vectors ``l`` of ``A(z)^T`` (left null vectors of A), ``A = high[owner[r]]``: (n_z, n_in)."""
    n_in = high.shape[2]
    if n_in == 1:
        return np.ones((z.size, 1), dtype=np.complex128)
    a, _ = _eval_many(high, owner, z, derivative=False)
    return _null_vectors(a)


def _normalise_orders(orders: Iterable[int] | None, max_order: int, n_in: int) -> list[int]:
    if orders is None:
        step = 2 if n_in == 1 else 1
        return list(range(step, max_order + 1, step)) or [max_order]
    out = sorted({int(o) for o in orders})
    if not out or out[0] < 1 or out[-1] > max_order:
        raise ValueError(f"orders must lie in 1..max_order={max_order}, got {orders!r}")
    return out


def plscf(
    data: FRFData,
    *,
    max_order: int | None = None,
    band: tuple[float, float] | None = None,
    orders: Iterable[int] | None = None,
    progress: bool = False,
    root_finder: str = "aberth",
    threads: int | None = None,
) -> PoleSet:
    """Estimate poles and participation factors with PolyMAX for a range of model orders.

    Parameters
    ----------
    data : FRFData
        FRFs, shape (n_out, n_in, n_freq), any form (poles do not depend on it).
    max_order : int, optional
        Highest denominator order ``n`` (each order gives ``n * n_in`` poles before the
        half-plane selection). Default :func:`default_max_order` (64 for one reference,
        40 for several).
    band : (float, float), optional
        ``(freq_lower, freq_upper)`` in Hz; default the whole data.
    orders : iterable of int, optional
        Orders to compute (default every even order 2..max_order for one reference, every
        order 1..max_order for several).
    progress : bool, optional
        Show a tqdm progress bar over the orders.
    root_finder : {'aberth', 'eig'}, optional
        ``'aberth'`` (default): roots of each order of degree >= 64 (one reference: >= 48
        when the orders reach 64; several: >= 32 when the orders end at degree 64-100) by the Aberth-Ehrlich
        iteration started from the previous order's roots (several times faster; an order
        that does not converge falls back to the companion eigenvalues), smaller orders by
        the companion eigenvalues. ``'eig'``: companion eigenvalues
        for every order, spread over ``threads`` worker threads.
    threads : int, optional
        Worker threads for ``root_finder='eig'`` (default: ``min(2, os.cpu_count())``).

    Returns
    -------
    PoleSet
        Poles with ``Im > 0`` whose frequency lies in the band, of every computed order.

    Raises
    ------
    IdentificationError
        Band outside the data, NaN/inf values, all-zero FRF, or too few lines for the order
        (``n_freq`` must exceed ``2 * max_order``).
    ValueError
        ``max_order`` < 1 or ``orders`` outside ``1..max_order``.

    See Also
    --------
    ema_rig.identification.stabilization.stabilize, ema_rig.identification.identify

    Examples
    --------
    >>> import numpy as np
    >>> from ema_rig.frf import FRFData
    >>> f = np.arange(0.0, 200.5, 0.5)
    >>> s = 1j * 2 * np.pi * f
    >>> lam = 2 * np.pi * 80 * (-0.01 + 1j * np.sqrt(1 - 0.01**2))
    >>> h = (1 / (s - lam) + 1 / (s - lam.conjugate()))[None, None, :]
    >>> ps = plscf(FRFData(f, h, ["1+Y"], ["1+Y"], frf_form="receptance"), max_order=10)
    >>> top = ps.order == 10
    >>> bool(np.any(np.isclose(ps.natural_freq[top], 80.0, rtol=1e-6)))
    True
    """
    if max_order is None:
        max_order = default_max_order(data.n_in)
    max_order = int(max_order)
    if max_order < 1:
        raise ValueError(f"max_order must be >= 1, got {max_order}")
    data = check_data(data, band)
    order_list = _normalise_orders(orders, max_order, data.n_in)
    with single_threaded():  # one BLAS limit for the whole call; the engine's own blocks nest in it
        engine = PlscfEngine(data, order_list[-1], root_finder=root_finder, threads=threads)
        return engine.poles(order_list, progress=progress)


class PlscfEngine:
    """pLSCF on one band, evaluated order by order up to a cap (the incremental form of :func:`plscf`).

    The lag sums and the Cholesky factor of ``R`` are formed once for the cap ``max_order``;
    the reduced matrix of every lower order is a leading block of the cap's (see the module
    notes), so asking for more orders later (:meth:`poles` with higher orders) costs the new
    orders' rows of ``Q = L^-1 S``, solves and roots (and, when the blocks must grow beyond the
    order they were built for, which doubles each time, the earlier rows once more). ``Q`` is
    streamed in blocks of rows (half the FRF data, 8..64 MB) and never held whole when it is
    larger. :attr:`order_limit` is the highest order the lines support (``R`` positive
    definite); asking for more raises :class:`~ema_rig.errors.IdentificationError`.

    Parameters
    ----------
    data : FRFData
        Checked data already cut to the band (:func:`check_data`).
    max_order : int
        Cap on the model order; ``data.n_freq`` must exceed ``2 * max_order``.
    root_finder : {'aberth', 'eig'}, optional
    threads : int, optional
        See :func:`plscf`.

    Raises
    ------
    IdentificationError
        Too few lines for ``max_order``.
    """

    def __init__(self, data: FRFData, max_order: int, *, root_finder: str = "aberth",
                 threads: int | None = None) -> None:
        if root_finder not in ("aberth", "eig"):
            raise ValueError(f"root_finder must be 'aberth' or 'eig', got {root_finder!r}")
        max_order = int(max_order)
        if max_order < 1:
            raise ValueError(f"max_order must be >= 1, got {max_order}")
        src = source_of(data)
        if data.n_freq <= 2 * max_order:
            raise IdentificationError(
                f"too few lines for max_order={max_order}: {data.n_freq} lines in "
                f"{data.freq[0]:g}..{data.freq[-1]:g} Hz, need more than {2 * max_order}",
                file=src,
            )
        self.data = data
        self.max_order = max_order
        self.root_finder = root_finder
        self.threads = threads  # None: min(2, cores), looked up only for root_finder='eig' (_compute)
        self.n_in = data.n_in
        self.f_lo, self.f_hi = float(data.freq[0]), float(data.freq[-1])
        with single_threaded():
            self._r, self._s, self._t, _, self.dt = _lag_sums(data, max_order)
            self.order_limit, self._r_factor = _order_limit(self._r)
        self._alloc = 0  # order the reduced blocks are built for (grown on demand up to the cap)
        self._done = 0  # rows of Q already accumulated into P
        self._last = 0  # highest order computed so far
        self._prev: NDArray[Any] | None = None  # roots of the last order rooted
        self._prev_low: NDArray[Any] | None = None  # and its alpha_low
        self._rows: dict[int, tuple[NDArray[Any], NDArray[Any]]] = {}
        self.n_aberth = 0
        self.fallbacks = 0

    def _blocks(self, n: int) -> None:
        """Build (or enlarge) the reduced blocks so that orders up to ``n`` can be formed.

        The blocks of order ``p`` are built from the lag sums of the cap; the leading rows of
        ``Q`` and the leading blocks of ``T`` do not depend on ``p``, so enlarging only
        re-accumulates ``P`` (now wider) from the rows already used, made again from the lag
        sums. The size at least doubles each time.
        """
        if n <= self._alloc:
            return
        p = min(self.max_order, self.order_limit, max(n, 2 * self._alloc))
        cap = self.max_order
        lags = np.arange(cap - p, cap + p + 1)  # lags -p..p inside the cap's -cap..cap
        self._T, self._linv = _reduced_factor(self._r[: p + 1], self._t[:, :, lags], p, self._r_factor)
        self._sp = self._s[:, :, lags]  # lag sums -p..p, (n_out, n_in, 2p+1)
        self._alloc = p
        ncol = (p + 1) * self.n_in
        self._P = np.zeros((ncol, ncol))  # lower triangle only (_add_gram)
        for _, rows in self._row_blocks(0, self._done - 1):
            self._P = _add_gram(self._P, rows.reshape(-1, ncol))

    def _row_blocks(self, a: int, b: int) -> Iterator[tuple[int, NDArray[Any]]]:
        """Rows ``a..b`` of ``Q`` in blocks of at most :data:`_Q_BLOCK_BYTES`: (first row, rows); a last block
        of fewer than :data:`_Q_LAST_BLOCK_SHARE` of a block's rows is part of the one before."""
        p = self._alloc
        n_out = self._sp.shape[0]
        budget = min(_Q_BLOCK_BYTES, max(_Q_BLOCK_MIN_BYTES, self.data.frf.nbytes // 2))
        per = max(1, budget // (n_out * (p + 1) * self.n_in * 8))
        starts = list(range(a, b + 1, per))
        if len(starts) > 1 and b + 1 - starts[-1] < _Q_LAST_BLOCK_SHARE * per:
            starts.pop()
        for k, i0 in enumerate(starts):
            yield i0, _q_rows(self._sp, self._linv, p, i0, starts[k + 1] - 1 if k + 1 < len(starts) else b)

    def _compute(self, order_list: list[int], bar: Any) -> None:
        """Solve and root every order of ``order_list`` (ascending, above those already done)."""
        n_in, dt, f_lo = self.n_in, self.dt, self.f_lo
        if order_list[-1] > self.order_limit:
            raise IdentificationError(
                f"order {order_list[-1]} is beyond what the lines of {self.f_lo:g}..{self.f_hi:g} Hz support "
                f"(order {self.order_limit} at most: the lines leave the basis matrix R singular above it, "
                "e.g. a gap or very uneven spacing in the frequency lines); lower max_order or choose a band "
                "without gaps", file=source_of(self.data))
        with single_threaded():
            self._blocks(order_list[-1])
        pool = None
        if self.root_finder == "eig" and len(order_list) > 4:
            threads = self.threads if self.threads is not None else min(2, os.cpu_count() or 1)
            if threads > 1:
                pool = ThreadPoolExecutor(max_workers=threads)

        def work(low: NDArray[Any]) -> NDArray[Any]:
            with single_threaded():
                return _roots_eig(low)

        wanted = set(order_list)

        def solvable() -> Iterator[int]:
            # add the rows of Q one block at a time; an order is solved once its rows are in P
            # (the rows since the last solved order are added together, one rank update)
            for i0, rows in self._row_blocks(self._done, order_list[-1]):
                a = 0
                for k in range(rows.shape[0]):
                    if i0 + k in wanted or k == rows.shape[0] - 1:
                        self._P = _add_gram(self._P, rows[a : k + 1].reshape(-1, rows.shape[2]))
                        a = k + 1
                        self._done = i0 + k + 1
                        if i0 + k in wanted:
                            yield i0 + k

        # per order: solve and root; the polish of the stable roots and the participation
        # factors of all these orders follow at once (_poles_of_orders)
        entries: list[tuple[int, NDArray[Any], Any]] = []
        chain: list[tuple[int, NDArray[Any], NDArray[Any]]] = []
        deflate: list[tuple[int, NDArray[Any]]] = []  # (entry index, alpha_low): _root_deflated
        aberth_from, chain_max = _ABERTH_MIN_DEGREE, _CHAIN_MAX_DEGREE
        if n_in == 1:
            if order_list[-1] >= _ABERTH_MIN_DEGREE:
                aberth_from = _CHAIN_FROM_DEGREE_ONE  # the chain goes on past _ABERTH_MIN_DEGREE
        elif _ABERTH_MIN_DEGREE <= order_list[-1] * n_in <= _CHAIN_LOW_TOP_MIMO:
            aberth_from = _CHAIN_FROM_DEGREE_MIMO  # likewise for several references
        try:
            with single_threaded():
                for n in solvable():
                    c = (n + 1) * n_in
                    low, high = _solve_order(self._T[:c, :c] - self._P[:c, :c], n, n_in)
                    self._last = n
                    if pool is not None:
                        entries.append((n, high, pool.submit(work, low)))
                        continue
                    z = None
                    big = self.root_finder == "aberth" and n * n_in >= aberth_from
                    if (n_in == 1 and not big and self.root_finder == "aberth" and n >= _DEFLATE_FROM_DEGREE
                            and self._prev is not None):
                        deflate.append((len(entries), low))  # rooted together (_root_deflated)
                        entries.append((n, high, None))
                        continue
                    self._root_deflated(deflate, entries, bar)
                    if big and self._prev is not None:
                        coef = det_coefficients(low)
                        if coef.size - 1 <= chain_max:
                            chain.append((len(entries), coef, low))  # rooted together (_root_chain)
                            entries.append((n, high, None))
                            continue
                        self._root_chain(chain, entries, bar)
                        # the first sweep's repulsion sums from the previous order's polynomial
                        assert self._prev_low is not None
                        z = aberth_warm(coef, det_coefficients(self._prev_low), self._prev)
                        self.n_aberth += z is not None
                        self.fallbacks += z is None
                    if z is None:
                        z = _roots_eig(low)
                    self._prev, self._prev_low = z, low
                    entries.append((n, high, z))
                    if bar is not None:
                        bar.update()
                self._root_deflated(deflate, entries, bar)
                self._root_chain(chain, entries, bar)
            if pool is not None:
                entries = [(n, high, fut.result()) for n, high, fut in entries]
                if bar is not None:
                    bar.update(len(entries))
        finally:
            if pool is not None:
                pool.shutdown(wait=True, cancel_futures=True)
        with single_threaded():
            done = _poles_of_orders(entries, dt, f_lo)
        for (n, _, _), row in zip(entries, done, strict=True):
            self._rows[n] = row

    def _root_chain(self, chain: list[tuple[int, NDArray[Any], NDArray[Any]]],
                    entries: list[tuple[int, NDArray[Any], Any]], bar: Any) -> None:
        """Roots of the orders deferred in ``chain`` ((entry index, det coefficients, alpha_low) each),
        all at once by :func:`~._roots.aberth_chain` from the roots before them; an order that does
        not converge falls back to the companion eigenvalues. Fills ``entries`` and empties ``chain``.
        """
        if not chain:
            return
        assert self._prev is not None
        found = aberth_chain([coef for _, coef, _ in chain], self._prev)
        for (k, _, low), z in zip(chain, found, strict=True):
            self.n_aberth += z is not None
            self.fallbacks += z is None
            n, high, _ = entries[k]
            entries[k] = (n, high, z if z is not None else _roots_eig(low))
            if bar is not None:
                bar.update()
        self._prev, self._prev_low = entries[chain[-1][0]][2], chain[-1][2]
        chain.clear()

    def _root_deflated(self, deflate: list[tuple[int, NDArray[Any]]],
                       entries: list[tuple[int, NDArray[Any], Any]], bar: Any) -> None:
        """Roots of the orders deferred in ``deflate`` ((entry index, alpha_low) each), all at once by
        :func:`_roots_deflated` from the roots before them. Fills ``entries`` and empties ``deflate``."""
        if not deflate:
            return
        assert self._prev is not None
        found = _roots_deflated([low for _, low in deflate], self._prev)
        for (k, _), z in zip(deflate, found, strict=True):
            n, high, _ = entries[k]
            entries[k] = (n, high, z)
            if bar is not None:
                bar.update()
        self._prev, self._prev_low = found[-1], deflate[-1][1]
        deflate.clear()

    def poles(self, orders: Iterable[int], *, progress: bool = False) -> PoleSet:
        """Poles of the given orders (computing those not yet computed).

        Parameters
        ----------
        orders : iterable of int
            Orders in ``1..max_order``; new ones must lie above every order computed so far.
        progress : bool, optional
            tqdm progress bar over the new orders.

        Returns
        -------
        PoleSet
        """
        order_list = _normalise_orders(orders, self.max_order, self.n_in)
        todo = [n for n in order_list if n not in self._rows]
        if todo and todo[0] <= self._last:
            raise ValueError(f"orders below {self._last + 1} can no longer be added, got {todo[0]}")
        bar = None
        if progress and todo:
            bar = progress_bar(total=len(todo), desc="pLSCF orders", unit="order")
        try:
            if todo:
                self._compute(todo, bar)
        finally:
            if bar is not None:
                bar.close()
        if self.fallbacks:
            logger.debug("pLSCF: %d orders fell back to companion eigenvalues", self.fallbacks)
        f_lo, f_hi, n_in = self.f_lo, self.f_hi, self.n_in
        rows = [self._rows[n] for n in order_list]
        # all orders at once: one band test over the concatenated poles
        order = np.repeat(np.asarray(order_list, dtype=np.int64), [r[0].size for r in rows])
        pole = np.concatenate([r[0] for r in rows]) if rows else np.zeros(0, complex)
        part = np.concatenate([r[1] for r in rows]) if rows else np.zeros((0, n_in), complex)
        fn = np.abs(pole) / (2 * np.pi)
        keep = (fn >= f_lo) & (fn <= f_hi)
        logger.debug("pLSCF: %d orders up to %d on %d lines", len(order_list), order_list[-1], self.data.n_freq)
        return PoleSet(
            order=order[keep],
            pole=pole[keep],
            participation=part[keep],
            band=(f_lo, f_hi),
            in_dofs=self.data.in_dofs,
            orders=tuple(order_list),
            meta={"dt": self.dt, "n_freq": self.data.n_freq,
                  "constraint": "alpha_0 = I (roots), polished on alpha_n = I",
                  "root_finder": self.root_finder, "aberth_orders": int(self.n_aberth),
                  "fallbacks": int(self.fallbacks), "freq_shift": f_lo},
        )


__all__ = ["PlscfEngine", "PoleSet", "check_data", "default_max_order", "plscf"]
