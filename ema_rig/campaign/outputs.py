"""The outputs of a campaign run: table (CSV), resolved settings (JSON), figures, HTML report.

Every file is written atomically, and only when what it shows changed: a cached re-run that
changed nothing rewrites nothing. The folder's manifest (``.ema-rig-figures.json``) records, for
every figure, a hash of its inputs (the rows and bearing information for the campaign figures, the
row's cache key for a measurement's figures) and the hash of the report's content; a figure whose
inputs hash is unchanged and whose file exists is reused, the others are drawn again. The manifest
is written again (atomically) as soon as a measurement's figures are written, so a run killed in
its figure phase keeps every figure it finished: the next run reuses them. Figures of a
previous run that this run does not produce (a bearing renamed, a measurement removed) are
removed, so the folder holds one campaign's outputs.

Layout::

    campaign.csv (units in the headers; [output] of the campaign file), settings.json, report.html
    <campaign figure>.png                  (validation_dummy.png, k_vs_load_6302.png ...)
    measurements/<id>.<kind>.png           (stabilization, model, synthesis; ids are safe names)
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Mapping, Sequence
from concurrent.futures import BrokenExecutor, Executor, Future, as_completed
from contextlib import ExitStack
from os import PathLike
from pathlib import Path
from typing import Any

from .. import _atomic
from .._version import version
from ..config import read_regular_file
from .drilldown import KINDS, MeasurementFigures, figure_key, measurement_figures
from .result import COLUMNS, CampaignResult

logger = logging.getLogger(__name__)

#: The figures written by the last run of a folder with the hash of their inputs.
MANIFEST = ".ema-rig-figures.json"
_MANIFEST_VERSION = 2
#: Folder of the per-measurement figures.
MEASUREMENT_DIR = "measurements"


def write_outputs(result: CampaignResult, out_dir: str | PathLike[str], *,
                  executor: Executor | None = None, drawn: Mapping[str, Any] | None = None) -> dict[str, Path]:
    """Write the table (CSV), the resolved settings (JSON), the figures and the HTML report.

    Parameters
    ----------
    result : CampaignResult
    out_dir : path
        The output folder (the caller holds its lock during :func:`~ema_rig.campaign.run`).
    executor : concurrent.futures.Executor, optional
        Draws the measurements' figures not in ``drawn`` (an identification each) in parallel
        while this process draws the campaign figures; the files are written here, in the same order.
        With none of those to draw, one of its workers draws every other campaign figure meanwhile.
    drawn : mapping, optional
        Measurement id -> (row cache key, :class:`~ema_rig.campaign.drilldown.MeasurementFigures`)
        drawn by the runner's worker with the computation (:func:`figures_to_draw`): written as
        they are when the row's key is still that one, instead of being drawn again.

    Returns
    -------
    dict
        Output kind (``"table"``, ``"settings"``, figure names, ``"report"``) -> path; a
        measurement's figures as ``"<id>/<kind>"``.

    Raises
    ------
    OSError
        When a file cannot be written (disk full, permission), naming that file.
    """
    from ..report import write_report_if_changed

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    files["table"] = out / "campaign.csv"
    write_if_changed(files["table"], result.to_csv())
    files["settings"] = out / "settings.json"
    settings = {**result.config.settings(), "k_MS_used": result.k_MS, "k_MS_std_used": result.k_MS_std,
                "calibration": _strip(result.calibration)}
    write_if_changed(files["settings"], json.dumps(_atomic._clean(settings), indent=2, allow_nan=False) + "\n")

    previous = _read_manifest(out)
    manifest: dict[str, Any] = {"version": _MANIFEST_VERSION, "figures": {}, "measurements": {}}
    # the measurements' figures that must be drawn again start first, in the executor
    drawn = drawn or {}
    ahead = {} if executor is None else _draw_ahead(result, out, previous, executor, drawn)
    # the pool shares the campaign figures when it has no measurement's figures to draw
    figures = _campaign_figures(result, out, previous, manifest, executor=None if ahead else executor)
    _record(out, previous, manifest)
    per_meas = _measurement_figures(result, out, previous, manifest, ahead, drawn)
    kept = set(manifest["figures"])
    for stale in set(previous.get("figures", {})) - kept:
        if _safe_rel(stale):
            (out / stale).unlink(missing_ok=True)
    files.update(figures)
    for mid, (paths, _, _) in per_meas.items():
        files.update({f"{mid}/{k}": p for k, p in paths.items()})
    files["report"] = out / "report.html"
    manifest["report"] = write_report_if_changed(result, files["report"], figures, measurements=per_meas,
                                                 previous_hash=previous.get("report"))
    write_if_changed(out / MANIFEST, json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return files


def _record(out: Path, previous: Mapping[str, Any], manifest: Mapping[str, Any]) -> None:
    """Write the manifest of a run still drawing: this run's figures so far over the previous ones.

    A run killed after this keeps the figures it recorded; those of the previous run stay listed
    (their hashes decide whether they are reused, and stale ones are still removed next time). No
    report hash: the report is written again. Nothing is written while this run has drawn nothing.
    """
    old = previous.get("figures", {})
    if all(old.get(n) == h for n, h in manifest["figures"].items()):
        return
    partial = {
        "version": _MANIFEST_VERSION,
        "figures": {**previous.get("figures", {}), **manifest["figures"]},
        "measurements": {**previous.get("measurements", {}), **manifest["measurements"]},
        "campaign_figures": manifest.get("campaign_figures", previous.get("campaign_figures")),
        "report": None,
    }
    _atomic.write_text(out / MANIFEST, json.dumps(partial, sort_keys=True, separators=(",", ":")) + "\n")


def write_if_changed(path: Path, text: str) -> bool:
    """Write ``text`` atomically unless ``path`` already holds exactly it; True when written."""
    data = text.encode("utf-8")
    try:
        if path.is_file() and path.stat().st_size == len(data) and path.read_bytes() == data:
            return False
    except OSError:
        pass
    _atomic.write_bytes(path, data)
    return True


def _hash(obj: Any) -> str:
    return hashlib.sha256(json.dumps(_atomic._clean(obj), sort_keys=True, default=str).encode()).hexdigest()


def _campaign_figures(result: CampaignResult, out: Path, previous: Mapping[str, Any],
                      manifest: dict[str, Any], executor: Executor | None = None) -> dict[str, Path]:
    """The campaign figures: drawn again only when the rows or the bearing information changed.

    With an ``executor`` (a pool with nothing else to draw), one of its workers draws every other
    figure meanwhile.
    """
    shown = [{c: r.get(c) for c in COLUMNS if c != "elapsed_s"} for r in result.rows]
    bearings = {k: repr(v) for k, v in result.config.bearings.items()}
    key = _hash({"rows": shown, "bearings": bearings, "version": version()})
    old = previous.get("figures", {})
    names = previous.get("campaign_figures")
    if (isinstance(names, list) and names and all(isinstance(n, str) and _safe_rel(n) for n in names)
            and all(old.get(n) == key and (out / n).is_file() for n in names)):
        manifest["campaign_figures"] = names
        manifest["figures"].update({n: key for n in names})
        return {Path(n).stem: out / n for n in names}
    from ..plot.campaign import campaign_figure_names

    names = campaign_figure_names(result)
    # an idle pool draws every other figure while this process draws the rest (the same figures,
    # drawn where a core is free: this process would otherwise draw them alone at the run's end)
    theirs = executor.submit(_campaign_pngs, result, names[1::2]) if executor is not None and len(names) > 1 else None
    pngs = _campaign_pngs(result, names if theirs is None else names[0::2])
    if theirs is not None:
        try:
            pngs.update(theirs.result())
        except BrokenExecutor as exc:  # its worker died: drawn here instead
            logger.warning("campaign figures drawn again in this process: %s", exc)
            pngs.update(_campaign_pngs(result, names[1::2]))
    figures: dict[str, Path] = {}
    for name in names:
        if name in pngs:
            path = out / f"{name}.png"
            _atomic.write_bytes(path, pngs[name])
            figures[name] = path
    manifest["campaign_figures"] = [p.name for p in figures.values()]
    manifest["figures"].update({p.name: key for p in figures.values()})
    return figures


def _campaign_pngs(result: CampaignResult, names: Sequence[str]) -> dict[str, bytes]:
    """The campaign figures of these names as PNG bytes (:func:`~ema_rig.plot.campaign.campaign_figures`).

    A picklable worker: a pool's process draws some of a campaign's figures while the caller
    draws the others. A name whose figure has nothing to show is left out.

    Parameters
    ----------
    result : CampaignResult
    names : sequence of str
        Names from :func:`~ema_rig.plot.campaign.campaign_figure_names`.

    Returns
    -------
    dict
        Name -> PNG bytes (RGB, 120 dpi).
    """
    from ..plot._render import render_png
    from ..plot.campaign import campaign_figures

    # pyplot-free Figures: nothing to close
    return {name: render_png(fig, dpi=120, colors=None, optimize=False)
            for name, fig in campaign_figures(result, names).items()}


def _plan(result: CampaignResult, out: Path, previous: Mapping[str, Any]) -> list[tuple[Any, Any, str, dict[str, str], bool]]:
    """Per measurement with a figure key: (measurement, row, key, relative paths, reusable)."""
    plan = []
    for m, row in zip(result.config.measurements, result.rows, strict=True):
        key = figure_key({"cache_key": row.get("cache_key") or _stored_key(out, m.id)})
        if key is None:
            continue
        rels, reuse = _reusable(out, previous, m.id, key)
        plan.append((m, row, key, rels, reuse))
    return plan


def _reusable(out: Path, previous: Mapping[str, Any], mid: str, key: str) -> tuple[dict[str, str], bool]:
    """A measurement's figure paths (relative) and whether the previous run's figures with this key are there."""
    old_figs = previous.get("figures", {})
    rels = {k: f"{MEASUREMENT_DIR}/{mid}.{k}.png" for k in KINDS}
    info = previous.get("measurements", {}).get(mid)
    reuse = bool(isinstance(info, dict) and info.get("key") == key and isinstance(info.get("kinds"), list)
                 and isinstance(info.get("warnings"), list) and isinstance(info.get("candidates"), list)
                 and all(k in rels and old_figs.get(rels[k]) == key and (out / rels[k]).is_file()
                         for k in info["kinds"]))
    return rels, reuse


def figures_to_draw(out: str | PathLike[str], rows: list[tuple[str, str]]) -> set[str]:
    """The measurements, of ``(id, row cache key)`` computed now, whose figures the folder cannot reuse.

    The runner has their workers draw them with the computation; the others (reused from the
    folder's previous run) are not drawn at all.

    Parameters
    ----------
    out : str or path-like
        The campaign's output folder.
    rows : list of (str, str)
        ``(measurement id, row cache key)`` of the measurements computed in this run.

    Returns
    -------
    set of str
        The ids whose figures must be drawn.
    """
    folder = Path(out)
    previous = _read_manifest(folder)
    need = set()
    for mid, cache_key in rows:
        key = figure_key({"cache_key": cache_key})
        if key is not None and not _reusable(folder, previous, mid, key)[1]:
            need.add(mid)
    return need


def _draw_ahead(result: CampaignResult, out: Path, previous: Mapping[str, Any],
                executor: Executor, drawn: Mapping[str, Any]) -> dict[str, Future[Any]]:
    """Submit the measurements' figures that cannot be reused nor were drawn with the computation to ``executor``."""
    if not result.config.measurement_figures:
        return {}
    return {m.id: executor.submit(measurement_figures, m, row, result.config, k_ms=result.k_MS,
                                  k_ms_std=result.k_MS_std)
            for m, row, key, _, reuse in _plan(result, out, previous)
            if not reuse and _given(drawn, m.id, key) is None}


def _measurement_figures(result: CampaignResult, out: Path, previous: Mapping[str, Any],
                         manifest: dict[str, Any], ahead: Mapping[str, Future[Any]] | None = None,
                         drawn: Mapping[str, Any] | None = None,
                         ) -> dict[str, tuple[dict[str, Path], list[str], list[Any]]]:
    """Each measurement's figures (``measurements/<id>.<kind>.png``), warnings and identification candidates."""
    folder = out / MEASUREMENT_DIR
    if folder.is_dir():
        _atomic.remove_temporaries(folder)
    old_meas = previous.get("measurements", {})
    done: dict[str, tuple[dict[str, Path], list[str], list[Any]]] = {}
    if not result.config.measurement_figures:
        return done
    ahead = ahead or {}
    plan = _plan(result, out, previous)
    drawn_now: dict[str, Any] = {}

    def keep(m: Any, key: str, rels: Mapping[str, str], kinds: list[str], warns: list[str],
             cands: list[Any]) -> None:
        manifest["measurements"][m.id] = {"key": key, "kinds": kinds, "warnings": warns, "candidates": cands}
        manifest["figures"].update({rels[k]: key for k in kinds})
        done[m.id] = ({k: out / rels[k] for k in kinds}, warns, cands)

    def write(m: Any, key: str, rels: Mapping[str, str], drawn: Any) -> None:
        folder.mkdir(exist_ok=True)
        paths = {k: out / rels[k] for k in drawn.png}
        if any(path.parent != folder for path in paths.values()):  # ids are validated in the schema
            raise OSError(f"{out / rels[next(iter(rels))]}: measurement id is not a plain file name")
        for k in rels:  # an older figure of this measurement must never pass for the new one
            (out / rels[k]).unlink(missing_ok=True)
        for w in drawn.warnings:
            logger.warning("%s: %s", m.id, w)
        with ExitStack() as renames:  # every figure complete beside its name, recorded, then renamed
            for k, path in paths.items():
                renames.enter_context(_atomic.atomic_path(path)).write_bytes(drawn.png[k])
            keep(m, key, rels, list(drawn.png), list(drawn.warnings), list(drawn.candidates))
            # recorded before the renames: a kill in between leaves these figures missing (drawn
            # again), a kill after them keeps every one; none finished is ever drawn twice
            _record(out, previous, manifest)

    by_id = {m.id: (m, key, rels) for m, _, key, rels, reuse in plan if not reuse}
    owner = {f: mid for mid, f in ahead.items() if mid in by_id}
    # figures drawn by the executor are written as they come in, whatever their order
    for fut in as_completed(owner):
        mid = owner[fut]
        m, key, rels = by_id[mid]
        try:
            drawn_now[mid] = fut.result()
        except Exception as exc:  # a worker died (killed, out of memory): said, drawn next time
            drawn_now[mid] = MeasurementFigures({}, (f"figures not drawn: worker failed ({type(exc).__name__}"
                                                     f"{': ' + str(exc) if str(exc) else ''}); drawn on the next run",))
            done[mid] = ({}, list(drawn_now[mid].warnings), [])
            logger.warning("%s: %s", mid, drawn_now[mid].warnings[0])
            continue
        write(m, key, rels, drawn_now[mid])
    for m, row, key, rels, reuse in plan:
        if reuse:
            info = old_meas[m.id]
            keep(m, key, rels, [k for k in KINDS if k in info["kinds"]], [str(w) for w in info["warnings"]],
                 [c for c in info["candidates"] if isinstance(c, dict)])
        elif m.id not in drawn_now:
            given = _given(drawn or {}, m.id, key)
            drawn_now[m.id] = given if given is not None else measurement_figures(
                m, row, result.config, k_ms=result.k_MS, k_ms_std=result.k_MS_std)
            write(m, key, rels, drawn_now[m.id])
    return {m.id: done[m.id] for m, *_ in plan if m.id in done}  # in the campaign's order


def _given(drawn: Mapping[str, Any], mid: str, key: str) -> Any:
    """The figures the runner's worker drew for ``mid`` when their row's figure key is ``key``, else None."""
    entry = drawn.get(mid)
    if entry is None or figure_key({"cache_key": entry[0]}) != key:
        return None
    return entry[1]


def _stored_key(out: Path, mid: str) -> str | None:
    """The cache key of the row the runner stored in ``results/<id>.json`` (None: none, not cacheable)."""
    try:
        doc = json.loads(read_regular_file(out / "results" / f"{mid}.json", max_bytes=64 << 20).decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    key = doc.get("cache_key") if isinstance(doc, dict) else None
    return key if isinstance(key, str) else None


def _safe_rel(name: str) -> bool:
    """A manifest entry that may be removed: ``x.png`` or ``measurements/x.png``, no other path."""
    parts = name.split("/")
    if len(parts) == 2 and parts[0] == MEASUREMENT_DIR:
        parts = parts[1:]
    n = parts[0]
    return (len(parts) == 1 and n.endswith(".png") and not n.startswith(".") and "\\" not in n
            and Path(n).name == n)


def _read_manifest(out: Path) -> dict[str, Any]:
    """The previous run's manifest (an older list of names counts as figures without hashes)."""
    try:
        doc = json.loads(read_regular_file(out / MANIFEST, max_bytes=1 << 24).decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return {}
    if isinstance(doc, list):
        return {"figures": {n: None for n in doc if isinstance(n, str) and _safe_rel(n)}}
    if not isinstance(doc, dict) or doc.get("version") != _MANIFEST_VERSION:
        return {}
    figs = doc.get("figures")
    meas = doc.get("measurements")
    return {
        "figures": {n: h for n, h in figs.items() if _safe_rel(n)} if isinstance(figs, dict) else {},
        "measurements": meas if isinstance(meas, dict) else {},
        "campaign_figures": doc.get("campaign_figures"),
        "report": doc.get("report") if isinstance(doc.get("report"), str) else None,
    }


def _strip(d: Mapping[str, Any] | None) -> dict[str, Any] | None:
    if d is None:
        return None
    return {k: v for k, v in d.items() if k not in ("candidates",)}


__all__ = ["MEASUREMENT_DIR", "figures_to_draw", "write_if_changed", "write_outputs"]
