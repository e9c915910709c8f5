"""A single self-contained HTML report of a campaign (figures embedded, table, settings, version).

Functions
---------
render_report
    The report as an HTML string.
write_report
    Write it atomically.
"""

from __future__ import annotations

import base64
import html
import json
import math
import platform
from collections.abc import Mapping
from datetime import UTC, datetime
from os import PathLike
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import _atomic

if TYPE_CHECKING:
    from .campaign.result import CampaignResult

_CSS = """
body{font-family:system-ui,-apple-system,Segoe UI,Roboto,sans-serif;margin:2em auto;max-width:1100px;
color:#222;line-height:1.4}
h1{font-size:1.6em;margin-bottom:0}h2{border-bottom:1px solid #ccc;padding-bottom:.2em;margin-top:1.6em}
table{border-collapse:collapse;font-size:.85em;width:100%}th,td{padding:.25em .5em;border-bottom:1px solid #e4e4e4;
text-align:right}th{background:#f4f4f4;position:sticky;top:0}td.l,th.l{text-align:left}
tr.err td{background:#fff0f0}.muted{color:#777}figure{margin:1em 0;text-align:center}
figure img{max-width:100%;border:1px solid #eee}figcaption{font-size:.9em;color:#555}
pre{background:#f7f7f7;padding:1em;overflow-x:auto;font-size:.8em}.kpi{display:inline-block;margin:.3em 1.5em .3em 0}
.kpi b{font-size:1.3em}
"""

_CAPTIONS = {
    "validation": "Estimated stiffness of the reference bearing against its FE bounds (cf. paper Fig. 9).",
    "k_vs_load": "Bearing stiffness versus radial load, with the Hertzian estimate and a F^(1/3) fit.",
    "rotating_vs_static": "Rotating against non-rotating stiffness (paper Sect. 6 reports -8.8 %).",
    "speed": "Effect of the shaft speed on the stiffness (paper Table 3).",
    "repeatability": "Deviation of repeated measurements from their condition mean.",
}


def _fmt(v: Any, unit: str = "") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return '<span class="muted">–</span>'
    if isinstance(v, float):
        if unit == "N/m":
            return f"{v / 1e6:.3f}"
        if unit:
            return format(v, unit)
        return f"{v:.4g}"
    return html.escape(str(v))


def _caption(name: str) -> str:
    for k, v in _CAPTIONS.items():
        if name.startswith(k):
            return v
    return name


def render_report(result: CampaignResult, figures: Mapping[str, str | PathLike[str]]) -> str:
    """Render the campaign report.

    Parameters
    ----------
    result : CampaignResult
    figures : mapping of str to path
        PNG files to embed (base64), by name.

    Returns
    -------
    str
        A complete HTML document with no external references.
    """
    from . import __version__

    cfg = result.config
    rows = result.rows
    n_ok = sum(r["status"] == "ok" for r in rows)
    parts = [
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{html.escape(cfg.title)} — ema_rig report</title><style>{_CSS}</style></head><body>",
        f"<h1>{html.escape(cfg.title)}</h1>",
        f"<p class='muted'>ema_rig {html.escape(__version__)} · Python {platform.python_version()} · "
        f"{datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC')} · campaign file "
        f"<code>{html.escape(str(cfg.path))}</code></p>",
        "<h2>Summary</h2><p>",
        f"<span class='kpi'><b>{n_ok}</b> / {len(rows)} measurements analysed</span>",
        f"<span class='kpi'><b>{len(rows) - n_ok}</b> failed</span>",
        f"<span class='kpi'>k_MS used: <b>{result.k_MS / 1e6:.2f}</b> MN/m"
        + (f" ± {result.k_MS_std / 1e6:.2f}" if result.k_MS_std else "")
        + (" (steel-disk calibration)" if result.calibration and result.calibration.get("status") == "ok"
           else " (rig file)")
        + "</span></p>",
    ]
    if result.calibration is not None and result.calibration.get("status") != "ok":
        parts.append(f"<p><b>Calibration failed:</b> {html.escape(str(result.calibration.get('error')))} — "
                     "k_MS taken from the rig file.</p>")
    parts.append("<h2>Figures</h2>")
    for name, path in figures.items():
        data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
        parts.append(f"<figure><img alt='{html.escape(name)}' src='data:image/png;base64,{data}'>"
                     f"<figcaption>{html.escape(_caption(name))}</figcaption></figure>")
    parts.append("<h2>Results</h2><p class='muted'>Stiffness in MN/m (= N/µm); ± is one standard "
                 "uncertainty; frequencies are undamped natural frequencies |λ|/2π.</p>")
    head = ["id", "bearing", "load [N]", "speed [rpm]", "shaft pos. [°]", "repeat", "k_TB", "± k_TB",
            "k_TB+MS", "f_H [Hz]", "± f_H", "ζ_H [%]", "f_spindle [Hz]", "status"]
    parts.append("<table><tr>" + "".join(
        f"<th class='{'l' if i in (0, 1, 13) else ''}'>{html.escape(h)}</th>" for i, h in enumerate(head)) + "</tr>")
    for r in rows:
        cls = "" if r["status"] == "ok" else " class='err'"
        status = "ok" if r["status"] == "ok" else f"error: {r['error']}"
        damp = r["housing_damping"] * 100 if isinstance(r["housing_damping"], float) else r["housing_damping"]
        cells = [
            ("l", _fmt(r["id"])), ("l", _fmt(r["bearing"])), ("", _fmt(r["radial_load"])), ("", _fmt(r["speed"])),
            ("", _fmt(r["shaft_position"])), ("", _fmt(r["repeat"])), ("", _fmt(r["k_TB"], "N/m")),
            ("", _fmt(r["k_TB_std"], "N/m")), ("", _fmt(r["k_TB_MS"], "N/m")), ("", _fmt(r["housing_freq"], ".1f")),
            ("", _fmt(r["housing_freq_std"], ".2f")), ("", _fmt(damp, ".2f")), ("", _fmt(r["spindle_freq"], ".1f")),
            ("l", html.escape(status)),
        ]
        parts.append(f"<tr{cls}>" + "".join(f"<td class='{c}'>{v}</td>" for c, v in cells) + "</tr>")
    parts.append("</table>")
    settings = {**cfg.settings(), "k_MS_used": result.k_MS, "k_MS_std_used": result.k_MS_std}
    parts.append("<h2>Settings</h2><pre>" + html.escape(json.dumps(settings, indent=2, default=str)) + "</pre>")
    parts.append("<p class='muted'>Method: PolyMAX (pLSCF) identification, LSFD mode shapes, housing mode matched "
                 "to the 3DOF rig model by shape and modal mass, inverted for k_TB+MS and k_TB through the series "
                 "relation 1/k_TB+MS = 1/k_TB + 1/k_MS (Jacobs et al., Sect. 4).</p></body></html>")
    return "\n".join(parts)


def write_report(result: CampaignResult, path: str | PathLike[str],
                 figures: Mapping[str, str | PathLike[str]]) -> Path:
    """Write :func:`render_report` atomically to ``path`` and return it."""
    p = Path(path)
    _atomic.write_text(p, render_report(result, figures))
    return p


__all__ = ["render_report", "write_report"]
