"""Units and plausibility (issue 20): a unit for files without a label (``--units``, rig ``[units]
ordinate``), rig parameters outside a plausible range refused with the unit they were probably
meant in, and ``ema-rig frf`` never writing an assumed unit as a label."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from ema_rig.cli import main
from ema_rig.config import load_rig
from ema_rig.errors import ConfigError
from ema_rig.io.uff import read_uff, read_uff58, write_uff58
from ema_rig.simulate import simulate_measurement

FREQ = np.arange(0.0, 1100.0 + 0.25, 0.5)
G0 = 9.80665  # m/s^2 per g (CGPM 1901), independent of ema_rig's constant


@pytest.fixture(scope="module")
def files(tmp_path_factory, rig_toml_text):
    """The same simulated measurement in g with labels, and in g without any unit label."""
    d = tmp_path_factory.mktemp("units")
    (d / "rig.toml").write_text(rig_toml_text, encoding="utf-8")
    rig = load_rig(d / "rig.toml")
    sim = simulate_measurement(rig, k_tb=71.57e6, freq=FREQ, noise=0.01, seed=7)
    write_uff58(d / "g.uff", sim.data, accel_unit="g", rig=rig, binary=True)
    write_uff58(d / "g_nolabel.uff", sim.data, accel_unit="g", rig=rig, binary=True, labelled=False)
    return d, rig, sim


def test_units_override_reads_an_unlabelled_file_in_g(files):
    d, rig, sim = files
    plain = read_uff58(d / "g_nolabel.uff", rig=rig)
    # without a label the code says acceleration and SI is assumed: every value 1/g of the truth
    np.testing.assert_allclose(plain.frf * G0, sim.data.frf, rtol=1e-12)  # binary double: exact to rounding
    given = read_uff58(d / "g_nolabel.uff", rig=rig, units="g")
    np.testing.assert_allclose(given.frf, sim.data.frf, rtol=1e-12)
    assert "given by the user" in given.meta["unit_decisions"][0]
    # a file's own label always wins over the override
    np.testing.assert_allclose(read_uff58(d / "g.uff", rig=rig, units="mm/s").frf, sim.data.frf, rtol=1e-12)
    # the documented rig-file entry does the same
    text = (d / "rig.toml").read_text(encoding="utf-8") + '\n[units]\nordinate = "g"\n'
    (d / "rig_g.toml").write_text(text, encoding="utf-8")
    rig_g = load_rig(d / "rig_g.toml")
    assert rig_g.unit_ordinate == "g"
    np.testing.assert_allclose(read_uff58(d / "g_nolabel.uff", rig=rig_g).frf, sim.data.frf, rtol=1e-12)


def test_units_option_on_the_command_line(files, capsys):
    d, _, sim = files
    out = d / "k.json"
    argv = ["stiffness", str(d / "g_nolabel.uff"), "--rig", str(d / "rig.toml"), "--no-spindle", "--json", str(out)]
    assert main([*argv, "--units", "g"]) == 0, capsys.readouterr().err
    # the simulator's radial dynamics are the 3DOF model's: k_TB within 1 %
    np.testing.assert_allclose(json.loads(out.read_text())["k_TB"], sim.truth["k_TB"], rtol=1e-2)
    for cmd in (["inspect", str(d / "g_nolabel.uff")], ["modes", str(d / "g_nolabel.uff")],
                ["calibrate", str(d / "g_nolabel.uff"), "--rig", str(d / "rig.toml")]):
        assert main([*cmd, "--units", "Hz"]) == 2, cmd
        assert "'Hz' is not a displacement, velocity or acceleration unit" in capsys.readouterr().err


def test_rig_units_entry_checked(tmp_path, rig_toml_text):
    (tmp_path / "rig.toml").write_text(rig_toml_text + '\n[units]\nordinate = "kg"\n', encoding="utf-8")
    with pytest.raises(ConfigError, match=r"units\.ordinate.*'kg' is not a displacement"):
        load_rig(tmp_path / "rig.toml")


@pytest.mark.parametrize(("line", "typo", "message"), [
    ("k_MS = 114e6", "k_MS = 114",
     "k_MS = 114 N/m is implausible for a mounting stiffness (expected 1.14e+06 .. 1.14e+10 N/m, Table 1 of the "
     "paper x/÷ 100); did you mean 114e6 (MN/m)?"),
    ("k_AS = 650e3", "k_AS = 650", "did you mean 650e3 (kN/m)?"),
    ("m_H = 2.566", "m_H = 2566", "m_H = 2566 kg is implausible for a housing mass"),
])
def test_implausible_rig_parameter_with_a_unit_hint(tmp_path, rig_toml_text, line, typo, message, capsys):
    assert line in rig_toml_text
    (tmp_path / "rig.toml").write_text(rig_toml_text.replace(line, typo), encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_rig(tmp_path / "rig.toml")
    assert message in str(info.value) and info.value.key == f"model.{line.split()[0]}"
    assert main(["stiffness", "x.uff", "--rig", str(tmp_path / "rig.toml")]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err


def test_frf_never_writes_an_assumed_unit_as_a_label(tmp_path, capsys):
    pyuff = pytest.importorskip("pyuff")
    fs, n = 1000.0, 1024
    t = np.arange(n) / fs
    force = np.zeros(n)
    force[3:6] = [100.0, 60.0, 20.0]
    resp = np.convolve(force, np.exp(-20 * t) * np.sin(2 * np.pi * 120 * t))[:n]
    common = dict(func_type=1, ord_data_type=4, num_pts=n, abscissa_spacing=1, abscissa_min=0.0,
                  abscissa_inc=1.0 / fs, abscissa_spec_data_type=17, orddenom_spec_data_type=0,
                  abscissa_axis_units_lab="s", binary=0, x=t, ref_node=1, ref_dir=3)
    src = tmp_path / "time.uff"
    pyuff.UFF(str(src)).write_sets([
        pyuff.prepare_58(id1="force", rsp_node=1, rsp_dir=3, ordinate_spec_data_type=13,
                         ordinate_axis_units_lab="NONE", data=force, **common),
        pyuff.prepare_58(id1="resp", rsp_node=2, rsp_dir=3, ordinate_spec_data_type=12,
                         ordinate_axis_units_lab="NONE", data=resp, **common)], mode="add")
    out = tmp_path / "frf.uff"
    with warnings.catch_warnings():
        warnings.simplefilter("always")
        assert main(["frf", str(src), "-o", str(out)]) == 0
    assert "carries no unit label either" in capsys.readouterr().err
    frf = [r for r in read_uff(out).records if r.function_type == 4][0]
    assert frf.header["ordinate_axis_units_lab"].strip() == "NONE"
    assert frf.header["orddenom_axis_units_lab"].strip() == "NONE"
    assert "SI (m, N) assumed" in read_uff58(out).meta["unit_decisions"][0]


def test_units_help_is_documented():
    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text(encoding="utf-8")
    assert 'ordinate = "g"' in readme and "--units" in readme
