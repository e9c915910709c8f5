"""Force and response time records of a modal system, simulated with numpy and scipy only.

An independent truth for the whole chain: random forces -> exact sampled response of a
classically damped modal system -> ``ema_rig.spectral.estimate_frf`` (Hann window, 50 %
overlap, H1, many averages) -> ``identify``. Nothing of ema_rig is used to make the records.

The structure is a sum of real (mass-normalised) modes; mode ``r`` obeys
``q_r'' + 2 zeta_r w_r q_r' + w_r^2 q_r = phi_r^T f(t)``. The forces are held constant over a
sample of a rate ``oversample`` times the analyser's (zero-order hold), so
``scipy.signal.cont2discrete(..., method='zoh')`` gives the exact sampled response of the
continuous system there; force and response are then decimated to ``fs`` with the same zero-phase
FIR anti-alias filter (``scipy.signal.decimate``), as an oversampling analyser does, so their
ratio is the continuous FRF in the band. The true natural frequency and damping ratio are those
of the continuous modes (``|lambda|/2pi`` and ``-Re lambda / |lambda|``). The outputs are
accelerations ``sum_r phi_or q_r''``.

Noise: ``floor`` adds white Gaussian sensor noise to every response (a fraction of its RMS);
``process`` adds an unmeasured random force at the last coordinate (a fraction of the measured
forces' RMS): its response follows the resonances, so the FRF error is proportional to the
structure's response (the "proportional noise" of an analyser), and H1 stays unbiased.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.signal


@dataclass(frozen=True)
class TimeCase:
    """One configuration of the study.

    Parameters
    ----------
    name : str
    natural_freq, damping_ratio : tuple of float
        The modes [Hz], [-].
    n_out, n_in : int
        Responses and (measured, uncorrelated random) forces.
    floor : float
        Sensor noise std relative to each response's RMS.
    process : float
        Unmeasured force std relative to the measured forces' std.
    band : (float, float)
        Identification band [Hz].
    fs : float
        Sampling rate [Hz]; lines at ``fs / segment``.
    segment : int
        FFT length; ``n_avg`` segments of 50 % overlap make the record.
    n_avg : int
    oversample : int
        Simulation rate / ``fs`` (decimated with an anti-alias filter).
    """

    name: str
    natural_freq: tuple[float, ...]
    damping_ratio: tuple[float, ...]
    n_out: int = 6
    n_in: int = 1
    floor: float = 0.02
    process: float = 0.0
    band: tuple[float, float] = (60.0, 900.0)
    fs: float = 2048.0
    segment: int = 8192
    n_avg: int = 30
    oversample: int = 4


def shapes(case: TimeCase, rng: np.random.Generator) -> np.ndarray:
    """Mode shapes (n_modes, n_coord): the outputs, then the force points (the first outputs) and one
    unmeasured force point; the first output (driving point of force 1) sees every mode."""
    nm = len(case.natural_freq)
    phi = rng.uniform(-1.0, 1.0, (nm, case.n_out + 1))
    phi[:, 0] = rng.uniform(0.5, 1.0, nm) * rng.choice([-1.0, 1.0], nm)
    return phi


def simulate(case: TimeCase, seed: int) -> tuple[np.ndarray, np.ndarray, float]:
    """Force (n_in, n_samples) and acceleration (n_out, n_samples) records, and fs."""
    rng = np.random.default_rng(seed)
    phi = shapes(case, rng)
    ovs = case.oversample
    n = (case.segment * (case.n_avg + 1) // 2 + 64) * ovs
    dt = 1.0 / (case.fs * ovs)
    force = rng.standard_normal((case.n_in, n))
    extra = case.process * rng.standard_normal(n)
    # forces at outputs 0..n_in-1; the unmeasured one at the last coordinate
    modal_in = phi[:, : case.n_in] @ force + phi[:, -1:] * extra[None, :]  # (n_modes, n)
    qdd = np.empty((len(case.natural_freq), n))
    for r, (fn, z) in enumerate(zip(case.natural_freq, case.damping_ratio, strict=True)):
        w = 2 * np.pi * fn
        a = np.array([[0.0, 1.0], [-(w**2), -2 * z * w]])
        b = np.array([[0.0], [1.0]])
        c = np.array([[-(w**2), -2 * z * w]])  # q'' = u - w^2 q - 2 z w q'
        d = np.array([[1.0]])
        ad, bd, cd, dd, _ = scipy.signal.cont2discrete((a, b, c, d), dt, method="zoh")
        num, den = scipy.signal.ss2tf(ad, bd, cd, dd)
        qdd[r] = scipy.signal.lfilter(num[0], den, modal_in[r])
    acc = phi[:, : case.n_out].T @ qdd
    if ovs > 1:
        acc = scipy.signal.decimate(acc, ovs, ftype="fir", axis=1, zero_phase=True)[:, 32:-32]
        force = scipy.signal.decimate(force, ovs, ftype="fir", axis=1, zero_phase=True)[:, 32:-32]
    if case.floor > 0:
        rms = np.sqrt(np.mean(acc**2, axis=1, keepdims=True))
        acc = acc + case.floor * rms * rng.standard_normal(acc.shape)
    return force, acc, case.fs


def true_poles(case: TimeCase) -> tuple[np.ndarray, np.ndarray]:
    """True natural frequencies [Hz] and damping ratios (continuous modes)."""
    return np.asarray(case.natural_freq, float), np.asarray(case.damping_ratio, float)


#: The configurations of the issue-18 study (every mode inside the band, >= 2 bandwidths from its edges).
CASES = (
    TimeCase("noise floor 5 %", (140.0, 260.0, 410.0, 575.0, 760.0), (0.012, 0.02, 0.01, 0.015, 0.018),
             floor=0.05),
    TimeCase("proportional (unmeasured force 30 %)", (140.0, 260.0, 410.0, 575.0, 760.0),
             (0.012, 0.02, 0.01, 0.015, 0.018), floor=0.002, process=0.3),
    TimeCase("heavy damping 4-8 %", (150.0, 300.0, 480.0, 650.0), (0.04, 0.06, 0.08, 0.05), floor=0.03,
             band=(40.0, 950.0)),
    TimeCase("pair 1 % apart, 1 reference, 2 % noise", (180.0, 400.0, 404.0, 640.0), (0.01, 0.008, 0.008, 0.012),
             floor=0.02),
    TimeCase("2 references", (140.0, 260.0, 410.0, 575.0, 760.0), (0.012, 0.02, 0.01, 0.015, 0.018),
             n_in=2, floor=0.03),
    TimeCase("128 outputs", (140.0, 260.0, 410.0, 575.0, 760.0), (0.012, 0.02, 0.01, 0.015, 0.018),
             n_out=128, floor=0.03, n_avg=16),
)


def run_case(case: TimeCase, seed: int) -> dict[str, np.ndarray]:
    """Simulate, estimate the FRFs with ema_rig, identify at the defaults; z-scores of the true modes.

    Returns
    -------
    dict
        ``z_f``, ``z_z`` (n_true,): (estimate - truth) / std of the mode found nearest each true
        one (NaN when none within 1 %); ``found`` (bool, n_true); ``n_modes`` identified.
    """
    from ema_rig.identification import identify
    from ema_rig.spectral import estimate_frf

    force, acc, fs = simulate(case, seed)
    est = estimate_frf(force, acc, fs, in_dofs=[f"{i + 1}+Z" for i in range(case.n_in)],
                       out_dofs=[f"{i + 1}+Z" for i in range(case.n_out)], segment=case.segment)
    ident = identify(est.frf.replace(coherence=est.coherence, n_averages=est.n_averages), band=case.band)
    fn, zn = true_poles(case)
    z_f = np.full(fn.size, np.nan)
    z_z = np.full(fn.size, np.nan)
    found = np.zeros(fn.size, bool)
    for k, (f, z) in enumerate(zip(fn, zn, strict=True)):
        if ident.natural_freq.size == 0:
            continue
        j = int(np.argmin(np.abs(ident.natural_freq - f)))
        if abs(ident.natural_freq[j] - f) <= 0.005 * f:
            found[k] = True
            z_f[k] = (ident.natural_freq[j] - f) / ident.natural_freq_std[j]
            z_z[k] = (ident.damping_ratio[j] - z) / ident.damping_ratio_std[j]
    return {"z_f": z_f, "z_z": z_z, "found": found, "n_modes": np.array(ident.natural_freq.size),
            "n_warnings": np.array(len(ident.warnings))}
