"""The campaign report's drill-down (a section per measurement), CSV units, and no rewrite on a cached re-run."""

from __future__ import annotations

import csv
import re
import shutil
from pathlib import Path

import pytest
from _campaigns import simulated_6302_campaign

from ema_rig.campaign import load_campaign, run
from ema_rig.config import load_rig
from ema_rig.errors import ConfigError

K_TRUE = {"m300": 5.9e7, "m900": 7.0e7}  # N/m


@pytest.fixture(scope="module")
def campaign_dir(tmp_path_factory: pytest.TempPathFactory, rig_toml_text: str) -> Path:
    """Two simulated 6302 measurements and a corrupt file, per-measurement figures on (the default)."""
    return simulated_6302_campaign(tmp_path_factory.mktemp("drill"), rig_toml_text, K_TRUE, seed=30, broken=True)


@pytest.fixture(scope="module")
def first(campaign_dir: Path, tmp_path_factory: pytest.TempPathFactory):
    out = tmp_path_factory.mktemp("out")
    return run(campaign_dir / "campaign.toml", out_dir=out), out


def _mtimes(folder: Path) -> dict[str, int]:
    return {str(p.relative_to(folder)): p.stat().st_mtime_ns for p in folder.rglob("*")
            if p.is_file() and p.name != ".ema-rig.lock"}


def test_every_row_links_to_its_section(first) -> None:
    result, out = first
    html = (out / "report.html").read_text(encoding="utf-8")
    assert "src='http" not in html and 'src="http' not in html and "<link" not in html  # one self-contained file
    for i, r in enumerate(result.rows):
        assert f"<a href='#meas-{i + 1}'>{r['id']}</a>" in html  # the row's link ...
        start = html.index(f"<section class='meas' id='meas-{i + 1}'>")  # ... to its own section
        section = html[start:html.index("</section>", start)]
        assert f"<h3>{r['id']}</h3>" in section
        if r["status"] == "ok":
            # stabilization chart, measured vs 3DOF model, measured vs synthesised: three embedded images
            assert section.count("data:image/png;base64,") == 3
            for kind in ("stabilization", "model", "synthesis"):
                assert (out / "measurements" / f"{r['id']}.{kind}.png").stat().st_size > 5_000
            # the candidate table, with the housing mode's verdict and the rejected modes' reasons
            assert "<table class='cand'>" in section and ">housing<" in section and ">rejected<" in section
            assert f"{r['housing_freq']:.2f}" in section
            # and the identification's clusters of stable poles with theirs
            assert "Identification: every cluster" in section and ">physical<" in section
        else:
            assert "not a UFF file" in section and "data:image" not in section
    # the per-measurement PNGs are small: the whole report stays well below 1 MB per measurement
    assert len(html) < 400_000 * len(result.rows)


def test_cached_rerun_rewrites_nothing(first, tmp_path: Path) -> None:
    _, out0 = first
    out = tmp_path / "out"
    shutil.copytree(out0, out)
    before = _mtimes(out)
    again = run(load_campaign(first[0].config.path), out_dir=out)
    assert (again.reused, again.computed) == (3, 0)  # the broken file's data error is cached too
    assert _mtimes(out) == before  # no figure, table, settings or report written again


def test_changed_measurement_redraws_only_its_figures(campaign_dir: Path, first, tmp_path: Path) -> None:
    _, out0 = first
    d = tmp_path / "c"
    shutil.copytree(campaign_dir, d)
    out = tmp_path / "out"
    shutil.copytree(out0, out)
    before = _mtimes(out)
    # m900 measured again (another noise draw); m300 unchanged
    from ema_rig.simulate import simulate_measurement, write_measurement

    rig = load_rig(d / "rig.toml")
    write_measurement(simulate_measurement(rig, k_tb=K_TRUE["m900"], noise=0.005, seed=99), d / "m900.uff", rig=rig)
    # and the broken measurement removed from the campaign: its section goes, nothing else
    text = (d / "campaign.toml").read_text(encoding="utf-8")
    (d / "campaign.toml").write_text(text[:text.rindex("[[measurement]]")], encoding="utf-8")
    res = run(d / "campaign.toml", out_dir=out)
    assert res.computed == 1 and res.reused == 1
    after = _mtimes(out)
    changed = {k for k in after if after[k] != before.get(k)}
    assert {f"measurements/m900.{k}.png" for k in ("stabilization", "model", "synthesis")} <= changed
    assert not any(k.startswith("measurements/m300") for k in changed)
    assert "report.html" in changed and "campaign.csv" in changed
    assert "meas-3" not in (out / "report.html").read_text(encoding="utf-8")


def test_csv_units_header_and_display_units(first) -> None:
    result, out = first
    rows = list(csv.DictReader((out / "campaign.csv").read_text(encoding="utf-8").splitlines()))
    assert {"k_TB [N/m]", "k_TB_std [N/m]", "speed [rpm]", "radial_load [N]", "housing_freq [Hz]",
            "housing_damping [-]"} <= set(rows[0])
    ok = [r for r in result.rows if r["status"] == "ok"]
    for unit in ("MN/m", "N/µm"):
        disp = list(csv.DictReader(result.to_csv(stiffness_unit=unit, damping_unit="%").splitlines()))
        for r, d in zip(ok, disp, strict=False):
            # 1 MN/m = 1 N/µm = 1e6 N/m; damping in percent: a pure rescaling (float round-off only)
            assert float(d[f"k_TB [{unit}]"]) == pytest.approx(r["k_TB"] / 1e6, rel=1e-12)
            assert float(d["housing_damping [%]"]) == pytest.approx(100 * r["housing_damping"], rel=1e-12)
    with pytest.raises(ValueError, match="stiffness unit"):
        result.to_csv(stiffness_unit="kN/mm")


def test_output_units_in_the_campaign_file(campaign_dir: Path, tmp_path: Path) -> None:
    d = tmp_path / "c"
    shutil.copytree(campaign_dir, d)
    text = (d / "campaign.toml").read_text(encoding="utf-8")
    cfg_text = 'rig = "rig.toml"\n[output]\nstiffness_unit = "MN/m"\ndamping_unit = "%"\n' + text.split("\n", 1)[1]
    (d / "campaign.toml").write_text(cfg_text, encoding="utf-8")
    cfg = load_campaign(d / "campaign.toml")
    assert (cfg.stiffness_unit, cfg.damping_unit) == ("MN/m", "%")
    (d / "campaign.toml").write_text(cfg_text.replace('"MN/m"', '"kN/mm"'), encoding="utf-8")
    with pytest.raises(ConfigError, match=re.escape("output.stiffness_unit")):
        load_campaign(d / "campaign.toml")


def test_result_repr_is_short(first) -> None:
    result, _ = first
    text = repr(result)
    assert len(text) < 300 and "3 measurements, 1 failed" in text  # not the rows (kB of text)
    html = result._repr_html_()
    assert html.count("<tr>") == 1 + len(result.rows) and "not a UFF file" in html
