"""A second opinion from sdypy-EMA: its LSCF estimator on the same band, mode by mode.

Functions
---------
crosscheck
    Run sdypy-EMA's LSCF on the band of an :class:`~ema_rig.identification.Identification`
    and match its stable poles to each identified mode.

Classes
-------
CrossCheck, CrossCheckRow
    The per-mode agreement table.

Notes
-----
sdypy-EMA's LSCF is a single-reference (common-denominator) estimator, so every
output/reference channel is handed to it as one "location". Its own stability test (1 %
frequency, 5 % damping between consecutive orders; its defaults) marks the stable poles; for
each mode of ema_rig the stable poles of sdypy-EMA within ``tol`` (relative) are collected
over all orders and their median frequency and damping reported. sdypy-EMA is imported only
here (it imports matplotlib.pyplot).
"""

from __future__ import annotations

import contextlib
import io
import time
import warnings
from dataclasses import dataclass

import numpy as np

from ..errors import IdentificationError
from ..frf import FRFData
from .identification import Identification


@dataclass(frozen=True, slots=True)
class CrossCheckRow:
    """One mode of ema_rig and sdypy-EMA's stable poles near it.

    ``natural_freq_peer`` / ``damping_ratio_peer`` are NaN and ``n_orders_peer`` is 0 when
    sdypy-EMA has no stable pole within the tolerance.
    """

    natural_freq: float
    damping_ratio: float
    natural_freq_peer: float
    damping_ratio_peer: float
    n_orders_peer: int

    @property
    def freq_diff(self) -> float:
        """Relative frequency difference (peer - ema_rig) / ema_rig."""
        return (self.natural_freq_peer - self.natural_freq) / self.natural_freq

    @property
    def found(self) -> bool:
        """True when sdypy-EMA has stable poles near the mode."""
        return self.n_orders_peer > 0


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
    """

    rows: tuple[CrossCheckRow, ...]
    band: tuple[float, float]
    order: int
    seconds: float

    def table(self) -> str:
        """The agreement table as text (one line per mode)."""
        lines = [f"sdypy-EMA LSCF cross-check, {self.band[0]:g}-{self.band[1]:g} Hz, orders up to {self.order} "
                 f"({self.seconds:.2f} s)",
                 f"{'ema_rig f [Hz]':>14} {'zeta [%]':>9} {'sdypy f [Hz]':>13} {'zeta [%]':>9} "
                 f"{'df [%]':>8} {'orders':>6}"]
        for r in self.rows:
            if r.found:
                lines.append(f"{r.natural_freq:>14.4f} {100 * r.damping_ratio:>9.3f} {r.natural_freq_peer:>13.4f} "
                             f"{100 * r.damping_ratio_peer:>9.3f} {100 * r.freq_diff:>8.3f} {r.n_orders_peer:>6d}")
            else:
                lines.append(f"{r.natural_freq:>14.4f} {100 * r.damping_ratio:>9.3f} {'no stable pole':>13}")
        return "\n".join(lines)


def crosscheck(data: FRFData, ident: Identification, *, order: int | None = None, tol: float = 0.01) -> CrossCheck:
    """sdypy-EMA's LSCF on the band of ``ident``, matched to its modes.

    Parameters
    ----------
    data : FRFData
        The measurement (any layout; all channels are pooled).
    ident : Identification
        The identification to check (its band and modes).
    order : int, optional
        Highest polynomial degree for sdypy-EMA (``pol_order_high = order // 2``); default
        the highest order ema_rig used times its number of references.
    tol : float, optional
        Relative frequency window for matching (default 1 %).

    Returns
    -------
    CrossCheck

    Raises
    ------
    IdentificationError
        sdypy-EMA is not installed.
    """
    try:
        import matplotlib

        matplotlib.use("Agg")
        from sdypy import EMA
        from sdypy.EMA import stabilization as sdy_stab
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
        fn, xi, test_fn, test_xi = sdy_stab._stabilization(m.all_poles, m.n_bands * half, err_fn=0.01, err_xi=0.05)
    seconds = time.perf_counter() - t0
    stable = (test_fn > 0) & (test_xi > 0) & (xi > 0) & (fn >= lo) & (fn <= hi)
    f_st, z_st = fn[stable], xi[stable]
    rows = []
    for f0, z0 in zip(np.asarray(natural_freq, float), np.asarray(damping_ratio, float), strict=True):
        near = np.abs(f_st - f0) <= tol * f0
        if near.any():
            rows.append(CrossCheckRow(float(f0), float(z0), float(np.median(f_st[near])),
                                      float(np.median(z_st[near])), int(near.sum())))
        else:
            rows.append(CrossCheckRow(float(f0), float(z0), float("nan"), float("nan"), 0))
    return CrossCheck(rows=tuple(rows), band=(lo, hi), order=2 * half, seconds=seconds)


__all__ = ["CrossCheck", "CrossCheckRow", "crosscheck"]
