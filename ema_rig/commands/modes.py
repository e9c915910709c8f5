"""modes: (placeholder; being implemented)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig modes``."""


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig modes``."""
    from ..errors import EmaRigError

    raise EmaRigError("'modes' is not implemented yet")
