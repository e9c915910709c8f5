"""Physical-mode judgement: every cluster of stable poles gets a verdict and a reason.

Functions
---------
judge_clusters
    Candidates of a stabilization (clusters of stable poles) judged on stability over the
    orders, damping, duplicates, shape phase (MPC) and their support in the measured FRFs.

Classes
-------
Candidate
    One cluster with its verdict (``accepted``) and the reason.

Notes
-----
Every number below is a field of :class:`~ema_rig.identification.criteria.JudgeCriteria`, with
its source there. A candidate is rejected, in this order, when

1. it is stable at fewer than ``min_poles`` orders, or present at less than
   ``min_persistence`` of the computed orders from its first appearance up (it flickers);
2. its mean damping ratio lies outside ``(0, max_damping]``, or its standard deviation over
   the cluster exceeds ``max_damping_spread`` (half) of the mean;
3. it duplicates a longer-lived cluster (frequencies within three standard deviations and
   participation MAC above 0.9, or shapes MAC above 0.95 and less than a tenth of a half-power
   bandwidth apart);
4. it lies inside the half-power bandwidth ``2 zeta f`` of a stronger candidate while its shape
   is far less monophase (MPC below ``split_mpc`` and at least 0.3 below the neighbour's): a
   pole that splits a mode -- unless it is well founded on its own (stable at 80 % of its
   orders, damping stable to 20 %, F at least a tenth of the neighbour's);
5. removing it from the LSFD fit does not worsen the fit: the F statistic of its two real
   parameters per channel, ``dRSS / (2 n_chan) / sigma^2``, is below the F test threshold
   ``F.isf(support_p / n_candidates, 2 n_chan, dof)`` (:meth:`JudgeCriteria.support_threshold
   <ema_rig.identification.criteria.JudgeCriteria.support_threshold>`, p = 0.001 family-wise,
   Bonferroni over the candidates judged together; a fixed ``min_support`` when given). ``sigma^2``
   is the residual per real number over the lines within two half-power bandwidths (at least
   five lines) of the candidate: the noise where the candidate acts, with
   ``dof = 2 n_lines n_chan - 2 n_chan - 2``;
6. its own term of the fit is less than ``min_peak_share`` (5 %) of the measured FRFs within
   its half-power bandwidth (``peak_share``): it makes no peak;
7. with three or more response (or reference) DOFs, its shape has no common phase (MPC below
   ``min_mpc``, 0.25: the noise columns of a measurement; unless well founded as in rule 4 with
   F at least ten times the threshold), or it is far from monophase (MPC
   below ``split_mpc``) and its evidence is weak (F below four times the threshold or peak share below
   30 %) and it is not well founded otherwise (as in rule 4, F at least ten times the threshold). Physical modes of a lightly damped structure are nearly monophase; the dam's
   most complex accepted shapes have MPC 0.34-0.45.

The MPC is computed on the residues along the longer axis of the measurement (outputs for a
classical test, references for a roving hammer), from the row or column that carries the
mode most strongly; for a single-channel measurement it is 1 by construction and rule 4 cannot
apply.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from .._blas import single_threaded
from ..frf import FORM_POWER as _FORM_POWER
from ..frf import FRFData
from .criteria import JUDGE_CRITERIA, JudgeCriteria
from .lsfd import LsfdBasis, _output_chunks, _projector, rows_times
from .mac import mac, mpc
from .modal import pole_residue_basis
from .stabilization import (
    SelectedMode,
    StabilizationData,
    _modes_from_rows,
    cluster_poles,
    order_ranks,
)


@dataclass(frozen=True, slots=True)
class Candidate:
    """One cluster of stable poles and its verdict.

    Parameters
    ----------
    mode : SelectedMode
        The cluster as a mode (mean frequency and damping, spread, representative pole,
        ``order_min`` .. ``order_max``).
    accepted : bool
        True when judged a physical mode.
    reason : str
        Why (one line).
    mpc : float
        MPC of the candidate's shape (NaN when not fitted).
    support : float
        F statistic of the candidate in the LSFD fit (NaN when not fitted).
    persistence : float
        Fraction of the computed orders from ``order_min`` up at which the cluster has a pole.
    peak_share : float
        ``||H_k|| / ||H||`` near the candidate's frequency (its own term of the fit against
        the measured FRFs; NaN when not fitted).
    """

    mode: SelectedMode
    accepted: bool
    reason: str
    mpc: float = float("nan")
    support: float = float("nan")
    persistence: float = float("nan")
    peak_share: float = float("nan")

    @property
    def natural_freq(self) -> float:
        """Mean natural frequency of the cluster [Hz]."""
        return self.mode.natural_freq

    @property
    def damping_ratio(self) -> float:
        """Mean damping ratio of the cluster."""
        return self.mode.damping_ratio

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dict: the mode's fields plus ``verdict``, ``reason``, ``mpc``, ``support``."""
        d = self.mode.to_dict()

        def num(x: float) -> float | None:
            return float(x) if np.isfinite(x) else None

        d.update({"verdict": "accepted" if self.accepted else "rejected", "reason": self.reason,
                  "mpc": num(self.mpc), "support": num(self.support), "persistence": num(self.persistence),
                  "peak_share": num(self.peak_share)})
        return d


def _fit(data: FRFData, poles: NDArray[np.complex128], basis_out: list[LsfdBasis] | None = None
         ) -> tuple[NDArray[Any], NDArray[Any], NDArray[Any], NDArray[Any]]:
    """Residues (n_modes, n_out, n_in), the F statistic, the peak share and the residual dof of every mode.

    The peak share is ``||H_k|| / ||H||`` over the lines within one half-power bandwidth (at
    least two lines each side) of mode ``k``, ``H_k`` its own term of the fit: about 1 for a
    mode that makes its peak, small for a pole in a trough or under a stronger mode.

    The increase of the residual sum of squares when mode ``k``'s two real parameters are
    dropped is ``x_K^T (C_KK)^-1 x_K`` per channel, ``C = (A^T A)^-1`` (no refit needed).

    The fit is :func:`~ema_rig.identification.lsfd.lsfd`'s (same basis with residual terms,
    same minimum-norm solve), run over chunks of outputs; only per-line sums (residual and
    ``|H|^2``, summed over channels) and each mode's term energy near its peak are kept, so
    the work arrays stay a fraction of the data. Call it on one BLAS thread. With ``basis_out`` (a list)
    the fit's basis and factor are appended to it (:class:`~ema_rig.identification.lsfd.LsfdBasis`: an LSFD
    at the same poles, in the same order, on the same lines takes them over, and an unweighted one of the same
    FRFs the unknowns: the same numbers).
    """
    n = poles.size
    p = _FORM_POWER[data.frf_form]
    f, h = data.freq, data.frf
    if p < 2 and f[0] == 0.0:
        f, h = f[1:], h[:, :, 1:]
    n_f = f.size
    n_out, n_in = h.shape[:2]
    n_chan = n_out * n_in
    a, scale = pole_residue_basis(f, poles, p, residuals=True)
    n_unk = a.shape[1]
    df = float(np.median(np.diff(f))) if n_f > 1 else 1.0
    # rows of `a` (Re, Im interleaved) on the lines within one half-power bandwidth of each mode
    near_rows = []
    for lam in poles:
        fk = abs(lam) / (2 * np.pi)
        near = np.abs(f - fk) <= max(-lam.real / (2 * np.pi), 2 * df)
        if not near.any():
            near = np.abs(f - fk) <= np.min(np.abs(f - fk))
        idx = np.flatnonzero(near)
        near_rows.append(np.stack([2 * idx, 2 * idx + 1], axis=1).ravel())
    x = np.empty((n_out, n_in, n_unk))
    line = np.zeros(n_f)  # residual |e|^2 per line, summed over channels
    y2 = np.zeros(n_f)  # |H|^2 per line, summed over channels
    t2 = np.zeros(n)  # energy of each mode's own term on its near lines, all channels
    uk, proj = _projector(a)
    for o0, o1, yv in _output_chunks(h):
        xs = rows_times(rows_times(yv, uk), proj.T)  # scaled unknowns (chunk, n_in, n_unk)
        x[o0:o1] = xs
        e = rows_times(xs, a.T)
        np.subtract(yv, e, out=e)
        # per line, summed over the channels: the squares of each real row summed over the channels first (the
        # rows contiguous: one pass, where the sum over (channel, Re/Im) per line ran an inner loop of two)
        e2 = e.reshape(-1, 2 * n_f)
        line += np.einsum("cj,cj->j", e2, e2).reshape(n_f, 2).sum(axis=1)
        del e, e2
        y = yv.reshape(-1, 2 * n_f)
        y2 += np.einsum("cj,cj->j", y, y).reshape(n_f, 2).sum(axis=1)
        for k, rows in enumerate(near_rows):
            kk = np.array([k, n + k])
            term = xs[:, :, kk] @ a[rows][:, kk].T  # (chunk, n_in, rows)
            t2[k] += float(np.einsum("oir,oir->", term, term))
        del xs, yv, y
    floor = 1e-14 * float(y2.sum()) / max(2 * n_f * n_chan, 1)
    sigma2 = np.empty(n)
    share = np.empty(n)
    dof = np.empty(n)
    for k, lam in enumerate(poles):
        # noise level near each mode: residual per real number over the lines within two
        # half-power bandwidths (at least 5 lines each side), so junk far away cannot mask it
        fk = abs(lam) / (2 * np.pi)
        win = np.abs(f - fk) <= max(-2.0 * lam.real / (2 * np.pi), 5 * df)
        sigma2[k] = max(float(line[win].mean() if win.any() else line.mean()) / (2 * n_chan), floor)
        # real equations of the noise estimate minus the candidate's parameters (2 per channel + pole)
        dof[k] = max(2.0 * (int(win.sum()) if win.any() else n_f) * n_chan - 2 * n_chan - 2, 1.0)
        rows = near_rows[k][0::2] // 2
        share[k] = float(np.sqrt(t2[k] / max(float(y2[rows].sum()), floor)))
    cov = proj @ proj.T  # (A^T A)^-1 of the scaled basis
    ks = np.arange(n)
    blk = np.empty((n, 2, 2))
    blk[:, 0, 0], blk[:, 0, 1] = cov[ks, ks], cov[ks, n + ks]
    blk[:, 1, 0], blk[:, 1, 1] = cov[n + ks, ks], cov[n + ks, n + ks]
    xc = x.reshape(n_chan, n_unk).T  # (n_unk, n_chan)
    xk = np.stack([xc[:n], xc[n : 2 * n]], axis=1)  # (n, 2, n_chan)
    d_rss = np.einsum("kic,kic->k", xk, np.linalg.solve(blk, xk))
    support = np.maximum(d_rss, 0.0) / (2 * n_chan) / sigma2
    if basis_out is not None:
        # the unknowns of the unit-norm basis too: an unweighted LSFD of the same FRFs takes them over
        basis_out.append(LsfdBasis(f, poles, p, True, a, scale, uk, proj, x.copy(), data.frf))
    x /= scale
    res = x[:, :, :n] + 1j * x[:, :, n : 2 * n]
    return np.moveaxis(res, 2, 0), support, share, dof


def shape_mpc(residues: NDArray[np.complex128]) -> NDArray[np.float64]:
    """MPC of each mode along the longer axis of the residues (n_modes, n_out, n_in) -> (n_modes,).

    The shape is the residue column (outputs) of the strongest reference, or, when there are
    more references than outputs, the residue row (references) of the strongest output.
    """
    res = np.asarray(residues)
    if res.shape[2] > res.shape[1]:
        res = np.swapaxes(res, 1, 2)
    strongest = np.argmax(np.linalg.norm(res, axis=1), axis=1)  # (n_modes,)
    shapes = res[np.arange(res.shape[0]), :, strongest]
    return mpc(shapes)


def judge_clusters(
    stab: StabilizationData,
    data: FRFData,
    *,
    min_poles: int | None = None,
    min_persistence: float | None = None,
    max_damping: float | None = None,
    min_support: float | None = None,
    split_mpc: float | None = None,
    min_peak_share: float | None = None,
    min_mpc: float | None = None,
    max_damping_spread: float | None = None,
    fit: bool = True,
    clusters: list[NDArray[np.intp]] | None = None,
    criteria: JudgeCriteria | None = None,
    basis_out: list[LsfdBasis] | None = None,
) -> tuple[Candidate, ...]:
    """Judge every cluster of stable poles of ``stab`` against the data ``data``.

    Parameters
    ----------
    stab : StabilizationData
        Stabilization of the pLSCF estimate (its participation vectors belong to the layout
        the poles were estimated on, which may be the transposed one).
    data : FRFData
        The measured FRFs in the band (original layout), used for the LSFD-based rules.
    min_poles, min_persistence, max_damping, min_support, split_mpc, min_peak_share, min_mpc, \
    max_damping_spread : optional
        Thresholds of the rules in the module notes; each one given replaces the field of the same
        name of ``criteria``. ``min_support`` given makes the support a fixed F threshold instead
        of the F test of :meth:`~ema_rig.identification.criteria.JudgeCriteria.support_threshold`.
    fit : bool, optional
        Apply the LSFD-based rules 4-7 (default True); False judges on stability,
        damping and participation duplicates only (rules 1-3).
    clusters : list of ndarray, optional
        Rows of ``stab`` per cluster (default :func:`~ema_rig.identification.stabilization.cluster_poles`).
    criteria : JudgeCriteria, optional
        Every threshold with its source (default :data:`~ema_rig.identification.criteria.JUDGE_CRITERIA`).
    basis_out : list, optional
        Receives the basis and factor of the last LSFD fit of the rules 4-7
        (:class:`~ema_rig.identification.lsfd.LsfdBasis`, poles in the order of the candidates; nothing
        without a fit): when those poles are the accepted modes', the LSFD at them takes it over.

    Returns
    -------
    tuple of Candidate
        Sorted by frequency; ``accepted`` ones are the physical modes.
    """
    crit = JUDGE_CRITERIA if criteria is None else criteria
    if not isinstance(crit, JudgeCriteria):
        raise TypeError(f"criteria must be a JudgeCriteria, got {type(crit).__name__}")
    given = {k: v for k, v in (("min_poles", min_poles), ("min_persistence", min_persistence),
                               ("max_damping", max_damping), ("min_support", min_support),
                               ("split_mpc", split_mpc), ("min_peak_share", min_peak_share),
                               ("min_mpc", min_mpc), ("max_damping_spread", max_damping_spread)) if v is not None}
    if given:
        crit = replace(crit, **given)  # type: ignore[arg-type]
    min_poles, min_persistence, max_damping = crit.min_poles, crit.min_persistence, crit.max_damping
    split_mpc, min_peak_share, min_mpc = crit.split_mpc, crit.min_peak_share, crit.min_mpc
    max_damping_spread = crit.max_damping_spread
    n_chan = data.n_out * data.n_in
    orders = np.asarray(stab.orders)
    if clusters is None:
        clusters = cluster_poles(stab, max_damping=max_damping)
    ranks = order_ranks(stab)
    modes = _modes_from_rows(stab, clusters, "auto", ranks)
    verdict: list[str | None] = [None] * len(modes)
    persistence = np.full(len(modes), np.nan)
    lo, hi = stab.band
    for i, m in enumerate(modes):
        span = int(np.sum(orders >= m.order_min))
        persistence[i] = m.n_poles / max(span, 1)
        if m.n_poles < min_poles:
            verdict[i] = f"stable at only {m.n_poles} orders (need {min_poles})"
        elif persistence[i] < min_persistence:
            verdict[i] = (f"intermittent: present at {m.n_poles} of the {span} orders from "
                          f"{m.order_min} up")
        elif not 0 < m.damping_ratio <= max_damping:
            verdict[i] = f"implausible damping ratio {m.damping_ratio:.3g}"
        elif m.damping_ratio_std > max_damping_spread * m.damping_ratio:
            verdict[i] = (f"damping not stable over the orders ({100 * m.damping_ratio:.2g} +/- "
                          f"{100 * m.damping_ratio_std:.2g} %)")
        elif not lo <= m.natural_freq <= hi:
            verdict[i] = "outside the band"
    # duplicates by participation: same frequency within the spread, same participation
    alive = [i for i in range(len(modes)) if verdict[i] is None]
    for a_i, i in enumerate(alive):
        for j in alive[a_i + 1 :]:
            if verdict[i] is not None or verdict[j] is not None:
                continue
            mi, mj = modes[i], modes[j]
            close = abs(mi.natural_freq - mj.natural_freq) <= 3 * (mi.natural_freq_std + mj.natural_freq_std)
            if close and float(mac(np.array(mi.participation), np.array(mj.participation))[0, 0]) > crit.dup_participation_mac:
                weak, strong = (j, i) if mi.n_poles >= mj.n_poles else (i, j)
                verdict[weak] = f"duplicate of {modes[strong].natural_freq:.6g} Hz"
    mpcs = np.full(len(modes), np.nan)
    support = np.full(len(modes), np.nan)
    peak = np.full(len(modes), np.nan)
    last: list[LsfdBasis] = []  # the basis of the last fit
    for _ in range(4 if fit else 0):
        alive = [i for i in range(len(modes)) if verdict[i] is None]
        if not alive:
            break
        poles = np.array([modes[i].pole for i in alive])
        last.clear()
        with single_threaded():
            res, sup, shr, dof = _fit(data, poles, last if basis_out is not None else None)
        need = np.asarray(crit.support_threshold(n_chan, dof, len(alive)), dtype=float)
        mp = shape_mpc(res)
        mpcs[alive] = mp
        support[alive] = sup
        peak[alive] = shr
        new = False
        # duplicates by shape, splits by shape phase, then support
        shapes = _shapes(res)
        for a_i, i in enumerate(alive):
            for b_i, j in enumerate(alive):
                if i == j or verdict[i] is not None or verdict[j] is not None:
                    continue
                fi, fj = modes[i].natural_freq, modes[j].natural_freq
                bw = 2 * max(modes[j].damping_ratio, 1e-4) * fj
                stronger = sup[b_i] > sup[a_i]
                if not stronger or abs(fi - fj) > bw:
                    continue
                if abs(fi - fj) < 0.1 * bw and float(mac(shapes[a_i], shapes[b_i])[0, 0]) > crit.dup_shape_mac:
                    verdict[i] = f"duplicate of {fj:.6g} Hz (shape MAC > {crit.dup_shape_mac:g})"
                    new = True
                elif (mp[a_i] < split_mpc and mp[a_i] < mp[b_i] - crit.mpc_gap
                      and not _well_founded(modes[i], persistence[i], sup[a_i],
                                            crit.founded_support_ratio * sup[b_i], crit)):
                    verdict[i] = f"splits the {fj:.6g} Hz mode (MPC {mp[a_i]:.2f} against {mp[b_i]:.2f})"
                    new = True
        n_dof = max(data.n_out, data.n_in)
        for a_i, i in enumerate(alive):
            if verdict[i] is not None:
                continue
            if sup[a_i] < need[a_i]:
                verdict[i] = (f"negligible contribution to the fit (F = {sup[a_i]:.3g} < {need[a_i]:.3g}"
                              + (")" if crit.min_support is not None else
                                 f", F test p = {crit.support_p:g}/{len(alive)} with {2 * n_chan}, "
                                 f"{dof[a_i]:.0f} dof)"))
                new = True
            elif shr[a_i] < min_peak_share:
                verdict[i] = (f"no peak of its own: {100 * shr[a_i]:.0f} % of the FRF near {modes[i].natural_freq:.5g} Hz "
                              f"(< {100 * min_peak_share:g} %)")
                new = True
            elif n_dof >= 3 and mp[a_i] < min_mpc and not _well_founded(
                    modes[i], persistence[i], sup[a_i], crit.strong_support_factor * need[a_i], crit):
                verdict[i] = f"shape without a common phase (MPC {mp[a_i]:.2f} < {min_mpc:g})"
                new = True
            elif (n_dof >= 3 and mp[a_i] < split_mpc
                  and (sup[a_i] < crit.weak_support_factor * need[a_i] or shr[a_i] < crit.weak_peak_share)
                  and not _well_founded(modes[i], persistence[i], sup[a_i],
                                        crit.strong_support_factor * need[a_i], crit)):
                verdict[i] = (f"weak (F = {sup[a_i]:.3g}, {100 * shr[a_i]:.0f} % of the FRF near it) with a shape "
                              f"far from monophase (MPC {mp[a_i]:.2f} < {split_mpc:g})")
                new = True
        if not new:
            break
    out = []
    for i, m in enumerate(modes):
        v = verdict[i]
        out.append(Candidate(mode=m, accepted=v is None, reason=v or "physical", mpc=float(mpcs[i]),
                             support=float(support[i]), persistence=float(persistence[i]),
                             peak_share=float(peak[i])))
    if basis_out is not None:
        basis_out.extend(last)
    return tuple(out)


def _well_founded(m: SelectedMode, persistence: float, support: float, need: float,
                  crit: JudgeCriteria = JUDGE_CRITERIA) -> bool:
    """A candidate whose other evidence outweighs a poor shape phase.

    Stable at 80 % of the orders from its first appearance up (a split or noise pole flickers),
    with damping stable to 20 % and an F statistic of at least ``need``: closely spaced,
    heavily overlapping modes can have residues whose phase LSFD cannot separate cleanly.
    """
    return (persistence >= crit.founded_persistence
            and m.damping_ratio_std <= crit.founded_damping_spread * m.damping_ratio and support >= need)


def _shapes(res: NDArray[np.complex128]) -> NDArray[np.complex128]:
    """All residues of each mode flattened to one vector, (n_modes, n_out * n_in)."""
    return res.reshape(res.shape[0], -1)


__all__ = ["Candidate", "judge_clusters", "shape_mpc"]
