"""write_uff58: round trips, header byte counts, NaN refusal, no mutation, pyuff compatibility."""

from __future__ import annotations

import contextlib
import io
import re
import warnings
from pathlib import Path

import numpy as np
import pytest

from ema_rig.config import load_rig
from ema_rig.errors import UFFError
from ema_rig.frf import FRFData
from ema_rig.io.uff import read_uff, read_uff58, write_uff58

G0 = 9.80665


def _data(*, n_in: int, real: bool, even: bool, seed: int = 1, n_freq: int = 37) -> FRFData:
    rng = np.random.default_rng(seed)
    if even:
        freq = 2.5 + 0.25 * np.arange(n_freq)  # starts above 0 Hz, step with few digits
    else:
        freq = np.cumsum(rng.uniform(0.1, 2.0, n_freq))
    shape = (3, n_in, n_freq)
    # magnitudes over 8 decades, both signs, like measured FRFs
    frf = rng.standard_normal(shape) * 10.0 ** rng.uniform(-4, 4, shape)
    if not real:
        frf = frf + 1j * rng.standard_normal(shape) * 10.0 ** rng.uniform(-4, 4, shape)
    ins = ["1+Y", "5+X"][:n_in]
    return FRFData(freq, frf, ["1+Y", "2+Y", "3+Z"], ins)


def _tol(binary: bool, double: bool) -> float:
    # stored precision: float64 exact; float32 2^-24; E20.12 13 digits; E13.5 6 digits
    return {(True, True): 0.0, (True, False): 6e-8, (False, True): 5e-13, (False, False): 5e-6}[(binary, double)]


@pytest.mark.parametrize("n_in", [1, 2])
@pytest.mark.parametrize("even", [True, False], ids=["even", "uneven"])
@pytest.mark.parametrize("double", [True, False], ids=["double", "single"])
@pytest.mark.parametrize("real", [True, False], ids=["real", "complex"])
@pytest.mark.parametrize("binary", [True, False], ids=["binary", "ascii"])
def test_round_trip(tmp_path: Path, binary: bool, real: bool, double: bool, even: bool, n_in: int) -> None:
    d = _data(n_in=n_in, real=real, even=even)
    p = tmp_path / "rt.uff"
    write_uff58(p, d, binary=binary, double=double, abscissa="even" if even else "uneven")
    back = read_uff58(p)
    tol = _tol(binary, double)
    # each value within the relative precision of its own storage format
    err = np.abs(back.frf - d.frf)
    assert np.all(err <= tol * np.abs(d.frf)), float(np.max(err / np.abs(d.frf)))
    if real:
        assert not np.any(back.frf.imag)
    # abscissa: even -> rebuilt from min/increment (exact for 0.25 Hz); uneven -> stored
    # explicitly (float64/float32 in binary, 7 digits %13.6E in ASCII)
    ftol = 0.0 if (even or (binary and double)) else (6e-8 if binary else 5e-7)
    np.testing.assert_allclose(back.freq, d.freq, rtol=ftol, atol=0)
    assert back.out_dofs == d.out_dofs and back.in_dofs == d.in_dofs
    assert back.frf_form == "accelerance"
    recs = read_uff(p)
    assert all(r.header["abscissa_spacing"] == (1 if even else 0) for r in recs)
    # an FRF is written complex even when every imaginary part is 0: read_uff58 refuses real-valued FRFs
    assert {r.header["ord_data_type"] for r in recs} == {6 if double else 5}


def _pyuff_read(path: Path) -> list[dict]:
    import pyuff

    with warnings.catch_warnings(), contextlib.redirect_stdout(io.StringIO()):
        warnings.simplefilter("ignore")
        s = pyuff.UFF(str(path)).read_sets()
    return s if isinstance(s, list) else [s]


@pytest.mark.parametrize("binary", [True, False])
def test_pyuff_reads_what_we_write(tmp_path: Path, binary: bool) -> None:
    d = _data(n_in=2, real=False, even=True)
    p = tmp_path / "x.uff"
    write_uff58(p, d, binary=binary)
    sets = _pyuff_read(p)
    assert len(sets) == 6
    for k, s in enumerate(sets):
        i, j = divmod(k, 2)
        # pyuff reads the values to the stored precision (binary exact, ASCII 13 digits)
        np.testing.assert_allclose(s["data"], d.frf[i, j], rtol=_tol(binary, True), atol=0)
        assert (s["rsp_node"], s["rsp_dir"]) == (d.out_dofs[i].node, d.out_dofs[i].direction)
        assert (s["ref_node"], s["ref_dir"]) == (d.in_dofs[j].node, d.in_dofs[j].direction)
        assert s["ordinate_spec_data_type"] == 12 and s["orddenom_spec_data_type"] == 13


@pytest.mark.parametrize("real", [True, False])
@pytest.mark.parametrize("even", [True, False])
@pytest.mark.parametrize("double", [True, False])
def test_binary_header_byte_count(tmp_path: Path, real: bool, even: bool, double: bool) -> None:
    d = _data(n_in=1, real=real, even=even, n_freq=29)
    p = tmp_path / "b.uff"
    write_uff58(p, d, binary=True, double=double, abscissa="even" if even else "uneven")
    buf = p.read_bytes()
    heads = list(re.finditer(rb"    58b +(\d+) +(\d+) +(\d+) +(\d+)[^\n]*\n", buf))
    assert len(heads) == 3
    size = 8 if double else 4
    per_point = 2 + (0 if even else 1)  # complex also for real values (zero imaginary parts)
    for m in heads:
        n_bytes = int(m.group(4))
        assert (int(m.group(1)), int(m.group(2)), int(m.group(3))) == (1, 2, 11)  # LE, IEEE, 11 lines
        assert n_bytes == 29 * per_point * size  # num_pts x values per point x bytes per value
        start = m.end()
        for _ in range(11):
            start = buf.index(b"\n", start) + 1
        # the payload is followed directly by the closing delimiter
        assert buf[start + n_bytes : start + n_bytes + 7] == b"    -1\n"


def test_ascii_header_records(tmp_path: Path) -> None:
    d = _data(n_in=1, real=False, even=True, n_freq=5)
    p = tmp_path / "a.uff"
    write_uff58(p, d, accel_unit="g")
    lines = p.read_text().splitlines()
    assert lines[0] == "    -1" and lines[1] == "    58"
    assert all(len(ln) == 80 for ln in lines[2:8])  # ids and record 6 fill 80 columns
    assert lines[7][:5] == "    4"  # function type FRF
    assert lines[8].split()[:3] == ["6", "5", "1"]  # complex double, 5 points, even
    assert float(lines[8][30:43]) == 2.5 and float(lines[8][43:56]) == 0.25
    assert lines[10][26:46].strip() == "Accelerance" and lines[10][47:67].strip() == "g"
    assert lines[11][:10].strip() == "13" and lines[11][47:67].strip() == "N"


def test_g_round_trip(tmp_path: Path) -> None:
    d = _data(n_in=1, real=False, even=True)
    p = tmp_path / "g.uff"
    write_uff58(p, d, binary=True, accel_unit="g")
    raw = read_uff(p)[0]
    # stored in g/N: the SI values divided by g0 (binary double: one rounding)
    np.testing.assert_allclose(raw.y, d.frf[0, 0] / G0, rtol=2e-16)
    back = read_uff58(p)
    np.testing.assert_allclose(back.frf, d.frf, rtol=4e-16)  # x g0 back: within 2 ulp
    assert "'g'" in back.meta["unit_decisions"][0]


def test_nan_is_refused_not_zeroed(tmp_path: Path) -> None:
    d = _data(n_in=1, real=False, even=True)
    frf = d.frf.copy()
    frf[1, 0, 4] = np.nan
    bad = d.replace(frf=frf)
    p = tmp_path / "nan.uff"
    with pytest.raises(UFFError, match=r"NaN/inf .*2\+Y / 1\+Y at 3.5 Hz.*never written as 0"):
        write_uff58(p, bad)
    assert not p.exists()  # atomic: nothing left behind
    assert list(tmp_path.iterdir()) == []


def test_no_mutation_of_caller(tmp_path: Path, rig_file: Path) -> None:
    rig = load_rig(rig_file)
    d = FRFData(np.arange(8) * 0.5, np.ones((2, 1, 8)) * (1 + 2j), ["13+Y", "11+Y"], ["11+Y"])
    before = d.frf.copy()
    freq_before = d.freq.copy()
    meta_before = dict(d.meta)
    write_uff58(tmp_path / "m.uff", d, rig=rig, accel_unit="g")
    np.testing.assert_array_equal(d.frf, before)  # sign flip and g scaling on copies only
    np.testing.assert_array_equal(d.freq, freq_before)
    assert dict(d.meta) == meta_before


def test_rig_round_trip_exact(tmp_path: Path, rig_file: Path) -> None:
    rig = load_rig(rig_file)
    rng = np.random.default_rng(7)
    outs = [s.dof.positive() for s in rig.sensors]
    ins = [r.positive() for r in rig.references]
    frf = rng.standard_normal((8, 2, 21)) + 1j * rng.standard_normal((8, 2, 21))
    d = FRFData(np.arange(21) * 0.5, frf, outs, ins)
    p = tmp_path / "rig.uff"
    write_uff58(p, d, binary=True, rig=rig)
    recs = read_uff(p)
    r13 = next(r for r in recs if r.response.node == 13)
    assert str(r13.response) == "13-Y"  # written with the sensor's signed DOF
    np.testing.assert_array_equal(r13.y, -d.frf[2, 0])  # and values x -1
    back = read_uff58(p, rig=rig)
    np.testing.assert_array_equal(back.frf, d.frf)  # binary double: exact
    assert back.out_dofs == d.out_dofs and back.roles[2] == "housing" and back.axes[3] == "lateral"


def test_write_options_checked(tmp_path: Path) -> None:
    d = _data(n_in=1, real=False, even=False)
    with pytest.raises(ValueError, match="abscissa='even'"):
        write_uff58(tmp_path / "x.uff", d, abscissa="even")
    with pytest.raises(ValueError, match="accel_unit"):
        write_uff58(tmp_path / "x.uff", d, accel_unit="mm/s^2")
    with pytest.raises(ValueError, match="needs accelerance"):
        write_uff58(tmp_path / "x.uff", d.replace(frf_form="mobility"), accel_unit="g")


@pytest.mark.parametrize("binary", [True, False])
def test_auto_abscissa_step_with_many_digits(tmp_path: Path, binary: bool) -> None:
    # 2000 Hz / 8192 lines = 0.244140625 Hz: 9 digits, more than E13.5's 6; the 13-column field
    # holds it exactly as a plain decimal, so the even axis comes back exactly
    f = np.linspace(0.0, 2000.0, 8193)
    d = FRFData(f, np.ones((1, 1, f.size), complex), ["1+Y"], ["1+Y"])
    write_uff58(tmp_path / "a.uff", d, binary=binary)
    assert read_uff(tmp_path / "a.uff")[0].header["abscissa_spacing"] == 1
    np.testing.assert_array_equal(read_uff58(tmp_path / "a.uff").freq, f)


def test_auto_abscissa_binary_stores_inexact_step_explicitly(tmp_path: Path) -> None:
    # a 1/3 Hz step has no exact 12-character decimal: binary 'auto' stores the float64
    # abscissa (exact); ASCII keeps the even header with 10 decimals (drift < 1e-9 Hz here)
    f = np.arange(50) / 3.0
    d = FRFData(f, np.ones((1, 1, 50), complex), ["1+Y"], ["1+Y"])
    write_uff58(tmp_path / "b.uff", d, binary=True)
    assert read_uff(tmp_path / "b.uff")[0].header["abscissa_spacing"] == 0
    np.testing.assert_array_equal(read_uff58(tmp_path / "b.uff").freq, f)
    write_uff58(tmp_path / "a.uff", d)
    assert read_uff(tmp_path / "a.uff")[0].header["abscissa_spacing"] == 1
    np.testing.assert_allclose(read_uff58(tmp_path / "a.uff").freq, f, rtol=0, atol=50 * 5e-11)
