"""The stabilization chart and the pole picker: inspect the returned artists."""

from __future__ import annotations

import numpy as np
import pytest
from lumped import five_mode_system

from ema_rig.identification import Selection, identify

FREQ = np.arange(0.0, 1000.5, 0.5)


@pytest.fixture(scope="module")
def case():
    system = five_mode_system()
    data = system.frf(FREQ, inputs=(0, 1), noise=0.01, rng=np.random.default_rng(4))
    ident = identify(data, band=(100.0, 900.0))
    return data, ident


def test_chart_artists(case, mplcleanup):
    import matplotlib.pyplot as plt

    from ema_rig.plot.stabilization import plot_stabilization

    data, ident = case
    stab = ident.stabilization
    chart = plot_stabilization(stab, data, selection=ident.selection)
    # a new, pyplot-free figure: nothing registered with pyplot, nothing shown
    assert plt.get_fignums() == []
    assert set(chart.poles) == {"o", "f", "d", "v", "s"}
    for letter, line in chart.poles.items():
        rows = chart.rows[letter]
        expected = np.flatnonzero((stab.status == letter) & ~stab.unstable)
        np.testing.assert_array_equal(rows, expected)
        # every point sits at (natural frequency, model order) of its pole
        np.testing.assert_array_equal(line.get_xdata(), stab.natural_freq[rows])
        np.testing.assert_array_equal(line.get_ydata(), stab.order[rows])
        assert line.get_label().endswith(f"({rows.size})")
    # FRF summary on a log twin axis with the SI unit
    assert chart.frf_axes is not None and chart.frf_axes.get_yscale() == "log"
    assert "m/s^2/N" in chart.frf_axes.get_ylabel()
    np.testing.assert_allclose(chart.frf_lines[0].get_ydata(), data.sum_frf(), rtol=1e-12)
    # the band is shaded because the FRF spans more than the band
    x0 = chart.band_patch.get_x()
    np.testing.assert_allclose([x0, x0 + chart.band_patch.get_width()], [100.0, 900.0], rtol=1e-12)
    # one dashed line and one label per selected mode; without the reported frequencies they mark
    # the PolyMAX cluster mean and say so
    assert len(chart.mode_lines) == len(ident.selection) == 6
    np.testing.assert_allclose([ln.get_xdata()[0] for ln in chart.mode_lines], ident.selection.natural_freq)
    assert [t.get_text().strip() for t in chart.mode_labels] == [f"{f:.1f} Hz" for f in ident.selection.natural_freq]
    assert chart.mode_lines[0].get_label() == "selected mode at the PolyMAX cluster (6)"
    assert chart.axes.get_xlabel() == "frequency [Hz]" and chart.axes.get_ylabel() == "model order"


def test_chart_options(case, mplcleanup):
    import matplotlib.pyplot as plt

    from ema_rig.plot.stabilization import plot_stabilization

    data, ident = case
    stab = ident.stabilization
    fig, ax = plt.subplots()
    chart = plot_stabilization(stab, data, ax=ax, indicator="cmif", show_unstable=True, color_scheme="viridis")
    assert chart.axes is ax and chart.figure is fig
    assert chart.rows["u"].size == int(stab.unstable.sum()) > 0
    assert len(chart.frf_lines) == 2  # two references: two singular values
    assert "CMIF" in chart.frf_axes.get_ylabel()
    bare = plot_stabilization(stab, show_new=False)
    assert "o" not in bare.poles and bare.frf_axes is None and bare.band_patch is None
    with pytest.raises(ValueError, match="indicator"):
        plot_stabilization(stab, indicator="peaks")
    with pytest.raises(ValueError, match="color_scheme"):
        plot_stabilization(stab, color_scheme="rainbow")


def _pick(chart, letter, ind):
    from matplotlib.backend_bases import MouseEvent, PickEvent

    line = chart.poles[letter]
    x, y = line.get_xdata()[ind], line.get_ydata()[ind]
    px, py = chart.axes.transData.transform((x, y))
    canvas = chart.figure.canvas
    me = MouseEvent("button_press_event", canvas, px, py, button=1)
    canvas.callbacks.process("pick_event", PickEvent("pick_event", canvas, me, line, ind=[ind]))


def test_picker_builds_a_replayable_selection(case, mplcleanup, tmp_path):
    from ema_rig.plot.picker import PolePicker
    from ema_rig.plot.stabilization import plot_stabilization

    data, ident = case
    chart = plot_stabilization(ident.stabilization, data)
    seen = []
    picker = PolePicker(chart, on_change=seen.append, source="test")
    stab = ident.stabilization
    s_rows = chart.rows["s"]
    near_640 = int(np.argmin(np.abs(stab.natural_freq[s_rows] - 640.0) + 1e-3 * (60 - stab.order[s_rows])))
    _pick(chart, "s", near_640)
    _pick(chart, "o", 0)  # new poles are not pickable
    assert len(picker.picks) == 1 and len(seen) == 1
    sel = picker.selection
    assert sel.modes[0].provenance == "manual"
    row = s_rows[near_640]
    assert sel.modes[0].pole == stab.pole[row]
    assert len(picker.markers) == 1 and len(chart.mode_lines) == 1
    path = tmp_path / "picked.json"
    sel.to_json(path)
    again = identify(data, selection=Selection.from_json(path))
    # the same data, band and order taken from the selection: the hand-picked pole itself
    # goes into LSFD
    assert again.band == (100.0, 900.0)
    assert again.modes.meta["polymax_poles"] == [[stab.pole[row].real, stab.pole[row].imag]]
    # ... and the default ML estimate starts there and stays within 3 standard uncertainties of it
    f_pick = abs(stab.pole[row]) / (2 * np.pi)
    assert abs(again.natural_freq[0] - f_pick) <= 3 * again.natural_freq_std[0]
    # picking it again removes it
    _pick(chart, "s", near_640)
    assert picker.picks == [] and len(chart.mode_lines) == 0
    picker.disconnect()
    _pick(chart, "s", near_640)
    assert picker.picks == []


def test_picker_never_picks_an_unstable_pole(case, mplcleanup):
    # unstable poles (Re lambda >= 0) carry no participation vector (NaN): they cannot be a
    # mode, so the picker ignores them even when told to accept new/unstable letters
    from ema_rig.plot.picker import PolePicker
    from ema_rig.plot.stabilization import plot_stabilization

    data, ident = case
    stab = ident.stabilization
    chart = plot_stabilization(stab, data, show_unstable=True)
    picker = PolePicker(chart, statuses="fdvsou")
    assert chart.rows["u"].size > 0
    _pick(chart, "u", 0)
    assert picker.picks == []
    with pytest.raises(ValueError, match="unstable pole"):
        picker.toggle_row(int(chart.rows["u"][0]))
    assert np.all(np.isnan(stab.participation[stab.unstable]))


def test_mode_labels_never_overlap_and_rejected_are_distinct(case, mplcleanup):
    # two modes 0.005 Hz apart (what a 9-reference roving hammer gave before) and a third
    # close by: every label must stay readable and rejected candidates look different
    from dataclasses import replace

    from ema_rig.plot.stabilization import plot_stabilization

    data, ident = case
    m0 = ident.selection.modes[0]
    crowd = (m0, replace(m0, natural_freq=m0.natural_freq + 0.005), replace(m0, natural_freq=m0.natural_freq + 3.0))
    sel = replace(ident.selection, modes=crowd + ident.selection.modes[1:])
    rejected = [c for c in ident.candidates if not c.accepted and c.mode.n_poles >= 4]
    chart = plot_stabilization(ident.stabilization, data, selection=sel, candidates=ident.candidates,
                               converged=ident.converged)
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(chart.figure)
    canvas.draw()
    renderer = canvas.get_renderer()
    boxes = [t.get_window_extent(renderer) for t in chart.mode_labels]
    assert len(boxes) == len(sel.modes)
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            assert not boxes[i].overlaps(boxes[j]), (chart.mode_labels[i].get_text(), chart.mode_labels[j].get_text())
    # every label inside the axes (none pushed out of sight)
    ax_box = chart.axes.get_window_extent(renderer)
    assert all(ax_box.contains(b.x0, b.y0) and ax_box.contains(b.x1, b.y1) for b in boxes)
    assert len(chart.rejected_lines) == len(rejected)
    for ln in chart.rejected_lines:
        assert ln.get_linestyle() == ":" and ln.get_color() != chart.mode_lines[0].get_color()
    assert "converged" in chart.axes.get_title()


def test_cli_chart_marks_the_reported_modes(monkeypatch, tmp_path, mplcleanup):
    # the reviewer's defect: the chart labelled the PolyMAX cluster (111.9 Hz) while the table and
    # JSON report the final modes (112.0 Hz). Oracle: the API's identify() on the same file.
    from pathlib import Path

    import ema_rig.plot.stabilization as stabilization_module
    from ema_rig.cli import main
    from ema_rig.io.uff import read_uff58

    drawn = []
    real = stabilization_module.plot_stabilization

    def spy(*args, **kwargs):
        drawn.append(real(*args, **kwargs))
        return drawn[-1]

    monkeypatch.setattr(stabilization_module, "plot_stabilization", spy)
    file = Path(__file__).resolve().parents[1] / "data" / "b6302_1000N_1200rpm.uff"
    assert main(["stabilization", str(file), "-o", str(tmp_path / "s.png")]) == 0
    expected = identify(read_uff58(file)).natural_freq
    (chart,) = drawn
    # the same modes to the printed 0.1 Hz, lines within 0.1 % (a replayed ML fit, not bitwise)
    assert [t.get_text() for t in chart.mode_labels] == [f"{f:.1f} Hz" for f in expected]
    np.testing.assert_allclose([ln.get_xdata()[0] for ln in chart.mode_lines], expected, rtol=1e-3)
    assert chart.mode_lines[0].get_label() == f"selected mode ({len(expected)})"
