"""Why a measurement may not be trusted: coherence, excitation in the record, phase behaviour.

Functions
---------
diagnose_frf
    Checks that need only the FRFs (phase behaviour; coherence when the data carry it).
diagnose_file
    The same plus what the UFF file holds besides the FRFs: coherence datasets (function
    type 6) and the force and response time records (function type 1).

Notes
-----
Each finding is one line in plain words. The thresholds are deliberately coarse (they flag
measurements an engineer would repeat, not borderline ones):

- phase: on a well-resolved FRF the phase turns by at most 180 degrees across a resonance,
  spread over several lines; jumps above 90 degrees between neighbouring lines at more than
  10 % of the lines mean noise dominates;
- coherence below 0.5 at the largest peak; a coherence record that exceeds 1 is reported as
  invalid and not used;
- the force peak (impact) in the last half of its record: the response after the impact is
  cut off (leakage, delay); a force record whose peak is less than 3 times its RMS has no
  clear impulse.
"""

from __future__ import annotations

from os import PathLike
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from ..errors import EmaRigError
from ..frf import FRFData
from ..io.uff import read_uff
from .criteria import WINDOW_KERNEL_LINES
from .noise import coherence_variance

PHASE_JUMP_FRACTION = 0.10
LOW_COHERENCE = 0.5


def _jump_fraction(h: NDArray[Any]) -> float:
    """Fraction of neighbouring-line pairs whose phase differs by more than 90 degrees."""
    if h.size < 8:
        return 0.0
    return float(np.mean(np.abs(np.angle(h[1:] * np.conj(h[:-1]))) > np.pi / 2))


def _phase_summary(fracs: list[tuple[str, float]]) -> list[str]:
    bad = [(label, f) for label, f in fracs if f > PHASE_JUMP_FRACTION]
    if not bad:
        return []
    worst = max(bad, key=lambda t: t[1])
    which = f"FRF {worst[0]}" if len(bad) == 1 else f"{len(bad)} of {len(fracs)} FRFs (worst {worst[0]})"
    return [f"{which}: the phase jumps by more than 90 degrees between neighbouring lines at "
            f"{100 * worst[1]:.0f} % of the lines (noise dominates)"]


def _jump_fractions(h: NDArray[Any]) -> NDArray[np.float64]:
    """:func:`_jump_fraction` of every FRF of ``h`` (shape (n_out, n_in, n_freq)) at once, shape (n_out, n_in).

    The same arithmetic per line pair (the count of jumps is an integer, the mean its quotient by the
    pairs): the same numbers as one call per FRF, in one pass over the array instead of a loop over the
    channels.
    """
    if h.shape[-1] < 8:
        return np.zeros(h.shape[:-1])
    w = np.conj(h[..., :-1])
    np.multiply(h[..., 1:], w, out=w)  # h[1:] conj(h[:-1]), the product of the loop, in place of the conjugate
    # |angle(w)| > pi / 2 where the sign bit of Re w is set, unless Re w is so small beside Im w that the angle
    # may round to pi / 2 (and at -0, NaN and inf): only those take the angle itself, the rest the sign
    # (np.angle, an atan2 per line pair, was most of the time)
    jump = np.signbit(w.real)
    k = np.flatnonzero(jump)
    wk = w.ravel()[k]
    near = k[~(np.abs(wk.real) > 1e-12 * np.abs(wk.imag))]
    if near.size:
        jump.ravel()[near] = np.abs(np.angle(w.ravel()[near])) > np.pi / 2
    out: NDArray[np.float64] = np.mean(jump, axis=-1)
    return out


def noise_only_outputs(data: FRFData, p: float) -> NDArray[np.bool_]:
    """Which outputs carry no measurable response: every FRF of the output is consistent with noise alone.

    A window correlates the spectrum of noise over the width of its spectral kernel
    (:data:`~ema_rig.identification.criteria.WINDOW_KERNEL_LINES`: 3 lines for Hann, whose H1 of pure noise
    jumps at only ~0.28 of the neighbouring pairs), so the test takes every ``k``-th line, ``k`` that width
    for the window ``data.meta["window"]`` names (Hann's where none is recorded or the name is unknown, as
    :func:`~ema_rig.identification.identify` does elsewhere; 1, every line, for the rectangle). On circular
    complex noise the phases of lines that far apart are independent and uniform, so the increments between
    successive lines taken are too, and each exceeds 90 degrees with probability 1/2 exactly
    (:func:`_jump_fractions` counts them). Each of the ``k`` chains of lines (starting at line 0 .. k - 1)
    is one binomial test: its count of jumps against half its ``m - 1`` trials (``m`` lines in the chain),
    the one-sided probability of that count or fewer under 1/2. An FRF is consistent with noise when no
    chain's probability is at or below ``p / k`` (Bonferroni: the chains are not independent of each other,
    the union bound keeps the test's level at ``p``; every line is used). A response, however weak, makes
    the lines agree near its resonances and lowers the count.

    Parameters
    ----------
    data : FRFData
        FRFs, shape (n_out, n_in, n_freq).
    p : float
        Significance of the one-sided binomial test (``StabilizationCriteria.noise_only_p``).

    Returns
    -------
    ndarray of bool, shape (n_out,)
        True for an output all of whose FRFs are consistent with noise alone (all False when the
        chains hold fewer than 8 lines).
    """
    from scipy.stats import binom

    window = data.meta.get("window")
    hann = WINDOW_KERNEL_LINES["hann"]
    step = WINDOW_KERNEL_LINES.get(str(window).lower(), hann) if window else hann
    if -(-data.n_freq // step) < 8:
        return np.zeros(data.n_out, bool)
    noise = np.ones((data.n_out, data.n_in), bool)
    for first in range(step):  # each chain of lines a kernel apart; Bonferroni over the chains
        h = data.frf[..., first::step]
        n_pairs = h.shape[-1] - 1
        jumps = np.rint(_jump_fractions(h) * n_pairs)  # (n_out, n_in) counts
        noise &= binom.cdf(jumps, n_pairs, 0.5) > p / step
    out: NDArray[np.bool_] = np.all(noise, axis=1)
    return out


def noisier_outputs(data: FRFData, factor: float, left_out: NDArray[np.bool_] | None = None) -> NDArray[np.bool_]:
    """Which outputs add more noise than information to an equally weighted (``1 / rms``) fit, from the coherence.

    The relative noise of output ``o`` is ``v_o = mean(var) / mean(|H|^2)`` over its inputs and lines, ``var``
    the H1 variance from the coherence (:func:`~ema_rig.identification.noise.coherence_variance`; the number
    of averages is common to all outputs and cancels). Weighted by ``1 / rms`` every output's equations count
    alike, so, where the outputs carry the same information, the fit behaves like an equally weighted mean of
    ``n`` estimates of variances ``v_i``: ``sum(v_i) / n^2``, which one estimate raises when its ``v_o``
    exceeds ``(2 n - 1) / (n - 1)`` times the mean of the others. The noisiest output beyond ``factor`` times
    that break-even is flagged, then the next among the rest, while at least two remain. Outputs already
    ``left_out`` of the fit (:func:`noise_only_outputs`) are neither compared with nor counted among them.

    Parameters
    ----------
    data : FRFData
        FRFs, shape (n_out, n_in, n_freq); nothing is flagged without ``data.coherence``.
    factor : float
        Multiple of the break-even (``StabilizationCriteria.noisier_output``).
    left_out : ndarray of bool, shape (n_out,), optional
        Outputs the fit is without anyway (never flagged here).

    Returns
    -------
    ndarray of bool, shape (n_out,)
    """
    out = np.zeros(data.n_out, bool) if left_out is None else np.array(left_out, dtype=bool)
    if data.coherence is None or (~out).sum() < 3:
        return np.zeros(data.n_out, bool)
    h2 = np.abs(data.frf) ** 2
    power = np.mean(h2, axis=(1, 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        v = np.mean(coherence_variance(h2, data.coherence), axis=(1, 2)) / power
    v = np.where(power > 0, v, np.inf)
    while (~out).sum() > 2:
        live = np.flatnonzero(~out)
        o = live[int(np.argmax(v[live]))]
        rest = v[live[live != o]]
        n = live.size
        if not v[o] > factor * (2 * n - 1) / (n - 1) * float(np.mean(rest)):
            break
        out[o] = True
    return out if left_out is None else out & ~left_out


def _phase_findings(data: FRFData) -> list[str]:
    fr = _jump_fractions(data.frf)
    return _phase_summary([(f"{data.out_dofs[o]}/{data.in_dofs[i]}", float(fr[o, i]))
                           for o in range(data.n_out) for i in range(data.n_in)])


def _coherence_findings(freq: NDArray[Any], coh: NDArray[Any], h: NDArray[Any], label: str) -> list[str]:
    coh = np.real(np.asarray(coh))
    if coh.size != h.size:
        return []
    over = int(np.sum(coh > 1.0 + 1e-6))
    if over:
        return [f"coherence {label} exceeds 1 at {over} lines: not a valid coherence, not used"]
    k = int(np.argmax(np.abs(h)))
    lo, hi = max(k - 3, 0), min(k + 4, coh.size)
    peak = coh[lo:hi]
    if float(np.min(peak)) < LOW_COHERENCE:
        return [f"coherence {label} at the largest peak ({freq[k]:.5g} Hz) is only "
                f"{float(np.min(peak)):.2f}-{float(np.max(peak)):.2f} (median {float(np.median(coh)):.2f} "
                "in the band): the response there is not explained by the measured force"]
    return []


def diagnose_frf(data: FRFData) -> list[str]:
    """Findings that make the FRFs of ``data`` untrustworthy (empty list when none).

    Uses ``data.coherence`` (shape (n_out, n_in, n_freq)) when the data carry one.
    """
    out = _phase_findings(data)
    coh = getattr(data, "coherence", None)
    if coh is not None:
        coh = np.asarray(coh)
        if coh.shape == data.frf.shape:
            for o in range(data.n_out):
                for i in range(data.n_in):
                    out += _coherence_findings(data.freq, coh[o, i], data.frf[o, i],
                                               f"{data.out_dofs[o]}/{data.in_dofs[i]}")
    return out


def diagnose_file(path: str | PathLike[str], data: FRFData | None = None) -> list[str]:
    """Findings from a UFF file's FRFs, coherence datasets and time records.

    Parameters
    ----------
    path : str or path-like
        The UFF file.
    data : FRFData, optional
        The FRFs as identified (band-limited); default all FRF datasets of the file.

    Returns
    -------
    list of str
        One line per finding. A file that cannot be read gives no finding (the reader's own
        error is reported elsewhere).
    """
    if data is not None and data.meta.get("source") == str(Path(path)) and not data.meta.get("ignored_datasets", True):
        # the reader used every dataset of this file (FRFs and attached coherence; no time
        # record, no loose coherence): the file holds nothing beyond `data`, no second read
        return diagnose_frf(data)
    try:
        uff = read_uff(path)
    except (EmaRigError, OSError):
        return []
    recs = [r for r in uff.records if r.status == "read" and r.type == 58 and r.y is not None and r.x is not None]
    frfs = [r for r in recs if r.function_type == 4]
    out: list[str] = []
    band = (float(data.freq[0]), float(data.freq[-1])) if data is not None else None
    data_coh = data is not None and getattr(data, "coherence", None) is not None
    if data is not None:
        out += diagnose_frf(data)
    fracs: list[tuple[str, float]] = []
    for r in frfs:
        x, y = np.asarray(r.x), np.asarray(r.y)
        keep = np.ones(x.size, bool) if band is None else (x >= band[0]) & (x <= band[1])
        if keep.sum() < 8:
            continue
        label = f"{r.response}/{r.reference}"
        if data is None:
            fracs.append((label, _jump_fraction(y[keep])))
        if data_coh:
            continue
        for c in recs:
            if (c.function_type == 6 and c.response == r.response and c.reference == r.reference
                    and c.y is not None and c.y.size == y.size):
                out += _coherence_findings(x[keep], np.asarray(c.y)[keep], y[keep], label)
    out += _phase_summary(fracs)
    refs = {str(r.reference) for r in frfs}
    for r in recs:
        if r.function_type != 1 or str(r.response) not in refs or str(r.response) != str(r.reference):
            continue
        f = np.abs(np.asarray(r.y, dtype=np.complex128))
        n = f.size
        if n < 16:
            continue
        k = int(np.argmax(f))
        rms = float(np.sqrt(np.mean(f**2)))
        if k > n // 2:
            out.append(f"force record {r.response}: the impact (force peak) sits at sample {k} of {n} "
                       f"({100 * k / n:.0f} % into the record), so the response to it is cut off "
                       "(leakage and delay corrupt the FRF)")
        if rms > 0 and f[k] / rms < 3.0:
            out.append(f"force record {r.response}: no clear impulse (peak only {f[k] / rms:.1f} times the RMS)")
    return out


__all__ = ["diagnose_file", "diagnose_frf", "noise_only_outputs", "noisier_outputs"]
