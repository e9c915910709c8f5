"""A second opinion from sdypy-EMA: its LSCF estimator on the same band, mode by mode.

Functions
---------
crosscheck
    Run sdypy-EMA's LSCF on the band of an :class:`~ema_rig.identification.Identification`
    and match its stable poles to each identified mode.

Classes
-------
CrossCheck, CrossCheckRow, PeerMode
    The per-mode agreement table, with a flag where the tools differ by more than their
    combined standard deviation, and the modes only sdypy-EMA finds.

Notes
-----
sdypy-EMA's LSCF is a single-reference (common-denominator) estimator, so every
output/reference channel is handed to it as one "location". Only its public API is used
(``Model.get_poles``, then ``Model.all_poles`` / ``pole_freq`` / ``pole_xi``, one array per
order): its stability test exists only as the private ``stabilization._stabilization`` or inside
``select_closest_poles``, whose fixed 2 Hz search window mixes modes closer than that. The same
test is applied here, as sdypy-EMA applies it: a pole is stable when the previous order has a
pole within 1 % in frequency and a pole within 5 % in damping (sdypy-EMA's defaults; not
necessarily the same pole) and its damping is positive. For each mode of ema_rig
the stable poles within ``tol`` (relative) are collected over all orders: their median frequency
and damping are sdypy-EMA's estimate and their standard deviation over the orders (ddof 1) its
sigma (the only spread sdypy-EMA offers; it is an order spread, not a noise-based uncertainty).

A mode is flagged when ``|f_peer - f| > COMBINED_SIGMAS * sqrt(sigma_f^2 + sigma_f,peer^2)``
(flag ``f``) or the same holds for the damping ratio (flag ``zeta``); a sigma that is not known
(NaN) counts as 0, so such a mode is flagged on any difference. When the data were windowed
exponentially (:func:`~ema_rig.processing.processing_history`), sdypy-EMA's poles get the same
correction as ema_rig's before they are compared. sdypy-EMA is imported only here (it imports
matplotlib.pyplot); this module selects no matplotlib backend.
"""

from __future__ import annotations

import contextlib
import io
import time
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import IdentificationError
from ..frf import FRFData
from ..processing import processing_history
from .identification import Identification
from .window_damping import remove_decay

COMBINED_SIGMAS = 1.0
"""Difference, in combined standard deviations, above which a mode is flagged. Source: issue 18
item 6 ("flags every mode where the two tools differ by more than their combined sigma"); with
Gaussian errors about a third of consistent estimates exceed 1 sigma, so a flag asks for a look
at the mode, it does not say which tool is wrong."""
PEER_MIN_ORDERS = 4
"""Orders a cluster of sdypy-EMA's stable poles must span to be listed as a mode ema_rig missed:
the minimum ema_rig's own judgement asks of a cluster (``judge_clusters(min_poles=4)``)."""
STABLE_FREQ_TOL = 0.01
"""Relative frequency change between consecutive orders of a stable pole (sdypy-EMA default)."""
STABLE_DAMPING_TOL = 0.05
"""Relative damping change between consecutive orders of a stable pole (sdypy-EMA default)."""


def _combined(a: float, b: float) -> float:
    return float(np.hypot(np.nan_to_num(a, nan=0.0), np.nan_to_num(b, nan=0.0)))


@dataclass(frozen=True, slots=True)
class CrossCheckRow:
    """One mode of ema_rig and sdypy-EMA's stable poles near it.

    ``natural_freq_peer`` / ``damping_ratio_peer`` (and their std) are NaN and ``n_orders_peer``
    is 0 when sdypy-EMA has no stable pole within the tolerance. Frequencies in Hz, damping
    ratios as fractions; ``*_std`` one standard deviation (NaN when unknown: ema_rig's as the
    identification states it, sdypy-EMA's the spread over its orders, NaN from one order).
    """

    natural_freq: float
    damping_ratio: float
    natural_freq_peer: float
    damping_ratio_peer: float
    n_orders_peer: int
    natural_freq_std: float = float("nan")
    damping_ratio_std: float = float("nan")
    natural_freq_std_peer: float = float("nan")
    damping_ratio_std_peer: float = float("nan")

    @property
    def freq_diff(self) -> float:
        """Relative frequency difference (peer - ema_rig) / ema_rig."""
        return (self.natural_freq_peer - self.natural_freq) / self.natural_freq

    @property
    def found(self) -> bool:
        """True when sdypy-EMA has stable poles near the mode."""
        return self.n_orders_peer > 0

    @property
    def freq_sigma(self) -> float:
        """Combined standard deviation of the two frequencies [Hz] (an unknown one counts as 0)."""
        return _combined(self.natural_freq_std, self.natural_freq_std_peer)

    @property
    def damping_sigma(self) -> float:
        """Combined standard deviation of the two damping ratios (an unknown one counts as 0)."""
        return _combined(self.damping_ratio_std, self.damping_ratio_std_peer)

    @property
    def flags(self) -> tuple[str, ...]:
        """``('f',)``, ``('zeta',)``, both or none: where the tools differ by more than
        ``COMBINED_SIGMAS`` combined standard deviations; ``('missing',)`` when sdypy-EMA has
        no stable pole near the mode."""
        if not self.found:
            return ("missing",)
        out = []
        if abs(self.natural_freq_peer - self.natural_freq) > COMBINED_SIGMAS * self.freq_sigma:
            out.append("f")
        if abs(self.damping_ratio_peer - self.damping_ratio) > COMBINED_SIGMAS * self.damping_sigma:
            out.append("zeta")
        return tuple(out)

    @property
    def flagged(self) -> bool:
        """True when :attr:`flags` is not empty."""
        return bool(self.flags)


@dataclass(frozen=True, slots=True)
class PeerMode:
    """A cluster of sdypy-EMA's stable poles with no ema_rig mode within the tolerance.

    Frequencies in Hz, damping ratios as fractions: the median over the orders and the standard
    deviation over them (ddof 1); ``n_orders`` the number of orders it is stable at.
    """

    natural_freq: float
    damping_ratio: float
    n_orders: int
    natural_freq_std: float
    damping_ratio_std: float


@dataclass(frozen=True, slots=True)
class CrossCheck:
    """Result of :func:`crosscheck`.

    Parameters
    ----------
    rows : tuple of CrossCheckRow
        One per identified mode, by frequency.
    band : tuple of float
        Band [Hz].
    order : int
        Highest polynomial order given to sdypy-EMA.
    seconds : float
        Wall time of sdypy-EMA's pole estimate.
    peer_only : tuple of PeerMode
        Modes sdypy-EMA finds (stable at ``PEER_MIN_ORDERS`` orders or more) where ema_rig
        reports none within the tolerance, by frequency.
    """

    rows: tuple[CrossCheckRow, ...]
    band: tuple[float, float]
    order: int
    seconds: float
    peer_only: tuple[PeerMode, ...] = ()

    def to_dict(self) -> dict[str, Any]:
        """The table as JSON-ready values: band, order, one entry per mode with its ``flags``, and
        ``peer_only``. The wall time is left out (a result never depends on the clock); NaN is None."""

        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        rows = [{"natural_freq": num(r.natural_freq), "damping_ratio": num(r.damping_ratio),
                 "natural_freq_std": num(r.natural_freq_std), "damping_ratio_std": num(r.damping_ratio_std),
                 "natural_freq_peer": num(r.natural_freq_peer), "damping_ratio_peer": num(r.damping_ratio_peer),
                 "natural_freq_std_peer": num(r.natural_freq_std_peer),
                 "damping_ratio_std_peer": num(r.damping_ratio_std_peer), "n_orders_peer": int(r.n_orders_peer),
                 "flags": list(r.flags)} for r in self.rows]
        missed = [{"natural_freq": num(m.natural_freq), "damping_ratio": num(m.damping_ratio),
                   "natural_freq_std": num(m.natural_freq_std), "damping_ratio_std": num(m.damping_ratio_std),
                   "n_orders": int(m.n_orders)} for m in self.peer_only]
        return {"tool": "sdypy-EMA LSCF", "band": [float(self.band[0]), float(self.band[1])], "order": int(self.order),
                "combined_sigmas": COMBINED_SIGMAS, "n_flagged": int(self.n_flagged), "modes": rows,
                "peer_only": missed}

    @property
    def n_flagged(self) -> int:
        """Number of flagged modes."""
        return sum(r.flagged for r in self.rows)

    def table(self) -> str:
        """The agreement table as text (one line per mode).

        Columns: ema_rig f and zeta, sdypy-EMA f and zeta, df [%], sdypy-EMA orders, then the
        frequency difference and combined sigma [Hz], the damping difference and combined sigma
        [% points], and the flag (``f``, ``zeta``, ``missing``; ``-`` when they agree).
        """
        lines = [f"sdypy-EMA LSCF cross-check, {self.band[0]:g}-{self.band[1]:g} Hz, orders up to {self.order} "
                 f"({self.seconds:.2f} s); flagged where they differ by more than {COMBINED_SIGMAS:g} combined "
                 f"sigma: {self.n_flagged} of {len(self.rows)}",
                 f"{'ema_rig f [Hz]':>14} {'zeta [%]':>9} {'sdypy f [Hz]':>13} {'zeta [%]':>9} "
                 f"{'df [%]':>8} {'orders':>6} {'df [Hz]':>9} {'sigma':>8} {'dzeta [%]':>9} {'sigma':>8}  flag"]
        for r in self.rows:
            if r.found:
                lines.append(
                    f"{r.natural_freq:>14.4f} {100 * r.damping_ratio:>9.3f} {r.natural_freq_peer:>13.4f} "
                    f"{100 * r.damping_ratio_peer:>9.3f} {100 * r.freq_diff:>8.3f} {r.n_orders_peer:>6d} "
                    f"{r.natural_freq_peer - r.natural_freq:>9.2g} {r.freq_sigma:>8.2g} "
                    f"{100 * (r.damping_ratio_peer - r.damping_ratio):>9.2g} {100 * r.damping_sigma:>8.2g}  "
                    f"{','.join(r.flags) or '-'}")
            else:
                lines.append(f"{r.natural_freq:>14.4f} {100 * r.damping_ratio:>9.3f} {'no stable pole':>13}"
                             f"{'':>58}missing")
        if self.peer_only:
            lines.append(f"found by sdypy-EMA only (stable at {PEER_MIN_ORDERS} or more orders, no ema_rig mode "
                         f"within the tolerance): {len(self.peer_only)}")
            for m in self.peer_only:
                lines.append(f"{'-':>14} {'':>9} {m.natural_freq:>13.4f} {100 * m.damping_ratio:>9.3f} {'':>8} "
                             f"{m.n_orders:>6d}{'':>40}  missed")
        return "\n".join(lines)


def _stable_poles(pole_freq: list[Any], pole_xi: list[Any]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Frequencies, damping ratios and order index of the stable poles (see Notes of the module)."""
    fs, zs, ks = [], [], []
    prev_f: np.ndarray | None = None
    prev_z: np.ndarray = np.zeros(0)
    for k, (f, z) in enumerate(zip(pole_freq, pole_xi, strict=True)):
        f = np.asarray(f, dtype=float)
        z = np.asarray(z, dtype=float)
        ok = np.isfinite(f) & np.isfinite(z) & (f > 0) & (z > 0)
        f, z = f[ok], z[ok]
        if prev_f is not None and prev_f.size and f.size:
            with np.errstate(divide="ignore", invalid="ignore"):
                df = np.abs(f[:, None] - prev_f[None, :]) / prev_f[None, :]
                dz = np.abs(z[:, None] - prev_z[None, :]) / prev_z[None, :]
            # as sdypy-EMA tests them: frequency and damping each against any pole of the previous order
            st = np.any(df < STABLE_FREQ_TOL, axis=1) & np.any(dz < STABLE_DAMPING_TOL, axis=1)
            fs.append(f[st])
            zs.append(z[st])
            ks.append(np.full(int(st.sum()), k))
        prev_f, prev_z = f, z
    if not fs:
        return np.zeros(0), np.zeros(0), np.zeros(0, dtype=int)
    return np.concatenate(fs), np.concatenate(zs), np.concatenate(ks)


def crosscheck(data: FRFData, ident: Identification, *, order: int | None = None, tol: float = 0.01) -> CrossCheck:
    """sdypy-EMA's LSCF on the band of ``ident``, matched to its modes and flagged.

    Parameters
    ----------
    data : FRFData
        The measurement (any layout; all channels are pooled).
    ident : Identification
        The identification to check (its band, modes and their standard deviations).
    order : int, optional
        Highest polynomial degree for sdypy-EMA (``pol_order_high = order // 2``); default
        the highest order ema_rig used times its number of references.
    tol : float, optional
        Relative frequency window for matching (default 1 %).

    Returns
    -------
    CrossCheck
        One row per mode with both estimates, their standard deviations and the flags.

    Raises
    ------
    IdentificationError
        sdypy-EMA is not installed.
    """
    try:
        from sdypy import EMA
    except ImportError:
        raise IdentificationError("the cross-check needs sdypy-EMA (pip install sdypy-EMA)") from None
    lo, hi = ident.band
    if order is None:
        order = max(ident.stabilization.orders) * ident.stabilization.poles.n_in
    natural_freq, damping_ratio = ident.natural_freq, ident.damping_ratio
    d = data.band(float(data.freq[0]), hi)
    frf = d.frf.reshape(-1, d.n_freq)
    # sdypy-EMA's LSCF needs at least one line below its lower limit (none at 0 Hz)
    lower = max(lo, float(d.freq[1]))
    half = max(2, int(order) // 2)
    t0 = time.perf_counter()
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        m = EMA.Model(frf=frf, freq=d.freq, lower=lower, upper=hi, pol_order_high=half, frf_form=d.frf_form)
        m.get_poles(method="lscf", show_progress=False)
        fn, xi, ks = _stable_poles(list(m.pole_freq), list(m.pole_xi))
    seconds = time.perf_counter() - t0
    hist = processing_history(data)
    if hist is not None and hist.exp_decay > 0 and fn.size:
        fn, xi = remove_decay(fn, xi, hist.exp_decay)
    inside = (fn >= lo) & (fn <= hi)
    f_st, z_st, k_st = fn[inside], xi[inside], ks[inside]
    f_std = np.asarray(ident.natural_freq_std, dtype=float)
    z_std = np.asarray(ident.damping_ratio_std, dtype=float)
    rows = []
    for k, (f0, z0) in enumerate(zip(np.asarray(natural_freq, float), np.asarray(damping_ratio, float),
                                     strict=True)):
        near = _closest_per_order(f_st, k_st, f0, tol)
        own = {"natural_freq_std": float(f_std[k]), "damping_ratio_std": float(z_std[k])}
        if near.size:
            n = int(near.size)
            rows.append(CrossCheckRow(
                float(f0), float(z0), float(np.median(f_st[near])), float(np.median(z_st[near])), n,
                natural_freq_std_peer=float(np.std(f_st[near], ddof=1)) if n > 1 else float("nan"),
                damping_ratio_std_peer=float(np.std(z_st[near], ddof=1)) if n > 1 else float("nan"), **own))
        else:
            rows.append(CrossCheckRow(float(f0), float(z0), float("nan"), float("nan"), 0, **own))
    peer_only = _peer_only(f_st, z_st, k_st, np.asarray(natural_freq, float), tol)
    return CrossCheck(rows=tuple(rows), band=(lo, hi), order=2 * half, seconds=seconds, peer_only=peer_only)


def _closest_per_order(f: np.ndarray, k: np.ndarray, f0: float, tol: float) -> np.ndarray:
    """Indices of the stable pole nearest ``f0`` in each order, where it lies within ``tol`` (relative).

    One pole per order, as sdypy-EMA's own ``select_closest_poles`` picks them: a second mode of
    the peer within the tolerance (a close pair) does not enter the median and the spread.
    """
    idx = np.flatnonzero(np.abs(f - f0) <= tol * f0)
    if idx.size == 0:
        return idx
    best: dict[int, int] = {}
    for i in idx[np.argsort(np.abs(f[idx] - f0), kind="stable")].tolist():
        best.setdefault(int(k[i]), i)
    return np.array(sorted(best.values()), dtype=int)


def _peer_only(f: np.ndarray, z: np.ndarray, k: np.ndarray, ours: np.ndarray, tol: float) -> tuple[PeerMode, ...]:
    """Clusters of stable poles (neighbours within ``tol`` relative) at >= PEER_MIN_ORDERS orders, no mode of ours near."""
    if f.size == 0:
        return ()
    o = np.argsort(f)
    f, z, k = f[o], z[o], k[o]
    cuts = np.flatnonzero(np.diff(f) > tol * f[:-1]) + 1
    out = []
    for idx in np.split(np.arange(f.size), cuts):
        n = int(np.unique(k[idx]).size)
        fm = float(np.median(f[idx]))
        if n < PEER_MIN_ORDERS or np.any(np.abs(ours - fm) <= tol * fm):
            continue
        out.append(PeerMode(fm, float(np.median(z[idx])), n, float(np.std(f[idx], ddof=1)),
                            float(np.std(z[idx], ddof=1))))
    return tuple(out)


__all__ = ["COMBINED_SIGMAS", "PEER_MIN_ORDERS", "STABLE_DAMPING_TOL", "STABLE_FREQ_TOL", "CrossCheck", "CrossCheckRow",
           "PeerMode", "crosscheck"]
