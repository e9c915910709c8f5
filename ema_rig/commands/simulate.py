"""simulate: (placeholder; being implemented)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig simulate``."""


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig simulate``."""
    from ..errors import EmaRigError

    raise EmaRigError("'simulate' is not implemented yet")
