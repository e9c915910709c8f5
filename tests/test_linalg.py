"""``ema_rig._linalg``: the thin factorizations give numpy's numbers to the bit, on the edge cases too."""

from __future__ import annotations

import numpy as np
import pytest

from ema_rig._linalg import thin_svd


def _numpy(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    u, s, vt = np.linalg.svd(a, full_matrices=False)
    return u, s, vt


@pytest.mark.parametrize(
    "kind", ["random", "rank_deficient", "zero_column", "duplicate_column", "zero", "tiny", "huge"]
)
@pytest.mark.parametrize("shape", [(1000, 12), (700, 32), (5000, 3)])
def test_thin_svd_is_numpys_svd_bit_for_bit(kind: str, shape: tuple[int, int]) -> None:
    # the oracle is numpy.linalg.svd itself (thin_svd claims its numbers exactly: tolerance 0). "tiny" / "huge":
    # entries below / above LAPACK gesdd's scaling range [2^-459, 2^459] (dgesdd.f scales the whole matrix
    # first); on 1f37e8b thin_svd factored them unscaled and differed by 1e-15 relative in s, 1e-13 in u
    rng = np.random.default_rng(0)
    a = rng.standard_normal(shape)
    if kind == "rank_deficient":
        a[:, -3:] = a[:, :3] @ rng.standard_normal((3, 3))
    elif kind == "zero_column":
        a[:, 2] = 0.0
    elif kind == "duplicate_column":
        a[:, 1] = a[:, 0]
    elif kind == "zero":
        a[:] = 0.0
    elif kind == "tiny":
        a *= 1e-160
    elif kind == "huge":
        a *= 1e160
    for got, want in zip(thin_svd(a), _numpy(a), strict=True):
        assert np.array_equal(got, want)


def test_thin_svd_non_finite_as_numpy() -> None:
    # numpy's call raises LinAlgError on a NaN entry and returns (NaN) factors on an infinite one: thin_svd must
    # do the same (on 1f37e8b it raised on the infinite entry, a behaviour numpy's call never had)
    a = np.random.default_rng(1).standard_normal((1000, 12))
    a[5, 3] = np.nan
    with pytest.raises(np.linalg.LinAlgError):
        thin_svd(a)
    a[5, 3] = np.inf
    for got, want in zip(thin_svd(a), _numpy(a), strict=True):
        assert np.array_equal(got, want, equal_nan=True)
