"""Private: UFF dataset 1858 ("dataset 58 qualifiers"), written and read by ema_rig itself.

Layout (I-DEAS universal file format, dataset 1858; the same fields in SDynPy, pyuff and
DeepSea's readers). Each dataset 1858 qualifies the dataset 58 that follows it:

- record 1 (6I12): set record number, octave format (0), measurement run number, 3 unused;
- record 2 (12I6): weighting type, **window type** (0 none/unknown, 1 Hanning narrow,
  2 Hanning broad, 3 flattop, 4 exponential, 5 impact, 6 impact and exponential), amplitude
  units, normalisation, abscissa / ordinate numerator / denominator / z-axis qualifiers, sampling
  type, 3 unused;
- record 3 (5E15.7): z RPM, z time, z order, **number of samples**, unused;
- record 4 (5E15.7): user values 1-4, **exponential window damping factor**;
- record 5 (5E15.7): unused (some writers: overall and weighted RMS);
- record 6 (2A2,2X,2A2): response and reference direction;
- record 7 (40A2): unused text.

The format does not fix the unit of the damping factor. ema_rig writes the decay rate ``a`` of
``w(t) = exp(-a t)`` in 1/s and tags record 7 with ``ema_rig`` followed by what the format has no
field for (``est=H1 avg=12 ovl=0.5 fs=1280 band=0.3125,512 win=hann``). A factor from another
writer is read as 1/s as well, with a note saying so. Pyuff 2.5.8 writes record 1 as 6I10 while
reading it as 6I12; both are accepted here (integers are split on blanks).
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from typing import Any

from ..processing import WINDOW_CODES, ProcessingHistory, window_code

TAG = "ema_rig"


def _e15(v: float) -> str:
    return f"{float(v):15.7E}"


def dataset_bytes(history: ProcessingHistory, *, record: int = 1) -> bytes:
    """The bytes of one ASCII dataset 1858 describing ``history`` (LF line ends).

    Parameters
    ----------
    history : ProcessingHistory
        Window, decay [1/s], segment length, averaging, estimator, sampling rate and band.
    record : int, optional
        Set record number (record 1, field 1).
    """
    code = history.window_code
    extra = [TAG]
    if history.estimator:
        extra.append(f"est={history.estimator}")
    if history.n_averages is not None:
        extra.append(f"avg={int(history.n_averages)}")
    if history.overlap is not None:
        extra.append(f"ovl={history.overlap:.6g}")
    if history.fs is not None:
        extra.append(f"fs={history.fs:.10g}")
    if history.band is not None:
        extra.append(f"band={history.band[0]:.10g},{history.band[1]:.10g}")
    text = " ".join(extra)
    win = re.sub(r"\s+", "_", history.window)
    if len(text) + 5 + len(win) <= 80:
        text += f" win={win}"
    n_samp = 0.0 if history.n_samples is None else float(history.n_samples)
    lines = [
        "    -1",
        f"{1858:6d}",
        f"{int(record):12d}{0:12d}{0:12d}{0:12d}{0:12d}{0:12d}",
        f"{0:6d}{code:6d}" + f"{0:6d}" * 10,
        _e15(0.0) + _e15(0.0) + _e15(0.0) + _e15(n_samp) + _e15(0.0),
        _e15(0.0) * 4 + _e15(history.exp_decay),
        _e15(0.0) * 5,
        "NONE  NONE",
        f"{text[:80]:<80}",
        "    -1",
    ]
    return ("\n".join(lines) + "\n").encode("ascii")


def _floats(line: str, n: int) -> list[float]:
    """``n`` E15.7 fields (fixed columns; blank-separated as a fallback)."""
    body = line.rstrip("\r\n")
    try:
        vals = [float(body[15 * k:15 * (k + 1)] or "0") for k in range(n)]
    except ValueError:
        toks = body.replace("D", "E").replace("d", "e").split()
        vals = [float(t) for t in toks[:n]]
        vals += [0.0] * (n - len(vals))
    return vals


def _ints(line: str, width: int, n: int) -> list[int]:
    body = line.rstrip("\r\n")
    try:
        vals = [int(body[width * k:width * (k + 1)].strip() or "0") for k in range(n)]
    except ValueError:
        toks = body.split()
        vals = [int(t) for t in toks[:n]]
        vals += [0] * (n - len(vals))
    return vals


def _body(lines: Sequence[str]) -> list[str]:
    """The record lines of a dataset 1858 (without delimiter and type lines)."""
    out = [ln for ln in lines]
    while out and out[0].strip() in ("-1", "1858", ""):
        out.pop(0)
    while out and out[-1].strip() in ("-1", ""):
        out.pop()
    return out


def parse(lines: Sequence[str], *, index: int) -> ProcessingHistory:
    """A :class:`~ema_rig.processing.ProcessingHistory` from the text lines of one dataset 1858.

    Raises
    ------
    ValueError
        Fewer than 4 records, or numbers that do not parse (message names the record).
    """
    rec = _body(lines)
    if len(rec) < 4:
        raise ValueError(f"dataset 1858 has {len(rec)} record line(s), needs at least 4")
    try:
        code = _ints(rec[1], 6, 2)[1]
    except (ValueError, IndexError):
        raise ValueError("dataset 1858 record 2 (12I6) unreadable") from None
    try:
        n_samp = _floats(rec[2], 4)[3]
    except (ValueError, IndexError):
        raise ValueError("dataset 1858 record 3 (5E15.7) unreadable") from None
    try:
        decay = _floats(rec[3], 5)[4]
    except (ValueError, IndexError):
        raise ValueError("dataset 1858 record 4 (5E15.7) unreadable") from None
    text = rec[6].strip() if len(rec) > 6 else ""
    ours = text.split(" ", 1)[0] == TAG
    kv: dict[str, str] = {}
    if ours:
        for tok in text.split()[1:]:
            k, _, v = tok.partition("=")
            kv[k] = v
    notes: list[str] = []
    if not decay >= 0.0:  # negative or NaN
        notes.append(f"dataset {index}: exponential window damping factor {decay:g} is negative: ignored")
        decay = 0.0
    is_exp = code in (4, 6)
    if decay > 0 and not is_exp:
        notes.append(f"dataset {index}: an exponential damping factor {decay:g} with window type {code} "
                     f"({WINDOW_CODES.get(code, 'unknown')}): taken as an exponential window")
    if is_exp and decay == 0:
        notes.append(f"dataset {index}: exponential window (type {code}) without a damping factor: the damping "
                     "it adds is unknown and cannot be removed")
    if decay > 0 and not ours:
        notes.append(f"dataset {index}: exponential window damping factor {decay:g} read as a decay rate in 1/s "
                     "(w(t) = exp(-a t); dataset 1858 does not fix its unit)")

    def num(key: str) -> float | None:
        try:
            return float(kv[key]) if key in kv else None
        except ValueError:
            notes.append(f"dataset {index}: record 7 {key}={kv[key]!r} is not a number: ignored")
            return None

    band = None
    if "band" in kv:
        try:
            lo, hi = (float(v) for v in kv["band"].split(","))
            band = (lo, hi) if 0 <= lo < hi else None
        except ValueError:
            band = None
        if band is None:
            notes.append(f"dataset {index}: record 7 band={kv['band']!r} unreadable: ignored")
    avg, ovl, fs = num("avg"), num("ovl"), num("fs")
    window = kv.get("win") or WINDOW_CODES.get(code, "unknown")
    if ours and "win" in kv and window_code(window) != code:
        window = WINDOW_CODES.get(code, "unknown")
    return ProcessingHistory(
        window=window, window_code=int(code), exp_decay=float(decay),
        n_samples=int(round(n_samp)) if n_samp >= 1 else None,
        n_averages=int(avg) if avg is not None and avg >= 1 else None,
        overlap=ovl if ovl is not None and 0 <= ovl < 1 else None,
        estimator=kv.get("est") or None, fs=fs if fs is not None and fs > 0 else None, band=band,
        source=f"dataset 1858 ({TAG})" if ours else "dataset 1858", notes=tuple(notes),
    )


def qualify(records: Sequence[Any]) -> tuple[dict[int, tuple[int, ProcessingHistory]], list[str]]:
    """Pair every dataset 1858 with the dataset 58 it qualifies.

    A dataset 1858 qualifies the next dataset 58 (the format's order, and ema_rig's). A file
    whose first dataset 1858 comes after its first dataset 58 and whose last dataset 58 is
    followed by one is read the other way round (each 1858 after its 58).

    Parameters
    ----------
    records : sequence of UFFRecord
        All datasets of the file, in file order.

    Returns
    -------
    pairs : dict
        Dataset-58 index -> (dataset-1858 index, history).
    notes : list of str
        Datasets 1858 unreadable or without a dataset 58 (ignored).
    """
    seq = [r for r in records if r.type in (58, 1858)]
    notes: list[str] = []
    if not any(r.type == 1858 for r in seq):
        return {}, notes
    after = seq[0].type == 58 and seq[-1].type == 1858
    order = list(reversed(seq)) if after else seq
    pairs: dict[int, tuple[int, ProcessingHistory]] = {}
    pending: Any = None
    for r in order:
        if r.type == 1858:
            if pending is not None:
                notes.append(f"dataset {pending.index}: dataset 1858 qualifies no dataset 58: ignored")
            pending = r
            continue
        if pending is None:
            continue
        q, pending = pending, None
        if q.status != "read":
            notes.append(f"dataset {q.index}: dataset 1858 refused ({q.reason}): ignored")
            continue
        try:
            pairs[r.index] = (q.index, parse(q.lines, index=q.index))
        except ValueError as exc:
            notes.append(f"dataset {q.index}: {exc}: ignored")
    if pending is not None:
        notes.append(f"dataset {pending.index}: dataset 1858 qualifies no dataset 58: ignored")
    return pairs, notes


def combine(pairs: dict[int, tuple[int, ProcessingHistory]], used: Sequence[int]
            ) -> tuple[ProcessingHistory | None, list[str], list[str]]:
    """One history for the FRF datasets ``used``: (history or None, notes, warnings).

    The FRFs of one matrix share one estimate; the history is returned when every used dataset
    has the same one (notes aside). Datasets without a 1858, or with different histories, give
    None and a warning when one of them names an exponential window (its damping then cannot be
    removed from the common poles).
    """
    hs = [pairs[i][1] for i in used if i in pairs]
    if not hs:
        return None, [], []
    notes = sorted({n for h in hs for n in h.notes})
    first = hs[0]
    same = all(_key(h) == _key(first) for h in hs)
    if same and len(hs) == len(used):
        return first, notes, []
    exp = any(h.exp_decay > 0 for h in hs)
    why = (f"{len(used) - len(hs)} of {len(used)} FRF datasets have no dataset 1858" if len(hs) < len(used)
           else "the FRF datasets' datasets 1858 differ")
    warn = [f"{why}: processing history not used"
            + ("; an exponential window's damping is NOT removed from the poles" if exp else "")]
    return None, notes, warn


def _key(h: ProcessingHistory) -> tuple[Any, ...]:
    return (h.window_code, h.exp_decay, h.n_samples, h.n_averages, h.overlap, h.estimator, h.fs, h.band)
