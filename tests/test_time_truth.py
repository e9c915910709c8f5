"""identify's default ± against an independent truth that goes through time data (issue 18).

Records of a modal system simulated with numpy/scipy only (``tests/_time_truth.py``) ->
``estimate_frf`` (Hann, 50 % overlap, H1) -> ``identify`` at the defaults. The full study
(6 configurations x 20 seeds) is ``benchmarks/study_time_truth.py``; here two configurations
x 4 seeds, pooled.
"""

from __future__ import annotations

import warnings

import _time_truth as tt
import numpy as np
import pytest


@pytest.fixture(scope="module")
def runs():
    out = []
    for name in ("noise floor 5 %", "pair 1 % apart, 1 reference, 2 % noise"):
        case = next(c for c in tt.CASES if c.name == name)
        for seed in range(4):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                out.append(tt.run_case(case, seed))
    return out


def test_every_true_mode_found_once(runs):
    # both modes of the pair 1 % apart included (one reference, 2 % noise)
    assert all(r["found"].all() for r in runs)
    assert all(int(r["n_modes"]) == r["found"].size for r in runs)


def test_two_sigma_covers_the_truth(runs):
    # 36 (mode, seed) values pooled: >= 90 % inside 2 sigma (measured 100 % in f, 97 % in zeta); the
    # full study gives 93-100 %. The sigma is conservative here (rms z measured 0.48 in f, 0.75 in
    # zeta: the window's line correlation is taken at its white-noise value); a sigma 3x too large
    # or 1.5x too small fails
    zf = np.concatenate([r["z_f"] for r in runs])
    zz = np.concatenate([r["z_z"] for r in runs])
    assert np.mean(np.abs(zf) <= 2) >= 0.9 and np.mean(np.abs(zz) <= 2) >= 0.9, (zf, zz)
    assert 0.33 < np.sqrt(np.mean(zf**2)) < 1.5 and 0.33 < np.sqrt(np.mean(zz**2)) < 1.5, (zf, zz)
