"""Benchmark: ema_rig's read_uff58 against bare pyuff ``UFF(path).read_sets()``, like with like.

A 16-FRF x 8193-line file (8 outputs x 2 references, complex double, even abscissa) is written
with pyuff in a temporary directory, as ASCII 58 and as binary 58b. Both readers read the same
file (checked to return the same values first). read_uff58 includes all its checks (framing,
num_pts, byte counts, NaN, units, DOF pairs, frequency axes) and the assembly into one FRFData;
pyuff returns a list of dicts.

* Warm: in this process, after one untimed read by each; the readers alternate in pairs
  (A B, B A, ...); median and min-max of the times, median (min-max) of the per-pair ratios
  ema_rig / pyuff. Both on the same BLAS thread setting (limited to one; neither reader uses
  BLAS for parsing).
* Cold: the first read in a fresh interpreter after the reader's import (import apart), median
  of ``--cold`` fresh processes per reader, alternating. The file is in the page cache for both.

Run: ``python benchmarks/bench_uff.py [--repeat N] [--cold N]``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
from _timing import paired  # benchmarks/_timing.py, beside this script

N_OUT, N_IN, N_FREQ = 8, 2, 8193


def _write_pyuff(path: Path, binary: bool) -> None:
    import pyuff

    rng = np.random.default_rng(0)
    freq = np.arange(N_FREQ) * 0.25
    sets = []
    for i in range(N_OUT):
        for j in range(N_IN):
            data = rng.standard_normal(N_FREQ) + 1j * rng.standard_normal(N_FREQ)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                sets.append(pyuff.prepare_58(
                    binary=int(binary), func_type=4, rsp_node=i + 1, rsp_dir=2, ref_node=100 + j, ref_dir=2,
                    ord_data_type=6, abscissa_spacing=1, abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
                    ordinate_spec_data_type=12, ordinate_axis_units_lab="m/s^2", orddenom_spec_data_type=13,
                    orddenom_axis_units_lab="N", data=data, x=freq,
                    id1="bench", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
                ))
    with contextlib.redirect_stdout(io.StringIO()):
        pyuff.UFF(str(path)).write_sets(sets, mode="add")  # "overwrite" truncates a binary first set


def read_ours(path: Path) -> None:
    from ema_rig.io.uff import read_uff58

    d = read_uff58(path)
    assert d.shape == (N_OUT, N_IN, N_FREQ)


def read_pyuff(path: Path) -> None:
    import pyuff

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sets = pyuff.UFF(str(path)).read_sets()
    assert len(sets) == N_OUT * N_IN


READERS: dict[str, Callable[[Path], None]] = {"ema_rig": read_ours, "pyuff": read_pyuff}



def spread(ts: list[float]) -> str:
    return f"{statistics.median(ts):.4f} ({min(ts):.4f}-{max(ts):.4f})"


def cold_worker(tool: str, path: str) -> None:
    """In a fresh interpreter: import time and first-read time of one reader."""
    t0 = time.perf_counter()
    if tool == "ema_rig":
        import ema_rig.io.uff  # noqa: F401
    else:
        import pyuff  # noqa: F401
    t_import = time.perf_counter() - t0
    t0 = time.perf_counter()
    READERS[tool](Path(path))
    print(json.dumps({"import": t_import, "first": time.perf_counter() - t0}))


def cold(tool: str, path: Path) -> dict[str, float]:
    out = subprocess.run([sys.executable, __file__, "--cold-worker", tool, str(path)],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--repeat", type=int, default=7, help="warm pairs (default 7)")
    ap.add_argument("--cold", type=int, default=3, help="fresh processes per reader (default 3)")
    ap.add_argument("--cold-worker", nargs=2, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.cold_worker:  # before importing either reader
        cold_worker(*args.cold_worker)
        return
    import pyuff
    from threadpoolctl import threadpool_limits

    from ema_rig.io.uff import read_uff58

    print(f"read_uff58 vs pyuff {pyuff.__version__} - {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}; "
          f"{N_OUT} x {N_IN} FRFs x {N_FREQ} lines, complex double; {args.repeat} warm pairs, "
          f"{args.cold} cold runs per reader")
    with tempfile.TemporaryDirectory() as tmp:
        head = (f"{'format':8s} {'MB':>5s} | {'ema_rig warm [s]':>24s} {'pyuff warm [s]':>24s} "
                f"{'ema/pyuff':>17s} | {'ema_rig cold':>12s} {'pyuff cold':>10s} {'ratio':>5s} | "
                f"{'import ema_rig':>14s} {'pyuff':>6s}")
        print(head)
        print("-" * len(head))
        for binary in (False, True):
            path = Path(tmp) / ("bench_58b.uff" if binary else "bench_58.uff")
            _write_pyuff(path, binary)
            mb = path.stat().st_size / 1e6
            # both read the same values (and the untimed first reads warm this process)
            d = read_uff58(path)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                s = pyuff.UFF(str(path)).read_sets()
            assert np.array_equal(d.frf[0, 1], s[1]["data"]), "readers disagree"
            with threadpool_limits(limits=1, user_api="blas"):
                ta, tb = paired(lambda p=path: read_ours(p), lambda p=path: read_pyuff(p), args.repeat)
            runs: dict[str, list[dict[str, float]]] = {"ema_rig": [], "pyuff": []}
            for i in range(args.cold):
                for tool in (("ema_rig", "pyuff") if i % 2 == 0 else ("pyuff", "ema_rig")):
                    runs[tool].append(cold(tool, path))
            med = {t: {k: statistics.median(r[k] for r in rs) for k in rs[0]} for t, rs in runs.items()}
            ratios = [a / b for a, b in zip(ta, tb, strict=True)]
            print(f"{'58b' if binary else '58 ASCII':8s} {mb:5.1f} | {spread(ta):>24s} {spread(tb):>24s} "
                  f"{statistics.median(ratios):5.2f} ({min(ratios):.2f}-{max(ratios):.2f}) | "
                  f"{med['ema_rig']['first']:12.4f} {med['pyuff']['first']:10.4f} "
                  f"{med['ema_rig']['first'] / med['pyuff']['first']:5.2f} | "
                  f"{med['ema_rig']['import']:14.3f} {med['pyuff']['import']:6.3f}")
    print("warm: median (min-max) of paired, alternating reads; ratio = ema_rig time / pyuff time per pair;")
    print("cold: the first read in a fresh interpreter after the import (median), import time apart.")


if __name__ == "__main__":
    main()
