"""Benchmark: the noise fit's blocks in one thread or two, by block size (``_NOISE_THREAD_MIN_VALUES``,
``_NOISE_THREAD_BLOCK`` of ``ema_rig/identification/noise.py``).

The arguments of the two 256-channel noise fits of the default ``identify`` on the 256-output file of
``bench_refine.py`` (the ML's, on the start model's residual, and the completeness test's, with its
mask) are recorded once; then both fits are timed (wall and CPU, median of ``--repeat``) with the
threads off (blocks of ``_NOISE_BLOCK``) and on with blocks of 32, 64 and 128 channels, and each
result is checked to be the one-thread result to the bit. Inside identify's ML stage BLAS has one
thread; run it so (an idle OpenBLAS pool spins on the other core after each product):

``OPENBLAS_NUM_THREADS=1 PYTHONPATH=. python benchmarks/bench_noise_threads.py [--repeat 15]``
"""

from __future__ import annotations

import argparse
import os
import statistics
import sys
import tempfile
import time
import warnings
from pathlib import Path
from typing import Any

import numpy as np

REPO = Path(__file__).resolve().parent.parent


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=15)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    sys.path.insert(0, str(REPO / "benchmarks"))
    from bench_refine import synthetic_256

    import ema_rig.identification.ml as ml
    import ema_rig.identification.noise as noise
    from ema_rig.identification import identify
    from ema_rig.io.uff import read_uff58

    path = Path(tempfile.mkdtemp()) / "synthetic_256.uff"
    synthetic_256(path)
    calls: list[tuple[tuple[Any, ...], dict[str, Any]]] = []
    fit = noise.fit_noise_model

    def record(*a: Any, **k: Any) -> Any:
        if np.shape(a[0])[0] == 256:
            calls.append((tuple(np.array(x) for x in a), {n: np.array(v) for n, v in k.items()}))
        return fit(*a, **k)

    noise.fit_noise_model = ml.fit_noise_model = record  # type: ignore[assignment]
    identify(read_uff58(path), band=(100.0, 1000.0))
    noise.fit_noise_model = ml.fit_noise_model = fit  # type: ignore[assignment]
    print(f"{len(calls)} fits of shape {[c[0][0].shape for c in calls]}; BLAS threads "
          f"{os.environ.get('OPENBLAS_NUM_THREADS', 'default')}; load average {os.getloadavg()[0]:.1f}")

    noise._NOISE_THREADS = 2  # the pool (off by default); the threshold below decides whether it runs

    def run(threshold: int, block: int) -> tuple[list[Any], float, float]:
        noise._NOISE_THREAD_MIN_VALUES, noise._NOISE_THREAD_BLOCK = threshold, block
        out = [fit(*a, **k) for a, k in calls]
        wall, cpu = [], []
        for _ in range(args.repeat):
            t0, c0 = time.perf_counter(), time.process_time()
            for a, k in calls:
                fit(*a, **k)
            wall.append(time.perf_counter() - t0)
            cpu.append(time.process_time() - c0)
        return out, statistics.median(wall), statistics.median(cpu)

    ref, _, _ = run(10**15, 128)
    for label, threshold, block in (("one thread, blocks of 32", 10**15, 128), ("two threads, blocks of 32", 1, 32),
                                    ("two threads, blocks of 64", 1, 64), ("two threads, blocks of 128", 1, 128)):
        out, wall, cpu = run(threshold, block)
        same = all(np.array_equal(x, y, equal_nan=True) for o, r in zip(out, ref, strict=True)
                   for x, y in zip(o, r, strict=True))
        print(f"{label:28s} wall {wall * 1e3:6.1f} ms  CPU {cpu * 1e3:6.1f} ms  (both fits)  identical: {same}")


if __name__ == "__main__":
    main()
