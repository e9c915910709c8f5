"""Benchmark: ema_rig's own threads inside the default ``identify``, switched one by one, in one process.

The switches are the module constants that decide whether a stage hands work to a second thread (none
changes a number: every task is joined in a fixed order, ``tests/test_threads_same_answer.py``):

* ``noise``: ``noise._NOISE_THREADS`` (2: the noise fit's blocks of ``_NOISE_THREAD_BLOCK`` channels in a pool);
* ``misfit``: ``noise._MISFIT_THREAD_MIN_VALUES`` (100 000: the completeness test's segments in two threads);
* ``ml``: ``ml._THREAD_MIN_EQUATIONS`` (20 000: the ML's scores and whole-basis fits in a second thread);
* ``at_poles``: ``identification._AT_POLES_THREAD_MIN_VALUES`` (the completeness test beside the ML's join);
* ``diagnose``: ``identification._DIAGNOSE_THREAD_MIN_LINES`` (the FRF diagnosis beside PolyMAX).

Each variant (``default``: the module's values; ``+name``: that switch on at the value above; ``-name``: off;
``all_off``) runs ``identify`` on the 256-output file of ``bench_refine.py`` (100-1000 Hz) or the bundled rig
file, in alternating order (A B C, C B A, ...), wall and CPU time (all threads) per call, median and range.
On a loaded machine run it with ``chrt -f 10`` (two cores for the process: what a quiet machine gives) and
without (what the queue gives), one BLAS thread as inside the stages:

``OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/bench_identify_threads.py [256|rig] [--repeat 20]
[--variants default,+noise,+ml,+misfit,all_off]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
OFF = 10**15
ON = {"noise": 2, "misfit": 100_000, "ml": 20_000}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", nargs="?", default="256", choices=["256", "rig"])
    ap.add_argument("--repeat", type=int, default=20)
    ap.add_argument("--variants", default="default,+noise,+ml,+misfit,+ml+misfit+noise,all_off")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    sys.path.insert(0, str(REPO / "benchmarks"))
    from profile_identify_stages import load_case  # beside this script

    import ema_rig.identification.identification as ident
    import ema_rig.identification.ml as ml
    import ema_rig.identification.noise as noise

    default = {"noise": noise._NOISE_THREADS, "misfit": noise._MISFIT_THREAD_MIN_VALUES,
               "ml": ml._THREAD_MIN_EQUATIONS, "at_poles": ident._AT_POLES_THREAD_MIN_VALUES,
               "diagnose": ident._DIAGNOSE_THREAD_MIN_LINES}

    def settings(name: str) -> dict[str, int]:
        if name == "default":
            return dict(default)
        if name == "all_off":
            return {"noise": 1, "misfit": OFF, "ml": OFF, "at_poles": OFF, "diagnose": OFF}
        out = dict(default)
        for part in name.replace("-", " -").replace("+", " +").split():
            key = part[1:]
            out[key] = (ON.get(key, default[key]) if part[0] == "+" else (1 if key == "noise" else OFF))
        return out

    def apply(s: dict[str, int]) -> None:
        noise._NOISE_THREADS, noise._MISFIT_THREAD_MIN_VALUES = s["noise"], s["misfit"]
        ml._THREAD_MIN_EQUATIONS = s["ml"]
        ident._AT_POLES_THREAD_MIN_VALUES, ident._DIAGNOSE_THREAD_MIN_LINES = s["at_poles"], s["diagnose"]

    names = args.variants.split(",")
    data, band = load_case(args.case)
    for _ in range(2):
        ident.identify(data, band=band)
    res: dict[str, list[tuple[float, float]]] = {n: [] for n in names}
    for i in range(args.repeat):
        for n in names if i % 2 == 0 else names[::-1]:
            apply(settings(n))
            t0, c0 = time.perf_counter(), time.process_time()
            ident.identify(data, band=band)
            res[n].append((time.perf_counter() - t0, time.process_time() - c0))
    apply(default)
    print(f"{args.case}: {args.repeat} alternating calls per variant; load average {os.getloadavg()[0]:.1f}")
    for n, v in res.items():
        w, c = [x[0] * 1e3 for x in v], [x[1] * 1e3 for x in v]
        print(f"{n:24s} wall {statistics.median(w):6.1f} ms ({min(w):.1f}-{max(w):.1f})  "
              f"cpu {statistics.median(c):6.1f} ms ({min(c):.1f}-{max(c):.1f})")


if __name__ == "__main__":
    main()
