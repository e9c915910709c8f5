"""Shaft-harmonic rejection at low shaft speeds: a window that covers the axis is no evidence.

A lightly damped mode inside ``|f - k f_shaft| <= tol`` is called a shaft harmonic only when a mode
at a random frequency would rarely be there by chance: the windows cover ``2 tol / f_shaft`` of the
frequency axis (``MatchCriteria.harmonic_max_chance``, 1/3: a Bayes factor of 3). At 120 rpm (2 Hz) the 0.2 %
windows cover everything above 500 Hz, and 85b2494 rejected a 0.3 %-damped housing mode as the
313th harmonic (refusal); the truth (``tests/rig_truth.py``, no ema_rig) says it is the housing mode.
"""

from __future__ import annotations

import numpy as np
import pytest
from _rig_synth import housing_shape as _housing_shape
from _rig_synth import modal as _modal
from rig_truth import RigTruth, write_case

from ema_rig.config import load_rig, parse_rig
from ema_rig.io.uff import read_uff58
from ema_rig.rig import stiffness as st
from ema_rig.rig.candidates import harmonic_bands, harmonic_chance, harmonic_order
from ema_rig.rig.matching import MATCH_CRITERIA, match_modes


@pytest.fixture
def rig(rig_toml_text):
    import tomllib

    return parse_rig(tomllib.loads(rig_toml_text))


def test_chance_is_the_covered_fraction():
    # oracle: the share of a dense uniform grid (100 harmonics) that harmonic_order calls harmonic
    speed, tol = 7.0, 0.35
    f = np.linspace(10 * speed, 110 * speed, 400_001)[:-1]
    hits = np.mean([harmonic_order(float(x), speed, tol, 0.5) is not None for x in f[::40]])
    # 10 000 samples: binomial std sqrt(0.1 * 0.9 / 1e4) = 0.003; 2 tol / speed = 0.1
    assert harmonic_chance(speed, tol) == pytest.approx(0.1, rel=1e-12)
    assert hits == pytest.approx(0.1, abs=0.01)
    # overlapping windows cover everything: capped at 1
    assert harmonic_chance(1.0, 0.75) == 1.0
    assert MATCH_CRITERIA.harmonic_max_chance == pytest.approx(1 / 3, rel=1e-15)
    assert "Jeffreys" in MATCH_CRITERIA.sources()["harmonic_max_chance"]


def test_boundary_of_the_rule(rig):
    # an undamped line exactly on harmonic k with the 0.2 % window: chance 2 * 2e-3 * k = 0.004 k,
    # 0.332 at k = 83 (a harmonic), 0.336 at k = 84 (no evidence: kept, and it passes as housing-like)
    line = _housing_shape(rig.model, 600.0)
    h = _housing_shape(rig.model, 626.0)
    mm = _modal([(600.0, 2e-4, line), (626.0, 0.02, h)])
    res = match_modes(mm, rig, speed_hz=600.0 / 83)
    c = next(c for c in res.candidates if c.natural_freq < 610)
    assert c.harmonic == 83 and c.harmonic_ambiguous is None and "harmonic" in c.reason
    assert not any("harmonic windows" in w for w in res.warnings)
    res = match_modes(mm, rig, speed_hz=600.0 / 84)
    c = next(c for c in res.candidates if c.natural_freq < 610)
    assert c.harmonic is None and c.harmonic_ambiguous == 84
    # the line now passes the housing criteria beside 626 Hz: one warning for the measurement
    assert sum("harmonic windows" in w for w in res.warnings) == 1


def test_low_speed_housing_mode_is_matched(tmp_path):
    # 0.3 % damping on every mode, 120 rpm: 85b2494 refused ("harmonic line 313 x shaft speed")
    truth = RigTruth(k_TB=71.57e6, seed=3, zeta=0.003)
    uff, rig_path = write_case(tmp_path, "slow", truth, np.arange(0.0, 1100.25, 0.5))
    rig = load_rig(rig_path)
    res = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False, speed_hz=2.0)
    assert res.housing_mode["natural_freq"] == pytest.approx(626.0, abs=0.5)
    # the rule under test (DESIGN sect. 3): within 2 sigma of the truth; a warning says the
    # harmonic rejection could not tell, once
    assert abs(res.k_TB - truth.k_TB) <= 2 * res.k_TB_std
    assert sum("harmonic windows" in w for w in res.warnings) == 1
    # at 240 rpm the housing mode sits between windows (626 / 4 = 156.5): no warning
    res4 = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False, speed_hz=4.0)
    assert res4.k_TB == res.k_TB and not any("harmonic windows" in w for w in res4.warnings)


def test_reversed_excitation_polarity_warns_once(tmp_path):
    # the rig file declares the excitation 11-Y, the file (and the truth) push along 11+Y: every FRF
    # is flipped, k_TB unchanged (sign-free); 85b2494 said nothing. The truth's housing mode has a
    # real positive driving-point constant phi_p^2 (rig_truth: real modes, reciprocity), so the
    # flipped one is negative: one warning naming the polarity
    truth = RigTruth(k_TB=71.57e6, seed=3)
    uff, rig_path = write_case(tmp_path, "pol", truth, np.arange(0.0, 1100.25, 0.5))
    rig = load_rig(rig_path)
    ok = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)
    assert not any("polarity" in w for w in ok.warnings)
    rig_path.write_text(rig_path.read_text(encoding="utf-8").replace('radial = "11+Y"', 'radial = "11-Y"'),
                        encoding="utf-8")
    rig = load_rig(rig_path)
    res = st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False)
    assert res.k_TB == pytest.approx(ok.k_TB, rel=1e-9)
    assert sum("driving-point modal constant" in w and "11-Y" in w for w in res.warnings) == 1


def test_split_test_keeps_the_lines_of_harmonics_that_are_no_evidence(tmp_path, monkeypatch):
    # one rule for modes and lines: the split test leaves out only the windows that are evidence,
    # k <= harmonic_max_chance / (2 harmonic_freq_tol) = (1/3) / 4e-3 = 83.3. 1a73dd8 left out every
    # window, at 120 rpm (2 Hz) every line above 500 Hz: the own-lines test of the 626 Hz housing mode
    # had no line left
    c = MATCH_CRITERIA
    bands = harmonic_bands((100.0, 1000.0), 2.0, c.harmonic_freq_tol, c.harmonic_min_order, c.harmonic_max_chance)
    assert bands[-1][0] < 166.0 < bands[-1][1] and bands[-1][1] < 167.0  # the 83rd harmonic is the last
    full = harmonic_bands((100.0, 1000.0), 2.0, c.harmonic_freq_tol, c.harmonic_min_order)  # every window
    assert full[-1][1] >= 1000.0 and full[-1][0] <= 1000.0  # up to the band's top, the 500th harmonic and on
    # at 1200 rpm (20 Hz) every harmonic of a 150-1000 Hz band is evidence (50 <= 83): all listed
    assert harmonic_bands((150.0, 1000.0), 20.0, c.harmonic_freq_tol, c.harmonic_min_order,
                          c.harmonic_max_chance) == harmonic_bands((150.0, 1000.0), 20.0, c.harmonic_freq_tol,
                                                                   c.harmonic_min_order)
    # what estimate_stiffness hands to identify at 120 rpm
    truth = RigTruth(k_TB=71.57e6, seed=3, zeta=0.003)
    uff, rig_path = write_case(tmp_path, "slow", truth, np.arange(0.0, 1100.25, 0.5))
    rig = load_rig(rig_path)
    seen: list[tuple[tuple[float, float], ...]] = []

    class _Stop(Exception):
        pass

    def spy(*a, **kw):
        seen.append(kw["harmonic_bands"])
        raise _Stop

    monkeypatch.setattr(st, "identify", spy)
    with pytest.raises(_Stop):
        st.estimate_stiffness(read_uff58(uff, rig=rig), rig, spindle=False, speed_hz=2.0)
    assert seen and seen[0] and max(hi for _, hi in seen[0]) < 167.0
