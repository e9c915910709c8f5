"""Study: which of the default ``identify``'s pieces two Python threads can run side by side (issue 18).

The default ``identify`` is a chain of numpy and LAPACK calls made from Python. A second thread
pays only when the two threads' work overlaps; numpy's calls release the interpreter lock (GIL)
inside their loops but take it back to return, so a call whose loop is short hands the lock to and
fro, and the hand-off (a futex wake and a context switch) costs more than the loop; some SciPy
wrappers of BLAS / LAPACK keep the lock for the whole call (part 2). This
study times, on this machine, the pieces ``identify`` is made of at the sizes of
``bench_default_ml.py``'s two files (the bundled rig file: 8 channels x 1701 lines; the 256-output
file: 256 x 1801), each piece run ``2 k`` times one after the other and split over two threads
(``k`` each), with one BLAS thread:

1. **Pieces alone** (``pieces``): a reduction over the lines of a block of 32 channels (the noise
   fit's block), an ``exp`` over the same block, the noise fit's Newton iteration on one block
   (:func:`~ema_rig.identification.noise._newton_block`), LAPACK ``dgeev`` on the companion matrix of
   a PolyMAX order below the Aberth chain (degree 46), the SVD of the LSFD basis of the rig file
   (3402 x 22, :func:`~ema_rig.identification.lsfd._projector`), the rig file's local-ML evaluation
   (:meth:`~ema_rig.identification.ml._Segment.evaluate`: ~25 small numpy calls).
2. **Does the call release the lock?** While a second thread is inside one long call (700 x 700;
   the SciPy BLAS wrappers 2200 x 2200),
   the calling thread spins a Python loop: the CPU share it gets is near 0 when the call holds the
   lock. It is compared with the share it gets beside a second thread that sleeps as long (what
   the machine's other load leaves it; on a loaded machine a call that releases the lock halves it,
   as the two busy threads share what is left): "held" below a quarter of that (the second thread
   first waits for the lock, up to one switch interval, 5 ms, which the caller runs: the calls take
   a few hundred ms so that this start stays a small part). SciPy's ``dgeev`` wrapper (what PolyMAX's
   :func:`~ema_rig.identification.plscf._eigvals` calls) is compared with ``numpy.linalg.eigvals``,
   and the SciPy BLAS / LAPACK wrappers PolyMAX's Gram updates, ``Q`` rows and order limit call
   (``dsyrk``, ``dtrmm``, ``dpotrf``) and the local ML's QR (``dgeqrf``) with numpy's calls.
3. **Overlap** (``overlap``): the caller runs a Python-bound piece (the ML evaluations) while a second
   thread runs the 22 companion eigenvalue calls of PolyMAX orders 2..44 (SciPy's ``dgeev``, as
   PolyMAX calls it): the wall time of both against their sum.

Wall time ``time.perf_counter``, CPU ``time.process_time`` (both threads), the median of
``--repeat`` runs. Run under ``chrt -f 10`` on a shared machine (the other load then cannot take the
cores): ``PYTHONPATH=. python benchmarks/study_gil_handoff.py [--repeat 9]``.
"""

from __future__ import annotations

import argparse
import os
import statistics
import threading
import time
from collections.abc import Callable

import numpy as np
from scipy.linalg.blas import dsyrk, dtrmm
from scipy.linalg.lapack import dgeqrf, dpotrf

from ema_rig._blas import single_threaded
from ema_rig.identification.lsfd import _projector
from ema_rig.identification.ml import _Segment
from ema_rig.identification.noise import _newton_block
from ema_rig.identification.plscf import _eigvals


def _timed(run: Callable[[], object], repeat: int) -> tuple[float, float]:
    """Median wall and CPU time [ms] of ``run``."""
    run()
    wall, cpu = [], []
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        run()
        wall.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    return 1e3 * statistics.median(wall), 1e3 * statistics.median(cpu)


def _in_two(piece: Callable[[], object], k: int) -> Callable[[], None]:
    """``2 k`` calls of ``piece``: ``k`` in this thread, ``k`` in a second one."""

    def run() -> None:
        t = threading.Thread(target=lambda: [piece() for _ in range(k)])
        t.start()
        for _ in range(k):
            piece()
        t.join()

    return run


def _pieces(rng: np.random.Generator) -> dict[str, tuple[Callable[[], object], int]]:
    """The pieces, each with its count ``k`` per thread."""
    u = np.exp(rng.uniform(-6.0, 4.0, (32, 1801)))
    z = (2e-3 + 0.01 * u) * rng.exponential(size=u.shape)
    cnt = np.full(32, 1801.0)
    lo, hi = np.full(32, -3.0), np.full(32, 3.0)
    comp = np.asfortranarray(np.diag(np.ones(45), -1))
    comp[0] = rng.standard_normal(46)
    basis = rng.standard_normal((3402, 22))
    seg, theta = _rig_segment(rng)
    return {
        "sum over lines, 32 x 1801": (lambda: np.sum(z, axis=1), 40),
        "exp, 32 x 1801": (lambda: np.exp(z), 40),
        "noise Newton block, 32 x 1801": (lambda: _newton_block(z, u, cnt, lo, hi, 60), 4),
        "dgeev, companion 46 x 46": (lambda: _eigvals(comp.copy(order="F")), 20),
        "SVD of the LSFD basis, 3402 x 22": (lambda: _projector(basis), 4),
        "ML evaluate, rig segment": (lambda: seg.evaluate(theta), 20),
    }


def _rig_segment(rng: np.random.Generator) -> tuple[_Segment, np.ndarray]:
    """A local-ML segment of the rig file's size: 150 lines, 8 channels, 3 modes, a 6-term background."""
    f = np.linspace(540.0, 600.0, 150)
    jw = 2j * np.pi * f
    lam = np.array([-2.0 + 2j * np.pi * 551.0, -2.5 + 2j * np.pi * 570.0, -3.0 + 2j * np.pi * 590.0])
    h = (rng.standard_normal((8, 3)) @ (1.0 / (jw[None, :] - lam[:, None]))).T  # (150, 8)
    yw = np.concatenate([h.real, h.imag], axis=0)
    seg = _Segment(jw, 2, yw, np.ones(f.size), lam, 6, np.zeros(0, np.complex128), (np.zeros(1), np.ones(1)),
                      1e-10)
    return seg, seg.theta(lam)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args()
    rng = np.random.default_rng(0)
    print(f"# {time.strftime('%Y-%m-%dT%H:%MZ', time.gmtime())}, {os.cpu_count()} cores, load average "
          f"{os.getloadavg()[0]:.1f}, BLAS one thread; median of {args.repeat} runs")
    with single_threaded():
        print(f"{'piece (2 k calls)':36s} {'k':>3s} {'serial wall/cpu [ms]':>22s} {'two threads wall/cpu':>22s} "
              f"{'wall ratio':>10s} {'per call [us]':>13s}")
        for name, (piece, k) in _pieces(rng).items():
            s_w, s_c = _timed(lambda p=piece, k=k: [p() for _ in range(2 * k)], args.repeat)
            t_w, t_c = _timed(_in_two(piece, k), args.repeat)
            print(f"{name:36s} {k:3d} {s_w:10.2f} / {s_c:8.2f} {t_w:10.2f} / {t_c:8.2f} {t_w / s_w:10.2f} "
                  f"{1e3 * s_w / (2 * k):13.1f}")
        # does a call release the lock? the CPU the calling thread gets while a second thread is inside
        # one long call, against what it gets beside a sleeping thread (near 0 when the call holds the lock)
        big = np.asfortranarray(rng.standard_normal((700, 700)))
        big2 = np.asfortranarray(rng.standard_normal((2200, 2200)))
        spd = np.asfortranarray(big2 @ big2.T + 2200.0 * np.eye(2200))
        tri = np.asfortranarray(np.triu(spd))
        longs: dict[str, Callable[[], object]] = {
            "scipy dgeev 700 x 700 (plscf._eigvals)": lambda: _eigvals(big.copy(order="F")),
            "numpy.linalg.eigvals 700 x 700": lambda: np.linalg.eigvals(big),
            "numpy.linalg.svd 700 x 700": lambda: np.linalg.svd(big),
            "20 matrix products 700 x 700": lambda: [big @ big for _ in range(20)],
            # the SciPy wrappers PolyMAX's Gram updates, Q rows and order limit call (plscf: dsyrk, dtrmm, dpotrf)
            "scipy dsyrk 2200 x 2200": lambda: dsyrk(1.0, big2),
            "scipy dtrmm 2200 x 2200": lambda: dtrmm(1.0, tri, big2),
            "scipy dpotrf 2200 x 2200": lambda: dpotrf(spd),
            "scipy dgeqrf 2200 x 2200 (ml._qr)": lambda: dgeqrf(big2),
        }
        def caller_share(c: Callable[[], object]) -> tuple[float, float]:
            """Wall time [s] of ``c`` in a second thread and the CPU share the spinning caller gets meanwhile."""
            done = threading.Event()

            def side() -> None:
                c()
                done.set()

            t = threading.Thread(target=side)
            t0, c0 = time.perf_counter(), time.thread_time()
            t.start()
            while not done.is_set():
                pass
            t.join()
            wall = time.perf_counter() - t0
            return wall, (time.thread_time() - c0) / wall

        for name, call in longs.items():
            wall, share = caller_share(call)
            # the share the caller gets on this machine now beside a second thread that holds nothing (sleeps as long)
            _, base = caller_share(lambda w=wall: time.sleep(w))
            print(f"{name:40s}: {1e3 * wall:6.0f} ms; meanwhile the calling thread got {100 * share:3.0f} % of a core "
                  f"({100 * base:3.0f} % beside a sleeping thread): "
                  f"{'lock held' if share < 0.25 * base else 'lock released'}")
        # overlap: Python-bound ML evaluations here, the PolyMAX orders' dgeev calls in a second thread
        seg, theta = _rig_segment(rng)
        comps = []
        for deg in range(2, 46, 2):
            c = np.asfortranarray(np.diag(np.ones(deg - 1), -1))
            c[0] = rng.standard_normal(deg)
            comps.append(c)

        def py_part() -> None:
            for _ in range(40):
                seg.evaluate(theta)

        def eig_part() -> None:
            for c in comps:
                _eigvals(c.copy(order="F"))

        def both() -> None:
            t = threading.Thread(target=eig_part)
            t.start()
            py_part()
            t.join()

        p_w, _ = _timed(py_part, args.repeat)
        e_w, _ = _timed(eig_part, args.repeat)
        b_w, b_c = _timed(both, args.repeat)
        print(f"overlap: 40 ML evaluations {p_w:.2f} ms + 22 dgeev (degrees 2..44) {e_w:.2f} ms = {p_w + e_w:.2f} ms "
              f"one after the other; side by side {b_w:.2f} ms wall ({b_c:.2f} ms CPU): "
              f"{100 * (p_w + e_w - b_w) / e_w:.0f} % of the dgeev time hidden")


if __name__ == "__main__":
    main()
