"""Files are sacred (issue 17): the folder lock, outputs onto inputs, ``demo``'s folder, signals.

Every reproducer is made in ``tmp_path``. The output-onto-input checks run before any file is
read, so most inputs here need not be valid UFF or TOML: what matters is that they are left
byte for byte as they were and that the error line names the output.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from test_campaign_faults import small  # noqa: F401 - the fixture

from ema_rig import _atomic
from ema_rig.cli import EXIT_ERROR, main
from ema_rig.errors import EmaRigError

REPO = Path(__file__).resolve().parents[1]
VICTIM = b"a user's file that must never be truncated\n"


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err.rstrip("\n")


# ------------------------------------------------------------------------------- the folder lock
def test_lock_removed_after_the_run_and_reusable(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with _atomic.folder_lock(out) as lock:
        assert lock.is_file() and lock.read_text().strip() == str(os.getpid())
        with pytest.raises(_atomic.FolderBusyError, match="in use"):  # still exclusive
            with _atomic.folder_lock(out):
                pass
    assert list(out.iterdir()) == []  # nothing left behind
    with _atomic.folder_lock(out):
        pass
    assert list(out.iterdir()) == []


@pytest.mark.parametrize("kind", ["symlink", "dangling", "fifo", "hardlink"])
def test_planted_lock_refused_and_its_target_untouched(kind: str, tmp_path: Path) -> None:
    out = tmp_path / "out"
    out.mkdir()
    lock = out / ".ema-rig.lock"
    victim = tmp_path / "victim.txt"
    if kind == "dangling":
        lock.symlink_to(victim)  # would have created victim.txt outside the folder
    elif kind == "fifo":
        os.mkfifo(lock)  # was "Invalid argument" (or a hang)
    else:
        victim.write_bytes(VICTIM)
        (lock.symlink_to if kind == "symlink" else lock.hardlink_to)(victim)
    with pytest.raises(EmaRigError) as info:
        with _atomic.folder_lock(out):
            pytest.fail("the lock must not be taken")
    msg = str(info.value)
    assert msg.startswith(f"{lock}: ") and {"symlink": "symbolic link", "dangling": "missing",
                                            "fifo": "FIFO", "hardlink": "hard link"}[kind] in msg, msg
    if kind == "dangling":
        assert not victim.exists()
    elif kind != "fifo":
        assert victim.read_bytes() == VICTIM


def test_planted_lock_through_the_cli(tmp_path: Path, rig_toml_text: str, capsys) -> None:
    (tmp_path / "rig.toml").write_text(rig_toml_text)
    campaign = tmp_path / "c.toml"
    campaign.write_text('rig = "rig.toml"\n[[measurement]]\nfile = "m1.uff"\n')
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "victim.txt"
    victim.write_bytes(VICTIM)
    (out / ".ema-rig.lock").symlink_to(victim)
    assert main(["campaign", str(campaign), "-o", str(out)]) == EXIT_ERROR
    line = _one_error_line(capsys)
    assert line.startswith(f"error: {out / '.ema-rig.lock'}: is a symbolic link"), line
    assert victim.read_bytes() == VICTIM and sorted(p.name for p in out.iterdir()) == [".ema-rig.lock"]


def test_dangling_output_folder_link_named(tmp_path: Path, capsys) -> None:
    link = tmp_path / "out"
    link.symlink_to(tmp_path / "gone")
    target = link / "x.json"
    with pytest.raises(OSError) as info:
        _atomic.write_text(target, "{}")
    assert "symbolic link to the missing" in str(info.value) and "File exists" not in str(info.value)
    assert not (tmp_path / "gone").exists()


# --------------------------------------------------------------------------- outputs onto inputs
def _cases(tmp: Path) -> list[tuple[list[str], Path]]:
    f, r, t = tmp / "m.uff", tmp / "rig.toml", tmp / "t.uff"
    return [
        (["modes", str(f), "--uff55", str(f)], f),
        (["modes", str(f), "--json", str(f)], f),
        (["modes", str(f), "--plot", str(f)], f),
        (["modes", str(f), "--automac", str(f)], f),
        (["modes", str(f), "--rig", str(r), "--json", str(r)], r),
        (["modes", str(f), "--selection", str(r), "--save-selection", str(r)], r),
        (["stiffness", str(f), "--rig", str(r), "--json", str(f)], f),
        (["stiffness", str(f), "--rig", str(r), "--plot", str(r)], r),
        (["calibrate", str(f), "--rig", str(r), "--json", str(f)], f),
        (["stabilization", str(f), "-o", str(f)], f),
        (["inspect", str(f), "--json", str(f)], f),
        (["simulate", "--rig", str(r), "--k-tb", "7e7", "-o", str(r)], r),
        (["frf", str(t), "-o", str(t)], t),
    ]


@pytest.mark.parametrize("i", range(13))
def test_output_onto_an_input_refused(i: int, tmp_path: Path, capsys) -> None:
    argv, victim = _cases(tmp_path)[i]
    for p in (tmp_path / "m.uff", tmp_path / "rig.toml", tmp_path / "t.uff"):
        p.write_bytes(VICTIM)
    assert main(argv) == EXIT_ERROR
    line = _one_error_line(capsys)
    assert line.startswith(f"error: {victim}: ") and "would overwrite the input" in line, line
    assert victim.read_bytes() == VICTIM
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.uff", "rig.toml", "t.uff"]


@pytest.mark.parametrize("how", ["hardlink", "symlink", "dotted"])
def test_output_onto_an_input_under_another_name(how: str, tmp_path: Path, capsys) -> None:
    f = tmp_path / "m.uff"
    f.write_bytes(VICTIM)
    other = tmp_path / "sub" / ".." / "m.uff" if how == "dotted" else tmp_path / "alias.uff"
    if how == "hardlink":
        other.hardlink_to(f)
    elif how == "symlink":
        other.symlink_to(f)
    assert main(["modes", str(f), "--uff55", str(other)]) == EXIT_ERROR
    assert "would overwrite the input FILE" in _one_error_line(capsys)
    assert f.read_bytes() == VICTIM


def test_two_outputs_onto_one_file_refused(tmp_path: Path, capsys) -> None:
    f = tmp_path / "m.uff"
    f.write_bytes(VICTIM)
    assert main(["modes", str(f), "--json", str(tmp_path / "o"), "--plot", str(tmp_path / "o")]) == EXIT_ERROR
    assert "same output file" in _one_error_line(capsys)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.uff"]


def test_campaign_output_folder_holding_inputs_refused(tmp_path: Path, rig_toml_text: str, capsys) -> None:
    (tmp_path / "rig.toml").write_text(rig_toml_text)
    out = tmp_path / "out"
    (out / "results").mkdir(parents=True)
    m1 = out / "results" / "m1.json"  # its result would be written over it
    m1.write_bytes(VICTIM)
    fig = out / "k_vs_load_6302.png"  # a campaign figure name: replaced or removed as stale
    fig.write_bytes(VICTIM)
    for name, meas in (("a.toml", m1), ("b.toml", fig)):
        (tmp_path / name).write_text(f'rig = "rig.toml"\n[[measurement]]\nfile = "{meas}"\nid = "m1"\n')
        assert main(["campaign", str(tmp_path / name), "-o", str(out)]) == EXIT_ERROR
        line = _one_error_line(capsys)
        assert "input" in line and str(meas) in line and "Traceback" not in line, line
        assert meas.read_bytes() == VICTIM
    assert not (out / ".ema-rig.lock").exists() and not (out / "campaign.csv").exists()


# ------------------------------------------------------------------------------------------ demo
def test_demo_refuses_a_users_folder(tmp_path: Path, capsys) -> None:
    out = tmp_path / "mine"
    (out / "data").mkdir(parents=True)
    own = out / "data" / "campaign.toml"
    own.write_bytes(VICTIM)
    assert main(["demo", "-o", str(out)]) == EXIT_ERROR
    line = _one_error_line(capsys)
    assert line.startswith(f"error: {out}: ") and "not made by 'ema-rig demo'" in line, line
    assert own.read_bytes() == VICTIM and sorted(p.name for p in out.rglob("*")) == ["campaign.toml", "data"]


def test_demo_claims_only_new_empty_or_its_own_folders(tmp_path: Path) -> None:
    from ema_rig.commands.demo import MARKER, claim_folder

    new = claim_folder(tmp_path / "new")
    assert (new / MARKER).is_file()
    (new / "data").mkdir()
    claim_folder(new)  # its own: accepted again
    empty = tmp_path / "empty"
    empty.mkdir()
    assert (claim_folder(empty) / MARKER).is_file()
    planted = tmp_path / "planted"
    planted.mkdir()
    (planted / MARKER).mkdir()  # a marker must be a regular file
    with pytest.raises(EmaRigError, match="not made by"):
        claim_folder(planted)


# --------------------------------------------------------------------------------------- signals
_WRITER = textwrap.dedent("""
    import os, sys, time
    from ema_rig import _atomic
    from ema_rig.cli import main

    real = os.replace

    def stalled(src, dst):  # the output is complete in its temporary file: stop before the rename
        print("writing", flush=True)
        time.sleep(60)

    os.replace = stalled
    sys.exit(main(sys.argv[1:]))
""")


@pytest.mark.skipif(os.name != "posix", reason="POSIX signals")
@pytest.mark.parametrize("sig, code", [(signal.SIGTERM, -signal.SIGTERM), (signal.SIGINT, 130)])
def test_signal_mid_write_leaves_no_temporary(sig: int, code: int, tmp_path: Path, rig_toml_text: str) -> None:
    (tmp_path / "rig.toml").write_text(rig_toml_text)
    out = tmp_path / "o" / "m.uff"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), *sys.path])}
    proc = subprocess.Popen([sys.executable, "-c", _WRITER, "simulate", "--rig", str(tmp_path / "rig.toml"),
                             "--k-tb", "7e7", "-o", str(out), "--fmax", "50", "--df", "1"],
                            env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert proc.stdout is not None
        lines = [proc.stdout.readline().strip() for _ in range(2)]  # the summary, then the stalled rename
        assert lines[-1] == "writing", lines
        temps = list(out.parent.iterdir())
        # mid-write: both outputs (measurement and truth) complete in their temporaries, renamed together
        assert len(temps) == 2 and all(".tmp" in t.name for t in temps), temps
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == code, err
    assert "Traceback" not in err
    assert list(out.parent.iterdir()) == []


def test_forked_child_never_removes_the_parents_temporaries(tmp_path: Path) -> None:
    with _atomic.atomic_path(tmp_path / "x.png") as tmp:
        tmp.write_bytes(b"partial")
        pid = os.fork() if hasattr(os, "fork") else None
        if pid == 0:  # pragma: no cover - the child
            _atomic.remove_active_files()
            os._exit(0)
        if pid is None:
            pytest.skip("no fork")
        os.waitpid(pid, 0)
        assert tmp.exists()
    assert (tmp_path / "x.png").read_bytes() == b"partial"
    time.sleep(0)


@pytest.mark.parametrize("sub", ["results", "measurements"])
def test_planted_subfolder_link_refused(sub: str, tmp_path: Path, rig_toml_text: str, capsys) -> None:
    (tmp_path / "rig.toml").write_text(rig_toml_text)
    campaign = tmp_path / "c.toml"
    campaign.write_text('rig = "rig.toml"\n[[measurement]]\nfile = "m1.uff"\n')
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    out = tmp_path / "out"
    out.mkdir()
    (out / sub).symlink_to(elsewhere)
    assert main(["campaign", str(campaign), "-o", str(out)]) == EXIT_ERROR
    assert _one_error_line(capsys).startswith(f"error: {out / sub}: is a symbolic link")
    assert list(elsewhere.iterdir()) == [] and not (out / ".ema-rig.lock").exists()


def test_shapes_onto_an_input_refused(small: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    # PREFIX_<n>.png is known once the modes are: checked after the identification, before any write
    f = tmp_path / "s_1.png"  # a measurement whose name is the first shape's
    f.write_bytes((small / "m1.uff").read_bytes())
    before = f.read_bytes()
    assert main(["modes", str(f), "--max-order", "16", "--shapes", str(tmp_path / "s"),
                 "--json", str(tmp_path / "modes.json")]) == EXIT_ERROR
    line = capsys.readouterr().err.strip().splitlines()[-1]
    assert line.startswith(f"error: {f}: --shapes would overwrite the input FILE"), line
    assert f.read_bytes() == before and sorted(p.name for p in tmp_path.iterdir()) == ["s_1.png"]


@pytest.mark.skipif(not hasattr(signal, "SIGHUP"), reason="POSIX signals")
def test_ignored_signals_stay_ignored() -> None:
    old = signal.signal(signal.SIGHUP, signal.SIG_IGN)  # as under nohup
    try:
        with _atomic.removing_temporaries_on_signal():
            assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
            assert signal.getsignal(signal.SIGTERM) is _atomic._on_signal
        assert signal.getsignal(signal.SIGHUP) is signal.SIG_IGN
    finally:
        signal.signal(signal.SIGHUP, old)


# --------------------------------------------------------------- nothing left behind (issue 20)
#: The hidden files an output folder keeps on purpose: what the campaign's figures were drawn from
#: (a rerun reuses them) and the mark of a folder ``demo`` made itself. Nothing else: no lock file,
#: no temporary.
_KEPT = {".ema-rig-figures.json", ".ema-rig-demo"}


def _left_behind(folder: Path) -> list[str]:
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*")
                  if (p.name.startswith(".") and p.name not in _KEPT) or ".tmp" in p.name)


def test_nothing_left_behind_by_any_command_on_any_exit(small: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    import shutil

    d = tmp_path / "c"
    shutil.copytree(small, d)
    out = tmp_path / "out"
    assert main(["campaign", str(d / "campaign.toml"), "-o", str(out / "ok")]) == 0
    assert (out / "ok" / "campaign.csv").is_file() and _left_behind(out / "ok") == []
    (d / "m2.uff").write_text("not a UFF file\n")  # one measurement fails: exit 3
    assert main(["campaign", str(d / "campaign.toml"), "-o", str(out / "ok")]) == 3
    assert _left_behind(out / "ok") == []
    (out / "u").mkdir()
    (out / "u" / "notes.txt").write_text("a user's folder\n")  # demo refuses it: exit 1
    assert main(["demo", "-o", str(out / "u")]) == 1
    assert sorted(p.name for p in (out / "u").iterdir()) == ["notes.txt"]
    # (a demo that runs: tests/test_cli_demo.py, with the same check)
    m1, rig = d / "m1.uff", d / "rig.toml"
    assert main(["modes", str(m1), "--rig", str(rig), "--json", str(out / "m" / "m.json"),
                 "--plot", str(out / "m" / "m.png")]) == 0
    assert main(["stiffness", str(m1), "--rig", str(rig), "--json", str(out / "s" / "s.json")]) == 0
    assert main(["stiffness", str(rig), "--rig", str(rig), "--json", str(out / "e" / "s.json")]) == 1
    assert sorted(p.name for p in (out / "m").iterdir()) == ["m.json", "m.png"]
    assert sorted(p.name for p in (out / "s").iterdir()) == ["s.json"]
    assert not (out / "e").exists() or list((out / "e").iterdir()) == []
    capsys.readouterr()


# ------------------------------------------------------- outputs checked before the run (review defect 5)
def _bad_outputs(tmp: Path) -> list[tuple[list[str], Path, str]]:
    """(argv, the output named in the error, what the error says) for outputs that cannot be written."""
    f, r, t, afile = tmp / "m.uff", tmp / "rig.toml", tmp / "t.uff", tmp / "afile"
    folder_in_way = f"cannot create the folder {afile} (a file is in the way)"
    return [
        (["modes", str(f), "--json", str(tmp / "j1.json"), "--plot", str(afile / "p.png")], afile / "p.png",
         folder_in_way),
        (["modes", str(f), "--plot", str(tmp / "noext")], tmp / "noext", "--plot must end in .png, .svg, .pdf"),
        (["modes", str(f), "--json", str(tmp / "dir")], tmp / "dir", "--json names a folder; give a file name"),
        (["modes", str(f), "--json", str(tmp / "j1.json"), "--shapes", str(afile / "s")], afile / "s_1.png",
         folder_in_way),
        (["modes", str(f), "--automac", str(tmp / "a.gif")], tmp / "a.gif", "--automac must end in .png"),
        (["modes", str(f), "--uff55", str(afile / "m.unv")], afile / "m.unv", folder_in_way),
        (["stabilization", str(f), "-o", str(tmp / "chart.gif")], tmp / "chart.gif", "-o must end in .png"),
        (["stiffness", str(f), "--rig", str(r), "--plot", str(tmp / "noext")], tmp / "noext",
         "--plot must end in .png"),
        (["stiffness", str(f), "--rig", str(r), "--json", str(tmp / "dir")], tmp / "dir", "--json names a folder"),
        (["calibrate", str(f), "--rig", str(r), "--plot", str(afile / "p.png")], afile / "p.png", folder_in_way),
        (["inspect", str(f), "--json", str(tmp / "dir")], tmp / "dir", "--json names a folder"),
        (["frf", str(t), "-o", str(afile / "f.uff")], afile / "f.uff", folder_in_way),
        (["simulate", "--rig", str(r), "--k-tb", "7e7", "-o", str(afile / "s.uff")], afile / "s.uff",
         folder_in_way),
    ]


@pytest.mark.parametrize("i", range(13))
def test_unwritable_output_refused_before_the_input_is_read(i: int, tmp_path: Path, capsys) -> None:
    """An output under a file, a folder given as a file, a figure without a figure suffix: refused before
    the run, naming the output (the inputs are not even UFF/TOML: reading them would fail with another
    error). Before, modes ran the whole identification, wrote --json, then failed on --plot."""
    argv, named, text = _bad_outputs(tmp_path)[i]
    for p in (tmp_path / "m.uff", tmp_path / "rig.toml", tmp_path / "t.uff", tmp_path / "afile"):
        p.write_bytes(VICTIM)
    (tmp_path / "dir").mkdir()
    before = sorted(p.name for p in tmp_path.iterdir())
    assert main(argv) == EXIT_ERROR
    line = _one_error_line(capsys)
    assert line.startswith(f"error: {named}: ") and text in line, line
    assert sorted(p.name for p in tmp_path.iterdir()) == before and list((tmp_path / "dir").iterdir()) == []
    assert (tmp_path / "afile").read_bytes() == VICTIM


def test_a_late_failure_leaves_none_of_the_outputs(small: Path, tmp_path: Path, capsys, monkeypatch) -> None:  # noqa: F811
    """modes --json --plot whose figure fails after the JSON is written: neither file is left (the JSON
    was before), nor a temporary; without the failure both are written."""
    import ema_rig.plot.synthesis as synthesis

    argv = ["modes", str(small / "m1.uff"), "--rig", str(small / "rig.toml"), "--max-order", "16",
            "--json", str(tmp_path / "m.json"), "--plot", str(tmp_path / "m.png")]
    real = synthesis.plot_synthesis

    def failing(*a: object, **k: object) -> object:
        raise ValueError("the figure cannot be drawn")

    monkeypatch.setattr(synthesis, "plot_synthesis", failing)
    assert main(argv) == EXIT_ERROR
    out, err = capsys.readouterr()
    assert "the figure cannot be drawn" in err
    assert list(tmp_path.iterdir()) == []
    # 'wrote m.json' was printed before the failure: the one error line says it was not kept
    assert f"wrote {tmp_path / 'm.json'}" in out
    (line,) = [x for x in err.splitlines() if x.startswith("error:")]
    assert f"nothing written ({tmp_path / 'm.json'} discarded)" in line
    monkeypatch.setattr(synthesis, "plot_synthesis", real)
    assert main(argv) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.json", "m.png"]
    capsys.readouterr()


def test_all_or_nothing_renames_together_and_commit_staged_keeps(tmp_path: Path) -> None:
    a, b, c = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    with pytest.raises(RuntimeError), _atomic.all_or_nothing():
        _atomic.write_text(a, "1")
        _atomic.write_text(b, "2")
        assert not a.exists() and not b.exists()  # staged: renamed only at the end
        raise RuntimeError("late failure")
    assert list(tmp_path.iterdir()) == []
    with pytest.raises(RuntimeError), _atomic.all_or_nothing():
        _atomic.write_text(c, "refusal")
        _atomic.commit_staged()  # an output meant to survive the failure
        _atomic.write_text(a, "1")
        raise RuntimeError("late failure")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["c.json"]
    with _atomic.all_or_nothing():
        _atomic.write_text(a, "1")
        _atomic.write_text(b, "2")
    assert a.read_text() == "1" and b.read_text() == "2" and len(list(tmp_path.iterdir())) == 3
    assert _atomic.remove_active_files() == []  # nothing left tracked


def test_a_stiffness_refusal_json_is_kept_although_the_command_fails(small: Path, tmp_path: Path, capsys,  # noqa: F811
                                                                       monkeypatch) -> None:
    """The refusal JSON (the error and every candidate) is the answer of a refused match: all_or_nothing
    keeps it (commit_staged) while the failing command's other outputs are never made."""
    import json

    import ema_rig.rig.stiffness as stiffness
    from ema_rig.errors import MatchingError

    def refused(*a: object, **k: object) -> object:
        raise MatchingError("no identified mode matches the housing mode", candidates=[{"natural_freq": 123.0}])

    monkeypatch.setattr(stiffness, "estimate_stiffness", refused)
    argv = ["stiffness", str(small / "m1.uff"), "--rig", str(small / "rig.toml"),
            "--json", str(tmp_path / "s.json"), "--plot", str(tmp_path / "s.png")]
    assert main(argv) == EXIT_ERROR
    assert "no identified mode matches" in _one_error_line(capsys)
    assert [p.name for p in tmp_path.iterdir()] == ["s.json"]
    doc = json.loads((tmp_path / "s.json").read_text(encoding="utf-8"))
    assert doc["error"] == "no identified mode matches the housing mode" and doc["candidates"] == [{"natural_freq": 123.0}]


def test_campaign_output_folder_under_a_file_named_as_the_folder(small: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    """campaign -o DIR with a file in the way names DIR (not DIR/campaign.csv, one of its files)."""
    (tmp_path / "afile").write_bytes(VICTIM)
    for out in (tmp_path / "afile", tmp_path / "afile" / "x"):
        assert main(["campaign", str(small / "campaign.toml"), "-o", str(out)]) == EXIT_ERROR
        assert _one_error_line(capsys) == f"error: {out}: cannot create the folder {out} (a file is in the way)"
    assert (tmp_path / "afile").read_bytes() == VICTIM
