"""Long seeded fuzz run of the UFF reader over real files (not collected by pytest).

Every mutation class of ``tests/_uff_mutants.py`` is applied to the real UFF files of the shared
corpus (``$EMA_RIG_SHARED/uff-corpus``, ``real-frf``) and to the bundled ``data/*.uff``; each
mutant is read with ``read_uff``, ``inspect_uff`` and ``read_uff58``. A mutant is *handled* when
it is read or refused with ema_rig's own error type; anything else (another exception, a numpy
warning) is *foreign* and is a bug. The table gives, per class, mutants tried / handled (and how
many of the handled ones were refused), and the first foreign tracebacks.

Run::

    python benchmarks/fuzz_uff.py [--mutants 12000] [--seed 2026] [--max-bytes 400000]

Seed files larger than ``--max-bytes`` are cut after their first datasets (the mutants stay valid
UFF structure up to the cut) so that the run takes minutes, not hours. Exit code 1 if any
mutant was foreign.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO / "tests"))  # the mutation classes shared with tests/test_uff_fuzz.py
sys.path.insert(0, str(REPO))

from _uff_mutants import MUTATORS, exercise  # noqa: E402


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


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--mutants", type=int, default=12000)
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--max-bytes", type=int, default=400_000)
    ap.add_argument("--show", type=int, default=5, help="foreign tracebacks to print")
    args = ap.parse_args(argv)
    shared = Path(os.environ.get("EMA_RIG_SHARED", REPO.parent / "shared"))
    files = _seed_files(shared, REPO / "data")
    if not files:
        print(f"no seed files under {shared} or data/", file=sys.stderr)
        return 2
    seeds = [(p.name, _cut(p.read_bytes(), args.max_bytes)) for p in files]
    kinds = list(MUTATORS)
    tried = dict.fromkeys(kinds, 0)
    handled = dict.fromkeys(kinds, 0)
    refused = dict.fromkeys(kinds, 0)
    foreign: list[tuple[str, int, str, str]] = []
    rng_top = np.random.default_rng(args.seed)
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "mutant.uff"
        for k in range(args.mutants):
            kind = kinds[k % len(kinds)]
            name, buf = seeds[int(rng_top.integers(len(seeds)))]
            rng = np.random.default_rng([args.seed, k])
            for _ in range(int(rng.integers(1, 4))):
                buf = MUTATORS[kind](buf, rng)
            outcome, detail = exercise(path, buf)
            tried[kind] += 1
            if outcome == "foreign":
                foreign.append((kind, k, name, detail or ""))
            else:
                handled[kind] += 1
                refused[kind] += outcome == "refused"
    dt = time.perf_counter() - t0
    print(f"{args.mutants} mutants of {len(seeds)} seed files (seed {args.seed}) in {dt:.0f} s")
    print(f"{'class':<14} {'tried':>7} {'handled':>8} {'refused':>8} {'foreign':>8}")
    for kind in kinds:
        print(f"{kind:<14} {tried[kind]:>7} {handled[kind]:>8} {refused[kind]:>8} {tried[kind] - handled[kind]:>8}")
    print(f"{'total':<14} {sum(tried.values()):>7} {sum(handled.values()):>8} {sum(refused.values()):>8} "
          f"{len(foreign):>8}")
    for kind, k, name, detail in foreign[: args.show]:
        print(f"\n--- foreign: class {kind}, mutant {k} of {name} ---\n{detail}")
    return 1 if foreign else 0


if __name__ == "__main__":
    sys.exit(main())
