"""Which channels a reader keeps, in which order, with which role: the seam between io and the rig.

The readers of :mod:`ema_rig.io` know DOFs and units, not the rig. What they need from a rig
file -- which responses to keep and in which order, the role and axis of each, the signed
reference DOFs, which unit wins a conflict -- is described by :class:`SensorLayout`, a
structural type: :class:`ema_rig.config.RigConfig` (the rig layer, which assigns the roles) is
one, and :class:`ChannelLayout` is a plain frozen one for a script without a rig file.

Classes
-------
SensorChannel
    What a reader needs of one sensor: ``dof`` (signed, as the rig file writes it), ``role``, ``axis``.
SensorLayout
    What a reader needs of a rig: ``sensors``, ``references``, ``sensor_for``, ``unit_preference``,
    ``unit_ordinate``, ``path``.
Channel, ChannelLayout
    Plain frozen implementations of the two.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

from ..dof import DOF


class SensorChannel(Protocol):
    """One response channel as the rig names it.

    Attributes
    ----------
    dof : DOF
        Node and signed direction as the rig file writes it (``13-Y`` measures along -Y).
    role : str
        What it is mounted on (``"housing"``, ``"spindle"``).
    axis : str
        Its axis in the rig (``"radial"``, ``"lateral"``, ``"axial"``).
    """

    @property
    def dof(self) -> DOF: ...

    @property
    def role(self) -> str: ...

    @property
    def axis(self) -> str: ...


class SensorLayout(Protocol):
    """What a reader needs of a rig: its sensors, references and unit rule.

    Attributes
    ----------
    sensors : sequence of SensorChannel
        The response channels to keep, in the order the data are returned.
    references : tuple of DOF
        The signed reference (excitation) DOFs, in order.
    unit_preference : str or None
        ``'code'`` or ``'label'``: which wins when a dataset's unit code and label disagree.
    unit_ordinate : str or None
        The response unit of datasets without a unit label (e.g. ``"g"``).
    path : str or None
        The file the layout was read from (named in messages).
    """

    @property
    def sensors(self) -> Sequence[SensorChannel]: ...

    @property
    def references(self) -> tuple[DOF, ...]: ...

    @property
    def unit_preference(self) -> str | None: ...

    @property
    def unit_ordinate(self) -> str | None: ...

    @property
    def path(self) -> str | None: ...

    def sensor_for(self, dof: DOF) -> SensorChannel | None:
        """The sensor measuring along ``dof``'s node and axis (sign ignored), or None."""
        ...


@dataclass(frozen=True, slots=True)
class Channel:
    """A plain :class:`SensorChannel`.

    Parameters
    ----------
    dof : DOF
        Node and signed direction as the file or rig writes it.
    role : str, optional
        What it is mounted on (``"housing"``, ``"spindle"``); empty when not known.
    axis : str, optional
        Its axis in the rig (``"radial"``, ``"lateral"``, ``"axial"``); empty when not known.
    """

    dof: DOF
    role: str = ""
    axis: str = ""


@dataclass(frozen=True, slots=True)
class ChannelLayout:
    """A plain :class:`SensorLayout`, for reading a file with known channels but no rig file.

    Parameters
    ----------
    sensors : tuple of Channel
        The response channels to keep, in order.
    references : tuple of DOF
        The signed reference DOFs, in order.
    unit_preference, unit_ordinate, path : str or None
        As in :class:`SensorLayout`.

    Examples
    --------
    >>> lay = ChannelLayout((Channel(DOF.parse("13-Y"), "housing", "radial"),), (DOF.parse("11+Y"),))
    >>> lay.sensor_for(DOF.parse("13+Y")).role
    'housing'
    """

    sensors: tuple[Channel, ...]
    references: tuple[DOF, ...]
    unit_preference: str | None = None
    unit_ordinate: str | None = None
    path: str | None = None

    def sensor_for(self, dof: DOF) -> Channel | None:
        """The sensor measuring along ``dof``'s node and axis (sign ignored), or None.

        Parameters
        ----------
        dof : DOF
            A DOF as written in a file.

        Returns
        -------
        Channel or None
        """
        return next((s for s in self.sensors if s.dof.same_axis(dof)), None)


__all__ = ["Channel", "ChannelLayout", "SensorChannel", "SensorLayout"]
