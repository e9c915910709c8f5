"""read_uff58 / read_uff: rig signs, units, assembly and the errors bad files must give.

Fixtures are written with pyuff (``prepare_58`` + ``write_sets``) in ``tmp_path`` so that they do
not depend on ema_rig's writer.
"""

from __future__ import annotations

import dataclasses
import struct
import warnings
from pathlib import Path

import numpy as np
import pytest
from _pyuff_files import write_with_pyuff

from ema_rig.config import load_rig
from ema_rig.errors import UFFError, UnitWarning
from ema_rig.frf import FRFData
from ema_rig.io.uff import read_uff, read_uff58, write_uff58

G0 = 9.80665
FREQ = np.arange(16) * 0.5  # Hz


def _set(node: int, direction: int, ref: int, ref_dir: int, data: np.ndarray, **kw) -> dict:
    import pyuff

    args = dict(
        binary=0, func_type=4, rsp_node=node, rsp_dir=direction, ref_node=ref, ref_dir=ref_dir,
        ord_data_type=6, abscissa_spacing=1, abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz",
        ordinate_spec_data_type=12, ordinate_axis_units_lab="m/s^2", orddenom_spec_data_type=13,
        orddenom_axis_units_lab="N", data=data, x=FREQ,
        id1="fixture", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
    )
    args.update(kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pyuff.prepare_58(**args)


_write = write_with_pyuff


def _truth(n_out: int, n_in: int, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.standard_normal((n_out, n_in, FREQ.size)) + 1j * rng.standard_normal((n_out, n_in, FREQ.size))


# pyuff writes ASCII doubles with %20.11e: 12 significant digits
RTOL_PYUFF = 1e-11


@pytest.mark.parametrize("file_sign", [-1, +1], ids=["file-13-Y", "file-13+Y"])
def test_rig_minus_y_sensor_in_g_comes_back_flipped_in_si(tmp_path: Path, rig_file: Path, file_sign: int) -> None:
    rig = load_rig(rig_file)
    truth = _truth(8, 2)  # SI accelerance along the positive axes, rig sensor order
    sets = []
    for i, s in enumerate(rig.sensors):
        for j, ref in enumerate(rig.references):
            # sensor 13 is mounted along -Y: what it records is -truth, and the file is in g
            recorded = truth[i, j] * s.dof.sign / G0
            direction = s.dof.direction if s.dof.node != 13 else file_sign * 2
            sets.append(_set(s.dof.node, direction, ref.node, ref.direction, recorded, ordinate_axis_units_lab="g"))
    path = _write(tmp_path / "rig_g.uff", sets)
    d = read_uff58(path, rig=rig)
    assert [str(x) for x in d.out_dofs] == ["11+Y", "12+Y", "13+Y", "14+Z", "15+X", "21+Y", "22+Y", "23+X"]
    assert [str(x) for x in d.in_dofs] == ["11+Y", "15+X"]
    assert d.frf_form == "accelerance" and d.unit_str == "m/s^2/N"
    # flipped back and converted from g/N to m/s^2/N, to pyuff's 12 written digits
    np.testing.assert_allclose(d.frf, truth, rtol=RTOL_PYUFF, atol=0)
    assert d.roles[2] == "housing" and d.axes[2] == "radial" and d.roles[5] == "spindle"
    assert all("9.80665" in u for u in d.meta["unit_decisions"])
    disagree = [s for s in d.meta["sign_flips"] if "rig file says 13-Y" in s]
    assert len(disagree) == (2 if file_sign > 0 else 0)  # noted when file and rig disagree
    # ... and a caveat of the result (task q_user14; 23abb6b had none): one line naming file and rig DOF
    conflict = [w for w in d.meta["warnings"] if "opposite signs" in w]
    assert len(conflict) == (1 if file_sign > 0 else 0)
    assert file_sign < 0 or "file 13+Y / rig 13-Y" in conflict[0]


def test_without_rig_negative_direction_is_flipped(tmp_path: Path) -> None:
    truth = _truth(2, 1)
    path = _write(tmp_path / "a.uff", [
        _set(13, -2, 11, 2, -truth[0, 0]),  # the file's own sign: along -Y
        _set(12, 2, 11, 2, truth[1, 0]),
    ])
    d = read_uff58(path)
    assert [str(x) for x in d.out_dofs] == ["13+Y", "12+Y"]  # file order, positive axes
    np.testing.assert_allclose(d.frf, truth, rtol=RTOL_PYUFF, atol=0)
    assert d.meta["sign_flips"] == ["dataset 0: 13-Y flipped into 13+Y (values x -1)"]
    assert d.meta["datasets"] == [0, 1] and d.meta["source"] == str(path)


@pytest.mark.parametrize(
    ("code", "label", "den_label", "form", "factor"),
    [
        (12, "mm/s^2", "N", "accelerance", 1e-3),
        (11, "mm/s", "N", "mobility", 1e-3),
        (8, "mm", "N", "receptance", 1e-3),
        (12, "in/s^2", "lbf", "accelerance", 0.0254 / 4.4482216152605),
        (0, "(m/s)/N", "NONE", "mobility", 1.0),
        (1, "g/N", "NONE", "accelerance", G0),
        (12, "NONE", "NONE", "accelerance", 1.0),
    ],
)
def test_units_to_si(tmp_path: Path, code: int, label: str, den_label: str, form: str, factor: float) -> None:
    truth = _truth(1, 1)
    path = _write(tmp_path / "u.uff", [_set(1, 2, 1, 2, truth[0, 0], ordinate_spec_data_type=code,
                                             ordinate_axis_units_lab=label, orddenom_axis_units_lab=den_label)])
    d = read_uff58(path)
    assert d.frf_form == form
    # exact unit definitions; values to pyuff's 12 digits
    np.testing.assert_allclose(d.frf[0, 0], truth[0, 0] * factor, rtol=RTOL_PYUFF, atol=0)
    assert len(d.meta["unit_decisions"]) == 1 and d.meta["unit_decisions"][0].startswith("dataset 0: " + form)


def test_unit_conflict_is_error_unless_rig_decides(tmp_path: Path, rig_file: Path) -> None:
    truth = _truth(1, 1)
    # code 12 (acceleration) but the label says velocity
    path = _write(tmp_path / "c.uff", [_set(11, 2, 11, 2, truth[0, 0], ordinate_axis_units_lab="mm/s")])
    with pytest.raises(UFFError, match=r"dataset 0: .*type 12 \(acceleration\) says accelerance .* mobility"):
        read_uff58(path)
    rig = load_rig(rig_file)
    one = dataclasses.replace(rig, sensors=rig.sensors[:1], axial=None)
    by_code = read_uff58(path, rig=dataclasses.replace(one, unit_preference="code"))
    assert by_code.frf_form == "accelerance"
    np.testing.assert_allclose(by_code.frf[0, 0], truth[0, 0], rtol=RTOL_PYUFF)  # no label scale
    by_label = read_uff58(path, rig=dataclasses.replace(one, unit_preference="label"))
    assert by_label.frf_form == "mobility"
    np.testing.assert_allclose(by_label.frf[0, 0], truth[0, 0] * 1e-3, rtol=RTOL_PYUFF)


def test_non_frf_datasets_are_plain_records(tmp_path: Path) -> None:
    t = np.linspace(0, 1, 16)
    path = _write(tmp_path / "mix.uff", [
        _set(1, 2, 1, 2, np.sin(t), func_type=1, ord_data_type=4, abscissa_spec_data_type=17,
             abscissa_axis_units_lab="s", ordinate_axis_units_lab="m/s^2"),
        _set(1, 2, 1, 2, _truth(1, 1)[0, 0]),
    ])
    f = read_uff(path)
    assert [r.function_type for r in f] == [1, 4]
    np.testing.assert_allclose(f[0].y, np.sin(t), rtol=RTOL_PYUFF)  # real time data as stored
    assert f[0].y.dtype == np.float64 and not f[0].y.flags.writeable
    d = read_uff58(path)
    assert d.shape == (1, 1, 16) and d.meta["datasets"] == [1]
    assert "function type 1" in d.meta["ignored_datasets"][0]


def test_minus_one_byte_pattern_inside_binary_payload(tmp_path: Path) -> None:
    # a float64 whose bytes are "\n    -1\n": pyuff's splitter would cut the dataset there
    v = struct.unpack("<d", b"\n    -1\n")[0]
    frf = np.full((1, 1, 6), 1.0 + 0j)
    frf[0, 0, 2] = v + 1j * v
    d = FRFData(np.arange(6) * 0.5, frf, ["1+Y"], ["1+Y"])
    p = tmp_path / "pattern.uff"
    write_uff58(p, d, binary=True)
    assert b"\n    -1\n" in p.read_bytes()[200:-8]
    back = read_uff58(p)
    np.testing.assert_array_equal(back.frf, d.frf)  # framed by byte count: exact


def test_missing_closing_delimiter_does_not_swallow_next(tmp_path: Path) -> None:
    truth = _truth(2, 1)
    p = _write(tmp_path / "two.uff", [_set(1, 2, 1, 2, truth[0, 0]), _set(2, 2, 1, 2, truth[1, 0])])
    text = p.read_bytes()
    first_end = text.index(b"    -1\n", 10)  # closing -1 of the first dataset
    p.write_bytes(text[:first_end] + text[first_end + 7 :])
    f = read_uff(p)
    assert [r.status for r in f] == ["read", "read"]
    assert any("closing -1" in n for n in f[0].notes)
    np.testing.assert_allclose(read_uff58(p).frf, truth, rtol=RTOL_PYUFF)


@pytest.mark.parametrize("even", [True, False])
def test_big_endian_58b(tmp_path: Path, even: bool) -> None:
    # byte order code 2: the same file with the header code changed and every value byte-swapped
    d = FRFData(FREQ, _truth(1, 1), ["1+Y"], ["1+Y"])
    p = tmp_path / "le.ufb"
    write_uff58(p, d, binary=True, abscissa="even" if even else "uneven")
    buf = p.read_bytes()
    head_end = buf.index(b"\n", buf.index(b"58b")) + 1
    q = head_end
    for _ in range(11):
        q = buf.index(b"\n", q) + 1
    n_bytes = int(buf[buf.index(b"58b") : head_end].split()[4])
    payload = np.frombuffer(buf[q : q + n_bytes], dtype="<f8").astype(">f8").tobytes()
    header = buf[:head_end].replace(b"58b     1", b"58b     2", 1)
    (tmp_path / "be.ufb").write_bytes(header + buf[head_end:q] + payload + buf[q + n_bytes :])
    back = read_uff58(tmp_path / "be.ufb")
    np.testing.assert_array_equal(back.frf, d.frf)  # binary double: exact
    np.testing.assert_array_equal(back.freq, FREQ)


# ------------------------------------------------------------------------------ errors
def _ok_file(tmp_path: Path, binary: bool = False) -> tuple[Path, FRFData]:
    d = FRFData(FREQ, _truth(2, 1), ["1+Y", "2+Y"], ["1+Y"])
    p = tmp_path / ("ok.ufb" if binary else "ok.uff")
    write_uff58(p, d, binary=binary)
    return p, d


def test_error_empty_file(tmp_path: Path) -> None:
    p = tmp_path / "empty.uff"
    p.write_bytes(b"")
    with pytest.raises(UFFError, match="empty.uff: empty file"):
        read_uff58(p)


def test_error_not_uff(tmp_path: Path) -> None:
    p = tmp_path / "notes.txt"
    p.write_text("this is a measurement log\nnot a universal file\n")
    with pytest.raises(UFFError, match="notes.txt: not a UFF file"):
        read_uff58(p)


def test_error_missing_file(tmp_path: Path) -> None:
    with pytest.raises(UFFError, match="file not found"):
        read_uff58(tmp_path / "nope.uff")


def test_error_truncated_ascii(tmp_path: Path) -> None:
    p, _ = _ok_file(tmp_path)
    buf = p.read_bytes()
    p.write_bytes(buf[: len(buf) - 300])  # cut inside the second dataset's values
    with pytest.raises(UFFError, match=r"dataset 1: FRF dataset refused: only \d+ of 32 values present"):
        read_uff58(p)
    assert [r.status for r in read_uff(p)] == ["read", "refused"]


def test_error_truncated_binary(tmp_path: Path) -> None:
    p, _ = _ok_file(tmp_path, binary=True)
    buf = p.read_bytes()
    p.write_bytes(buf[: len(buf) - 100])
    with pytest.raises(UFFError, match=r"dataset 1: .*truncated binary data: \d+ of 256 bytes"):
        read_uff58(p)


def test_error_nan_values(tmp_path: Path) -> None:
    # pyuff 2.5.8 writes a NaN as 0.00000000000e+00, so the NaN is put into the text here
    p = _write(tmp_path / "nan.uff", [_set(1, 2, 1, 2, _truth(1, 1)[0, 0])])
    lines = p.read_text().splitlines(keepends=True)
    row = lines[14]  # second data line: points 2 and 3 (re, im, re, im)
    lines[14] = row[:40] + f"{'NaN':>20}" + row[60:]
    p.write_text("".join(lines))
    assert read_uff(p)[0].status == "refused"
    with pytest.raises(UFFError, match=r"dataset 0: .*1 NaN or inf value\(s\), first at point 3"):
        read_uff58(p)


def test_error_duplicate_pair(tmp_path: Path) -> None:
    t = _truth(2, 1)
    # 13-Y and 13+Y are the same DOF once signs are corrected
    p = _write(tmp_path / "dup.uff", [_set(13, -2, 11, 2, t[0, 0]), _set(13, 2, 11, 2, t[1, 0])])
    with pytest.raises(UFFError, match=r"dataset 1: duplicate FRF 13\+Y / 11\+Y: also in dataset 0"):
        read_uff58(p)


def test_error_missing_pair(tmp_path: Path) -> None:
    t = _truth(2, 2)
    p = _write(tmp_path / "miss.uff", [
        _set(1, 2, 1, 2, t[0, 0]), _set(2, 2, 1, 2, t[1, 0]), _set(1, 2, 5, 1, t[0, 1]),
    ])
    with pytest.raises(UFFError, match=r"missing FRF 2\+Y / 5\+X"):
        read_uff58(p)


def test_error_mismatched_frequency_axes(tmp_path: Path) -> None:
    t = _truth(2, 1)
    p = _write(tmp_path / "ax.uff", [
        _set(1, 2, 1, 2, t[0, 0]), _set(2, 2, 1, 2, t[1, 0], x=FREQ * (1 + 1e-4)),
    ])
    with pytest.raises(UFFError, match=r"dataset 1: frequency axis differs from dataset 0 by up to"):
        read_uff58(p)
    # a difference inside the tolerance is accepted (no resampling: dataset 0's axis is kept)
    assert read_uff58(p, freq_rtol=2e-4).n_freq == FREQ.size
    p2 = _write(tmp_path / "ax2.uff", [_set(1, 2, 1, 2, t[0, 0]), _set(2, 2, 1, 2, t[1, 0][:8], x=FREQ[:8])])
    with pytest.raises(UFFError, match="dataset 1: 8 frequency lines but dataset 0 has 16"):
        read_uff58(p2)


def test_error_rig_dof_absent_from_file(tmp_path: Path, rig_file: Path) -> None:
    rig = load_rig(rig_file)
    t = _truth(8, 2)
    sets = [
        _set(s.dof.node, s.dof.direction, r.node, r.direction, t[i, j])
        for i, s in enumerate(rig.sensors) if s.dof.node != 22
        for j, r in enumerate(rig.references)
    ]
    p = _write(tmp_path / "lack.uff", sets)
    with pytest.raises(UFFError, match=r"rig sensor 22\+Y .* has no FRF in the file"):
        read_uff58(p, rig=rig)


def test_file_channel_without_sensor_is_ignored_with_warning(tmp_path: Path, rig_file: Path) -> None:
    rig = load_rig(rig_file)
    t = _truth(9, 2)
    sets = [
        _set(s.dof.node, s.dof.direction, r.node, r.direction, t[i, j])
        for i, s in enumerate(rig.sensors) for j, r in enumerate(rig.references)
    ]
    sets.append(_set(99, 3, 11, 2, t[8, 0]))  # a channel the rig file does not list
    p = _write(tmp_path / "extra.uff", sets)
    with pytest.warns(UnitWarning, match=r"response 99\+Z has no \[\[sensor\]\] entry"):
        d = read_uff58(p, rig=rig)
    assert d.n_out == 8 and d.meta["ignored_channels"] == ["dataset 16: 99+Z (no rig sensor)"]


@pytest.mark.parametrize("odt", [2, 4], ids=["real-single", "real-double"])
def test_real_valued_frf_is_refused_not_read_with_zero_imaginary(tmp_path: Path, odt: int) -> None:
    # pyuff writes both as its real type; the ordinate data type named in the message is the file's
    """An FRF is complex: a dataset of function type 4 stored as real values (a magnitude here) was read
    on 4ff7088 as an FRF with zero imaginary part, and ``modes`` printed modes from it with exit 0."""
    mag = np.abs(_truth(1, 1)[0, 0])
    path = _write(tmp_path / "mag.uff", [_set(1, 2, 1, 2, mag, ord_data_type=odt)])
    assert read_uff(path)[0].status == "read"  # the record itself is well framed: read_uff keeps it
    with pytest.raises(UFFError, match=r"dataset 0: FRF stored as real values \(ordinate data type [24]"):
        read_uff58(path)
    from ema_rig.io.uff import inspect_uff

    ds = inspect_uff(path)["datasets"][0]
    assert ds["status"] == "refused" and "real values" in ds["reason"] and ds["num_pts"] is None


@pytest.mark.parametrize(("code", "name"), [(19, "rpm"), (20, "order"), (8, "displacement")])
def test_frf_abscissa_code_that_is_no_frequency_is_refused(tmp_path: Path, code: int, name: str) -> None:
    """Without a unit label the abscissa code 19 (rpm), 20 (order) or a response quantity was read as Hz on
    4ff7088 (an rpm axis would put every mode 60x too high)."""
    truth = _truth(1, 1)[0, 0]
    path = _write(tmp_path / "x.uff", [_set(1, 2, 1, 2, truth, abscissa_spec_data_type=code,
                                             abscissa_axis_units_lab="NONE")])
    with pytest.raises(UFFError, match=rf"dataset 0: abscissa specific data type {code} \({name}\) is not a freq"):
        read_uff58(path)
    # an rpm code contradicting a frequency label is refused as well; the plain frequency code reads as Hz
    path = _write(tmp_path / "y.uff", [_set(1, 2, 1, 2, truth, abscissa_spec_data_type=19)])
    with pytest.raises(UFFError, match="contradicts its frequency unit label 'Hz'"):
        read_uff58(path)
    for ok_code in (0, 1, 18):
        path = _write(tmp_path / "z.uff", [_set(1, 2, 1, 2, truth, abscissa_spec_data_type=ok_code,
                                                 abscissa_axis_units_lab="NONE")])
        np.testing.assert_array_equal(read_uff58(path).freq, FREQ)  # exact: 0.5 Hz steps


def test_units_option_in_conflict_with_the_code_is_named_as_the_users(tmp_path: Path) -> None:
    """--units g on a velocity-coded file: 4ff7088 blamed "the unit label 'g'", which the file does not have."""
    path = _write(tmp_path / "v.uff", [_set(1, 2, 1, 2, _truth(1, 1)[0, 0], ordinate_spec_data_type=11,
                                             ordinate_axis_units_lab="NONE", orddenom_axis_units_lab="NONE")])
    with pytest.raises(UFFError, match=r"type 11 \(velocity\) says mobility .* 'g' was given by the user \(--units"):
        read_uff58(path, units="g")


def test_unlabelled_denominator_takes_the_force_unit_of_dataset_164(tmp_path: Path) -> None:
    """An inch-pound file (dataset 164: length 39.37 in/m, force 0.2248 lbf/N) whose FRF ordinate is labelled
    'g' and whose denominator is not labelled: the denominator is in the file's force unit, lbf. 4ff7088 took
    it as N: every FRF 4.448x too large (modal masses 4.448x too small), with 'dataset 164 not applied'."""
    import pyuff

    lbf = 4.4482216152605  # N, exact by definition
    truth = _truth(1, 1)[0, 0]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        u164 = pyuff.prepare_164(units_code=2, units_description="Inch (pound f)", temp_mode=2,
                                 length=1 / 0.0254, force=1 / lbf, temp=1.8, temp_offset=459.67)
    u164["type"] = 164
    frf = _set(1, 2, 1, 2, truth, ordinate_axis_units_lab="g", orddenom_axis_units_lab="NONE",
               orddenom_force_unit_exp=1)
    path = _write(tmp_path / "inch.uff", [u164, frf])
    d = read_uff58(path)
    # g / lbf in SI: 9.80665 / 4.4482216152605 = 2.2046 (m/s^2)/N; pyuff's 12 digits (164 factors too)
    np.testing.assert_allclose(d.frf[0, 0], truth * G0 / lbf, rtol=1e-10)
    assert "force unit of dataset 164" in d.meta["unit_decisions"][0]
    # a labelled denominator still wins over dataset 164
    path = _write(tmp_path / "inch_n.uff", [u164, _set(1, 2, 1, 2, truth, ordinate_axis_units_lab="g")])
    np.testing.assert_allclose(read_uff58(path).frf[0, 0], truth * G0, rtol=RTOL_PYUFF)


@pytest.mark.parametrize(("den", "factor"), [("lbf", 1 / 4.4482216152605), ("kN", 1e-3)])
def test_labelled_denominator_counts_without_an_ordinate_label(tmp_path: Path, den: str, factor: float) -> None:
    """Ordinate code 12 without a unit label, denominator labelled 'lbf' (or 'kN'): 4ff7088 read the values per N
    and wrote "no unit label ... SI (m, N) assumed" (4.448x or 1000x too large)."""
    truth = _truth(1, 1)[0, 0]
    path = _write(tmp_path / "d.uff", [_set(1, 2, 1, 2, truth, ordinate_axis_units_lab="NONE",
                                             orddenom_axis_units_lab=den)])
    d = read_uff58(path)
    np.testing.assert_allclose(d.frf[0, 0], truth * factor, rtol=RTOL_PYUFF)  # exact unit definitions
    assert f"per '{den}' (denominator label)" in d.meta["unit_decisions"][0]
    assert "SI (m) assumed for the ordinate" in d.meta["units_assumed"]  # the ordinate's unit is still assumed
    path = _write(tmp_path / "e.uff", [_set(1, 2, 1, 2, truth, ordinate_axis_units_lab="NONE",
                                             orddenom_axis_units_lab="m/s^2")])
    with pytest.raises(UFFError, match="denominator unit label 'm/s\\^2' is not a force unit"):
        read_uff58(path)
