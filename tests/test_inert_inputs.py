"""Issue 17: text from files is inert, numeric keys are range-checked at load, clearer messages.

Everything is generated in ``tmp_path``; the campaign tests reuse the cheap simulated campaign of
``test_campaign_faults`` (its ``small`` fixture).
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import pytest
from test_campaign_faults import HEAD, K_TB, _copy, small  # noqa: F401 - the fixture

from ema_rig._text import csv_cell, inert
from ema_rig.campaign import load_campaign, run
from ema_rig.cli import main
from ema_rig.errors import ConfigError

ESC, RLO, LRI, PDI = "\x1b", "\u202e", "\u2066", "\u2069"
HOSTILE = f"6302{ESC}]0;pwned\x07{ESC}[2J{RLO}gnp.exe{PDI}"


def _toml(text: str) -> str:
    """``text`` as a TOML basic string (control and non-ASCII characters as \\UXXXXXXXX escapes)."""
    body = "".join(c if (" " <= c < "\x7f" and c not in '"\\') else f"\\U{ord(c):08x}" for c in text)
    return f'"{body}"'


# ------------------------------------------------------------------------------------ the helpers
@pytest.mark.parametrize("ch", ["\x00", "\x07", ESC, "\x7f", "\x9b", "\u2028", "\u061c", "\u200e", "\u200f",
                                *(chr(c) for c in range(0x202A, 0x202F)), *(chr(c) for c in range(0x2066, 0x206A))])
def test_inert_escapes_controls_and_bidi(ch: str) -> None:
    out = inert(f"a{ch}b")
    assert ch not in out and out.startswith("a\\") and out.endswith("b")


def test_inert_keeps_ordinary_text() -> None:
    family = "\U0001f468\u200d\U0001f469\u200d\U0001f467"  # a ZWJ emoji sequence is not a control
    for text in ("6302 radial", "Lager µ-Prüfung", "軸受", "عربي", family, "x\ty"):
        assert inert(text, keep="\t") == text


@pytest.mark.parametrize(("cell", "quoted"), [
    ("=HYPERLINK(\"http://x\",\"y\")", True), ("+1+2", True), ("-2+3", True), ("@SUM(A1)", True),
    ("\t=1", True), ("\r=1", True), ("-1.5", False), ("+2e6", False), ("-3", False), ("6302", False),
    ("a=b", False),
])
def test_csv_cells_never_formulas(cell: str, quoted: bool) -> None:
    out = csv_cell(cell)
    assert out.startswith("'") == quoted, out
    assert csv_cell(-1.5) == -1.5 and csv_cell(3) == 3 and math.isnan(csv_cell(math.nan))


# --------------------------------------------------------------------- terminal, report and table
def test_hostile_names_inert_on_terminal_report_and_csv(small: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    d = _copy(small, tmp_path / "c")
    text = (d / "campaign.toml").read_text().replace("bearing = '6302'", 'bearing = "=cmd|calc!A1"', 1)
    text = text.replace("bearing = '6302'", f"bearing = {_toml(HOSTILE)}", 1)
    text = text.replace('rig = "rig.toml"', f'rig = "rig.toml"\ntitle = {_toml(f"Lab {RLO}gnp.exe {ESC}[31mred")}', 1)
    (d / "campaign.toml").write_text(text, encoding="utf-8")
    out = tmp_path / "out"
    assert main(["campaign", str(d / "campaign.toml"), "-o", str(out)]) == 0
    printed = capsys.readouterr()
    for stream in (printed.out, printed.err):
        assert ESC not in stream and RLO not in stream and PDI not in stream and "\x07" not in stream
    assert "6302\\x1b]0;pwned\\x07" in printed.out  # shown, escaped, not hidden
    html = (out / "report.html").read_text(encoding="utf-8")
    assert RLO not in html and ESC not in html and "\\u202e" in html
    assert "<h1>Lab \\u202egnp.exe \\x1b[31mred</h1>" in html
    raw = (out / "campaign.csv").read_text(encoding="utf-8")
    assert ESC not in raw and RLO not in raw
    rows = list(csv.DictReader(io.StringIO(raw)))
    assert rows[0]["bearing"] == "'=cmd|calc!A1"  # text, not a formula
    assert all(not r[k].startswith(("=", "+", "@")) for r in rows for k in r)
    # numbers stay numbers: every k_TB cell parses
    assert all(float(r["k_TB [N/m]"]) > 0 for r in rows)


def test_file_names_inert_on_inspect(small: Path, tmp_path: Path, capsys) -> None:  # noqa: F811
    f = tmp_path / f"a{ESC}[2J{RLO}b.uff"
    f.write_bytes((small / "m1.uff").read_bytes())
    assert main(["inspect", str(f)]) == 0
    printed = capsys.readouterr()
    assert ESC not in printed.out + printed.err and RLO not in printed.out + printed.err
    assert "a\\x1b[2J\\u202eb.uff" in printed.out


# ------------------------------------------------------------------- range checks at load time
_GEOM = "[bearings.6302]\nn_balls = 7\nball_diameter = 7.938e-3\npitch_diameter = 28.5e-3\n{extra}\n"


@pytest.mark.parametrize(("extra", "key", "words"), [
    ("clearance = 5e-324", "clearance", "outside the plausible range 0 or [1e-09, 0.001] m"),
    ("clearance = -1e-6", "clearance", ">= 0"),
    ("clearance = nan", "clearance", "finite"),
    ("youngs_modulus = 1e308", "youngs_modulus", "outside the plausible range"),
    ("youngs_modulus = 1e-300", "youngs_modulus", "outside the plausible range"),
    ("youngs_modulus = inf", "youngs_modulus", "finite"),
    ("youngs_modulus = -208e9", "youngs_modulus", "positive"),
    ("ball_youngs_modulus = 310", "ball_youngs_modulus", "Ashby"),
    ("inner_conformity = 1e300", "inner_conformity", "Harris"),
    ("outer_conformity = 0.5", "outer_conformity", "outside"),
    ("poisson_ratio = 0.7", "poisson_ratio", "[0, 0.5)"),
])
def test_bearing_geometry_range_checked_at_load(small: Path, tmp_path: Path, extra: str, key: str,  # noqa: F811
                                                words: str) -> None:
    # was: accepted, then ZeroDivisionError in the Hertz curve after every measurement had run
    d = _copy(small, tmp_path / "c")
    text = (d / "campaign.toml").read_text().replace("[defaults]", _GEOM.format(extra=extra) + "[defaults]")
    (d / "campaign.toml").write_text(text)
    with pytest.raises(ConfigError) as info:
        load_campaign(d / "campaign.toml")
    msg = str(info.value)
    assert msg.startswith(str(d / "campaign.toml")) and f"bearings.6302.{key}" in msg and words in msg, msg


def test_plausible_geometry_and_hertz_curve_drawn(small: Path, tmp_path: Path) -> None:  # noqa: F811
    d = _copy(small, tmp_path / "c")
    extra = "clearance = 10e-6\nyoungs_modulus = 208e9\nball_youngs_modulus = 310e9\nball_poisson_ratio = 0.26"
    text = (d / "campaign.toml").read_text().replace("[defaults]", _GEOM.format(extra=extra) + "[defaults]")
    (d / "campaign.toml").write_text(text)
    cfg = load_campaign(d / "campaign.toml")
    assert cfg.bearings["6302"].geometry.clearance == 10e-6
    res = run(cfg, out_dir=tmp_path / "out")
    assert res.ok and (tmp_path / "out" / "k_vs_load_6302.png").stat().st_size > 10_000


# --------------------------------------------------------------------------- clearer messages
def test_greek_mu_is_the_micro_sign(small: Path, tmp_path: Path) -> None:  # noqa: F811
    d = _copy(small, tmp_path / "c")
    out = {}
    for name, unit in (("micro", "N/\u00b5m"), ("greek", "N/\u03bcm")):
        text = (d / "campaign.toml").read_text()
        (d / f"{name}.toml").write_text(text.replace("[output]", f'[output]\nstiffness_unit = "{unit}"'))
        cfg = load_campaign(d / f"{name}.toml")
        assert cfg.stiffness_unit == "N/\u00b5m"
        out[name] = cfg
    res = run(out["greek"], report=False)
    assert "k_TB [N/\u00b5m]" in res.to_csv() and res.to_csv(stiffness_unit="N/\u03bcm") == res.to_csv()


@pytest.mark.parametrize(("mid", "words"), [
    ("\U0001f468\u200d\U0001f469", "U+200D ZERO WIDTH JOINER"),
    ("a\u202eb", "U+202E RIGHT-TO-LEFT OVERRIDE"),
    ("a\x1bb", "a control character, U+001B"),
])
def test_id_with_an_invisible_character_named(small: Path, tmp_path: Path, mid: str, words: str) -> None:  # noqa: F811
    d = _copy(small, tmp_path / "c")
    (d / "campaign.toml").write_text(HEAD + f'[[measurement]]\nfile = "m1.uff"\nid = {_toml(mid)}\n', encoding="utf-8")
    with pytest.raises(ConfigError) as info:
        load_campaign(d / "campaign.toml")
    msg = str(info.value)
    assert words in msg and ("control character" in msg) == ("\x1b" in mid), msg


def test_k_tb_values_unchanged_by_inert_cells(small: Path) -> None:  # noqa: F811
    res = run(small / "campaign.toml", report=False)
    rows = list(csv.DictReader(io.StringIO(res.to_csv())))
    for r in rows:
        assert float(r["k_TB [N/m]"]) == pytest.approx(K_TB[r["id"]], rel=0.01)


@pytest.mark.parametrize(("old", "new", "key"), [
    ("m_H = 2.566", "m_H = 1e-300", "model.m_H"),
    ("k_S = 348e6", "k_S = 1e308", "model.k_S"),
    ("k_B = 180e3", "k_B = 5e-324", "model.k_B"),
])
def test_rig_model_range_checked_at_load(small: Path, tmp_path: Path, old: str, new: str, key: str) -> None:  # noqa: F811
    from ema_rig.config import load_rig

    d = _copy(small, tmp_path / "c")
    text = (d / "rig.toml").read_text()
    assert old in text
    (d / "rig.toml").write_text(text.replace(old, new))
    with pytest.raises(ConfigError) as info:
        load_rig(d / "rig.toml")
    assert str(info.value).startswith(str(d / "rig.toml")) and key in str(info.value) and "plausible" in str(info.value)


@pytest.mark.parametrize(("field", "value"), [("radial_load", "1e308"), ("speed", "1e300")])
def test_conditions_range_checked_at_load(small: Path, tmp_path: Path, field: str, value: str) -> None:  # noqa: F811
    d = _copy(small, tmp_path / "c")
    text = (d / "campaign.toml").read_text()
    old = "radial_load = 200.0" if field == "radial_load" else "speed = 600.0"
    (d / "campaign.toml").write_text(text.replace(old, f"{field} = {value}", 1))
    with pytest.raises(ConfigError, match=rf"measurement\[0\]\.{field}.*plausible"):
        load_campaign(d / "campaign.toml")
