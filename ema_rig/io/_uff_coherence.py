"""Private: attach UFF58 coherence datasets (function type 6) to the FRFs read from the same file.

A coherence dataset belongs to the FRF with the same (response, reference) pair, mapped like the
FRFs (signs do not matter: coherence is |gamma|^2), on the same frequency lines. Values above 1
(some analysers write them at isolated lines) and below 0 are clipped, and flagged when they exceed
the range by more than rounding (``ROUNDING``); a record labelled ``%`` is divided by 100, one with
another unit label or with most of its lines above 1 (a percentage without its label) is not a
coherence 0..1 and is ignored; anything that cannot be attached
is ignored with a note saying why, never an error: the FRFs do not depend on it.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..dof import DOF
from . import _uff_units
from .units import parse_unit

_AVERAGES = re.compile(
    r"(?:\b(?:n_?avg|avgs?|averages?|number\s+of\s+averages|no\.?\s*of\s+averages)\b\s*[:=]?\s*(\d{1,6})\b"
    r"|\b(\d{1,6})\s*(?:avgs?|averages)\b)",
    re.IGNORECASE,
)


ROUNDING = 1e-6
"""Excess beyond 0..1 clipped without a warning (rounding of float32 or short decimal output)."""


@dataclass(frozen=True, slots=True)
class Coherence:
    """Result of :func:`attach`: the array (or None) and what happened."""

    values: NDArray[np.float64] | None
    datasets: tuple[int, ...]
    notes: tuple[str, ...]
    warnings: tuple[str, ...]


def n_averages(id_lines: Sequence[Sequence[str]]) -> tuple[int | None, str | None]:
    """Number of averages written in the id lines of the datasets used, if any.

    UFF58 has no header field for it; some writers put ``"Averages: 20"`` or ``"20 avg"`` into an
    id line. Returns (value, note): None when absent or when the datasets disagree (noted).
    """
    found: set[int] = set()
    for ids in id_lines:
        for line in ids:
            m = _AVERAGES.search(line)
            if m:
                found.add(int(m.group(1) or m.group(2)))
    if len(found) == 1:
        v = found.pop()
        return (v, None) if v >= 1 else (None, f"number of averages {v} in the id lines ignored")
    if len(found) > 1:
        return None, f"id lines give different numbers of averages {sorted(found)}: none recorded"
    return None, None


def attach(
    records: Sequence[Any],
    freq: NDArray[np.float64],
    tol: float,
    out_order: Sequence[DOF],
    in_order: Sequence[DOF],
    key_of: Callable[[DOF, DOF], tuple[DOF, DOF] | None],
) -> Coherence:
    """Build the coherence array of shape (n_out, n_in, n_freq) from coherence records.

    Parameters
    ----------
    records : sequence of UFFRecord
        Dataset-58 records of function type 6, in file order.
    freq : ndarray, shape (n_freq,)
        The FRFs' frequency axis in Hz.
    tol : float
        Largest accepted deviation of a coherence abscissa from ``freq`` in Hz.
    out_order, in_order : sequence of DOF
        The FRFs' output and input DOFs (positive directions).
    key_of : callable
        Maps a file (response, reference) pair to the FRFs' (output, input) key, or None when
        the rig file drops that channel.

    Returns
    -------
    Coherence
        ``values`` float64 in 0..1, or None when not every FRF has a usable coherence record
        (then nothing is attached and a note says which FRFs lack one).
    """
    notes: list[str] = []
    warns: list[str] = []
    out_ix = {d: i for i, d in enumerate(out_order)}
    in_ix = {d: j for j, d in enumerate(in_order)}
    coh: NDArray[np.float64] | None = None  # allocated at the first usable record
    filled: dict[tuple[int, int], int] = {}
    for r in records:
        why = _unusable(r, freq, tol)
        if why is not None:
            notes.append(f"dataset {r.index}: coherence ignored: {why}")
            continue
        key = key_of(r.response, r.reference)
        if key is None or key[0] not in out_ix or key[1] not in in_ix:
            notes.append(
                f"dataset {r.index}: coherence {r.response} / {r.reference} ignored: no FRF for this pair"
            )
            continue
        i, j = out_ix[key[0]], in_ix[key[1]]
        if (i, j) in filled:
            notes.append(
                f"dataset {r.index}: coherence {key[0]} / {key[1]} ignored: already given by dataset {filled[(i, j)]}"
            )
            continue
        y = np.real(np.asarray(r.y, dtype=np.complex128 if np.iscomplexobj(r.y) else np.float64))
        scale = _percent_scale(r)
        if scale != 1.0:
            y = y * scale
            notes.append(f"dataset {r.index}: coherence unit label '%': values x {scale:g}")
        if float(np.median(y)) > 1.0 + ROUNDING:
            # clipping repairs isolated lines above 1; a record mostly above 1 is on another scale
            notes.append(
                f"dataset {r.index}: coherence {key[0]} / {key[1]} ignored: {int(np.sum(y > 1.0 + ROUNDING))} of "
                f"{y.size} lines above 1 (median {float(np.median(y)):.6g}): not a coherence in 0..1 (a percentage "
                "without a '%' label?)"
            )
            continue
        hi, lo = y > 1.0 + ROUNDING, y < -ROUNDING
        if hi.any():
            warns.append(
                f"dataset {r.index}: coherence {key[0]} / {key[1]} above 1 at {int(hi.sum())} of {y.size} lines "
                f"(max {float(y.max()):.6g}, first at {float(freq[int(np.argmax(hi))]):g} Hz); clipped to 1"
            )
        if lo.any():
            warns.append(
                f"dataset {r.index}: coherence {key[0]} / {key[1]} below 0 at {int(lo.sum())} lines "
                f"(min {float(y.min()):.6g}); clipped to 0"
            )
        if coh is None:
            coh = np.zeros((len(out_order), len(in_order), freq.size))
        coh[i, j] = np.clip(y, 0.0, 1.0)
        filled[(i, j)] = r.index
    if not filled or coh is None:
        return Coherence(None, (), tuple(notes), tuple(warns))
    missing = [f"{out_order[i]} / {in_order[j]}" for i in range(len(out_order)) for j in range(len(in_order))
               if (i, j) not in filled]
    if missing:
        # a noise model needs the coherence of every FRF; a partial array is not attached
        notes.append(
            f"coherence not attached: only {len(filled)} of {len(filled) + len(missing)} FRFs have one "
            f"(none for {', '.join(missing[:6])}{', ...' if len(missing) > 6 else ''})"
        )
        return Coherence(None, (), tuple(notes), tuple(warns))
    coh.setflags(write=False)  # frozen: FRFData keeps it without a copy
    return Coherence(coh, tuple(sorted(filled.values())), tuple(notes), tuple(warns))


_PERCENT = ("%", "percent")
"""Coherence unit labels that mean per cent (values 0..100)."""


def _percent_scale(r: Any) -> float:
    """0.01 for a coherence labelled in per cent, else 1 (its label was checked by :func:`_unusable`)."""
    return 0.01 if str(r.header.get("ordinate_axis_units_lab", "")).strip().lower() in _PERCENT else 1.0


def _unit_problem(r: Any) -> str | None:
    """Why a coherence's ordinate unit label does not fit a coherence (dimensionless or %), or None."""
    lab = str(r.header.get("ordinate_axis_units_lab", ""))
    if lab.strip().lower() in _PERCENT:
        return None
    try:
        u = parse_unit(lab, "coherence unit label")
    except ValueError as exc:
        return str(exc).split(";", 1)[0]
    if u is not None and (u.dims != (0, 0, 0) or u.factor != 1.0):
        return f"unit label {lab.strip()!r} is not dimensionless (a coherence is a ratio 0..1)"
    return None


def _unusable(r: Any, freq: NDArray[np.float64], tol: float) -> str | None:
    """Why a coherence record cannot be attached (None if it can)."""
    if r.status != "read":
        return f"refused ({r.reason})"
    unit = _unit_problem(r)
    if unit is not None:
        return unit
    if r.response is None or r.reference is None:
        return "response or reference DOF missing"
    assert r.x is not None and r.y is not None
    if np.iscomplexobj(r.y) and np.any(r.y.imag != 0):
        return "complex values (coherence is real)"
    try:
        afac = _uff_units.abscissa_factor(dict(r.header))
    except ValueError as exc:
        return str(exc)
    if r.x.size != freq.size:
        return f"{r.x.size} frequency lines, the FRFs have {freq.size}"
    with np.errstate(all="ignore"):
        dev = float(np.max(np.abs(r.x * afac - freq)))
    if not dev <= tol:
        return f"frequency lines differ from the FRFs' by up to {dev:.6g} Hz"
    return None
