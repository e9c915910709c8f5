"""Study: the local F test of a missing mode against model error, with placebo poles (issue 18).

``uff-corpus/ufffiles_frf.unv`` (one channel) in band A (the whole file) and band B (its inner
80 %), each identified at the defaults. For each band, the local nested F test
(``identification._nested_test``: one more pole with its residues over the band's final poles,
both re-estimated by the local ML on the lines within ``local_hbw`` half-power half-bandwidths)
of a pole at 704.9 Hz (A's mode, which B lacks; B's own poles within 3 Hz of it left out of the
null) and of placebo poles of the same damping at other places of the same neighbourhood. If the
F statistic were set by a model error the extra pole absorbs anywhere, the placebos would score
alike; the null of a placebo-calibrated test is "the candidate's F is that of an extra pole at
another place of the same lines".

Run: ``PYTHONPATH=. python benchmarks/study_local_f_placebo.py``.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np

SHARED = Path(os.environ.get("EMA_RIG_SHARED", "/work/shared"))
PLACES = (650.0, 657.5, 665.0, 672.5, 680.0, 695.0, 704.9, 710.0)  # Hz


def main() -> None:
    from ema_rig.identification import identification as idm
    from ema_rig.identification import identify
    from ema_rig.identification.criteria import COMPLETENESS_CRITERIA as cc
    from ema_rig.io.uff import read_uff58

    d = read_uff58(SHARED / "uff-corpus/ufffiles_frf.unv")
    lo, hi = float(d.freq[0]), float(d.freq[-1])
    bands = {"A": (lo, hi), "B": (lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo))}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = {k: identify(d, band=b) for k, b in bands.items()}
    la = np.asarray(res["A"].modes.poles)
    p704 = la[int(np.argmin(np.abs(np.abs(la) / (2 * np.pi) - 704.9)))]
    for name, (b0, b1) in bands.items():
        x = res[name]
        sel = (d.freq >= b0) & (d.freq <= b1)
        dd = d.replace(freq=d.freq[sel], frf=d.frf[:, :, sel], coherence=None)
        lam = np.asarray(x.modes.poles)
        fn = np.abs(lam) / (2 * np.pi)
        assert x.residual_test is not None and x.residual_test.variance is not None
        var = x.residual_test.variance
        print(f"band {name} {b0:.2f}-{b1:.2f} Hz: modes in 640-720 Hz {np.round(fn[(fn > 640) & (fn < 720)], 2).tolist()}")
        null = [p for p in lam if abs(abs(p) / (2 * np.pi) - 704.9) > 3.0]
        zeta = -p704.real / abs(p704)
        for fc in PLACES:
            wn = 2 * np.pi * fc
            p = complex(-zeta * wn, wn * np.sqrt(1 - zeta**2))
            half = max(cc.local_hbw * zeta * fc, 0.5 * cc.min_segment_lines * float(np.median(np.diff(dd.freq))))
            sl = (dd.freq >= fc - half) & (dd.freq <= fc + half)
            r = idm._nested_test(dd, null, p, sl, var, cc, [fc])
            tag = "A's mode" if fc == 704.9 else "placebo"
            if r is None:
                print(f"    {fc:7.2f} Hz ({tag}): the fit failed")
                continue
            print(f"    {fc:7.2f} Hz ({tag}, zeta {100 * zeta:.2f} %) lines {dd.freq[sl][0]:.1f}-{dd.freq[sl][-1]:.1f} Hz: "
                  f"F = {r[0]:8.1f} (F quantile {r[1]:.2f} with {r[2]:.0f}, {r[3]:.0f} dof)")


if __name__ == "__main__":
    main()
