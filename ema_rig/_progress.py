"""One progress bar for long work, in a terminal and in Jupyter.

``tqdm(disable=None)`` hides the bar whenever stderr is not a terminal, which is also the case
in a Jupyter kernel; there the notebook widget (``tqdm.auto``) is wanted instead.
"""

from __future__ import annotations

import sys
from typing import Any


def in_notebook() -> bool:
    """True inside an IPython kernel (Jupyter, VS Code notebooks), False in a terminal or script."""
    shell = sys.modules.get("IPython")
    if shell is None or "ipykernel" not in sys.modules:
        return False
    get = getattr(shell, "get_ipython", None)
    ip = get() if callable(get) else None
    return ip is not None and type(ip).__name__ == "ZMQInteractiveShell"


def progress_bar(*, total: int, desc: str, unit: str = "it", initial: int = 0) -> Any:
    """A tqdm bar: the notebook widget in Jupyter, a terminal bar on a TTY, nothing otherwise."""
    from tqdm.auto import tqdm

    class _Bar(tqdm):  # type: ignore[misc]
        # no monitor thread: a campaign forks its worker pool while the bar is open
        monitor_interval = 0

    return _Bar(total=total, initial=initial, desc=desc, unit=unit, disable=False if in_notebook() else None)


__all__ = ["in_notebook", "progress_bar"]
