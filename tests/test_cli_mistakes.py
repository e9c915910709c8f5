"""Typical command-line mistakes get the answer a test engineer needs (issue 20): the sub-command's own
usage with the nearest option, and ema_rig's TOML files given in the wrong place named as such."""

from __future__ import annotations

from pathlib import Path

import pytest

from ema_rig.cli import main

DATA = Path(__file__).resolve().parents[1] / "data"


def test_misspelt_option_gives_the_subcommands_usage_and_did_you_mean(capsys):
    code = main(["stiffness", str(DATA / "b6302_1000N_600rpm.uff"), "--rig", str(DATA / "rig.toml"),
                 "--bnad", "150", "1000"])
    err = capsys.readouterr().err
    assert code == 2
    assert err.startswith("usage: ema-rig stiffness ")  # not the top-level usage
    assert "--bnad (did you mean --band?)" in err and "Traceback" not in err


def test_misspelt_command(capsys):
    assert main(["stifness", "x.uff"]) == 2
    assert "unknown command 'stifness' (did you mean stiffness?)" in capsys.readouterr().err


def test_toml_files_in_the_wrong_place_are_named(capsys):
    cases = [
        (["modes", str(DATA / "campaign.toml")], "it is a campaign file (TOML); run it with 'ema-rig campaign FILE'"),
        (["inspect", str(DATA / "rig.toml")], "it is a rig file (TOML); give it as '--rig FILE'"),
        (["stiffness", str(DATA / "b6302_1000N_600rpm.uff"), "--rig", str(DATA / "campaign.toml")],
         "this is a campaign file, not a rig file: run it with 'ema-rig campaign FILE'"),
        (["campaign", str(DATA / "rig.toml"), "-o", "/nonexistent/never-written"],
         "this is a rig file, not a campaign file"),
    ]
    for argv, text in cases:
        assert main(argv) == 1, argv
        err = capsys.readouterr().err
        assert err.count("\n") == 1 and text in err and err.startswith("error: "), (argv, err)


@pytest.mark.parametrize("command", ["campaign", "rig"])
def test_a_uff_file_given_as_toml_is_named_as_such(command: str, capsys: pytest.CaptureFixture[str]) -> None:
    """A measurement given where a campaign or rig file belongs is named a UFF file, with the commands
    that take it (it read "invalid TOML: Expected '='" before, or "not UTF-8 text" for a binary UFF)."""
    uff = str(DATA / "b6302_1000N_1200rpm.uff")
    argv = ["campaign", uff] if command == "campaign" else ["modes", uff, "--rig", uff]
    assert main(argv) == 1
    err = capsys.readouterr().err
    assert "is a UFF file (a measurement), not a TOML file" in err and "ema-rig modes" in err
    assert "Traceback" not in err


@pytest.mark.filterwarnings("ignore:.*is not an excitation of the rig file")  # the per-dataset warning
def test_a_wrong_excitation_in_the_rig_file_is_named_with_the_files_references(tmp_path, capsys):
    """Review defect 7: a rig whose excitation is not the file's reference dropped every dataset, and
    the error then blamed the first sensor ("has no FRF in the file (file responses: none)") although
    the file holds it; the error names the excitation and lists the file's references."""
    rig = tmp_path / "rig.toml"
    rig.write_text((DATA / "rig.toml").read_text(encoding="utf-8").replace('radial = "11+Y"', 'radial = "3+Z"'),
                   encoding="utf-8")
    assert main(["modes", str(DATA / "b6302_1000N_600rpm.uff"), "--rig", str(rig)]) == 1
    err = capsys.readouterr().err.splitlines()[-1]
    assert err.startswith("error: ") and "rig excitation 3+Z" in err, err
    assert "(file references: 11+Y)" in err and "has no FRF" not in err, err


def test_a_low_max_order_is_blamed_on_the_cap_not_the_measurement(real_frf_dir, capsys):
    """Review defect 9: with --max-order 3 the real rig file has no stable pole, while the default order
    finds its modes (test_real_bands); the refusal said "the measurement itself is suspect: coherence ...".
    It now says the cap may be too low and to raise --max-order."""
    assert main(["modes", str(real_frf_dir / "vt_case1_full.uff"), "--max-order", "3"]) == 1
    err = capsys.readouterr().err.splitlines()[-1]
    assert "no stable pole" in err and "the order cap may be too low: --max-order 3" in err, err
    assert "raise it" in err and "suspect" not in err, err


def test_a_too_narrow_band_is_blamed_on_the_band_not_the_measurement(real_frf_dir, capsys):
    """Smoke review (benchmarks/results/smoke_b1a9ba2.txt, part C): --band 100 100.3 on vt_case1 (0.3125 Hz lines)
    said "only 1 frequency lines in the band; need at least 8; the measurement itself is suspect: coherence ...".
    The data hold 1601 lines: the band is what is wrong, and the line says how to mend it."""
    assert main(["modes", str(real_frf_dir / "vt_case1_full.uff"), "--band", "100", "100.3"]) == 1
    err = capsys.readouterr().err.splitlines()[-1]
    assert "only 1 frequency lines in the band 100..100.3 Hz" in err and "widen the band" in err, err
    assert "suspect" not in err, err
