"""The identified mode handed to the rig: a frozen, typed record that still reads like a mapping.

:func:`ema_rig.rig.matching.match_modes` picks the radial housing mode (and the spindle bending
mode) among the identified modes; :class:`MatchedMode` is what it hands on to the inversion, the
uncertainty budget and the results (``MatchResult.housing_mode``, ``StiffnessResult.housing_mode``
and ``spindle_mode``, ``CalibrationResult.housing_mode``).

Every value is a typed attribute (``mode.natural_freq``). For the scripts written against the
dicts these records replaced, a :class:`MatchedMode` is also a read-only
:class:`~collections.abc.Mapping` of the entries it was given, in the order given
(``mode["natural_freq"]``, ``mode.get("modal_mass")``, ``dict(mode)``), so the JSON written from
it is unchanged.

Classes
-------
MatchedMode
    One matched mode: frequency, damping, their uncertainties and the matching evidence.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True, slots=True, eq=False)
class MatchedMode(Mapping[str, Any]):
    """One identified mode as the rig uses it (the housing or the spindle bending mode).

    Parameters
    ----------
    natural_freq : float
        Natural frequency [Hz] (the undamped ``|lambda| / 2 pi``).
    damping_ratio : float
        Damping ratio [-].
    natural_freq_std, damping_ratio_std : float or None, optional
        One standard uncertainty from the data [Hz], [-].
    modal_mass : float or None, optional
        Effective modal mass at the radial driving point [kg].
    modal_mass_source : str or None, optional
        Where ``modal_mass`` comes from (driving point or housing transfer FRFs).
    model_modal_mass : float or None, optional
        The 3DOF model's housing-mode effective mass at this frequency [kg].
    spindle_ratio, model_spindle_ratio : float or None, optional
        Measured and model spindle/housing motion ``phi_S / phi_H`` [-].
    axial_ratio, lateral_ratio : float or None, optional
        Axial and lateral housing motion relative to the radial [-].
    model_natural_freq : float or None, optional
        The model's frequency of this mode [Hz] (spindle bending mode).
    source : str or None, optional
        How the mode was selected (``"auto"``, ``"near"``, ``"manual"``).
    entries : tuple of str, optional
        The names given, in order: the keys of the mapping view (and of the JSON). Default: every
        field that is not None, in field order.

    Examples
    --------
    >>> m = MatchedMode.from_mapping({"natural_freq": 626.0, "damping_ratio": 0.01})
    >>> m.natural_freq, m["damping_ratio"], dict(m.with_entries(source="auto"))
    (626.0, 0.01, {'natural_freq': 626.0, 'damping_ratio': 0.01, 'source': 'auto'})
    """

    natural_freq: float
    damping_ratio: float
    natural_freq_std: float | None = None
    modal_mass: float | None = None
    modal_mass_source: str | None = None
    model_modal_mass: float | None = None
    spindle_ratio: float | None = None
    model_spindle_ratio: float | None = None
    axial_ratio: float | None = None
    lateral_ratio: float | None = None
    model_natural_freq: float | None = None
    damping_ratio_std: float | None = None
    source: str | None = None
    entries: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        names = _FIELDS
        if not self.entries:
            given = tuple(n for n in names if getattr(self, n) is not None)
            object.__setattr__(self, "entries", given)
        unknown = [k for k in self.entries if k not in names]
        if unknown or len(set(self.entries)) != len(self.entries):
            raise ValueError(f"MatchedMode entries must be distinct names of {names}, got {self.entries!r}")

    @classmethod
    def from_mapping(cls, values: Mapping[str, Any]) -> MatchedMode:
        """A record of the entries of ``values`` (their order kept).

        Parameters
        ----------
        values : mapping
            Entries named as the fields (``natural_freq`` and ``damping_ratio`` required).

        Returns
        -------
        MatchedMode

        Raises
        ------
        ValueError
            If a name is not a field.
        """
        unknown = [k for k in values if k not in _FIELDS]
        if unknown:
            raise ValueError(f"unknown MatchedMode entries {unknown}; allowed: {_FIELDS}")
        return cls(**dict(values), entries=tuple(values))

    def with_entries(self, **values: Any) -> MatchedMode:
        """A copy with ``values`` set; a new name is appended to :attr:`entries` (as a dict would).

        Parameters
        ----------
        **values
            Entries to set, named as the fields.

        Returns
        -------
        MatchedMode
        """
        unknown = [k for k in values if k not in _FIELDS]
        if unknown:
            raise ValueError(f"unknown MatchedMode entries {unknown}; allowed: {_FIELDS}")
        entries = self.entries + tuple(k for k in values if k not in self.entries)
        return dataclasses.replace(self, **values, entries=entries)

    # ---- the read-only mapping view (the dicts these records replaced)
    def __getitem__(self, key: str) -> Any:
        if key not in self.entries:
            raise KeyError(key)
        return getattr(self, key)

    def __iter__(self) -> Iterator[str]:
        return iter(self.entries)

    def __len__(self) -> int:
        return len(self.entries)

    def __repr__(self) -> str:
        return f"MatchedMode({', '.join(f'{k}={self[k]!r}' for k in self.entries)})"


_FIELDS: tuple[str, ...] = tuple(f.name for f in dataclasses.fields(MatchedMode) if f.name != "entries")

__all__ = ["MatchedMode"]
