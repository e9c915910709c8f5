"""Checked number types for the ``ema-rig`` command line (one definition for every command).

argparse calls a ``type=`` function on the text of an option; the functions here turn it into a
number and refuse, with a one-line reason, anything outside the option's physical range: NaN
and infinities (unless a command gives ``inf`` a meaning), negative speeds, zero resolutions,
negative seeds. argparse then prints ``ema-rig <command>: error: argument <option>: <reason>``
and exits with code 2, before any file is read or written.

Functions
---------
finite_float, positive_float, nonneg_float
    A finite float; one > 0; one >= 0.
positive_stiffness
    A stiffness > 0 [N/m] where ``inf`` is allowed (a rigid steel disk).
mounting_stiffness
    ``--k-ms``: a k_MS [N/m] inside the rig file's plausible range (Table 1 of the paper x/÷ 100).
shaft_speed
    A shaft speed [rpm] in ``ema_rig.config.CONDITION_RANGES["speed"]`` (0 = not rotating).
nonneg_int, positive_int, model_order
    An integer >= 0; >= 1; a PolyMAX model order >= 2 (orders step by 2 for one reference).
number
    Build a checked type with other bounds.
BandAction
    ``--band LO HI``: two finite frequencies with 0 <= LO < HI.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence
from typing import Any

from .._text import std_text
from ..config import CONDITION_RANGES, implausible
from ..io.units import response_unit


def _describe(kind: type, lo: float | None, hi: float | None, lo_open: bool, allow_inf: bool) -> str:
    what = "an integer" if kind is int else ("a number" if allow_inf else "a finite number")
    parts = []
    if lo is not None:
        parts.append(f"{'>' if lo_open else '>='} {lo:g}")
    if hi is not None:
        parts.append(f"<= {hi:g}")
    return what + (" " + " and ".join(parts) if parts else "")


def number(
    kind: type = float,
    *,
    lo: float | None = None,
    hi: float | None = None,
    lo_open: bool = False,
    allow_inf: bool = False,
    unit: str = "",
    source: str = "",
) -> Callable[[str], Any]:
    """An argparse ``type=`` that parses ``kind`` (int or float) and checks its range.

    Parameters
    ----------
    kind : {int, float}
        Integers refuse ``1.5`` and ``1e3``; floats always refuse NaN.
    lo, hi : float, optional
        Inclusive bounds (``lo`` exclusive with ``lo_open``).
    lo_open : bool, optional
        Require ``value > lo`` instead of ``>=``.
    allow_inf : bool, optional
        Accept ``inf`` (floats only, still checked against the bounds).
    unit : str, optional
        Unit named in the message, e.g. ``"Hz"``.
    source : str, optional
        Where the bounds come from, named in the message (``"... (source)"``).

    Returns
    -------
    callable
        ``f(text) -> int | float`` raising :class:`argparse.ArgumentTypeError`.
    """
    desc = _describe(kind, lo, hi, lo_open, allow_inf) + (f" [{unit}]" if unit else "") + (f" ({source})" if source else "")

    def parse(text: str) -> Any:
        try:
            value = kind(text)
        except (ValueError, OverflowError):
            raise argparse.ArgumentTypeError(f"must be {desc}, got {text!r}") from None
        if kind is float and (math.isnan(value) or (math.isinf(value) and not allow_inf)):
            raise argparse.ArgumentTypeError(f"must be {desc}, got {text!r}")
        if lo is not None and (value <= lo if lo_open else value < lo):
            raise argparse.ArgumentTypeError(f"must be {desc}, got {text!r}")
        if hi is not None and value > hi:
            raise argparse.ArgumentTypeError(f"must be {desc}, got {text!r}")
        return value

    parse.__doc__ = f"The option's text as {desc}; argparse.ArgumentTypeError otherwise."
    return parse


finite_float = number(float)
positive_float = number(float, lo=0.0, lo_open=True)
nonneg_float = number(float, lo=0.0)
positive_stiffness = number(float, lo=0.0, lo_open=True, allow_inf=True, unit="N/m")
nonneg_int = number(int, lo=0)
positive_int = number(int, lo=1)
model_order = number(int, lo=2)  # the upper limit depends on the data: identify checks it


def mounting_stiffness(text: str) -> float:
    """``--k-ms V`` [N/m]: a finite positive number inside the rig file's plausible range of ``k_MS``.

    The range and its message are the rig file's ``[model] k_MS`` check (:func:`ema_rig.config.implausible`):
    a k_MS typed in MN/m, or with three zeros too many, would invert another k_TB without a word.
    """
    value = float(positive_float(text))
    why = implausible("k_MS", value)
    if why is not None:
        raise argparse.ArgumentTypeError(f"got {text!r}: {why}")
    return value


#: ``--speed RPM``: a shaft speed in the range a campaign's ``speed`` key has (one definition, ema_rig.config)
shaft_speed = number(float, lo=CONDITION_RANGES["speed"].lo, hi=CONDITION_RANGES["speed"].hi,
                     unit=CONDITION_RANGES["speed"].unit, source=CONDITION_RANGES["speed"].source)


class BandAction(argparse.Action):
    """``--band LO HI`` [Hz]: two finite frequencies with ``0 <= LO < HI`` (use with ``nargs=2``)."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: str | Sequence[Any] | None, option_string: str | None = None) -> None:
        assert values is not None and not isinstance(values, str)
        lo, hi = (float(v) for v in values)
        if not (math.isfinite(lo) and math.isfinite(hi) and 0.0 <= lo < hi):
            raise argparse.ArgumentError(self, f"needs 0 <= LO < HI, two finite frequencies [Hz], got {lo:g} {hi:g}")
        setattr(namespace, self.dest, (lo, hi))


__all__ = ["BandAction", "add_units_argument", "finite_float", "nonneg_float", "nonneg_int", "model_order", "number",
           "positive_float", "positive_int", "positive_stiffness", "mounting_stiffness", "note_clipped_band", "shaft_speed"]


def units(text: str) -> str:
    """``--units``: a response unit for FRF datasets without a unit label (``g``, ``m/s^2``, ``mm/s`` ...)."""
    try:
        response_unit(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text


def add_units_argument(parser: argparse.ArgumentParser) -> None:
    """Register ``--units UNIT`` (the same option for every command that reads FRFs)."""
    parser.add_argument("--units", type=units, default=None, metavar="UNIT",
                        help="response unit of FRF datasets that carry no unit label, e.g. g, m/s^2, mm/s (per N "
                             "unless the file says otherwise; default: the rig file's [units] ordinate). A unit "
                             "label in the file always wins")


def note_clipped_band(requested: Sequence[float] | None, used: Sequence[float] | None, file: object) -> None:
    """A ``note:`` line on stderr when an explicit ``--band`` was narrowed to the data's lines.

    ``stiffness`` and ``calibrate`` clip their band to the data (``modes`` refuses a band that
    extends beyond them); the band identified is then not the one asked for, and says so.
    """
    if requested is None or used is None or tuple(map(float, used)) == tuple(map(float, requested)):
        return
    print(f"note: {file}: --band {requested[0]:g} {requested[1]:g} extends beyond the data: identified in "
          f"{used[0]:g}..{used[1]:g} Hz", file=sys.stderr)


def pm(std: float | None, scale: float = 1.0) -> str:
    """`` +/- <std>`` with two significant digits (never a rounded 0.000), or nothing without a std."""
    if std is None or not (std == std):
        return ""
    return f" +/- {std_text(scale * std)}"
