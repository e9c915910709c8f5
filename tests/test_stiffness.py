"""The per-measurement stiffness pipeline (ema_rig.rig.stiffness).

Two layers of tests:

* the pipeline with the identification replaced by a known modal model (exact truth: the
  housing mode of the 3DOF model at a chosen k_TB), so matching + inversion + uncertainty are
  checked without identification error;
* end to end on simulated measurements (noise, every extra mode, harmonics) through PolyMAX,
  against the simulator's truth; and a coverage test of the reported uncertainty.
"""

from __future__ import annotations

import json
import math
import tomllib
import types
from dataclasses import replace

import numpy as np
import pytest
from _rig_synth import damping_term_by_hand, housing_shape, modal, rig_modes

from ema_rig.config import MODEL_KEYS, parse_rig
from ema_rig.errors import InversionError, MatchingError
from ema_rig.rig import stiffness as st
from ema_rig.rig.inversion import housing_freq_from_k_tb_ms
from ema_rig.rig.model import series_stiffness


@pytest.fixture
def rig(rig_toml_text):
    return parse_rig(tomllib.loads(rig_toml_text))


def _zero_unc(rig):
    """The rig with every parameter exactly known: only the frequency term remains."""
    return replace(rig, uncertainty={k: 0.0 for k in MODEL_KEYS})


def _fake_identify(monkeypatch, mm, freq_std):
    """Replace PolyMAX by a known modal model (natural_freq_std per mode, Hz)."""
    calls = []

    def fake(data, band, max_order, progress, *_rig):
        calls.append(band)
        return types.SimpleNamespace(modes=mm, natural_freq_std=np.full(mm.n_modes, freq_std), warnings=())

    monkeypatch.setattr(st, "_identify", fake)
    return calls


def _data_from(mm):
    f = np.linspace(1.0, 2000.0, 2000)
    return mm.synthesize(f, frf_form="accelerance").with_meta(file="fake.uff")


# ----------------------------------------------------------------------------- known modes
@pytest.mark.parametrize("k_tb", [71.57e6, 32.6e6])  # paper bearing at 626 Hz, dummy bearing
def test_pipeline_exact_modes_round_trip(rig, monkeypatch, k_tb):
    f_h = housing_freq_from_k_tb_ms(series_stiffness(k_tb, rig.model.k_MS), rig.model)
    mm = modal(rig_modes(rig.model, f_h))
    _fake_identify(monkeypatch, mm, 0.2)
    res = st.estimate_stiffness(_data_from(mm), _zero_unc(rig), spindle=False)
    # exact housing frequency in, exact 3DOF inversion out: k_TB to 1e-9 (root-finder grade)
    np.testing.assert_allclose(res.k_TB, k_tb, rtol=1e-9)
    np.testing.assert_allclose(res.k_TB_MS, series_stiffness(k_tb, rig.model.k_MS), rtol=1e-9)
    # only the frequency term: u_k/k = S_f u_f/f, S_f = 3.84 at 626 Hz (DESIGN §4, 3 digits)
    if abs(f_h - 626.0) < 1:
        np.testing.assert_allclose(res.k_TB_std_measured / res.k_TB, 3.84 * 0.2 / f_h, rtol=5e-3)
    # the rest is the damping-model term, zeta = 2 %: rectangular over the wider of the viscous/hysteretic
    # readings' (1 - sqrt(1 - 2 zeta^2)) and the all-in-the-bearing reading's shift (0.066 % at 626 Hz)
    u_damp = damping_term_by_hand(rig.model, f_h, 0.02)
    u_meas = 0.2 / f_h
    np.testing.assert_allclose(res.uncertainty_budget["f_H"], u_meas**2 / (u_meas**2 + u_damp**2), rtol=1e-6)
    assert res.warnings == ()  # an exact, unambiguous housing mode needs no caveat
    d = res.to_dict()
    for key in ("k_TB", "k_TB_std", "k_TB_MS", "k_MS", "housing_mode", "spindle_mode",
                "uncertainty_budget", "candidates", "file"):
        assert key in d
    assert d["file"] == "fake.uff"
    json.dumps(d, allow_nan=False)  # JSON-safe (no NaN, no numpy types)
    # the spindle mode of the model set is found in the same band when it is in the model
    assert d["spindle_mode"] is not None


def test_budget_with_parameter_tolerances(rig, monkeypatch):
    mm = modal(rig_modes(rig.model, 626.0))
    _fake_identify(monkeypatch, mm, 0.0)
    r = replace(rig, uncertainty={"m_H": 0.01, **{k: 0.0 for k in MODEL_KEYS if k != "m_H"}})
    res = st.estimate_stiffness(_data_from(mm), r, spindle=False)
    # +1 % in m_H -> +1.88 % in k_TB (DESIGN §4): the only term, 2 % tolerance on the quoted value
    np.testing.assert_allclose(res.k_TB_std / res.k_TB, 0.0188, rtol=2e-2)
    # beside it only the damping-model term (zeta 2 %: S_f = 3.84 times its 0.066 % of the frequency,
    # 0.25 % of k_TB, 1.8 % of the variance)
    u_d = 3.84 * damping_term_by_hand(rig.model, 626.0, 0.02)
    np.testing.assert_allclose(res.uncertainty_budget["m_H"], 0.0188**2 / (0.0188**2 + u_d**2), atol=3e-3)
    kinds = {t.name: t.kind for t in res.uncertainty.terms}
    assert kinds["m_H"] == "assumed (rig file)" and kinds["f_H"] == "measured"
    assert kinds["damping model"] == "model form" and res.notes == ()
    # a calibrated k_MS with its std: the k_MS term appears with sensitivity -0.62 (DESIGN §4), beside
    # the damping-model term
    res2 = st.estimate_stiffness(_data_from(mm), _zero_unc(rig), k_ms=114e6, k_ms_std=1.14e6, spindle=False)
    np.testing.assert_allclose(res2.k_TB_std / res2.k_TB, math.hypot(0.0062, u_d), rtol=3e-2)
    np.testing.assert_allclose(sum(res2.uncertainty_budget.values()), 1.0, rtol=1e-12)


def test_calibrate_exact_disk(rig, monkeypatch):
    f_disk = housing_freq_from_k_tb_ms(rig.model.k_MS, rig.model)  # rigid disk: k_TB+MS = k_MS
    mm = modal(rig_modes(rig.model, f_disk))
    _fake_identify(monkeypatch, mm, 0.5)
    res = st.calibrate(_data_from(mm), rig)
    # DESIGN §4: 897.35 Hz for k_TB+MS = k_MS; the calibration returns k_MS to 1e-9
    np.testing.assert_allclose(f_disk, 897.35, atol=0.01)
    np.testing.assert_allclose(res.k_MS, rig.model.k_MS, rtol=1e-9)
    assert res.k_MS_std > 0
    d = res.to_dict()
    assert {"k_MS", "k_MS_std", "housing_mode"} <= set(d)
    np.testing.assert_allclose(d["housing_mode"]["natural_freq"], f_disk, rtol=1e-12)
    # a finite disk in series: 1/k_MS = 1/k_TB+MS - 1/k_disk (rtol 1e-9, closed form)
    res2 = st.calibrate(_data_from(mm), rig, k_disk=2e9)
    np.testing.assert_allclose(1 / res2.k_MS, 1 / rig.model.k_MS - 1 / 2e9, rtol=1e-9)


def _disk_freq_by_hand(params, k_tb_ms):
    """Housing-mode frequency [Hz] of the paper's 3DOF matrices, written out here (oracle)."""
    import scipy.linalg

    k, ka, ks, kb = k_tb_ms, params.k_AS, params.k_S, params.k_B
    kk = np.array([[ka + k, -k, -ka], [-k, k + ks, -ks], [-ka, -ks, ka + ks + kb]])
    mm = np.diag([params.m_H, params.m_S, params.m_F])
    f = np.sqrt(scipy.linalg.eigvalsh(kk, mm)) / (2 * math.pi)
    return float(f[1])  # frame < housing < spindle bending on Table 1


def test_calibrate_soft_disk_from_rig_file(rig_toml_text, monkeypatch):
    # the paper's "at least 10x": a disk 10x k_MS with a 5 % FE uncertainty, given in the rig file
    k_ms = 114e6
    k_disk, k_disk_std = 10 * k_ms, 0.05 * 10 * k_ms
    rig = parse_rig(tomllib.loads(rig_toml_text + f"\n[calibration]\nk_disk = {k_disk}\nk_disk_std = {k_disk_std}\n"))
    assert (rig.k_disk, rig.k_disk_std) == (k_disk, k_disk_std)
    k_series = 1.0 / (1.0 / k_ms + 1.0 / k_disk)  # disk in series with the mounting: 103.6 MN/m
    f_disk = _disk_freq_by_hand(rig.model, k_series)
    mm = modal(rig_modes(rig.model, f_disk))
    _fake_identify(monkeypatch, mm, 0.5)
    res = st.calibrate(_data_from(mm), rig)
    # the series compliance is removed: k_MS back within its stated sigma (exact modes: ~1e-9)
    assert abs(res.k_MS - k_ms) < res.k_MS_std
    np.testing.assert_allclose(res.k_MS, k_ms, rtol=1e-6)
    # the disk's std enters the budget: d k_MS / d k_disk = -(k_MS/k_disk)^2 = -0.01 -> 0.05 % of k_MS
    assert res.k_MS_std >= 0.01 * k_disk_std * (1 - 1e-9)
    # an explicit k_disk (CLI --k-disk) wins over the rig file's
    res2 = st.calibrate(_data_from(mm), rig, k_disk=2 * k_disk)
    np.testing.assert_allclose(1 / res2.k_MS, 1 / k_series - 1 / (2 * k_disk), rtol=1e-6)
    # the rigid-disk convention on the same data would be 9.1 % low: the key matters
    plain = st.calibrate(_data_from(mm), parse_rig(tomllib.loads(rig_toml_text)))
    np.testing.assert_allclose(plain.k_MS / k_ms, 1 / 1.1, rtol=1e-6)
    # the paper's bound itself (10x) is no caveat
    assert not any("steel disk" in w for w in res.warnings + res2.warnings)


def test_calibrate_disk_softer_than_the_papers_warns(rig_toml_text, monkeypatch):
    """A disk only 1.3x the mounting it calibrates: no word on 4ff7088 (`calibrate data/disk.uff --k-disk 1.5e8`,
    one zero short, gave k_MS = 474 MN/m, 4.2x the rig's, +/- 0.3 %, exit 0). The closed form's own sensitivity
    is the oracle: 1 % in k_disk is k_MS / k_disk % in k_MS (d ln k_MS / d ln k_disk)."""
    rig = parse_rig(tomllib.loads(rig_toml_text))
    k_ms, k_disk = 114e6, 1.5e8
    f_disk = _disk_freq_by_hand(rig.model, 1.0 / (1.0 / k_ms + 1.0 / k_disk))
    mm = modal(rig_modes(rig.model, f_disk))
    _fake_identify(monkeypatch, mm, 0.5)
    res = st.calibrate(_data_from(mm), rig, k_disk=k_disk)
    np.testing.assert_allclose(res.k_MS, k_ms, rtol=1e-6)  # the closed form itself is right (exact modes)
    w = [w for w in res.warnings if "steel disk" in w]
    assert len(w) == 1 and "only 1.3x" in w[0] and "1 % in k_disk is 0.76 % in k_MS" in w[0], w
    assert "k_disk_std is not given" in w[0]


@pytest.mark.parametrize(
    ("table", "key"),
    [
        ("k_disk = -1.0", "calibration.k_disk"),
        ("k_disk = 'stiff'", "calibration.k_disk"),
        ("k_disk_std = 1e7", "calibration.k_disk_std"),
        ("k_disk = 1e9\nk_disk_std = -5.0", "calibration.k_disk_std"),
        ("k_disk = 1e9\nkdisk_std = 5.0", "calibration.kdisk_std"),
    ],
)
def test_rig_file_calibration_keys_validated(rig_toml_text, table, key):
    from ema_rig.errors import ConfigError

    with pytest.raises(ConfigError, match=key.replace(".", r"\.")) as ei:
        parse_rig(tomllib.loads(rig_toml_text + "\n[calibration]\n" + table + "\n"), file="rig.toml")
    assert "rig.toml" in str(ei.value)


def test_housing_frequency_above_rigid_bearing_is_error_not_negative(rig, monkeypatch):
    # a housing mode at 950 Hz needs k_TB+MS > k_MS (114e6): k_TB would be negative
    mm = modal([(950.0, 0.02, housing_shape(rig.model, 950.0))])
    _fake_identify(monkeypatch, mm, 0.2)
    with pytest.raises(InversionError, match="897") as ei:
        st.estimate_stiffness(_data_from(mm), rig, spindle=False)
    assert ei.value.file == "fake.uff"


def test_no_housing_mode_lists_candidates(rig, monkeypatch):
    modes = [m for m in rig_modes(rig.model, 626.0) if abs(m[0] - 626.0) > 1]
    mm = modal(modes)
    _fake_identify(monkeypatch, mm, 0.2)
    with pytest.raises(MatchingError) as ei:
        st.estimate_stiffness(_data_from(mm), rig, spindle=False)
    cands = ei.value.candidates
    assert len(cands) == mm.n_modes and all(c["status"] == "rejected" and c["reason"] for c in cands)
    # the reasons live in the candidates (JSON); the message is one short line naming the nearest
    reasons = " ".join(c["reason"] for c in cands)
    assert "tilt" in reasons and "lateral" in reasons
    assert len(str(ei.value)) <= 300 and "\n" not in str(ei.value)
    assert "663.0 Hz" in str(ei.value)  # the frame mode: housing-like shape, 12x the mass


def test_band_outside_data_is_error(rig, monkeypatch):
    mm = modal(rig_modes(rig.model, 626.0))
    _fake_identify(monkeypatch, mm, 0.2)
    from ema_rig.errors import IdentificationError

    with pytest.raises(IdentificationError, match="outside the data"):
        st.estimate_stiffness(_data_from(mm), rig, band=(3000.0, 4000.0))


# ----------------------------------------------------------------------------- end to end
identify_mod = pytest.importorskip("ema_rig.identification")
simulate = pytest.importorskip("ema_rig.simulate")


def _has_identify():
    return hasattr(identify_mod, "identify")


@pytest.mark.skipif(not _has_identify(), reason="ema_rig.identification.identify not available yet")
@pytest.mark.parametrize(
    ("k_tb", "speed_hz"),
    [(71.57e6, None), (32.6e6, None), (90e6, 25.0)],  # 626 Hz bearing, dummy, rotating 1500 rpm
)
def test_end_to_end_simulated(rig, k_tb, speed_hz):
    sim = simulate.simulate_measurement(rig, k_tb=k_tb, noise=0.01, seed=3, speed_hz=speed_hz)
    res = st.estimate_stiffness(sim.data, rig, speed_hz=speed_hz, spindle=False)
    # the simulator's radial dynamics are the 3DOF model's: k_TB within 1 % (issue 4); 1.5 % where the
    # modal mass is ambiguous (the rotating case: cross-axis motion past the misalignment's 2 sigma) and
    # m_H is read from the mode's shape (issue 19: 0.7 % low there against its 2.7 % std, k_TB -1.0 %)
    np.testing.assert_allclose(res.k_TB, sim.truth["k_TB"], rtol=1e-2 if speed_hz is None else 1.5e-2)
    np.testing.assert_allclose(res.housing_mode["natural_freq"], sim.truth["f_H"], rtol=2e-3)
    kinds = {c["status"] for c in res.candidates}
    assert "housing" in kinds and "rejected" in kinds


@pytest.mark.skipif(not _has_identify(), reason="ema_rig.identification.identify not available yet")
def test_uncertainty_coverage(rig):
    """k_TB +- 2 k_TB_std (1 sigma std, ~95 % nominal) covers the truth in >= 90 % of 20 runs.

    Parameters are exact here (the simulator uses the rig file's values), so k_TB_std holds only
    the identified frequency spread: the test checks that term honestly.
    """
    r = _zero_unc(rig)
    f = np.arange(100.0, 1100.0 + 0.25, 0.5)  # the band of interest only: fast
    hits, n = 0, 20
    errs, rel_std = [], []
    for seed in range(n):
        sim = simulate.simulate_measurement(rig, k_tb=71.57e6, noise=0.02, seed=100 + seed, freq=f)
        res = st.estimate_stiffness(sim.data, r, spindle=False, max_order=40)
        z = (res.k_TB - sim.truth["k_TB"]) / res.k_TB_std
        errs.append(z)
        rel_std.append(res.k_TB_std / res.k_TB)
        hits += abs(z) <= 2.0
    assert hits >= math.ceil(0.9 * n), f"coverage {hits}/{n}, z = {np.round(errs, 2)}"
    # and the interval stays informative (a huge std would cover trivially): median u(k)/k < 1 %
    # (measured 0.62 %: the ML sigma of f_H plus the term of the housing mode's local modal-mass check,
    # issues 18/19; a 10x wider interval fails)
    assert np.median(rel_std) < 1e-2, f"median relative std {np.median(rel_std):.2e}"


# ----------------------------------------------------------------------------- plot (Fig. 7)
def test_plot_rig_fit_artists(rig, monkeypatch, mplcleanup, tmp_path):
    from ema_rig.plot.rig import plot_rig_fit, save_figure

    mm = modal(rig_modes(rig.model, 626.0))
    _fake_identify(monkeypatch, mm, 0.2)
    data = _data_from(mm)
    res = st.estimate_stiffness(data, rig, spindle=False)
    p = plot_rig_fit(data, res, rig)
    assert set(p.axes) == {"housing", "spindle", "candidates"}
    # 3 radial housing + 2 radial spindle sensors drawn, one model line per panel
    assert len(p.artists["measured"]) == 5 and len(p.artists["model"]) == 2
    # the chosen mode is marked at its frequency (exact: the known housing mode)
    xs = [ln.get_xdata()[0] for ln in p.artists["housing_mode"]]
    np.testing.assert_allclose(xs, 626.0, rtol=1e-12)
    # the candidates inside 150-700 Hz (287, 300, 410, 626, 663 Hz) each get a marker
    assert len(p.artists["candidates"]) == 5
    # the drawn model is the inverted one: its housing mode is the identified frequency
    np.testing.assert_allclose(housing_freq_from_k_tb_ms(p.model_k_tb_ms, rig.model), 626.0, rtol=1e-9)
    assert p.axes["housing"].get_ylabel() == "|FRF| [m/s^2/N]"
    out = tmp_path / "fig7.png"
    save_figure(p.figure, out)
    assert out.stat().st_size > 10_000


@pytest.mark.skipif(not _has_identify(), reason="ema_rig.identification.identify not available yet")
def test_end_to_end_spindle_mode(rig):
    sim = simulate.simulate_measurement(rig, k_tb=71.57e6, noise=0.01, seed=11)
    res = st.estimate_stiffness(sim.data, rig)
    assert res.spindle_mode is not None and res.spindle_band is not None
    # the spindle bending mode of the 3DOF model (1907.2 Hz) found in its own band: 0.1 %
    np.testing.assert_allclose(res.spindle_mode["natural_freq"], sim.truth["f_spindle"], rtol=1e-3)
    np.testing.assert_allclose(res.k_TB, sim.truth["k_TB"], rtol=1e-2)


def test_mass_off_the_model_warns_and_widens(rig, monkeypatch):
    # the housing mode with 1.3x the model's effective mass (exact modal data): warning and a
    # model-form term |ln 1.3| / 4 of the frequency (the split-mass reading f sqrt(1.3) at 2 sigma)
    modes = [m for m in rig_modes(rig.model, 626.0) if abs(m[0] - 626.0) > 1e-9]
    mm = modal(modes + [(626.0, 0.02, housing_shape(rig.model, 626.0, mass_factor=1.3))])
    _fake_identify(monkeypatch, mm, 0.1)
    res = st.estimate_stiffness(_data_from(mm), _zero_unc(rig), spindle=False)
    assert any("1.30x the model's" in w for w in res.warnings)
    # the mass ratio comes from the fit of the housing mode with its 663 Hz neighbour on every channel
    # over +-30 % (issue 19): exact to ~3e-4 on these synthesised FRFs (its residual terms stand for
    # the modes outside those lines only approximately; the one-channel fit over +-10 % gave ~1e-5)
    assert res.uncertainty.term("effective mass").rel_input == pytest.approx(math.log(1.3) / 4, rel=1e-3)
    # the value itself is untouched (the identified frequency is inverted)
    assert res.inverted_freq == pytest.approx(626.0, rel=1e-12)
    assert res.to_dict()["warnings"] == list(res.warnings)


def test_two_passing_modes_far_apart_are_refused(rig, monkeypatch):
    # two perfect housing-like modes 20 % apart: no term can cover that -> refused, one line
    h1, h2 = housing_shape(rig.model, 560.0), housing_shape(rig.model, 680.0)
    mm = modal([(560.0, 0.02, h1), (680.0, 0.02, h2)])
    _fake_identify(monkeypatch, mm, 0.1)
    with pytest.raises(MatchingError, match="ambiguous housing mode") as ei:
        st.estimate_stiffness(_data_from(mm), rig, spindle=False)
    assert len(ei.value.message) <= 300 and ei.value.candidates


def test_plot_rig_fit_phase(rig, monkeypatch, mplcleanup):
    """Drill-down figure with magnitude and phase (issue 20): the phase drawn is the FRF's angle,
    wrapped so that a driving point's accelerance (180 deg below its resonance, 0 above) is one
    unbroken line through +90 deg at the housing mode."""
    from ema_rig.plot.rig import plot_rig_fit

    mm = modal(rig_modes(rig.model, 626.0))
    _fake_identify(monkeypatch, mm, 0.2)
    data = _data_from(mm)
    res = st.estimate_stiffness(data, rig, spindle=False)
    p = plot_rig_fit(data, res, rig, phase=True)
    assert set(p.axes) == {"housing", "housing_phase", "spindle", "spindle_phase", "candidates"}
    assert p.axes["housing_phase"].get_ylim() == (-100.0, 280.0)  # accelerance: centred on +90 deg
    meas = p.axes["housing_phase"].get_lines()[0]
    f, ph = np.asarray(meas.get_xdata()), np.asarray(meas.get_ydata())
    ok = np.isfinite(ph)
    # noise-free data: the line is the angle of the FRF (to rounding), wrapped into [-90, 270) deg
    expect = np.degrees(np.angle(data.frf[0, 0, (data.freq >= 150.0) & (data.freq <= 700.0)]))
    np.testing.assert_allclose(np.mod(ph[ok] - expect + 180.0, 360.0) - 180.0, 0.0, atol=1e-9)
    assert np.all((ph[ok] >= -90.0) & (ph[ok] < 270.0)) and np.array_equal(np.isnan(f), ~ok)
    # a driving point's phase at its resonance is +90 deg (accelerance of a lightly damped mode);
    # the neighbouring modes shift it (here by 0.9 deg)
    assert abs(np.interp(626.0, f[ok], ph[ok]) - 90.0) < 3.0
    model = p.artists["model"]
    assert all(np.isfinite(ln.get_ydata()).all() for ln in model if ln.axes is p.axes["housing_phase"])


def test_plot_rig_fit_fixed_layout_is_computed_once_and_draws_what_matplotlib_draws(rig, monkeypatch, mplcleanup,
                                                                                    mpl_texts_on_whole_pixels):
    """The report's figure (``dpi=``): one layout for two measurements whose magnitude tick labels land
    at other places (the second 4x the first: log10 4 = 0.6 decade), and the picture matplotlib's own
    savefig draws with the axes there. Oracles: matplotlib's constrained layout of the figure built
    anew (``dpi=None``), and its savefig with the axes placed where the fixed layout put them."""
    import io

    from matplotlib.figure import Figure
    from matplotlib.layout_engine import ConstrainedLayoutEngine
    from PIL import Image

    import ema_rig.plot._render as render
    from ema_rig.plot.rig import plot_rig_fit

    def pixels(fig, fast):
        if fast:
            png = render.render_png(fig, dpi=dpi, colors=None)
        else:
            buf = io.BytesIO()
            fig.savefig(buf, format="png", dpi=dpi)
            png = buf.getvalue()
        return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)

    mm = modal(rig_modes(rig.model, 626.0))
    _fake_identify(monkeypatch, mm, 0.2)
    data = _data_from(mm)
    res = st.estimate_stiffness(data, rig, spindle=False)
    monkeypatch.setattr(render, "_FIXED", {})  # no layout kept by an earlier test
    runs: list = []
    orig = ConstrainedLayoutEngine.execute
    monkeypatch.setattr(ConstrainedLayoutEngine, "execute", lambda self, f: runs.append(f) or orig(self, f))
    dpi, size = 64.0, (12.8, 10.4)
    kept = Figure(figsize=size, layout="constrained")  # as kept_figure gives it
    ends = []
    for d in (data, data.replace(frf=4.0 * data.frf)):
        p = plot_rig_fit(d, res, rig, phase=True, figure=kept, dpi=dpi, title="t")
        ax = p.axes["housing"]
        lo, hi = ax.get_ylim()
        ticks = [y for y in ax.get_yticks() if lo <= y <= hi]
        ends.append(ax.transData.transform((0.0, hi))[1] - ax.transData.transform((0.0, ticks[-1]))[1])
        got = pixels(kept, fast=True)
    # premise: the highest magnitude label lands elsewhere relative to the top of its axes
    assert abs(ends[0] - ends[1]) > 3.0, ends
    assert len(runs) == 1  # one layout for both (the constrained layout per figure: when the labels move)
    positions = [a.get_position().bounds for a in kept.axes]
    suptitle = kept.texts[0].get_position()

    fresh = plot_rig_fit(data.replace(frf=4.0 * data.frf), res, rig, phase=True, title="t").figure
    fresh.set_size_inches(size)
    pixels(fresh, fast=False)  # matplotlib's constrained layout, drawn by savefig
    laid = [a.get_position().bounds for a in fresh.axes]
    # the same columns; rows within the room kept for the magnitude labels' ends (half a label
    # height: 10 pt at 64 dpi is 8.9 px, half of it 4.4 px, at each end of each magnitude panel:
    # measured 0 px across; along, 2.1 px in position and 5.1 px in height)
    d = np.abs(np.array(positions) - np.array(laid)) * np.array([size[0], size[1]] * 2) * dpi
    assert d[:, [0, 2]].max() < 0.01 and d[:, [1, 3]].max() < 9.0, d.max(axis=0)
    fresh.set_layout_engine("none")
    for a, bounds in zip(fresh.axes, positions, strict=True):
        a.set_position(bounds)
    fresh.texts[0].set_position(suptitle)
    diff = np.abs(pixels(fresh, fast=False) - got).max(axis=2)
    # the same pixels up to anti-aliased edges rounded the other way (measured: 1-2 levels of 255 on
    # 5000 pixels) and where the x gridlines cross the minor y gridlines, drawn as one collection after
    # them instead of one line per tick (112 pixels, at most 6 levels); a shifted panel, a missing tick
    # or label changes thousands of pixels by far more
    assert diff.max() <= 8 and (diff > 2).sum() < 400, (int(diff.max()), int((diff > 2).sum()))


@pytest.mark.parametrize("call", ["estimate_stiffness", "calibrate"])
def test_a_path_in_place_of_the_data_says_how_to_read_it(rig, call):
    # the smoke review (b_smoke8) passed a file's path to the API and got an AttributeError from deep
    # inside; the data's type is checked first and the message names the reader (fails before: no
    # TypeError, an AttributeError on str.meta)
    with pytest.raises(TypeError, match=r"FRFData \(read the file with read_uff58\(path, rig=rig\)\), got str"):
        getattr(st, call)("measurement.uff", rig)
