"""Private: writing FRFData as UFF dataset 58 (ASCII) or 58b (binary).

ema_rig writes the bytes itself instead of calling ``pyuff.UFF.write_sets`` because pyuff 2.5.8's
writer gets several things wrong for FRFs: the 58b byte count is ``num_pts * 8`` whatever the
data (wrong for complex or uneven data), ``force_double=False`` in binary announces single
precision but writes doubles, values are packed one ``struct.pack`` call at a time (slow), the
caller's dict is updated in place, ASCII doubles get 12 significant digits (``%20.11e``) instead
of the 13 of E20.12, and the abscissa minimum/increment get 6 digits. Files written here are
read back by pyuff (tests cross-check this) and by :func:`ema_rig.io.uff.read_uff58`.
"""

from __future__ import annotations

import os
import time

import numpy as np
from numpy.typing import NDArray

from ..dof import DOF
from ..literals import FrfForm

_FORM_CODE = {"receptance": (8, "m"), "mobility": (11, "m/s"), "accelerance": (12, "m/s^2")}


def fmt13(v: float) -> str:
    """A non-negative number in a 13-column field with a leading blank, as exact as fits.

    The E13.5 fields of record 7 (abscissa minimum and increment) are read as a 13-column
    number by every reader; ``%13.6E`` keeps only 7 digits, so an increment such as
    0.244140625 Hz (2000 Hz / 8192) would drift by 2e-4 Hz at the last line. The shortest
    round-trip decimal (or the most digits that fit) is written instead when it is closer.
    """
    v = float(v)
    cands = []
    r = repr(v)
    if "e" not in r and "inf" not in r and "nan" not in r and len(r) <= 12:
        cands.append(r)
    for d in range(11, -1, -1):
        f = f"{v:.{d}f}"
        if len(f) <= 12:
            cands.append(f)
            break
    cands.append(f"{v:.6E}")
    best = min(cands, key=lambda c: abs(float(c) - v))
    return best.rjust(13)


def line80(text: str) -> str:
    return f"{text[:80]:<80}"


def fmt_axis(code: int, len_exp: int, force_exp: int, label: str, unit: str) -> str:
    return f"{code:10d}{len_exp:5d}{force_exp:5d}{0:5d} {label[:20]:<20} {unit[:20]:<20}"


def format_values(flat: NDArray[np.float64], fmts: list[str]) -> str:
    """Format ``flat`` cyclically with the per-field formats ``fmts``, one cycle per line."""
    k = len(fmts)
    n_full = flat.size // k
    line = "".join(fmts) + "\n"
    vals = flat.tolist()
    out = (line * n_full) % tuple(vals[: n_full * k])
    rem = flat.size - n_full * k
    if rem:
        out += ("".join(fmts[:rem]) + "\n") % tuple(vals[n_full * k :])
    return out


def dataset_bytes(
    *,
    x: NDArray[np.float64],
    y: NDArray[np.complex128],
    even: bool,
    binary: bool,
    double: bool,
    response: DOF,
    reference: DOF,
    frf_form: FrfForm,
    unit_label: str,
    ids: tuple[str, str, str, str, str],
    force_label: str = "N",
) -> bytes:
    """The bytes of one dataset 58/58b (from the opening to the closing ``-1`` line, LF ends).

    Parameters
    ----------
    x : ndarray, shape (n,)
        Abscissa in Hz (non-negative, increasing).
    y : ndarray, shape (n,)
        Complex FRF values in the unit ``unit_label`` per N; always written as complex data
        (ordinate type 5 or 6), also when every imaginary part is 0: ``read_uff58`` refuses an FRF
        stored as real values (a magnitude, a real part or misdeclared (Re, Im) pairs).
    """
    n = x.size
    code, _ = _FORM_CODE[frf_form]
    ord_type = 6 if double else 5
    head = [
        *(line80(s) for s in ids),
        f"{4:5d}{1:10d}{0:5d}{0:10d} {'NONE':<10}{response.node:10d}{response.direction:4d} "
        f"{'NONE':<10}{reference.node:10d}{reference.direction:4d}",
        f"{ord_type:10d}{n:10d}{1 if even else 0:10d}"
        + (fmt13(x[0]) + fmt13((x[-1] - x[0]) / (n - 1) if n > 1 else 0.0) if even else f"{0.0:13.6E}{0.0:13.6E}")
        + f"{0.0:13.6E}",
        fmt_axis(18, 0, 0, "Frequency", "Hz"),
        fmt_axis(code, 1, 0, frf_form.capitalize(), unit_label),
        fmt_axis(13, 0, 1, "Force", force_label),
        fmt_axis(0, 0, 0, "NONE", "NONE"),
    ]
    parts = [y.real, y.imag]
    cols = parts if even else [x, *parts]
    if binary:
        fdt = "<f8" if double else "<f4"
        # interleaved per point: [x] re [im]; the abscissa has the ordinate's precision
        payload = np.empty(n, dtype=np.dtype([(f"c{i}", fdt) for i in range(len(cols))]))
        for i, c in enumerate(cols):
            payload[f"c{i}"] = c
        data = payload.tobytes()
        first = f"{58:6d}b{1:6d}{2:6d}{11:12d}{len(data):12d}{0:6d}{0:6d}{0:12d}{0:12d}"
        text = "    -1\n" + first + "\n" + "\n".join(head) + "\n"
        return text.encode("utf-8") + data + b"    -1\n"
    flat = np.column_stack(cols).ravel()
    if double:
        if even:
            fmts = ["%20.12E"] * 4
        else:  # 2(E13.5,E20.12) real, E13.5,2E20.12 complex
            fmts = ["%13.6E", "%20.12E", "%20.12E"]
    else:
        fmts = ["%13.5E"] * 6 if even else ["%13.6E", "%13.5E", "%13.5E"] * 2
    body = format_values(flat, fmts)
    text = "    -1\n" + f"{58:6d}" + "\n" + "\n".join(head) + "\n" + body + "    -1\n"
    return text.encode("utf-8")


def date_id() -> str:
    """Record-3 date in the customary ``DD-Mon-YY HH:MM:SS`` form (UTC).

    ``SOURCE_DATE_EPOCH`` (seconds, the reproducible-builds convention) replaces the clock, so
    that generated files can be byte-identical from run to run.
    """
    epoch = os.environ.get("SOURCE_DATE_EPOCH", "")
    stamp = time.gmtime(int(epoch)) if epoch.strip().isdigit() else time.gmtime()
    return time.strftime("%d-%b-%y %H:%M:%S", stamp)
