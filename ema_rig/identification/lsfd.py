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

*Weights.* With the noise variance ``v_ci = E|e_ci|^2`` of every channel ``c`` and line ``i``
given, each channel's rows (Re and Im of a line, each carrying ``v_ci / 2``) are divided by
``sqrt(v_ci)``: for fixed poles this weighted least-squares fit is the maximum-likelihood
estimate of the residues and residual terms under independent complex Gaussian noise
(Pintelon & Schoukens, *System Identification*, 2nd ed. 2012, sect. 7.2 and 9.4). Unweighted,
the lines near the largest peak, where the noise is largest in absolute terms, set the residues
of the weak modes and the residual terms. When the variances share one line profile up to a
scale per channel (a scale does not change a channel's fit), the basis is weighted and factored
once as above; otherwise each channel solves its normal equations in the orthonormal basis of
the shared factorization (batched matrix products, then a small eigen-solve per channel).
``identify`` reports per channel the weighted fit unless the model errs there (see
``_lsfd_noise_weighted``).
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._blas import single_threaded
from .._linalg import thin_svd
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
    variance: ArrayLike | None = None,
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
    variance : array_like, shape (n_out, n_in, n_freq) or (n_freq,), optional
        Noise variance ``E|e|^2`` of every line of ``data`` [FRF unit^2] (before the band is cut),
        > 0; ``inf`` gives a line no weight. Each line's equations are divided by its noise
        standard deviation (the maximum-likelihood residues for the given poles, see Notes of the
        module). Default: unweighted least squares.

    Returns
    -------
    ModalModel
        Receptance residues (n_modes, n_out, n_in), residuals, per-channel relative fit error
        ``||H - H_syn|| / ||H||`` over the band; poles sorted by natural frequency.

    Raises
    ------
    IdentificationError
        No pole, a pole with ``Im <= 0``, or fewer equations than unknowns; a ``variance``
        of the wrong shape, NaN, or not positive.

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
    cut = check_data(data, band)
    var = None
    if variance is not None:
        var = np.asarray(variance, dtype=np.float64)
        if var.ndim == 1:
            var = var[None, None, :]
        if var.ndim != 3 or var.shape[2] != data.n_freq or var.shape[:2] not in ((1, 1), data.frf.shape[:2]):
            raise IdentificationError(
                f"LSFD variance has shape {np.shape(variance)}, expected {data.frf.shape} or ({data.n_freq},)",
                file=source_of(data))
        var = var[:, :, np.searchsorted(data.freq, cut.freq)]
    return _lsfd_checked(cut, poles, residuals=residuals, variance=var)


@dataclass(frozen=True, slots=True, eq=False)
class LsfdBasis:
    """The pole-residue basis of one LSFD fit and its SVD factor, for a later fit at the same poles.

    ``identify`` fits the residues unweighted at the ML poles, then weighted by the noise at the
    same poles on the same lines: with this the second fit forms neither the basis nor its factor
    again (the per-channel weighted fit factors the unweighted basis too).

    Parameters
    ----------
    freq : ndarray, shape (n_freq,)
        Lines fitted [Hz] (0 Hz already left out where the basis is singular there).
    poles : ndarray, shape (n_modes,), complex
        Poles [rad/s], sorted by modulus as the fit sorts them.
    power : int
        Form power of the data (0 receptance, 1 mobility, 2 accelerance).
    residuals : bool
        Whether the basis holds the two residual columns.
    a, scale : ndarray, shapes (2 n_freq, n_unknown) and (n_unknown,)
        :func:`~ema_rig.identification.modal.pole_residue_basis` of ``poles`` on ``freq``.
    uk, proj : ndarray, shapes (2 n_freq, rank) and (n_unknown, rank)
        The factor of ``a`` (:func:`_projector`).
    unknowns : ndarray, shape (n_out, n_in, n_unknown), optional
        The unknowns of the unit-norm basis (before the division by ``scale``) of the unweighted fit of
        the FRFs ``frf``, when the fit that formed the basis kept them (the judgement's): an unweighted
        fit of the same FRFs takes them over (the same numbers).
    frf : ndarray, shape (n_out, n_in, n_freq), complex, optional
        The FRFs those unknowns fit: the data's (read-only) array itself, compared by identity.
    """

    freq: NDArray[np.float64]
    poles: NDArray[np.complex128]
    power: int
    residuals: bool
    a: NDArray[np.float64]
    scale: NDArray[np.float64]
    uk: NDArray[np.float64]
    proj: NDArray[np.float64]
    unknowns: NDArray[np.float64] | None = None
    frf: NDArray[np.complex128] | None = None

    def matches(self, freq: NDArray[np.float64], poles: NDArray[np.complex128], power: int, residuals: bool) -> bool:
        """Whether this is the basis of ``poles`` (sorted as :func:`_fit` sorts them) on the lines ``freq``."""
        return (self.power == power and self.residuals == residuals and np.array_equal(self.poles, poles)
                and np.array_equal(self.freq, freq))


def model_order(poles: ArrayLike) -> NDArray[np.complex128]:
    """The poles as an LSFD model holds them: shape (n_modes,), sorted by ``|pole|`` [rad/s].

    The order of :attr:`ModalModel.poles <ema_rig.identification.modal.ModalModel.poles>` of every
    :func:`lsfd` fit (and of the tests formed at those poles, e.g. the completeness test): a task that
    needs the model's poles but not its residues takes them from here, before the fit is done.

    Parameters
    ----------
    poles : array_like of complex, any shape
        Continuous-time poles [rad/s], in any order.

    Returns
    -------
    ndarray of complex, shape (n_modes,)
        The same poles, sorted by ``|pole|`` as the LSFD model holds them [rad/s].
    """
    lam = np.atleast_1d(np.asarray(poles, dtype=np.complex128)).ravel()
    out: NDArray[np.complex128] = lam[np.argsort(np.abs(lam))]
    return out


def _lsfd_checked(data: FRFData, poles: ArrayLike, *, residuals: bool = True,
                  variance: NDArray[np.float64] | None = None,
                  model_out: NDArray[np.complex128] | None = None,
                  basis_out: list[LsfdBasis] | None = None, basis: LsfdBasis | None = None,
                  pole_columns: NDArray[np.complex128] | None = None) -> ModalModel:
    """:func:`lsfd` on data already validated and cut by :func:`~ema_rig.identification.plscf.check_data`.

    For callers that checked the data once for several steps (``identify``); same parameters,
    result and pole errors as :func:`lsfd`, without the band and the second data check.
    ``variance`` (shape (n_out, n_in, n_freq) or (1, 1, n_freq)) is on the lines of ``data``.
    With ``model_out`` (complex, shape of ``data.frf``) the fitted model's FRFs on the data's lines
    are written into it: the fit's own product of basis and coefficients (what
    :meth:`~ema_rig.identification.modal.ModalModel.synthesize` gives, without forming it again),
    the data at a line the fit leaves out (0 Hz with a lower residual, where the model is infinite).
    With ``basis_out`` (a list) the fit's basis and factor are appended to it (:class:`LsfdBasis`; not
    when a common line profile of the weights changed the factor). ``basis``: an earlier fit's basis and
    factor (e.g. the judgement's, :func:`~ema_rig.identification.judge.judge_clusters`), used when it
    belongs to these poles and lines (the same numbers). ``pole_columns``: the poles' columns on the data's
    lines when the caller has them (:func:`_fit`).
    """
    return _fit(data, poles, residuals=residuals, variance=variance, model_out=model_out, basis_out=basis_out,
                basis=basis, pole_columns=pole_columns)[0]


def _lsfd_noise_weighted(data: FRFData, poles: ArrayLike, variance: NDArray[np.float64], *,
                         residuals: bool = True, unweighted: ModalModel | None = None,
                         basis: LsfdBasis | None = None) -> ModalModel:
    """The residues ``identify`` reports: per channel the noise-weighted fit unless the model errs.

    Both fits at ``poles`` on data checked as for :func:`_lsfd_checked`, the weighted one (the
    maximum-likelihood residues when the model holds) and the unweighted one, are scored per
    channel by the median over the lines of ``|e|^2 / variance`` (the residual in units of the
    noise; a least-median-of-squares comparison, Rousseeuw, JASA 79, 1984). Each channel keeps the
    weighted fit unless its typical line lies further from the data in noise units than with the
    unweighted fit: then the model misses something that the weights spread over the band (the
    residual terms stand for modes far outside the band, not for one just beyond its edge), and the
    unweighted fit, set by the resonances, is kept.

    Parameters
    ----------
    data : FRFData
        FRFs already validated and cut to the band, shape (n_out, n_in, n_freq).
    poles : array_like, shape (n_modes,), complex
        Poles [rad/s], ``Im > 0``.
    variance : ndarray, shape (n_out, n_in, n_freq)
        Noise variance ``E|e|^2`` of every line [FRF unit^2] (``inf``: no weight, not scored).
    residuals : bool, optional
        Fit the residual terms (default True).
    unweighted : ModalModel, optional
        The unweighted fit at the same poles on the same data (:func:`_lsfd_checked`), when the
        caller has it: it is scored by its synthesis instead of being fitted again.
    basis : LsfdBasis, optional
        The basis and factor of that fit (``_lsfd_checked(basis_out=...)``): used by both instead of
        forming them again when it belongs to these poles and lines (the same numbers).

    Returns
    -------
    ModalModel
        ``meta["weighted"]`` says how many channels kept the weighted fit.
    """
    var = np.asarray(variance, dtype=np.float64)
    if unweighted is None:
        un, s_un = _fit(data, poles, residuals=residuals, score=var, basis=basis)
    else:
        un, s_un = unweighted, _synthesis_score(data, unweighted, var, residuals, basis)
    wt, s_wt = _fit(data, poles, residuals=residuals, variance=var, score=var, basis=basis)
    keep = s_wt <= s_un  # NaN (no line with a finite variance): unweighted
    n_keep = int(np.sum(keep))
    if n_keep == keep.size:
        return replace(wt, meta={**wt.meta, "weighted": f"{n_keep} of {keep.size} channels"})
    assert un.fit_error is not None and wt.fit_error is not None
    return replace(
        un,
        residues=np.where(keep[None], wt.residues, un.residues),
        lower_residual=np.where(keep, wt.lower_residual, un.lower_residual),
        upper_residual=np.where(keep, wt.upper_residual, un.upper_residual),
        fit_error=np.where(keep, wt.fit_error, un.fit_error),
        meta={**un.meta, "weighted": f"{n_keep} of {keep.size} channels"},
    )


def _fit(data: FRFData, poles: ArrayLike, *, residuals: bool = True, variance: NDArray[np.float64] | None = None,
         score: NDArray[np.float64] | None = None, model_out: NDArray[np.complex128] | None = None,
         basis: LsfdBasis | None = None, basis_out: list[LsfdBasis] | None = None,
         pole_columns: NDArray[np.complex128] | None = None) -> tuple[ModalModel, NDArray[np.float64]]:
    """The fit of :func:`_lsfd_checked` and, with ``score`` (a variance like ``variance``), the median
    over the lines of ``|e|^2 / score`` per channel, shape (n_out, n_in) (NaN without such a line;
    empty without ``score``). With ``model_out`` (shape of ``data.frf``, complex) the fitted model's
    FRFs are written into it (the data at a line the fit leaves out). ``basis`` an earlier fit's
    basis and factor, used when it belongs to these poles and lines; ``basis_out`` (a list) receives
    this fit's (:class:`LsfdBasis`). ``pole_columns``, shape (n_freq, 2 n_modes), complex: the poles' columns
    on ``data.freq`` in the order of the model (:func:`model_order`), :func:`~ema_rig.identification.modal.modal_basis`
    without residual columns (e.g. :func:`~ema_rig.identification.noise.segment_pole_columns`), when the
    caller has them: the basis is formed from them (the same numbers)."""
    lam = np.atleast_1d(np.asarray(poles, dtype=np.complex128)).ravel()
    src = source_of(data)
    if lam.size == 0:
        raise IdentificationError("LSFD needs at least one pole", file=src)
    if not np.all(np.isfinite(lam)) or np.any(lam.imag <= 0):
        raise IdentificationError("LSFD poles must be finite with Im > 0 (one of each conjugate pair)", file=src)
    lam = model_order(lam)
    p = _FORM_POWER[data.frf_form]
    f = data.freq
    h = data.frf
    weights = None if variance is None else _line_weights(variance, h.shape, src)
    sv = None if score is None else np.broadcast_to(score, h.shape)
    off = 0
    if residuals and p < 2 and f[0] == 0.0:
        if model_out is not None:
            model_out[:, :, 0] = h[:, :, 0]
        off = 1
        f, h = f[1:], h[:, :, 1:]
        weights = None if weights is None else weights[:, :, 1:]
        sv = None if sv is None else sv[:, :, 1:]
    n_modes = lam.size
    n_unk = 2 * n_modes + (2 if residuals else 0)
    n_f = f.size
    if 2 * n_f < n_unk:
        raise IdentificationError(
            f"LSFD: {n_f} lines cannot determine {n_unk} real unknowns ({n_modes} modes)", file=src
        )
    reuse = basis is not None and basis.matches(f, lam, p, residuals)
    if reuse:
        assert basis is not None
        a, scale = basis.a, basis.scale
    else:
        a, scale = pole_residue_basis(f, lam, p, residuals=residuals,
                                      pole_columns=None if pole_columns is None else pole_columns[off:])
    n_out, n_in, _ = h.shape
    x = np.empty((n_out, n_in, n_unk))
    num = np.empty((n_out, n_in))
    den = np.empty((n_out, n_in))
    med = np.full((n_out, n_in) if sv is not None else (0, 0), np.nan)
    common = None if weights is None else _common_profile(weights)
    shared = weights is None or common is not None
    # unweighted, or one line profile for every channel (a channel's scale does not change its
    # fit): the basis weighted once, columns to unit norm again, one shared factorization
    cn = np.ones(n_unk)
    aw = a
    if common is not None:
        aw = a * common[:, None]
        cn = np.sqrt(np.einsum("kj,kj->j", aw, aw))
        cn = np.where(cn > 0, cn, 1.0)
        aw = aw / cn
    # the unweighted fit of the same FRFs formed with the basis (the judgement's): its unknowns
    known = basis.unknowns if reuse and weights is None and basis is not None and basis.frf is data.frf else None
    with single_threaded():
        if reuse and common is None:
            assert basis is not None
            uk, proj = basis.uk, basis.proj  # the factor of the unweighted basis ``a``
        else:
            uk, proj = _projector(aw)
        if basis_out is not None and common is None:
            basis_out.append(LsfdBasis(f, lam, p, bool(residuals), a, scale, uk, proj))
        for o0, o1, yv in _output_chunks(h):
            if known is not None:
                xs = known[o0:o1]  # the same products of the same chunks (cn is 1 unweighted)
            elif weights is None or common is not None:
                xs = rows_times(rows_times(yv if common is None else yv * common, uk), proj.T) / cn  # (chunk, n_in, n_unk)
            else:
                xs = _weighted_solve(uk, proj, yv, np.repeat(weights[o0:o1], 2, axis=2))
            x[o0:o1] = xs / scale
            res = rows_times(xs, a.T)
            if model_out is not None:
                model_out[o0:o1, :, off:] = res.view(np.complex128)
            np.subtract(yv, res, out=res)
            if sv is not None:
                med[o0:o1] = _median_score(res[:, :, 0::2] ** 2 + res[:, :, 1::2] ** 2, sv[o0:o1])
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
        meta={"method": "lsfd", "residuals": bool(residuals),
              "weighted": "no" if weights is None else ("line profile" if shared else "per channel")},
    ), med


def _median_score(e2: NDArray[np.float64], v: NDArray[np.float64]) -> NDArray[np.float64]:
    """Median over the lines of ``e2 / v`` per channel, lines with a finite ``v > 0`` only (NaN without one).

    ``e2`` and ``v`` have shape (n_out, n_in, n_freq); the result (n_out, n_in).
    """
    fin = np.isfinite(v) & (v > 0)
    if fin.all():
        q = e2 / v
        if not np.isnan(q).any():  # no line to leave out: the plain median (nanmedian loops per channel)
            out0: NDArray[np.float64] = np.median(q, axis=2)
            return out0
    with np.errstate(all="ignore"):
        q = np.where(fin, e2 / np.where(fin, v, 1.0), np.nan)
    has = np.asarray(fin.any(axis=2))
    out: NDArray[np.float64] = np.where(has, np.nanmedian(np.where(has[:, :, None], q, 0.0), axis=2), np.nan)
    return out


def _synthesis_score(data: FRFData, model: ModalModel, score: NDArray[np.float64], residuals: bool,
                     basis: LsfdBasis | None = None) -> NDArray[np.float64]:
    """:func:`_median_score` of ``model``'s synthesis error on the lines :func:`_fit` fits (shape (n_out, n_in)).

    ``model`` is a fit of :func:`_fit` on ``data`` (real residual terms): its synthesis is formed as
    :func:`_fit` forms its own, the real basis times the unknowns, chunk by chunk (BLAS).
    """
    f, h = data.freq, data.frf
    sv = np.broadcast_to(score, h.shape)
    p = _FORM_POWER[data.frf_form]
    if residuals and p < 2 and f[0] == 0.0:
        f, h, sv = f[1:], h[:, :, 1:], sv[:, :, 1:]
    if basis is not None and basis.matches(f, model.poles, p, residuals):
        a, scale = basis.a, basis.scale  # the basis of the fit that gave ``model``
    else:
        a, scale = pole_residue_basis(f, model.poles, p, residuals=residuals)
    res = np.moveaxis(model.residues, 0, 2)  # (n_out, n_in, n_modes)
    parts = [res.real, res.imag]
    if residuals:
        parts += [model.lower_residual.real[:, :, None], model.upper_residual.real[:, :, None]]
    xs = np.concatenate(parts, axis=2) * scale  # unknowns of the unit-norm basis
    med = np.empty(h.shape[:2])
    with single_threaded():
        for o0, o1, yv in _output_chunks(h):
            e = rows_times(xs[o0:o1], a.T)
            np.subtract(yv, e, out=e)
            med[o0:o1] = _median_score(e[:, :, 0::2] ** 2 + e[:, :, 1::2] ** 2, sv[o0:o1])
    return med


def _line_weights(variance: NDArray[np.float64], shape: tuple[int, ...], src: str | None) -> NDArray[np.float64]:
    """``1 / sqrt(variance)`` broadcast to ``shape`` (n_out, n_in, n_freq), each channel scaled to a maximum of 1.

    Raises
    ------
    IdentificationError
        NaN or non-positive variances, or a channel without any finite variance.
    """
    var = np.asarray(variance, dtype=np.float64)
    if np.any(np.isnan(var)) or np.any(var <= 0):
        raise IdentificationError("LSFD variance must be > 0 (inf for a line without weight), without NaN",
                                  file=src)
    w = np.broadcast_to(1.0 / np.sqrt(var), shape)
    top = np.max(w, axis=2, keepdims=True)
    if np.any(top <= 0):
        raise IdentificationError("LSFD variance is inf at every line of a channel: nothing to fit", file=src)
    out: NDArray[np.float64] = w / top
    return out


def _common_profile(weights: NDArray[np.float64]) -> NDArray[np.float64] | None:
    """The line profile (2 n_freq,) shared by every channel's weights (each scaled to maximum 1), or None.

    Channels whose weights differ only by a factor have the same profile after the scaling of
    :func:`_line_weights`; the profile is returned for the real rows (Re, Im interleaved per line).
    """
    flat = weights.reshape(-1, weights.shape[-1])
    first = flat[0]
    if flat.shape[0] > 1 and not np.allclose(flat, first[None, :], rtol=1e-12, atol=0.0):
        return None
    return np.repeat(first, 2)


def _weighted_solve(uk: NDArray[np.float64], proj: NDArray[np.float64], yv: NDArray[np.float64],
                    w: NDArray[np.float64]) -> NDArray[np.float64]:
    """Per-channel weighted least squares in the shared basis: the unknowns of ``yv`` (chunk, n_in, 2 n_freq).

    With the basis ``a = uk S V^T`` factored once (:func:`_projector`: ``uk`` orthonormal,
    ``proj = V S^-1``), the unknowns are ``x = proj z`` where ``z`` solves the channel's normal
    equations ``(uk^T W^2 uk) z = uk^T W^2 y`` (``W`` its weights ``w``, same shape as ``yv``),
    then a small symmetric eigen-solve per channel
    (Jacobi-scaled, minimum norm below the rank cutoff of :func:`_projector`). ``uk`` is
    orthonormal, so the normal matrix's condition is at most that of ``W^2`` on the basis's span.
    The normal matrices come from one product of the weights with the lines' outer products
    (more channels than unknowns) or from each channel's weighted basis (fewer).

    Returns
    -------
    ndarray, shape (chunk, n_in, n_unknown)
        Unknowns of the (unweighted) basis.
    """
    n_o, n_i, n_r = yv.shape
    r = uk.shape[1]
    w2 = (w * w).reshape(-1, n_r)
    yc = yv.reshape(-1, n_r)
    n_c = w2.shape[0]
    if n_c > r:
        # many channels: one product of the weights with the lines' outer products (blocks of 32 MB)
        flat = np.zeros((n_c, r * r))
        step = max(1, int((32 << 20) // max(8 * r * r, 1)))
        for k0 in range(0, n_r, step):
            u = uk[k0 : k0 + step]
            flat += w2[:, k0 : k0 + step] @ (u[:, :, None] * u[:, None, :]).reshape(u.shape[0], r * r)
        gram = flat.reshape(n_c, r, r)
    else:
        # few channels: each channel's weighted basis times the basis, one channel at a time in one work array
        # (the same BLAS product per channel as a batched one, whose work array of every channel outgrows the cache)
        gram = np.empty((n_c, r, r))
        ukt = np.ascontiguousarray(uk.T)
        tmp = np.empty_like(ukt)
        for c in range(n_c):
            np.multiply(ukt, w2[c], out=tmp)
            np.matmul(tmp, uk, out=gram[c])
    rhs = (w2 * yc) @ uk  # (channels, r)
    d = np.sqrt(np.maximum(np.einsum("cii->ci", gram), 0.0))
    d = np.where(d > 0, d, 1.0)
    ev, vec = np.linalg.eigh(gram / (d[:, :, None] * d[:, None, :]))
    keep = ev > np.finfo(float).eps * r * ev[:, -1:]
    inv = np.where(keep, 1.0 / np.where(keep, ev, 1.0), 0.0)
    z = np.einsum("crk,ck->cr", vec, inv * np.einsum("crk,cr->ck", vec, rhs / d)) / d
    res: NDArray[np.float64] = (z @ proj.T).reshape(n_o, n_i, proj.shape[0])
    return res


def rows_times(x: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """``x @ b`` as one matrix product of all the rows of ``x`` (one BLAS call).

    ``x @ b`` on a stack of shape (chunk, n_in, k) calls BLAS once per (n_in, k) block of the stack:
    with one reference that is one matrix-vector product per channel.

    Parameters
    ----------
    x : ndarray, shape (..., k)
        Rows (e.g. FRFs as interleaved real pairs, or unknowns per channel).
    b : ndarray, shape (k, m)

    Returns
    -------
    ndarray, shape (..., m)
        Equal to ``x @ b`` to rounding.
    """
    out: NDArray[np.float64] = (np.ascontiguousarray(x).reshape(-1, x.shape[-1]) @ b).reshape(*x.shape[:-1], b.shape[1])
    return out


def _projector(a: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Minimum-norm least-squares solve through the SVD of the small basis, as ``lstsq`` does.

    Returns ``uk`` (2 n_freq, rank) and ``proj`` (n_unknown, rank): the unknowns of data rows
    ``y`` (..., 2 n_freq) are ``(y @ uk) @ proj.T``, and ``proj @ proj.T`` is the
    (pseudo-)inverse of ``a.T @ a`` (the unscaled covariance of the unknowns).
    """
    u, sv, vt = thin_svd(a)  # numpy's SVD, the same numbers
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


__all__ = ["lsfd", "model_order"]
