"""stabilization: (placeholder; being implemented)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig stabilization``."""


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig stabilization``."""
    from ..errors import EmaRigError

    raise EmaRigError("'stabilization' is not implemented yet")
