"""Peak memory of ``ema-rig frf`` on a large time-data file (issue 17): peak RSS / file size.

Writes a binary 58b file of ``--samples`` float64 samples in all (one force and one response
channel of half as many samples each, fs = 1000 Hz, a random force through a 120 Hz resonator),
streamed to disk in blocks, then runs ``ema-rig frf`` on it in a child process per option set and
reads the child's peak resident set size (``ru_maxrss``). The baseline is a child that only
imports what ``frf`` imports (interpreter, numpy, scipy): it is reported, not subtracted.

Memory is what this measures (a work limit, not a time budget); the times are printed for
information. The issue's numbers before the fix: 10^8 samples (800 MB) -> 11.8 GB peak (14.8x);
``--overlap 0.9999`` on a 650 kB file -> 2.4-3.2 GB.

Run::

    python benchmarks/bench_frf_memory.py [--samples 100000000] [--dir DIR] [--keep]
    python benchmarks/bench_frf_memory.py --samples 40000 --options "--overlap 0.9999"
"""

from __future__ import annotations

import argparse
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
FS = 1000.0

_CHILD = """
import resource, sys, time
sys.path.insert(0, {repo!r})
t0 = time.perf_counter()
if sys.argv[1] == "baseline":
    import numpy, scipy.signal, scipy.linalg  # noqa: F401
    import ema_rig.cli, ema_rig.spectral, ema_rig.io.time_data, ema_rig.io.uff  # noqa: F401
    rc = 0
else:
    from ema_rig.cli import main
    rc = main(sys.argv[1:])
print("RESULT", rc, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024, time.perf_counter() - t0)
"""


def _header(node: int, code: int, label: str, axis: str, n: int) -> bytes:
    def line(text: str) -> str:
        return text[:80].ljust(80) + "\n"

    nbytes = 8 * n
    lines = [f"    -1\n    58b     1     2          11{nbytes:12d}     0     0           0           0\n"]
    lines += [line(t) for t in (f"{axis} {node}", "bench_frf_memory", "24-Nov-26 00:00:00", "NONE", "NONE")]
    lines.append(line(f"{1:5d}{0:10d}{0:5d}{0:10d} {'NONE':<10s}{node:10d}{3:4d} {'NONE':<10s}{1:10d}{3:4d}"))
    lines.append(line(f"{4:10d}{n:10d}{1:10d}{0.0:13.5E}{1 / FS:13.5E}{0.0:13.5E}"))
    lines.append(line(f"{17:10d}{0:5d}{0:5d}{0:5d} {'Time':<20s} {'s':<20s}"))
    len_exp, force_exp = (0, 1) if code == 13 else (1, 0)
    lines.append(line(f"{code:10d}{len_exp:5d}{force_exp:5d}{0:5d} {axis:<20s} {label:<20s}"))
    lines += [line(f"{0:10d}{0:5d}{0:5d}{0:5d} {'NONE':<20s} {'NONE':<20s}")] * 2
    return "".join(lines).encode()


def write_time_file(path: Path, n_total: int, seed: int = 1) -> int:
    """A 58b force + response file of ``n_total`` float64 samples, written in blocks; its size."""
    from scipy.signal import lfilter, lfilter_zi

    n = n_total // 2
    p = np.exp((-0.02 * 2 * np.pi * 120.0 + 1j * 2 * np.pi * 120.0 * np.sqrt(1 - 0.02**2)) / FS)
    a = np.real(np.poly([p, p.conj()]))
    b = np.array([1.0, -2.0, 1.0])
    block = 1 << 20
    with open(path, "wb") as fh:
        for node, code, label, axis in ((1, 13, "N", "Force"), (2, 12, "m/s^2", "Acceleration")):
            fh.write(_header(node, code, label, axis, n))
            rng = np.random.default_rng(seed)  # the same force both passes: the response is its filter
            zi = lfilter_zi(b, a) * 0.0
            for k in range(0, n, block):
                x = rng.standard_normal(min(block, n - k))
                if code == 13:
                    fh.write(x.astype("<f8").tobytes())
                else:
                    y, zi = lfilter(b, a, x, zi=zi)
                    fh.write(y.astype("<f8").tobytes())
            fh.write(b"    -1\n")
    return path.stat().st_size


def _child(args: list[str]) -> tuple[int, int, float, str]:
    env = dict(os.environ, MPLBACKEND="Agg")
    r = subprocess.run([sys.executable, "-c", _CHILD.format(repo=str(REPO)), *args], capture_output=True,
                       text=True, env=env)
    line = next((ln for ln in r.stdout.splitlines() if ln.startswith("RESULT")), None)
    if line is None:
        return -1, 0, 0.0, r.stderr[-2000:]
    _, rc, rss, dt = line.split()
    return int(rc), int(rss), float(dt), r.stderr.strip().splitlines()[-1] if r.stderr.strip() else ""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--samples", type=int, default=100_000_000, help="samples in the file (all channels)")
    ap.add_argument("--dir", default=None, help="folder for the file (default: a temporary one)")
    ap.add_argument("--options", action="append", default=None,
                    help="frf options, one set per use (default: the defaults, and --segment 65536)")
    args = ap.parse_args(argv)
    option_sets = args.options or ["", "--segment 65536 --binary"]
    with tempfile.TemporaryDirectory(dir=args.dir) as tmp:
        src = Path(tmp) / "time.ufb"
        t0 = time.perf_counter()
        size = write_time_file(src, args.samples)
        print(f"file: {args.samples} samples, {size / 1e6:.1f} MB (written in {time.perf_counter() - t0:.0f} s)")
        rc, base, _, _ = _child(["baseline"])
        print(f"baseline (interpreter + numpy + scipy + ema_rig): {base / 1e6:.0f} MB")
        print(f"{'options':<36} {'exit':>4} {'peak MB':>9} {'peak/file':>9} {'(peak-base)/file':>16} {'s':>6}")
        worst = 0.0
        for opts in option_sets:
            out = Path(tmp) / "frf.uff"
            rc, rss, dt, err = _child(["frf", str(src), "-o", str(out), *shlex.split(opts)])
            ratio = rss / size
            worst = max(worst, ratio)
            print(f"{opts or '(defaults)':<36} {rc:>4} {rss / 1e6:>9.0f} {ratio:>9.2f} {(rss - base) / size:>16.2f} "
                  f"{dt:>6.0f}" + (f"   {err}" if rc else ""))
            out.unlink(missing_ok=True)
    print(f"worst peak / file size: {worst:.2f}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
