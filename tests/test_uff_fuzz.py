"""Bounded fuzzing of the UFF reader: mutated and truncated valid files, random bytes, and the
mutation classes of ``_uff_mutants`` (unit labels, dataset-164 factors and exponents, header
integers, value counts, delimiters, truncation).

Any exception other than ema_rig's own error types is a bug, and so is any warning other than
UnitWarning (an ignored channel).
The budget is fixed (a few hundred examples each, no deadline per example), a few seconds in all.
The long run (>= 10 000 mutants over the corpus and data/) is ``benchmarks/fuzz_uff.py``.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from _uff_mutants import MUTATORS, exercise
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ema_rig.errors import EmaRigError, UnitWarning
from ema_rig.frf import FRFData
from ema_rig.io.uff import inspect_uff, read_uff, read_uff58, write_uff58


def _seeds(tmp: Path) -> list[bytes]:
    rng = np.random.default_rng(11)
    d = FRFData(np.arange(9) * 0.5, rng.standard_normal((2, 2, 9)) + 1j * rng.standard_normal((2, 2, 9)),
                ["1+Y", "13-Y"], ["1+Y", "5+X"])
    out = []
    for binary in (False, True):
        for even in ("even", "uneven"):
            p = tmp / f"s_{binary}_{even}.uff"
            write_uff58(p, d, binary=binary, abscissa=even, double=not binary or even == "even")
            out.append(p.read_bytes())
    return out


SEEDS: list[bytes] = []


@pytest.fixture(scope="module")
def seeds(tmp_path_factory: pytest.TempPathFactory) -> list[bytes]:
    if not SEEDS:
        SEEDS.extend(_seeds(tmp_path_factory.mktemp("seeds")))
    return SEEDS


def _exercise(path: Path, buf: bytes) -> None:
    path.write_bytes(buf)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a numpy RuntimeWarning is a bug too
        warnings.filterwarnings("ignore", category=UnitWarning)
        for fn in (read_uff, inspect_uff, read_uff58):
            try:
                fn(path)
            except EmaRigError:
                pass  # the project's own, clear error: fine


mutation = st.tuples(
    st.sampled_from(["flip", "delete", "insert", "truncate", "dup_line"]),
    st.integers(min_value=0, max_value=10**9),
    st.binary(min_size=1, max_size=12),
)


def _mutate(buf: bytes, op: str, k: int, blob: bytes) -> bytes:
    if not buf:
        return blob
    i = k % len(buf)
    if op == "flip":
        return buf[:i] + blob + buf[i + len(blob) :]
    if op == "delete":
        return buf[:i] + buf[i + len(blob) :]
    if op == "insert":
        return buf[:i] + blob + buf[i:]
    if op == "truncate":
        return buf[:i]
    lines = buf.split(b"\n")
    j = k % len(lines)
    return b"\n".join(lines[: j + 1] + lines[j:])


@settings(max_examples=250, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(which=st.integers(min_value=0, max_value=3), muts=st.lists(mutation, min_size=1, max_size=4))
def test_mutated_valid_files(tmp_path: Path, seeds: list[bytes], which: int, muts: list) -> None:
    buf = seeds[which]
    for op, k, blob in muts:
        buf = _mutate(buf, op, k, blob)
    _exercise(tmp_path / "m.uff", buf)


@settings(max_examples=120, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(
    head=st.sampled_from([b"", b"    -1\n", b"    -1\n    58\n", b"    -1\n    58b     1     2    11    64\n",
                          b"    -1\n   164\n"]),
    body=st.binary(max_size=400),
    tail=st.sampled_from([b"", b"    -1\n", b"\r\n    -1"]),
)
def test_random_bytes(tmp_path: Path, head: bytes, body: bytes, tail: bytes) -> None:
    _exercise(tmp_path / "r.uff", head + body + tail)


@settings(max_examples=120, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(lines=st.lists(st.text(alphabet=" 0123456789.-+Eeb\r\nND/()g^s", max_size=90), min_size=1, max_size=30))
def test_uff_like_text(tmp_path: Path, lines: list[str]) -> None:
    text = "    -1\n    58\n" + "\n".join(lines) + "\n    -1\n"
    _exercise(tmp_path / "t.uff", text.encode())


def _seed_164(tmp: Path) -> bytes:
    """A file whose units come from dataset 164 and the header exponents (no unit labels)."""
    d = FRFData(np.arange(6) * 2.0, np.ones((1, 1, 6)) * (0.5 + 0.25j), ["3+Z"], ["1+Z"])
    p = tmp / "s164.uff"
    write_uff58(p, d)
    buf = p.read_bytes().replace(b"m/s^2               ", b"NONE                ")
    u164 = b"    -1\n   164\n         2  mm (milli newton)  0\n  1.0E+03  1.0E+00  1.0E+00\n  2.7315E+02\n    -1\n"
    return u164 + buf.replace(b"N                   ", b"NONE                ")


@pytest.fixture(scope="module")
def seed_164(tmp_path_factory: pytest.TempPathFactory) -> bytes:
    return _seed_164(tmp_path_factory.mktemp("s164"))


@pytest.mark.parametrize(("kind", "n"), [("unit_label", 150), ("exp164", 150), ("header_int", 150),
                                         ("num_pts", 60), ("delimiter", 40), ("truncate_tail", 40)])
def test_mutation_classes(tmp_path: Path, seeds: list[bytes], seed_164: bytes, kind: str, n: int) -> None:
    # seeded numpy draws (no hypothesis shrinking needed: a failure prints the seed and mutant)
    pool = [*seeds, seed_164]
    outcomes: dict[str, int] = {}
    for k in range(n):
        rng = np.random.default_rng([8, k, len(kind)])
        buf = pool[k % len(pool)]
        for _ in range(int(rng.integers(1, 3))):
            buf = MUTATORS[kind](buf, rng)
        outcome, detail = exercise(tmp_path / "m.uff", buf)
        assert outcome != "foreign", f"{kind} mutant {k}: {detail}\n{buf[:2000]!r}"
        outcomes[outcome] = outcomes.get(outcome, 0) + 1
    # the class must reach the reader's refusals, not only valid files (else it tests nothing)
    assert outcomes.get("refused", 0) > 0, outcomes


def test_seeded_fuzz_with_misread_oracle(tmp_path: Path) -> None:
    # issue 17: a few hundred seeded mutants of FRF and time-data seeds ema_rig writes itself,
    # read by read_uff / inspect_uff / read_uff58 and (time data) the frf command; the oracle
    # (_uff_mutants.misreads) says a read dataset holds the original's values wherever the edit
    # did not touch them. The long run is benchmarks/fuzz_uff.py (>= 20 000 mutants).
    import sys

    sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "benchmarks"))
    from _uff_mutants import exercise_frf, misreads
    from fuzz_uff import generated_seeds

    seeds = generated_seeds(tmp_path)
    kinds = list(MUTATORS)
    counts = {"read": 0, "refused": 0, "frf_read": 0}
    for k in range(300):
        kind = kinds[k % len(kinds)]
        rng = np.random.default_rng([17, k])
        name, orig, is_time = seeds[int(rng.integers(len(seeds)))]
        buf = orig
        for _ in range(int(rng.integers(1, 4))):
            buf = MUTATORS[kind](buf, rng)
        outcome, detail = exercise(tmp_path / "m.uff", buf)
        assert outcome != "foreign", f"{kind} mutant {k} of {name}: {detail}"
        counts[outcome] += 1
        wrong = misreads(orig, buf)
        assert not wrong, f"{kind} mutant {k} of {name}: {wrong}"
        if is_time:
            f_outcome, f_detail = exercise_frf(tmp_path / "m.uff", buf, tmp_path / "frf.uff")
            assert f_outcome != "foreign", f"{kind} mutant {k} of {name} (frf): {f_detail}"
            counts["frf_read"] += f_outcome == "read"
    # the run reaches both sides: mutants read, mutants refused, and frf results written
    assert counts["read"] > 10 and counts["refused"] > 100 and counts["frf_read"] > 5, counts


def test_misread_oracle_catches_a_shift(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    # the oracle itself: a reader that moved the values by one place (what padding filling a gap
    # or a byte count eating the close does) is caught; an edited value is not a misread
    from dataclasses import replace

    from _uff_mutants import misreads

    from ema_rig.io import _uff_parse

    d = FRFData(np.arange(5) * 10.0, (np.arange(1, 11).reshape(2, 1, 5) * (0.25 + 0.1j)), ["1+Y", "2+Y"], ["1+Y"])
    p = tmp_path / "o.uff"
    write_uff58(p, d)
    orig = p.read_bytes()
    edited = orig.replace(b"2.500000000000E-01", b"2.600000000000E-01", 1)  # a value's own text
    assert misreads(orig, edited) == []
    relabel = orig.replace(b"ema_rig", b"ema_RIG", 1)  # dataset 0's header, not its data
    assert misreads(orig, relabel) == []
    scan = _uff_parse.scan

    def shifting_scan(buf: bytes) -> list:
        raws = scan(buf)
        if buf == relabel:  # a faulty reader: dataset 0's values moved by one place
            raws[0] = replace(raws[0], y=np.roll(raws[0].y, 1))
        return raws

    monkeypatch.setattr(_uff_parse, "scan", shifting_scan)
    found = misreads(orig, relabel)
    assert len(found) == 1 and "did not touch it" in found[0], found
    untouched = orig.replace(b"ema_rig", b"ema_rig", 1)  # no edit at all: dataset 0 untouched
    assert misreads(orig, untouched) == []
