"""inspect: (placeholder; being implemented)."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Register the options of ``ema-rig inspect``."""


def run(args: argparse.Namespace) -> int:
    """Run ``ema-rig inspect``."""
    from ..errors import EmaRigError

    raise EmaRigError("'inspect' is not implemented yet")
