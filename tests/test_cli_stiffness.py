"""``ema-rig calibrate`` and ``ema-rig stiffness`` on simulated UFF58 files (exit codes, JSON, plot)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from ema_rig.cli import main
from ema_rig.config import load_rig

simulate = pytest.importorskip("ema_rig.simulate")
identify_mod = pytest.importorskip("ema_rig.identification")
pytest.importorskip("ema_rig.io.uff")
needs_identify = pytest.mark.skipif(not hasattr(identify_mod, "identify"),
                                    reason="ema_rig.identification.identify not available yet")

FREQ = np.arange(0.0, 1100.0 + 0.25, 0.5)  # up to the housing band's top: small files, fast runs


def _write(tmp_path, rig_file, name, k_tb, **kw):
    rig = load_rig(rig_file)
    sim = simulate.simulate_measurement(rig, k_tb=k_tb, freq=FREQ, noise=0.01, seed=7, **kw)
    path = tmp_path / name
    simulate.write_measurement(sim, path, rig=rig)
    return path, sim.truth


@needs_identify
def test_stiffness_command_json_and_plot(tmp_path, rig_file, capsys, mplcleanup):
    path, truth = _write(tmp_path, rig_file, "bearing.uff", 71.57e6)
    out, png = tmp_path / "res.json", tmp_path / "fig7.png"
    code = main(["stiffness", str(path), "--rig", str(rig_file), "--json", str(out), "--plot", str(png)])
    assert code == 0, capsys.readouterr().err
    doc = json.loads(out.read_text())
    # the simulator's radial dynamics are the 3DOF model's: k_TB within 1 %
    np.testing.assert_allclose(doc["k_TB"], truth["k_TB"], rtol=1e-2)
    assert doc["k_MS"] == load_rig(rig_file).model.k_MS  # no --k-ms: the rig file's value
    assert doc["housing_mode"]["natural_freq"] == pytest.approx(truth["f_H"], rel=2e-3)
    assert doc["k_TB_std"] > 0 and doc["candidates"]
    assert png.stat().st_size > 10_000  # a real PNG was written
    text = capsys.readouterr().out
    assert "k_TB" in text and "housing" in text


@needs_identify
def test_calibrate_command(tmp_path, rig_file, capsys):
    path, truth = _write(tmp_path, rig_file, "disk.uff", math.inf)
    out = tmp_path / "cal.json"
    code = main(["calibrate", str(path), "--rig", str(rig_file), "--json", str(out)])
    assert code == 0, capsys.readouterr().err
    doc = json.loads(out.read_text())
    # steel disk = rigid bearing: k_MS recovered within 1 % (k_MS sensitivity to f is ~2x k_TB's smaller)
    np.testing.assert_allclose(doc["k_MS"], truth["k_MS"], rtol=1e-2)
    assert doc["k_MS_std"] > 0
    assert doc["housing_mode"]["natural_freq"] == pytest.approx(897.35, rel=2e-3)


@needs_identify
def test_stiffness_with_calibrated_kms_too_soft_is_clean_error(tmp_path, rig_file, capsys):
    # a k_MS below the measured k_TB+MS (4.4e7) would need a negative bearing stiffness
    path, _ = _write(tmp_path, rig_file, "bearing.uff", 71.57e6)
    out = tmp_path / "res.json"
    code = main(["stiffness", str(path), "--rig", str(rig_file), "--k-ms", "30e6", "--json", str(out),
                 "--no-spindle"])
    err = capsys.readouterr().err
    assert code == 1 and not out.exists()
    assert err.startswith("error: ") and err.count("\n") == 1 and "Traceback" not in err
    assert "k_MS" in err


@needs_identify
def test_no_housing_mode_in_band_exit_1(tmp_path, rig_file, capsys):
    path, _ = _write(tmp_path, rig_file, "bearing.uff", 71.57e6)
    code = main(["stiffness", str(path), "--rig", str(rig_file), "--band", "250", "450", "--no-spindle"])
    err = capsys.readouterr().err
    assert code == 1
    assert "no identified mode matches the radial housing mode" in err and err.count("\n") == 1


def test_missing_file_and_usage(tmp_path, rig_file, capsys):
    assert main(["stiffness", str(tmp_path / "nope.uff"), "--rig", str(rig_file)]) == 1
    err = capsys.readouterr().err
    assert err.startswith("error: ") and "nope.uff" in err
    assert main(["calibrate", str(tmp_path / "nope.uff"), "--rig", str(tmp_path / "norig.toml")]) == 1
    assert "norig.toml" in capsys.readouterr().err
    assert main(["stiffness", "x.uff"]) == 2  # --rig is required: argparse usage error
    capsys.readouterr()
    assert main(["stiffness", "x.uff", "--rig", str(rig_file), "--max-order", "1"]) == 2  # argparse refuses it
    assert "--max-order" in capsys.readouterr().err
