"""A single self-contained HTML report of a campaign (figures embedded, table, settings, version).

Functions
---------
render_report
    The report as an HTML string.
write_report
    Write it atomically.
write_report_if_changed
    Write it only when its content (all but the time stamp) changed.

Each measurement's row in the results table links to its own section: the stabilization chart, the
measured FRFs against the 3DOF model, the measured against the synthesised FRFs, every candidate
mode with its verdict, and the warnings. Figures are embedded (base64 PNG), so the report is one
file with no external reference.
"""

from __future__ import annotations

import base64
import hashlib
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
from ._text import inert, std_text
from ._version import version
from .campaign.drilldown import KINDS

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
pre{background:#f7f7f7;padding:1em;overflow-x:auto;font-size:.8em}.wide{overflow-x:auto}.kpi{display:inline-block;margin:.3em 1.5em .3em 0}
.kpi b{font-size:1.3em}
section.meas{border-top:2px solid #ddd;margin-top:2em}section.meas h3{margin-bottom:.2em}
ul.warn li{color:#8a4b00}.cand td.reason{text-align:left;font-size:.95em;max-width:40em}
tr.chosen td{background:#eef8ee}a.top{font-size:.8em;float:right}
"""

_CAPTIONS = {
    "validation": "Estimated stiffness of the reference bearing against its FE bounds (cf. paper Fig. 9).",
    "k_vs_load": "Bearing stiffness versus radial load, with the Hertzian estimate and a F^(1/3) fit.",
    "rotating_vs_static": "Rotating against non-rotating stiffness (paper Sect. 6 reports -8.8 %).",
    "speed": "Effect of the shaft speed on the stiffness (paper Table 3). Error bars: the identification "
             "(measured) uncertainty of each estimate only; the rig-model tolerances shift every speed "
             "alike and are left out so that a speed effect stays visible.",
    "repeatability": "Deviation of repeated measurements from their condition mean.",
    "damping": "Bearing damping c_TB (viscous dashpot in parallel with k_TB) from the housing mode's identified "
               "damping through the 3DOF model, against radial load and speed: measured where the housing "
               "mode's spindle/housing phase gives the bearing's share of the damping (filled markers, ±1σ "
               "with the share's), else all of the mode's damping read as the bearing's, an upper bound "
               "(open markers, the bound's own ±1σ).",
}


def _c_tb_mark(r: Mapping[str, Any]) -> str:
    """``'≤ '`` before an upper-bound ``c_TB`` in the results table (:func:`ema_rig.rig.damping.c_tb_kind`)."""
    from .rig.damping import c_tb_kind

    c = r.get("c_TB")
    return "≤ " if isinstance(c, float | int) and math.isfinite(c) and c_tb_kind(r) == "upper bound" else ""


def _c_tb(r: Mapping[str, Any]) -> str:
    """The row's ``c_TB`` as :func:`ema_rig.rig.damping.c_tb_text` says it (its kind from the detail)."""
    from .rig.damping import c_tb_kind, c_tb_text

    c, sd = r.get("c_TB", math.nan), r.get("c_TB_std", math.nan)
    if not (isinstance(c, float | int) and math.isfinite(c)):
        return "c_TB not available"
    detail = r.get("detail") or {}
    up, up_sd = detail.get("c_TB_upper"), detail.get("c_TB_upper_std")
    return c_tb_text(float(c), float(sd) if isinstance(sd, float | int) else math.nan, c_tb_kind(r),
                     upper=float(up) if isinstance(up, float | int) else None,
                     upper_std=float(up_sd) if isinstance(up_sd, float | int) else None, pm="±", unit="N·s/m")


def _h(text: Any) -> str:
    """Text from files for the HTML: control and bidirectional characters shown escaped, then HTML-escaped."""
    return html.escape(inert(text))


def _fmt(v: Any, unit: str = "") -> str:
    if v is None or (isinstance(v, float) and not math.isfinite(v)):
        return '<span class="muted">–</span>'
    if isinstance(v, float):
        if unit == "N/m":
            return f"{v / 1e6:.3f}"
        if unit:
            return format(v, unit)
        return f"{v:.4g}"
    return _h(str(v))


def _fmt_std(v: Any, unit: str = "") -> str:
    """An uncertainty cell: two significant digits (:func:`~ema_rig._text.std_text`), never a rounded 0.

    ``unit`` ``"N/m"`` prints it in MN/m, as :func:`_fmt` prints the value beside it.
    """
    if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
        return _fmt(None)
    return std_text(v / 1e6 if unit == "N/m" else float(v))


def _caption(name: str) -> str:
    for k, v in _CAPTIONS.items():
        if name.startswith(k):
            return v
    return name


#: By measurement id: its figures (kind -> PNG path), the warnings of drawing them, and the
#: identification's candidates with their verdicts (dicts: natural_freq, damping_ratio, verdict, reason).
MeasurementFigurePaths = Mapping[str, tuple[Mapping[str, "str | PathLike[str]"], list[str], list[Any]]]


def anchor(index: int) -> str:
    """HTML id of the section of the ``index``-th measurement (0-based; ids may hold any character)."""
    return f"meas-{index + 1}"


def _img(path: str | PathLike[str], alt: str) -> str:
    data = base64.b64encode(Path(path).read_bytes()).decode("ascii")
    return f"<img alt='{_h(alt)}' src='data:image/png;base64,{data}'>"


def render_report(result: CampaignResult, figures: Mapping[str, str | PathLike[str]], *,
                  measurements: MeasurementFigurePaths | None = None, generated: str | None = None) -> str:
    """Render the campaign report.

    Parameters
    ----------
    result : CampaignResult
    figures : mapping of str to path
        Campaign PNG files to embed (base64), by name.
    measurements : mapping, optional
        Per measurement id: (figure kind -> PNG path, warnings of drawing them); every
        measurement gets a section either way (conditions, result, candidates, warnings).
    generated : str, optional
        Time stamp shown in the header (default: now, UTC).

    Returns
    -------
    str
        A complete HTML document with no external references.
    """
    cfg = result.config
    rows = result.rows
    n_ok = sum(r["status"] == "ok" for r in rows)
    parts = [
        "<!doctype html><html lang='en'><head><meta charset='utf-8'>",
        f"<title>{_h(cfg.title)} — ema_rig report</title><style>{_CSS}</style></head><body>",
        f"<h1>{_h(cfg.title)}</h1>",
        f"<p class='muted'>ema_rig {_h(version())} · Python {platform.python_version()} · "
        f"{_h(generated if generated is not None else datetime.now(UTC).strftime('%Y-%m-%d %H:%M UTC'))}"
        " · campaign file "
        f"<code>{_h(str(cfg.path))}</code></p>",
        "<h2>Summary</h2><p>",
        f"<span class='kpi'><b>{n_ok}</b> / {len(rows)} measurements analysed</span>",
        f"<span class='kpi'><b>{len(rows) - n_ok}</b> failed</span>",
        f"<span class='kpi'>k_MS used: <b>{result.k_MS / 1e6:.2f}</b> MN/m"
        + (f" ± {std_text(result.k_MS_std / 1e6)}" if result.k_MS_std else "")
        + (" (steel-disk calibration)" if result.calibration and result.calibration.get("status") == "ok"
           else " (rig file)")
        + "</span></p>",
    ]
    if result.calibration is not None and result.calibration.get("status") != "ok":
        parts.append(f"<p><b>Calibration failed:</b> {_h(str(result.calibration.get('error')))} — "
                     "k_MS taken from the rig file.</p>")
    parts.append("<h2>Figures</h2>")
    for name, path in figures.items():
        parts.append(f"<figure>{_img(path, name)}<figcaption>{_h(_caption(name))}</figcaption></figure>")
    parts.append("<h2 id='results'>Results</h2><p class='muted'>Stiffness in MN/m (= N/µm); ± is one standard "
                 "uncertainty (measured: from the identified housing frequency, and the housing mass where the measured one was used; total: with the rig-file tolerances "
                 "and model-form terms); frequencies are undamped natural frequencies |λ|/2π; c_TB marked ≤ is an "
                 "upper bound (all of the housing mode's damping read as the bearing's), its ± the bound's own. "
                 "Each id links to the measurement's own section (figures, candidate modes, warnings).</p>")
    head = ["id", "bearing", "load [N]", "speed [rpm]", "shaft pos. [°]", "repeat", "k_TB [MN/m]",
            "± measured [MN/m]", "± total [MN/m]", "k_TB+MS [MN/m]", "f_H [Hz]", "± f_H [Hz]", "ζ_H [%]",
            "f_spindle [Hz]", "c_TB [N·s/m]", "± c_TB [N·s/m]", "f_H from", "warnings", "status"]
    parts.append("<div class='wide'><table><tr>" + "".join(
        f"<th class='{'l' if i in (0, 1, 16, 18) else ''}'>{_h(h)}</th>" for i, h in enumerate(head))
        + "</tr>")
    for i, r in enumerate(rows):
        cls = "" if r["status"] == "ok" else " class='err'"
        status = "ok" if r["status"] == "ok" else f"error: {r['error']}"
        damp = r["housing_damping"] * 100 if isinstance(r["housing_damping"], float) else r["housing_damping"]
        cells = [
            ("l", f"<a href='#{anchor(i)}'>{_fmt(r['id'])}</a>"), ("l", _fmt(r["bearing"])), ("", _fmt(r["radial_load"])), ("", _fmt(r["speed"])),
            ("", _fmt(r["shaft_position"])), ("", _fmt(r["repeat"])), ("", _fmt(r["k_TB"], "N/m")),
            ("", _fmt_std(r.get("k_TB_std_measured", math.nan), "N/m")),
            ("", _fmt_std(r["k_TB_std"], "N/m")), ("", _fmt(r["k_TB_MS"], "N/m")), ("", _fmt(r["housing_freq"], ".1f")),
            ("", _fmt_std(r["housing_freq_std"])), ("", _fmt(damp, ".2f")), ("", _fmt(r["spindle_freq"], ".1f")),
            ("", _c_tb_mark(r) + _fmt(r.get("c_TB", math.nan), ".0f")), ("", _fmt_std(r.get("c_TB_std", math.nan))),
            ("l", _h(_source(r))),
            ("", str(len(_unique(r.get("warnings") or ())))),
            ("l", _h(status)),
        ]
        parts.append(f"<tr{cls}>" + "".join(f"<td class='{c}'>{v}</td>" for c, v in cells) + "</tr>")
    parts.append("</table></div>")  # 19 columns: the table scrolls in its box, not the page
    parts.append("<h2>Measurements</h2>")
    for i, r in enumerate(rows):
        parts.append(_measurement_section(i, r, (measurements or {}).get(str(r["id"]))))
    settings = {**cfg.settings(), "k_MS_used": result.k_MS, "k_MS_std_used": result.k_MS_std}
    parts.append("<h2>Settings</h2><pre>" + _h(json.dumps(settings, indent=2, default=str)) + "</pre>")
    parts.append("<p class='muted'>Method: PolyMAX (pLSCF) identification, LSFD mode shapes, housing mode matched "
                 "to the 3DOF rig model by shape and modal mass, inverted for k_TB+MS and k_TB through the series "
                 "relation 1/k_TB+MS = 1/k_TB + 1/k_MS (Jacobs et al., Sect. 4).</p></body></html>")
    return "\n".join(parts)


def _comparison(detail: Any) -> str:
    """The 3DOF inversion of the identified frequency beside the result and what the evidence resolved."""
    if not isinstance(detail, Mapping):
        return ""
    inv = detail.get("inversion_3dof")
    notes = [str(n) for n in (detail.get("notes") or [])]
    out = []
    if isinstance(inv, Mapping) and inv.get("k_TB") is not None:
        out.append(f"<p class='muted'>Plain 3DOF inversion of the identified frequency (rig-file m_H, no "
                   f"coupling correction): k_TB {_fmt(float(inv['k_TB']), 'N/m')} MN/m at "
                   f"{_fmt(float(inv['freq']), '.2f')} Hz; reported (housing model with the measured evidence): "
                   f"{_fmt(float(detail.get('k_TB', math.nan)), 'N/m')} MN/m.</p>")
    hmass = detail.get("housing_mass")
    if isinstance(hmass, Mapping) and hmass.get("m_H_measured") is not None:
        out.append(f"<p class='muted'>Housing mass from the driving-point modal mass: "
                   f"{_fmt(float(hmass['m_H_measured']), '.4g')} ± {_fmt(float(hmass['m_H_measured_std']), '.2g')} kg "
                   f"(rig file {_fmt(float(hmass['m_H_rig_file']), '.4g')} kg"
                   + (f"; combined with the mode's spindle/housing ratio, which alone gives "
                      f"{_fmt(float(hmass['m_H_from_shape']), '.4g')} ± "
                      f"{_fmt(float(hmass['m_H_from_shape_std']), '.2g')} kg"
                      if hmass.get("m_H_from_shape") is not None and hmass.get("m_H_from_shape_std") is not None
                      else "")
                   + f"); used: {html.escape(str(hmass.get('source')))}.</p>")
    rb = detail.get("housing_rigid_body")
    if isinstance(rb, Mapping):
        out.append(_rigid_body_line(rb))
    if notes:
        out.append("<p>Notes:</p><ul>" + "".join(f"<li>{html.escape(n)}</li>" for n in notes) + "</ul>")
    return "\n".join(out)


def _rigid_body_line(rb: Mapping[str, Any]) -> str:
    """The housing's axial and tilt stiffness on its bearing (with ±1 sigma), and what is unidentifiable."""
    parts = []
    if rb.get("axial_stiffness") is not None:
        parts.append(f"axial {_fmt(float(rb['axial_stiffness']), 'N/m')} ± "
                     f"{_fmt_std(float(rb.get('axial_stiffness_std') or math.nan), 'N/m')} MN/m")
    tilt = rb.get("tilt_stiffness")
    if isinstance(tilt, Mapping):
        for ax in ("x", "z"):
            t = tilt.get(ax)
            if isinstance(t, Mapping):
                parts.append(f"tilt about {ax} {_fmt(float(t['stiffness']) / 1e3, '.4g')} ± "
                             f"{_fmt(float(t['stiffness_std']) / 1e3, '.2g')} kN·m/rad "
                             f"({_fmt(float(t['freq']), '.1f')} Hz)")
    why = [str(w) for w in (rb.get("unidentifiable") or [])]
    text = "Housing on its bearing: " + ("; ".join(parts) if parts else "no rigid-body stiffness identified")
    if why:
        text += " · not identified: " + "; ".join(html.escape(w) for w in why)
    return f"<p class='muted'>{text}.</p>"


def _measurement_section(i: int, r: Mapping[str, Any],
                         figs: tuple[Mapping[str, str | PathLike[str]], list[str], list[Any]] | None) -> str:
    """The section of one measurement: conditions, result, warnings, figures, candidate modes."""
    ok = r["status"] == "ok"
    head = (f"<section class='meas' id='{anchor(i)}'><a class='top' href='#results'>back to the table</a>"
            f"<h3>{_h(str(r['id']))}</h3><p class='muted'>{_h(str(r.get('file', '')))} · "
            f"bearing {_fmt(r['bearing'])} · {_fmt(r['radial_load'])} N · {_fmt(r['speed'])} rpm</p>")
    parts = [head]
    if ok:
        parts.append(f"<p>k_TB = <b>{_fmt(r['k_TB'], 'N/m')} ± {_fmt_std(r['k_TB_std'], 'N/m')}</b> MN/m (total; "
                     f"± {_fmt_std(r.get('k_TB_std_measured', math.nan), 'N/m')} measured) · "
                     f"housing mode {_fmt(r['housing_freq'], '.2f')} ± {_fmt_std(r['housing_freq_std'])} Hz (measured)"
                     f" · from {_h(_SOURCE_TEXT.get(_source(r), _source(r)))} · "
                     f"bearing damping {_h(_c_tb(r))}, loss factor "
                     f"{_fmt(r.get('loss_factor', math.nan), '.4f')} ± {_fmt_std(r.get('loss_factor_std', math.nan))}"
                     "</p>")
        parts.append(_comparison(r.get("detail")))
    else:
        parts.append(f"<p><b>error:</b> {_h(str(r.get('error')))}</p>")
    warns = _unique([*(r.get("warnings") or []), *(figs[1] if figs else [])])
    if warns:
        parts.append("<p>Warnings:</p><ul class='warn'>" + "".join(f"<li>{_h(w)}</li>" for w in warns)
                     + "</ul>")
    else:
        parts.append("<p class='muted'>No warnings.</p>")
    for kind, path in (figs[0].items() if figs else ()):
        alt = f"{r['id']} {kind}"
        parts.append(f"<figure>{_img(path, alt)}"
                     f"<figcaption>{_h(KINDS.get(kind, kind))}</figcaption></figure>")
    if figs is None or not figs[0]:
        parts.append("<p class='muted'>No figures for this measurement (its file could not be read or "
                     "identified again).</p>")
    detail = r.get("detail")
    cands = detail.get("candidates") if isinstance(detail, Mapping) else None
    if isinstance(cands, list) and cands:
        # the stiffness result's candidates carry the identification's measured std (the table's ± f_H)
        parts.append(_candidate_table(cands, "Modes matched to the 3DOF model (the housing mode is the one kept):",
                                      spread=False))
    if figs and figs[2]:
        # the drill-down's clusters carry the spread of their poles over the model orders: no uncertainty
        parts.append(_candidate_table(figs[2], "Identification: every cluster of stable poles and its verdict:",
                                      spread=True))
    parts.append("</section>")
    return "\n".join(parts)


_SOURCE_TEXT = {"auto": "the automatic identification", "pick": "a pick (hand-picked poles)",
                "replay": "a replayed selection", "tracked replay": "a tracked replay (matched by frequency order: "
                "check it on the chart)"}


def _source(r: Mapping[str, Any]) -> str:
    """Where the row's housing mode came from: auto, pick, replay or tracked replay ('' for an error)."""
    v = r.get("mode_source")
    return v if isinstance(v, str) and r.get("status") == "ok" else ""


def _unique(warnings: Any) -> list[str]:
    """The warnings in order, each once (a caveat the row and the figures both carry is said once)."""
    return list(dict.fromkeys(str(w) for w in warnings))


def _candidate_table(cands: list[Any], title: str, *, spread: bool) -> str:
    """Candidate modes with their verdict and the reason.

    ``spread``: their ``natural_freq_std`` is the spread of a cluster's poles over the model orders
    (the drill-down's clusters), else the measured standard uncertainty (the matched candidates,
    the same number as the table's ± f_H); the column is headed by what it holds.
    """
    verdict_key = "verdict" if any(isinstance(c, Mapping) and "verdict" in c for c in cands) else "status"
    std_head = "order spread f [Hz]" if spread else "± f measured [Hz]"
    rows = [f"<table class='cand'><tr><th>f [Hz]</th><th>{std_head}</th><th>ζ [%]</th><th class='l'>verdict</th>"
            "<th class='l'>reason</th></tr>"]
    for c in cands:
        if not isinstance(c, Mapping):
            continue
        z = c.get("damping_ratio")
        verdict = str(c.get(verdict_key, ""))
        cls = " class='chosen'" if verdict in ("housing", "chosen", "selected") else ""
        f_std = c.get("natural_freq_std")
        rows.append(f"<tr{cls}><td>{_fmt(c.get('natural_freq'), '.2f')}</td>"
                    f"<td>{_fmt(f_std, '.3f') if spread else _fmt_std(f_std)}"
                    f"</td><td>{_fmt(z * 100 if isinstance(z, float) else z, '.2f')}</td>"
                    f"<td class='l'>{_h(verdict)}</td>"
                    f"<td class='reason'>{_h(str(c.get('reason', '')))}</td></tr>")
    rows.append("</table>")
    return f"<p>{_h(title)}</p>" + "".join(rows)


def write_report(result: CampaignResult, path: str | PathLike[str],
                 figures: Mapping[str, str | PathLike[str]], *,
                 measurements: MeasurementFigurePaths | None = None) -> Path:
    """Write :func:`render_report` atomically to ``path`` and return it."""
    p = Path(path)
    _atomic.write_text(p, render_report(result, figures, measurements=measurements))
    return p


def write_report_if_changed(result: CampaignResult, path: str | PathLike[str],
                            figures: Mapping[str, str | PathLike[str]], *,
                            measurements: MeasurementFigurePaths | None = None,
                            previous_hash: str | None = None) -> str:
    """Write the report unless its content, all but the time stamp, hashes to ``previous_hash``.

    Returns
    -------
    str
        The content hash (SHA-256 of the report rendered without a time stamp), to pass as
        ``previous_hash`` next time.
    """
    p = Path(path)
    digest = hashlib.sha256(render_report(result, figures, measurements=measurements,
                                          generated="").encode("utf-8")).hexdigest()
    if digest != previous_hash or not p.is_file():
        _atomic.write_text(p, render_report(result, figures, measurements=measurements))
    return digest


__all__ = ["anchor", "render_report", "write_report", "write_report_if_changed"]
