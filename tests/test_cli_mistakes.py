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
