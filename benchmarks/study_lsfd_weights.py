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

Run: ``python benchmarks/study_lsfd_weights.py [--seeds N] [--identify]``.
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--identify", action="store_true", help="also at the poles identify reports (slower)")
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


if __name__ == "__main__":
    main()
