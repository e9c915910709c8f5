"""Campaign faults (issue 8): stale results, killed workers and parents, concurrent runs, hostile ids.

Every reproducer is generated here: small simulated measurements (150-1000 Hz every 2 Hz, no extra
modes, max order 16: about 0.05 s each) so that the fault tests stay fast.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from ema_rig import _atomic
from ema_rig.campaign import load_campaign, run
from ema_rig.cli import EXIT_ERROR, main
from ema_rig.config import load_rig
from ema_rig.errors import ConfigError, EmaRigError

FREQ = np.arange(150.0, 1200.0, 2.0)  # Hz: the housing modes (~500-900 Hz) and the steel disk's 897 Hz
K_TB = {"m1": 5.0e7, "m2": 6.0e7, "m3": 7.0e7, "m4": 8.0e7}  # N/m
HEAD = 'rig = "rig.toml"\ncalibration = "disk.uff"\n[output]\nmeasurement_figures = false\n[defaults]\nmax_order = 16\n'


def _measurement(mid: str, load: float, *, bearing: str = "6302", file: str | None = None) -> str:
    return (f'[[measurement]]\nfile = "{file or mid + ".uff"}"\nid = "{mid}"\nbearing = \'{bearing}\'\n'
            f"radial_load = {load}\nspeed = 600.0\n")


@pytest.fixture(scope="module")
def small(tmp_path_factory: pytest.TempPathFactory, rig_toml_text: str) -> Path:
    """A steel-disk calibration and four cheap 6302 measurements with known k_TB."""
    from ema_rig.simulate import simulate_measurement, write_measurement

    d = tmp_path_factory.mktemp("small")
    (d / "rig.toml").write_text(rig_toml_text, encoding="utf-8")
    rig = load_rig(d / "rig.toml")
    disk = simulate_measurement(rig, k_tb=math.inf, freq=FREQ, noise=0.002, seed=1, extra_modes=False)
    write_measurement(disk, d / "disk.uff", rig=rig)
    text = HEAD
    for i, (mid, k) in enumerate(K_TB.items()):
        sim = simulate_measurement(rig, k_tb=k, freq=FREQ, noise=0.002, seed=2 + i, extra_modes=False,
                                   speed_hz=10.0)
        write_measurement(sim, d / f"{mid}.uff", rig=rig)
        text += _measurement(mid, 200.0 * (i + 1))
    (d / "campaign.toml").write_text(text, encoding="utf-8")
    return d


@pytest.fixture(scope="module")
def small_out(small: Path, tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The output folder of one run of the small campaign (tests copy it before changing it)."""
    out = tmp_path_factory.mktemp("small_out") / "out"
    run(small / "campaign.toml", out_dir=out, report=False)
    return out


def _copy(small: Path, dst: Path) -> Path:
    """The campaign in a folder of its own: TOML files copied (tests edit them), UFF files linked."""
    dst.mkdir()
    for f in small.iterdir():
        if f.suffix == ".toml":
            shutil.copy(f, dst / f.name)
        else:
            try:
                (dst / f.name).symlink_to(f)
            except OSError:  # no symlinks (Windows without the privilege)
                shutil.copy(f, dst / f.name)
    return dst


def _k(result) -> dict[str, float]:
    return {r["id"]: r["k_TB"] for r in result.rows}


def test_small_campaign_is_right(small: Path) -> None:
    res = run(small / "campaign.toml", report=False)
    assert res.ok and res.calibration is not None
    # the simulator's radial dynamics are the 3DOF model's, the disk run gives k_MS back
    assert res.k_MS == pytest.approx(114e6, rel=0.01)
    for mid, k in K_TB.items():
        assert _k(res)[mid] == pytest.approx(k, rel=0.01), mid


@pytest.fixture
def alarm():
    """Fail instead of hanging: SIGALRM after 30 s."""
    if not hasattr(signal, "setitimer"):
        pytest.skip("needs SIGALRM")

    def boom(signum, frame):
        raise TimeoutError("blocked on a special file")

    old = signal.signal(signal.SIGALRM, boom)
    signal.setitimer(signal.ITIMER_REAL, 30.0)
    yield
    signal.setitimer(signal.ITIMER_REAL, 0.0)
    signal.signal(signal.SIGALRM, old)


# ------------------------------------------------------------------------ 1. stale results
@pytest.mark.parametrize(
    ("old", "new"),
    [
        ("m_H = 2.566", "m_H = 2.9"),  # model parameter: k_MS and every k_TB change
        ('dof = "13-Y"', 'dof = "13+Y"'),  # a sensor's sign
        ("[excitation]", "[identification]\nband = [400.0, 1000.0]\n[excitation]"),  # the band
        ("[excitation]", "[uncertainty]\nm_H = 0.01\n[excitation]"),  # the uncertainty budget
        ("[excitation]", '[units]\nprefer = "label"\n[excitation]'),  # unit conflicts
    ],
)
def test_rig_edit_recomputes_everything(small: Path, tmp_path: Path, old: str, new: str) -> None:
    d = _copy(small, tmp_path / "c")
    out = tmp_path / "out"
    first = run(d / "campaign.toml", out_dir=out, report=False)
    cal_key = json.loads((out / "results" / "_calibration.json").read_text())["cache_key"]
    rig = (d / "rig.toml").read_text()
    assert old in rig
    (d / "rig.toml").write_text(rig.replace(old, new, 1))
    edited = run(d / "campaign.toml", out_dir=out, report=False)
    assert (edited.computed, edited.reused) == (len(K_TB), 0)
    assert json.loads((out / "results" / "_calibration.json").read_text())["cache_key"] != cal_key
    # oracle: a fresh run of the edited campaign in an empty folder
    fresh = run(d / "campaign.toml", out_dir=tmp_path / "fresh", report=False)
    assert edited.k_MS == fresh.k_MS
    for a, b in zip(edited.rows, fresh.rows, strict=True):
        assert (a["status"], a["error"]) == (b["status"], b["error"])
        assert a["k_TB"] == pytest.approx(b["k_TB"], rel=1e-12, nan_ok=True)
        assert a["k_TB_std"] == pytest.approx(b["k_TB_std"], rel=1e-12, nan_ok=True)
    if old.startswith("m_H"):
        # +13 % in m_H moves k_MS and k_TB by far more than their 1 % accuracy: a stale row would show
        assert abs(edited.k_MS / first.k_MS - 1) > 0.05
        assert all(abs(edited.rows[i]["k_TB"] / first.rows[i]["k_TB"] - 1) > 0.05 for i in range(len(K_TB)))


def test_campaign_settings_change_recomputes(small: Path, tmp_path: Path) -> None:
    d = _copy(small, tmp_path / "c")
    out = tmp_path / "out"
    run(d / "campaign.toml", out_dir=out, report=False)
    text = (d / "campaign.toml").read_text()
    (d / "campaign.toml").write_text(text.replace("max_order = 16", "max_order = 18"))
    assert run(d / "campaign.toml", out_dir=out, report=False).computed == len(K_TB)
    (d / "campaign.toml").write_text(text.replace('speed = 600.0', 'speed = 900.0', 1))
    res = run(d / "campaign.toml", out_dir=out, report=False)
    assert res.computed >= 1  # m1's speed changed (the order change back recomputes the rest)
    assert run(d / "campaign.toml", out_dir=out, report=False).computed == 0


# ------------------------------------------------------------------------ 2. killed workers
def _fork_only() -> None:
    import multiprocessing

    if multiprocessing.get_context().get_start_method() != "fork":
        pytest.skip("the fault is injected through a patched function inherited by fork")


def test_killed_worker_rows_are_not_cached(small: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _fork_only()
    from ema_rig.campaign import runner

    real, parent = runner._compute, os.getpid()

    def oom_killed(task):  # the OOM killer takes the worker that reads m2.uff
        if task.file.name == "m2.uff" and os.getpid() != parent:
            os.kill(os.getpid(), signal.SIGKILL)
        return real(task)

    monkeypatch.setattr(runner, "_compute", oom_killed)
    out = tmp_path / "out"
    first = run(small / "campaign.toml", out_dir=out, jobs=2, report=False)
    failed = [r["id"] for r in first.rows if r["status"] != "ok"]
    assert "m2" in failed
    for r in first.rows:
        if r["status"] != "ok":
            assert "worker failed" in r["error"] and "BrokenProcessPool" in r["error"]
            assert json.loads((out / "results" / f"{r['id']}.json").read_text())["cache_key"] is None
    monkeypatch.undo()
    again = run(small / "campaign.toml", out_dir=out, jobs=2, report=False)
    assert (again.computed, again.reused) == (len(failed), len(K_TB) - len(failed))
    assert again.ok
    assert run(small / "campaign.toml", out_dir=out, report=False).computed == 0


def test_internal_error_is_not_cached(small: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    from ema_rig.campaign import runner

    real = runner._compute

    def buggy(task):
        if task.file.name == "m3.uff":
            raise RuntimeError("a bug")
        return real(task)

    monkeypatch.setattr(runner, "_compute", buggy)
    out = tmp_path / "out"
    first = run(small / "campaign.toml", out_dir=out, report=False)
    assert [r["id"] for r in first.rows if r["status"] != "ok"] == ["m3"]
    assert "internal error (RuntimeError)" in first.rows[2]["error"]
    monkeypatch.undo()
    again = run(small / "campaign.toml", out_dir=out, report=False)
    assert (again.computed, again.reused) == (1, 3) and again.ok


_PARENT_SCRIPT = """
import os, sys, time
from pathlib import Path
from ema_rig.campaign import runner, run

campaign, pids = Path(sys.argv[1]), Path(sys.argv[2])
real, parent = runner._compute, os.getpid()

def slow(task):
    if os.getpid() == parent:  # the calibration runs in the parent
        return real(task)
    (pids / str(os.getpid())).write_text("")
    time.sleep(120)

runner._compute = slow
run(campaign, jobs=2, report=False)
"""


def _dead(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (FileNotFoundError, ProcessLookupError):
        return True
    return state in ("Z", "X")  # a zombie has exited; only its parent's reaping is missing


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_killed_parent_leaves_no_worker(small: Path, tmp_path: Path) -> None:
    _fork_only()
    pids = tmp_path / "pids"
    pids.mkdir()
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[1]), *sys.path])}
    proc = subprocess.Popen([sys.executable, "-c", _PARENT_SCRIPT, str(small / "campaign.toml"), str(pids)],
                            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 60
        while len(list(pids.iterdir())) < 2 and time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.05)
        workers = [int(p.name) for p in pids.iterdir()]
        assert len(workers) == 2, "both workers should be busy"
    finally:
        proc.kill()  # kill -9 of the main process
        proc.wait()
    deadline = time.monotonic() + 5
    while not all(_dead(w) for w in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    alive = [w for w in workers if not _dead(w)]
    for w in alive:  # never leave them behind, even when the test fails
        os.kill(w, signal.SIGKILL)
    assert not alive, "pool workers survived their parent"


# ------------------------------------------------------------------------ 3. ids and output names
@pytest.mark.parametrize(
    ("mid", "why"),
    [
        ("../../x", "contains one of"),
        ("/abs/x", "contains one of"),
        ("x/../a", "contains one of"),
        ("a\\\\b", "contains one of"),
        ("C:x", "contains one of"),
        ("", "is empty"),
        ("..", "starts with '.'"),
        (".hidden", "starts with '.'"),
        ("_calibration", "reserved for ema_rig"),
        (" m1", "blanks"),
        ("a\\u0000b", "control character"),
        ("a\\nb", "control character"),
        ("nul", "device name"),
        ("x" * 200, "longer than"),
    ],
)
def test_bad_ids_refused(small: Path, tmp_path: Path, mid: str, why: str) -> None:
    d = _copy(small, tmp_path / "c")
    (d / "campaign.toml").write_text(HEAD + f'[[measurement]]\nfile = "m1.uff"\nid = "{mid}"\n')
    with pytest.raises(ConfigError, match="measurement\\[0\\]\\.id") as info:
        load_campaign(d / "campaign.toml")
    assert why in str(info.value) and str(d / "campaign.toml") in str(info.value)


@pytest.mark.parametrize(("a", "b"), [("m1", "M1"), ("caf\u00e9", "cafe\u0301")])
def test_ids_unique_after_normalisation(small: Path, tmp_path: Path, a: str, b: str) -> None:
    d = _copy(small, tmp_path / "c")
    text = HEAD + f'[[measurement]]\nfile = "m1.uff"\nid = "{a}"\n[[measurement]]\nfile = "m2.uff"\nid = "{b}"\n'
    (d / "campaign.toml").write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match="duplicate measurement id"):
        load_campaign(d / "campaign.toml")


def test_id_derived_from_a_hidden_file_name_says_to_give_one(small: Path, tmp_path: Path) -> None:
    d = _copy(small, tmp_path / "c")
    shutil.copy(d / "m1.uff", d / ".uff")
    (d / "campaign.toml").write_text(HEAD + '[[measurement]]\nfile = ".uff"\n')
    with pytest.raises(ConfigError, match="give an explicit id"):
        load_campaign(d / "campaign.toml")


@pytest.mark.parametrize("doc", ["[1, 2]", "42", "null", '"text"', "{}", '{"cache_key": 3}', "[" * 100_000,
                                 '{"status": "ok"', "\udcff", "fifo"])
def test_foreign_result_json_is_recomputed(small: Path, small_out: Path, tmp_path: Path, doc: str, alarm) -> None:
    out = shutil.copytree(small_out, tmp_path / "out")
    (out / "results" / "m1.json").unlink()
    if doc == "fifo":
        if not hasattr(os, "mkfifo"):
            pytest.skip("needs FIFOs")
        os.mkfifo(out / "results" / "m1.json")  # reading it would block; writing replaces it
    else:
        (out / "results" / "m1.json").write_bytes(doc.encode("utf-8", "surrogateescape"))
    res = run(small / "campaign.toml", out_dir=out, report=False)
    assert (res.computed, res.reused) == (1, 3) and res.ok


def test_tampered_result_with_the_right_key_is_recomputed(small: Path, small_out: Path, tmp_path: Path) -> None:
    out = shutil.copytree(small_out, tmp_path / "out")
    p = out / "results" / "m1.json"
    doc = json.loads(p.read_text())
    doc["k_TB"] = "huge"
    p.write_text(json.dumps(doc))
    res = run(small / "campaign.toml", out_dir=out, report=False)
    assert (res.computed, res.reused) == (1, 3) and isinstance(res.rows[0]["k_TB"], float)


# ------------------------------------------------------------------------ 6. special files
@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_fifo_and_device_measurements_do_not_block(small: Path, tmp_path: Path, alarm) -> None:
    d = _copy(small, tmp_path / "c")
    os.mkfifo(d / "fifo.uff")
    text = (d / "campaign.toml").read_text() + _measurement("fifo", 300.0) + _measurement("zero", 300.0, file="/dev/zero")
    (d / "campaign.toml").write_text(text)
    res = run(d / "campaign.toml", out_dir=tmp_path / "out", report=False)
    bad = {r["id"]: r["error"] for r in res.rows if r["status"] != "ok"}
    assert set(bad) == {"fifo", "zero"}
    assert "not a regular file" in bad["fifo"] and "fifo.uff" in bad["fifo"]
    assert "not a regular file" in bad["zero"] and "/dev/zero" in bad["zero"]
    assert json.loads((tmp_path / "out" / "results" / "fifo.json").read_text())["cache_key"] is None


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
@pytest.mark.parametrize("which", ["rig", "calibration"])
def test_fifo_rig_or_calibration_refused(small: Path, tmp_path: Path, alarm, which: str) -> None:
    d = _copy(small, tmp_path / "c")
    os.mkfifo(d / "fifo")
    text = (d / "campaign.toml").read_text().replace(
        'rig = "rig.toml"' if which == "rig" else 'calibration = "disk.uff"',
        f'{which} = "fifo"')
    (d / "campaign.toml").write_text(text)
    with pytest.raises(ConfigError, match=f"{which}: not a regular file"):
        load_campaign(d / "campaign.toml")
    if which == "rig":
        with pytest.raises(ConfigError, match="not a regular file"):
            load_rig(d / "fifo")


# ------------------------------------------------------------------------ 8. lost outputs
def test_second_run_on_the_same_folder_refuses(small: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "out"
    other = _copy(small, tmp_path / "other")
    (other / "campaign.toml").write_text((other / "campaign.toml").read_text().replace("max_order = 16",
                                                                                     "max_order = 18"))
    seen: list[BaseException] = []

    def meanwhile(done: int, total: int) -> None:
        if done == 1:  # a second campaign starts on the same folder while the first runs
            try:
                run(other / "campaign.toml", out_dir=out)
            except EmaRigError as exc:
                seen.append(exc)
            assert main(["campaign", str(other / "campaign.toml"), "-o", str(out)]) == EXIT_ERROR

    first = run(small / "campaign.toml", out_dir=out, progress=meanwhile)
    assert len(seen) == 1 and isinstance(seen[0], _atomic.FolderBusyError)
    assert str(out) in str(seen[0]) and f"process {os.getpid()}" in str(seen[0])
    err = capsys.readouterr().err
    assert err.startswith(f"error: {out}: output folder is in use") and err.count("\n") == 1
    # the folder holds the first campaign only
    settings = json.loads((out / "settings.json").read_text())
    assert settings["campaign"] == str(small / "campaign.toml") and settings["max_order"] == 16
    assert first.ok and str(small / "campaign.toml") in (out / "report.html").read_text()
    # once the first has finished, the folder is free again
    assert run(other / "campaign.toml", out_dir=out, report=False).computed == len(K_TB)


def test_leftover_temporaries_removed(small: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    (out / "results").mkdir(parents=True)
    left = [out / ".report.html.a1b2c3d4.tmp.html", out / ".k_vs_load_6302.png.zz_99xyz.tmp.png",
            out / "results" / ".m1.json.q1w2e3r4.tmp.json"]
    keep = [out / ".keep", out / "notes.tmp.png", out / "results" / "mine.txt"]
    for p in left + keep:
        p.write_text("x")
    run(small / "campaign.toml", out_dir=out, report=False)
    assert not any(p.exists() for p in left) and all(p.exists() for p in keep)


def test_figure_names_unique_and_mathtext_escaped(small: Path, tmp_path: Path) -> None:
    d = _copy(small, tmp_path / "c")
    text = HEAD
    bearings = ["a/b", "a b", r"p$\frac$q"]  # "a/b" and "a b" shared a file; "$\frac$" broke mathtext
    for j, b in enumerate(bearings):
        for i, mid in enumerate(("m1", "m2")):
            text += _measurement(f"{mid}_{j}", 200.0 * (i + 1), bearing=b, file=f"{mid}.uff")
    (d / "campaign.toml").write_text(text)
    out = tmp_path / "out"
    res = run(d / "campaign.toml", out_dir=out)
    assert res.ok
    figs = sorted(k for k in res.files if k.startswith("k_vs_load_"))
    assert len(figs) == 3 and all(res.files[k].stat().st_size > 10_000 for k in figs)
    html = (out / "report.html").read_text()
    # per bearing: k_vs_load and damping (issue 19)
    assert html.count("data:image/png;base64,") == 6
    assert len([k for k in res.files if k.startswith("damping_")]) == 3
    assert all(Path(res.files[k]).parent == out for k in figs)


def test_stale_figures_of_a_previous_campaign_removed(small: Path, tmp_path: Path) -> None:
    d = _copy(small, tmp_path / "c")
    out = tmp_path / "out"
    run(d / "campaign.toml", out_dir=out)
    assert (out / "k_vs_load_6302.png").exists()
    (d / "campaign.toml").write_text((d / "campaign.toml").read_text().replace("'6302'", "'6205'"))
    run(d / "campaign.toml", out_dir=out)
    assert (out / "k_vs_load_6205.png").exists() and not (out / "k_vs_load_6302.png").exists()


def test_disk_full_names_the_output_file(small: Path, tmp_path: Path, monkeypatch, capsys) -> None:
    import errno

    real = os.replace

    def full(src, dst):
        if str(dst).endswith("m2.json"):
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(src, dst)

    monkeypatch.setattr(_atomic.os, "replace", full)
    out = tmp_path / "out"
    assert main(["campaign", str(small / "campaign.toml"), "-o", str(out)]) == EXIT_ERROR
    err = capsys.readouterr().err
    assert err == f"error: {out / 'results' / 'm2.json'}: No space left on device\n"
    assert not list((out / "results").glob(".*tmp*"))  # no temporary left behind


# ------------------------------------------------------------------------ 5/7. strict TOML
_BIG = "1" + "0" * 400


@pytest.mark.parametrize(
    ("old", "new", "key", "words"),
    [
        ("[defaults]", "[bearings.6302]\nhertz = \"false\"\n[defaults]", "bearings.6302.hertz", "true or false"),
        ("[defaults]", "[bearings.6302]\nhertz = 1\n[defaults]", "bearings.6302.hertz", "true or false"),
        ("[defaults]", "[bearings.6302]\nlabel = 3\n[defaults]", "bearings.6302.label", "string"),
        ("[defaults]", "[bearings.6302]\nk_lower = true\n[defaults]", "bearings.6302.k_lower", "number"),
        ("speed = 600.0\n", "speed = 600.0\nshaft_position = true\n", "measurement[0].shaft_position", "number"),
        ("speed = 600.0\n", "speed = 600.0\nshaft_position = [1]\n", "measurement[0].shaft_position", "number"),
        ("speed = 600.0\n", "speed = 600.0\nshaft_position = nan\n", "measurement[0].shaft_position", "finite"),
        ("speed = 600.0\n", "speed = 600.0\nrepeat = -3\n", "measurement[0].repeat", ">= 1"),
        ("speed = 600.0\n", "speed = 600.0\nrepeat = 0\n", "measurement[0].repeat", ">= 1"),
        ("speed = 600.0\n", "speed = 600.0\nrepeat = 1.5\n", "measurement[0].repeat", "integer"),
        ("speed = 600.0\n", "speed = 600.0\nrepeat = true\n", "measurement[0].repeat", "integer"),
        ("speed = 600.0\n", "speed = 600.0\nrepeat = " + _BIG + "\n", "measurement[0].repeat", "64-bit"),
        ("radial_load = 200.0", "radial_load = " + _BIG, "measurement[0].radial_load", "401 digits"),
        ("radial_load = 200.0", "radial_load = -1.0", "measurement[0].radial_load", ">= 0"),
        ("radial_load = 200.0", "radial_load = true", "measurement[0].radial_load", "number"),
        ("speed = 600.0", 'speed = "600"', "measurement[0].speed", "number"),
        ("speed = 600.0", "speed = inf", "measurement[0].speed", "finite"),
        ("bearing = '6302'", "bearing = 6302", "measurement[0].bearing", "string"),
        ('file = "m1.uff"', "file = 1", "measurement[0].file", "string"),
        ('file = "m1.uff"', 'file = ""', "measurement[0].file", "empty"),
        ('id = "m1"', "id = 1", "measurement[0].id", "string"),
        # accepted on 4ff7088: a shaft speed no rolling bearing runs at, an angle of 28 turns
        ("speed = 600.0\n", "speed = 6e5\n", "measurement[0].speed", "dental air turbines"),
        ("speed = 600.0\n", "speed = 600.0\nshaft_position = 1e4\n", "measurement[0].shaft_position", "one turn"),
        ("speed = 600.0\n", "speed = 600.0\ntags = [1]\n", "measurement[0].tags", "strings"),
        ("max_order = 16", "max_order = true", "defaults.max_order", "integer"),
        ("max_order = 16", "max_order = 16.0", "defaults.max_order", "integer"),
        ("max_order = 16", "max_order = 1", "defaults.max_order", ">= 2"),
        ("max_order = 16", "max_order = " + _BIG, "defaults.max_order", "64-bit"),
        ("max_order = 16", "band = [1000.0, 150.0]", "defaults.band", "lo < hi"),
        ("max_order = 16", "band = [true, 900.0]", "defaults.band", "number"),
        ("max_order = 16", "band = 3", "defaults.band", "pair"),
        ('calibration = "disk.uff"', 'calibration = "disk.uff"\nk_disk = true', "k_disk", "number"),
        ('calibration = "disk.uff"', 'calibration = "disk.uff"\nk_disk = 0', "k_disk", "positive"),
        ('calibration = "disk.uff"', 'calibration = "disk.uff"\ntitle = 3', "title", "string"),
        ('calibration = "disk.uff"', "calibration = true", "calibration", "string"),
        ('calibration = "disk.uff"', 'calibration = "nope.uff"', "calibration", "not found"),
        ('calibration = "disk.uff"', 'calibration = "disk.uff"\nbearings = 3', "bearings", "table"),
    ],
)
def test_campaign_values_strictly_typed(small: Path, tmp_path: Path, old: str, new: str, key: str,
                                        words: str, capsys) -> None:
    d = _copy(small, tmp_path / "c")
    text = (d / "campaign.toml").read_text()
    assert old in text
    (d / "campaign.toml").write_text(text.replace(old, new, 1))
    with pytest.raises(ConfigError) as info:
        load_campaign(d / "campaign.toml")
    msg = str(info.value)
    assert info.value.key == key and words in msg and str(d / "campaign.toml") in msg and len(msg) < 300
    # the command line: one line on stderr, no traceback, exit 1
    assert main(["campaign", str(d / "campaign.toml"), "-o", str(tmp_path / "o")]) == EXIT_ERROR
    err = capsys.readouterr().err
    assert err.startswith("error: ") and err.count("\n") == 1 and key in err


# ------------------------------------------------------------------------ one definition of the key
def test_every_task_field_enters_the_key(small: Path) -> None:
    import dataclasses

    from ema_rig.campaign.runner import MeasurementTask, task_key

    rig = load_rig(small / "rig.toml")
    base = MeasurementTask(kind="measurement", file=small / "m1.uff", rig=rig, k_ms=1.14e8, k_ms_std=1e6,
                           k_disk=None, speed_hz=10.0, band=(150.0, 1000.0), max_order=16)
    other_model = dataclasses.replace(rig.model, k_S=rig.model.k_S * 1.001)
    changed = {
        "kind": "calibration", "k_ms": 1.15e8, "k_ms_std": 2e6, "k_disk": 2e9, "speed_hz": 10.5,
        "band": (150.0, 999.0), "max_order": 18, "rig": dataclasses.replace(rig, model=other_model),
        "selection": '{"format": "ema_rig.selection/1"}',  # the selection's text: its content is the key
    }
    # the file and the selection's file enter by their content (digest, selection text), named in errors only
    assert set(changed) | {"file", "selection_file"} == {f.name for f in dataclasses.fields(MeasurementTask)}
    key = task_key(base, "digest")
    for name, value in changed.items():
        assert task_key(dataclasses.replace(base, **{name: value}), "digest") != key, name
    assert task_key(base, "other digest") != key
    # the rig's content counts, not its path; the file's content counts, not its name
    assert task_key(dataclasses.replace(base, rig=dataclasses.replace(rig, path="/elsewhere/rig.toml"),
                                        file=Path("/elsewhere/m.uff")), "digest") == key
    assert task_key(dataclasses.replace(base, selection_file="/elsewhere/picks.json"), "digest") == key


def test_moved_rig_file_with_the_same_content_is_reused(small: Path, tmp_path: Path) -> None:
    d = _copy(small, tmp_path / "c")
    out = tmp_path / "out"
    run(d / "campaign.toml", out_dir=out, report=False)
    (d / "rig.toml").rename(d / "rig2.toml")
    (d / "campaign.toml").write_text((d / "campaign.toml").read_text().replace("rig.toml", "rig2.toml"))
    assert run(d / "campaign.toml", out_dir=out, report=False).reused == len(K_TB)


def test_dollar_in_a_file_name_keeps_the_stiffness_figure(small: Path, tmp_path: Path) -> None:
    src = tmp_path / "a$x^$b.uff"  # an unescaped "$x^$" is invalid mathtext: savefig raised
    shutil.copy(small / "m1.uff", src)
    png = tmp_path / "fit.png"
    code = main(["stiffness", str(src), "--rig", str(small / "rig.toml"), "--max-order", "16", "--plot", str(png)])
    assert code == 0 and png.stat().st_size > 10_000


def test_runner_does_not_import_plotting() -> None:
    code = ("import sys, ema_rig.campaign, ema_rig.campaign.runner; "
            "print(sorted(m for m in sys.modules if m.startswith(('matplotlib', 'ema_rig.plot', 'ema_rig.report'))))")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[1]), *sys.path])}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
    assert out.strip() == "[]"


# ------------------------------------------------------------------------ issue 17: failures become rows
def _with_figures(small: Path, dst: Path, ids: tuple[str, ...] = tuple(K_TB), figures: bool = True) -> Path:
    """The small campaign with the per-measurement figures on (or off), for the measurements ``ids`` only."""
    d = _copy(small, dst)
    text = HEAD.replace("measurement_figures = false", "measurement_figures = true") if figures else HEAD
    text += "".join(_measurement(mid, 200.0 * (i + 1)) for i, mid in enumerate(K_TB) if mid in ids)
    (d / "campaign.toml").write_text(text)
    return d


def test_killed_worker_still_draws_the_report(small: Path, tmp_path: Path, monkeypatch, capsys) -> None:
    # was: a BrokenProcessPool traceback from the output writer, exit 1, no new report
    _fork_only()
    from ema_rig.campaign import runner

    real, parent = runner._compute, os.getpid()

    def oom_killed(task):
        if task.file.name == "m2.uff" and os.getpid() != parent:
            os.kill(os.getpid(), signal.SIGKILL)
        return real(task)

    monkeypatch.setattr(runner, "_compute", oom_killed)
    d = _with_figures(small, tmp_path / "c", ("m1", "m2", "m3"))
    out = tmp_path / "out"
    assert main(["campaign", str(d / "campaign.toml"), "-o", str(out), "--jobs", "2"]) == 3
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err and captured.err.count("\n") == 1, captured.err
    rows = {r["id"]: r for r in csv.DictReader((out / "campaign.csv").read_text().splitlines())}
    failed = sorted(i for i, r in rows.items() if r["status"] != "ok")
    # one task per worker: only the measurements in flight when the worker died fail (at most --jobs)
    assert "m2" in failed and len(failed) <= 2, failed
    for i in failed:
        assert json.loads((out / "results" / f"{i}.json").read_text())["cache_key"] is None
    html = (out / "report.html").read_text()
    assert "worker failed" in html and all(i in html for i in ("m1", "m2", "m3"))
    assert not (out / ".ema-rig.lock").exists()


def test_worker_killed_while_drawing_figures(small: Path, tmp_path: Path, monkeypatch) -> None:
    _fork_only()
    from ema_rig.io import uff

    d = _with_figures(small, tmp_path / "c", ("m1", "m2", "m3"))
    out = tmp_path / "out"
    run(d / "campaign.toml", out_dir=out, report=False)  # the rows; the figures come next
    real, parent = uff.read_uff58, os.getpid()

    def killed(path, *a, **k):  # the worker drawing m3's figures is killed
        if Path(path).name == "m3.uff" and os.getpid() != parent:
            os.kill(os.getpid(), signal.SIGKILL)
        return real(path, *a, **k)

    monkeypatch.setattr(uff, "read_uff58", killed)
    res = run(d / "campaign.toml", out_dir=out, jobs=2)
    assert res.ok and res.reused == 3 and (out / "report.html").stat().st_size > 10_000
    assert "figures not drawn: worker failed" in (out / "report.html").read_text()
    # m3 starts once m1 or m2 is done: that one's figures are written; the one in flight with m3
    # (if any) fails with the pool
    before = {p.name: p.stat().st_ino for p in (out / "measurements").iterdir()}
    assert not any(n.startswith("m3.") for n in before) and len(before) in (3, 6), sorted(before)
    monkeypatch.undo()
    run(d / "campaign.toml", out_dir=out, jobs=1)
    after = {p.name: p.stat().st_ino for p in (out / "measurements").iterdir()}
    assert len(after) == 9 and {f"m3.{k}.png" for k in ("model", "stabilization", "synthesis")} <= set(after)
    assert all(after[n] == i for n, i in before.items())  # the figures drawn before were kept


def test_previous_report_not_left_looking_current(small: Path, tmp_path: Path, monkeypatch) -> None:
    from ema_rig.campaign import runner

    d = _copy(small, tmp_path / "c")
    out = tmp_path / "out"
    run(d / "campaign.toml", out_dir=out)
    assert (out / "report.html").is_file()
    real = runner._compute

    def interrupted(task):
        if task.file.name == "m3.uff":
            raise KeyboardInterrupt
        return real(task)

    monkeypatch.setattr(runner, "_compute", interrupted)
    (d / "campaign.toml").write_text((d / "campaign.toml").read_text().replace("max_order = 16", "max_order = 18"))
    with pytest.raises(KeyboardInterrupt):
        run(d / "campaign.toml", out_dir=out)
    assert not (out / "report.html").exists()  # the old report would show the old rows as current
    assert not (out / ".ema-rig.lock").exists()
    monkeypatch.undo()
    assert run(d / "campaign.toml", out_dir=out).ok and (out / "report.html").is_file()


# ------------------------------------------------------------------------ issue 17: resume keeps figures
_KILL_SCRIPT = """
import os, re, signal, sys
from pathlib import Path
from ema_rig.campaign import outputs
from ema_rig.cli import main

folder = Path(sys.argv[2]) / "measurements"

def finished():
    return [p for p in folder.glob("*.png") if not re.match(sys.argv[3], p.name)] if folder.is_dir() else []

target, real = len(finished()) + 3, outputs._record

def record(*a, **k):  # kill -9 of this (the parent) process, in the figure phase, at a defined point:
    # while a measurement's figures are recorded but not yet renamed, once a measurement's are written
    if len(finished()) >= target:
        os.kill(os.getpid(), signal.SIGKILL)
    return real(*a, **k)

outputs._record = record
sys.exit(main(["campaign", sys.argv[1], "-o", sys.argv[2], "--jobs", "2"]))
"""


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_parent_killed_in_figure_phase_keeps_finished_figures(small: Path, tmp_path: Path) -> None:
    _fork_only()
    from PIL import Image

    ids = ("m1", "m2", "m3")
    d = _with_figures(small, tmp_path / "c", ids)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parents[1]), *sys.path])}
    kept: dict[str, int] = {}
    for n in (1, 2):  # two kill -9 of the parent, each once one more measurement's figures are written
        proc = subprocess.run([sys.executable, "-c", _KILL_SCRIPT, str(d / "campaign.toml"), str(out),
                               _atomic._TEMP_NAME.pattern], env=env, capture_output=True, text=True, timeout=300)
        assert proc.returncode == -signal.SIGKILL, proc.stderr[-2000:]
        for p in (out / "measurements").glob("*.png"):
            if _atomic._TEMP_NAME.match(p.name):
                continue  # a figure being written when the parent was killed: removed by the next run
            with Image.open(p) as img:
                img.load()  # complete: never a half-written figure
            kept.setdefault(p.name, p.stat().st_ino)
        assert len(kept) == 3 * n, sorted(kept)  # the measurements written before the kill, not the one in flight
    res = run(d / "campaign.toml", out_dir=out, jobs=2)
    assert res.ok and res.computed == 0
    figs = {p.name: p.stat().st_ino for p in (out / "measurements").glob("*.png")}
    assert len(figs) == 3 * len(ids)
    assert all(figs[n] == i for n, i in kept.items())  # not drawn again on resume
    # same code, same data: the same numbers (the figures are drawn from the numbers, after them)
    clean = run(_with_figures(small, tmp_path / "clean", ids, figures=False) / "campaign.toml", report=False)
    assert _k(res) == pytest.approx(_k(clean), rel=1e-9)
    assert not any(_atomic._TEMP_NAME.match(p.name) for p in out.rglob("*"))


# ------------------------------------------------------------------------ issue 22: one identification each
def test_figures_drawn_from_the_computation(small: Path, tmp_path: Path, monkeypatch) -> None:
    # was: every measurement identified twice, once for its row and again for its figures
    from ema_rig.rig import stiffness

    d = _with_figures(small, tmp_path / "c", ("m1", "m2"))
    calls: list[str] = []
    real = stiffness.estimate_stiffness

    def counted(data, *a, **k):
        calls.append(str(data.meta.get("source")))
        return real(data, *a, **k)

    monkeypatch.setattr(stiffness, "estimate_stiffness", counted)
    out = tmp_path / "out"
    assert run(d / "campaign.toml", out_dir=out).ok
    assert len(calls) == 2, calls  # one identification per measurement, none again for its figures
    first = {p.name: p.read_bytes() for p in (out / "measurements").iterdir()}
    assert len(first) == 6
    # a resumed run (rows reused from disk, figures lost) identifies once to draw them, the old
    # way: the same PNG bytes (same process, same BLAS setting) as drawn from the computation
    for p in (out / "measurements").iterdir():
        p.unlink()
    calls.clear()
    res = run(d / "campaign.toml", out_dir=out)
    assert res.reused == 2 and len(calls) == 2, calls
    assert {p.name: p.read_bytes() for p in (out / "measurements").iterdir()} == first
    calls.clear()
    assert run(d / "campaign.toml", out_dir=out).reused == 2 and calls == []  # nothing to draw, nothing identified


def test_failed_calibration_is_a_warning_of_every_row(small: Path, tmp_path: Path, capsys) -> None:
    """A steel-disk file that cannot be read: the rows fall back on the rig file's k_MS. On 4ff7088 the rows
    said nothing (no warning; only the exit code 3 and one line on stderr told it, and the CSV not at all)."""
    d = tmp_path / "c"
    shutil.copytree(small, d)
    (d / "disk.uff").write_text("not a UFF file\n", encoding="utf-8")
    assert main(["campaign", str(d / "campaign.toml"), "-o", str(d / "out")]) == 3
    assert "calibration failed" in capsys.readouterr().err
    k_ms = load_rig(d / "rig.toml").model.k_MS
    for mid in K_TB:
        row = json.loads((d / "out" / "results" / f"{mid}.json").read_text())
        assert row["status"] == "ok" and row["k_MS"] == k_ms  # the documented fallback
        assert any("taken from the rig file" in w and "disk.uff" in w for w in row["warnings"]), row["warnings"]
    # the reused rows of a second run keep it
    assert main(["campaign", str(d / "campaign.toml"), "-o", str(d / "out")]) == 3
    row = json.loads((d / "out" / "results" / "m1.json").read_text())
    assert any("taken from the rig file" in w for w in row["warnings"])
