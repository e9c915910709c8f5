"""The ``Literal`` aliases of ema_rig: every string that selects a behaviour, in one module.

As scikit-rf keeps its string options in ``constants.py``: a type checker then refuses a
misspelt option where it is written, and the documentation names the allowed values once.

Aliases
-------
FrfForm
    ``"accelerance"``, ``"mobility"``, ``"receptance"`` (re-exported by :mod:`ema_rig.frf`).
UncertaintyKind
    Where an uncertainty term's size comes from (:attr:`ema_rig.rig.uncertainty.UncertaintyTerm.kind`).
SensorRole, SensorAxis
    ``[[sensor]] role`` and ``axis`` of a rig file.
UnitPreference
    ``[units] prefer`` of a rig file: which of a UFF dataset's unit code and label wins.
DampingModel
    The bearing damping model of :func:`ema_rig.rig.damping.bearing_damping`.
DampingKind
    What its ``c_TB`` is: ``"measured"`` or ``"upper bound"`` (:data:`ema_rig.rig.damping.C_TB_KINDS`).
Estimator
    The FRF estimator of :func:`ema_rig.spectral.estimate_frf`.
FailureKind
    Which housing criterion a candidate mode failed (:class:`ema_rig.rig.failures.Failure`):
    ``"mass units"`` is a modal-mass failure whose ratio points at a unit mistake (g vs m/s^2).

Constants
---------
KIND_MEASURED, KIND_RIG, KIND_DEFAULT, KIND_MODEL, KINDS
    The values of :data:`UncertaintyKind`.
"""

from __future__ import annotations

from typing import Final, Literal

FrfForm = Literal["accelerance", "mobility", "receptance"]
UncertaintyKind = Literal["measured", "assumed (rig file)", "assumed (default)", "model form"]
SensorRole = Literal["housing", "spindle"]
SensorAxis = Literal["radial", "lateral", "axial"]
UnitPreference = Literal["code", "label"]
DampingModel = Literal["viscous", "hysteretic"]
DampingKind = Literal["measured", "upper bound"]
Estimator = Literal["H1", "H2", "Hv"]
FailureKind = Literal["range", "harmonic", "no radial sensor", "no radial motion", "spindle ratio", "lateral",
                      "axial", "tilt", "amplitude", "mass", "mass units"]

KIND_MEASURED: Final = "measured"
KIND_RIG: Final = "assumed (rig file)"
KIND_DEFAULT: Final = "assumed (default)"
KIND_MODEL: Final = "model form"
KINDS: Final[tuple[UncertaintyKind, ...]] = (KIND_MEASURED, KIND_RIG, KIND_DEFAULT, KIND_MODEL)
"""The labels of :attr:`ema_rig.rig.uncertainty.UncertaintyTerm.kind` (uncertainty kinds)."""

__all__ = [
    "KINDS",
    "KIND_DEFAULT",
    "KIND_MEASURED",
    "KIND_MODEL",
    "KIND_RIG",
    "DampingKind",
    "DampingModel",
    "Estimator",
    "FailureKind",
    "FrfForm",
    "SensorAxis",
    "SensorRole",
    "UncertaintyKind",
    "UnitPreference",
]
