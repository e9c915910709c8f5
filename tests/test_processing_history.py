"""Processing history (issue 18 item 4): UFF dataset 1858 written by ``frf`` and read back, the
usable (anti-alias) band and the exact removal of an exponential window's damping.

The truth generator is a time-domain simulation written here with scipy only (a 3-DOF chain,
discretised with a zero-order hold: the sampled system has exactly the poles exp(lambda T) of the
continuous one), independent of ema_rig's simulator.
"""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from ema_rig.cli import main
from ema_rig.frf import FRFData
from ema_rig.identification import identify
from ema_rig.io.uff import read_uff, read_uff58, write_uff58
from ema_rig.processing import ProcessingHistory, processing_history, usable_band

FS = 512.0
N = 4096  # 8 s records


def _chain() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mass, damping and stiffness of a 3-DOF chain (modes near 40, 110 and 230 Hz)."""
    m = np.diag([1.0, 1.0, 1.0])
    k = np.array([[2.0, -1.0, 0.0], [-1.0, 2.0, -1.0], [0.0, -1.0, 1.0]])
    # stiffness scaled so that the modes sit near 40, 110, 230 Hz (three separate springs to ground)
    _, v = np.linalg.eigh(k)
    target = (2 * np.pi * np.array([40.0, 110.0, 230.0])) ** 2
    kk = v @ np.diag(target) @ v.T
    zeta = np.array([0.005, 0.008, 0.006])
    c = v @ np.diag(2 * zeta * np.sqrt(target)) @ v.T
    return m, c, kk


def _truth() -> tuple[np.ndarray, np.ndarray]:
    """Natural frequencies [Hz] and damping ratios of the chain, from the state-space eigenvalues."""
    m, c, k = _chain()
    n = m.shape[0]
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(m, k), -np.linalg.solve(m, c)]])
    lam = np.linalg.eigvals(a)
    lam = lam[lam.imag > 0]
    lam = lam[np.argsort(lam.imag)]
    return np.abs(lam) / (2 * np.pi), -lam.real / np.abs(lam)


def _simulate(n_rec: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Hammer blows on DOF 0 and the acceleration of DOF 2: (force, accel), shape (n_rec, N) each."""
    from scipy.signal import cont2discrete, dlsim

    m, c, k = _chain()
    n = m.shape[0]
    mi = np.linalg.inv(m)
    a = np.block([[np.zeros((n, n)), np.eye(n)], [-mi @ k, -mi @ c]])
    b = np.vstack([np.zeros((n, 1)), mi[:, :1]])
    cm = np.hstack([-mi @ k, -mi @ c])[2:3]
    dm = mi[2:3, :1]
    ad, bd, cd, dd, _ = cont2discrete((a, b, cm, dm), 1.0 / FS, method="zoh")
    force = np.zeros((n_rec, N))
    acc = np.zeros((n_rec, N))
    for r in range(n_rec):
        blow = rng.uniform(50.0, 150.0) * np.array([1.0, 0.6, 0.2])  # no zero of its spectrum below fs/2
        force[r, 4:7] = blow
        _, y, _ = dlsim((ad, bd, cd, dd, 1.0 / FS), force[r])
        acc[r] = y[:, 0] + 1e-6 * np.abs(y).max() * rng.standard_normal(N)
    return force, acc


def _write_time_uff(path: Path, force: np.ndarray, acc: np.ndarray) -> None:
    import pyuff

    t = np.arange(N) / FS
    sets = []
    for r in range(force.shape[0]):
        common = dict(func_type=1, ord_data_type=4, num_pts=N, abscissa_spacing=1, abscissa_min=0.0,
                      abscissa_inc=1.0 / FS, abscissa_spec_data_type=17, orddenom_spec_data_type=0,
                      abscissa_axis_units_lab="s", binary=0, x=t, ref_node=1, ref_dir=3)
        sets.append(pyuff.prepare_58(id1="force", rsp_node=1, rsp_dir=3, ordinate_spec_data_type=13,
                                     ordinate_axis_units_lab="N", data=force[r], **common))
        sets.append(pyuff.prepare_58(id1="resp", rsp_node=3, rsp_dir=3, ordinate_spec_data_type=12,
                                     ordinate_axis_units_lab="m/s^2", data=acc[r], **common))
    pyuff.UFF(str(path)).write_sets(sets, mode="add")


@pytest.fixture(scope="module")
def impact_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    src = tmp_path_factory.mktemp("impact") / "time.uff"
    force, acc = _simulate(4, np.random.default_rng(18))
    _write_time_uff(src, force, acc)
    return src


# ------------------------------------------------------------------ dataset 1858 read / write
def _history(**kw: object) -> ProcessingHistory:
    base: dict[str, object] = dict(window="exponential", window_code=4, exp_decay=0.5756462732485115,
                                   n_samples=4096, n_averages=4, overlap=0.0, estimator="H1", fs=512.0,
                                   band=(0.125, 204.8), source="ema_rig frf")
    base.update(kw)
    return ProcessingHistory(**base)  # type: ignore[arg-type]


def _frf_data() -> FRFData:
    f = np.linspace(1.0, 200.0, 400)
    lam = -2.0 + 2j * np.pi * 60.0
    h = (1.0 / (2j * np.pi * f - lam) + 1.0 / (2j * np.pi * f - lam.conjugate()))[None, None, :]
    return FRFData(f, np.concatenate([h, 2 * h]), ["2+Z", "3+Z"], ["1+Z"], frf_form="receptance")


@pytest.mark.parametrize("binary", [False, True])
def test_1858_round_trip_and_pyuff_reads_it(tmp_path: Path, binary: bool):
    pyuff = pytest.importorskip("pyuff")
    out = tmp_path / "frf.uff"
    hist = _history()
    write_uff58(out, _frf_data(), history=hist, binary=binary)
    assert [r.type for r in read_uff(out).records] == [1858, 58, 1858, 58]
    back = read_uff58(out)
    got = back.meta["processing"]
    assert isinstance(got, ProcessingHistory)
    assert (got.window, got.window_code, got.n_samples, got.n_averages, got.estimator) == (
        "exponential", 4, 4096, 4, "H1")
    # E15.7 keeps 8 significant digits of the decay rate; fs and band are written with 10
    np.testing.assert_allclose(got.exp_decay, hist.exp_decay, rtol=1e-7)
    assert got.fs == 512.0 and got.band == (0.125, 204.8) and got.source == "dataset 1858 (ema_rig)"
    assert back.n_averages == 4  # the coherence variance needs it
    assert not any("1858" in s for s in back.meta["ignored_datasets"])
    # an independent parser (pyuff 2.5.8) reads the standard fields the same way
    sets = [s for s in pyuff.UFF(str(out)).read_sets() if s["type"] == 1858]
    assert len(sets) == 2
    assert sets[0]["window_type"] == 4 and sets[0]["num_of_samples"] == 4096.0
    np.testing.assert_allclose(sets[0]["exponential_window_damping_factor"], hist.exp_decay, rtol=1e-7)


@pytest.mark.parametrize("after", [False, True])
def test_1858_of_another_writer_is_read_with_a_unit_note(tmp_path: Path, after: bool):
    """pyuff's writer (record 1 as 6I10, no ema_rig tag), before or after each dataset 58."""
    pyuff = pytest.importorskip("pyuff")
    f = np.linspace(1.0, 200.0, 400)
    y = 1.0 / (1.0 + 1j * f)
    sets = []
    for node in (2, 3):
        q = pyuff.prepare_1858(record_num=1, octave_format=0, measurement_run=0, weighting_type=0, window_type=6,
                               amplitude_units=0, normalization_method=0, abscissa_data_type_qualifier=0,
                               ordinate_numerator_data_type_qualifier=0, ordinate_denominator_data_type_qualifier=0,
                               z_axis_data_type_qualifier=0, sampling_type=0, z_rpm_value=0.0, z_time_value=0.0,
                               z_order_value=0.0, num_of_samples=2048.0, user_value_1=0.0, user_value_2=0.0,
                               user_value_3=0.0, user_value_4=0.0, exponential_window_damping_factor=3.25,
                               response_direction="NONE", reference_direction="NONE")
        d = pyuff.prepare_58(binary=0, func_type=4, rsp_node=node, rsp_dir=3, ref_node=1, ref_dir=3, ord_data_type=6,
                             num_pts=f.size, abscissa_spacing=1, abscissa_min=1.0, abscissa_inc=float(f[1] - f[0]),
                             abscissa_spec_data_type=18, ordinate_spec_data_type=12, orddenom_spec_data_type=13,
                             ordinate_axis_units_lab="m/s^2", abscissa_axis_units_lab="Hz", data=y, x=f)
        sets += [d, q] if after else [q, d]
    src = tmp_path / "foreign.uff"
    pyuff.UFF(str(src)).write_sets(sets, mode="add")
    data = read_uff58(src)
    h = processing_history(data)
    assert h is not None and h.source == "dataset 1858"
    assert (h.window, h.window_code, h.exp_decay, h.n_samples) == ("impact and exponential", 6, 3.25, 2048)
    assert h.n_averages is None and h.band is None and h.fs is None
    assert any("read as a decay rate in 1/s" in n for n in data.meta["notes"])
    # the sampling rate is not known: no anti-alias limit is imposed
    assert usable_band(h) is None


def test_unreadable_1858_is_a_note_not_an_error(tmp_path: Path):
    out = tmp_path / "frf.uff"
    write_uff58(out, _frf_data(), history=_history())
    text = out.read_text().replace("     0     4     0", "     0     X     0", 1)
    out.write_text(text)
    data = read_uff58(out)
    assert any("record 2" in n and "ignored" in n for n in data.meta["notes"])
    # the two FRFs no longer share one history: none is used, and the warning says the damping stays
    assert "processing" not in data.meta
    assert any("NOT removed" in w for w in data.meta["warnings"])


# ------------------------------------------------------------------ frf -> modes, time data
@pytest.fixture(scope="module")
def windowed(impact_file: Path, tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    out = tmp_path_factory.mktemp("frf")
    exp, rect = out / "exp.uff", out / "rect.uff"
    with warnings.catch_warnings():  # the CLI prints warnings as one line on stderr
        warnings.simplefilter("always")
        assert main(["frf", str(impact_file), "-o", str(exp), "--window", "exponential"]) == 0
    assert main(["frf", str(impact_file), "-o", str(rect), "--window", "force"]) == 0
    return exp, rect


def test_frf_writes_one_1858_before_every_58(windowed):
    exp, _ = windowed
    recs = read_uff(exp).records
    assert [r.type for r in recs] == [1858, 58, 1858, 58]  # FRF and coherence
    h = read_uff58(exp).meta["processing"]
    # ln(1/0.01) over the segment of N-1 samples at FS: the exponential window's decay rate
    np.testing.assert_allclose(h.exp_decay, np.log(100.0) / (N - 1) * FS, rtol=1e-5)  # fs to 2e-6, below
    assert (h.n_averages, h.estimator, h.n_samples) == (4, "H1", N)
    # pyuff wrote the time step with 6 digits (1.95312e-3 s): fs comes back as 512.001 Hz
    np.testing.assert_allclose(h.fs, FS, rtol=1e-5)
    np.testing.assert_allclose(h.band, (FS / N, 0.8 * FS / 2), rtol=1e-5)


def test_modes_remove_the_window_damping_and_stay_in_the_usable_band(windowed, tmp_path: Path, capsys):
    exp, _ = windowed
    f_true, z_true = _truth()
    a = np.log(100.0) / (N - 1) * FS
    data = read_uff58(exp)
    before = identify(FRFData(data.freq, data.frf, data.out_dofs, data.in_dofs, data.frf_form))  # no history
    after = identify(data)
    # without the history: the 230 Hz mode (above 0.8 fs/2 = 204.8 Hz) is reported, and every damping
    # ratio is too high by a / omega_n (Fladung & Rost 1997)
    assert np.any(np.abs(before.natural_freq - f_true[2]) < 1.0)
    k0 = int(np.argmin(np.abs(before.natural_freq - f_true[0])))
    np.testing.assert_allclose(before.damping_ratio[k0], z_true[0] + a / (2 * np.pi * f_true[0]), rtol=0.02)
    # with it: nothing above the usable band, and the structure's damping back (measured to 1e-4 relative
    # on these nearly noise-free records; the window's share at 40 Hz is 46 % of the damping, so a missing
    # or doubled correction fails by 400x)
    assert after.band[1] <= 0.8 * FS / 2 and np.all(after.natural_freq < 0.8 * FS / 2)
    np.testing.assert_allclose(np.sort(after.natural_freq), f_true[:2], rtol=1e-4)
    np.testing.assert_allclose(after.damping_ratio[np.argsort(after.natural_freq)], z_true[:2], rtol=1e-3)
    assert any("removed from every pole" in n for n in after.notes)
    assert any("clipped to" in n and "valid up to" in n for n in after.notes)
    # the CLI shows the same
    j = tmp_path / "modes.json"
    assert main(["modes", str(exp), "--json", str(j)]) == 0
    doc = json.loads(j.read_text())
    assert doc["processing"]["window"] == "exponential" and doc["processing"]["n_averages"] == 4
    zs = sorted((m["natural_freq"], m["damping_ratio"]) for m in doc["modes"])
    np.testing.assert_allclose([z for _, z in zs], z_true[:2], rtol=1e-3)


def test_windowed_and_unwindowed_estimates_agree(windowed):
    """The force-window FRF (no exponential) and the corrected exponential one give the same damping
    (both nearly noise-free: 1e-3 relative; uncorrected they differ by 46 % at 40 Hz)."""
    exp, rect = windowed
    e, r = identify(read_uff58(exp)), identify(read_uff58(rect))
    assert e.modes.n_modes == r.modes.n_modes == 2
    np.testing.assert_allclose(np.sort(e.natural_freq), np.sort(r.natural_freq), rtol=1e-5)
    np.testing.assert_allclose(e.damping_ratio[np.argsort(e.natural_freq)],
                               r.damping_ratio[np.argsort(r.natural_freq)], rtol=1e-3)


def test_a_mode_only_the_window_explains_is_not_reported():
    """A pole that decays more slowly than the window alone allows is not a structural mode."""
    f = np.linspace(1.0, 200.0, 800)
    poles = [-3.0 + 2j * np.pi * 50.0, -1.0 + 2j * np.pi * 120.0]  # decay 3 and 1 rad/s in the windowed FRF
    h = sum(1.0 / (2j * np.pi * f - p) + 1.0 / (2j * np.pi * f - np.conj(p)) for p in poles)
    hist = ProcessingHistory(window="exponential", window_code=4, exp_decay=2.0, source="test")
    data = FRFData(f, h[None, None, :], ["2+Z"], ["1+Z"], frf_form="receptance", meta={"processing": hist})
    ident = identify(data)
    # 50 Hz: decay 3 - 2 = 1 rad/s left; 120 Hz: 1 - 2 < 0, the window alone over-explains it
    np.testing.assert_allclose(ident.natural_freq, [np.hypot(1.0, 2 * np.pi * 50.0) / (2 * np.pi)], rtol=1e-6)
    np.testing.assert_allclose(ident.damping_ratio, [1.0 / np.hypot(1.0, 2 * np.pi * 50.0)], rtol=1e-4)
    assert any("120" in w and "not reported" in w for w in ident.warnings)
    # the receptance residues are the window's (same in the time domain): unchanged, as LSFD gave them
    assert ident.modes.residues.shape == (1, 1, 1)


# ------------------------------------------------------------------ real data
def test_vt_case1_exponential_window_34hz_damping_matches_the_analyser(real_frf_dir: Path, tmp_path: Path):
    """vt_case1 time records through ``frf --window exponential``: the 34 Hz damping within 2 sigma of
    the analyser's own FRF (dataset 2 of vt_case1_full.uff); measured 0.004 +/- 0.054 % vs
    0.024 +/- 0.0008 %, 0.70 % before the correction."""
    src = real_frf_dir / "vt_case1_full.uff"
    out = tmp_path / "vt1_exp.uff"
    with warnings.catch_warnings():  # no unit labels, one average: printed on stderr by the CLI
        warnings.simplefilter("always")
        assert main(["frf", str(src), "-o", str(out), "--window", "exponential"]) == 0
    ours, theirs = identify(read_uff58(out)), identify(read_uff58(src))
    ko = int(np.argmin(np.abs(ours.natural_freq - 34.06)))
    kt = int(np.argmin(np.abs(theirs.natural_freq - 34.06)))
    assert abs(ours.natural_freq[ko] - 34.06) < 0.05 and abs(theirs.natural_freq[kt] - 34.06) < 0.05
    dz = abs(ours.damping_ratio[ko] - theirs.damping_ratio[kt])
    sig = float(np.hypot(ours.damping_ratio_std[ko], theirs.damping_ratio_std[kt]))
    assert dz < 2 * sig, (ours.damping_ratio[ko], theirs.damping_ratio[kt], sig)
    # the uncorrected value (0.70 %) would be 12 sigma away
    assert ours.damping_ratio[ko] + read_uff58(out).meta["processing"].exp_decay / (2 * np.pi * 34.06) - \
        theirs.damping_ratio[kt] > 5 * sig
    # FRFs to Nyquist (640 Hz) but the analyser band is 500 Hz: nothing above 0.8 fs/2 = 512 Hz
    assert np.all(ours.natural_freq < 512.0)


def test_estimate_frf_result_carries_its_history_into_identify():
    """The library route (estimate_frf -> identify, no file): same correction and usable band."""
    from ema_rig.spectral import estimate_frf

    force, acc = _simulate(4, np.random.default_rng(7))
    est = estimate_frf(force[:, None, :], acc[:, None, :], FS, in_dofs=["1+Z"], out_dofs=["3+Z"],
                       window="exponential")
    h = processing_history(est.frf)
    assert h is not None and h.source == "estimate_frf"
    np.testing.assert_allclose(h.fs, FS, rtol=1e-12)  # k fs / segment lines
    np.testing.assert_allclose(usable_band(h), 0.8 * FS / 2, rtol=1e-12)
    ident = identify(est.frf)
    f_true, z_true = _truth()
    assert np.all(ident.natural_freq < 0.8 * FS / 2)
    o = np.argsort(ident.natural_freq)
    np.testing.assert_allclose(ident.natural_freq[o], f_true[:2], rtol=1e-4)
    np.testing.assert_allclose(ident.damping_ratio[o], z_true[:2], rtol=1e-3)


def test_window_correction_sigma_matches_monte_carlo():
    """First-order propagation of (sigma_f, sigma_zeta) through the pole shift vs 200 000 draws."""
    from ema_rig.identification.window_damping import _propagate

    rng = np.random.default_rng(3)
    f0, z0, sf, sz, a = 34.05, 0.00696, 0.0066, 0.00075, 1.4395
    fn, zn, sfn, szn = _propagate(f0, z0, sf, sz, a)
    f = f0 + sf * rng.standard_normal(200_000)
    z = z0 + sz * rng.standard_normal(200_000)
    w = 2 * np.pi * f
    lam = -z * w + a + 1j * w * np.sqrt(1 - z * z)
    w0 = 2 * np.pi * f0
    lam0 = complex(-z0 * w0 + a, w0 * np.sqrt(1 - z0**2))  # the pole with its real part moved by +a
    np.testing.assert_allclose([fn, zn], [abs(lam0) / (2 * np.pi), -lam0.real / abs(lam0)], rtol=1e-12)
    # light damping: zeta' = zeta - a / omega_n to ~zeta^2 (here 2e-4 of zeta')
    np.testing.assert_allclose(zn, z0 - a / w0, rtol=2e-4)
    # sampling error of a std from 2e5 draws: 0.16 %; the linearisation is exact to ~zeta^2
    np.testing.assert_allclose(sfn, np.std(np.abs(lam) / (2 * np.pi)), rtol=0.01)
    np.testing.assert_allclose(szn, np.std(-lam.real / np.abs(lam)), rtol=0.01)
