"""Command-line numbers and error lines (issue 8, items 5 and 7).

Every number on the command line is checked by argparse before any file is read or written
(finite, in its physical range; exit 2 naming the option), and every error line of a command
names the file it concerns: the one the error carries, else the command's input, never the
temporary file an output is written through.
"""

from __future__ import annotations

import errno
from pathlib import Path

import pytest

from ema_rig.cli import EXIT_ERROR, EXIT_USAGE, build_parser, main
from ema_rig.errors import EmaRigError

REPO = Path(__file__).resolve().parent.parent
DISK = REPO / "data" / "disk.uff"  # bundled steel-disk measurement (8 x 2 FRFs)


def _one_error_line(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err, err
    lines = [ln for ln in err.splitlines() if ln.startswith("error:") or ": error: " in ln]
    assert len(lines) == 1, err
    return lines[0]


# (command line after the file arguments, option named in the refusal)
_REFUSED = [
    # simulate: NaN speed used to simulate a non-rotating shaft, -1 seed blamed the rig file
    ("simulate --speed nan", "--speed"),
    ("simulate --speed inf", "--speed"),
    ("simulate --speed -1", "--speed"),
    ("simulate --speed 1e6", "--speed"),  # accepted on 4ff7088: no rolling-element bearing runs at 1e6 rpm
    ("simulate --seed -1", "--seed"),
    ("simulate --seed 1.5", "--seed"),
    ("simulate --noise nan", "--noise"),
    ("simulate --noise -0.1", "--noise"),
    ("simulate --noise 11", "--noise"),
    ("simulate --fmax inf", "--fmax"),
    ("simulate --fmax 0", "--fmax"),
    ("simulate --df 0", "--df"),
    ("simulate --df -0.5", "--df"),
    ("simulate --df nan", "--df"),
    ("simulate --k-tb nan", "--k-tb"),
    ("simulate --k-tb 0", "--k-tb"),
    ("simulate --k-tb -1", "--k-tb"),
    # stiffness: an infinite speed was accepted
    ("stiffness --speed inf", "--speed"),
    ("stiffness --speed nan", "--speed"),
    ("stiffness --speed -600", "--speed"),
    ("stiffness --speed 1e6", "--speed"),  # accepted silently on 4ff7088 (harmonics at 16.7 kHz: no effect)
    ("stiffness --k-ms nan", "--k-ms"),
    ("stiffness --k-ms inf", "--k-ms"),
    ("stiffness --k-ms 0", "--k-ms"),
    # accepted on 4ff7088: k_TB inverted with a k_MS 1000x off (71.6 -> 44.0 MN/m on the bundled 1200 rpm file)
    ("stiffness --k-ms 114e9", "--k-ms"),
    ("stiffness --k-ms 114", "--k-ms"),
    ("stiffness --k-ms-std -1", "--k-ms-std"),
    ("stiffness --k-ms-std inf", "--k-ms-std"),
    ("stiffness --band 1000 100", "--band"),
    ("stiffness --band 100 100", "--band"),
    ("stiffness --band nan 100", "--band"),
    ("stiffness --band -1 100", "--band"),
    ("stiffness --band 100 1e999", "--band"),
    ("stiffness --max-order 1", "--max-order"),
    ("stiffness --max-order 2.5", "--max-order"),
    ("calibrate --k-disk inf", "--k-disk"),
    ("calibrate --k-disk nan", "--k-disk"),
    ("calibrate --k-disk -1", "--k-disk"),
    ("calibrate --band 500 150", "--band"),
    ("calibrate --max-order 0", "--max-order"),
    # modes / stabilization: --max-order 1 was an IndexError traceback deep in plscf
    ("modes --max-order 1", "--max-order"),
    ("modes --max-order 1e3", "--max-order"),
    ("modes --band 5 5", "--band"),
    ("stabilization --max-order 1", "--max-order"),
    ("stabilization --band inf 100", "--band"),
    ("campaign --jobs 0", "--jobs"),
    ("demo --jobs -1", "--jobs"),
]

_FILES = {
    "simulate": ["--rig", "{rig}", "--k-tb", "7e7", "-o", "{out}"],
    "stiffness": ["{disk}", "--rig", "{rig}"],
    "calibrate": ["{disk}", "--rig", "{rig}"],
    "modes": ["{disk}"],
    "stabilization": ["{disk}", "-o", "{out}.png"],
    "campaign": ["{tmp}/campaign.toml", "-o", "{tmp}/out"],
    "demo": ["-o", "{tmp}/out"],
}


def _argv(cmd_line: str, tmp_path: Path, rig_file: Path) -> list[str]:
    cmd, *opts = cmd_line.split()
    names = {"rig": str(rig_file), "out": str(tmp_path / "out.uff"), "disk": str(DISK), "tmp": str(tmp_path)}
    # options last: "--k-tb -1" must override the default "--k-tb 7e7"
    return [cmd, *(a.format(**names) for a in _FILES[cmd]), *opts]


@pytest.mark.parametrize("cmd_line, option", _REFUSED)
def test_bad_numbers_refused_before_any_work(cmd_line, option, tmp_path, rig_file, capsys):
    before = set(tmp_path.iterdir())
    assert main(_argv(cmd_line, tmp_path, rig_file)) == EXIT_USAGE
    line = _one_error_line(capsys)
    assert f"argument {option}" in line, line
    assert str(rig_file) not in line  # the seed, speed ... are not the rig file's fault
    assert set(tmp_path.iterdir()) == before  # nothing written


def test_edge_values_accepted(tmp_path, rig_file):
    p = build_parser()
    sim = p.parse_args(_argv("simulate --k-tb inf --speed 0 --seed 0 --noise 0 --df 1e-3 --fmax 1", tmp_path, rig_file))
    # inf is the documented steel disk; 0 rpm is a shaft at rest
    assert sim.k_tb == float("inf") and sim.speed == 0.0 and sim.seed == 0 and sim.noise == 0.0
    assert (sim.df, sim.fmax) == (1e-3, 1.0)
    st = p.parse_args(_argv("stiffness --band 0 1000 --max-order 2 --speed 1200 --k-ms-std 0", tmp_path, rig_file))
    assert st.band == (0.0, 1000.0) and st.max_order == 2 and st.speed == 1200.0 and st.k_ms_std == 0.0
    assert p.parse_args(_argv("modes --max-order 2000", tmp_path, rig_file)).max_order == 2000  # data decides
    assert p.parse_args(_argv("campaign -j 2", tmp_path, rig_file)).jobs == 2


@pytest.mark.parametrize("fmax, df", [("2000", "1e-12"), ("1e300", "1e-300"), ("1e300", "0.5"), ("0.5", "0.5")])
def test_simulate_line_count_checked(fmax, df, tmp_path, rig_file, capsys):
    # --df 1e-12 was a 14 PiB allocation and a MemoryError traceback; 0.5/0.5 is two lines
    out = tmp_path / "m.uff"
    argv = ["simulate", "--rig", str(rig_file), "--k-tb", "7e7", "-o", str(out), "--fmax", fmax, "--df", df]
    assert main(argv) == EXIT_ERROR
    line = _one_error_line(capsys)
    assert line.startswith(f"error: {out}: ") and "frequency lines" in line, line
    assert list(tmp_path.iterdir()) == [rig_file]


def test_simulate_smallest_grid_written(tmp_path, rig_file):
    import json

    out = tmp_path / "m.uff"
    argv = ["simulate", "--rig", str(rig_file), "--k-tb", "7e7", "-o", str(out), "--fmax", "1", "--df", "0.5",
            "--seed", "4", "--noise", "0"]
    assert main(argv) == 0
    truth = json.loads((tmp_path / "m.uff.truth.json").read_text())
    assert truth["seed"] == 4 and truth["speed_hz"] is None


# ------------------------------------------------------------------ every error line names a file
@pytest.mark.parametrize("cmd", ["inspect", "modes", "stabilization", "stiffness", "calibrate", "campaign",
                                 "simulate", "demo"])
@pytest.mark.parametrize("exc", [EmaRigError("no stable pole"), ValueError("no stable pole"),
                                 OSError(errno.EIO, "no stable pole"), MemoryError("no stable pole")])
def test_error_without_a_file_names_the_commands_file(cmd, exc, tmp_path, rig_file, capsys, monkeypatch):
    import importlib

    argv = ["inspect", str(DISK)] if cmd == "inspect" else _argv(cmd, tmp_path, rig_file)
    subject = {"inspect": str(DISK), "modes": str(DISK), "stabilization": str(DISK), "stiffness": str(DISK),
               "calibrate": str(DISK), "campaign": f"{tmp_path}/campaign.toml",
               "simulate": str(tmp_path / "out.uff"), "demo": f"{tmp_path}/out"}[cmd]

    def fail(args):
        raise exc

    monkeypatch.setattr(importlib.import_module(f"ema_rig.commands.{cmd}"), "run", fail)
    assert main(argv) == EXIT_ERROR
    line = _one_error_line(capsys)
    assert line.startswith(f"error: {subject}: "), line
    assert "no stable pole" in line


def test_error_with_its_own_file_keeps_it(tmp_path, rig_file, capsys):
    # a rig file that does not exist: the rig is named, not the measurement
    assert main(["stiffness", str(DISK), "--rig", str(tmp_path / "nope.toml")]) == EXIT_ERROR
    assert _one_error_line(capsys).startswith(f"error: {tmp_path / 'nope.toml'}: ")


@pytest.mark.parametrize("named", [True, False])
def test_disk_full_names_the_output_not_the_temporary_file(named, tmp_path, capsys, monkeypatch):
    # ENOSPC from open() carries the temporary file's name, from write() no name at all
    def full(self, *a, **k):
        raise OSError(errno.ENOSPC, "No space left on device", str(self) if named else None)

    monkeypatch.setattr(Path, "write_text", full)
    out = tmp_path / "inspect.json"
    assert main(["inspect", str(DISK), "--json", str(out)]) == EXIT_ERROR
    assert _one_error_line(capsys) == f"error: {out}: No space left on device"
    assert list(tmp_path.iterdir()) == []  # no output, no leftover temporary file


def test_output_below_a_regular_file(tmp_path, capsys):
    (tmp_path / "afile").write_text("x")
    out = tmp_path / "afile" / "inspect.json"
    assert main(["inspect", str(DISK), "--json", str(out)]) == EXIT_ERROR
    line = _one_error_line(capsys)
    assert line == f"error: {out}: cannot create the folder {tmp_path / 'afile'} (a file is in the way)"


def test_simulate_write_failure_names_the_output(tmp_path, rig_file, capsys):
    (tmp_path / "afile").write_text("x")
    out = tmp_path / "afile" / "m.uff"
    argv = ["simulate", "--rig", str(rig_file), "--k-tb", "7e7", "-o", str(out), "--fmax", "10", "--df", "1"]
    assert main(argv) == EXIT_ERROR
    assert _one_error_line(capsys).startswith(f"error: {out}: ")


def test_simulate_leaves_no_measurement_without_its_truth(tmp_path, rig_file, capsys, monkeypatch):
    import ema_rig._atomic

    def full(path, obj):
        raise OSError(errno.ENOSPC, "No space left on device", str(path))

    monkeypatch.setattr(ema_rig._atomic, "write_json", full)
    out = tmp_path / "m.uff"
    argv = ["simulate", "--rig", str(rig_file), "--k-tb", "7e7", "-o", str(out), "--fmax", "10", "--df", "1"]
    assert main(argv) == EXIT_ERROR
    # the UFF staged before the truth failed is discarded, and the one error line says so
    assert _one_error_line(capsys) == f"error: {out}.truth.json: No space left on device; nothing written ({out} discarded)"
    assert list(tmp_path.iterdir()) == [rig_file]  # the UFF written first was removed again


def test_averages_reach_the_default_estimate(monkeypatch: pytest.MonkeyPatch) -> None:
    """``--averages`` and the rig file's ``n_averages`` set ``FRFData.n_averages``, the one place the
    default ML estimate reads it (issue 21: it used to be a ``meta`` entry only ``--refine`` read)."""
    import ema_rig.identification as ident_pkg
    from ema_rig.errors import IdentificationError

    seen: list[object] = []

    def spy(data, **kw):  # type: ignore[no-untyped-def]
        seen.append(data.n_averages)
        raise IdentificationError("stop here")

    monkeypatch.setattr(ident_pkg, "identify", spy)
    uff = str(Path(__file__).resolve().parents[1] / "data" / "b6302_1000N_1200rpm.uff")
    assert main(["modes", uff, "--averages", "12.5"]) == EXIT_ERROR
    assert main(["modes", uff, "--averages", "0.5"]) == EXIT_USAGE  # below one average: a usage error
    assert seen == [12.5]


def test_speed_range_is_the_campaign_keys_with_its_source(capsys):
    """``--speed`` and a campaign's ``speed`` share one range (ema_rig.config), and the refusal names its source."""
    from ema_rig.config import CONDITION_RANGES

    p = build_parser()
    hi = CONDITION_RANGES["speed"].hi
    assert p.parse_args(["stiffness", "f.uff", "--rig", "r.toml", "--speed", f"{hi:g}"]).speed == hi
    with pytest.raises(SystemExit):
        p.parse_args(["stiffness", "f.uff", "--rig", "r.toml", "--speed", f"{hi * 1.01:g}"])
    assert "dental air turbines" in capsys.readouterr().err


def test_speed_above_every_band_warns_that_it_changes_nothing(capsys):
    """--speed only rejects shaft-harmonic lines: a shaft frequency above the bands identified changes nothing."""
    from types import SimpleNamespace

    from ema_rig.commands.stiffness import _warn_idle_speed

    res = SimpleNamespace(file="m.uff", band=(150.0, 1000.0), spindle_band=(1500.0, 2200.0))
    _warn_idle_speed(1e5, res)  # 1666.7 Hz: inside the spindle band, harmonics there are rejected
    _warn_idle_speed(1200.0, res)
    _warn_idle_speed(0.0, res)
    assert capsys.readouterr().err == ""
    _warn_idle_speed(2e5, res)  # 3333 Hz, above 2200 Hz
    err = capsys.readouterr().err
    assert err.startswith("warning: m.uff: --speed 200000 rpm: the shaft frequency 3333.33 Hz") and "2200 Hz" in err


def test_python_dash_m_runs_the_command_line(tmp_path):
    """``python -m ema_rig`` is the installed ``ema-rig`` (4ff7088: "No module named ema_rig.__main__")."""
    import subprocess
    import sys

    env = {**__import__("os").environ, "PYTHONPATH": str(REPO)}
    done = subprocess.run([sys.executable, "-m", "ema_rig", "inspect", str(tmp_path / "none.uff")],
                          capture_output=True, text=True, env=env, cwd=tmp_path, timeout=120)
    assert done.returncode == EXIT_ERROR and done.stderr.strip() == f"error: {tmp_path / 'none.uff'}: file not found"


def test_k_ms_option_has_the_rig_files_range_and_hint(capsys):
    """--k-ms is checked like the rig file's [model] k_MS (one definition: ema_rig.config.implausible)."""
    p = build_parser()
    assert p.parse_args(["stiffness", "f.uff", "--rig", "r.toml", "--k-ms", "1.14e8"]).k_ms == 1.14e8
    with pytest.raises(SystemExit):
        p.parse_args(["stiffness", "f.uff", "--rig", "r.toml", "--k-ms", "114e9"])
    assert "did you mean 1.14e+08 N/m?" in capsys.readouterr().err


def test_explicit_band_narrowed_to_the_data_is_said(capsys):
    """stiffness / calibrate clip --band to the data (modes refuses it): 4ff7088 did it without a word
    (calibrate --band 700 5000 on the bundled 0-2000 Hz disk file identified in 700..2000 Hz, exit 0, silent)."""
    from ema_rig.commands._args import note_clipped_band

    note_clipped_band((700.0, 1100.0), [700.0, 1100.0], "d.uff")  # as asked: nothing to say
    note_clipped_band(None, [150.0, 1000.0], "d.uff")  # no --band: the rig file's or default band
    assert capsys.readouterr().err == ""
    note_clipped_band((700.0, 5000.0), [700.0, 2000.0], "d.uff")
    assert capsys.readouterr().err == "note: d.uff: --band 700 5000 extends beyond the data: identified in 700..2000 Hz\n"
