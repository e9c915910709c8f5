"""Benchmark: the bundled rig files at 1200/1800/2400 rpm with their shaft speed, this tree against another.

``identify`` (150-1000 Hz, ``data/rig.toml``) and ``estimate_stiffness(..., speed_hz=rpm / 60)`` of
``data/b6302_1000N_<rpm>rpm.uff``. In this tree a shaft speed leaves the lines of its harmonics
(``ema_rig.rig.candidates.harmonic_bands``) out of the split test's own-lines test; the baseline
tree has no such keyword and identifies without it. Two long-lived worker processes, one per tree,
asked in alternating order (A B, B A, ...); CPU time (``time.process_time``) with one BLAS thread.
The answers (modes, k_TB and its sigma, warnings, notes) of both trees are printed side by side
and compared.

Run: ``python benchmarks/bench_harmonics.py --baseline /tmp/base [--repeat 7]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

from _timing import ask_worker, close_workers, git_head  # benchmarks/_timing.py, beside this script

REPO = Path(__file__).resolve().parent.parent
RPMS = (1200, 1800, 2400)

WORKER = r"""
import inspect, json, sys, time, warnings
warnings.simplefilter("ignore")
from ema_rig.config import load_rig
from ema_rig.identification import identify
from ema_rig.io.uff import read_uff58
from ema_rig.rig.stiffness import estimate_stiffness
repo = sys.argv[1]
rig = load_rig(repo + "/data/rig.toml")
band = (150.0, 1000.0)
data = {r: read_uff58(f"{repo}/data/b6302_1000N_{r}rpm.uff", rig=rig) for r in (1200, 1800, 2400)}
kw = {}
if "harmonic_bands" in inspect.signature(identify).parameters:
    from ema_rig.rig.candidates import harmonic_bands
    from ema_rig.rig.matching import MATCH_CRITERIA as c
    kw = {r: {"harmonic_bands": harmonic_bands(band, r / 60.0, c.harmonic_freq_tol, c.harmonic_min_order)}
          for r in data}
identify(data[1200], band=band)  # warm-up
import ema_rig
print("ready", ema_rig.__file__, flush=True)
for line in sys.stdin:
    what, r = line.split()
    r = int(r)
    run = ((lambda: identify(data[r], band=band, **kw.get(r, {}))) if what == "identify"
           else (lambda: estimate_stiffness(data[r], rig, speed_hz=r / 60.0, band=band)))
    t0, c0 = time.perf_counter(), time.process_time()
    out = run()
    t1, c1 = time.perf_counter() - t0, time.process_time() - c0
    if what == "answer":
        i = identify(data[r], band=band, **kw.get(r, {}))
        ans = {"modes": [(float(a), float(b)) for a, b in zip(i.natural_freq, i.damping_ratio)],
               "std": [float(a) for a in i.natural_freq_std], "ident_warnings": list(i.warnings),
               "ident_notes": list(i.notes), "k_TB": out.k_TB, "k_TB_std": out.k_TB_std,
               "housing_freq": out.housing_mode["natural_freq"], "warnings": list(out.warnings),
               "notes": list(out.notes)}
        print(json.dumps(ans), flush=True)
    else:
        print(f"{t1:.6f} {c1:.6f}", flush=True)
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", required=True, type=Path)
    ap.add_argument("--repeat", type=int, default=7)
    args = ap.parse_args()
    one = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    procs = {}
    for tag, tree in (("new", REPO), ("old", args.baseline.resolve())):
        # cwd=tree: ``python -c`` puts the working directory first on sys.path, before PYTHONPATH
        procs[tag] = subprocess.Popen([sys.executable, "-c", WORKER, str(REPO)], text=True, stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, cwd=str(tree),
                                      env=dict(os.environ, PYTHONPATH=str(tree), **one))
    for tag, p in procs.items():
        assert p.stdout is not None
        ready, where = p.stdout.readline().split()
        tree = REPO if tag == "new" else args.baseline.resolve()
        assert ready == "ready" and Path(where).resolve().is_relative_to(tree), (tag, where)
    print(f"# {time.strftime('%Y-%m-%dT%H:%MZ', time.gmtime())}: new = {REPO} @ {git_head(REPO)}, "
          f"old = {args.baseline} @ {git_head(args.baseline)}; {os.cpu_count()} cores, one BLAS thread; "
          f"load average at start {os.getloadavg()[0]:.1f}")
    same = True
    for r in RPMS:
        answers = {}
        for tag, p in procs.items():
            assert p.stdin is not None and p.stdout is not None
            p.stdin.write(f"answer {r}\n")
            p.stdin.flush()
            answers[tag] = p.stdout.readline()
        eq = answers["old"] == answers["new"]
        same &= eq
        print(f"{r} rpm: answers (modes, std, k_TB, sigma, warnings, notes) {'identical' if eq else 'DIFFER'}")
        if not eq:
            print("  old:", answers["old"].strip())
            print("  new:", answers["new"].strip())
    print(f"{'case':28s} {'old CPU [s]':>22s} {'new CPU [s]':>22s} {'new/old':>18s}")
    for what in ("identify", "stiffness"):
        for r in RPMS:
            t: dict[str, list[float]] = {"old": [], "new": []}
            for i in range(args.repeat):
                for tag in (("old", "new") if i % 2 == 0 else ("new", "old")):
                    t[tag].append(ask_worker(procs[tag], f"{what} {r}")[1])

            def fmt(x: list[float], f: str = ".3f") -> str:
                return f"{statistics.median(x):{f}} ({min(x):{f}}-{max(x):{f}})"

            ratio = [b / a for a, b in zip(t["old"], t["new"], strict=True)]
            print(f"{what + ' ' + str(r) + ' rpm':28s} {fmt(t['old']):>22s} {fmt(t['new']):>22s} "
                  f"{fmt(ratio, '.2f'):>18s}  (load average now {os.getloadavg()[0]:.1f})", flush=True)
    close_workers(procs.values())
    if not same:
        raise SystemExit("the answers differ")


if __name__ == "__main__":
    main()
