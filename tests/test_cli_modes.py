"""``ema-rig modes`` and ``ema-rig stabilization`` end to end through UFF files."""

from __future__ import annotations

import json

import numpy as np
import pytest
from lumped import five_mode_system

from ema_rig.cli import main

FREQ = np.arange(0.0, 1000.5, 0.5)


@pytest.fixture(scope="module")
def system():
    return five_mode_system()


@pytest.fixture
def uff_file(tmp_path, system):
    from ema_rig.io.uff import write_uff58

    data = system.frf(FREQ, inputs=(0, 1), noise=0.01, rng=np.random.default_rng(8))
    path = tmp_path / "lumped.uff"
    write_uff58(path, data, binary=True)
    return path


def test_modes_json(uff_file, tmp_path, system, capsys):
    out = tmp_path / "modes.json"
    sel = tmp_path / "sel.json"
    rc = main(["modes", str(uff_file), "--band", "0", "1000", "--json", str(out), "--save-selection", str(sel)])
    assert rc == 0
    doc = json.loads(out.read_text())
    modes = doc["modes"]
    f = np.array([m["natural_freq"] for m in modes])
    z = np.array([m["damping_ratio"] for m in modes])
    # the six modes (two of them 1 % apart) of the lumped system, 1 % noise
    np.testing.assert_allclose(f, system.natural_freq, rtol=1e-4)
    np.testing.assert_allclose(z, system.damping_ratio, rtol=5e-2)
    for m in modes:
        assert {"natural_freq", "damping_ratio", "natural_freq_std", "damping_ratio_std", "mpc"} <= set(m)
        assert 0 <= m["natural_freq_std"] < 1e-3 * m["natural_freq"]
        # classically damped: real shapes (each from its best-excited driving point)
        assert m["mpc"] > 0.99
    assert doc["band"] == [0.0, 1000.0]
    assert capsys.readouterr().err == ""
    # replaying the saved selection on the same file gives the same modes
    out2 = tmp_path / "modes2.json"
    assert main(["modes", str(uff_file), "--band", "0", "1000", "--selection", str(sel), "--json", str(out2)]) == 0
    f2 = [m["natural_freq"] for m in json.loads(out2.read_text())["modes"]]
    np.testing.assert_allclose(f2, f, rtol=1e-12)


def test_modes_with_rig_file(tmp_path, rig_file, capsys):
    from ema_rig.config import load_rig
    from ema_rig.simulate import simulate_measurement, write_measurement

    rig = load_rig(rig_file)
    sim = simulate_measurement(rig, k_tb=7.157e7, noise=0.01, seed=1, freq=np.arange(0.0, 1200.5, 0.5))
    path = write_measurement(sim, tmp_path / "meas.uff", rig=rig, binary=True)
    truth = json.loads((tmp_path / "meas.uff.truth.json").read_text())
    out = tmp_path / "m.json"
    assert main(["modes", str(path), "--rig", str(rig_file), "--band", "150", "1000", "--json", str(out)]) == 0
    modes = json.loads(out.read_text())["modes"]
    k = int(np.argmin([abs(m["natural_freq"] - truth["f_H"]) for m in modes]))
    # the housing mode of the 3DOF model (626 Hz), found among the rig's other modes
    np.testing.assert_allclose(modes[k]["natural_freq"], truth["f_H"], rtol=1e-3)
    # effective modal mass at the radial driving point close to the model's ~2.64 kg
    np.testing.assert_allclose(modes[k]["modal_mass"]["11+Y"], 2.64, rtol=0.05)
    assert "m_eff 11+Y" in capsys.readouterr().out


@pytest.mark.parametrize("suffix", [".png", ".svg", ".pdf"])
def test_stabilization_chart_file(uff_file, tmp_path, suffix, mplcleanup):
    import matplotlib.pyplot as plt

    out = tmp_path / f"chart{suffix}"
    assert main(["stabilization", str(uff_file), "--band", "100", "900", "--max-order", "20", "-o", str(out)]) == 0
    head = out.read_bytes()[:8]
    magic = {".png": b"\x89PNG", ".svg": b"<?xml", ".pdf": b"%PDF"}[suffix]
    assert head.startswith(magic)
    assert plt.get_fignums() == []  # the CLI closes its figure
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".chart")] == []  # no temp left


def test_cli_errors(uff_file, tmp_path, capsys):
    assert main(["modes", str(uff_file), "--band", "900", "1500"]) == 1
    err = capsys.readouterr().err
    # the band overlaps the data in part: "extends beyond", with the overlap to use (it read "lies outside")
    assert err.startswith("error: ") and str(uff_file) in err and "extends beyond the data" in err
    assert "outside" not in err
    assert main(["stabilization", str(uff_file), "-o", str(tmp_path / "chart.gif")]) == 1
    assert "-o must end in .png, .svg, .pdf" in capsys.readouterr().err
    assert not (tmp_path / "chart.gif").exists()
    # a cap above what the lines allow is reduced with a note, not refused
    assert main(["modes", str(uff_file), "--max-order", "2000"]) == 0
    assert "max_order reduced from 2000 to 1000" in capsys.readouterr().out
    # issue 8: --max-order 1 is a clear one-line error, not an IndexError: the CLI refuses it
    # as an argument, the library with the reason
    one_ref = tmp_path / "one_ref.uff"
    from ema_rig.errors import IdentificationError
    from ema_rig.identification import identify
    from ema_rig.io.uff import read_uff58, write_uff58

    d = read_uff58(uff_file)
    write_uff58(one_ref, d.sel(inp=d.in_dofs[0]))
    for cmd in (["modes"], ["stabilization", "-o", str(tmp_path / "c.png")]):
        assert main([*cmd[:1], str(one_ref), "--max-order", "1", *cmd[1:]]) == 2
        err = capsys.readouterr().err
        assert "--max-order: must be an integer >= 2" in err and "Traceback" not in err
    with pytest.raises(IdentificationError, match="max_order=1 is below the smallest useful order 2"):
        identify(read_uff58(one_ref), max_order=1)
    bad = tmp_path / "sel.json"
    bad.write_text("{}")
    assert main(["modes", str(uff_file), "--selection", str(bad)]) == 1
    assert "not a valid mode selection" in capsys.readouterr().err


def test_modes_synthesis_plot(uff_file, tmp_path, mplcleanup):
    png = tmp_path / "syn.png"
    assert main(["modes", str(uff_file), "--band", "50", "950", "--plot", str(png)]) == 0
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 20_000
    assert not list(tmp_path.glob(".syn.png*"))  # written atomically, no temporary left behind


def test_modes_refine_shapes_and_uff55(uff_file, tmp_path, system):
    """--refine gives Fisher-information +/- that cover the state-space truth; shapes reach the JSON
    and dataset 55 is read back by pyuff (an independent reader) with the same frequencies."""
    pyuff = pytest.importorskip("pyuff")
    out, u55 = tmp_path / "modes.json", tmp_path / "modes.unv"
    rc = main(["modes", str(uff_file), "--band", "0", "1000", "--refine", "--json", str(out),
               "--uff55", str(u55)])
    assert rc == 0
    doc = json.loads(out.read_text())
    assert doc["refinement"]["converged"] and doc["refinement"]["noise_source"] == "estimated"
    truth = np.sort(system.natural_freq)
    for m in doc["modes"]:
        k = np.argmin(abs(truth - m["natural_freq"]))
        # 1 % complex noise: the refined 2-sigma interval holds the truth (4 sigma as a test margin
        # over six modes), and it is not huge: sigma below 0.1 % of the frequency
        assert abs(m["natural_freq"] - truth[k]) < 4 * m["natural_freq_std"], (m["natural_freq"], truth[k])
        assert m["natural_freq_std"] < 1e-3 * truth[k]
        shape = m["mode_shape"]["shape"]
        assert len(shape) == len(doc["out_dofs"]) and {"dof", "re", "im"} <= set(shape[0])
    sets = [s for s in pyuff.UFF(str(u55)).read_sets() if s["type"] == 55]
    assert len(sets) == len(doc["modes"])
    f55 = sorted(abs(complex(s["eig"])) / (2 * np.pi) for s in sets)
    np.testing.assert_allclose(f55, sorted(m["natural_freq"] for m in doc["modes"]), rtol=1e-5)


@pytest.mark.parametrize("labelled", [True, False])
def test_modes_says_when_the_units_were_assumed(tmp_path, system, capsys, labelled):
    """Review finding (m_review6): for a file without unit labels (dam0.unv) ``modes`` printed
    effective masses in kg (2.9e6..1.9e8) without the 'SI assumed' caveat ``inspect`` gives; the
    caveat is now a note in the text and in the JSON, and only when the units were assumed."""
    from ema_rig.io.uff import write_uff58

    path = tmp_path / "lumped.uff"
    write_uff58(path, system.frf(FREQ, inputs=(0,)), binary=True, labelled=labelled)
    out = tmp_path / "modes.json"
    assert main(["modes", str(path), "--json", str(out)]) == 0
    text = capsys.readouterr().out
    notes = [n for n in json.loads(out.read_text())["notes"] if "SI (m, N) assumed" in n]
    if labelled:
        assert notes == [] and "SI (m, N) assumed" not in text
    else:
        # six outputs x one reference, none labelled: every dataset's units assumed
        assert notes == ["units: 6 of 6 FRF datasets: no unit label and no dataset 164: SI (m, N) assumed; "
                         "effective masses [kg], residues and mode shapes are in SI only if the file is"]
        assert f"note   {notes[0]}" in text


def _identify_must_not_run(monkeypatch):
    """Make any identification fail the test: the refusal must come before the slow part."""
    import ema_rig.identification as ident_pkg

    def refuse(*args, **kwargs):
        raise AssertionError("identify ran although the command's outputs could not be written")
    monkeypatch.setattr(ident_pkg, "identify", refuse)


def test_uff55_of_a_scalar_dof_refused_before_the_identification(corpus_dir, tmp_path, monkeypatch, capsys):
    """readuff_uff58b_frf.frf measures node 192 direction 0 (a scalar channel): dataset 55 cannot hold it.

    The smoke review (benchmarks/results/smoke_b1a9ba2.txt) found the refusal came only after the whole
    identification (and discarded its --json); on ufffiles_frf-sized data that is a minute of waiting.
    """
    _identify_must_not_run(monkeypatch)
    out = tmp_path / "m.json"
    code = main(["modes", str(corpus_dir / "readuff_uff58b_frf.frf"), "--uff55", str(tmp_path / "m.unv"),
                 "--json", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and "--uff55" in err and "'192'" in err and "Traceback" not in err, err
    assert not out.exists() and not (tmp_path / "m.unv").exists()


def test_a_file_without_geometry_refused_before_the_identification(tmp_path, monkeypatch, capsys):
    """--geometry naming a UFF file without node datasets: its error comes first, naming that file."""
    from pathlib import Path

    _identify_must_not_run(monkeypatch)
    measurement = Path(__file__).resolve().parent.parent / "data" / "dummy_200N_r1.uff"
    bad = tmp_path / "not_geometry.uff"
    bad.write_bytes(measurement.read_bytes())
    code = main(["modes", str(measurement), "--geometry", str(bad), "--shapes", str(tmp_path / "s")])
    err = capsys.readouterr().err
    assert code == 1 and err.startswith(f"error: {bad}: no node dataset"), err
    assert list(tmp_path.iterdir()) == [bad]
