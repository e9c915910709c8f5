"""Residues of the noise-weighted LSFD against an exact oracle, before (unweighted) and after.

The seeded six-coordinate M, C, K system of ``tests/_mck_truth.py`` (state-space poles, known
mass-normalised shapes, FRFs by a direct solve; numpy/scipy only) with complex Gaussian noise of
standard deviation ``sqrt(p^2 |H|^2 + floor^2)``. The exact receptance residue of mode ``r`` at
output ``o`` and reference ``q`` is ``phi_r[o] phi_r[q] / (2 j w_d,r)`` (proportional damping).

Per configuration and seed three fits at the same poles:

* ``unweighted``: :func:`ema_rig.identification.lsfd` as before (plain least squares);
* ``weighted``: the identification's own noise variance
  (``identification._misfit``: the completeness test's estimate, coherence when present);
* ``oracle``: weighted by the true variance (the maximum-likelihood residues, for reference).

Two pole sets: the exact poles (LSFD alone) and the poles ``identify`` reports (the pipeline).
Printed: the rms over seeds of each mode's relative residue error ``||R_est - R|| / ||R||`` over
the outputs, and the median per-line error of the synthesis against the noise-free FRFs.

With ``--rig``, also the rig-truth sets of ``tests/rig_truth.py`` (12 coordinates, modes at 114
and 137 Hz just below the 150-1000 Hz band, 2 % proportional noise): the driving-point modal mass
of the housing mode against the truth's, at the exact poles and at the poles ``identify`` reports,
unweighted, weighted, and as reported (the weights spread the misfit of the near out-of-band
modes, which the residual terms cannot follow; the reported model keeps the unweighted fit there).

Run: ``python benchmarks/study_lsfd_weights.py [--seeds N] [--identify] [--rig]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(REPO), str(REPO / "tests")]

from _mck_truth import BASE_FREQ, SHAPES, make  # noqa: E402

from ema_rig.frf import FRFData  # noqa: E402
from ema_rig.identification import identify, lsfd  # noqa: E402
from ema_rig.identification.criteria import COMPLETENESS_CRITERIA  # noqa: E402
from ema_rig.identification.identification import _misfit  # noqa: E402

CONFIGS = {  # name: (relative p, floor relative to the channel RMS, with coherence)
    "proportional 3 %": (0.03, 0.0, False),
    "floor 2 %": (0.0, 0.02, False),
    "prop 2 % + floor 1 %": (0.02, 0.01, False),
    "prop 2 % + floor 1 %, coherence": (0.02, 0.01, True),
}


def exact_residues(poles: np.ndarray, outputs: list[int], refs: list[int]) -> np.ndarray:
    """``phi_r[o] phi_r[q] / (2 j w_d,r)`` of the in-band modes, shape (n_modes, n_out, n_in)."""
    fn = np.abs(poles) / (2 * np.pi)
    idx = [int(np.argmin(np.abs(np.asarray(BASE_FREQ) - f))) for f in fn]
    phi = SHAPES[idx]
    return (phi[:, outputs, None] * phi[:, None, refs]) / (2j * poles.imag)[:, None, None]


def rel_err(est: np.ndarray, true: np.ndarray) -> np.ndarray:
    return np.linalg.norm((est - true).reshape(true.shape[0], -1), axis=1) / np.linalg.norm(
        true.reshape(true.shape[0], -1), axis=1)


def one(seed: int, p: float, floor: float, coh: bool, with_identify: bool) -> dict[str, np.ndarray]:
    t = make(seed, noise=p, floor_rel=floor)
    data = FRFData(t.freq, t.frf, t.out_dofs, t.in_dofs, frf_form="accelerance",
                   coherence=t.coherence if coh else None, n_averages=t.n_averages if coh else None)
    truth = exact_residues(t.poles, list(range(6)), [0])
    out: dict[str, np.ndarray] = {}
    pole_sets = [("exact", t.poles)]
    ident_model = None
    if with_identify:
        ident = identify(data)
        lam = ident.modes.poles
        if lam.size == t.poles.size:
            pole_sets.append(("identify", lam))
            ident_model = ident.modes
    for tag, lam in pole_sets:
        var = _misfit(data, lsfd(data, lam), COMPLETENESS_CRITERIA).variance.reshape(data.frf.shape)
        fits = {"unweighted": lsfd(data, lam), "weighted": lsfd(data, lam, variance=var),
                "oracle": lsfd(data, lam, variance=t.variance)}
        if tag == "identify" and ident_model is not None:
            fits["reported"] = ident_model  # per channel the weighted fit unless the model errs there
        for name, m in fits.items():
            out[f"{tag}/{name}"] = rel_err(m.residues, truth)
            syn = m.synthesize(t.freq).frf
            out[f"{tag}/{name}/line"] = np.array([np.median(np.abs(syn - t.exact) / np.abs(t.exact))])
    return out


def rig_truth_masses(seeds: int) -> None:
    """Driving-point modal mass of the housing mode on the rig-truth sets, relative error [%]."""
    import rig_truth
    from rig_truth import RigTruth, measurement

    freq = np.arange(0.0, 1100.25, 0.5)
    rows: dict[str, list[float]] = {}
    for seed in range(seeds):
        truth = RigTruth(k_TB=70e6, sensor_mass=0.015, seed=seed)
        m, k = truth.matrices()
        lam2, phi = rig_truth._eigh(k, m)
        i = rig_truth._housing_index(lam2, phi, m)
        m_true = 1.0 / float(truth.observation()[0] @ phi[:, i]) ** 2
        w = np.sqrt(np.clip(lam2, 0.0, None))
        poles = -truth.zeta * w + 1j * w * np.sqrt(1 - truth.zeta**2)
        meas = measurement(truth, freq)
        data = FRFData(freq, meas.frf[:, None, :], list(meas.out), ["11+Y"], frf_form="accelerance").band(150, 1000)
        fn = np.abs(poles) / (2 * np.pi)
        exact = poles[(fn > 150) & (fn < 1000)]
        ident = identify(data)
        for tag, lam in (("exact", exact), ("identify", ident.modes.poles)):
            var = _misfit(data, lsfd(data, lam), COMPLETENESS_CRITERIA).variance.reshape(data.frf.shape)
            fits = {"unweighted": lsfd(data, lam), "weighted": lsfd(data, lam, variance=var)}
            if tag == "identify":
                fits["reported"] = ident.modes
            for name, mod in fits.items():
                r = int(np.argmin(np.abs(mod.poles - poles[i])))
                rows.setdefault(f"{tag}/{name}", []).append(100 * (mod.modal_mass("11+Y")[r] / m_true - 1))
    print(f"== rig truth (k_TB 70 MN/m, 15 g sensors), {seeds} seeds: housing driving-point modal mass error [%]")
    for key, v in rows.items():
        print(f"   {key:22s} mean {np.mean(v):+6.2f}  rms {np.sqrt(np.mean(np.square(v))):5.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--identify", action="store_true", help="also at the poles identify reports (slower)")
    ap.add_argument("--rig", action="store_true", help="also the rig-truth sets' driving-point modal mass")
    args = ap.parse_args()
    for cname, (p, floor, coh) in CONFIGS.items():
        runs = [one(s, p, floor, coh, args.identify) for s in range(args.seeds)]
        keys = [k for k in runs[0] if not k.endswith("/line") and all(k in r for r in runs)]
        print(f"== {cname}: rms relative residue error per mode over {args.seeds} seeds "
              f"(modes {', '.join(f'{f:g}' for f in BASE_FREQ[:5])} Hz); median per-line error vs exact FRF")
        for k in keys:
            e = np.sqrt(np.mean([r[k] ** 2 for r in runs], axis=0))
            ln = np.median([r[k + "/line"][0] for r in runs])
            print(f"   {k:22s} " + " ".join(f"{100 * x:6.2f}" for x in e) + f"  %   line {100 * ln:5.2f} %")
    if args.rig:
        rig_truth_masses(args.seeds)


if __name__ == "__main__":
    main()
