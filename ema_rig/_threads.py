"""A task a second thread may run, taken back by the caller when that thread has not started it.

Used where ema_rig hands independent work (a fixed task, its inputs copies or arrays no one changes
afterwards) to a second thread: the numbers are the same whichever thread runs it, and when, and
the caller joins the results in a fixed order, so no result depends on the threads or the load.
"""

from __future__ import annotations

from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor
from typing import Generic, TypeVar

T = TypeVar("T")


class Job(Generic[T]):
    """A task that a second thread may run (``pool``; None: run here, now, or with ``later`` when asked).

    :meth:`result` runs it in the calling thread when the second thread has not started it yet,
    so neither thread idles while the other has queued work. A task depends on its inputs only
    (copies or arrays no one changes afterwards): the numbers are the same whichever thread runs
    it, and when; the caller joins the results in a fixed order.
    """

    def __init__(self, task: Callable[[], T], pool: ThreadPoolExecutor | None, *, later: bool = False) -> None:
        self._task = task
        self._future: Future[T] | None = pool.submit(task) if pool is not None else None
        self._value: tuple[T] | None = None if pool is not None or later else (task(),)

    def result(self) -> T:
        """The task's result (waits for the second thread when it runs it)."""
        if self._value is None:
            self._value = ((self._task(),) if self._future is None or self._future.cancel()
                           else (self._future.result(),))
        return self._value[0]


__all__ = ["Job"]
