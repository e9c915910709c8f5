"""c_TB's upper bound where the housing mode shares the radial housing motion with another mode.

A flexible frame part between the frame and the air springs, its own frequency 1-3 % from the
housing mode, couples to the housing through the air springs: the housing's radial motion, and
with it the bearing's dashpot, is spread over two modes. Read from the housing mode's own damping
ratio (the model's modal mass, all of the damping in the bearing) c_TB was an upper bound that
did not hold: on 4ff7088 the fresh seeds 24-35 of the study's frame-part family broke it in 4 of 12
(``benchmarks/results/study_unseen_truths_r_truth11.txt``; seed 25 1004 +/- 58 N s/m against the
dashpot's 1250, z -4.2; seed 29 729 +/- 33 against 883, z -4.6), each under a k_TB warning (a
warning on k_TB does not make a wrong c_TB right). The group's damping trace is kept by the
mixing (``sum_i 2 zeta_i w_i = 2 zeta_h w_h + the partners' own``): read from it the bound holds.

Oracle: the truth generator of ``benchmarks/study_unseen_truths.py`` (a lumped M, K, C of the rig
with the frame part, solved directly at every line; it imports nothing from ema_rig), whose
bearing dashpot ``Truth.c_TB`` is the value to bound.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

from ema_rig.config import load_rig
from ema_rig.io.uff import read_uff58
from ema_rig.rig import stiffness as st

pytest.importorskip("pyuff")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import study_unseen_truths as gen  # noqa: E402  (the independent truth generator)


def _estimate(tmp_path, truth):
    """The stiffness result of ``truth`` (the study generator's), written as UFF58 and its rig file."""
    rig_path = tmp_path / "rig.toml"
    rig_path.write_text(truth.rig_text(), encoding="utf-8")
    uff = tmp_path / "m.uff"
    gen.write_uff(uff, gen.FREQ, truth.frf(gen.FREQ))
    rig = load_rig(rig_path)
    return st.estimate_stiffness(read_uff58(uff, rig=rig), rig)



@pytest.mark.parametrize("seed", [25, 29])  # 25: the split-mass group; 29: two modes pass as housing mode
def test_c_tb_bound_holds_where_a_frame_part_shares_the_housing_motion(tmp_path, seed):
    truth, _ = gen.families()["frame part 1-3 % from the housing mode"](seed)
    res = _estimate(tmp_path, truth)
    assert res.warnings  # k_TB is caveated (the shared motion), as before
    d = res.damping
    assert d is not None and d.kind == "upper bound"
    # the bound holds to its own 2 sigma (broken on 4ff7088: z -4.2 / -4.6) ...
    assert truth.c_TB <= res.c_TB + 2 * res.c_TB_std
    # ... and is not vacuous: the partner's own damping (the frame part's, 0.3 % structural) makes
    # it 1.4-1.6x the dashpot on these seeds
    assert res.c_TB < 2.0 * truth.c_TB
    assert any("from their damping trace" in n for n in res.notes)
    assert np.isfinite(res.c_TB_std) and res.c_TB_std > 0


def test_mixed_lateral_pair_c_tb_split_by_the_mixing(tmp_path):
    # r_truth11's "lateral mode 1-2 % from the housing mode" made with tests/rig_truth.py: the housing's
    # lateral mode at 635 Hz, 30 % of the housing mode's energy in it through a bearing cross stiffness,
    # a bearing dashpot (zeta 2 %) and the lateral motion's own 2 % dashpot. The pair's damping trace
    # bounds the uncoupled housing mode's damping but carries the lateral motion's own: on 4ff7088 c_TB
    # read 2782 N s/m against the dashpot's 1126 (2.5x). The mixing (from both modes' amplitude ratios)
    # splits the trace: the uncoupled housing mode's damping, all of it read as the bearing's
    from rig_truth import TABLE1, RigTruth, write_case

    from ema_rig.cli import main

    ks = 1.0 / (1.0 / 71.57e6 + 1.0 / TABLE1["k_MS"])
    c_tb = 2 * 0.02 * (ks * TABLE1["m_H"]) ** 0.5 / (ks / 71.57e6) ** 2  # zeta 2 % on a lone housing
    truth = RigTruth(k_TB=71.57e6, cross_axis="lateral", lateral_freq=635.0, cross_leak=0.30,
                     damping="bearing_viscous", c_TB=c_tb, zeta=0.02, structural_zeta=0.003, seed=1)
    uff, rig_path = write_case(tmp_path, "mixed", truth, np.arange(0.0, 1100.25, 0.5))
    out = tmp_path / "res.json"
    assert main(["stiffness", str(uff), "--rig", str(rig_path), "--no-spindle", "--json", str(out)]) == 0
    import json

    doc = json.loads(out.read_text())
    assert doc["warnings"] == [] and doc["c_TB_kind"] == "upper bound"
    assert c_tb <= doc["c_TB"] + 2 * doc["c_TB_std"]
    # the uncoupled housing mode's damping: the dashpot and what the structure (0.3 %) adds to that mode
    # (a lone housing mode's bound reads 1.03-1.11x the dashpot on the study's fresh seeds); was 2.5x
    assert doc["c_TB"] <= 1.2 * c_tb
    # the partner the pair was decoupled with is in the JSON (DESIGN 3.2, an added key)
    partner = doc["mixed_partner"]
    assert partner is not None and doc["c_TB_partners"] == [partner]
    # ... and is the truth's lateral-dominated mode of the pair (scipy's eigenvalues of the truth's M, K:
    # the mode with most kinetic energy in z_H), to the identification's 0.5 %
    from scipy.linalg import eigh

    m, k = truth.matrices()
    lam, phi = eigh(k, m)
    f_lat = float(np.sqrt(lam[int(np.argmax(m[5, 5] * phi[5] ** 2))]) / (2 * np.pi))
    assert partner["natural_freq"] == pytest.approx(f_lat, rel=5e-3)
    assert any("split by its mixing" in n for n in doc["notes"])


def test_a_second_housing_mode_of_another_shape_is_no_polarity_warning(tmp_path):
    # r_truth12's family "second housing mode 1-4 % from the radial one, another shape", seed 46: an
    # ovalisation-like mode (the driving point 11 against 12 and 13) at 741 Hz beside the housing mode.
    # k_TB was right (z +0.07) but the run warned "741.3 Hz would be a clean radial translation with
    # 11+Y reversed: check the polarity of 11+Y" -- while the housing mode itself read 11, 12 and 13 in
    # phase, which a reversed 11+Y would not. The warning sent the user to a sensor that is fine
    truth, _ = gen.families()[
        "second housing mode 1-4 % from the radial one, another shape (ovalisation-like), 5-20 kg"](46)
    res = _estimate(tmp_path, truth)
    assert not any("polarity" in w for w in res.warnings)
    assert res.warnings == () and abs(res.k_TB - truth.k_TB) <= 2 * res.k_TB_std
    # the candidate still records which flip would make that mode a translation (for the drill-down)
    assert any(c.polarity_suspect == "11+Y" for c in res.match.candidates)


def test_mass_read_at_a_pole_damped_in_the_bearing(tmp_path):
    # r_truth12's "very heavy bearing damping zeta 10-20 %": a dashpot in the bearing, in series with
    # k_MS, makes the modal fit read the driving-point mass low by O(zeta^2) (the residue carries the
    # series element's Z'(s)). On 4ff7088 seed 37 read m_H 2.414 kg against the truth's 2.566 (-5.9 %,
    # used as measured), k_TB -11.2 % at z -2.61 and c_TB -18 % at z -3.36, all silent; seed 43 k_TB
    # -9.5 % at z -2.26 (benchmarks/results/study_unseen_truths_r_truth12.txt). Read through the damped
    # 3DOF model the mass, k_TB and c_TB are the truth's
    truth, _ = gen.families()["very heavy bearing damping zeta 10-20 %"](37)
    res = _estimate(tmp_path, truth)
    assert res.warnings == ()
    assert abs(res.k_TB - truth.k_TB) <= 2 * res.k_TB_std
    d = res.damping
    assert d is not None and d.kind == "measured" and abs(res.c_TB - truth.c_TB) <= 2 * res.c_TB_std
    hm = res.housing_mass
    if hm is not None and hm.used is not None and hm.used_rel_std is not None:  # where measured: the truth's
        assert abs(hm.used - truth.m_H) <= 2 * hm.used * hm.used_rel_std
