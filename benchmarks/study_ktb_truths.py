"""Study: is k_TB within 2 sigma of the truth, or warned, or refused? (issue 11)

Runs the independent rig truths of ``tests/rig_truth.py`` (the paper's 3DOF radial dynamics
solved directly, a rigid housing seen by misaligned sensors, tilt / flexible / frame modes) over
many seeds for each class of trouble, through UFF58 and the public pipeline, and counts per class:
refused, warned, within 2 sigma without warning, and **silently wrong** (no warning, |z| > 2).

Usage::

    PYTHONPATH=.:tests python benchmarks/study_ktb_truths.py [--seeds N]

Point PYTHONPATH at another checkout (e.g. the main branch) to count "before" (results without a
``warnings`` attribute count as unwarned).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from rig_truth import RigTruth, write_case  # noqa: E402

from ema_rig.config import load_rig  # noqa: E402
from ema_rig.errors import EmaRigError  # noqa: E402
from ema_rig.io.uff import read_uff58  # noqa: E402
from ema_rig.rig import stiffness as st  # noqa: E402

FREQ = np.arange(0.0, 1100.25, 0.5)


def _run(tmp: Path, name: str, truth: RigTruth, k_ms: float | None = None, k_ms_std: float | None = None,
         **kw: object) -> tuple[str, float, float, float]:
    """(outcome, bias %, z, sigma %) of one case; outcome refused / warned / ok / SILENT."""
    uff, rig_path = write_case(tmp, name, truth, FREQ, **kw)
    rig = load_rig(rig_path)
    data = read_uff58(uff, rig=rig)
    try:
        res = st.estimate_stiffness(data, rig, spindle=False, k_ms=k_ms, k_ms_std=k_ms_std)
    except EmaRigError:
        return "refused", math.nan, math.nan, math.nan
    w = tuple(getattr(res, "warnings", ()))
    bias = res.k_TB / truth.k_TB - 1
    z = (res.k_TB - truth.k_TB) / res.k_TB_std
    out = "warned" if w else ("ok" if abs(z) <= 2 else "SILENT")
    return out, 100 * bias, z, 100 * res.k_TB_std / res.k_TB


def _calibrated(tmp: Path, name: str, seed: int) -> tuple[str, float, float, float]:
    """Soft disk (10x k_MS) calibration, then the bearing with the calibrated k_MS."""
    disk = RigTruth(k_TB=10 * 114e6, seed=seed)
    uff, rig_path = write_case(tmp, name + "_disk", disk, FREQ)
    rig = load_rig(rig_path)
    cal = st.calibrate(read_uff58(uff, rig=rig), rig)
    truth = RigTruth(k_TB=float(np.random.default_rng(seed).uniform(50e6, 100e6)), seed=seed + 500)
    return _run(tmp, name, truth, k_ms=cal.k_MS, k_ms_std=cal.k_MS_std)


def scenarios() -> dict[str, Callable[[Path, int], tuple[str, float, float, float]]]:
    def rng(s: int) -> np.random.Generator:
        return np.random.default_rng(10_000 + s)

    return {
        "baseline (k_TB 40-90 MN/m, 536-652 Hz)": lambda t, s: _run(
            t, "base", RigTruth(k_TB=float(rng(s).uniform(40e6, 90e6)), seed=s)),
        "baseline, 10 % noise": lambda t, s: _run(
            t, "noisy", RigTruth(k_TB=float(rng(s).uniform(40e6, 90e6)), seed=s), noise=0.10),
        "among frame/flexible modes (90-150 MN/m)": lambda t, s: _run(
            t, "crowd", RigTruth(k_TB=float(rng(s).uniform(90e6, 150e6)), seed=s)),
        "no driving point + tilt within 0.5 %": lambda t, s: _run(
            t, "nodp_tilt", RigTruth(tilt_x_freq=626.0 * (1 + rng(s).uniform(-0.005, 0.005)), seed=s),
            drop=("11+Y",)),
        "frame mode 6 Hz below, no driving point": lambda t, s: _run(
            t, "frame", RigTruth(k_TB=93e6, flex_frame_freq=float(rng(s).uniform(655, 665)) - 0.0,
                                 seed=s), drop=("11+Y",)),
        "frame mode 6 Hz below, driving point": lambda t, s: _run(
            t, "frame_dp", RigTruth(k_TB=93e6, flex_frame_freq=float(rng(s).uniform(655, 665)), seed=s)),
        "housing appendage 0.4-2 % near 695 Hz": lambda t, s: _run(
            t, "app", RigTruth(k_TB=float(rng(s).uniform(95e6, 160e6)),
                               appendage_fraction=float(rng(s).uniform(0.004, 0.02)),
                               flex_housing_freq=820.0, flex_frame_freq=600.0, seed=s)),
        "soft disk (10x k_MS) calibration": lambda t, s: _calibrated(t, "disk", s),
        "hysteretic damping 10 %": lambda t, s: _run(
            t, "hyst", RigTruth(zeta=0.10, damping="hysteretic", seed=s)),
        "bearing dashpot (zeta 2 % + 8 %)": lambda t, s: _run(
            t, "dash", RigTruth(zeta=0.02, damping="dashpot", dashpot_zeta=0.08, seed=s)),
        "reversed radial sensor 12+Y": lambda t, s: _run(t, "flip", RigTruth(seed=s), flip=("12+Y",)),
        "file in g without labels": lambda t, s: _run(t, "g", RigTruth(seed=s), scale=1 / 9.80665),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=10)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    print(f"{'class':42s} {'n':>3s} {'refused':>7s} {'warned':>6s} {'ok':>4s} {'SILENT':>6s}  "
          f"{'max|bias| %':>11s} {'median sigma %':>14s} {'max|z| unwarned':>15s} {'max|z| warned':>13s}")
    total_silent = 0
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        for name, fn in scenarios().items():
            counts = {"refused": 0, "warned": 0, "ok": 0, "SILENT": 0}
            worst, z_ok, z_w = 0.0, 0.0, 0.0
            sigmas = []
            for s in range(args.seeds):
                out, bias, z, sig = fn(tmp, s)
                counts[out] += 1
                if math.isfinite(bias):
                    sigmas.append(sig)
                    worst = max(worst, abs(bias))
                    if out == "warned":
                        z_w = max(z_w, abs(z))
                    else:
                        z_ok = max(z_ok, abs(z))
            total_silent += counts["SILENT"]
            print(f"{name:42s} {args.seeds:3d} {counts['refused']:7d} {counts['warned']:6d} {counts['ok']:4d} "
                  f"{counts['SILENT']:6d}  {worst:11.1f} {np.median(sigmas) if sigmas else math.nan:14.2f} "
                  f"{z_ok:15.2f} {z_w:13.2f}")
    print(f"silently wrong (no warning, |z| > 2): {total_silent}")


if __name__ == "__main__":
    main()
