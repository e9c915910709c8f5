"""Study: does identify's default ±2 sigma cover the truth when the FRFs come from time data? (issue 18)

The independent truth generator of ``tests/_time_truth.py`` (numpy/scipy only: a modal system's
exact sampled response to random forces) -> ``ema_rig.spectral.estimate_frf`` (Hann, 50 %
overlap, H1, 16-30 averages, coherence attached) -> ``identify`` at the defaults. For every
configuration of ``_time_truth.CASES`` and ``--seeds`` seeds: how often each true mode was found
(within 0.5 %), the share of found modes whose natural frequency and damping ratio lie within
2 standard uncertainties of the truth, the rms z, and the identified mode count.

Run: ``PYTHONPATH=. python benchmarks/study_time_truth.py [--seeds 20]``.
"""

from __future__ import annotations

import argparse
import sys
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import _time_truth as tt  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--case", default="", help="only the configurations whose name contains this")
    args = ap.parse_args()
    print(f"{'configuration':42s} {'found':>6s} {'modes':>6s} {'f in 2s':>8s} {'z in 2s':>8s} "
          f"{'rms z_f':>8s} {'rms z_z':>8s}")
    for case in tt.CASES:
        if args.case not in case.name:
            continue
        zf, zz, found, nm = [], [], [], []
        for seed in range(args.seeds):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                r = tt.run_case(case, 1000 + seed)
            zf.append(r["z_f"])
            zz.append(r["z_z"])
            found.append(r["found"])
            nm.append(int(r["n_modes"]))
        f, z, fo = np.array(zf), np.array(zz), np.array(found)
        ok = np.isfinite(f) & np.isfinite(z)
        print(f"{case.name:42s} {fo.mean():6.3f} {np.mean(nm):6.2f} {np.mean(np.abs(f[ok]) <= 2):8.3f} "
              f"{np.mean(np.abs(z[ok]) <= 2):8.3f} {np.sqrt(np.mean(f[ok] ** 2)):8.2f} "
              f"{np.sqrt(np.mean(z[ok] ** 2)):8.2f}", flush=True)


if __name__ == "__main__":
    main()
