"""Study: does a real measurement give the same modes in two reasonable bands (issue 18)?

For each file, ``identify`` at the defaults on two overlapping bands. A mode found in both
(nearest within 1 %) counts as consistent when its change lies within the combined two standard
uncertainties ``2 sqrt(s_a^2 + s_b^2)`` in natural frequency (and, reported separately, damping).
Modes away from the overlap's edges (three half-power bandwidths) found in only one band are
listed. Every reference mode of the data's README (a peer's or a published value) inside a band,
away from its edges, must be found exactly once (within 1 %). Files: ``real-frf/dam0.unv``, ``real-frf/vt_case1_full.uff``, ``uff-corpus/ufffiles_frf.unv``
under ``$EMA_RIG_SHARED`` (default ``/work/shared``).

Run: ``python benchmarks/study_real_bands.py`` (``--no-ml-features``: with
``CompletenessCriteria(ml_features=False)``, without the candidates at the features the local ML found).
"""

from __future__ import annotations

import os
import sys
import warnings
from pathlib import Path

import numpy as np

SHARED = Path(os.environ.get("EMA_RIG_SHARED", "/work/shared"))
#: Reference modes [Hz] from ``real-frf/README.md`` (vt_case1: published and two peers; dam0: sdypy-EMA).
REFERENCE = {
    "real-frf/dam0.unv": (2.482, 2.958, 3.497, 4.081, 4.167, 4.633, 7.124, 8.223, 8.643, 10.21, 10.89),
    "real-frf/vt_case1_full.uff": (34.06, 161.6, 212.09),
}
CASES = (
    ("real-frf/dam0.unv", (1.0, 12.0), (1.5, 11.5)),
    ("real-frf/dam0.unv", (1.0, 12.0), (2.0, 12.4)),
    ("real-frf/vt_case1_full.uff", (10.0, 300.0), (20.0, 400.0)),
    ("real-frf/vt_case1_full.uff", (0.0, 500.0), (25.0, 250.0)),
    ("uff-corpus/ufffiles_frf.unv", None, "inner"),
)


def main() -> None:
    from ema_rig.identification import identify
    from ema_rig.identification.criteria import CompletenessCriteria, IdentificationCriteria
    from ema_rig.io.uff import read_uff58

    crit = IdentificationCriteria(completeness=CompletenessCriteria(ml_features="--no-ml-features" not in sys.argv[1:]))
    rel_changes: list[float] = []

    n_f = n_f_ok = n_z_ok = 0
    n_ref = n_ref_once = n_one_band = 0
    for rel, band_a, band_b in CASES:
        path = SHARED / rel
        if not path.exists():
            print(f"{rel}: missing, skipped")
            continue
        data = read_uff58(path)
        if band_a is None:
            lo, hi = float(data.freq[0]), float(data.freq[-1])
            band_a = (lo, hi)
            band_b = (lo + 0.1 * (hi - lo), hi - 0.1 * (hi - lo))
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            a = identify(data, band=band_a, criteria=crit)
            b = identify(data, band=band_b, criteria=crit)
        lo, hi = max(a.band[0], b.band[0]), min(a.band[1], b.band[1])
        print(f"{rel}: band A {band_a}, {a.natural_freq.size} modes; band B {band_b}, {b.natural_freq.size} modes")
        for x, tag in ((a, "A"), (b, "B")):
            for fr in REFERENCE.get(rel, ()):
                if not (x.band[0] + 0.02 * fr < fr < x.band[1] - 0.02 * fr):
                    continue
                hits = int(np.sum(np.abs(x.natural_freq - fr) <= 0.01 * fr))
                n_ref += 1
                n_ref_once += hits == 1
                if hits != 1:
                    print(f"    reference {fr:g} Hz found {hits} times in band {tag}")
        for x, y, tag in ((a, b, "A"), (b, a, "B")):
            for k, f in enumerate(x.natural_freq):
                edge = 3 * x.damping_ratio[k] * f
                if not (lo + edge < f < hi - edge):
                    continue
                j = int(np.argmin(np.abs(y.natural_freq - f))) if y.natural_freq.size else -1
                if j < 0 or abs(y.natural_freq[j] - f) > 0.01 * f:
                    print(f"    {f:10.4f} Hz only in band {tag}")
                    n_one_band += 1
                    continue
                if tag == "B":
                    continue
                sf = np.hypot(x.natural_freq_std[k], y.natural_freq_std[j])
                sz = np.hypot(x.damping_ratio_std[k], y.damping_ratio_std[j])
                df, dz = y.natural_freq[j] - f, y.damping_ratio[j] - x.damping_ratio[k]
                ok_f, ok_z = abs(df) <= 2 * sf, abs(dz) <= 2 * sz
                n_f += 1
                rel_changes.append(abs(df) / f)
                n_f_ok += bool(ok_f)
                n_z_ok += bool(ok_z)
                print(f"    {f:10.4f} Hz: change {df:+.4f} Hz = {df / sf:+.2f} sigma, zeta {100 * dz:+.3f} % = "
                      f"{dz / sz:+.2f} sigma {'ok' if ok_f and ok_z else 'OUTSIDE 2 sigma'}")
    if n_f:
        print(f"inside 2 sigma: frequency {n_f_ok}/{n_f} = {100 * n_f_ok / n_f:.0f} %, "
              f"damping {n_z_ok}/{n_f} = {100 * n_z_ok / n_f:.0f} %; median |change| of f "
              f"{1e6 * float(np.median(rel_changes)):.0f} ppm, mean {1e6 * float(np.mean(rel_changes)):.0f} ppm")
    print(f"reference modes found exactly once: {n_ref_once}/{n_ref}; modes in only one band (away from the "
          f"edges): {n_one_band}")


if __name__ == "__main__":
    main()
