"""FRFs and coherence from force and response time histories (H1, H2, Hv).

Functions
---------
estimate_frf
    Force and response time records -> :class:`FRFEstimate` (an FRFData plus the ordinary
    coherence), with a window per channel, segment averaging with overlap, and averaging over
    several records (one impact each).
time_window
    The (force, response) window pair of a window name, shape (n_segment,) each.

Classes
-------
FRFEstimate
    Frozen result: ``frf`` (FRFData), ``coherence`` (n_out, n_in, n_freq), the averaging used and
    the caveats as ``warnings``.

Notes
-----
Spectra are averaged over every segment of every record (``S_xx = sum X^* X^T``,
``S_yx = sum Y X^*``, ``S_yy = sum |Y|^2``; the common FFT scaling cancels in every ratio):

- ``H1 = S_yx S_xx^-1`` (least squares with noise on the response only; any number of inputs),
- ``H2 = S_yy / conj(S_yx)`` (noise on the force only; one input),
- ``Hv`` (total least squares, noise on both, equally weighted; one input):
  ``(S_yy - S_xx + sqrt((S_xx - S_yy)^2 + 4 |S_yx|^2)) / (2 conj(S_yx))``,
- ordinary coherence ``|S_yx|^2 / (S_xx S_yy)`` per (output, input).

With one average the coherence is 1 by definition; the result then carries a warning. Offsets:
with a tapered window the mean of every segment is removed from both channels (as
:func:`scipy.signal.csd` does); with an impact window the force's offset is its mean after the
force window (where a hammer force is zero) and the response is used as recorded. The 0 Hz line
is not returned (it carries no information once offsets are removed): the first line is
``fs / n_segment``.

The exponential window ``w[n] = e^(-a n)`` applied to force and response alike turns
``y = h * x`` into ``(w y) = (w h) * (w x)``: the estimate is exactly the FRF of the system whose
poles are all shifted by ``-a fs`` rad/s. That extra damping is returned as ``added_damping``
(rad/s); a damping ratio identified from such an FRF is too high by about
``added_damping / (2 pi natural_freq)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .dof import DOF, as_dof
from .frf import FRFData
from .literals import Estimator, FrfForm
from .processing import independent_averages

ESTIMATORS: tuple[str, ...] = ("H1", "H2", "Hv")
LOW_COHERENCE = 0.8
"""Coherence below which a line is counted as poorly measured (a warning is given when more
than a quarter of the lines are)."""
MAX_DEFAULT_SEGMENT = 1 << 20
"""Longest default segment of a tapered window, in samples (a quarter of the record up to this):
memory is a few times one segment per channel, so a 10^8-sample file stays within about its own size."""
SEGMENT_BATCH_BYTES = 16 << 20
"""Segments are processed in batches of about this many bytes of samples (memory, not results)."""
IMPACT_WINDOWS: tuple[str, ...] = ("force", "exponential", "impact")
"""Window names for impact tests: ``force`` (force window on the force, none on the
response), ``exponential`` (the same exponential on both), ``impact`` (force window times the
exponential on the force, the exponential on the response)."""


@dataclass(frozen=True, slots=True, eq=False)
class FRFEstimate:
    """FRFs estimated from time data, with their coherence.

    Attributes
    ----------
    frf : FRFData
        The estimated FRFs, shape (n_out, n_in, n_freq); lines ``k fs / segment``, k = 1..segment/2.
    coherence : ndarray, shape (n_out, n_in, n_freq), float64
        Ordinary coherence of each (output, input) pair, in [0, 1].
    estimator : {'H1', 'H2', 'Hv'}
    window : str
        Window name as given.
    segment : int
        Samples per segment (the FFT length).
    overlap : float
        Fraction of a segment shared by consecutive segments.
    n_averages : int
        Number of segments averaged (over all records).
    added_damping : float
        Extra decay rate of every pole caused by an exponential window [rad/s]; 0 without one.
    warnings : tuple of str
        One-line caveats (one average, added damping, low coherence ...).
    """

    frf: FRFData
    coherence: NDArray[np.float64]
    estimator: str
    window: str
    segment: int
    overlap: float
    n_averages: int
    added_damping: float = 0.0
    warnings: tuple[str, ...] = field(default=())

    def __repr__(self) -> str:
        return (
            f"FRFEstimate({self.estimator}, {self.window} window, {self.n_averages} average(s) of "
            f"{self.segment} samples, {self.frf!r})"
        )


def time_window(name: str, n: int, fs: float, *, force_width: float | None = None,
                exp_end: float = 0.01) -> tuple[NDArray[np.float64], NDArray[np.float64], float]:
    """The force and response windows of a window name.

    Parameters
    ----------
    name : str
        ``'force'``, ``'exponential'``, ``'impact'`` (see :data:`IMPACT_WINDOWS`), ``'rect'``
        (alias of ``'boxcar'``), or any window name of :func:`scipy.signal.get_window`
        (``'hann'``, ``'hamming'``, ``'flattop'`` ...; periodic form), used for both channels.
    n : int
        Segment length in samples.
    fs : float
        Sampling rate [Hz].
    force_width : float, optional
        Length of the force window [s] from the segment start (default: 1/10 of the segment).
    exp_end : float, optional
        Value of the exponential window at the last sample, in (0, 1] (default 0.01).

    Returns
    -------
    w_force, w_response : ndarray, shape (n,)
        Windows applied to the force and the response channels.
    added_damping : float
        Decay rate of the exponential window [rad/s] (0 without one).
    """
    from scipy.signal import get_window

    if n < 2:
        raise ValueError(f"segment must hold at least 2 samples, got {n}")
    if not 0.0 < exp_end <= 1.0:
        raise ValueError(f"exp_end must lie in (0, 1], got {exp_end}")
    key = name.lower()
    ones = np.ones(n)
    if key not in IMPACT_WINDOWS:
        try:
            w = np.asarray(get_window("boxcar" if key == "rect" else key, n, fftbins=True), dtype=np.float64)
        except ValueError as exc:
            raise ValueError(
                f"unknown window {name!r}: use one of {IMPACT_WINDOWS}, 'rect' or a scipy.signal "
                f"window name ({exc})"
            ) from None
        return w, w, 0.0
    decay = np.log(1.0 / exp_end) / (n - 1)  # per sample
    expo = np.exp(-decay * np.arange(n))
    width = 0.1 * n / fs if force_width is None else float(force_width)
    if not (np.isfinite(width) and width > 0):
        raise ValueError(f"force_width must be a finite positive time in s, got {force_width}")
    n_force = int(round(min(width * fs, n + 1.0)))
    if not 1 <= n_force <= n:
        raise ValueError(f"force_width {width:g} s must cover 1 to {n} samples at fs = {fs:g} Hz")
    fwin = np.zeros(n)
    fwin[:n_force] = 1.0
    if key == "force":
        return fwin, ones, 0.0
    if key == "exponential":
        return expo, expo, float(decay * fs)
    return fwin * expo, expo, float(decay * fs)


def _as_records(a: ArrayLike, what: str) -> NDArray[np.float64]:
    arr = np.asarray(a, dtype=np.float64)
    if arr.ndim == 1:
        arr = arr[None, None, :]
    elif arr.ndim == 2:
        arr = arr[None]
    if arr.ndim != 3:
        raise ValueError(f"{what} must have shape (n_samples,), (n_ch, n_samples) or "
                         f"(n_records, n_ch, n_samples), got {np.shape(a)}")
    flat = arr.reshape(-1) if arr.flags.c_contiguous else None
    blocks = ((flat[a : a + (1 << 20)] for a in range(0, flat.size, 1 << 20)) if flat is not None
              else (arr[i, j] for i in range(arr.shape[0]) for j in range(arr.shape[1])))
    for block in blocks:  # in blocks: a boolean copy of the whole record is not needed
        if not np.all(np.isfinite(block)):
            raise ValueError(f"{what} contains NaN or inf values")
    return arr


def estimate_frf(
    force: ArrayLike,
    response: ArrayLike,
    fs: float,
    *,
    in_dofs: Sequence[DOF | str],
    out_dofs: Sequence[DOF | str],
    frf_form: FrfForm = "accelerance",
    estimator: Estimator = "H1",
    window: str = "hann",
    segment: int | None = None,
    overlap: float | None = None,
    force_width: float | None = None,
    exp_end: float = 0.01,
    meta: dict[str, Any] | None = None,
) -> FRFEstimate:
    """Estimate FRFs and coherence from force and response time histories.

    Parameters
    ----------
    force : array_like, shape (n_samples,), (n_in, n_samples) or (n_records, n_in, n_samples)
        Excitation forces [N], sampled at ``fs``.
    response : array_like, shape (n_samples,), (n_out, n_samples) or (n_records, n_out, n_samples)
        Responses (acceleration [m/s^2], velocity [m/s] or displacement [m], per ``frf_form``),
        sampled simultaneously with the forces. Each record (e.g. one impact) is cut into
        segments separately; spectra are averaged over all segments of all records.
    fs : float
        Sampling rate [Hz].
    in_dofs, out_dofs : sequence of DOF or str
        Reference and response DOFs, lengths n_in and n_out.
    frf_form : {'accelerance', 'mobility', 'receptance'}, optional
        What the responses are (default accelerance).
    estimator : {'H1', 'H2', 'Hv'}, optional
        H1 (default; any n_in), H2 or Hv (one input; Hv weights force and response noise equally
        in the units given, so it depends on them).
    window : str, optional
        ``'hann'`` (default), ``'rect'``, any :func:`scipy.signal.get_window` name, or an impact
        window ``'force'``, ``'exponential'``, ``'impact'`` (see :func:`time_window`).
    segment : int, optional
        Samples per segment (FFT length). Default: the whole record for ``'rect'`` and impact
        windows, a quarter of it otherwise, at most :data:`MAX_DEFAULT_SEGMENT` samples.
    overlap : float, optional
        Fraction in [0, 1) shared by consecutive segments. Default 0.5 for tapered windows,
        0 for ``'rect'`` and impact windows.
    force_width : float, optional
        Force window length [s] (impact windows), default 1/10 of the segment.
    exp_end : float, optional
        Exponential window value at the end of the segment (default 0.01).
    meta : dict, optional
        Provenance stored in the FRFData.

    Returns
    -------
    FRFEstimate
        ``frf`` with lines ``fs/segment`` .. ``fs/2`` [Hz] (0 Hz omitted), ``coherence``, the
        averaging used and ``warnings``: one average (coherence meaningless), the damping added
        by an exponential window, a force peak outside the force window (blow cut off or
        absent), coherence below :data:`LOW_COHERENCE` on more than a quarter of the lines.

    Raises
    ------
    ValueError
        Mismatched shapes, NaN/inf samples, an unknown estimator or window, fewer averages than
        inputs (H1 needs ``n_averages >= n_in``), H2/Hv with several inputs, or a line where the
        force has no energy.

    Examples
    --------
    A two-sample moving sum ``y[n] = x[n] + x[n-1]`` has ``H(f) = 1 + exp(-2j pi f / fs)``:

    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> x = rng.standard_normal(8192)
    >>> y = x + np.concatenate([[0.0], x[:-1]])
    >>> est = estimate_frf(x, y, 1000.0, in_dofs=["1+Z"], out_dofs=["2+Z"], segment=512)
    >>> f = est.frf.freq
    >>> bool(np.allclose(est.frf.frf[0, 0], 1 + np.exp(-2j * np.pi * f / 1000.0), atol=0.02))
    True
    """
    if estimator not in ESTIMATORS:
        raise ValueError(f"estimator must be one of {ESTIMATORS}, got {estimator!r}")
    fs = float(fs)
    if not (np.isfinite(fs) and fs > 0):
        raise ValueError(f"fs must be a positive sampling rate in Hz, got {fs}")
    x = _as_records(force, "force")
    y = _as_records(response, "response")
    if x.shape[0] != y.shape[0] or x.shape[2] != y.shape[2]:
        raise ValueError(
            f"force {x.shape} and response {y.shape} must have the same number of records and samples"
        )
    n_rec, n_in, n_samp = x.shape
    n_out = y.shape[1]
    if len(in_dofs) != n_in or len(out_dofs) != n_out:
        raise ValueError(f"{len(in_dofs)} in_dofs / {len(out_dofs)} out_dofs for {n_in} force and "
                         f"{n_out} response channel(s)")
    if estimator != "H1" and n_in != 1:
        raise ValueError(f"{estimator} needs exactly one input, got {n_in}; use H1 for several inputs")
    key = window.lower()
    whole = key in IMPACT_WINDOWS or key in ("rect", "boxcar")
    nseg = int(segment) if segment is not None else (n_samp if whole else min(n_samp // 4, MAX_DEFAULT_SEGMENT))
    if not 2 <= nseg <= n_samp:
        raise ValueError(f"segment must lie in 2..{n_samp} samples (the record length), got {nseg}")
    ov = float(overlap) if overlap is not None else (0.0 if whole else 0.5)
    if not 0.0 <= ov < 1.0:
        raise ValueError(f"overlap must lie in [0, 1), got {ov}")
    w_x, w_y, added = time_window(window, nseg, fs, force_width=force_width, exp_end=exp_end)
    warn: list[str] = []
    step = max(1, int(round(nseg * (1.0 - ov))))
    starts = np.arange(0, n_samp - nseg + 1, step)
    n_avg = n_rec * starts.size
    if estimator == "H1" and n_avg < n_in:
        raise ValueError(f"H1 with {n_in} inputs needs at least {n_in} averages, got {n_avg} "
                         "(shorter segments, more overlap or more records)")

    freq = np.arange(1, nseg // 2 + 1) * fs / nseg
    s_xx = np.zeros((n_in, n_in, freq.size), dtype=np.complex128)
    s_yx = np.zeros((n_out, n_in, freq.size), dtype=np.complex128)
    s_yy = np.zeros((n_out, freq.size))
    impact = key in IMPACT_WINDOWS
    n_force = int(np.count_nonzero(time_window("force", nseg, fs, force_width=force_width)[0])) if impact else 0
    n_late, t_late = 0, 0.0
    # segments are cut, windowed and transformed a batch at a time, so memory is a few batches
    # (about SEGMENT_BATCH_BYTES each) plus the record, whatever the overlap (issue 17)
    batch = max(1, SEGMENT_BATCH_BYTES // (8 * nseg * (n_in + n_out)))
    windows_x = np.lib.stride_tricks.sliding_window_view(x, nseg, axis=-1)  # views, (n_rec, n_ch, n - nseg + 1, nseg)
    windows_y = np.lib.stride_tricks.sliding_window_view(y, nseg, axis=-1)
    with np.errstate(over="ignore", invalid="ignore"):  # values near the float limit: refused below
        for r in range(n_rec):
            for b0 in range(0, starts.size, batch):
                sel = slice(starts[b0], starts[min(b0 + batch, starts.size) - 1] + 1, step)
                xs = np.array(windows_x[r][:, sel])  # (n_in, n_batch, nseg): a copy of this batch only
                ys = np.array(windows_y[r][:, sel])
                if impact:
                    # the force should be zero after the blow: its mean there is the channel's offset;
                    # the response is used as recorded (an offset would be spread by the exponential window)
                    tail = xs[..., n_force:] if n_force < nseg else xs
                    xs -= tail.mean(axis=-1, keepdims=True)
                    if key in ("force", "impact") and n_force < nseg:
                        peak_at = np.argmax(np.abs(xs), axis=-1)  # (n_in, n_batch)
                        late = peak_at >= n_force
                        if late.any():
                            n_late += int(late.sum())
                            t_late = max(t_late, float(peak_at[late].max()) / fs)
                else:
                    xs -= xs.mean(axis=-1, keepdims=True)
                    ys -= ys.mean(axis=-1, keepdims=True)
                xs *= w_x
                ys *= w_y
                fx = np.fft.rfft(xs, axis=-1)[..., 1:]  # drop 0 Hz: the mean was removed
                del xs
                fy = np.fft.rfft(ys, axis=-1)[..., 1:]
                del ys
                s_xx += np.einsum("isf,jsf->ijf", fx.conj(), fx)  # (n_in, n_in, n_freq)
                s_yx += np.einsum("osf,isf->oif", fy, fx.conj())  # (n_out, n_in, n_freq)
                s_yy += np.einsum("osf,osf->of", fy, fy.conj()).real  # (n_out, n_freq)
    big = np.sqrt(np.finfo(float).max) / 4  # beyond it |S_yx|^2 in the coherence would overflow
    if not all(np.all(np.abs(v) < big) for v in (s_xx, s_yx, s_yy)):  # also False for NaN/inf
        peak = max(abs(float(v)) for v in (x.max(), x.min(), y.max(), y.min()))
        raise ValueError(f"the spectra overflow float64: force or response values up to {peak:.3g} are too "
                         "large (check the units)")
    if n_late:
        warn.append(f"the largest force sample of {n_late} segment(s) lies outside the force "
                    f"window (at {t_late:.4g} s > {n_force / fs:.4g} s): the blow is cut off or the force "
                    "holds no blow; check the trigger and --force-width")
    s_xx_diag = np.einsum("iif->if", s_xx).real  # (n_in, n_freq)
    floor = np.finfo(float).eps * float(s_xx_diag.max(initial=0.0)) * nseg
    dead = np.any(s_xx_diag <= floor, axis=0)
    if dead.any():
        k = int(np.argmax(dead))
        raise ValueError(f"the force has no energy at {freq[k]:g} Hz ({int(dead.sum())} line(s)): "
                         "no FRF can be estimated there (check the force channel and the window)")
    with np.errstate(divide="ignore", invalid="ignore"):
        if estimator == "H1":
            # Y = H X gives S_yx = H S_xx^T, i.e. S_xx H^T = S_yx^T per line
            a = np.moveaxis(s_xx, 2, 0)
            b = np.moveaxis(s_yx, 2, 0).transpose(0, 2, 1)
            h = np.moveaxis(np.linalg.solve(a, b).transpose(0, 2, 1), 0, 2)
        else:
            g_yx = s_yx[:, 0, :]
            g_xx = s_xx_diag[0][None, :]
            if estimator == "H2":
                h = (s_yy / g_yx.conj())[:, None, :]
            else:
                root = np.sqrt((g_xx - s_yy) ** 2 + 4.0 * np.abs(g_yx) ** 2)
                h = ((s_yy - g_xx + root) / (2.0 * g_yx.conj()))[:, None, :]
        coh = np.abs(s_yx) ** 2 / (s_xx_diag[None, :, :] * s_yy[:, None, :])
    coh = np.clip(np.nan_to_num(coh, nan=0.0), 0.0, 1.0)
    if not np.all(np.isfinite(h)):
        bad = ~np.all(np.isfinite(h), axis=(0, 1))
        raise ValueError(f"{estimator} is undefined at {int(bad.sum())} line(s), first {freq[np.argmax(bad)]:g} Hz "
                         "(a response or cross spectrum is zero there)")
    if n_avg == 1:
        warn.append("one average: the coherence is 1 by definition and says nothing about noise or "
                    "nonlinearity; average several records (impacts) or segments")
    elif np.mean(coh < LOW_COHERENCE) > 0.25:
        warn.append(f"coherence below {LOW_COHERENCE:g} on {100 * np.mean(coh < LOW_COHERENCE):.0f} % of the "
                    f"lines (median {np.median(coh):.2f}): noise, leakage, or a force that does not drive "
                    "the response; the FRF is unreliable there")
    if added > 0:
        warn.append(f"exponential window: every pole is {added:.4g} rad/s more damped in this FRF; a "
                    f"damping ratio identified from it is too high by {added:.4g} / (2 pi f_n)")
    info = dict(meta or {})
    info.update(estimator=estimator, window=window, segment=nseg, overlap=ov, added_damping=added, n_segments=n_avg)
    # overlapped segments are not independent: the FRFs carry the independent number (the coherence-based
    # noise variance needs it), the estimate and its history the count of segments averaged
    n_ind = independent_averages(w_y, step, int(starts.size), n_rec)
    data = FRFData(freq, np.asarray(h, dtype=np.complex128), tuple(as_dof(d) for d in out_dofs), tuple(as_dof(d) for d in in_dofs), frf_form,
                   meta=info, n_averages=n_ind)
    coh.setflags(write=False)
    return FRFEstimate(data, coh, estimator, window, nseg, ov, n_avg, added, tuple(warn))


__all__ = ["ESTIMATORS", "IMPACT_WINDOWS", "LOW_COHERENCE", "MAX_DEFAULT_SEGMENT", "SEGMENT_BATCH_BYTES", "FRFEstimate",
           "estimate_frf", "time_window"]
