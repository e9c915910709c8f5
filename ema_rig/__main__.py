"""``python -m ema_rig ...``: the ``ema-rig`` command line (the same as the installed script)."""

from __future__ import annotations

import sys

from .cli import main

if __name__ == "__main__":  # pragma: no branch - run by ``python -m ema_rig``
    sys.exit(main())
