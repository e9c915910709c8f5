"""Measured FRFs against the 3DOF rig model (the paper's Fig. 7).

Functions
---------
plot_rig_fit
    Housing and spindle radial FRFs (black) against the model (grey) in 150–700 Hz, magnitude
    (and on request phase), the chosen housing mode marked, every candidate mode in a strip below
    with the reason it was rejected.
save_figure
    Save a figure atomically.

Classes
-------
RigPlot
    The figure, its axes by name and the artists by category.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from os import PathLike
from typing import TYPE_CHECKING, Any

import numpy as np

from .._atomic import atomic_path
from .._text import plain, std_text
from ..rig.model import HOUSING, SPINDLE, RigModel
from ._render import fixed_layout, plot_line, reuse_axes, semilogy
from .synthesis import phase_centre, phase_line

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

    from ..config import RigConfig
    from ..frf import FRFData

__all__ = ["RigPlot", "plot_rig_fit", "save_figure", "short_reason"]

_MEAS = "black"
_MODEL = "0.55"
_STATUS_COLOR = {"housing": "tab:red", "spindle": "tab:blue", "rejected": "0.45"}


@dataclass(frozen=True, slots=True, eq=False)
class RigPlot:
    """Result of :func:`plot_rig_fit`.

    Attributes
    ----------
    figure : matplotlib.figure.Figure
    axes : dict
        ``'housing'``, ``'spindle'`` (may be absent) and ``'candidates'`` axes; with ``phase=True``
        also ``'housing_phase'`` and ``'spindle_phase'`` (the phase [deg] under each magnitude).
    artists : dict
        ``'measured'``, ``'model'``, ``'housing_mode'``, ``'candidates'``: lists of artists.
    model_k_tb_ms : float
        ``k_TB+MS`` of the drawn model [N/m].
    """

    figure: Figure
    axes: dict[str, Axes]
    artists: dict[str, list[Any]] = field(default_factory=dict)
    model_k_tb_ms: float = math.nan


def short_reason(reason: str) -> str:
    """A few words for a candidate's rejection reason (the full text stays in the JSON)."""
    r = reason.lower()
    for key, word in (("harmonic", "harmonic"), ("spindle mode", "spindle"), ("lateral mode", "lateral"),
                      ("axial mode", "axial"), ("tilt", "tilt"), ("modal mass", "mass"),
                      ("outside", "range"), ("amplitudes differ", "shape"), ("spindle/housing", "spindle ratio"),
                      ("matches better", "weaker"), ("no radial", "no radial")):
        if key in r:
            return word
    return "rejected"


def _model_parts(result: Any, rig: RigConfig) -> list[tuple[str, Any, np.ndarray, dict[str, Any]]]:
    """(label, RigModel, modal damping ratios, line style) of the drawn models.

    Always the model with the inverted ``k_TB+MS`` and the identified damping; in addition the
    least-squares fit when the result carries one.
    """
    k = float(result.k_TB_MS)
    k_ms = getattr(result, "k_MS", None)
    params = rig.model if k_ms is None else replace(rig.model, k_MS=float(k_ms))
    z_h = float(result.housing_mode.get("damping_ratio") or 0.02)
    sm = getattr(result, "spindle_mode", None) or (result.match.spindle_mode if hasattr(result, "match") else None)
    z_s = float(sm["damping_ratio"]) if sm else 0.01
    out = [("3DOF model (housing mode inverted)", RigModel(params, k), np.array([0.03, z_h, z_s]),
            {"color": _MODEL, "lw": 2.6, "alpha": 0.9})]
    fit = getattr(result, "fit", None)
    if fit is not None:
        out.append((f"3DOF model fitted 150–700 Hz (rms log error {fit.residual_rms:.2f})", fit.model,
                    np.asarray(fit.damping_ratio, dtype=float), {"color": "0.35", "lw": 1.4, "ls": "--"}))
    return out


def plot_rig_fit(
    data: FRFData,
    result: Any,
    rig: RigConfig,
    *,
    band: tuple[float, float] = (150.0, 700.0),
    figure: Figure | None = None,
    title: str | None = None,
    phase: bool = False,
    dpi: float | None = None,
) -> RigPlot:
    """Measured radial FRFs against the 3DOF model (paper Fig. 7).

    Parameters
    ----------
    data : FRFData
        The measurement (radial reference, sensor roles and axes).
    result : StiffnessResult or CalibrationResult
        Gives ``k_TB_MS``, ``k_MS``, the housing mode and the matching candidates; an attribute
        ``fit`` (a :class:`~ema_rig.rig.inversion.RigFit`) is drawn instead when present.
    rig : RigConfig
        Rig parameters and sensors.
    band : (float, float), optional
        Frequency range of the plot [Hz] (paper: 150–700 Hz).
    figure : Figure, optional
        Figure to draw into; default a new one (no pyplot state). One that holds an earlier fit
        drawn with the same panels keeps its axes (emptied, :func:`ema_rig.plot._render.reuse_axes`):
        the same picture, without building axes and ticks again; any other is cleared.
    title : str, optional
        Figure title (default: file name and k_TB).
    phase : bool, optional
        Also draw the phase [deg] of the measured and model FRFs under each magnitude panel
        (default False: the paper's Fig. 7 shows magnitudes only).
    dpi : float, optional
        The pixel density [dots per inch] the figure will be drawn at, once, to a raster (a
        report's PNG). Given, the figure is laid out here for that density instead of by a
        constrained layout at every draw (:func:`ema_rig.plot._render.fixed_layout`: the room for
        the lowest and highest magnitude tick labels is always kept, so the layout is the same for
        every measurement with the same texts and is computed once for them; the figure's layout
        engine is switched off). Default: a constrained layout at every draw.

    Returns
    -------
    RigPlot
    """
    from matplotlib.figure import Figure

    lo, hi = float(band[0]), float(band[1])
    if not hi > lo:
        raise ValueError(f"band must satisfy lo < hi, got {band!r}")
    ref = rig.radial.positive()
    in_idx = [j for j, d in enumerate(data.in_dofs) if d.same_axis(ref)]
    if not in_idx:
        raise ValueError(f"the data have no radial reference {rig.radial}")
    q = in_idx[0]
    sel = (data.freq >= lo) & (data.freq <= hi)
    if sel.sum() < 2:
        raise ValueError(f"band {lo:g}..{hi:g} Hz holds fewer than 2 lines of the data")
    f = data.freq[sel]

    def outputs(role: str) -> list[int]:
        idx = []
        for i, d in enumerate(data.out_dofs):
            r, a = data.roles[i], data.axes[i]
            if r is None or a is None:
                s = rig.sensor_for(d)
                r, a = (s.role, s.axis) if s is not None else (None, None)
            if r == role and a == "radial":
                idx.append(i)
        return idx

    h_out, s_out = outputs("housing"), outputs("spindle")
    models = _model_parts(result, rig)
    model = models[0][1]
    ff = np.linspace(lo, hi, 1500)
    h_models = [m.frf(ff, damping_ratio=z, frf_form=data.frf_form, outputs=(HOUSING, SPINDLE))
                for _, m, z, _ in models]

    fig = figure if figure is not None else Figure(figsize=(8.0, 7.2), layout="constrained")
    names = ["housing", "spindle"] if s_out else ["housing"]
    if phase:
        names = [n for name in names for n in (name, f"{name}_phase")]
    n_main = len(names)
    # a figure that holds an earlier fit with these panels keeps its axes (emptied); else cleared
    kept = reuse_axes(fig, f"ema_rig.rig_fit {','.join(names)}")
    if dpi is not None:
        fig.set_dpi(dpi)
    fresh = kept is None  # kept axes keep their grid and tick styles
    if kept is None:
        gs = fig.add_gridspec(n_main + 1, 1, height_ratios=[1.2 if n.endswith("_phase") else 3.0 for n in names]
                              + [1.25])
        ax_h = fig.add_subplot(gs[0])
        kept = [ax_h, *(fig.add_subplot(gs[k], sharex=ax_h) for k in range(1, n_main + 1))]
    axes: dict[str, Any] = dict(zip([*names, "candidates"], kept, strict=True))
    ax_h, ax_c = axes["housing"], axes["candidates"]
    artists: dict[str, list[Any]] = {"measured": [], "model": [], "housing_mode": [], "candidates": []}
    unit = data.unit_str

    panels = [("housing", h_out, 0, "Housing, radial")]
    if s_out:
        panels.append(("spindle", s_out, 1, "Spindle, radial"))
    for name, idx, row, label in panels:
        ax = axes[name]
        for k, i in enumerate(idx):
            (ln,) = semilogy(ax, f, np.abs(data.frf[i, q, sel]), color=_MEAS, lw=0.9,
                                label="measured" if k == 0 else None)
            artists["measured"].append(ln)
        for (mlabel, _, _, style), hm in zip(models, h_models, strict=True):
            (lm,) = semilogy(ax, ff, np.abs(hm[row]), zorder=1, label=mlabel, **style)
            artists["model"].append(lm)
        ax.set_ylabel(f"|FRF| [{unit}]")
        y0, y1 = ax.get_ylim()
        ax.set_ylim(y0, y1 * 4.0)  # headroom for the labels above the resonance peak
        if fresh:
            ax.grid(True, which="major", color="0.88", lw=0.6)
            ax.grid(True, which="minor", axis="y", color="0.94", lw=0.4)
        dofs = ", ".join(str(data.out_dofs[i]) for i in idx)
        ax.text(0.01, 0.97, f"{label} ({dofs}) / force {data.in_dofs[q]}", transform=ax.transAxes,
                va="top", ha="left", fontsize=9, bbox={"fc": "white", "ec": "none", "alpha": 0.8})
        if phase:
            pax = axes[f"{name}_phase"]
            # the window holds a driving point's whole range without a wrap: 180..0 deg for
            # accelerance, 90..-90 for mobility, 0..-180 for receptance
            c = phase_centre(data.frf_form)
            for i in idx:
                h = data.frf[i, q, sel]
                (ln,) = plot_line(pax, *phase_line(f, h, c), color=_MEAS, lw=0.9)
                artists["measured"].append(ln)
            for (_, _, _, style), hm in zip(models, h_models, strict=True):
                (lm,) = plot_line(pax, *phase_line(ff, hm[row], c), zorder=1, **style)
                artists["model"].append(lm)
            pax.set_ylim(c - 190.0, c + 190.0)
            pax.set_yticks(c + np.array([-180.0, -90.0, 0.0, 90.0, 180.0]))
            pax.set_ylabel("phase [deg]")
            if fresh:
                pax.grid(True, color="0.88", lw=0.6)

    fh = float(result.housing_mode["natural_freq"])
    for name in names:
        ax = axes[name]
        if lo <= fh <= hi:
            vl = ax.axvline(fh, color=_STATUS_COLOR["housing"], lw=1.0, ls="--", zorder=0,
                            label=f"housing mode {fh:.1f} Hz" if name == "housing" else None)
            artists["housing_mode"].append(vl)
    ax_h.legend(loc="upper left", bbox_to_anchor=(0.0, 0.91), fontsize=8.5, framealpha=0.9)
    k_tb = getattr(result, "k_TB", None)
    if k_tb is not None:
        txt = (f"$k_{{TB+MS}}$ = {model.k_TB_MS / 1e6:.2f} MN/m\n"
               f"$k_{{TB}}$ = {k_tb / 1e6:.2f} ± {std_text(result.k_TB_std / 1e6)} MN/m (±1σ total)")
    else:
        txt = f"$k_{{MS}}$ = {result.k_MS / 1e6:.2f} ± {std_text(result.k_MS_std / 1e6)} MN/m (±1σ total; steel disk)"
    ax_h.text(0.99, 0.97, txt, transform=ax_h.transAxes, va="top", ha="right", fontsize=9,
              bbox={"fc": "white", "ec": "0.7", "alpha": 0.9})

    # ---- candidate strip: every identified mode, coloured by verdict, with a short reason
    cands = list(getattr(result, "candidates", []) or [])
    inside = [c for c in cands if lo <= c["natural_freq"] <= hi]
    outside = [c for c in cands if not lo <= c["natural_freq"] <= hi]
    ax_c.set_ylim(0, 1)
    ax_c.set_yticks([])
    ax_c.set_xlim(lo, hi)
    # label packing: each label occupies [left, right] in axis fraction; take the lowest free row
    # the strip's width before any layout (that of a new figure, also when the figure is reused)
    axis_pt = ax_c.get_subplotspec().get_position(fig).width * fig.get_figwidth() * 72.0
    rows: list[list[tuple[float, float]]] = [[] for _ in range(4)]
    for c in inside:
        x = c["natural_freq"]
        st = c["status"]
        col = _STATUS_COLOR.get(st, "0.45")
        mk = {"housing": "v", "spindle": "s"}.get(st, "x")
        plot_line(ax_c, [x, x], [0.0, 0.28], color=col, lw=1.0)
        (pt,) = plot_line(ax_c, [x], [0.28], marker=mk, color=col, ms=7, ls="none")
        artists["candidates"].append(pt)
        lab = "housing mode" if st == "housing" else ("spindle mode" if st == "spindle" else short_reason(c["reason"]))
        text = f"{x:.0f} Hz {lab}"
        pos = (x - lo) / (hi - lo)
        ha = "left" if pos < 0.1 else ("right" if pos > 0.88 else "center")
        width = (len(text) * 0.56 * 7.5 + 6.0) / axis_pt  # ~0.56 em per character at 7.5 pt
        left = {"left": pos, "right": pos - width, "center": pos - width / 2}[ha]
        span = (left, left + width)
        level = next((i for i, row in enumerate(rows)
                      if all(span[1] <= a or span[0] >= b for a, b in row)), len(rows) - 1)
        rows[level].append(span)
        ax_c.text(x, 0.34 + 0.165 * level, text, rotation=0, ha=ha,
                  va="bottom", fontsize=7.5, color=col, clip_on=True)
    note = "identified modes: " + ("none in this band" if not inside else "x rejected, ▼ chosen")
    if outside:
        shown = ", ".join(
            f"{c['natural_freq']:.0f} Hz {c['status'] if c['status'] != 'rejected' else short_reason(c['reason'])}"
            for c in outside[:5])
        note += f"; {len(outside)} outside {lo:.0f}–{hi:.0f} Hz:\n{shown}" + (", ..." if len(outside) > 5 else "")
    ax_c.set_title(note, fontsize=8, loc="left", y=1.0)  # pinned where matplotlib puts it: the strip has no y ticks
    ax_c.set_xlabel("Frequency [Hz]")
    for name in names:
        if fresh:
            axes[name].tick_params(labelbottom=False)
        axes[name].set_xlim(lo, hi)
    if title is None:
        fname = getattr(result, "file", None)
        base = str(fname).replace("\\", "/").rsplit("/", 1)[-1] if fname else "measurement"
        title = f"{plain(base)}: measured FRFs (black) and 3DOF model (grey), {lo:.0f}–{hi:.0f} Hz"
    fig.suptitle(title, fontsize=10)
    if dpi is not None:
        fixed_layout(fig, [axes[name].yaxis for name in names if not name.endswith("_phase")])
    return RigPlot(figure=fig, axes=axes, artists=artists, model_k_tb_ms=float(model.k_TB_MS))


def save_figure(fig: Figure, path: str | PathLike[str], *, dpi: int = 150) -> None:
    """Save ``fig`` atomically (format from the suffix: png, svg, pdf)."""
    with atomic_path(path) as tmp:
        fig.savefig(tmp, dpi=dpi)
