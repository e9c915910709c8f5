"""Least-squares frequency-domain (LSFD) estimation of modal constants.

Functions
---------
lsfd
    Residues of every output/input pair for given poles, with lower and upper residual terms,
    as a :class:`~ema_rig.identification.modal.ModalModel`.

Notes
-----
For poles ``lambda_r`` (fixed) the FRFs are linear in the unknowns. In receptance form::

    H_rec(w) = sum_r [ R_r / (j w - lambda_r) + conj(R_r) / (j w - conj(lambda_r)) ]
               + LR / (j w)^2 + UR

and the data of form ``p`` (0 receptance, 1 mobility, 2 accelerance) are
``(j w)^p H_rec(w)``. ``R_r`` is complex (two real unknowns per mode), ``LR`` and ``UR`` are real:
one real least-squares problem (real and imaginary parts of every line stacked) whose basis is
shared by all ``n_out * n_in`` channels, solved once with many right-hand sides after scaling
each basis column to unit norm. Lines at 0 Hz are skipped when the basis is singular there.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import IdentificationError
from ..frf import _FORM_POWER, FRFData
from .modal import ModalModel
from .plscf import check_data, source_of


def lsfd(
    data: FRFData,
    poles: ArrayLike,
    *,
    band: tuple[float, float] | None = None,
    residuals: bool = True,
) -> ModalModel:
    """Fit residues (and residual terms) for known poles.

    Parameters
    ----------
    data : FRFData
        FRFs, shape (n_out, n_in, n_freq), any form.
    poles : array_like, shape (n_modes,), complex
        Poles [rad/s] with ``Im > 0`` (one of each conjugate pair).
    band : (float, float), optional
        Band [Hz] of the fit (default all lines).
    residuals : bool, optional
        Fit the lower (``1/(j w)^2``, 1/kg) and upper (constant, m/N) residual terms
        (default True).

    Returns
    -------
    ModalModel
        Receptance residues (n_modes, n_out, n_in), residuals, per-channel relative fit error
        ``||H - H_syn|| / ||H||`` over the band; poles sorted by natural frequency.

    Raises
    ------
    IdentificationError
        No pole, a pole with ``Im <= 0``, or fewer equations than unknowns.

    Examples
    --------
    >>> import numpy as np
    >>> from ema_rig.frf import FRFData
    >>> f = np.linspace(1.0, 200.0, 400)
    >>> jw = 2j * np.pi * f
    >>> lam = -0.02 * 2 * np.pi * 80 + 2j * np.pi * 80
    >>> res = 1e-3j
    >>> h = (res / (jw - lam) + np.conj(res) / (jw - np.conj(lam)))[None, None]
    >>> m = lsfd(FRFData(f, h, ["1+Y"], ["1+Y"], frf_form="receptance"), [lam])
    >>> bool(np.isclose(m.residues[0, 0, 0], res))
    True
    """
    data = check_data(data, band)
    lam = np.atleast_1d(np.asarray(poles, dtype=np.complex128)).ravel()
    src = source_of(data)
    if lam.size == 0:
        raise IdentificationError("LSFD needs at least one pole", file=src)
    if not np.all(np.isfinite(lam)) or np.any(lam.imag <= 0):
        raise IdentificationError("LSFD poles must be finite with Im > 0 (one of each conjugate pair)", file=src)
    lam = lam[np.argsort(np.abs(lam))]
    p = _FORM_POWER[data.frf_form]
    f = data.freq
    h = data.frf
    if residuals and p < 2 and f[0] == 0.0:
        f, h = f[1:], h[:, :, 1:]
    jw = 2j * np.pi * f
    n_modes = lam.size
    with np.errstate(divide="ignore", invalid="ignore"):
        fac = jw**p
        pos = 1.0 / (jw[:, None] - lam[None, :])
        neg = 1.0 / (jw[:, None] - lam.conj()[None, :])
        cols: list[NDArray[Any]] = [fac[:, None] * (pos + neg), fac[:, None] * (1j * pos - 1j * neg)]
        if residuals:
            lr = jw ** (p - 2) if p >= 2 else 1.0 / jw ** (2 - p)
            cols += [lr[:, None], fac[:, None]]
    basis = np.concatenate(cols, axis=1)  # (n_freq, n_unknown) complex
    n_unk = basis.shape[1]
    if 2 * f.size < n_unk:
        raise IdentificationError(
            f"LSFD: {f.size} lines cannot determine {n_unk} real unknowns ({n_modes} modes)", file=src
        )
    a = np.concatenate([basis.real, basis.imag], axis=0)
    scale = np.linalg.norm(a, axis=0)
    scale = np.where(scale > 0, scale, 1.0)
    n_out, n_in, n_f = h.shape
    y = h.reshape(n_out * n_in, n_f).T  # (n_freq, n_chan)
    b = np.concatenate([y.real, y.imag], axis=0)
    x, *_ = np.linalg.lstsq(a / scale, b, rcond=None)
    x = x / scale[:, None]  # (n_unk, n_chan)
    res = (x[:n_modes] + 1j * x[n_modes : 2 * n_modes]).T.reshape(n_out, n_in, n_modes)
    residues = np.moveaxis(res, 2, 0)
    if residuals:
        lower = x[2 * n_modes].reshape(n_out, n_in).astype(np.complex128)
        upper = x[2 * n_modes + 1].reshape(n_out, n_in).astype(np.complex128)
    else:
        lower = np.zeros((n_out, n_in), np.complex128)
        upper = np.zeros((n_out, n_in), np.complex128)
    fit = (basis @ x).T.reshape(n_out, n_in, n_f)
    num = np.linalg.norm(h - fit, axis=2)
    den = np.linalg.norm(h, axis=2)
    fit_error = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return ModalModel(
        poles=lam,
        residues=residues,
        lower_residual=lower,
        upper_residual=upper,
        out_dofs=data.out_dofs,
        in_dofs=data.in_dofs,
        roles=data.roles,
        axes=data.axes,
        frf_form=data.frf_form,
        band=(float(data.freq[0]), float(data.freq[-1])),
        fit_error=fit_error,
        meta={"method": "lsfd", "residuals": bool(residuals)},
    )


__all__ = ["lsfd"]
