"""The pole picker holds still (issue 20): driven by synthetic matplotlib mouse and key events (Agg).

The events go through the canvas as a backend would deliver them (``MouseEvent._process`` runs the
figure's hit test and emits ``pick_event``), so what is tested is what a click on the screen does.
"""

from __future__ import annotations

import numpy as np
import pytest
from lumped import five_mode_system

from ema_rig.identification import identify

FREQ = np.arange(0.0, 1000.5, 0.5)


@pytest.fixture(scope="module")
def case():
    system = five_mode_system()
    data = system.frf(FREQ, inputs=(0, 1), noise=0.01, rng=np.random.default_rng(4))
    return data, identify(data, band=(100.0, 900.0))


def _chart(case):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from ema_rig.plot.picker import PolePicker
    from ema_rig.plot.stabilization import plot_stabilization

    data, ident = case
    chart = plot_stabilization(ident.stabilization, data, selection=ident.selection)
    FigureCanvasAgg(chart.figure)
    picker = PolePicker(chart)
    chart.figure.canvas.draw()
    return chart, picker


def _pixel(chart, freq, order):
    return chart.axes.transData.transform((freq, order))


def _click(chart, px, py):
    from matplotlib.backend_bases import MouseEvent

    MouseEvent("button_press_event", chart.figure.canvas, px, py, button=1)._process()


def _key(chart, key):
    from matplotlib.backend_bases import KeyEvent

    KeyEvent("key_press_event", chart.figure.canvas, key, x=10, y=10)._process()


def _stable_pole(chart, near_freq):
    """(freq, order) of the stable pole at the highest order nearest ``near_freq`` [Hz]."""
    line = chart.poles["s"]
    f, o = np.asarray(line.get_xdata()), np.asarray(line.get_ydata())
    k = int(np.argmin(np.abs(f - near_freq) / near_freq + 1e-4 * (o.max() - o)))
    return float(f[k]), float(o[k])


def test_clicks_do_not_move_the_chart_and_a_second_click_unpicks(case, mplcleanup):
    chart, picker = _chart(case)
    limits = (chart.axes.get_xlim(), chart.axes.get_ylim())
    f, o = _stable_pole(chart, 640.0)
    px, py = _pixel(chart, f, o)
    _click(chart, px, py)
    assert len(picker.picks) == 1 and picker.picks[0][0] == int(o)
    # the view is the one the picker fixed: the same pixel shows the same pole (issue: 0-89 -> 0-75.8)
    assert (chart.axes.get_xlim(), chart.axes.get_ylim()) == limits
    # (the layout engine may nudge the axes by a fraction of a pixel; the pick radius is 5 px)
    np.testing.assert_allclose(_pixel(chart, f, o), (px, py), atol=1.0)
    # the label of the picked mode sits in the room kept above the poles, not over them (it was
    # placed for the chart's own top while the picker held a higher one: over the highest orders)
    chart.figure.canvas.draw()
    renderer = chart.figure.canvas.get_renderer()
    n_max = max(case[1].stabilization.orders)
    assert len(chart.mode_labels) == 1
    for t in chart.mode_labels:
        bottom = chart.axes.transData.inverted().transform((0.0, t.get_window_extent(renderer).y0))[1]
        assert bottom > n_max, (bottom, n_max)
    _click(chart, px, py)
    assert picker.picks == [] and picker.markers == []
    assert (chart.axes.get_xlim(), chart.axes.get_ylim()) == limits
    # the chart leaves room above the highest order for the mode labels: no pole under a label row
    assert chart.axes.get_ylim()[1] > 1.5 * max(case[1].stabilization.orders)


def test_undo_and_keyboard(case, mplcleanup):
    chart, picker = _chart(case)
    a, b = _stable_pole(chart, 640.0), _stable_pole(chart, 300.0)
    assert abs(a[0] - b[0]) > 100  # two different modes
    _click(chart, *_pixel(chart, *a))
    _click(chart, *_pixel(chart, *b))
    first, second = picker.picks
    _key(chart, "u")  # undo the second pick
    assert picker.picks == [first]
    assert picker.undo() and picker.picks == []
    assert not picker.undo()  # nothing left to undo
    _click(chart, *_pixel(chart, *a))
    _click(chart, *_pixel(chart, *b))
    _key(chart, "x")  # remove the last pick
    assert picker.picks == [first]
    _key(chart, "escape")  # clear
    assert picker.picks == [] and len(chart.mode_lines) == 0
    _key(chart, "ctrl+z")  # clearing is undoable
    assert picker.picks == [first] and len(chart.mode_lines) == 1
    assert [m.provenance for m in picker.selection.modes] == ["manual"]
    picker.disconnect()
    _key(chart, "escape")
    assert picker.picks == [first]


def test_a_click_on_the_ring_unpicks(case, mplcleanup):
    from matplotlib.backend_bases import MouseEvent, PickEvent

    chart, picker = _chart(case)
    f, o = _stable_pole(chart, 640.0)
    _click(chart, *_pixel(chart, f, o))
    ring = picker.markers[0]
    canvas = chart.figure.canvas
    me = MouseEvent("button_press_event", canvas, *_pixel(chart, f, o), button=1)
    canvas.callbacks.process("pick_event", PickEvent("pick_event", canvas, me, ring, ind=[0]))
    assert picker.picks == []
