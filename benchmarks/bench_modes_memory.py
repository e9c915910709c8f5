"""Peak memory of ``ema-rig modes`` on a large binary UFF58 file, against the size of its FRFs.

Data: 128 outputs x 2 references x 16 001 lines (50-2 000 Hz), the six-mode modal sum of
``bench_scale.py`` (150-1 600 Hz, 1 % complex noise), written with
``ema_rig.io.uff.write_uff58(..., binary=True)`` (58b, float64) into a temporary folder.
FRF data = 128 * 2 * 16 001 * 16 bytes = 65.5 MB.

Three kinds of fresh child process, run interleaved ``--repeat`` times (default 3):

* ``import``: ``python -c "import ema_rig.io.uff, ema_rig.identification"`` (the bare import);
* ``read``:   the same import plus ``read_uff58(FILE)``;
* ``modes``:  ``ema-rig modes FILE --json OUT`` (the CLI's ``main`` as the console script calls
  it; whole file, default band and order).

The peak resident set of each child is its own ``VmHWM`` (``/proc/self/status``), written by an
``atexit`` hook when it ends (not ``ru_maxrss``, which Linux carries over from the forking parent).
Reported, as medians with min-max over the repeats:

* ``modes - import``: peak of ``ema-rig modes`` above the bare import, / FRF data (issue 13's
  measure; goal <= 2.5);
* ``modes - read``: what identification adds above reading the file, / FRF data;
* ``read - import``: what reading costs, / FRF data;
* whether every true natural frequency is among the modes of the JSON within 0.1 %.

Run from the repository root::

    python benchmarks/bench_modes_memory.py [--repeat N] [--keep FILE]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_scale import FREQ_TOL, MODES_HZ, data_bytes, synthetic_frf  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
N_OUT, N_IN, N_LINES = 128, 2, 16001
GOAL = 2.5


# Each child records its own peak RSS (VmHWM, per process image) when it exits. The rusage of a
# child (ru_maxrss) is not used: Linux carries it over from the forking parent across exec, so the
# parent's own memory would leak into every child's figure.
_WRAP = """import atexit, sys
_hwm_file = sys.argv.pop(1)
def _hwm():
    with open('/proc/self/status') as fh:
        kb = next(int(line.split()[1]) for line in fh if line.startswith('VmHWM:'))
    with open(_hwm_file, 'w') as out:
        out.write(str(kb * 1024))
atexit.register(_hwm)
"""


def run_measured(body: str, args: list[str], env: dict[str, str], tmp: Path) -> tuple[int, float, int, str]:
    """Run ``body`` (Python source, ``sys.argv[1:] = args``) in a fresh interpreter.

    Returns (exit code, wall seconds, peak RSS of that process [bytes], stderr).
    """
    hwm_file = tmp / "hwm.txt"
    hwm_file.unlink(missing_ok=True)
    cmd = [sys.executable, "-c", _WRAP + body, str(hwm_file), *args]
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    dt = time.perf_counter() - t0
    rss = int(hwm_file.read_text()) if hwm_file.exists() else -1
    return proc.returncode, dt, rss, proc.stderr


def _stat(xs: list[float]) -> str:
    return f"{statistics.median(xs):6.2f} [{min(xs):.2f}-{max(xs):.2f}]"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3, help="interleaved rounds (default 3)")
    ap.add_argument("--keep", default=None, metavar="FILE", help="also keep the UFF file here")
    args = ap.parse_args(argv)
    from ema_rig.io.uff import write_uff58

    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env.setdefault("MPLBACKEND", "Agg")
    size = data_bytes(N_OUT, N_IN, N_LINES)
    with tempfile.TemporaryDirectory() as tmp:
        uff = Path(tmp) / "big_58b.uff"
        out_json = Path(tmp) / "modes.json"
        t0 = time.perf_counter()
        data = synthetic_frf(N_OUT, N_IN, N_LINES)
        write_uff58(uff, data, binary=True)
        del data
        t_write = time.perf_counter() - t0
        if args.keep:
            Path(args.keep).write_bytes(uff.read_bytes())
        print(f"bench_modes_memory {time.strftime('%Y-%m-%d %H:%M %Z')}  cores {os.cpu_count()}  "
              f"load {os.getloadavg()[0]:.1f}")
        print(f"file: {N_OUT} x {N_IN} x {N_LINES} lines, binary UFF58, {uff.stat().st_size / 1e6:.1f} MB "
              f"(written in {t_write:.1f} s); FRF data {size / 1e6:.1f} MB")
        cmds = {  # body, argv
            "import": ("import ema_rig.io.uff, ema_rig.identification", []),
            "read": ("import ema_rig.io.uff, ema_rig.identification; ema_rig.io.uff.read_uff58(sys.argv[1])",
                     [str(uff)]),
            # exactly what the ema-rig console script does
            "modes": ("sys.argv[0] = 'ema-rig'; from ema_rig.cli import main; sys.exit(main())",
                      ["modes", str(uff), "--json", str(out_json)]),
        }
        peak: dict[str, list[float]] = {k: [] for k in cmds}
        wall: dict[str, list[float]] = {k: [] for k in cmds}
        found_all: list[bool] = []
        found_freqs: list[float] = []
        for k in range(args.repeat):
            names = list(cmds) if k % 2 == 0 else list(cmds)[::-1]
            for name in names:
                out_json.unlink(missing_ok=True)
                rc, dt, rss, err = run_measured(*cmds[name], env, Path(tmp))
                if rc != 0:
                    print(f"{name}: exit {rc}: {err.strip().splitlines()[-1] if err.strip() else ''}")
                    return 1
                peak[name].append(rss)
                wall[name].append(dt)
                if name == "modes":
                    doc = json.loads(out_json.read_text())
                    fn = np.array([m["natural_freq"] for m in doc["modes"]], float)
                    found_freqs = fn.tolist()
                    found_all.append(all(np.any(np.abs(fn - f) <= FREQ_TOL * f) for f in MODES_HZ))
    print("peak RSS [MB] and wall time [s] per child, median [min-max] over "
          f"{args.repeat} interleaved rounds:")
    for name in cmds:
        print(f"  {name:<7} peak {_stat([p / 1e6 for p in peak[name]])} MB   time {_stat(wall[name])} s")
    med = {k: statistics.median(v) for k, v in peak.items()}
    ratio = (med["modes"] - med["import"]) / size
    print(f"modes - import: {ratio:5.2f} x FRF data   (goal <= {GOAL}: {'met' if ratio <= GOAL else 'NOT met'})")
    print(f"modes - read  : {(med['modes'] - med['read']) / size:5.2f} x FRF data   (identification beyond reading)")
    print(f"read  - import: {(med['read'] - med['import']) / size:5.2f} x FRF data   (reading the file)")
    print(f"modes found: {'all' if all(found_all) else 'NOT all'} {MODES_HZ.size} true modes within "
          f"{FREQ_TOL:.1%} in {sum(found_all)}/{len(found_all)} runs "
          f"(identified: {', '.join(f'{f:.2f}' for f in found_freqs)} Hz)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
