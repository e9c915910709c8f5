"""Benchmark: ema_rig's read_uff58 against bare pyuff ``UFF(path).read_sets()``.

A 16-FRF x 8193-line file (8 outputs x 2 references, complex double, even abscissa) is written
with pyuff in a temporary directory, as ASCII 58 and as binary 58b. Each reader runs on the
same file in the same process; the best of ``--repeat`` runs is reported as MB/s with the time
ratio ema_rig / pyuff (goal: <= 1.5). read_uff58 includes all its checks (framing, num_pts,
byte counts, NaN, units, DOF pairs, frequency axes) and the assembly into one FRFData.

Run: ``python benchmarks/bench_uff.py [--repeat N]``
"""

from __future__ import annotations

import argparse
import contextlib
import io
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np


def _write_pyuff(path: Path, binary: bool, n_out: int = 8, n_in: int = 2, n_freq: int = 8193) -> None:
    import pyuff

    rng = np.random.default_rng(0)
    freq = np.arange(n_freq) * 0.25
    sets = []
    for i in range(n_out):
        for j in range(n_in):
            data = rng.standard_normal(n_freq) + 1j * rng.standard_normal(n_freq)
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


def _best(fn, repeat: int) -> float:
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def main() -> None:
    import pyuff

    from ema_rig.io.uff import read_uff58

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        print(f"{'format':8s} {'size MB':>8s} {'ema_rig s':>10s} {'MB/s':>8s} {'pyuff s':>9s} {'MB/s':>8s} {'ratio':>6s}")
        for binary in (False, True):
            path = Path(tmp) / ("bench_58b.uff" if binary else "bench_58.uff")
            _write_pyuff(path, binary)
            mb = path.stat().st_size / 1e6

            def ours(path: Path = path) -> None:
                d = read_uff58(path)
                assert d.shape == (8, 2, 8193)

            def theirs(path: Path = path) -> None:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore")
                    sets = pyuff.UFF(str(path)).read_sets()
                assert len(sets) == 16

            # check both read the same values before timing
            d = read_uff58(path)
            s = pyuff.UFF(str(path)).read_sets()
            assert np.array_equal(d.frf[0, 1], s[1]["data"]), "readers disagree"
            t_ours = _best(ours, args.repeat)
            t_pyuff = _best(theirs, args.repeat)
            print(f"{'58b' if binary else '58 ASCII':8s} {mb:8.2f} {t_ours:10.4f} {mb / t_ours:8.1f} "
                  f"{t_pyuff:9.4f} {mb / t_pyuff:8.1f} {t_ours / t_pyuff:6.2f}")
    print("ratio = ema_rig time / pyuff time (goal <= 1.5)")


if __name__ == "__main__":
    main()
