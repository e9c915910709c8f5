"""ema_rig: experimental modal analysis for rolling-element bearing test rigs.

UFF58 import, PolyMAX (pLSCF) identification, matching to the rig's 3DOF model and inversion of
the housing mode for the bearing stiffness k_TB (Jacobs et al., "Estimating rolling element
bearing stiffness under different operational conditions through modal analysis").

Importing the package has no global side effects: no pyplot, no sdypy, no warning filters.

Public API
----------
FRFData
    The FRF matrix (``ema_rig.frf``).
DOF
    Node + signed direction (``ema_rig.dof``).
RigConfig, load_rig
    The rig configuration file (``ema_rig.config``).
read_uff58, write_uff58
    UFF dataset 58 import and export (``ema_rig.io.uff``).
identify
    PolyMAX identification with stabilization, selection and LSFD (``ema_rig.identification``).
estimate_stiffness, calibrate
    k_TB of a mounted bearing / k_MS from a steel-disk run (``ema_rig.rig.stiffness``).
load_campaign, run_campaign
    Campaign files and runs (``ema_rig.campaign``).

Layers
------
Bottom to top; a module imports only from its own layer or below (``tests/test_layers.py``
states the same table and checks every import, the ones inside functions and under
``TYPE_CHECKING`` included, and that the import graph has no cycle):

0. foundations: ``errors``, ``dof`` (node + signed direction; ``DOF.same_axis`` is the one
   "same sensor axis"), ``literals`` (every ``Literal`` alias), ``frf`` (``FRFData``),
   ``processing`` (the record of how FRFs were estimated), the private helpers.
1. ``io/``: UFF read/write, time data, geometry, units; ``mode_shapes`` (shape records, for
   JSON and dataset 55). Knows DOFs and units, not the rig: the readers take a
   ``io.layout.SensorLayout`` (a ``RigConfig`` is one), the dataset-55 writer a
   ``mode_shapes.ModalShapes`` (a ``ModalModel`` is one).
2. ``identification/`` (pLSCF, stabilization, LSFD, ML, crosscheck) and ``spectral`` (H1/H2/Hv).
3. the rig: ``config`` (the rig file; it assigns the sensor roles), ``rig/`` (model, candidates,
   matching, inversion, fit, uncertainty, stiffness, Hertz) and ``simulate``.
4. campaign core: ``campaign.schema``, ``campaign.result``; ``demo_data``.
5. outputs: ``plot/``, ``campaign.drilldown``, ``report``, ``campaign.outputs``.
6. the campaign run: ``campaign.runner`` (every measurement, then the outputs) and the
   ``campaign`` facade.
7. ``commands/``, ``cli``, and this facade.

Imports inside functions remain only to keep a light module light (``import ema_rig``, the
command line's start-up and ``import ema_rig.campaign`` load no numpy) or for an optional,
heavy or platform-specific package; the test lists each kind with its reason.

The errors, DOF, RigConfig and load_rig are plain Python and imported with the package; every
other name (FRFData and ``__version__`` included) is resolved on first use, so ``import ema_rig``
imports neither numpy nor scipy, and ``ema-rig --help`` or a usage error stays fast.
"""

from __future__ import annotations

import importlib
import logging
from typing import TYPE_CHECKING, Any

from ._version import version
from .config import RigConfig, load_rig
from .dof import DOF
from .errors import (
    ConfigError,
    EmaRigError,
    IdentificationError,
    IdentificationWarning,
    InversionError,
    MatchingError,
    UFFError,
    UnitWarning,
)

if TYPE_CHECKING:  # what the lazy names are, for type checkers and IDEs
    from .campaign import load_campaign
    from .campaign import run as run_campaign
    from .frf import FRFData
    from .identification import identify
    from .io.uff import read_uff58, write_uff58
    from .rig.stiffness import calibrate, estimate_stiffness

logging.getLogger(__name__).addHandler(logging.NullHandler())

_LAZY = {
    "FRFData": ("ema_rig.frf", "FRFData"),
    "read_uff58": ("ema_rig.io.uff", "read_uff58"),
    "write_uff58": ("ema_rig.io.uff", "write_uff58"),
    "identify": ("ema_rig.identification", "identify"),
    "estimate_stiffness": ("ema_rig.rig.stiffness", "estimate_stiffness"),
    "calibrate": ("ema_rig.rig.stiffness", "calibrate"),
    "load_campaign": ("ema_rig.campaign", "load_campaign"),
    "run_campaign": ("ema_rig.campaign", "run"),
}


def __getattr__(name: str) -> Any:
    if name == "__version__":
        globals()["__version__"] = v = version()  # importlib.metadata (~40 ms): only when asked for
        return v
    if name in _LAZY:
        mod, attr = _LAZY[name]
        globals()[name] = value = getattr(importlib.import_module(mod), attr)  # once
        return value
    raise AttributeError(f"module 'ema_rig' has no attribute {name!r}")


def __dir__() -> list[str]:
    # the lazy names are part of the API: show them before their first use (tab completion)
    return sorted(set(globals()) | set(_LAZY) | {"__version__"})


__all__ = [
    "ConfigError",
    "DOF",
    "EmaRigError",
    "FRFData",
    "IdentificationError",
    "IdentificationWarning",
    "InversionError",
    "MatchingError",
    "RigConfig",
    "UFFError",
    "UnitWarning",
    "__version__",
    "calibrate",
    "estimate_stiffness",
    "identify",
    "load_campaign",
    "load_rig",
    "read_uff58",
    "run_campaign",
    "write_uff58",
]
