"""Hostile UFF input (issue 8, items 4-6): every reproducer is generated in ``tmp_path``.

The reader must refuse what it cannot vouch for with one error type (:class:`UFFError`) that
names the file and the dataset, never read a wrong value, never raise OverflowError,
ZeroDivisionError or MemoryError, never block on a FIFO or a device, and keep its memory a small
multiple of the data actually present.
"""

from __future__ import annotations

import os
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ema_rig.cli import main
from ema_rig.errors import UFFError
from ema_rig.frf import FRFData
from ema_rig.io.uff import inspect_uff, read_uff, read_uff58, write_uff58

REPO = Path(__file__).resolve().parent.parent
FREQ = np.arange(5) * 10.0
# distinct, exactly representable values: the last one (2.5 + 1j) is the one a cut file damages
TRUTH = (np.arange(1, 11).reshape(2, 1, 5) * (0.25 + 0.1j)).astype(np.complex128)


def _data() -> FRFData:
    return FRFData(FREQ, TRUTH, ["1+Y", "2+Y"], ["1+Y"])


def _ascii(tmp_path: Path, name: str = "ok.uff") -> tuple[Path, bytes]:
    p = tmp_path / name
    write_uff58(p, _data())
    return p, p.read_bytes()


def _label(buf: bytes, old: str, new: str) -> bytes:
    """Replace a 20-column unit label field of every dataset."""
    o, n = old.ljust(20).encode(), new.ljust(20).encode()
    assert len(n) == 20 and o in buf
    return buf.replace(o, n)


def _named(exc: pytest.ExceptionInfo[UFFError], path: Path, dataset: int | None) -> None:
    """The one-line error names the file and (when given) the dataset."""
    assert type(exc.value) is UFFError
    assert str(path) in str(exc.value)
    if dataset is not None:
        assert exc.value.dataset == dataset and f"dataset {dataset}:" in str(exc.value)


# ------------------------------------------------------------------ truncated / miscounted
@pytest.mark.parametrize("cut", [5, 9])
@pytest.mark.parametrize("newline", [False, True])
def test_ascii_cut_inside_last_number_is_refused(tmp_path: Path, cut: int, newline: bool) -> None:
    p, buf = _ascii(tmp_path)
    body = buf.rstrip()
    assert body.endswith(b"-1")
    body = body[: -len(b"    -1")].rstrip()  # the file as written, without its closing -1
    p.write_bytes(body[:-cut] + (b"\n" if newline else b""))  # "2.000000000000E+00" -> "2.0000000"
    rec = read_uff(p)
    assert [r.status for r in rec] == ["read", "refused"]
    assert "no closing -1" in (rec[1].reason or "")
    with pytest.raises(UFFError, match="no closing -1") as exc:
        read_uff58(p)
    _named(exc, p, 1)


def test_ascii_without_closing_delimiter_but_complete_is_refused(tmp_path: Path) -> None:
    # every value complete, only the final -1 missing: the reader cannot tell, so it refuses
    p, buf = _ascii(tmp_path)
    p.write_bytes(buf.rstrip()[: -len(b"    -1")])
    with pytest.raises(UFFError, match="no closing -1") as exc:
        read_uff58(p)
    _named(exc, p, 1)


def test_dataset_164_without_closing_delimiter_is_refused(tmp_path: Path) -> None:
    p, buf = _ascii(tmp_path)
    u164 = b"    -1\n   164\n         1  SI\n  1.0E+00  1.0E+00  1.0E+00\n  2.7315E+02"  # cut, no -1
    p.write_bytes(buf + u164)
    assert read_uff(p)[2].status == "refused"
    with pytest.raises(UFFError, match="units dataset 164 refused") as exc:
        read_uff58(p)
    _named(exc, p, 2)


def _binary_real(tmp_path: Path) -> tuple[Path, bytes]:
    """Two 58b datasets of real float64 values (ordinate type 4, 10 lines, byte count 80)."""
    p = tmp_path / "real.ufb"
    write_uff58(p, _data(), binary=True)
    buf = p.read_bytes().replace(b"         6         5         1", b"         4        10         1")
    assert buf.count(b"         4        10         1") == 2
    p.write_bytes(buf)
    return p, buf


def test_58b_num_pts_one_too_many_does_not_swallow_next_dataset(tmp_path: Path) -> None:
    # 11 points of 8 bytes: the 8 extra bytes are the closing "    -1\n" and one blank, so the
    # next dataset's opening -1 looks like a close (the old reader lost dataset 1, exit 0)
    p, buf = _binary_real(tmp_path)
    close = buf.index(b"    -1\n    -1\n    58b")
    assert close - buf.index(b"58b") > 80  # the first payload ends right before its closing -1
    p.write_bytes(buf.replace(b"         4        10         1", b"         4        11         1", 1))
    rec = read_uff(p)
    assert [r.status for r in rec] == ["refused", "read"]
    assert "byte count 80" in (rec[0].reason or "")
    second = np.empty(10)
    second[0::2], second[1::2] = TRUTH[1, 0].real, TRUTH[1, 0].imag
    np.testing.assert_array_equal(rec[1].y, second)  # binary double: exact
    with pytest.raises(UFFError, match="FRF dataset refused") as exc:
        read_uff58(p)
    _named(exc, p, 0)


def test_58b_num_pts_and_byte_count_both_too_large_are_refused(tmp_path: Path) -> None:
    # a consistent header (11 points, 88 bytes) framed by the next dataset's -1: refused too
    p, buf = _binary_real(tmp_path)
    head = buf.index(b"58b")
    line_end = buf.index(b"\n", head)
    fields = buf[head:line_end].split()
    assert fields[4] == b"80"
    new_line = buf[head:line_end].replace(b"          80", b"          88", 1)
    first = buf[:head] + new_line + buf[line_end:]
    p.write_bytes(first.replace(b"         4        10         1", b"         4        11         1", 1))
    rec = read_uff(p)
    assert [r.status for r in rec] == ["refused", "read"]
    assert "followed by more data" in (rec[0].reason or "")


def test_58b_wrong_byte_count_with_exact_close_still_read(tmp_path: Path) -> None:
    # the writer's byte count is wrong but the payload is followed exactly by the -1 (pyuff's
    # writer does this): the values are vouched for by the framing and read bit-exact
    p, buf = _binary_real(tmp_path)
    head = buf.index(b"58b")
    line_end = buf.index(b"\n", head)
    p.write_bytes(buf[:head] + buf[head:line_end].replace(b"          80", b"          99", 1) + buf[line_end:])
    rec = read_uff(p)
    assert [r.status for r in rec] == ["read", "read"]
    assert any("byte count 99 is wrong" in n for n in rec[0].notes)
    first = np.empty(10)
    first[0::2], first[1::2] = TRUTH[0, 0].real, TRUTH[0, 0].imag
    np.testing.assert_array_equal(rec[0].y, first)


def test_minus_one_pattern_at_payload_end_with_wrong_byte_count(tmp_path: Path) -> None:
    # the last value's bytes are "\n    -1\n" and the byte count is wrong: framing by the -1
    # alone would cut the payload; the after-close check keeps it exact or refuses
    v = struct.unpack("<d", b"\n    -1\n")[0]
    frf = np.full((1, 1, 4), 1.0 + 0j)
    frf[0, 0, -1] = 1.0 + 1j * v
    p = tmp_path / "pat.ufb"
    write_uff58(p, FRFData(np.arange(4.0), frf, ["1+Y"], ["1+Y"]), binary=True)
    buf = p.read_bytes()
    head = buf.index(b"58b")
    line_end = buf.index(b"\n", head)
    p.write_bytes(buf[:head] + buf[head:line_end].replace(b"          64", b"          65", 1) + buf[line_end:])
    rec = read_uff(p)[0]
    if rec.status == "read":
        np.testing.assert_array_equal(rec.y, frf[0, 0])
    else:
        assert "byte count" in (rec.reason or "")


# ------------------------------------------------------------------------------- units
@pytest.mark.parametrize("label", ["mm^120*m^-119/s^2", "mm^-999/N", "mm^200/mm^199/s^2", "m/s^99999999999",
                                   "((mm^9)^9)^9"])
def test_unit_label_out_of_range_is_one_clear_error(tmp_path: Path, label: str) -> None:
    p, buf = _ascii(tmp_path)
    p.write_bytes(_label(buf, "m/s^2", label))
    with pytest.raises(UFFError, match="out of range|beyond") as exc:
        read_uff58(p)
    _named(exc, p, 0)
    assert label.split("^")[0] in str(exc.value)  # the label is quoted


def test_unit_label_small_exponents_still_understood(tmp_path: Path) -> None:
    # mm^2/mm/s^2 is mm/s^2: factor 1e-3 (oracle: 1 mm = 1e-3 m)
    p, buf = _ascii(tmp_path)
    p.write_bytes(_label(buf, "m/s^2", "mm^2/mm/s^2"))
    np.testing.assert_allclose(read_uff58(p).frf, TRUTH * 1e-3, rtol=1e-12)  # 13 digits written


def _with_164(buf: bytes, factors: bytes, exp_field: bytes) -> bytes:
    """The file without unit labels, after a dataset 164, with the ordinate length exponent set."""
    u164 = b"    -1\n   164\n         2  mm (milli newton)  0\n" + factors + b"\n  2.73150E+02\n    -1\n"
    b = _label(_label(buf, "m/s^2", "NONE"), "N", "NONE")
    return u164 + b.replace(b"        12    1    0    0 Accelerance", b"        12" + exp_field + b"    0    0 Accelerance")


@pytest.mark.parametrize("exp", [b"  999", b" -999", b"   13"])
def test_dataset_164_exponent_out_of_range(tmp_path: Path, exp: bytes) -> None:
    p, buf = _ascii(tmp_path)
    p.write_bytes(_with_164(buf, b"  1.0E+03  1.0E+00  1.0E+00", exp))
    with pytest.raises(UFFError, match="exponent .* out of range") as exc:
        read_uff58(p)
    _named(exc, p, 1)


@pytest.mark.parametrize("factors", [b"  1.0E+300  1.0E+00  1.0E+00", b"  1.0E-300  1.0E+00  1.0E+00"])
def test_dataset_164_factor_overflow(tmp_path: Path, factors: bytes) -> None:
    # (1e300)^12 overflows, (1e-300)^12 underflows to 0: neither may give inf or all-zero data
    p, buf = _ascii(tmp_path)
    p.write_bytes(_with_164(buf, factors, b"   12"))
    with pytest.raises(UFFError, match="no finite non-zero conversion") as exc:
        read_uff58(p)
    _named(exc, p, 1)


def test_dataset_164_in_range_exponent_applies(tmp_path: Path) -> None:
    # length factor 1000 (file unit mm) with exponent 1: values x 1e-3 (oracle: mm -> m)
    p, buf = _ascii(tmp_path)
    p.write_bytes(_with_164(buf, b"  1.0E+03  1.0E+00  1.0E+00", b"    1"))
    np.testing.assert_allclose(read_uff58(p).frf, TRUTH * 1e-3, rtol=1e-12)


def test_unit_factor_underflow_of_values_refused(tmp_path: Path) -> None:
    # a legal label (um^12/m^11/s^2 is an acceleration, factor 1e-72) on values of 1e-300
    # gives 1e-372, i.e. 0 in float64: refused, never all-zero data
    p, buf = _ascii(tmp_path)
    small = buf.replace(b"E-01", b"E-300").replace(b"E+00", b"E-300")
    p.write_bytes(_label(small, "m/s^2", "um^12/m^11/s^2"))
    with pytest.raises(UFFError, match=r"5 non-zero value\(s\) become 0 when.*underflow") as exc:
        read_uff58(p)
    _named(exc, p, 0)


# ----------------------------------------------------------------------- header integers
@pytest.mark.parametrize("where", ["type", "record7", "record6", "58b"])
def test_huge_header_integer_named_with_file(tmp_path: Path, where: str,
                                             capsys: pytest.CaptureFixture[str]) -> None:
    big = b"5" * 5000
    if where == "58b":
        p = tmp_path / "big.ufb"
        write_uff58(p, _data(), binary=True)
        buf = p.read_bytes()
        buf = buf.replace(b"    58b     1     2", b"    58b     1 " + big, 1)
    else:
        p, buf = _ascii(tmp_path, "big.uff")
        if where == "type":
            buf = buf.replace(b"    58\n", b"    " + big + b"\n", 1)
        elif where == "record7":
            buf = buf.replace(b"         6         5         1", b"         6 " + big[:400] + b" 1", 1)
        else:  # record 6 with a 400-digit node: the free-format fallback parses it
            buf = buf.replace(b"NONE               1   2 NONE", b"NONE " + big[:400] + b" 2 NONE", 1)
    p.write_bytes(buf)
    with pytest.raises(UFFError) as exc:
        read_uff58(p)
    _named(exc, p, 0)
    assert main(["inspect", str(p)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"error: {p}: dataset 0:")


# ----------------------------------------------------------------- special files, memory
def _cli(path: Path | str, timeout: float = 60.0) -> subprocess.CompletedProcess[str]:
    code = "import sys; from ema_rig.cli import main; sys.exit(main(sys.argv[1:]))"
    env = dict(os.environ, PYTHONPATH=str(REPO))
    return subprocess.run([sys.executable, "-c", code, "inspect", str(path)], capture_output=True, text=True,
                          timeout=timeout, env=env)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this platform")
def test_fifo_refused_without_blocking(tmp_path: Path) -> None:
    fifo = tmp_path / "m.uff"
    os.mkfifo(fifo)
    with pytest.raises(UFFError, match="FIFO") as exc:
        read_uff(fifo)  # must return at once: nobody ever writes to this FIFO
    _named(exc, fifo, None)
    r = _cli(fifo)  # and the CLI: one line, no traceback (the timeout turns a hang into a failure)
    assert r.returncode == 1 and r.stderr.strip() == f"error: {fifo}: {exc.value.message}"


@pytest.mark.skipif(not Path("/dev/zero").exists(), reason="no /dev/zero")
def test_dev_zero_and_directory_refused(tmp_path: Path) -> None:
    with pytest.raises(UFFError, match="character device") as exc:
        read_uff58("/dev/zero")
    _named(exc, Path("/dev/zero"), None)
    with pytest.raises(UFFError, match="directory"):
        inspect_uff(tmp_path)
    r = _cli("/dev/zero")
    assert r.returncode == 1 and "Traceback" not in r.stderr and r.stderr.startswith("error: /dev/zero: ")


_RSS = """
import resource, sys
from ema_rig.errors import UFFError
from ema_rig.io.uff import read_uff
try:
    f = read_uff(sys.argv[1])
    print(" ".join(f"{r.status}: {r.reason}" for r in f))
except UFFError as exc:
    print("refused:", exc)
print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)
"""


def _peak_rss(path: Path) -> tuple[str, int]:
    env = dict(os.environ, PYTHONPATH=str(REPO))
    r = subprocess.run([sys.executable, "-c", _RSS, str(path)], capture_output=True, text=True, timeout=120, env=env)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    return lines[0], int(lines[-1])


def _baseline_rss(tmp_path: Path) -> int:
    p, _ = _ascii(tmp_path, "small.uff")
    return _peak_rss(p)[1]


@pytest.mark.skipif(sys.platform != "linux", reason="sparse files and ru_maxrss in bytes*1024: Linux")
def test_sparse_and_huge_files_memory(tmp_path: Path) -> None:
    base = _baseline_rss(tmp_path)
    size = 256 << 20
    # 1. a sparse file of zeros: refused after the first 64 KiB, the rest is never read
    zeros = tmp_path / "zeros.uff"
    with open(zeros, "wb") as fh:
        fh.truncate(size)
    verdict, rss = _peak_rss(zeros)
    assert verdict.startswith("refused") and "not a UFF file" in verdict
    assert rss - base < 16 << 20  # nothing read beyond the head (allowance: allocator noise)
    # 2. a valid dataset-58 header, then zeros: the file is read once (1x), refused at once
    _, buf = _ascii(tmp_path)
    head = buf[: buf.index(b"  2.5")]
    with open(zeros, "wb") as fh:
        fh.write(head)
        fh.truncate(size)
    verdict, rss = _peak_rss(zeros)
    assert verdict.startswith("refused") and "not a number" in verdict
    assert rss - base < 1.5 * size  # the old reader peaked at ~10x the file size
    zeros.unlink()
    # 3. a header announcing 10 values, then 64 MB of "0 ": parsed in chunks, refused early
    text = tmp_path / "text.uff"
    n_text = 64 << 20
    with open(text, "wb") as fh:
        fh.write(head)
        fh.write(b"0 " * (n_text // 2))
    verdict, rss = _peak_rss(text)
    assert verdict.startswith("refused") and "header announces 10" in verdict
    assert rss - base < 1.5 * n_text  # a token list would need ~20x (one Python bytes per value)


@pytest.mark.parametrize("tail", [b"   ", b"\x00\x00", b"\x1a", b"\r\n\r\n", b""])
def test_58b_trailing_blanks_after_last_close_still_read(tmp_path: Path, tail: bytes) -> None:
    # what follows the last closing -1 is not data: blanks, NULs or a DOS end-of-file mark
    p, buf = _binary_real(tmp_path)
    p.write_bytes(buf + tail)
    assert [r.status for r in read_uff(p)] == ["read", "read"]


def test_underscore_in_number_refused(tmp_path: Path) -> None:
    # Python's float() reads "2_5" as 25: a UFF number never holds "_", so the dataset is refused
    p, buf = _ascii(tmp_path)
    p.write_bytes(buf.replace(b"2.500000000000E-01", b"2_500000000000E-01", 1))
    assert read_uff(p)[0].status == "refused" and "'_'" in (read_uff(p)[0].reason or "")


@pytest.mark.parametrize("label", ["(um^-12)^12", "(mm^-9*um^-9)^2", "(um^12)^12"])
def test_nested_unit_powers_refused(tmp_path: Path, label: str) -> None:
    # (1e72)^12 would raise OverflowError in Python's float power: the exponent check comes first
    p, buf = _ascii(tmp_path)
    p.write_bytes(_label(buf, "m/s^2", label))
    with pytest.raises(UFFError, match="beyond|out of range") as exc:
        read_uff58(p)
    _named(exc, p, 0)


# ------------------------------------------------------------- ambiguous framing (issue 17)
def _binary_float32_real(tmp_path: Path) -> tuple[Path, bytes, np.ndarray]:
    """One 58b dataset of 12 real float32 values (ordinate type 2, byte count 48), the payload
    followed directly by the closing "    -1" (as ema_rig's writer does)."""
    p = tmp_path / "f32.ufb"
    write_uff58(p, FRFData(np.arange(6.0), np.full((1, 1, 6), 1.5 + 0.25j), ["1+Y"], ["1+Y"]), binary=True,
                double=False)
    buf = p.read_bytes().replace(b"         5         6         1", b"         2        12         1", 1)
    assert buf.endswith(b"    -1\n") and b"          48     0" in buf
    p.write_bytes(buf)
    return p, buf, np.tile([1.5, 0.25], 6)


def test_58b_float32_num_pts_plus_one_eating_the_close_is_refused(tmp_path: Path) -> None:
    # num_pts 13 and byte count 52: the 13th float32 is the 4 blanks of "    -1" and the rest
    # "-1" still looks like a close; the old reader returned 13 values, the last 1.35e-19
    p, buf, vals = _binary_float32_real(tmp_path)
    rec = read_uff(p)[0]
    assert rec.status == "read"
    np.testing.assert_array_equal(rec.y, vals)  # float32-exact values
    mutant = buf.replace(b"          48     0", b"          52     0", 1)
    p.write_bytes(mutant.replace(b"         2        12         1", b"         2        13         1", 1))
    rec = read_uff(p)[0]
    assert rec.status == "refused" and "ambiguous framing" in (rec.reason or ""), rec.reason


def test_zero_padding_standing_in_for_a_missing_value_is_refused(tmp_path: Path) -> None:
    # 5 complex points = 10 values, 4 per line: 4 + 4 + 2, the last line padded with 2 zeros.
    # One value deleted from the first line: 11 values, the last one 0; trimming to 10 would
    # shift every later value by one (real <-> imaginary). Refused, the padded file still read.
    p, buf = _ascii(tmp_path)
    lines = buf.split(b"\n")
    last = next(i for i in range(len(lines) - 1, 0, -1) if b"E" in lines[i])  # dataset 1's last data line
    assert [lines[i].count(b"E") for i in (last - 2, last - 1, last)] == [4, 4, 2]
    lines[last] = lines[last] + b"  0.000000000000E+00  0.000000000000E+00"
    p.write_bytes(b"\n".join(lines))
    rec = read_uff(p)
    assert rec[1].status == "read" and any("zero-padded" in n for n in rec[1].notes)
    np.testing.assert_allclose(rec[1].y, TRUTH[1, 0], rtol=1e-15)  # 13 digits: to the last bit or two
    lines[last - 2] = b"".join(b"  " + t for t in lines[last - 2].split()[:3])  # one value missing
    p.write_bytes(b"\n".join(lines))
    rec = read_uff(p)
    assert rec[1].status == "refused" and "ambiguous" in (rec[1].reason or ""), rec[1].reason


def test_positive_numbers_run_together_are_refused(tmp_path: Path) -> None:
    # "2.5E-01" + "1.0E-01" without a blank: "2.500000000000E-011.000000000000E-01" has no
    # split point the text vouches for (the old reader cut it after "E-011"); a split before a
    # sign ("...E-01-1.0...") is what fixed-width Fortran output does and stays readable
    p, buf = _ascii(tmp_path)
    first = b"  2.500000000000E-01  1.000000000000E-01"
    assert buf.count(first) == 1
    p.write_bytes(buf.replace(first, b"  2.500000000000E-011.000000000000E-01"))
    rec = read_uff(p)[0]
    assert rec.status == "refused" and "run together without a sign" in (rec.reason or "")
    p.write_bytes(buf.replace(first, b"  2.500000000000E-01-1.000000000000E-01"))
    rec = read_uff(p)[0]
    assert rec.status == "read"
    assert rec.y[0] == 0.25 - 0.1j


def test_58b_data_short_by_a_few_bytes_cannot_take_its_close_as_data(tmp_path: Path) -> None:
    # 6 bytes lost inside the payload and a second -1 line at the end of the file (a trailing
    # delimiter): framed by the byte count, the payload ends with the close "    -1" and the
    # trailing -1 looks like the close; every value after the loss would be shifted by 6 bytes
    # (found by the fuzz, seed 99: 0.0101 read as 1.2e51)
    p = tmp_path / "short.ufb"
    write_uff58(p, FRFData(FREQ, TRUTH[:1], ["1+Y"], ["1+Y"]), binary=True)
    buf = p.read_bytes() + b"    -1\n"  # a trailing delimiter line at the end of the file
    q = buf.index(b"\n", buf.index(b"NONE                 NONE", buf.index(b"58b"))) + 1
    assert buf[q + 80 :] == b"    -1\n    -1\n"  # 5 complex float64 values, then the close
    p.write_bytes(buf)
    assert read_uff(p)[0].status == "read"  # a trailing -1 alone is fine
    p.write_bytes(buf[: q + 20] + buf[q + 26 :])  # 6 bytes of the data lost
    rec = read_uff(p)
    assert rec[0].status == "refused" and "ambiguous framing" in (rec[0].reason or ""), rec[0].reason
