"""The unit grammar: a unit label (``"mm s^-2"``, ``"in/s²/lbf"``, ``"milli-g"``, ``"ms"``) -> SI factor.

One grammar for every label ema_rig reads: ordinates, denominators and abscissas of UFF
dataset 58 (FRFs and time data), and for what a user types (``--units``, rig-file ``[units]``).

Functions
---------
parse_unit_label
    A unit label -> :class:`Unit` (dimensions, factor to SI, quantity), or :class:`UnitLabelError`.

Classes
-------
Unit
    Frozen: exponents of (length, time, force), the factor to SI and the quantity's name.
UnitLabelError
    A label the grammar cannot read (unknown word, bad syntax) or whose exponents are out of range.

Notes
-----
Grammar (blanks around operators are ignored)::

    label   := product (("/" | "per") product)*
    product := power ((" " | "." | "*" | "·") power)*
    power   := atom [("^" | "**" | "") ["-" | "+"] digits | "²" | "³" | "⁻²" ...]
    atom    := "(" label ")" | "1" | word

A word is an SI prefix (``p n u µ μ m c d k M G``) followed by ``m``, ``s``, ``N``, ``Hz`` or
``g`` (standard gravity, 9.80665 m/s²: ``mg`` is milli-g; ``milli-g``, ``micro-g`` are
accepted too), or one of ``in``, ``inch``, ``ft``, ``lbf``, ``lb`` (pound-force), ``kgf``,
``sec``, ``min``, ``rad`` (1/2π of a cycle, so ``rad/s`` is a frequency), ``rpm``, ``kg``
(N s²/m). Words are case-sensitive (``MN`` is a meganewton, ``mN`` a millinewton); a label
written entirely in capitals (``MM/S^2``, ``G``, ``LBF``) is read in lower case with the
prefixes ``m u n c k`` only (``MM`` is a millimetre there). ``sec``, ``inch``, ``lbf``, ``Hz``,
``rpm`` are read in any case. Both micro signs are accepted: U+00B5 (µ) and U+03BC (μ).
A product has no implicit precedence problems: ``m/s/N`` is m s⁻¹ N⁻¹, ``m/s^2`` is m s⁻².
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from ..literals import FrfForm

G0 = 9.80665
"""Standard gravity in m/s^2 (exact, CGPM 1901)."""
LBF = 4.4482216152605
"""One pound-force in N (exact by definition)."""
INCH = 0.0254
"""One inch in m (exact)."""
MAX_UNIT_POWER = 12
"""Largest exponent magnitude accepted in a unit label or a header unit exponent (real units
use 1..3); beyond it a label such as ``mm^120*m^-119`` would give a factor of 0 or overflow."""

_PREFIXES = {"p": 1e-12, "n": 1e-9, "u": 1e-6, "µ": 1e-6, "μ": 1e-6, "m": 1e-3, "c": 1e-2, "d": 1e-1,
             "k": 1e3, "M": 1e6, "G": 1e9}
_WORD_PREFIXES = {"pico": "p", "nano": "n", "micro": "u", "milli": "m", "centi": "c", "deci": "d",
                  "kilo": "k", "mega": "M", "giga": "G"}
# base: (length, time, force) exponents and factor to SI
_BASES: dict[str, tuple[tuple[int, int, int], float]] = {
    "m": ((1, 0, 0), 1.0), "s": ((0, 1, 0), 1.0), "N": ((0, 0, 1), 1.0), "Hz": ((0, -1, 0), 1.0),
    "g": ((1, -2, 0), G0),
}
_SPECIAL: dict[str, tuple[tuple[int, int, int], float]] = {
    "in": ((1, 0, 0), INCH), "ft": ((1, 0, 0), 0.3048), "lb": ((0, 0, 1), LBF), "kgf": ((0, 0, 1), G0),
    "min": ((0, 1, 0), 60.0), "rad": ((0, 0, 0), 1.0 / (2.0 * math.pi)), "kg": ((-1, 2, 1), 1.0),
    "gn": ((1, -2, 0), G0),
}
_ANY_CASE: dict[str, tuple[tuple[int, int, int], float]] = {
    "sec": ((0, 1, 0), 1.0), "secs": ((0, 1, 0), 1.0), "inch": ((1, 0, 0), INCH),
    "inches": ((1, 0, 0), INCH), "lbf": ((0, 0, 1), LBF), "hz": ((0, -1, 0), 1.0),
    "khz": ((0, -1, 0), 1e3), "rpm": ((0, -1, 0), 1.0 / 60.0),
}
_CAPS_PREFIXES = ("m", "u", "n", "c", "k")


def _table(prefixes: dict[str, float] | tuple[str, ...], lower: bool) -> dict[str, tuple[tuple[int, int, int], float]]:
    out: dict[str, tuple[tuple[int, int, int], float]] = {}
    for base, (dims, fac) in _BASES.items():
        out[base.lower() if lower else base] = (dims, fac)
        for p in prefixes:
            out[(p + base).lower() if lower else p + base] = (dims, fac * _PREFIXES[p])
    for word, val in _SPECIAL.items():
        out[word] = val
    if lower:  # "MN" read in lower case is a millinewton: in capitals only lower-case prefixes exist
        out["n"] = ((0, 0, 1), 1.0)
        out.pop("kg", None)
        out.pop("mn", None)  # "MN": a meganewton or a millinewton? refused
    return out


_EXACT = _table(_PREFIXES, lower=False)
_CAPS = _table(_CAPS_PREFIXES, lower=True)

_QUANTITIES = {
    (1, 0, 0): "displacement", (1, -1, 0): "velocity", (1, -2, 0): "acceleration", (0, 0, 1): "force",
    (0, 1, 0): "time", (0, -1, 0): "frequency", (0, 0, 0): "dimensionless",
    (1, 0, -1): "receptance", (1, -1, -1): "mobility", (1, -2, -1): "accelerance",
    (-1, 2, 1): "mass",
}
_SUPERSCRIPTS = str.maketrans({"⁰": "0", "¹": "1", "²": "2", "³": "3", "⁴": "4", "⁵": "5", "⁶": "6",
                               "⁷": "7", "⁸": "8", "⁹": "9", "⁻": "-", "⁺": "+"})
_SUPER_RUN = re.compile(r"([⁻⁺]?[⁰¹²³⁴⁵⁶⁷⁸⁹]+)")
_WORD_PREFIX = re.compile(r"\b(pico|nano|micro|milli|centi|deci|kilo|mega|giga)[- ]?(?=[A-Za-zµμ])", re.I)
_TOKEN = re.compile(r"(\*\*|\^)|([A-Za-zµμ]+)|([-+]?\d+)|([()/*.·])|( )")
_NO_LABEL = frozenset({"", "none", "nounits", "-", "n/a", "unknown"})


class UnitLabelError(ValueError):
    """A unit label that cannot be read: unknown word, bad syntax or an exponent out of range."""


@dataclass(frozen=True, slots=True)
class Unit:
    """A parsed unit label.

    Attributes
    ----------
    dims : tuple of int
        Exponents of (length, time, force): ``(1, -2, 0)`` is an acceleration, ``(1, -2, -1)``
        an accelerance, ``(0, -1, 0)`` a frequency.
    factor : float
        Multiply a value in this unit by ``factor`` to get SI (m, s, N, Hz); finite and > 0.
    label : str
        The label as given (stripped).
    """

    dims: tuple[int, int, int]
    factor: float
    label: str = ""

    @property
    def quantity(self) -> str:
        """``'acceleration'``, ``'velocity'``, ``'displacement'``, ``'force'``, ``'time'``,
        ``'frequency'``, ``'accelerance'``, ``'mobility'``, ``'receptance'``, ``'mass'``,
        ``'dimensionless'`` or ``'other'``."""
        return _QUANTITIES.get(self.dims, "other")


def is_no_label(label: str) -> bool:
    """True for an empty label or one that says there is none (``NONE``, ``-``, ``n/a``).

    Parameters
    ----------
    label : str
        A unit label as written in a file.

    Returns
    -------
    bool
    """
    return label.strip().lower() in _NO_LABEL


def parse_unit_label(label: str) -> Unit:
    """Parse a unit label into dimensions and a factor to SI.

    Parameters
    ----------
    label : str
        E.g. ``"m/s^2"``, ``"mm s^-2"``, ``"m.s**-2"``, ``"g"``, ``"mg"``, ``"milli-g"``,
        ``"(m/s)/N"``, ``"in/s2/lbf"``, ``"µm"``, ``"ms"``, ``"kHz"``, ``"N/μm"``.

    Returns
    -------
    Unit
        ``factor`` converts a value in ``label`` to SI; ``quantity`` names what it measures.

    Raises
    ------
    UnitLabelError
        An empty label, an unknown word, a syntax error, or an exponent beyond
        :data:`MAX_UNIT_POWER` (the message quotes the label and says what is wrong).

    Examples
    --------
    >>> u = parse_unit_label("mm s^-2")
    >>> u.quantity, u.factor
    ('acceleration', 0.001)
    >>> parse_unit_label("milli-g").factor == parse_unit_label("mg").factor == 9.80665e-3
    True
    >>> parse_unit_label("N/μm").factor == parse_unit_label("N/µm").factor == 1e6
    True
    """
    shown = label.strip()
    if is_no_label(shown):
        raise UnitLabelError(f"unit label {shown!r} says nothing (no unit)")
    try:
        dims, factor = _parse(shown)
    except UnitLabelError as exc:
        raise UnitLabelError(f"unit label {shown!r}: {exc}") from None
    return Unit(dims, factor, shown)


def force_factor(label: str) -> float:
    """Factor to SI of the force units in a label, raised to their exponents (``'g/lbf'`` -> 1/4.448...).

    Parameters
    ----------
    label : str
        A unit label that :func:`parse_unit_label` reads.

    Returns
    -------
    float
        The part of the label's factor that its force words (N with prefixes, lbf, lb, kgf) give:
        ``parse_unit_label(label).factor`` divided by the factor of the same label with every
        force word read as N. For a label per force (force exponent -1) its inverse is the force
        unit the label is per: ``1 / force_factor('(m/s)/kN') == 1000``.

    Raises
    ------
    UnitLabelError
        As :func:`parse_unit_label`.
    """
    shown = label.strip()
    if is_no_label(shown):
        raise UnitLabelError(f"unit label {shown!r} says nothing (no unit)")
    try:
        return _parse(shown)[1] / _parse(shown, force_as_newton=True)[1]
    except UnitLabelError as exc:
        raise UnitLabelError(f"unit label {shown!r}: {exc}") from None


def _parse(text: str, *, force_as_newton: bool = False) -> tuple[tuple[int, int, int], float]:
    s = re.sub(r"\s+", " ", text)
    s = _WORD_PREFIX.sub(lambda m: _WORD_PREFIXES[m.group(1).lower()], s)
    s = _SUPER_RUN.sub(lambda m: "^" + m.group(1).translate(_SUPERSCRIPTS), s)
    s = re.sub(r"\s*(\*\*|\^|/|\*|\.|·)\s*", r"\1", s.strip())
    s = re.sub(r"(?i)\s+per\s+", "/", s)
    s = re.sub(r"\s*([()])\s*", r"\1", s)
    table = _EXACT
    if not any(c.islower() for c in s if c not in "µμ"):
        s, table = s.lower(), _CAPS
    toks: list[tuple[str, str]] = []
    pos = 0
    while pos < len(s):
        m = _TOKEN.match(s, pos)
        if m is None:
            raise UnitLabelError(f"character {s[pos]!r} is not part of a unit")
        kind = m.lastindex or 0
        toks.append((("op", "word", "int", "sym", "blank")[kind - 1], m.group(kind)))
        pos = m.end()
    p = _Parser(toks, table, force_as_newton)
    u = p.label()
    if p.i != len(toks):
        raise UnitLabelError(f"unexpected {toks[p.i][1]!r}")
    return u


class _Parser:
    """Recursive descent over the tokens of one label."""

    def __init__(self, toks: list[tuple[str, str]], table: dict[str, tuple[tuple[int, int, int], float]],
                 force_as_newton: bool = False):
        self.toks, self.table, self.i = toks, table, 0
        self.force_as_newton = force_as_newton  # every force word read as N (see force_factor)

    def _peek(self) -> tuple[str, str] | None:
        return self.toks[self.i] if self.i < len(self.toks) else None

    def label(self) -> tuple[tuple[int, int, int], float]:
        u = self.product()
        while (t := self._peek()) is not None and t == ("sym", "/"):
            self.i += 1
            u = _combine(u, self.product(), -1)
        return u

    def product(self) -> tuple[tuple[int, int, int], float]:
        u = self.power()
        while (t := self._peek()) is not None and (t[0] == "blank" or t in (("sym", "*"), ("sym", "."),
                                                                             ("sym", "·"))):
            self.i += 1
            u = _combine(u, self.power(), 1)
        return u

    def power(self) -> tuple[tuple[int, int, int], float]:
        u = self.atom()
        t = self._peek()
        if t is not None and t[0] == "op":
            self.i += 1
            t = self._peek()
            if t is None or t[0] != "int":
                raise UnitLabelError(f"{'^' if t is None else t[1]!r} after an exponent sign is not an integer")
        if t is not None and t[0] == "int":
            self.i += 1
            return _power(u, t[1])
        return u

    def atom(self) -> tuple[tuple[int, int, int], float]:
        t = self._peek()
        if t is None:
            raise UnitLabelError("ends where a unit is expected")
        self.i += 1
        if t == ("sym", "("):
            u = self.label()
            if self._peek() != ("sym", ")"):
                raise UnitLabelError("unbalanced parentheses")
            self.i += 1
            return u
        if t == ("int", "1"):
            return (0, 0, 0), 1.0
        if t[0] == "word":
            w = t[1]
            hit = self.table.get(w) or _ANY_CASE.get(w.lower())
            if hit is None:
                raise UnitLabelError(f"unknown unit {w!r} (known: SI prefixes with m, s, N, Hz, g; in, ft, "
                                     "lbf, sec, min, rad, rpm)")
            return (hit[0], 1.0) if self.force_as_newton and hit[0] == (0, 0, 1) else hit
        raise UnitLabelError(f"unexpected {t[1]!r}")


def _checked(dims: tuple[int, ...], factor: float, what: str) -> tuple[tuple[int, int, int], float]:
    if any(abs(x) > MAX_UNIT_POWER for x in dims):
        raise UnitLabelError(f"{what} gives a unit exponent beyond {MAX_UNIT_POWER}")
    if not (math.isfinite(factor) and factor > 0.0):
        raise UnitLabelError(f"{what} gives a conversion factor {factor:g}")
    return (int(dims[0]), int(dims[1]), int(dims[2])), factor


def _combine(a: tuple[tuple[int, int, int], float], b: tuple[tuple[int, int, int], float],
             sign: int) -> tuple[tuple[int, int, int], float]:
    d = tuple(x + sign * y for x, y in zip(a[0], b[0], strict=True))
    return _checked(d, a[1] * (b[1] if sign > 0 else 1.0 / b[1]), "a product of units")


def _power(u: tuple[tuple[int, int, int], float], text: str) -> tuple[tuple[int, int, int], float]:
    if len(text.lstrip("+-")) > 3 or abs(int(text)) > MAX_UNIT_POWER:
        raise UnitLabelError(f"exponent {text[:12]} out of range (at most {MAX_UNIT_POWER} in magnitude)")
    p = int(text)
    dims = tuple(x * p for x in u[0])
    _checked(dims, 1.0, f"exponent {p}")  # exponents first: then the power below cannot overflow...
    try:
        factor = u[1] ** p
    except OverflowError:  # ...unless the factor itself is extreme (a product of many prefixes)
        factor = math.inf
    return _checked(dims, factor, f"exponent {p}")



#: FRF form of a response unit per force, by its (length, time, mass) exponents.
FORM_DIMS: dict[tuple[int, int, int], FrfForm] = {(1, 0, 0): "receptance", (1, -1, 0): "mobility",
                                                   (1, -2, 0): "accelerance"}


def parse_unit(label: str, what: str = "unit label") -> Unit | None:
    """Parse a unit label with :func:`ema_rig.io.units.parse_unit_label`; None if there is none.

    Parameters
    ----------
    label : str
        The label as stored (``"NONE"`` or blank: no label).
    what : str, optional
        What the label belongs to, for the message (``"ordinate unit label"``).

    Raises
    ------
    ValueError
        A label that is given but cannot be read (unknown word, syntax, exponent out of range):
        never taken as SI.
    """
    if is_no_label(label):
        return None
    try:
        return parse_unit_label(label)
    except UnitLabelError as exc:
        reason = str(exc).split(": ", 1)[-1]
        raise ValueError(f"{what} {label.strip()!r} not understood ({reason}); the values are not read "
                         "rather than taken as SI") from None


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
    if unit is None or dims not in FORM_DIMS:
        raise ValueError(f"unit {label!r} is not a displacement, velocity or acceleration unit (optionally per "
                         "force), e.g. g, m/s^2, mm/s, um, g/N")
    return unit

__all__ = ["FORM_DIMS", "G0", "INCH", "LBF", "MAX_UNIT_POWER", "Unit", "UnitLabelError", "force_factor", "is_no_label",
           "parse_unit", "parse_unit_label", "response_unit"]
