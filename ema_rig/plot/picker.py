"""Interactive pole picking on a stabilization chart (backend neutral).

Classes
-------
PolePicker
    Click poles of a :class:`~ema_rig.plot.stabilization.StabilizationPlot` to select modes;
    the result is a :class:`~ema_rig.identification.stabilization.Selection` that saves to JSON and
    replays in batch.

Notes
-----
The picker only uses ``canvas.mpl_connect('pick_event', ...)`` and ``'key_press_event'``, which
every matplotlib backend delivers: a Qt or Tk window, and Jupyter with ipympl (``%matplotlib
widget``). No GUI toolkit is imported here.

The chart holds still while picking: the axes limits are fixed when the picker starts (with room
for the frequency labels), so the pole under the mouse stays there and a second click on a picked
pole (or on its ring) un-picks it. Keys: ``u`` / ``ctrl+z`` undo the last change, ``x`` / ``delete``
remove the last pick, ``escape`` clears every pick (undoable); none of them is a key of matplotlib's
navigation toolbar (``backspace`` would also step the view back). Typical use::

    import matplotlib.pyplot as plt
    from ema_rig.identification import identify
    from ema_rig.plot.stabilization import plot_stabilization
    from ema_rig.plot.picker import PolePicker

    ident = identify(data, band=(150, 1000))
    fig, ax = plt.subplots(figsize=(10, 6), layout="constrained")  # room for the legend
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

from ..identification.stabilization import select_poles

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
        The highlight artists of the picked poles (pickable: a click on one un-picks it).
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
        self._history: list[list[tuple[int, int]]] = []
        self._artist_status = {id(a): k for k, a in plot.poles.items()}
        ax = plot.axes
        # freeze the view: room for four rows of mode labels above the highest order (what
        # StabilizationPlot.mark_modes may ask for), so no pick ever rescales the chart
        n_max = max(plot.stab.orders) if plot.stab.orders else 1
        y0, y1 = ax.get_ylim()
        self._limits = (ax.get_xlim(), (y0, max(y1, 1.03 * n_max / (1.0 - 0.13 * 4))))
        ax.set_autoscale_on(False)
        self._hold_still()
        canvas = plot.figure.canvas
        self._cids: list[int] = [canvas.mpl_connect("pick_event", self._on_pick),
                                 canvas.mpl_connect("key_press_event", self._on_key)]

    # -------------------------------------------------------------------- events
    def _hold_still(self) -> None:
        """Put the axes limits back to the ones fixed at the start."""
        xl, yl = self._limits
        self.plot.axes.set_xlim(*xl)
        self.plot.axes.set_ylim(*yl)

    def _on_key(self, event: Any) -> None:
        key = getattr(event, "key", None)
        if key in ("u", "ctrl+z", "cmd+z"):
            self.undo()
        elif key in ("x", "delete") and self.picks:
            self._change(self.picks[:-1])
        elif key == "escape" and self.picks:
            self._change([])

    def undo(self) -> bool:
        """Take back the last change (pick, un-pick, removal or clearing); False when there is none."""
        if not self._history:
            return False
        self.picks = self._history.pop()
        self._after_change()
        return True

    def _change(self, picks: list[tuple[int, int]]) -> None:
        self._history.append(list(self.picks))
        self.picks = picks
        self._after_change()

    def _after_change(self) -> None:
        self._redraw()
        if self.on_change is not None:
            self.on_change(self.selection)

    def _on_pick(self, event: Any) -> None:
        if event.artist in self.markers:  # the ring of a picked pole: un-pick it
            self._change([p for k, p in enumerate(self.picks) if self.markers[k] is not event.artist])
            return
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
        stab = self.plot.stab
        picked = [r for r in rows if (int(stab.order[r]), stab.index_in_order(int(r))) in self.picks]
        if picked:  # a click on a picked pole un-picks it, even where other poles lie under the mouse
            self.toggle_row(int(picked[0]))
            return
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
            self._change([p for p in self.picks if p != key])
        else:
            # one pick per mode: a new pick within freq_tol of an existing one replaces it
            f = stab.natural_freq[row]
            self._change([p for p in self.picks
                          if abs(stab.natural_freq[stab.row_of(*p)] - f) > self.freq_tol * f] + [key])

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
                mec="k", mew=1.8, zorder=6, picker=True, pickradius=6,
            )
            self.markers.append(m)
        self.plot.mark_modes(self.selection if self.picks else None)
        self._hold_still()
        self.plot.figure.canvas.draw_idle()

    # ------------------------------------------------------------------- results
    @property
    def selection(self) -> Selection:
        """The picked modes (provenance ``"manual"``), sorted by frequency."""
        return select_poles(self.plot.stab, self.picks, freq_tol=self.freq_tol, source=self.source)

    def disconnect(self) -> None:
        """Stop listening to pick and key events."""
        for cid in self._cids:
            self.plot.figure.canvas.mpl_disconnect(cid)
        self._cids = []


__all__ = ["PolePicker"]
