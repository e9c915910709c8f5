"""Study: do the modes of the real files depend on the OpenBLAS kernel? (issue 18 item 1)

Every real measurement in ../shared (``real-frf/`` and ``uff-corpus/``) goes through
``ema-rig modes FILE --json OUT`` twice in fresh processes: with the default OpenBLAS kernel of
the machine and with ``OPENBLAS_CORETYPE=Haswell``. The two pole sets are compared as sets: each
mode is paired with the nearest mode of the other run (mutual nearest in frequency); reported are
the modes without a partner, and for the pairs the largest difference of natural frequency and
damping ratio in units of the first run's standard uncertainty and relative. Files that ``modes``
refuses (time data, no stable pole ...) are listed with their exit code (the same in both runs is
what matters).

Run: ``python benchmarks/study_kernel_dependence.py [--tree DIR] [--kernel Haswell]`` (``--tree``:
another checkout to study, e.g. the commit before a fix).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
SHARED = Path(os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared"))
BANDS = {"dam0.unv": ("1", "12")}  # the band the tests and the issue use


def _files() -> list[Path]:
    real = sorted((SHARED / "real-frf").glob("*.u*"))
    corpus = sorted(p for p in (SHARED / "uff-corpus").glob("*") if p.suffix in (".uff", ".unv", ".frf", ".ufb"))
    return real + corpus


def _modes(tree: Path, f: Path, out: Path, kernel: str | None) -> tuple[int, dict | None]:
    env = dict(os.environ, PYTHONPATH=str(tree), MPLBACKEND="Agg")
    env.pop("OPENBLAS_CORETYPE", None)
    if kernel:
        env["OPENBLAS_CORETYPE"] = kernel
    cmd = [sys.executable, "-m", "ema_rig.cli", "modes", str(f), "--json", str(out)]
    if f.name in BANDS:
        cmd += ["--band", *BANDS[f.name]]
    # cwd: ``python -m`` puts the working directory first on sys.path, before PYTHONPATH
    run = subprocess.run(cmd, env=env, cwd=tree, capture_output=True, text=True, timeout=900)
    return run.returncode, (json.loads(out.read_text()) if run.returncode == 0 and out.exists() else None)


def _compare(a: dict, b: dict) -> str:
    fa = np.array([m["natural_freq"] for m in a["modes"]])
    fb = np.array([m["natural_freq"] for m in b["modes"]])
    if fa.size == 0 or fb.size == 0:
        return f"{fa.size} vs {fb.size} modes"
    ia = np.argmin(np.abs(fa[:, None] - fb[None, :]), axis=1)
    ib = np.argmin(np.abs(fb[:, None] - fa[None, :]), axis=1)
    pairs = [(i, int(j)) for i, j in enumerate(ia) if ib[j] == i]
    lone = (fa.size - len(pairs), fb.size - len(pairs))
    zf, zz, rel = [], [], []
    for i, j in pairs:
        ma, mb = a["modes"][i], b["modes"][j]
        df = abs(ma["natural_freq"] - mb["natural_freq"])
        dz = abs(ma["damping_ratio"] - mb["damping_ratio"])
        sf, sz = ma.get("natural_freq_std") or np.nan, ma.get("damping_ratio_std") or np.nan
        zf.append(df / sf if sf > 0 else np.inf if df else 0.0)
        zz.append(dz / sz if sz > 0 else np.inf if dz else 0.0)
        rel.append(df / ma["natural_freq"])
    k = int(np.argmax(zf))
    return (f"{fa.size} vs {fb.size} modes, without partner {lone[0]}/{lone[1]}; max |df| {max(zf):.2g} sigma "
            f"(at {a['modes'][pairs[k][0]]['natural_freq']:.5g} Hz, relative {rel[k]:.1e}), max relative "
            f"{max(rel):.1e}; max |dzeta| {max(zz):.2g} sigma")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--tree", type=Path, default=REPO)
    ap.add_argument("--kernel", default="Haswell")
    args = ap.parse_args()
    print(f"tree {args.tree.resolve()}; default OpenBLAS kernel vs OPENBLAS_CORETYPE={args.kernel}; "
          f"load average {os.getloadavg()[0]:.1f}")
    with tempfile.TemporaryDirectory() as tmp:
        for f in _files():
            ra, a = _modes(args.tree, f, Path(tmp) / "a.json", None)
            rb, b = _modes(args.tree, f, Path(tmp) / "b.json", args.kernel)
            name = f"{f.parent.name}/{f.name}"
            if a is None or b is None:
                print(f"{name:45s} exit {ra} / {rb}" + ("" if ra == rb else "  DIFFERENT EXIT"), flush=True)
            else:
                print(f"{name:45s} {_compare(a, b)}", flush=True)


if __name__ == "__main__":
    main()
