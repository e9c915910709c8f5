"""Private: unit decisions for UFF dataset-58 FRFs (ordinate codes, unit labels, dataset 164).

A unit label such as ``"g"``, ``"m/s^2"``, ``"(m/s)/N"``, ``"(1/N)*(m/s²)"`` or ``"in/s2/lbf"``
is parsed into dimensions (length, time, force exponents) and a factor to SI. The ordinate
specific data type code (8 displacement, 11 velocity, 12 acceleration; denominator 13 or 9
force) gives the quantity. Code and label must agree; when they do not, the rig file's
``[units] prefer`` decides, else it is an error.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import Any

G0 = 9.80665
"""Standard gravity in m/s^2 (exact, CGPM 1901)."""
LBF = 4.4482216152605
"""One pound-force in N (exact by definition)."""
INCH = 0.0254

# atom: (length, time, force) exponents and factor to SI
_ATOMS: dict[str, tuple[tuple[int, int, int], float]] = {
    "m": ((1, 0, 0), 1.0),
    "mm": ((1, 0, 0), 1e-3),
    "cm": ((1, 0, 0), 1e-2),
    "um": ((1, 0, 0), 1e-6),
    "in": ((1, 0, 0), INCH),
    "inch": ((1, 0, 0), INCH),
    "ft": ((1, 0, 0), 0.3048),
    "s": ((0, 1, 0), 1.0),
    "sec": ((0, 1, 0), 1.0),
    "n": ((0, 0, 1), 1.0),
    "kn": ((0, 0, 1), 1e3),
    "lbf": ((0, 0, 1), LBF),
    "lb": ((0, 0, 1), LBF),
    "g": ((1, -2, 0), G0),
}
_TOKEN = re.compile(r"\s*(?:([a-z]+)(?:\^?(-?\d+))?|(1)|(\))(?:\^?(-?\d+))?|([(*/]))")
_FORM_DIMS = {(1, 0, 0): "receptance", (1, -1, 0): "mobility", (1, -2, 0): "accelerance"}
_CODE_FORM = {8: "receptance", 11: "mobility", 12: "accelerance"}
_CODE_NAMES = {
    0: "unknown", 1: "general", 2: "stress", 3: "strain", 5: "temperature", 6: "heat flux",
    8: "displacement", 9: "reaction force", 11: "velocity", 12: "acceleration", 13: "excitation force",
    15: "pressure", 16: "mass", 17: "time", 18: "frequency", 19: "rpm", 20: "order",
}
_NO_LABEL = {"", "none", "nounits", "-", "n/a", "unknown"}
MAX_UNIT_POWER = 12
"""Largest exponent magnitude accepted in a unit label or a header unit exponent (real units
use 1..3); beyond it a label such as ``mm^120*m^-119`` would give a factor of 0 or overflow."""


class UnitRangeError(ValueError):
    """A unit label or unit exponent is out of range (the factor would be 0, inf or overflow)."""


@dataclass(frozen=True, slots=True)
class Unit:
    """A parsed unit: exponents of (length, time, force) and the factor to SI."""

    dims: tuple[int, int, int]
    factor: float


def parse_unit(label: str) -> Unit | None:
    """Parse a unit label; None if it is empty/NONE or not understood.

    Parameters
    ----------
    label : str
        E.g. ``"m/s^2"``, ``"g"``, ``"(m/s)/N"``, ``"mm/s2"``, ``"(1/N)*(m/s²)"``.

    Raises
    ------
    UnitRangeError
        A label that is understood but whose exponents exceed ``MAX_UNIT_POWER`` (``mm^-999/N``).
    """
    s = label.strip().lower()
    if s in _NO_LABEL:
        return None
    s = s.replace("²", "^2").replace("³", "^3").replace("µ", "u").replace("μ", "u").replace("**", "^")
    s = s.replace(" ", "")
    shown = label.strip()
    toks: list[tuple[str, str | None]] = []
    pos = 0
    while pos < len(s):
        m = _TOKEN.match(s, pos)
        if m is None or m.end() == pos:
            return None
        if m.group(1):
            toks.append((m.group(1), m.group(2)))
        elif m.group(3):
            toks.append(("1", None))
        elif m.group(4):
            toks.append((m.group(4), m.group(5)))
        else:
            toks.append((m.group(6), None))
        pos = m.end()
    try:
        unit, rest = _expr(toks, 0)
    except UnitRangeError as exc:
        raise UnitRangeError(f"unit label {shown!r}: {exc}") from None
    except (KeyError, IndexError, ValueError):
        return None
    if rest != len(toks):
        return None
    return unit


def _checked(dims: tuple[int, ...], factor: float, what: str) -> Unit:
    """A Unit whose exponents and factor are in range (UnitRangeError otherwise)."""
    if any(abs(x) > MAX_UNIT_POWER for x in dims):
        raise UnitRangeError(f"{what} gives a unit exponent beyond {MAX_UNIT_POWER}")
    if not (math.isfinite(factor) and factor > 0.0):
        raise UnitRangeError(f"{what} gives a conversion factor {factor:g}")
    return Unit(dims, factor)  # type: ignore[arg-type]


def _mul(a: Unit, b: Unit, sign: int) -> Unit:
    d = tuple(x + sign * y for x, y in zip(a.dims, b.dims, strict=True))
    return _checked(d, a.factor * (b.factor if sign > 0 else 1.0 / b.factor), "a product of units")


def _pow(u: Unit, p: int) -> Unit:
    if abs(p) > MAX_UNIT_POWER:
        raise UnitRangeError(f"exponent {p} out of range (at most {MAX_UNIT_POWER} in magnitude)")
    dims = tuple(x * p for x in u.dims)
    _checked(dims, 1.0, f"exponent {p}")  # exponents first: then the power below cannot overflow...
    try:
        factor = u.factor**p
    except OverflowError:  # ...unless the factor itself is extreme (a product of many prefixes)
        factor = math.inf
    return _checked(dims, factor, f"exponent {p}")


def _term(toks: list[tuple[str, str | None]], i: int) -> tuple[Unit, int]:
    name, power = toks[i]
    if name == "(":
        u, j = _expr(toks, i + 1)
        if toks[j][0] != ")":
            raise ValueError("unbalanced")
        p = toks[j][1]
        return (_pow(u, _power(p)) if p else u), j + 1
    if name == "1":
        return Unit((0, 0, 0), 1.0), i + 1
    dims, fac = _ATOMS[name]
    u = Unit(dims, fac)
    return (_pow(u, _power(power)) if power else u), i + 1


def _power(text: str) -> int:
    if len(text.lstrip("-")) > 3:
        raise UnitRangeError(f"exponent {text[:12]}... out of range (at most {MAX_UNIT_POWER} in magnitude)")
    return int(text)


def _expr(toks: list[tuple[str, str | None]], i: int) -> tuple[Unit, int]:
    u, i = _term(toks, i)
    while i < len(toks) and toks[i][0] in ("*", "/"):
        op = toks[i][0]
        v, i = _term(toks, i + 1)
        u = _mul(u, v, 1 if op == "*" else -1)
    return u, i


@dataclass(frozen=True, slots=True)
class UnitDecision:
    """How the values of one FRF dataset are turned into SI."""

    frf_form: str
    factor: float
    text: str
    note: str | None = None


def _code_name(code: int) -> str:
    return f"{code} ({_CODE_NAMES.get(code, 'other')})"


_AXIS_WORDS = {
    "receptance": "receptance", "compliance": "receptance", "flexibility": "receptance",
    "mobility": "mobility", "admittance": "mobility",
    "accelerance": "accelerance", "inertance": "accelerance",
}


def response_unit(label: str) -> Unit:
    """Check a response unit given by the user for files without a unit label (``--units``, ``[units] ordinate``).

    Parameters
    ----------
    label : str
        A displacement, velocity or acceleration unit (``"g"``, ``"m/s^2"``, ``"mm/s"``, ``"um"``),
        optionally per force (``"g/N"``, ``"(m/s)/lbf"``).

    Returns
    -------
    Unit

    Raises
    ------
    ValueError
        Naming the label and what is allowed.
    """
    unit = parse_unit(label)
    dims = None if unit is None else (unit.dims[0], unit.dims[1], 0) if unit.dims[2] in (0, -1) else None
    if unit is None or dims not in _FORM_DIMS:
        raise ValueError(f"unit {label!r} is not a displacement, velocity or acceleration unit (optionally per "
                         "force), e.g. g, m/s^2, mm/s, um, g/N")
    return unit


def decide(h: dict[str, Any], units164: dict[str, Any] | None, preference: str | None,
           assumed: str | None = None) -> UnitDecision:
    """Decide FRF form and SI factor of one dataset-58 FRF (see :func:`_decide`).

    A free-text axis label naming another FRF form (``"Receptance"`` over ``(m/s)/N``) does not
    decide anything, but the disagreement is added to the decision text. ``assumed`` (a unit
    checked by :func:`response_unit`) stands in for a missing ordinate unit label; a file's own
    label always wins.
    """
    num_lab = str(h.get("ordinate_axis_units_lab", ""))
    if assumed is not None and num_lab.strip().lower() in _NO_LABEL:
        h = {**h, "ordinate_axis_units_lab": assumed}
        dec = _decide(h, units164, preference)
        dec = UnitDecision(dec.frf_form, dec.factor,
                           f"{dec.text}; the file has no unit label: {assumed!r} given by the user (--units or "
                           "the rig file's [units] ordinate)")
    else:
        dec = _decide(h, units164, preference)
    if not (math.isfinite(dec.factor) and dec.factor > 0.0):
        raise UnitRangeError(f"unit conversion factor {dec.factor:g} is not finite and positive ({dec.text})")
    lab = h.get("ordinate_axis_lab", "")
    named = next((f for w, f in _AXIS_WORDS.items() if w in lab.lower()), None)
    if named is not None and named != dec.frf_form:
        text = f"{dec.text}; note: the axis label {lab!r} names {named}, codes/unit labels decide"
        return UnitDecision(dec.frf_form, dec.factor, text)
    return dec


def _decide(h: dict[str, Any], units164: dict[str, Any] | None, preference: str | None) -> UnitDecision:
    """Decide FRF form and SI factor of one dataset-58 FRF.

    Parameters
    ----------
    h : dict
        Parsed header (ordinate/denominator codes, exponents, labels).
    units164 : dict or None
        The dataset 164 in force for this dataset (length/force factors: file units per SI unit).
    preference : {'code', 'label'} or None
        Which wins when the ordinate code and the unit label disagree.

    Returns
    -------
    UnitDecision

    Raises
    ------
    ValueError
        With the reason (the caller turns it into a UFFError naming file and dataset).
    """
    num_code = h["ordinate_spec_data_type"]
    den_code = h["orddenom_spec_data_type"]
    num_lab = h["ordinate_axis_units_lab"]
    den_lab = h["orddenom_axis_units_lab"]
    if num_code not in (0, 1, 8, 11, 12):
        raise ValueError(
            f"ordinate specific data type {_code_name(num_code)} is not displacement (8), velocity (11) "
            "or acceleration (12)"
        )
    if den_code not in (0, 1, 9, 13):
        raise ValueError(f"denominator specific data type {_code_name(den_code)} is not a force (13 or 9)")
    code_form = _CODE_FORM.get(num_code)
    pn, pd = parse_unit(num_lab), parse_unit(den_lab)
    num_lab_given = num_lab.strip().lower() not in _NO_LABEL
    den_lab_given = den_lab.strip().lower() not in _NO_LABEL
    notes: list[str] = []
    label_form: str | None = None
    label_factor: float | None = None
    label_text = ""
    if pn is not None:
        dims, fac = pn.dims, pn.factor
        if dims[2] == -1:  # the ordinate label already holds the whole FRF unit (per force)
            label_text = f"label {num_lab!r} (whole FRF unit)"
            num_dims = (dims[0], dims[1], 0)
        elif dims[2] == 0:
            num_dims = dims
            if pd is not None and pd.dims == (0, 0, 1):
                fac = fac / pd.factor
                label_text = f"labels {num_lab!r} / {den_lab!r}"
            elif den_lab_given:
                raise ValueError(f"denominator unit label {den_lab!r} is not a force unit (N, kN, lbf)")
            else:
                label_text = f"label {num_lab!r} per N (denominator not labelled)"
        else:
            num_dims = (9, 9, 9)
        label_form = _FORM_DIMS.get(num_dims)
        label_factor = fac
        if label_form is None:
            label_text = f"label {num_lab!r} (not a displacement, velocity or acceleration per force)"
    elif num_lab_given and code_form is None:
        raise ValueError(
            f"unit label {num_lab!r} not understood and ordinate specific data type {_code_name(num_code)} "
            "does not say the quantity; cannot tell accelerance, mobility or receptance"
        )
    elif num_lab_given:
        notes.append(f"unit label {num_lab!r} not understood; ignored")

    if code_form is not None and label_text and label_form != code_form:
        msg = (
            f"ordinate specific data type {_code_name(num_code)} says {code_form} but the unit "
            f"{label_text} says {label_form or 'something else'}"
        )
        if preference == "code":
            notes.append(msg + "; the rig file prefers the code")
            label_form = label_factor = None
        elif preference == "label" and label_form is not None:
            notes.append(msg + "; the rig file prefers the label")
            code_form = None
        else:
            raise ValueError(msg + " (set [units] prefer = \"code\" or \"label\" in the rig file to decide)")
    if label_form is None and code_form is None:
        raise ValueError(
            f"ordinate quantity unknown: specific data type {_code_name(num_code)} and unit label {num_lab!r}"
        )
    form = label_form or code_form
    assert form is not None
    if label_factor is not None and label_form is not None:
        text = f"{form} from {label_text}: x {label_factor:.10g} to SI"
        if code_form is not None:
            text += f" (ordinate code {_code_name(num_code)} agrees)"
        if units164 is not None:
            text += f"; dataset 164 ({units164['unit_description']}) not applied, the label is explicit"
        return UnitDecision(form, label_factor, text + _j(notes))
    # from the code: the unit system of dataset 164, else SI
    text = f"{form} from ordinate code {_code_name(num_code)}"
    if units164 is None:
        return UnitDecision(form, 1.0, text + "; no unit label and no dataset 164: SI (m, N) assumed" + _j(notes))
    n_len = h["ordinate_len_unit_exp"] or 1
    n_force = h["ordinate_force_unit_exp"]
    d_len = h["orddenom_len_unit_exp"]
    d_force = h["orddenom_force_unit_exp"] or 1
    for name, e in (("ordinate length", n_len), ("ordinate force", n_force),
                    ("denominator length", d_len), ("denominator force", d_force)):
        if abs(e) > MAX_UNIT_POWER:
            raise UnitRangeError(
                f"{name} unit exponent {e} out of range (at most {MAX_UNIT_POWER} in magnitude) for the "
                "dataset 164 conversion"
            )
    lf, ff = units164["length_factor"], units164["force_factor"]
    try:
        fac = 1.0 / (lf ** (n_len - d_len) * ff ** (n_force - d_force))
    except (OverflowError, ZeroDivisionError):
        fac = math.nan
    if not math.isfinite(fac) or fac <= 0:
        raise UnitRangeError(
            f"dataset 164 unit factors (length {lf:g}, force {ff:g}) with exponents length {n_len - d_len}, "
            f"force {n_force - d_force} give no finite non-zero conversion"
        )
    text += (
        f"; units of dataset 164 ({units164['unit_description']}: length factor {lf:.10g}, force factor "
        f"{ff:.10g}) with exponents length {n_len - d_len}, force {n_force - d_force}: x {fac:.10g} to SI"
    )
    return UnitDecision(form, fac, text + _j(notes))


def _j(notes: list[str]) -> str:
    return "" if not notes else "; " + "; ".join(notes)


def abscissa_factor(h: dict[str, Any]) -> float:
    """Factor from the file's abscissa unit to Hz (ValueError if it is not a frequency)."""
    code = h["abscissa_spec_data_type"]
    lab = h["abscissa_axis_units_lab"].strip().lower()
    if code == 17 or lab in ("s", "sec", "(sec)", "ms"):
        raise ValueError(f"abscissa is time (code {code}, unit {h['abscissa_axis_units_lab']!r}), not frequency")
    if lab in ("rad/s", "rad/sec"):
        return 1.0 / (2.0 * math.pi)
    if lab in _NO_LABEL or lab in ("hz", "1/s", "(hz)"):
        return 1.0
    if lab == "khz":
        return 1e3
    raise ValueError(f"abscissa unit {h['abscissa_axis_units_lab']!r} is not a frequency unit (Hz, rad/s)")
