"""The thresholds of each identification stage, one frozen object per stage, each with its source.

Classes
-------
IdentificationCriteria
    The three below, for :func:`~ema_rig.identification.identification.identify` (``criteria=``).
StabilizationCriteria
    Tolerances of the status letters of the stabilization chart.
JudgeCriteria
    Rules of the physical-mode judgement of :func:`~ema_rig.identification.judge.judge_clusters`,
    the support of a candidate as an F test with its degrees of freedom.
ResultCriteria
    When the final model is warned about (poor fit, a mode at the band edge).
CompletenessCriteria
    When the mode set of :func:`~ema_rig.identification.identification.identify` is complete:
    a chi-square test of the residual against the noise estimate per band segment and channel.

Every field carries its source in ``dataclasses.fields(...)[i].metadata["source"]`` (and
:meth:`sources` returns them by name): a p-value with its degrees of freedom, the paper
(``/work/shared/paper.md``: PolyMAX and its stabilization tolerances), a textbook, or the named
data set a value was checked on. Nothing here was tuned until a grid passed.

References
----------
Peeters, Van der Auweraer, Guillaume, Leuridan, "The PolyMAX frequency-domain method: a new
standard for modal parameter estimation?", Shock and Vibration 11 (2004): stabilization
tolerances 1 % (frequency), 5 % (damping), 2 % (vector).
Bendat & Piersol, *Random Data*, 4th ed. 2010, ch. 9 (variance of H1 estimates).
Pintelon & Schoukens, *System Identification*, 2nd ed. 2012, ch. 19 (cost function at the
minimum is chi-square with N - P degrees of freedom; model-error detection).
Allemang, "The modal assurance criterion - twenty years of use and abuse", Sound and Vibration
37 (2003) (MAC above 0.9 for the same vector; MPC of a real mode near 1).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from types import MappingProxyType
from typing import Any


def _src(default: Any, source: str) -> Any:
    return field(default=default, metadata={"source": source})


class _Sourced:
    """Mixin: the source of every field by name."""

    __slots__ = ()

    def sources(self) -> dict[str, str]:
        """The source of every threshold, by field name."""
        return {f.name: str(f.metadata.get("source", "")) for f in fields(self)}  # type: ignore[arg-type]


@dataclass(frozen=True, slots=True)
class StabilizationCriteria(_Sourced):
    """Tolerances of the stabilization letters (:func:`~ema_rig.identification.stabilization.stabilize`).

    Parameters
    ----------
    freq_tol : float
        Relative change of natural frequency between two orders for ``f`` (default 0.01).
    damping_tol : float
        Relative change of damping ratio for ``d`` (default 0.05).
    mac_tol : float
        ``1 - MAC`` of the participation vectors for ``v`` (default 0.02).
    cluster_freq_tol, cluster_damping_tol, cluster_mac_tol : float
        Scales of the distance between two stable poles when they are clustered into modes
        (:func:`~ema_rig.identification.stabilization.cluster_poles`: average linkage cut at
        distance 1): relative frequency difference (0.005), relative damping difference (0.5),
        ``1 - MAC`` of the participation vectors (0.1).
    noise_only_p : float
        An output whose FRFs' phase jumps (more than 90 degrees between neighbouring lines,
        :func:`~ema_rig.identification.diagnose.noise_only_outputs`) are not significantly fewer than
        pure noise gives (one-sided binomial test against 1/2 on each chain of lines one window kernel
        apart, :data:`WINDOW_KERNEL_LINES`; p / chains above this, 0.001) carries no measurable
        response: the poles are estimated without it (a dead or disconnected sensor; PolyMAX weights
        each output by ``1 / rms``, so its noise would weigh as much as another output's resonances).
    noisier_output : float
        With coherence, an output whose relative noise ``mean(var) / mean(|H|^2)`` (the noise power it
        adds to PolyMAX's ``1 / rms``-weighted cost) exceeds this factor (1) times the break-even
        ``(2 n - 1) / (n - 1)`` times the mean of the other ``n - 1`` outputs' is left out of the pole
        estimation, the noisiest first, one at a time (:func:`~ema_rig.identification.diagnose.noisier_outputs`).
    """

    freq_tol: float = _src(0.01, "PolyMAX standard tolerance 1 % (Peeters et al. 2004; paper.md, stabilization)")
    damping_tol: float = _src(0.05, "PolyMAX standard tolerance 5 % (Peeters et al. 2004; paper.md)")
    mac_tol: float = _src(0.02, "PolyMAX standard tolerance 2 % on 1 - MAC (Peeters et al. 2004; paper.md)")
    cluster_freq_tol: float = _src(0.005, "half the stabilization tolerance freq_tol (1 %, Peeters et al. 2004): "
                                   "the poles of one mode agree within it between orders, and two modes 1 % "
                                   "apart (issue 18, a close pair) are two linkage distances apart")
    cluster_damping_tol: float = _src(0.5, "JudgeCriteria.max_damping_spread (0.5): the damping of one mode's poles "
                                      "may scatter that much across orders, so the linkage must not split it there")
    cluster_mac_tol: float = _src(0.1, "1 - MAC 0.1: MAC above 0.9 is the same vector (Allemang 2003; "
                                  "JudgeCriteria.dup_participation_mac)")
    noise_only_p: float = _src(0.001, "one-sided binomial test per chain of lines one window kernel apart "
                               "(WINDOW_KERNEL_LINES), Bonferroni over the chains, p = 0.001: the phases of circular "
                               "complex noise on lines that far apart are independent and uniform, so their "
                               "increments are too and each exceeds 90 degrees with probability 1/2 exactly "
                               "(a signal lowers it)")
    noisier_output: float = _src(1.0, "the break-even itself (factor 1): the variance of an equally weighted mean of n "
                                 "estimates, sum(v_i) / n^2, rises by adding one of variance above (2n - 1) / (n - 1) "
                                 "times the others' mean (PolyMAX's 1 / rms weights average the outputs' equations "
                                 "equally; inverse-variance weighting, Bendat & Piersol ch. 9 variances)")

    def as_kwargs(self) -> dict[str, float]:
        """``freq_tol``, ``damping_tol``, ``mac_tol`` for :func:`stabilize`."""
        return {"freq_tol": self.freq_tol, "damping_tol": self.damping_tol, "mac_tol": self.mac_tol}

    def cluster_scales(self, freq_tol: float | None = None, damping_tol: float | None = None,
                       mac_tol: float | None = None) -> tuple[float, float, float]:
        """The clustering scales (frequency, damping, ``1 - MAC``): each given value, else its ``cluster_*`` field."""
        return (self.cluster_freq_tol if freq_tol is None else freq_tol,
                self.cluster_damping_tol if damping_tol is None else damping_tol,
                self.cluster_mac_tol if mac_tol is None else mac_tol)


@dataclass(frozen=True, slots=True)
class JudgeCriteria(_Sourced):
    """Rules of :func:`~ema_rig.identification.judge.judge_clusters` (numbers in its module notes).

    Parameters
    ----------
    min_poles : int
        Orders a cluster must be stable at (default 4).
    min_persistence : float
        Share of the computed orders from its first appearance up (default 0.5).
    max_damping : float
        Largest damping ratio of a mode (default 0.2).
    max_damping_spread : float
        Largest standard deviation of the damping over the cluster, relative (default 0.5).
    support_p : float
        Family-wise level of the F test of a candidate's support (default 0.001): the candidate is
        kept when its F statistic exceeds ``F.isf(support_p / n_candidates, 2 n_chan, dof_resid)``
        (Bonferroni over the candidates judged together: the pole of a noise cluster was placed
        where it fits best, so each candidate is one look). ``2 n_chan`` residue parameters (the
        statistic's numerator); ``dof_resid = 2 n_lines n_chan - 2 n_chan - 2`` on the lines of the
        noise estimate (two half-power bandwidths, at least 5 lines each side).
    min_support : float or None
        A fixed F threshold instead of the test (default None: the F quantile above). Kept for the
        old keyword argument ``judge_clusters(min_support=...)``.
    split_mpc : float
        MPC below which a candidate inside a stronger one's half-power band splits it (0.5).
    mpc_gap : float
        ... and at least this much below the neighbour's MPC (0.3).
    min_peak_share : float
        Share of the measured FRF near the candidate its own term must carry (0.05).
    min_mpc : float
        MPC below which a shape has no common phase (0.25).
    dup_participation_mac : float
        Participation MAC above which two clusters within three standard deviations are one (0.9).
    dup_shape_mac : float
        Shape MAC above which two candidates a tenth of a half-power band apart are one (0.95).
    founded_persistence, founded_damping_spread, founded_support_ratio : float
        A candidate with a poor shape phase is "well founded" when stable at this share of its
        orders (0.8), its damping stable to this fraction (0.2), and F at least this fraction of its
        stronger neighbour's (0.1).
    strong_support_factor, weak_support_factor, weak_peak_share : float
        "Well founded" against rule 7 needs F at least ``strong_support_factor`` times the threshold
        (10); "weak" evidence is F below ``weak_support_factor`` times it (4) or a peak share below
        ``weak_peak_share`` (0.3).
    """

    min_poles: int = _src(4, "a cluster at 4 orders spans a full growth step (orders step 2, span n/4 >= 8)")
    min_persistence: float = _src(0.5, "a physical pole is present at most orders; noise poles flicker "
                                  "(dam0, vt_case1: physical >= 0.7, rejected <= 0.4)")
    max_damping: float = _src(0.2, "structural damping of test rigs < 20 % (issue 18 time truths up to 8 %)")
    max_damping_spread: float = _src(0.5, "a physical pole's damping is stable to 5 % per order "
                                     "(PolyMAX tolerance, Peeters et al. 2004); 50 % over the cluster")
    support_p: float = _src(1e-3, "F test p = 0.001 family-wise (Bonferroni over the candidates), "
                            "dof (2 n_chan, 2 n_lines n_chan - 2 n_chan - 2)")
    min_support: float | None = _src(None, "None: the F quantile of support_p; a number: a fixed F (old API)")
    split_mpc: float = _src(0.5, "MPC of a real mode is near 1 (Allemang 2003); 0.5 halfway to a random phase")
    mpc_gap: float = _src(0.3, "an MPC 0.3 below the neighbour's: outside the spread of physical modes on dam0")
    min_peak_share: float = _src(0.05, "a mode whose own term is 5 % of the FRF is below the 2-10 % noise of "
                                 "the bundled simulator: no peak of its own")
    min_mpc: float = _src(0.25, "random residue phases of n_dof >= 3 give MPC ~ 1/n_dof; dam0's most "
                          "complex accepted shapes have MPC 0.34-0.45 (data set dam0)")
    dup_participation_mac: float = _src(0.9, "MAC above 0.9: the same vector (Allemang 2003)")
    dup_shape_mac: float = _src(0.95, "MAC above 0.95: the same shape within 2 % noise (Allemang 2003)")
    founded_persistence: float = _src(0.8, "stable at 80 % of its orders: a physical pole (dam0, vt_case1)")
    founded_damping_spread: float = _src(0.2, "damping stable to 20 %: four PolyMAX tolerances of 5 %")
    founded_support_ratio: float = _src(0.1, "F a tenth of the neighbour's: one order of magnitude")
    strong_support_factor: float = _src(10.0, "F ten times the test threshold: one order of magnitude")
    weak_support_factor: float = _src(4.0, "F below four times the threshold: within a factor 2 in amplitude")
    weak_peak_share: float = _src(0.3, "own term below 30 % of the FRF: the half-power level is 71 %")

    def support_threshold(self, n_chan: int, dof_resid: Any, n_looks: int = 1) -> Any:
        """F threshold of a candidate's support: ``F.isf(support_p / n_looks, 2 n_chan, dof_resid)``.

        Parameters
        ----------
        n_chan : int
            Channels (outputs x references) of the fit.
        dof_resid : float or ndarray
            Degrees of freedom of the noise estimate (real equations minus parameters), one per
            candidate.
        n_looks : int, optional
            Candidates tested together (Bonferroni).

        Returns
        -------
        float or ndarray
            Same shape as ``dof_resid``; ``min_support`` when it is set.
        """
        import numpy as np

        dof = np.maximum(np.asarray(dof_resid, dtype=float), 1.0)
        if self.min_support is not None:
            out = np.full(dof.shape, float(self.min_support))
        else:
            from scipy.stats import f as f_dist

            out = np.asarray(f_dist.isf(self.support_p / max(int(n_looks), 1), 2 * n_chan, dof), dtype=float)
        return float(out) if out.ndim == 0 else out


@dataclass(frozen=True, slots=True)
class MLCriteria:
    """Thresholds of the default ML stage, each with its source.

    Parameters
    ----------
    window_hbw : float
        Half-width of each mode's line window in half-power half-bandwidths (default 4): the
        lines within ``+-k`` half-bandwidths carry ``(k/(1+k^2) + atan k) / (pi/2)`` of a single
        mode's Fisher information on its pole under white noise, 99.4 % for ``k = 4``.
    min_side_lines : int
        Lines on each side of a mode at least (default 12), so that a mode lighter than the line
        spacing keeps enough equations for its residues and the local polynomial.
    block_lines : int
        Adjacent lines summed into one score of the sandwich covariance (default 4): the main
        lobe of the Hann window spans 4 lines (Harris 1978), so errors of lines closer than
        that are correlated by leakage. The least block length: see ``block_from_scores``.
    block_from_scores : bool
        The block length of the sandwich chosen from the segment's own line scores (default True):
        Andrews' (Econometrica 59, 1991, eq. 6.4) AR(1) plug-in bandwidth of the Bartlett kernel,
        ``1.1447 (alpha(1) n)^(1/3)``, at least ``block_lines``, and the meat formed from all
        overlapping blocks of that length (overlapping batch means, Meketon & Schmeiser 1984, the
        Bartlett kernel's twin). Where the residual is white the bandwidth stays near the window's
        main lobe; where a model error correlates it over many lines (a missing mode, leakage of a
        mode the segment does not fit) the blocks grow with it, and so does the sigma.
    max_iter : int
        Work limit: Levenberg-Marquardt evaluations per segment (default 400).
    misfit_p, misfit_ratio : float
        A segment whose leverage-corrected residual exceeds the noise estimate in a chi-square test
        at ``p < misfit_p`` (default 0.001, dof = its real equations) and by at least
        ``misfit_ratio`` (default 2, the rule of :func:`~ema_rig.identification.refine.refine` for a
        residual above the stated noise) is reported as a local misfit.
    basis_rcond : float
        Numerical rank of a segment's pole-free columns (local polynomial and the other modes'
        tails): singular directions below ``basis_rcond`` times the largest are dropped (default
        1.5e-8 = sqrt of the float64 epsilon). A singular vector is determined only to an angle of
        about ``eps / gap`` (Golub & Van Loan 2013, sect. 5.4.1 and 8.6): below sqrt(eps) its
        direction, and so the projection of the data, is set by rounding, not by the data. Of the
        directions above it, those along which the start model stays below the noise are dropped
        too (:meth:`_Segment.keep_supported`: truncated SVD at the discrepancy level).
    background_sigmas : float
        ... that is, below ``background_sigmas`` (default 1) noise standard deviations in every
        channel: a term whose squared coefficient is below its variance adds more variance than it
        removes bias (the break-even of Mallows' Cp, Technometrics 15, 1973; the discrepancy
        principle, Hansen 1998 sect. 7.2).
    move_hbw : float
        A pole may move by this many PolyMAX half-power half-bandwidths, or two line spacings
        (default 1): further means it left for another feature of the data (the same rule as
        :func:`~ema_rig.identification.refine.refine`).
    lm_rtol : float
        Levenberg-Marquardt has converged when an accepted step lowers the cost by at most this
        fraction of it (default 1e-12, a few thousand float epsilons of the cost).
    lm_pred_rtol : float
        ... or when the Gauss-Newton model predicts at most this fraction for the next step
        (default 1e-15, ~5 float epsilons: the cost's own rounding, so the evaluation could not
        tell the step from rounding; the predicted reduction of Dennis & Schnabel 1996, sect. 6.4).
    lm_offset : float
        ... or when the relative offset of the residual, ``sqrt((pred / P) / (cost / (N - P_all)))``
        with ``pred`` the Gauss-Newton predicted reduction (the squared projection of the residual on
        the tangent plane of the ``P`` free pole parameters) and ``N - P_all`` the residual degrees of
        freedom, is at most this (default 0.001, Bates & Watts, Technometrics 23, 1981): the distance
        left to the minimum is then below ``sqrt(P) lm_offset`` standard deviations of the estimate
        (0.007 for 50 parameters), where the iterations would only crawl along directions the data
        barely determine.
    lm_step_sigma : float
        ... or when the next (Gauss-Newton) step moves every free parameter by at most this many of its
        standard deviations ``sqrt(s^2 (J^T J)^-1_ii)`` (``s^2`` the cost over its residual degrees of
        freedom; default 0.05, 0 switches the test off): iterating further changes the estimate by a
        small fraction of its standard error, which is statistically meaningless (Press et al.,
        *Numerical Recipes*, 3rd ed. 2007, sect. 15.5.2: stop once chi-square changes by much less than
        1; a move of ``delta`` changes it by ``delta^T F delta``, F the Fisher information, in total
        chi-square units).
    """

    window_hbw: float = 4.0
    min_side_lines: int = 12
    block_lines: int = 4
    block_from_scores: bool = True
    max_iter: int = 400
    move_hbw: float = 1.0
    misfit_p: float = 1e-3
    misfit_ratio: float = 2.0
    basis_rcond: float = 1.4901161193847656e-08
    background_sigmas: float = 1.0
    lm_rtol: float = 1e-12
    lm_pred_rtol: float = 1e-15
    lm_offset: float = 1e-3
    lm_step_sigma: float = 0.05

    def sources(self) -> dict[str, str]:
        """The source of every threshold, by field name."""
        return {
            "window_hbw": "99.4 % of a single mode's Fisher information on its pole (Lorentzian integral)",
            "min_side_lines": "residues + degree-2 local polynomial need >= 10 lines per side",
            "block_lines": "Hann main lobe width, 4 lines (Harris 1978)",
            "block_from_scores": "Andrews 1991 AR(1) plug-in bandwidth (Bartlett kernel), overlapping batch means "
                                 "(Meketon & Schmeiser 1984): the scores' own correlation length",
            "max_iter": "work limit (Levenberg-Marquardt converges in < 10 evaluations from PolyMAX)",
            "misfit_p": "chi-square test of the residual against the noise estimate, p = 0.001 with its dof",
            "misfit_ratio": "residual twice the noise: the refinement's bound for a model error (refine.py)",
            "basis_rcond": "sqrt(float64 eps): numerical rank of the pole-free columns (Golub & Van Loan 5.4.1, 8.6)",
            "background_sigmas": "1 noise sigma: break-even of bias and variance (Mallows' Cp 1973, discrepancy principle)",
            "move_hbw": "half-power half-bandwidth: a pole further away is another feature of the data",
            "lm_rtol": "cost change of a few thousand float64 eps: converged (unchanged stop test)",
            "lm_pred_rtol": "predicted reduction (Dennis & Schnabel 1996, 6.4) at the cost's rounding, ~5 float64 eps",
            "lm_offset": "relative offset convergence criterion 0.001 (Bates & Watts, Technometrics 23, 1981)",
            "lm_step_sigma": "a step of 0.05 standard errors is statistically meaningless: stop (Numerical Recipes "
                             "3rd ed. 2007, sect. 15.5.2)",
        }


#: The default criteria of :func:`local_ml`.
ML_CRITERIA = MLCriteria()


#: Equivalent noise bandwidth [bins] of the windows a processing history names (``FRFData.meta["window"]``;
#: :func:`ema_rig.processing.window_code`'s names): Harris, "On the use of windows for harmonic analysis
#: with the discrete Fourier transform", Proc. IEEE 66(1), 1978, table 1 (rectangle 1.00, Hamming 1.36,
#: Hann 1.50); the flat top 3.77 (Heinzel, Ruediger & Schilling, "Spectrum and spectral density estimation
#: by the DFT", AEI 2002, HFT/"flattop" of the analysers). A transient's windows (force, exponential, an
#: impact record) leave the record's rectangle: 1.00. Any other name, or none: the Hann window's
#: (``CompletenessCriteria.resolution_lines``).
WINDOW_ENBW: Mapping[str, float] = MappingProxyType({"hann": 1.5, "hanning": 1.5, "hamming": 1.36, "flattop": 3.77, "rect": 1.0,
                                 "rectangular": 1.0, "uniform": 1.0, "none": 1.0, "force": 1.0,
                                 "exponential": 1.0, "impact": 1.0})

#: Width [lines] of the spectral kernel of the windows of :data:`WINDOW_ENBW`: the DFT of a K-term cosine-sum
#: window is its coefficients on 2K - 1 neighbouring lines (Harris, Proc. IEEE 66(1), 1978, section V-C;
#: Heinzel, Ruediger & Schilling, AEI 2002, sections C.1-C.3), so the windowed spectrum of white noise is
#: uncorrelated (for Gaussian noise independent) between lines at least that far apart: Hann and Hamming
#: (2 terms) 3 lines, the flat top (5 terms, scipy.signal.windows.flattop, ENBW 3.77) 9; the record's
#: rectangle (a transient's windows, as in :data:`WINDOW_ENBW`) 1. Any other name, or none: Hann's.
WINDOW_KERNEL_LINES: Mapping[str, int] = MappingProxyType({"hann": 3, "hanning": 3, "hamming": 3, "flattop": 9, "rect": 1,
                                        "rectangular": 1, "uniform": 1, "none": 1, "force": 1,
                                        "exponential": 1, "impact": 1})


@dataclass(frozen=True, slots=True)
class CompletenessCriteria(_Sourced):
    """When the mode set is complete: the residual is consistent with the noise estimate.

    Parameters
    ----------
    p_value : float
        Family-wise level of the chi-square tests (default 0.001), Bonferroni over the segments x
        (channels + 1) tests. A segment's statistic is ``sum 2 |e|^2 / var`` over its lines and
        channels, chi-square with ``2 n_lines n_chan - 2 m n_chan - 2 m`` dof (``m`` modes in it;
        per channel ``2 n_lines - 2 m``).
    misfit_ratio : float
        ... and the residual at least this many times the noise estimate (default 2): the bound of
        a model error of :func:`~ema_rig.identification.refine.refine` (and of the local ML's
        misfit warning, ``MLCriteria.misfit_ratio``); below it a real structure's small model
        errors (nonlinearity, leakage) would fail every segment of a long record.
    segment_hbw : float
        Each accepted mode's segment spans this many half-power half-bandwidths each side (4, the
        local ML window: 99.4 % of a mode's information, ``MLCriteria.window_hbw``); the lines between
        are cut into segments no wider than the median mode segment.
    min_segment_lines : int
        Lines per segment at least (24: two ML sides of 12 lines, ``MLCriteria.min_side_lines``).
    poly_degree : int
        Degree of the complex polynomial removed from each segment's residual before the test (2):
        it stands for the modes outside the segment and the band, as the local polynomial of the
        ML segments (``ema_rig.identification.ml``, degree up to 2); a missing mode is a peak, which
        it cannot take.
    max_extra_steps : int
        Work limit: growth steps of the order beyond the first repeat of the mode set while a
        segment without any candidate cluster fails (1); the step is kept only when the higher
        order changes the modes in the failing segments, and its verdicts are taken there only.
        Here a segment fails also when the lines of a core of its modes (modes each inside every
        other's core, ``segment_edges(chained=False)``) exceed the noise variance of the test:
        a chain of modes makes one long segment in which a local misfit is diluted.
    edge_peak_lines : int
        A failing segment at a band edge is put down to a mode outside the band only when its excess
        over the noise is largest in its outermost ``edge_peak_lines`` lines (default 4, the Hann main
        lobe): the skirt of a mode beyond the edge grows towards it, a mode inside the band (a peak of
        the data) has its largest excess at its own lines, and is a missing mode.
    max_added : int
        Work limit: missing modes added per failing segment and step (2).
    local_evidence : bool
        Decide a missing mode (a candidate in a failing segment) by a nested F test on the lines
        near it (default True; ``identification._complete``); False: the global F test of the judge
        and the segment passing with it.
    local_hbw : float
        Half-width of those lines in half-power half-bandwidths of the candidate (4, the ML window),
        at least ``min_segment_lines / 2`` lines.
    local_p : float
        Family-wise level of that F test (0.001), Bonferroni over the candidates tested on the same
        lines; dof ``(2 n_chan + 2, dof of the local fit with the mode)``.
    split_sigmas : float
        An accepted mode whose ML estimate moved more than this many ML standard uncertainties from
        its PolyMAX pole towards a rejected cluster on its local lines is tested two modes against
        one with that cluster (3, the ML duplicate rule's distance; ``identification._split``).
    drop_weak : bool
        Drop an accepted mode whose own term is weak (``JudgeCriteria.weak_peak_share``) when its
        segment passes the test without it (default False: on ufffiles_frf this dropped 5-13 of
        ~40 modes, differently in two overlapping bands, and made the band study worse).
    peak_line_out : bool
        A missing mode (or the second mode of a split) must pass the local F test also without the
        line nearest to it (default True): a pole can zero any one line, so a misfit of one line (a
        glitch, leakage, a distorted peak) is no mode; a real one shows on the lines of its skirt as
        well, however light.
    split_misfit : bool
        An accepted mode whose own lines (``local_hbw``) exceed the noise (the chi-square test of the
        segments, the lines as one segment) is tested for a second mode beside it (default True;
        ``identification._split_start``): a second pole started one half-power half-bandwidth below
        and above its ML estimate must explain those lines to the noise and pass the local nested F
        test (``local_p``, Bonferroni over the two starts), also without its peak line; after the
        band's refit the ML must hold it and its segment must pass, else the split is undone. Own
        lines cut by the band's edge are not tested (their misfit may be a mode beyond the edge: the
        band-edge rule of ``segment_misfit``; the rig file's 958 Hz mode at 150-1000 Hz).
    split_min_channels : int
        Channels (outputs x references) a mode's lines need for ``split_misfit`` (default 2): a
        second mode close to another shows as a change of the ratio between the channels across the
        peak (the channels x lines matrix of the lines has rank two, one mode's rank one), which
        one pole cannot make; on one channel a split rests on the line shape alone, which a model
        error of the one mode (leakage, nonlinearity) distorts alike.
    ml_features : bool
        Where the local ML moved a mode's pole inside its lines further than ``MLCriteria.move_hbw``
        (and held it at its PolyMAX pole), the place it moved to is a candidate missing mode (the
        strongest by its local F per segment), decided like any other by the local F test (also
        without its peak line). In a segment the band-edge rule puts down to a mode beyond the edge,
        such a feature inside the band is tested too: the ML placed the pole inside the band, not
        beyond it. Default True: on ufffiles_frf 79.95-719.55 Hz it adds the 713.7 Hz mode that
        0-799.5 Hz has (every held mode of the band then ML-estimated, no poor-fit warning, the
        band-to-band changes of the modes smaller); with the sandwich's block length from the
        scores (``MLCriteria.block_from_scores``) the changes of 56 of 59 modes lie inside their
        combined 2 sigma (with fixed 4-line blocks 48 of 59: a band whose model fits had a sigma
        that saw only the residual's short-range part). The 704.9 Hz mode, then in 0-799.5 Hz
        only, is found by both bands since the extra order step also asks the modes' own cores
        (``max_extra_steps``; benchmarks/results/study_real_bands.txt).
    resolution_lines : float
        Resolution bandwidth of the spectrum in lines where its window is Hann or not recorded (1.5,
        the Hann window's equivalent noise bandwidth; a window the processing history names gives its
        own, :data:`WINDOW_ENBW`). Two accepted modes closer than it with the same shape
        (``resolution_mac``) cannot be told apart by the spectrum: a Hann-windowed random test's
        leakage smears a lightly damped mode whose half-power band spans a few lines into two poles
        about a line apart (r_truth13, ``tests/rig_truth.py`` ``hann_leaked_frf``). They are reported
        as one mode (the one holding the larger residue; ``identification._leakage_merged``), on
        ``split_min_channels`` channels at least.
    resolution_mac : float
        Shape MAC (the residues of every output and reference) above which two such modes are the same
        shape (0.9).
    """

    p_value: float = _src(1e-3, "chi-square test p = 0.001 family-wise (Bonferroni), dof = 2 lines x channels - "
                          "parameters (Pintelon & Schoukens 2012, ch. 19)")
    misfit_ratio: float = _src(ML_CRITERIA.misfit_ratio, "refine.py / MLCriteria.misfit_ratio: a residual twice the noise is a model error")
    segment_hbw: float = _src(ML_CRITERIA.window_hbw, "MLCriteria.window_hbw: 99.4 % of a mode's Fisher information within 4 hbw")
    min_segment_lines: int = _src(2 * ML_CRITERIA.min_side_lines, "2 x MLCriteria.min_side_lines (residues + local polynomial)")
    poly_degree: int = _src(2, "the ML segments' local polynomial (ml.py, degree 2) for modes outside a segment")
    max_extra_steps: int = _src(1, "work limit (no clock): one more growth span (the count rule's span) while a "
                                "segment fails and the modes there change")
    edge_peak_lines: int = _src(ML_CRITERIA.block_lines, "Hann main lobe, 4 lines (Harris 1978; MLCriteria.block_lines): a skirt from "
                                "beyond the band peaks in the outermost lobe, a mode inside peaks further in")
    max_added: int = _src(2, "work limit: two missing modes per segment and step (a close pair)")
    local_evidence: bool = _src(True, "issue 18: the same data in two overlapping bands must give the same modes on the "
                                "overlap; a decision from the lines near a mode is the same in any band "
                                "(benchmarks/study_real_bands.py, ufffiles_frf 206.9 Hz)")
    local_hbw: float = _src(ML_CRITERIA.window_hbw, "MLCriteria.window_hbw: 99.4 % of a mode's Fisher information within 4 hbw")
    local_p: float = _src(1e-3, "F test p = 0.001 family-wise (Bonferroni over the candidates tested on the same lines), "
                          "dof (2 n_chan + 2, residual dof of the local fit) (JudgeCriteria.support_p)")
    split_sigmas: float = _src(3.0, "three ML standard uncertainties: the ML duplicate rule's distance (identification._unresolved); "
                               "a pole moved further towards a neighbouring cluster stands for two features")
    drop_weak: bool = _src(False, "off: on ufffiles_frf (two bands) it dropped modes inconsistently "
                           "(benchmarks/study_real_bands.py)")
    peak_line_out: bool = _src(True, "a jackknife of the peak line (Efron & Tibshirani 1993, ch. 11): ufffiles_frf 94.99 Hz "
                               "(zeta 0.19 %, beside the 96.1 Hz mode) zeroes the 95.0 Hz line alone; vt_case1's 34.06 Hz "
                               "(zeta 0.02 %, half-power band below a line) stands on its skirt (benchmarks/study_real_bands.py)")
    split_misfit: bool = _src(True, "issue 18: a local misfit around a peak is a missing mode; data/disk.uff 0-2000 Hz merged "
                              "789.7 and 801.0 Hz into 797.7 Hz (F 150-240 against 2.4 with (18, ~3000) dof; "
                              "benchmarks/study_disk_pair.py)")
    split_min_channels: int = _src(2, "one mode's lines form a channels x lines matrix of rank one (its shape times its "
                                   "response), two close modes one of rank two, which needs two channels; on ufffiles_frf (one "
                                   "FRF) all 5 second modes split_misfit proposed at 0-799.5 Hz were held by the band's ML at "
                                   "their start and undone, at 1.9x the identify's CPU (benchmarks/results/study_disk_pair.txt)")
    resolution_lines: float = _src(WINDOW_ENBW["hann"], "equivalent noise bandwidth of a Hann window, 1.50 bins (Harris, Proc. IEEE 66(1), "
                                   "1978, table 1): the resolution bandwidth of a random test's spectrum, the Hann window "
                                   "the common one, taken where the processing history names none (a UFF without "
                                   "dataset 1858)")
    resolution_mac: float = _src(0.9, "MAC above 0.9: the same vector (Allemang 2003; JudgeCriteria.dup_participation_mac)")
    ml_features: bool = _src(True, "on: on ufffiles_frf 79.95-719.55 Hz it adds the 713.7 Hz mode of 0-799.5 Hz (held modes "
                             "8 -> 0) and, with MLCriteria.block_from_scores, frequency changes inside their 2 sigma are "
                             "56/59 (off: 4 modes in one band only; benchmarks/study_real_bands.py); the candidate is where "
                             "the data's ML moved a pole beyond MLCriteria.move_hbw ('another feature of the data'), not any "
                             "place")


@dataclass(frozen=True, slots=True)
class ResultCriteria(_Sourced):
    """When :func:`~ema_rig.identification.identification.identify` warns about its final model.

    Parameters
    ----------
    poor_fit : float
        Median relative synthesis error over the channels above which the fit is called poor (0.20).
    edge_hbw : float
        A mode closer to a band edge than ``edge_hbw`` half-power half-bandwidths ``zeta f_n`` ...
        (2.0) ...
    edge_band_share : float
        ... or than this share of the band's width (0.01) is warned about as sitting at the edge.
    skirt_rise : float
        Above the highest mode, the FRFs' magnitude rising from its minimum to the upper band edge
        more than this factor (2) times the upper residual's own rise ``(f_edge / f_min)^p``, with a
        median synthesis error above ``poor_fit`` there, is the skirt of a mode above the band that the
        model does not represent: warned about (the mode itself is not reported). Mirrored at the lower
        edge: below the lowest mode, a fall from the band start to the minimum more than this factor
        times the lower residual's own ``(f_min / f_start)^(2 - p)``, with the same error, is content no
        mode or residual represents (dam0's DC lines: 1100x); the default band then starts at that
        minimum, an explicit band is warned about.
    skirt_lines : int
        Lines of the running median the magnitude is smoothed with for that test (9).
    """

    poor_fit: float = _src(0.20, "twice the largest noise of the project's test configurations (10 %: issue 18, "
                           "bundled simulator at 2 and 10 %): a model that misses no mode leaves an error near the "
                           "noise level")
    edge_hbw: float = _src(2.0, "2 zeta f_n is the half-power bandwidth (Ewins, Modal Testing, 2nd ed. 2000, half-power points): "
                           "closer to the edge, one half-power point of the peak lies outside the band")
    edge_band_share: float = _src(0.01, "convention kept from the first version (a89f743), no data set behind it: a "
                                  "floor for lightly damped modes, whose half-power bandwidth is a line or two")
    skirt_rise: float = _src(2.0, "the upper residual is a constant receptance: where the term of a mode above the band "
                             "doubles over the lines, a constant fitted between misses it by a third at an end, beyond "
                             "poor_fit (on the project's data: vt_case1 7.6, every other file and band <= 1.3)")
    skirt_lines: int = _src(2 * ML_CRITERIA.block_lines + 1, "the Hann main lobe each side of a line (MLCriteria.block_lines "
                            "= 4): passes a skirt's trend, not a line's noise (5 and 15 lines flag the same files)")


@dataclass(frozen=True, slots=True)
class IdentificationCriteria:
    """The criteria of every stage of :func:`~ema_rig.identification.identification.identify`.

    Parameters
    ----------
    stabilization : StabilizationCriteria
    judge : JudgeCriteria
    completeness : CompletenessCriteria
    result : ResultCriteria
    """

    stabilization: StabilizationCriteria = field(default_factory=StabilizationCriteria)
    judge: JudgeCriteria = field(default_factory=JudgeCriteria)
    completeness: CompletenessCriteria = field(default_factory=CompletenessCriteria)
    result: ResultCriteria = field(default_factory=ResultCriteria)

    def sources(self) -> dict[str, str]:
        """The source of every threshold, by ``stage.field``."""
        return {f"{stage}.{k}": v for stage in ("stabilization", "judge", "completeness", "result")
                for k, v in getattr(self, stage).sources().items()}


#: Defaults of each stage.
STABILIZATION_CRITERIA = StabilizationCriteria()
JUDGE_CRITERIA = JudgeCriteria()
COMPLETENESS_CRITERIA = CompletenessCriteria()
RESULT_CRITERIA = ResultCriteria()
IDENTIFICATION_CRITERIA = IdentificationCriteria()

__all__ = [
    "COMPLETENESS_CRITERIA",
    "ML_CRITERIA",
    "MLCriteria",
    "IDENTIFICATION_CRITERIA",
    "JUDGE_CRITERIA",
    "RESULT_CRITERIA",
    "STABILIZATION_CRITERIA",
    "WINDOW_ENBW",
    "WINDOW_KERNEL_LINES",
    "CompletenessCriteria",
    "IdentificationCriteria",
    "JudgeCriteria",
    "ResultCriteria",
    "StabilizationCriteria",
]
