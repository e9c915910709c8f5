"""Degrees of freedom: a node number and a signed direction.

A DOF is written as ``"11+Y"`` or ``"13-Y"`` (node 13, measuring along -Y). UFF dataset 58
stores the direction as a signed integer code: 1..6 = X, Y, Z, RX, RY, RZ, 0 = scalar; a negative
code is the same axis with the opposite sign.

Classes
-------
DOF
    Frozen (node, direction) pair with parsing and formatting.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

AXIS_NAMES: tuple[str, ...] = ("S", "X", "Y", "Z", "RX", "RY", "RZ")
"""Names of the UFF direction codes 0..6 (``S`` = scalar, no direction)."""

_DOF_RE = re.compile(r"^\s*(\d+)\s*(?:([+-])\s*(RX|RY|RZ|X|Y|Z)|(RX|RY|RZ|X|Y|Z)\s*([+-])|([+-])?\s*(S))?\s*$", re.I)


@dataclass(frozen=True, slots=True, order=True)
class DOF:
    """A measurement degree of freedom.

    Parameters
    ----------
    node : int
        Node (point) number, >= 0.
    direction : int
        Signed UFF direction code in -6..6 (0 = scalar).

    Examples
    --------
    >>> DOF.parse("13-Y")
    DOF('13-Y')
    >>> DOF.parse("13-Y").positive()
    DOF('13+Y')
    >>> DOF(13, -2).sign, DOF(13, -2).axis
    (-1, 'Y')
    """

    node: int
    direction: int

    def __post_init__(self) -> None:
        if isinstance(self.node, bool) or not isinstance(self.node, int) or self.node < 0:
            raise ValueError(f"DOF node must be a non-negative integer, got {self.node!r}")
        if isinstance(self.direction, bool) or not isinstance(self.direction, int):
            raise TypeError(f"DOF direction must be an integer code -6..6, got {self.direction!r}")
        if not -6 <= self.direction <= 6:
            raise ValueError(
                f"DOF direction code must be in -6..6 (1..6 = X, Y, Z, RX, RY, RZ), got {self.direction}"
            )

    @classmethod
    def parse(cls, text: str | DOF) -> DOF:
        """Parse ``"11+Y"``, ``"11Y+"``, ``"11-RZ"`` or ``"11"`` (scalar) into a DOF.

        Parameters
        ----------
        text : str or DOF
            DOF text, case-insensitive; a DOF is returned unchanged.

        Returns
        -------
        DOF

        Raises
        ------
        ValueError
            If the text is not of the form node, sign, axis.
        """
        if isinstance(text, DOF):
            return text
        if not isinstance(text, str):
            raise TypeError(f"a DOF is written as a string like '11+Y', got {text!r}")
        m = _DOF_RE.match(text)
        if not m:
            raise ValueError(
                f"cannot read DOF {text!r}: expected node, sign and axis such as '11+Y' or '13-Y' "
                "(axes X, Y, Z, RX, RY, RZ)"
            )
        node = int(m.group(1))
        if m.group(3):
            sign, axis = m.group(2), m.group(3)
        elif m.group(4):
            sign, axis = m.group(5), m.group(4)
        else:
            return cls(node, 0)
        code = AXIS_NAMES.index(axis.upper())
        return cls(node, code if sign == "+" else -code)

    @property
    def axis(self) -> str:
        """Axis name without sign: ``'X'``, ``'Y'``, ``'Z'``, ``'RX'``, ``'RY'``, ``'RZ'`` or ``'S'``."""
        return AXIS_NAMES[abs(self.direction)]

    @property
    def sign(self) -> int:
        """+1 for a positive (or scalar) direction, -1 for a negative one."""
        return -1 if self.direction < 0 else 1

    def positive(self) -> DOF:
        """The same node and axis with a positive sign."""
        return DOF(self.node, abs(self.direction))

    def same_axis(self, other: DOF) -> bool:
        """Whether ``other`` is measured at the same node along the same axis (sign ignored).

        The one definition of "the same sensor axis": ``13-Y`` and ``13+Y`` are one channel
        written with opposite signs; ``13+Y`` and ``13+Z`` or ``14+Y`` are not.

        Parameters
        ----------
        other : DOF
            The DOF to compare with.

        Returns
        -------
        bool

        Examples
        --------
        >>> DOF.parse("13-Y").same_axis(DOF.parse("13+Y"))
        True
        >>> DOF.parse("13+Y").same_axis(DOF.parse("13+Z"))
        False
        """
        return self.node == other.node and abs(self.direction) == abs(other.direction)

    def __str__(self) -> str:
        if self.direction == 0:
            return f"{self.node}"
        return f"{self.node}{'+' if self.direction > 0 else '-'}{self.axis}"

    def __repr__(self) -> str:
        return f"DOF('{self}')"


def as_dof(value: str | DOF | tuple[int, int]) -> DOF:
    """Coerce ``"11+Y"``, a ``DOF`` or a ``(node, code)`` tuple to a DOF.

    Parameters
    ----------
    value : str, DOF or (int, int)
        DOF text, a DOF (returned unchanged) or ``(node, signed direction code)``.

    Returns
    -------
    DOF
    """
    if isinstance(value, DOF):
        return value
    if isinstance(value, tuple):
        return DOF(int(value[0]), int(value[1]))
    return DOF.parse(value)


__all__ = ["AXIS_NAMES", "DOF", "as_dof"]
