"""``ema-rig inspect``: the table, the §3.2 JSON, and one-line errors with exit code 1."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from ema_rig.cli import main
from ema_rig.frf import FRFData
from ema_rig.io.uff import write_uff58

KEYS = {"index", "type", "function_type", "response", "reference", "num_pts", "status", "reason"}


def _file(tmp_path: Path, *, binary: bool = False, outs=("11+Y", "13-Y"), name: str = "m.uff") -> Path:
    rng = np.random.default_rng(5)
    d = FRFData(np.arange(12) * 0.5, rng.standard_normal((len(outs), 1, 12)) + 0j, list(outs), ["11+Y"])
    p = tmp_path / name
    write_uff58(p, d, binary=binary)
    return p


def test_table_and_json(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = _file(tmp_path, binary=True)
    out_json = tmp_path / "sub" / "inspect.json"
    assert main(["inspect", str(p), "--json", str(out_json)]) == 0
    out = capsys.readouterr().out
    # one row per dataset with its DOFs, function type, points and band
    rows = [ln for ln in out.splitlines() if ln.split()[:1] in (["0"], ["1"])]
    assert len(rows) == 2
    assert rows[1].split()[:7] == ["1", "58b", "4", "FRF", "13-Y", "11+Y", "12"]
    assert "0..5.5" in rows[1] and rows[1].rstrip().endswith("read")
    rep = json.loads(out_json.read_text())
    assert rep["file"] == str(p)
    assert [set(d) >= KEYS for d in rep["datasets"]] == [True, True]
    d1 = rep["datasets"][1]
    assert (d1["type"], d1["function_type"], d1["response"], d1["reference"], d1["num_pts"], d1["status"],
            d1["reason"]) == (58, 4, "13-Y", "11+Y", 12, "read", None)
    assert rep["frf"]["out_dofs"] == ["11+Y", "13+Y"]  # assembled: 13-Y flipped into +Y
    assert not list(out_json.parent.glob(".*tmp*"))  # atomic write left no temporary file


def test_with_rig(tmp_path: Path, rig_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    outs = ("11+Y", "12+Y", "13-Y", "14+Z", "15+X", "21+Y", "22+Y", "23+X")
    rng = np.random.default_rng(2)
    d = FRFData(np.arange(6) * 1.0, rng.standard_normal((8, 2, 6)) + 0j, list(outs), ["11+Y", "15+X"])
    p = tmp_path / "rig.uff"
    write_uff58(p, d)
    assert main(["inspect", str(p), "--rig", str(rig_file), "--json", str(tmp_path / "r.json")]) == 0
    out = capsys.readouterr().out
    assert "13+Y (housing, radial)" in out and "23+X (spindle, axial)" in out
    rep = json.loads((tmp_path / "r.json").read_text())
    assert rep["frf"]["roles"][5] == "spindle" and rep["frf"]["shape"] == [8, 2, 6]


def _one_error_line(capsys: pytest.CaptureFixture[str], *words: str) -> None:
    err = capsys.readouterr().err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    assert "Traceback" not in err
    for w in words:
        assert w in lines[0], (w, lines[0])


def _corrupt(tmp_path: Path, kind: str) -> Path:
    if kind == "empty":
        p = tmp_path / "empty.uff"
        p.write_bytes(b"")
    elif kind == "not_uff":
        p = tmp_path / "log.txt"
        p.write_text("just some text\n1 2 3\n")
    elif kind in ("truncated_ascii", "truncated_binary"):
        p = _file(tmp_path, binary=kind.endswith("binary"))
        buf = p.read_bytes()
        p.write_bytes(buf[: len(buf) - 60])
    elif kind == "nan":
        p = _file(tmp_path)
        text = p.read_text().splitlines(keepends=True)
        text[13] = text[13][:20] + f"{'NaN':>20}" + text[13][40:]
        p.write_text("".join(text))
    elif kind == "duplicate":
        p = _file(tmp_path, outs=("13+Y", "13-Y"))  # FRFData allows both signs; the file then has a duplicate
    elif kind == "axes":
        a = _file(tmp_path, outs=("1+Y",), name="a.uff").read_bytes()
        d = FRFData(np.arange(12) * 0.51, np.ones((1, 1, 12), complex), ["2+Y"], ["11+Y"])
        write_uff58(tmp_path / "b.uff", d)
        p = tmp_path / "axes.uff"
        p.write_bytes(a + (tmp_path / "b.uff").read_bytes())
    else:
        raise AssertionError(kind)
    return p


@pytest.mark.parametrize(
    ("kind", "words"),
    [
        ("empty", ["empty.uff", "empty file"]),
        ("not_uff", ["log.txt", "not a UFF file"]),
        ("truncated_ascii", ["dataset 1", "truncated"]),
        ("truncated_binary", ["dataset 1", "truncated binary data"]),
        ("nan", ["dataset 0", "NaN"]),
        ("duplicate", ["dataset 1", "duplicate FRF 13+Y / 11+Y"]),
        ("axes", ["dataset 1", "frequency axis differs"]),
    ],
)
def test_bad_input_exit_1_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str], kind: str, words: list) -> None:
    p = _corrupt(tmp_path, kind)
    assert main(["inspect", str(p)]) == 1
    _one_error_line(capsys, str(p), *words)


def test_rig_dof_missing_exit_1(tmp_path: Path, rig_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = _file(tmp_path)  # only 11+Y and 13-Y: the rig's other sensors and its axial excitation are absent
    assert main(["inspect", str(p), "--rig", str(rig_file)]) == 1
    # the excitations are checked first (a wrong one drops every dataset): the missing one is named
    _one_error_line(capsys, "rig excitation 15+X", "is not a reference in the file (file references: 11+Y)")


def test_missing_file_exit_1(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["inspect", str(tmp_path / "none.uff")]) == 1
    _one_error_line(capsys, "none.uff", "file not found")


def test_a_dataset_with_an_unreadable_unit_label_is_refused_in_table_and_json(
        corpus_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """Review defect 6: the corpus file's ordinate label '(m/s≤)/N' (a mis-decoded '²') was listed as
    "read" with reason null, then the command exited 1 saying the values are not read. DESIGN §3.2:
    such a dataset is "refused" with the reason (and num_pts null), and inspect exits 1 (a refused dataset)."""
    out_json = tmp_path / "i.json"
    assert main(["inspect", str(corpus_dir / "ufffiles_frf_utf8unit.unv"), "--json", str(out_json)]) == 1
    out, err = capsys.readouterr()
    d = json.loads(out_json.read_text(encoding="utf-8"))["datasets"][0]
    assert d["status"] == "refused" and d["num_pts"] is None
    assert "ordinate unit label '(m/s≤)/N' not understood" in d["reason"]
    assert "refused: ordinate unit label" in out and "0 read, 1 refused" in out
    assert err.count("\n") == 1 and "refused: ordinate unit label" in err
