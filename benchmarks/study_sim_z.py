"""Study: is the measured ± of f_H and k_TB a standard uncertainty on the bundled simulator? (issue 18)

``simulate_measurement`` (the rig of ``data/rig.toml``, k_TB = 71.57 MN/m, all modes of the
simulator, default misalignment) at ``--noise`` for ``--seeds`` seeds -> ``estimate_stiffness`` at
the defaults. z of the housing frequency ``(f_H - truth) / natural_freq_std`` against the
simulator's housing mode, and of k_TB with its measured part only
``(k_TB - truth) / k_TB_std_measured`` (the rig-file tolerances are the same for every seed, so the
scatter over seeds measures only the measured part). Reports the rms z (1 for a standard
uncertainty) and the share inside 2.

Run: ``PYTHONPATH=. python benchmarks/study_sim_z.py [--seeds 30] [--noise 0.02]``.
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=30)
    ap.add_argument("--noise", type=float, nargs="+", default=[0.02, 0.10])
    args = ap.parse_args()
    from ema_rig.config import load_rig
    from ema_rig.rig.stiffness import estimate_stiffness
    from ema_rig.simulate import simulate_measurement

    rig = load_rig(REPO / "data" / "rig.toml")
    for noise in args.noise:
        zf, zk, nwarn = [], [], 0
        for seed in range(args.seeds):
            sim = simulate_measurement(rig, k_tb=7.157e7, noise=noise, seed=seed)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = estimate_stiffness(sim.data, rig)
            hm = res.housing_mode
            modes = [m for m in sim.truth["modes"] if m.get("kind") == "housing_radial"]
            f_true = modes[0]["natural_freq"] if modes else sim.truth["f_H"]
            zf.append((hm["natural_freq"] - f_true) / hm["natural_freq_std"])
            zk.append((res.k_TB - sim.truth["k_TB"]) / res.k_TB_std_measured)
            nwarn += bool(res.warnings)
        zf_a, zk_a = np.array(zf), np.array(zk)
        print(f"noise {100 * noise:g} %: rms z f_H {np.sqrt(np.mean(zf_a**2)):.2f} (mean {zf_a.mean():+.2f}, "
              f"in 2: {np.mean(np.abs(zf_a) <= 2):.2f}), rms z k_TB measured {np.sqrt(np.mean(zk_a**2)):.2f} "
              f"(mean {zk_a.mean():+.2f}, in 2: {np.mean(np.abs(zk_a) <= 2):.2f}); {nwarn} of {args.seeds} "
              "with warnings", flush=True)


if __name__ == "__main__":
    main()
