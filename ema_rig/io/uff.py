"""UFF dataset 58 (ASCII) and 58b (binary): reading, checking and writing FRFs.

The only module of ema_rig that touches UFF files (DESIGN §2, §5).

Functions
---------
read_uff58
    All FRF datasets (function type 4) of a file as one :class:`~ema_rig.frf.FRFData` in SI units.
write_uff58
    Write an :class:`~ema_rig.frf.FRFData` as ASCII 58 or binary 58b, atomically.
read_uff
    Every dataset of a file as a plain :class:`UFFRecord` ("read" or "refused" with a reason).
inspect_uff
    The DESIGN §3.2 ``inspect`` JSON of a file.

Classes
-------
UFFRecord, UFFFile
    Frozen records of :func:`read_uff`.

Notes
-----
Only function type 4 (frequency response function) is assembled into ``FRFData``; coherence
datasets (type 6) of the same pairs are attached to it as ``FRFData.coherence``. Type 3 (cross
spectrum) is a spectrum, not a ratio to force, and its scaling depends on the analyser's
averaging; it is listed by :func:`read_uff` like time data and PSDs.

Every dataset is checked against its header: exactly ``num_pts`` values (a zero-padded last line
is trimmed, anything else refused), the 58b byte count, the dataset framing (a 58b payload is
framed by its byte count, so a ``-1`` byte pattern inside it cannot cut it). Why the framing and
parsing are done here rather than by pyuff is listed in ``ema_rig/io/_uff_parse.py``; pyuff is
the independent cross-check in the tests and the benchmark. Units: see :func:`read_uff58`.
The reader refuses what it cannot vouch for (see :func:`read_uff`): one error type,
:class:`~ema_rig.errors.UFFError`, naming the file and the dataset.
"""

from __future__ import annotations

import os
import re
import stat
import tomllib
import warnings
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from types import MappingProxyType
from typing import Any, cast

import numpy as np
from numpy.typing import NDArray

from .._atomic import atomic_path
from ..dof import DOF
from ..errors import FileAccessError, UFFError, UnitWarning
from ..frf import FRFData
from ..processing import ProcessingHistory
from . import _uff_1858, _uff_coherence, _uff_parse, _uff_units, _uff_write
from .layout import SensorLayout

FUNCTION_TYPES: dict[int, str] = {
    0: "general", 1: "time response", 2: "auto spectrum", 3: "cross spectrum", 4: "FRF",
    5: "transmissibility", 6: "coherence", 7: "auto correlation", 8: "cross correlation",
    9: "PSD", 10: "ESD", 11: "probability density", 12: "spectrum", 13: "cumulative frequency distribution",
    14: "peaks valley", 15: "stress/cycles", 16: "strain/cycles", 17: "orbit", 18: "mode indicator",
    19: "force pattern", 20: "partial power", 21: "partial coherence", 22: "eigenvalue", 23: "eigenvector",
    24: "shock response spectrum", 25: "finite impulse response filter", 26: "multiple coherence",
    27: "order function",
}
"""Names of the UFF dataset-58 function type codes (record 6, field 1), 0-27 as the dataset 58
specification lists them (the SDRL universal file text, https://www.ceas3.uc.edu/sdrluff/, reproduced
by pyuff 2.5.8 as ``pyuff.datasets.dataset_58.get_structure_58(raw=True)``); another code is shown as
its number."""


@dataclass(frozen=True, slots=True, eq=False)
class UFFRecord:
    """One dataset of a UFF file, as stored.

    Attributes
    ----------
    index : int
        0-based position in the file.
    type : int or None
        Dataset type (58, 164, 151, 55 ...); None if the type line is unreadable.
    binary : bool
        True for 58b.
    function_type : int or None
        Dataset-58 function type (1 time, 4 FRF, 6 coherence, 9 PSD ...).
    response, reference : DOF or None
        As written in the file (signed; taken from the entity name when node and direction are 0).
    num_pts : int or None
        Number of values returned (equals the header's num_pts for a read dataset 58).
    x : ndarray, shape (num_pts,), float64, or None
        Abscissa in the file's unit (always explicit; for even spacing it is computed from the
        header's minimum and increment on each access, ``min + k inc``, and not stored).
    y : ndarray, shape (num_pts,), float64 or complex128, or None
        Values as stored, in the file's unit.
    units : mapping
        ``abscissa``, ``ordinate``, ``denominator``: dicts with ``code`` (specific data type),
        ``label`` (unit label), ``axis`` (axis label), ``len_exp``, ``force_exp``, ``temp_exp``.
    ids : tuple of str
        The five id lines of a dataset 58.
    header : mapping
        Every parsed header field (dataset 58) or the parsed content (dataset 164).
    status : {'read', 'refused'}
    reason : str or None
        Why the dataset was refused.
    notes : tuple of str
        What was repaired or assumed while reading (zero padding trimmed, Latin-1 labels ...).
    lines : tuple of str
        Header text lines (dataset 58) or all text lines (other ASCII datasets, not parsed).
    """

    index: int
    type: int | None
    binary: bool
    function_type: int | None
    response: DOF | None
    reference: DOF | None
    num_pts: int | None
    x_stored: NDArray[np.float64] | None
    y: NDArray[Any] | None
    units: Mapping[str, Any]
    ids: tuple[str, ...]
    header: Mapping[str, Any]
    status: str
    reason: str | None
    notes: tuple[str, ...] = ()
    lines: tuple[str, ...] = field(default=(), repr=False)

    @property
    def x(self) -> NDArray[np.float64] | None:
        """Abscissa in the file's unit, shape (num_pts,) (see the class docstring), or None."""
        if self.x_stored is not None or self.y is None:
            return self.x_stored
        h = self.header
        if h.get("abscissa_spacing") != 1:
            return None
        x = h["abscissa_min"] + np.arange(self.y.size, dtype=np.float64) * h["abscissa_inc"]
        x.setflags(write=False)
        return cast("NDArray[np.float64] | None", x)

    @property
    def num_pts_header(self) -> int | None:
        """The header's num_pts (dataset 58), also for a refused dataset."""
        v = self.header.get("num_pts")
        return int(v) if v is not None else None

    @property
    def band(self) -> tuple[float, float] | None:
        """(first, last) abscissa value of a read dataset 58."""
        if self.x_stored is None and self.y is not None and self.header.get("abscissa_spacing") == 1:
            h, n = self.header, self.y.size
            return (float(h["abscissa_min"]), float(h["abscissa_min"] + (n - 1) * h["abscissa_inc"])) if n else None
        if self.x is None or self.x.size == 0:
            return None
        return float(self.x[0]), float(self.x[-1])


@dataclass(frozen=True, slots=True, eq=False)
class UFFFile:
    """Every dataset of a UFF file in file order (see :func:`read_uff`)."""

    path: str
    records: tuple[UFFRecord, ...]

    def __iter__(self) -> Iterator[UFFRecord]:
        return iter(self.records)

    def __len__(self) -> int:
        return len(self.records)

    def __getitem__(self, i: int) -> UFFRecord:
        return self.records[i]


def _readonly(a: NDArray[Any] | None) -> NDArray[Any] | None:
    if a is not None:
        a.setflags(write=False)
    return a


def _to_record(raw: _uff_parse.RawDataset) -> UFFRecord:
    h = raw.header
    units: dict[str, Any] = {}
    if raw.type == 58 and "abscissa_spec_data_type" in h:
        for key, name in (("abscissa", "abscissa"), ("ordinate", "ordinate"), ("denominator", "orddenom")):
            units[key] = {
                "code": h.get(f"{name}_spec_data_type"),
                "label": h.get(f"{name}_axis_units_lab"),
                "axis": h.get(f"{name}_axis_lab"),
                "len_exp": h.get(f"{name}_len_unit_exp"),
                "force_exp": h.get(f"{name}_force_unit_exp"),
                "temp_exp": h.get(f"{name}_temp_unit_exp"),
            }
    status, reason = raw.status, raw.reason
    if status == "read" and raw.y is not None:
        n_bad, k = _nonfinite(raw.y, raw.x)
        if raw.x is None and h.get("abscissa_spacing") == 1 and raw.y.size:
            with np.errstate(over="ignore", invalid="ignore"):
                last = h["abscissa_min"] + (raw.y.size - 1) * h["abscissa_inc"]
            if not np.isfinite(last) and n_bad == 0:
                n_bad, k = 1, raw.y.size - 1
        if n_bad:
            status, reason = "refused", f"{n_bad} NaN or inf value(s), first at point {k}"
    return UFFRecord(
        index=raw.index,
        type=raw.type,
        binary=raw.binary,
        function_type=h.get("func_type"),
        response=h.get("response"),
        reference=h.get("reference"),
        num_pts=None if raw.y is None or raw.status != "read" else int(raw.y.size),
        x_stored=_readonly(raw.x),
        y=_readonly(raw.y),
        units=MappingProxyType(units),
        ids=tuple(h.get(f"id{i}", "") for i in range(1, 6)) if raw.type == 58 else (),
        header=MappingProxyType(dict(h)),
        status=status,
        reason=reason,
        notes=raw.notes,
        lines=raw.lines,
    )


def _nonfinite(y: NDArray[Any], x: NDArray[np.float64] | None) -> tuple[int, int]:
    """(count, first index) of the points whose value or abscissa is NaN or inf, in 1 Mi-point
    blocks (two boolean arrays of the whole dataset would cost a quarter of its size)."""
    n_bad, first = 0, -1
    step = 1 << 20
    for a in range(0, y.size, step):
        bad = ~np.isfinite(y[a : a + step])
        if x is not None:
            bad |= ~np.isfinite(x[a : a + step])
        c = int(np.count_nonzero(bad))
        if c and first < 0:
            first = a + int(np.argmax(bad))
        n_bad += c
    return n_bad, first


MAX_FILE_BYTES = 1 << 34
"""Largest UFF file read (16 GiB); larger files are refused before reading."""
_HEAD_BYTES = 1 << 16


def _toml_hint(head: bytes) -> str | None:
    """What an ema_rig TOML file given where a UFF file belongs is, and the command for it."""
    try:
        doc = tomllib.loads(head.decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError):
        return None
    if "measurement" in doc:
        return "it is a campaign file (TOML); run it with 'ema-rig campaign FILE'"
    if "model" in doc or "sensor" in doc:
        return ("it is a rig file (TOML); give it as '--rig FILE' and the UFF measurement as the file, "
                "e.g. 'ema-rig stiffness MEASUREMENT.uff --rig FILE'")
    return None
_HEAD_OK = re.compile(rb"(?:\xef\xbb\xbf)?(?:[ \t]*(?:\r\n|\r|\n))*[ \t]*-1[ \t]*(?:\r|\n|\Z)")


def starts_like_uff(head: bytes) -> bool:
    """Whether the first bytes of a file start like a UFF file.

    Parameters
    ----------
    head : bytes
        The file's first bytes (64 KiB are plenty).

    Returns
    -------
    bool
        True when they open with a ``-1`` dataset delimiter line (a UTF-8 byte-order mark and
        blank lines before it allowed).
    """
    return _HEAD_OK.match(head) is not None


def _load_bytes(path: str | PathLike[str]) -> tuple[Path, bytes]:
    """Read a regular file that starts like a UFF file, refusing everything else early.

    FIFOs, devices, sockets and directories are refused from ``os.stat`` before any open (a
    FIFO would block, ``/dev/zero`` never ends); the file is then opened non-blocking and checked
    again on the open descriptor. Its first 64 KiB must start with a ``-1`` delimiter line
    (blank lines before it are allowed) before the rest is read, so a large file of zeros or
    text is refused after reading 64 KiB.
    """
    p = Path(path)
    try:
        st = os.stat(p)
    except FileNotFoundError:
        raise FileAccessError("file not found", file=p) from None
    except OSError as exc:
        raise FileAccessError(f"cannot read: {exc.strerror or exc}", file=p) from None
    if stat.S_ISDIR(st.st_mode):
        raise UFFError("is a directory, expected a UFF file", file=p)
    if not stat.S_ISREG(st.st_mode):
        raise UFFError(f"is a {_file_kind(st.st_mode)}, not a regular file; only regular files are read", file=p)
    if st.st_size == 0:
        raise UFFError("empty file (no UFF dataset)", file=p)
    if st.st_size > MAX_FILE_BYTES:
        raise UFFError(f"file of {st.st_size} bytes is larger than the limit of {MAX_FILE_BYTES} bytes", file=p)
    try:
        fd = os.open(p, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_BINARY", 0))
    except OSError as exc:
        raise FileAccessError(f"cannot read: {exc.strerror or exc}", file=p) from None
    with os.fdopen(fd, "rb", buffering=0) as fh:
        try:
            st = os.fstat(fh.fileno())
            if not stat.S_ISREG(st.st_mode):  # replaced between stat and open
                raise UFFError(f"is a {_file_kind(st.st_mode)}, not a regular file", file=p)
            head = fh.read(_HEAD_BYTES)
            if not starts_like_uff(head):
                if not head.strip():
                    raise UFFError("empty file (no UFF dataset)", file=p)
                raise UFFError(
                    "not a UFF file: " + (_toml_hint(head) or
                                          "the first line that is not blank is not the dataset delimiter '    -1'"),
                    file=p,
                )
            if len(head) < _HEAD_BYTES:
                buf = head
            else:
                fh.seek(0)
                buf = fh.read()  # one bytes object of the file's size, no intermediate copies
        except MemoryError:
            raise FileAccessError(f"not enough memory to read {st.st_size} bytes", file=p) from None
        except OSError as exc:
            raise FileAccessError(f"cannot read: {exc.strerror or exc}", file=p) from None
    if len(buf) > MAX_FILE_BYTES:
        raise UFFError(f"file grew past the limit of {MAX_FILE_BYTES} bytes while being read", file=p)
    return p, buf


def _file_kind(mode: int) -> str:
    for test, name in ((stat.S_ISFIFO, "FIFO (named pipe)"), (stat.S_ISCHR, "character device"),
                       (stat.S_ISBLK, "block device"), (stat.S_ISSOCK, "socket")):
        if test(mode):
            return name
    return "special file"


def read_uff(path: str | PathLike[str]) -> UFFFile:
    """Read every dataset of a UFF file as plain records.

    Parameters
    ----------
    path : str or path-like
        UFF/UNV file (ASCII, binary 58b or mixed; LF, CRLF or CR line ends).

    Returns
    -------
    UFFFile
        One :class:`UFFRecord` per dataset in file order. Datasets 58/58b are parsed (any
        function type: time, spectrum, FRF, coherence, PSD ...), dataset 164 gives its unit
        factors, other types are listed with their text lines. A dataset that cannot be read
        exactly (wrong value count, truncated, byte count, NaN ...) has status ``"refused"`` and a
        reason; it never raises.

    Raises
    ------
    UFFError
        If the file is missing, not a regular file (FIFO, device, directory: refused from
        ``os.stat`` before opening, so nothing blocks), empty, larger than ``MAX_FILE_BYTES``,
        or its first line that is not blank is not a ``-1`` delimiter (checked on the first
        64 KiB before the rest is read).

    Notes
    -----
    What a dataset is refused for, besides a wrong value count: an ASCII dataset without its
    closing ``-1`` before the end of the file (the last value may be cut); a 58b dataset whose
    byte count disagrees with num_pts and data type, unless the closing ``-1`` follows the
    payload exactly and is itself followed by the next dataset or the end of the file; a 58b
    closing ``-1`` that is followed by more data (num_pts too large swallowed the real one);
    integer header fields longer than 11 characters; header lines over 4096 bytes; data
    sections holding other bytes than numbers and blanks. ASCII values are parsed in 1 MB
    chunks, so memory stays about the file size plus the float64 values.
    """
    p, buf = _load_bytes(path)
    raws = _uff_parse.scan(buf)
    if not raws:
        raise UFFError("not a UFF file: no dataset delimiter line '    -1' found", file=p)
    return UFFFile(str(p), tuple(_to_record(r) for r in raws))


def _dataset_summary(r: UFFRecord, records: tuple[UFFRecord, ...], units164: Mapping[str, Any] | None,
                     pref: str | None, assumed: str | None) -> dict[str, Any]:
    d: dict[str, Any] = {
        "index": r.index,
        "type": r.type,
        "binary": r.binary,
        "function_type": r.function_type,
        "response": None if r.response is None else str(r.response),
        "reference": None if r.reference is None else str(r.reference),
        "num_pts": r.num_pts,
        "status": r.status,
        "reason": r.reason,
    }
    if r.type == 58 and r.function_type == 4 and r.status == "read":
        # what read_uff58 refuses an FRF for (header, unit labels and units, a dataset 164 after it): the same
        # check, the same reason (other function types keep their labels as they are: a time history in V is read)
        try:
            _frf_decision(records, r, units164, pref, assumed)
        except ValueError as exc:
            d.update(status="refused", reason=str(exc), num_pts=None)
    if r.type == 58:
        d["function"] = FUNCTION_TYPES.get(r.function_type) if r.function_type is not None else None
        d["num_pts_header"] = r.num_pts_header
        d["ord_data_type"] = r.header.get("ord_data_type")
        sp = r.header.get("abscissa_spacing")
        d["spacing"] = None if sp is None else ("even" if sp == 1 else "uneven")
        d["band"] = None if r.band is None or d["status"] != "read" else list(r.band)
        d["units"] = {k: v.get("label") for k, v in r.units.items()}
    elif r.type == 164 and r.status == "read":
        d["units"] = dict(r.header)
    d["notes"] = list(r.notes)
    return d


def inspect_uff(path: str | PathLike[str], *, rig: SensorLayout | None = None,
                units: str | None = None) -> dict[str, Any]:
    """Summary of every dataset of a file, the DESIGN §3.2 ``inspect`` JSON.

    An FRF dataset is ``"refused"`` with the reason :func:`read_uff58` gives when it refuses it
    (header, unit labels and codes, unit exponents, a non-SI dataset 164 after unlabelled data),
    by the same check.

    Parameters
    ----------
    path : str or path-like
    rig : SensorLayout, optional
        Its ``unit_preference`` and ``unit_ordinate`` decide units as in :func:`read_uff58`.
    units : str, optional
        As ``read_uff58(..., units=)``.

    Returns
    -------
    dict
        ``{"file": str, "datasets": [{"index", "type", "function_type", "response", "reference",
        "num_pts", "status", "reason", ...}, ...]}``; ``type`` is ``"58"``, ``"58b"``, ``"164"`` ...;
        ``num_pts`` is the number of values returned (None when refused; ``num_pts_header`` holds
        the header's). Extra keys: ``function``, ``spacing``, ``band`` (first and last abscissa
        value), ``units`` (labels), ``notes``.
    """
    f = read_uff(path)
    pref = rig.unit_preference if rig is not None else None
    assumed = units if units is not None else (rig.unit_ordinate if rig is not None else None)
    return {"file": f.path, "datasets": [_dataset_summary(r, f.records, u, pref, assumed)
                                         for r, u in zip(f.records, _units164_in_force(f.records), strict=True)]}


def _units164_in_force(records: tuple[UFFRecord, ...]) -> list[Mapping[str, Any] | None]:
    """The header of the latest read dataset 164 before each record (None before the first)."""
    out: list[Mapping[str, Any] | None] = []
    current: Mapping[str, Any] | None = None
    for r in records:
        out.append(current)
        if r.type == 164 and r.status == "read":
            current = r.header
    return out


def _frf_decision(records: tuple[UFFRecord, ...], r: UFFRecord, units164: Mapping[str, Any] | None,
                  pref: str | None, assumed: str | None) -> _uff_units.UnitDecision:
    """The unit decision of a read FRF dataset, or ValueError with why read_uff58 refuses it.

    The one definition of what refuses a read FRF dataset for its header or units (``inspect``
    shows the same reason): a header that is no FRF (:func:`_uff_units.frf_header_problem`), a
    missing response or reference DOF, units that cannot be decided (:func:`_uff_units.decide`:
    unreadable or contradicting labels, exponents that are no response per force), SI assumed while
    a non-SI dataset 164 follows (:func:`_uff_units.trailing_units_problem`).
    """
    problem = _uff_units.frf_header_problem(r.header)
    if problem is not None:
        raise ValueError(problem)
    if r.response is None or r.reference is None:
        raise ValueError("response or reference DOF missing: " + "; ".join(r.notes))
    dec = _uff_units.decide(dict(r.header), dict(units164) if units164 else None, pref, assumed)
    if _uff_units.SI_ASSUMED in dec.text or _uff_units.ORDINATE_SI_ASSUMED in dec.text:
        trailing = _uff_units.trailing_units_problem(records, r.index)
        if trailing is not None:
            raise ValueError(trailing)
    return dec


# --------------------------------------------------------------------------- read_uff58
def _match_ref(rig: SensorLayout, d: DOF) -> DOF | None:
    for r in rig.references:
        if r.same_axis(d):
            return r
    return None


def read_uff58(
    path: str | PathLike[str], *, rig: SensorLayout | None = None, freq_rtol: float = 1e-6,
    units: str | None = None,
) -> FRFData:
    """Read all FRF datasets of a UFF58 file into one FRFData in SI units.

    Parameters
    ----------
    path : str or path-like
        UFF file with datasets 58/58b; every dataset of function type 4 (FRF) is used.
    rig : SensorLayout (a RigConfig or a ChannelLayout), optional
        Rig configuration: selects and orders the outputs (rig sensor order), sets roles and axes,
        decides signs, and may settle unit conflicts (``unit_preference``).
    freq_rtol : float, optional
        Tolerance for comparing frequency axes between datasets, relative to the highest
        frequency. Axes that differ more are an error; nothing is resampled.
    units : str, optional
        Response unit of FRF datasets that carry no ordinate unit label, e.g. ``"g"`` (per N
        unless the denominator says otherwise; ``ema-rig ... --units g``); default the rig
        file's ``[units] ordinate``. A dataset's own label always wins.

    Returns
    -------
    FRFData
        ``frf`` shape (n_out, n_in, n_freq) in SI (m/s^2/N, m/s/N or m/N), ``freq`` in Hz.
        ``coherence`` (n_out, n_in, n_freq), 0..1, from the file's coherence datasets, or None
        (see Notes);
        ``n_averages`` when an id line states it (UFF58 has no field for it), else None.
        ``meta``: ``source`` (path), ``datasets`` (indices used), ``coherence_datasets``,
        ``unit_decisions`` (one str per dataset used), ``sign_flips``, ``ignored_channels``,
        ``ignored_datasets``, ``notes``, ``warnings`` (one-line strings: coherence clipped ...),
        ``ids`` (id lines per dataset index), ``rig`` (rig file path or None),
        ``units_assumed`` (a sentence, present only when datasets state no units: SI assumed), and
        ``processing`` (:class:`~ema_rig.processing.ProcessingHistory` from the datasets 1858
        before the FRFs, present only when every FRF has the same one; when no id line gives another
        count, ``n_averages`` is its equivalent number of independent averages,
        :meth:`~ema_rig.processing.ProcessingHistory.independent_averages`: overlapped segments count less).

    Raises
    ------
    UFFError
        Naming file, dataset index and the problem: unreadable or refused FRF dataset, NaN/inf,
        unknown or conflicting units, duplicate or missing (response, reference) pairs,
        frequency axes that differ, a rig sensor or reference absent from the file.

    Notes
    -----
    Units. The quantity comes from the ordinate specific data type (8 displacement -> receptance,
    11 velocity -> mobility, 12 acceleration -> accelerance; denominator 13 or 9, force) and from
    the unit labels (``g`` = 9.80665 m/s^2, ``mm``, ``in``, ``lbf``, ``(m/s)/N`` ...). When code and
    label name different quantities, ``rig.unit_preference`` (``"code"`` or ``"label"``) decides,
    else it is an error. A unit label sets the scale (:func:`ema_rig.io.units.parse_unit_label`:
    ``mm s^-2``, ``mg``, ``in/s2/lbf`` ...); a label that cannot be read is an error naming the
    dataset and the label, never taken as SI; without a label, the scale comes from the latest
    preceding dataset 164 (its length/force factors and the header's unit exponents), else SI is
    assumed, unless a dataset 164 with other units follows (then refused: whether it was meant for
    the datasets before it the file does not say). A whole-FRF ordinate label (``g/N``) over a
    denominator label naming another force (``lbf``) is refused. The abscissa label is read by the same grammar (Hz, kHz, rad/s; a time unit is an
    error). Each decision is recorded in ``meta["unit_decisions"]``.

    Signs. Without a rig, a negative direction in the file (``13-Y``) is flipped into the
    positive axis (values x -1, DOF ``13+Y``). With a rig, the rig's sign decides: a sensor
    ``13-Y`` is flipped whether the file writes 13-Y or 13+Y (a disagreement is noted in
    ``meta["sign_flips"]`` and is one line of ``meta["warnings"]``, a caveat of the results); the same holds for the references ``rig.radial`` / ``rig.axial``.
    File responses with no rig sensor are ignored with a :class:`~ema_rig.errors.UnitWarning`.

    Coherence. Datasets of function type 6 are attached to the FRF of the same (response,
    reference) pair (mapped like the FRFs, sign-free) when they lie on the same frequency lines;
    a record labelled ``%`` is divided by 100, one with another unit label or with most lines above 1
    is ignored with a note; values above 1 (which real analysers write) or below 0 are clipped into 0..1 and listed in
    ``meta["warnings"]`` (a result caveat, not a Python warning: reading a real file is routine). A coherence
    whose pair has no FRF, whose lines differ, or that is refused is ignored with a note. The
    coherence is attached only when every FRF has one (else ``coherence`` is None, with a note
    naming the FRFs without).
    """
    uf = read_uff(path)
    src = uf.path
    pref = rig.unit_preference if rig is not None else None
    assumed = units if units is not None else (rig.unit_ordinate if rig is not None else None)
    if assumed is not None:
        try:
            _uff_units.response_unit(assumed)
        except ValueError as exc:
            raise UFFError(f"units: {exc}", file=src) from None
    used, ignored_datasets, coh_recs = _frf_datasets(uf, src, pref, assumed)
    freq, tol, dec0 = _common_freq_axis(used, src, freq_rtol)
    chans = _map_channels(used, rig, src)
    out_order, in_order, roles, axes = _rig_order(chans, rig, src)
    frf, decisions, used_idx, ids = _assemble(used, chans, out_order, in_order, freq.size, src)
    notes = [f"dataset {r.index}: {n}" for r, _, _ in used for n in r.notes]

    def coh_key(rd: DOF, fd: DOF) -> tuple[DOF, DOF] | None:
        if rig is None:
            return rd.positive(), fd.positive()
        sensor, rref = rig.sensor_for(rd), _match_ref(rig, fd)
        return None if sensor is None or rref is None else (sensor.dof.positive(), rref.positive())

    coh = _uff_coherence.attach(coh_recs, freq, tol, out_order, in_order, coh_key)
    attached = set(coh.datasets)
    ignored_datasets += [f"dataset {r.index}: function type 6 (coherence), not attached" for r in coh_recs
                         if r.index not in attached]
    n_count, avg_note = _uff_coherence.n_averages([r.ids for r in uf.records if r.index in ids or r.index in attached])
    n_avg: float | None = n_count
    notes += list(coh.notes) + ([avg_note] if avg_note else [])
    # ---- processing history from datasets 1858 (issue 18; see _uff_1858) ----
    q_pairs, q_notes = _uff_1858.qualify(uf.records)
    history, h_notes, h_warnings = _uff_1858.combine(q_pairs, sorted(used_idx))
    q_used = {q for q, _ in q_pairs.values()}
    ignored_datasets = [s for s in ignored_datasets if not any(s.startswith(f"dataset {q}:") for q in q_used)]
    notes += q_notes + h_notes
    if history is not None and (n_avg is None or n_avg == history.n_averages):
        # the segments the history (and an id line) count, overlapped, count less (Welch 1967)
        n_avg = history.independent_averages()
    # ---- end processing history ----
    meta: dict[str, Any] = {
        "source": src,
        "datasets": sorted(used_idx),
        "coherence_datasets": list(coh.datasets),
        "unit_decisions": decisions,
        "sign_flips": chans.sign_flips,
        "ignored_channels": chans.ignored_channels,
        "ignored_datasets": ignored_datasets,
        "notes": notes,
        "warnings": list(coh.warnings) + h_warnings + sign_conflict_warning(chans.sign_conflicts),
        "ids": ids,
        "rig": None if rig is None else rig.path,
    }
    n_assumed = sum(_uff_units.SI_ASSUMED in d for d in decisions)
    n_ordinate = sum(_uff_units.ORDINATE_SI_ASSUMED in d for d in decisions)
    if n_assumed or n_ordinate:  # the caveat for every result in kg, m or N (effective masses, residues, shapes)
        meta["units_assumed"] = "; ".join(
            f"{n} of {len(decisions)} FRF datasets: {what}"
            for n, what in ((n_assumed, _uff_units.SI_ASSUMED), (n_ordinate, _uff_units.ORDINATE_SI_ASSUMED)) if n)
    if history is not None:
        meta["processing"] = history  # issue 18: window, averaging, band (dataset 1858)
    frf.setflags(write=False)  # built here and frozen: FRFData keeps it without a copy
    try:
        return FRFData(
            freq, frf, tuple(out_order), tuple(in_order), dec0.frf_form, roles=tuple(roles), axes=tuple(axes),
            meta=meta, coherence=coh.values, n_averages=n_avg,
        )
    except ValueError as exc:  # pragma: no cover - all checked above
        raise UFFError(str(exc), file=src) from None


# ---- the parts of read_uff58, in the order it calls them
_Used = list[tuple[UFFRecord, _uff_units.UnitDecision, Mapping[str, Any] | None]]


def _frf_datasets(uf: UFFFile, src: str, pref: str | None,
                  assumed: str | None) -> tuple[_Used, list[str], list[UFFRecord]]:
    """The FRF datasets with their unit decisions, the datasets ignored (why), the coherence datasets."""
    used: _Used = []
    ignored_datasets: list[str] = []
    coh_recs: list[UFFRecord] = []
    for r, current164 in zip(uf.records, _units164_in_force(uf.records), strict=True):
        if r.type == 164 and r.status == "read":
            continue
        if r.status != "read" and r.type in (None, 164):
            # an unreadable type line may hide an FRF; a refused 164 would change the units of
            # the FRFs after it: neither can be skipped silently
            what = "dataset of unknown type" if r.type is None else "units dataset 164"
            raise UFFError(f"{what} refused: {r.reason}", file=src, dataset=r.index)
        if r.type != 58:
            ignored_datasets.append(f"dataset {r.index}: type {r.type} (not 58)")
            continue
        if r.function_type == 6:
            coh_recs.append(r)
            continue
        if r.function_type not in (4, None):
            name = FUNCTION_TYPES.get(r.function_type, "other")
            ignored_datasets.append(f"dataset {r.index}: function type {r.function_type} ({name}), not an FRF")
            continue
        if r.status != "read":
            raise UFFError(f"FRF dataset refused: {r.reason}", file=src, dataset=r.index)
        try:
            dec = _frf_decision(uf.records, r, current164, pref, assumed)
        except ValueError as exc:
            raise UFFError(str(exc), file=src, dataset=r.index) from None
        used.append((r, dec, current164))
    if not used:
        kinds = sorted({FUNCTION_TYPES.get(r.function_type, str(r.function_type)) for r in uf.records
                        if r.type == 58 and r.function_type is not None})
        raise UFFError(
            "no FRF dataset (dataset 58, function type 4) in the file"
            + (f"; found {', '.join(kinds)}" if kinds else ""),
            file=src,
        )
    return used, ignored_datasets, coh_recs


def _common_freq_axis(used: _Used, src: str,
                      freq_rtol: float) -> tuple[NDArray[np.float64], float, _uff_units.UnitDecision]:
    """The one frequency axis [Hz] of every FRF dataset (compared with a tolerance), the tolerance
    [Hz] and the first dataset's unit decision (its FRF form is every dataset's)."""
    r0, dec0, _ = used[0]
    try:
        afac0 = _uff_units.abscissa_factor(dict(r0.header))
    except ValueError as exc:
        raise UFFError(str(exc), file=src, dataset=r0.index) from None
    assert r0.x is not None
    freq = r0.x * afac0
    if freq[0] < 0 or (freq.size > 1 and not np.all(np.diff(freq) > 0)):
        raise UFFError("frequency axis is negative or not strictly increasing", file=src, dataset=r0.index)
    tol = freq_rtol * max(float(np.abs(freq).max()), np.finfo(float).tiny)
    for r, dec, _ in used[1:]:
        try:
            afac = _uff_units.abscissa_factor(dict(r.header))
        except ValueError as exc:
            raise UFFError(str(exc), file=src, dataset=r.index) from None
        assert r.x is not None
        if r.x.size != freq.size:
            raise UFFError(
                f"{r.x.size} frequency lines but dataset {r0.index} has {freq.size} (no resampling is done)",
                file=src, dataset=r.index,
            )
        dev = float(np.max(np.abs(r.x * afac - freq)))
        if dev > tol:
            raise UFFError(
                f"frequency axis differs from dataset {r0.index} by up to {dev:.6g} Hz "
                f"(tolerance freq_rtol={freq_rtol:g} x {freq[-1]:g} Hz; no resampling is done)",
                file=src, dataset=r.index,
            )
        if dec.frf_form != dec0.frf_form:
            raise UFFError(
                f"FRF form {dec.frf_form} differs from dataset {r0.index} ({dec0.frf_form})",
                file=src, dataset=r.index,
            )
    return freq, tol, dec0


@dataclass
class _Channels:
    """The (response, reference) pairs of the file in positive DOFs, with the sign of each."""

    pairs: dict[tuple[DOF, DOF], tuple[int, float, UFFRecord]] = field(default_factory=dict)
    out_order: list[DOF] = field(default_factory=list)
    in_order: list[DOF] = field(default_factory=list)
    sign_flips: list[str] = field(default_factory=list)
    #: (dataset index, DOF as the file writes it, DOF as the rig file says) where the signs differ
    sign_conflicts: list[tuple[int, DOF, DOF]] = field(default_factory=list)
    ignored_channels: list[str] = field(default_factory=list)
    #: Every response / reference DOF (positive) the file's FRF datasets name, kept or ignored.
    file_out: list[DOF] = field(default_factory=list)
    file_in: list[DOF] = field(default_factory=list)


def _map_channels(used: _Used, rig: SensorLayout | None, src: str) -> _Channels:
    """DOFs, signs and the rig's sensors: every FRF dataset as a positive (response, reference) pair."""
    ch = _Channels()
    for r, _dec, _ in used:
        rd, fd = r.response, r.reference
        assert rd is not None and fd is not None
        for seen, d in ((ch.file_out, rd.positive()), (ch.file_in, fd.positive())):
            if d not in seen:
                seen.append(d)
        if rig is not None:
            sensor = rig.sensor_for(rd)
            if sensor is None:
                msg = f"{src}: dataset {r.index}: response {rd} has no [[sensor]] entry in the rig file; channel ignored"
                warnings.warn(msg, UnitWarning, stacklevel=3)  # the caller of read_uff58
                ch.ignored_channels.append(f"dataset {r.index}: {rd} (no rig sensor)")
                continue
            rref = _match_ref(rig, fd)
            if rref is None:
                msg = f"{src}: dataset {r.index}: reference {fd} is not an excitation of the rig file; dataset ignored"
                warnings.warn(msg, UnitWarning, stacklevel=3)  # the caller of read_uff58
                ch.ignored_channels.append(f"dataset {r.index}: reference {fd} (not a rig excitation)")
                continue
            so, si = sensor.dof.sign, rref.sign
            for fdof, rdof in ((rd, sensor.dof), (fd, rref)):
                if fdof.sign != rdof.sign:
                    ch.sign_flips.append(
                        f"dataset {r.index}: file writes {fdof}, rig file says {rdof}: the rig's sign is used"
                    )
                    ch.sign_conflicts.append((r.index, fdof, rdof))
            out_key, in_key = sensor.dof.positive(), rref.positive()
        else:
            so, si = rd.sign, fd.sign
            out_key, in_key = rd.positive(), fd.positive()
        for fdof, s in ((rd, so), (fd, si)):
            if s < 0:
                ch.sign_flips.append(f"dataset {r.index}: {fdof} flipped into {fdof.positive()} (values x -1)")
        key = (out_key, in_key)
        if key in ch.pairs:
            raise UFFError(
                f"duplicate FRF {out_key} / {in_key}: also in dataset {ch.pairs[key][0]}",
                file=src, dataset=r.index,
            )
        ch.pairs[key] = (r.index, float(so * si), r)
        if out_key not in ch.out_order:
            ch.out_order.append(out_key)
        if in_key not in ch.in_order:
            ch.in_order.append(in_key)
    return ch


def sign_conflict_warning(conflicts: list[tuple[int, DOF, DOF]]) -> list[str]:
    """One result caveat when the rig file and the UFF file give a DOF opposite signs (DESIGN §3.1: the
    rig file's DOF is the one "as written in the UFF file"); the rig's sign is used, so if the file is
    right those FRFs are negated. Empty when they agree.

    Parameters
    ----------
    conflicts : list of (int, DOF, DOF)
        (dataset index, DOF as the UFF file writes it, DOF as the rig file says) per disagreement.

    Returns
    -------
    list of str
        Nothing or one line (``read_uff58``'s ``meta["warnings"]``, ``read_time_uff``'s ``warnings``).
    """
    if not conflicts:
        return []
    pairs = sorted({(str(f), str(g)) for _, f, g in conflicts})
    shown = ", ".join(f"file {f} / rig {g}" for f, g in pairs[:4]) + (", ..." if len(pairs) > 4 else "")
    return [f"rig file and UFF file give opposite signs for {len(pairs)} DOF(s) ({shown}) in {len(conflicts)} "
            "dataset(s): the rig file's sign is used; if the UFF file is right, those FRFs are negated"]


def _rig_order(ch: _Channels, rig: SensorLayout | None,
               src: str) -> tuple[list[DOF], list[DOF], list[str | None], list[str | None]]:
    """Output and input order, roles and axes: the file's order without a rig, the rig's with one
    (every rig sensor and excitation must be in the file)."""
    if rig is None:
        return ch.out_order, ch.in_order, [], []
    # the excitations first: a wrong one drops every dataset, and its sensors would look missing too
    for ref in rig.references:
        if ref.positive() not in ch.in_order:
            raise UFFError(
                f"rig excitation {ref} ({rig.path or 'rig file'}) is not a reference in the file "
                f"(file references: {', '.join(str(d) for d in ch.file_in) or 'none'})",
                file=src,
            )
    for sensor in rig.sensors:
        if sensor.dof.positive() not in ch.out_order:
            raise UFFError(
                f"rig sensor {sensor.dof} ({rig.path or 'rig file'}) has no FRF in the file "
                f"(file responses: {', '.join(str(d) for d in ch.file_out) or 'none'})",
                file=src,
            )
    return ([s.dof.positive() for s in rig.sensors], [d.positive() for d in rig.references],
            [s.role for s in rig.sensors], [s.axis for s in rig.sensors])


def _assemble(used: _Used, ch: _Channels, out_order: list[DOF], in_order: list[DOF], n_freq: int,
              src: str) -> tuple[NDArray[np.complex128], list[str], list[int], dict[int, tuple[str, ...]]]:
    """The FRF matrix (n_out, n_in, n_freq) in SI with signs applied, the unit decision of each
    dataset, the datasets used and their id lines."""
    frf = np.empty((len(out_order), len(in_order), n_freq), dtype=np.complex128)
    decisions: list[str] = []
    used_idx: list[int] = []
    ids: dict[int, tuple[str, ...]] = {}
    dec_by_index = {r.index: dec for r, dec, _ in used}
    for i, o in enumerate(out_order):
        for j, q in enumerate(in_order):
            if (o, q) not in ch.pairs:
                raise UFFError(f"missing FRF {o} / {q}: no dataset for this (response, reference) pair", file=src)
            idx, sign, r = ch.pairs[(o, q)]
            dec = dec_by_index[idx]
            assert r.y is not None
            with np.errstate(over="ignore", under="ignore"):
                frf[i, j] = r.y * (sign * dec.factor)
            _check_scaled(r.y, frf[i, j], dec.factor, src, idx)
            decisions.append(f"dataset {idx}: {dec.text}")
            used_idx.append(idx)
            ids[idx] = r.ids
    return frf, decisions, used_idx, ids


def _check_scaled(y: NDArray[Any], scaled: NDArray[Any], factor: float, src: str, idx: int) -> None:
    """Refuse values that overflow or vanish when the unit factor is applied."""
    if not np.all(np.isfinite(scaled)):
        raise UFFError(f"values overflow when the unit factor {factor:g} is applied", file=src, dataset=idx)
    lost = (scaled == 0) & (y != 0)
    if lost.any():
        raise UFFError(
            f"{int(lost.sum())} non-zero value(s) become 0 when the unit factor {factor:g} is applied (underflow)",
            file=src, dataset=idx,
        )


# -------------------------------------------------------------------------- write_uff58
def write_uff58(
    path: str | PathLike[str],
    data: FRFData,
    *,
    binary: bool = False,
    double: bool = True,
    accel_unit: str = "m/s^2",
    rig: SensorLayout | None = None,
    abscissa: str = "auto",
    history: ProcessingHistory | None = None,
    labelled: bool = True,
) -> None:
    """Write FRFs as UFF dataset 58 (ASCII) or 58b (binary), one dataset per (output, input).

    Parameters
    ----------
    path : str or path-like
        Output file, written atomically (a temporary file renamed into place).
    data : FRFData
        FRFs in SI; never modified.
    binary : bool, optional
        58b (little-endian IEEE 754) instead of ASCII.
    double : bool, optional
        Double precision (ordinate types 6; ASCII E20.12, 13 significant digits) or single
        (type 5; ASCII E13.5, 6 digits; binary float32).
    accel_unit : {'m/s^2', 'g'}, optional
        Unit of accelerance: ``'g'`` writes values / 9.80665 labelled ``g`` (read back in m/s^2/N).
    rig : SensorLayout (a RigConfig or a ChannelLayout), optional
        Each output is written with its rig sensor's signed DOF (sensor ``13-Y``: node 13,
        direction -2, values x -1), and each input with the rig's signed reference, so that
        ``read_uff58(path, rig=rig)`` gives ``data`` back.
    abscissa : {'auto', 'even', 'uneven'}, optional
        ``'auto'`` writes an even abscissa (minimum and increment in the header) when the lines
        are equally spaced and, in binary, the header's 13-column fields reproduce the axis to
        1e-12 (else the explicit float64 abscissa is stored); in ASCII an even axis is always
        written even (the uneven ASCII abscissa, E13.5, has fewer digits than the header).
    history : ProcessingHistory, optional
        How the FRFs were estimated (window, exponential decay, averaging, band): written as a
        dataset 1858 before every dataset 58 and read back into ``meta["processing"]``.
    labelled : bool, optional
        Write the unit labels (default). False when the units were assumed, not known (time
        histories without unit labels): the labels say ``NONE``, the ordinate code still names
        the quantity, and a reader assumes SI with a note instead of reading an assumption as fact.

    Raises
    ------
    UFFError
        NaN/inf values (never written as 0), an unknown option, or an output that cannot be written.

    Notes
    -----
    Round trip precision: binary double is bit-exact (``'g'`` within 1 ulp); ASCII double to
    13 significant digits; single precision to float32 (binary) or 6 digits (ASCII). The even
    abscissa minimum and increment are written in their 13-column fields as the shortest exact
    decimal when it fits (0.244140625), else with as many digits as fit (about 11 for steps
    below 10 Hz); the uneven ASCII abscissa keeps 7 digits (``%13.6E``).
    """
    if not isinstance(data, FRFData):
        raise TypeError(f"data must be an FRFData, got {type(data).__name__}")
    if accel_unit not in ("m/s^2", "g"):
        raise ValueError(f"accel_unit must be 'm/s^2' or 'g', got {accel_unit!r}")
    if abscissa not in ("auto", "even", "uneven"):
        raise ValueError(f"abscissa must be 'auto', 'even' or 'uneven', got {abscissa!r}")
    if accel_unit == "g" and data.frf_form != "accelerance":
        raise ValueError(f"accel_unit='g' needs accelerance data, got {data.frf_form}")
    bad = ~np.isfinite(data.frf)
    if bad.any():
        i, j, k = (int(v[0]) for v in np.nonzero(bad))
        raise UFFError(
            f"refusing to write {int(bad.sum())} NaN/inf FRF value(s) (first: {data.out_dofs[i]} / "
            f"{data.in_dofs[j]} at {data.freq[k]:g} Hz); NaN is never written as 0",
            file=path,
        )
    freq = np.array(data.freq, dtype=np.float64)
    even = _choose_even(freq, abscissa, binary, data.is_even)
    if abscissa == "even" and not data.is_even:
        raise ValueError("abscissa='even' but the frequency lines are not equally spaced")
    if accel_unit == "g":
        scale, label = 1.0 / _uff_units.G0, "g"
    else:
        scale, label = 1.0, _uff_write._FORM_CODE[data.frf_form][1]
    date = _uff_write.date_id()
    chunks: list[bytes] = []
    for i, o in enumerate(data.out_dofs):
        o_w, so = o, 1.0
        if rig is not None:
            s = rig.sensor_for(o)
            if s is not None:
                o_w, so = s.dof, float(o.sign * s.dof.sign)
        for j, q in enumerate(data.in_dofs):
            q_w, sq = q, 1.0
            if rig is not None:
                rr = _match_ref(rig, q)
                if rr is not None:
                    q_w, sq = rr, float(q.sign * rr.sign)
            y = data.frf[i, j] * (so * sq)  # new array: the caller's data are never touched
            if scale != 1.0:
                y = y * scale
            ids = (f"{o_w} / {q_w} {data.frf_form}", "ema_rig", date, "NONE", "NONE")
            if history is not None:  # issue 18: dataset 1858 qualifies the dataset 58 after it
                chunks.append(_uff_1858.dataset_bytes(history, record=len(chunks) // 2 + 1))
            chunks.append(
                _uff_write.dataset_bytes(
                    x=freq, y=y, even=even, binary=binary, double=double, response=o_w, reference=q_w,
                    frf_form=data.frf_form, unit_label=label if labelled else "NONE", ids=ids,
                    force_label="N" if labelled else "NONE",
                )
            )
    try:
        with atomic_path(path) as tmp:
            tmp.write_bytes(b"".join(chunks))
    except OSError as exc:
        raise UFFError(f"cannot write: {exc.strerror or exc}", file=path) from None


def _choose_even(freq: NDArray[np.float64], abscissa: str, binary: bool, is_even: bool) -> bool:
    if abscissa != "auto":
        return abscissa == "even"
    if not is_even or freq.size < 2:
        return freq.size < 2
    if not binary:
        return True
    f0 = float(_uff_write.fmt13(freq[0]))
    df = float(_uff_write.fmt13((freq[-1] - freq[0]) / (freq.size - 1)))
    rebuilt = f0 + np.arange(freq.size) * df
    return bool(np.max(np.abs(rebuilt - freq)) <= 1e-12 * max(float(freq[-1]), 1.0))


__all__ = ["FUNCTION_TYPES", "UFFFile", "UFFRecord", "inspect_uff", "read_uff", "read_uff58", "write_uff58"]
