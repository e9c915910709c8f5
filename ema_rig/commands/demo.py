"""demo: (placeholder; being implemented)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig demo``."""


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig demo``."""
    from ..errors import EmaRigError

    raise EmaRigError("'demo' is not implemented yet")
