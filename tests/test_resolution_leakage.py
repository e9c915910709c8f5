"""The housing mode read on lines too coarse for it: a Hann-windowed spectrum (leakage).

The truth is ``tests/rig_truth.py``'s 12-coordinate rig (not ema_rig's model), its FRF lines those of
a Hann-windowed random test (:func:`rig_truth.hann_leaked_frf`: the exact FRF averaged over the
window's spectral power, Bendat & Piersol ch. 8), written to UFF58 and read back. On 7b8cca3 the
split housing mode (two poles about a line apart) was warned of only as a coupling and a missing
mass part, and a mass read 0.9x the model's as "an unidentified part of the housing motion"; the
warning of the resolution is new (the tests fail there).
"""

from __future__ import annotations

import numpy as np
import pytest
from rig_truth import RigTruth, write_case

from ema_rig.config import load_rig
from ema_rig.io.uff import read_uff58
from ema_rig.rig import stiffness as st
from ema_rig.rig.matching import MATCH_CRITERIA

pytest.importorskip("ema_rig.identification")

_RESOLUTION = "lines of"  # the resolution warning names the line spacing ("... lines of 5 Hz ...")


def _estimate(tmp_path, name, truth, df, hann):
    freq = np.arange(0.0, 1100.0 + df / 2, df)
    uff, rig_path = write_case(tmp_path, name, truth, freq, hann=hann)
    rig = load_rig(rig_path)
    return st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)


def _resolution_warnings(res):
    return [w for w in res.warnings if "half-power band spans" in w and _RESOLUTION in w]


def test_leaked_housing_mode_is_warned_of_its_resolution(tmp_path):
    # zeta 1 % at 626 Hz: half-power band 12.5 Hz, 2.5 lines of 5 Hz (a 400-line analyser on 2 kHz);
    # the window smears the peak and the driving-point mass reads ~0.9x the model's
    truth = RigTruth(k_TB=71.57e6, zeta=0.01, seed=2)
    res = _estimate(tmp_path, "leak", truth, 5.0, hann=True)
    w = _resolution_warnings(res)
    assert len(w) == 1, res.warnings
    # the remedy: lines of at most B_r / (4 x 1.5), B_r read from the identified damping, which the
    # window widens (true B_r 12.5 Hz: 2.1 Hz), and finer than the 5 Hz measured
    n_min = MATCH_CRITERIA.min_bandwidth_resolutions * MATCH_CRITERIA.resolution_lines
    most = float(w[0].rsplit("at most ", 1)[1].split(" Hz")[0])
    assert 2 * 0.01 * truth.housing_freq() / n_min <= most < 5.0
    # the result itself stays within its (wide) uncertainty
    assert abs(res.k_TB - truth.k_TB) <= 2 * res.k_TB_std


def test_exact_lines_at_the_same_spacing_are_not_warned(tmp_path):
    # the same truth and spacing without the window: the readings agree, no resolution warning
    # (coarse lines alone are no caveat: no blanket warning)
    truth = RigTruth(k_TB=71.57e6, zeta=0.01, seed=2)
    res = _estimate(tmp_path, "exact", truth, 5.0, hann=False)
    assert _resolution_warnings(res) == [], res.warnings
    assert abs(res.k_TB - truth.k_TB) <= 2 * res.k_TB_std


def test_resolution_criteria_are_sourced():
    src = MATCH_CRITERIA.sources()
    assert "Harris" in src["resolution_lines"] and "Bendat" in src["min_bandwidth_resolutions"]
    from ema_rig.identification.criteria import COMPLETENESS_CRITERIA

    src = COMPLETENESS_CRITERIA.sources()
    assert "Harris" in src["resolution_lines"] and "Allemang" in src["resolution_mac"]


def test_mode_split_by_leakage_is_reported_once(tmp_path):
    # zeta 1 % at 626 Hz on lines of 4.17 Hz: its half-power band spans 3 lines, and the Hann
    # window's smoothing (rig_truth.hann_leaked_frf) is fitted by two poles 0.8 lines apart on
    # 6b525dd (625.1 and 628.4 Hz, the same shape): the spectrum resolves nothing closer than the
    # window's noise bandwidth (1.5 lines, Harris 1978), so one mode is reported, with the warning
    from ema_rig.identification import identify

    truth = RigTruth(k_TB=71.57e6, zeta=0.01, seed=3)
    f_h = truth.housing_freq()
    df = round(2 * 0.01 * f_h / 3.0, 3)
    m, k = truth.matrices()
    lam = np.linalg.eigvals(np.linalg.solve(m, k)).real
    f_true = np.sqrt(lam[lam > 0]) / (2 * np.pi)
    assert np.sum(np.abs(f_true - f_h) < 3 * df) == 1  # no second true mode near the housing mode
    freq = np.arange(0.0, 1100.0 + df / 2, df)
    uff, rig_path = write_case(tmp_path, "split", truth, freq, hann=True)
    rig = load_rig(rig_path)
    ident = identify(read_uff58(uff, rig=rig))
    fn = ident.modes.natural_freq
    near = fn[np.abs(fn - f_h) < 3 * df]
    assert near.size == 1, fn
    # the window smooths the peak symmetrically: the one pole sits on the true frequency to a tenth of a line
    assert abs(near[0] - f_h) < 0.1 * df
    assert any("reported as one mode" in w and "resolution bandwidth is 1.5 lines" in w for w in ident.warnings), \
        ident.warnings
    # k_TB without the phantom partner's coupling term: within 2 sigma, sigma a few % (37-75 % with the pair)
    res = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)
    assert abs(res.k_TB - truth.k_TB) <= 2 * res.k_TB_std
    assert res.k_TB_std < 0.10 * res.k_TB
