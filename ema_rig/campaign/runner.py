"""Running a campaign: what a measurement depends on, the result cache, the worker pool.

What one computation depends on is a single frozen dataclass, :class:`MeasurementTask`: the
resolved rig (its content: model parameters, sensors, ``[identification]``, ``[units]``,
``[uncertainty]``), k_MS and its uncertainty, the speed, band and order, the kind of computation.
The worker receives exactly that object (it never re-reads the rig file), and the cache key is
the hash of every one of its fields plus the file's content hash, the ema_rig version and its code, so
nothing that changes a result can be left out of the key by accident.

Only results that depend on the data are cached: a good result, or an ema_rig error about the
data (bad file, no housing mode). Infrastructure failures (a worker killed, an interruption, an
unexpected exception, a file the worker could not read at that moment: I/O, permission, memory,
:class:`~ema_rig.errors.FileAccessError`) are reported in the row but never reused: the next run
computes them again.

Pool workers die with the process that started them (``PR_SET_PDEATHSIG`` on Linux, and a
watchdog thread on the parent's process id everywhere but Windows).

Where the time goes with ``jobs > 1``: the calibration runs first in this process, and its first
call pays the imports of the numerical stack (scipy, the identification); the pool is started
after it, so its forked workers inherit those modules instead of importing them again; when
they will draw, this process computes and draws the first measurement to draw just before, for
the same reason: the workers inherit the figures' one-time work (matplotlib's imports, the mathtext
grammar, font lookups) and take its kept figures over, built and laid out, with their texts
measured and glyphs rendered (:func:`ema_rig.plot._render.kept_figure`); with nothing to draw
now, a small figure (:func:`ema_rig.plot._render.warm_up`). The
measurements are submitted longest first (by their time in the previous run, else by file size),
so that no worker is left alone with one long measurement at the end. A worker draws the
report's figures of the measurement it computed right after computing it, from that computation
(it is not identified again; only the PNG bytes come back). The figures of rows
reused from a previous run but missing from the folder are drawn at the end by the same pool (an
identification each) while this process draws the campaign figures; with none of those, a worker
draws every other campaign figure while this process draws the rest.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import os
import signal
import stat
import sys
import threading
import time
from collections import deque
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import (
    FIRST_COMPLETED,
    BrokenExecutor,
    Executor,
    Future,
    ProcessPoolExecutor,
    wait,
)
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from .. import _atomic
from .._blas import single_threaded
from .._progress import progress_bar
from .._version import code_fingerprint, version
from ..config import RigConfig, read_regular_file
from ..errors import EmaRigError, FileAccessError
from .drilldown import DPI, KINDS, measurement_figures
from .outputs import MANIFEST, MEASUREMENT_DIR, figures_to_draw, write_outputs
from .result import COLUMNS, CampaignResult
from .schema import CampaignConfig, Measurement, load_campaign

logger = logging.getLogger(__name__)

#: Name of the calibration's result in ``results/`` (ids may not start with ``_``).
CALIBRATION_NAME = "_calibration"
#: Bump when the meaning of a cached result changes without a version change (5: c_TB read with the
#: bearing's measured share of the damping, c_TB_kind).
_KEY_SCHEMA = 5
_MAX_RESULT_BYTES = 64 * 1024 * 1024
_NUMERIC = ("radial_load", "speed", "shaft_position", "k_TB", "k_TB_std", "k_TB_std_measured", "k_TB_MS", "k_MS", "housing_freq",
            "housing_freq_std", "housing_damping", "spindle_freq", "spindle_damping", "c_TB", "c_TB_std",
            "loss_factor", "loss_factor_std", "elapsed_s")


@dataclass(frozen=True, slots=True)
class MeasurementTask:
    """Everything one computation depends on; the worker's only input and the cache key's source.

    Attributes
    ----------
    kind : str
        ``"measurement"`` (k_TB) or ``"calibration"`` (k_MS from a steel disk).
    file : Path
        The UFF file (in the key by its content hash, not by its name).
    rig : RigConfig
        The resolved rig; its content enters the key, not where it was read from (``path``).
    k_ms, k_ms_std : float or None
        Mounting stiffness [N/m] used for k_TB and its standard uncertainty.
    k_disk : float or None
        Steel-disk stiffness [N/m] (calibration).
    speed_hz : float or None
        Shaft speed [Hz] (None: not rotating).
    band : (float, float) or None
        Identification band [Hz] (None: the rig's, else the default).
    max_order : int or None
    selection : str or None
        A saved mode selection (its JSON text: the content enters the key) replayed instead of
        the automatic identification.
    selection_file : str or None
        Where that selection was read from, named in an error (not in the key: the content is).
    """

    kind: str
    file: Path
    rig: RigConfig
    k_ms: float | None = None
    k_ms_std: float | None = None
    k_disk: float | None = None
    speed_hz: float | None = None
    band: tuple[float, float] | None = None
    max_order: int | None = None
    selection: str | None = None
    selection_file: str | None = field(default=None, metadata={"cache_key": False})


def _canonical(obj: Any) -> Any:
    """A JSON-able, order-independent form of a task's value (floats by their exact repr)."""
    if obj is None or isinstance(obj, (bool, int, str)):
        return obj
    if isinstance(obj, float):
        return repr(obj)
    if isinstance(obj, PathLike):
        return os.fspath(obj)
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {"__type__": type(obj).__name__,
                **{f.name: _canonical(getattr(obj, f.name)) for f in dataclasses.fields(obj)
                   if f.metadata.get("cache_key", True)}}
    if isinstance(obj, Mapping):
        return {str(k): _canonical(v) for k, v in sorted(obj.items(), key=lambda kv: str(kv[0]))}
    if isinstance(obj, (list, tuple)):
        return [_canonical(v) for v in obj]
    raise TypeError(f"cannot put a {type(obj).__name__} into a cache key")  # a new field type: add it here


def task_key(task: MeasurementTask, digest: str) -> str:
    """The cache key of a task whose file has content hash ``digest``.

    Every field of the task except the file name enters the key (recursively; only fields marked
    ``metadata={"cache_key": False}``, such as the rig's path, are left out), with the file's
    content hash, the ema_rig version, the hash of its sources (:func:`~ema_rig._version.code_fingerprint`:
    an update that keeps the version computes again) and the key schema.
    """
    fields = _canonical(task)
    fields.pop("file")
    payload = {"task": fields, "digest": digest, "version": version(), "code": code_fingerprint(),
               "schema": _KEY_SCHEMA}
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def file_digest(path: Path) -> str:
    """SHA-256 of a regular file's content.

    The file is opened non-blocking and checked on the open descriptor, so a FIFO or a device
    given as a measurement raises at once instead of blocking the campaign.

    Raises
    ------
    EmaRigError
        When the file is missing, not a regular file or unreadable (naming the file).
    """
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except FileNotFoundError:
        raise EmaRigError("file not found", file=path) from None
    except OSError as exc:
        raise EmaRigError(f"cannot open: {exc.strerror}", file=path) from None
    try:
        if not stat.S_ISREG(os.fstat(fd).st_mode):
            raise EmaRigError("not a regular file (a FIFO, socket, device or folder?)", file=path)
        h = hashlib.sha256()
        with os.fdopen(fd, "rb", closefd=False) as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
        return h.hexdigest()
    except OSError as exc:
        raise EmaRigError(f"cannot read: {exc.strerror}", file=path) from None
    finally:
        os.close(fd)


def _nan(x: Any) -> float:
    return math.nan if x is None else float(x)


def process_measurement(task: MeasurementTask) -> dict[str, Any]:
    """Run one task (k_TB of a measurement, or the k_MS calibration): a picklable worker.

    Parameters
    ----------
    task : MeasurementTask

    Returns
    -------
    dict
        ``status`` ("ok" or "error"), ``error`` (message), ``error_kind`` ("" / "data" for an
        ema_rig error about the data / "infrastructure" for a file that could not be read at that
        moment / "internal" for anything else), ``warnings``, the result
        columns, ``detail`` and ``elapsed_s``. Errors are returned, never raised, so that one bad
        file does not stop a campaign; ``KeyboardInterrupt`` and ``SystemExit`` propagate.
    """
    return _process(task)[0]


def _process(task: MeasurementTask) -> tuple[dict[str, Any], tuple[Any, Any] | None]:
    """:func:`process_measurement`, also giving (FRFData, StiffnessResult) of a good measurement."""
    t0 = time.perf_counter()
    computed = None
    # one BLAS thread per measurement: the matrices are small, and with --jobs N the N workers
    # would otherwise each start a thread per core and fight over the cores
    try:
        with single_threaded():
            out, computed = _compute(task)
    except EmaRigError as exc:
        # a replayed selection comes from the campaign file's [defaults], [bearings] or the measurement:
        # the error names it, since the data alone may be fine
        replay = "" if task.selection_file is None else f" (mode selection replayed: {task.selection_file})"
        # a file that could not be read now (I/O, permission, memory) says nothing of its content: not cached
        kind = "infrastructure" if isinstance(exc, FileAccessError) else "data"
        out = {"status": "error", "error": str(exc) + replay, "error_kind": kind}
    except Exception as exc:  # a bug or an unexpected file: reported, logged, never cached
        logger.exception("%s failed unexpectedly", task.file)
        out = {"status": "error", "error": f"internal error ({type(exc).__name__}): {exc}", "error_kind": "internal"}
    out["elapsed_s"] = time.perf_counter() - t0
    return out, computed


def _process_and_draw(task: MeasurementTask, m: Measurement | None = None,
                      cfg: CampaignConfig | None = None) -> tuple[dict[str, Any], Any]:
    """Run a measurement's task and, with ``m`` and ``cfg``, draw its report figures from that computation.

    A picklable worker: it returns the row of :func:`process_measurement` and the figures. They
    are drawn from the identification just made (it is not picklable, and identifying again for
    the figures would double the work), as :class:`~ema_rig.campaign.drilldown.MeasurementFigures`
    (PNG bytes); None without ``m``, for a failed row, or when drawing failed unexpectedly
    (logged; the output phase then draws them again, as for a row reused from a previous run).
    """
    out, computed = _process(task)
    if computed is None or out.get("status") != "ok" or m is None or cfg is None:
        return out, None

    try:
        drawn = measurement_figures(m, out, cfg, k_ms=cfg.rig.model.k_MS if task.k_ms is None else task.k_ms,
                                    k_ms_std=task.k_ms_std, computed=computed)
    except Exception:  # a drawing bug must not cost the row: the output phase tries again and reports it
        logger.exception("%s: figures not drawn with the computation", m.id)
        drawn = None
    return out, drawn


def _compute(task: MeasurementTask) -> tuple[dict[str, Any], tuple[Any, Any] | None]:
    from ..io.uff import read_uff58
    from ..rig.damping import c_tb_kind
    from ..rig.stiffness import calibrate, estimate_stiffness

    data = read_uff58(task.file, rig=task.rig)
    if task.kind == "calibration":
        d = calibrate(data, task.rig, k_disk=task.k_disk, band=task.band, max_order=task.max_order).to_dict()
        return {**d, "status": "ok", "error": "", "error_kind": "", "warnings": list(d.get("warnings") or [])}, None
    selection = None
    if task.selection is not None:
        from ..identification import Selection

        selection = Selection.from_json(task.selection)
    res = estimate_stiffness(data, task.rig, k_ms=task.k_ms, k_ms_std=task.k_ms_std, speed_hz=task.speed_hz,
                             band=task.band, max_order=task.max_order, selection=selection)
    d = res.to_dict()
    hm = d.get("housing_mode") or {}
    sm = d.get("spindle_mode") or {}
    return {
        "status": "ok", "error": "", "error_kind": "",
        "k_TB": _nan(d.get("k_TB")), "k_TB_std": _nan(d.get("k_TB_std")),
        "k_TB_std_measured": _nan(d.get("k_TB_std_measured")), "k_TB_MS": _nan(d.get("k_TB_MS")),
        "k_MS": _nan(d.get("k_MS")),
        "housing_freq": _nan(hm.get("natural_freq")), "housing_freq_std": _nan(hm.get("natural_freq_std")),
        "housing_damping": _nan(hm.get("damping_ratio")),
        "spindle_freq": _nan(sm.get("natural_freq")), "spindle_damping": _nan(sm.get("damping_ratio")),
        "mode_source": str(d.get("mode_source") or "auto"),
        "c_TB": _nan(d.get("c_TB")), "c_TB_std": _nan(d.get("c_TB_std")),
        "c_TB_kind": "" if d.get("c_TB") is None else c_tb_kind(d),
        "loss_factor": _nan(d.get("loss_factor")), "loss_factor_std": _nan(d.get("loss_factor_std")),
        "warnings": list(d.get("warnings") or []),
        "detail": d,
    }, (data, res)


def _cacheable(result: Mapping[str, Any]) -> bool:
    """Only a result of the data is reused: ok, or an ema_rig error about the data."""
    return result.get("status") == "ok" or result.get("error_kind") == "data"


def _load_cached(path: Path, key: str, *, row: bool) -> dict[str, Any] | None:
    """A previous result with this key, or None (missing, unreadable, foreign or malformed)."""
    try:  # a regular file of sane size only (a FIFO planted as results/<id>.json must not block)
        doc = json.loads(read_regular_file(path, max_bytes=_MAX_RESULT_BYTES).decode("utf-8"))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(doc, dict) or doc.get("cache_key") != key or doc.get("status") not in ("ok", "error"):
        return None
    if not isinstance(doc.get("error", ""), str):
        return None
    if row:
        for k in _NUMERIC:
            v = doc.get(k)
            if v is None:
                doc[k] = math.nan  # JSON null back to NaN
            elif isinstance(v, bool) or not isinstance(v, (int, float)):
                return None
    elif doc["status"] == "ok" and not _positive(doc.get("k_MS")):
        return None
    return doc


def _positive(x: Any) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and x > 0


# --------------------------------------------------------------------------- workers
def _worker_init(parent: int) -> None:
    """Initializer of pool workers: die with ``parent``; leave Ctrl-C to the parent."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles an interrupt and stops the pool
    _atomic.close_inherited_locks()  # the parent's folder lock must die with the parent
    if sys.platform.startswith("linux"):
        try:
            import ctypes

            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGKILL, 0, 0, 0)  # PR_SET_PDEATHSIG: killed when the parent dies
        except (OSError, AttributeError):  # pragma: no cover - no prctl: the watchdog remains
            pass
    if os.name == "nt":  # pragma: no cover - os.kill(pid, 0) would terminate the process on Windows
        return
    if not _alive(parent):  # the parent died before the death signal was armed
        os._exit(1)
    threading.Thread(target=_watch_parent, args=(parent, os.getppid()), name="ema-rig-parent-watch",
                     daemon=True).start()


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def _watch_parent(parent: int, ppid: int) -> None:  # pragma: no cover - runs in the workers
    while True:
        time.sleep(1.0)
        if os.getppid() != ppid or not _alive(parent):
            os._exit(1)


def make_pool(jobs: int) -> ProcessPoolExecutor:
    """A process pool whose workers die with this process and ignore Ctrl-C."""
    return ProcessPoolExecutor(max_workers=jobs, initializer=_worker_init, initargs=(os.getpid(),))


# --------------------------------------------------------------------------- run
def run(
    campaign: CampaignConfig | str | PathLike[str],
    *,
    out_dir: str | PathLike[str] | None = None,
    jobs: int = 1,
    executor: Executor | None = None,
    force: bool = False,
    progress: bool | Callable[[int, int], None] = False,
    report: bool = True,
) -> CampaignResult:
    """Run a campaign: calibrate k_MS, estimate k_TB for every measurement, write the outputs.

    Parameters
    ----------
    campaign : CampaignConfig or path
        A loaded campaign or the path of a campaign file.
    out_dir : path, optional
        Output folder. Per-measurement results go to ``out_dir/results/<id>.json`` as they finish;
        ``campaign.csv``, ``settings.json``, the figures and ``report.html`` are written at the
        end. The folder is locked for the run: a second run on it raises. Without it, nothing is
        written and nothing can be reused.
    jobs : int, optional
        Number of worker processes when no ``executor`` is given (1 = in this process); they
        also draw the report's per-measurement figures.
    executor : concurrent.futures.Executor, optional
        Any executor, e.g. ``dask.distributed.Client(...).get_executor()``; overrides ``jobs``.
    force : bool, optional
        Recompute every measurement even when a valid previous result exists.
    progress : bool or callable, optional
        True shows a tqdm bar (hidden when not a TTY); a callable gets ``(done, total)``.
    report : bool, optional
        Write the table, figures and HTML report (default True; needs ``out_dir``).

    Returns
    -------
    CampaignResult

    Raises
    ------
    FolderBusyError
        When another run holds ``out_dir``.
    OSError
        When an output cannot be written (naming the file).

    Notes
    -----
    A measurement is reused when its JSON result exists and its key - the hash of the file
    content and of every field of its :class:`MeasurementTask` (the rig's content, k_MS, band,
    order, speed) and the ema_rig version and code - is unchanged, so a run killed halfway loses only the
    measurements in flight. Failures of the infrastructure are never reused.
    """
    cfg = campaign if isinstance(campaign, CampaignConfig) else load_campaign(campaign)
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")
    if out_dir is None:
        return _run(cfg, None, jobs, executor, force, progress, report)
    out = Path(out_dir)
    check_out_folder(cfg, out)
    with _atomic.folder_lock(out):
        for sub in ("results", "measurements"):  # a planted link would send our writes elsewhere
            if os.path.islink(out / sub):
                raise EmaRigError("is a symbolic link; ema-rig writes its results only inside the output "
                                  "folder: remove it", file=out / sub)
        for folder in (out, out / "results"):
            _atomic.remove_temporaries(folder)
        return _run(cfg, out, jobs, executor, force, progress, report)


def check_out_folder(cfg: CampaignConfig, out: Path) -> None:
    """Refuse an output folder where the run would write over one of the campaign's inputs.

    The inputs (campaign file, rig file, calibration, every measurement file) are compared with
    every file the run writes (same inode or same resolved path), and none may be a figure
    (``*.png``) directly in the folder or lie in its ``results/`` or ``measurements/`` folders
    (files there are replaced or removed as stale).

    Raises
    ------
    OutputIsInputError
        Naming the output and the input it would overwrite.
    OutputPathError
        Naming the folder (or an output in it) when it cannot be made or written.
    """
    _atomic.check_output_folder(out)  # a file in the way: named as the folder, not as one of its files
    inputs = [("campaign file", cfg.path), ("rig", cfg.rig_file), ("calibration", cfg.calibration)]
    inputs += [(f"measurement {m.id!r}", m.file) for m in cfg.measurements]
    outputs: list[tuple[str, Any]] = [(n, out / n) for n in ("campaign.csv", "settings.json", "report.html",
                                                              MANIFEST, ".ema-rig.lock")]
    outputs.append(("calibration result", out / "results" / f"{CALIBRATION_NAME}.json"))
    for m in cfg.measurements:
        outputs.append((f"result of {m.id!r}", out / "results" / f"{m.id}.json"))
        outputs += [(f"figure of {m.id!r}", out / MEASUREMENT_DIR / f"{m.id}.{k}.png") for k in KINDS]
    _atomic.check_outputs(inputs, outputs)
    home = Path(os.path.realpath(out))
    for label, path in inputs:
        if path is None:
            continue
        real = Path(os.path.realpath(path))
        if (real.parent == home and real.suffix.lower() == ".png") or real.parent in (
                home / "results", home / MEASUREMENT_DIR):
            raise _atomic.OutputIsInputError(
                f"output folder holds the input {label} ({path}) where the campaign writes and removes its "
                "own files; choose another output folder", file=out)


def _run(cfg: CampaignConfig, out: Path | None, jobs: int, executor: Executor | None, force: bool,
         progress: bool | Callable[[int, int], None], report: bool) -> CampaignResult:
    res_dir = None if out is None else out / "results"
    rig = cfg.rig

    def result_path(name: str) -> Path | None:
        if res_dir is None:
            return None
        p = res_dir / f"{name}.json"
        if p.parent != res_dir:  # ids are validated in the schema; never write elsewhere
            raise EmaRigError(f"measurement id {name!r} is not a plain file name")
        return p

    # 1. k_MS from the steel disk (or the rig file)
    k_ms, k_ms_std = cfg.rig.model.k_MS, None
    calib: dict[str, Any] | None = None
    if cfg.calibration is not None:
        ctask = MeasurementTask(kind="calibration", file=cfg.calibration, rig=rig, k_disk=cfg.k_disk,
                                max_order=cfg.max_order)
        cpath = result_path(CALIBRATION_NAME)
        try:
            ckey: str | None = task_key(ctask, file_digest(cfg.calibration))
        except EmaRigError as exc:
            ckey, calib = None, {"status": "error", "error": str(exc), "error_kind": "input"}
        if calib is None and ckey is not None:
            calib = None if (force or cpath is None) else _load_cached(cpath, ckey, row=False)
            if calib is None:
                calib = process_measurement(ctask)
        assert calib is not None
        calib["file"] = str(cfg.calibration)
        calib["cache_key"] = ckey if _cacheable(calib) else None
        if cpath is not None:
            _atomic.write_json(cpath, calib)
        if calib["status"] == "ok":
            k_ms, k_ms_std = float(calib["k_MS"]), calib.get("k_MS_std")
        else:
            logger.warning("calibration failed (%s); using k_MS from the rig file", calib["error"])

    # 2. the measurements: a task each, reused when the key matches
    rows: dict[str, dict[str, Any]] = {}
    todo: list[tuple[Measurement, MeasurementTask, str]] = []
    failed_input: list[tuple[Measurement, dict[str, Any]]] = []
    digests: dict[str, str] = {}
    cached_rows: list[tuple[Measurement, dict[str, Any]]] = []
    for m in cfg.measurements:
        try:
            t = MeasurementTask(kind="measurement", file=m.file, rig=rig, k_ms=k_ms, k_ms_std=k_ms_std,
                                speed_hz=m.speed / 60.0 if m.speed > 0 else None, band=cfg.band,
                                max_order=cfg.max_order, selection=read_selection(m),
                                selection_file=None if m.selection is None else str(m.selection))
            digests[m.id] = file_digest(m.file)
            key = task_key(t, digests[m.id])
        except EmaRigError as exc:  # missing, unreadable or not a regular file: checked every run
            failed_input.append((m, {"status": "error", "error": str(exc), "error_kind": "input"}))
            continue
        path = result_path(m.id)
        cached = None if (force or path is None) else _load_cached(path, key, row=True)
        if cached is not None:
            cached_rows.append((m, cached))
        else:
            todo.append((m, t, key))
    # a file whose content another measurement holds too is computed as often as it is listed, but
    # its rows are one measurement: a campaign-wide fact, so never taken from (or kept in) a cached row
    same_data = same_content_warnings(cfg.measurements, digests)
    for m, cached in cached_rows:
        # the conditions (bearing, load, tags ...) do not change the computation but are today's
        row = {**cached, **m.conditions()}
        kept = [w for w in (row.get("warnings") or []) if not str(w).startswith(SAME_CONTENT)]
        now = kept + ([same_data[m.id]] if m.id in same_data and row.get("status") == "ok" else [])
        if now != list(row.get("warnings") or []):
            row["warnings"] = now
            path = result_path(m.id)
            if path is not None:  # results/<id>.json stays the row the table shows
                _atomic.write_json(path, row)
        rows[m.id] = row
    if executor is not None or jobs > 1:
        # longest first: a long measurement started last would keep one worker busy alone at the end
        todo.sort(key=lambda mtk: _expected_cost(mtk[0].file, result_path(mtk[0].id)), reverse=True)
    reused = len(rows)
    bar = _progress(progress, len(cfg.measurements), reused)

    # a k_TB computed with the rig file's k_MS because the calibration failed says so in its own row
    # (its key holds that k_MS: a reused row was computed with the same one, and carries the line too)
    calib_warning = (None if calib is None or calib["status"] == "ok" else
                     f"k_MS {k_ms / 1e6:.2f} MN/m taken from the rig file: the steel-disk calibration "
                     f"{cfg.calibration} failed ({calib['error']})")

    def finish(m: Measurement, key: str | None, result: dict[str, Any]) -> None:
        blank = {c: math.nan for c in COLUMNS} | {"mode_source": "", "c_TB_kind": ""}  # every column in every row, errors included
        row = {**blank, "warnings": [], **m.conditions(), **result,
               "cache_key": key if _cacheable(result) else None}
        if calib_warning is not None and row.get("status") == "ok":
            row["warnings"] = [*row["warnings"], calib_warning]
        if m.id in same_data and row.get("status") == "ok":
            row["warnings"] = [*row["warnings"], same_data[m.id]]
        rows[m.id] = row
        path = result_path(m.id)
        if path is not None:
            _atomic.write_json(path, row)
        bar(1)

    for m, outcome in failed_input:
        finish(m, None, outcome)
    if todo and out is not None and report:
        # the rows change: the previous report and table must not look current while (or if) this run
        # stops (a script reading campaign.csv after a killed re-run read the replaced files' old k_TB)
        for name in ("report.html", "campaign.csv"):
            (out / name).unlink(missing_ok=True)
    drill_down = out is not None and report and cfg.measurement_figures
    # a measurement computed now whose figures cannot be reused is drawn by its worker, from the
    # computation (no second identification); its figures wait in `drawn` for the output phase
    draw: set[str] = set()
    if drill_down and todo:
        assert out is not None

        draw = figures_to_draw(out, [(m.id, key) for m, _, key in todo])
    drawn: dict[str, Any] = {}

    def task_of(m: Measurement, t: MeasurementTask) -> tuple[Callable[..., Any], tuple[Any, ...]]:
        return (_process_and_draw, (t, m, cfg) if m.id in draw else (t,))

    def settle(m: Measurement, key: str, outcome: tuple[dict[str, Any], Any]) -> None:
        result, figs = outcome
        if figs is not None and key is not None and m.id in draw:
            drawn[m.id] = (key, figs)
        finish(m, key, result)
    own_pool: ProcessPoolExecutor | None = None
    if executor is None and jobs > 1 and cfg.measurements and (len(todo) > 1 or drill_down):
        # forked after the calibration: the workers inherit its imports; they also draw the
        # measurements' figures of the report (with the computation, or at the end for reused rows),
        # and inherit the figures' one-time work too, done here once instead of once per worker:
        # the measurement to draw that --jobs 1 draws first is computed and drawn here first (its
        # figures built, laid out, their texts measured and glyphs rendered; a layout reused for
        # others is within half a pixel of their own, and this is the one --jobs 1 reuses: the same
        # pictures), else a small figure is drawn
        place = {m.id: i for i, m in enumerate(cfg.measurements)}
        first = min((mtk for mtk in todo if mtk[0].id in draw), key=lambda mtk: place[mtk[0].id], default=None)
        if first is not None:
            todo.remove(first)
            m, t, key = first
            fn, args = task_of(m, t)
            settle(m, key, fn(*args))
        elif drill_down:
            from ..plot._render import warm_up

            warm_up(DPI)
        own_pool = executor = make_pool(min(jobs, len(cfg.measurements)))
    try:
        if executor is None:
            for m, t, key in todo:
                fn, args = task_of(m, t)
                settle(m, key, fn(*args))
        else:
            # our own pool gets one task per worker at a time, so a worker that dies (killed, out of
            # memory) takes down only the measurements in flight: they become error rows, and the
            # rest go on in a fresh pool; another executor gets every task at once
            pending = deque(todo)
            window = jobs if own_pool is not None else max(len(todo), 1)
            futs: dict[Future[Any], tuple[Measurement, str]] = {}
            while pending or futs:
                while pending and len(futs) < window:
                    m, t, key = pending.popleft()
                    fn, args = task_of(m, t)
                    futs[executor.submit(fn, *args)] = (m, key)
                ready, _ = wait(futs, return_when=FIRST_COMPLETED)
                broken = False
                while ready:
                    for fut in ready:
                        m, key = futs.pop(fut)
                        try:
                            got = fut.result()
                        except Exception as exc:  # the worker died (killed process, lost dask worker)
                            broken = broken or isinstance(exc, BrokenExecutor)
                            got = ({"status": "error", "error_kind": "infrastructure",
                                    "error": f"worker failed ({type(exc).__name__}: {exc or 'no message'}); "
                                             "not cached, computed again on the next run"}, None)
                        settle(m, key, got)
                    # a broken pool fails every task it holds: collect them all before replacing it
                    ready = set(wait(futs)[0]) if broken and futs else set()
                if broken and own_pool is not None:
                    own_pool.shutdown(wait=True, cancel_futures=True)
                    own_pool = executor = make_pool(min(jobs, len(cfg.measurements)))
        bar(None)

        ordered = tuple(
            {c: rows[m.id].get(c, math.nan if c not in ("error", "status", "mode_source", "c_TB_kind") else "")
             for c in COLUMNS}
            | {"detail": rows[m.id].get("detail"), "warnings": list(rows[m.id].get("warnings") or [])}
            for m in cfg.measurements
        )
        result = CampaignResult(
            config=cfg, rows=ordered, calibration=calib, k_MS=k_ms, k_MS_std=k_ms_std,
            out_dir=out, computed=len(cfg.measurements) - reused, reused=reused,
        )
        if out is not None and report:
            result = dataclasses.replace(result, files=write_outputs(result, out, executor=own_pool, drawn=drawn))
    except BaseException:
        bar(None)
        if own_pool is not None:
            own_pool.shutdown(wait=False, cancel_futures=True)
            own_pool = None
        raise
    finally:
        if own_pool is not None:
            own_pool.shutdown()
    return result


#: Start of the warning of a row whose file content another measurement of the campaign holds too.
SAME_CONTENT = "same file content as measurement"


def same_content_warnings(measurements: Sequence[Measurement], digests: Mapping[str, str]) -> dict[str, str]:
    """Id -> a warning for every measurement whose file content another measurement holds too.

    Two rows computed from one file are one measurement: under other conditions (bearing, load,
    speed, shaft position) at least one of them was given the wrong file and shows another
    condition's k_TB; under the same conditions they are no independent repeats (their spread is 0).

    Parameters
    ----------
    measurements : sequence of Measurement
        The campaign's measurements, in campaign order.
    digests : mapping of str to str
        Measurement id -> SHA-256 of its file's content (:func:`file_digest`); ids without one are
        left out.

    Returns
    -------
    dict of str to str
        One line per measurement sharing its content, naming the others (id and file).
    """
    groups: dict[str, list[Measurement]] = {}
    for m in measurements:
        if m.id in digests:
            groups.setdefault(digests[m.id], []).append(m)
    out: dict[str, str] = {}
    for group in groups.values():
        for m in group if len(group) > 1 else ():
            others = [o for o in group if o is not m]
            alike = all(_same_conditions(o, m) for o in others)
            why = ("the same data, not an independent repeat" if alike else
                   "under other conditions (bearing, load, speed or shaft position): one of them is the wrong "
                   "file, and its k_TB belongs to the other's conditions")
            names = ", ".join(f"{o.id!r} ({o.file})" for o in others)
            out[m.id] = f"{SAME_CONTENT} {names}: {why}"
    return out


def _same_conditions(a: Measurement, b: Measurement) -> bool:
    """Same bearing, radial load, speed and shaft position (a value not given, NaN, equals NaN)."""
    def same(x: float, y: float) -> bool:
        return x == y or (math.isnan(x) and math.isnan(y))

    return a.bearing == b.bearing and all(same(getattr(a, k), getattr(b, k))
                                          for k in ("radial_load", "speed", "shaft_position"))


def read_selection(m: Measurement) -> str | None:
    """The text of a measurement's mode selection (None without one).

    Raises
    ------
    EmaRigError
        When the file cannot be read (naming it).
    """
    if m.selection is None:
        return None
    try:
        return m.selection.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise EmaRigError(f"cannot read the mode selection: {exc}", file=m.selection) from None


def _expected_cost(file: Path, previous: Path | None) -> tuple[float, float]:
    """Sort key of a measurement's expected run time: its time in the previous run, then its size.

    Only an ordering hint; any unreadable value counts as unknown (0).
    """
    seconds = 0.0
    if previous is not None:
        try:
            doc = json.loads(read_regular_file(previous, max_bytes=_MAX_RESULT_BYTES).decode("utf-8"))
            value = doc.get("elapsed_s") if isinstance(doc, dict) else None
            if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value):
                seconds = float(value)
        except (OSError, ValueError, RecursionError):
            pass
    try:
        size = float(os.stat(file).st_size)
    except OSError:
        size = 0.0
    return seconds, size


def _progress(progress: bool | Callable[[int, int], None], total: int, initial: int) -> Callable[[int | None], None]:
    """A tiny adapter: ``step(1)`` advances, ``step(None)`` closes."""
    if callable(progress):
        state = {"done": initial}

        def step(n: int | None) -> None:
            if n is not None:
                state["done"] += n
                progress(state["done"], total)

        return step
    if progress:
        pbar = progress_bar(total=total, initial=initial, desc="measurements", unit="meas")

        def step(n: int | None) -> None:
            if n is None:
                pbar.close()
            else:
                pbar.update(n)

        return step
    return lambda n: None


__all__ = ["CALIBRATION_NAME", "SAME_CONTENT", "MeasurementTask", "check_out_folder", "file_digest", "make_pool", "process_measurement", "run",
           "same_content_warnings", "task_key"]
