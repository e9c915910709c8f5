"""stiffness: (placeholder; being implemented)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig stiffness``."""


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig stiffness``."""
    from ..errors import EmaRigError

    raise EmaRigError("'stiffness' is not implemented yet")
