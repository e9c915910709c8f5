"""campaign: (placeholder; being implemented)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig campaign``."""


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig campaign``."""
    from ..errors import EmaRigError

    raise EmaRigError("'campaign' is not implemented yet")
