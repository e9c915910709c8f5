"""Measured vs synthesised FRF overlay: the artists carry the data, the synthesis the physics."""

from __future__ import annotations

import numpy as np
import pytest
from lumped import five_mode_system
from numpy.testing import assert_allclose

from ema_rig.identification import lsfd
from ema_rig.plot.synthesis import plot_synthesis


@pytest.mark.usefixtures("mplcleanup")
def test_overlay_of_an_exact_model_matches_the_measurement() -> None:
    system = five_mode_system(close_pair=False)
    freq = np.linspace(0.0, 1000.0, 2001)
    data = system.frf(freq, inputs=(0, 1))
    model = lsfd(data, system.poles, band=(50.0, 950.0))  # the true poles: an exact modal model
    chart = plot_synthesis(data, model, max_channels=4)

    assert len(chart.axes) == 4 and chart.channels == [(0, 0), (1, 0), (2, 0), (3, 0)]
    for (i, j), meas, syn in zip(chart.channels, chart.measured, chart.synthesized, strict=True):
        f = meas.get_xdata()
        # the band is shown with a 10 % margin on each side: 50 - 90 = clipped to 0 Hz .. 1000 Hz
        assert f[0] == pytest.approx(0.0) and f[-1] == pytest.approx(1000.0)
        inside = (f >= 50.0) & (f <= 950.0)
        # an exact modal model with residuals reproduces the FRF inside its band to 1e-6
        assert_allclose(syn.get_ydata()[inside], meas.get_ydata()[inside], rtol=1e-6)
        assert_allclose(meas.get_ydata(), np.abs(data.frf[i, j]), rtol=1e-12)
    # the per-channel fit error in the titles is the model's own (here ~0 %)
    assert all("fit error 0.0 %" in ax.get_title(loc="left") for ax in chart.axes)


def test_line_error_is_the_median_relative_error_per_line() -> None:
    """Every line counts alike: a 10 % gain error on the data (an exact model otherwise) reads
    |1.1 - 1| / 1.1 = 9.09 % at every line, whatever the peaks; the band norm of ``fit_error`` agrees here."""
    system = five_mode_system(close_pair=False)
    freq = np.linspace(0.0, 1000.0, 2001)
    data = system.frf(freq, inputs=(0, 1))
    model = lsfd(data, system.poles, band=(50.0, 950.0))
    assert np.nanmax(model.line_error(data)) < 1e-6  # the exact model
    scaled = data.replace(frf=1.1 * data.frf)
    assert_allclose(model.line_error(scaled), 0.1 / 1.1, rtol=1e-5)
