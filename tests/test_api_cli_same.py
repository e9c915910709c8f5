"""One API, one CLI (issue 20): the same warnings from both, coherence at the peak included."""

from __future__ import annotations

import json

import numpy as np

from ema_rig.cli import main
from ema_rig.config import load_rig
from ema_rig.dof import DOF
from ema_rig.identification import identify
from ema_rig.io._uff58_coherence import coherence_bytes
from ema_rig.io.uff import read_uff58
from ema_rig.rig.stiffness import estimate_stiffness
from ema_rig.simulate import simulate_measurement, write_measurement

FREQ = np.arange(0.0, 1100.0 + 0.25, 0.5)


def _file_with_poor_coherence(tmp_path, rig_file):
    """A simulated measurement whose driving-point coherence drops to 0.3 around the housing peak."""
    rig = load_rig(rig_file)
    sim = simulate_measurement(rig, k_tb=71.57e6, freq=FREQ, noise=0.01, seed=7)
    path = tmp_path / "m.uff"
    write_measurement(sim, path, rig=rig)
    good = np.full(FREQ.size, 0.98)
    poor = np.where(np.abs(FREQ - sim.truth["f_H"]) < 15.0, 0.3, 0.98)  # below diagnose's 0.5 at the peak
    with open(path, "ab") as fh:  # one coherence per FRF (as analysers export them): the reader attaches them
        for o in sim.data.out_dofs:
            for i in sim.data.in_dofs:
                c = poor if (str(o), str(i)) == ("11+Y", "11+Y") else good
                fh.write(coherence_bytes(FREQ, c, response=DOF.parse(str(o)), reference=DOF.parse(str(i)),
                                         ids=(f"{o} / {i} coherence", "test", "", "", "NONE")))
    return path


def test_coherence_warning_from_the_api_and_the_cli(tmp_path, rig_file, capsys):
    path = _file_with_poor_coherence(tmp_path, rig_file)
    rig = load_rig(rig_file)
    data = read_uff58(path, rig=rig).with_meta(file=str(path))
    assert data.coherence is not None  # the reader attached it
    ident = identify(data, band=(150.0, 1000.0))
    coh_warn = [w for w in ident.warnings if "coherence 11+Y/11+Y at the largest peak" in w]
    assert len(coh_warn) == 1 and "only 0.30" in coh_warn[0]
    out = tmp_path / "modes.json"
    assert main(["modes", str(path), "--rig", str(rig_file), "--band", "150", "1000", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["warnings"] == list(ident.warnings)  # the same list, each once
    res = estimate_stiffness(data, rig, spindle=False)
    out = tmp_path / "k.json"
    assert main(["stiffness", str(path), "--rig", str(rig_file), "--no-spindle", "--json", str(out)]) == 0
    assert json.loads(out.read_text())["warnings"] == list(res.warnings)
    assert any("coherence 11+Y/11+Y at the largest peak" in w for w in res.warnings)
    capsys.readouterr()
