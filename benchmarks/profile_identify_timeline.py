"""Profile: when each stage of one default ``identify`` runs, and on which thread (the wall time's critical path).

Wraps the stages of ``profile_identify_stages.py`` (PolyMAX poles, judgement, the completeness test, the
local ML's parts, the LSFD, the noise fits) to record their start and end (``time.perf_counter``, ms from
the start of the call) and the CPU time of the thread that ran them (``time.thread_time``: a stage whose
work runs in a pool shows only its own thread's share). Stages above 3 ms of wall time are listed for the
last of ``--calls`` calls on the 256-output file of ``bench_refine.py`` (100-1000 Hz) or the bundled rig
file. On a loaded machine run it with ``chrt -f 10`` (wall times otherwise mostly measure the queue):

``PYTHONPATH=. chrt -f 10 python benchmarks/profile_identify_timeline.py [256|rig] [--calls 4]``
"""

from __future__ import annotations

import argparse
import functools
import sys
import threading
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", nargs="?", default="256", choices=["256", "rig"])
    ap.add_argument("--calls", type=int, default=4)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    sys.path.insert(0, str(REPO / "benchmarks"))
    from profile_identify_stages import load_case  # beside this script

    import ema_rig.identification.identification as ident
    import ema_rig.identification.ml as ml
    import ema_rig.identification.noise as noise

    events: list[tuple[str, str, float, float, float]] = []

    def wrap(owner: Any, name: str) -> Callable[..., Any]:
        f: Callable[..., Any] = getattr(owner, name)

        @functools.wraps(f)
        def timed(*a: Any, **k: Any) -> Any:
            t0, c0 = time.perf_counter(), time.thread_time()
            try:
                return f(*a, **k)
            finally:
                events.append((name, threading.current_thread().name, t0, time.perf_counter(),
                               time.thread_time() - c0))

        setattr(owner, name, timed)
        return timed

    for name in ("_local_ml_staged", "_lsfd_at", "_misfit_at", "_lsfd_checked", "judge_clusters", "diagnose_frf",
                 "_split", "segment_misfit", "_fit_modes", "_complete"):
        wrap(ident, name)
    ml.fit_noise_model = wrap(noise, "fit_noise_model")  # the ML's own reference to it
    for name in ("_whole_basis", "_segment_tail", "_lm"):
        wrap(ml, name)
    wrap(sys.modules["ema_rig.identification.plscf"].PlscfEngine, "poles")
    data, band = load_case(args.case)
    for _ in range(args.calls):
        events.clear()
        t_start = time.perf_counter()
        ident.identify(data, band=band)
        t_end = time.perf_counter()
    print(f"{args.case}: identify {1e3 * (t_end - t_start):.0f} ms wall (the last of {args.calls} calls)")
    print(f"{'stage':18s} {'thread':22s} {'start':>7s} {'end':>7s} {'wall':>6s} {'CPU':>6s}  [ms]")
    for name, thread, t0, t1, cpu in sorted(events, key=lambda e: e[2]):
        if t1 - t0 > 3e-3:
            print(f"{name:18s} {thread[-22:]:22s} {1e3 * (t0 - t_start):7.1f} {1e3 * (t1 - t_start):7.1f} "
                  f"{1e3 * (t1 - t0):6.1f} {1e3 * cpu:6.1f}")


if __name__ == "__main__":
    main()
