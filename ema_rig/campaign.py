"""Campaigns: bearing stiffness over many measurements, one row per measurement.

A campaign file (TOML) names the rig file, an optional steel-disk calibration file and one
``[[measurement]]`` table per UFF export with its conditions::

    rig = "rig.toml"                  # relative to the campaign file
    calibration = "disk.uff"          # optional: k_MS from a steel-disk run
    k_disk = 2.0e9                    # optional: finite stiffness of the disk [N/m]
    title = "6302 campaign"           # optional

    [defaults]                        # optional identification settings
    band = [150.0, 1000.0]            # Hz
    max_order = 60

    [bearings.dummy]                  # optional, per bearing name
    k_lower = 31.14e6                 # FE bounds [N/m], drawn as a band
    k_upper = 34.12e6
    [bearings.6302]
    hertz = true                      # draw the Hertzian estimate (ema_rig.rig.hertz)

    [[measurement]]
    file = "m001.uff"
    bearing = "6302"
    radial_load = 1000.0              # N
    speed = 600.0                     # rpm (0 = not rotating)
    shaft_position = 0.0              # deg (optional)
    repeat = 1                        # optional
    tags = ["lifetime"]               # optional free-form
    id = "m001"                       # optional, default: the file stem

:func:`run` processes the measurements (in parallel with ``jobs`` processes or any
:class:`concurrent.futures.Executor`, e.g. ``dask.distributed.Client.get_executor()``), writes a
JSON result per measurement as soon as it finishes, skips measurements whose inputs (file content
and settings) have not changed since a previous run, and returns a :class:`CampaignResult`.

Functions
---------
load_campaign
    Read and validate a campaign file into a :class:`CampaignConfig`.
run
    Run a campaign; returns a :class:`CampaignResult`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
import time
from collections.abc import Callable, Iterable, Mapping
from concurrent.futures import Executor, Future, ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from . import _atomic
from .config import RigConfig, load_rig, read_toml
from .errors import ConfigError, EmaRigError

logger = logging.getLogger(__name__)

_TOP_KEYS = ("rig", "calibration", "k_disk", "title", "defaults", "bearings", "measurement")
_MEAS_KEYS = ("file", "bearing", "radial_load", "speed", "shaft_position", "repeat", "tags", "id")
_DEFAULT_KEYS = ("band", "max_order")
_BEARING_KEYS = ("k_lower", "k_upper", "hertz", "label")

#: Column order of the campaign table.
COLUMNS: tuple[str, ...] = (
    "id", "file", "bearing", "radial_load", "speed", "shaft_position", "repeat", "tags",
    "status", "k_TB", "k_TB_std", "k_TB_MS", "k_MS",
    "housing_freq", "housing_freq_std", "housing_damping",
    "spindle_freq", "spindle_damping", "error", "elapsed_s",
)


@dataclass(frozen=True, slots=True)
class Measurement:
    """One measurement of a campaign and its conditions.

    Attributes
    ----------
    id : str
        Unique name (default: the file stem).
    file : Path
        UFF58 file (absolute).
    bearing : str
        Bearing name, e.g. ``"6302"`` or ``"dummy"``.
    radial_load : float
        Static radial load [N] (NaN when not given).
    speed : float
        Shaft speed [rpm]; 0 means not rotating.
    shaft_position : float
        Angular shaft position [deg] (NaN when not given).
    repeat : int
        Repeat number (1 when not given).
    tags : tuple of str
    """

    id: str
    file: Path
    bearing: str = ""
    radial_load: float = math.nan
    speed: float = 0.0
    shaft_position: float = math.nan
    repeat: int = 1
    tags: tuple[str, ...] = ()

    @property
    def rotating(self) -> bool:
        """True when the shaft turns (speed > 0)."""
        return self.speed > 0

    def conditions(self) -> dict[str, Any]:
        """The conditions as a flat dict (the first columns of the table)."""
        return {
            "id": self.id,
            "file": str(self.file),
            "bearing": self.bearing,
            "radial_load": self.radial_load,
            "speed": self.speed,
            "shaft_position": self.shaft_position,
            "repeat": self.repeat,
            "tags": ";".join(self.tags),
        }


@dataclass(frozen=True, slots=True)
class BearingInfo:
    """Reference information drawn beside a bearing's results (FE bounds, Hertz curve)."""

    k_lower: float | None = None
    k_upper: float | None = None
    hertz: bool = False
    label: str = ""


@dataclass(frozen=True, slots=True)
class CampaignConfig:
    """A validated campaign file.

    Attributes
    ----------
    path : Path or None
    rig_file : Path
    rig : RigConfig
    calibration : Path or None
        Steel-disk measurement giving k_MS.
    k_disk : float or None
        Stiffness of the steel disk [N/m] (None: infinitely stiff).
    band : tuple of float or None
        Identification band [Hz] (None: the pipeline's default).
    max_order : int or None
    bearings : mapping of str to BearingInfo
    measurements : tuple of Measurement
    title : str
    """

    rig_file: Path
    rig: RigConfig
    measurements: tuple[Measurement, ...]
    calibration: Path | None = None
    k_disk: float | None = None
    band: tuple[float, float] | None = None
    max_order: int | None = None
    bearings: Mapping[str, BearingInfo] = field(default_factory=dict)
    title: str = "ema_rig campaign"
    path: Path | None = None

    def settings(self) -> dict[str, Any]:
        """The resolved settings, as written to the report and hashed for caching."""
        return {
            "campaign": str(self.path) if self.path else None,
            "rig_file": str(self.rig_file),
            "model": self.rig.model.as_dict(),
            "radial": str(self.rig.radial),
            "axial": None if self.rig.axial is None else str(self.rig.axial),
            "sensors": [[str(s.dof), s.role, s.axis] for s in self.rig.sensors],
            "uncertainty": dict(self.rig.uncertainty),
            "calibration": None if self.calibration is None else str(self.calibration),
            "k_disk": self.k_disk,
            "band": None if self.band is None else list(self.band),
            "max_order": self.max_order,
        }


def _number(v: Any, key: str, file: str, *, allow_zero: bool = True) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(float(v)):
        raise ConfigError(f"must be a finite number, got {v!r}", file=file, key=key)
    x = float(v)
    if x < 0 or (x == 0 and not allow_zero):
        raise ConfigError(f"must be {'>= 0' if allow_zero else '> 0'}, got {v!r}", file=file, key=key)
    return x


def _unknown(table: Mapping[str, Any], allowed: tuple[str, ...], where: str, file: str) -> None:
    for k in table:
        if k not in allowed:
            raise ConfigError(
                f"unknown key; allowed keys here are {', '.join(allowed)}",
                file=file,
                key=f"{where}.{k}" if where else k,
            )


def load_campaign(path: str | PathLike[str]) -> CampaignConfig:
    """Read and validate a campaign file.

    Parameters
    ----------
    path : str or path-like
        The campaign TOML file. Relative paths inside it are relative to its folder.

    Returns
    -------
    CampaignConfig

    Raises
    ------
    ConfigError
        Naming the key path (``measurement[3].radial_load``) and what is allowed, for unknown or
        missing keys, bad values, duplicate ids, and missing files.
    """
    p = Path(path).resolve()
    fname = str(path)
    doc = read_toml(p)
    _unknown(doc, _TOP_KEYS, "", fname)
    base = p.parent

    def file_key(v: Any, key: str) -> Path:
        if not isinstance(v, str) or not v:
            raise ConfigError(f"must be a file path, got {v!r}", file=fname, key=key)
        q = (base / v).resolve()
        if not q.is_file():
            raise ConfigError(f"file not found: {q}", file=fname, key=key)
        return q

    if "rig" not in doc:
        raise ConfigError("missing required key (path of the rig file)", file=fname, key="rig")
    rig_file = file_key(doc["rig"], "rig")
    rig = load_rig(rig_file)
    calibration = file_key(doc["calibration"], "calibration") if "calibration" in doc else None
    k_disk = _number(doc["k_disk"], "k_disk", fname, allow_zero=False) if "k_disk" in doc else None
    title = str(doc.get("title", p.stem))

    defaults = doc.get("defaults", {})
    if not isinstance(defaults, Mapping):
        raise ConfigError("must be a table [defaults]", file=fname, key="defaults")
    _unknown(defaults, _DEFAULT_KEYS, "defaults", fname)
    band = None
    if "band" in defaults:
        b = defaults["band"]
        if not isinstance(b, list) or len(b) != 2:
            raise ConfigError(f"must be [lo, hi] in Hz, got {b!r}", file=fname, key="defaults.band")
        lo, hi = (_number(x, "defaults.band", fname) for x in b)
        if hi <= lo:
            raise ConfigError(f"needs lo < hi, got {b!r}", file=fname, key="defaults.band")
        band = (lo, hi)
    max_order = None
    if "max_order" in defaults:
        mo = defaults["max_order"]
        if isinstance(mo, bool) or not isinstance(mo, int) or mo < 2:
            raise ConfigError(f"must be an integer >= 2, got {mo!r}", file=fname, key="defaults.max_order")
        max_order = mo

    bearings: dict[str, BearingInfo] = {}
    raw_b = doc.get("bearings", {})
    if not isinstance(raw_b, Mapping):
        raise ConfigError("must be a table of tables [bearings.<name>]", file=fname, key="bearings")
    for name, t in raw_b.items():
        where = f"bearings.{name}"
        if not isinstance(t, Mapping):
            raise ConfigError("must be a table", file=fname, key=where)
        _unknown(t, _BEARING_KEYS, where, fname)
        k_lo = _number(t["k_lower"], f"{where}.k_lower", fname, allow_zero=False) if "k_lower" in t else None
        k_hi = _number(t["k_upper"], f"{where}.k_upper", fname, allow_zero=False) if "k_upper" in t else None
        if k_lo is not None and k_hi is not None and k_hi < k_lo:
            raise ConfigError("k_upper must be >= k_lower", file=fname, key=where)
        bearings[str(name)] = BearingInfo(k_lo, k_hi, bool(t.get("hertz", False)), str(t.get("label", "")))

    raw = doc.get("measurement")
    if not isinstance(raw, list) or not raw:
        raise ConfigError("needs at least one [[measurement]] table", file=fname, key="measurement")
    meas: list[Measurement] = []
    seen: dict[str, int] = {}
    for i, m in enumerate(raw):
        where = f"measurement[{i}]"
        if not isinstance(m, Mapping):
            raise ConfigError("must be a table", file=fname, key=where)
        _unknown(m, _MEAS_KEYS, where, fname)
        if "file" not in m:
            raise ConfigError("missing required key 'file'", file=fname, key=f"{where}.file")
        fpath = (base / str(m["file"])).resolve()  # a missing file is a row error, not fatal
        mid = str(m.get("id", Path(str(m["file"])).stem))
        if mid in seen:
            raise ConfigError(
                f"duplicate measurement id {mid!r} (also measurement[{seen[mid]}]); give an explicit id",
                file=fname, key=f"{where}.id",
            )
        seen[mid] = i
        rep = m.get("repeat", 1)
        if isinstance(rep, bool) or not isinstance(rep, int):
            raise ConfigError(f"must be an integer, got {rep!r}", file=fname, key=f"{where}.repeat")
        tags = m.get("tags", [])
        if isinstance(tags, str):
            tags = [tags]
        if not isinstance(tags, list) or not all(isinstance(t, str) for t in tags):
            raise ConfigError("must be a list of strings", file=fname, key=f"{where}.tags")
        meas.append(
            Measurement(
                id=mid,
                file=fpath,
                bearing=str(m.get("bearing", "")),
                radial_load=_number(m["radial_load"], f"{where}.radial_load", fname) if "radial_load" in m else math.nan,
                speed=_number(m["speed"], f"{where}.speed", fname) if "speed" in m else 0.0,
                shaft_position=float(m["shaft_position"]) if "shaft_position" in m else math.nan,
                repeat=rep,
                tags=tuple(tags),
            )
        )
    return CampaignConfig(
        rig_file=rig_file, rig=rig, measurements=tuple(meas), calibration=calibration, k_disk=k_disk,
        band=band, max_order=max_order, bearings=bearings, title=title, path=p,
    )


# --------------------------------------------------------------------------- results
@dataclass(frozen=True, slots=True)
class CampaignResult:
    """What a campaign run produced.

    Attributes
    ----------
    config : CampaignConfig
    rows : tuple of dict
        One row per measurement in campaign order, keys :data:`COLUMNS`.
    calibration : dict or None
        The k_MS calibration (``k_MS``, ``k_MS_std``, ``housing_mode``, ``status``, ``error``).
    k_MS, k_MS_std : float
        The mounting stiffness used [N/m] and its standard uncertainty.
    out_dir : Path or None
        Where tables, figures and the report were written.
    computed, reused : int
        How many measurements were computed in this run and how many reused from a previous run.
    files : dict
        Written outputs by kind (``"table"``, ``"report"``, figure names ...).
    """

    config: CampaignConfig
    rows: tuple[dict[str, Any], ...]
    calibration: dict[str, Any] | None
    k_MS: float
    k_MS_std: float | None
    out_dir: Path | None = None
    computed: int = 0
    reused: int = 0
    files: Mapping[str, Path] = field(default_factory=dict)

    @property
    def n_failed(self) -> int:
        """Number of measurements that ended in an error."""
        return sum(r["status"] != "ok" for r in self.rows)

    @property
    def ok(self) -> bool:
        """True when every measurement (and the calibration, if any) succeeded."""
        cal_ok = self.calibration is None or self.calibration.get("status") == "ok"
        return self.n_failed == 0 and cal_ok

    def to_records(self) -> list[dict[str, Any]]:
        """The table rows as a list of dicts (keys :data:`COLUMNS`)."""
        return [dict(r) for r in self.rows]

    def to_dataframe(self) -> Any:
        """The table as a pandas DataFrame (needs the ``pandas`` extra)."""
        from ._optional import import_optional

        pd = import_optional("pandas", extra="pandas")
        return pd.DataFrame(self.to_records(), columns=list(COLUMNS))

    def to_csv(self) -> str:
        """The table as CSV text."""
        import csv
        import io

        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=list(COLUMNS), extrasaction="ignore", lineterminator="\n")
        w.writeheader()
        for r in self.rows:
            w.writerow({k: _csv_value(r.get(k)) for k in COLUMNS})
        return buf.getvalue()


def _csv_value(v: Any) -> Any:
    if v is None:
        return ""
    if isinstance(v, float):
        return "" if not math.isfinite(v) else repr(v)
    return v


# --------------------------------------------------------------------------- work
def _file_digest(path: Path) -> str:
    h = hashlib.sha256()
    try:
        with path.open("rb") as fh:
            for chunk in iter(lambda: fh.read(1 << 20), b""):
                h.update(chunk)
    except OSError as exc:
        return f"unreadable:{exc.strerror}"
    return h.hexdigest()


def _cache_key(task: Mapping[str, Any]) -> str:
    from . import __version__

    payload = {k: v for k, v in task.items() if k not in ("file",)}
    payload["digest"] = _file_digest(Path(task["file"]))
    payload["version"] = __version__
    return hashlib.sha256(json.dumps(payload, sort_keys=True, default=str).encode()).hexdigest()


def _nan(x: Any) -> float:
    return math.nan if x is None else float(x)


def process_measurement(task: Mapping[str, Any]) -> dict[str, Any]:
    """Run the stiffness pipeline on one measurement (a picklable worker for any executor).

    Parameters
    ----------
    task : mapping
        ``file``, ``rig`` (path), ``k_ms``, ``k_ms_std``, ``speed_hz``, ``band``, ``max_order``.

    Returns
    -------
    dict
        The result columns: ``status`` ("ok" or "error"), ``k_TB`` ... ``error``. Errors of the
        measurement (bad file, no housing mode) are returned in ``error``, never raised, so that one
        bad file does not stop a campaign.
    """
    from ._blas import single_threaded

    # one BLAS thread per measurement: the matrices are small, and with --jobs N the N workers
    # would otherwise each start a thread per core and fight over the cores
    with single_threaded():
        return _process_measurement(task)


def _process_measurement(task: Mapping[str, Any]) -> dict[str, Any]:
    from .io.uff import read_uff58
    from .rig.stiffness import estimate_stiffness

    t0 = time.perf_counter()
    out: dict[str, Any] = {"status": "error", "error": ""}
    try:
        rig = load_rig(task["rig"])
        data = read_uff58(task["file"], rig=rig)
        res = estimate_stiffness(
            data, rig, k_ms=task["k_ms"], k_ms_std=task.get("k_ms_std"),
            speed_hz=task.get("speed_hz"),
            band=None if task.get("band") is None else tuple(task["band"]),
            max_order=task.get("max_order"),
        )
        d = res.to_dict()
        hm = d.get("housing_mode") or {}
        sm = d.get("spindle_mode") or {}
        out.update(
            status="ok",
            k_TB=_nan(d.get("k_TB")),
            k_TB_std=_nan(d.get("k_TB_std")),
            k_TB_MS=_nan(d.get("k_TB_MS")),
            k_MS=_nan(d.get("k_MS")),
            housing_freq=_nan(hm.get("natural_freq")),
            housing_freq_std=_nan(hm.get("natural_freq_std")),
            housing_damping=_nan(hm.get("damping_ratio")),
            spindle_freq=_nan(sm.get("natural_freq")),
            spindle_damping=_nan(sm.get("damping_ratio")),
        )
        out["detail"] = d
    except EmaRigError as exc:
        out["error"] = str(exc)
    except Exception as exc:  # a bug or an unexpected file: recorded in the row and the log
        logger.exception("measurement %s failed unexpectedly", task.get("file"))
        out["error"] = f"internal error ({type(exc).__name__}): {exc}"
    out["elapsed_s"] = time.perf_counter() - t0
    return out


def _calibrate_task(task: Mapping[str, Any]) -> dict[str, Any]:
    from .io.uff import read_uff58
    from .rig.stiffness import calibrate

    try:
        rig = load_rig(task["rig"])
        data = read_uff58(task["file"], rig=rig)
        res = calibrate(
            data, rig, k_disk=task.get("k_disk"),
            band=None if task.get("band") is None else tuple(task["band"]),
            max_order=task.get("max_order"),
        )
        d = res.to_dict()
        d["status"] = "ok"
        d["error"] = ""
        return d
    except EmaRigError as exc:
        return {"status": "error", "error": str(exc)}


def _load_cached(path: Path, key: str) -> dict[str, Any] | None:
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    if doc.get("cache_key") != key:
        return None
    return doc


def _floatify(doc: dict[str, Any]) -> dict[str, Any]:
    """JSON null back to NaN for the numeric columns."""
    for k in ("radial_load", "shaft_position", "k_TB", "k_TB_std", "k_TB_MS", "k_MS", "housing_freq",
              "housing_freq_std", "housing_damping", "spindle_freq", "spindle_damping", "elapsed_s"):
        if k in doc and doc[k] is None:
            doc[k] = math.nan
    return doc


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
        ``campaign.csv``, the figures and ``report.html`` are written at the end. Without it,
        nothing is written and nothing can be reused.
    jobs : int, optional
        Number of worker processes when no ``executor`` is given (1 = in this process).
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

    Notes
    -----
    A measurement is reused when its JSON result exists and the hash of its file content and of
    every setting it depends on (rig, k_MS, band, order, speed, ema_rig version) is unchanged, so
    a run killed halfway loses only the measurements that were in flight.
    """
    cfg = campaign if isinstance(campaign, CampaignConfig) else load_campaign(campaign)
    out = None if out_dir is None else Path(out_dir)
    res_dir = None if out is None else out / "results"
    if res_dir is not None:
        res_dir.mkdir(parents=True, exist_ok=True)
    if jobs < 1:
        raise ValueError(f"jobs must be >= 1, got {jobs}")

    own_pool: Executor | None = None
    if executor is None and jobs > 1:
        own_pool = executor = ProcessPoolExecutor(max_workers=jobs)
    try:
        # 1. k_MS from the steel disk (or the rig file)
        k_ms, k_ms_std = cfg.rig.model.k_MS, None
        calib: dict[str, Any] | None = None
        if cfg.calibration is not None:
            ctask = {"file": str(cfg.calibration), "rig": str(cfg.rig_file), "k_disk": cfg.k_disk,
                     "band": None, "max_order": cfg.max_order, "kind": "calibration"}
            ckey = _cache_key(ctask)
            cpath = None if res_dir is None else res_dir / "_calibration.json"
            calib = None if (force or cpath is None) else _load_cached(cpath, ckey)
            if calib is None:
                calib = _calibrate_task(ctask)
                calib["cache_key"] = ckey
                calib["file"] = str(cfg.calibration)
                if cpath is not None:
                    _atomic.write_json(cpath, calib)
            if calib["status"] == "ok":
                k_ms, k_ms_std = float(calib["k_MS"]), calib.get("k_MS_std")
            else:
                logger.warning("calibration failed (%s); using k_MS from the rig file", calib["error"])

        # 2. the measurements
        tasks = []
        for m in cfg.measurements:
            t = {"file": str(m.file), "rig": str(cfg.rig_file), "k_ms": k_ms, "k_ms_std": k_ms_std,
                 "speed_hz": m.speed / 60.0 if m.speed > 0 else None,
                 "band": None if cfg.band is None else list(cfg.band), "max_order": cfg.max_order,
                 "model": cfg.rig.model.as_dict(), "uncertainty": dict(cfg.rig.uncertainty)}
            tasks.append((m, t, _cache_key(t)))

        rows: dict[str, dict[str, Any]] = {}
        todo = []
        for m, t, key in tasks:
            cached = None if (force or res_dir is None) else _load_cached(res_dir / f"{m.id}.json", key)
            if cached is not None:
                rows[m.id] = _floatify(cached)
            else:
                todo.append((m, t, key))
        reused = len(rows)

        bar = _progress(progress, len(tasks), reused)

        def finish(m: Measurement, key: str, result: dict[str, Any]) -> None:
            blank = {c: math.nan for c in COLUMNS}  # every column in every row, errors included
            row = {**blank, **m.conditions(), **result, "cache_key": key}
            rows[m.id] = row
            if res_dir is not None:
                _atomic.write_json(res_dir / f"{m.id}.json", row)
            bar(1)

        if executor is None:
            for m, t, key in todo:
                finish(m, key, process_measurement(t))
        else:
            futs: dict[Future[dict[str, Any]], tuple[Measurement, str]] = {
                executor.submit(process_measurement, t): (m, key) for m, t, key in todo
            }
            for fut in as_completed(futs):
                m, key = futs[fut]
                try:
                    outcome = fut.result()
                except Exception as exc:  # the worker died (killed process, lost dask worker)
                    outcome = {"status": "error", "error": f"worker failed ({type(exc).__name__}): {exc}"}
                finish(m, key, outcome)
        bar(None)
    finally:
        if own_pool is not None:
            own_pool.shutdown()

    ordered = tuple(
        {c: rows[m.id].get(c, math.nan if c not in ("error", "status") else "") for c in COLUMNS}
        | {"detail": rows[m.id].get("detail")}
        for m in cfg.measurements
    )
    result = CampaignResult(
        config=cfg, rows=ordered, calibration=calib, k_MS=k_ms, k_MS_std=k_ms_std,
        out_dir=out, computed=len(todo), reused=reused,
    )
    if out is not None and report:
        files = write_outputs(result, out)
        result = dataclasses.replace(result, files=files)
    return result


def _progress(progress: bool | Callable[[int, int], None], total: int, initial: int) -> Callable[[int | None], None]:
    """A tiny adapter: ``step(1)`` advances, ``step(None)`` closes."""
    if callable(progress):
        state = {"done": initial}

        def step(n: int | None) -> None:
            if n is not None:
                state["done"] += n
                progress(state["done"], total)  # type: ignore[operator]

        return step
    if progress:
        from tqdm.auto import tqdm

        pbar = tqdm(total=total, initial=initial, desc="measurements", unit="meas", disable=None)

        def step(n: int | None) -> None:
            if n is None:
                pbar.close()
            else:
                pbar.update(n)

        return step
    return lambda n: None


def write_outputs(result: CampaignResult, out_dir: str | PathLike[str]) -> dict[str, Path]:
    """Write the table (CSV), the resolved settings (JSON), the figures and the HTML report.

    Returns
    -------
    dict
        Output kind -> path.
    """
    from .plot.campaign import campaign_figures
    from .report import write_report

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    files: dict[str, Path] = {}
    files["table"] = out / "campaign.csv"
    _atomic.write_text(files["table"], result.to_csv())
    files["settings"] = out / "settings.json"
    _atomic.write_json(files["settings"], {**result.config.settings(), "k_MS_used": result.k_MS,
                                           "k_MS_std_used": result.k_MS_std,
                                           "calibration": _strip(result.calibration)})
    for name, fig in campaign_figures(result).items():  # pyplot-free Figures: nothing to close
        path = out / f"{name}.png"
        with _atomic.atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=120)
        files[name] = path
    files["report"] = out / "report.html"
    write_report(result, files["report"], {k: v for k, v in files.items() if v.suffix == ".png"})
    return files


def _strip(d: Mapping[str, Any] | None) -> dict[str, Any] | None:
    if d is None:
        return None
    return {k: v for k, v in d.items() if k not in ("candidates",)}


def summary_rows(result: CampaignResult) -> Iterable[dict[str, Any]]:
    """Rows for a compact console table: id, conditions, k_TB ± std, housing mode, status."""
    for r in result.rows:
        yield {
            "id": r["id"],
            "bearing": r["bearing"],
            "load [N]": r["radial_load"],
            "speed [rpm]": r["speed"],
            "k_TB [N/m]": r["k_TB"],
            "± [N/m]": r["k_TB_std"],
            "f_H [Hz]": r["housing_freq"],
            "status": r["status"] if r["status"] == "ok" else f"error: {r['error']}",
        }


__all__ = [
    "BearingInfo",
    "COLUMNS",
    "CampaignConfig",
    "CampaignResult",
    "Measurement",
    "load_campaign",
    "process_measurement",
    "run",
    "summary_rows",
    "write_outputs",
]
