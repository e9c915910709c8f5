"""Benchmark: ema_rig PolyMAX (pLSCF) against sdypy-EMA LSCF, like with like.

Data: 8 outputs x 4000 lines (0.5-2000 Hz at 0.5 Hz) of an exact modal sum (accelerance) with
modes at 4.7, 290, 455, 626, 810, 1100, 1450, 1908 Hz, 0.5-3 % damping and 1 % complex noise
(seeded). Both tools get the same lines and compute poles at the same denominator orders
(every even order 2..max order; sdypy's ``pol_order_high`` = max order / 2):

* ``ema_rig.identification.plscf(data, max_order=N)`` (poles and participation factors);
* ``sdypy.EMA.Model(...).get_poles('lscf')`` (poles).

sdypy-EMA's LSCF takes one reference, so the main comparison runs on ONE reference. The
two-reference (MIMO) rows pit ema_rig's poly-reference pLSCF (an ``n_in x n_in`` matrix
denominator, participation factors) against sdypy-EMA on the same 16 FRFs stacked as 16 rows
of one reference: a DIFFERENT model (one scalar common denominator, no participation factors),
so its time is the cost of a comparable job, not of the same estimator; its poles are checked
against the truth all the same.

How the times are taken
-----------------------
* Warm: in this process, after one untimed call of each tool. The two tools alternate in
  pairs (A B, B A, A B, ...) so that a busy period on the shared machine hits both; each row
  gives the median and the min-max of the times, and the median of the per-pair ratios.
* BLAS threads: every warm row runs twice, with the BLAS pools of BOTH tools limited to one
  thread (threadpoolctl, every BLAS library loaded) and with both on the default thread count.
  (ema_rig additionally runs its small LAPACK kernels single-threaded inside ``plscf``, by
  design; that is part of the tool being measured.)
* Peak memory: each warm row also gives the peak resident memory one call adds above the
  process before it (``/proc/self/clear_refs`` resets the kernel's high-water mark; freed heap
  returned first with ``malloc_trim``), per tool, under the same BLAS setting.
* Cold: the first call in a fresh interpreter, after the tool's import (import time listed
  apart), median of ``--cold`` fresh processes per tool, alternating; with the peak resident
  memory that call added above the process after the import.
* Accuracy: the 626 Hz mode against the truth at order 100 and at the max order.
* Root step and its floor (ema_rig, one reference): the time spent finding the roots of every
  order's denominator (warm-started Aberth iteration, companion eigenvalues below degree 64)
  against what no root finder that certifies its roots can go below: ONE evaluation of the
  polynomial and its derivative at the final roots of every order (the pass that confirms
  them), timed with ema_rig's own evaluation kernel on the same coefficients. Each order's
  step and floor are replayed in pairs and the fastest of each counts (the cost without the
  time slices other processes take on a shared machine). Both are CPU times
  (``time.process_time``, one BLAS thread), so a loaded machine inflates them alike.

Run: ``python benchmarks/bench_plscf.py [--repeat N] [--cold N] [--quick]``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import statistics
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
from _timing import measure_call  # benchmarks/_timing.py, beside this script

MODES_HZ = np.array([4.7, 290.0, 455.0, 626.0, 810.0, 1100.0, 1450.0, 1908.0])
DAMPING = np.array([0.03, 0.012, 0.008, 0.010, 0.005, 0.015, 0.020, 0.025])
OUT_DOFS = ["11+Y", "12+Y", "13+Y", "14+Z", "15+X", "21+Y", "22+Y", "23+X"]
TARGET = 3  # the 626 Hz mode


# ------------------------------------------------------------------------------------- data
def make_arrays(n_in: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """freq [Hz] (n_freq,), accelerance h (8, n_in, n_freq) without the 0 Hz line, poles (8,)."""
    rng = np.random.default_rng(seed)
    freq = np.arange(1, 4001) * 0.5
    phi = rng.uniform(-1.0, 1.0, (8, 8)) * 0.4  # mass-normalised shapes, one per row
    phi[TARGET, :3] = [0.6, 0.55, 0.58]  # the housing mode moves the radial housing sensors
    refs = [0, 4][:n_in]
    wn = 2 * np.pi * MODES_HZ
    lam = wn * (-DAMPING + 1j * np.sqrt(1 - DAMPING**2))
    jw = 2j * np.pi * freq
    h = np.zeros((8, n_in, freq.size), complex)
    for r in range(8):
        res = np.outer(phi[r], phi[r, refs]) / (2j * lam[r].imag)
        h += res[:, :, None] / (jw - lam[r]) + res.conj()[:, :, None] / (jw - lam[r].conj())
    h *= jw**2
    rms = np.sqrt(np.mean(np.abs(h) ** 2, axis=2, keepdims=True))
    h = h + 0.01 * rms * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
    return freq, h, lam


def ema_data(freq: np.ndarray, h: np.ndarray) -> Any:
    from ema_rig.frf import FRFData

    return FRFData(freq, h, OUT_DOFS, [OUT_DOFS[i] for i in (0, 4)[: h.shape[1]]])


# ------------------------------------------------------------------------------------ tools
def call_ema(data: Any, max_order: int, *, even: bool = False) -> Any:
    from ema_rig.identification import plscf

    orders = range(2, max_order + 1, 2) if even else None  # None: the default (every order for MIMO)
    return plscf(data, max_order=max_order, orders=orders)


def call_sdypy(freq: np.ndarray, h1: np.ndarray, max_order: int) -> Any:
    from sdypy import EMA

    # the data has no 0 Hz line: sdypy pads zeros below `lower` itself
    model = EMA.Model(frf=h1, freq=freq, lower=freq[0], upper=freq[-1], pol_order_high=max_order // 2)
    model.get_poles("lscf", show_progress=False)
    return model


def import_sdypy() -> None:
    import matplotlib

    matplotlib.use("Agg")  # sdypy imports pyplot
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from sdypy import EMA  # noqa: F401


# --------------------------------------------------------------------------------- accuracy
def _truth(lam_true: complex) -> tuple[float, float]:
    return abs(lam_true) / (2 * np.pi), -lam_true.real / abs(lam_true)


def err_ema(ps: Any, order: int, lam_true: complex) -> tuple[float, float]:
    fn0, z0 = _truth(lam_true)
    idx = ps.at_order(order)
    idx = idx[ps.pole[idx].real < 0]
    k = idx[np.argmin(np.abs(ps.natural_freq[idx] - fn0))]
    return ps.natural_freq[k] / fn0 - 1, ps.damping_ratio[k] / z0 - 1


def root_step_and_floor(data: Any, max_order: int, replays: int = 3) -> tuple[float, float, int, float]:
    """(root step [s], one evaluation pass at the final roots [s], orders, root step's share of the call).

    Each root-finding call (one order, or one batched chain of orders, ``aberth_chain``, or one batch
    of companion orders with their stable roots divided out, ``_roots_deflated``, whose floor is the
    sum of its orders' floors) is recorded with its inputs during one ``plscf``
    call and then replayed ``replays`` times, interleaved with its floor (one evaluation at
    the final roots of each of its orders); per call the fastest replay of each counts, in CPU
    time (``time.process_time``; one BLAS thread). On a shared machine a step of a fraction of a
    millisecond timed once inside the call can absorb a whole time slice of another process; the
    minimum of paired replays in CPU time is the cost without that interference, for the step
    and its floor alike. The share is the root step's wall time inside that
    ``plscf`` call over the call's wall time (both with the machine's interference).
    """
    import importlib

    from ema_rig.identification._roots import _ratio, det_coefficients

    mod = importlib.import_module("ema_rig.identification.plscf")
    # each root-finding call: (replay, [(coefficients, final roots) per order it roots])
    calls: list[tuple[Callable[[], Any], list[tuple[np.ndarray, np.ndarray]]]] = []
    eig0 = mod._roots_eig
    # one order at a time: aberth(c, z0) on older trees, aberth_warm(c, prev_coef, prev) (the
    # first sweep's repulsion from the previous order's polynomial) on newer ones
    one_name = "aberth_warm" if hasattr(mod, "aberth_warm") else "aberth"
    aberth0 = getattr(mod, one_name)
    chain0 = getattr(mod, "aberth_chain", None)  # the batched chain of orders (newer trees)
    in_call = [0.0]
    empty = np.zeros(0, complex)

    def rec_aberth(c: np.ndarray, *args: Any) -> Any:
        t0 = time.perf_counter()
        z = aberth0(c, *args)
        in_call[0] += time.perf_counter() - t0
        # a failed call (None): the fallback that follows is timed as its own call
        calls.append((lambda c=c, args=args: aberth0(c, *args), [(c, z if z is not None else empty)]))
        return z

    def rec_chain(coefs: list[np.ndarray], start: np.ndarray) -> Any:
        t0 = time.perf_counter()
        found = chain0(coefs, start)
        in_call[0] += time.perf_counter() - t0
        calls.append((lambda coefs=coefs, start=start: chain0(coefs, start),
                      [(c, z if z is not None else empty) for c, z in zip(coefs, found, strict=True)]))
        return found

    defl0 = getattr(mod, "_roots_deflated", None)  # the companion orders' stable roots divided out (newer trees)

    def rec_deflated(lows: list[np.ndarray], anchor: np.ndarray) -> Any:
        mod._roots_eig = eig0  # its own fallbacks are part of its call (not recorded twice)
        try:
            t0 = time.perf_counter()
            found = defl0(lows, anchor)
            in_call[0] += time.perf_counter() - t0
        finally:
            mod._roots_eig = rec_eig
        calls.append((lambda lows=lows, anchor=anchor: defl0(lows, anchor),
                      [(det_coefficients(low), z) for low, z in zip(lows, found, strict=True)]))
        return found

    def rec_eig(low: np.ndarray) -> Any:
        t0 = time.perf_counter()
        z = eig0(low)
        in_call[0] += time.perf_counter() - t0
        calls.append((lambda low=low: eig0(low), [(det_coefficients(low), z)]))
        return z

    setattr(mod, one_name, rec_aberth)
    mod._roots_eig = rec_eig
    if chain0 is not None:
        mod.aberth_chain = rec_chain
    if defl0 is not None:
        mod._roots_deflated = rec_deflated
    try:
        t0 = time.perf_counter()
        call_ema(data, max_order)
        total = time.perf_counter() - t0
    finally:
        setattr(mod, one_name, aberth0)
        mod._roots_eig = eig0
        if chain0 is not None:
            mod.aberth_chain = chain0
        if defl0 is not None:
            mod._roots_deflated = defl0
    step = floor = 0.0
    orders = 0
    for run, found in calls:
        ts, tf = [], []
        for _ in range(replays):
            t0 = time.process_time()
            run()
            ts.append(time.process_time() - t0)
            t_floor = 0.0
            for c, z in found:
                if z.size:
                    j = np.arange(1, c.size)
                    dc, cr = c[1:] * j, c[::-1].copy()
                    dcr = cr[1:] * j
                    t0 = time.process_time()
                    _ratio(c, dc, cr, dcr, z)
                    t_floor += time.process_time() - t0
            tf.append(t_floor)
        step += min(ts)
        floor += min(tf)
        orders += sum(1 for _, z in found if z.size)
    return step, floor, orders, in_call[0] / total


def mb(nbytes: int) -> str:
    return f"{nbytes / 1e6:6.1f}"


def err_sdypy(model: Any, order: int, lam_true: complex) -> tuple[float, float]:
    fn0, z0 = _truth(lam_true)
    p = np.asarray(model.all_poles[order // 2 - 1])  # sdypy's list: orders 2, 4, ...
    p = p[(p.imag > 0) & (p.real < 0)]
    fn = np.abs(p) / (2 * np.pi)
    k = np.argmin(np.abs(fn - fn0))
    return fn[k] / fn0 - 1, (-p[k].real / abs(p[k])) / z0 - 1


# ---------------------------------------------------------------------------------- timing
@contextlib.contextmanager
def blas_threads(n: int | None) -> Iterator[None]:
    """Limit every loaded BLAS library to ``n`` threads (None: leave the default)."""
    if n is None:
        yield
        return
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=n, user_api="blas"):
        yield


def default_threads() -> str:
    from threadpoolctl import threadpool_info

    return ",".join(sorted({str(i["num_threads"]) for i in threadpool_info() if i["user_api"] == "blas"}))



def paired_cpu(fa: Callable[[], Any], fb: Callable[[], Any], repeat: int) -> tuple[list[float], list[float], list[float], list[float]]:
    """:func:`_timing.paired` that also records each call's CPU time (``time.process_time``, every
    thread of the process): (wall A, wall B, CPU A, CPU B) [s]. With one BLAS thread the CPU time
    is the work a call does, without the time slices other processes take on a shared machine."""
    ta: list[float] = []
    tb: list[float] = []
    ca: list[float] = []
    cb: list[float] = []
    for i in range(repeat):
        for which in ((0, 1) if i % 2 == 0 else (1, 0)):
            t0, c0 = time.perf_counter(), time.process_time()
            (fa if which == 0 else fb)()
            (ta if which == 0 else tb).append(time.perf_counter() - t0)
            (ca if which == 0 else cb).append(time.process_time() - c0)
    return ta, tb, ca, cb


def spread(ts: list[float]) -> str:
    return f"{statistics.median(ts):7.3f} ({min(ts):.3f}-{max(ts):.3f})"


def ratio_spread(ta: list[float], tb: list[float]) -> str:
    r = [b / a for a, b in zip(ta, tb, strict=True)]
    return f"{statistics.median(r):6.2f} ({min(r):.2f}-{max(r):.2f})"


# ------------------------------------------------------------------------------ cold calls
def _rss_kib() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * (os.sysconf("SC_PAGE_SIZE") // 1024)


def cold_worker(tool: str, n_in: int, max_order: int) -> None:
    """In a fresh interpreter: import time, first-call time, peak RSS added by the first call."""
    import resource

    freq, h, _ = make_arrays(n_in)
    t0 = time.perf_counter()
    if tool == "ema_rig":
        from ema_rig.identification import plscf  # noqa: F401
    else:
        import_sdypy()
    t_import = time.perf_counter() - t0
    if tool == "ema_rig":
        data = ema_data(freq, h)
        call: Callable[[], Any] = lambda: call_ema(data, max_order)  # noqa: E731
    else:
        h1 = np.ascontiguousarray(h[:, 0, :])
        call = lambda: call_sdypy(freq, h1, max_order)  # noqa: E731
    rss0 = _rss_kib()
    t0 = time.perf_counter()
    call()
    t_first = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss  # KiB on Linux
    print(json.dumps({"import": t_import, "first": t_first, "peak_mb": max(peak - rss0, 0) / 1024}))


def cold(tool: str, n_in: int, max_order: int) -> dict[str, float]:
    out = subprocess.run([sys.executable, __file__, "--cold-worker", tool, str(n_in), str(max_order)],
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


# ------------------------------------------------------------------------------------ main
def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5, help="warm pairs per row (default 5)")
    ap.add_argument("--cold", type=int, default=3, help="fresh processes per tool for the first call (default 3)")
    ap.add_argument("--quick", action="store_true", help="max orders 50 and 100 only, 3 pairs, 1 cold run")
    ap.add_argument("--cold-worker", nargs=3, default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.cold_worker:
        tool, n_in, mo = args.cold_worker
        cold_worker(tool, int(n_in), int(mo))
        return 0
    orders = (50, 100) if args.quick else (50, 100, 200)
    repeat = 3 if args.quick else args.repeat
    n_cold = 1 if args.quick else args.cold

    import_sdypy()
    import scipy.linalg  # noqa: F401  (every BLAS library loaded before threadpoolctl looks)

    import ema_rig

    freq, h, lam = make_arrays(1)
    data1 = ema_data(freq, h)
    h1 = np.ascontiguousarray(h[:, 0, :])
    print(f"ema_rig {ema_rig.__version__} pLSCF vs sdypy-EMA LSCF - {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, "
          f"numpy {np.__version__}, {os.cpu_count()} CPUs, default BLAS threads {default_threads()}")
    print(f"data: 8 outputs x 1 reference x {freq.size} lines ({freq[0]:g}-{freq[-1]:g} Hz), "
          f"modes {', '.join(f'{f:g}' for f in MODES_HZ)} Hz, 1 % noise; same data for both tools\n")

    call_ema(data1, 10)  # untimed: lazy imports, threadpoolctl's library scan
    call_sdypy(freq, h1, 10)

    print(f"Warm, paired and alternating ({repeat} pairs): median (min-max) seconds; ratio = sdypy / ema_rig per pair;")
    print("peak = resident memory one call adds [MB]; CPU ratio = the same ratio of the calls' CPU times")
    print("(process_time, all threads: with one BLAS thread the work of each call, without other processes' time slices)")
    head = (f"{'max order':>9} {'BLAS thr':>8} | {'ema_rig [s]':>22} {'peak':>6} | {'sdypy [s]':>22} {'peak':>6} | "
            f"{'sdypy/ema_rig':>18} | {'CPU ratio':>18}")
    print(head)
    print("-" * len(head))
    results: dict[int, tuple[Any, Any]] = {}
    for mo in orders:
        for threads in (1, None):
            with blas_threads(threads):
                _, pa, ps = measure_call(lambda mo=mo: call_ema(data1, mo))
                _, pb, model = measure_call(lambda mo=mo: call_sdypy(freq, h1, mo))
                ta, tb, ca, cb = paired_cpu(lambda mo=mo: call_ema(data1, mo), lambda mo=mo: call_sdypy(freq, h1, mo), repeat)
            results[mo] = (ps, model)
            print(f"{mo:>9} {threads or 'default':>8} | {spread(ta):>22} {mb(pa)} | {spread(tb):>22} {mb(pb)} | "
                  f"{ratio_spread(ta, tb):>18} | {ratio_spread(ca, cb):>18}")

    print("\nAccuracy of the 626 Hz mode against the truth (same data, same order)")
    head = f"{'max order':>9} {'order':>5} | {'ema_rig df/f':>12} {'dz/z':>9} | {'sdypy df/f':>10} {'dz/z':>9}"
    print(head)
    print("-" * len(head))
    for mo in orders:
        ps, model = results[mo]
        for order in sorted({min(100, mo), mo}):
            de, ds = err_ema(ps, order, lam[TARGET]), err_sdypy(model, order, lam[TARGET])
            print(f"{mo:>9} {order:>5} | {de[0]:>+12.2e} {de[1]:>+9.2e} | {ds[0]:>+10.2e} {ds[1]:>+9.2e}")

    print("\nRoot step against its floor (ema_rig, one reference, BLAS 1 thread): CPU seconds finding the roots of")
    print("every order vs one evaluation of p and p' at the final roots of every order; per order the fastest")
    print("of 3 paired replays of each, median of 3 such runs; share = the root step's part of the plscf call's")
    print("wall time, timed inside the call (median of the 3 runs)")
    head = f"{'max order':>9} | {'root step [s]':>13} {'floor [s]':>10} {'step/floor':>10} | {'share of plscf':>14}"
    print(head)
    print("-" * len(head))
    for mo in orders:
        with blas_threads(1):
            runs = [root_step_and_floor(data1, mo) for _ in range(3)]  # each: fastest of 3 replays per order
        step, floor = statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs)
        share = statistics.median(r[3] for r in runs)
        print(f"{mo:>9} | {step:>13.4f} {floor:>10.4f} {step / floor:>10.1f} | {share:>13.0%}")

    print(f"\nCold: first call in a fresh interpreter, default BLAS threads, median of {n_cold} per tool "
          "(alternating); import apart; peak = RSS the call added")
    head = (f"{'max order':>9} | {'ema_rig import':>14} {'first [s]':>9} {'peak MB':>8} | "
            f"{'sdypy import':>12} {'first [s]':>9} {'peak MB':>8}")
    print(head)
    print("-" * len(head))
    for mo in orders:
        runs: dict[str, list[dict[str, float]]] = {"ema_rig": [], "sdypy": []}
        for i in range(n_cold):
            for tool in (("ema_rig", "sdypy") if i % 2 == 0 else ("sdypy", "ema_rig")):
                runs[tool].append(cold(tool, 1, mo))
        med = {t: {k: statistics.median(r[k] for r in rs) for k in rs[0]} for t, rs in runs.items()}
        e, s = med["ema_rig"], med["sdypy"]
        print(f"{mo:>9} | {e['import']:>14.3f} {e['first']:>9.3f} {e['peak_mb']:>8.1f} | "
              f"{s['import']:>12.3f} {s['first']:>9.3f} {s['peak_mb']:>8.1f}")

    print("\nTwo references (MIMO), 8 outputs x 2 references, both tools on the even orders 2..N.")
    print("ema_rig: poly-reference pLSCF (2 x 2 matrix denominator: 2n poles at order n, participation factors).")
    print("sdypy: the 16 FRFs stacked as 16 rows of ONE reference - a different model (scalar common")
    print("denominator: n poles at order n, no participation factors); paired as above (CPU ratio as above),")
    print("626 Hz error at order N")
    freq2, h2, lam2 = make_arrays(2)
    data2 = ema_data(freq2, h2)
    h16 = np.ascontiguousarray(h2.reshape(-1, h2.shape[-1]))
    head = (f"{'max order':>9} {'BLAS thr':>8} | {'ema_rig [s]':>22} {'peak':>6} {'df/f':>9} {'dz/z':>9} | "
            f"{'sdypy stacked [s]':>22} {'peak':>6} {'df/f':>9} {'dz/z':>9} | {'sdypy/ema_rig':>18} | {'CPU ratio':>18}")
    print(head)
    print("-" * len(head))
    for mo in orders:
        for threads in (1, None):
            with blas_threads(threads):
                _, pa, ps = measure_call(lambda mo=mo: call_ema(data2, mo, even=True))
                _, pb, model = measure_call(lambda mo=mo: call_sdypy(freq2, h16, mo))
                ta, tb, ca, cb = paired_cpu(lambda mo=mo: call_ema(data2, mo, even=True),
                                            lambda mo=mo: call_sdypy(freq2, h16, mo), repeat)
            de = err_ema(ps, mo, lam2[TARGET])
            ds = err_sdypy(model, mo, lam2[TARGET])
            print(f"{mo:>9} {threads or 'default':>8} | {spread(ta):>22} {mb(pa)} {de[0]:>+9.2e} {de[1]:>+9.2e} | "
                  f"{spread(tb):>22} {mb(pb)} {ds[0]:>+9.2e} {ds[1]:>+9.2e} | {ratio_spread(ta, tb):>18} | "
                  f"{ratio_spread(ca, cb):>18}")
    print("\nema_rig = plscf(data, max_order=N); sdypy = Model.get_poles('lscf') with pol_order_high = N/2;")
    print("both compute every even denominator order 2..N on the same 4000 lines. The root step's floor is")
    print("one evaluation pass at the final roots, not a faster root finder: step/floor says how far from it.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
