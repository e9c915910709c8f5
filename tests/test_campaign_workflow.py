"""The engineer's workflow end to end: what the table, the report and the figures make a user read.

Each test guards a finding of a review as a new user (q_user13) and fails on 7b8cca3:

* one file listed under two measurements (a copy-paste of a ``[[measurement]]`` table whose ``file``
  was not changed) gave two ``ok`` rows without a warning: the second condition's row showed the
  first condition's k_TB;
* a ± below the printed value's last digit was printed as 0 (``k_TB 70.000 +/- 0.000 (measured)``,
  the campaign table's ``± meas. 0.00``);
* the repeatability figure's grey bar was the total ±, dominated by rig-model tolerances that are the
  same for every repeat (80-560x the measured part on the demo), and the speed/repeat figures' measured
  ± left out the measured housing mass the table's "± measured" holds.
"""

from __future__ import annotations

import filecmp
import math
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from ema_rig._text import std_text
from ema_rig.campaign import run
from ema_rig.campaign.runner import SAME_CONTENT
from ema_rig.cli import main
from ema_rig.config import load_rig

K_TRUE = {"a500": 6.0e7, "b1000": 7.2e7}  # N/m


@pytest.fixture(scope="module")
def copied_campaign(tmp_path_factory: pytest.TempPathFactory, rig_toml_text: str) -> Path:
    """Two simulated measurements and a byte copy of the first listed at another load."""
    from ema_rig.simulate import simulate_measurement, write_measurement

    d = tmp_path_factory.mktemp("copied campaign ü")
    (d / "rig.toml").write_text(rig_toml_text, encoding="utf-8")
    rig = load_rig(d / "rig.toml")
    lines = ['rig = "rig.toml"', "[defaults]", "max_order = 24", "[output]", "measurement_figures = false"]
    for i, (mid, k) in enumerate(K_TRUE.items()):
        write_measurement(simulate_measurement(rig, k_tb=k, noise=0.005, seed=40 + i), d / f"{mid}.uff", rig=rig)
        lines += ["[[measurement]]", f'file = "{mid}.uff"', 'bearing = "6302"', f"radial_load = {mid[1:]}.0"]
    shutil.copyfile(d / "a500.uff", d / "c1500.uff")  # the copy-paste mistake: 1500 N holds the 500 N data
    lines += ["[[measurement]]", 'file = "c1500.uff"', 'bearing = "6302"', "radial_load = 1500.0"]
    (d / "campaign.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return d


def _same(row: dict) -> list[str]:
    return [w for w in row["warnings"] if w.startswith(SAME_CONTENT)]


def test_one_file_under_two_measurements_is_warned(copied_campaign: Path, tmp_path: Path) -> None:
    d = copied_campaign
    assert filecmp.cmp(d / "a500.uff", d / "c1500.uff", shallow=False)  # the oracle: the bytes are the same
    out = tmp_path / "out"
    result = run(d / "campaign.toml", out_dir=out)
    rows = {r["id"]: r for r in result.rows}
    assert all(r["status"] == "ok" for r in rows.values())
    # the copy's row shows the 500 N file's k_TB (within 1 %: the simulator's radial dynamics are the
    # 3DOF model's): a number for 1500 N that is not a 1500 N measurement, so it must carry a warning
    assert abs(rows["c1500"]["k_TB"] / K_TRUE["a500"] - 1) < 0.01
    for mid, other in (("a500", "c1500"), ("c1500", "a500")):
        (line,) = _same(rows[mid])
        assert repr(other) in line and "wrong file" in line, line
    assert _same(rows["b1000"]) == []
    # the table, the row's JSON and the report say it too
    csv_text = (out / "campaign.csv").read_text(encoding="utf-8")
    assert csv_text.count(SAME_CONTENT) == 2
    assert SAME_CONTENT in (out / "results" / "c1500.json").read_text(encoding="utf-8")
    report = (out / "report.html").read_text(encoding="utf-8")
    assert report.count(SAME_CONTENT) >= 2
    # the matched candidates carry the measured std (the table's ± f_H), headed "order spread" before
    assert "order spread" not in report and report.count("<th>± f measured [Hz]</th>") == 3
    assert f"<td>{std_text(rows['b1000']['housing_freq_std'])}</td>" in report
    # the notebook's table: both ± labelled as the report labels them, and the rows' warnings counted
    # (it showed one unlabelled ±, the total, and no warnings at all)
    table = result._repr_html_()
    assert "<th>± measured [MN/m]</th>" in table and "<th>± total [MN/m]</th>" in table
    cells = re.findall(r"<tr><td>c1500</td>(.*?)</tr>", table)[0]
    assert f"<td>{std_text(rows['c1500']['k_TB_std_measured'] / 1e6)}</td>" in cells
    assert f"<td>{len(rows['c1500']['warnings'])}</td><td>ok</td>" in cells

    # a re-run reuses the rows and keeps the line; once the copy is gone from the campaign, the
    # reused row of a500 drops it (a fact of the campaign, not of the cached computation)
    again = {r["id"]: r for r in run(d / "campaign.toml", out_dir=out).rows}
    assert _same(again["a500"]) == _same(rows["a500"])
    text = (d / "campaign.toml").read_text(encoding="utf-8")
    (d / "two.toml").write_text(text.split("[[measurement]]\nfile = \"c1500.uff\"")[0], encoding="utf-8")
    res = run(d / "two.toml", out_dir=out)
    assert res.reused == 2 and all(_same(r) == [] for r in res.rows)
    assert SAME_CONTENT not in (out / "results" / "a500.json").read_text(encoding="utf-8")


def test_same_conditions_called_no_independent_repeat(copied_campaign: Path, tmp_path: Path) -> None:
    d = copied_campaign
    text = (d / "campaign.toml").read_text(encoding="utf-8").replace("radial_load = 1500.0", "radial_load = 500.0")
    (d / "repeat.toml").write_text(text.replace("radial_load = 500.0\n[[measurement]]\nfile = \"c1500.uff\"",
                                                "radial_load = 500.0\n[[measurement]]\nfile = \"c1500.uff\"\nrepeat = 2"),
                                   encoding="utf-8")
    rows = {r["id"]: r for r in run(d / "repeat.toml").rows}
    (line,) = _same(rows["c1500"])
    assert "not an independent repeat" in line


@pytest.mark.parametrize(("std", "text"), [(0.004834, "0.0048"), (2.7366, "2.7"), (104.13, "104"),
                                           (0.00019, "0.00019"), (0.0996, "0.10"), (9.96, "10"), (0.0, "0")])
def test_std_text_two_significant_digits(std: float, text: str) -> None:
    assert std_text(std) == text


def test_small_uncertainty_not_printed_as_zero(rig_file: Path, tmp_path: Path,
                                               capsys: pytest.CaptureFixture[str]) -> None:
    """At 0.05 % noise the measured ± of k_TB is ~0.0002 MN/m: printed as 0.000 before."""
    import json

    from ema_rig.simulate import simulate_measurement, write_measurement

    rig = load_rig(rig_file)
    write_measurement(simulate_measurement(rig, k_tb=7.0e7, noise=0.0005, seed=5, extra_modes=False),
                      tmp_path / "m.uff", rig=rig)
    assert main(["stiffness", str(tmp_path / "m.uff"), "--rig", str(rig_file), "--no-spindle",
                 "--json", str(tmp_path / "m.json")]) == 0
    doc = json.loads((tmp_path / "m.json").read_text(encoding="utf-8"))
    line = next(s for s in capsys.readouterr().out.splitlines() if s.startswith("k_TB "))
    got = re.search(r"\+/- (\S+) \(measured\) \+/- (\S+) \(total\)", line)
    assert got is not None, line
    # two significant digits: the printed value within 5 % (half a unit of the second digit) of the JSON's
    for printed, key in zip(got.groups(), ("k_TB_std_measured", "k_TB_std"), strict=True):
        assert doc[key] > 0
        assert abs(float(printed) / (doc[key] / 1e6) - 1) <= 0.05, (line, key, doc[key])


def _row(load: float, speed: float, k: float, total: float, measured: float, f_h: float, repeat: int = 1) -> dict:
    """A campaign row whose measured ± holds a measured m_H term beside f_H (a trusted force chain)."""
    return {"id": f"{load:g}_{speed:g}_{repeat}", "bearing": "6302", "status": "ok", "radial_load": load,
            "speed": speed, "shaft_position": math.nan, "repeat": repeat, "k_TB": k, "k_TB_std": total,
            "k_TB_std_measured": measured,
            "detail": {"uncertainty_terms": [{"name": "f_H", "std": f_h},
                                             {"name": "m_H", "std": math.sqrt(measured**2 - f_h**2)},
                                             {"name": "k_MS", "std": math.sqrt(total**2 - measured**2)}]}}


def _half_bars(ax) -> list[float]:
    return [round(float(np.ptp(seg[:, 1])) / 2, 9) for c in ax.collections for seg in c.get_segments()]


def test_figures_show_the_tables_measured_and_total(tmp_path: Path) -> None:
    from ema_rig.plot.campaign import (
        measured_std,
        plot_k_vs_load,
        plot_repeatability,
        plot_rotating_vs_static,
        plot_speed_effect,
    )

    # total 2 MN/m (rig tolerances), measured 0.3 MN/m of which the f_H term is 0.1 MN/m
    rows = [_row(1000.0, 600.0, 7.0e7 + r * 1e5, 2e6, 3e5, 1e5, repeat=r) for r in (1, 2)]
    assert measured_std(rows[0]) == 3e5  # the table's "± measured", not the f_H term alone
    ax = plot_repeatability(rows).axes[0]
    # the grey bar: the mean measured ± in % of the repeats' mean, not the total's 2.86 %
    assert _half_bars(ax) == [round(100 * 3e5 / 7.015e7, 9)]  # repeats at 70.1 and 70.2 MN/m
    assert "measured" in ax.get_title()
    speed_rows = [_row(1000.0, s, 7.0e7, 2e6, 3e5, 1e5) for s in (600.0, 1200.0)]
    assert set(_half_bars(plot_speed_effect(speed_rows, "6302").axes[0])) == {0.3}
    static = [_row(1000.0, 0.0, 7.7e7, 2e6, 3e5, 1e5)]
    fig, change = plot_rotating_vs_static(speed_rows + static, "6302")
    assert set(_half_bars(fig.axes[0])) == {0.3} and "measured" in fig.axes[0].get_ylabel()
    assert change == pytest.approx(100 * (7.0 / 7.7 - 1))
    legend = [t.get_text() for t in plot_k_vs_load(rows, "6302").axes[0].get_legend().get_texts()]
    assert any("±1σ total" in t for t in legend), legend


def test_updated_code_is_not_served_from_the_cache(copied_campaign: Path, tmp_path: Path) -> None:
    """A re-run after an update that keeps the version number (every commit of a source tree or an
    editable install is 0.1.0) reused every row computed by the old code: the old k_TB, silently."""
    import json
    import os
    import subprocess
    import sys

    import ema_rig

    pkg = tmp_path / "site"
    shutil.copytree(Path(ema_rig.__file__).parent, pkg / "ema_rig", ignore=shutil.ignore_patterns("__pycache__"))
    d = copied_campaign
    (tmp_path / "one.toml").write_text(
        f'rig = "{(d / "rig.toml").as_posix()}"\n[defaults]\nmax_order = 24\n[output]\nmeasurement_figures = false\n'
        f'[[measurement]]\nfile = "{(d / "a500.uff").as_posix()}"\nbearing = "6302"\nradial_load = 500.0\n',
        encoding="utf-8")
    code = ("import json, sys; from ema_rig.campaign import run; r = run(sys.argv[1], out_dir=sys.argv[2], "
            "report=False); print(json.dumps([r.computed, r.rows[0]['k_TB']]))")
    env = {**os.environ, "PYTHONPATH": str(pkg), "OMP_NUM_THREADS": "1"}

    def campaign() -> tuple[int, float]:
        done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "one.toml"), str(tmp_path / "out")],
                              env=env, capture_output=True, text=True, check=True, cwd=tmp_path)
        computed, k_tb = json.loads(done.stdout.strip().splitlines()[-1])
        return int(computed), float(k_tb)

    first = campaign()
    assert first[0] == 1 and abs(first[1] / K_TRUE["a500"] - 1) < 0.01
    # the update: a stiffness that comes out twice as large (any change of the code that computes a row)
    with open(pkg / "ema_rig" / "rig" / "stiffness.py", "a", encoding="utf-8") as fh:
        fh.write("\n\n_old_estimate = estimate_stiffness\n\n\ndef estimate_stiffness(*args, **kwargs):  # type: ignore\n"
                 "    res = _old_estimate(*args, **kwargs)\n"
                 "    return replace(res, k_TB=2 * res.k_TB)\n")  # the module's own dataclasses.replace
    again = campaign()
    assert again[0] == 1  # computed again by the new code, not reused
    assert again[1] == pytest.approx(2 * first[1], rel=1e-12)  # the same data and settings through the new code


def test_failed_replay_names_the_selection_file(copied_campaign: Path, tmp_path: Path) -> None:
    """A selection from ``[defaults]`` that finds no mode: the error row named the data file only."""
    import json

    d = copied_campaign
    pole = complex(-0.02 * 2 * math.pi * 400.0, 2 * math.pi * 400.0 * math.sqrt(1 - 0.02**2))
    picks = tmp_path / "picks at 400 Hz.json"  # no mode of the simulated rig lies within 3 % of 400 Hz
    picks.write_text(json.dumps({"format": "ema_rig.selection/1", "band": [150.0, 1000.0], "max_order": 24,
                                 "modes": [{"order": 10, "index": 0, "pole": [pole.real, pole.imag],
                                            "natural_freq": 400.0, "damping_ratio": 0.02}]}), encoding="utf-8")
    (tmp_path / "c.toml").write_text(
        f'rig = "{(d / "rig.toml").as_posix()}"\n[defaults]\nmax_order = 24\nselection = "{picks.as_posix()}"\n'
        f'[[measurement]]\nfile = "{(d / "b1000.uff").as_posix()}"\nbearing = "6302"\nradial_load = 1000.0\n',
        encoding="utf-8")
    (row,) = run(tmp_path / "c.toml").rows
    assert row["status"] == "error" and "400 Hz" in row["error"]
    assert str(picks) in row["error"], row["error"]


def test_interrupted_rerun_leaves_no_stale_table(copied_campaign: Path, tmp_path: Path) -> None:
    """A re-run stopped after a measurement file was replaced kept the previous campaign.csv, with the
    replaced file's old k_TB (the report was removed, the table not)."""
    d = tmp_path / "c"
    shutil.copytree(copied_campaign, d)
    (d / "c.toml").write_text('rig = "rig.toml"\n[defaults]\nmax_order = 24\n[output]\nmeasurement_figures = false\n'
                              '[[measurement]]\nfile = "a500.uff"\nbearing = "6302"\nradial_load = 500.0\n'
                              '[[measurement]]\nfile = "b1000.uff"\nbearing = "6302"\nradial_load = 1000.0\n',
                              encoding="utf-8")
    out = tmp_path / "out"
    run(d / "c.toml", out_dir=out)
    assert (out / "campaign.csv").is_file() and (out / "report.html").is_file()
    shutil.copyfile(d / "b1000.uff", d / "a500.uff")  # the 500 N file replaced (a re-export, a fix)

    def stop(done: int, total: int) -> None:
        raise KeyboardInterrupt  # Ctrl-C as the first measurement of the re-run finishes

    with pytest.raises(KeyboardInterrupt):
        run(d / "c.toml", out_dir=out, progress=stop)
    assert not (out / "report.html").exists()
    assert not (out / "campaign.csv").exists()  # no table with the old file's k_TB
    # resumed: the table is the new one
    res = run(d / "c.toml", out_dir=out)
    assert res.rows[0]["k_TB"] == pytest.approx(res.rows[1]["k_TB"], rel=1e-12)  # the same bytes now
    assert "a500" in (out / "campaign.csv").read_text(encoding="utf-8")


def test_hand_pick_on_a_changed_file_is_warned(rig_file: Path, tmp_path: Path) -> None:
    """Poles picked by hand on a file, replayed after the file changed: replayed by the nearest mode
    with mode_source "replay" and no warning before, as if the picks had been found."""
    from ema_rig.identification import identify
    from ema_rig.identification.stabilization import Selection, select_poles
    from ema_rig.io.uff import read_uff58
    from ema_rig.rig.stiffness import estimate_stiffness
    from ema_rig.simulate import simulate_measurement, write_measurement

    rig = load_rig(rig_file)
    f = tmp_path / "m.uff"
    write_measurement(simulate_measurement(rig, k_tb=7.0e7, noise=0.01, seed=1, extra_modes=False), f, rig=rig)
    data = read_uff58(f, rig=rig)
    ident = identify(data, band=(150.0, 1000.0), max_order=40)
    # the user's picks: the automatic modes' representative poles, picked by hand on the chart
    picks = select_poles(ident.stabilization, [(m.order, m.index) for m in ident.selection.modes], source=str(f))
    picks = Selection.from_json(picks.to_json())  # saved and loaded, as the notebook and a campaign do

    same = estimate_stiffness(data, rig, selection=picks, max_order=40)
    assert same.mode_source == "pick" and not [w for w in same.warnings if "picked by hand" in w]
    # the file is replaced by another measurement of the same bearing (another noise draw)
    write_measurement(simulate_measurement(rig, k_tb=7.0e7, noise=0.01, seed=2, extra_modes=False), f, rig=rig)
    changed = estimate_stiffness(read_uff58(f, rig=rig), rig, selection=picks, max_order=40)
    assert changed.mode_source == "replay"
    assert [w for w in changed.warnings if "picked by hand on this file" in w], changed.warnings


def test_unreadable_moment_is_not_cached(copied_campaign: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """A file the worker could not read at that moment (EIO on a network share, EACCES, no memory) was
    cached as an error of the data: the next run reused it for the same bytes instead of reading them."""
    import errno
    import os
    import types

    import ema_rig.io.uff as uff

    d = copied_campaign
    (tmp_path / "c.toml").write_text(
        f'rig = "{(d / "rig.toml").as_posix()}"\n[defaults]\nmax_order = 24\n[output]\nmeasurement_figures = false\n'
        f'[[measurement]]\nfile = "{(d / "b1000.uff").as_posix()}"\nbearing = "6302"\nradial_load = 1000.0\n',
        encoding="utf-8")

    def failing_open(path, *args, **kwargs):  # the reader's open only: the runner's digest reads fine
        raise OSError(errno.EIO, os.strerror(errno.EIO), str(path))

    monkeypatch.setattr(uff, "os", types.SimpleNamespace(**{**vars(os), "open": failing_open}))
    out = tmp_path / "out"
    (row,) = run(tmp_path / "c.toml", out_dir=out, report=False).rows
    assert row["status"] == "error" and "Input/output error" in row["error"]
    monkeypatch.undo()
    again = run(tmp_path / "c.toml", out_dir=out, report=False)
    assert again.reused == 0 and again.rows[0]["status"] == "ok"  # read again, not the cached error
    assert again.rows[0]["k_TB"] == pytest.approx(K_TRUE["b1000"], rel=0.01)


@pytest.mark.parametrize(("typo", "key", "hint"), [
    ("radial_load = 500.0", "radial_laod = 500.0", "radial_load"),
    ("max_order = 24", "max_ordre = 24", "max_order"),
])
def test_misspelt_campaign_key_names_the_nearest(copied_campaign: Path, tmp_path: Path, typo: str, key: str,
                                                 hint: str) -> None:
    """A misspelt key was refused with the list of allowed keys only (a misspelt option got "did you mean")."""
    from ema_rig.campaign import load_campaign
    from ema_rig.errors import ConfigError

    text = (copied_campaign / "campaign.toml").read_text(encoding="utf-8").replace(typo, key, 1)
    (copied_campaign / "typo.toml").write_text(text, encoding="utf-8")
    with pytest.raises(ConfigError, match=f"unknown key; did you mean {hint}\\? allowed keys here are"):
        load_campaign(copied_campaign / "typo.toml")
