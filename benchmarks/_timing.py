"""Shared by the benchmarks: paired timing (two callables in alternating order) and the peak
resident memory of one call (Linux ``/proc``)."""

from __future__ import annotations

import gc
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


def _status_kb(key: str) -> int:
    with open("/proc/self/status") as fh:
        for line in fh:
            if line.startswith(key + ":"):
                return int(line.split()[1])
    raise RuntimeError(f"/proc/self/status has no {key}")


def rss_bytes() -> int:
    """Current resident set of this process [bytes] (Linux)."""
    return _status_kb("VmRSS") * 1024


def hwm_bytes() -> int:
    """Peak resident set of this process since start or the last :func:`reset_peak` [bytes]."""
    return _status_kb("VmHWM") * 1024


def reset_peak() -> None:
    """Reset the kernel's peak-RSS mark of this process to the current RSS (Linux >= 4.0)."""
    with open("/proc/self/clear_refs", "w") as fh:
        fh.write("5")


def _malloc_trim() -> None:
    """Give freed heap memory back to the system (glibc; a no-op elsewhere)."""
    try:
        import ctypes

        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except (OSError, AttributeError):
        pass


def measure_call(fn: Callable[[], Any]) -> tuple[float, int, Any]:
    """Run ``fn`` once: (seconds, peak RSS above the RSS before the call [bytes], result)."""
    gc.collect()
    _malloc_trim()
    reset_peak()
    before = rss_bytes()
    t0 = time.perf_counter()
    out = fn()
    dt = time.perf_counter() - t0
    return dt, hwm_bytes() - before, out


def ask_worker(proc: Any, request: str) -> tuple[float, float]:
    """Send one request line to a worker process and read its answer ``"<wall> <cpu>"`` [s].

    ``proc`` is a :class:`subprocess.Popen` with text pipes on stdin and stdout, one answer line
    per request line (the long-lived tree workers of the ``*_vs_tree`` benchmarks).
    """
    assert proc.stdin is not None and proc.stdout is not None
    proc.stdin.write(request + "\n")
    proc.stdin.flush()
    wall, cpu = proc.stdout.readline().split()
    return float(wall), float(cpu)


def git_head(tree: Any) -> str:
    """Short commit of a git tree, or ``"(not a git tree)"`` (an exported archive)."""
    import subprocess

    r = subprocess.run(["git", "-C", str(tree), "rev-parse", "--short", "HEAD"], capture_output=True, text=True)
    return r.stdout.strip() or "(not a git tree)"


def close_workers(procs: Any) -> None:
    """Close the request pipe of each worker process (its loop over stdin ends) and wait for it."""
    for p in procs:
        assert p.stdin is not None
        p.stdin.close()
        p.wait()
