"""The campaign file (TOML) into validated, frozen dataclasses.

Every value is type-checked strictly with the TOML helpers of :mod:`ema_rig.config` (bool is not a
number, a string is not a bool, integers outside the 64-bit range are refused), and every error
names the file and the key path. Measurement ids become file names (``results/<id>.json``), so
they are validated too: no path separators, no leading dot or underscore, not empty, unique after
normalisation (Unicode NFC and case folding, as on a case-insensitive file system).
"""

from __future__ import annotations

import dataclasses
import math
import os
import stat
import unicodedata
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from typing import Any

from ..config import (
    BEARING_GEOMETRY_KEYS,
    CONDITION_RANGES,
    RigConfig,
    check_hertz_curve,
    check_keys,
    load_rig,
    parse_bearing_geometry,
    parse_disk,
    read_toml,
    short_repr,
    toml_band,
    toml_bool,
    toml_int,
    toml_number,
    toml_str,
    toml_table,
)
from ..errors import ConfigError, EmaRigError

_TOP_KEYS = ("rig", "calibration", "k_disk", "k_disk_std", "title", "defaults", "bearings", "measurement", "output")
_MEAS_KEYS = ("file", "bearing", "radial_load", "speed", "shaft_position", "repeat", "tags", "id", "selection")
_DEFAULT_KEYS = ("band", "max_order", "selection")
_BEARING_KEYS = ("k_lower", "k_upper", "hertz", "label", "selection", *BEARING_GEOMETRY_KEYS)
_OUTPUT_KEYS = ("stiffness_unit", "damping_unit", "measurement_figures")

#: Characters refused in a measurement id: path separators and what some file systems reserve.
_ID_FORBIDDEN = '/\\:*?"<>|'
_ID_MAX_BYTES = 150
_WINDOWS_NAMES = {"con", "prn", "aux", "nul", *(f"com{i}" for i in range(10)), *(f"lpt{i}" for i in range(10))}


@dataclass(frozen=True, slots=True)
class Measurement:
    """One measurement of a campaign and its conditions.

    Attributes
    ----------
    id : str
        Unique name (default: the file stem); a safe file name (see :func:`check_id`).
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
    selection : Path or None
        A saved mode selection (JSON, e.g. picked with ``PolePicker``) replayed on this
        measurement instead of the automatic identification: the measurement's own
        ``selection``, else its bearing's (``[bearings.NAME] selection``), else
        ``[defaults] selection``.
    """

    id: str
    file: Path
    bearing: str = ""
    radial_load: float = math.nan
    speed: float = 0.0
    shaft_position: float = math.nan
    repeat: int = 1
    tags: tuple[str, ...] = ()
    selection: Path | None = None

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
    """Reference information drawn beside a bearing's results (FE bounds, Hertz curve).

    Attributes
    ----------
    k_lower, k_upper : float or None
        FE bounds of the stiffness [N/m], drawn as a band.
    hertz : bool
        Draw the Hertzian estimate (needs ``geometry``; true by default when a geometry is given).
    label : str
    geometry : BallBearingGeometry or None
        Deep-groove ball-bearing geometry (``[bearings.NAME]`` keys ``n_balls``, ``ball_diameter``
        ...); a bearing named ``6302`` with ``hertz = true`` and no geometry gets the paper's.
    """

    k_lower: float | None = None
    k_upper: float | None = None
    hertz: bool = False
    label: str = ""
    geometry: Any = None


@dataclass(frozen=True, slots=True)
class CampaignConfig:
    """A validated campaign file.

    Attributes
    ----------
    path : Path or None
    rig_file : Path
    rig : RigConfig
        The resolved rig; what the measurements depend on is its content, never its path.
    calibration : Path or None
        Steel-disk measurement giving k_MS.
    k_disk : float or None
        Stiffness of the steel disk [N/m] (None: infinitely stiff): the campaign's ``k_disk``,
        else the rig file's ``[calibration] k_disk``.
    k_disk_std : float or None
        Its standard uncertainty [N/m] (from the same file as ``k_disk``).
    band : tuple of float or None
        Identification band [Hz] (None: the rig file's, else the pipeline's default).
    max_order : int or None
    bearings : mapping of str to BearingInfo
    measurements : tuple of Measurement
    title : str
    stiffness_unit : str
        Stiffness unit of the CSV (``[output] stiffness_unit``: N/m, MN/m or N/µm).
    damping_unit : str
        Damping unit of the CSV (``[output] damping_unit``: ``-`` for a fraction, or ``%``).
    measurement_figures : bool
        Draw each measurement's figures for the report (``[output] measurement_figures``, default
        true; about a second per measurement on the first run, reused afterwards).
    """

    rig_file: Path
    rig: RigConfig
    measurements: tuple[Measurement, ...]
    calibration: Path | None = None
    k_disk: float | None = None
    k_disk_std: float | None = None
    band: tuple[float, float] | None = None
    max_order: int | None = None
    bearings: Mapping[str, BearingInfo] = field(default_factory=dict)
    title: str = "ema_rig campaign"
    path: Path | None = None
    stiffness_unit: str = "N/m"
    damping_unit: str = "-"
    measurement_figures: bool = True

    def settings(self) -> dict[str, Any]:
        """The resolved settings, as written to ``settings.json`` and the report."""
        return {
            "campaign": str(self.path) if self.path else None,
            "rig_file": str(self.rig_file),
            "model": self.rig.model.as_dict(),
            "radial": str(self.rig.radial),
            "axial": None if self.rig.axial is None else str(self.rig.axial),
            "sensors": [[str(s.dof), s.role, s.axis] for s in self.rig.sensors],
            "uncertainty": dict(self.rig.uncertainty),
            "identification": {k: list(v) if isinstance(v, tuple) else v
                               for k, v in self.rig.identification.items()},
            "unit_preference": self.rig.unit_preference,
            "unit_ordinate": self.rig.unit_ordinate,
            "calibration": None if self.calibration is None else str(self.calibration),
            "k_disk": self.k_disk,
            "k_disk_std": self.k_disk_std,
            "band": None if self.band is None else list(self.band),
            "max_order": self.max_order,
        }


def normalized_id(mid: str) -> str:
    """The form under which two ids are the same file on some file system (NFC, case-folded).

    Parameters
    ----------
    mid : str
        A measurement id.
    """
    return unicodedata.normalize("NFC", mid).casefold()


def check_id(mid: str, key: str, file: str | None, *, derived: bool = False) -> str:
    """Validate a measurement id as a safe file name and return it.

    Parameters
    ----------
    mid : str
        The id.
    key : str
        Key path for the message.
    file : str or None
        The campaign file, for the message.
    derived : bool, optional
        True when the id was derived from the file name (the message then says to give one).

    Raises
    ------
    ConfigError
        For an empty id, one with a path separator or a reserved character, a leading dot or
        underscore (``_`` names are ema_rig's own files, such as the calibration's cache), control
        characters, surrounding blanks, a reserved device name, or more than 150 bytes.
    """
    hint = " (derived from the file name; give an explicit id)" if derived else ""

    def bad(what: str) -> ConfigError:
        return ConfigError(f"measurement id {short_repr(mid)} {what}{hint}", file=file, key=key)

    if not mid:
        raise bad("is empty")
    if mid != mid.strip():
        raise bad("starts or ends with blanks")
    if any(ch in _ID_FORBIDDEN for ch in mid):
        raise bad(f"contains one of {_ID_FORBIDDEN} (ids become file names)")
    odd = next((ch for ch in mid if unicodedata.category(ch).startswith("C")), None)
    if odd is not None:
        raise bad(_invisible(odd))
    if mid.startswith("."):
        raise bad("starts with '.' (ids become file names)")
    if mid.startswith("_"):
        raise bad("starts with '_' (reserved for ema_rig's own files)")
    if mid.split(".")[0].casefold() in _WINDOWS_NAMES:
        raise bad("is a reserved device name on Windows")
    if len(mid.encode("utf-8")) > _ID_MAX_BYTES:
        raise bad(f"is longer than {_ID_MAX_BYTES} bytes")
    return mid


def _invisible(ch: str) -> str:
    """Why an id with this character (Unicode category C*) is refused, naming the character."""
    cat = unicodedata.category(ch)
    name = unicodedata.name(ch, "unnamed")
    what = {"Cc": "a control character", "Cf": "an invisible format character", "Cs": "a lone surrogate",
            "Co": "a private-use character", "Cn": "an unassigned code point"}.get(cat, "an invisible character")
    return (f"contains {what}, U+{ord(ch):04X} {name} (ids become file names and table cells; "
            "use letters, digits, '-', '_' and '.')")


def _existing_file(v: Any, key: str, fname: str, base: Path) -> Path:
    """A path key that must name an existing regular file (stat only: a FIFO is never opened)."""
    q = (base / toml_str(v, key, fname, nonempty=True)).resolve()
    shown = str(q) if len(str(q)) <= 200 else short_repr(str(q))
    try:
        st = os.stat(q)
    except FileNotFoundError:
        raise ConfigError(f"file not found: {shown}", file=fname, key=key) from None
    except OSError as exc:
        raise ConfigError(f"cannot access {shown}: {exc.strerror}", file=fname, key=key) from None
    if not stat.S_ISREG(st.st_mode):
        raise ConfigError(f"not a regular file: {shown}", file=fname, key=key)
    return q


def _selection_file(table: Mapping[str, Any], where: str, fname: str, base: Path) -> Path | None:
    """The ``selection`` key of a table: an existing mode-selection JSON file, or None."""
    if "selection" not in table:
        return None
    key = f"{where}.selection"
    q = _existing_file(table["selection"], key, fname, base)
    from ..identification import Selection

    try:
        Selection.from_json(q)
    except (EmaRigError, OSError, UnicodeDecodeError) as exc:
        msg = exc.message if isinstance(exc, EmaRigError) else str(exc)
        raise ConfigError(f"{q.name}: {msg}", file=fname, key=key) from None
    return q


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
        missing keys, values of the wrong type, bad or duplicate ids, and missing files.
    """
    p = Path(path).resolve()
    fname = str(path)
    doc = read_toml(p)
    if "model" in doc and "measurement" not in doc:
        raise ConfigError("this is a rig file, not a campaign file (README, 'Campaign file'): a campaign names "
                          "it with rig = \"...\" and lists [[measurement]] tables", file=fname)
    check_keys(doc, _TOP_KEYS, "", fname)
    base = p.parent

    if "rig" not in doc:
        raise ConfigError("missing required key (path of the rig file)", file=fname, key="rig")
    rig_file = _existing_file(doc["rig"], "rig", fname, base)
    rig = load_rig(rig_file)
    calibration = _existing_file(doc["calibration"], "calibration", fname, base) if "calibration" in doc else None
    k_disk, k_disk_std = parse_disk(doc, "", fname)
    if k_disk is not None:  # the campaign's disk wins over the rig file's [calibration]
        rig = dataclasses.replace(rig, k_disk=k_disk, k_disk_std=k_disk_std)
    k_disk, k_disk_std = rig.k_disk, rig.k_disk_std
    title = toml_str(doc["title"], "title", fname) if "title" in doc else p.stem

    defaults = toml_table(doc, "defaults", fname, required=False)
    check_keys(defaults, _DEFAULT_KEYS, "defaults", fname)
    band = toml_band(defaults["band"], "defaults.band", fname) if "band" in defaults else None
    max_order = toml_int(defaults["max_order"], "defaults.max_order", fname, lo=2) if "max_order" in defaults else None
    default_sel = _selection_file(defaults, "defaults", fname, base)
    bearing_sel: dict[str, Path | None] = {}

    bearings: dict[str, BearingInfo] = {}
    raw_b = toml_table(doc, "bearings", fname, required=False)
    for name, t in raw_b.items():
        where = f"bearings.{name}"
        if not isinstance(t, Mapping):
            raise ConfigError("must be a table", file=fname, key=where)
        check_keys(t, _BEARING_KEYS, where, fname)
        k_lo = toml_number(t["k_lower"], f"{where}.k_lower", fname, lo=0.0, lo_open=True) if "k_lower" in t else None
        k_hi = toml_number(t["k_upper"], f"{where}.k_upper", fname, lo=0.0, lo_open=True) if "k_upper" in t else None
        if k_lo is not None and k_hi is not None and k_hi < k_lo:
            raise ConfigError("k_upper must be >= k_lower", file=fname, key=where)
        geometry = parse_bearing_geometry(t, where, fname)
        hertz = toml_bool(t["hertz"], f"{where}.hertz", fname) if "hertz" in t else geometry is not None
        if hertz and geometry is None:
            if str(name) != "6302":
                raise ConfigError("hertz = true needs the bearing geometry (n_balls, ball_diameter, "
                                  "pitch_diameter [m]); only 6302 has a built-in one", file=fname,
                                  key=f"{where}.hertz")
            from ..rig.hertz import BEARING_6302

            geometry = BEARING_6302
        label = toml_str(t["label"], f"{where}.label", fname) if "label" in t else ""
        bearing_sel[str(name)] = _selection_file(t, where, fname, base)
        bearings[str(name)] = BearingInfo(k_lo, k_hi, hertz, label, geometry)

    output = toml_table(doc, "output", fname, required=False)
    check_keys(output, _OUTPUT_KEYS, "output", fname)
    units: dict[str, Any] = {}
    if "measurement_figures" in output:
        units["measurement_figures"] = toml_bool(output["measurement_figures"], "output.measurement_figures", fname)
    for k, allowed in (("stiffness_unit", ("N/m", "MN/m", "N/µm", "N/um")), ("damping_unit", ("-", "%"))):
        if k in output:
            v = toml_str(output[k], f"output.{k}", fname)
            # U+03BC (Greek mu, what most keyboards type) is the same unit as U+00B5 (micro sign)
            v = v.replace("\u03bc", "\u00b5") if k == "stiffness_unit" else v
            if v not in allowed:
                raise ConfigError(f"must be one of {', '.join(repr(a) for a in allowed)}, got {short_repr(v)}",
                                  file=fname, key=f"output.{k}")
            units[k] = v

    raw = doc.get("measurement")
    if not isinstance(raw, list) or not raw:
        raise ConfigError("needs at least one [[measurement]] table", file=fname, key="measurement")
    meas: list[Measurement] = []
    seen: dict[str, int] = {}
    for i, m in enumerate(raw):
        where = f"measurement[{i}]"
        if not isinstance(m, Mapping):
            raise ConfigError("must be a table", file=fname, key=where)
        check_keys(m, _MEAS_KEYS, where, fname)
        if "file" not in m:
            raise ConfigError("missing required key 'file'", file=fname, key=f"{where}.file")
        rel = toml_str(m["file"], f"{where}.file", fname, nonempty=True)
        fpath = (base / rel).resolve()  # a missing or unreadable file is a row error, not fatal
        if "id" in m:
            mid = check_id(toml_str(m["id"], f"{where}.id", fname), f"{where}.id", fname)
        else:
            mid = check_id(Path(rel).stem, f"{where}.id", fname, derived=True)
        norm = normalized_id(mid)
        if norm in seen:
            raise ConfigError(
                f"duplicate measurement id {short_repr(mid)} (also measurement[{seen[norm]}], ids are compared "
                "ignoring case); give an explicit id",
                file=fname, key=f"{where}.id",
            )
        seen[norm] = i
        tags = m.get("tags", [])
        if isinstance(tags, str):
            tags = [tags]
        if not isinstance(tags, list) or not all(isinstance(t, str) for t in tags):
            raise ConfigError("must be a list of strings", file=fname, key=f"{where}.tags")

        def num(k: str, default: float, lo: float | None, w: str = where, mm: Mapping[str, Any] = m) -> float:
            if k not in mm:
                return default
            v = toml_number(mm[k], f"{w}.{k}", fname, lo=lo)
            return CONDITION_RANGES[k].check(v, f"{w}.{k}", fname) if k in CONDITION_RANGES else v

        bearing = toml_str(m["bearing"], f"{where}.bearing", fname) if "bearing" in m else ""
        sel = _selection_file(m, where, fname, base)
        if sel is None:
            sel = bearing_sel.get(bearing) or default_sel
        meas.append(
            Measurement(
                id=mid,
                file=fpath,
                bearing=bearing,
                radial_load=num("radial_load", math.nan, 0.0),
                speed=num("speed", 0.0, 0.0),
                shaft_position=num("shaft_position", math.nan, None),
                repeat=toml_int(m["repeat"], f"{where}.repeat", fname, lo=1) if "repeat" in m else 1,
                tags=tuple(tags),
                selection=sel,
            )
        )
    for name, info in bearings.items():  # the Hertz curve is drawn over these loads after the measurements
        loads = [m.radial_load for m in meas if m.bearing == name and m.radial_load > 0]
        if info.hertz and info.geometry is not None and loads:
            check_hertz_curve(info.geometry, (max(min(loads) * 0.8, 1.0), max(loads) * 1.15),
                              f"bearings.{name}", fname)
    return CampaignConfig(
        rig_file=rig_file, rig=rig, measurements=tuple(meas), calibration=calibration, k_disk=k_disk,
        k_disk_std=k_disk_std, band=band, max_order=max_order, bearings=bearings, title=title, path=p, **units,
    )


__all__ = ["BearingInfo", "CampaignConfig", "Measurement", "check_id", "load_campaign", "normalized_id"]
