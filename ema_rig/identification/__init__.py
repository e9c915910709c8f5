"""Modal identification: PolyMAX (pLSCF), stabilization, automatic selection, LSFD.

Functions
---------
identify
    The whole chain for one measurement (pLSCF -> stabilize -> select -> LSFD).
plscf
    Poles and participation factors for a range of model orders (:class:`PoleSet`).
stabilize
    Status letters o f d v s per pole (:class:`StabilizationData`).
select_modes, select_near, select_poles, resolve_selection
    Automatic, nearest-frequency, hand-picked and replayed mode selections (:class:`Selection`).
lsfd
    Residues with lower and upper residuals (:class:`ModalModel`).
mac, mpc
    Shape correlation (MAC / auto-MAC) and modal phase collinearity.

Classes
-------
PoleSet, StabilizationData, Selection, SelectedMode, ModalModel, Identification
"""

from __future__ import annotations

from .identification import Identification, identify
from .lsfd import lsfd
from .mac import mac, mpc
from .modal import ModalModel
from .plscf import PoleSet, default_max_order, plscf
from .stabilization import (
    SelectedMode,
    Selection,
    StabilizationData,
    resolve_selection,
    select_modes,
    select_near,
    select_poles,
    stabilize,
)

__all__ = [
    "Identification",
    "ModalModel",
    "PoleSet",
    "SelectedMode",
    "Selection",
    "StabilizationData",
    "default_max_order",
    "identify",
    "lsfd",
    "mac",
    "mpc",
    "plscf",
    "resolve_selection",
    "select_modes",
    "select_near",
    "select_poles",
    "stabilize",
]
