"""Time histories (UFF dataset 58, function type 1) as force and response records.

Functions
---------
read_time_uff
    Every time-history dataset of a UFF file -> :class:`TimeData` (forces and responses on one
    time axis, in SI where the unit labels say how).

Classes
-------
TimeData
    Frozen: ``force`` (n_records, n_in, n_samples), ``response`` (n_records, n_out, n_samples),
    ``fs``, DOFs, FRF form.

Notes
-----
The datasets are read by :func:`ema_rig.io.uff.read_uff` (the checked parser). A dataset whose
ordinate type is 13 (excitation force) or 9 (reaction force) is a force channel; 12, 11 or 8
(acceleration, velocity, displacement) a response channel; with type 0 (unknown) or 1 (general)
its unit label decides (``N`` a force, ``m/s²`` or ``g`` a response). An explicit (uneven-format)
time axis is accepted as even sampling within the rounding of its 6 digits. A DOF that appears k times is k
records (e.g. k impacts, each written as its own force and response datasets); record r pairs
the r-th dataset of every channel.

Units: the time axis label is read by :func:`ema_rig.io.units.parse_unit_label` (``s``, ``ms``,
``(Sec)``; no label: s); each channel's values by its ordinate label, else by the dataset 164
in force (length and force factors, the exponents of its data type), else as SI (noted). A
label that cannot be read, or one that is not of the channel's quantity, is an error. The
channels of one record must start at the same time (the header's abscissa minimum); ema_rig
does not shift channels. A record that needs no scaling is kept as a view of the file's values.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from types import MappingProxyType
from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from ..dof import DOF
from ..errors import UFFError, UnitWarning
from ..literals import FrfForm
from . import _uff_units
from .layout import SensorLayout
from .uff import UFFRecord, read_uff, sign_conflict_warning
from .units import FORM_DIMS, parse_unit

_FORCE_CODES = (13, 9)
_RESPONSE_FORM: dict[int, FrfForm] = {12: "accelerance", 11: "mobility", 8: "receptance"}
_DIMS: dict[str, tuple[int, int, int]] = {"force": (0, 0, 1), **{form: dims for dims, form in FORM_DIMS.items()}}  # (length, time, force) exponents
_CODES_UNSTATED = (0, 1)  # ordinate specific data type "unknown" and "general": the unit label says what it is
EXPLICIT_ABSCISSA_DIGITS = 6
"""Significant digits an explicit (uneven-format) time abscissa carries at worst: ASCII ``E13.5``, the
format UFF58 record 12 prescribes for it (float32 in 58b is finer). Even sampling written this way is
accepted within its rounding, see :func:`_time_axis`."""


@dataclass(frozen=True, slots=True, eq=False)
class TimeData:
    """Simultaneously sampled force and response records.

    Attributes
    ----------
    force : ndarray, shape (n_records, n_in, n_samples), float64
        Forces [N] (or the file's unit when it has no unit label, see ``notes``).
    response : ndarray, shape (n_records, n_out, n_samples), float64
        Responses [m/s^2, m/s or m per ``frf_form``] (same caveat).
    fs : float
        Sampling rate [Hz].
    in_dofs, out_dofs : tuple of DOF
        Force and response DOFs, sign-corrected (positive directions).
    frf_form : str
        ``'accelerance'``, ``'mobility'`` or ``'receptance'`` (from the responses).
    source : str
        The file.
    notes : tuple of str
        Unit assumptions, sign flips, ignored datasets.
    warnings : tuple of str
        Caveats of every result from these records (one line each): the rig file and the UFF file
        giving a DOF opposite signs, as ``read_uff58``'s ``meta["warnings"]``.
    datasets : mapping
        ``{"force": [[index per record] per input], "response": [...]}``: dataset indices used.
    """

    force: NDArray[np.float64]
    response: NDArray[np.float64]
    fs: float
    in_dofs: tuple[DOF, ...]
    out_dofs: tuple[DOF, ...]
    frf_form: FrfForm
    source: str
    notes: tuple[str, ...] = ()
    warnings: tuple[str, ...] = ()
    datasets: Mapping[str, Any] = field(default_factory=dict)

    @property
    def n_records(self) -> int:
        """Number of records (impacts or takes) per channel."""
        return int(self.force.shape[0])

    @property
    def n_samples(self) -> int:
        """Samples per record."""
        return int(self.force.shape[2])

    def __repr__(self) -> str:
        return (f"TimeData({len(self.in_dofs)} force x {len(self.out_dofs)} response channel(s), "
                f"{self.n_records} record(s) of {self.n_samples} samples at {self.fs:g} Hz)")


def _scale(r: UFFRecord, kind: str, src: str, notes: list[str], units164: Mapping[str, Any] | None,
           records: tuple[UFFRecord, ...]) -> float:
    """SI factor of one channel's values: its unit label, else the dataset 164 in force, else 1
    (unless a dataset 164 follows: :func:`~ema_rig.io._uff_units.trailing_units_problem`)."""
    try:
        fac, how = _uff_units.ordinate_factor(dict(r.header), _DIMS[kind], None if units164 is None
                                              else dict(units164))
    except ValueError as exc:
        raise UFFError(str(exc), file=src, dataset=r.index) from None
    if how.startswith("no unit label"):
        trailing = _uff_units.trailing_units_problem(records, r.index)
        if trailing is not None:
            raise UFFError(trailing, file=src, dataset=r.index)
        notes.append(f"dataset {r.index}: no unit label and no dataset 164; values used as stored (SI assumed)")
    elif fac != 1.0:
        notes.append(f"dataset {r.index}: {how} x {fac:.10g} to SI")
    return float(fac)


def _channel_kind(r: UFFRecord, src: str, notes: list[str]) -> Literal["force"] | FrfForm:
    """``'force'`` or the FRF form of a time history's responses, from its ordinate type code or,
    when the code is 0 (unknown) or 1 (general), from its unit label (``N``, ``m/s²``, ``g``).

    Writers such as HBM catman and UFFFiles.jl store code 0 or 1 with a unit label (corpus:
    ``hbm_catman_time.uff`` 1 / ``m/s²``, ``ufffiles_time.unv`` 0 / ``N``); the label then says what
    the channel measures, as it does for an FRF (:func:`ema_rig.io._uff_units.decide`). A code 0/1
    without a label, or with a label of another quantity (V, Pa), is refused.
    """
    code = r.header.get("ordinate_spec_data_type")
    if code in _FORCE_CODES:
        return "force"
    if code in _RESPONSE_FORM:
        return _RESPONSE_FORM[code]
    lab = str(r.header.get("ordinate_axis_units_lab", ""))
    unit = None
    if code in _CODES_UNSTATED:
        try:
            unit = parse_unit(lab, "ordinate unit label")
        except ValueError as exc:
            raise UFFError(str(exc), file=src, dataset=r.index) from None
    kind: Literal["force"] | FrfForm | None = None
    if unit is not None:
        kind = "force" if unit.dims == _DIMS["force"] else FORM_DIMS.get(unit.dims)
    if unit is None or kind is None:
        said = "" if code not in _CODES_UNSTATED else " and it has no unit label" if unit is None else (
            f" and its unit label {lab.strip()!r} is not a force, acceleration, velocity or displacement")
        raise UFFError(f"ordinate type {code} is neither a force (13, 9) nor a response (12, 11, 8){said}: "
                       "cannot tell excitation from response", file=src, dataset=r.index)
    notes.append(f"dataset {r.index}: ordinate type {code} states no quantity; its unit label {lab.strip()!r} "
                 f"says {unit.quantity}")
    return kind


def _time_axis(r: UFFRecord, src: str) -> tuple[float, float, int]:
    """(start [s], sampling interval [s], samples) of a time history, from its header when evenly spaced."""
    h = r.header
    try:
        tfac = _uff_units.time_factor(dict(h))
    except ValueError as exc:
        raise UFFError(str(exc), file=src, dataset=r.index) from None
    assert r.y is not None
    n = int(r.y.size)
    if n < 2:
        raise UFFError("time history with fewer than 2 samples", file=src, dataset=r.index)
    if h.get("abscissa_spacing") == 1:
        t0, dt = float(h["abscissa_min"]) * tfac, float(h["abscissa_inc"]) * tfac
        if not dt > 0:
            raise UFFError(f"time increment {h['abscissa_inc']!r} is not positive", file=src, dataset=r.index)
        return t0, dt, n
    x = r.x
    assert x is not None
    dt = float(x[-1] - x[0]) / (n - 1)
    # an explicit abscissa is stored to 6 significant digits at worst (ASCII E13.5, UFF58 record
    # 12; float32 is finer): even sampling written that way lies within half a unit of the sixth
    # digit of the largest |t| of the line through its end points
    top = float(np.max(np.abs(x)))
    tol = 0.5 * 10.0 ** (np.floor(np.log10(top)) + 1 - EXPLICIT_ABSCISSA_DIGITS) if top > 0 else 0.0
    dev = float(np.max(np.abs(x - (x[0] + np.arange(n) * dt))))
    if not (dt > 0 and np.all(np.diff(x) > 0) and dev <= 2.0 * tol):  # 2: both end points are rounded too
        raise UFFError(f"time axis is not evenly spaced and increasing (deviates by up to {dev:.3g} s from even "
                       f"sampling at {dt:.6g} s; its 6-digit rounding allows {2.0 * tol:.3g} s)",
                       file=src, dataset=r.index)
    return float(x[0]) * tfac, dt * tfac, n


def read_time_uff(path: str | PathLike[str], *, rig: SensorLayout | None = None) -> TimeData:
    """Read the force and response time histories of a UFF file.

    Parameters
    ----------
    path : str or path-like
        UFF file with dataset-58 time histories (function type 1), ASCII or binary.
    rig : SensorLayout (a RigConfig or a ChannelLayout), optional
        Keeps only the rig's sensors (in rig order, the rig's sign decides as in
        :func:`~ema_rig.io.uff.read_uff58`) and the rig's excitations as forces.

    Returns
    -------
    TimeData

    Raises
    ------
    UFFError
        Naming file and dataset: no time history, a refused time dataset, an ordinate type that
        is neither force nor response, unknown units (ordinate or time axis), different sampling
        or lengths, channels of one record that start at different times, channels with
        different numbers of records, no force or no response channel.
    """
    uf = read_uff(path)
    src = uf.path
    notes: list[str] = []
    chans: dict[tuple[str, DOF], list[tuple[UFFRecord, float, float]]] = {}
    forms: set[FrfForm] = set()
    dt0: float | None = None
    n0: int | None = None
    first: UFFRecord | None = None
    current164: Mapping[str, Any] | None = None
    conflicts: list[tuple[int, DOF, DOF]] = []
    for r in uf.records:
        if r.type == 164:
            if r.status != "read":
                raise UFFError(f"units dataset 164 refused: {r.reason}", file=src, dataset=r.index)
            current164 = r.header
            continue
        if r.type != 58 or r.function_type != 1:
            if r.type == 58:
                notes.append(f"dataset {r.index}: function type {r.function_type}, not a time history; ignored")
            continue
        if r.status != "read":
            raise UFFError(f"time history refused: {r.reason}", file=src, dataset=r.index)
        if r.response is None:
            raise UFFError("time history without a node/direction", file=src, dataset=r.index)
        kind = _channel_kind(r, src, notes)
        if kind != "force":
            forms.add(kind)
        assert r.y is not None
        if np.iscomplexobj(r.y):
            raise UFFError("complex time history", file=src, dataset=r.index)
        t_start, dt, n = _time_axis(r, src)
        if first is None:
            first, dt0, n0 = r, dt, n
        elif abs(dt - (dt0 or dt)) > 1e-9 * dt or n != n0:
            raise UFFError(f"sampling ({n} samples, dt {dt:g} s) differs from dataset {first.index} "
                           f"({n0} samples, dt {dt0:g} s)", file=src, dataset=r.index)
        fac = _scale(r, kind, src, notes, current164, uf.records)
        dof = r.response
        sign = float(dof.sign)
        if rig is not None:
            if kind == "force":
                match = next((q for q in rig.references if q.same_axis(dof)), None)
                if match is None:
                    notes.append(f"dataset {r.index}: force at {dof} is not a rig excitation; ignored")
                    continue
                sign = float(match.sign)
                if dof.sign != match.sign:
                    conflicts.append((r.index, dof, match))
            else:
                sensor = rig.sensor_for(dof)
                if sensor is None:
                    msg = f"{src}: dataset {r.index}: response {dof} has no [[sensor]] entry in the rig file; channel ignored"
                    warnings.warn(msg, UnitWarning, stacklevel=2)
                    notes.append(f"dataset {r.index}: {dof} has no rig sensor; ignored")
                    continue
                sign = float(sensor.dof.sign)
                if dof.sign != sensor.dof.sign:
                    conflicts.append((r.index, dof, sensor.dof))
        if sign < 0:
            notes.append(f"dataset {r.index}: {dof} flipped into {dof.positive()} (values x -1)")
        key = ("force" if kind == "force" else "response", dof.positive())
        chans.setdefault(key, []).append((r, sign * fac, t_start))
    if first is None or dt0 is None:
        raise UFFError("no time history (dataset 58, function type 1) in the file", file=src)
    if len(forms) > 1:
        raise UFFError(f"responses of different kinds ({', '.join(sorted(forms))}); one FRF form per file",
                       file=src)
    ins = [k[1] for k in chans if k[0] == "force"]
    outs = [k[1] for k in chans if k[0] == "response"]
    if rig is not None:
        outs = [s.dof.positive() for s in rig.sensors if ("response", s.dof.positive()) in chans]
        ins = [q.positive() for q in rig.references if ("force", q.positive()) in chans]
        missing = [str(s.dof) for s in rig.sensors if ("response", s.dof.positive()) not in chans]
        if missing:
            raise UFFError(f"rig sensor(s) {', '.join(missing)} have no time history in the file", file=src)
    if not ins:
        raise UFFError("no force channel (ordinate type 13 or 9) among the time histories", file=src)
    if not outs:
        raise UFFError("no response channel (ordinate type 12, 11 or 8) among the time histories", file=src)
    counts = {f"{k[0]} {k[1]}": len(v) for k, v in chans.items()}
    if len(set(counts.values())) != 1:
        raise UFFError("channels hold different numbers of records: "
                       + ", ".join(f"{k}: {v}" for k, v in counts.items()), file=src)
    n_rec = next(iter(counts.values()))
    assert dt0 is not None
    for k in range(n_rec):  # record k of every channel must start at the same time
        starts = [(chans[c][k][2], chans[c][k][0].index) for c in chans]
        (ta, ia), (tb, ib) = min(starts), max(starts)
        if tb - ta > 1e-6 * dt0:
            raise UFFError(
                f"channels of record {k + 1} start at different times: dataset {ia} at {ta:.9g} s, dataset {ib} "
                f"at {tb:.9g} s ({(tb - ta) / dt0:.4g} samples apart); the FRF needs simultaneous records "
                "(ema_rig does not shift channels)", file=src, dataset=ib)

    def stack(kind: str, dofs: list[DOF]) -> tuple[NDArray[np.float64], list[list[int]]]:
        used = [[r.index for r, _, _ in chans[(kind, d)]] for d in dofs]
        if n_rec == 1 and len(dofs) == 1:
            r, s, _ = chans[(kind, dofs[0])][0]
            assert r.y is not None
            if s == 1.0 and r.y.dtype == np.float64:  # a view of the file's values: no copy
                return r.y[None, None, :], used
        arr = np.empty((n_rec, len(dofs), int(n0 or 0)))
        for c, d in enumerate(dofs):
            for k, (r, s, _) in enumerate(chans[(kind, d)]):
                assert r.y is not None
                np.multiply(r.y, s, out=arr[k, c])
        arr.setflags(write=False)
        return arr, used

    force, used_f = stack("force", ins)
    resp, used_r = stack("response", outs)
    return TimeData(
        force=force, response=resp, fs=1.0 / dt0, in_dofs=tuple(ins), out_dofs=tuple(outs),
        frf_form=forms.pop(), source=src, notes=tuple(notes), warnings=tuple(sign_conflict_warning(conflicts)),
        datasets=MappingProxyType({"force": used_f, "response": used_r}),
    )


__all__ = ["TimeData", "read_time_uff"]
