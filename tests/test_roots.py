"""Warm-started Aberth roots (``identification._roots``) against the companion eigenvalues."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from ema_rig.identification import _roots

EPS = np.finfo(float).eps


def _companion_roots(c: np.ndarray) -> np.ndarray:
    """Roots of sum_j c_j z^j as the eigenvalues of its companion matrix (numpy's roots)."""
    return np.roots(c[::-1])


def _set_distance(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Relative distance of each root of ``a`` to its partner in ``b`` (a one-to-one matching)."""
    assert a.size == b.size
    cost = np.abs(a[:, None] - b[None, :])
    i, j = linear_sum_assignment(cost)
    return cost[i, j] / np.abs(b[j])


def _kac(n: int, seed: int) -> np.ndarray:
    """A random real polynomial of degree n (roots cluster near the unit circle, like a pLSCF
    denominator's)."""
    return np.random.default_rng(seed).standard_normal(n + 1)


def _warm(c: np.ndarray, seed: int) -> np.ndarray:
    """Start from the roots of a lower-order neighbour, as pLSCF does: the roots of the
    polynomial with the two highest coefficients dropped and the rest perturbed by 1 %."""
    rng = np.random.default_rng(seed)
    lower = c[:-2] * (1 + 0.01 * rng.standard_normal(c.size - 2))
    return _roots.warm_start(_companion_roots(lower), c.size - 1)


@pytest.mark.parametrize("n", [64, 120, 200])
@pytest.mark.parametrize("stale", [True, False], ids=["stale-repulsion", "fresh-repulsion"])
def test_aberth_finds_the_companion_roots(n, stale, monkeypatch):
    if not stale:
        # every sweep sums the repulsion afresh: the path without reuse gives the same set
        monkeypatch.setattr(_roots, "_STALE", 0.0)
    c = _kac(n, seed=n)
    found = _roots.aberth(c, _warm(c, seed=n + 1))
    assert found is not None
    want = _companion_roots(c)
    # same set to round-off: both are within their condition number of the exact roots; the
    # worst root differs by 1e-14 (n = 64) to 6e-14 (n = 200) here; 5e-13 leaves room for
    # another LAPACK's rounding and fails on a 10x loss of accuracy (or a root lost: O(1))
    assert _set_distance(found, want).max() < 5e-13
    # every accepted root passes the backward-error test (the acceptance rule itself)
    j = np.arange(1, n + 1)
    cr = c[::-1].copy()
    _, small = _roots._ratio(c, c[1:] * j, cr, cr[1:] * j, found)
    assert small.all()


def test_roots_far_outside_the_unit_circle_go_through_the_reversed_polynomial():
    # degree 200 with a conjugate pair of modulus 8: 8^200 overflows, so the ratio of those
    # roots is evaluated on q(y) = y^N p(1/y)
    inner = _kac(198, seed=5)
    far = 8.0 * np.exp(1j * np.pi / 3)
    c = np.convolve(inner, [abs(far) ** 2, -2 * far.real, 1.0])  # (z - far)(z - conj far) p(z)
    assert 200 * np.log10(8.0) > 150
    start = np.concatenate([_companion_roots(inner) * (1 + 1e-3j), [1.05 * far, 0.95 * far.conjugate()]])
    found = _roots.aberth(c, start * np.exp(1e-3j))
    assert found is not None
    want = _companion_roots(c)
    assert np.sum(np.abs(found) > 7) == 2
    # as above: round-off of both methods (measured 1.3e-14)
    assert _set_distance(found, want).max() < 5e-13


def test_newton_ratio_against_direct_evaluation():
    rng = np.random.default_rng(7)
    for n in (3, 50, 200):
        c = rng.standard_normal(n + 1)
        z = np.exp(2j * np.pi * rng.random(40)) * rng.uniform(0.5, 1.5, 40)
        j = np.arange(1, n + 1)
        cr = c[::-1].copy()
        r, small = _roots._ratio(c, c[1:] * j, cr, cr[1:] * j, z)
        want = np.polyval(c[::-1], z) / np.polyval((c[1:] * j)[::-1], z)
        # random points are no roots: p is far above rounding level, and the ratio is the
        # quotient of two evaluations each accurate to a few hundred eps here (measured
        # 2.5e-15 at n = 200 against Horner); a wrong power or block would be O(1)
        np.testing.assert_allclose(r, want, rtol=2e-14)
        assert not small.any()


def test_rounding_flag_tells_a_root_from_a_point_next_to_it():
    c = _kac(100, seed=3)
    z = _roots.aberth(c, _warm(c, seed=4))
    assert z is not None
    j = np.arange(1, 101)
    cr = c[::-1].copy()
    _, at = _roots._ratio(c, c[1:] * j, cr, cr[1:] * j, z)
    # 1e-8 relative away from a root (of condition number < 1e6 here) p is far above the
    # rounding level 4 N eps sum |c_j| |z|^j
    _, off = _roots._ratio(c, c[1:] * j, cr, cr[1:] * j, z * (1 + 1e-8))
    assert at.all() and not off.any()


def test_repulsion_sums_against_the_definition(monkeypatch):
    rng = np.random.default_rng(11)
    z = rng.standard_normal(57) + 1j * rng.standard_normal(57)
    ia = np.arange(0, 57, 3)  # every third root iterating
    want = np.array([sum(1.0 / (z[i] - z[j]) for j in range(57) if j != i) for i in ia])
    with np.errstate(divide="ignore", invalid="ignore"):
        for block in (50, 300, 4096):  # blocks of 1 row, several rows, one block
            monkeypatch.setattr(_roots, "_REPULSION_BLOCK", block)
            # a sum of 56 terms: round-off
            np.testing.assert_allclose(_roots._repulsion(z[ia], ia, z), want, rtol=1e-13)



def test_chain_repulsion_sums_against_the_definition(monkeypatch):
    # the chain's sums (real arithmetic: conj(d) / |d|^2) over a padded table of three
    # polynomials' roots: each root's sum runs over its own polynomial's other roots; the
    # padding (_FAR beyond each degree) contributes nothing. Against the complex sums written
    # out: round-off of a sum of <= 39 terms (1e-13 relative)
    rng = np.random.default_rng(12)
    degrees = (20, 31, 40)
    table = np.full((3, 40), _roots._FAR, dtype=np.complex128)
    for i, d in enumerate(degrees):
        table[i, :d] = rng.standard_normal(d) + 1j * rng.standard_normal(d)
    own = np.repeat(np.arange(3), [7, 9, 11])
    pos = np.concatenate([rng.choice(d, k, replace=False) for d, k in zip(degrees, (7, 9, 11), strict=True)])
    zr = table[own, pos]
    want = np.array([sum(1.0 / (zr[m] - table[own[m], j]) for j in range(degrees[own[m]]) if j != pos[m])
                     for m in range(zr.size)])
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        for block in (40, 200, 4096):  # blocks of 1 row, several rows, one block
            monkeypatch.setattr(_roots, "_REPULSION_BLOCK", block)
            np.testing.assert_allclose(_roots._chain_repulsion(zr, pos, table, own), want, rtol=1e-13)

def _chain(degrees, seed):
    """Polynomials of rising degree whose roots move between neighbours as a pLSCF denominator's
    do: truncations of one random series, each perturbed by 1 %."""
    rng = np.random.default_rng(seed)
    series = rng.standard_normal(max(degrees) + 1)
    return [series[: d + 1] * (1 + 0.01 * rng.standard_normal(d + 1)) for d in degrees]


def test_aberth_chain_finds_the_companion_roots_of_every_polynomial():
    degrees = list(range(64, 101, 2))
    coefs = _chain(degrees, seed=21)
    start = _companion_roots(coefs[0][:-2])  # the roots below the first, as pLSCF passes them
    found = _roots.aberth_chain(coefs, start)
    for c, z in zip(coefs, found, strict=True):
        assert z is not None
        # the same set to round-off as the companion eigenvalues (as for aberth above: measured
        # 1e-14 to 5e-14; a lost root or a 10x loss of accuracy fails)
        assert _set_distance(z, _companion_roots(c)).max() < 5e-13
        n = c.size - 1
        j = np.arange(1, n + 1)
        cr = c[::-1].copy()
        _, small = _roots._ratio(c, c[1:] * j, cr, cr[1:] * j, z)
        assert small.all()  # every root accepted on the backward-error test



def test_aberth_chain_starts_several_low_degree_polynomials_per_sweep(monkeypatch):
    # 19 polynomials of degrees 64-100: started one per sweep, the last would start at sweep 19
    # at the earliest and need at least one more sweep to be accepted (no warm start is at
    # rounding level before its first correction), so the chain would take > 19 sweeps (one
    # evaluation, _chain_ratio, per sweep); started in groups (_CHAIN_GROUP up to degree
    # _CHAIN_GROUP_MAX_DEGREE) it takes fewer (measured: 15; 06ee910: 27), with the companion roots of each
    # to round-off as in the test above
    degrees = list(range(64, 101, 2))
    coefs = _chain(degrees, seed=21)
    start = _companion_roots(coefs[0][:-2])
    sweeps = []
    ratio = _roots._chain_ratio

    def counted(*args, **kwargs):
        sweeps.append(1)
        return ratio(*args, **kwargs)

    monkeypatch.setattr(_roots, "_chain_ratio", counted)
    found = _roots.aberth_chain(coefs, start)
    assert len(sweeps) < len(degrees)
    for c, z in zip(coefs, found, strict=True):
        assert z is not None
        assert _set_distance(z, _companion_roots(c)).max() < 5e-13

def test_aberth_chain_far_roots_and_non_convergence(monkeypatch):
    # the last polynomial has a conjugate pair of modulus 8 (8^200 overflows): its roots go
    # through the reversed polynomial, the others' stay direct, in the same sweeps
    inner = _kac(198, seed=5)
    far = 8.0 * np.exp(1j * np.pi / 3)
    last = np.convolve(inner, [abs(far) ** 2, -2 * far.real, 1.0])
    coefs = [inner[:197] * 1.01, inner, last]
    reversed_calls = []
    ratio = _roots._ratio_prepared

    def counted(*args):
        reversed_calls.append(args[2])
        return ratio(*args)

    monkeypatch.setattr(_roots, "_ratio_prepared", counted)
    found = _roots.aberth_chain(coefs, _companion_roots(inner[:195]))
    assert 200 in reversed_calls  # the polynomial with the far pair took that path
    for c, z in zip(coefs, found, strict=True):
        assert z is not None
        assert _set_distance(z, _companion_roots(c)).max() < 5e-13  # round-off, as above
    assert np.sum(np.abs(found[-1]) > 7) == 2
    # one sweep cannot accept a warm start: every polynomial is reported unconverged (None),
    # which the caller turns into the eigenvalue fallback
    assert _roots.aberth_chain(coefs, _companion_roots(inner[:195]), maxiter=1) == [None, None, None]


def test_aberth_chain_several_polynomials_with_far_roots():
    # every polynomial of the chain has its own conjugate pair far outside the unit circle
    # (moduli 7.5, 8, 8.5: each polynomial's powers overflow, so all three go through their
    # reversed polynomials, in the same sweeps, each from blocks prepared once and kept by the
    # chain): each must be rooted on its OWN reversed polynomial. The first two have blocks of
    # the same shape (degrees 196 and 198), so blocks taken from the wrong polynomial would not
    # fail loudly; the roots would then not be the companion's.
    base = _kac(198, seed=7)

    def with_pair(inner: np.ndarray, r: float) -> np.ndarray:
        far = r * np.exp(1j * np.pi / 3)
        return np.convolve(inner, [abs(far) ** 2, -2 * far.real, 1.0])

    coefs = [with_pair(base[:195] * 1.01, 7.5), with_pair(base[:197], 8.0), with_pair(base, 8.5)]
    found = _roots.aberth_chain(coefs, _companion_roots(base[:195]))
    for c, z, r in zip(coefs, found, (7.5, 8.0, 8.5), strict=True):
        assert z is not None
        # round-off, as in test_aberth_finds_the_companion_roots
        assert _set_distance(z, _companion_roots(c)).max() < 5e-13
        assert np.isclose(np.sort(np.abs(z))[-1], r, rtol=1e-12)


def test_blocked_evaluation_of_several_polynomials_against_horner():
    rng = np.random.default_rng(13)
    degrees = (3, 40, 101)
    padded = np.zeros((3, 102))
    for i, d in enumerate(degrees):
        padded[i, : d + 1] = rng.standard_normal(d + 1)
    blocks, _ = _roots.coefficient_blocks(padded)
    owner = np.repeat(np.arange(3), 30)
    z = np.exp(2j * np.pi * rng.random(90)) * rng.uniform(0.3, 1.0, 90)  # |z| <= 1, as polished
    p, dp = _roots.eval_blocked(blocks, 101, owner, z)
    for i, d in enumerate(degrees):
        c = padded[i, : d + 1]
        sel = owner == i
        # each value accurate to a few hundred eps of the sum of moduli (as the ratio test
        # above); a wrong block, power or padding is O(1)
        scale = np.polyval(np.abs(c[::-1]), np.abs(z[sel]))
        np.testing.assert_allclose(p[sel], np.polyval(c[::-1], z[sel]), rtol=0, atol=1e-14 * scale.max())
        dc = c[1:] * np.arange(1, d + 1)
        dscale = np.polyval(np.abs(dc[::-1]), np.abs(z[sel])) if d else np.ones(sel.sum())
        np.testing.assert_allclose(dp[sel], np.polyval(dc[::-1], z[sel]), rtol=0, atol=1e-14 * dscale.max())


def test_chain_ratio_with_blocks_at_the_active_degree_against_horner():
    # one sweep of a chain as aberth_chain makes it: the active polynomials (degrees 40, 57, 90,
    # polynomials 1-3 of a chain of degrees 30-200) with their blocks cut for the highest ACTIVE
    # degree (90), not the chain's; and one root of the degree-90 polynomial at modulus 60 (90 log10 60 > 150: its
    # powers would overflow), which alone goes through the reversed polynomial. Ratios against
    # Horner (numpy.polyval), rounding flags against the acceptance rule written out: each root
    # of numpy.roots is at rounding level (4 N eps sum |c_j| |z|^j), a point 1e-8 relative from
    # it is not. A block cut for the wrong degree, a root given another polynomial's blocks or
    # the far root evaluated directly (inf / inf: NaN) fails by O(1)
    rng = np.random.default_rng(17)
    degrees = np.array([30, 40, 57, 90, 200])
    coefs = [rng.standard_normal(d + 1) for d in degrees]
    far = 60.0
    coefs[3] = np.convolve(coefs[3][:-1], [-far, 1.0])  # (z - 60) times a degree-89 polynomial
    uo = np.array([1, 2, 3])
    na = int(degrees[uo].max())
    padded = np.zeros((degrees.size, na + 1))  # every polynomial cut at degree 90 (as the chain's
    for i in uo:  # blocks of one layout: the inactive ones' are not read)
        padded[i, : degrees[i] + 1] = coefs[i]
    blocks, abs_blocks = _roots.coefficient_blocks(padded)
    zs = []
    for i in uo:
        r = _companion_roots(coefs[i])
        r = r[np.argsort(np.abs(r))][-12:]  # the 12 largest: the far one among them
        zs.append(np.concatenate([r, r * (1 + 1e-8)]))
    z = np.concatenate(zs)
    cuts = np.concatenate([[0], np.cumsum([x.size for x in zs])])
    reversed_roots = []
    ratio = _roots._ratio_prepared

    def counted(*args):
        reversed_roots.append(args[3].copy())
        return ratio(*args)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(_roots, "_ratio_prepared", counted)
        with np.errstate(all="ignore"):
            r, small = _roots._chain_ratio(blocks, abs_blocks, coefs, degrees, na, uo, cuts, z,
                                           np.ones(uo.size, dtype=bool), {})
    # the far root (and its neighbour 1e-8 away) only, on the reversed polynomial
    assert len(reversed_roots) == 1 and reversed_roots[0].size == 2
    assert np.all(np.abs(reversed_roots[0]) > 59)
    for t, i in enumerate(uo):
        c = coefs[i]
        sl = slice(cuts[t], cuts[t + 1])
        at, zt, rt = small[sl], z[sl], r[sl]
        half = zt.size // 2
        assert at[:half].all() and not at[half:].any()
        # 1e-8 from a root, p is ~1e-8 |z p'| and both evaluations (blocked, Horner) err by a few
        # hundred eps of the sum of moduli: the two ratios agree to ~1e-8 relative (measured
        # <= 1.1e-8); 1e-6 leaves room for another BLAS's rounding, a wrong block or power is O(1)
        dc = c[1:] * np.arange(1, c.size)
        want = np.polyval(c[::-1], zt[half:]) / np.polyval(dc[::-1], zt[half:])
        np.testing.assert_allclose(rt[half:], want, rtol=1e-6)


@pytest.mark.parametrize("n", [20, 150])
def test_self_repulsion_against_the_definition(n):
    # p'' / (2 p') at every root of p against the sum over the other roots (numpy.roots). Both
    # sides carry the roots' round-off: measured 1.5e-14 (n = 20) and 4.5e-13 (n = 150)
    # relative; 1e-11 fails on a missing factor 2 or a wrong derivative (O(1))
    c = _kac(n, seed=n + 3)
    z = _companion_roots(c)
    d = z[:, None] - z[None, :]
    np.fill_diagonal(d, np.inf)
    want = (1.0 / d).sum(axis=1)
    got = _roots.self_repulsion(c, z)
    assert np.max(np.abs(got - want) / np.abs(want)) < 1e-11


@pytest.mark.parametrize("n", [100, 200])
def test_aberth_warm_finds_the_companion_roots(n):
    # started from the roots of the neighbour below (as pLSCF), the first sweep's repulsion from
    # that polynomial: the same roots as the eigenvalues to round-off (as aberth above), and the
    # fallback when the previous roots are not the whole set of the previous polynomial
    c = _kac(n, seed=n + 7)
    rng = np.random.default_rng(n)
    lower = c[:-2] * (1 + 0.01 * rng.standard_normal(c.size - 2))
    prev = _companion_roots(lower)
    want = _companion_roots(c)
    for p in (prev, prev[:-1]):
        found = _roots.aberth_warm(c, lower, p)
        assert found is not None
        assert _set_distance(found, want).max() < 5e-13


def test_warm_started_roots_of_a_clustered_polynomial():
    # a rig-like cluster: two lightly damped pairs 1e-3 rad apart (|z| = 0.995) on a random
    # polynomial of degree 156, started from the roots of a perturbed lower neighbour (one
    # pair moved by 1e-4): aberth_warm (first sweep from the neighbour's p''/2p') and a chain
    # of the neighbour and the polynomial against numpy.roots, as sets: measured 2.4e-11 and
    # 6.6e-10 relative (the worst-conditioned roots of a random degree-160 polynomial, both
    # methods within their condition numbers). The cluster's four roots themselves (measured
    # <= 1.2e-11 from the exact ones): 1e-9 fails on a lost or doubled root of it (O(1e-3))
    def pair(z):
        return np.array([abs(z) ** 2, -2 * z.real, 1.0])

    n = 160
    rng = np.random.default_rng(n)
    base = rng.standard_normal(n - 3)
    a, b = 0.995 * np.exp(0.9j), 0.995 * np.exp(0.901j)
    c = np.convolve(np.convolve(base, pair(a)), pair(b))
    lower = np.convolve(base[:-2] * (1 + 0.01 * rng.standard_normal(n - 5)), pair(a * 1.0001))
    prev = _companion_roots(lower)
    want = _companion_roots(c)
    for found in (_roots.aberth_warm(c, lower, prev), _roots.aberth_chain([lower, c], prev[:-2])[1]):
        assert found is not None
        assert _set_distance(found, want).max() < 1e-8
        assert np.abs(found - a).min() < 1e-9 and np.abs(found - b).min() < 1e-9


def test_coincident_approximations_are_parted():
    # two approximations on one point repel each other infinitely: neither moves, and the root
    # they should share out is never found; after _STALL sweeps the later one restarts elsewhere.
    # Without the parting aberth returns None and the chain gives None for every polynomial
    # (each starts from the twins of the one before); with it, the companion roots to round-off
    # (as above: measured <= 5e-14)
    c = _kac(64, seed=31)
    z0 = _warm(c, seed=32)
    z0[7] = z0[3]
    found = _roots.aberth(c, z0)
    assert found is not None
    assert _set_distance(found, _companion_roots(c)).max() < 5e-13
    coefs = _chain(list(range(64, 71, 2)), seed=33)
    start = _companion_roots(coefs[0][:-2])
    start[5] = start[2]
    for c, z in zip(coefs, _roots.aberth_chain(coefs, start), strict=True):
        assert z is not None
        assert _set_distance(z, _companion_roots(c)).max() < 5e-13
