"""Figures of a campaign: the paper's Sect. 5-6 plots from a :class:`~ema_rig.campaign.CampaignResult`.

Functions
---------
campaign_figures
    Every figure the campaign's data support, by name.
campaign_figure_names
    Their names, without building them (to share them out between processes).
plot_k_vs_load
    k_TB versus radial load with error bars, the Hertzian estimate and a F^(1/3) fit.
plot_rotating_vs_static
    Rotating against non-rotating stiffness with the mean change in %.
plot_speed_effect
    k_TB versus shaft speed.
plot_validation
    A reference bearing (the dummy) against its FE bounds (the paper's Fig. 9).
plot_repeatability
    Deviation of each repeat from its condition's mean.

All functions take the result rows and return a matplotlib Figure (never shown).
Error bars are +/- one standard uncertainty, labelled as the table labels it: the total (``k_TB_std``)
where estimates are compared with a bound or a curve, the measured part (``k_TB_std_measured``) where
they are compared with one another (speeds, repeats: the rig-model tolerances are common to all). Names that come from the campaign file
(bearings, repeats) are escaped for matplotlib's mathtext, so a ``$`` is drawn as a ``$``.
"""

from __future__ import annotations

import functools
import hashlib
import math
from collections import defaultdict
from collections.abc import Callable, Collection, Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._text import plain
from ..campaign.schema import BearingInfo
from ..rig.damping import c_tb_kind
from ..rig.hertz import ball_bearing_radial_stiffness
from ..simulate import planted_k_tb

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..campaign.result import CampaignResult
    from ..campaign.schema import BearingInfo

Row = Mapping[str, Any]
_MN = 1e6  # plots in MN/m = N/um


def _ok(rows: Sequence[Row]) -> list[Row]:
    return [r for r in rows if r.get("status") == "ok" and math.isfinite(r.get("k_TB", math.nan))]


def _figure(figsize: tuple[float, float] = (7.0, 4.4)) -> Figure:
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, layout="constrained")
    return fig


def figure_stem(bearing: str) -> str:
    """A file-name-safe stem for a bearing, unique per bearing name.

    Letters, digits, ``-`` and ``_`` are kept; a name that needed changes (``"a/b"``, ``"a b"``) gets
    a short hash of the original, so two names never share a file.
    """
    safe = "".join(ch if (ch.isascii() and ch.isalnum()) or ch in "-_" else "_" for ch in bearing)[:60]
    if safe != bearing or not safe:
        safe = f"{safe or 'bearing'}-{hashlib.sha256(bearing.encode('utf-8')).hexdigest()[:8]}"
    return safe


def _finite(x: Any) -> bool:
    return isinstance(x, (int, float)) and math.isfinite(x)


def plot_k_vs_load(rows: Sequence[Row], bearing: str, *, info: BearingInfo | None = None) -> Figure:
    """k_TB of one bearing versus radial load, rotating and non-rotating separately.

    Parameters
    ----------
    rows : sequence of mapping
        Campaign rows (``radial_load`` N, ``speed`` rpm, ``k_TB``/``k_TB_std`` N/m).
    bearing : str
        Bearing name to plot.
    info : BearingInfo, optional
        With ``hertz=True`` and a ``geometry`` the analytical Hertzian estimate of that geometry is
        drawn, labelled as an estimate.

    Returns
    -------
    matplotlib.figure.Figure
    """
    fig = _figure()
    ax = fig.add_subplot()
    sel = [r for r in _ok(rows) if r["bearing"] == bearing and _finite(r["radial_load"])]
    groups: dict[str, list[Row]] = defaultdict(list)
    for r in sel:
        groups["rotating" if r["speed"] > 0 else "not rotating"].append(r)
    markers = {"rotating": ("o", "C0"), "not rotating": ("s", "C3")}
    for name, rs in groups.items():
        f = np.array([r["radial_load"] for r in rs])
        k = np.array([r["k_TB"] for r in rs]) / _MN
        s = np.array([r["k_TB_std"] for r in rs]) / _MN
        m, c = markers[name]
        ax.errorbar(f, k, yerr=s, fmt=m, color=c, capsize=3, ms=5, label=f"measured, {name} (±1σ total)")
    loads = np.array([r["radial_load"] for r in sel])
    if loads.size and np.any(loads > 0):
        fl = np.linspace(max(loads[loads > 0].min() * 0.8, 1.0), loads.max() * 1.15, 100)
        rot = [r for r in sel if r["speed"] > 0 and r["radial_load"] > 0] or [r for r in sel if r["radial_load"] > 0]
        if rot:
            fr = np.array([r["radial_load"] for r in rot])
            kr = np.array([r["k_TB"] for r in rot])
            coef = float(np.sum(kr * fr ** (1 / 3)) / np.sum(fr ** (2 / 3)))  # least squares k = c F^(1/3)
            ax.plot(fl, coef * fl ** (1 / 3) / _MN, "--", color="0.35",
                    label=f"fit k = c·F^(1/3), c = {coef:.3g} N/m/N^(1/3)")
        if info is not None and info.hertz and info.geometry is not None:
            try:  # checked when the campaign was loaded; a failure here must not lose the figure
                with np.errstate(all="raise"):
                    k_hertz = np.asarray(ball_bearing_radial_stiffness(fl, info.geometry), dtype=float)
            except (ArithmeticError, ValueError, RuntimeError):
                k_hertz = None
            if k_hertz is not None and np.all(np.isfinite(k_hertz)):
                ax.plot(fl, k_hertz / _MN, ":", color="C2", lw=2,
                        label=f"Hertz estimate (bearing alone; {info.geometry.describe()})")
    ax.set_xlabel("radial load F_r [N]")
    ax.set_ylabel("bearing stiffness k_TB [MN/m]")
    ax.set_title(f"Bearing {plain(bearing)}: stiffness versus radial load")
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return fig


def plot_rotating_vs_static(
    rows: Sequence[Row], bearing: str, *, planted: Mapping[str, float] | None = None
) -> tuple[Figure, float]:
    """Rotating versus non-rotating stiffness of one bearing.

    Non-rotating measurements are shown per shaft position, rotating ones per speed, each with its
    measured ±1σ (:func:`measured_std`: the rig-model tolerances shift both groups alike); the mean
    change (rotating mean / non-rotating mean - 1) is written in the title (the paper measured
    -8.8 %). On a real campaign it is a measurement. When every compared measurement is synthetic
    (``planted`` holds its true k_TB), the title says the change was recovered and gives the value
    planted in the data, computed the same way from the truths.

    Parameters
    ----------
    rows : sequence of mapping
        Campaign rows.
    bearing : str
    planted : mapping of str to float, optional
        Measurement id -> the k_TB [N/m] planted by the simulator (see
        :func:`ema_rig.simulate.planted_k_tb`).

    Returns
    -------
    fig : matplotlib.figure.Figure
    change_percent : float
        Mean change in %, NaN when one of the two groups is empty.
    """
    sel = [r for r in _ok(rows) if r["bearing"] == bearing]
    static = [r for r in sel if r["speed"] <= 0]
    rot = [r for r in sel if r["speed"] > 0]
    # compare at the load(s) where both exist, so a load sweep does not bias the change
    loads = {r["radial_load"] for r in static} & {r["radial_load"] for r in rot}
    if loads:
        static = [r for r in static if r["radial_load"] in loads]
        rot = [r for r in rot if r["radial_load"] in loads]
    fig = _figure()
    ax = fig.add_subplot()
    labels: list[str] = []
    x = 0
    for group, color, fmt in ((static, "C3", "s"), (rot, "C0", "o")):
        for r in sorted(group, key=lambda r: (r["speed"], _key(r["shaft_position"]), r["repeat"])):
            if r["speed"] > 0:
                lab = f"{r['speed']:.0f} rpm"
            else:
                pos = r["shaft_position"]
                lab = f"pos {pos:.0f}°" if _finite(pos) else "static"
            # a comparison of conditions: the measured ± (the rig-model tolerances shift both groups alike)
            ax.errorbar([x], [r["k_TB"] / _MN], yerr=[measured_std(r) / _MN], fmt=fmt, color=color, capsize=3)
            labels.append(lab + (f" #{r['repeat']}" if r["repeat"] != 1 else ""))
            x += 1
    change = math.nan
    if static and rot:
        ms = float(np.mean([r["k_TB"] for r in static]))
        mr = float(np.mean([r["k_TB"] for r in rot]))
        change = 100.0 * (mr / ms - 1.0)
        ax.axhline(ms / _MN, color="C3", ls="--", lw=1, label=f"non-rotating mean {ms / _MN:.1f} MN/m")
        ax.axhline(mr / _MN, color="C0", ls="--", lw=1, label=f"rotating mean {mr / _MN:.1f} MN/m")
        ax.legend(fontsize=8)
    ax.set_xticks(range(len(labels)), labels, rotation=45, ha="right", fontsize=8)
    ax.set_ylabel("bearing stiffness k_TB [MN/m] (±1σ measured)")
    load_txt = f" at {', '.join(f'{v:g}' for v in sorted(loads))} N" if loads else ""
    ttl = f"Bearing {plain(bearing)}{load_txt}: rotating vs non-rotating"
    if math.isfinite(change):
        ids = [r["id"] for r in (*static, *rot)]
        if planted is not None and all(i in planted for i in ids):
            ps = float(np.mean([planted[r["id"]] for r in static]))
            pr = float(np.mean([planted[r["id"]] for r in rot]))
            ttl += (
                f"\nmean change {change:+.1f} % recovered; planted in the synthetic data: "
                f"{100.0 * (pr / ps - 1.0):+.1f} %"
            )
        else:
            ttl += f" — measured mean change {change:+.1f} %"
    ax.set_title(ttl, fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    return fig, change


def _key(x: Any) -> float:
    return x if _finite(x) else -1.0


def measured_std(row: Row) -> float:
    """The part of ``k_TB_std`` [N/m] that comes from the measurement: the table's "± measured".

    The row's ``k_TB_std_measured`` (the identified housing frequency, and the housing mass where
    the inversion used the measured one); a row without that column (written before it existed)
    falls back to its budget's ``f_H`` term. The rig-model tolerances (masses, stiffnesses) and
    k_MS are the same for every measurement of a campaign: they shift all estimates together and
    cannot hide or create a difference between conditions, so a comparison of conditions needs
    only this part. NaN when the row has neither.
    """
    if _finite(row.get("k_TB_std_measured")):
        return float(row["k_TB_std_measured"])
    detail = row.get("detail")
    if isinstance(detail, dict):
        for t in detail.get("uncertainty_terms") or ():
            if isinstance(t, dict) and t.get("name") == "f_H" and _finite(t.get("std")):
                return float(t["std"])
        share: Any = (detail.get("uncertainty_budget") or {}).get("f_H")
        std: Any = row.get("k_TB_std")
        if _finite(share) and _finite(std):
            return float(std) * math.sqrt(max(float(share), 0.0))
    return math.nan


def plot_speed_effect(rows: Sequence[Row], bearing: str) -> Figure:
    """k_TB versus shaft speed, one series per radial load measured at several speeds.

    The error bars are the measured (identification) uncertainty of each estimate,
    :func:`measured_std`: the rig-model tolerances are fully correlated between speeds and would
    hide any speed effect. The spread (sample standard deviation over mean) of each series is
    written beside it: the paper (Table 3) finds it no larger than the spread of repeats at one speed.
    """
    sel = [r for r in _ok(rows) if r["bearing"] == bearing and r["speed"] > 0]
    fig = _figure()
    ax = fig.add_subplot()
    by_load: dict[float, list[Row]] = defaultdict(list)
    for r in sel:
        by_load[r["radial_load"]].append(r)
    # a speed effect needs one load measured at several speeds; single-speed loads would only clutter
    by_load = {k: v for k, v in by_load.items() if len({r["speed"] for r in v}) > 1}
    for i, (load, rs) in enumerate(sorted(by_load.items(), key=lambda kv: _key(kv[0]))):
        rs = sorted(rs, key=lambda r: r["speed"])
        ax.errorbar([r["speed"] for r in rs], [r["k_TB"] / _MN for r in rs],
                    yerr=[measured_std(r) / _MN for r in rs], fmt="o", color=f"C{i}", capsize=3,
                    label=f"{load:g} N" if _finite(load) else "load n/a")
        speeds = sorted({r["speed"] for r in rs})  # repeats at one speed: the line joins their mean
        means = [np.mean([r["k_TB"] for r in rs if r["speed"] == v]) / _MN for v in speeds]
        ax.plot(speeds, means, "-", color=f"C{i}", lw=1)
        k = np.array([r["k_TB"] for r in rs])
        if k.size > 1:
            ax.annotate(f"spread {100 * k.std(ddof=1) / k.mean():.1f} %", (rs[-1]["speed"], k[-1] / _MN),
                        textcoords="offset points", xytext=(6, 0), fontsize=8, va="center")
    ax.set_xlabel("shaft speed [rpm]")
    ax.set_ylabel("bearing stiffness k_TB [MN/m]")
    ax.set_title(f"Bearing {plain(bearing)}: effect of speed (±1σ measured; model tolerances common to all)",
                 fontsize=10)
    ax.grid(True, alpha=0.3)
    if by_load:
        ax.legend(title="radial load", fontsize=8)
    return fig


def plot_validation(rows: Sequence[Row], bearing: str, info: BearingInfo) -> Figure:
    """A bearing of known stiffness against its FE bounds (the paper's Fig. 9).

    The grey band spans ``info.k_lower`` ... ``info.k_upper``; each repeat has its own marker.
    """
    sel = [r for r in _ok(rows) if r["bearing"] == bearing]
    fig = _figure()
    ax = fig.add_subplot()
    loads = [r["radial_load"] for r in sel if _finite(r["radial_load"])]
    lo_x = min(loads) if loads else 0.0
    hi_x = max(loads) if loads else 1.0
    pad = 0.1 * (hi_x - lo_x or 1.0)
    if info.k_lower is not None and info.k_upper is not None:
        ax.axhspan(info.k_lower / _MN, info.k_upper / _MN, color="0.85", zorder=0,
                   label=f"FE bounds {info.k_lower / _MN:.2f}–{info.k_upper / _MN:.2f} MN/m")
    by_rep: dict[int, list[Row]] = defaultdict(list)
    for r in sel:
        by_rep[r["repeat"]].append(r)
    mk = "osD^v<>"
    for i, (rep, rs) in enumerate(sorted(by_rep.items())):
        rs = sorted(rs, key=lambda r: _key(r["radial_load"]))
        off = (i - (len(by_rep) - 1) / 2) * 0.012 * (hi_x - lo_x or 1.0)
        ax.errorbar([r["radial_load"] + off for r in rs], [r["k_TB"] / _MN for r in rs],
                    yerr=[r["k_TB_std"] / _MN for r in rs], fmt=mk[i % len(mk)] + "-", color=f"C{i}",
                    capsize=3, ms=6, lw=1, label=f"repeat {rep} (±1σ total)")
    inside = sum(
        1 for r in sel
        if info.k_lower is not None and info.k_upper is not None and info.k_lower <= r["k_TB"] <= info.k_upper
    )
    ax.set_xlim(lo_x - pad, hi_x + pad)
    ax.set_xlabel("radial load of the air springs [N]")
    ax.set_ylabel("estimated stiffness k_TB [MN/m]")
    ax.set_title(f"Validation on the {plain(bearing)} bearing: {inside}/{len(sel)} estimates inside the FE bounds",
                 fontsize=10)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8, loc="best")
    return fig


def plot_repeatability(rows: Sequence[Row]) -> Figure | None:
    """Deviation of each repeat from the mean of its condition, in %.

    A condition is (bearing, radial load, speed, shaft position). The grey bar beside each is the
    mean measured uncertainty of its repeats (:func:`measured_std`, in % of their mean): what the
    deviations are to be compared with, since the rig-model tolerances are the same for every
    repeat. Returns None when no condition was measured more than once.
    """
    groups: dict[tuple[Any, ...], list[Row]] = defaultdict(list)
    for r in _ok(rows):
        groups[(r["bearing"], _key(r["radial_load"]), r["speed"], _key(r["shaft_position"]))].append(r)
    groups = {k: v for k, v in groups.items() if len(v) > 1}
    if not groups:
        return None
    fig = _figure()
    ax = fig.add_subplot()
    labels = []
    # numeric order of loads, speeds and positions (200 N before 1000 N), bearings by name
    for i, (k, rs) in enumerate(sorted(groups.items(), key=lambda kv: (str(kv[0][0]), *map(_key, kv[0][1:])))):
        vals = np.array([r["k_TB"] for r in rs])
        dev = 100 * (vals / vals.mean() - 1)
        ax.plot(np.full(dev.size, i), dev, "o", color="C0")
        # the repeats' differences: the rig-model tolerances, common to all of them, cancel
        rel = 100 * np.array([measured_std(r) for r in rs]) / vals.mean()
        if np.all(np.isfinite(rel)):
            ax.errorbar([i + 0.15], [0.0], yerr=[rel.mean()], fmt="none", ecolor="0.5", capsize=3)
        b, load, speed, _pos = k
        labels.append(f"{plain(b)}\n{load:g} N, {speed:g} rpm")
    ax.axhline(0, color="k", lw=0.8)
    ax.set_xticks(range(len(labels)), labels, fontsize=7, rotation=30, ha="right")
    ax.set_ylabel("deviation from condition mean [%]")
    ax.set_title("Repeatability (grey bar: mean ±1σ measured; model tolerances common to all)", fontsize=10)
    ax.grid(True, axis="y", alpha=0.3)
    return fig


def _planted(rows: Sequence[Row], result: CampaignResult) -> dict[str, float]:
    """Id -> k_TB planted by the simulator, for the rows whose file carries a truth file."""
    base = result.config.path.parent if result.config.path is not None else Path.cwd()
    out: dict[str, float] = {}
    for r in rows:
        if not r.get("file"):
            continue
        k = planted_k_tb(base / Path(r["file"]))  # an absolute file stays as it is
        if k is not None:
            out[r["id"]] = k
    return out


def plot_damping(rows: Sequence[Row], bearing: str) -> Figure | None:
    """Bearing damping ``c_TB`` (±1σ) of one bearing against radial load and against speed: filled
    markers where it is measured, open ones where it is the upper bound
    (:func:`ema_rig.rig.damping.c_tb_kind`).

    Parameters
    ----------
    rows : sequence of mapping
        Campaign rows (``radial_load`` N, ``speed`` rpm, ``c_TB``/``c_TB_std`` N s/m).
    bearing : str
        Bearing name to plot.

    Returns
    -------
    matplotlib.figure.Figure or None
        None when no row of the bearing has a damping value, or neither load nor speed varies.
    """
    sel = [r for r in _ok(rows) if r["bearing"] == bearing and _finite(r.get("c_TB"))]
    loads = {r["radial_load"] for r in sel if _finite(r["radial_load"])}
    speeds = {r["speed"] for r in sel if _finite(r["speed"])}
    panels = [p for p, vals in (("radial_load", loads), ("speed", speeds)) if len(vals) > 1]
    if not sel or not panels:
        return None
    fig = _figure((4.2 * len(panels) + 1.0, 4.0))
    axes = fig.subplots(1, len(panels), squeeze=False)[0]
    labels = {"radial_load": "radial load F_r [N]", "speed": "speed [rpm]"}
    for ax, key in zip(axes, panels, strict=True):
        rot = [r for r in sel if _finite(r[key])]
        for name, group, (mk, col) in (("rotating", [r for r in rot if r["speed"] > 0], ("o", "C0")),
                                       ("not rotating", [r for r in rot if r["speed"] <= 0], ("s", "C3"))):
            if not group:
                continue
            for kind, part in (("measured", [r for r in group if c_tb_kind(r) == "measured"]),
                               ("upper bound", [r for r in group if c_tb_kind(r) != "measured"])):
                if not part:
                    continue
                x = np.array([r[key] for r in part], dtype=float)
                y = np.array([r["c_TB"] for r in part], dtype=float)
                e = np.array([r.get("c_TB_std", math.nan) for r in part], dtype=float)
                ax.errorbar(x, y, yerr=np.where(np.isfinite(e), e, 0.0), fmt=mk, color=col, capsize=3, ms=5,
                            mfc=col if kind == "measured" else "none",
                            label=f"{name}, {kind} (±1σ)")
        ax.set_xlabel(labels[key])
        ax.set_ylabel("bearing damping c_TB [N·s/m]")
        ax.grid(True, alpha=0.3)
        lo, hi = ax.get_ylim()
        ax.set_ylim(lo, hi + 0.25 * (hi - lo))  # headroom: the legend above the error bars, not on them
        ax.legend(fontsize=8, loc="upper right")
    fig.suptitle(f"Bearing {plain(bearing)}: damping from the housing mode (3DOF model)", fontsize=10)
    return fig


def campaign_figures(result: CampaignResult, names: Collection[str] | None = None) -> dict[str, Figure]:
    """Every figure the campaign's data support.

    Parameters
    ----------
    result : CampaignResult
    names : collection of str, optional
        Build only the figures of these names (:func:`campaign_figure_names`); default all.

    Returns
    -------
    dict
        Name -> Figure: ``validation_<bearing>`` for bearings with FE bounds,
        ``k_vs_load_<bearing>``, ``rotating_vs_static_<bearing>``, ``speed_<bearing>``,
        ``damping_<bearing>`` where the data exist, and ``repeatability``, in that order
        (Sect. 5, validation, before Sect. 6, operating conditions).
    """
    figs: dict[str, Figure] = {}
    for name, build in _planned(result).items():
        if names is None or name in names:
            fig = build()
            if fig is not None:
                figs[name] = fig
    return figs


def campaign_figure_names(result: CampaignResult) -> list[str]:
    """The names :func:`campaign_figures` may return, in its order, without building a figure.

    A name whose figure turns out to have nothing to show (too few repeats, no damping) is
    listed but not returned.

    Parameters
    ----------
    result : CampaignResult

    Returns
    -------
    list of str
    """
    return list(_planned(result))


def _planned(result: CampaignResult) -> dict[str, Callable[[], Figure | None]]:
    """Name -> how to build that figure, in the order of :func:`campaign_figures`."""
    rows = result.rows
    ok = _ok(rows)
    plan: dict[str, Callable[[], Figure | None]] = {}
    bearings = sorted({r["bearing"] for r in ok})
    for b in bearings:
        info = result.config.bearings.get(b, BearingInfo())
        rs = [r for r in ok if r["bearing"] == b]
        safe = figure_stem(b)
        if info.k_lower is not None and info.k_upper is not None:
            plan[f"validation_{safe}"] = functools.partial(plot_validation, rows, b, info)
            continue
        if len({r["radial_load"] for r in rs if _finite(r["radial_load"])}) > 1:
            plan[f"k_vs_load_{safe}"] = functools.partial(plot_k_vs_load, rows, b, info=info)
        if any(r["speed"] > 0 for r in rs) and any(r["speed"] <= 0 for r in rs):
            plan[f"rotating_vs_static_{safe}"] = functools.partial(
                lambda b, rs: plot_rotating_vs_static(rows, b, planted=_planted(rs, result))[0], b, rs)
        if len({r["speed"] for r in rs if r["speed"] > 0}) > 1:
            plan[f"speed_{safe}"] = functools.partial(plot_speed_effect, rows, b)
        plan[f"damping_{safe}"] = functools.partial(plot_damping, rows, b)
    # Sect. 5 (validation) before Sect. 6 (operating conditions)
    plan = dict(sorted(plan.items(), key=lambda kv: not kv[0].startswith("validation")))
    plan["repeatability"] = functools.partial(plot_repeatability, rows)
    return plan


__all__ = [
    "campaign_figure_names",
    "campaign_figures",
    "measured_std",
    "figure_stem",
    "plot_damping",
    "plot_k_vs_load",
    "plot_repeatability",
    "plot_rotating_vs_static",
    "plot_speed_effect",
    "plot_validation",
]
