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
shared by all ``n_out * n_in`` channels. Each basis column is scaled to unit norm and the small
basis factored once by SVD (the minimum-norm solution ``lstsq`` gives, with its default cutoff);
the channels are then projected in chunks of outputs, the complex FRFs read as interleaved real
pairs without a copy, so the work arrays stay a fraction of the data (BLAS on one thread).
Lines at 0 Hz are skipped when the basis is singular there.
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._blas import single_threaded
from ..errors import IdentificationError
from ..frf import FORM_POWER as _FORM_POWER
from ..frf import FRFData
from .modal import ModalModel, pole_residue_basis
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
    return _lsfd_checked(check_data(data, band), poles, residuals=residuals)


def _lsfd_checked(data: FRFData, poles: ArrayLike, *, residuals: bool = True) -> ModalModel:
    """:func:`lsfd` on data already validated and cut by :func:`~ema_rig.identification.plscf.check_data`.

    For callers that checked the data once for several steps (``identify``); same parameters,
    result and pole errors as :func:`lsfd`, without the band and the second data check.
    """
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
    n_modes = lam.size
    n_unk = 2 * n_modes + (2 if residuals else 0)
    n_f = f.size
    if 2 * n_f < n_unk:
        raise IdentificationError(
            f"LSFD: {n_f} lines cannot determine {n_unk} real unknowns ({n_modes} modes)", file=src
        )
    a, scale = pole_residue_basis(f, lam, p, residuals=residuals)
    n_out, n_in, _ = h.shape
    x = np.empty((n_out, n_in, n_unk))
    num = np.empty((n_out, n_in))
    den = np.empty((n_out, n_in))
    with single_threaded():
        uk, proj = _projector(a)
        for o0, o1, yv in _output_chunks(h):
            xs = (yv @ uk) @ proj.T  # scaled unknowns (chunk, n_in, n_unk)
            x[o0:o1] = xs / scale
            res = xs @ a.T
            np.subtract(yv, res, out=res)
            num[o0:o1] = np.sqrt(np.einsum("oik,oik->oi", res, res))
            den[o0:o1] = np.sqrt(np.einsum("oik,oik->oi", yv, yv))
            del res, xs, yv
    residues = np.moveaxis(x[:, :, :n_modes] + 1j * x[:, :, n_modes : 2 * n_modes], 2, 0)
    if residuals:
        lower = x[:, :, 2 * n_modes].astype(np.complex128)
        upper = x[:, :, 2 * n_modes + 1].astype(np.complex128)
    else:
        lower = np.zeros((n_out, n_in), np.complex128)
        upper = np.zeros((n_out, n_in), np.complex128)
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


def _projector(a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Minimum-norm least-squares solve through the SVD of the small basis, as ``lstsq`` does.

    Returns ``uk`` (2 n_freq, rank) and ``proj`` (n_unknown, rank): the unknowns of data rows
    ``y`` (..., 2 n_freq) are ``(y @ uk) @ proj.T``, and ``proj @ proj.T`` is the
    (pseudo-)inverse of ``a.T @ a`` (the unscaled covariance of the unknowns).
    """
    u, sv, vt = np.linalg.svd(a, full_matrices=False)
    keep = sv > np.finfo(float).eps * max(a.shape) * sv[0]
    return np.ascontiguousarray(u[:, keep]), vt[keep].T / sv[keep]


def _output_chunks(h: NDArray[np.complex128]) -> Iterator[tuple[int, int, NDArray[np.float64]]]:
    """FRFs (n_out, n_in, n_freq) in chunks of outputs as real views (chunk, n_in, 2 n_freq).

    Re and Im are interleaved per line (no copy unless the lines are strided); a chunk's
    work arrays of one fit stay within a fraction of the data (at most 64 MB).
    """
    n_out, n_in, n_f = h.shape
    budget = int(min(max(h.nbytes // 8, 8 << 20), 64 << 20))
    step = max(1, budget // max(n_in * n_f * 16, 1))
    for o0 in range(0, n_out, step):
        o1 = min(o0 + step, n_out)
        blk = h[o0:o1]
        if blk.strides[-1] != blk.itemsize:
            blk = np.ascontiguousarray(blk)
        yield o0, o1, blk.view(np.float64)


__all__ = ["lsfd"]
