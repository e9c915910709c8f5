"""Time data units, start times and the ``frf`` options (issue 17).

Oracle: the same samples written twice, once in SI (s, N, m/s^2) and once in other units (a
time axis in ms, dataset 164 in inch and pound-force); the unit definitions (1 in = 0.0254 m,
1 lbf = 4.4482216152605 N) say what the second must give relative to the first. The streamed
estimator is checked against the exact FRF of a discrete resonator (as tests/test_spectral.py).
"""

from __future__ import annotations

import tracemalloc
import warnings
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter

from ema_rig.cli import main
from ema_rig.errors import UFFError
from ema_rig.io.time_data import read_time_uff
from ema_rig.io.uff import read_uff58
from ema_rig.spectral import SEGMENT_BATCH_BYTES, estimate_frf

FS = 1000.0
_P = np.exp((-0.02 * 2 * np.pi * 120.0 + 1j * 2 * np.pi * 120.0 * np.sqrt(1 - 0.02**2)) / FS)
A = np.real(np.poly([_P, _P.conj()]))
B = np.array([1.0, -2.0, 1.0])
IN, LBF = 0.0254, 4.4482216152605


def _signals(n: int = 4096) -> tuple[np.ndarray, np.ndarray]:
    x = np.random.default_rng(3).standard_normal(n)
    return x, lfilter(B, A, x)


def _write(path: Path, x: np.ndarray, y: np.ndarray, *, t_unit: str = "s", t_scale: float = 1.0,
           labels: tuple[str, str] = ("N", "m/s^2"), starts: tuple[float, float] = (0.0, 0.0),
           u164: bytes = b"") -> Path:
    import pyuff

    sets = []
    for (node, code, data, lab, t0) in ((1, 13, x, labels[0], starts[0]), (2, 12, y, labels[1], starts[1])):
        sets.append(pyuff.prepare_58(
            func_type=1, ord_data_type=4, num_pts=data.size, abscissa_spacing=1, abscissa_min=t0 * t_scale,
            abscissa_inc=t_scale / FS, abscissa_spec_data_type=17, abscissa_axis_units_lab=t_unit,
            orddenom_spec_data_type=0, binary=0, x=(t0 + np.arange(data.size) / FS) * t_scale, ref_node=1, ref_dir=3,
            id1="t", rsp_node=node, rsp_dir=3, ordinate_spec_data_type=code, ordinate_axis_units_lab=lab,
            data=data))
    pyuff.UFF(str(path)).write_sets(sets, mode="add")
    if u164:
        path.write_bytes(u164 + path.read_bytes())
    return path


def test_time_axis_in_ms_is_read_as_ms(tmp_path: Path) -> None:
    # the old reader took 1 ms steps as 1 s: fs = 1 Hz, FRF lines 0.001..0.5 Hz
    x, y = _signals()
    td_s = read_time_uff(_write(tmp_path / "s.uff", x, y))
    td_ms = read_time_uff(_write(tmp_path / "ms.uff", x, y, t_unit="ms", t_scale=1e3))
    assert td_s.fs == pytest.approx(FS, rel=1e-12)
    assert td_ms.fs == pytest.approx(FS, rel=1e-11)  # 1/FS written to 12 digits by pyuff
    np.testing.assert_array_equal(td_ms.response, td_s.response)


def test_unknown_time_unit_refused(tmp_path: Path) -> None:
    x, y = _signals(256)
    p = _write(tmp_path / "t.uff", x, y, t_unit="fortnight")
    with pytest.raises(UFFError, match=r"dataset 0: abscissa unit label 'fortnight' not understood"):
        read_time_uff(p)


def test_channels_starting_at_different_times_refused(tmp_path: Path) -> None:
    # the response starts 5 samples after the force: treating them as simultaneous skews the
    # phase by 2 pi f 5/fs; refused with both datasets and the shift named
    x, y = _signals(256)
    p = _write(tmp_path / "t.uff", x, y, starts=(0.0, 5 / FS))
    with pytest.raises(UFFError, match=r"start at different times: dataset 0 at 0 s, dataset 1 at 0.005 s \(5 "
                                       r"samples apart\)") as exc:
        read_time_uff(p)
    assert exc.value.dataset == 1
    assert main(["frf", str(p), "-o", str(tmp_path / "f.uff")]) == 1
    # the same start (not 0) in every channel is fine
    assert read_time_uff(_write(tmp_path / "same.uff", x, y, starts=(2.0, 2.0))).fs == pytest.approx(FS)


_U164_INCH = (b"    -1\n   164\n         2  inch (lbf)          2\n"
              b"  3.93700787402E+01  2.24808943100E-01  1.00000000000E+00\n  2.73150000000E+02\n    -1\n")


def test_dataset_164_applied_to_time_data(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    # no unit labels, dataset 164 in inch/lbf: response x 0.0254, force x 4.448 (the old frf
    # ignored it: the FRF came out 175x off, with a warning about missing unit labels)
    x, y = _signals()
    si = _write(tmp_path / "si.uff", x, y)
    inch = _write(tmp_path / "inch.uff", x, y, labels=("NONE", "NONE"), u164=_U164_INCH)
    td = read_time_uff(inch)
    ref = read_time_uff(si)
    np.testing.assert_allclose(td.force, ref.force * LBF, rtol=1e-11)  # factors written to 12 digits
    np.testing.assert_allclose(td.response, ref.response * IN, rtol=1e-11)
    assert any("dataset 164" in n for n in td.notes)
    out_si, out_in = tmp_path / "f_si.uff", tmp_path / "f_in.uff"
    assert main(["frf", str(si), "-o", str(out_si), "--window", "hann"]) == 0
    capsys.readouterr()
    assert main(["frf", str(inch), "-o", str(out_in), "--window", "hann"]) == 0
    assert "without unit labels" not in capsys.readouterr().err  # the units are known
    h_si, h_in = read_uff58(out_si).frf, read_uff58(out_in).frf
    np.testing.assert_allclose(h_in, h_si * (IN / LBF), rtol=1e-9)  # 1/175.1, written to 13 digits


def test_no_labels_no_164_warning_says_so(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    x, y = _signals()
    p = _write(tmp_path / "n.uff", x, y, labels=("NONE", "NONE"))
    with warnings.catch_warnings():
        warnings.simplefilter("always")  # the CLI prints it as one "warning:" line
        assert main(["frf", str(p), "-o", str(tmp_path / "f.uff"), "--window", "hann"]) == 0
    assert "without unit labels or dataset 164" in capsys.readouterr().err


@pytest.mark.parametrize("opt", [["--force-width", "inf"], ["--force-width", "nan"], ["--force-width", "0"],
                                 ["--overlap", "nan"], ["--overlap", "-0.5"], ["--segment", "0"],
                                 ["--exp-end", "inf"], ["--exp-end", "0"], ["--segment", "1e9"]])
def test_frf_out_of_range_options_are_usage_errors(tmp_path: Path, opt: list[str],
                                                   capsys: pytest.CaptureFixture[str]) -> None:
    x, y = _signals(256)
    p = _write(tmp_path / "t.uff", x, y)
    assert main(["frf", str(p), "-o", str(tmp_path / "f.uff"), *opt]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and opt[0] in err


@pytest.mark.parametrize("opt", [["--overlap", "1"], ["--segment", "100000"], ["--force-width", "1e300"]])
def test_frf_options_beyond_the_data_are_clean_errors(tmp_path: Path, opt: list[str],
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    x, y = _signals(256)
    p = _write(tmp_path / "t.uff", x, y)
    assert main(["frf", str(p), "-o", str(tmp_path / "f.uff"), "--window", "impact", *opt]) == 1
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.startswith(f"error: {p}: ")
    assert not (tmp_path / "f.uff").exists()


def test_streamed_segments_memory_is_bounded_and_exact() -> None:
    # overlap 0.995 on 2^15 samples: 1434 segments of 4096. Holding every segment (the old code)
    # needs ~4 copies of 1434 x 4096 x 2 channels x 8 bytes = 375 MB; streamed, a few batches
    x, y = _signals(2**15)
    tracemalloc.start()
    try:
        est = estimate_frf(x, y, FS, in_dofs=["1+Z"], out_dofs=["2+Z"], segment=4096, overlap=0.995)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert est.n_averages == 1434
    assert peak < 6 * SEGMENT_BATCH_BYTES, peak  # 96 MB: several batch-sized temporaries at most
    f = est.frf.freq
    zi = 1.0 / np.exp(2j * np.pi * f / FS)
    exact = np.polyval(B[::-1], zi) / np.polyval(A[::-1], zi)
    # noise-free H1 with a hann window: leakage of a 2 % resonance at 4096 lines, as test_spectral
    np.testing.assert_allclose(est.frf.frf[0, 0], exact, rtol=0, atol=0.02 * np.abs(exact).max())


def test_values_whose_spectra_overflow_are_refused() -> None:
    # 1e200 N: |X|^2 overflows float64; refused naming the size (the fuzz found a numpy overflow
    # warning in the coherence instead)
    x, y = _signals(1024)
    with pytest.raises(ValueError, match=r"spectra overflow float64: force or response values up to 1e\+200"):
        estimate_frf(x * 1e200 / np.abs(x).max(), y, FS, in_dofs=["1+Z"], out_dofs=["2+Z"])
