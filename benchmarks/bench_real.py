"""ema_rig against sdypy-EMA on the shared real measured FRFs: modes found, agreement, time.

Run from the repository root (needs ../shared or EMA_RIG_SHARED)::

    python benchmarks/bench_real.py [--sdypy-order 160]

For every file of ``real-frf/`` (and the corpus' single mobility FRF) in the band named below,
ema_rig's :func:`~ema_rig.identification.identify` runs at its defaults (no order given) and
sdypy-EMA's LSCF runs on the same band up to ``--sdypy-order``. Reported per file: the modes
ema_rig selects, how many of the reference modes (README of ``real-frf``; the published and peer
values) are found exactly once within 1 %, how many of ema_rig's modes sdypy-EMA confirms (its
own stable poles within 1 %, at three or more orders), the median frequency difference, and
both wall times. The script uses only ``identify`` and the result's modes, so it runs unchanged
on older versions of ema_rig (to record "before" numbers).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import os
import time
import warnings
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parents[1]
SHARED = Path(os.environ.get("EMA_RIG_SHARED", HERE.parent / "shared"))

# file, band [Hz] (None = whole file), reference modes [Hz] (README of real-frf)
CASES = [
    ("real-frf/dam0.unv", (1.0, 12.0), [2.482, 2.958, 3.497, 4.081, 4.167, 4.633, 7.124, 8.223, 8.643, 10.21, 10.89]),
    ("real-frf/vt_case1_full.uff", None, [34.06, 161.6, 212.09]),
    ("real-frf/vt_case2_full.uff", None, [192.59]),
    ("uff-corpus/ufffiles_frf.unv", (20.0, 780.0), []),
]


def sdypy_stable(data, band, order):
    """sdypy-EMA LSCF stable poles (frequency [Hz], damping) in the band, and the wall time."""
    from sdypy import EMA

    # sdypy-EMA's public pole lists and the same 1 %/5 % consecutive-order test as --crosscheck
    from ema_rig.identification.crosscheck import _stable_poles

    lo, hi = band
    d = data.band(float(data.freq[0]), hi)
    half = order // 2
    t0 = time.perf_counter()
    with warnings.catch_warnings(), contextlib.redirect_stderr(io.StringIO()):
        warnings.simplefilter("ignore")
        m = EMA.Model(frf=d.frf.reshape(-1, d.n_freq), freq=d.freq, lower=max(lo, float(d.freq[1])), upper=hi,
                      pol_order_high=half, frf_form=d.frf_form)
        m.get_poles(method="lscf", show_progress=False)
        fn, xi, _ = _stable_poles(list(m.pole_freq), list(m.pole_xi))
    sec = time.perf_counter() - t0
    ok = (fn >= lo) & (fn <= hi)
    return fn[ok], xi[ok], sec


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sdypy-order", type=int, default=160)
    args = ap.parse_args()
    from ema_rig.errors import EmaRigError
    from ema_rig.identification import identify
    from ema_rig.io.uff import read_uff58

    if not SHARED.is_dir():
        raise SystemExit(f"shared data not found at {SHARED}; set EMA_RIG_SHARED")
    print(f"shared data: {SHARED}")
    head = (f"{'file':<28} {'band [Hz]':>12} {'ema_rig':>7} {'ref found':>9} {'confirmed':>9} "
            f"{'|df| med':>9} {'t ema_rig':>9} {'t sdypy':>8}  notes")
    print(head)
    for name, band, ref in CASES:
        path = SHARED / name
        if not path.exists():
            print(f"{name:<28} missing")
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            data = read_uff58(path)
        b = band if band is not None else (float(data.freq[0]), float(data.freq[-1]))
        t0 = time.perf_counter()
        try:
            ident = identify(data, band=band)
            err = None
        except EmaRigError as exc:
            ident, err = None, exc.message
        t_ema = time.perf_counter() - t0
        f_sdy, _, t_sdy = sdypy_stable(data, b, args.sdypy_order)
        bstr = f"{b[0]:g}-{b[1]:g}"
        if ident is None:
            print(f"{name:<28} {bstr:>12} {'refused':>7} {'-':>9} {'-':>9} {'-':>9} {t_ema:>8.2f}s {t_sdy:>7.2f}s  "
                  f"{(err or '')[:90]}; sdypy stable poles in band: {f_sdy.size}")
            continue
        fn = ident.natural_freq
        found_once = sum(int(np.sum(np.abs(fn - r) <= 0.01 * r) == 1) for r in ref)
        conf, diffs = 0, []
        for f in fn:
            near = np.abs(f_sdy - f) <= 0.01 * f
            if near.sum() >= 3:
                conf += 1
                diffs.append(abs(np.median(f_sdy[near]) - f) / f)
        med = f"{100 * np.median(diffs):.3f}%" if diffs else "-"
        notes = []
        if hasattr(ident, "converged"):
            notes.append("converged" if ident.converged else "NOT converged")
            notes.append(f"orders to {max(ident.poles.orders)}")
            notes += [w[:60] for w in ident.warnings]
        fe = ident.modes.fit_error
        if fe is not None:
            notes.append(f"fit error median {100 * float(np.median(fe)):.0f} %")
        print(f"{name:<28} {bstr:>12} {fn.size:>7d} {f'{found_once}/{len(ref)}':>9} {f'{conf}/{fn.size}':>9} "
              f"{med:>9} {t_ema:>8.2f}s {t_sdy:>7.2f}s  {'; '.join(notes)}")


if __name__ == "__main__":
    main()
