"""The sandwich's meat of the local ML under correlated residuals (issue 18, Build point 2).

Oracle: the long-run variance of an AR(1) series, ``Var(sum of n terms) -> n s^2 / (1 - rho)^2``
(``s^2`` the innovation variance), analytic and independent of the code. A model error correlates
the residual, and so the line scores, over many lines; a meat from fixed blocks of 4 lines sees
only the short-range part of that variance.
"""

from __future__ import annotations

import numpy as np
import scipy.signal

from ema_rig.identification.ml import _meat, _score_bandwidth


def _ar1(rng: np.random.Generator, rho: float, k: int, n: int) -> np.ndarray:
    x = scipy.signal.lfilter([1.0], [1.0, -rho], rng.standard_normal((k, n + 200)), axis=1)[:, 200:]
    # the scores of a converged fit sum to zero (the first-order condition): centre each series
    return x - x.mean(axis=1, keepdims=True)


def test_meat_from_the_scores_follows_a_long_correlation():
    # rho 0.9: the long-run variance is 1 / (1 - rho)^2 = 100 per line, while blocks of 4 lines
    # capture (4 + 2 (3 rho + 2 rho^2 + rho^3)) / (4 (1 - rho^2)) = 18.5 of it
    rng = np.random.default_rng(7)
    rho, n, reps = 0.9, 600, 150
    truth = n / (1 - rho) ** 2
    fixed = np.mean([_meat(_ar1(rng, rho, 2, n), 4, False)[0, 0] for _ in range(reps)]) / truth
    rng = np.random.default_rng(7)
    data = np.mean([_meat(_ar1(rng, rho, 2, n), 4, True)[0, 0] for _ in range(reps)]) / truth
    assert fixed < 0.3, fixed
    # Bartlett's bias at Andrews' bandwidth (~43 lines here) is about -2 rho / ((1 - rho^2) b) = -22 %,
    # with the centring's -b/n on top (0.77 measured): 0.65..0.95 holds it with the spread of 150 replicates (~3 %)
    assert 0.65 <= data <= 0.95, data


def test_meat_from_the_scores_stays_short_on_white_scores():
    # white scores: the bandwidth stays near the window's main lobe (4 lines) and the meat unbiased
    rng = np.random.default_rng(11)
    n, reps = 600, 150
    bw = [_score_bandwidth(rng.standard_normal((4, n))) for _ in range(20)]
    assert max(bw) < 8, bw
    ratio = np.mean([_meat(rng.standard_normal((2, n)), 4, True)[0, 0] for _ in range(reps)]) / n
    assert 0.9 <= ratio <= 1.1, ratio
