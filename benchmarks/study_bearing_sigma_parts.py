"""Study (issue 19): what sigma(k_TB) is made of, per class of ``study_bearing_truths.py``.

For every class and seed of :mod:`study_bearing_truths` (the independent truths of
``tests/rig_truth.py``), the k_TB budget split by kind (measured / assumed / model form) and by
input (m_H, k_MS, k_S, the rest, the model-form terms), each as a standard uncertainty in % of
k_TB, and where the inverted m_H came from. Medians over the seeds.

Usage::

    PYTHONPATH=. python benchmarks/study_bearing_sigma_parts.py [--seeds N] [--only NAME] [--force-chain U]

Point PYTHONPATH at another checkout to decompose "before" (the truths and this script stay this
tree's).
"""

from __future__ import annotations

import argparse
import math
import sys
import tempfile
import warnings
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import study_bearing_truths as sb  # noqa: E402
from rig_truth import write_case  # noqa: E402

from ema_rig.config import load_rig  # noqa: E402
from ema_rig.errors import EmaRigError  # noqa: E402
from ema_rig.io.uff import read_uff58  # noqa: E402
from ema_rig.rig import stiffness as st  # noqa: E402

KINDS = ("measured", "assumed (rig file)", "model form")
NAMED = ("m_H", "k_MS", "k_S")


def parts(res: object) -> dict[str, float]:
    """Standard uncertainty per kind and per named input, in % of k_TB."""
    unc = res.uncertainty  # type: ignore[attr-defined]
    k = unc.k_TB
    out = {"total": 100 * unc.k_TB_std / k}
    for kind in KINDS:
        out[kind] = 100 * math.sqrt(sum(t.std**2 for t in unc.terms if t.kind == kind)) / k
    for n in NAMED:
        out[n] = 100 * sum(t.std for t in unc.terms if t.name == n) / k
    out["other params"] = 100 * math.sqrt(sum(t.std**2 for t in unc.terms if t.kind != "model form"
                                              and t.name not in (*NAMED, "f_H"))) / k
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--only", default=None)
    ap.add_argument("--force-chain", type=float, default=None)
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")
    cols = ("total", *KINDS, *NAMED, "other params")
    print("| class | " + " | ".join(f"median {c} %" for c in cols) + " | largest model-form terms | m_H from |")
    print("|---|" + "---|" * (len(cols) + 2))
    with tempfile.TemporaryDirectory() as tmp:
        t = Path(tmp)
        for name, make in sb.classes().items():
            if args.only and args.only not in name:
                continue
            rows, mf, src = [], Counter(), Counter()
            for s in range(args.seeds):
                truth = sb._fc(make(s), args.force_chain)
                uff, rig_path = write_case(t, "c", truth, sb.FREQ)
                try:
                    rig = load_rig(rig_path)
                    res = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)
                except EmaRigError:
                    continue
                rows.append(parts(res))
                for term in res.uncertainty.terms:
                    if term.kind == "model form" and term.std / res.k_TB > 0.005:
                        mf[term.name.split(" ")[0] if term.name.startswith("neighbour") else term.name] += 1
                hm = getattr(res, "housing_mass", None)
                src[hm.source if hm is not None else
                    ("rig file, widened" if res.uncertainty.term("m_H").rel_input > 0.0051 else "rig file")] += 1
            med = {c: float(np.median([r[c] for r in rows])) for c in cols}
            top = ", ".join(f"{k} x{v}" for k, v in mf.most_common(3)) or "-"
            print(f"| {name} | " + " | ".join(f"{med[c]:.2f}" for c in cols) + f" | {top} | "
                  + ", ".join(f"{k} x{v}" for k, v in src.most_common()) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
