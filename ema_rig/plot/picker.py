"""Interactive pole picking on a stabilization chart (backend neutral).

Classes
-------
PolePicker
    Click poles of a :class:`~ema_rig.plot.stabilization.StabilizationPlot` to select modes;
    the result is a :class:`~ema_rig.identification.stabilization.Selection` that saves to JSON and
    replays in batch.

Notes
-----
The picker only uses ``canvas.mpl_connect('pick_event', ...)``, which every matplotlib
backend delivers: a Qt or Tk window, and Jupyter with ipympl (``%matplotlib widget``). No GUI
toolkit is imported here. Typical use::

    import matplotlib.pyplot as plt
    from ema_rig.identification import identify
    from ema_rig.plot.stabilization import plot_stabilization
    from ema_rig.plot.picker import PolePicker

    ident = identify(data, band=(150, 1000))
    fig, ax = plt.subplots(figsize=(10, 6))
    chart = plot_stabilization(ident.stabilization, data, ax=ax, selection=ident.selection)
    picker = PolePicker(chart)        # click poles; click again to unpick
    plt.show()                        # (in Jupyter the figure is live already)
    picker.selection.to_json("modes.json")
    # later, in batch:
    identify(other_data, band=(150, 1000), selection=Selection.from_json("modes.json"))
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from ..identification.stabilization import Selection
    from .stabilization import StabilizationPlot


class PolePicker:
    """Toggle poles of a stabilization chart by clicking them.

    Parameters
    ----------
    plot : StabilizationPlot
        The chart (its pole artists were drawn pickable).
    statuses : str, optional
        Status letters whose poles may be picked (default ``"fdvs"``; new poles are ignored).
        Unstable poles (``Re lambda >= 0``) are never picked, whatever the letters.
    on_change : callable, optional
        Called with the current :class:`Selection` after every change.
    freq_tol : float, optional
        Relative window for the spread statistics of a picked mode (default 0.005).
    source : str, optional
        Recorded in the selection (e.g. the measurement file).

    Attributes
    ----------
    picks : list of (int, int)
        Picked ``(order, index)`` pairs in click order.
    markers : list
        The highlight artists of the picked poles.
    """

    def __init__(
        self,
        plot: StabilizationPlot,
        *,
        statuses: str = "fdvs",
        on_change: Callable[[Selection], Any] | None = None,
        freq_tol: float = 0.005,
        source: str | None = None,
    ) -> None:
        self.plot = plot
        self.statuses = set(statuses)
        self.on_change = on_change
        self.freq_tol = freq_tol
        self.source = source
        self.picks: list[tuple[int, int]] = []
        self.markers: list[Any] = []
        self._artist_status = {id(a): k for k, a in plot.poles.items()}
        self._cid: int | None = plot.figure.canvas.mpl_connect("pick_event", self._on_pick)

    # -------------------------------------------------------------------- events
    def _on_pick(self, event: Any) -> None:
        letter = self._artist_status.get(id(event.artist))
        if letter is None or letter not in self.statuses:
            return
        ind = np.atleast_1d(getattr(event, "ind", []))
        if ind.size == 0:
            return
        rows = self.plot.rows[letter][ind]
        rows = rows[~self.plot.stab.unstable[rows]]  # an unstable pole is never a mode
        if rows.size == 0:
            return
        me = getattr(event, "mouseevent", None)
        row = int(rows[0])
        if me is not None and me.xdata is not None and me.ydata is not None and rows.size > 1:
            stab = self.plot.stab
            ax = self.plot.axes
            pts = ax.transData.transform(np.column_stack([stab.natural_freq[rows], stab.order[rows]]))
            d = np.hypot(pts[:, 0] - me.x, pts[:, 1] - me.y)
            row = int(rows[np.argmin(d)])
        self.toggle_row(row)

    def toggle_row(self, row: int) -> None:
        """Pick the pole in PoleSet row ``row``, or unpick it (or its mode) if already picked.

        Raises
        ------
        ValueError
            The pole is unstable (``Re lambda >= 0``): never a physical mode.
        """
        stab = self.plot.stab
        if stab.unstable[row]:
            raise ValueError(f"row {row} is an unstable pole ({stab.natural_freq[row]:.6g} Hz): not a mode")
        key = (int(stab.order[row]), stab.index_in_order(row))
        if key in self.picks:
            self.picks.remove(key)
        else:
            # one pick per mode: a new pick within freq_tol of an existing one replaces it
            f = stab.natural_freq[row]
            self.picks = [
                p
                for p in self.picks
                if abs(stab.natural_freq[stab.row_of(*p)] - f) > self.freq_tol * f
            ]
            self.picks.append(key)
        self._redraw()
        if self.on_change is not None:
            self.on_change(self.selection)

    def _redraw(self) -> None:
        for m in self.markers:
            m.remove()
        self.markers.clear()
        stab = self.plot.stab
        ax = self.plot.axes
        for order, index in self.picks:
            row = stab.row_of(order, index)
            (m,) = ax.plot(
                [stab.natural_freq[row]], [order], ls="none", marker="o", ms=12, mfc="none",
                mec="k", mew=1.8, zorder=6,
            )
            self.markers.append(m)
        self.plot.mark_modes(self.selection if self.picks else None)
        self.plot.figure.canvas.draw_idle()

    # ------------------------------------------------------------------- results
    @property
    def selection(self) -> Selection:
        """The picked modes (provenance ``"manual"``), sorted by frequency."""
        from ..identification.stabilization import select_poles

        return select_poles(self.plot.stab, self.picks, freq_tol=self.freq_tol, source=self.source)

    def disconnect(self) -> None:
        """Stop listening to pick events."""
        if self._cid is not None:
            self.plot.figure.canvas.mpl_disconnect(self._cid)
            self._cid = None


__all__ = ["PolePicker"]
