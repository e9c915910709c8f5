"""fit_noise_model reaches the maximum of its likelihood (issue 18: the faster search loses nothing).

Oracle: the profile negative log-likelihood written out here from its definition (exponential
``|e|^2`` with mean ``a + b |H|^2``), minimised per channel by ``scipy.optimize.minimize_scalar``
(bounded Brent) over ``ln q`` on a fine scan's best bracket; independent of the module's grid,
single-precision screen and Newton iteration.
"""

from __future__ import annotations

import numpy as np
from scipy.optimize import minimize_scalar

from ema_rig.identification.noise import fit_noise_model


def _profile(z: np.ndarray, u: np.ndarray, w: np.ndarray, q: float) -> tuple[float, float]:
    """ln s + mean ln(1 + q u / m) over the lines with w, and s (m the mean u there)."""
    zz, uu = z[w], u[w]
    shape = 1.0 + q * uu / uu.mean()
    s = float(np.mean(zz / shape))
    return float(np.log(s) + np.mean(np.log(shape))), s


def _oracle(z: np.ndarray, u: np.ndarray, w: np.ndarray) -> tuple[float, float, float]:
    """(a, b, nll) at the best of q = 0 and the bounded minimum over ln q in [ln 1e-5, ln 1e8]."""
    xs = np.linspace(np.log(1e-5), np.log(1e8), 400)
    fs = [_profile(z, u, w, float(np.exp(x)))[0] for x in xs]
    k = int(np.argmin(fs))
    lo, hi = xs[max(k - 1, 0)], xs[min(k + 1, xs.size - 1)]
    res = minimize_scalar(lambda x: _profile(z, u, w, float(np.exp(x)))[0], bounds=(lo, hi), method="bounded",
                          options={"xatol": 1e-10})
    q = float(np.exp(res.x))
    f0, s0 = _profile(z, u, w, 0.0)
    f1, s1 = _profile(z, u, w, q)
    if f0 <= f1:
        return s0, 0.0, f0
    return s1, s1 * q / u[w].mean(), f1


def test_noise_fit_reaches_the_likelihood_minimum():
    rng = np.random.default_rng(7)
    n_chan, n = 12, 1500
    u = np.exp(rng.uniform(-6.0, 4.0, (n_chan, n)))
    # floors and relative parts over four decades of their ratio, two pure floors, one pure relative
    a_true = 10.0 ** rng.uniform(-4, -2, n_chan)
    b_true = 10.0 ** rng.uniform(-3, -1, n_chan)
    b_true[:2] = 0.0
    a_true[2] = 0.0
    z = (a_true[:, None] + b_true[:, None] * u) * rng.exponential(size=u.shape)
    mask = rng.uniform(size=u.shape) > 0.2
    mask[0] = True
    a, b, var = fit_noise_model(z, u, mask=mask)
    for c in range(n_chan):
        a_o, b_o, f_o = _oracle(z[c], u[c], mask[c])
        assert a[c] > 0  # the level s of the profile
        f_new = _profile(z[c], u[c], mask[c], float(b[c] / a[c] * u[c][mask[c]].mean()))[0]
        # the same maximum of the likelihood (its flat top: 1e-10 of the profile), the same variance
        # to 1e-4 (Brent's x tolerance 1e-10 in ln q; a search stopped early is off by percent)
        assert f_new <= f_o + 1e-10, (c, f_new, f_o)
        v_o = a_o + b_o * u[c]
        np.testing.assert_allclose(var[c], v_o, rtol=1e-4, err_msg=f"channel {c}")
    assert np.all(var > 0)


def test_noise_fit_of_many_channels_is_the_fit_of_each_channel_alone():
    """The fit processes channels in blocks (issue 18: speed); every channel's result is the one
    its own fit gives, to the bit (oracle: the channel fitted alone), with and without a mask."""
    rng = np.random.default_rng(3)
    n_chan, n = 160, 400
    u = np.exp(rng.uniform(-6.0, 4.0, (n_chan, n)))
    a_true = 10.0 ** rng.uniform(-4, -2, n_chan)
    b_true = 10.0 ** rng.uniform(-3, -1, n_chan)
    z = (a_true[:, None] + b_true[:, None] * u) * rng.exponential(size=u.shape)
    mask = rng.uniform(size=u.shape) > 0.1
    for m in (None, mask):
        a, b, var = fit_noise_model(z, u, mask=m)
        for c in (0, 31, 32, 95, 96, 127, 128, 159):  # both sides of block edges
            a1, b1, v1 = fit_noise_model(z[c:c + 1], u[c:c + 1], mask=None if m is None else m[c:c + 1])
            assert a[c] == a1[0] and b[c] == b1[0], (c, a[c], a1[0], b[c], b1[0])
            assert np.array_equal(var[c], v1[0])


def _full_grid(z: np.ndarray, u: np.ndarray, w: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """The profile at every grid point of every channel, from its definition (shape (n_chan, n_grid))."""
    return np.array([[_profile(z[c], u[c], w[c], float(q))[0] for q in grid] for c in range(z.shape[0])])


def test_bound_screen_keeps_the_best_grid_point():
    """The grid points left by the binned bounds contain the best point of the full grid (issue 18:
    the screen that replaced the single-precision pass over all 50 points loses nothing).

    Oracle: the profile written out here from its definition at all 50 grid points, in double
    precision. Channels: pure floor, pure proportional (the flat profile towards q -> inf, where
    neighbouring grid points differ by 1e-6), mixtures, a fifth of the lines masked, lines with
    |H|^2 exactly 0, |H|^2 over 90 octaves (beyond the 60 binned ones).
    """
    from ema_rig.identification.noise import _noise_bounds, _noise_grid

    rng = np.random.default_rng(11)
    n_chan, n = 24, 900
    u = np.exp(rng.uniform(-12.0, 4.0, (n_chan, n)))
    u[20:] = np.exp(rng.uniform(-60.0, 2.0, (4, n)))  # 90 octaves
    u[5, :7] = 0.0
    a_true = 10.0 ** rng.uniform(-4, -2, n_chan)
    b_true = 10.0 ** rng.uniform(-3, -1, n_chan)
    b_true[:3] = 0.0
    a_true[3:9] = 0.0
    z = (a_true[:, None] + b_true[:, None] * u) * rng.exponential(size=u.shape)
    grid = np.concatenate([[0.0], np.logspace(-4.0, 8.0, 49)])
    for masked in (False, True):
        w = rng.uniform(size=u.shape) > 0.2 if masked else np.ones(u.shape, bool)
        f = _full_grid(z, u, w, grid)
        # the module's inputs: z and |H|^2 / m on the used lines, 0 elsewhere
        m = np.array([u[c][w[c]].mean() for c in range(n_chan)])
        wz = np.where(w, z, 0.0)
        unw = np.where(w, u / m[:, None], 0.0)
        cnt = w.sum(axis=1).astype(float)
        alive = _noise_bounds(wz, unw, cnt, grid)
        best = _noise_grid(wz, unw, cnt, grid)[3]
        for c in range(n_chan):
            j = int(np.argmin(f[c]))
            assert alive[c, j], (masked, c, j)
            # the same grid point, up to rounding between points whose profiles differ by < 1e-12
            assert f[c, best[c]] <= f[c, j] + 1e-12, (masked, c, best[c], j)
        # the screen leaves few points: 1-2 per channel here (all 50 would be a screen that does nothing)
        assert alive.sum(axis=1).mean() <= 4.0, alive.sum(axis=1)


def _pools(monkeypatch):
    """A list that records every thread pool the noise module creates from now on."""
    import ema_rig.identification.noise as noise

    made = []

    class Spy(noise.ThreadPoolExecutor):  # type: ignore[misc]
        def __init__(self, *a, **k):  # type: ignore[no-untyped-def]
            made.append(a)
            super().__init__(*a, **k)

    monkeypatch.setattr(noise, "ThreadPoolExecutor", Spy)
    return made


def test_noise_fit_in_threads_is_the_fit_in_one_thread(monkeypatch):
    """Blocks of channels run in a pool of two threads (issue 18: speed); the answer is the
    one-thread answer to the bit (oracle: the same fit with the pool switched off), for the noise
    fit and for the completeness test that calls it, so no load or scheduling changes a result. In threads the
    blocks hold ``_NOISE_THREAD_BLOCK`` channels, in one thread ``_NOISE_BLOCK``: 300 channels give blocks of
    128, 128 and 44 against ten of 32 and one of 12, so the answer cannot depend on the partition either."""
    import ema_rig.identification.noise as noise

    rng = np.random.default_rng(5)
    n_chan, n = 300, 600
    assert noise._NOISE_THREAD_BLOCK % noise._NOISE_BLOCK == 0 and n_chan % noise._NOISE_THREAD_BLOCK != 0
    u = np.exp(rng.uniform(-8.0, 4.0, (n_chan, n)))
    z = (1e-3 + 0.02 * u) * rng.exponential(size=u.shape)
    mask = rng.uniform(size=u.shape) > 0.15
    made = _pools(monkeypatch)
    monkeypatch.setattr(noise, "_NOISE_THREADS", 2)  # the pool (off by default: the blocks in one thread)
    monkeypatch.setattr(noise, "_NOISE_THREAD_MIN_VALUES", 1)  # the threads used on these small data
    two = [noise.fit_noise_model(z, u, mask=m) for m in (None, mask)]
    assert len(made) >= 2  # they ran (bin sums, candidate points, Newton: in pools)
    monkeypatch.setattr(noise, "_NOISE_THREADS", 1)
    one = [noise.fit_noise_model(z, u, mask=m) for m in (None, mask)]
    for r2, r1 in zip(two, one, strict=True):
        for x2, x1 in zip(r2, r1, strict=True):
            assert np.array_equal(x2, x1)


def test_noise_fit_threads_only_from_its_work_size(monkeypatch):
    """The noise fit's blocks run in threads only from ``_NOISE_THREAD_MIN_VALUES`` values (channels x
    lines; a work-size rule, measured on the 256-output file: below it the threads' hand-offs cost more than
    they save) and more than one block of ``_NOISE_THREAD_BLOCK`` channels. Oracle: the pools the module
    creates, for fits just below and at the threshold, and at it with one thread's block only."""
    import ema_rig.identification.noise as noise

    rng = np.random.default_rng(6)
    u = np.exp(rng.uniform(-6.0, 3.0, (160, 500)))  # two blocks of 128 channels in threads
    assert u.shape[0] > noise._NOISE_THREAD_BLOCK
    z = (1e-3 + 0.01 * u) * rng.exponential(size=u.shape)
    made = _pools(monkeypatch)
    monkeypatch.setattr(noise, "_NOISE_THREADS", 2)  # the pool (off by default: the blocks in one thread)
    monkeypatch.setattr(noise, "_NOISE_THREAD_MIN_VALUES", u.size + 1)
    below = noise.fit_noise_model(z, u)
    assert made == []
    monkeypatch.setattr(noise, "_NOISE_THREAD_MIN_VALUES", u.size)
    at = noise.fit_noise_model(z, u)
    assert len(made) >= 2
    for x_b, x_a in zip(below, at, strict=True):
        assert np.array_equal(x_b, x_a)
    made.clear()
    small = noise.fit_noise_model(z[: noise._NOISE_THREAD_BLOCK], u[: noise._NOISE_THREAD_BLOCK])
    assert made == []  # one block of the threads' size: nothing to share, no pool
    for x_s, x_a in zip(small, at, strict=True):
        assert np.array_equal(x_s, x_a[: noise._NOISE_THREAD_BLOCK])


def test_noise_fit_of_a_channel_with_a_nan_line_is_nan_and_leaves_the_others():
    """A NaN or inf squared residual makes that channel's fit NaN (it is not hidden as a tiny
    variance); every other channel keeps the fit it has alone (oracle: each channel fitted alone)."""
    rng = np.random.default_rng(8)
    u = np.exp(rng.uniform(-6.0, 3.0, (40, 500)))
    z = (1e-3 + 0.01 * u) * rng.exponential(size=u.shape)
    z[3, 5] = np.nan
    z[13, 3] = np.inf
    with np.errstate(invalid="ignore"):
        a, b, var = fit_noise_model(z, u)
    assert np.isnan(a[3]) and np.isnan(b[3]) and np.isnan(a[13]) and np.isnan(b[13])
    for c in (0, 2, 4, 12, 14, 39):
        a1, b1, _ = fit_noise_model(z[c:c + 1], u[c:c + 1])
        assert a[c] == a1[0] and b[c] == b1[0]


def test_bound_coefficients_from_the_cache_are_those_formed_anew():
    """The bins' bound coefficients kept per octave (``noise._BOUND_CACHE``, shared by the fits of one
    process) are the numbers a fit with an empty cache forms, to the bit, whichever fit formed them first.

    Oracle: the coefficients of the same exponent range formed with the cache emptied, and the
    per-bin formulas (``_bin_coefficients``) evaluated at the bins' edges in one call, assembled in the
    layout of ``_noise_bounds``' products (row ``k n_b + b``: sum ``k`` of bin ``b``). Exact equality
    is the claim: the same operations on the same edges, only formed at another time.
    """
    import ema_rig.identification.noise as noise

    grid = np.concatenate([[0.0], np.logspace(-4.0, 8.0, 49)])
    noise._BOUND_CACHE.clear()
    fresh = noise._bound_coefficients(-18, 5, grid)
    noise._BOUND_CACHE.clear()
    noise._bound_coefficients(-30, -2, grid)  # another fit's range first: octaves -18..-2 come from the cache
    noise._bound_coefficients(3, 9, grid)
    warm = noise._bound_coefficients(-18, 5, grid)
    for a, b in zip(fresh, warm, strict=True):
        assert a.shape == b.shape and a.tobytes() == b.tobytes()
    kb = noise._BOUND_BINS
    frac = np.arange(kb) / (2 * kb) + 0.5
    octs = np.arange(-18, 6)
    lo = np.concatenate([[0.0, 0.0], np.ldexp(np.tile(frac, octs.size), np.repeat(octs, kb))])
    hi = np.concatenate([[0.0, np.ldexp(0.5, -18)], np.ldexp(np.tile(frac + 0.5 / kb, octs.size), np.repeat(octs, kb))])
    c_s, c_t = noise._bin_coefficients(lo, hi, grid)
    n_b = lo.size
    c_s[0] = [[1.0] * (2 * grid.size), [0.0] * (2 * grid.size), [0.0] * (2 * grid.size)]  # bin 0 (u = 0): z alone
    c_t[0] = 0.0
    assert np.array_equal(warm[0], c_s.transpose(1, 0, 2).reshape(3 * n_b, -1))
    assert np.array_equal(warm[1], c_t.transpose(1, 0, 2).reshape(4 * n_b, -1))


def test_bin_sums_are_the_sums_over_the_lines_binned_by_frexp():
    """The bounds' per-bin sums (``noise._bin_sums``, bin index read off the float's bits, np.bincount per sum)
    are the sums of each bin's lines (issue 18: the faster screen bins every line where its definition puts it).

    Oracle: the bin of each line from its definition with ``np.frexp`` (``u = mant 2**ex``: bin
    ``kb (ex - e_lo) + floor(2 kb mant) - kb + 2``, at least 1; bin 0 for ``u = 0``), the sums by ``np.add.at``
    in line order, written out here. Lines: ``u`` exactly 0, exactly on the bins' edges (binary fractions),
    subnormal, below the binned octaves, and spread over 40 octaves. Exact equality is the claim: the same
    additions in the same order.
    """
    import ema_rig.identification.noise as noise

    rng = np.random.default_rng(5)
    n_chan, n = 6, 400
    kb = noise._BOUND_BINS
    u = np.exp(rng.uniform(-20.0, 8.0, (n_chan, n)))
    u[0, :12] = 0.0
    u[1, :40] = np.ldexp(np.tile(np.arange(kb) / (2 * kb) + 0.5, 10), np.repeat(np.arange(-5, 5), kb))  # edges
    u[2, :5] = [5e-324, 1e-310, 2.0**-1022, 2.0**-1000, 1e-200]  # subnormal and far below the binned octaves
    z = rng.exponential(size=u.shape)
    e_hi, e_lo = int(np.frexp(u.max())[1]), -25
    n_b = 2 + (e_hi - e_lo + 1) * kb
    with np.errstate(divide="ignore", over="ignore"):  # 1 / u of the subnormal u: inf in both
        st_s, st_t = noise._bin_sums(z, u, e_lo, n_b)
        mant, ex = np.frexp(u)
        idx = np.maximum(kb * (ex - e_lo) + np.floor(2 * kb * mant).astype(int) - kb + 2, 1)
        idx = np.where(u > 0, idx, 0)
        pos = u > 0
        v = np.where(pos, 1.0 / np.where(pos, u, 1.0), 0.0)
        lg = np.where(pos, np.log(np.where(pos, u, 1.0)), 0.0)
    for c in range(n_chan):
        want_s = np.zeros((3, n_b))
        want_t = np.zeros((4, n_b))
        with np.errstate(over="ignore"):
            terms = (z[c], z[c] * u[c], z[c] * v[c])
        for k, term in enumerate(terms):
            np.add.at(want_s[k], idx[c], term)
        for k, term in enumerate((np.ones(n), u[c], v[c], lg[c])):
            np.add.at(want_t[k], idx[c], term)
        assert np.array_equal(st_s[c], want_s.ravel()), c
        assert np.array_equal(st_t[c], want_t.ravel()), c
