"""The stabilization chart.

Functions
---------
plot_stabilization
    Poles by status over frequency and model order, the sum of FRFs (or the CMIF) on a log
    twin axis, the identification band shaded and the selected modes marked.

Classes
-------
StabilizationPlot
    What :func:`plot_stabilization` drew: figure, axes and the artists by category.

Notes
-----
Nothing here calls ``pyplot.show()`` or selects a backend. With ``ax=None`` the figure is a
plain :class:`matplotlib.figure.Figure` (no pyplot state; save it with ``fig.savefig``). For
interactive picking create the axes with pyplot yourself and pass ``ax=``, then attach a
:class:`ema_rig.plot.picker.PolePicker`.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ._render import plot_line, reuse_axes, semilogy

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..frf import FRFData
    from ..identification.stabilization import Selection, StabilizationData

#: Marker style per status letter: (marker, filled, legend label).
_MARKERS: Mapping[str, tuple[str, bool, str]] = {
    "o": (".", True, "o  new pole"),
    "f": ("^", False, "f  stable frequency"),
    "d": ("D", False, "d  + damping"),
    "v": ("v", False, "v  + vector"),
    "s": ("o", True, "s  stable f, damping, vector"),
    "u": ("x", True, "unstable (mathematical)"),
}

COLOR_SCHEMES: Mapping[str, Mapping[str, str]] = {
    "default": {
        "o": "#9a9a9a",
        "f": "#1f77b4",
        "d": "#ff7f0e",
        "v": "#9467bd",
        "s": "#d62728",
        "u": "#c8c8c8",
        "frf": "#303030",
        "band": "#fff2b3",
        "mode": "#2ca02c",
    },
    "viridis": {
        "o": "#b0b0b0",
        "f": "#443983",
        "d": "#31688e",
        "v": "#35b779",
        "s": "#fde725",
        "u": "#d0d0d0",
        "frf": "#202020",
        "band": "#e8f4f8",
        "mode": "#440154",
    },
    "high-contrast": {
        "o": "#999999",
        "f": "#0072b2",
        "d": "#e69f00",
        "v": "#cc79a7",
        "s": "#000000",
        "u": "#cccccc",
        "frf": "#555555",
        "band": "#f0e442",
        "mode": "#d55e00",
    },
}


@dataclass(eq=False)
class StabilizationPlot:
    """Handles of a drawn stabilization chart.

    Attributes
    ----------
    figure : Figure
    axes : Axes
        Frequency [Hz] vs model order (the pickable poles live here).
    frf_axes : Axes or None
        The log twin axis with the FRF summary.
    stab : StabilizationData
        The data drawn.
    poles : dict of str to Line2D
        One artist per status letter (``'u'`` for unstable poles when shown).
    rows : dict of str to ndarray
        For each artist, the :class:`PoleSet` row of every point (``event.ind`` -> row).
    frf_lines : list of Line2D
    band_patch : Patch or None
    mode_lines, mode_labels : list
        Vertical lines and text labels of the selected modes.
    rejected_lines : list
        Grey dotted lines of the rejected candidates.
    """

    figure: Figure
    axes: Axes
    frf_axes: Axes | None
    stab: StabilizationData
    poles: dict[str, Any] = field(default_factory=dict)
    rows: dict[str, NDArray[np.intp]] = field(default_factory=dict)
    frf_lines: list[Any] = field(default_factory=list)
    band_patch: Any = None
    mode_lines: list[Any] = field(default_factory=list)
    mode_labels: list[Any] = field(default_factory=list)
    colors: Mapping[str, str] = field(default_factory=dict)
    rejected_lines: list[Any] = field(default_factory=list)

    def mark_modes(
        self, selection: Selection | None, rejected: Sequence[Any] = (), mode_freq: Sequence[float] | None = None
    ) -> None:
        """Replace the mode markers: selected modes (dashed line + frequency label) and rejected
        candidates (grey dotted line over the orders where they were stable, no label).

        ``mode_freq`` [Hz], one per selected mode, are the reported (final) natural frequencies,
        e.g. :attr:`ema_rig.identification.Identification.natural_freq`: lines and labels go there.
        Without it they mark the selection's PolyMAX cluster poles (the legend says so).

        Labels never hide each other: each goes to the lowest of up to four label rows above the
        poles where it does not overlap its left neighbour (the chart grows upwards to make room).
        """
        for a in self.mode_lines + self.mode_labels + self.rejected_lines:
            a.remove()
        self.mode_lines.clear()
        self.mode_labels.clear()
        self.rejected_lines.clear()
        ax = self.axes
        orders = self.stab.orders
        n_max = max(orders) if orders else 1
        for c in rejected:
            # grey dotted over the whole height, a cross at the top of the orders where it was stable
            (ln,) = plot_line(ax, [c.natural_freq] * 2, [0, n_max], color=self.colors.get("rejected", "#666666"),
                            lw=1.0, ls=":", alpha=0.9, zorder=1, marker="x", markevery=[1], ms=7, mew=1.5)
            self.rejected_lines.append(ln)
        if selection is None or not (selection.modes if mode_freq is None else len(mode_freq)):
            return
        x0, x1 = ax.get_xlim()
        width = 0.02 * (x1 - x0)  # a rotated 8-pt label is about 2 % of the axis wide
        if mode_freq is None:
            freqs = [float(m.natural_freq) for m in selection.modes]
        else:
            freqs = sorted(float(f) for f in mode_freq)
        levels: list[float] = []  # right edge of the last label in each row
        rows = []
        for f in freqs:
            for k, right in enumerate(levels):
                if f - width >= right:
                    levels[k] = f
                    rows.append(k)
                    break
            else:
                if len(levels) < 4:
                    levels.append(f)
                    rows.append(len(levels) - 1)
                else:  # more than four labels crowd one spot: the least recently used row
                    k = int(np.argmin(levels))
                    levels[k] = f
                    rows.append(k)
        n_rows = max(rows) + 1
        row_h = 0.13  # fraction of the axis height per label row
        if ax.get_autoscale_on():
            top = 1.03 * n_max / (1.0 - row_h * n_rows)
            ax.set_ylim(0, top)
        else:  # the view is fixed (a PolePicker holds it still, with room for four rows): label in it
            top = ax.get_ylim()[1]
        for f, k in zip(freqs, rows, strict=True):
            ln = ax.axvline(f, color=self.colors.get("mode", "g"), lw=1.0, ls="--", alpha=0.8, zorder=1)
            y = top * (1.0 - row_h * k) - 0.01 * top
            txt = ax.text(
                f, y, f"{f:.1f} Hz", rotation=90, va="top", ha="center", fontsize=8,
                color=self.colors.get("mode", "g"), clip_on=True, zorder=5,
                bbox={"boxstyle": "square,pad=0.05", "fc": "white", "ec": "none", "alpha": 0.8},
            )
            self.mode_lines.append(ln)
            self.mode_labels.append(txt)


def plot_stabilization(
    stab: StabilizationData,
    frf: FRFData | None = None,
    *,
    ax: Axes | None = None,
    selection: Selection | None = None,
    indicator: str = "sum",
    show_unstable: bool = False,
    show_new: bool = True,
    color_scheme: str = "default",
    title: str | None = None,
    figsize: tuple[float, float] = (10.0, 6.0),
    markersize: float = 5.0,
    candidates: Sequence[Any] = (),
    converged: bool | None = None,
    figure: Figure | None = None,
    mode_freq: Sequence[float] | None = None,
) -> StabilizationPlot:
    """Draw a stabilization chart.

    Parameters
    ----------
    stab : StabilizationData
        Poles with status letters (:func:`~ema_rig.identification.stabilization.stabilize`).
    frf : FRFData, optional
        Drawn behind the poles on a log twin axis, unit from ``frf.unit_str``.
    ax : Axes, optional
        Axes to draw into; default a new :class:`~matplotlib.figure.Figure`.
    selection : Selection, optional
        Modes to mark with a dashed line and their frequency.
    indicator : {'sum', 'cmif'}, optional
        Sum of FRF magnitudes over all channels, or the CMIF singular values.
    show_unstable : bool, optional
        Also draw the unstable (mathematical) poles (default False).
    show_new : bool, optional
        Draw the status-``o`` poles (default True).
    color_scheme : {'default', 'viridis', 'high-contrast'}, optional
    title : str, optional
    figsize : (float, float), optional
        Size of a new figure [in].
    markersize : float, optional
    candidates : sequence of Candidate, optional
        Judged clusters (:attr:`ema_rig.identification.Identification.candidates`); the
        rejected ones stable at four or more orders are drawn as grey dotted lines.
    converged : bool, optional
        Whether the mode set converged over the orders; said in the default title.
    figure : Figure, optional
        With ``ax=None``: a figure to draw into instead of a new one. One that holds an earlier
        chart drawn this way keeps its axes (emptied, :func:`ema_rig.plot._render.reuse_axes`):
        the same picture, without building axes and ticks again; any other is cleared.
    mode_freq : sequence of float, optional
        The reported natural frequencies [Hz] of the selected modes, shape (n_modes,) (the
        identification's final ones, :attr:`ema_rig.identification.Identification.natural_freq`):
        the dashed lines and labels are drawn there. Without it they mark the selection's PolyMAX
        cluster poles and the legend entry says ``at the PolyMAX cluster``.

    Returns
    -------
    StabilizationPlot

    Raises
    ------
    ValueError
        Unknown ``indicator`` or ``color_scheme``.
    """
    if indicator not in ("sum", "cmif"):
        raise ValueError(f"indicator must be 'sum' or 'cmif', got {indicator!r}")
    if color_scheme not in COLOR_SCHEMES:
        raise ValueError(f"color_scheme must be one of {sorted(COLOR_SCHEMES)}, got {color_scheme!r}")
    colors = COLOR_SCHEMES[color_scheme]
    kept: list[Any] | None = None
    if ax is None:
        from matplotlib.figure import Figure

        if figure is None:
            fig = Figure(figsize=figsize, layout="constrained")
        else:
            fig = figure
            kept = reuse_axes(fig, f"ema_rig.stabilization frf={frf is not None}")
        ax = kept[0] if kept else fig.add_subplot()
    else:
        fig = ax.figure  # type: ignore[assignment]
    lo, hi = stab.band
    plot = StabilizationPlot(figure=fig, axes=ax, frf_axes=None, stab=stab, colors=colors)

    # FRF summary on a log twin axis, drawn underneath the poles
    if frf is not None:
        tw = kept[1] if kept else ax.twinx()
        data = frf
        if indicator == "sum":
            y = data.sum_frf()[None, :]
            label = f"sum of |H|  [{data.unit_str}]"
        else:
            y = data.cmif()
            label = f"CMIF  [{data.unit_str}]"
        for k, yk in enumerate(y):
            pos = np.where(yk > 0, yk, np.nan)
            (ln,) = semilogy(
                tw, data.freq, pos, color=colors["frf"], lw=1.0 if k == 0 else 0.7, alpha=0.55 if k == 0 else 0.35,
                zorder=1, label=("sum of FRFs" if indicator == "sum" else f"CMIF {k + 1}"),
            )
            plot.frf_lines.append(ln)
        tw.set_ylabel(label)
        ax.set_zorder(tw.get_zorder() + 1)
        ax.patch.set_visible(False)
        plot.frf_axes = tw

    # identification band
    if frf is not None and (frf.freq[0] < lo or frf.freq[-1] > hi):
        host = plot.frf_axes if plot.frf_axes is not None else ax
        plot.band_patch = host.axvspan(
            lo, hi, color=colors["band"], alpha=0.35, lw=0, zorder=0, label=f"band {lo:g}-{hi:g} Hz"
        )

    # poles by status
    fn = stab.natural_freq
    order = stab.order
    unstable = stab.unstable
    cats: list[tuple[str, NDArray[np.bool_]]] = []
    if show_unstable:
        cats.append(("u", unstable))
    for letter in ("o", "f", "d", "v", "s"):
        if letter == "o" and not show_new:
            continue
        cats.append((letter, (stab.status == letter) & ~unstable))
    for letter, mask in cats:
        rows = np.flatnonzero(mask)
        marker, filled, text = _MARKERS[letter]
        c = colors[letter]
        size = markersize * (0.7 if letter in ("o", "u") else 1.0)
        (ln,) = plot_line(
            ax,
            fn[rows],
            order[rows],
            ls="none",
            marker=marker,
            ms=size,
            mec=c,
            mfc=c if filled else "none",
            mew=1.0,
            alpha=0.6 if letter in ("o", "u") else 0.9,
            label=f"{text} ({rows.size})",
            zorder=3 if letter in ("o", "u") else 4,
            picker=True,
            pickradius=5,
        )
        plot.poles[letter] = ln
        plot.rows[letter] = rows

    ax.set_xlim(lo, hi) if frf is None else ax.set_xlim(max(frf.freq[0], 0.0), frf.freq[-1])
    orders = stab.orders
    top = (max(orders) if orders else 1) * 1.25 + 1  # room for the mode labels
    ax.set_ylim(0, top)
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("model order")
    if not kept:  # kept axes keep their grid style
        ax.grid(True, which="major", alpha=0.25)
    rejected = [c for c in candidates if not c.accepted and c.mode.n_poles >= 4]
    plot.mark_modes(selection, rejected, mode_freq)
    handles = [plot.poles[k] for k in plot.poles]
    if plot.mode_lines:
        where = "" if mode_freq is not None else " at the PolyMAX cluster"
        plot.mode_lines[0].set_label(f"selected mode{where} ({len(plot.mode_lines)})")
        handles.append(plot.mode_lines[0])
    if plot.rejected_lines:
        plot.rejected_lines[0].set_label(f"rejected candidate ({len(plot.rejected_lines)})")
        handles.append(plot.rejected_lines[0])
    if plot.frf_lines:
        handles.append(plot.frf_lines[0])
    if plot.band_patch is not None:
        handles.append(plot.band_patch)
    ax.legend(
        handles=handles, loc="upper center", bbox_to_anchor=(0.5, -0.11), fontsize=8, framealpha=0.9,
        ncols=min(4, len(handles)),
    )
    counts = stab.counts()
    ax.set_title(
        title
        if title is not None
        else f"Stabilization {lo:g}-{hi:g} Hz, orders {min(orders) if orders else 0}-{max(orders) if orders else 0}"
        f"  ({counts['s']} stable, {counts['unstable']} unstable of {len(stab)})"
        + ("" if converged is None else ("; mode set converged" if converged else "; mode set NOT converged")),
        fontsize=10,
        y=1.0,  # pinned where matplotlib puts it (x ticks below; the order axis starts at 0 and the FRF
        # axis is log: no offset text), without measuring both axes' tick labels at each draw
    )
    return plot


__all__ = ["COLOR_SCHEMES", "StabilizationPlot", "plot_stabilization"]
