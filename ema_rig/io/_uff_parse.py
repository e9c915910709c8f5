"""Private: framing and parsing of UFF files into plain dataset records.

Why ema_rig frames and parses UFF itself rather than trusting :class:`pyuff.UFF` (DESIGN §5;
each point is seen in the shared corpus):

- pyuff splits a file at every ``"    -1"`` byte pattern, so a binary payload that happens to
  contain it is cut short and later datasets are misaligned; a 58b block is framed here by its
  header byte count instead.
- pyuff returns the values it finds, not the header's ``num_pts``: zero padding on the last line
  becomes extra points and a truncated excerpt comes back short without a warning.
- pyuff reads the abscissa of binary uneven double data as float64 while writers store it as
  float32 (the byte count tells which); it parses ASCII fields at fixed columns only, so uneven
  doubles written ``2E20.12`` or numbers run together are misread; it decodes labels as UTF-8
  with replacement, so Latin-1 labels (``m/s²``) are lost.
- pyuff parses ASCII values in a Python loop; numpy is an order of magnitude faster here.

Every dataset becomes a record whose status is ``"read"`` (exactly ``num_pts`` values) or
``"refused"`` with a reason; whole-file problems raise :class:`~ema_rig.errors.UFFError`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field, replace
from itertools import pairwise
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..dof import AXIS_NAMES, DOF
from .units import is_no_label

_EOL = re.compile(rb"\r\n|\r|\n")
# a delimiter line: optional blanks, -1, optional blanks, end of line (or of file)
_DELIM_TAIL = re.compile(rb"-1[ \t]*(?:\r|\n|\Z)")  # literal prefix: fast search
_NUM = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
# Fortran Ew.d output of an exponent of 3 digits drops the 'E' ("1.234567-102"): a mantissa with a
# point and no exponent, then a signed 3-digit integer (split apart by _NUM)
_MANTISSA = re.compile(rb"[-+]?(?:\d+\.\d*|\.\d+)")
_FORTRAN_EXP3 = re.compile(rb"[-+]\d{3}")
_GAP = re.compile(rb"(?:[ \t\x00]*(?:\r\n|\r|\n))*")
_DELIM_AT = re.compile(rb"[ \t]*-1[ \t]*(?=\r|\n|\Z)")
_DEXP = bytes.maketrans(b"dD", b"eE")
_TYPE_LINE = re.compile(rb"^\s*(\d+)\s*([bB]?)")
# a DOF in an entity name: node, optional '.' or ':', axis with its sign after ('1.Z-', '.1.Z+', '1Z')
# or before it ('1+Z', '1:-Y', ema_rig's own way of writing a DOF)
_ENTITY_DOF = re.compile(r"^\.?(\d+)[.:]?(?:(RX|RY|RZ|X|Y|Z)([+-]?)|([+-])(RX|RY|RZ|X|Y|Z))$", re.I)
# a byte that cannot be part of an ASCII data section (numbers incl. NaN/inf, blanks, line ends)
_NOT_DATA = re.compile(rb"[^0-9eEdD+\-. \t\r\n\x0b\x0cnNaAiIfFtTyY]")
# a closing -1 that follows a binary payload exactly (at most one line end before it)
_CLOSE_EXACT = re.compile(rb"(?:\r\n|\r|\n)?[ \t]*-1[ \t]*(?:\r\n|\r|\n|\Z)")
# the end of a binary payload that is itself a delimiter line ("    -1" after 4 blanks or a line end)
_DATA_ENDS_AS_CLOSE = re.compile(rb"(?:[\r\n]|[ \t]{4})[ \t]*-1[ \t]*(?:\r\n|\r|\n)?\Z")
# what may follow a closing -1: blank lines, then the end of the file (after blanks, NULs or a
# DOS end-of-file mark) or the next dataset's -1
_AFTER_CLOSE = re.compile(rb"(?:[ \t\x00]*(?:\r\n|\r|\n))*(?:[ \t\x00\x1a]*\Z|[ \t]*-1[ \t]*(?:\r|\n|\Z))")

MAX_HEADER_LINE = 4096
"""Longest header line accepted, in bytes (a UFF record is 80 columns)."""
MAX_INT_CHARS = 11
"""Longest integer field accepted in a header, in characters (sign and 10 digits)."""
MAX_ASCII_HEADER_LINES = 1000
"""Most header lines a 58b type line may announce (the format has 11)."""
MAX_TEXT_KEPT = 16 << 20
"""Datasets that are not parsed keep their text lines up to this many bytes."""
_CHUNK = 1 << 20  # ASCII values are parsed in chunks of about this many bytes

#: values per point: (is_complex, is_double) from the ordinate data type code
ORD_TYPES: dict[int, tuple[bool, bool]] = {2: (False, False), 4: (False, True), 5: (True, False), 6: (True, True)}


@dataclass(frozen=True, slots=True)
class RawDataset:
    """One dataset as found in the file (private to the UFF modules)."""

    index: int
    type: int | None
    binary: bool
    offset: int
    status: str
    reason: str | None
    header: dict[str, Any] = field(default_factory=dict)
    x: NDArray[np.float64] | None = None
    y: NDArray[Any] | None = None
    notes: tuple[str, ...] = ()
    lines: tuple[str, ...] = ()


class _Refuse(Exception):
    """Internal: a dataset cannot be read; the message is the reason."""


def _find_delim(buf: bytes, pos: int) -> int | None:
    """Start of the next line at or after ``pos`` that holds only ``-1`` (and blanks), or None."""
    while True:
        m = _DELIM_TAIL.search(buf, pos)
        if m is None:
            return None
        j = m.start()
        while j > pos and buf[j - 1] in (32, 9):
            j -= 1
        if j == 0 or buf[j - 1] in (10, 13):
            if j >= pos:
                return j
        pos = m.start() + 2


def _decode(raw: bytes) -> tuple[str, bool]:
    """Decode one header line: UTF-8 if valid, else Latin-1 (returns text, used_latin1)."""
    try:
        return raw.decode("utf-8"), False
    except UnicodeDecodeError:
        return raw.decode("latin-1"), True


def _next_line(buf: bytes, pos: int) -> tuple[bytes, int]:
    """The line starting at ``pos`` (without its end) and the position after its end."""
    m = _EOL.search(buf, pos)
    if m is None:
        return buf[pos:], len(buf)
    return buf[pos : m.start()], m.end()


def _int(tok: str | bytes, what: str) -> int:
    """One integer header field; too long (> MAX_INT_CHARS) or not an integer: refuse."""
    t = tok.strip()
    if len(t) > MAX_INT_CHARS:
        head = t[:12].decode("latin-1") if isinstance(t, bytes) else t[:12]
        raise _Refuse(f"{what}: integer field {head!r}... has {len(t)} characters (at most {MAX_INT_CHARS})")
    try:
        return int(t)
    except ValueError:
        shown = t[:40].decode("latin-1") if isinstance(t, bytes) else t[:40]
        raise _Refuse(f"{what}: expected an integer, found {shown!r}") from None


def _ints(text: str, n: int, what: str) -> list[int]:
    toks = text.split()
    if len(toks) < n:
        raise _Refuse(f"{what}: expected {n} integers, found {text.strip()[:80]!r}")
    return [_int(t, what) for t in toks[:n]]


def _parse_record6(line: str) -> dict[str, Any]:
    """Record 6: function type, ids, response and reference entity/node/direction."""
    fixed = [(0, 5), (5, 15), (15, 20), (20, 30), (41, 51), (51, 55), (66, 76), (76, 80)]
    try:
        vals = [int(line[a:b]) for a, b in fixed]
        ents = (line[31:41].strip(), line[56:66].strip())
    except ValueError:
        toks = line.split()
        if len(toks) != 10:
            raise _Refuse(
                "record 6 (function type, response/reference node and direction) unreadable: "
                f"{line.strip()[:80]!r}"
            ) from None
        vals = [_int(toks[i], "record 6") for i in (0, 1, 2, 3, 5, 6, 8, 9)]
        ents = (toks[4], toks[7])
    keys = ("func_type", "func_id", "ver_num", "load_case_id", "rsp_node", "rsp_dir", "ref_node", "ref_dir")
    out: dict[str, Any] = dict(zip(keys, vals, strict=True))
    out["rsp_ent_name"], out["ref_ent_name"] = ents
    return out


def _parse_record7(line: bytes) -> dict[str, Any]:
    """Record 7: ordinate data type, num_pts, spacing, abscissa min/increment, z value."""
    toks = _NUM.findall(line.translate(_DEXP))
    if len(toks) < 5:
        raise _Refuse(f"record 7 (data type, num_pts, spacing, abscissa) unreadable: {line.strip()[:80]!r}")
    ints = [_int(t, "record 7 (data type, num_pts, spacing)") for t in toks[:3]]
    floats = [float(t) for t in toks[3:6]] + [0.0] * (6 - len(toks[:6]))
    return {
        "ord_data_type": ints[0],
        "num_pts": ints[1],
        "abscissa_spacing": ints[2],
        "abscissa_min": floats[0],
        "abscissa_inc": floats[1],
        "z_axis_value": floats[2],
    }


def _parse_axis(line: str, name: str, rec: int) -> dict[str, Any]:
    """Records 8..11: spec data type, length/force/temperature exponents, axis and unit labels.

    The format is I10, 3I5, 1X, 20A1, 1X, 20A1: the labels are read at their columns. A line whose
    integers are not at their columns (written blank-separated) has its labels after the fourth
    integer, as two words (axis label, unit label) or none; any other number of words cannot be
    split into the two labels and is refused rather than losing the unit label.
    """
    try:
        vals = [int(line[0:10]), int(line[10:15]), int(line[15:20]), int(line[20:25])]
        axis_lab, unit_lab = line[26:46].strip(), line[47:67].strip()
    except ValueError:
        what = f"record {rec} ({name} axis)"
        vals = _ints(line, 4, what)
        words = line.split()[4:]
        if len(words) not in (0, 2):
            raise _Refuse(
                f"{what}: written without its fixed columns, with {len(words)} word(s) after the four integers "
                f"({' '.join(words)[:60]!r}): which is the axis label and which the unit label is ambiguous"
            ) from None
        axis_lab, unit_lab = (words[0], words[1]) if words else ("", "")
    return {
        f"{name}_spec_data_type": vals[0],
        f"{name}_len_unit_exp": vals[1],
        f"{name}_force_unit_exp": vals[2],
        f"{name}_temp_unit_exp": vals[3],
        f"{name}_axis_lab": axis_lab,
        f"{name}_axis_units_lab": unit_lab,
    }


def _dof_from(node: int, direction: int, entity: str) -> tuple[DOF | None, str | None]:
    """Resolve a DOF from the node/direction fields or, when both are 0, from the entity name."""
    if node == 0 and direction == 0:
        m = _ENTITY_DOF.match(entity.strip())
        if m:
            axis, sign = (m.group(2), m.group(3)) if m.group(2) else (m.group(5), m.group(4))
            code = AXIS_NAMES.index(axis.upper())
            d = DOF(int(m.group(1)), -code if sign == "-" else code)
            return d, f"DOF {d} taken from entity name {entity!r} (node/direction fields are 0)"
        if entity.strip() and not is_no_label(entity):
            return DOF(0, 0), (f"node and direction fields are 0 and the entity name {entity.strip()!r} is not "
                               "read as a DOF: DOF 0 (scalar) used")
    if node < 0 or not -6 <= direction <= 6:
        return None, f"node {node} / direction {direction} is not a valid DOF"
    return DOF(node, direction), None


def _parse_header(lines: list[bytes]) -> tuple[dict[str, Any], list[str], tuple[str, ...]]:
    """Parse the 11 header records of a dataset 58 into a dict."""
    if len(lines) < 11:
        raise _Refuse(f"header has {len(lines)} of 11 records (truncated dataset)")
    notes: list[str] = []
    text: list[str] = []
    latin = False
    for raw in lines[:11]:
        t, lat = _decode(raw)
        latin |= lat
        text.append(t)
    if latin:
        notes.append("header text is not UTF-8; decoded as Latin-1")
    h: dict[str, Any] = {f"id{i + 1}": text[i].strip() for i in range(5)}
    h.update(_parse_record6(text[5]))
    h.update(_parse_record7(lines[6]))
    for rec, name in zip((8, 9, 10, 11), ("abscissa", "ordinate", "orddenom", "z_axis"), strict=True):
        h.update(_parse_axis(text[rec - 1], name, rec))
    for key, node, dirk, ent in (
        ("response", "rsp_node", "rsp_dir", "rsp_ent_name"),
        ("reference", "ref_node", "ref_dir", "ref_ent_name"),
    ):
        d, note = _dof_from(h[node], h[dirk], h[ent])
        h[key] = d
        if note:
            notes.append(note)
    return h, notes, tuple(text)


def _values_ascii(buf: bytes, start: int, end: int, expected: int) -> tuple[NDArray[np.float64], list[str]]:
    """Parse the ASCII values in ``buf[start:end]``; exactly ``expected`` values or refuse.

    The section is parsed in chunks of about 1 MB cut at blanks, so the memory used is the
    float64 result plus one chunk's tokens, whatever the section holds; a section with more
    values than announced is refused as soon as that is clear.
    """
    notes: list[str] = []
    parts: list[NDArray[np.float64]] = []
    count = 0
    run_together = False
    pos = start
    while pos < end:
        stop = min(end, pos + _CHUNK)
        if stop < end:  # cut after the last blank of the window
            for blank in (b"\n", b" ", b"\r", b"\t"):
                cut = buf.rfind(blank, pos, stop)
                if cut > pos:
                    break
            if cut <= pos:
                bad = _NOT_DATA.search(buf, pos, stop)
                if bad is not None:
                    shown = buf[bad.start() : bad.start() + 20].decode("latin-1")
                    raise _Refuse(f"data section holds text that is not a number: {shown!r}")
                raise _Refuse(f"data section holds a run of over {_CHUNK} characters without a blank")
            stop = cut + 1
        chunk = buf[pos:stop]
        pos = stop
        if b"_" in chunk:  # float() would read "1_000" as 1000
            raise _Refuse("data section holds text that is not a number: '_'")
        if b"d" in chunk or b"D" in chunk:
            chunk = chunk.translate(_DEXP)
        toks = chunk.split()
        if not toks:
            continue
        try:
            arr = np.array(toks, dtype=np.float64)
        except ValueError:
            arr = _split_run_together(chunk, toks)
            run_together = True
        count += arr.size
        if count > expected + 4096:
            raise _Refuse(f"more than {count} values present but the header announces {expected}")
        parts.append(arr)
    if run_together:
        notes.append("numbers run together without blanks; split by number syntax")
    vals = np.concatenate(parts) if parts else np.empty(0)
    n = vals.size
    if n < expected:
        raise _Refuse(f"only {n} of {expected} values present (truncated data)")
    if n > expected:
        extra = n - expected
        tail = buf[max(start, end - 65536) : end].rstrip()
        last_line = tail[max(tail.rfind(b"\n"), tail.rfind(b"\r")) + 1 :]
        n_last = len(_NUM.findall(last_line.translate(_DEXP)))
        if extra <= n_last and not np.any(vals[expected:]):
            _check_padding(buf, start, end, n, extra)
            notes.append(f"last line zero-padded: {extra} trailing zero(s) past num_pts ignored")
            vals = vals[:expected]
        else:
            raise _Refuse(f"{n} values present but the header announces {expected}")
    return vals, notes


def _split_run_together(chunk: bytes, toks: list[bytes]) -> NDArray[np.float64]:
    """Values of blank-separated words some of which hold several numbers run together.

    A word is split only before a sign (``1.0E+00-2.0E+00``, written by fixed-width Fortran
    formats when a negative value takes the blank column); positive numbers run together
    (``1.0E+001.0E+00``) have no split point that the text vouches for, so they are refused.
    """
    out: list[float] = []
    for w in toks:
        try:
            out.append(float(w))
            continue
        except ValueError:
            pass
        parts = _NUM.findall(w)
        if b"".join(parts) != w:
            bad = _NOT_DATA.search(w)
            shown = (w if bad is None else w[bad.start() :])[:20].decode("latin-1")
            raise _Refuse(f"data section holds text that is not a number: {shown!r}")
        for a, b in pairwise(parts):
            if _FORTRAN_EXP3.fullmatch(b) and _MANTISSA.fullmatch(a):
                raise _Refuse(
                    f"number {w[:40].decode('latin-1')!r} holds {(a + b).decode('latin-1')!r}: Fortran E output of a "
                    f"3-digit exponent, which drops the 'E' ({a.decode('latin-1')}E{b.decode('latin-1')}); not read "
                    "(as written it is two numbers, the mantissa and an integer)"
                )
        if any(p[:1] not in (b"-", b"+") for p in parts[1:]):
            raise _Refuse(
                f"numbers run together without a sign between them ({w[:40].decode('latin-1')!r}): where one "
                "ends and the next begins is ambiguous"
            )
        out.extend(float(p) for p in parts)
    del chunk
    return np.array(out, dtype=np.float64)


def _check_padding(buf: bytes, start: int, end: int, n: int, extra: int) -> None:
    """Refuse zero padding that may stand in for a missing value.

    Padding fills the last line up to the values per line of the others; it is trusted only
    when every line holds that same number of values (the last one after padding). A line
    with one value fewer means a value is missing and the padding would shift every value
    after it (real and imaginary parts swapped).
    """
    counts: set[int] = set()
    for line in _EOL.split(buf[start:end]):
        if line.strip():
            counts.add(len(_NUM.findall(line.translate(_DEXP))))
            if len(counts) > 1:
                break
    if len(counts) != 1:
        raise _Refuse(
            f"{n} values where {n - extra} are announced, the last {extra} zero, but the lines hold different "
            "numbers of values: the zeros may be padding or a value may be missing (ambiguous)"
        )


def _split_values(
    h: dict[str, Any], vals: NDArray[np.float64], x_vals: NDArray[np.float64] | None
) -> tuple[NDArray[np.float64] | None, NDArray[Any]]:
    """Turn flat values into (x, y) according to spacing and data type (x None when even)."""
    is_complex, _ = ORD_TYPES[h["ord_data_type"]]
    n = h["num_pts"]
    even = h["abscissa_spacing"] == 1
    k = 2 if is_complex else 1
    x: NDArray[np.float64] | None
    if even:  # the abscissa is min + k inc: not stored (UFFRecord.x computes it on access)
        yv = vals
        x = None
    elif x_vals is not None:
        yv = vals
        x = x_vals
    else:
        v = vals.reshape(n, k + 1)
        x = np.ascontiguousarray(v[:, 0])
        yv = v[:, 1:].ravel()
    if is_complex and yv.dtype == np.float64 and yv.size == 2 * n and yv.flags.c_contiguous:
        y = yv.view(np.complex128)  # (Re, Im) pairs already in place: no copy
    elif is_complex:
        y = np.empty(n, dtype=np.complex128)
        y.real = yv[0::2]
        y.imag = yv[1::2]
    else:
        y = np.ascontiguousarray(yv, dtype=np.float64)
    return (None if x is None else np.ascontiguousarray(x, dtype=np.float64)), y


def _check_header_values(h: dict[str, Any]) -> None:
    if h["ord_data_type"] not in ORD_TYPES:
        raise _Refuse(
            f"ordinate data type {h['ord_data_type']} not supported (2, 4 real; 5, 6 complex)"
        )
    if h["num_pts"] <= 0:
        raise _Refuse(f"num_pts = {h['num_pts']} (must be positive)")
    if h["abscissa_spacing"] not in (0, 1):
        raise _Refuse(f"abscissa spacing code {h['abscissa_spacing']} (must be 0 uneven or 1 even)")
    if h["abscissa_spacing"] == 1 and not (np.isfinite(h["abscissa_min"]) and np.isfinite(h["abscissa_inc"])):
        raise _Refuse("abscissa minimum or increment is not finite")


def _binary_layouts(h: dict[str, Any]) -> list[tuple[int, int]]:
    """Possible (bytes per abscissa value, total bytes) for a 58b payload."""
    is_complex, is_double = ORD_TYPES[h["ord_data_type"]]
    s = 8 if is_double else 4
    n = h["num_pts"]
    ny = n * (2 if is_complex else 1)
    if h["abscissa_spacing"] == 1:
        return [(0, ny * s)]
    return [(xs, ny * s + n * xs) for xs in ((s, 4) if is_double else (4,))]


def _values_binary(
    h: dict[str, Any], payload: bytes | memoryview, xs: int, byte_order: str
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    is_complex, is_double = ORD_TYPES[h["ord_data_type"]]
    s = 8 if is_double else 4
    k = 2 if is_complex else 1
    ft = f"{byte_order}f{s}"
    with np.errstate(invalid="ignore"):  # signalling NaNs: reported by the finiteness check
        return _values_binary_cast(payload, ft, xs, k, byte_order)


def _values_binary_cast(
    payload: bytes | memoryview, ft: str, xs: int, k: int, byte_order: str
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    if xs == 0:
        vals = np.frombuffer(payload, dtype=ft)
        # native float64 stays a read-only view of the file's bytes (no copy)
        return (vals if vals.dtype == np.float64 else vals.astype(np.float64)), None
    dt = np.dtype([("x", f"{byte_order}f{xs}"), ("y", ft, (k,))])
    rec = np.frombuffer(payload, dtype=dt)
    return rec["y"].astype(np.float64).ravel(), rec["x"].astype(np.float64)


def _finish58(h: dict[str, Any], vals: NDArray[np.float64], x_vals: NDArray[np.float64] | None) -> tuple[Any, Any]:
    with np.errstate(all="ignore"):  # overflow/NaN are reported by the finiteness check
        x, y = _split_values(h, vals, x_vals)
    if (x is not None and x.size != h["num_pts"]) or y.size != h["num_pts"]:  # pragma: no cover - guarded above
        raise _Refuse("internal: value count differs from num_pts")
    return x, y


def _parse164(lines: list[bytes]) -> dict[str, Any]:
    """Dataset 164 (units): unit code, description, length/force/temperature factors."""
    if len(lines) < 3:
        raise _Refuse("dataset 164 needs 3 records")
    t0, _ = _decode(lines[0])
    try:
        code = int(t0[0:10])
    except ValueError:
        raise _Refuse(f"dataset 164 record 1 unreadable: {t0.strip()!r}") from None
    nums = [float(v) for v in _NUM.findall(lines[1].translate(_DEXP))]
    if len(nums) < 3 or not all(np.isfinite(nums[:3])) or min(nums[:3]) <= 0:
        raise _Refuse("dataset 164 record 2 must hold three positive unit factors (length, force, temperature)")
    return {
        "unit_code": code,
        "unit_description": t0[10:30].strip(),
        "length_factor": nums[0],
        "force_factor": nums[1],
        "temp_factor": nums[2],
    }


def scan(buf: bytes) -> list[RawDataset]:
    """Split a UFF file into datasets and parse the 58/58b and 164 ones.

    Parameters
    ----------
    buf : bytes
        The whole file.

    Returns
    -------
    list of RawDataset
        In file order. Empty when the file holds no delimiter line.
    """
    out: list[RawDataset] = []
    seen_x: list[NDArray[np.float64]] = []  # the last distinct abscissas, shared between datasets
    pos = 0
    n = len(buf)
    while pos < n:
        start_or_none = _find_delim(buf, pos)
        if start_or_none is None:
            break
        start = start_or_none
        _, p = _next_line(buf, start)
        if p >= n:
            break
        try:
            type_line, p_hdr = _line_limited(buf, p, n)
        except _Refuse as exc:
            ds, pos = _refuse_until_delim(buf, p, len(out), start, None, False, f"dataset type line: {exc}")
            out.append(ds)
            continue
        tm = _TYPE_LINE.match(type_line)
        if type_line.strip() == b"-1":
            # two delimiters in a row (an end followed by a start): start again at the second
            pos = p
            continue
        index = len(out)
        if tm is None or len(tm.group(1)) > 6:
            what = "is not a number" if tm is None else f"holds a {len(tm.group(1))}-digit number"
            ds, pos = _refuse_until_delim(
                buf, p_hdr, index, start, None, False,
                f"dataset type line {type_line[:20].decode('latin-1').strip()!r} {what}",
            )
            out.append(ds)
            continue
        dtype = int(tm.group(1))
        binary = bool(tm.group(2))
        if dtype == 58 and binary:
            ds, pos = _read_58b(buf, type_line, p_hdr, index, start)
        else:
            ds, pos = _read_ascii(buf, dtype, binary, p_hdr, index, start)
        out.append(_share_abscissa(ds, seen_x))
    return out


def _share_abscissa(ds: RawDataset, seen: list[NDArray[np.float64]]) -> RawDataset:
    """The dataset with its abscissa replaced by an equal one already read (one array, not one per dataset)."""
    if ds.x is None:
        return ds
    for x in seen:
        if x.shape == ds.x.shape and np.array_equal(x, ds.x):
            return replace(ds, x=x)
    seen.insert(0, ds.x)
    del seen[4:]
    return ds


def _line_limited(buf: bytes, pos: int, end: int) -> tuple[bytes, int]:
    """Like :func:`_next_line` within ``buf[:end]``, refusing a line over MAX_HEADER_LINE bytes."""
    m = _EOL.search(buf, pos, min(end, pos + MAX_HEADER_LINE + 2))
    if m is None:
        if end - pos > MAX_HEADER_LINE:
            raise _Refuse(f"header line longer than {MAX_HEADER_LINE} bytes (not a UFF header)")
        return buf[pos:end], end
    return buf[pos : m.start()], m.end()


def _refuse_until_delim(
    buf: bytes, p: int, index: int, start: int, dtype: int | None, binary: bool, reason: str,
    header: dict[str, Any] | None = None,
) -> tuple[RawDataset, int]:
    d = _find_delim(buf, p)
    end = len(buf) if d is None else _next_line(buf, d)[1]
    if binary and header and isinstance(header.get("n_bytes"), int) and header["n_bytes"] >= 0:
        # skip the announced payload so that a -1 pattern inside it does not end the dataset
        hit = _delim_after(buf, p + header["n_bytes"])
        if hit is not None:
            end = hit[1]
    ds = RawDataset(index, dtype, binary, start, "refused", reason, header or {})
    return ds, end


def _read_ascii(buf: bytes, dtype: int, binary: bool, p: int, index: int, start: int) -> tuple[RawDataset, int]:
    """An ASCII dataset: lines up to the closing delimiter."""
    d = _find_delim(buf, p)
    notes: list[str] = []
    no_close = "no closing -1 delimiter before the end of the file (truncated file?)"
    if d is None:
        # the end of the file may cut the last value (19.6 for 19.625): nothing can vouch for it;
        # a dataset 58 is still parsed to say what else is wrong (a short value count ...)
        body_end = pos = len(buf)
    else:
        body_end = d
        _, pos = _next_line(buf, d)
        # a missing closing -1: the delimiter found is the next dataset's opening one
        nxt, _ = _next_line(buf, pos) if pos < len(buf) else (b"", pos)
        if pos < len(buf) and _looks_like_new_dataset(nxt[:80]):
            notes.append("closing -1 delimiter missing; the next dataset starts right after the data")
            pos = d
    if d is None and (binary or dtype != 58):
        return RawDataset(index, dtype, binary, start, "refused", no_close), pos
    if binary:
        return RawDataset(index, dtype, binary, start, "refused", f"binary dataset {dtype}b not supported"), pos
    if dtype == 58:
        h: dict[str, Any] = {}
        lines: list[bytes] = []
        q = p
        try:
            while len(lines) < 11 and q < body_end:
                ln, q = _line_limited(buf, q, body_end)
                lines.append(ln)
            h, hn, text = _parse_header(lines)
            notes.extend(hn)
            _check_header_values(h)
            is_complex, _ = ORD_TYPES[h["ord_data_type"]]
            per = (2 if is_complex else 1) + (0 if h["abscissa_spacing"] == 1 else 1)
            vals, vn = _values_ascii(buf, q, body_end, h["num_pts"] * per)
            notes.extend(vn)
            x, y = _finish58(h, vals, None)
        except _Refuse as exc:
            reason = str(exc) if d is not None else f"{exc}; {no_close}"
            return RawDataset(index, 58, False, start, "refused", reason, h, notes=tuple(notes)), pos
        if d is None:
            return RawDataset(index, 58, False, start, "refused", f"{no_close}: the last value may be cut", h,
                              notes=tuple(notes)), pos
        return RawDataset(index, 58, False, start, "read", None, h, x, y, tuple(notes), text), pos
    if body_end - p > MAX_TEXT_KEPT:
        if dtype == 164:
            reason = f"dataset 164 holds {body_end - p} bytes (3 short records expected)"
            return RawDataset(index, 164, False, start, "refused", reason), pos
        notes.append(f"{body_end - p} bytes of text not kept (more than {MAX_TEXT_KEPT})")
        return RawDataset(index, dtype, False, start, "read", None, {}, notes=tuple(notes)), pos
    lines = _EOL.split(buf[p:body_end])
    if lines and lines[-1] == b"":
        lines.pop()
    text = tuple(_decode(ln)[0] for ln in lines)
    if dtype == 164:
        try:
            h = _parse164(lines)
        except _Refuse as exc:
            return RawDataset(index, 164, False, start, "refused", str(exc), lines=text), pos
        return RawDataset(index, 164, False, start, "read", None, h, notes=tuple(notes), lines=text), pos
    return RawDataset(index, dtype, False, start, "read", None, {}, notes=tuple(notes), lines=text), pos


def _looks_like_new_dataset(line: bytes) -> bool:
    """A type line of a known dataset (a bare integer, optionally with 'b', and nothing else numeric)."""
    m = re.fullmatch(rb"\s*(\d{1,6})([bB]?)\s*", line) or re.fullmatch(rb"\s*(58)([bB])\s.*", line)
    return m is not None and int(m.group(1)) in (15, 18, 55, 58, 82, 151, 164, 1858, 2400, 2411, 2412, 2414, 2420)


def _read_58b(buf: bytes, type_line: bytes, p: int, index: int, start: int) -> tuple[RawDataset, int]:
    """A binary 58b dataset, framed by the header's byte count."""
    n = len(buf)
    toks = type_line.split()
    notes: list[str] = []
    if len(toks) < 5:
        return _refuse_until_delim(buf, p, index, start, 58, True, "58b header line has fewer than 5 fields")
    try:
        bo, fp, n_ascii, n_bytes = (_int(t, "58b header line") for t in toks[1:5])
    except _Refuse as exc:
        return _refuse_until_delim(
            buf, p, index, start, 58, True,
            f"58b header line unreadable (byte order, format, ascii lines, bytes): {exc}",
        )
    if bo not in (1, 2):
        return _refuse_until_delim(buf, p, index, start, 58, True, f"58b byte order code {bo} (must be 1 or 2)")
    if fp != 2:
        return _refuse_until_delim(
            buf, p, index, start, 58, True, f"58b floating-point format {fp} is not IEEE 754 (2)"
        )
    if not 11 <= n_ascii <= MAX_ASCII_HEADER_LINES:
        return _refuse_until_delim(
            buf, p, index, start, 58, True,
            f"58b announces {n_ascii} header lines (11 expected, at most {MAX_ASCII_HEADER_LINES} accepted)",
        )
    lines: list[bytes] = []
    q = p
    h: dict[str, Any] = {"byte_ordering": bo, "fp_format": fp, "n_ascii_lines": n_ascii, "n_bytes": n_bytes}
    try:
        for _ in range(n_ascii):
            if q >= n:
                break
            ln, q = _line_limited(buf, q, n)
            lines.append(ln)
        hh, hn, text = _parse_header(lines)
        h.update(hh)
        notes.extend(hn)
        _check_header_values(h)
    except _Refuse as exc:
        return _refuse_until_delim(buf, q, index, start, 58, True, str(exc), h)
    layouts = _binary_layouts(h)
    chosen = next((lay for lay in layouts if lay[1] == n_bytes), None)
    if chosen is None:
        # header byte count wrong (e.g. pyuff's writer): accept a layout only if the closing -1
        # follows its payload exactly (at most one line end) and the next dataset or the end of
        # the file follows that -1; a num_pts one too many would otherwise swallow the closing
        # -1 as a value and take the next dataset's opening -1 for the close
        for lay in layouts:
            if q + lay[1] <= n and _close_exactly(buf, q + lay[1]) is not None:
                chosen = lay
                notes.append(f"header byte count {n_bytes} is wrong; num_pts and data type give {lay[1]}")
                break
    if chosen is None:
        need = " or ".join(str(lay[1]) for lay in layouts)
        return _refuse_until_delim(
            buf, q, index, start, 58, True,
            f"header byte count {n_bytes} does not match num_pts={h['num_pts']} and data type "
            f"{h['ord_data_type']} ({need} bytes) and no closing -1 follows such a payload exactly; "
            "try pyuff.fix_58b if the file was rewritten in text mode",
            h,
        )
    xs, nb = chosen
    if q + nb > n:
        return RawDataset(
            index, 58, True, start, "refused",
            f"truncated binary data: {max(n - q, 0)} of {nb} bytes present", h,
        ), n
    end = _delim_after(buf, q + nb)
    if end is None:
        return _refuse_until_delim(
            buf, q + nb, index, start, 58, True,
            f"binary data of {nb} bytes is not followed by the closing -1 (byte count or framing wrong; "
            "try pyuff.fix_58b)",
            h,
        )
    if _AFTER_CLOSE.match(buf, end[1]) is None:
        # the -1 taken for the close is followed by a dataset body: it was the next dataset's
        # opening -1 and the payload swallowed the real close; resume the scan at that -1 line
        resume = end[0]
        while resume > 0 and buf[resume - 1] in (32, 9):
            resume -= 1
        return RawDataset(
            index, 58, True, start, "refused",
            f"the -1 after {nb} bytes of binary data is followed by more data, not by the next dataset "
            "or the end of the file (num_pts or byte count too large?)",
            h,
        ), resume
    ambiguous = _close_ambiguity(buf, q + nb)
    if ambiguous:
        return RawDataset(index, 58, True, start, "refused", f"{ambiguous} (ambiguous framing)", h), end[1]
    gap = buf[q + nb : end[0]]
    if gap:
        notes.append(f"{len(gap)} byte(s) {gap!r} between the binary data and the closing -1")
    if xs == 4 and ORD_TYPES[h["ord_data_type"]][1]:
        notes.append("uneven abscissa stored as float32 (ordinate float64)")
    vals, x_vals = _values_binary(h, memoryview(buf)[q : q + nb], xs, "<" if bo == 1 else ">")
    x, y = _finish58(h, vals, x_vals)
    return RawDataset(index, 58, True, start, "read", None, h, x, y, tuple(notes), text), end[1]


def _close_ambiguity(buf: bytes, p: int) -> str | None:
    """Why the closing -1 found at the payload end ``p`` does not vouch for where the payload ends.

    Writers put the close right after the payload as ``"    -1"`` (the I6 field: 4 blanks) or on
    a line of its own after a line end. A close that follows the payload without a line end and
    with another number of blanks means the payload took some of its blanks (num_pts or the byte
    count one too many, or a byte lost in the data); a payload whose last byte is a blank or a
    line end that could equally begin the close line is the same doubt one byte earlier.
    """
    m = _DELIM_TAIL.search(buf, p)
    if m is None:  # pragma: no cover - the caller found a close
        return None
    lead = buf[p : m.start()]
    if b"\n" not in lead and b"\r" not in lead and lead != b"    ":
        return (f"the closing -1 follows the binary data with {len(lead)} blank(s) and no line end (a close "
                "written right after the data has 4): the data may have taken some of its blanks")
    tail = _DATA_ENDS_AS_CLOSE.search(buf, max(0, p - 90), p)
    if tail is not None:
        return (f"the binary data end with the bytes of a closing -1 line ({tail.group()!r}): num_pts or the "
                "byte count too large would read that close as data and take a later -1 for it")
    if p > 0 and buf[p - 1] in b" \t\r\n" and _delim_after(buf, p - 1) is not None:
        return (f"the binary data end with {buf[p - 1 : p]!r}, which with what follows forms the closing -1 "
                "line: num_pts or the byte count one too many would read it as data")
    return None


def _close_exactly(buf: bytes, p: int) -> tuple[int, int] | None:
    """(start, end) of a closing -1 line right at ``p`` (after at most one line end) that is
    followed by the end of the file or the next dataset's opening -1, else None."""
    m = _CLOSE_EXACT.match(buf, p)
    if m is None or _AFTER_CLOSE.match(buf, m.end()) is None:
        return None
    return m.start(), m.end()


def _delim_after(buf: bytes, p: int) -> tuple[int, int] | None:
    """If only blank lines separate ``p`` from a -1 line: (start of that line, end of that line)."""
    if p > len(buf):
        return None
    q = _GAP.match(buf, p).end()  # type: ignore[union-attr]
    for cand in (q, p):
        d = _DELIM_AT.match(buf, cand)
        if d is not None:
            return cand, _next_line(buf, cand)[1]
    return None
