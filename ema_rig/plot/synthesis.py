"""Measured FRFs against the FRFs synthesised from the identified modal model.

Functions
---------
shown_channels
    The channels drawn by default: all, or the driving points and then the worst fits.
plot_synthesis
    Small multiples, one panel per (output, reference) channel: measured and synthesised
    magnitude, the fitted band shaded, the identified natural frequencies marked and the
    per-channel fit error (the model's ``fit_error``, as the command line gives it) in the title.

Classes
-------
SynthesisPlot
    What :func:`plot_synthesis` returns: the figure, the axes and the artists by kind.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ..identification.window_damping import with_window_damping
from ._render import fixed_layout, plot_line, reuse_axes, semilogy

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..frf import FRFData
    from ..identification.modal import ModalModel


@dataclass(frozen=True, slots=True)
class SynthesisPlot:
    """Result of :func:`plot_synthesis`.

    Attributes
    ----------
    figure : matplotlib.figure.Figure
    axes : list of Axes
        One per channel shown, row-major.
    measured, synthesized : list of Line2D
        One line per channel.
    channels : list of tuple of int
        ``(output index, reference index)`` of each panel.
    phase_axes : list of Axes
        With ``phase=True``: the phase panel under each magnitude panel [deg].
    """

    figure: Figure
    axes: list[Axes] = field(default_factory=list)
    measured: list[Any] = field(default_factory=list)
    synthesized: list[Any] = field(default_factory=list)
    channels: list[tuple[int, int]] = field(default_factory=list)
    phase_axes: list[Axes] = field(default_factory=list)


def phase_centre(frf_form: str) -> float:
    """Centre [deg] of a phase window that holds a driving point's whole range without a wrap.

    180..0 deg for accelerance (centre 90), 90..-90 for mobility (0), 0..-180 for receptance (-90).

    Parameters
    ----------
    frf_form : {'accelerance', 'mobility', 'receptance'}
        The FRF's form.

    Returns
    -------
    float
        The window's centre [deg].
    """
    return {"accelerance": 90.0, "mobility": 0.0}.get(frf_form, -90.0)


def phase_line(f: NDArray[np.float64], h: NDArray[np.complex128],
               centre: float) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Frequencies [Hz] and phase of ``h`` [deg] wrapped into ``[centre - 180, centre + 180)``.

    Parameters
    ----------
    f : ndarray, shape (n,)
        Frequencies [Hz].
    h : ndarray, shape (n,)
        Complex FRF values.
    centre : float
        Centre of the phase window [deg] (:func:`phase_centre`).

    Returns
    -------
    f, phase : ndarray, shape (n + n_wraps,)
        With a NaN inserted in both where the phase wraps by a full turn, so the wrap is drawn as
        the gap it is and not as a vertical stroke across the panel.
    """
    ph = np.mod(np.degrees(np.angle(h)) - centre + 180.0, 360.0) - 180.0 + centre
    jump = np.flatnonzero(np.abs(np.diff(ph)) > 180.0) + 1
    return np.insert(np.asarray(f, dtype=float), jump, np.nan), np.insert(ph, jump, np.nan)


def shown_channels(modes: ModalModel, max_channels: int,
                   line_error: NDArray[np.float64] | None = None) -> list[tuple[int, int]]:
    """The channels a synthesis figure shows by default: all of them, or the ones that matter.

    Parameters
    ----------
    modes : ModalModel
        The model, ``n_out`` outputs x ``n_in`` references.
    max_channels : int
        At most this many channels.
    line_error : ndarray, shape (n_out, n_in), optional
        Ranks the channels when the model has no ``fit_error`` (NaN ranks last).

    Returns
    -------
    list of (int, int)
        ``(output, reference)`` indices. With ``n_out * n_in <= max_channels``: every channel,
        output by output for each reference. Else the driving points (output DOF = reference
        DOF, in reference order) first, then the other channels by the model's ``fit_error``
        (the command line's synthesis error), worst first; ties keep the output-by-output order.
        Deterministic: the same model gives the same channels.
    """
    n_out, n_in = len(modes.out_dofs), len(modes.in_dofs)
    every = [(i, j) for j in range(n_in) for i in range(n_out)]
    if len(every) <= max_channels:
        return every
    drive = [(modes.out_dofs.index(d), j) for j, d in enumerate(modes.in_dofs) if d in modes.out_dofs]
    score = modes.fit_error if modes.fit_error is not None else line_error
    rest = [c for c in every if c not in drive]
    if score is not None:
        key = np.nan_to_num(np.asarray(score, dtype=float), nan=-np.inf)
        rest = [rest[k] for k in np.argsort([-key[c] for c in rest], kind="stable")]
    return (drive + rest)[:max(max_channels, 0)]


def plot_synthesis(
    data: FRFData,
    modes: ModalModel,
    *,
    channels: Sequence[tuple[int, int]] | None = None,
    max_channels: int = 12,
    margin: float = 0.1,
    title: str | None = None,
    phase: bool = False,
    fig_width: float | None = None,
    figure: Figure | None = None,
    dpi: float | None = None,
) -> SynthesisPlot:
    """Overlay measured and synthesised FRFs, one panel per channel.

    Parameters
    ----------
    data : FRFData
        The measurement, shape (n_out, n_in, n_freq); its outputs and references must include
        those of ``modes``.
    modes : ModalModel
        The LSFD model (poles, residues and residual terms). One whose poles had an exponential
        window's damping removed (``meta["window_decay"]``) is drawn with it put back
        (:func:`~ema_rig.identification.window_damping.with_window_damping`): the model the fit
        used, comparable with the windowed FRFs; the figure title says so.
    channels : sequence of (int, int), optional
        ``(output, reference)`` indices into ``modes.out_dofs`` / ``modes.in_dofs``; default:
        :func:`shown_channels` (every output against every reference, or, with more than
        ``max_channels`` of them, the driving points and then the worst fits).
    max_channels : int, optional
        Upper bound on the panels drawn by default (12). With fewer panels than channels the
        title says how many are shown ("12 of 26 channels shown").
    margin : float, optional
        Fraction of the fitted band shown on each side of it (0.1): the synthesis is only valid
        inside the band, the margin shows where it stops being so.
    title : str, optional
        Figure title (default: the source file and the band).
    phase : bool, optional
        Also draw the phase [deg] under each magnitude panel (default False).
    fig_width : float, optional
        Figure width [inch] (default 11 for two columns, 7 for one).
    figure : Figure, optional
        A figure to draw into instead of a new one (its size is left as it is). One that holds an
        earlier synthesis plot with the same panels keeps its axes (emptied,
        :func:`ema_rig.plot._render.reuse_axes`): the same picture, without building axes and
        ticks again; any other is cleared.
    dpi : float, optional
        The pixel density [dots per inch] the figure will be drawn at, once, to a raster (a
        report's PNG). Given, the figure is laid out here for that density instead of by a
        constrained layout at every draw (:func:`ema_rig.plot._render.fixed_layout`: the room
        for the lowest and highest magnitude tick labels is always kept, so the layout is the same
        for every measurement with the same texts and is computed once for them; the figure's
        layout engine is switched off). Default: a constrained layout at every draw.

    Returns
    -------
    SynthesisPlot

    Raises
    ------
    KeyError
        If a DOF of the model is missing from the data.
    """
    from matplotlib.colors import to_rgba
    from matplotlib.figure import Figure

    lo, hi = (float(modes.band[0]), float(modes.band[1]))
    if not (math.isfinite(lo) and math.isfinite(hi)):
        lo, hi = float(data.freq[0]), float(data.freq[-1])
    width = hi - lo
    shown = data.band(max(float(data.freq[0]), lo - margin * width), min(float(data.freq[-1]), hi + margin * width))
    meas = shown.sel(out=list(modes.out_dofs), inp=list(modes.in_dofs)).to_form(modes.frf_form)
    # the model the fit used: with an exponential window's damping put back, as the FRFs have it
    fitted = with_window_damping(modes)
    decay = float(fitted.meta.get("window_damping_applied") or 0.0)
    syn = fitted.synthesize(meas.freq, frf_form=modes.frf_form)
    per_line = fitted.line_error(meas)
    given = channels is not None
    if channels is None:
        channels = shown_channels(modes, max_channels, per_line)
    n = len(channels)
    n_all = len(modes.out_dofs) * len(modes.in_dofs)
    ncol = 2 if n > 1 else 1
    nrow = math.ceil(n / ncol)
    w = fig_width if fig_width is not None else (11.0 if ncol == 2 else 7.0)
    kept = None
    if figure is None:
        fig = Figure(figsize=(w, 1.0 + (3.0 if phase else 2.0) * nrow), layout="constrained")
    else:
        fig = figure
        kept = reuse_axes(fig, f"ema_rig.synthesis {n} in {nrow}x{ncol} phase={phase}")
    if dpi is not None:
        fig.set_dpi(dpi)
    if phase:
        grid = (np.array(kept, dtype=object).reshape(2 * nrow, ncol) if kept else
                fig.subplots(2 * nrow, ncol, sharex=True, squeeze=False, height_ratios=[2.0, 1.0] * nrow))
        axs, paxs = grid[0::2], grid[1::2]
    else:
        axs = (np.array(kept, dtype=object).reshape(nrow, ncol) if kept else
               fig.subplots(nrow, ncol, sharex=True, squeeze=False))
        paxs = None
    out = SynthesisPlot(figure=fig)
    # the cycle colours as RGBA once: matplotlib looks "CN" up in the property cycle at every use
    # (each draw of a line, each alpha set on a patch) and caches only literal colours
    span, synthesised = to_rgba("C0"), to_rgba("C3")
    for k, (i, j) in enumerate(channels):
        ax = axs[k // ncol][k % ncol]
        if paxs is not None:
            pax = paxs[k // ncol][k % ncol]
            c = phase_centre(meas.frf_form)
            plot_line(pax, *phase_line(meas.freq, meas.frf[i, j], c), color="k", lw=0.9)
            plot_line(pax, *phase_line(meas.freq, syn.frf[i, j], c), color=synthesised, lw=0.9, ls="--")
            _vspan(pax, lo, hi, color=span, alpha=0.06, lw=0)
            pax.set_ylim(c - 190, c + 190)
            pax.set_yticks(c + np.array([-180, -90, 0, 90, 180]))
            if not kept:  # kept axes keep their grid style (the ticks' own)
                pax.grid(True, alpha=0.25)
            pax.set_ylabel("phase [deg]", fontsize=8)
            out.phase_axes.append(pax)
        m = np.abs(meas.frf[i, j])
        s = np.abs(syn.frf[i, j])
        (lm,) = semilogy(ax, meas.freq, m, color="k", lw=1.0, label="measured")
        (ls,) = semilogy(ax, meas.freq, s, color=synthesised, lw=1.0, ls="--", label="synthesised (LSFD)")
        _vspan(ax, lo, hi, color=span, alpha=0.06, lw=0)
        _vlines(ax, modes.natural_freq, color="0.6", lw=0.6, ls=":")
        role = modes.roles[i] or ""
        axis = modes.axes[i] or ""
        # the fit's own error (``fit_error``, the number the command line and the JSON give), not a second norm
        err = "" if modes.fit_error is None else f"fit error {100 * float(modes.fit_error[i, j]):.1f} % "
        ax.set_title(f"{modes.out_dofs[i]} / {modes.in_dofs[j]}  {role} {axis}  {err}"
                     f"(median per line {100 * per_line[i, j]:.0f} %)",
                     fontsize=8.5, loc="left", y=1.0)  # pinned: where matplotlib puts it (no x ticks on top, a
        # log axis has no offset text), without measuring every tick label of the axes at each draw
        if not kept:
            ax.grid(True, which="both", alpha=0.25)
        ax.set_ylabel(f"|H| [{meas.unit_str}]", fontsize=8)
        out.axes.append(ax)
        out.measured.append(lm)
        out.synthesized.append(ls)
        out.channels.append((i, j))
    lowest = axs if paxs is None else paxs  # the panels that carry the frequency axis of each row
    for k in range(n, nrow * ncol):  # unused panels of the last row
        axs[k // ncol][k % ncol].set_visible(False)
        if paxs is not None:
            paxs[k // ncol][k % ncol].set_visible(False)
        # the panel above a hidden one is the lowest of its column: it shows the frequencies
        # (sharex gave its tick labels to the hidden bottom row only)
        above = lowest[k // ncol - 1][k % ncol]
        above.xaxis.set_tick_params(labelbottom=True)
        above.set_xlabel("frequency [Hz]")
    for ax in lowest[-1]:
        ax.set_xlabel("frequency [Hz]")
    axs[0][0].legend(fontsize=8, loc="lower right")
    src = str(modes.meta.get("file") or data.meta.get("file") or data.meta.get("source") or "")
    name = src.replace("\\", "/").rsplit("/", 1)[-1]
    subset = (f"; {n} of {n_all} channels shown" + ("" if given else ": the driving points, then the worst fits")
              if n < n_all else "")
    windowed = (f"\nsynthesis with the exponential window's damping ({decay:.4g} 1/s), as measured"
                if decay > 0 else "")
    fig.suptitle(title or f"{name + ': ' if name else ''}measured vs synthesised FRFs, {len(modes.poles)} modes in "
                 f"{lo:g}–{hi:g} Hz\n(dotted: natural frequencies{subset}){windowed}", fontsize=10)
    if dpi is not None:
        fixed_layout(fig, [ax.yaxis for ax in out.axes])
    return out


def _vspan(ax: Axes, lo: float, hi: float, **style: Any) -> Any:
    """The patch ``ax.axvspan(lo, hi, **style)`` draws (the band ``lo``-``hi`` [data] over the whole height).

    The same rectangle, transform, clip and place among the axes' children, so the same pixels;
    only the x data limits are taken in directly, as :func:`_vlines` does, instead of through
    ``add_patch``, which maps the patch's corners to data by composing its transform with the data
    transform anew for every span (about 0.6 ms each; eight spans per figure of a report).
    """
    from matplotlib.axis import GRIDLINE_INTERPOLATION_STEPS
    from matplotlib.patches import Rectangle

    p = Rectangle((lo, 0.0), hi - lo, 1.0, **style)
    p.set_transform(ax.get_xaxis_transform(which="grid"))
    path: Any = p.get_path()  # the interpolation steps are private
    path._interpolation_steps = GRIDLINE_INTERPOLATION_STEPS  # as axvspan
    ax.add_artist(p)  # clipped to the axes patch, appended to the children as add_patch does
    _take_in_x(ax, np.array([lo, hi]))
    return p


def _take_in_x(ax: Axes, x: np.ndarray) -> None:
    """Widen the x data limits of ``ax`` to hold ``x`` [data], shape (n,); the y limits stay.

    The y coordinates given with them are zeros, not NaN: a point with a NaN coordinate is left
    out of the limits altogether.
    """
    if x.size:
        ax.update_datalim(np.column_stack([x, np.zeros(x.size)]), updatey=False)


def _vlines(ax: Axes, x: Any, **style: Any) -> Any:
    """Vertical lines over the whole height of ``ax`` at ``x`` [data], as ``axvline`` draws them, one artist."""
    from matplotlib.collections import LineCollection

    x = np.asarray(x, dtype=float).ravel()
    lc = LineCollection([np.array([[v, 0.0], [v, 1.0]]) for v in x], transform=ax.get_xaxis_transform(which="grid"),
                        colors=[style.get("color", "k")], linewidths=style.get("lw", 1.0),
                        linestyles=style.get("ls", "-"))
    ax.add_collection(lc, autolim=False)
    _take_in_x(ax, x)  # as axvline's do (the curves drawn first asked for an autoscale)
    return lc


__all__ = ["SynthesisPlot", "phase_centre", "phase_line", "plot_synthesis", "shown_channels"]
