"""Text that reaches matplotlib from user input (file names, bearing names): drawn literally."""

from __future__ import annotations

from typing import Any


def plain(text: Any) -> str:
    """``text`` as a string matplotlib draws literally: ``$`` escaped, so no mathtext is parsed.

    An unescaped pair of ``$`` starts mathtext, and an invalid formula (``p$\\frac$q``) makes
    ``savefig`` raise, losing the figure.
    """
    return str(text).replace("$", r"\$")


__all__ = ["plain"]
