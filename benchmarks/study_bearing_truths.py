"""Study (issue 19): the bearing measured where the 3DOF inversion could only hedge.

Runs the independent rig truths of ``tests/rig_truth.py`` (imports nothing from ema_rig) for the
classes of issue 19 over many seeds, through UFF58 (written by pyuff) and the public pipeline,
and counts per class: refused, warned, within 2 sigma without a warning (``ok``) and **silently
wrong** (no warning, ``|k_TB - truth| > 2 sigma``), with the median sigma(k_TB). A second table
gives the bearing damping (c_TB or loss factor) against the truth for a viscous dashpot and a
hysteretic bearing.

Usage::

    PYTHONPATH=. python benchmarks/study_bearing_truths.py [--seeds N] [--only NAME]

Point PYTHONPATH at another checkout (e.g. the main branch) to count "before": the truths and
this script stay this tree's (a rig file with sensor masses is refused there).
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

from rig_truth import RigTruth, TiltRigTruth, write_case  # noqa: E402

from ema_rig.config import load_rig  # noqa: E402
from ema_rig.errors import EmaRigError  # noqa: E402
from ema_rig.io.uff import read_uff58  # noqa: E402
from ema_rig.rig import stiffness as st  # noqa: E402

FREQ = np.arange(0.0, 1100.25, 0.5)
Outcome = tuple[str, float, float, float, str]
AXIAL: list[bool] = []  # per run with an axial stiffness: within 2 sigma of the truth's
# per tilt-class run and axis: (class, axis, reported, within 2 sigma, relative sigma, z, z of the measured sigma)
TILT: list[tuple[str, str, bool, bool, float, float, float]] = []


def _run(tmp: Path, name: str, truth: RigTruth, damping_model: str = "viscous", label: str = ""
         ) -> tuple[Outcome, object]:
    uff, rig_path = write_case(tmp, name, truth, FREQ)
    try:
        rig = load_rig(rig_path)
        data = read_uff58(uff, rig=rig)
        res = st.estimate_stiffness(data, rig, spindle=False, damping_model=damping_model)
    except EmaRigError as exc:
        return ("refused", math.nan, math.nan, math.nan, str(exc)[:120]), None
    w = tuple(res.warnings)
    rb = getattr(res, "rigid_body", None)  # absent on a tree before issue 19
    if rb is not None and rb.axial_stiffness is not None and truth.sensor_mass == 0:
        # the truth's axial bearing stiffness: the housing's axial coordinate on its spring
        k_ax = truth.params["m_H"] * (2 * math.pi * truth.axial_freq) ** 2
        AXIAL.append(abs(rb.axial_stiffness - k_ax) <= 2 * rb.axial_stiffness_std)
    if isinstance(truth, TiltRigTruth):
        # the truth's tilt stiffness: the diagonal of K for th_X and th_Z
        for ax, k_true in zip(("x", "z"), truth.tilt_stiffness(), strict=True):
            ts = None if rb is None else rb.tilt_about(ax)
            if ts is None:
                TILT.append((label, ax, False, False, math.nan, math.nan, math.nan))
            else:
                zt = (ts.stiffness - k_true) / ts.stiffness_std
                zm = (ts.stiffness - k_true) / ts.stiffness_std_measured
                TILT.append((label, ax, True, abs(zt) <= 2, ts.stiffness_std / ts.stiffness, zt, zm))
    bias = res.k_TB / truth.k_TB - 1
    z = (res.k_TB - truth.k_TB) / res.k_TB_std
    out = "warned" if w else ("ok" if abs(z) <= 2 else "SILENT")
    return (out, 100 * bias, z, 100 * res.k_TB_std / res.k_TB, w[0][:120] if w else ""), res


def _fc(truth: RigTruth, force_chain: float | None) -> RigTruth:
    truth.file_force_chain = force_chain
    return truth


def _rng(s: int) -> np.random.Generator:
    return np.random.default_rng(20_000 + s)


def _k(s: int) -> float:
    return float(_rng(s).uniform(40e6, 90e6))


def _frame_near(s: int) -> RigTruth:
    r = _rng(s)
    t = RigTruth(k_TB=float(r.uniform(40e6, 90e6)), seed=s)
    f_h = t.housing_freq()
    sign = 1.0 if r.uniform() < 0.5 else -1.0
    t.flex_frame_freq = f_h * (1 + sign * float(r.uniform(0.01, 0.03)))
    return t


def classes() -> dict[str, Callable[[int], RigTruth]]:
    """Truth per seed for every class of issue 19."""
    return {
        "baseline": lambda s: RigTruth(k_TB=_k(s), seed=s),
        "axial partner (300-900 Hz, 1-8 %)": lambda s: RigTruth(
            k_TB=_k(s), cross_axis="axial", axial_freq=float(_rng(s).uniform(300, 900)),
            cross_leak=float(_rng(s + 99).uniform(0.01, 0.08)), seed=s),
        "lateral partner (300-900 Hz, 1-8 %)": lambda s: RigTruth(
            k_TB=_k(s), cross_axis="lateral", lateral_freq=float(_rng(s).uniform(300, 900)),
            cross_leak=float(_rng(s + 99).uniform(0.01, 0.08)), seed=s),
        "sensor masses 4-20 g, declared": lambda s: RigTruth(
            k_TB=_k(s), sensor_mass=float(_rng(s).uniform(0.004, 0.020)), seed=s),
        "sensor masses 4-20 g, not declared": lambda s: RigTruth(
            k_TB=_k(s), sensor_mass=float(_rng(s).uniform(0.004, 0.020)), declare_sensor_masses=False, seed=s),
        "m_H in the rig file off by 3 %": lambda s: RigTruth(
            k_TB=_k(s), file_m_H_factor=1.03 if s % 2 else 0.97, seed=s),
        "frame mode 1-3 % from the housing mode": _frame_near,
        "housing appendage (1-3 % of m_H)": lambda s: RigTruth(
            k_TB=float(_rng(s).uniform(95e6, 160e6)), appendage_fraction=float(_rng(s).uniform(0.01, 0.03)),
            flex_housing_freq=820.0, flex_frame_freq=600.0, seed=s),
        "695 Hz housing mode strong (5-15 kg)": lambda s: RigTruth(
            k_TB=float(_rng(s).uniform(60e6, 110e6)), flex_housing_mass=float(_rng(s).uniform(5.0, 15.0)), seed=s),
        "tilt: sensors off one line, tilt modes 170-265 Hz": _tilt,
        "tilt + sensor masses 4-20 g, declared": lambda s: _tilt(s, sensor_mass=float(_rng(s).uniform(0.004, 0.020))),
    }


def _tilt(s: int, sensor_mass: float = 0.0) -> RigTruth:
    """The tilt class (issue 19): radial housing sensors off one line, both tilt modes in the band,
    the rig file states every housing sensor's position and the housing's rotary inertia (3 %)."""
    r = np.random.default_rng(30_000 + s)
    return TiltRigTruth(k_TB=_k(s), tilt_x_freq=float(r.uniform(170, 210)), tilt_z_freq=float(r.uniform(225, 265)),
                        sensor_mass=sensor_mass, seed=s)


def damping_classes() -> dict[str, Callable[[int], tuple[RigTruth, str, float]]]:
    """(truth, declared damping model, true c_TB or loss factor) per seed."""
    def visc(s: int) -> tuple[RigTruth, str, float]:
        c = float(_rng(s).uniform(300, 2500))
        return RigTruth(k_TB=_k(s), damping="bearing_viscous", c_TB=c, seed=s), "viscous", c

    def hyst(s: int) -> tuple[RigTruth, str, float]:
        eta = float(_rng(s).uniform(0.02, 0.15))
        return RigTruth(k_TB=_k(s), damping="bearing_hysteretic", eta_TB=eta, seed=s), "hysteretic", eta

    return {"viscous dashpot c_TB 300-2500 N s/m": visc, "hysteretic bearing eta 0.02-0.15": hyst}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--only", default=None, help="substring of the class names to run")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--force-chain", type=float, default=None,
                    help="state [uncertainty] force_chain in every rig file (the truth's FRF scale is exact)")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    print("| class | n | ok (no warning, within 2 sigma) | warned | refused | SILENT | median sigma(k_TB) % "
          "| median |bias| % |")
    print("|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        for name, make in classes().items():
            if args.only and args.only not in name:
                continue
            rows = [_run(t, "c", _fc(make(s), args.force_chain), label=name)[0] for s in range(args.seeds)]
            cnt = {k: sum(r[0] == k for r in rows) for k in ("ok", "warned", "refused", "SILENT")}
            sig = [r[3] for r in rows if r[0] != "refused"]
            bias = [abs(r[1]) for r in rows if r[0] != "refused"]
            print(f"| {name} | {len(rows)} | {cnt['ok']} | {cnt['warned']} | {cnt['refused']} | {cnt['SILENT']} "
                  f"| {np.median(sig) if sig else math.nan:.2f} | {np.median(bias) if bias else math.nan:.2f} |")
            if args.verbose:
                for s, r in enumerate(rows):
                    print(f"|   seed {s} | {r[0]} | bias {r[1]:+.2f} % | z {r[2]:+.2f} | sigma {r[3]:.2f} % | {r[4]} |")
        print()
        print(f"axial stiffness (housing's axial rigid-body mode) within 2 sigma of the truth: {sum(AXIAL)} of "
              f"{len(AXIAL)} runs that report one (classes without sensor masses)")
        if TILT:
            print()
            print("| tilt class | axis | runs | reported | within 2 sigma | median sigma % | max |z| | median |bias| % "
                  "| max |z| of the measured sigma alone |")
            print("|---|---|---|---|---|---|---|---|---|")
            for cname in dict.fromkeys(r[0] for r in TILT):
                for ax in ("x", "z"):
                    rr = [r for r in TILT if r[0] == cname and r[1] == ax]
                    rep = [r for r in rr if r[2]]
                    print(f"| {cname} | {ax} | {len(rr)} | {len(rep)} | {sum(r[3] for r in rep)} "
                          f"| {100 * np.median([r[4] for r in rep]) if rep else math.nan:.2f} "
                          f"| {max((abs(r[5]) for r in rep), default=math.nan):.2f} "
                          f"| {100 * np.median([abs(r[5] * r[4]) for r in rep]) if rep else math.nan:.3f} "
                          f"| {max((abs(r[6]) for r in rep), default=math.nan):.2f} |")
        print()
        print("| damping class | n | within 2 sigma | median sigma % | max sigma % | median |bias| % | warned "
              "| c_TB measured / upper bound | upper bound within 2 of its own sigma |")
        print("|---|---|---|---|---|---|---|---|---|")
        for name, dmake in damping_classes().items():
            if args.only and args.only not in name:
                continue
            inside, sig, bias, warned, measured, bound_in = 0, [], [], 0, 0, 0
            for s in range(args.seeds):
                truth, model, true_val = dmake(s)
                truth = _fc(truth, args.force_chain)
                _, res = _run(t, "d", truth, damping_model=model)
                if res is None or getattr(res, "damping", None) is None:
                    continue
                d = res.damping  # type: ignore[attr-defined]
                val, sd = (d.c_TB, d.c_TB_std) if model == "viscous" else (d.loss_factor, d.loss_factor_std)
                inside += abs(val - true_val) <= 2 * sd
                sig.append(100 * sd / val)
                bias.append(100 * abs(val / true_val - 1))
                warned += bool(res.warnings)  # type: ignore[attr-defined]
                measured += getattr(d, "kind", "upper bound") == "measured"  # before the kind: all bounds
                if model == "viscous":
                    up, up_sd = getattr(d, "c_TB_upper", d.c_TB), getattr(d, "c_TB_upper_std", d.c_TB_std)
                    bound_in += abs(up - true_val) <= 2 * up_sd
                if args.verbose:
                    print(f"|   seed {s} | {val:.4g} vs {true_val:.4g} | z {(val - true_val) / sd:+.2f} "
                          f"| sigma {100 * sd / val:.2f} % | | | {len(res.warnings)} |")  # type: ignore[attr-defined]
            if not sig:
                print(f"| {name} | {args.seeds} | no damping reported | | | | |")
                continue
            print(f"| {name} | {args.seeds} | {inside} | {np.median(sig):.2f} | {np.max(sig):.2f} "
                  f"| {np.median(bias):.2f} | {warned} | {measured} / {len(sig) - measured} "
                  f"| {bound_in if model == 'viscous' else '-'} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
