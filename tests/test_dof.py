"""DOF parsing and formatting."""

from __future__ import annotations

import pytest

from ema_rig.dof import DOF, as_dof


@pytest.mark.parametrize(
    ("text", "node", "code"),
    [("11+Y", 11, 2), ("13-Y", 13, -2), ("13Y-", 13, -2), ("7+rz", 7, 6), ("3-X", 3, -1), ("5", 5, 0)],
)
def test_parse(text: str, node: int, code: int) -> None:
    d = DOF.parse(text)
    assert (d.node, d.direction) == (node, code)


def test_round_trip_text_and_sign() -> None:
    d = DOF.parse("13-Y")
    assert str(d) == "13-Y"
    assert d.sign == -1 and d.axis == "Y"
    assert d.positive() == DOF(13, 2)
    assert as_dof((13, -2)) == d


@pytest.mark.parametrize("bad", ["", "Y+", "11+Q", "11++Y", "-1+Y"])
def test_parse_rejects(bad: str) -> None:
    with pytest.raises(ValueError, match="DOF"):
        DOF.parse(bad)


def test_code_range() -> None:
    with pytest.raises(ValueError, match="-6..6"):
        DOF(1, 7)
