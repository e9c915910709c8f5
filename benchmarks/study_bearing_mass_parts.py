"""Study (issue 19): sigma(k_TB) where m_H is measured - its parts, its two routes, and what would shrink it.

For the classes of :mod:`study_bearing_truths` whose rig file's ``m_H`` is wrong (sensor masses not
declared, ``m_H`` 3 % off; the independent truths of ``tests/rig_truth.py``), per seed:

* the k_TB budget (``m_H``, ``k_S`` - with its share through the shape route -, ``k_MS``, ``m_F``,
  the rest, model form), each a standard uncertainty in % of k_TB;
* the two measurements of ``m_H`` in % of ``m_H``: the driving-point route (force chain; local fit,
  damping ratio and, without the sensors' positions, the radial sensors' spread), the centre's
  reading's relative std alone (``centre``; shared by both routes), and the shape route
  (:func:`ema_rig.rig.fit.housing_mass_from_ratio`: the ratio's relative calibration with the
  centre's reading, ``k_S``, ``m_S``, ``m_F``, the rest) and the GLS weight of the shape route;
* what-ifs on the same identification (each one tolerance changed, everything else as stated):
  sigma(k_TB) with the force chain stated at 1 %, ``k_S`` at 1 %, ``k_MS`` at 1 % (a calibration),
  ``m_F`` at 2.5 % - which assumed quantity, if measured, would pay.

Usage::

    PYTHONPATH=. python benchmarks/study_bearing_mass_parts.py [--seeds N] [--only NAME]
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import study_bearing_truths as sb  # noqa: E402
from rig_truth import write_case  # noqa: E402

from ema_rig.config import load_rig  # noqa: E402
from ema_rig.io.uff import read_uff58  # noqa: E402
from ema_rig.rig import stiffness as st  # noqa: E402
from ema_rig.rig import uncertainty as un  # noqa: E402
from ema_rig.rig.fit import housing_mass_from_ratio, measured_housing_mass  # noqa: E402

CLASSES = ("sensor masses 4-20 g, not declared", "m_H in the rig file off by 3 %")
WHAT_IF = {"force chain 1 %": ("force_chain", 0.01), "k_S 1 %": ("k_S", 0.01), "k_MS 1 %": ("k_MS", 0.01),
           "m_F 2.5 %": ("m_F", 0.025)}


def _sigma(res: object) -> float:
    return 100 * res.k_TB_std / res.k_TB  # type: ignore[attr-defined]


def _what_if(data: object, rig: object, ident: object, key: str, value: float) -> float:
    if key == "force_chain":
        rig2 = replace(rig, force_chain=value)  # type: ignore[type-var]
    else:
        rig2 = replace(rig, uncertainty={**rig.uncertainty, key: value})  # type: ignore[attr-defined,type-var]
    return _sigma(st.estimate_stiffness(data, rig2, spindle=False, identification=ident))  # type: ignore[arg-type]


def row(data: object, rig: object, res: object) -> dict[str, float]:
    """The parts of one result (see the module docstring); NaN where a route is absent."""
    unc = res.uncertainty  # type: ignore[attr-defined]
    k = unc.k_TB
    out: dict[str, float] = {"f_H": unc.f_H, "total": 100 * unc.k_TB_std / k}
    for n in ("m_H", "k_S", "k_MS", "m_F"):
        out[n] = 100 * sum(t.std for t in unc.terms if t.name == n) / k
    out["rest"] = 100 * math.sqrt(sum(t.std**2 for t in unc.terms if t.kind != "model form"
                                      and t.name not in ("m_H", "k_S", "k_MS", "m_F"))) / k
    out["model form"] = 100 * unc.std_of("model form") / k
    hm = res.housing_mass  # type: ignore[attr-defined]
    nan = math.nan
    out.update({"dp fc": nan, "dp fit": nan, "centre": nan, "shape ratio": nan, "shape k_S": nan, "shape m_S": nan,
                "shape m_F": nan, "shape rest": nan, "w": nan, "source": nan})
    if hm is None:
        return out
    out["dp fc"] = 100 * hm.force_chain
    out["dp fit"] = 100 * hm.modal_mass_std / hm.modal_mass
    params = replace(rig.model, k_MS=unc.k_MS)  # type: ignore[attr-defined]
    rel = {**un.DEFAULT_REL_UNCERTAINTY, **rig.uncertainty}  # type: ignore[attr-defined]
    sr = res.housing_mode.get("spindle_ratio")  # type: ignore[attr-defined]
    n_s = sum(1 for s in rig.sensors if s.role == "spindle" and s.axis == "radial")  # type: ignore[attr-defined]
    n_h = sum(1 for s in rig.sensors if s.role == "housing" and s.axis == "radial")  # type: ignore[attr-defined]
    s_c = un._centre_reading_std(res.identification.modes, rig, res.match.housing_index)  # type: ignore[attr-defined]
    out["centre"] = 100 * s_c
    shape = None if sr is None else housing_mass_from_ratio(
        unc.f_H, float(sr), params, rel, math.hypot(un.ACCEL_CALIBRATION * math.sqrt(1 / n_s + 1 / n_h), s_c))
    if shape is not None:
        sens = shape.sensitivity
        out["shape ratio"] = 100 * abs(sens["ratio"]) * shape.ratio_rel_std
        for n in ("k_S", "m_S", "m_F"):
            out[f"shape {n}"] = 100 * abs(sens[n]) * rel[n]
        out["shape rest"] = 100 * math.sqrt(sum((sens[n] * rel[n]) ** 2 for n in ("k_AS", "k_B")))
        if hm.by_shape is not None:
            u_a = math.hypot(hm.force_chain, hm.modal_mass_std / hm.modal_mass)
            out["w"] = un._shape_weight(unc.f_H, params, rig, u_a, shape,
                                        cov=2 * abs(sens["ratio"]) * s_c**2)[0]
    mm_dp = measured_housing_mass(unc.f_H, hm.modal_mass, params)
    out["dp m_H"] = nan if mm_dp is None else mm_dp
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--only", default=None)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    cols = ("total", "m_H", "k_S", "k_MS", "m_F", "rest", "model form", "dp fc", "dp fit", "centre", "shape ratio",
            "shape k_S", "shape m_S", "shape m_F", "shape rest", "w")
    print("| class | n | " + " | ".join(f"median {c}" for c in cols) + " | "
          + " | ".join(f"median sigma, {w}" for w in WHAT_IF) + " |")
    print("|---|---|" + "---|" * (len(cols) + len(WHAT_IF)))
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        for name in CLASSES:
            if args.only and args.only not in name:
                continue
            make = sb.classes()[name]
            rows, ifs = [], {w: [] for w in WHAT_IF}
            for s in range(args.seeds):
                uff, rig_path = write_case(t, "c", make(s), sb.FREQ)
                rig = load_rig(rig_path)
                data = read_uff58(uff, rig=rig)
                res = st.estimate_stiffness(data, rig, spindle=False)
                rows.append(row(data, rig, res))
                for w, (key, v) in WHAT_IF.items():
                    ifs[w].append(_what_if(data, rig, res.identification, key, v))
            med = {c: float(np.nanmedian([r[c] for r in rows])) for c in cols}
            print(f"| {name} | {len(rows)} | " + " | ".join(f"{med[c]:.2f}" for c in cols) + " | "
                  + " | ".join(f"{np.median(v):.2f}" for v in ifs.values()) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
