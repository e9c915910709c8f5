"""Scale benchmark: time and peak memory of identification against the size of the FRF data.

Grid (full mode): outputs 8 / 64 / 256 x references 1 / 3 x lines 4 001 / 64 001 x model orders
50 / 200. Quick mode (``--quick``, a few seconds, for CI): outputs 8 x references 1 / 3 x 4 001
lines x order 50.

Data: an exact modal sum (accelerance) of six modes between 150 and 1 600 Hz (0.6-1.5 % damping,
random real shapes, seeded) on ``n_lines`` lines from 50 to 2 000 Hz, plus 1 % complex noise per
channel; references are the first outputs (drive points). Written straight into
:class:`ema_rig.frf.FRFData`, generated in blocks of outputs so that building it costs little more
than the data.

Every row runs in its own child process. After the import and the data, the child measures three
public calls of the same data, each on the whole band:

* ``identify``: ``ema_rig.identification.identify(data, band=(lo, hi), max_order=P)``;
* ``plscf``: ``ema_rig.identification.plscf(data, max_order=P)``;
* ``lsfd``: ``ema_rig.identification.lsfd(data, <true poles>, band=(lo, hi))``.

How the numbers are taken
-------------------------
* Peak memory: the peak resident set of the child during one call minus its resident set just
  before the call (after import, data and ``gc.collect()``); the kernel's high-water mark is reset
  before each call (``/proc/self/clear_refs``, Linux), so each call gets its own peak. The table
  gives the largest peak of the warm calls, so the lazy imports of the first call are not
  counted, or, for a row too slow for a warm round in its time budget, the first call's peak
  (marked ``*``; the imports add some 10-40 MB there). The first call's peak is always in the
  JSON (``peak_first``). Reported as ``peak / data`` with data = n_out * n_in * n_lines * 16 bytes (the
  complex128 FRF array).
* Time: the first call of each function in the fresh process is reported apart (``first``; the
  first call of the process is ``identify`` and pays the lazy imports and BLAS start-up). Then
  warm rounds of the three calls, interleaved and alternating in order (A B C, C B A, ...), so a
  busy period on the shared machine hits all three; ``median [min-max]`` of the warm calls.
* BLAS threads: every warm call runs under each of the ``--blas`` settings, interleaved in the
  same process on the same data: the machine's default and one thread (threadpoolctl, numpy's
  and scipy's BLAS) unless told otherwise; one line per setting. (``plscf`` pins its own small
  LAPACK kernels to one thread by design; that is part of what is measured.)
* Modes found: how many of the six true natural frequencies ``identify`` returned within 0.1 %,
  and the model order the adaptive identification reached (``P`` is its cap).
* Two children per row. Memory is measured in one that runs with ``MALLOC_MMAP_THRESHOLD_=65536``
  and calls ``malloc_trim(0)`` before each call, so that memory freed by an earlier call goes
  back to the system instead of staying resident and hiding part of the next call's peak
  (glibc's adaptive threshold would otherwise serve arrays up to 32 MB from a heap that is not
  returned); one warm round there. Time is measured in a second child with the default
  allocator: the small mmap threshold makes every large temporary a fresh mapping with its page
  faults, which slowed ``plscf`` at 64 x 3 x 4001, P = 200 from 3.4 s to 8.2 s.
* Limits: rows run smallest first. A row whose ``identify`` first call is projected above
  ``--max-row-s`` (60 s), or whose projected memory (data + peak) exceeds ``--max-mem-gb`` (8 GB),
  or that does not fit in the remaining ``--budget-s`` (840 s), is skipped and listed with the
  reason. Projection: a straight line ``a + b * data size`` through the finished rows with the
  same references and order (the slope from the same references at any order when only one such
  row exists), the peak from the largest such row's peak / data. Warm rounds run while they fit in
  ``--warm-s`` (20 s) per row, so the largest rows may have first calls only; a child that runs
  past 3 x ``--max-row-s`` + 60 s is killed.

Run from the repository root::

    python benchmarks/bench_scale.py --quick
    python benchmarks/bench_scale.py [--repeat N] [--json OUT]
    python benchmarks/bench_scale.py --only 256x3x64001x200 --max-row-s 200   # chosen rows
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from _timing import measure_call, rss_bytes  # benchmarks/_timing.py, beside this script

MODES_HZ = np.array([150.0, 290.0, 455.0, 626.0, 1100.0, 1600.0])
DAMPING = np.array([0.012, 0.008, 0.010, 0.006, 0.015, 0.012])
F_LO, F_HI = 50.0, 2000.0
NOISE = 0.01
FREQ_TOL = 1e-3  # relative tolerance for "mode found"
STEPS = ("identify", "plscf", "lsfd")


# ------------------------------------------------------------------------------------ data
def true_poles() -> np.ndarray:
    """Poles [rad/s] of the synthetic modes, ``Im > 0``, shape (n_modes,)."""
    wn = 2 * np.pi * MODES_HZ
    return wn * (-DAMPING + 1j * np.sqrt(1 - DAMPING**2))


def synthetic_frf(n_out: int, n_in: int, n_lines: int, *, seed: int = 0, block: int = 16) -> Any:
    """A modal-sum accelerance matrix as :class:`ema_rig.frf.FRFData`.

    Parameters
    ----------
    n_out, n_in : int
        Outputs (nodes 1..n_out, +Y) and references (the first ``n_in`` outputs).
    n_lines : int
        Lines from 50 to 2 000 Hz, equally spaced.
    seed : int
        Seed of the shapes and the noise.
    block : int
        Outputs generated at a time (bounds the temporaries to ``block / n_out`` of the data).

    Returns
    -------
    FRFData
        Shape (n_out, n_in, n_lines), accelerance in m/s^2/N, 1 % complex noise per channel.
    """
    from ema_rig.frf import FRFData

    rng = np.random.default_rng(seed)
    freq = np.linspace(F_LO, F_HI, n_lines)
    lam = true_poles()
    jw = 2j * np.pi * freq
    # q[r] = (jw)^2 / (2j wd) * (1/(jw - lam) - 1/(jw - conj lam)): one mode, unit shape product
    q = np.empty((lam.size, n_lines), complex)
    for r, pole in enumerate(lam):
        q[r] = jw**2 / (2j * pole.imag) * (1 / (jw - pole) - 1 / (jw - pole.conjugate()))
    phi = rng.uniform(-1.0, 1.0, (lam.size, n_out))
    phi[:, :n_in] = np.sign(phi[:, :n_in]) * (0.5 + 0.5 * np.abs(phi[:, :n_in]))  # drive points see every mode
    h = np.empty((n_out, n_in, n_lines), complex)
    for o0 in range(0, n_out, block):
        o1 = min(o0 + block, n_out)
        coef = np.einsum("rb,ri->bir", phi[:, o0:o1], phi[:, :n_in])  # (block, n_in, n_modes)
        hb = h[o0:o1]
        np.matmul(coef, q, out=hb)
        rms = np.sqrt(np.mean(np.abs(hb) ** 2, axis=2, keepdims=True))
        noise = rng.standard_normal((o1 - o0, n_in, n_lines)) + 1j * rng.standard_normal((o1 - o0, n_in, n_lines))
        hb += (NOISE / np.sqrt(2)) * rms * noise
        del noise
    dofs = [f"{k + 1}+Y" for k in range(n_out)]
    data = FRFData(freq, h, dofs, dofs[:n_in])
    del h
    gc.collect()
    return data


def data_bytes(n_out: int, n_in: int, n_lines: int) -> int:
    """Bytes of the complex128 FRF array."""
    return n_out * n_in * n_lines * 16


# ------------------------------------------------------------------------------- child
@dataclass(frozen=True)
class Row:
    """One grid point."""

    n_out: int
    n_in: int
    n_lines: int
    order: int

    @property
    def size(self) -> int:
        return data_bytes(self.n_out, self.n_in, self.n_lines)

    def label(self) -> str:
        return f"{self.n_out:>3d} x {self.n_in} x {self.n_lines:>6d}  P={self.order:<3d}"


def _blas_limit(threads: int) -> Any:
    """Context: BLAS pools limited to ``threads`` (0 = leave the machine's default)."""
    import contextlib

    from threadpoolctl import threadpool_limits

    return threadpool_limits(limits=threads, user_api="blas") if threads else contextlib.nullcontext()


def run_child(spec: dict[str, Any]) -> dict[str, Any]:
    """Measure one row in this (fresh) process; return a JSON-able dict."""
    t0 = time.perf_counter()
    from ema_rig.identification import identify, lsfd, plscf

    t_import = time.perf_counter() - t0
    import scipy.linalg  # noqa: F401  (load scipy's BLAS too, so that the thread limits reach it)

    settings = [int(x) for x in spec["blas"]]
    row = Row(spec["n_out"], spec["n_in"], spec["n_lines"], spec["order"])
    t0 = time.perf_counter()
    data = synthetic_frf(row.n_out, row.n_in, row.n_lines)
    t_data = time.perf_counter() - t0
    lam = true_poles()
    band = (float(data.freq[0]), float(data.freq[-1]))
    calls: dict[str, Callable[[], Any]] = {
        "identify": lambda: identify(data, band=band, max_order=row.order),
        "plscf": lambda: plscf(data, max_order=row.order),
        "lsfd": lambda: lsfd(data, lam, band=band),
    }
    res: dict[str, Any] = {"import_s": t_import, "data_s": t_data, "rss_base": rss_bytes(), "steps": {}}
    found: int | None = None
    error: str | None = None
    for name in STEPS:  # first calls, under the first BLAS setting
        try:
            with _blas_limit(settings[0]):
                dt, peak, out = measure_call(calls[name])
        except Exception as exc:  # reported per step, never swallowed silently
            res["steps"][name] = {"first": None, "peak_first": None, "peak": None, "warm": {}, "peak_warm": [],
                                  "error": f"{type(exc).__name__}: {exc}"}
            error = f"{name}: {type(exc).__name__}: {exc}"
            continue
        res["steps"][name] = {"first": dt, "peak_first": peak, "peak": None, "peak_warm": [],
                              "warm": {str(b): [] for b in settings}}
        if name == "identify":
            fn = np.asarray(out.natural_freq)
            found = int(sum(np.any(np.abs(fn - f) <= FREQ_TOL * f) for f in MODES_HZ))
            res["n_identified"] = int(fn.size)
            sel = getattr(out, "selection", None)  # the order the adaptive identification reached
            res["order_reached"] = int(sel.max_order) if sel is not None else None
            res["natural_freq"] = fn.tolist()
        del out
    ok = [n for n in STEPS if res["steps"][n]["first"] is not None]
    round_s = sum(res["steps"][n]["first"] for n in ok) * len(settings)
    budget = float(spec["warm_s"])
    n_warm = int(min(spec["repeat"], budget // max(round_s, 1e-9))) if ok else 0
    for k in range(n_warm):
        order = [(b, n) for b in settings for n in ok]
        for b, name in order if k % 2 == 0 else order[::-1]:
            with _blas_limit(b):
                dt, peak, out = measure_call(calls[name])
            del out
            res["steps"][name]["warm"][str(b)].append(dt)
            res["steps"][name]["peak_warm"].append(peak)
    for name in ok:  # warm peaks exclude the lazy imports of the first call; else the first call's
        st = res["steps"][name]
        st["peak"] = max(st["peak_warm"]) if st["peak_warm"] else st["peak_first"]
        st["peak_source"] = "warm" if st["peak_warm"] else "first"
    res["found"] = found
    res["error"] = error
    return res


# ------------------------------------------------------------------------------ parent
def _run_child(spec: dict[str, Any], env: dict[str, str], timeout: float) -> tuple[dict[str, Any] | None, str | None]:
    """One child process for one row: (its result, None) or (None, why it gave none)."""
    cmd = [sys.executable, __file__, "--child", json.dumps(spec)]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=timeout)
    except subprocess.TimeoutExpired:
        return None, f"killed after {timeout:.0f} s (timeout)"
    if proc.returncode != 0:
        last = (proc.stderr.strip().splitlines() or ["?"])[-1]
        return None, f"child failed: {last}"
    return json.loads(proc.stdout.strip().splitlines()[-1]), None


def grid(quick: bool) -> list[Row]:
    if quick:
        rows = [Row(8, n_in, 4001, 50) for n_in in (1, 3)]
    else:
        rows = [Row(o, i, n, p) for o in (8, 64, 256) for i in (1, 3) for n in (4001, 64001) for p in (50, 200)]
    return sorted(rows, key=lambda r: (r.size, r.order, r.n_in))


def _slope(points: list[tuple[int, float]]) -> float | None:
    """Seconds per byte through the two largest distinct sizes, or None."""
    pts = sorted(dict(points).items())
    if len(pts) < 2:
        return None
    (s1, t1), (s2, t2) = pts[-2], pts[-1]
    return max((t2 - t1) / (s2 - s1), 0.0)


def project(row: Row, done: dict[Row, dict[str, Any]]) -> tuple[float, float] | None:
    """(identify first-call seconds, peak bytes above the baseline) projected for ``row``.

    A line ``a + b * size`` through the finished rows with the same references and order (slope
    from the same references at any order if only one such row); None without such a row.
    """
    def first(r: Row) -> float | None:
        return done[r]["steps"]["identify"]["first"]

    same = [r for r in done if r.n_in == row.n_in and r.order == row.order and first(r) is not None]
    if not same:
        return None
    slope = _slope([(r.size, first(r)) for r in same])
    if slope is None:
        by_order: dict[int, list[tuple[int, float]]] = {}
        for r in done:
            f = first(r)
            if r.n_in == row.n_in and f is not None:
                by_order.setdefault(r.order, []).append((r.size, f))
        slopes = [x for pts in by_order.values() if (x := _slope(pts)) is not None]
        slope = max(slopes) if slopes else 0.0
    ref = max(same, key=lambda r: r.size)
    t_ref = first(ref) or 0.0
    t = max(t_ref - slope * ref.size, 0.0) + slope * row.size
    peaks = [st["peak"] or 0 for st in done[ref]["steps"].values()]
    return t, max(peaks) / ref.size * row.size


def _fmt_warm(w: list[float]) -> str:
    return f"{statistics.median(w):6.2f} [{min(w):.2f}-{max(w):.2f}]" if w else f"{'-':>6}"


def _row_lines(row: Row, m: dict[str, Any], settings: list[int]) -> list[str]:
    """One line per BLAS setting; the first carries the first call, the peak and the modes."""
    lines = []
    for k, b in enumerate(settings):
        head = f"{row.label():<26} {row.size / 1e6:8.1f}" if k == 0 else f"{'':<26} {'':>8}"
        cells = []
        for n in STEPS:
            st = m["steps"][n]
            if st["first"] is None:
                cells.append(f"{'error':<35}" if k == 0 else f"{'':<35}")
                continue
            first = f"{st['first']:6.2f}" if k == 0 else f"{'':>6}"
            star = "*" if st.get("peak_source") == "first" else " "
            peak = f"{st['peak'] / row.size:5.2f}{star}" if k == 0 else f"{'':>6}"
            cells.append(f"{first} {_fmt_warm(st['warm'][str(b)]):<21} {peak}")
        found = (f"{m['found']}/{MODES_HZ.size}" if m.get("found") is not None else "-") if k == 0 else ""
        if k == 0 and m.get("order_reached") is not None:
            found += f" (order {m['order_reached']})"
        blas = "default" if b == 0 else f"{b} thr"
        lines.append(f"{head} {blas:>7} | " + " | ".join(cells) + f" | {found}")
    return lines


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="CI-size grid (a few seconds)")
    ap.add_argument("--repeat", type=int, default=None, help="warm rounds per row (default 3, quick 1)")
    ap.add_argument("--max-row-s", type=float, default=60.0, help="skip rows projected above this [s]")
    ap.add_argument("--max-mem-gb", type=float, default=8.0, help="skip rows projected above this [GB]")
    ap.add_argument("--budget-s", type=float, default=840.0, help="total time budget [s]")
    ap.add_argument("--warm-s", type=float, default=20.0, help="time for warm rounds per row [s]")
    ap.add_argument("--blas", default="0,1",
                    help="BLAS thread settings timed in each row, comma-separated (0 = the default; "
                         "default '0,1': both, interleaved; the first call runs under the first)")
    ap.add_argument("--only", default=None, metavar="ROWS",
                    help="run only these rows, e.g. '256x3x64001x200,8x1x4001x50' (OUTxREFxLINESxORDER)")
    ap.add_argument("--json", default=None, metavar="OUT", help="also write the rows as JSON")
    ap.add_argument("--child", default=None, help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.child is not None:
        print(json.dumps(run_child(json.loads(args.child))))
        return 0
    repeat = args.repeat if args.repeat is not None else (1 if args.quick else 3)
    rows = grid(args.quick)
    if args.only:
        try:
            rows = sorted((Row(*(int(x) for x in item.lower().split("x"))) for item in args.only.split(",")),
                          key=lambda r: (r.size, r.order, r.n_in))
        except TypeError:
            ap.error(f"--only: expected OUTxREFxLINESxORDER items, got {args.only!r}")
    env = dict(os.environ)
    root = str(Path(__file__).resolve().parents[1])
    env["PYTHONPATH"] = root + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env_mem = {**env, "MALLOC_MMAP_THRESHOLD_": "65536"}
    settings = [int(x) for x in args.blas.split(",")]
    blas = ", ".join("default" if b == 0 else f"{b}" for b in settings)
    print(f"bench_scale {time.strftime('%Y-%m-%d %H:%M %Z')}  python {platform.python_version()}  "
          f"numpy {np.__version__}  cores {os.cpu_count()}  load {os.getloadavg()[0]:.1f}  BLAS threads {blas}")
    print("time [s]: first call in a fresh process, then median [min-max] of warm interleaved calls; "
          "peak/data: peak RSS of the call above the RSS before it, over the FRF array bytes")
    head = (f"{'out x ref x lines  order':<26} {'data MB':>8} {'BLAS':>7} | "
            + " | ".join(f"{n + ': first, warm':<28} {'pk/d':>5} " for n in STEPS) + " | modes")
    print(head)
    print("-" * len(head))
    done: dict[Row, dict[str, Any]] = {}
    out_rows: list[dict[str, Any]] = []
    t_start = time.perf_counter()
    for row in rows:
        remaining = args.budget_s - (time.perf_counter() - t_start)
        proj = project(row, done)
        reason = None
        if proj is not None:
            t_proj, peak_proj = proj
            mem_proj = (row.size + peak_proj) / 1e9
            if t_proj > args.max_row_s:
                reason = f"projected identify {t_proj:.0f} s > {args.max_row_s:.0f} s"
            elif mem_proj > args.max_mem_gb:
                reason = f"projected memory {mem_proj:.1f} GB > {args.max_mem_gb:.0f} GB"
            elif 3 * t_proj > remaining:
                reason = f"projected {3 * t_proj:.0f} s > remaining budget {remaining:.0f} s"
        elif remaining <= 0:
            reason = "budget used up"
        if reason is None and row.size * 1.5 / 1e9 > args.max_mem_gb:
            reason = f"data alone {row.size / 1e9:.1f} GB"
        record: dict[str, Any] = {"row": asdict(row), "data_bytes": row.size}
        if reason is not None:
            print(f"{row.label():<26} {row.size / 1e6:8.1f} | skipped: {reason}")
            record["skipped"] = reason
            out_rows.append(record)
            continue
        spec = {**asdict(row), "repeat": repeat, "warm_s": min(args.warm_s, max(remaining, 0.0)),
                "blas": settings}
        # the time child (default allocator), then the memory child (small mmap threshold)
        m, why = _run_child(spec, env, 3 * args.max_row_s + 60)
        mem, why_mem = (None, None) if m is None else _run_child(
            {**spec, "repeat": 1, "blas": settings[:1]}, env_mem, 3 * args.max_row_s + 60)
        if m is None or mem is None:
            print(f"{row.label():<26} {row.size / 1e6:8.1f} | {why or why_mem}")
            record["skipped"] = why or why_mem
            out_rows.append(record)
            continue
        for name, st in m["steps"].items():
            ms = mem["steps"].get(name) or {}
            for key in ("peak_first", "peak", "peak_warm", "peak_source"):
                st[key] = ms.get(key)
        m["rss_base_memory_child"] = mem["rss_base"]
        done[row] = m
        record.update(m)
        out_rows.append(record)
        for line in _row_lines(row, m, settings):
            print(line, flush=True)
        if m.get("error"):
            print(f"    error: {m['error']}")
    print(f"total {time.perf_counter() - t_start:.0f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(out_rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
