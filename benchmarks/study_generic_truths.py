"""Study: the generic identification at its defaults on physics the other truth studies do not cover (issue 18).

An independent truth generator (``tests/_generic_truth.py``, numpy / scipy only; neither ``ema_rig.simulate`` nor ema_rig's modal
kernel): M, C, K are built from chosen natural frequencies, damping ratios and real mass-normalised
shapes (``M = P^-T P^-1``, ``K = P^-T diag(w^2) P^-1``, ``C = P^-T diag(2 zeta w) P^-1``), local
dashpots are added where the damping is non-proportional, the truth poles are the eigenvalues of the
first-order form and the FRFs are a direct solve of ``(K - w^2 M + j w C) x = f`` at every line.
Noise is complex circular Gaussian per line, ``sqrt(p^2 |H|^2 + floor^2)`` with the coherence that
matches it for ``n_averages`` averages (``g2 = |H|^2 / (|H|^2 + n var)``).

Families (each over ``--seeds`` seeds; shapes, frequencies and damping drawn per seed):

* ``clean``            6 well separated modes, proportional damping (the benign reference: warnings counted)
* ``complex``          local dashpots: modal phase collinearity of some modes well below 1 (zeta up to ~20 %)
* ``complex5``         five times those dashpots (zeta up to ~60 %: some modes near critical damping)
* ``pair1`` / ``pair2``  a near-repeated pair 0.1-0.5 % apart, 1 and 2 references
* ``dense``            15 modes in the band, modal overlap factor 0.3-1
* ``outside``          a strong mode 2-4 % above the band's upper edge (residual terms)
* ``rigid``            band from 2 Hz with two rigid-body modes (free-free: K singular)
* ``dead``             one channel noise only (disconnected)
* ``weak``             one channel 40 dB lower (its floor the same as the others')
* ``receptance`` / ``mobility``  the clean truths in the other ordinate types
* ``g``                accelerance in g (every FRF / 9.80665, labelled accelerance)
* ``nocoh``            the clean truths without coherence / n_averages
* ``steady`` / ``drift``  H1 of 30 averages of random excitation, stiffness constant / growing 1 % over the
                       averages (the truth: the system at the mean stiffness)

For each run: every true mode found once (an identified mode matched to its nearest true pole
within ``max(5 sigma, 1/4 half-power bandwidth, 0.3 line)`` and inside half the distance to the
true neighbour), modes the data do not support (unmatched), z of f and zeta of the matched modes,
the share inside +-2 sigma over all seeds, and the warnings ("cpu s": process CPU time of ``identify``).
A "missed" mode may be one the data barely hold: in ``dense`` the missed ones are the weakest at the
reference (peak term 0.5-5 % of the median mode's, seeds 2, 4, 11, 12, 19).

Usage::

    OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/study_generic_truths.py [--seeds 20] [--only FAMILY]
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "tests"))

from _generic_truth import Case, families, match  # noqa: E402


@dataclass(frozen=True)
class Outcome:
    """What one identification gave against its truth."""

    n_true: int
    found: int  # true modes matched exactly once
    missed: int
    doubled: int  # true modes matched by more than one identified mode
    extra: int  # identified modes matched to no true mode
    zf: tuple[float, ...]
    zz: tuple[float, ...]
    warnings: tuple[str, ...]
    seconds: float


def run(case: Case) -> Outcome:
    """``identify`` at its defaults on one case."""
    from ema_rig.frf import FRFData
    from ema_rig.identification import identify

    n_out, n_in = case.frf.shape[:2]
    data = FRFData(case.freq, case.frf, [f"{i + 1}+Y" for i in range(n_out)], [f"{i + 1}+Y" for i in range(n_in)],
                   frf_form=case.form, coherence=case.coherence, n_averages=case.n_averages)
    t0 = time.process_time()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ident = identify(data)
    sec = time.process_time() - t0
    f, z = ident.natural_freq, ident.damping_ratio
    sf, sz = ident.natural_freq_std, ident.damping_ratio_std
    m = match(case, f, sf)
    ft = np.abs(case.poles) / (2 * np.pi)
    zt = -case.poles.real / np.abs(case.poles)
    counts = np.bincount([j for j in m if j is not None], minlength=ft.size)
    zf, zz = [], []
    for i, j in enumerate(m):
        if j is not None and counts[j] == 1:
            zf.append(float((f[i] - ft[j]) / sf[i]) if sf[i] > 0 else float("nan"))
            zz.append(float((z[i] - zt[j]) / sz[i]) if sz[i] > 0 else float("nan"))
    return Outcome(ft.size, int(np.sum(counts == 1)), int(np.sum(counts == 0)), int(np.sum(counts > 1)),
                   sum(j is None for j in m), tuple(zf), tuple(zz), tuple(ident.warnings), sec)


def _share(z: list[float]) -> str:
    a = np.asarray(z)
    if a.size == 0:
        return "  -  "
    ok = np.isfinite(a) & (np.abs(a) <= 2)
    return f"{np.mean(ok):5.3f}"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--seed-offset", type=int, default=0)
    ap.add_argument("--only", action="append", default=[])
    ap.add_argument("-v", "--verbose", action="store_true", help="one line per seed")
    args = ap.parse_args()
    fams = families()
    names = [n for n in fams if not args.only or n in args.only]
    print(f"{'family':11s} {'runs':>4s} {'true':>5s} {'found':>5s} {'miss':>4s} {'dup':>3s} {'extra':>5s} "
          f"{'f in2':>5s} {'z in2':>5s} {'rms zf':>6s} {'rms zz':>6s} {'warned':>6s} {'cpu s':>6s}")
    for name in names:
        outs = []
        for s in range(args.seed_offset, args.seed_offset + args.seeds):
            o = run(fams[name](s))
            outs.append(o)
            if args.verbose:
                print(f"  {name} seed {s}: true {o.n_true} found {o.found} miss {o.missed} dup {o.doubled} "
                      f"extra {o.extra} zf {np.round(o.zf, 2).tolist()} zz {np.round(o.zz, 2).tolist()} "
                      f"warnings {list(o.warnings)}", flush=True)
        zf = [x for o in outs for x in o.zf]
        zz = [x for o in outs for x in o.zz]
        rf = np.sqrt(np.nanmean(np.square(zf))) if zf else np.nan
        rz = np.sqrt(np.nanmean(np.square(zz))) if zz else np.nan
        print(f"{name:11s} {len(outs):4d} {sum(o.n_true for o in outs):5d} {sum(o.found for o in outs):5d} "
              f"{sum(o.missed for o in outs):4d} {sum(o.doubled for o in outs):3d} {sum(o.extra for o in outs):5d} "
              f"{_share(zf)} {_share(zz)} {rf:6.2f} {rz:6.2f} {sum(bool(o.warnings) for o in outs):6d} "
              f"{sum(o.seconds for o in outs):6.1f}", flush=True)
        kinds: dict[str, int] = {}
        for o in outs:
            for w in o.warnings:
                kinds[w[:90]] = kinds.get(w[:90], 0) + 1
        for w, nw in sorted(kinds.items(), key=lambda t: -t[1])[:6]:
            print(f"    {nw:3d}x {w}", flush=True)


if __name__ == "__main__":
    main()
