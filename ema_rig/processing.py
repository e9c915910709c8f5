"""Processing history of an FRF estimate: window, averaging and the analyser's usable band.

Classes
-------
ProcessingHistory
    Frozen record of how the FRFs were estimated from time data (UFF dataset 1858 or
    :func:`ema_rig.spectral.estimate_frf`).

Functions
---------
processing_history
    The history attached to an :class:`~ema_rig.frf.FRFData` (``meta["processing"]`` from a
    file's datasets 1858, or the keys :func:`~ema_rig.spectral.estimate_frf` writes), or None.
usable_band
    Upper end of the band the FRFs are valid in [Hz] (analyser band, else the anti-alias limit
    ``ANTI_ALIAS_FRACTION * fs / 2``), or None when nothing says so.

Notes
-----
An exponential window ``w(t) = exp(-a t)`` applied alike to force and response multiplies the
impulse response ``h(t) = sum_r A_r exp(lambda_r t)`` by ``exp(-a t)``: the windowed FRF is that
of a system with the same residues and every pole moved to ``lambda_r - a``. The structural pole
is therefore ``lambda_r = lambda_id + a`` exactly (real part shifted by ``+a = +1/tau``), the
correction of Fladung & Rost [1]_; in damping terms ``zeta = zeta_id - a / omega_n`` for light
damping.

References
----------
.. [1] W. Fladung, R. Rost, "Application and correction of the exponential window for frequency
   response functions", Mechanical Systems and Signal Processing 11(1), 23-36 (1997).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

ANTI_ALIAS_FRACTION = 0.8
"""Fraction of the Nyquist frequency an analyser's anti-alias filter leaves usable. Source: the
customary sampling rate of 2.56 x the analyser band (1/2.56 = 0.39 fs = 0.78 fs/2; e.g. the
DataPhysics SignalCalc record of vt_case1: 1280 Hz sampling, 500 Hz band); 0.8 rounds it up."""

WINDOW_CODES: dict[int, str] = {
    0: "none or unknown", 1: "hanning narrow", 2: "hanning broad", 3: "flattop", 4: "exponential",
    5: "impact", 6: "impact and exponential",
}
"""Window type codes of UFF dataset 1858 (record 2, field 2)."""


@dataclass(frozen=True, slots=True)
class ProcessingHistory:
    """How FRFs were estimated from time data.

    Attributes
    ----------
    window : str
        Window name (``'hann'``, ``'exponential'`` ... as ema_rig names it, else the dataset 1858
        code's name, e.g. ``'hanning narrow'``).
    window_code : int
        UFF dataset 1858 window type code (0 none/unknown, 1 Hanning narrow, 2 Hanning broad,
        3 flattop, 4 exponential, 5 impact (force), 6 impact and exponential).
    exp_decay : float
        Decay rate ``a`` of an exponential window ``exp(-a t)`` on force and response [1/s]; 0
        without one. Every pole of the FRFs is ``a`` rad/s more damped than the structure's.
    n_samples : int or None
        Samples per FFT segment.
    n_averages : int or None
        Number of averages.
    overlap : float or None
        Fraction of a segment shared by consecutive segments.
    estimator : str or None
        ``'H1'``, ``'H2'``, ``'Hv'``.
    fs : float or None
        Sampling rate [Hz].
    band : tuple of float or None
        The analyser's band ``(freq_lower, freq_upper)`` [Hz]: where the FRFs are valid.
    source : str
        Where the history comes from (``'dataset 1858 (ema_rig)'``, ``'dataset 1858'``,
        ``'estimate_frf'``).
    notes : tuple of str
        Assumptions made while reading it (e.g. the unit of a foreign decay factor).
    """

    window: str = "unknown"
    window_code: int = 0
    exp_decay: float = 0.0
    n_samples: int | None = None
    n_averages: int | None = None
    overlap: float | None = None
    estimator: str | None = None
    fs: float | None = None
    band: tuple[float, float] | None = None
    source: str = ""
    notes: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        if not (self.exp_decay >= 0.0):
            raise ValueError(f"exp_decay must be >= 0 [1/s], got {self.exp_decay!r}")
        if self.n_averages is not None and self.n_averages < 1:
            raise ValueError(f"n_averages must be >= 1, got {self.n_averages!r}")
        if self.fs is not None and not self.fs > 0:
            raise ValueError(f"fs must be > 0 [Hz], got {self.fs!r}")

    def to_dict(self) -> dict[str, Any]:
        """The history as a JSON-ready dict (``band`` a list or None)."""
        return {
            "window": self.window, "window_code": self.window_code, "exp_decay": self.exp_decay,
            "n_samples": self.n_samples, "n_averages": self.n_averages, "overlap": self.overlap,
            "estimator": self.estimator, "fs": self.fs,
            "band": None if self.band is None else list(self.band), "source": self.source,
            "notes": list(self.notes),
        }


def processing_history(data: Any) -> ProcessingHistory | None:
    """The processing history of FRF data, or None when nothing records it.

    Parameters
    ----------
    data : FRFData
        Looks at ``meta["processing"]`` (set by :func:`ema_rig.io.uff.read_uff58` from datasets
        1858), else at the keys :func:`ema_rig.spectral.estimate_frf` puts into ``meta``
        (``window``, ``added_damping``, ``segment``, ``n_averages``, ``overlap``, ``estimator``).

    Returns
    -------
    ProcessingHistory or None
    """
    meta = getattr(data, "meta", {}) or {}
    hist = meta.get("processing")
    if isinstance(hist, ProcessingHistory):
        return hist
    if "added_damping" in meta and "segment" in meta and "window" in meta:
        seg = int(meta["segment"])
        fs = None
        freq = getattr(data, "freq", None)
        if freq is not None and len(freq) >= 2:
            fs = float(freq[1] - freq[0]) * seg  # lines k fs / segment
        navg = getattr(data, "n_averages", None)
        return ProcessingHistory(
            window=str(meta["window"]), window_code=window_code(str(meta["window"])),
            exp_decay=float(meta["added_damping"]), n_samples=seg,
            n_averages=None if navg is None else int(navg),
            overlap=None if meta.get("overlap") is None else float(meta["overlap"]),
            estimator=None if meta.get("estimator") is None else str(meta["estimator"]),
            fs=fs, band=None, source="estimate_frf",
        )
    return None


def window_code(name: str) -> int:
    """The dataset 1858 window type code of an ema_rig window name (0 when it has none).

    Parameters
    ----------
    name : str
        ``'hann'``, ``'flattop'``, ``'exponential'``, ``'force'``, ``'impact'``, ``'rect'`` ...

    Returns
    -------
    int
    """
    return {"hann": 1, "hanning": 1, "flattop": 3, "exponential": 4, "force": 5, "impact": 6}.get(name.lower(), 0)


def usable_band(history: ProcessingHistory | None) -> float | None:
    """Upper end [Hz] of the band the FRFs can be trusted in, or None when unknown.

    Parameters
    ----------
    history : ProcessingHistory or None

    Returns
    -------
    float or None
        The analyser band's upper end when recorded, else ``ANTI_ALIAS_FRACTION * fs / 2``
        when the sampling rate is known, else None.
    """
    if history is None:
        return None
    if history.band is not None:
        return float(history.band[1])
    if history.fs is not None:
        return ANTI_ALIAS_FRACTION * history.fs / 2.0
    return None


__all__ = ["ANTI_ALIAS_FRACTION", "WINDOW_CODES", "ProcessingHistory", "processing_history", "usable_band",
           "window_code"]
