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
(acceleration, velocity, displacement) a response channel. A DOF that appears k times is k
records (e.g. k impacts, each written as its own force and response datasets); record r pairs
the r-th dataset of every channel.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from types import MappingProxyType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..config import RigConfig
from ..dof import DOF
from ..errors import UFFError, UnitWarning
from . import _uff_units
from .uff import UFFRecord, read_uff

_FORCE_CODES = (13, 9)
_RESPONSE_FORM = {12: "accelerance", 11: "mobility", 8: "receptance"}
_DIMS = {"force": (0, 0, 1), "accelerance": (1, -2, 0), "mobility": (1, -1, 0), "receptance": (1, 0, 0)}


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
    datasets : mapping
        ``{"force": [[index per record] per input], "response": [...]}``: dataset indices used.
    """

    force: NDArray[np.float64]
    response: NDArray[np.float64]
    fs: float
    in_dofs: tuple[DOF, ...]
    out_dofs: tuple[DOF, ...]
    frf_form: str
    source: str
    notes: tuple[str, ...] = ()
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


def _scale(r: UFFRecord, kind: str, src: str, notes: list[str]) -> float:
    label = str(r.units.get("ordinate", {}).get("label") or "")
    try:
        unit = _uff_units.parse_unit(label)
    except ValueError as exc:  # a label understood but out of range
        raise UFFError(f"ordinate unit label {label!r}: {exc}", file=src, dataset=r.index) from None
    if unit is None:
        if label.strip().lower() not in _uff_units._NO_LABEL:
            raise UFFError(f"ordinate unit label {label!r} not understood", file=src, dataset=r.index)
        notes.append(f"dataset {r.index}: no unit label; values used as stored (SI assumed)")
        return 1.0
    if unit.dims != _DIMS[kind]:
        raise UFFError(f"ordinate unit {label!r} is not a {'force' if kind == 'force' else kind + ' response'}"
                       " unit", file=src, dataset=r.index)
    if unit.factor != 1.0:
        notes.append(f"dataset {r.index}: {label} x {unit.factor:.10g} to SI")
    return float(unit.factor)


def read_time_uff(path: str | PathLike[str], *, rig: RigConfig | None = None) -> TimeData:
    """Read the force and response time histories of a UFF file.

    Parameters
    ----------
    path : str or path-like
        UFF file with dataset-58 time histories (function type 1), ASCII or binary.
    rig : RigConfig, optional
        Keeps only the rig's sensors (in rig order, the rig's sign decides as in
        :func:`~ema_rig.io.uff.read_uff58`) and the rig's excitations as forces.

    Returns
    -------
    TimeData

    Raises
    ------
    UFFError
        Naming file and dataset: no time history, a refused time dataset, an ordinate type that
        is neither force nor response, unknown units, different sampling or lengths, channels
        with different numbers of records, no force or no response channel.
    """
    uf = read_uff(path)
    src = uf.path
    notes: list[str] = []
    chans: dict[tuple[str, DOF], list[tuple[UFFRecord, float]]] = {}
    forms: set[str] = set()
    dt0: float | None = None
    n0: int | None = None
    first: UFFRecord | None = None
    for r in uf.records:
        if r.type != 58 or r.function_type != 1:
            if r.type == 58:
                notes.append(f"dataset {r.index}: function type {r.function_type}, not a time history; ignored")
            continue
        if r.status != "read":
            raise UFFError(f"time history refused: {r.reason}", file=src, dataset=r.index)
        if r.response is None:
            raise UFFError("time history without a node/direction", file=src, dataset=r.index)
        code = r.header.get("ordinate_spec_data_type")
        if code in _FORCE_CODES:
            kind = "force"
        elif code in _RESPONSE_FORM:
            kind = _RESPONSE_FORM[code]
            forms.add(kind)
        else:
            raise UFFError(f"ordinate type {code} is neither a force (13, 9) nor a response (12, 11, 8): "
                           "cannot tell excitation from response", file=src, dataset=r.index)
        assert r.x is not None and r.y is not None
        if np.iscomplexobj(r.y):
            raise UFFError("complex time history", file=src, dataset=r.index)
        if r.x.size < 2:
            raise UFFError("time history with fewer than 2 samples", file=src, dataset=r.index)
        d = np.diff(r.x)
        dt = float(d.mean())
        if not dt > 0 or np.ptp(d) > 1e-6 * dt:
            raise UFFError("time axis is not evenly spaced and increasing", file=src, dataset=r.index)
        if first is None:
            first, dt0, n0 = r, dt, r.x.size
        elif abs(dt - (dt0 or dt)) > 1e-9 * dt or r.x.size != n0:
            raise UFFError(f"sampling ({r.x.size} samples, dt {dt:g} s) differs from dataset {first.index} "
                           f"({n0} samples, dt {dt0:g} s)", file=src, dataset=r.index)
        fac = _scale(r, "force" if kind == "force" else kind, src, notes)
        dof = r.response
        sign = float(dof.sign)
        if rig is not None:
            if kind == "force":
                match = next((q for q in rig.references if q.node == dof.node
                              and abs(q.direction) == abs(dof.direction)), None)
                if match is None:
                    notes.append(f"dataset {r.index}: force at {dof} is not a rig excitation; ignored")
                    continue
                sign = float(match.sign)
            else:
                sensor = rig.sensor_for(dof)
                if sensor is None:
                    msg = f"{src}: dataset {r.index}: response {dof} has no [[sensor]] entry in the rig file; channel ignored"
                    warnings.warn(msg, UnitWarning, stacklevel=2)
                    notes.append(f"dataset {r.index}: {dof} has no rig sensor; ignored")
                    continue
                sign = float(sensor.dof.sign)
        if sign < 0:
            notes.append(f"dataset {r.index}: {dof} flipped into {dof.positive()} (values x -1)")
        key = ("force" if kind == "force" else "response", dof.positive())
        chans.setdefault(key, []).append((r, sign * fac))
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

    def stack(kind: str, dofs: list[DOF]) -> tuple[NDArray[np.float64], list[list[int]]]:
        arr = np.empty((n_rec, len(dofs), int(n0 or 0)))
        used: list[list[int]] = []
        for c, d in enumerate(dofs):
            recs = chans[(kind, d)]
            used.append([r.index for r, _ in recs])
            for k, (r, s) in enumerate(recs):
                assert r.y is not None
                arr[k, c] = np.asarray(r.y, dtype=np.float64) * s
        arr.setflags(write=False)
        return arr, used

    force, used_f = stack("force", ins)
    resp, used_r = stack("response", outs)
    return TimeData(
        force=force, response=resp, fs=1.0 / dt0, in_dofs=tuple(ins), out_dofs=tuple(outs),
        frf_form=forms.pop(), source=src, notes=tuple(notes),
        datasets=MappingProxyType({"force": used_f, "response": used_r}),
    )


__all__ = ["TimeData", "read_time_uff"]
