"""UFF58 as other exporters write it: what the reader misread or accepted on 23abb6b (task q_user14).

Every fixture is written by pyuff (the independent writer of ``tests/_pyuff_files.py``), with the
header fields as the exporters named in each test store them; the oracle is the same samples
written with the fields the reader already understood (codes 13/12, no percent, one force
unit), or the unit definitions (1 lbf = 4.4482216152605 N exactly, 1 % = 0.01). Each test fails
on 23abb6b (the failing behaviour is named in its docstring).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from _pyuff_files import write_with_pyuff

from ema_rig.errors import UFFError
from ema_rig.io.time_data import read_time_uff
from ema_rig.io.uff import inspect_uff, read_uff58

FREQ = np.arange(1, 65) * 2.0  # Hz
LBF = 4.4482216152605  # N, exact by definition
# pyuff writes ASCII doubles with %20.11e (12 significant digits)
RTOL_PYUFF = 1e-11


def _set(**kw: object) -> dict:
    import pyuff

    args: dict = dict(
        binary=0, func_type=4, rsp_node=11, rsp_dir=2, ref_node=1, ref_dir=2, ord_data_type=6, abscissa_spacing=1,
        abscissa_spec_data_type=18, abscissa_axis_units_lab="Hz", ordinate_spec_data_type=12,
        ordinate_axis_units_lab="m/s^2", orddenom_spec_data_type=13, orddenom_axis_units_lab="N", x=FREQ,
        id1="exporter variant", id2="NONE", id3="NONE", id4="NONE", id5="NONE",
    )
    args.update(kw)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pyuff.prepare_58(**args)


def _frf() -> np.ndarray:
    w, wn = 2 * np.pi * FREQ, 2 * np.pi * 60.0
    return -(w**2) / (wn**2 - w**2 + 2j * 0.02 * wn * w)  # accelerance of 1 kg, m/s^2/N


def _coherence() -> np.ndarray:
    return 0.9 + 0.09 * np.sin(FREQ / 10.0)  # 0.81..0.99, inside 0..1


def _coh_set(values: np.ndarray, label: str) -> dict:
    return _set(func_type=6, ord_data_type=4, ordinate_spec_data_type=0, ordinate_axis_units_lab=label,
                orddenom_spec_data_type=0, orddenom_axis_units_lab="NONE", data=values.astype(float))


# ----------------------------------------------------------------------------- coherence scale
def test_coherence_labelled_percent_is_divided_by_100(tmp_path: Path) -> None:
    """A coherence written in per cent (label '%', values 0..100) is the same coherence / 100.

    23abb6b clipped every line to 1 (a perfect coherence everywhere, with a warning only).
    """
    p = write_with_pyuff(tmp_path / "pct.uff", [_set(data=_frf()), _coh_set(100.0 * _coherence(), "%")])
    d = read_uff58(p)
    assert d.coherence is not None
    np.testing.assert_allclose(d.coherence[0, 0], _coherence(), rtol=RTOL_PYUFF)
    assert not d.meta["warnings"]
    assert any("'%'" in n for n in d.meta["notes"])


def test_unlabelled_coherence_mostly_above_one_is_ignored_not_clipped(tmp_path: Path) -> None:
    """Values 81..99 without a label are not a coherence 0..1 (a percentage that lost its label).

    Clipping is a repair for isolated lines above 1 (vt_case1: 5 of 1601 lines); 23abb6b clipped
    all 64 lines to 1 and attached that.
    """
    p = write_with_pyuff(tmp_path / "pct_nolabel.uff", [_set(data=_frf()), _coh_set(100.0 * _coherence(), "NONE")])
    d = read_uff58(p)
    assert d.coherence is None
    assert any("not a coherence in 0..1" in n for n in d.meta["notes"])


def test_coherence_with_a_dimensioned_unit_label_is_ignored(tmp_path: Path) -> None:
    """A function-type-6 dataset labelled 'g' is not a ratio; 23abb6b attached it as coherence."""
    p = write_with_pyuff(tmp_path / "coh_g.uff", [_set(data=_frf()), _coh_set(_coherence(), "g")])
    d = read_uff58(p)
    assert d.coherence is None
    assert any("not dimensionless" in n for n in d.meta["notes"])


def test_coherence_labelled_one_is_still_attached(tmp_path: Path) -> None:
    """Label '1' (UFFFiles.jl's coherence, corpus ufffiles_coh.unv) is dimensionless: attached as is."""
    p = write_with_pyuff(tmp_path / "coh_1.uff", [_set(data=_frf()), _coh_set(_coherence(), "1")])
    d = read_uff58(p)
    assert d.coherence is not None
    np.testing.assert_allclose(d.coherence[0, 0], _coherence(), rtol=RTOL_PYUFF)


# ----------------------------------------------------------------------- contradicting labels
def test_whole_frf_label_contradicting_the_denominator_label_is_refused(tmp_path: Path) -> None:
    """Ordinate label 'g/N' over denominator label 'lbf': per N or per lbf (x 4.45)? 23abb6b read it
    per N without a word; now refused naming the file, the dataset and both labels."""
    p = write_with_pyuff(tmp_path / "gN_lbf.uff", [_set(data=_frf() / 9.80665, ordinate_axis_units_lab="g/N",
                                                        orddenom_axis_units_lab="lbf")])
    with pytest.raises(UFFError, match=r"gN_lbf.uff.*dataset 0.*'g/N'.*'lbf'.*contradict"):
        read_uff58(p)
    ds = inspect_uff(p)["datasets"][0]  # inspect says the same of the dataset
    assert ds["status"] == "refused" and "contradict" in ds["reason"]


@pytest.mark.parametrize(("num", "den", "factor"), [("g/lbf", "lbf", 9.80665 / LBF), ("(m/s^2)/N", "N", 1.0),
                                                     ("m/s^2/kN", "kN", 1e-3)])
def test_whole_frf_label_agreeing_with_the_denominator_label_is_read(tmp_path: Path, num: str, den: str,
                                                                      factor: float) -> None:
    """The same force unit in both labels (LMS / m+p style) is read once, not twice."""
    h = _frf()
    p = write_with_pyuff(tmp_path / "ok.uff", [_set(data=h / factor, ordinate_axis_units_lab=num,
                                                    orddenom_axis_units_lab=den)])
    np.testing.assert_allclose(read_uff58(p).frf[0, 0], h, rtol=RTOL_PYUFF)


# ------------------------------------------------------------------------------ time histories
FS = 512.0


def _time_sets(codes: tuple[int, int], labels: tuple[str, str], *, spacing: int = 1, t0: float = 0.0,
               jitter: float = 0.0) -> list[dict]:
    rng = np.random.default_rng(14)
    n = 256
    t = t0 + (np.arange(n) + jitter * rng.uniform(-1, 1, n)) / FS
    x, y = rng.standard_normal(n), rng.standard_normal(n)
    out = []
    for node, code, lab, data in ((1, codes[0], labels[0], x), (11, codes[1], labels[1], y)):
        out.append(_set(func_type=1, ord_data_type=4, rsp_node=node, rsp_dir=2, ref_node=0, ref_dir=0,
                        abscissa_spacing=spacing, abscissa_min=t0, abscissa_spec_data_type=17,
                        abscissa_axis_units_lab="s", abscissa_inc=1.0 / FS, x=t,
                        ordinate_spec_data_type=code, ordinate_axis_units_lab=lab, orddenom_spec_data_type=0,
                        orddenom_axis_units_lab="NONE", data=data))
    return out


@pytest.mark.parametrize("codes", [(0, 0), (1, 1), (0, 1)])
def test_time_history_quantity_from_its_label_when_the_code_states_none(tmp_path: Path,
                                                                        codes: tuple[int, int]) -> None:
    """HBM catman (code 1, 'm/s²') and UFFFiles.jl (code 0, 'N') state the quantity in the unit
    label only; 23abb6b refused the file ("cannot tell excitation from response"). The result must
    equal the same samples written with codes 13 / 12."""
    ref = read_time_uff(write_with_pyuff(tmp_path / "coded.uff", _time_sets((13, 12), ("N", "m/s²"))))
    got = read_time_uff(write_with_pyuff(tmp_path / "label.uff", _time_sets(codes, ("N", "m/s²"))))
    assert got.in_dofs == ref.in_dofs and got.out_dofs == ref.out_dofs and got.frf_form == "accelerance"
    np.testing.assert_array_equal(got.force, ref.force)
    np.testing.assert_array_equal(got.response, ref.response)
    assert any("unit label 'N' says force" in n for n in got.notes)


@pytest.mark.parametrize(("labels", "match"), [(("V", "m/s²"), "'V' not understood"),
                                                (("NONE", "m/s²"), "no unit label")])
def test_time_history_without_a_quantity_still_refused(tmp_path: Path, labels: tuple[str, str], match: str) -> None:
    """Code 0 with a voltage or without a label says nothing usable: refused, naming file and dataset."""
    p = write_with_pyuff(tmp_path / "volt.uff", _time_sets((0, 12), labels))
    with pytest.raises(UFFError, match=rf"volt.uff.*dataset 0.*{match}"):
        read_time_uff(p)


# ------------------------------------------------------------------ a unit system written last
def _u164(length: float, force: float) -> dict:
    import pyuff

    u = pyuff.prepare_164(units_code=2, units_description="Inch (pound f)" if length != 1.0 else "SI", temp_mode=2,
                          length=length, force=force, temp=1.8, temp_offset=459.67)
    u["type"] = 164
    return u


def test_frf_without_labels_followed_by_an_inch_dataset_164_is_refused(tmp_path: Path) -> None:
    """A dataset 164 sets the units of what follows it; one written after the unlabelled FRFs may be
    meant for them (x 4.45 / 39.4 apart). 23abb6b read the FRF as SI, saying "no dataset 164"."""
    frf = _set(data=_frf(), ordinate_axis_units_lab="NONE", orddenom_axis_units_lab="NONE")
    p = write_with_pyuff(tmp_path / "last164.uff", [frf, _u164(39.37007874015748, 0.2248089430997105)])
    with pytest.raises(UFFError, match=r"last164.uff.*dataset 0.*dataset 1 \(164.*follows it"):
        read_uff58(p)
    # the same dataset 164 before the FRF applies to it; an SI dataset 164 after it changes nothing
    p = write_with_pyuff(tmp_path / "first164.uff", [_u164(39.37007874015748, 0.2248089430997105), frf])
    np.testing.assert_allclose(read_uff58(p).frf[0, 0], _frf() * 0.0254 / LBF, rtol=RTOL_PYUFF)
    p = write_with_pyuff(tmp_path / "si164.uff", [frf, _u164(1.0, 1.0)])
    np.testing.assert_allclose(read_uff58(p).frf[0, 0], _frf(), rtol=RTOL_PYUFF)


def test_time_history_without_labels_followed_by_a_dataset_164_is_refused(tmp_path: Path) -> None:
    """The same for time histories (the ``frf`` command's input)."""
    sets = _time_sets((13, 12), ("NONE", "NONE"))
    p = write_with_pyuff(tmp_path / "t_last164.uff", [*sets, _u164(39.37007874015748, 0.2248089430997105)])
    with pytest.raises(UFFError, match=r"t_last164.uff.*dataset 0.*dataset 2 \(164.*follows it"):
        read_time_uff(p)


# --------------------------------------------------------------- explicit (uneven-format) time axis
@pytest.mark.parametrize("t0", [0.0, -0.05])
def test_evenly_sampled_time_axis_written_explicitly_is_read(tmp_path: Path, t0: float) -> None:
    """pyuff writes an explicit abscissa as the UFF58 spec says (E13.5: 6 significant digits), so the
    steps of a 512 Hz record differ by up to 1e-8 s; 23abb6b refused every such file ("not evenly
    spaced": steps equal to 1e-6 of dt). Oracle: the same samples with the header's even axis; the
    sampling rate agrees within what 6 digits of the largest |t| (0.5 s) allow over the record."""
    ref = read_time_uff(write_with_pyuff(tmp_path / "even.uff", _time_sets((13, 12), ("N", "g"), t0=t0)))
    got = read_time_uff(write_with_pyuff(tmp_path / "explicit.uff", _time_sets((13, 12), ("N", "g"), spacing=0,
                                                                                t0=t0)))
    np.testing.assert_array_equal(got.force, ref.force)
    np.testing.assert_array_equal(got.response, ref.response)
    duration = 255 / FS
    assert abs(got.fs - FS) / FS <= 2 * 5e-7 / duration  # two end points rounded to 5e-7 s (E13.5 at 0.1..1 s)


def test_truly_uneven_time_axis_still_refused(tmp_path: Path) -> None:
    """Sampling instants jittered by up to 1 % of a step are not an even record: refused, with the deviation."""
    p = write_with_pyuff(tmp_path / "jitter.uff", _time_sets((13, 12), ("N", "g"), spacing=0, jitter=0.01))
    with pytest.raises(UFFError, match=r"jitter.uff.*dataset 0.*not evenly spaced.*deviates by up to"):
        read_time_uff(p)


# ------------------------------------------------------------- records 8-11 without fixed columns
def _free_format_axes(path: Path, axes: dict[int, str]) -> Path:
    """Rewrite header records 8..11 (lines 10..13 after the dataset's type line) as given."""
    lines = path.read_text().split("\n")
    start = next(i for i, ln in enumerate(lines) if ln.strip() == "58")
    for k, text in axes.items():
        lines[start + k] = text
    path.write_text("\n".join(lines))
    return path


def test_axis_records_written_blank_separated_keep_their_unit_labels(tmp_path: Path) -> None:
    """Records 8..11 as "12 1 0 0 Acceleration g" (integers not at the I10,3I5 columns): 23abb6b read
    the integers but took the labels from columns 27-46 / 48-67 (empty here), so 'g' was lost and the
    FRF read as SI, 9.81x too small, saying "no unit label". Oracle: the fixed-column file."""
    h = _frf()
    fixed = write_with_pyuff(tmp_path / "fixed.uff", [_set(data=h / 9.80665, ordinate_axis_units_lab="g")])
    free = _free_format_axes(write_with_pyuff(tmp_path / "free.uff", [_set(data=h / 9.80665,
                                                                           ordinate_axis_units_lab="g")]),
                             {8: "18 0 0 0 Frequency Hz", 9: "12 1 0 0 Acceleration g", 10: "13 0 1 0 Force N",
                              11: "0 0 0 0 NONE NONE"})
    np.testing.assert_array_equal(read_uff58(free).frf, read_uff58(fixed).frf)
    np.testing.assert_allclose(read_uff58(free).frf[0, 0], h, rtol=RTOL_PYUFF)
    # three words after the integers: axis label "Real Part" and unit "g", or "Real" and "Part g"? refused
    amb = _free_format_axes(write_with_pyuff(tmp_path / "amb.uff", [_set(data=h)]), {9: "12 1 0 0 Real Part g"})
    with pytest.raises(UFFError, match=r"amb.uff.*dataset 0.*record 9.*3 word\(s\).*ambiguous"):
        read_uff58(amb)


# ------------------------------------------------------------------------ DOFs in entity names
@pytest.mark.parametrize(("rsp", "ref", "sign"), [("11+Y", "1:+Y", 1.0), ("11:-Y", "1+Y", -1.0),
                                                  ("11Y-", ".1.Y+", -1.0)])
def test_dof_in_entity_name_with_the_sign_before_the_axis(tmp_path: Path, rsp: str, ref: str, sign: float) -> None:
    """Node and direction fields 0, the DOF in the entity name as ema_rig itself writes a DOF ('11+Y') or
    with a colon ('1:+Y'): 23abb6b read these as DOF 0 (scalar) without a word (the corpus form
    '.1.Z-' was read). Oracle: the node/direction fields 11 / +-2 and 1 / 2."""
    h = _frf()
    p = write_with_pyuff(tmp_path / "ent.uff", [_set(data=sign * h, rsp_node=0, rsp_dir=0, ref_node=0, ref_dir=0,
                                                     rsp_ent_name=rsp, ref_ent_name=ref)])
    d = read_uff58(p)
    assert [str(x) for x in d.out_dofs] == ["11+Y"] and [str(x) for x in d.in_dofs] == ["1+Y"]
    np.testing.assert_allclose(d.frf[0, 0], h, rtol=RTOL_PYUFF)


def test_entity_name_that_is_no_dof_is_noted(tmp_path: Path) -> None:
    """'Point11' with node and direction 0: DOF 0 as before, but no longer silently."""
    p = write_with_pyuff(tmp_path / "pt.uff", [_set(data=_frf(), rsp_node=0, rsp_dir=0, rsp_ent_name="Point11")])
    d = read_uff58(p)
    assert str(d.out_dofs[0]) == "0"
    assert any("'Point11' is not read as a DOF" in n for n in d.meta["notes"])


def test_frf_unit_exponents_of_the_whole_frf_under_an_inch_dataset_164_are_refused(tmp_path: Path) -> None:
    """Ordinate exponents length 1, force -1 (the whole FRF's) with the denominator's 0, 0, under an
    inch/lbf dataset 164: 23abb6b scaled by lbf^-2 (the ordinate's -1 and the denominator's assumed 1),
    a factor 4.45 off in one direction or the other. Now refused; the spec's 1, 0 over 0, 1 (and pyuff's
    unfilled 0s) still read with the inch/lbf factor (oracle: 1 in = 0.0254 m, 1 lbf = 4.4482216152605 N)."""
    inch = _u164(39.37007874015748, 0.2248089430997105)
    unlabelled = dict(ordinate_axis_units_lab="NONE", orddenom_axis_units_lab="NONE")
    whole = _set(data=_frf(), ordinate_len_unit_exp=1, ordinate_force_unit_exp=-1, orddenom_len_unit_exp=0,
                 orddenom_force_unit_exp=0, **unlabelled)
    with pytest.raises(UFFError, match=r"whole.uff.*dataset 1.*ordinate length 1, force -1.*not clear"):
        read_uff58(write_with_pyuff(tmp_path / "whole.uff", [inch, whole]))
    for exps in ((1, 0, 0, 1), (0, 0, 0, 0)):
        spec = _set(data=_frf(), ordinate_len_unit_exp=exps[0], ordinate_force_unit_exp=exps[1],
                    orddenom_len_unit_exp=exps[2], orddenom_force_unit_exp=exps[3], **unlabelled)
        d = read_uff58(write_with_pyuff(tmp_path / "spec.uff", [inch, spec]))
        np.testing.assert_allclose(d.frf[0, 0], _frf() * 0.0254 / LBF, rtol=RTOL_PYUFF)


# ------------------------------------------------------------------- task q_user15: the leftovers
def _reader_reason(path: Path) -> str:
    """read_uff58's refusal without its ``<file>: dataset N: `` head."""
    with pytest.raises(UFFError) as info:
        read_uff58(path)
    return str(info.value).split(": ", 2)[2]


def test_inspect_refuses_what_read_uff58_refuses_for_its_units(tmp_path: Path,
                                                                capsys: pytest.CaptureFixture[str]) -> None:
    """An FRF dataset whose units read_uff58 refuses (a non-SI dataset 164 after unlabelled data, unit
    exponents that are no response per force, an acceleration code under a velocity label) is "refused"
    by inspect with the reader's reason, word for word; 1f37e8b listed all three as "read"."""
    from ema_rig.cli import main

    inch = _u164(39.37007874015748, 0.2248089430997105)
    unlabelled = dict(ordinate_axis_units_lab="NONE", orddenom_axis_units_lab="NONE")
    files = {
        "last164.uff": ([_set(data=_frf(), **unlabelled), inch], 0),
        "whole.uff": ([inch, _set(data=_frf(), ordinate_len_unit_exp=1, ordinate_force_unit_exp=-1,
                                  orddenom_len_unit_exp=0, orddenom_force_unit_exp=0, **unlabelled)], 1),
        "code_label.uff": ([_set(data=_frf(), ordinate_axis_units_lab="m/s")], 0),
    }
    for name, (sets, index) in files.items():
        p = write_with_pyuff(tmp_path / name, sets)
        ds = inspect_uff(p)["datasets"][index]
        assert ds["status"] == "refused" and ds["num_pts"] is None, name
        assert ds["reason"] == _reader_reason(p), name
        assert main(["inspect", str(p)]) == 1
        row = next(ln for ln in capsys.readouterr().out.splitlines() if ln.startswith(f"{index}  58"))
        assert row.endswith(f"refused: {ds['reason']}"), name


def test_inspect_with_the_user_unit_reads_what_read_uff58_reads(tmp_path: Path) -> None:
    """``--units`` (inspect_uff's ``units``) settles an unlabelled FRF as it does for read_uff58: the
    dataset 164 after it then changes nothing, and both read it."""
    p = write_with_pyuff(tmp_path / "last164.uff", [
        _set(data=_frf(), ordinate_axis_units_lab="NONE"), _u164(39.37007874015748, 0.2248089430997105)])
    assert inspect_uff(p, units="m/s^2")["datasets"][0]["status"] == "read"
    np.testing.assert_allclose(read_uff58(p, units="m/s^2").frf[0, 0], _frf(), rtol=RTOL_PYUFF)


def test_fortran_exponent_of_three_digits_without_e_is_named(tmp_path: Path) -> None:
    """Fortran E output of an exponent beyond 99 drops the 'E' ("1.234567-102" for 1.234567E-102);
    1f37e8b read it as two numbers and refused with a bare value count. Still refused (the number
    is not read), now naming the file, the dataset, the token and the form."""
    p = write_with_pyuff(tmp_path / "exp3.uff", [_set(data=_frf())])
    lines = p.read_text().split("\n")
    first_data = next(i for i, ln in enumerate(lines) if ln.strip() == "58") + 12
    toks = lines[first_data].split()
    lines[first_data] = " ".join(["1.234567-102", *toks[1:]])
    p.write_text("\n".join(lines))
    with pytest.raises(UFFError, match=r"exp3.uff.*dataset 0.*'1.234567-102'.*Fortran.*3-digit exponent.*'E'"):
        read_uff58(p)
    assert "1.234567E-102" in inspect_uff(p)["datasets"][0]["reason"]


def test_time_history_sign_conflict_with_the_rig_is_the_frf_warning(tmp_path: Path) -> None:
    """The file writes response 11-Y, the rig says 11+Y: read_time_uff (the ``frf`` path) gives the same
    one-line warning as read_uff58 does for FRFs (task q_user14 finding 8); 1f37e8b gave none."""
    from ema_rig.dof import DOF
    from ema_rig.io.layout import Channel, ChannelLayout

    rig = ChannelLayout(sensors=(Channel(DOF.parse("11+Y")),), references=(DOF.parse("1+Y"),))
    sets = _time_sets((13, 12), ("N", "m/s^2"))
    sets[1]["rsp_dir"] = -2
    td = read_time_uff(write_with_pyuff(tmp_path / "t_sign.uff", sets), rig=rig)
    frf = read_uff58(write_with_pyuff(tmp_path / "f_sign.uff", [_set(data=_frf(), rsp_dir=-2)]), rig=rig)
    assert len(td.warnings) == 1 and "file 11-Y / rig 11+Y" in td.warnings[0]
    assert list(td.warnings) == [w for w in frf.meta["warnings"] if "opposite signs" in w]
    agree = read_time_uff(write_with_pyuff(tmp_path / "t_ok.uff", _time_sets((13, 12), ("N", "m/s^2"))), rig=rig)
    assert agree.warnings == ()


def test_function_type_names_of_the_spec() -> None:
    """Codes 13-17 and 19-27 are named as the dataset 58 spec lists them (the SDRL UFF text that pyuff
    reproduces, ``get_structure_58(raw=True)``, the oracle here); 1f37e8b showed them as numbers."""
    import re

    import pyuff.datasets.dataset_58 as spec

    from ema_rig.io.uff import FUNCTION_TYPES

    text = spec.get_structure_58(raw=True)
    listed = text[text.index("Function Type") : text.index("Function Identification Number")]
    names = {int(c): n.strip().lower() for c, n in re.findall(r"^\s*(\d+) - (.+)$", listed, re.M)}
    assert set(names) == set(range(28)) == set(FUNCTION_TYPES)
    assert all(FUNCTION_TYPES[c] == names[c] for c in (*range(13, 18), *range(19, 28)))
