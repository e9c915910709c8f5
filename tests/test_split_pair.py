"""Two modes where the ML put one pole between them: a test of 2 modes against 1 on the same lines (issue 18).

ufffiles_frf (one FRF, ``benchmarks/study_real_bands.py``): in 0-800 Hz the clusters at 402 and
413.6 Hz were both accepted, in 80-720 Hz only 402 Hz, its ML estimate then moved to 406.6 Hz,
between the two peaks, and the 415 Hz cluster was "negligible" in the global fit. Now an accepted
mode whose ML estimate moved more than 3 sigma towards a rejected cluster, to between the two, is
tested against that cluster on the lines near it (nested F test, both models re-estimated there).
Oracle: the simulated modes' true poles; a single true mode with a spurious cluster beside it is
the control (the F test must reject it).
"""

from __future__ import annotations

import numpy as np
import pytest

from ema_rig.frf import FRFData
from ema_rig.identification.criteria import IdentificationCriteria
from ema_rig.identification.identification import _Completed, _fit_modes, _misfit, _split
from ema_rig.identification.judge import Candidate
from ema_rig.identification.stabilization import SelectedMode


def _pole(fn: float, z: float) -> complex:
    w = 2 * np.pi * fn
    return complex(-z * w, w * np.sqrt(1 - z * z))


def _data(modes, seed):
    """One mobility FRF of the given (f_n [Hz], zeta, amplitude) modes, 1 % complex noise."""
    f = np.arange(300.0, 520.0, 0.5)
    jw = 2j * np.pi * f
    h = np.zeros(f.size, complex)
    for fn, z, a in modes:
        lam = _pole(fn, z)
        r = a / (2j * lam.imag)
        h += r / (jw - lam) + np.conj(r) / (jw - np.conj(lam))
    h = jw * h
    rng = np.random.default_rng(seed)
    h = h + 0.01 * np.median(np.abs(h)) * (rng.standard_normal(f.size) + 1j * rng.standard_normal(f.size))
    return FRFData(f, h[None, None], ["1+Y"], ["1+Y"], frf_form="mobility")


def _data_outputs(modes, shapes, seed, noise):
    """Mobility FRFs of one reference at ``len(shapes[0])`` outputs: mode k's residue at output o is
    ``shapes[k][o] * a_k``; complex noise ``noise`` of each channel's median magnitude."""
    f = np.arange(300.0, 520.0, 0.5)
    jw = 2j * np.pi * f
    n_out = len(shapes[0])
    h = np.zeros((n_out, f.size), complex)
    for (fn, z, a), phi in zip(modes, shapes, strict=True):
        lam = _pole(fn, z)
        r = a * np.asarray(phi, float)[:, None] / (2j * lam.imag)
        h += r / (jw - lam) + np.conj(r) / (jw - np.conj(lam))
    h = jw * h
    rng = np.random.default_rng(seed)
    scale = noise * np.median(np.abs(h), axis=1, keepdims=True)
    h = h + scale * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape))
    return FRFData(f, h[:, None], [f"{o + 1}+Y" for o in range(n_out)], ["1+Y"], frf_form="mobility")


def _mode(fn: float, z: float, n_poles: int) -> SelectedMode:
    return SelectedMode(order=40, index=0, pole=_pole(fn, z), natural_freq=fn, damping_ratio=z,
                        natural_freq_std=0.01, damping_ratio_std=1e-4, n_poles=n_poles, participation=(1 + 0j,))


def _split_from(d: FRFData, f_cand: float) -> tuple[_Completed, _Completed]:
    # the state of ufffiles_frf's inner band: 402.1 Hz accepted (PolyMAX pole), a cluster beside it
    # rejected by the global F test
    kept, cand = _mode(402.1, 0.0215, 24), _mode(f_cand, 0.0135, 19)
    cands = (Candidate(kept, True, "physical"), Candidate(cand, False, "negligible contribution to the fit"))
    crit = IdentificationCriteria()
    fitted = _fit_modes(d, [kept], True)
    done = _Completed([kept], cands, fitted, _misfit(d, fitted[0], crit.completeness), ())
    return done, _split(d, done, True, crit)


@pytest.mark.parametrize("seed", [0, 1])
def test_two_modes_one_pole_between_split(seed):
    true = [(402.0, 0.02, 1.0), (413.5, 0.015, 0.7)]
    done, out = _split_from(_data(true, seed), 415.0)
    # the one-pole ML lands between the peaks (measured 408.2 Hz, sigma 2.0 Hz): the situation
    f_ml = abs(done.fitted[1].poles[0]) / (2 * np.pi)
    assert 403.0 < f_ml < 412.0
    # the rule's trigger: the ML moved more than split_sigmas of its sigma from the PolyMAX pole (402.1 Hz)
    # towards the cluster. Here the move is 3.0 sigma for every seed (0-7: 3.00-3.03 on 23abb6b, seed 7 below 3;
    # the one-pole fit's sandwich sigma grows with the misfit the move leaves), so whether it fires turns on the
    # last 1 % of sigma (the LM's step stop, MLCriteria.lm_step_sigma, leaves seed 1 at 2.998): the rule is
    # checked on both sides, the split where it fires (seed 0: 3.012)
    fires = f_ml - 402.1 > IdentificationCriteria().completeness.split_sigmas * done.fitted[1].natural_freq_std[0]
    assert fires or seed != 0
    assert (len(out.split) == 1 and out.candidates[1].accepted) == fires
    if not fires:
        return
    # both true modes recovered within their half-power half-bandwidth / 10 (measured within 0.05 Hz)
    fn = np.sort(out.fitted[0].natural_freq)
    assert fn.size == 2
    np.testing.assert_allclose(fn, [402.0, 413.5], atol=0.1 * 0.015 * 402)


@pytest.mark.parametrize("seed", [0, 1])
def test_one_mode_spurious_cluster_not_added(seed):
    # one true mode; a cluster at 390 Hz on the side the ML moves to (402.1 -> 402.0 Hz, > 3 sigma):
    # the nested F test on its lines must reject it
    done, out = _split_from(_data([(402.0, 0.02, 1.0)], seed), 390.0)
    assert out is done and not out.split


def _merged(d: FRFData, fn: float, z: float) -> tuple[_Completed, _Completed]:
    # one accepted mode, no rejected cluster beside it: the state of data/disk.uff at 0-2000 Hz
    kept = _mode(fn, z, 10)
    crit = IdentificationCriteria()
    fitted = _fit_modes(d, [kept], True)
    done = _Completed([kept], (Candidate(kept, True, "physical"),), fitted, _misfit(d, fitted[0], crit.completeness), ())
    return done, _split(d, done, True, crit)


@pytest.mark.parametrize("seed", [0, 1])
def test_pair_one_percent_apart_no_cluster_split(seed):
    # issue 18 Build 3: two modes 1 % apart, one reference, 2 % noise; PolyMAX gave one pole between
    # them and no cluster beside it. Oracle: the true poles of the simulated modes.
    true = [(402.0, 0.02, 1.0), (406.0, 0.015, 0.7)]
    shapes = [(1.0, 0.8, 0.5, -0.3), (0.4, -0.6, 1.0, 0.9)]
    done, out = _merged(_data_outputs(true, shapes, seed, 0.02), 404.0, 0.02)
    assert len(out.split) == 1
    fn = np.sort(out.fitted[0].natural_freq)
    zeta = out.fitted[0].damping_ratio[np.argsort(out.fitted[0].natural_freq)]
    assert fn.size == 2
    # within a tenth of the half-power half-bandwidth (0.6-0.8 Hz): the pair resolved, not a compromise
    np.testing.assert_allclose(fn, [402.0, 406.0], atol=0.1 * 0.015 * 402)
    np.testing.assert_allclose(zeta, [0.02, 0.015], atol=0.004)
    assert out.test.passed


@pytest.mark.parametrize("seed", [0, 1])
def test_one_mode_own_lines_fit_not_split(seed):
    # control: one true mode at 2 % noise; its own lines fit, so no second mode is tested or added
    done, out = _merged(_data_outputs([(402.0, 0.02, 1.0)], [(1.0, 0.8, 0.5, -0.3)], seed, 0.02), 402.3, 0.02)
    assert out is done and not out.split


def test_disk_uff_pair_found_within_two_sigma(identified_at_defaults):
    # data/disk.uff at the default band (0-2000 Hz): the simulator's truth has 789.66 Hz (zeta 2 %) and
    # 801.0 Hz (zeta 1.5 %), 1.4 % apart; before, one mode at 797.7 +/- 0.74 Hz (4.4 sigma from 801 Hz)
    # came without a warning. DESIGN 3: a result without a warning lies within 2 sigma of the truth.
    import json
    from pathlib import Path

    path = Path(__file__).resolve().parent.parent / "data" / "disk.uff"
    truth = json.loads(path.with_name("disk.uff.truth.json").read_text())["modes"]
    ident = identified_at_defaults(path)
    fn, zeta = ident.natural_freq, ident.damping_ratio
    s_f, s_z = ident.natural_freq_std, ident.damping_ratio_std
    for t in truth:
        if not 780 < t["natural_freq"] < 810:
            continue
        k = int(np.argmin(np.abs(fn - t["natural_freq"])))
        assert abs(fn[k] - t["natural_freq"]) <= 2 * s_f[k], (t, fn[k], s_f[k])
        assert abs(zeta[k] - t["damping_ratio"]) <= 2 * s_z[k], (t, zeta[k], s_z[k])
    assert np.sum((fn > 780) & (fn < 810)) == 2
