"""calibrate: (placeholder; being implemented)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig calibrate``."""


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig calibrate``."""
    from ..errors import EmaRigError

    raise EmaRigError("'calibrate' is not implemented yet")
