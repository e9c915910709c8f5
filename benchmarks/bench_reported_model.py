"""Benchmark: the reported model's per-channel choice with and without refitting the unweighted LSFD.

``identify`` reports, per channel, the noise-weighted LSFD unless the unweighted one is closer to the
data in noise units (``_lsfd_noise_weighted``). The unweighted fit at the same poles was already made
by ``_fit_modes``; passing it in (``unweighted=``) scores its synthesis instead of fitting it again.
Paired timing (alternating order) of the two calls on the bundled rig file (150-1000 Hz) and on the
256-output file of ``bench_refine.synthetic_256`` (100-1000 Hz), at the poles, data and noise variance ``identify`` uses, and the check
that both give the same model.

Run: ``python benchmarks/bench_reported_model.py`` (results: ``benchmarks/results/reported_model.txt``).
"""

from __future__ import annotations

import os
import statistics
import sys
import warnings

import numpy as np

sys.path.insert(0, os.path.dirname(__file__))
from _timing import paired  # noqa: E402

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def _case(data, band):
    from ema_rig.identification import identify
    from ema_rig.identification.criteria import COMPLETENESS_CRITERIA
    from ema_rig.identification.identification import _misfit
    from ema_rig.identification.lsfd import _lsfd_checked
    from ema_rig.identification.plscf import check_data

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        ident = identify(data, band=band)
    cut = check_data(data, ident.band)
    poles = ident.modes.poles
    un = _lsfd_checked(cut, poles)
    test = _misfit(cut, un, COMPLETENESS_CRITERIA)
    var = np.where(np.all(~np.isfinite(test.variance), axis=1, keepdims=True), 1.0, test.variance)
    return cut, poles, var.reshape(cut.frf.shape), un


def main() -> None:
    from ema_rig.config import load_rig
    from ema_rig.identification.lsfd import _lsfd_noise_weighted
    from ema_rig.io.uff import read_uff58

    cases = {"rig file (8 out, 1701 lines)": (read_uff58(REPO + "/data/b6302_1000N_1200rpm.uff",
                                                          rig=load_rig(REPO + "/data/rig.toml")), (150.0, 1000.0))}
    import tempfile
    from pathlib import Path

    from bench_refine import synthetic_256

    tmp = tempfile.TemporaryDirectory()
    synth = Path(tmp.name) / "synthetic_256.uff"
    synthetic_256(synth)
    cases["256 outputs (1801 lines)"] = (read_uff58(synth), (100.0, 1000.0))
    for name, (data, band) in cases.items():
        cut, poles, var, un = _case(data, band)
        a = _lsfd_noise_weighted(cut, poles, var)
        b = _lsfd_noise_weighted(cut, poles, var, unweighted=un)
        same = a.meta["weighted"] == b.meta["weighted"] and np.array_equal(a.residues, b.residues)
        ta, tb = paired(lambda: _lsfd_noise_weighted(cut, poles, var),  # noqa: B023
                        lambda: _lsfd_noise_weighted(cut, poles, var, unweighted=un), 41)  # noqa: B023
        ma, mb = statistics.median(ta), statistics.median(tb)
        print(f"{name}: refit {1e3 * ma:.2f} ms, reuse {1e3 * mb:.2f} ms, ratio {mb / ma:.2f} "
              f"(median of 41 pairs); weighted {a.meta['weighted']}; same model: {same}")


if __name__ == "__main__":
    main()
