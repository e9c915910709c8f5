"""Benchmark: ema_rig PolyMAX against sdypy-EMA LSCF and against the eigenvalue floor.

Data (issue #3): 8 outputs x 1 input x 4001 lines, 0-2000 Hz at 0.5 Hz, modes at 4.7, 290,
455, 626, 810, 1100, 1450, 1908 Hz with 0.5-3 % damping, 1 % complex noise (seeded); then the
same structure with a second reference. For every even denominator order up to 100 and up to
200 it prints, side by side from one run:

* the time of the whole stabilization computation (``plscf`` + ``stabilize``; default root
  finder and the companion-eigenvalue one) and of
  sdypy-EMA ``Model.get_poles('lscf')`` at the same maximum order (``pol_order_high`` 50 / 100;
  sdypy is single-reference, so for two references it runs on the first reference only);
* the floor: the summed ``numpy.linalg.eigvals`` time of the companion matrices of all those
  orders, measured in a subprocess with ``OPENBLAS_NUM_THREADS=1`` (single thread);
* the 626 Hz mode at order 100 (and 200) against the truth, for both estimators.

Run: ``python benchmarks/bench_plscf.py [--repeat N]``.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

MODES_HZ = np.array([4.7, 290.0, 455.0, 626.0, 810.0, 1100.0, 1450.0, 1908.0])
DAMPING = np.array([0.03, 0.012, 0.008, 0.010, 0.005, 0.015, 0.020, 0.025])
OUT_DOFS = ["11+Y", "12+Y", "13+Y", "14+Z", "15+X", "21+Y", "22+Y", "23+X"]
TARGET = 3  # the 626 Hz mode


def make_data(n_in: int, seed: int = 0):
    """Exact modal-sum FRFs (accelerance) of a classically damped 8-mode system + 1 % noise."""
    from ema_rig.frf import FRFData

    rng = np.random.default_rng(seed)
    freq = np.arange(0.0, 2000.0 + 0.25, 0.5)
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
    return FRFData(freq, h, OUT_DOFS, [OUT_DOFS[i] for i in refs]), lam


def run_ema_rig(data, max_order: int, repeat: int, root_finder: str = "aberth"):
    from ema_rig.identification import plscf, stabilize

    orders = list(range(2, max_order + 1, 2))
    best = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        ps = plscf(data, max_order=max_order, orders=orders, root_finder=root_finder)
        stab = stabilize(ps)
        best = min(best, time.perf_counter() - t0)
    return best, ps, stab


def companions(data, max_order: int):
    """The companion matrices ema_rig builds for every even order (for the floor)."""
    from ema_rig.identification.plscf import (
        _companion,
        _lag_sums,
        _reduced_blocks,
        _solve_order,
        check_data,
    )

    d = check_data(data, None)
    n_in = d.n_in
    r, s, t, _, _ = _lag_sums(d, max_order)
    T, Q = _reduced_blocks(r, s, t, max_order)
    ncol = (max_order + 1) * n_in
    mats = []
    for n in range(2, max_order + 1, 2):
        rows = Q[: n + 1].reshape(-1, ncol)
        m = T[: (n + 1) * n_in, : (n + 1) * n_in] - (rows.T @ rows)[: (n + 1) * n_in, : (n + 1) * n_in]
        low, _ = _solve_order(m, n, n_in)
        mats.append(_companion(low[::-1]))
    return mats


def floor_time(mats, repeat: int) -> float:
    """Summed single-thread eigvals time, measured in a fresh interpreter."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mats.npz"
        np.savez(path, *mats)
        env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        out = subprocess.run(
            [sys.executable, __file__, "--floor-worker", str(path), "--repeat", str(repeat)],
            env=env,
            capture_output=True,
            text=True,
            check=True,
        )
    return float(json.loads(out.stdout)["floor"])


def floor_worker(path: str, repeat: int) -> None:
    data = np.load(path)
    mats = [data[k] for k in data.files]
    best = np.inf
    for _ in range(repeat):
        total = 0.0
        for c in mats:
            t0 = time.perf_counter()
            np.linalg.eigvals(c)
            total += time.perf_counter() - t0
        best = min(best, total)
    print(json.dumps({"floor": best}))


def run_sdypy(data, pol_order_high: int, repeat: int):
    import matplotlib

    matplotlib.use("Agg")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        from sdypy import EMA

    best = np.inf
    for _ in range(repeat):
        # lower = first line above 0 Hz: sdypy-EMA 0.31 builds a wrong R for lower = 0
        model = EMA.Model(
            frf=data.frf[:, 0, :], freq=data.freq, lower=data.freq[1], upper=data.freq[-1],
            pol_order_high=pol_order_high,
        )
        t0 = time.perf_counter()
        model.get_poles("lscf", show_progress=False)
        best = min(best, time.perf_counter() - t0)
    return best, model


def err_ema(ps, order: int, lam_true: complex):
    idx = ps.at_order(order)
    idx = idx[ps.pole[idx].real < 0]
    fn0 = abs(lam_true) / (2 * np.pi)
    z0 = -lam_true.real / abs(lam_true)
    k = idx[np.argmin(np.abs(ps.natural_freq[idx] - fn0))]
    return ps.natural_freq[k] / fn0 - 1, ps.damping_ratio[k] / z0 - 1


def err_sdypy(model, order: int, lam_true: complex):
    p = np.asarray(model.all_poles[order // 2 - 1])
    p = p[(p.imag > 0) & (p.real < 0)]
    fn = np.abs(p) / (2 * np.pi)
    fn0 = abs(lam_true) / (2 * np.pi)
    z0 = -lam_true.real / abs(lam_true)
    k = np.argmin(np.abs(fn - fn0))
    return fn[k] / fn0 - 1, (-p[k].real / abs(p[k])) / z0 - 1


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--floor-worker", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.floor_worker:
        floor_worker(args.floor_worker, args.repeat)
        return 0

    from ema_rig.identification import identify

    print(f"ema_rig pLSCF benchmark — numpy {np.__version__}, {os.cpu_count()} CPUs, best of {args.repeat}")
    print("data: 8 outputs x 4001 lines (0-2000 Hz), modes", ", ".join(f"{f:g}" for f in MODES_HZ), "Hz, 1 % noise\n")
    for n_in in (1, 2):
        data, lam = make_data(n_in)
        print(f"=== {n_in} reference{'s' if n_in > 1 else ''} " + "=" * 60)
        head = (
            f"{'max order':>9} | {'ema_rig [s]':>11} {'(eig) [s]':>9} {'floor [s]':>9} {'sdypy [s]':>9} | "
            f"{'ema/floor':>9} {'sdypy/ema':>9} | {'626 Hz df/f':>11} {'dz/z':>9} | {'sdypy df/f':>10} {'dz/z':>9}"
        )
        print(head)
        print("-" * len(head))
        for max_order in (100, 200):
            t_ema, ps, stab = run_ema_rig(data, max_order, args.repeat)
            t_eig, _, _ = run_ema_rig(data, max_order, args.repeat, "eig")
            t_floor = floor_time(companions(data, max_order), args.repeat)
            t_sd, model = run_sdypy(data, max_order // 2, args.repeat)
            for order in sorted({100, max_order}):
                de = err_ema(ps, order, lam[TARGET])
                ds = err_sdypy(model, order, lam[TARGET])
                lead = (
                    f"{max_order:>9} | {t_ema:>11.3f} {t_eig:>9.3f} {t_floor:>9.3f} {t_sd:>9.3f} | "
                    f"{t_ema / t_floor:>9.2f} {t_sd / t_ema:>9.2f} |"
                    if order == 100
                    else f"{'':>9} | {'':>11} {'':>9} {'':>9} {'':>9} | {'':>9} {'':>9} |"
                )
                print(
                    f"{lead} {de[0]:>+11.2e} {de[1]:>+9.2e} | {ds[0]:>+10.2e} {ds[1]:>+9.2e}   (order {order})"
                )
        t0 = time.perf_counter()
        ident = identify(data, band=(150.0, 1000.0))
        t_id = time.perf_counter() - t0
        k = int(np.argmin(np.abs(ident.natural_freq - 626)))
        fn0 = abs(lam[TARGET]) / (2 * np.pi)
        z0 = -lam[TARGET].real / abs(lam[TARGET])
        print(
            f"identify(band 150-1000 Hz, default max order): {t_id:.3f} s, {ident.modes.n_modes} modes; 626 Hz: "
            f"df/f {ident.natural_freq[k] / fn0 - 1:+.2e}, dz/z {ident.damping_ratio[k] / z0 - 1:+.2e}, "
            f"cluster std {ident.natural_freq_std[k]:.2e} Hz\n"
        )
    print("ema_rig = plscf + stabilize over every even order (default: warm-started Aberth roots);")
    print("(eig) = the same with companion eigenvalues on 2 threads; floor = summed single-thread eigvals")
    print("of the same companion matrices; sdypy = Model.get_poles('lscf') at pol_order_high = max order / 2")
    print("(single reference: for 2 references sdypy runs on the first reference only).")
    print("Goals: sdypy/ema >= 2, ema/floor <= 1.2; 626 Hz at order 100: |df/f| <= 5e-6, |dz/z| <= 2e-3.")
    return 0


if __name__ == "__main__":
    sys.exit(main())
