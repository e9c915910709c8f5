"""Modal identification: PolyMAX (pLSCF), stabilization, automatic selection, LSFD.

Functions
---------
identify
    The whole chain for one measurement (pLSCF with a growing order -> stabilize -> judge the
    clusters -> LSFD), with warnings and notes.
judge_clusters
    Every cluster of stable poles with a verdict and its reason (:class:`Candidate`).
diagnose_file, diagnose_frf
    Why a measurement may not be trusted (coherence, impact position, phase).
crosscheck
    sdypy-EMA's LSCF on the same band, mode by mode (:class:`CrossCheck`).
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
PoleSet, PlscfEngine, StabilizationData, Selection, SelectedMode, Candidate, ModalModel,
Identification, CrossCheck
"""

from __future__ import annotations

from .crosscheck import CrossCheck, crosscheck
from .diagnose import diagnose_file, diagnose_frf
from .identification import Identification, default_order_cap, identify, transpose_layout
from .judge import Candidate, judge_clusters
from .lsfd import lsfd
from .mac import mac, mpc
from .modal import ModalModel
from .plscf import PlscfEngine, PoleSet, default_max_order, plscf
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
    "Candidate",
    "CrossCheck",
    "Identification",
    "ModalModel",
    "PlscfEngine",
    "PoleSet",
    "SelectedMode",
    "Selection",
    "StabilizationData",
    "crosscheck",
    "default_max_order",
    "default_order_cap",
    "diagnose_file",
    "diagnose_frf",
    "identify",
    "judge_clusters",
    "lsfd",
    "mac",
    "mpc",
    "plscf",
    "resolve_selection",
    "select_modes",
    "select_near",
    "select_poles",
    "stabilize",
    "transpose_layout",
]
