"""Text from files made inert: no terminal escapes, no reordered text, no spreadsheet formulas.

Names read from user files (bearing names, tags, UFF labels, file names) reach a terminal, an
HTML report and a CSV table. There they must show as what they are:

* control characters (C0, DEL, C1: ``ESC`` starts a terminal escape sequence that can recolour,
  retitle or clear the terminal) and the line/paragraph separators U+2028/U+2029 are shown as
  ``\\x1b`` / ``\\u2028``;
* bidirectional controls (U+061C, U+200E, U+200F, U+202A-U+202E, U+2066-U+2069: "Trojan Source",
  CVE-2021-42574) would reorder what is shown; they are shown as ``\\u202e``;
* a CSV cell that starts with ``=``, ``+``, ``-``, ``@``, a tab or a carriage return is taken for a
  formula by spreadsheets (OWASP "CSV injection"); such a text cell gets a leading ``'``, while a
  number (``-1.5``, ``+2e6``) stays a number.

Other format characters (the zero-width joiner inside an emoji, a soft hyphen) are left alone:
they do not change what the surrounding text says.

Functions
---------
inert
    A string with control and bidirectional characters escaped.
csv_cell
    A CSV cell value that a spreadsheet does not evaluate.
std_text
    A standard uncertainty with two significant digits, never rounded to 0.
"""

from __future__ import annotations

import math
import unicodedata
from typing import Any

#: Bidirectional formatting characters (Unicode UAX #9, explicit embedding/override/isolate marks).
BIDI_CONTROLS = frozenset("\u061c\u200e\u200f\u202a\u202b\u202c\u202d\u202e\u2066\u2067\u2068\u2069")
_SEPARATORS = frozenset("\u2028\u2029")
#: First characters that make a spreadsheet evaluate a cell (OWASP, CSV injection).
_FORMULA_START = ("=", "+", "-", "@", "\t", "\r")


def _escape(ch: str) -> str:
    o = ord(ch)
    return f"\\x{o:02x}" if o < 0x100 else f"\\u{o:04x}"


def unsafe(ch: str) -> bool:
    """True for a character :func:`inert` escapes (control, bidirectional control, line separator)."""
    return ch in BIDI_CONTROLS or ch in _SEPARATORS or unicodedata.category(ch) == "Cc"


def inert(text: Any, keep: str = "") -> str:
    """``text`` as a string whose control and bidirectional characters are escaped.

    Parameters
    ----------
    text : object
        Converted with ``str``.
    keep : str, optional
        Control characters left as they are (``"\\n"`` for multi-line messages).

    Returns
    -------
    str
        ``"a\\x1b[2Jb"`` for ``"a<ESC>[2Jb"``, ``"x\\u202ey"`` for ``"x<RLO>y"``.

    Examples
    --------
    >>> inert("6302\\x1b[31m")
    '6302\\\\x1b[31m'
    >>> inert("abc\\u202edef")
    'abc\\\\u202edef'
    """
    s = str(text)
    if s.isprintable() and not (BIDI_CONTROLS.intersection(s)):
        return s  # the usual case, fast
    return "".join(_escape(c) if c not in keep and unsafe(c) else c for c in s)


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def csv_cell(value: Any) -> Any:
    """A CSV cell value that spreadsheets show as text, never evaluate as a formula.

    Numbers are returned as they are (``-1.5`` stays a negative number, NaN stays NaN); a string
    that parses as a number is kept; any other string that starts with ``= + - @``, a tab or a
    carriage return gets a leading ``'``, and its control characters are escaped.

    Examples
    --------
    >>> csv_cell("=HYPERLINK(\\"x\\")")
    '\\'=HYPERLINK("x")'
    >>> csv_cell("-1.5"), csv_cell(-1.5)
    ('-1.5', -1.5)
    """
    if value is None or isinstance(value, (bool, int, float)):
        return value
    s = str(value)
    if s.startswith(_FORMULA_START) and not _is_number(s.strip()):
        s = "'" + s
    return inert(s)



def plain(text: Any) -> str:
    """``text`` as a string matplotlib draws literally: ``$`` escaped, so no mathtext is parsed.

    An unescaped pair of ``$`` starts mathtext, and an invalid formula (``p$\\frac$q``) makes
    ``savefig`` raise, losing the figure.

    Parameters
    ----------
    text : object
        A name from user input (file, bearing, tag).

    Returns
    -------
    str
    """
    return str(text).replace("$", r"\$")


def std_text(std: float) -> str:
    """A standard uncertainty for print: two significant digits in fixed point, never a rounded 0.

    A ± printed with the value's fixed decimals reads 0.00 when the uncertainty is below the last
    digit (k_TB ``70.000 +/- 0.000 (measured)`` at 0.05 % noise), as if the value were exact.

    Parameters
    ----------
    std : float
        The uncertainty, in the unit it is printed in (>= 0; NaN or inf printed as such).

    Returns
    -------
    str
        ``0.00044``, ``0.0048``, ``2.7``, ``35``, ``1240``; ``0`` only for an exact 0.

    Examples
    --------
    >>> std_text(0.004834), std_text(2.7366), std_text(104.13), std_text(0.0)
    ('0.0048', '2.7', '104', '0')
    """
    x = float(std)
    if not math.isfinite(x) or x == 0.0:
        return f"{x:g}"
    decimals = max(0, 1 - math.floor(math.log10(abs(x))))
    text = f"{x:.{decimals}f}"
    if float(text) != 0.0 and len(text.replace("-", "").replace(".", "").lstrip("0")) > 2 and decimals > 0:
        # rounding carried into a new digit (0.0995 -> 0.100): one decimal fewer keeps two digits
        text = f"{x:.{decimals - 1}f}"
    return text


__all__ = ["BIDI_CONTROLS", "csv_cell", "inert", "plain", "std_text", "unsafe"]
