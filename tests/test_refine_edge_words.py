"""The --refine edge warning does not blame "a mode just outside the band" where nothing lies outside.

The smoke review (benchmarks/results/smoke_b1a9ba2.txt, part D) found ``modes --refine`` on every bundled
file at its default band (the whole file, 0-2000 Hz in 0.5 Hz lines) warned "the model misses the data near
the lower band edge (0.5..100 Hz ...), probably a mode just outside the band ...: move the edge away from
it". Below 0.5 Hz there is no band to be outside of; the misfit is the rig's rigid-body modes at 4.7-16 Hz
(data/*.truth.json) that 0.5 Hz lines do not resolve. Inputs here are the misfit ratios the warning
reads (|residual|^2 / noise variance, 1 for a model that fits to the noise).
"""

from __future__ import annotations

import numpy as np

from ema_rig.identification.refine import _edge_misfit


def _misfit_at_start(freq: np.ndarray) -> list[str]:
    z = np.ones((2, freq.size))
    z[:, :10] = 50.0  # a misfit 50x the noise on the first lines only
    return _edge_misfit(z, freq)


def test_band_from_the_first_line_above_0_hz_is_not_told_to_move_its_edge():
    (w,) = _misfit_at_start(np.arange(1, 4001) * 0.5)  # 0.5..2000 Hz
    assert "next to 0 Hz" in w and "just outside" not in w and "move the edge" not in w


def test_band_starting_higher_still_points_below_it():
    (w,) = _misfit_at_start(150.0 + np.arange(1701) * 0.5)  # 150..1000 Hz
    assert "lower band edge (150.." in w and "just outside the band" in w


def test_a_fit_to_the_noise_says_nothing():
    assert _edge_misfit(np.ones((2, 1000)), np.arange(1, 1001) * 0.5) == []
