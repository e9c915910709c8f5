"""Rig and campaign configuration files (TOML) into validated, frozen dataclasses.

The rig file's keys are a stable interface (README, "The rig file")::

    [model]                # all seven keys required, SI units
    m_H, m_S, m_F, k_MS, k_AS, k_S, k_B
    [excitation]
    radial = "11+Y"        # required; reference DOF of the radial shaker
    axial = "15+X"         # optional second reference
    [[sensor]]             # one per accelerometer
    dof = "13-Y"; role = "housing" | "spindle"; axis = "radial" | "lateral" | "axial"

Optional tables (extensions, all keys optional):

- ``[uncertainty]``: relative standard uncertainty (fraction, 0.01 = 1 %) of any of the seven
  model parameters, used by the k_TB uncertainty budget; ``force_chain``: that of the FRF scale
  (force sensor x accelerometer calibration); stating it trusts the force chain, so the
  driving-point modal mass measures ``m_H``.
- ``[identification]``: ``band = [lo, hi]`` (Hz), ``max_order`` (int, the cap of the adaptive order),
  ``k_MS_band = [lo, hi]``, ``refine`` (bool: maximum-likelihood refinement after PolyMAX),
  ``n_averages`` (number of averages behind the FRFs and coherence, >= 1).
- ``[units]``: ``prefer = "code" | "label"``: which wins when a UFF unit label contradicts the
  ordinate data-type code (default: a conflict is an error).
- ``[rig]``: ``name``, ``description`` (free text).
- ``[calibration]``: ``k_disk`` (the steel disk's own stiffness [N/m], e.g. from FE; it acts in
  series with ``k_MS`` during the calibration) and ``k_disk_std`` (its standard uncertainty [N/m];
  needs ``k_disk``). Without ``k_disk`` the disk is assumed rigid, with a model-form term.
- ``[[mass]]`` (one table per attached mass: an impedance head, a fixture, cables): ``mass`` [kg,
  required], ``on = "housing" | "spindle"`` (required), ``mass_std`` [kg, default 10 % of
  ``mass``], ``position = [x, y, z]`` [m, from the housing's centre of mass: x axial, y radial,
  z lateral; optional], ``name``.
- ``[[sensor]]`` optional keys ``mass`` [kg], ``mass_std`` [kg, default 10 % of ``mass``] and
  ``position = [x, y, z]`` [m]: the accelerometer's own mass rides on the body of its ``role``.
- ``[housing]``: ``inertia_x``, ``inertia_z`` [kg m^2], the bare housing's rotary inertia about the
  axial (x) and lateral (z) axes through its centre of mass (tilt), and ``inertia_x_std``,
  ``inertia_z_std`` [kg m^2, default 10 % of the inertia]. With the radial housing sensors'
  positions, the housing's tilt modes give its tilt stiffness per axis; attached masses with a
  position add ``m r^2`` about each axis.

Attached masses are carried by the model: ``RigConfig.model`` holds the effective
``m_H = [model] m_H + masses on the housing`` (``m_S`` likewise); ``declared_model`` the
``[model]`` table as written. Their tolerances add in quadrature to the ``m_H`` (``m_S``)
tolerance, so ``RigConfig.uncertainty`` carries the relative tolerance of the effective mass.

Functions
---------
load_rig, parse_rig
    Read a rig file / a mapping into a :class:`RigConfig`.
"""

from __future__ import annotations

import difflib
import math
import os
import stat
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from os import PathLike
from pathlib import Path
from typing import Any

from .dof import DOF
from .errors import ConfigError
from .io.units import response_unit

MODEL_KEYS: tuple[str, ...] = ("m_H", "m_S", "m_F", "k_MS", "k_AS", "k_S", "k_B")
SENSOR_ROLES: tuple[str, ...] = ("housing", "spindle")
SENSOR_AXES: tuple[str, ...] = ("radial", "lateral", "axial")
_TOP_KEYS = ("model", "excitation", "sensor", "uncertainty", "identification", "units", "rig", "calibration",
             "mass", "housing")
MASS_BODIES: tuple[str, ...] = ("housing", "spindle")
DEFAULT_ADDED_MASS_REL_STD = 0.10
"""Relative standard uncertainty of an attached mass without ``mass_std``: a datasheet mass leaves
out the cable, stud, wax or glue (a few grams on a 10 g accelerometer)."""

#: Table 1 of the paper (SI) and what each parameter is: the centre of the plausible ranges.
_TABLE1: dict[str, tuple[float, str]] = {
    "m_H": (2.566, "a housing mass"), "m_S": (2.8, "an equivalent spindle mass"),
    "m_F": (205.0, "an equivalent frame mass"), "k_MS": (114e6, "a mounting stiffness"),
    "k_AS": (650e3, "an air-spring stiffness"), "k_S": (348e6, "a spindle bending stiffness"),
    "k_B": (180e3, "a bushing stiffness"),
}
PLAUSIBLE_SPAN = 100.0
"""A rig parameter is plausible within Table 1 of the paper divided or multiplied by this factor:
rigs of another size pass, a unit slip (N/m for MN/m, kN/m, g or t for kg: factors 1e3, 1e6) does not."""


def implausible(key: str, v: float) -> str | None:
    """Why the rig parameter ``key`` = ``v`` (SI) is implausible, with the unit it was probably meant in; None
    when it lies within Table 1 of the paper ×/÷ :data:`PLAUSIBLE_SPAN`.

    Parameters
    ----------
    key : {'m_H', 'm_S', 'm_F', 'k_MS', 'k_AS', 'k_S', 'k_B'}
    v : float
        The value [kg or N/m].

    Returns
    -------
    str or None
        E.g. ``k_MS = 114 N/m is implausible for a mounting stiffness (...); did you mean 114e6 (MN/m)?``
    """
    ref, what = _TABLE1[key]
    lo, hi = ref / PLAUSIBLE_SPAN, ref * PLAUSIBLE_SPAN
    if lo <= v <= hi:
        return None
    mass = key.startswith("m_")
    unit = "kg" if mass else "N/m"
    # a unit slip (MN/m or kN/m typed as N/m, g or t as kg) or three or six zeros too many
    scales = ((1e-3, "g"), (1e3, "t")) if mass else ((1e6, "MN/m"), (1e3, "kN/m"), (1e-3, ""), (1e-6, ""))
    hint = ""
    for f, name in scales:
        if lo <= v * f <= hi:
            hint = (f"; did you mean {v * f:g} kg ({v:g} {name})?" if mass
                    else f"; did you mean {v * f:g} N/m?" if f < 1
                    else f"; did you mean {v:g}e{round(math.log10(f)):d} ({name})?")
            break
    return (f"{key} = {v:g} {unit} is implausible for {what} (expected {lo:g} .. {hi:g} {unit}, "
            f"Table 1 of the paper x/÷ {PLAUSIBLE_SPAN:g}){hint}")


def check_plausible(model: ModelParams, file: str | None) -> None:
    """Refuse a rig parameter outside its plausible range, with the unit it was probably meant in.

    Raises
    ------
    ConfigError
        E.g. ``k_MS = 114 N/m is implausible for a mounting stiffness; did you mean 114e6 (MN/m)?``
    """
    for key in _TABLE1:
        why = implausible(key, float(getattr(model, key)))
        if why is not None:
            raise ConfigError(why, file=file, key=f"model.{key}")


@dataclass(frozen=True, slots=True)
class ModelParams:
    """Parameters of the 3DOF rig model (paper Table 1), SI units.

    Parameters
    ----------
    m_H, m_S, m_F : float
        Housing, equivalent spindle and equivalent frame mass [kg].
    k_MS, k_AS, k_S, k_B : float
        Mounting-system, air-spring, spindle-bending and bushing stiffness [N/m].
    """

    m_H: float
    m_S: float
    m_F: float
    k_MS: float
    k_AS: float
    k_S: float
    k_B: float

    def as_dict(self) -> dict[str, float]:
        """The seven parameters as a plain dict."""
        return {k: getattr(self, k) for k in MODEL_KEYS}


@dataclass(frozen=True, slots=True)
class Sensor:
    """One accelerometer: its DOF as written in the UFF file, its role and its axis.

    Parameters
    ----------
    dof : DOF
        Node and signed direction as written in the UFF file (``13-Y`` measures along -Y).
    role : str
        ``'housing'`` or ``'spindle'``.
    axis : str
        ``'radial'``, ``'lateral'`` or ``'axial'``.
    mass, mass_std : float, optional
        The sensor's mass and its standard uncertainty [kg] (0 when the rig file does not give it).
    position : (float, float, float) or None, optional
        ``(x, y, z)`` [m] from the housing's centre of mass (x axial, y radial, z lateral).
    """

    dof: DOF
    role: str
    axis: str
    mass: float = 0.0
    mass_std: float = 0.0
    position: tuple[float, float, float] | None = None


@dataclass(frozen=True, slots=True)
class AddedMass:
    """A mass attached to the housing or the spindle (a sensor, an impedance head, a fixture).

    Attributes
    ----------
    name : str
        ``[[mass]] name`` or ``"sensor <dof>"``.
    mass, mass_std : float
        Mass and its standard uncertainty [kg].
    body : str
        ``'housing'`` or ``'spindle'``.
    position : tuple of float or None
        ``(x, y, z)`` [m] from the housing's centre of mass (x axial, y radial, z lateral).
    """

    name: str
    mass: float
    mass_std: float
    body: str
    position: tuple[float, float, float] | None = None


DEFAULT_INERTIA_REL_STD = DEFAULT_ADDED_MASS_REL_STD
"""Relative standard uncertainty of a ``[housing]`` rotary inertia without its ``_std``: that of a
datasheet mass (a CAD inertia leaves out bolts, cables and glue alike)."""

MAX_INERTIA_RADIUS = 1.0
"""A housing's radius of gyration above this [m] is refused as a unit slip (kg mm^2 or g cm^2 typed
as kg m^2): a test-bearing housing is a few centimetres across."""


@dataclass(frozen=True, slots=True)
class RotaryInertia:
    """The bare housing's rotary inertia about its centre of mass (``[housing]``), per tilt axis.

    Attributes
    ----------
    x, x_std : float or None
        About the axial (x) axis and its standard uncertainty [kg m^2] (None: not stated).
    z, z_std : float or None
        About the lateral (z) axis and its standard uncertainty [kg m^2].
    """

    x: float | None = None
    x_std: float | None = None
    z: float | None = None
    z_std: float | None = None

    def about(self, axis: str) -> tuple[float, float] | None:
        """``(inertia, std)`` [kg m^2] about ``'x'`` or ``'z'``, or None when not stated."""
        v, sd = (self.x, self.x_std) if axis == "x" else (self.z, self.z_std)
        return None if v is None or sd is None else (v, sd)


@dataclass(frozen=True, slots=True)
class RigConfig:
    """A validated rig configuration.

    Attributes
    ----------
    model : ModelParams
    radial : DOF
        Reference DOF of the radial shaker (as written in the file).
    axial : DOF or None
        Reference DOF of the axial shaker.
    sensors : tuple of Sensor
    uncertainty : dict
        Relative standard uncertainty per model parameter (fraction).
    identification : dict
        Optional defaults: ``band`` (lo, hi) Hz, ``max_order``, ``k_MS_band``.
    unit_preference : str or None
        ``'code'`` or ``'label'``: which wins in a UFF unit conflict.
    unit_ordinate : str or None
        ``[units] ordinate``: the response unit (e.g. ``"g"``) of FRF datasets without a unit label.
    k_disk : float or None
        Calibration disk stiffness [N/m] (``[calibration]``); None = assumed rigid.
    k_disk_std : float or None
        Its standard uncertainty [N/m].
    name : str
    path : str or None
        File it was read from (for messages; excluded from cache keys: the content counts).
    added_masses : tuple of AddedMass
        Attached masses (``[[mass]]`` tables and sensor masses); already in ``model``.
    declared_model : ModelParams or None
        The ``[model]`` table as written (None: same as ``model``, no attached masses).
    force_chain : float or None
        ``[uncertainty] force_chain``: relative standard uncertainty of the FRF scale (force
        sensor times accelerometer sensitivity). Given, the force chain is trusted: the
        driving-point modal mass measures ``m_H``. None: not trusted.
    rotary_inertia : RotaryInertia or None
        ``[housing]``: the bare housing's rotary inertia per tilt axis (None: the table is absent).
    """

    model: ModelParams
    radial: DOF
    axial: DOF | None
    sensors: tuple[Sensor, ...]
    uncertainty: Mapping[str, float] = field(default_factory=dict)
    identification: Mapping[str, Any] = field(default_factory=dict)
    unit_preference: str | None = None
    unit_ordinate: str | None = None
    k_disk: float | None = None
    k_disk_std: float | None = None
    name: str = ""
    # where it was read from: named in messages, but not part of what a result depends on
    path: str | None = field(default=None, metadata={"cache_key": False})
    added_masses: tuple[AddedMass, ...] = ()
    declared_model: ModelParams | None = None
    force_chain: float | None = None
    rotary_inertia: RotaryInertia | None = None

    def sensor_for(self, dof: DOF) -> Sensor | None:
        """The sensor whose node and axis match ``dof`` (sign ignored), or None."""
        for s in self.sensors:
            if s.dof.same_axis(dof):
                return s
        return None

    @property
    def references(self) -> tuple[DOF, ...]:
        """Reference DOFs: radial, then axial when given."""
        return (self.radial,) if self.axial is None else (self.radial, self.axial)


# ---------------------------------------------------------------- strict TOML value checks
# One set of checks for every TOML file of ema_rig (rig and campaign): bool is not a number, a
# string is not a bool, integers outside TOML's 64-bit range are refused, every error names the
# key path.
_INT64 = 2**63


def short_repr(v: Any) -> str:
    """``repr`` of a value, shortened so a 5000-digit integer does not flood the message.

    Parameters
    ----------
    v : object
        Any value.
    """
    text = repr(v)
    return text if len(text) <= 40 else f"{text[:30]}... ({len(text)} characters)"


def _int64(v: int, key: str, file: str | None) -> None:
    if not -_INT64 <= v < _INT64:
        raise ConfigError(
            f"integer with {len(str(abs(v)))} digits is outside the 64-bit range TOML allows",
            file=file, key=key,
        )


def toml_number(v: Any, key: str, file: str | None, *, lo: float | None = None, lo_open: bool = False) -> float:
    """A finite number (TOML integer or float, never a bool or a string), optionally bounded below.

    Parameters
    ----------
    v : object
        The parsed TOML value.
    key : str
        Dotted key path for the message, e.g. ``"measurement[3].speed"``.
    file : str or None
        The TOML file, for the message.
    lo : float, optional
        Lower bound; ``lo_open=True`` excludes it (``lo=0, lo_open=True``: positive).
    lo_open : bool, optional
        Whether ``lo`` itself is refused.

    Returns
    -------
    float

    Raises
    ------
    ConfigError
        For a non-number, a huge integer, NaN/inf or a value below the bound.
    """
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ConfigError(f"must be a number, got {short_repr(v)}", file=file, key=key)
    if isinstance(v, int):
        _int64(v, key, file)
    x = float(v)
    if not math.isfinite(x):
        raise ConfigError(f"must be a finite number, got {short_repr(v)}", file=file, key=key)
    if lo is not None and (x < lo or (lo_open and x == lo)):
        what = "a finite positive number" if (lo == 0 and lo_open) else f"{'>' if lo_open else '>='} {lo:g}"
        raise ConfigError(f"must be {what}, got {short_repr(v)}", file=file, key=key)
    return x


def toml_int(v: Any, key: str, file: str | None, *, lo: int | None = None) -> int:
    """An integer (never a bool or a float) inside TOML's 64-bit range, optionally ``>= lo``.

    Parameters
    ----------
    v : object
        The parsed TOML value.
    key : str
        Its key path (named in the error).
    file : str or None
        The TOML file (named in the error).
    lo : int, optional
        Smallest value allowed.
    """
    if isinstance(v, bool) or not isinstance(v, int):
        raise ConfigError(f"must be an integer, got {short_repr(v)}", file=file, key=key)
    _int64(v, key, file)
    if lo is not None and v < lo:
        raise ConfigError(f"must be an integer >= {lo}, got {short_repr(v)}", file=file, key=key)
    return v


def toml_bool(v: Any, key: str, file: str | None) -> bool:
    """``true`` or ``false`` (a string such as ``"false"`` or a number is an error).

    Parameters
    ----------
    v : object
        The parsed TOML value.
    key : str
        Its key path (named in the error).
    file : str or None
        The TOML file (named in the error).
    """
    if not isinstance(v, bool):
        raise ConfigError(f"must be true or false, got {short_repr(v)}", file=file, key=key)
    return v


def toml_str(v: Any, key: str, file: str | None, *, nonempty: bool = False) -> str:
    """A string (a number or a bool is an error), optionally not empty.

    Parameters
    ----------
    v : object
        The parsed TOML value.
    key : str
        Its key path (named in the error).
    file : str or None
        The TOML file (named in the error).
    nonempty : bool, optional
        Refuse an empty or blank string.
    """
    if not isinstance(v, str):
        raise ConfigError(f"must be a string, got {short_repr(v)}", file=file, key=key)
    if nonempty and not v.strip():
        raise ConfigError("must not be empty", file=file, key=key)
    return v


def check_keys(table: Mapping[str, Any], allowed: tuple[str, ...], where: str, file: str | None) -> None:
    """Refuse a key of ``table`` that is not in ``allowed``, naming it and the allowed keys.

    Parameters
    ----------
    table : mapping
        A parsed TOML table.
    allowed : tuple of str
        Its allowed keys.
    where : str
        Key path of the table (empty at the top level).
    file : str or None
        The TOML file (named in the error).
    """
    for k in table:
        if k not in allowed:
            key = f"{where}.{k}" if where else k
            # a misspelt key (radial_laod, bnad) names its nearest allowed key, as a misspelt option does
            near = difflib.get_close_matches(str(k), allowed, n=1, cutoff=0.6)
            hint = f"did you mean {near[0]}? " if near else ""
            raise ConfigError(
                f"unknown key; {hint}allowed keys here are {', '.join(allowed)}", file=file, key=key
            )


def toml_table(doc: Mapping[str, Any], name: str, file: str | None, *, required: bool,
               where: str = "") -> Mapping[str, Any]:
    """The sub-table ``doc[name]`` (empty when absent and not required).

    Parameters
    ----------
    doc : mapping
        The parsed TOML document or table.
    name : str
        The sub-table's name.
    file : str or None
        The TOML file (named in the error).
    required : bool
        Whether an absent table is an error.
    where : str, optional
        Key path of ``doc`` (empty at the top level).
    """
    key = f"{where}.{name}" if where else name
    if name not in doc:
        if required:
            raise ConfigError(f"missing required table [{key}]", file=file, key=key)
        return {}
    t = doc[name]
    if not isinstance(t, Mapping):
        raise ConfigError(f"must be a table [{key}]", file=file, key=key)
    return t


def toml_band(v: Any, key: str, file: str | None) -> tuple[float, float]:
    """A frequency band ``[lo, hi]`` in Hz with ``0 <= lo < hi``.

    Parameters
    ----------
    v : object
        The parsed TOML value (a two-element array).
    key : str
        Its key path (named in the error).
    file : str or None
        The TOML file (named in the error).
    """
    if not isinstance(v, (list, tuple)) or len(v) != 2:
        raise ConfigError(f"must be a pair [lo, hi] in Hz, got {short_repr(v)}", file=file, key=key)
    lo = toml_number(v[0], key, file, lo=0.0)
    hi = toml_number(v[1], key, file, lo=0.0, lo_open=True)
    if not lo < hi:
        raise ConfigError(f"must satisfy 0 <= lo < hi, got {short_repr(v)}", file=file, key=key)
    return lo, hi


def parse_disk(t: Mapping[str, Any], prefix: str, file: str | None) -> tuple[float | None, float | None]:
    """``k_disk`` (> 0) and ``k_disk_std`` (>= 0, needs ``k_disk``) [N/m] of a table, each optional.

    ``prefix`` is the key path of the table (``"calibration."`` in the rig file, ``""`` at the top
    of a campaign file), for the error messages.

    Parameters
    ----------
    t : mapping
        The TOML table holding ``k_disk`` / ``k_disk_std``.
    prefix : str
        Key path of the table, with its trailing dot.
    file : str or None
        The TOML file (named in the error).
    """
    k_disk = (CONDITION_RANGES["k_disk"].check(toml_number(t["k_disk"], f"{prefix}k_disk", file, lo=0.0, lo_open=True),
                                               f"{prefix}k_disk", file) if "k_disk" in t else None)
    std = None
    if "k_disk_std" in t:
        std = toml_number(t["k_disk_std"], f"{prefix}k_disk_std", file, lo=0.0)
        if k_disk is None:
            raise ConfigError(
                f"needs {prefix}k_disk (the stiffness it is the uncertainty of)", file=file, key=f"{prefix}k_disk_std"
            )
    return k_disk, std


def _dof(v: Any, key: str, file: str | None) -> DOF:
    if not isinstance(v, str):
        raise ConfigError(f"must be a DOF string such as '11+Y', got {short_repr(v)}", file=file, key=key)
    if len(v) > 40:  # no DOF is this long; keep the message short
        raise ConfigError(f"must be a DOF string such as '11+Y', got {short_repr(v)}", file=file, key=key)
    try:
        d = DOF.parse(v)
    except ValueError as exc:
        raise ConfigError(str(exc), file=file, key=key) from None
    if d.direction == 0:
        raise ConfigError(f"DOF {short_repr(v)} needs a signed direction such as '11+Y'", file=file, key=key)
    return d


def parse_rig(doc: Mapping[str, Any], *, file: str | PathLike[str] | None = None) -> RigConfig:
    """Validate a parsed rig TOML document.

    Parameters
    ----------
    doc : mapping
        The TOML document as returned by :func:`tomllib.load`.
    file : str or path-like, optional
        Used in error messages.

    Returns
    -------
    RigConfig

    Raises
    ------
    ConfigError
        Naming the key path and the allowed values.
    """
    fname = None if file is None else str(file)
    check_keys(doc, _TOP_KEYS, "", fname)
    m = toml_table(doc, "model", fname, required=True)
    check_keys(m, MODEL_KEYS, "model", fname)
    for k in MODEL_KEYS:
        if k not in m:
            raise ConfigError(
                f"missing required key (the [model] table needs {', '.join(MODEL_KEYS)})",
                file=fname,
                key=f"model.{k}",
            )
    model = ModelParams(**{k: MODEL_RANGES[k[0]].check(toml_number(m[k], f"model.{k}", fname, lo=0.0, lo_open=True),
                                                         f"model.{k}", fname) for k in MODEL_KEYS})
    check_plausible(model, fname)

    ex = toml_table(doc, "excitation", fname, required=True)
    check_keys(ex, ("radial", "axial"), "excitation", fname)
    if "radial" not in ex:
        raise ConfigError("missing required key (reference DOF of the radial shaker)", file=fname, key="excitation.radial")
    radial = _dof(ex["radial"], "excitation.radial", fname)
    axial = _dof(ex["axial"], "excitation.axial", fname) if "axial" in ex else None
    if axial is not None and axial.positive() == radial.positive():
        raise ConfigError("axial and radial references are the same DOF", file=fname, key="excitation.axial")

    raw_sensors = doc.get("sensor")
    if raw_sensors is None:
        raise ConfigError("missing required [[sensor]] tables (one per accelerometer)", file=fname, key="sensor")
    if not isinstance(raw_sensors, list) or not raw_sensors:
        raise ConfigError("must be a non-empty array of tables [[sensor]]", file=fname, key="sensor")
    sensors: list[Sensor] = []
    seen: dict[tuple[int, int], int] = {}
    for i, s in enumerate(raw_sensors):
        where = f"sensor[{i}]"
        if not isinstance(s, Mapping):
            raise ConfigError("must be a table", file=fname, key=where)
        check_keys(s, ("dof", "role", "axis", "name", "mass", "mass_std", "position"), where, fname)
        for req in ("dof", "role", "axis"):
            if req not in s:
                raise ConfigError("missing required key (dof, role, axis)", file=fname, key=f"{where}.{req}")
        dof = _dof(s["dof"], f"{where}.dof", fname)
        role, axis = s["role"], s["axis"]
        if role not in SENSOR_ROLES:
            raise ConfigError(f"must be one of {', '.join(SENSOR_ROLES)}, got {short_repr(role)}", file=fname, key=f"{where}.role")
        if axis not in SENSOR_AXES:
            raise ConfigError(f"must be one of {', '.join(SENSOR_AXES)}, got {short_repr(axis)}", file=fname, key=f"{where}.axis")
        node_axis = (dof.node, abs(dof.direction))
        if node_axis in seen:
            raise ConfigError(
                f"DOF {dof} is already used by sensor[{seen[node_axis]}]", file=fname, key=f"{where}.dof"
            )
        seen[node_axis] = i
        s_mass, s_std = _mass_and_std(s, where, fname, required=False)
        sensors.append(Sensor(dof, role, axis, s_mass, s_std, _position(s, where, fname)))

    unc_t = toml_table(doc, "uncertainty", fname, required=False)
    check_keys(unc_t, (*MODEL_KEYS, "force_chain"), "uncertainty", fname)
    uncertainty = {}
    force_chain = None
    for k, v in unc_t.items():
        x = toml_number(v, f"uncertainty.{k}", fname)
        if not 0 <= x < 1:
            raise ConfigError(
                f"is a relative standard uncertainty (fraction, 0.01 = 1 %), must be in [0, 1), got {short_repr(v)}",
                file=fname,
                key=f"uncertainty.{k}",
            )
        if k == "force_chain":
            force_chain = x
        else:
            uncertainty[k] = x

    id_t = toml_table(doc, "identification", fname, required=False)
    check_keys(id_t, ("band", "max_order", "k_MS_band", "refine", "n_averages"), "identification", fname)
    ident: dict[str, Any] = {}
    for k in ("band", "k_MS_band"):
        if k in id_t:
            ident[k] = toml_band(id_t[k], f"identification.{k}", fname)
    if "max_order" in id_t:
        ident["max_order"] = toml_int(id_t["max_order"], "identification.max_order", fname, lo=2)
    if "refine" in id_t:
        ident["refine"] = toml_bool(id_t["refine"], "identification.refine", fname)
    if "n_averages" in id_t:
        ident["n_averages"] = toml_number(id_t["n_averages"], "identification.n_averages", fname, lo=1.0)

    units_t = toml_table(doc, "units", fname, required=False)
    check_keys(units_t, ("prefer", "ordinate"), "units", fname)
    pref = units_t.get("prefer")
    if pref is not None and pref not in ("code", "label"):
        raise ConfigError(f"must be 'code' or 'label', got {short_repr(pref)}", file=fname, key="units.prefer")
    ordinate = None
    if "ordinate" in units_t:
        ordinate = toml_str(units_t["ordinate"], "units.ordinate", fname, nonempty=True)
        try:
            response_unit(ordinate)
        except ValueError as exc:
            raise ConfigError(str(exc), file=fname, key="units.ordinate") from None

    rig_t = toml_table(doc, "rig", fname, required=False)
    check_keys(rig_t, ("name", "description"), "rig", fname)
    if "description" in rig_t:
        toml_str(rig_t["description"], "rig.description", fname)

    cal_t = toml_table(doc, "calibration", fname, required=False)
    check_keys(cal_t, ("k_disk", "k_disk_std"), "calibration", fname)
    k_disk, k_disk_std = parse_disk(cal_t, "calibration.", fname)

    added = [AddedMass(f"sensor {se.dof}", se.mass, se.mass_std, se.role, se.position)
             for se in sensors if se.mass > 0]
    raw_masses = doc.get("mass", [])
    if not isinstance(raw_masses, list):
        raise ConfigError("must be an array of tables [[mass]]", file=fname, key="mass")
    for i, t in enumerate(raw_masses):
        where = f"mass[{i}]"
        if not isinstance(t, Mapping):
            raise ConfigError("must be a table", file=fname, key=where)
        check_keys(t, ("name", "mass", "mass_std", "on", "position"), where, fname)
        if "on" not in t:
            raise ConfigError("missing required key (the body it sits on: housing or spindle)", file=fname,
                              key=f"{where}.on")
        if t["on"] not in MASS_BODIES:
            raise ConfigError(f"must be one of {', '.join(MASS_BODIES)}, got {short_repr(t['on'])}", file=fname,
                              key=f"{where}.on")
        a_mass, a_std = _mass_and_std(t, where, fname, required=True)
        added.append(AddedMass(toml_str(t.get("name", f"mass[{i}]"), f"{where}.name", fname), a_mass, a_std,
                               str(t["on"]), _position(t, where, fname)))
    declared = model
    inertia = _rotary_inertia(doc, model.m_H, fname)
    if added:
        model, uncertainty = _with_added_masses(model, uncertainty, added)

    return RigConfig(
        model=model,
        radial=radial,
        axial=axial,
        sensors=tuple(sensors),
        uncertainty=uncertainty,
        identification=ident,
        unit_preference=pref,
        unit_ordinate=ordinate,
        k_disk=k_disk,
        k_disk_std=k_disk_std,
        name=toml_str(rig_t.get("name", ""), "rig.name", fname),
        path=fname,
        added_masses=tuple(added),
        declared_model=declared if added else None,
        force_chain=force_chain,
        rotary_inertia=inertia,
    )


def _rotary_inertia(doc: Mapping[str, Any], m_h: float, file: str | None) -> RotaryInertia | None:
    """The ``[housing]`` table: rotary inertia about x and z [kg m^2] with their stds, or None."""
    t = toml_table(doc, "housing", file, required=False)
    check_keys(t, ("inertia_x", "inertia_x_std", "inertia_z", "inertia_z_std"), "housing", file)
    if not t:
        return None
    vals: dict[str, float | None] = {}
    for ax in ("x", "z"):
        key = f"inertia_{ax}"
        if key not in t:
            if f"{key}_std" in t:
                raise ConfigError(f"needs {key} (the inertia it is the uncertainty of)", file=file,
                                  key=f"housing.{key}_std")
            vals[ax] = vals[f"{ax}_std"] = None
            continue
        v = toml_number(t[key], f"housing.{key}", file, lo=0.0, lo_open=True)
        if v > m_h * MAX_INERTIA_RADIUS**2:
            raise ConfigError(
                f"= {v:g} kg m^2 is a radius of gyration of {math.sqrt(v / m_h):.3g} m for the {m_h:g} kg housing: "
                f"implausible; did you mean {v * 1e-6:g} kg m^2 (from kg mm^2)?", file=file, key=f"housing.{key}")
        vals[ax] = v
        vals[f"{ax}_std"] = (toml_number(t[f"{key}_std"], f"housing.{key}_std", file, lo=0.0)
                             if f"{key}_std" in t else DEFAULT_INERTIA_REL_STD * v)
    return RotaryInertia(x=vals["x"], x_std=vals["x_std"], z=vals["z"], z_std=vals["z_std"])


def _mass_and_std(t: Mapping[str, Any], where: str, file: str | None, *, required: bool) -> tuple[float, float]:
    """``mass`` [kg] (> 0; 0 when absent and not required) and ``mass_std`` [kg] of a table."""
    if "mass" not in t:
        if required:
            raise ConfigError("missing required key (the attached mass in kg)", file=file, key=f"{where}.mass")
        if "mass_std" in t:
            raise ConfigError("needs mass (the mass it is the uncertainty of)", file=file, key=f"{where}.mass_std")
        return 0.0, 0.0
    mass = toml_number(t["mass"], f"{where}.mass", file, lo=0.0, lo_open=True)
    std = (toml_number(t["mass_std"], f"{where}.mass_std", file, lo=0.0) if "mass_std" in t
           else DEFAULT_ADDED_MASS_REL_STD * mass)
    return mass, std


def _position(t: Mapping[str, Any], where: str, file: str | None) -> tuple[float, float, float] | None:
    """``position = [x, y, z]`` [m] of a table, or None."""
    if "position" not in t:
        return None
    v = t["position"]
    if not isinstance(v, list) or len(v) != 3:
        raise ConfigError(f"must be [x, y, z] in metres, got {short_repr(v)}", file=file, key=f"{where}.position")
    x, y, z = (toml_number(c, f"{where}.position[{j}]", file) for j, c in enumerate(v))
    return (x, y, z)


def _with_added_masses(model: ModelParams, uncertainty: dict[str, float],
                       added: list[AddedMass]) -> tuple[ModelParams, dict[str, float]]:
    """Effective ``m_H``/``m_S`` with the attached masses and the tolerance of each sum.

    ``u(m_eff)^2 = (u_rel m)^2 + sum_i u(m_i)^2`` with ``u_rel`` the ``[uncertainty]`` value,
    else the default of :data:`ema_rig.rig.uncertainty.DEFAULT_REL_UNCERTAINTY` (0.5 % for m_H,
    2 % for m_S, repeated here so the config layer does not import the rig layer).
    """
    default_rel = {"m_H": 0.005, "m_S": 0.02}
    unc = dict(uncertainty)
    new: dict[str, float] = {}
    for body, key in (("housing", "m_H"), ("spindle", "m_S")):
        on = [a for a in added if a.body == body]
        if not on:
            continue
        m0 = float(getattr(model, key))
        rel0 = unc.get(key, default_rel[key])
        m_eff = m0 + sum(a.mass for a in on)
        var = (rel0 * m0) ** 2 + sum(a.mass_std**2 for a in on)
        new[key] = m_eff
        unc[key] = math.sqrt(var) / m_eff
    return replace(model, **new), unc


#: Largest TOML file read [bytes]; rig and campaign files are a few kB.
MAX_TOML_BYTES = 16 * 1024 * 1024


def read_regular_file(path: str | PathLike[str], *, max_bytes: int) -> bytes:
    """The bytes of a regular file, refusing FIFOs, devices and directories without blocking.

    The file is opened non-blocking and checked with ``fstat`` on the open descriptor, so a FIFO
    or a device given as a file name gives an error instead of a hang (or an endless read).

    Parameters
    ----------
    path : str or path-like
        The file.
    max_bytes : int
        Largest size read; a larger file is refused.

    Raises
    ------
    OSError
        When the file cannot be opened (not found, permission).
    ValueError
        When it is not a regular file or larger than ``max_bytes``; the message names no file.
    """
    fd = os.open(os.fspath(path), os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    try:
        st = os.fstat(fd)
        if stat.S_ISDIR(st.st_mode):
            raise IsADirectoryError(21, "is a directory", os.fspath(path))
        if not stat.S_ISREG(st.st_mode):
            raise ValueError("is not a regular file (a FIFO, socket or device?)")
        if st.st_size > max_bytes:
            raise ValueError(f"is {st.st_size} bytes, larger than the {max_bytes} bytes allowed")
        with os.fdopen(fd, "rb", closefd=False) as fh:
            return fh.read(max_bytes + 1)
    finally:
        os.close(fd)


def _refuse_uff(p: Path, raw: bytes) -> None:
    """Raise a ConfigError that names a UFF measurement given where a TOML file belongs."""
    # the UFF reader loads numpy: imported on this error path only, so loading a campaign stays light
    from .io.uff import starts_like_uff

    if starts_like_uff(raw[:65536]):
        raise ConfigError("is a UFF file (a measurement), not a TOML file: identify it with "
                          "'ema-rig modes FILE', or give it to 'ema-rig stiffness FILE --rig RIG.toml'; "
                          "a campaign file lists such files under [[measurement]]", file=p)


def read_toml(path: str | PathLike[str]) -> dict[str, Any]:
    """Read a TOML file, turning IO and syntax errors into :class:`ConfigError`.

    Only regular files up to :data:`MAX_TOML_BYTES` are read (a FIFO or device is refused at once).

    Parameters
    ----------
    path : str or path-like
        The TOML file.
    """
    p = Path(path)
    try:
        raw = read_regular_file(p, max_bytes=MAX_TOML_BYTES)
        return tomllib.loads(raw.decode("utf-8"))
    except FileNotFoundError:
        raise ConfigError("file not found", file=p) from None
    except IsADirectoryError:
        raise ConfigError("is a directory, expected a TOML file", file=p) from None
    except PermissionError:
        raise ConfigError("permission denied", file=p) from None
    except OSError as exc:
        raise ConfigError(f"cannot read: {exc.strerror or exc}", file=p) from None
    except tomllib.TOMLDecodeError as exc:
        _refuse_uff(p, raw)
        raise ConfigError(f"invalid TOML: {exc}", file=p) from None
    except UnicodeDecodeError as exc:
        _refuse_uff(p, raw)
        raise ConfigError(f"not UTF-8 text: {exc.reason}", file=p) from None
    except ValueError as exc:
        raise ConfigError(str(exc), file=p) from None


def load_rig(path: str | PathLike[str]) -> RigConfig:
    """Read and validate a rig configuration file.

    Parameters
    ----------
    path : str or path-like
        TOML file with the tables above (README, "The rig file").

    Returns
    -------
    RigConfig

    Raises
    ------
    ConfigError
        If the file is missing, not TOML, or a key is missing, unknown or invalid.
    """
    doc = read_toml(path)
    if "measurement" in doc and "model" not in doc:
        raise ConfigError("this is a campaign file, not a rig file: run it with 'ema-rig campaign FILE', "
                          "or give the rig file it names", file=path)
    return parse_rig(doc, file=path)


#: Geometry keys of a ``[bearings.NAME]`` table (SI units), see :func:`parse_bearing_geometry`.
BEARING_GEOMETRY_KEYS: tuple[str, ...] = (
    "n_balls", "ball_diameter", "pitch_diameter", "clearance", "inner_conformity", "outer_conformity",
    "youngs_modulus", "poisson_ratio", "ball_youngs_modulus", "ball_poisson_ratio",
)
_GEOMETRY_REQUIRED = ("n_balls", "ball_diameter", "pitch_diameter")


@dataclass(frozen=True, slots=True)
class KeyRange:
    """The physically plausible range of a numeric key, its unit and where the range comes from.

    Parameters
    ----------
    lo, hi : float
        Lower and upper limit, in ``unit``.
    unit : str
        Unit of the key (for the message).
    source : str
        Where the range comes from (named in the message).
    lo_open : bool, optional
        Whether ``lo`` itself is refused.
    zero_ok : bool, optional
        Whether 0 is allowed besides ``[lo, hi]`` (a clearance of exactly zero).
    """

    lo: float
    hi: float
    unit: str
    source: str
    lo_open: bool = False
    zero_ok: bool = False  # 0 is allowed besides [lo, hi] (a clearance of exactly zero)

    def check(self, v: float, key: str, file: str | None) -> float:
        """``v`` when inside the range, else a :class:`ConfigError` naming ``key`` and the source."""
        inside = (self.lo < v if self.lo_open else self.lo <= v) and v <= self.hi
        if inside or (self.zero_ok and v == 0.0):
            return v
        rng = f"{'(' if self.lo_open else '['}{self.lo:g}, {self.hi:g}] {self.unit}".rstrip()
        if self.zero_ok:
            rng = f"0 or {rng}"
        raise ConfigError(f"{v:g} is outside the plausible range {rng} ({self.source})", file=file, key=key)


#: Plausible ranges of the rig model's masses (``m_*``) and stiffnesses (``k_*``): they refuse
#: values that overflow or underflow the model's eigenproblems (1e-300 kg, 1e308 N/m).
MODEL_RANGES: dict[str, KeyRange] = {
    "m": KeyRange(1e-3, 1e6, "kg", "a gram (a sensor) to 1000 t (a machine foundation); the paper's "
                  "rig: 2.566 kg housing, 205 kg frame"),
    "k": KeyRange(1e1, 1e13, "N/m", "from a soft air spring (~1e3 N/m) to 1e13 N/m, 1000 times the stiffest "
                  "rolling-bearing contacts (~1e10 N/m, Harris & Kotzalas); Table 1: 180e3 to 348e6"),
}
#: Plausible ranges of the measurement conditions of a campaign.
CONDITION_RANGES: dict[str, KeyRange] = {
    "radial_load": KeyRange(0.0, 1e8, "N", "above the static load ratings of the largest bearings (~1e7 N)"),
    "speed": KeyRange(0.0, 5e5, "rpm", "the ball bearings of dental air turbines, the fastest rolling bearings "
                      "in service, run at 3.5-4.5e5 rpm"),
    "shaft_position": KeyRange(-360.0, 360.0, "deg", "an angle of the shaft within one turn either way"),
    "k_disk": KeyRange(1e3, 1e15, "N/m", "a steel disk is far stiffer than the bearing it replaces "
                       "(1e7-1e10 N/m)"),
}
#: Plausible ranges of the bearing geometry keys (SI), each with its source. They refuse typing
#: slips (millimetres for metres, GPa for Pa) and values that would underflow or overflow the
#: Hertz formulas (a clearance of 5e-324 m, a modulus of 1e308 Pa) when the campaign is loaded.
GEOMETRY_RANGES: dict[str, KeyRange] = {
    "n_balls": KeyRange(3, 1000, "", "a ball bearing has at least 3 balls; slewing rings stay below 1000"),
    "ball_diameter": KeyRange(1e-4, 0.5, "m", "ISO 3290-1 balls start at 0.3 mm; above 0.5 m a length in mm "
                              "was typed as metres (7.938 mm is 7.938e-3)"),
    "pitch_diameter": KeyRange(5e-4, 10.0, "m", "the smallest miniature bearings (1 mm bore) have a ~2 mm "
                               "pitch circle; above 10 m a length in mm was typed as metres"),
    "clearance": KeyRange(1e-9, 1e-3, "m", "ISO 5753-1 radial internal clearances are 0 to a few hundred µm; "
                          "below 1 nm write 0", zero_ok=True),
    "inner_conformity": KeyRange(0.5, 1.0, "", "groove radius / ball diameter, 0.515-0.54 in deep-groove "
                                 "bearings (Harris & Kotzalas); must exceed 0.5", lo_open=True),
    "outer_conformity": KeyRange(0.5, 1.0, "", "groove radius / ball diameter, 0.515-0.54 in deep-groove "
                                 "bearings (Harris & Kotzalas); must exceed 0.5", lo_open=True),
    "youngs_modulus": KeyRange(1e8, 1.2e12, "Pa", "from PTFE (0.4 GPa) to diamond (1.2 TPa), Ashby's "
                               "modulus chart; bearing steel is 208e9"),
    "ball_youngs_modulus": KeyRange(1e8, 1.2e12, "Pa", "from PTFE (0.4 GPa) to diamond (1.2 TPa), Ashby's "
                                    "modulus chart; silicon nitride is 310e9"),
    "poisson_ratio": KeyRange(0.0, 0.5, "", "isotropic solids: 0 <= nu < 0.5", ),
    "ball_poisson_ratio": KeyRange(0.0, 0.5, "", "isotropic solids: 0 <= nu < 0.5"),
}


def parse_bearing_geometry(t: Mapping[str, Any], where: str, file: str | None) -> Any:
    """The deep-groove ball-bearing geometry of a bearing table, or None when it gives none.

    Keys (SI units): ``n_balls``, ``ball_diameter`` [m], ``pitch_diameter`` [m] (all three
    required once any geometry key is given), ``clearance`` (diametral radial clearance [m],
    default 0), ``inner_conformity`` / ``outer_conformity`` (groove radius / ball diameter,
    default 0.52), ``youngs_modulus`` [Pa] and ``poisson_ratio`` of the rings (default steel,
    208 GPa, 0.3), ``ball_youngs_modulus`` / ``ball_poisson_ratio`` when the balls differ.
    The 6302 of the paper::

        [bearings.6302]
        n_balls = 7
        ball_diameter = 7.938e-3
        pitch_diameter = 28.5e-3

    Parameters
    ----------
    t : mapping
        The ``[bearings.NAME]`` table.
    where : str
        Its key path (``bearings.NAME``), for the messages.
    file : str or None
        The TOML file (named in the error).

    Returns
    -------
    BallBearingGeometry or None

    Raises
    ------
    ConfigError
        Naming the key: a missing required key, a wrong type, a value out of range, or a
        geometry that cannot exist (balls larger than the pitch circle, too many balls).
    """
    from .rig.hertz import BallBearingGeometry

    given = [k for k in BEARING_GEOMETRY_KEYS if k in t]
    if not given:
        return None
    for k in _GEOMETRY_REQUIRED:
        if k not in t:
            raise ConfigError(f"missing required key (the bearing geometry also gives {', '.join(given)})",
                              file=file, key=f"{where}.{k}")
    kw: dict[str, Any] = {"n_balls": toml_int(t["n_balls"], f"{where}.n_balls", file, lo=3)}
    GEOMETRY_RANGES["n_balls"].check(kw["n_balls"], f"{where}.n_balls", file)
    for k in given:
        if k == "n_balls":
            continue
        v = toml_number(t[k], f"{where}.{k}", file, lo=0.0, lo_open=k != "clearance" and "poisson" not in k)
        if "poisson" in k and not v < 0.5:
            raise ConfigError(f"must lie in [0, 0.5), got {v:g}", file=file, key=f"{where}.{k}")
        kw[k] = GEOMETRY_RANGES[k].check(v, f"{where}.{k}", file)
    try:
        geometry = BallBearingGeometry(**kw)
    except ValueError as exc:
        raise ConfigError(str(exc), file=file, key=where) from None
    check_hertz_curve(geometry, (1.0, 1e5), where, file)
    return geometry


def check_hertz_curve(geometry: Any, loads: tuple[float, ...], where: str, file: str | None) -> None:
    """Evaluate the Hertzian stiffness of ``geometry`` at ``loads`` [N]; refuse it if that fails.

    Run when the file is loaded, so that a geometry whose Hertz curve cannot be drawn is refused
    before any measurement is computed, never after.

    Parameters
    ----------
    geometry : BallBearingGeometry
        The bearing geometry.
    loads : tuple of float
        Radial loads [N] the campaign measures at.
    where : str
        Key path of the bearing table (``bearings.NAME``).
    file : str or None
        The TOML file (named in the error).

    Raises
    ------
    ConfigError
        Naming ``where`` (``bearings.NAME``) when a stiffness is not finite and positive or the
        computation fails.
    """
    import numpy as np

    from .rig.hertz import ball_bearing_radial_stiffness

    try:
        with np.errstate(all="raise"):
            k = np.asarray(ball_bearing_radial_stiffness(np.asarray(loads, dtype=float), geometry), dtype=float)
    except (ArithmeticError, ValueError, FloatingPointError, RuntimeError) as exc:
        raise ConfigError(f"the Hertz estimate of this geometry cannot be computed ({type(exc).__name__}: "
                          f"{exc})", file=file, key=where) from None
    if not (np.all(np.isfinite(k)) and np.all(k[np.asarray(loads) > 0] > 0)):
        raise ConfigError("the Hertz estimate of this geometry is not a finite positive stiffness "
                          f"between {min(loads):g} and {max(loads):g} N", file=file, key=where)


__all__ = [
    "AddedMass",
    "BEARING_GEOMETRY_KEYS",
    "CONDITION_RANGES",
    "GEOMETRY_RANGES",
    "KeyRange",
    "MODEL_RANGES",
    "MAX_TOML_BYTES",
    "MODEL_KEYS",
    "ModelParams",
    "RigConfig",
    "RotaryInertia",
    "SENSOR_AXES",
    "SENSOR_ROLES",
    "Sensor",
    "check_hertz_curve",
    "check_keys",
    "load_rig",
    "parse_bearing_geometry",
    "parse_rig",
    "read_regular_file",
    "read_toml",
    "short_repr",
    "parse_disk",
    "toml_band",
    "toml_bool",
    "toml_int",
    "toml_number",
    "toml_str",
    "toml_table",
]
