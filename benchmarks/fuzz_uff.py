"""Long seeded fuzz run of the UFF reader and of ``ema-rig frf``, with a misread oracle (not collected by pytest).

Seeds: the real UFF files of the shared corpus (``$EMA_RIG_SHARED/uff-corpus``, ``real-frf``),
the bundled ``data/*.uff``, FRF files written by ema_rig (ASCII/binary, even/uneven, single and
double precision) and time-data files (``tests/_uff_mutants.time_seed``: ASCII and 58b, unit
labels, a time axis in ms, dataset 164 in inch/lbf). Every mutation class of
``tests/_uff_mutants.py`` is applied; each mutant is

- read with ``read_uff``, ``inspect_uff`` and ``read_uff58`` (and, for time-data seeds, run
  through the ``frf`` command): *read*, *refused* with ema_rig's own error, or *foreign*
  (another exception or a numpy warning: a bug);
- checked by the misread oracle ``_uff_mutants.misreads``: a dataset read from bytes the edit
  did not touch must be the original dataset with the original values, and in a dataset the
  edit touched only the values whose text or bytes it touched may differ (a shift from a
  missing value, padding taken for data, a wrongly split run-together number, a byte count
  that ate the closing ``-1`` all show up as differences elsewhere): a *misread*;
- run under an alarm of ``--timeout`` seconds: a *hang* if it fires.

Run::

    python benchmarks/fuzz_uff.py [--mutants 20000] [--seed 2026] [--max-bytes 100000] [--quick]

Seed files larger than ``--max-bytes`` are cut after their first datasets. Exit code 1 if any
mutant was foreign, misread or hung.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))  # the mutation classes shared with tests/test_uff_fuzz.py
sys.path.insert(0, str(REPO))

from _uff_mutants import MUTATORS, exercise, exercise_frf, misreads, time_seed  # noqa: E402


class _Hang(Exception):
    pass


def _alarm(signum: int, frame: object) -> None:
    raise _Hang()


def _seed_files(shared: Path, data: Path) -> list[Path]:
    files: list[Path] = []
    for folder in (shared / "uff-corpus", shared / "real-frf", data):
        if folder.is_dir():
            files += sorted(p for p in folder.iterdir() if p.suffix.lower() in (".uff", ".unv", ".ufb", ".frf"))
    return files


def _cut(buf: bytes, max_bytes: int) -> bytes:
    """The first datasets of a large file, ending after a closing -1 line."""
    if len(buf) <= max_bytes:
        return buf
    end = buf.rfind(b"\n    -1", 0, max_bytes)
    if end <= 0:
        return buf[:max_bytes]
    nl = buf.find(b"\n", end + 1)
    return buf[: nl + 1 if nl > 0 else len(buf)]


def generated_seeds(tmp: Path) -> list[tuple[str, bytes, bool]]:
    """(name, bytes, is_time_data) of the seeds ema_rig writes itself."""
    from ema_rig.frf import FRFData
    from ema_rig.io.uff import write_uff58

    rng = np.random.default_rng(11)
    d = FRFData(np.arange(1, 10) * 0.5, rng.standard_normal((2, 2, 9)) + 1j * rng.standard_normal((2, 2, 9)),
                ["1+Y", "13-Y"], ["1+Y", "5+X"])
    out: list[tuple[str, bytes, bool]] = []
    for binary in (False, True):
        for even in ("even", "uneven"):
            for double in (True, False):
                p = tmp / "seed.uff"
                write_uff58(p, d, binary=binary, abscissa=even, double=double)
                out.append((f"frf_{'b' if binary else 'a'}_{even}_{'d' if double else 's'}", p.read_bytes(), False))
    for name, kw in (("time_ascii", {}), ("time_58b", {"binary": True}), ("time_ms", {"t_unit": "ms", "dt": 1.0}),
                     ("time_164", {"u164": True, "labels": ("NONE", "NONE")}),
                     ("time_mixed_labels", {"labels": ("kN", "mm s^-2")})):
        out.append((name, time_seed(256, **kw), True))  # type: ignore[arg-type]
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mutants", type=int, default=20000)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--max-bytes", type=int, default=100_000)
    ap.add_argument("--timeout", type=float, default=20.0, help="seconds per mutant before it counts as a hang")
    ap.add_argument("--quick", action="store_true", help="600 mutants of the generated seeds only (about a minute)")
    ap.add_argument("--show", type=int, default=5, help="foreign tracebacks and misreads to print")
    ap.add_argument("--dump", type=int, default=None, metavar="K",
                    help="write mutant K and its seed to mutant_K.uff / seed_K.uff in the working folder and stop")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        seeds = generated_seeds(tmp)
        if not args.quick:
            shared = Path(os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared"))
            seeds += [(p.name, _cut(p.read_bytes(), args.max_bytes), "time" in p.name)
                      for p in _seed_files(shared, REPO / "data")]
        n_mut = 600 if args.quick else args.mutants
        kinds = list(MUTATORS)
        cols = ("tried", "read", "refused", "foreign", "misread", "hang", "frf_run", "frf_read")
        table = {k: dict.fromkeys(cols, 0) for k in kinds}
        bad: list[tuple[str, str, int, str, str]] = []
        rng_top = np.random.default_rng(args.seed)
        signal.signal(signal.SIGALRM, _alarm)
        path, out = tmp / "mutant.uff", tmp / "frf_out.uff"
        t0 = time.perf_counter()
        for k in range(n_mut):
            kind = kinds[k % len(kinds)]
            name, orig, is_time = seeds[int(rng_top.integers(len(seeds)))]
            rng = np.random.default_rng([args.seed, k])
            buf = orig
            for _ in range(int(rng.integers(1, 4))):
                buf = MUTATORS[kind](buf, rng)
            if args.dump is not None:
                if k == args.dump:
                    Path(f"mutant_{k}.uff").write_bytes(buf)
                    Path(f"seed_{k}.uff").write_bytes(orig)
                    print(f"mutant {k}: class {kind}, seed {name}")
                    return 0
                continue
            row = table[kind]
            row["tried"] += 1
            signal.setitimer(signal.ITIMER_REAL, args.timeout)
            try:
                outcome, detail = exercise(path, buf)
                wrong = misreads(orig, buf)
                if is_time:
                    row["frf_run"] += 1
                    f_outcome, f_detail = exercise_frf(path, buf, out)
                    row["frf_read"] += f_outcome == "read"
                    if f_outcome == "foreign":
                        outcome, detail = "foreign", "frf: " + (f_detail or "")
            except _Hang:
                row["hang"] += 1
                bad.append(("hang", kind, k, name, f"more than {args.timeout:g} s"))
                continue
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
            row[outcome] += 1
            if outcome == "foreign":
                bad.append(("foreign", kind, k, name, detail or ""))
            if wrong:
                row["misread"] += 1
                bad.append(("misread", kind, k, name, "; ".join(wrong[:3])))
        dt = time.perf_counter() - t0
    print(f"{n_mut} mutants of {len(seeds)} seed files (seed {args.seed}{', quick' if args.quick else ''}) in {dt:.0f} s")
    print(f"{'class':<14}" + "".join(f"{c:>9}" for c in cols))
    tot = dict.fromkeys(cols, 0)
    for kind in kinds:
        print(f"{kind:<14}" + "".join(f"{table[kind][c]:>9}" for c in cols))
        for c in cols:
            tot[c] += table[kind][c]
    print(f"{'total':<14}" + "".join(f"{tot[c]:>9}" for c in cols))
    for what, kind, k, name, detail in bad[: args.show]:
        print(f"\n--- {what}: class {kind}, mutant {k} of {name} ---\n{detail}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
