"""Study: the directions issue 22's brief for y_plscf9 proposed for the pLSCF speed points, measured.

On the data and calls of ``bench_plscf.py`` (8 outputs x 4000 lines, every even order 2..N, BLAS
limited to one thread, CPU time ``time.process_time``, the fastest of ``--repeat`` alternating
rounds, see ``study_plscf_bounds.fastest``), each variant against what ``plscf`` does now, with
how far its result is from the current one:

1. **Companion eigenvalues, one reference, N = 50** (the 25 companion matrices ``plscf`` hands to
   LAPACK ``dgeev``, recorded in one call): ``dgeev`` as now; ``numpy.linalg.eigvals``; the
   Hessenberg QR alone (``dlahqr`` from ``scipy.linalg.cython_lapack``, called through ctypes: a
   companion matrix IS upper Hessenberg, so this skips ``dgeev``'s balancing and reduction; for
   n < 75 ``dhseqr`` calls ``dlahqr``), unbalanced and after ``dgebal``; ``dgebal`` alone; ``dgeev``
   on the transposed companion, on the companion flipped (coefficients in the last row) and on the
   companion of the polynomial itself (roots z, not 1 / z); single precision ``sgeev``, alone and
   followed by three Newton steps on every root (``plscf``'s polish, ``_refine_many``).
   Distance: the largest relative distance of a root to the nearest ``dgeev`` root, per order.
2. **Lag sums' FFT** (``_re_lag_sums`` on 8 complex channels of 4000 lines, lags -50..50): the
   inverse real FFT of length 7998 = 2 3 31 43 (now; numpy and scipy.fft), of length 8000 (5-smooth:
   a DIFFERENT transform, angles pi k l / 4000 instead of pi k l / 3999, speed only: a zero-padded
   transform does not give these lags), and Bluestein's chirp-z form of the same sums (exact
   angles; a convolution of length >= n + 2p by complex FFTs of the 5-smooth length 4320).
3. **Two references, N = 50**: ``dgeev`` on the 15 block companion matrices (not Hessenberg:
   identity blocks two rows below the diagonal) against ``dgeev`` on the scalar companion of
   ``det A(z)`` (Hessenberg: ``dgehrd`` has nothing to do); distance of its roots to the block ones.

Run (from the repository root): ``PYTHONPATH=. python benchmarks/study_plscf_directions.py [--repeat 9]``.
"""

from __future__ import annotations

import argparse
import ctypes
import importlib
import os
import time
from typing import Any

import bench_plscf as bp  # beside this script: its data, calls and BLAS limit
import numpy as np
from study_plscf_bounds import fastest, record_roots


def _dlahqr() -> Any:
    """LAPACK ``dlahqr`` (eigenvalues of an upper Hessenberg matrix) from scipy's Cython LAPACK capsule."""
    import scipy.linalg.cython_lapack as cl

    cap = cl.__pyx_capi__["dlahqr"]  # type: ignore[attr-defined]
    api = ctypes.pythonapi
    api.PyCapsule_GetName.restype, api.PyCapsule_GetName.argtypes = ctypes.c_char_p, [ctypes.py_object]
    api.PyCapsule_GetPointer.restype = ctypes.c_void_p
    api.PyCapsule_GetPointer.argtypes = [ctypes.py_object, ctypes.c_char_p]
    ip, dp = ctypes.POINTER(ctypes.c_int), ctypes.POINTER(ctypes.c_double)
    fn = ctypes.CFUNCTYPE(None, ip, ip, ip, ip, ip, dp, ip, dp, dp, ip, ip, dp, ip, ip)(
        api.PyCapsule_GetPointer(cap, api.PyCapsule_GetName(cap)))

    def eig(h: np.ndarray) -> np.ndarray:  # h: Fortran-ordered, overwritten
        n = h.shape[0]
        wr, wi, z = np.empty(n), np.empty(n), np.zeros(1)
        info = ctypes.c_int(0)

        def i(v: int) -> Any:
            return ctypes.byref(ctypes.c_int(v))

        fn(i(0), i(0), i(n), i(1), i(n), h.ctypes.data_as(dp), i(n), wr.ctypes.data_as(dp), wi.ctypes.data_as(dp),
           i(1), i(1), z.ctypes.data_as(dp), i(1), ctypes.byref(info))
        if info.value:
            raise np.linalg.LinAlgError(f"dlahqr info {info.value}")
        return wr + 1j * wi

    return eig


def set_dist(a: np.ndarray, b: np.ndarray) -> float:
    """Largest relative distance of a value of ``a`` to the nearest value of ``b``."""
    return float((np.abs(a[:, None] - b[None, :]).min(axis=1) / np.abs(a)).max())


def bluestein_re_lag_sums(x: np.ndarray, p: int, length: int) -> np.ndarray:
    """``Re sum_k x_k exp(j pi k l / (n - 1))``, ``l = -p..p``, by the chirp-z convolution (FFT length ``length``).

    ``k l = (k^2 + l^2 - (k - l)^2) / 2``: with ``c_m = exp(j pi m^2 / (2 (n - 1)))`` (angle taken
    modulo 2 pi exactly through ``m^2 mod 4 (n - 1)``) the sum is ``c_l sum_k (x_k c_k) conj(c_{k-l})``,
    a correlation over ``k - l`` in ``-p..n-1+p``, exact for a circular length >= n + 2p.
    """
    n = x.shape[-1]

    def chirp(m: np.ndarray) -> np.ndarray:
        return np.exp(1j * np.pi * ((m * m) % (4 * (n - 1))) / (2 * (n - 1)))

    lags = np.arange(-p, p + 1)
    v = np.conj(chirp(np.arange(-p, n + p)))
    z = np.fft.ifft(np.fft.fft(x * chirp(np.arange(n)), length, axis=-1) * np.fft.fft(v[::-1], length), axis=-1)
    return (chirp(lags) * z[..., v.size - 1 - p + lags]).real


def main() -> int:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--repeat", type=int, default=9)
    args = ap.parse_args()
    import scipy.fft
    from scipy.linalg.lapack import dgebal, dgeev, sgeev

    mod = importlib.import_module("ema_rig.identification.plscf")
    dlahqr = _dlahqr()
    print(f"# {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}, load average {os.getloadavg()[0]:.1f}, "
          f"BLAS 1 thread, CPU ms, fastest of {args.repeat} alternating rounds")
    with bp.blas_threads(1):
        # 1. one reference, N = 50: the companion matrices of one plscf call
        freq, h, _ = bp.make_arrays(1)
        comps, eig_roots, _ = record_roots(bp.ema_data(freq, h), 50)
        lows = [c for c, _ in eig_roots]  # det coefficients = alpha_low of one reference

        def ev(c: np.ndarray) -> np.ndarray:
            wr, wi, _, _, _ = dgeev(c, compute_vl=0, compute_vr=0, overwrite_a=0)
            return np.asarray(wr + 1j * wi)

        def balanced(c: np.ndarray) -> np.ndarray:
            return np.asfortranarray(dgebal(c, scale=1, permute=1)[0])

        variants = {
            "dgeev (now)": (comps, ev),
            "numpy.linalg.eigvals": (comps, np.linalg.eigvals),
            "dlahqr, no balancing": (comps, lambda c: dlahqr(c.copy(order="F"))),
            "dgebal + dlahqr": (comps, lambda c: dlahqr(balanced(c))),
            "dgebal alone": (comps, lambda c: dgebal(c, scale=1, permute=1)),
            "dgeev, transposed": ([np.asfortranarray(c.T) for c in comps], ev),
            "dgeev, flipped": ([np.asfortranarray(c[::-1, ::-1]) for c in comps], ev),
            "dgeev, roots z": ([mod._companion((c / c[-1])[:, None, None]) for c in lows], ev),
            "sgeev (float32)": ([np.asfortranarray(c, dtype=np.float32) for c in comps],
                                lambda c: (lambda r: r[0] + 1j * r[1])(sgeev(c, compute_vl=0, compute_vr=0))),
        }
        t = fastest({k: (lambda m=m, f=f: [f(c) for c in m]) for k, (m, f) in variants.items()}, args.repeat)
        print("\n1. one reference, N = 50: the 25 companion matrices (degrees 2..50)")
        print(f"{'variant':>22} | {'CPU ms':>7} {'/ dgeev':>7} | max rel distance of a root to dgeev's (1 / z for 'roots z')")
        for k, (m, f) in variants.items():
            if k == "dgebal alone":
                dist = "-"
            else:
                d = 0.0
                for c, (_, z) in zip(m, eig_roots, strict=True):
                    w = np.asarray(f(c), dtype=complex)
                    w = 1.0 / w if k == "dgeev, roots z" else w
                    d = max(d, set_dist(1.0 / z, w))
                dist = f"{d:.1e}"
            print(f"{k:>22} | {t[k] * 1e3:7.3f} {t[k] / t['dgeev (now)']:7.2f} | {dist}")
        # single precision needs every root (not only the stable ones, as now) polished: three
        # Newton steps of plscf's own polish on alpha_low, all orders at once
        high = np.zeros((len(lows), max(c.size for c in lows), 1, 1))
        for k, c in enumerate(lows):
            high[k, : c.size, 0, 0] = c
        c32 = variants["sgeev (float32)"][0]

        def sgeev_polished() -> tuple[np.ndarray, np.ndarray]:
            w = [np.asarray(variants["sgeev (float32)"][1](c), dtype=complex) for c in c32]
            owner = np.repeat(np.arange(len(w)), [x.size for x in w])
            return mod._refine_many(high, owner, 1.0 / np.concatenate(w), iters=3), owner

        t = fastest({"dgeev": lambda: [ev(c) for c in comps], "sgeev + polish": sgeev_polished}, args.repeat)
        zp, owner = sgeev_polished()
        d = max(set_dist(z, zp[owner == k]) for k, (_, z) in enumerate(eig_roots))
        print(f"{'sgeev + 3 Newton steps':>22} | {t['sgeev + polish'] * 1e3:7.3f} {t['sgeev + polish'] / t['dgeev']:7.2f} | "
              f"{d:.1e} (z against dgeev's z; its dgeev row {t['dgeev'] * 1e3:.3f} ms)")

        # 2. the lag sums' inverse FFT
        p = 50
        rng = np.random.default_rng(0)
        x = rng.standard_normal((8, 4000)) + 1j * rng.standard_normal((8, 4000))
        now = mod._re_lag_sums(x, p)
        fft_variants = {
            "irfft 7998 (now)": lambda: mod._re_lag_sums(x, p),
            "numpy irfft 7998": lambda: np.fft.irfft(x, n=7998, axis=-1),
            "scipy.fft irfft 7998": lambda: scipy.fft.irfft(x, n=7998, axis=-1),
            "numpy irfft 8000": lambda: np.fft.irfft(x, n=8000, axis=-1),
            "Bluestein 4320": lambda: bluestein_re_lag_sums(x, p, 4320),
        }
        t = fastest(fft_variants, args.repeat * 5)
        blue = bluestein_re_lag_sums(x, p, 4320)
        print("\n2. lag sums of 8 complex channels x 4000 lines, lags -50..50")
        print(f"{'variant':>22} | {'CPU ms':>7}")
        for k in fft_variants:
            print(f"{k:>22} | {t[k] * 1e3:7.3f}")
        print(f"Bluestein vs now: max |difference| / max |sum| = {np.abs(blue - now).max() / np.abs(now).max():.1e}")

        # 3. two references, N = 50: block companions against the det polynomial's scalar companion
        freq, h, _ = bp.make_arrays(2)
        comps2, eig2, _ = record_roots(bp.ema_data(freq, h), 50)
        scal = [mod._companion(c[::-1, None, None]) for c, _ in eig2]  # det A_low: c_0 = 1, reversed monic
        t = fastest({"block": lambda: [ev(c) for c in comps2], "scalar": lambda: [ev(c) for c in scal]}, args.repeat)
        d = max(set_dist(z, 1.0 / ev(s)) for (_, z), s in zip(eig2, scal, strict=True))
        print(f"\n3. two references, N = 50: {len(comps2)} block companions (sizes {comps2[0].shape[0]}.."
              f"{comps2[-1].shape[0]})")
        print(f"dgeev block {t['block'] * 1e3:.3f} ms, scalar companion of det A {t['scalar'] * 1e3:.3f} ms "
              f"({t['scalar'] / t['block']:.2f}); max rel distance of a root {d:.1e}")
    print(f"# load average at the end {os.getloadavg()[0]:.1f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
