"""Benchmark: cost of the ML refinement, ``identify`` with and without ``refine=True``, in one run.

Data:

* the bundled rig file ``data/b6302_1000N_1200rpm.uff`` read with ``data/rig.toml`` (8 outputs,
  1 reference, band 150-1000 Hz at 0.5 Hz: 1701 lines, 10 modes);
* a 256-output synthetic file written to a temporary folder with ``write_uff58`` and read back:
  modal sum of 8 modes in 100-900 Hz (1-2 % damping), 1 reference, 0.5 Hz lines in 0-1000 Hz,
  1 % proportional complex noise (seeded).

For each, after one untimed call of each (imports, caches), ``identify(data, band=...)`` and
``identify(data, band=..., refine=True)`` run in ``--repeat`` alternating pairs (A B, B A, ...;
single BLAS thread inside, as the library does): median (min-max) wall times and the median
(min-max) of the per-pair ratios; then what the refinement changed (the sigma of the housing
mode on the rig file).

Run: ``python benchmarks/bench_refine.py [--repeat N]``.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import warnings
from pathlib import Path

import numpy as np
from _timing import paired  # benchmarks/_timing.py, beside this script

REPO = Path(__file__).resolve().parent.parent


def _spread(x: list[float], fmt: str = ".3f") -> str:
    return f"{statistics.median(x):{fmt}} ({min(x):{fmt}}-{max(x):{fmt}})"


def synthetic_256(path: Path) -> None:
    from ema_rig.frf import FRFData
    from ema_rig.io.uff import write_uff58

    rng = np.random.default_rng(256)
    fn = np.array([130.0, 210.0, 320.0, 410.0, 505.0, 640.0, 720.0, 860.0])
    zeta = rng.uniform(0.01, 0.02, fn.size)
    lam = 2 * np.pi * fn * (-zeta + 1j * np.sqrt(1 - zeta**2))
    freq = np.arange(0.0, 1000.0 + 0.25, 0.5)
    jw = 2j * np.pi * freq
    n_out = 256
    phi = rng.uniform(-1.0, 1.0, (fn.size, n_out)) * 0.3
    h = np.zeros((n_out, 1, freq.size), complex)
    for r in range(fn.size):
        res = phi[r] * phi[r, 0] / (2j * lam[r].imag)
        h[:, 0] += res[:, None] / (jw - lam[r]) + np.conj(res)[:, None] / (jw - lam[r].conj())
    h *= jw**2
    h += 0.01 * np.abs(h) * (rng.standard_normal(h.shape) + 1j * rng.standard_normal(h.shape)) / np.sqrt(2)
    dofs = [f"{i + 1}+Y" for i in range(n_out)]
    write_uff58(path, FRFData(freq, h, dofs, [dofs[0]]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args()
    from ema_rig.config import load_rig
    from ema_rig.identification import identify
    from ema_rig.io.uff import read_uff58

    rig = load_rig(REPO / "data" / "rig.toml")
    cases = [("rig file b6302_1000N_1200rpm (8 out, 1701 lines)", read_uff58(REPO / "data" / "b6302_1000N_1200rpm.uff",
                                                                           rig=rig), (150.0, 1000.0), args.repeat)]
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / "synthetic_256.uff"
        synthetic_256(p)
        cases.append(("synthetic 256 outputs (1801 lines)", read_uff58(p), (100.0, 1000.0), max(1, args.repeat // 2)))
    print(f"{'data':48s} {'identify [s]':>22s} {'+refine [s]':>22s} {'ratio':>18s}  refinement")
    for name, data, band, rep in cases:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            plain = identify(data, band=band)
            ref = identify(data, band=band, refine=True)
            ta, tb = paired(lambda data=data, band=band: identify(data, band=band),
                            lambda data=data, band=band: identify(data, band=band, refine=True), rep)
        r = ref.refinement  # type: ignore[attr-defined]
        info = f"converged={r.converged}, {r.noise_source}, {r.n_iter} evaluations, {ref.modes.n_modes} modes"  # type: ignore[attr-defined]
        ratio = [b / a for a, b in zip(ta, tb, strict=True)]
        print(f"{name:48s} {_spread(ta):>22s} {_spread(tb):>22s} {_spread(ratio, '.2f'):>18s}  {info}")
        if name.startswith("rig"):
            k = int(np.argmin(np.abs(plain.natural_freq - 626.16)))  # type: ignore[attr-defined]
            print(f"    housing mode: PolyMAX {plain.natural_freq[k]:.3f} +- {plain.natural_freq_std[k]:.3f} Hz "  # type: ignore[attr-defined]
                  f"(cluster spread), refined {ref.natural_freq[k]:.3f} +- {ref.natural_freq_std[k]:.3f} Hz "  # type: ignore[attr-defined]
                  "(Fisher); truth 626.159 Hz")


if __name__ == "__main__":
    main()
