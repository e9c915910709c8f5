"""Bounded fuzzing of the UFF reader: mutated and truncated valid files, random bytes.

Any exception other than ema_rig's own error types is a bug, and so is any warning other than
UnitWarning (an ignored channel).
The budget is fixed (a few hundred examples, no deadline per example), well under 15 s.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
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
