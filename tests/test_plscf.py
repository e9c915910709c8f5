"""PolyMAX (pLSCF) against a lumped system with exactly known poles."""

from __future__ import annotations

import numpy as np
import pytest
from lumped import five_mode_system

from ema_rig.errors import IdentificationError
from ema_rig.frf import FRFData
from ema_rig.identification import identify, mac, plscf

FREQ = np.arange(0.0, 1000.5, 0.5)
CLOSE = 3  # index of the 414.1 Hz mode: node at reference 0, 1 % above mode 2


@pytest.fixture(scope="module")
def system():
    return five_mode_system()


def _nearest(ps, order, fn):
    idx = ps.at_order(order)
    k = np.argmin(np.abs(ps.natural_freq[idx] - fn))
    return idx[k]


@pytest.mark.parametrize("inputs", [(0,), (0, 1)], ids=["SIMO", "MIMO"])
def test_noise_free_poles_at_top_order(system, inputs):
    data = system.frf(FREQ, inputs=inputs)
    ps = plscf(data, max_order=40 if len(inputs) == 1 else 24)
    top = ps.orders[-1]
    visible = [r for r in range(6) if len(inputs) == 2 or r != CLOSE]
    for r in visible:
        k = _nearest(ps, top, system.natural_freq[r])
        # noise-free data: only the discrete-time model approximation error remains
        np.testing.assert_allclose(ps.natural_freq[k], system.natural_freq[r], rtol=1e-6)
        np.testing.assert_allclose(ps.damping_ratio[k], system.damping_ratio[r], rtol=1e-4)
        if len(inputs) == 2:
            # participation factors of a classically damped system = shape at the references
            truth = system.normal_modes()[1][r, list(inputs)]
            assert mac(ps.participation[k], truth)[0, 0] > 0.999


def test_lower_orders_are_exact_from_max_order_factors(system):
    # noisy data keep M_n well conditioned, so round-off stays at the 1e-12 level
    data = system.frf(FREQ, inputs=(0, 1), noise=0.01, rng=np.random.default_rng(1))
    full = plscf(data, max_order=24)
    alone = plscf(data, max_order=24, orders=[12])
    a = np.sort_complex(full.pole[full.order == 12])
    b = np.sort_complex(alone.pole)
    # the order-12 system sliced from the order-24 factors or built for order 12 alone: the
    # same equations, only round-off may differ
    np.testing.assert_allclose(a, b, rtol=1e-9)


def test_root_finders_agree(system):
    data = system.frf(FREQ, inputs=(0, 1), noise=0.01, rng=np.random.default_rng(3))
    warm = plscf(data, max_order=40)
    eig = plscf(data, max_order=40, root_finder="eig", threads=2)
    # the orders reach degree 64 (and stay <= 100): orders 16..40 (degree 32-80) by the batched
    # warm-started iteration (the chain from degree 32), none fell back; orders 1..15 by the companion QR
    assert warm.meta["aberth_orders"] == 25 and warm.meta["fallbacks"] == 0
    assert eig.meta["aberth_orders"] == 0
    np.testing.assert_array_equal(warm.order, eig.order)
    for n in warm.orders:
        ia, ib = warm.at_order(n), eig.at_order(n)
        # warm-started Aberth iteration and companion QR find the same roots (round-off only)
        np.testing.assert_allclose(warm.pole[ia], eig.pole[ib], rtol=1e-9)
        # and the same participation vectors (unit norm, NaN for the unstable poles): null vectors of
        # A(z) at poles that agree to round-off (measured 1.4e-12 here, 3.4e-13 on the bench_plscf data)
        pa, pb = warm.participation[ia], eig.participation[ib]
        np.testing.assert_array_equal(np.isnan(pa), np.isnan(pb))
        np.testing.assert_allclose(pa[~np.isnan(pa)], pb[~np.isnan(pb)], rtol=0, atol=1e-9)
    with pytest.raises(ValueError, match="root_finder"):
        plscf(data, max_order=4, root_finder="roots")


def test_two_references_chain_start_by_top_degree(system):
    """Two references: the batched chain starts at degree 32 only while the orders end at degree
    64-100 (``_CHAIN_FROM_DEGREE_MIMO``, ``_CHAIN_LOW_TOP_MIMO``), at 64 when they go on beyond."""
    data = system.frf(FREQ, inputs=(0, 1), noise=0.01, rng=np.random.default_rng(5))
    ends_at_100 = plscf(data, max_order=50, orders=range(2, 51, 2))
    beyond = plscf(data, max_order=52, orders=range(2, 53, 2))
    eig = plscf(data, max_order=52, orders=range(2, 53, 2), root_finder="eig", threads=1)
    # even orders 16..50 (degree 32-100) against 32..52 (degree 64-104), no fallback
    assert ends_at_100.meta["aberth_orders"] == 18 and ends_at_100.meta["fallbacks"] == 0
    assert beyond.meta["aberth_orders"] == 11 and beyond.meta["fallbacks"] == 0
    for ps in (ends_at_100, beyond):
        for n in ps.orders:
            # the companion eigenvalues of the same denominators (QR: an independent method);
            # round-off only, as in test_root_finders_agree
            np.testing.assert_allclose(ps.pole[ps.at_order(n)], eig.pole[eig.at_order(n)], rtol=1e-9)


def test_one_reference_root_finders_agree_at_every_order(system):
    """One reference up to order 210: orders below degree 48 by the companion QR, 48-200 by the
    batched chain, 202-210 one by one (both Aberth paths and every power-row kernel); every order
    against the companion eigenvalues of the same denominators (``root_finder='eig'``, the
    numpy.roots method), as sets."""
    data = system.frf(FREQ, inputs=(0,), noise=0.01, rng=np.random.default_rng(4))
    warm = plscf(data, max_order=210)
    eig = plscf(data, max_order=210, root_finder="eig", threads=1)
    assert warm.meta["aberth_orders"] == 82 and warm.meta["fallbacks"] == 0
    np.testing.assert_array_equal(warm.order, eig.order)
    worst = {True: 0.0, False: 0.0}
    for n in warm.orders:
        a, b = warm.pole[warm.at_order(n)], eig.pole[eig.at_order(n)]
        d = np.abs(a[:, None] - b[None, :])
        j = d.argmin(axis=1)
        assert np.unique(j).size == a.size  # one to one
        rel = d[np.arange(a.size), j] / np.abs(b[j])
        for stable in (True, False):
            sel = (b[j].real < 0) == stable
            worst[stable] = max(worst[stable], float(rel[sel].max(initial=0.0)))
    # the same roots to round-off times their condition: the stable (physical) poles are well
    # conditioned (measured 2.0e-14), the unstable noise poles less (measured 1.1e-12); the
    # chain's acceptance test 1e5 times looser than rounding level gives 3e-9 and 4e-7
    assert worst[True] < 1e-12, worst
    assert worst[False] < 1e-11, worst


def test_warm_started_roots():
    from ema_rig.identification._roots import aberth, det_coefficients, warm_start

    rng = np.random.default_rng(0)
    alpha = rng.standard_normal((6, 2, 2))
    c = det_coefficients(alpha)
    # det of a degree-5 2x2 polynomial matrix: degree 10, checked at a random point
    z = 0.3 + 0.7j
    a = sum(alpha[j] * z**j for j in range(6))
    np.testing.assert_allclose(np.polyval(c[::-1], z), np.linalg.det(a), rtol=1e-12)
    truth = np.roots(c[::-1])
    found = aberth(c, warm_start(truth[:-2] * 1.01, 10))
    assert found is not None
    # every root found to round-off (roots of a well-conditioned random polynomial)
    dist = np.abs(found[:, None] - truth[None, :]).min(axis=0)
    np.testing.assert_allclose(dist, 0.0, atol=1e-9 * np.abs(truth).max())
    # no convergence within the limit: None, so the caller falls back to eigenvalues
    assert aberth(c, warm_start(np.zeros(0), 10), maxiter=1) is None


@pytest.mark.parametrize("m", [9, 150], ids=["accumulate", "row-products"])
@pytest.mark.parametrize("n", [0, 1, 7, 64, 200])
def test_block_powers_match_numpy_power(n, m):
    import math

    from ema_rig.identification._roots import _ROW_PRODUCTS, powers

    assert (m < _ROW_PRODUCTS) == (m == 9)  # both ways of forming the power rows are tested
    rng = np.random.default_rng(n)
    x = np.exp(2j * np.pi * rng.random(m)) * (1.0 + 0.02 * rng.standard_normal(m))
    x[0] = 0.0  # 0**0 = 1
    got = powers(x, n)
    assert got.shape == (n + 1, m)
    eps = np.finfo(float).eps
    j = np.arange(n + 1)[:, None]
    if np.finfo(np.longdouble).eps < eps / 100:
        # a plain running product in extended precision (x86: 64-bit mantissa), independent of the
        # blocks: its error (~n 1e-19) is negligible (numpy's long double power is not: 4e-14 at
        # n = 200). Each power is a product of two rows, each row a chain of at most isqrt(n) + 1
        # and ceil((n + 1) / b) rounded products: ~2 sqrt(n) + 2 rounded factors (measured
        # 1e-14 = 45 eps at n = 200), 4 eps per factor bounds them
        def exact(v: np.ndarray) -> np.ndarray:
            run = np.ones((n + 1, m), dtype=np.clongdouble if v.dtype.kind == "c" else np.longdouble)
            run[1:] = v
            return np.multiply.accumulate(run, axis=0).astype(v.dtype)

        rtol = 4 * (2 * math.isqrt(max(n, 1)) + 4) * eps
    else:  # no extended precision: numpy's double power errs itself by up to ~2 n eps

        def exact(v: np.ndarray) -> np.ndarray:
            return v[None, :] ** j

        rtol = 4 * max(n, 1) * eps
    np.testing.assert_allclose(got, exact(x), rtol=rtol, atol=0)
    np.testing.assert_allclose(powers(np.abs(x), n), exact(np.abs(x)), rtol=rtol, atol=0)


def test_reduced_normal_equations_match_explicit_least_squares(system):
    from ema_rig.identification.plscf import _lag_sums, _reduced_blocks

    data = system.frf(FREQ, inputs=(0, 1), noise=0.01, rng=np.random.default_rng(2)).band(100, 900)
    p, n_in = 6, 2
    r, s, t, w, dt = _lag_sums(data, p)
    T, Q = _reduced_blocks(r, s, t, p)
    m_fast = T - np.einsum("iok,iol->kl", Q, Q)
    # explicit real-coefficient least squares on z = exp(j 2 pi (f - f_lo) dt)
    z = np.exp(2j * np.pi * (data.freq - data.freq[0]) * dt)
    X = z[:, None] ** np.arange(p + 1)
    m_slow = np.zeros_like(m_fast)
    for o in range(data.n_out):
        H = data.frf[o].T * w[o]  # (n_freq, n_in)
        Y = -(X[:, :, None] * H[:, None, :]).reshape(z.size, (p + 1) * n_in)
        R = (X.conj().T @ X).real
        S = (X.conj().T @ Y).real
        Tm = (Y.conj().T @ Y).real
        m_slow += Tm - S.T @ np.linalg.solve(R, S)
    # Toeplitz lag sums by FFT + one Cholesky == the textbook normal equations
    np.testing.assert_allclose(m_fast, m_slow, rtol=1e-9, atol=1e-9 * np.abs(m_slow).max())


def _textbook_reduced_matrix(data, n):
    """M_n of the real-coefficient least squares, built from the lines directly (no lag sums)."""
    f = data.freq
    dt = 1 / (2 * (f[-1] - f[0]))
    z = np.exp(2j * np.pi * (f - f[0]) * dt)
    X = z[:, None] ** np.arange(n + 1)
    n_in = data.n_in
    m = np.zeros(((n + 1) * n_in, (n + 1) * n_in))
    for o in range(data.n_out):
        H = data.frf[o].T / np.sqrt(np.mean(np.abs(data.frf[o]) ** 2))  # output weight 1 / rms
        Y = -(X[:, :, None] * H[:, None, :]).reshape(z.size, -1)
        R, S, T = (X.conj().T @ X).real, (X.conj().T @ Y).real, (Y.conj().T @ Y).real
        m += T - S.T @ np.linalg.solve(R, S)
    return m, dt


def _block_companion_roots(alpha):
    """All z with det(sum_j alpha_j z^j) = 0, alpha_top = I: eigenvalues of the block companion."""
    n, n_in = alpha.shape[0] - 1, alpha.shape[1]
    c = np.zeros((n * n_in, n * n_in))
    for j in range(n):  # last block row: -alpha_0 .. -alpha_{n-1}; identities above it
        c[(n - 1) * n_in :, j * n_in : (j + 1) * n_in] = -alpha[j]
    c[np.arange((n - 1) * n_in), np.arange(n_in, n * n_in)] = 1.0
    return np.linalg.eigvals(c)


def test_two_reference_coefficients_poles_and_participation(system):
    from ema_rig.identification.plscf import _solve_order

    data = system.frf(FREQ, inputs=(0, 1), noise=0.01, rng=np.random.default_rng(7))
    n, n_in = 36, 2  # degree 72 of det A: the warm-started root path
    m, dt = _textbook_reduced_matrix(data, n)
    # the constrained least-squares solutions from the sub-blocks of M (alpha_0 = I, alpha_n = I)
    k = n * n_in
    x_low = np.linalg.solve(m[n_in:, n_in:], -m[n_in:, :n_in])
    x_high = np.linalg.solve(m[:k, :k], -m[:k, k:])
    low, high = _solve_order(np.tril(m), n, n_in)  # only the lower triangle is to be read
    # one Cholesky factor and M^-1 [E_0, E_n] against the textbook sub-block solves: both backward
    # stable for M (cond(M) ~ 1e5 here), measured differences 6e-12 of the largest coefficient
    np.testing.assert_allclose(low[1:].reshape(-1, n_in), x_low, rtol=0, atol=1e-10 * np.abs(x_low).max())
    np.testing.assert_allclose(high[:-1].reshape(-1, n_in), x_high, rtol=0, atol=1e-10 * np.abs(x_high).max())
    np.testing.assert_array_equal(low[0], np.eye(n_in))
    np.testing.assert_array_equal(high[-1], np.eye(n_in))

    ps = plscf(data, max_order=n, orders=range(2, n + 1, 2))
    # the orders reach degree 64 (72): orders 16..36 (degree 32-72) go the warm-started way (the
    # batched chain from degree 32); an order that the iteration does not accept falls back to the
    # companion eigenvalues, so every order is checked below
    assert ps.meta["aberth_orders"] >= 1 and ps.meta["aberth_orders"] + ps.meta["fallbacks"] == 11
    f_hi = FREQ[-1]
    for order in (16, 24):
        # the chain below degree 64: every unstable pole (a root of A_low as found, not polished) on
        # the oracle's block-companion eigenvalues, round-off only as below, and as many
        mo, _ = _textbook_reduced_matrix(data, order)
        xl = np.linalg.solve(mo[n_in:, n_in:], -mo[n_in:, :n_in])
        low_t = np.concatenate([np.eye(n_in)[None], xl.reshape(order, n_in, n_in)])
        s_low = np.log(1 / _block_companion_roots(low_t[::-1])) / dt
        oracle = s_low[(s_low.real >= 0) & (s_low.imag > 0) & (np.abs(s_low) / (2 * np.pi) <= f_hi)]
        got = ps.pole[ps.at_order(order)]
        got = got[got.real >= 0]
        assert got.size == oracle.size
        d = np.abs(got[:, None] - oracle[None, :]).min(axis=1) / np.abs(got)
        assert d.max() < 3e-10, d.max()
    for order in (32, 34, n):
        if order == n:
            xl, xh = x_low, x_high
        else:
            mo, _ = _textbook_reduced_matrix(data, order)
            ko = order * n_in
            xl = np.linalg.solve(mo[n_in:, n_in:], -mo[n_in:, :n_in])
            xh = np.linalg.solve(mo[:ko, :ko], -mo[:ko, ko:])
        got = ps.pole[ps.at_order(order)]
        # oracle poles: the block-companion eigenvalues of the textbook coefficients; the unstable
        # ones from alpha_0 = I (roots of A_low: 1 / eigenvalues of the reversed, monic polynomial),
        # the stable ones polished onto the roots of A_high (alpha_n = I, monic)
        low_t = np.concatenate([np.eye(n_in)[None], xl.reshape(order, n_in, n_in)])
        high_t = np.concatenate([xh.reshape(order, n_in, n_in), np.eye(n_in)[None]])
        s_low = np.log(1 / _block_companion_roots(low_t[::-1])) / dt
        s_high = np.log(_block_companion_roots(high_t)) / dt
        unstable = got.real >= 0
        # every pole of the estimator is one of the oracle's (sets, not order). Unstable: the
        # same roots by two routes, round-off only (measured 1.4e-11). Stable: a root of A_low
        # moved by three Newton steps onto A_high's (measured 3e-11 at order 36; one mode at
        # order 32/34 ends 8e-9 away, the polish's own convergence)
        for sel, oracle, tol in ((unstable, s_low[(s_low.real >= 0) & (s_low.imag > 0)], 3e-10),
                                 (~unstable, s_high[(s_high.real < 0) & (s_high.imag > 0)], 1e-7)):
            oracle = oracle[np.abs(oracle) / (2 * np.pi) <= f_hi]
            d = np.abs(got[sel][:, None] - oracle[None, :]).min(axis=1) / np.abs(got[sel])
            assert d.max() < tol, d.max()
        # the unstable roots are the whole set of A_low's (same count); the stable ones are the
        # six physical modes, each on a root of A_high
        in_band = (s_low.real >= 0) & (s_low.imag > 0) & (np.abs(s_low) / (2 * np.pi) <= f_hi)
        assert unstable.sum() == np.sum(in_band)
        assert (~unstable).sum() == 6
        # participation factors of every checked order (not only the top one): the null vector
        # l of A_high(z)^T at each stable pole, from an SVD
        idx = ps.at_order(order)
        for r in np.flatnonzero(~unstable):
            z = np.exp(got[r] * dt)
            a = np.einsum("j,jab->ab", z ** np.arange(order + 1), high_t)
            _, sv, vh = np.linalg.svd(a.T)
            # A is singular at the pole: measured <= 6e-9, and 1.2e-6 for the one mode of order 34
            # that the polish leaves 8e-9 from A_high's root (see above)
            assert sv[-1] < 1e-5 * sv[0]
            ref = vh[-1].conj()
            l_vec = ps.participation[idx[r]]
            # unit vectors equal up to a phase. The estimator's l is orthogonal to one row of
            # A^T, the SVD's to the best rank-1 fit: they differ by about sv[-1] / sv[0] (first
            # order in the distance from singularity; measured 0.4-0.9 times it, or round-off,
            # <= 6e-15, where A is singular to round-off)
            ip = np.vdot(ref, l_vec)
            assert np.linalg.norm(l_vec - ip / abs(ip) * ref) < 2 * sv[-1] / sv[0] + 1e-13


def test_solve_order_falls_back_when_not_positive_definite():
    from ema_rig.identification.plscf import _solve_order

    rng = np.random.default_rng(3)
    a = rng.standard_normal((5, 10))  # rank 5 of 10: M is singular, no Cholesky factor
    m = a.T @ a
    low, high = _solve_order(np.tril(m), 4, 2)
    # least squares on the symmetric sub-blocks: the normal equations hold to round-off
    x_low, x_high = low[1:].reshape(-1, 2), high[:-1].reshape(-1, 2)
    np.testing.assert_allclose(m[2:, 2:] @ x_low, -m[2:, :2], atol=1e-10 * np.abs(m).max())
    np.testing.assert_allclose(m[:8, :8] @ x_high, -m[:8, 8:], atol=1e-10 * np.abs(m).max())


def test_simo_cannot_separate_close_pair_but_mimo_does(system):
    simo = identify(system.frf(FREQ, inputs=(0,)))
    mimo = identify(system.frf(FREQ, inputs=(0, 1)))
    f_close = system.natural_freq[CLOSE]
    # the 414.1 Hz mode has a node at reference 0: a single-reference test cannot see it
    assert np.min(np.abs(simo.natural_freq - f_close)) > 0.005 * f_close
    # both references: both modes of the 1 % pair, each to the noise-free tolerance
    np.testing.assert_allclose(np.sort(mimo.natural_freq), system.natural_freq, rtol=1e-6)
    np.testing.assert_allclose(
        mimo.damping_ratio[np.argsort(mimo.natural_freq)], system.damping_ratio, rtol=1e-4
    )


@pytest.mark.parametrize("inputs", [(0,), (0, 1)], ids=["SIMO", "MIMO"])
def test_noisy_identification(system, inputs):
    rng = np.random.default_rng(20241122)
    data = system.frf(FREQ, inputs=inputs, noise=0.01, rng=rng)
    ident = identify(data)
    visible = [r for r in range(6) if len(inputs) == 2 or r != CLOSE]
    assert ident.modes.n_modes == len(visible)
    order = np.argsort(ident.natural_freq)
    # 1 % noise on 8000 complex values per mode: the estimate scatters well below 1e-4 / 5e-2
    np.testing.assert_allclose(ident.natural_freq[order], system.natural_freq[visible], rtol=1e-4)
    np.testing.assert_allclose(ident.damping_ratio[order], system.damping_ratio[visible], rtol=5e-2)


def test_spurious_poles_come_out_unstable(system):
    data = system.frf(FREQ, inputs=(0,), noise=0.01, rng=np.random.default_rng(5))
    ps = plscf(data, max_order=60)
    top = ps.at_order(60)
    stable = top[ps.pole[top].real < 0]
    # with alpha_0 = I the mathematical poles leave the unit circle: at the top order only
    # the 5 visible physical poles (plus at most a couple of edge poles) stay stable,
    # out of 30 pole pairs
    assert 5 <= stable.size <= 8
    assert np.mean(ps.pole.real >= 0) > 0.5
    for r in (0, 1, 2, 4, 5):
        # one noisy order (no cluster averaging): each physical mode is among the stable poles
        assert np.min(np.abs(ps.natural_freq[stable] / system.natural_freq[r] - 1)) < 1e-3


def test_shifted_band_and_uneven_grid(system):
    data = system.frf(FREQ, inputs=(0, 1))
    ps = plscf(data, band=(300.0, 700.0), max_order=20)
    assert ps.band == (300.0, 700.0)
    # an uneven grid (every 7th line dropped) takes the direct lag-sum path
    keep = np.ones(FREQ.size, bool)
    keep[::7] = False
    uneven = FRFData(FREQ[keep], data.frf[:, :, keep], data.out_dofs, data.in_dofs)
    assert not uneven.is_even
    ps2 = plscf(uneven, band=(300.0, 700.0), max_order=20)
    for p in (ps, ps2):
        for r in (2, 3, 4):  # the modes inside 300..700 Hz
            k = _nearest(p, 20, system.natural_freq[r])
            # the shift keeps the band on the whole half circle: same accuracy as a full band
            np.testing.assert_allclose(p.natural_freq[k], system.natural_freq[r], rtol=1e-6)
            np.testing.assert_allclose(p.damping_ratio[k], system.damping_ratio[r], rtol=1e-4)


def test_poleset_is_tidy_and_frozen(system):
    ps = plscf(system.frf(FREQ, inputs=(0, 1)), max_order=6)
    assert ps.orders == (1, 2, 3, 4, 5, 6)
    n = len(ps)
    assert ps.order.shape == ps.pole.shape == ps.natural_freq.shape == (n,)
    assert ps.participation.shape == (n, 2)
    # unit vectors where a pole can be physical; unstable poles (Re > 0) get none (NaN)
    phys = ps.pole.real < 0
    assert phys.any() and (~phys).any()
    np.testing.assert_allclose(np.linalg.norm(ps.participation[phys], axis=1), 1.0, rtol=1e-12)
    assert np.all(np.isnan(ps.participation[~phys]))
    assert np.all(ps.pole.imag > 0)
    with pytest.raises(ValueError):
        ps.pole[0] = 0
    rec = ps.to_records()[0]
    assert set(rec) == {"order", "natural_freq", "damping_ratio", "pole_real", "pole_imag"}


# ---------------------------------------------------------------------------- bad input
def _data(h=None, freq=FREQ):
    if h is None:
        h = np.ones((2, 1, freq.size), complex)
    return FRFData(freq, h, ["1+Y", "2+Y"], ["1+Y"], meta={"file": "meas.uff"})


def test_band_outside_data():
    # a band overlapping the data in part extends beyond it (the overlap is suggested); one without overlap
    # lies outside it: the same wording as the stiffness stage's (one definition, errors.band_error)
    with pytest.raises(IdentificationError, match=r"band 900..1200 Hz extends beyond the data \(0..1000 Hz\); "
                       r"choose a band within it, e.g. 900..1000 Hz") as e:
        plscf(_data(), max_order=10, band=(900, 1200))
    assert e.value.file == "meas.uff"
    with pytest.raises(IdentificationError, match=r"band 1100..1200 Hz lies outside the data \(0..1000 Hz\)"):
        plscf(_data(), max_order=10, band=(1100, 1200))
    with pytest.raises(IdentificationError, match="freq_lower < freq_upper"):
        identify(_data(), band=(500, 100))


def test_too_few_lines_for_order():
    f = np.linspace(0, 100, 50)
    with pytest.raises(IdentificationError, match="too few lines for max_order=40: 50 lines"):
        plscf(_data(freq=f), max_order=40)


def test_all_zero_and_nan():
    with pytest.raises(IdentificationError, match="zero everywhere"):
        identify(_data(np.zeros((2, 1, FREQ.size), complex)))
    h = np.ones((2, 1, FREQ.size), complex)
    h[1, 0, 10] = np.nan
    with pytest.raises(IdentificationError, match=r"NaN/inf values \(first: output 2\+Y, input 1\+Y, 5 Hz\)"):
        identify(_data(h))


def test_no_stable_pole_is_an_error():
    rng = np.random.default_rng(0)
    h = rng.standard_normal((2, 1, FREQ.size)) + 1j * rng.standard_normal((2, 1, FREQ.size))
    # white noise has no physical pole: the estimator makes every pole unstable
    with pytest.raises(IdentificationError, match="no stable pole in the band 0..1000 Hz"):
        identify(_data(h))


@pytest.mark.crosscheck
def test_crosscheck_sdypy_lscf(system):
    import matplotlib

    matplotlib.use("Agg")
    from sdypy import EMA

    data = system.frf(FREQ, inputs=(0,))
    ident = identify(data, max_order=40)
    # sdypy-EMA 0.31 mishandles lower=0; start at the first line above 0 Hz instead
    model = EMA.Model(frf=data.frf[:, 0, :], freq=FREQ, lower=FREQ[1], upper=FREQ[-1], pol_order_high=20)
    model.get_poles("lscf", show_progress=False)
    theirs = np.asarray(model.all_poles[-1])
    theirs = theirs[(theirs.imag > 0) & (theirs.real < 0)]
    fn = np.abs(theirs) / (2 * np.pi)
    zeta = -theirs.real / np.abs(theirs)
    assert ident.modes.n_modes == 5
    for f0, z0 in zip(ident.natural_freq, ident.damping_ratio, strict=True):
        k = np.argmin(np.abs(fn - f0))
        # the same noise-free physical poles from an independent implementation
        np.testing.assert_allclose(fn[k], f0, rtol=1e-6)
        np.testing.assert_allclose(zeta[k], z0, rtol=1e-4)


def test_frf_memory_layout_does_not_matter(system):
    # an FRF array in Fortran order (as a transposed or sliced array arrives): the lag sums read
    # it in place; the same poles as the C-ordered copy, to round-off
    data = system.frf(FREQ, inputs=(0,), noise=0.01, rng=np.random.default_rng(5))
    fortran = FRFData(data.freq, np.asfortranarray(data.frf), data.out_dofs, data.in_dofs, frf_form=data.frf_form)
    a = plscf(data, max_order=20, orders=[20])
    b = plscf(fortran, max_order=20, orders=[20])
    np.testing.assert_allclose(np.sort_complex(a.pole), np.sort_complex(b.pole), rtol=1e-12)


@pytest.mark.parametrize("n_in", [1, 2, 3])
def test_solve_order_against_the_sub_block_solves(n_in):
    # the constrained solutions of a well-conditioned random SPD M (alpha_0 = I, alpha_n = I)
    # from the textbook sub-block solves; _solve_order takes one Cholesky factor and the small
    # pivot blocks' inverses (closed form for 2 x 2). Both are backward stable for M (cond 9-13
    # here): round-off, measured <= 8e-16 of the largest coefficient; 1e-13 fails on a wrong
    # block or a transposed inverse (O(1))
    from ema_rig.identification.plscf import _solve_order

    n = 7
    k = n * n_in
    rng = np.random.default_rng(n_in)
    a = rng.standard_normal((3 * (k + n_in), k + n_in))
    m = a.T @ a
    x_low = np.linalg.solve(m[n_in:, n_in:], -m[n_in:, :n_in])
    x_high = np.linalg.solve(m[:k, :k], -m[:k, k:])
    low, high = _solve_order(np.tril(m), n, n_in)
    np.testing.assert_allclose(low[1:].reshape(-1, n_in), x_low, rtol=0, atol=1e-13 * np.abs(x_low).max())
    np.testing.assert_allclose(high[:-1].reshape(-1, n_in), x_high, rtol=0, atol=1e-13 * np.abs(x_high).max())
    np.testing.assert_array_equal(low[0], np.eye(n_in))
    np.testing.assert_array_equal(high[-1], np.eye(n_in))


def test_small_inverse_and_companion_against_numpy():
    from ema_rig.identification.plscf import _companion, _inv_small, _roots_eig

    rng = np.random.default_rng(11)
    for size in (1, 2, 3):
        a = rng.standard_normal((size, size)) + 3 * np.eye(size)
        # closed form (1 x 1, 2 x 2) or LAPACK against numpy's inverse: round-off (cond ~ 3)
        np.testing.assert_allclose(_inv_small(a), np.linalg.inv(a), rtol=1e-14, atol=1e-15)
    assert not np.isfinite(_inv_small(np.array([[1.0, 2.0], [2.0, 4.0]]))).all()  # singular: caller's test
    for n_in, n in ((1, 1), (1, 9), (2, 1), (2, 5), (3, 4)):
        beta = rng.standard_normal((n + 1, n_in, n_in))
        beta[n] = np.eye(n_in)
        c = _companion(beta)
        # the block companion written out: first block row -beta_(n-1) .. -beta_0, identities below
        want = np.zeros((n * n_in, n * n_in))
        for j in range(n):
            want[:n_in, j * n_in : (j + 1) * n_in] = -beta[n - 1 - j]
        want[np.arange(n_in, n * n_in), np.arange(0, (n - 1) * n_in)] = 1.0
        np.testing.assert_array_equal(c, want)
        assert c.flags.f_contiguous
    # one reference: the roots of A_low (alpha_0 = 1) against numpy.roots, as sets; round-off of
    # two eigenvalue routes on a random degree-30 polynomial (measured 3.7e-15 relative)
    low = rng.standard_normal(31)
    low[0] = 1.0
    got = _roots_eig(low.reshape(-1, 1, 1))
    want = np.roots(low[::-1])
    d = np.abs(got[:, None] - want[None, :]).min(axis=1) / np.abs(got)
    assert got.size == 30 and d.max() < 5e-14


def test_deflated_roots_against_constructed_roots():
    """_roots_deflated (stable roots divided out, QR of the quotient) against polynomials built from
    their roots: seven lightly damped pairs (|z| 0.95-0.999) that move by 1e-4 from order to order,
    as pLSCF's physical poles do, and unstable noise roots drawn afresh per order. The anchor holds
    the pairs of the order below plus a start far from any root and a duplicate start (two starts
    on one root: the later must not be divided out twice)."""
    from ema_rig.identification.plscf import _roots_deflated, _roots_eig

    rng = np.random.default_rng(7)
    base = 0.95 + 0.049 * rng.random(7)
    ang = np.sort(rng.uniform(0.2, 2.9, 7))
    lows, truths = [], []
    for deg in range(20, 42, 2):
        pairs = base * np.exp(1j * ang) * (1 + 1e-4 * rng.standard_normal(7))
        m = (deg - 14) // 2
        noise = rng.uniform(1.05, 1.5, m) * np.exp(1j * (np.arange(m) + rng.uniform(0.2, 0.8, m)) * np.pi / m)
        roots = np.concatenate([pairs, pairs.conj(), noise, noise.conj()])
        c = np.poly(roots)[::-1].real  # lowest first
        lows.append((c / c[0]).reshape(-1, 1, 1))
        truths.append(roots)
    anchor = np.concatenate([base * np.exp(1j * ang), [0.5j, base[0] * np.exp(1j * ang[0])]])
    anchor = np.concatenate([anchor, anchor.conj()])
    got = _roots_deflated(lows, anchor)
    for low, z, truth in zip(lows, got, truths, strict=True):
        assert z.size == truth.size
        # against the constructed roots (the rounding of the coefficients moves them: the companion
        # eigenvalues are as far, measured 1.7e-10 relative at most) and against the companion
        # eigenvalues of the same coefficients (measured 1.1e-13 relative at most)
        d = np.abs(z[:, None] - truth[None, :])
        assert np.unique(d.argmin(axis=1)).size == truth.size  # one to one
        assert (d.min(axis=1) / np.abs(z)).max() < 1e-9
        qr = _roots_eig(low)
        assert (np.abs(z[:, None] - qr[None, :]).min(axis=1) / np.abs(z)).max() < 1e-12
    # no stable start: every order by the companion eigenvalues alone
    assert all(np.array_equal(a, _roots_eig(low)) for a, low in zip(_roots_deflated(lows, 2.0 + anchor), lows, strict=True))
