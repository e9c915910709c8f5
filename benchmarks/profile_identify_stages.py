"""Profile: CPU per stage of the default ``identify`` (ms per call), without cProfile's overhead.

The stages of :func:`ema_rig.identification.identify` (PolyMAX poles, stabilization, judgement, the
completeness test with LSFD and the local ML, the reported residues) are wrapped with
``time.process_time`` counters (inclusive: a stage's time holds its sub-stages'), on the two files of
``bench_default_ml.py``: the bundled rig file (150-1000 Hz) and the 256-output synthetic file of
``bench_refine.py`` (100-1000 Hz). Run it with one BLAS thread for numbers that do not depend on
the machine's other load:

``OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/profile_identify_stages.py [rig|256] [--repeat 10] [--one-thread] [--wall]``

``--wall`` counts wall time (``time.perf_counter``) per stage instead: where the caller waits, at the
default BLAS setting (on a loaded machine it mostly measures waiting for a core).

The counters take the CPU time of the process: a stage that runs while another thread works (the
noise fit's blocks, the local ML's second thread, the completeness test's segments, the data's
findings, the LSFD at the ML poles with its completeness test beside the ML's join) is charged that
thread's time too. ``--one-thread`` switches those threads off (their work-size thresholds raised
above the data, identify's own tasks run when created; the answers are the same to the bit) so that each
stage's own work is what its counter shows.
"""

from __future__ import annotations

import argparse
import functools
import sys
import tempfile
import time
import warnings
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent

STAGES = {
    "ema_rig.identification.identification": ["_complete", "_fit_modes", "_local_ml_staged", "_lsfd_at", "_misfit_at", "_lsfd_checked",
                                              "_reported_model", "judge_clusters", "stabilize", "cluster_poles",
                                              "diagnose_frf", "_split", "_split_start", "_parsimonious",
                                              "_skirt_warnings", "segment_misfit", "_one_line"],
    # the noise fit inside the completeness test; the judge's LSFD
    "ema_rig.identification.noise": ["fit_noise_model"],
    "ema_rig.identification.judge": ["_fit"],
    # inside the local ML: the segments' fits, their scores and covariances, the whole-basis (model-form) refits
    "ema_rig.identification.ml": ["_lm", "_segment_tail", "_whole_basis"],
}


def load_case(case: str) -> tuple[Any, tuple[float, float]]:
    """The data and band of ``case``: "256" (the 256-output file of ``bench_refine.py``, 100-1000 Hz) or "rig"
    (the bundled rig file, 150-1000 Hz)."""
    from ema_rig.config import load_rig
    from ema_rig.io.uff import read_uff58

    if case == "256":
        sys.path.insert(0, str(REPO / "benchmarks"))
        from bench_refine import synthetic_256

        path = Path(tempfile.mkdtemp()) / "synthetic_256.uff"
        synthetic_256(path)
        return read_uff58(path), (100.0, 1000.0)
    return read_uff58(REPO / "data" / "b6302_1000N_1200rpm.uff", rig=load_rig(REPO / "data" / "rig.toml")), (150.0, 1000.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", choices=["rig", "256"])
    ap.add_argument("--repeat", type=int, default=10)
    ap.add_argument("--one-thread", action="store_true", help="switch off ema_rig's own worker threads")
    ap.add_argument("--thread-clock", action="store_true",
                    help="count the CPU time of the calling thread only (the work left on the path the caller waits "
                         "for; on an idle machine the rest runs beside it)")
    ap.add_argument("--wall", action="store_true",
                    help="count wall time per stage (perf_counter) instead of CPU time: where the caller waits")
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    sys.path.insert(0, str(REPO / "benchmarks"))
    import ema_rig.identification.identification  # noqa: F401  (the module, not the package's function)
    import ema_rig.identification.judge  # noqa: F401
    import ema_rig.identification.ml  # noqa: F401
    import ema_rig.identification.noise  # noqa: F401
    import ema_rig.identification.plscf  # noqa: F401
    clock = time.perf_counter if args.wall else time.thread_time if args.thread_clock else time.process_time
    acc: dict[str, float] = defaultdict(float)
    cnt: dict[str, int] = defaultdict(int)

    def wrap(owner: Any, name: str, label: str) -> None:
        f: Callable[..., Any] = getattr(owner, name)

        @functools.wraps(f)
        def timed(*a: Any, **k: Any) -> Any:
            t = clock()
            try:
                return f(*a, **k)
            finally:
                acc[label] += clock() - t
                cnt[label] += 1

        setattr(owner, name, timed)

    for mod, names in STAGES.items():
        for n in names:
            wrap(sys.modules[mod], n, n)
    plscf = sys.modules["ema_rig.identification.plscf"]
    wrap(plscf.PlscfEngine, "poles", "PolyMAX poles")
    wrap(plscf.PlscfEngine, "__init__", "PolyMAX setup")
    wrap(sys.modules["ema_rig.identification.ml"]._Segment, "_scores", "ML scores")
    ident = sys.modules["ema_rig.identification.identification"]
    if args.one_thread:
        noise, ml = sys.modules["ema_rig.identification.noise"], sys.modules["ema_rig.identification.ml"]
        noise._NOISE_THREADS = 1
        noise._MISFIT_THREAD_MIN_VALUES = ml._THREAD_MIN_EQUATIONS = ident._DIAGNOSE_THREAD_MIN_LINES = 10**15
        from ema_rig._threads import Job

        # identify's own second thread (the LSFD at the ML poles and the completeness test beside the
        # ML's join): run by the caller when it is created
        ident.Job = lambda task, pool, **kw: Job(task, None, **kw)
    data, band = load_case(args.case)
    ident.identify(data, band=band)
    acc.clear()
    cnt.clear()
    t0, c0, m0 = time.perf_counter(), time.process_time(), time.thread_time()
    for _ in range(args.repeat):
        ident.identify(data, band=band)
    wall = (time.perf_counter() - t0) / args.repeat * 1e3
    cpu = (time.process_time() - c0) / args.repeat * 1e3
    main_cpu = (time.thread_time() - m0) / args.repeat * 1e3
    print(f"{args.case}{' (ema_rig threads off)' if args.one_thread else ''}: identify {cpu:.1f} ms CPU, of it "
          f"{main_cpu:.1f} ms in the calling thread ({wall:.1f} ms wall) per call; stages, "
          f"{'wall' if args.wall else ('calling-thread ' if args.thread_clock else '') + 'CPU'} ms per identify (inclusive):")
    for k, v in sorted(acc.items(), key=lambda kv: -kv[1]):
        print(f"  {k:20s} {v / args.repeat * 1e3:8.1f}  ({cnt[k] / args.repeat:.1f} calls)")


if __name__ == "__main__":
    main()
