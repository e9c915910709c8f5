"""Study: c_TB's measured share and k_TB's damping terms where the spindle's support damps too.

Truths from ``tests/rig_truth.py`` (imports nothing from ema_rig): a bearing dashpot (housing
zeta 3 or 8 % on k_TB+MS) plus the structure's stiffness-proportional damping (zeta 0.3, 0.6,
1 % at 600 Hz on every spring of the rig, the spindle's support k_S included), k_TB 6e7, 2e8,
6e8 N/m, the rig file's tolerances as written or tightened to 1e-4. Per truth: c_TB's kind, the
share used, c_TB and k_TB against the truth with z = error / sigma, the number of warnings.

Usage::

    nice -n 19 python benchmarks/study_share_span.py TREE   # TREE: the ema_rig checkout to import
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path


def main(tree: str) -> int:
    sys.path.insert(0, tree)
    sys.path.insert(0, str(Path(tree) / "tests"))
    import numpy as np
    from rig_truth import TABLE1, RigTruth, tighten_tolerances, write_case

    from ema_rig.config import load_rig
    from ema_rig.io.uff import read_uff58
    from ema_rig.rig import stiffness as st

    freq = np.arange(0.0, 1100.25, 0.5)
    tmp = Path(tempfile.mkdtemp())
    for sz in (0.003, 0.006, 0.01):
        for k_tb in (6e7, 2e8, 6e8):
            for zeta in (0.03, 0.08):
                for tight in (False, True):
                    ks = 1 / (1 / k_tb + 1 / TABLE1["k_MS"])
                    c = 2 * zeta * math.sqrt(ks * TABLE1["m_H"]) / (ks / k_tb) ** 2
                    t = RigTruth(k_TB=k_tb, damping="bearing_viscous", c_TB=c, structural_zeta=sz, seed=5)
                    uff, rp = write_case(tmp, "g", t, freq)
                    if tight:
                        tighten_tolerances(rp)
                    rig = load_rig(rp)
                    r = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)
                    d = r.damping
                    share = "-" if d is None or d.share is None else f"{d.share:.3f}"
                    print(f"| {sz:.3f} | {k_tb:.0e} | {zeta:.2f} | {int(tight)} | {d.kind if d else '-'} | {share} | "
                          f"{r.c_TB:.1f} | {c:.1f} | {100 * (r.c_TB / c - 1):+.1f} | {100 * r.c_TB_std / r.c_TB:.1f} | "
                          f"{(r.c_TB - c) / r.c_TB_std:+.2f} | {100 * (r.k_TB / k_tb - 1):+.2f} | "
                          f"{100 * r.k_TB_std / r.k_TB:.2f} | {(r.k_TB - k_tb) / r.k_TB_std:+.2f} | {len(r.warnings)} |",
                          flush=True)
    return 0


if __name__ == "__main__":
    print("| structure zeta | k_TB | bearing zeta | tight | c_TB kind | share | c_TB | c_TB true | err % | sigma % | z "
          "| k_TB err % | k_TB sigma % | k_TB z | warnings |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    raise SystemExit(main(sys.argv[1] if len(sys.argv) > 1 else str(Path(__file__).resolve().parents[1])))
