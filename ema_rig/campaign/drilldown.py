"""Per-measurement figures of a campaign report: what a test engineer checks a result against.

For every measurement the report shows the stabilization chart over the sum of FRFs, the measured
radial FRFs against the 3DOF model (the paper's Fig. 7) and the measured against the synthesised
FRFs. A measurement computed in this run is drawn by the runner's worker right after its
computation, from that computation's objects (they do not cross the process boundary: the
figures, PNG bytes, do). A row reused from a previous run (or a failed row) is drawn here again
from the measurement file with exactly the settings of the row's task (the rig, k_MS and its std,
speed, band, order): the pipeline is deterministic, so the selection drawn is the row's. The
housing frequency found again is compared with the row's; a difference is reported in the figure
set's ``warnings`` instead of being drawn silently.

The figures are expensive (drawing; an identification each when drawn here), so :func:`figure_key` names what they depend
on - the row's cache key (file content, task, ema_rig version) and this module's drawing settings -
and :mod:`ema_rig.campaign.outputs` draws them again only when that key changes.
"""

from __future__ import annotations

import hashlib
import json
import logging
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from .._text import plain
from .._version import version
from ..errors import EmaRigError

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from .schema import CampaignConfig, Measurement

logger = logging.getLogger(__name__)

#: The per-measurement figures, in report order: kind -> caption.
KINDS: dict[str, str] = {
    "stabilization": "Stabilization chart over the sum of FRF magnitudes; dashed: the automatically selected modes.",
    "model": "Measured radial FRFs (black) against the 3DOF rig model at the identified k_TB+MS (grey), "
             "magnitude and phase, every candidate mode below with its verdict (paper Fig. 7).",
    "synthesis": "Measured FRFs against the FRFs synthesised from the identified modal model (LSFD), one "
                 "sensor of each kind (housing/spindle, radial/lateral/axial); shaded: the identification band.",
}
#: Bump when the drawing changes (size, resolution, content): every per-measurement figure is redrawn.
_DRAW_VERSION = 10  # 10: texts at whole pixels (ema_rig.plot._render._text_cached)
#: Pixel density and size of the embedded figures: at least 1000 px wide (readable on screen; issue 20).
DPI = 80
_SIZE = (12.8, 5.6)
#: Relative difference between the re-identified and the row's housing frequency that is reported.
_FREQ_TOL = 1e-6


@dataclass(frozen=True, slots=True)
class MeasurementFigures:
    """The figures of one measurement, as PNG bytes.

    Attributes
    ----------
    png : dict of str to bytes
        Figure kind (:data:`KINDS`) -> PNG image; kinds that could not be drawn are absent.
    warnings : tuple of str
        One line per figure that could not be drawn or that may not show the row's result, and
        the identification's own warnings (non-converged mode set ...) not already in the row.
    candidates : tuple of dict
        The identification's stable-pole clusters with their verdict: ``natural_freq`` and
        ``natural_freq_std`` [Hz], ``damping_ratio``, ``verdict`` ("physical" or "rejected"), ``reason``.
    """

    png: dict[str, bytes] = field(default_factory=dict, repr=False)
    warnings: tuple[str, ...] = ()
    candidates: tuple[dict[str, Any], ...] = ()


def figure_key(row: Mapping[str, Any]) -> str | None:
    """What the figures of a row depend on, as a hash; None when the row cannot be reproduced.

    A row without a cache key (an input or infrastructure failure) has no figures.
    """
    key = row.get("cache_key")
    if not isinstance(key, str) or not key:
        return None
    payload = {"row": key, "draw": _DRAW_VERSION, "dpi": DPI, "size": list(_SIZE), "version": version()}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def png_bytes(fig: Figure, dpi: int = DPI) -> bytes:
    """A figure as a compact PNG (a palette of 256 of its own colours).

    Drawn once by Agg and quantized from the pixel buffer, the minor ticks of log axes as one
    artist each (:func:`ema_rig.plot._render.render_png`): the picture ``savefig`` gives, faster.
    The palette holds the figure's 128 most frequent colours and 128 farthest from those
    (:func:`ema_rig.plot._render.palette_indices`).
    zlib level 3 (:data:`ema_rig.plot._render.PNG_LEVEL`): half the encoding time of zlib's default
    level 6 for 15 % more bytes; the exhaustive one (``optimize``) saves 8-10 % of level 6's bytes
    for 8x its encoding time.
    """
    from ..plot._render import render_png

    return render_png(fig, dpi=dpi, colors=256, optimize=False)


def measurement_figures(
    m: Measurement,
    row: Mapping[str, Any],
    cfg: CampaignConfig,
    *,
    k_ms: float,
    k_ms_std: float | None,
    computed: tuple[Any, Any] | None = None,
) -> MeasurementFigures:
    """Draw the figures of one measurement from its file, with the settings of its row.

    Parameters
    ----------
    m : Measurement
    row : mapping
        The campaign row (``status``, ``housing_freq`` ...).
    cfg : CampaignConfig
        Gives the rig, band and order.
    k_ms, k_ms_std : float
        Mounting stiffness [N/m] used by the campaign and its standard uncertainty.
    computed : (FRFData, StiffnessResult), optional
        The measured FRFs and the result of the row's own computation, in this process (the
        runner's worker draws right after computing): drawn from them instead of reading and
        identifying again. Used for an ``ok`` row only.

    Returns
    -------
    MeasurementFigures
        For a failed row only the stabilization chart (when the identification itself worked).
    """
    from ..identification import identify
    from ..io.uff import read_uff58
    from ..plot._render import gc_paused, kept_figure
    from ..plot.rig import plot_rig_fit
    from ..plot.stabilization import plot_stabilization
    from ..plot.synthesis import plot_synthesis
    from ..rig.stiffness import default_band, estimate_stiffness

    png: dict[str, bytes] = {}
    warns: list[str] = []
    speed_hz = m.speed / 60.0 if m.speed > 0 else None
    try:
        result = None
        if computed is not None and row.get("status") == "ok":
            data, result = computed[0].with_meta(file=m.file.name), computed[1]
            ident = result.identification
        elif row.get("status") == "ok":
            data = read_uff58(m.file, rig=cfg.rig).with_meta(file=m.file.name)
            result = estimate_stiffness(data, cfg.rig, k_ms=k_ms, k_ms_std=k_ms_std, speed_hz=speed_hz,
                                        band=cfg.band, max_order=cfg.max_order, selection=m.selection)
            ident = result.identification
            assert ident is not None  # estimate_stiffness returns the identification it used
            f_row = row.get("housing_freq")
            f_now = float(result.housing_mode["natural_freq"])
            if isinstance(f_row, float) and math.isfinite(f_row) and abs(f_now - f_row) > _FREQ_TOL * f_row:
                warns.append(f"the figures show a housing mode at {f_now:.2f} Hz, the table {f_row:.2f} Hz "
                             "(the data changed since the row was computed?)")
        else:
            data = read_uff58(m.file, rig=cfg.rig).with_meta(file=m.file.name)
            band = default_band(data, cfg.rig, cfg.band)
            mo = cfg.max_order if cfg.max_order is not None else cfg.rig.identification.get("max_order")
            ident = identify(data, band=band, max_order=mo)
    except EmaRigError as exc:  # a failed row already says why; a good one that fails now is news
        return MeasurementFigures({}, () if row.get("status") != "ok" else (f"no figures: {exc}",))
    known = {str(w) for w in (row.get("warnings") or ())}
    warns += [f"identification: {w}" for w in getattr(ident, "warnings", ())
              if str(w) not in known and f"identification: {w}" not in known]
    cands = tuple({"natural_freq": float(c.natural_freq), "natural_freq_std": float(c.mode.natural_freq_std),
                   "damping_ratio": float(c.damping_ratio),
                   "verdict": "physical" if c.accepted else "rejected", "reason": str(c.reason)}
                  for c in getattr(ident, "candidates", ()))
    lo, hi = ident.band
    width = hi - lo
    view = data.band(max(float(data.freq[0]), lo - 0.05 * width), min(float(data.freq[-1]), hi + 0.05 * width))
    # one figure per kind per worker thread, its axes and ticks kept from one measurement to the
    # next (kept_figure): each figure is turned into PNG bytes before the next of its kind is drawn
    drawers: dict[str, Any] = {
        "stabilization": lambda: plot_stabilization(
            ident.stabilization, view, selection=ident.selection, mode_freq=ident.natural_freq, markersize=3.5,
            title=f"{plain(m.id)}: PolyMAX {lo:.0f}–{hi:.0f} Hz", figure=kept_figure("stabilization", _SIZE)).figure,
    }
    if result is not None:
        channels = _synthesis_channels(data, ident.modes)
        n_rows = math.ceil(len(channels) / 2) if len(channels) > 1 else 1
        drawers["model"] = lambda: plot_rig_fit(
            data, result, cfg.rig, figure=kept_figure("model", (_SIZE[0], 10.4)), phase=True, dpi=DPI,
            title=f"{plain(m.id)}: measured FRFs (black) and 3DOF model (grey)").figure
        drawers["synthesis"] = lambda: plot_synthesis(
            data, ident.modes, channels=channels, phase=True,
            figure=kept_figure("synthesis", (_SIZE[0], 1.0 + 3.0 * n_rows)), dpi=DPI,
            title=f"{plain(m.id)}: measured vs synthesised FRFs, {lo:.0f}–{hi:.0f} Hz").figure
    # the collector held off while building the figures too, as while rendering them (gc_paused):
    # its passes would walk the worker's long-lived objects (caches, kept figures) again and again
    with gc_paused():
        for kind, draw in drawers.items():
            try:
                png[kind] = png_bytes(draw())
            except (ValueError, KeyError, EmaRigError) as exc:  # a figure that cannot be drawn: said, not hidden
                warns.append(f"{kind} figure not drawn: {exc}")
    return MeasurementFigures(png, tuple(warns), cands)


def _synthesis_channels(data: Any, modes: Any, n: int = 4) -> list[tuple[int, int]]:
    """Up to ``n`` outputs against the first reference: the first of each (role, axis) sensor group."""
    kind = {d: (data.roles[i] if data.roles else "", data.axes[i] if data.axes else "")
            for i, d in enumerate(data.out_dofs)}
    seen: set[Any] = set()
    out: list[tuple[int, int]] = []
    for i, d in enumerate(modes.out_dofs):
        k = kind.get(d, ("", str(d)))
        if k not in seen:
            seen.add(k)
            out.append((i, 0))
    return out[:n]


__all__ = ["DPI", "KINDS", "MeasurementFigures", "figure_key", "measurement_figures", "png_bytes"]
