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


@pytest.mark.usefixtures("mplcleanup")
def test_phase_panel_is_the_frf_angle_with_gaps_at_wraps() -> None:
    """The phase drawn is the FRF's angle (mod 360), inside the form's window, and a wrap is a gap,
    never a vertical stroke across the panel (a plain +/-180 deg wrap drew one at accelerance's 180 deg)."""
    system = five_mode_system(close_pair=False)
    freq = np.linspace(0.0, 1000.0, 2001)
    # accelerance: a driving point's phase runs 180..0 deg, across the plain +/-180 wrap
    data = system.frf(freq, inputs=(0, 1)).to_form("accelerance")
    model = lsfd(data, system.poles, band=(50.0, 950.0))
    chart = plot_synthesis(data, model, max_channels=2, phase=True)
    assert len(chart.phase_axes) == 2
    for pax, (i, j) in zip(chart.phase_axes, chart.channels, strict=True):
        line = pax.get_lines()[0]  # the measured phase
        f, ph = np.asarray(line.get_xdata(), float), np.asarray(line.get_ydata(), float)
        ok = np.isfinite(ph)
        expect = np.degrees(np.angle(np.interp(f[ok], data.freq, data.frf[i, j].real)
                                     + 1j * np.interp(f[ok], data.freq, data.frf[i, j].imag)))
        d = np.mod(ph[ok] - expect + 180.0, 360.0) - 180.0  # the same angle, up to whole turns
        assert np.max(np.abs(d)) < 1e-9
        lo, hi = pax.get_ylim()
        assert np.all((ph[ok] >= lo) & (ph[ok] <= hi))
        # between two finite neighbours the drawn phase never jumps by half a turn or more
        both = ok[1:] & ok[:-1]
        assert np.max(np.abs(np.diff(ph))[both]) < 180.0


def test_phase_line_wraps_into_its_window_with_a_gap() -> None:
    """A phase ramp over three turns: every drawn value inside [centre - 180, centre + 180), equal to the
    angle up to whole turns, and a NaN gap at each of the wraps (a plain angle jumps by 360 deg there)."""
    from ema_rig.plot.synthesis import phase_centre, phase_line

    f = np.linspace(0.0, 3.0, 601)
    h = np.exp(-2j * np.pi * f)  # -360 deg per unit: three whole turns
    c = phase_centre("accelerance")
    fx, ph = phase_line(f, h, c)
    ok = np.isfinite(ph)
    assert np.all((ph[ok] >= c - 180.0) & (ph[ok] < c + 180.0))
    assert_allclose(np.mod(ph[ok] + 360.0 * f + 180.0, 360.0) - 180.0, 0.0, atol=1e-9)
    assert_allclose(fx[ok], f)
    assert np.sum(~ok) == 3 and np.max(np.abs(np.diff(ph))[ok[1:] & ok[:-1]]) < 180.0
