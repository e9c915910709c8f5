"""Study: why the sandwich with blocks of 4-6 lines under-covers where the model misses (issue 18).

``uff-corpus/ufffiles_frf.unv`` in band A (the whole file) and band B (its inner 80 %) at the
defaults. For every segment of the final local ML fit: its lines, the rule's least block length
``nb`` (the Hann main lobe, at least the mode's half-power half-bandwidth), the autocorrelation
of its weighted residual at lags 1, 4 and 16 lines (pooled over channels, Re and Im), Andrews'
(1991) bandwidth of its line scores, and each mode's frequency standard deviation (the larger of
the robust and the Fisher one, ``ml._basis_stds``, before the model-form part) with the robust meat
from non-overlapping blocks of ``nb`` lines against overlapping blocks of the data-chosen length
(``MLCriteria.block_from_scores``).

Run: ``PYTHONPATH=. python benchmarks/study_sandwich_blocks.py``.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np

SHARED = Path(os.environ.get("EMA_RIG_SHARED", "/work/shared"))


def main() -> None:
    from ema_rig.identification import identification as idm
    from ema_rig.identification import identify, ml
    from ema_rig.io.uff import read_uff58

    rec: list[tuple[Any, ...]] = []
    tail, call = ml._segment_tail, idm.local_ml

    def each_call(*a: Any, **k: Any) -> Any:
        rec.clear()  # only the last fit (the final model's) is reported
        return call(*a, **k)

    def each_segment(seg: Any, theta: Any, last: Any, held: Any, why: Any, fn0: Any, lines: Any, n_chan: int,
                     nb: int, rho: Any, nv: Any, criteria: Any) -> Any:
        out = tail(seg, theta, last, held, why, fn0, lines, n_chan, nb, rho, nv, criteria)
        ev = seg.evaluate(theta, scores=True, rho=rho, noise_var=nv, prev=last)
        e = np.asarray(ev["e"])
        n = seg.jw.size
        z = np.concatenate([e[:n], e[n:]], axis=1)  # (n, 2C): Re and Im of every channel
        z = z / np.sqrt(np.mean(z * z))
        ac = [float(np.sum(z[:-lag] * z[lag:]) / np.sum(z * z)) if lag < n else np.nan for lag in (1, 4, 16)]
        sc = np.asarray(ev["line_scores"])
        fixed = ml._basis_stds(seg, ev, theta, nb, False)[:, 0]
        data = ml._basis_stds(seg, ev, theta, nb, True)[:, 0]
        rec.append((lines, n, nb, ac, ml._score_bandwidth(sc), fn0, held.copy(), fixed, data))
        return out

    idm.local_ml = each_call
    ml._segment_tail = each_segment
    d = read_uff58(SHARED / "uff-corpus/ufffiles_frf.unv")
    lo, hi = float(d.freq[0]), float(d.freq[-1])
    for name, band in (("A", (lo, hi)), ("B", (lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo)))):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            identify(d, band=band)
        print(f"band {name} {band[0]:.2f}-{band[1]:.2f} Hz, final local ML fit:")
        for lines, n, nb, ac, bw, fn0, held, fixed, data in rec:
            print(f"  {lines[0]:7.2f}-{lines[1]:7.2f} Hz, {n:4d} lines: nb {nb:2d}, Andrews bandwidth {bw:6.1f} lines, "
                  f"residual autocorrelation lag 1/4/16 {ac[0]:+.2f}/{ac[1]:+.2f}/{ac[2]:+.2f}")
            for j, f in enumerate(fn0):
                print(f"      {f:8.3f} Hz{' (held)' if held[j] else '       '}: sigma_f blocks of {nb} {fixed[j]:.4f} Hz, "
                      f"from the scores {data[j]:.4f} Hz ({data[j] / fixed[j]:.2f}x)")


if __name__ == "__main__":
    main()
