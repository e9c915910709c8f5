"""Mutators of valid UFF files for fuzzing the reader (shared by the CI fuzz test and benchmarks/fuzz_uff.py).

Each mutator takes the bytes of a valid UFF file and a numpy ``Generator`` and returns new bytes.
The classes aim at what the reader must refuse or read exactly: bytes, unit labels, dataset-164
factors and exponents, header integers, value counts, delimiters, line ends, truncation.

:func:`exercise` reads one mutant the way a user would (``read_uff``, ``inspect_uff``,
``read_uff58``) and says whether it was read, refused with ema_rig's own error, or escaped with
anything else (a bug; numpy warnings count as escapes too).
"""

from __future__ import annotations

import re
import traceback
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ema_rig.errors import EmaRigError, IdentificationWarning, UnitWarning
from ema_rig.io.uff import inspect_uff, read_uff, read_uff58

Mutator = Callable[[bytes, np.random.Generator], bytes]

_ATOMS = ["m", "mm", "cm", "um", "in", "ft", "s", "sec", "N", "kN", "lbf", "lb", "g", "1", "µm", "m/s²", "x", ""]
_OPS = ["/", "*", "", " ", "^", "**"]


def _huge_int(rng: np.random.Generator) -> str:
    kind = int(rng.integers(0, 7))
    if kind == 0:
        return str(int(rng.integers(-20, 21)))
    if kind == 1:
        return str(int(rng.choice([999, -999, 120, -119, 200, 199, 4300, -4300])))
    if kind == 2:
        return ("-" if rng.random() < 0.5 else "") + "9" * int(rng.integers(10, 40))
    if kind == 3:
        return "5" * int(rng.choice([401, 4301, 5000]))
    if kind == 4:
        return str(int(rng.integers(-(2**31), 2**31)))
    if kind == 5:
        return rng.choice(["", "-", "+", "1.5", "1e3", "0x10", "nan", " 7 "])
    return str(int(rng.integers(0, 10**9)))


_CRAFTED = ["(um^-12)^12", "(mm^12/um^12)^12", "mm^120*m^-119/s^2", "mm^-999/N", "mm^200/mm^199/s^2",
            "((mm^9)^9)^9", "(1/um^12)^-12", "g^12/lbf^-12", "in^12*ft^-12/s^13", "(kN^-12)^-1"]


def random_unit_label(rng: np.random.Generator) -> str:
    """A unit label from the label grammar with random (also absurd) exponents."""
    if rng.random() < 0.2:
        return str(rng.choice(_CRAFTED))
    parts: list[str] = []
    for k in range(int(rng.integers(1, 5))):
        if k:
            parts.append(str(rng.choice(_OPS)))
        if rng.random() < 0.15:
            parts.append("(")
        parts.append(str(rng.choice(_ATOMS)))
        if rng.random() < 0.5:
            parts.append(str(rng.choice(["^", "", "**"])) + _huge_int(rng)[:30])
        if rng.random() < 0.1:
            parts.append(")" + (("^" + _huge_int(rng)[:10]) if rng.random() < 0.5 else ""))
    return "".join(parts)


_LABEL_FIELD = re.compile(rb"(?m)^( {8}\d{2}| {9}\d) {3,4}-?\d+ {3,4}-?\d+ {3,4}-?\d+ (.{20}) (.{1,20})")


def unit_label(buf: bytes, rng: np.random.Generator) -> bytes:
    """Replace the unit label of one record 8..11 (20 columns from column 48)."""
    hits = list(_LABEL_FIELD.finditer(buf))
    if not hits:
        return buf
    m = hits[int(rng.integers(len(hits)))]
    lab = random_unit_label(rng).encode("utf-8", "replace")
    lab = lab[:20].ljust(20) if rng.random() < 0.8 else lab  # sometimes longer than the field
    return buf[: m.start(3)] + lab + buf[m.end(3) :]


_EXP_FIELDS = re.compile(rb"(?m)^( {8}\d{2}| {9}\d)( {3,4}-?\d+)( {3,4}-?\d+)( {3,4}-?\d+)")


def exp164(buf: bytes, rng: np.random.Generator) -> bytes:
    """Put a dataset 164 with random factors in front and set random unit exponents in records 8..11."""
    facs = []
    for _ in range(3):
        good = ["1.0E+03", "1.0", "2.54E-02", "4.448E+00", "1.0E+300", "1.0E-300", "1.0E+30", "1.0E-30"]
        bad = ["0.0", "-1.0", "NaN", "inf", "1" + "0" * int(rng.integers(1, 400))]
        facs.append(str(rng.choice(good if rng.random() < 0.85 else bad)))
    u164 = f"    -1\n   164\n         2  mm (milli newton)  0\n  {facs[0]}  {facs[1]}  {facs[2]}\n  2.7315E+02\n    -1\n"
    out = u164.encode() if rng.random() < 0.9 else b""
    hits = list(_EXP_FIELDS.finditer(buf))
    if not hits:
        return out + buf
    for _ in range(int(rng.integers(1, 4))):
        m = hits[int(rng.integers(len(hits)))]
        g = int(rng.integers(2, 5))
        val = _huge_int(rng)
        val = val if rng.random() < 0.3 else val[:4]
        new = (" " + val).rjust(5).encode() if len(val) <= 4 else (" " + val).encode()
        buf = buf[: m.start(g)] + new + buf[m.end(g) :]
        hits = list(_EXP_FIELDS.finditer(buf))
        if not hits:
            break
    return out + buf


def header_int(buf: bytes, rng: np.random.Generator) -> bytes:
    """Replace one integer field of a type line, record 6, record 7 or a 58b header line."""
    lines = buf.split(b"\n")
    cands = [i for i, ln in enumerate(lines[:4000]) if re.match(rb"^\s*-?\d+(\s+-?[\d.E+\-]+)*\s*\r?$", ln)
             or ln.lstrip().startswith(b"58b")]
    if not cands:
        return buf
    i = cands[int(rng.integers(len(cands)))]
    toks = lines[i].split()
    if not toks:
        return buf
    k = int(rng.integers(len(toks)))
    toks[k] = _huge_int(rng).encode()
    lines[i] = b" " + b"    ".join(toks)
    return b"\n".join(lines)


def num_pts(buf: bytes, rng: np.random.Generator) -> bytes:
    """Change num_pts of one dataset by a small amount (and sometimes the 58b byte count with it)."""
    hits = list(re.finditer(rb"(?m)^( +[2456])( +)(\d+)( +[01] )", buf))
    if not hits:
        return buf
    m = hits[int(rng.integers(len(hits)))]
    n = int(m.group(3)) + int(rng.choice([-2, -1, 1, 2, 1000, -10**6]))
    out = buf[: m.start(3)] + str(n).encode() + buf[m.end(3) :]
    if rng.random() < 0.5:
        # the 58b byte count of the dataset before this record 7, moved by +-8/16
        head = out.rfind(b"58b", 0, m.start())
        if head >= 0:
            le = out.find(b"\n", head)
            f = out[head:le].split()
            if len(f) >= 5 and f[4].isdigit():
                f[4] = str(int(f[4]) + int(rng.choice([-16, -8, 8, 16]))).encode()
                out = out[:head] + b"     ".join(f) + out[le:]
    return out


def delimiter(buf: bytes, rng: np.random.Generator) -> bytes:
    """Remove, duplicate or indent one ``-1`` delimiter line."""
    hits = [m.start() for m in re.finditer(rb"(?m)^ *-1 *\r?$", buf)]
    if not hits:
        return buf
    s = hits[int(rng.integers(len(hits)))]
    e = buf.find(b"\n", s)
    e = len(buf) if e < 0 else e + 1
    op = int(rng.integers(3))
    if op == 0:
        return buf[:s] + buf[e:]
    if op == 1:
        return buf[:e] + buf[s:e] + buf[e:]
    return buf[:s] + b"\t-1 \n" + buf[e:]


def line_ends(buf: bytes, rng: np.random.Generator) -> bytes:
    """Change the line ends of one region to CR or CRLF (or strip some)."""
    n = len(buf)
    a = int(rng.integers(0, max(n, 1)))
    b = min(n, a + int(rng.integers(1, 4000)))
    new = rng.choice([b"\r", b"\r\n", b"", b"\n\n"])
    return buf[:a] + buf[a:b].replace(b"\n", bytes(new)) + buf[b:]


def truncate_tail(buf: bytes, rng: np.random.Generator) -> bytes:
    """Cut the file in its last 200 bytes (inside the last number, the last -1 ...)."""
    if len(buf) < 2:
        return buf
    return buf[: max(1, len(buf) - int(rng.integers(1, min(200, len(buf)))))]


def bytes_edit(buf: bytes, rng: np.random.Generator) -> bytes:
    """Flip, delete, insert or duplicate a few bytes or a line at a random place."""
    if not buf:
        return bytes(rng.integers(0, 256, 8, dtype=np.uint8))
    i = int(rng.integers(len(buf)))
    blob = bytes(rng.integers(0, 256, int(rng.integers(1, 13)), dtype=np.uint8))
    if rng.random() < 0.3:
        blob = bytes(rng.choice([b"-1", b"\n", b"    -1\n", b"E+", b"58b", b"\x00", b" ", b"NaN"]))
    op = int(rng.integers(4))
    if op == 0:
        return buf[:i] + blob + buf[i + len(blob) :]
    if op == 1:
        return buf[:i] + buf[i + len(blob) :]
    if op == 2:
        return buf[:i] + blob + buf[i:]
    lines = buf.split(b"\n")
    j = int(rng.integers(len(lines)))
    return b"\n".join(lines[: j + 1] + lines[j:])


def junk_tail(buf: bytes, rng: np.random.Generator) -> bytes:
    """Random bytes, zeros or blank text after a cut of the valid file."""
    cut = int(rng.integers(0, len(buf) + 1))
    kind = int(rng.integers(3))
    n = int(rng.integers(1, 5000))
    tail = bytes(n) if kind == 0 else (b" 0" * n if kind == 1 else bytes(rng.integers(0, 256, n, dtype=np.uint8)))
    return buf[:cut] + tail


MUTATORS: dict[str, Mutator] = {
    "bytes": bytes_edit,
    "unit_label": unit_label,
    "exp164": exp164,
    "header_int": header_int,
    "num_pts": num_pts,
    "delimiter": delimiter,
    "line_ends": line_ends,
    "truncate_tail": truncate_tail,
    "junk_tail": junk_tail,
}
"""Mutation classes by name."""


def exercise(path: Path, buf: bytes) -> tuple[str, str | None]:
    """Write ``buf`` to ``path`` and read it as a user would.

    Returns
    -------
    (outcome, detail)
        ``("read", None)``, ``("refused", None)`` (an :class:`EmaRigError`, with or without
        some refused datasets) or ``("foreign", traceback text)`` for any other exception or a
        warning other than UnitWarning.
    """
    path.write_bytes(buf)
    outcome = "read"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", category=UnitWarning)
        try:
            f = read_uff(path)
            inspect_uff(path)
            if any(r.status != "read" for r in f):
                outcome = "refused"
            read_uff58(path)
        except EmaRigError:
            outcome = "refused"
        except Exception:  # noqa: BLE001 - the point of the fuzzer: anything else is a bug
            return "foreign", traceback.format_exc(limit=6)
    return outcome, None


# ------------------------------------------------------------------- misread oracle (issue 17)
def edit_region(orig: bytes, mut: bytes) -> tuple[int, int, int]:
    """(start, end in the original, end in the mutant) of the one byte range that differs.

    The common prefix and suffix of the two files bound every edit, so one range covers all the
    mutations applied (a conservative "touched" region).
    """
    n = min(len(orig), len(mut))
    a = np.frombuffer(orig[:n], np.uint8)
    b = np.frombuffer(mut[:n], np.uint8)
    diff = np.flatnonzero(a != b)
    p = int(diff[0]) if diff.size else n
    ra = np.frombuffer(orig[len(orig) - n + p :], np.uint8)[::-1] if n > p else np.zeros(0, np.uint8)
    rb = np.frombuffer(mut[len(mut) - n + p :], np.uint8)[::-1] if n > p else np.zeros(0, np.uint8)
    rdiff = np.flatnonzero(ra != rb)
    s = int(rdiff[0]) if rdiff.size else ra.size
    return p, len(orig) - s, len(mut) - s


def _records(buf: bytes) -> list[tuple[int, int, object]]:
    """(start, end, UFFRecord) of every dataset, as read_uff returns them (with their byte spans)."""
    from ema_rig.io import _uff_parse
    from ema_rig.io.uff import _to_record

    raws = _uff_parse.scan(buf)
    offs = [r.offset for r in raws] + [len(buf)]
    return [(offs[i], offs[i + 1], _to_record(r)) for i, r in enumerate(raws)]


def _flat(rec: object) -> np.ndarray:
    """The values of a dataset-58 record in file order (x interleaved when uneven), as float64."""
    y = np.asarray(rec.y)  # type: ignore[attr-defined]
    yv = y.view(np.float64).reshape(y.size, -1) if np.iscomplexobj(y) else y.reshape(-1, 1)
    if rec.header.get("abscissa_spacing") == 1:  # type: ignore[attr-defined]
        return yv.ravel()
    return np.column_stack([np.asarray(rec.x), yv]).ravel()  # type: ignore[attr-defined]


_NUMTOK = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eEdD][-+]?\d+)?|nan|inf", re.I)


def _value_spans(buf: bytes, start: int, end: int, rec: object) -> list[tuple[int, int]] | None:
    """Byte span of each stored value of ``rec`` (a dataset starting at ``start``) in ``buf``."""
    h = rec.header  # type: ignore[attr-defined]
    pos = start
    for _ in range(2 + (h.get("n_ascii_lines", 11) if rec.binary else 11)):  # type: ignore[attr-defined]
        m = re.compile(rb"\r\n|\r|\n").search(buf, pos)
        if m is None:
            return None
        pos = m.end()
    from ema_rig.io._uff_parse import ORD_TYPES

    is_complex, is_double = ORD_TYPES[h["ord_data_type"]]
    if rec.binary:  # type: ignore[attr-defined]
        s = 8 if is_double else 4
        k = 2 if is_complex else 1
        n = h["num_pts"]
        f32_x = any("float32" in note for note in rec.notes)  # type: ignore[attr-defined]
        xs = 0 if h["abscissa_spacing"] == 1 else (4 if f32_x or not is_double else s)
        sizes = ([xs] if xs else []) + [s] * k
        spans = []
        for _ in range(n):
            for sz in sizes:
                spans.append((pos, pos + sz))
                pos += sz
        return spans
    from ema_rig.io._uff_parse import _find_delim

    close = _find_delim(buf, pos)
    return [m.span() for m in _NUMTOK.finditer(buf, pos, min(end, len(buf) if close is None else close))]


def misreads(orig: bytes, mut: bytes) -> list[str]:
    """Silent misreads of a mutant: datasets read with values the original file does not hold.

    For every dataset 58 the mutant reads: when its bytes lie outside the edited range it must
    be the same dataset as in the original (same start, same values, same DOFs); when the edit
    touches it and the original dataset at the same start was read with the same num_pts, data
    type and spacing, only the values whose text (ASCII) or bytes (58b) the edit touched may
    differ. A value that moved (a shift from a missing value, padding taken for data, a split
    run-together number, a byte count that ate a delimiter) shows up as a difference outside
    the touched values.
    """
    p, e_orig, e_mut = edit_region(orig, mut)
    delta = e_mut - e_orig
    try:
        o_recs = {a: (a, b, r) for a, b, r in _records(orig)}
        m_recs = _records(mut)
    except Exception as exc:  # noqa: BLE001 - reported by exercise() as foreign anyway
        return [f"scan failed: {exc!r}"]
    out: list[str] = []
    for a, b, r in m_recs:
        if r.type != 58 or r.status != "read":  # type: ignore[attr-defined]
            continue
        if b <= p or a >= e_mut:  # untouched: the same bytes as in the original
            a0 = a if b <= p else a - delta
            # the delimiter line itself may have been edited (blanks, line ends): the same dataset
            # then starts a few bytes away; take the nearest original start within 16 bytes
            near = [o for o in o_recs if abs(o - a0) <= 16]
            hit = o_recs[min(near, key=lambda o: abs(o - a0))] if near else None
            if hit is None or hit[2].status != "read":  # type: ignore[attr-defined]
                out.append(f"untouched dataset at byte {a} read, but the original has no read dataset there")
                continue
            ro = hit[2]
            same = (np.array_equal(_flat(ro), _flat(r)) and ro.response == r.response  # type: ignore[attr-defined]
                    and ro.reference == r.reference and ro.header.get("num_pts") == r.header.get("num_pts"))  # type: ignore[attr-defined]
            if not same:
                out.append(f"untouched dataset at byte {a} read with other values than the original")
            continue
        if a >= p:  # a dataset that starts inside the edit: its content is the edit's
            continue
        hit = o_recs.get(a)
        if hit is None or hit[2].status != "read":  # type: ignore[attr-defined]
            continue
        ro = hit[2]
        keys = ("num_pts", "ord_data_type", "abscissa_spacing")
        if any(ro.header.get(k) != r.header.get(k) for k in keys) or ro.binary != r.binary:  # type: ignore[attr-defined]
            continue  # the header says something else now: nothing to compare value by value
        fo, fm = _flat(ro), _flat(r)
        spans = _value_spans(orig, hit[0], hit[1], ro)
        if spans is None or len(spans) != fo.size or fo.size != fm.size:
            continue
        touched = np.array([s < e_orig and e > p for s, e in spans])
        differ = ~((fo == fm) | (np.isnan(fo) & np.isnan(fm)))
        bad = differ & ~touched
        if bad.any():
            k = int(np.argmax(bad))
            out.append(f"dataset at byte {a}: value {k} is {fm[k]!r}, the original holds {fo[k]!r}, and the edit "
                       f"(bytes {p}..{e_orig}) did not touch it")
    return out


def exercise_frf(path: Path, buf: bytes, out: Path) -> tuple[str, str | None]:
    """Write ``buf`` to ``path`` and run ``ema-rig frf`` on it (the command's own code, no subprocess).

    Returns ``("read", None)`` when FRFs were written, ``("refused", None)`` for ema_rig's own
    error, ``("foreign", traceback)`` for anything else (a ValueError escaping the command is a
    bug: the command turns the estimator's into UFFError).
    """
    import contextlib
    import io

    from ema_rig.cli import build_parser

    path.write_bytes(buf)
    args = build_parser().parse_args(["frf", str(path), "-o", str(out)])
    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("error")
        warnings.filterwarnings("ignore", category=UnitWarning)
        warnings.filterwarnings("ignore", category=IdentificationWarning)
        try:
            args._run(args)
        except EmaRigError:
            return "refused", None
        except Exception:  # noqa: BLE001 - the point of the fuzzer: anything else is a bug
            return "foreign", traceback.format_exc(limit=6)
    return "read", None


def time_seed(n: int = 512, *, binary: bool = False, labels: tuple[str, str] = ("N", "m/s^2"),
              t_unit: str = "s", dt: float = 1e-3, u164: bool = False, seed: int = 5) -> bytes:
    """A force + response time-data file (dataset 58, function type 1), the fuzz seed of ``frf``.

    Written here field by field (not by pyuff): ``n`` samples per channel, float64, even time axis
    with step ``dt`` in ``t_unit``; with ``u164`` a dataset 164 (inch, lbf) in front.
    """
    rng = np.random.default_rng(seed)
    x = rng.standard_normal(n)
    y = np.convolve(x, [0.5, 1.0, -0.25])[:n]

    def line(text: str) -> str:
        return text[:80].ljust(80) + "\n"

    out = []
    if u164:
        out.append("    -1\n   164\n         2  inch (lbf)          2\n"
                   "  3.93700787402E+01  2.24808943100E-01  1.00000000000E+00\n  2.73150000000E+02\n    -1\n")
    for node, code, lab, vals in ((1, 13, labels[0], x), (2, 12, labels[1], y)):
        head = "    -1\n" + (f"    58b     1     2          11{8 * n:12d}     0     0           0           0\n"
                             if binary else "    58\n")
        recs = [line(t) for t in (f"ch {node}", "fuzz seed", "24-Nov-26 00:00:00", "NONE", "NONE")]
        recs.append(line(f"{1:5d}{0:10d}{0:5d}{0:10d} {'NONE':<10s}{node:10d}{3:4d} {'NONE':<10s}{1:10d}{3:4d}"))
        recs.append(line(f"{4:10d}{n:10d}{1:10d}{0.0:13.5E}{dt:13.5E}{0.0:13.5E}"))
        recs.append(line(f"{17:10d}{0:5d}{0:5d}{0:5d} {'Time':<20s} {t_unit:<20s}"))
        le, fe = (0, 1) if code == 13 else (1, 0)
        recs.append(line(f"{code:10d}{le:5d}{fe:5d}{0:5d} {'Signal':<20s} {lab:<20s}"))
        recs += [line(f"{0:10d}{0:5d}{0:5d}{0:5d} {'NONE':<20s} {'NONE':<20s}")] * 2
        text = (head + "".join(recs)).encode()
        if binary:
            body = vals.astype("<f8").tobytes()
        else:
            body = "".join(("%20.12E" * len(c)) % tuple(c) + "\n" for c in np.array_split(vals, -(-n // 4))).encode()
        out.append((text + body + b"    -1\n").decode("latin-1"))
    return "".join(out).encode("latin-1")
