"""Rig configuration: the DESIGN §3.1 contract and its validation messages."""

from __future__ import annotations

from pathlib import Path

import pytest

from ema_rig.config import load_rig
from ema_rig.dof import DOF
from ema_rig.errors import ConfigError


def test_paper_rig(rig_file: Path) -> None:
    rig = load_rig(rig_file)
    assert rig.model.m_H == 2.566 and rig.model.k_MS == 114e6
    assert rig.radial == DOF(11, 2) and rig.axial == DOF(15, 1)
    assert len(rig.sensors) == 8
    s13 = rig.sensor_for(DOF(13, 2))
    assert s13 is not None and s13.dof.sign == -1 and s13.role == "housing"


@pytest.mark.parametrize(
    ("old", "new", "key", "words"),
    [
        ("m_H = 2.566\n", "", "model.m_H", "missing"),
        ("k_B = 180e3\n", "k_B = 180e3\nk_X = 1.0\n", "model.k_X", "allowed keys"),
        ('role = "spindle"', 'role = "shaft"', "role", "housing, spindle"),
        ('axis = "lateral"', 'axis = "vertical"', "axis", "radial, lateral, axial"),
        ('radial = "11+Y"', 'radial = "eleven"', "excitation.radial", "11+Y"),
        ("m_S = 2.8", "m_S = -2.8", "model.m_S", "positive"),
        ('dof = "12+Y"', 'dof = "11-Y"', "dof", "already used"),
    ],
)
def test_errors_name_key_and_allowed_values(
    tmp_path: Path, rig_toml_text: str, old: str, new: str, key: str, words: str
) -> None:
    assert old in rig_toml_text
    p = tmp_path / "bad.toml"
    p.write_text(rig_toml_text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_rig(p)
    msg = str(info.value)
    assert str(p) in msg and key in msg and words in msg


def test_unreadable_files(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="not found"):
        load_rig(tmp_path / "nope.toml")
    bad = tmp_path / "x.toml"
    bad.write_text("[model\n", encoding="utf-8")
    with pytest.raises(ConfigError, match="invalid TOML"):
        load_rig(bad)


def test_optional_tables(tmp_path: Path, rig_toml_text: str) -> None:
    p = tmp_path / "r.toml"
    p.write_text(
        rig_toml_text
        + "\n[uncertainty]\nm_H = 0.005\n[identification]\nband = [150.0, 1000.0]\nmax_order = 60\n"
        + '[units]\nprefer = "label"\n',
        encoding="utf-8",
    )
    rig = load_rig(p)
    assert rig.uncertainty == {"m_H": 0.005}
    assert rig.identification == {"band": (150.0, 1000.0), "max_order": 60}
    assert rig.unit_preference == "label"


_BIG = "1" + "0" * 400  # a 401-digit integer: outside TOML's 64-bit range


@pytest.mark.parametrize(
    ("old", "new", "key", "words"),
    [
        ("m_H = 2.566", "m_H = true", "model.m_H", "number"),
        ("m_H = 2.566", 'm_H = "2.566"', "model.m_H", "number"),
        ("m_H = 2.566", "m_H = nan", "model.m_H", "finite"),
        ("k_S = 348e6", "k_S = " + _BIG, "model.k_S", "64-bit"),
        ('radial = "11+Y"', "radial = 11", "excitation.radial", "DOF string"),
        ("[excitation]", "[uncertainty]\nm_H = true\n[excitation]", "uncertainty.m_H", "number"),
        ("[excitation]", "[uncertainty]\nm_H = 1.5\n[excitation]", "uncertainty.m_H", "[0, 1)"),
        ("[excitation]", "[identification]\nmax_order = true\n[excitation]", "identification.max_order", "integer"),
        ("[excitation]", "[identification]\nmax_order = " + _BIG + "\n[excitation]", "identification.max_order",
         "64-bit"),
        ("[excitation]", "[identification]\nband = [false, 900.0]\n[excitation]", "identification.band", "number"),
        ("[excitation]", "[units]\nprefer = 1\n[excitation]", "units.prefer", "'code' or 'label'"),
        ("[excitation]", "[rig]\nname = 1\n[excitation]", "rig.name", "string"),
        ("[excitation]", "[rig]\ndescription = false\n[excitation]", "rig.description", "string"),
    ],
)
def test_values_strictly_typed(tmp_path: Path, rig_toml_text: str, old: str, new: str, key: str, words: str) -> None:
    assert old in rig_toml_text
    p = tmp_path / "bad.toml"
    p.write_text(rig_toml_text.replace(old, new, 1), encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_rig(p)
    msg = str(info.value)
    assert info.value.key == key and words in msg and str(p) in msg and len(msg) < 300


def test_cli_one_line_error_for_a_huge_integer(tmp_path: Path, rig_toml_text: str, capsys) -> None:
    from ema_rig.cli import main

    p = tmp_path / "bad.toml"
    p.write_text(rig_toml_text.replace("k_S = 348e6", "k_S = " + _BIG), encoding="utf-8")
    assert main(["simulate", "--rig", str(p), "--k-tb", "6e7", "-o", str(tmp_path / "x.uff")]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"error: {p}: model.k_S: ") and err.count("\n") == 1 and not (tmp_path / "x.uff").exists()


def test_special_and_huge_files_refused(tmp_path: Path) -> None:
    import os

    from ema_rig.config import read_regular_file

    if hasattr(os, "mkfifo"):
        os.mkfifo(tmp_path / "fifo.toml")
        with pytest.raises(ConfigError, match="not a regular file"):
            load_rig(tmp_path / "fifo.toml")  # would block forever on a plain open()
    if Path("/dev/zero").exists():
        with pytest.raises(ConfigError, match="not a regular file"):
            load_rig("/dev/zero")  # would read forever
    with pytest.raises(ConfigError, match="is a directory"):
        load_rig(tmp_path)
    big = tmp_path / "big.toml"
    big.write_bytes(b"# " + b"x" * 100 + b"\n")
    with pytest.raises(ValueError, match="larger than the 50 bytes"):
        read_regular_file(big, max_bytes=50)


@pytest.mark.parametrize(
    ("line", "ok", "words"),
    [
        ("refine = true\nn_averages = 10", True, ""),
        ('refine = "true"', False, "identification.refine"),
        ("refine = 1", False, "identification.refine"),
        ("n_averages = 0.5", False, "identification.n_averages"),
        ("n_averages = true", False, "identification.n_averages"),
    ],
)
def test_identification_refine_keys(tmp_path: Path, rig_toml_text: str, line: str, ok: bool, words: str) -> None:
    """The refinement switch is a real bool and the number of averages at least 1 (strict TOML types)."""
    p = tmp_path / "rig.toml"
    p.write_text(rig_toml_text + f"\n[identification]\n{line}\n", encoding="utf-8")
    if ok:
        ident = load_rig(p).identification
        assert ident["refine"] is True and ident["n_averages"] == 10.0
    else:
        with pytest.raises(ConfigError, match=words.replace(".", r"\.")):
            load_rig(p)
