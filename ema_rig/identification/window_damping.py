"""The processing history applied to an identification: usable band and exponential-window damping.

Functions
---------
processing_band
    Clip an identification band to where the FRFs are valid (the analyser band from dataset
    1858, else ``ANTI_ALIAS_FRACTION * fs / 2``).
remove_decay
    Natural frequencies and damping ratios with a decay rate removed (the pole shift alone).
remove_window_damping
    Remove an exponential window's damping from every identified pole (exact), with the
    standard deviations carried through; modes whose damping the window alone explains are
    dropped with a warning.
with_window_damping
    Its inverse on a model: the window's damping put back, for comparison with the windowed FRFs.

Notes
-----
With ``w(t) = exp(-a t)`` on force and response, the windowed FRF has the structure's residues
and every pole moved to ``lambda - a`` (Fladung & Rost 1997, see :mod:`ema_rig.processing`), so
``lambda_true = lambda_id + a``: the real part shifts by ``+a`` and the damped frequency
``Im lambda`` is unchanged. With ``omega_n = |lambda|`` and ``zeta = -Re lambda / |lambda|``
the standard deviations follow by first-order propagation through ``(f, zeta) -> (Re, Im)
-> (Re + a, Im) -> (f', zeta')``, treating ``f`` and ``zeta`` as uncorrelated and ``a`` as exact
(it is the window's, not estimated).

A corrected damping ratio below zero by more than ``DROP_SIGMAS`` standard deviations is not
a decaying structural mode (the pole decays more slowly than the window alone makes it): the
mode is dropped with a warning. One that is consistent with zero is kept with a warning that
the window dominates its damping.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..frf import FORM_POWER, FRFData
from ..processing import ANTI_ALIAS_FRACTION, processing_history, usable_band
from .modal import ModalModel

DROP_SIGMAS = 2.0
"""A corrected damping ratio this many standard deviations below zero drops the mode (the 2 sigma
of the DESIGN contract "a result without warnings lies within 2 standard uncertainties")."""


def processing_band(data: FRFData, band: tuple[float, float] | None
                    ) -> tuple[tuple[float, float] | None, list[str]]:
    """The band clipped to the FRFs' usable band, and a note when it was clipped.

    Parameters
    ----------
    data : FRFData
    band : (float, float) or None
        Requested ``(freq_lower, freq_upper)`` [Hz]; None for the whole data.

    Returns
    -------
    band : (float, float) or None
        Unchanged when the history gives no limit or the band lies inside it.
    notes : list of str
    """
    hist = processing_history(data)
    top = usable_band(hist)
    if top is None or hist is None:
        return band, []
    lo, hi = (float(data.freq[0]), float(data.freq[-1])) if band is None else (float(band[0]), float(band[1]))
    if hi <= top:
        return band, []
    what = (f"the analyser band ({hist.source})" if hist.band is not None
            else f"{ANTI_ALIAS_FRACTION:g} x fs/2 (fs = {hist.fs:g} Hz, the anti-alias limit)")
    if lo >= top:
        return band, [f"band {lo:g}..{hi:g} Hz lies above the usable band (up to {top:g} Hz, {what}): not clipped"]
    # the last line at or below the limit
    k = int(np.searchsorted(data.freq, top, side="right")) - 1
    new_hi = float(data.freq[max(k, 0)])
    return (lo, new_hi), [f"band end {hi:g} Hz clipped to {new_hi:g} Hz: the FRFs are valid up to {top:g} Hz ({what})"]


def remove_decay(natural_freq: ArrayLike, damping_ratio: ArrayLike, decay: float
                 ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Poles with ``decay`` removed from their decay rate (the real part moved by ``+decay``).

    Parameters
    ----------
    natural_freq : array_like, shape (n,)
        Undamped natural frequencies ``|lambda| / 2 pi`` [Hz] of the windowed FRF's poles.
    damping_ratio : array_like, shape (n,)
        Their damping ratios ``-Re lambda / |lambda|``.
    decay : float
        The exponential window's decay rate ``a`` [1/s].

    Returns
    -------
    natural_freq, damping_ratio : ndarray, shape (n,)
        Of ``lambda + a`` (the damped frequency ``Im lambda`` unchanged).
    """
    f = np.asarray(natural_freq, dtype=np.float64)
    z = np.asarray(damping_ratio, dtype=np.float64)
    w = 2 * np.pi * f
    re = -z * w + float(decay)
    im = w * np.sqrt(np.clip(1.0 - z * z, 0.0, None))
    w2 = np.hypot(re, im)
    return w2 / (2 * np.pi), -re / w2


def _propagate(f: float, z: float, sf: float, sz: float, a: float) -> tuple[float, float, float, float]:
    """(f', zeta', std f', std zeta') of the pole (f, zeta) with its real part shifted by +a [rad/s]."""
    w = 2 * np.pi * f
    q = np.sqrt(max(1.0 - z * z, 0.0))
    re, im = -z * w, w * q
    j1 = np.array([[-2 * np.pi * z, -w], [2 * np.pi * q, -w * z / q if q > 0 else 0.0]])
    cov = j1 @ np.diag([sf * sf, sz * sz]) @ j1.T
    re2 = re + a
    w2 = float(np.hypot(re2, im))
    j2 = np.array([[re2 / (2 * np.pi * w2), im / (2 * np.pi * w2)], [-im * im / w2**3, re2 * im / w2**3]])
    c2 = j2 @ cov @ j2.T
    fn, zn = remove_decay([f], [z], a)
    return float(fn[0]), float(zn[0]), float(np.sqrt(max(c2[0, 0], 0.0))), float(np.sqrt(max(c2[1, 1], 0.0)))


def _move_poles(model: ModalModel, decay: float) -> ModalModel:
    """``model`` with every pole's real part moved by ``+decay`` [1/s], its residues carried along.

    The residues of the FRF form measured are the window's (unchanged by the shift); the model
    stores receptance residues ``R = residue / lambda^p`` (p = 2 accelerance, 1 mobility), so
    ``R_new = R (lambda / lambda_new)^p``. The residual terms are left as they are.
    """
    poles = np.asarray(model.poles, dtype=np.complex128)
    lam = poles + float(decay)
    ratio = (poles / lam) ** FORM_POWER[model.frf_form] if lam.size else np.ones(0)
    return replace(model, poles=lam, residues=np.asarray(model.residues) * ratio[:, None, None])


def with_window_damping(model: ModalModel) -> ModalModel:
    """The model as the windowed FRFs show it: the exponential window's damping put back.

    The inverse of the pole shift :func:`remove_window_damping` makes: the model the fit used,
    to compare with the (windowed) FRFs it was fitted to, e.g. in a synthesis figure or
    :meth:`~ema_rig.identification.modal.ModalModel.line_error`.

    Parameters
    ----------
    model : ModalModel
        With ``meta["window_decay"] = a`` [1/s] when :func:`remove_window_damping` corrected it.

    Returns
    -------
    ModalModel
        Unchanged without ``meta["window_decay"]`` (or ``a <= 0``). Else every pole moved by
        ``-a`` (its residues carried along), ``meta["window_decay"]`` removed and
        ``meta["window_damping_applied"] = a``.
    """
    a = float(model.meta.get("window_decay") or 0.0)
    if a <= 0:
        return model
    meta = {k: v for k, v in model.meta.items() if k != "window_decay"}
    meta["window_damping_applied"] = a
    return replace(_move_poles(model, -a), meta=meta)


def remove_window_damping(ident: Any, data: FRFData) -> Any:
    """The identification with an exponential window's damping removed from its modes.

    Parameters
    ----------
    ident : Identification
        As :func:`~ema_rig.identification.identify` returns it (poles of the windowed FRFs).
    data : FRFData
        The data it was identified from; its processing history
        (:func:`~ema_rig.processing.processing_history`) gives the window's decay ``a`` [1/s].

    Returns
    -------
    Identification
        Unchanged without an exponential window. Else ``modes.poles`` moved by ``+a`` (residues
        unchanged: the windowed FRF has the same residues), frequencies, damping ratios and their
        standard deviations recomputed, ``modes.meta["window_decay"] = a`` and
        ``modes.meta["polymax_poles"]`` the poles before the shift (as identified on the chart),
        a note, and a warning per mode whose damping the window dominates or explains alone
        (the latter are dropped). ``modes.fit_error`` stays that of the windowed FRFs.
    """
    hist = processing_history(data)
    a = 0.0 if hist is None else float(hist.exp_decay)
    if a <= 0:
        return ident
    mm = ident.modes
    poles = np.asarray(mm.poles, dtype=np.complex128)
    start = mm.meta.get("polymax_poles") or [[float(p.real), float(p.imag)] for p in poles]
    new_p, sf2, sz2 = [], [], []
    keep: list[int] = []
    warnings = list(ident.warnings)
    for k, p in enumerate(poles):
        f, z = float(abs(p) / (2 * np.pi)), float(-p.real / abs(p))
        sf, sz = float(ident.natural_freq_std[k]), float(ident.damping_ratio_std[k])
        fn, zn, sfn, szn = _propagate(f, z, sf, sz, a)
        label = f"mode at {fn:.6g} Hz"
        if zn < 0 and (np.isfinite(szn) and zn + DROP_SIGMAS * szn < 0):
            warnings.append(f"{label} not reported: its damping ({100 * z:.3g} % in the windowed FRF) is less than "
                            f"the exponential window's alone ({100 * a / (2 * np.pi * fn):.3g} %), so it is not a "
                            "decaying structural mode (window, leakage or noise)")
            continue
        if not (np.isfinite(szn) and zn > DROP_SIGMAS * szn):
            warnings.append(f"{label}: damping {100 * zn:.3g} +/- {100 * szn:.2g} % after removing the exponential "
                            f"window's {100 * a / (2 * np.pi * fn):.3g} %: the window dominates it; a longer record "
                            "or a weaker window would resolve it")
        keep.append(k)
        new_p.append(complex(p.real + a, p.imag))
        sf2.append(sfn)
        sz2.append(szn)
    idx = np.asarray(keep, dtype=np.intp)
    meta = dict(mm.meta)
    meta["window_decay"] = a
    meta["polymax_poles"] = [start[k] for k in keep]
    model = _move_poles(replace(mm, poles=poles[idx], residues=np.asarray(mm.residues)[idx], meta=meta), a)
    note = (f"exponential window ({hist.source if hist else ''}): {a:.6g} 1/s removed from every pole's real "
            f"part (Fladung & Rost 1997), i.e. {100 * a / (2 * np.pi):.4g} % / f[Hz] of damping ratio")
    notes = tuple(ident.notes) + (note,) + tuple(f"data: {n}" for n in (hist.notes if hist else ()))
    if hist is not None and hist.source == "dataset 1858":
        warnings.append(f"the exponential window damping factor {a:g} of another writer's dataset 1858 is taken "
                        "as a decay rate in 1/s (the format does not fix its unit): check the damping ratios")
    return replace(ident, modes=model, natural_freq_std=np.asarray(sf2, dtype=np.float64),
                   damping_ratio_std=np.asarray(sz2, dtype=np.float64), warnings=tuple(warnings), notes=notes)


__all__ = ["DROP_SIGMAS", "processing_band", "remove_decay", "remove_window_damping", "with_window_damping"]
