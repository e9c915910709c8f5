"""Paired timing shared by the benchmarks: two callables timed in alternating order."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any


def paired(fa: Callable[[], Any], fb: Callable[[], Any], repeat: int) -> tuple[list[float], list[float]]:
    """Times [s] of ``fa`` and ``fb`` in ``repeat`` alternating pairs (A B, B A, ...).

    Alternating the order keeps drifts of the machine (load, clock, caches) out of the ratio.
    """
    ta: list[float] = []
    tb: list[float] = []
    for i in range(repeat):
        for which in ((0, 1) if i % 2 == 0 else (1, 0)):
            t0 = time.perf_counter()
            (fa if which == 0 else fb)()
            (ta if which == 0 else tb).append(time.perf_counter() - t0)
    return ta, tb
