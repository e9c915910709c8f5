"""A figure kept per worker and drawn again for the next measurement is the figure drawn anew."""

from __future__ import annotations

import io
import threading
from pathlib import Path

import numpy as np
import pytest
from _campaigns import simulated_6302_campaign

pytest.importorskip("PIL")

from PIL import Image  # noqa: E402

from ema_rig.campaign import load_campaign  # noqa: E402
from ema_rig.campaign.drilldown import measurement_figures  # noqa: E402


def _pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def _in_new_thread(fn):
    """``fn()`` in a thread of its own: its own kept figures and canvases (none yet), as a new worker."""
    out: list = []
    t = threading.Thread(target=lambda: out.append(fn()))
    t.start()
    t.join()
    assert out, "the drawing thread failed"
    return out[0]


def _two_measurements(tmp_path: Path, rig_toml_text: str):
    """Two simulated measurements far apart in k_TB, and a function drawing a measurement's figures."""
    d = simulated_6302_campaign(tmp_path, rig_toml_text, {"a300": 4.0e7, "b900": 9.0e7}, seed=41)
    cfg = load_campaign(d / "campaign.toml")
    row = {"status": "ok"}

    def draw(m):
        return measurement_figures(m, row, cfg, k_ms=cfg.rig.model.k_MS, k_ms_std=None)

    return cfg.measurements, draw


def test_a_reused_figure_draws_what_a_new_one_draws(tmp_path: Path, rig_toml_text: str) -> None:
    # two measurements far apart in k_TB (housing mode, limits, tick labels, titles all differ);
    # oracle: matplotlib drawing the second measurement on figures built for it alone
    (first, second), draw = _two_measurements(tmp_path, rig_toml_text)
    reused = _in_new_thread(lambda: (draw(first), draw(second))[1])  # on the figures of the first
    fresh = _in_new_thread(lambda: draw(second))
    assert set(reused.png) == set(fresh.png) == {"stabilization", "model", "synthesis"}
    assert reused.warnings == fresh.warnings
    for kind in fresh.png:
        a, b = _pixels(reused.png[kind]), _pixels(fresh.png[kind])
        assert a.shape == b.shape, kind
        diff = np.abs(a - b).max(axis=2)
        # the same pixels (measured: identical, all three kinds); 2 levels of 255 leave room for
        # an anti-aliased edge rounded the other way. A leftover of the first measurement (a line,
        # a label, a legend entry, a limit, a tick) or a shifted panel changes hundreds of pixels
        # by far more
        assert (diff > 2).sum() == 0, (kind, int((diff > 2).sum()))
    # and the premise: the two measurements' figures differ
    first_only = _in_new_thread(lambda: draw(first))
    assert any((np.abs(_pixels(first_only.png[k]) - _pixels(fresh.png[k])) > 16).sum() > 1000 for k in fresh.png)


def test_figures_of_a_measurement_drawn_again_after_another_are_the_same_bytes(tmp_path: Path,
                                                                             rig_toml_text: str) -> None:
    # A, B, A in one worker (kept figures, kept lines, kept layouts, replayed axes, glyph caches):
    # nothing of B may be left in A's second drawing. Oracle: A's first drawing, byte for byte
    # (the PNG encoding is deterministic: the same pixels and palette give the same bytes)
    (a, b), draw = _two_measurements(tmp_path, rig_toml_text)
    first, middle, again = _in_new_thread(lambda: (draw(a), draw(b), draw(a)))
    assert set(first.png) == set(again.png) == {"stabilization", "model", "synthesis"}
    for kind in first.png:
        assert first.png[kind] == again.png[kind], kind
        assert middle.png[kind] != first.png[kind], kind  # the premise: B's figures are other pictures


def test_a_kept_line_changed_after_it_was_drawn_is_not_taken_again() -> None:
    # plot_line takes a kept axes' line again only as it was made: one a caller changed afterwards
    # (colour, width, visibility) is dropped and a new one made with the style asked for
    from matplotlib.figure import Figure

    from ema_rig.plot._render import plot_line, reuse_axes

    fig = Figure(figsize=(3, 2))
    assert reuse_axes(fig, "ema_rig.test") is None
    ax = fig.add_subplot()
    (kept,) = plot_line(ax, [0.0, 1.0], [0.0, 1.0], color="k", lw=1.0)
    (changed,) = plot_line(ax, [0.0, 1.0], [1.0, 0.0], color="k", lw=0.5)
    changed.set_color("r")
    assert reuse_axes(fig, "ema_rig.test") == [ax]
    (again,) = plot_line(ax, [0.0, 2.0], [0.0, 3.0], color="k", lw=1.0)
    (other,) = plot_line(ax, [0.0, 2.0], [3.0, 0.0], color="k", lw=0.5)
    assert again is kept and other is not changed
    assert other.get_color() == "k" and list(ax.lines) == [again, other]
    assert np.array_equal(again.get_xdata(), [0.0, 2.0]) and np.array_equal(again.get_ydata(), [0.0, 3.0])
    ax.autoscale_view()
    assert ax.get_ylim()[1] >= 3.0  # the data limits and autoscale took the new data in


#: What a forked worker draws (:func:`_draw_in_worker`): set by the test before the pool forks.
_IN_WORKER: dict = {}


def _draw_in_worker():
    from ema_rig.plot._render import kept_figure

    png = _IN_WORKER["draw"](_IN_WORKER["m"]).png
    marks = {k: getattr(kept_figure(k, tuple(f.get_size_inches())), "_test_mark", None)
             for k, f in _IN_WORKER["figures"].items()}
    return png, marks


def test_a_forked_worker_draws_on_its_parents_figures_what_its_parent_draws(tmp_path: Path,
                                                                          rig_toml_text: str) -> None:
    # a campaign's pool forks after this process drew a measurement: each worker takes the figures
    # over (axes, ticks, layouts built once; on a canvas of its own, its fonts opened anew).
    # Oracle: this process drawing the second measurement on its own figures, byte for byte, while
    # two workers draw it at once (a canvas or font shared across the fork fails or mixes them up).
    # On 23abb6b the workers built their figures anew (no mark): the first assertion fails there
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    from ema_rig.plot._render import _local

    (a, b), draw = _two_measurements(tmp_path, rig_toml_text)
    draw(a)
    figures = dict(_local()["figures"])
    assert set(figures) == {"stabilization", "model", "synthesis"}
    for fig in figures.values():
        fig._test_mark = "parent"
    _IN_WORKER.update(draw=draw, m=b, figures=figures)
    try:
        with ProcessPoolExecutor(2, mp_context=mp.get_context("fork")) as pool:
            futs = [pool.submit(_draw_in_worker) for _ in range(2)]
            here = draw(b)
            drawn = [f.result() for f in futs]
    finally:
        _IN_WORKER.clear()
    for png, marks in drawn:
        assert marks == {k: "parent" for k in figures}  # the parent's figures, taken over
        assert set(png) == set(here.png) == {"stabilization", "model", "synthesis"}
        for kind in here.png:
            assert png[kind] == here.png[kind], kind
