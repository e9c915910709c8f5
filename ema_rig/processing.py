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
independent_averages
    The equivalent number of independent averages of overlapped windowed segments (Welch [2]_).

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
.. [2] P. D. Welch, "The use of fast Fourier transform for the estimation of power spectra",
   IEEE Trans. Audio Electroacoustics 15(2), 70-73 (1967); D. B. Percival, A. T. Walden,
   *Spectral Analysis for Physical Applications* (1993), eq. (292b).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # numpy is imported where it is used: the command line's parser does not need it
    from numpy.typing import ArrayLike

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

    def independent_averages(self) -> float | None:
        """The equivalent number of independent averages behind the FRFs (None when ``n_averages`` is).

        ``n_averages`` overlapped segments are not independent: :func:`independent_averages` with the
        window (Hann for the Hanning codes, flattop, else the rectangular window, whose overlapped
        segments share the most and so count the fewest) and the step ``n_samples (1 - overlap)``,
        the segments taken as one record (several records would count more). Without an overlap,
        or without the segment length, ``n_averages`` itself.
        """
        n = self.n_averages
        if n is None or n <= 1 or not self.overlap or self.overlap <= 0 or not self.n_samples:
            return None if n is None else float(n)
        import numpy as np
        from scipy.signal import get_window  # scipy: only for overlapped segments

        name = {"hanning narrow": "hann", "hanning broad": "hann", "hanning": "hann"}.get(self.window, self.window)
        try:
            w = get_window("boxcar" if name in ("rect", "none or unknown") else name, self.n_samples, fftbins=True)
        except (ValueError, TypeError):  # an impact/exponential window or a name scipy does not know
            w = np.ones(self.n_samples)
        step = max(1, int(round(self.n_samples * (1.0 - self.overlap))))
        return independent_averages(w, step, n)

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
        # the segments averaged (estimate_frf's count; FRFData.n_averages holds the independent number)
        navg = meta.get("n_segments", getattr(data, "n_averages", None))
        return ProcessingHistory(
            window=str(meta["window"]), window_code=window_code(str(meta["window"])),
            exp_decay=float(meta["added_damping"]), n_samples=seg,
            n_averages=None if navg is None else int(navg),
            overlap=None if meta.get("overlap") is None else float(meta["overlap"]),
            estimator=None if meta.get("estimator") is None else str(meta["estimator"]),
            fs=fs, band=None, source="estimate_frf",
        )
    return None


def independent_averages(window: ArrayLike, step: int, n_segments: int, n_records: int = 1) -> float:
    """The equivalent number of independent averages of overlapped windowed segments.

    Consecutive segments that share samples give correlated spectra: averaging ``n`` of them
    reduces the variance of a spectral estimate only by (Welch 1967; Percival & Walden eq. 292b)

    ``n_eff = n / (1 + 2 sum_{k=1}^{n-1} (1 - k/n) rho(k step)^2)``,
    ``rho(s) = sum_t w_t w_{t+s} / sum_t w_t^2``

    (Hann at 50 % overlap: rho = 1/6, n_eff = n / 1.056 for large n; a 4096-sample record cut into
    1024-sample Hann segments at 99.9 % overlap: 3073 segments, 6.6 independent averages). Records
    are independent of each other.
    This is the number the coherence-based noise variance ``(1 - g2) / (n g2) |H|^2`` holds for.

    Parameters
    ----------
    window : array_like, shape (n_samples,)
        The data window applied to each segment.
    step : int
        Samples between the starts of consecutive segments (>= 1).
    n_segments : int
        Segments per record (>= 1).
    n_records : int, optional
        Independent records, each cut into ``n_segments`` segments.

    Returns
    -------
    float
        ``n_records * n_eff`` (equal to ``n_records * n_segments`` when segments do not overlap).

    Examples
    --------
    >>> import numpy as np
    >>> round(independent_averages(np.hanning(1025)[:-1], 512, 1000), 1)  # Hann, 50 % overlap
    947.4
    >>> independent_averages(np.ones(8), 8, 5)  # no overlap: every segment counts
    5.0
    """
    import numpy as np

    w = np.asarray(window, dtype=np.float64)
    if step < 1 or n_segments < 1 or n_records < 1:
        raise ValueError(f"step, n_segments and n_records must be >= 1, got {step}, {n_segments}, {n_records}")
    k = np.arange(1, n_segments)
    k = k[k * step < w.size]  # segments further apart share no sample
    if k.size == 0:
        return float(n_records * n_segments)
    spec = np.fft.rfft(w, 2 * w.size)
    acf = np.fft.irfft(np.abs(spec) ** 2, 2 * w.size)[: w.size]  # sum_t w_t w_{t+s}, every shift s
    rho = acf[k * step] / acf[0]
    return float(n_records * n_segments / (1.0 + 2.0 * np.sum((1.0 - k / n_segments) * rho**2)))


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
