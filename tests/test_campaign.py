"""Campaigns: one row per measurement, partial failure, caching and restart, parallel executors."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from ema_rig.campaign import COLUMNS, load_campaign, run
from ema_rig.cli import EXIT_PARTIAL, main
from ema_rig.config import load_rig
from ema_rig.errors import ConfigError

K_TRUE = {"m200": 5.6e7, "m500": 6.4e7, "m1000": 7.2e7}  # N/m, a plausible Hertz-like rise


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory: pytest.TempPathFactory, rig_toml_text: str) -> Path:
    """Three simulated 6302 measurements (noise, extra modes), one corrupt file, a campaign file."""
    from ema_rig.simulate import simulate_measurement, write_measurement

    d = tmp_path_factory.mktemp("campaign")
    (d / "rig.toml").write_text(rig_toml_text, encoding="utf-8")
    rig = load_rig(d / "rig.toml")
    # the per-measurement report figures are tested in test_report_drilldown.py (they cost ~1 s each)
    lines = ['rig = "rig.toml"', 'title = "test campaign"', "[output]", "measurement_figures = false",
             "[bearings.6302]", "hertz = true"]
    for i, (mid, k) in enumerate(K_TRUE.items()):
        sim = simulate_measurement(rig, k_tb=k, noise=0.005, seed=10 + i, speed_hz=10.0)
        write_measurement(sim, d / f"{mid}.uff", binary=bool(i % 2), rig=rig)
        lines += ["[[measurement]]", f'file = "{mid}.uff"', 'bearing = "6302"',
                  f"radial_load = {mid[1:]}.0", "speed = 600.0", "repeat = 1"]
    (d / "broken.uff").write_text("this is not a UFF file\n", encoding="utf-8")
    lines += ["[[measurement]]", 'file = "broken.uff"', 'bearing = "6302"', "radial_load = 1500.0",
              "speed = 600.0"]
    (d / "campaign.toml").write_text("\n".join(lines) + "\n", encoding="utf-8")
    return d


def _ok_rows(result) -> dict[str, dict]:
    return {r["id"]: r for r in result.rows if r["status"] == "ok"}


@pytest.fixture(scope="module")
def first_run(campaign_dir: Path, tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("out")
    return run(campaign_dir / "campaign.toml", out_dir=out), out


def test_rows_truth_and_partial_failure(first_run) -> None:
    result, out = first_run
    assert [r["id"] for r in result.rows] == ["m200", "m500", "m1000", "broken"]
    ok = _ok_rows(result)
    assert set(ok) == set(K_TRUE)
    for mid, k in K_TRUE.items():
        # the simulator's radial dynamics are the 3DOF model's: k_TB within 1 % of the truth
        assert abs(ok[mid]["k_TB"] / k - 1) < 0.01, (mid, ok[mid]["k_TB"], k)
        assert ok[mid]["k_TB_std"] > 0
        # the measured part (identification) is part of the total, never more
        assert 0 < ok[mid]["k_TB_std_measured"] <= ok[mid]["k_TB_std"]
        assert isinstance(ok[mid]["warnings"], list)
    bad = result.rows[3]
    assert bad["status"] == "error" and "broken.uff" in bad["error"] and math.isnan(bad["k_TB"])
    assert result.n_failed == 1 and not result.ok
    # the outputs: table with every row, per-measurement JSON, figures, a self-contained report
    csv_lines = (out / "campaign.csv").read_text().splitlines()
    assert [h.split(" [")[0] for h in csv_lines[0].split(",")] == list(COLUMNS) and len(csv_lines) == 5
    assert "k_TB [N/m]" in csv_lines[0] and "speed [rpm]" in csv_lines[0] and "housing_damping [-]" in csv_lines[0]
    assert "k_TB_std_measured [N/m]" in csv_lines[0] and csv_lines[0].endswith(",warnings")
    assert {p.stem for p in (out / "results").glob("*.json")} == {"m200", "m500", "m1000", "broken"}
    html = (out / "report.html").read_text()
    assert "data:image/png;base64," in html and "broken.uff" in html and "src='http" not in html
    assert (out / "k_vs_load_6302.png").stat().st_size > 10_000


def test_cli_partial_failure_exit_code(campaign_dir: Path, first_run, capsys: pytest.CaptureFixture[str]) -> None:
    _, out = first_run
    code = main(["campaign", str(campaign_dir / "campaign.toml"), "-o", str(out)])
    captured = capsys.readouterr()
    assert code == EXIT_PARTIAL
    assert "partial failure" in captured.err and "Traceback" not in captured.err
    assert "m1000" in captured.out


def test_restart_recomputes_only_missing(campaign_dir: Path, first_run, tmp_path: Path) -> None:
    reference, _ = first_run
    out = tmp_path / "out"

    def die_after_two(done: int, total: int) -> None:
        if done == 2:
            raise KeyboardInterrupt  # the run is killed after two measurements finished

    with pytest.raises(KeyboardInterrupt):
        run(campaign_dir / "campaign.toml", out_dir=out, progress=die_after_two)
    assert len(list((out / "results").glob("*.json"))) == 2
    again = run(campaign_dir / "campaign.toml", out_dir=out)
    assert (again.computed, again.reused) == (2, 2)
    for a, b in zip(again.rows, reference.rows, strict=True):
        assert a["status"] == b["status"]
        if a["status"] == "ok":
            assert a["k_TB"] == pytest.approx(b["k_TB"], rel=1e-12)  # same input, same answer
    # unchanged inputs: nothing recomputed; --force recomputes everything
    assert run(campaign_dir / "campaign.toml", out_dir=out, report=False).computed == 0
    assert run(campaign_dir / "campaign.toml", out_dir=out, force=True, report=False).computed == 4


def test_changed_file_is_recomputed(campaign_dir: Path, tmp_path: Path) -> None:
    import shutil

    d = tmp_path / "c"
    shutil.copytree(campaign_dir, d)
    out = tmp_path / "out"
    run(d / "campaign.toml", out_dir=out, report=False)
    (d / "broken.uff").write_text("still not a UFF file, but different\n", encoding="utf-8")
    res = run(d / "campaign.toml", out_dir=out, report=False)
    assert (res.computed, res.reused) == (1, 3)


def test_parallel_jobs_match_serial(campaign_dir: Path, first_run, tmp_path: Path) -> None:
    reference, ref_out = first_run
    # --jobs 2 with the outputs: measurements in the pool (longest first), table, figures and
    # report written by the output process
    par = run(campaign_dir / "campaign.toml", out_dir=tmp_path, jobs=2)
    numeric = ("k_TB", "k_TB_std", "k_TB_MS", "k_MS", "housing_freq", "housing_freq_std", "housing_damping")
    for a, b in zip(par.rows, reference.rows, strict=True):
        assert a["id"] == b["id"] and a["status"] == b["status"] and a["error"] == b["error"]
        if a["status"] == "ok":
            # the same computation on one BLAS thread in another process: the same bits
            assert [a[k] for k in numeric] == [b[k] for k in numeric], a["id"]
    assert sorted(par.files) == sorted(reference.files)
    assert all(p.parent == tmp_path and p.stat().st_size > 0 for p in par.files.values())
    def table(folder: Path) -> list[list[str]]:  # the CSV without the run time column
        lines = [line.split(",") for line in (folder / "campaign.csv").read_text().splitlines()]
        col = next(i for i, h in enumerate(lines[0]) if h.startswith("elapsed_s"))
        return [cells[:col] + cells[col + 1:] for cells in lines]

    assert table(tmp_path) == table(ref_out)
    assert "data:image/png;base64," in (tmp_path / "report.html").read_text()


def test_dask_distributed_executor(campaign_dir: Path, first_run) -> None:
    distributed = pytest.importorskip("distributed")
    reference, _ = first_run
    # dashboard on a free port: None means the default 8787, and a taken 8787 failed the test
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as cluster, distributed.Client(cluster) as client:
        res = run(campaign_dir / "campaign.toml", executor=client.get_executor(), report=False)
    assert _ok_rows(res).keys() == _ok_rows(reference).keys()
    for mid, r in _ok_rows(res).items():
        assert r["k_TB"] == pytest.approx(_ok_rows(reference)[mid]["k_TB"], rel=1e-9)


def test_dataframe(first_run) -> None:
    pytest.importorskip("pandas")
    result, _ = first_run
    df = result.to_dataframe()
    assert list(df.columns) == list(COLUMNS) and len(df) == 4
    assert df.loc[df["id"] == "m500", "k_TB"].item() == pytest.approx(_ok_rows(result)["m500"]["k_TB"])


@pytest.mark.parametrize(
    ("extra", "key"),
    [("colour = 1\n", "colour"), ("[[measurement]]\nfile = 'x.uff'\nspeeed = 3\n", "speeed")],
)
def test_config_errors_name_the_key(campaign_dir: Path, tmp_path: Path, extra: str, key: str) -> None:
    text = (campaign_dir / "campaign.toml").read_text()
    bad = tmp_path / "bad.toml"
    (tmp_path / "rig.toml").write_text((campaign_dir / "rig.toml").read_text())
    bad.write_text(extra + text if not extra.startswith("[[") else text + extra, encoding="utf-8")
    with pytest.raises(ConfigError, match=key):
        load_campaign(bad)


def test_duplicate_ids_rejected(campaign_dir: Path, tmp_path: Path) -> None:
    (tmp_path / "rig.toml").write_text((campaign_dir / "rig.toml").read_text())
    text = 'rig = "rig.toml"\n' + "[[measurement]]\nfile = 'a.uff'\n" * 2
    (tmp_path / "c.toml").write_text(text)
    with pytest.raises(ConfigError, match="duplicate measurement id"):
        load_campaign(tmp_path / "c.toml")


def test_results_json_is_strict(first_run) -> None:
    _, out = first_run
    doc = json.loads((out / "results" / "broken.json").read_text())
    assert doc["status"] == "error" and doc["k_TB"] is None  # NaN written as null, valid JSON


def test_pool_gets_the_longest_measurement_first(campaign_dir: Path, first_run, tmp_path: Path) -> None:
    import shutil
    from concurrent.futures import ThreadPoolExecutor

    _, ref_out = first_run
    out = tmp_path / "out"
    shutil.copytree(ref_out / "results", out / "results")
    slow = out / "results" / "m500.json"
    doc = json.loads(slow.read_text())
    slow.write_text(json.dumps({**doc, "elapsed_s": 100.0}))  # took longest last time

    submitted: list[str] = []

    class Recording(ThreadPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):  # type: ignore[no-untyped-def, override]
            submitted.append(Path(args[0].file).stem)
            return super().submit(fn, *args, **kwargs)

    with Recording(max_workers=1) as ex:
        res = run(campaign_dir / "campaign.toml", out_dir=out, executor=ex, force=True, report=False)
    assert res.computed == 4 and submitted[0] == "m500"
    # the others by their previous time: the broken file failed at once, so it comes last
    assert submitted[-1] == "broken"


def test_parallel_output_error_reaches_the_caller(campaign_dir: Path, tmp_path: Path,
                                                  monkeypatch: pytest.MonkeyPatch) -> None:
    from ema_rig import _atomic
    from ema_rig.errors import EmaRigError

    (tmp_path / "report.html").mkdir()  # the report cannot replace a folder
    with pytest.raises(EmaRigError, match="report.html names a folder"):  # refused before the run
        run(campaign_dir / "campaign.toml", out_dir=tmp_path, jobs=2)
    assert not (tmp_path / "results").exists()
    # without that check, the write error after the pool drew the measurements' figures reaches the caller
    monkeypatch.setattr(_atomic, "check_output_path", lambda *a, **k: None)
    with pytest.raises(OSError) as info:
        run(campaign_dir / "campaign.toml", out_dir=tmp_path, jobs=2)
    assert "report.html" in str(info.value)
