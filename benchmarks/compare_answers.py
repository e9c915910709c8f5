"""Check: the default ``identify`` of this tree gives the same answers, byte for byte, as another run.

Collects, for the bundled files (``data/*.uff``, the b6302 ones also at 150-1000 Hz), the 256-output
file of ``bench_refine.py``, vt_case1_full at four bands and dam0 at three (from ``../shared/real-frf``):
poles, residues, residual terms, standard uncertainties and their kinds, warnings, notes, fit errors,
the completeness test's variance, the candidates with their verdicts and reasons. Run it in two trees
(or with two BLAS thread counts) and compare (the shared folder: ``EMA_RIG_SHARED`` or ``../shared``):

``PYTHONPATH=. python benchmarks/compare_answers.py collect /tmp/a.pkl [SHARED]`` (in each tree), then
``python benchmarks/compare_answers.py compare /tmp/a.pkl /tmp/b.pkl`` (prints every difference).
"""

from __future__ import annotations

import glob
import os
import pickle
import sys
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent


def collect(out: Path, shared: Path) -> None:
    warnings.simplefilter("ignore")
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_refine import synthetic_256

    from ema_rig.identification import identify
    from ema_rig.io.uff import read_uff58

    cases: list[tuple[str, tuple[float, float] | None]] = []
    for p in sorted(glob.glob(str(REPO / "data" / "*.uff"))):
        cases.append((p, None))
        if "b6302" in p:
            cases.append((p, (150.0, 1000.0)))
    syn = Path(tempfile.gettempdir()) / "ema_rig_compare_answers_256.uff"  # one path: the model's meta names it
    if not syn.exists():
        synthetic_256(syn)
    cases.append((str(syn), (100.0, 1000.0)))
    cases += [(str(shared / "real-frf" / "vt_case1_full.uff"), b) for b in ((10, 300), (20, 400), (0, 500), (25, 250))]
    cases += [(str(shared / "real-frf" / "dam0.unv"), b) for b in ((1, 12), (1.5, 11.5), (2, 12.4))]
    res: dict[str, Any] = {}
    for p, b in cases:
        key = f"{Path(p).name} {b}"
        try:
            i = identify(read_uff58(p), band=b)
        except Exception as exc:  # recorded: the other run must fail the same way
            res[key] = repr(exc)
        else:
            m = i.modes
            res[key] = {"poles": m.poles, "residues": m.residues, "lower": m.lower_residual, "upper": m.upper_residual,
                        "f_std": i.natural_freq_std, "z_std": i.damping_ratio_std, "kind": i.std_kind,
                        "warnings": i.warnings, "notes": i.notes, "fit": m.fit_error,
                        "meta": repr(sorted(m.meta.items())),
                        "variance": None if i.residual_test is None else i.residual_test.variance,
                        "candidates": [(c.natural_freq, c.accepted, c.reason) for c in i.candidates]}
        print(key, "ok" if isinstance(res[key], dict) else res[key], flush=True)
    import ema_rig

    print("ema_rig from", ema_rig.__file__)
    with open(out, "wb") as fh:
        pickle.dump(res, fh)


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        a, b = np.asarray(a), np.asarray(b)
        return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()
    if isinstance(a, (list, tuple)):
        return isinstance(b, (list, tuple)) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return bool(a == b)


def compare(a_path: Path, b_path: Path) -> int:
    with open(a_path, "rb") as fa, open(b_path, "rb") as fb:
        a_all, b_all = pickle.load(fa), pickle.load(fb)
    bad = 0
    for key, a in a_all.items():
        b = b_all.get(key)
        if isinstance(a, str) or isinstance(b, str) or b is None:
            if a != b:
                bad += 1
                print("differs:", key, a if isinstance(a, str) else "ok", "|", b if isinstance(b, str) else b and "ok")
            continue
        for field, value in a.items():
            if not _same(value, b[field]):
                bad += 1
                print("differs:", key, field)
    print(f"{len(a_all)} cases, {bad} differences")
    return bad


if __name__ == "__main__":
    if len(sys.argv) >= 3 and sys.argv[1] == "collect":
        collect(Path(sys.argv[2]), Path(sys.argv[3]) if len(sys.argv) > 3 else Path(os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared")))
    elif len(sys.argv) == 4 and sys.argv[1] == "compare":
        sys.exit(1 if compare(Path(sys.argv[2]), Path(sys.argv[3])) else 0)
    else:
        sys.exit(__doc__)
