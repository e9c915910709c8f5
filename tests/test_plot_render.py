"""The fast report renderer draws the picture matplotlib's own ``savefig`` draws."""

from __future__ import annotations

import io

import numpy as np
import pytest

pytest.importorskip("PIL")

from PIL import Image  # noqa: E402

from ema_rig.plot._render import collapse_minor_ticks, render_png  # noqa: E402

# the oracle of every comparison here is matplotlib's savefig with its texts at whole pixels, as the
# report renderer places them (conftest.mpl_texts_on_whole_pixels)
pytestmark = pytest.mark.usefixtures("mpl_texts_on_whole_pixels")


def _figure(scale: float = 1.0):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.0, 3.2), layout="constrained")
    axs = fig.subplots(1, 2)
    f = np.linspace(100.0, 1000.0, 2000)
    for k, ax in enumerate(axs):
        ax.semilogy(f, scale * (1.0 + 1e3 / (1.0 + ((f - 300.0 - 300.0 * k) / 5.0) ** 2)), color="k", lw=0.9)
        ax.grid(True, which="both", alpha=0.3)
        ax.set_xlabel("frequency [Hz]")
        ax.set_title(f"panel {k}", loc="left", fontsize=8)
    axs[0].set_ylabel("|H|")
    fig.suptitle("two panels")
    return fig


def _savefig_pixels(fig, dpi: float) -> np.ndarray:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    buf.seek(0)
    return np.asarray(Image.open(buf).convert("RGB")).astype(int)


def _pixels(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def _layout_runs(monkeypatch) -> list:
    """Figures a constrained layout is run for from now on (a reused layout runs none)."""
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    runs: list = []
    orig = ConstrainedLayoutEngine.execute
    monkeypatch.setattr(ConstrainedLayoutEngine, "execute", lambda self, f: runs.append(f) or orig(self, f))
    return runs


def test_render_matches_savefig_and_reuses_the_layout(monkeypatch):
    # oracle: matplotlib's savefig of an identical figure (minor ticks as Tick objects, constrained layout)
    want = _savefig_pixels(_figure(), 64)
    first = _pixels(render_png(_figure(), dpi=64, colors=None))
    fig = _figure()
    engine = fig.get_layout_engine()
    runs = _layout_runs(monkeypatch)
    second = _pixels(render_png(fig, dpi=64, colors=None))
    # the second figure took the kept layout: the layout was not run, and the engine is back afterwards
    assert runs == []
    assert fig.get_layout_engine() is engine
    for got in (first, second):
        assert got.shape == want.shape
        diff = np.abs(got - want).max(axis=2)
        # the minor ticks and gridlines drawn as collections land on the same pixels (measured: at
        # most 3 levels of 255 apart, on 0.08 % of the pixels); a misplaced tick, gridline or
        # panel would differ by far more on far more pixels
        assert (diff > 16).mean() < 1e-3


def test_collapsed_minor_ticks_keep_their_positions():
    fig = _figure()
    ax = fig.axes[0]
    want = ax.yaxis.get_minorticklocs()
    lo, hi = ax.get_ylim()
    want = want[(want >= lo) & (want <= hi)]
    assert collapse_minor_ticks(fig) == 2  # both log y axes; the linear x axes untouched
    grid = [c for c in ax.collections if c.get_segments()]
    ys = np.sort([s[0, 1] for s in grid[0].get_segments()])
    np.testing.assert_allclose(ys, np.sort(want), rtol=1e-12)  # same data positions, one artist


def test_palette_png_is_small_and_close():
    png = render_png(_figure(2.0), dpi=64, colors=64)
    img = Image.open(io.BytesIO(png))
    assert img.mode == "P"  # a palette image, written directly
    assert len(png) < 40_000
    # oracle: the same figure without a palette (251 colours). Measured: at most 3 levels of 255
    # off, on 3.4 % of the pixels (PIL's maximum-coverage palette of 64: 3 levels, on 17 % of
    # them); a pixel given another than its nearest palette colour, or a palette missing the line
    # and text colours, is tens of levels off on many pixels
    want = _pixels(render_png(_figure(2.0), dpi=64, colors=None))
    diff = np.abs(_pixels(png) - want).max(axis=2)
    assert diff.max() <= 4
    assert (diff > 0).mean() < 0.05


def _packed(rgb: np.ndarray) -> np.ndarray:
    return np.ascontiguousarray(np.dstack([rgb, np.full(rgb.shape[:2], 255, np.uint8)])).view("<u4")[..., 0]


def test_palette_of_few_colours_is_exact_and_of_many_the_nearest():
    from ema_rig.plot._render import palette_indices

    rng = np.random.default_rng(7)
    colours = rng.integers(0, 256, (200, 3), dtype=np.uint8)
    img = colours[rng.integers(0, 200, (40, 50))]
    index, palette = palette_indices(_packed(img), 256)
    np.testing.assert_array_equal(palette[index], img)  # no more colours than the palette holds: exact
    # 600 colours into 64: oracle, the definition checked by brute force: palette colours are
    # image colours, the 32 most frequent among them, and every pixel shows its nearest one
    weights = rng.random(600) ** 4
    colours = rng.integers(0, 256, (600, 3), dtype=np.uint8)
    img = colours[rng.choice(600, size=(60, 70), p=weights / weights.sum())]
    index, palette = palette_indices(_packed(img), 64)
    assert len(palette) == 64 and index.max() < 64
    flat = img.reshape(-1, 3)
    uniq, counts = np.unique(flat, axis=0, return_counts=True)
    assert {tuple(c) for c in palette} <= {tuple(c) for c in uniq}
    assert {tuple(c) for c in uniq[counts > np.sort(counts)[-32]]} <= {tuple(c) for c in palette}
    d = ((flat[:, None, :].astype(int) - palette[None, :, :].astype(int)) ** 2).sum(axis=2)
    shown = d[np.arange(flat.shape[0]), index.reshape(-1)]
    np.testing.assert_array_equal(shown, d.min(axis=1))


def test_palette_counts_a_background_given_with_several_alphas_as_one_colour():
    # a figure is mostly its background, the first pixel's colour: counted apart from the other
    # pixels, and pixels of the same RGB with another alpha byte are the same colour. Oracle: the
    # definition by brute force (the 8 most frequent colours are in the palette of 16, every pixel
    # shows its nearest palette colour), on 300 colours where the background covers 80 %
    from ema_rig.plot._render import palette_indices

    rng = np.random.default_rng(11)
    colours = rng.integers(0, 256, (300, 3), dtype=np.uint8)
    img = colours[rng.integers(0, 300, (50, 60))]
    img[rng.random((50, 60)) < 0.8] = (250, 250, 250)
    img[0, 0] = (250, 250, 250)
    packed = _packed(img)
    packed[1::7, ::3] &= 0x00FFFFFF  # alpha 0 on some pixels, whatever their colour
    index, palette = palette_indices(packed, 16)
    flat = img.reshape(-1, 3)
    uniq, counts = np.unique(flat, axis=0, return_counts=True)
    assert {tuple(c) for c in uniq[counts > np.sort(counts)[-8]]} <= {tuple(c) for c in palette}
    assert (250, 250, 250) in {tuple(c) for c in palette}
    d = ((flat[:, None, :].astype(int) - palette[None, :, :].astype(int)) ** 2).sum(axis=2)
    np.testing.assert_array_equal(d[np.arange(flat.shape[0]), index.reshape(-1)], d.min(axis=1))


def test_palette_depends_on_the_image_only():
    # the colour ids a thread keeps (counted across images) are numbered in the order colours
    # are first seen; the palette must not follow that order. Three colours into two: two of
    # them equally frequent, seen first in either order by two fresh threads
    from concurrent.futures import ThreadPoolExecutor

    from ema_rig.plot._render import palette_indices

    a, b, c = (np.array(x, np.uint8) for x in ((200, 10, 10), (10, 10, 200), (255, 255, 255)))
    img = np.stack([a] * 20 + [b] * 20 + [c] * 60).reshape(10, 10, 3)

    def after(first: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        palette_indices(_packed(np.broadcast_to(first, (2, 2, 3)).copy()), 2)
        return palette_indices(_packed(img), 2)

    results = []
    for first in (a, b):
        with ThreadPoolExecutor(1) as pool:
            results.append(pool.submit(after, first).result())
    (i1, p1), (i2, p2) = results
    np.testing.assert_array_equal(p1[i1], p2[i2])



def _text_figure():
    """Little but mathtext: glyph loads are most of its drawing."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.0, 3.0))
    for k in range(30):
        fig.text(0.02 + 0.3 * (k % 3), 0.03 * (k // 3) * 3.2, rf"$10^{{{k}}}\,\zeta_{{{k}}}\omega$ k$_{{TB}}$", fontsize=7)
    return fig


def _render_many(n: int) -> list[bytes]:
    return [render_png(_text_figure(), dpi=64, colors=None) for _ in range(n)]



@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="forked workers need fork()")
def test_forked_workers_draw_what_their_parent_draws():
    # a campaign's --jobs 2 pool forks after this process has drawn: its kept canvas holds the
    # mathtext parses of the log tick labels, and their FreeType fonts read glyphs through file
    # descriptors a fork shares with the children. Used by two processes at once, they read each
    # other's file offsets and FreeType fails ("invalid outline"). Measured with the parent's
    # canvas reused in the children: 6 of 6 runs failed; oracle: the parent's own picture.
    import multiprocessing as mp
    from concurrent.futures import ProcessPoolExecutor

    want = render_png(_text_figure(), dpi=64, colors=None)  # drawn here before the fork
    with ProcessPoolExecutor(2, mp_context=mp.get_context("fork")) as pool:
        futs = [pool.submit(_render_many, 12) for _ in range(2)]
        here = _render_many(12)  # and drawing here while the workers draw
        drawn = [png for f in futs for png in f.result()]
    assert len(drawn) == 24
    for png in drawn + here:
        assert png == want  # the same drawing in another process: the same bytes


def test_threads_draw_what_one_thread_draws():
    # an executor's threads drawing figures of one size at once: with one canvas for both they
    # would draw into one pixel buffer (with one canvas for all threads this test failed 3 of 3 runs);
    # oracle: the same figure drawn alone
    from concurrent.futures import ThreadPoolExecutor

    want = render_png(_figure(), dpi=64, colors=None)
    with ThreadPoolExecutor(2) as pool:
        futs = [pool.submit(lambda: [render_png(_figure(), dpi=64, colors=None) for _ in range(4)]) for _ in range(2)]
        drawn = [png for f in futs for png in f.result()]
    assert len(drawn) == 8
    for png in drawn:
        assert png == want


def _stacked(top: float, *, title: bool):
    """A magnitude panel over a phase panel (labels of the upper x axis hidden), the y range of the
    magnitude set so that a major tick label sits ``top`` decades below its upper end (0: at it)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(5.0, 4.0), layout="constrained")
    ax, pax = fig.subplots(2, 1, sharex=True, height_ratios=[2.0, 1.0])
    f = np.linspace(100.0, 1000.0, 500)
    ax.semilogy(f, 1.0 + 1e3 / (1.0 + ((f - 400.0) / 5.0) ** 2), color="k", lw=0.9)
    ax.set_ylim(0.5, 10.0 ** (3.0 + top))
    pax.plot(f, np.sin(f / 50.0), color="k", lw=0.9)
    if title:
        ax.set_title("magnitude", loc="left", fontsize=8)
    pax.set_xlabel("frequency [Hz]")
    return fig


def _positions_px(fig) -> np.ndarray:
    w, h = fig.bbox.width, fig.bbox.height
    return np.array([a.get_position().bounds for a in fig.axes]) * [w, h, w, h]


def test_a_label_within_what_a_title_covers_keeps_the_layout(monkeypatch):
    # the upper y tick label sits at the top end of the axes (it sticks out by half its height),
    # or well inside: with a title above, the title reaches further up either way, so the layout
    # is the same and is reused; oracle: matplotlib's own constrained layout of that figure
    render_png(_stacked(0.0, title=True), dpi=64, colors=None)
    fig = _stacked(0.45, title=True)
    runs = _layout_runs(monkeypatch)
    render_png(fig, dpi=64, colors=None)
    assert runs == []  # reused
    got = _positions_px(fig)
    fresh = _stacked(0.45, title=True)
    render_png(fresh, dpi=64, colors=None, reuse_layout=False)
    # the layout is solved to a fraction of a pixel; a layout kept for a different one (the label
    # widening the top margin, ~4 px here) would be off by more than a pixel
    np.testing.assert_allclose(got, _positions_px(fresh), atol=0.5)


def test_a_label_sticking_out_where_nothing_covers_it_is_laid_out_again(monkeypatch):
    # without a title the upper label at the top end widens the top margin: not the same layout
    render_png(_stacked(0.45, title=False), dpi=64, colors=None)
    fig = _stacked(0.0, title=False)
    runs = _layout_runs(monkeypatch)
    render_png(fig, dpi=64, colors=None)
    assert runs == [fig]  # laid out in full
    fresh = _stacked(0.45, title=False)
    render_png(fresh, dpi=64, colors=None, reuse_layout=False)
    # and the two layouts do differ (the test's premise): by at least a pixel
    assert np.abs(_positions_px(fig) - _positions_px(fresh)).max() > 1.0


def _texts_figure():
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.0, 3.0), layout="constrained")
    ax = fig.add_subplot()
    ax.plot([0.0, 1.0], [0.0, 2.0], color="k", label="a line")
    ax.set_xlabel("frequency [Hz]")
    ax.set_ylabel("|H| [m/s^2/N]")  # rotated 90 deg
    ax.set_title("$k_{TB+MS}$ = 1.25 MN/m", fontsize=9)  # mathtext
    ax.text(0.3, 1.0, "at 30 deg", rotation=30)
    ax.legend(loc="lower right")
    return fig


def test_texts_drawn_from_kept_glyphs_are_the_pixels_matplotlib_draws():
    # oracle: matplotlib's savefig (each glyph shaped and rendered by FreeType at every draw); the
    # renderer keeps the glyph bitmaps of every text and draws the second figure from them
    want = _savefig_pixels(_texts_figure(), 72)
    for _ in range(2):  # the first draw renders the glyphs, the second takes them all from the cache
        got = _pixels(render_png(_texts_figure(), dpi=72, colors=None))
        assert got.shape == want.shape
        # the same pixels (no log axis here: nothing else is drawn differently); a glyph off by a
        # pixel or drawn at another subpixel offset changes dozens of pixels
        assert np.abs(got - want).max() == 0


def _panels(fig, seed: int, ylim: tuple[float, float] = (-50.0, 50.0)):
    """Two linear panels of one kept-figure kind: the same axes and limits, other data and texts."""
    from matplotlib.ticker import MultipleLocator

    from ema_rig.plot._render import reuse_axes

    axs = reuse_axes(fig, "ema_rig.test_panels") or fig.subplots(2, 1)
    rng = np.random.default_rng(seed)
    f = np.linspace(100.0, 1000.0, 400)
    for ax in axs:
        ax.plot(f, rng.normal(size=f.size).cumsum(), color="k", lw=0.8, label=f"run {seed}")
        ax.set_xlim(100.0, 1000.0)
        ax.set_ylim(*ylim)
        ax.yaxis.set_major_locator(MultipleLocator(20.0))  # no tick at an end of these limits
        ax.grid(True, alpha=0.3)
        ax.set_ylabel("displacement [um]")
        ax.legend(loc="upper right", fontsize=7)
    axs[1].set_xlabel("frequency [Hz]")
    axs[0].set_title(f"measurement {seed}", fontsize=9)
    return fig


def _fresh_panels(seed: int, ylim: tuple[float, float] = (-50.0, 50.0)):
    from matplotlib.figure import Figure

    return _panels(Figure(figsize=(4.0, 6.0), layout="constrained"), seed, ylim)


def test_axes_replayed_from_their_recorded_calls_are_the_pixels_matplotlib_draws(monkeypatch):
    # a kept figure drawn again with the same axes limits draws its axes (ticks, gridlines, tick
    # labels, axis labels) from the calls it made into Agg the first time; oracle: matplotlib's
    # savefig of the same panels built anew, which draws every axis itself
    from matplotlib.axis import Axis
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.0, 6.0), layout="constrained")
    render_png(_panels(fig, 1), dpi=72, colors=None)  # draws and records the axes
    drawn: list = []
    orig = Axis.draw
    monkeypatch.setattr(Axis, "draw", lambda self, r: drawn.append(self) or orig(self, r))
    got = _pixels(render_png(_panels(fig, 2), dpi=72, colors=None))
    assert drawn == []  # every axis came from its recording (the limits, ticks and boxes are the same)
    monkeypatch.setattr(Axis, "draw", orig)
    want = _savefig_pixels(_fresh_panels(2), 72)
    assert got.shape == want.shape
    # the same pixels (linear axes: nothing drawn as a collection); a tick, gridline or label of
    # the recording drawn elsewhere, or one missing, changes dozens of pixels
    assert np.abs(got - want).max() == 0


def test_an_axis_with_other_limits_is_drawn_anew():
    # the premise of the key: other limits, other ticks at other places in the same axes boxes (tick
    # labels as wide: the layout is the same); oracle: savefig of those panels built anew
    from matplotlib.figure import Figure

    fig = Figure(figsize=(4.0, 6.0), layout="constrained")
    render_png(_panels(fig, 1), dpi=72, colors=None)
    got = _pixels(render_png(_panels(fig, 1, ylim=(-54.0, 46.0)), dpi=72, colors=None))
    want = _savefig_pixels(_fresh_panels(1, ylim=(-54.0, 46.0)), 72)
    assert got.shape == want.shape
    assert np.abs(got - want).max() == 0
    old = _savefig_pixels(_fresh_panels(1), 72)
    assert (np.abs(old - want).max(axis=2) > 64).sum() > 100  # the two y axes do differ


def test_an_axis_whose_limits_keep_changing_is_recorded_less_and_draws_the_same(monkeypatch):
    # y limits that follow the data (a log magnitude axis): no recording is ever replayed, so after
    # _VOLATILE misses in a row an axis is recorded at every _VOLATILE-th draw only; the x axes,
    # whose limits stay, are replayed. Oracle for the pixels: savefig of the last panels built anew
    from matplotlib.figure import Figure

    import ema_rig.plot._render as render

    made: list = []
    orig = render._Recorder.__init__

    def counting(self, target):
        made.append(1)
        orig(self, target)

    monkeypatch.setattr(render._Recorder, "__init__", counting)
    fig = Figure(figsize=(4.0, 6.0), layout="constrained")
    for k in range(7):
        got = _pixels(render_png(_panels(fig, 1, ylim=(-50.0 - k, 50.0 - k)), dpi=72, colors=None))
    # 2 x axes recorded at their first draw, then replayed; 2 y axes recorded at draws 1, 2, 3 and 6
    # (recording at every draw: 14)
    assert len(made) == 2 + 2 * 4
    want = _savefig_pixels(_fresh_panels(1, ylim=(-56.0, 44.0)), 72)
    assert got.shape == want.shape
    assert np.abs(got - want).max() == 0


def test_new_texts_drawn_from_kept_glyphs_are_the_pixels_matplotlib_draws(monkeypatch):
    # texts not drawn before (the text cache emptied) whose glyphs were: each glyph's bitmap is
    # taken by font, size, rotation and its position within the pixel; oracle: matplotlib's savefig
    from ema_rig.plot import _render

    want = _savefig_pixels(_texts_figure(), 72)
    render_png(_texts_figure(), dpi=72, colors=None)  # renders every glyph once
    monkeypatch.setattr(_render, "_TEXTS", {})
    glyphs = dict(_render._GLYPHS)
    got = _pixels(render_png(_texts_figure(), dpi=72, colors=None))
    assert set(_render._GLYPHS) == set(glyphs)  # no glyph rendered again: all came from the glyph cache
    assert got.shape == want.shape
    # the same pixels; a glyph taken for another position within its pixel, or placed a pixel
    # off, changes dozens of pixels
    assert np.abs(got - want).max() == 0

def test_texts_drawn_elsewhere_within_their_pixel_render_no_glyph_again(monkeypatch):
    # the log tick labels of a magnitude axis whose limits follow the data land at another place
    # within their pixel at every measurement: drawn at the nearest whole pixel, each is the bitmaps
    # kept when it was drawn before anywhere (on 7b8cca3 every glyph was rendered again at the new
    # subpixel offset). Oracle: matplotlib's savefig with its texts at whole pixels (conftest)
    from matplotlib.figure import Figure

    from ema_rig.plot import _render

    def figure(shift_px: float):
        fig = Figure(figsize=(4.0, 3.0), dpi=72)
        ax = fig.add_axes((0.2, 0.2, 0.7, 0.7))
        ax.semilogy([1.0, 2.0], [1e-3, 1e2], color="k")
        ax.set_ylim(1e-3 * 10 ** (shift_px / 150.0), 1e2)  # every y tick label moves by a fraction of a pixel
        for k, txt in enumerate(("$k_{TB}$ = 1.25 MN/m", "287.0 Hz")):
            ax.text(0.1 + shift_px / 201.6, 0.3 + 0.3 * k, txt, transform=ax.transAxes, rotation=90 * k)
        return fig

    render_png(figure(0.0), dpi=72, colors=None)
    texts, glyphs = set(_render._TEXTS), set(_render._GLYPHS)
    for shift in (0.23, 0.61):
        got = _pixels(render_png(figure(shift), dpi=72, colors=None))
        assert set(_render._TEXTS) == texts and set(_render._GLYPHS) == glyphs  # nothing rendered again
        want = _savefig_pixels(figure(shift), 72)
        assert got.shape == want.shape
        assert np.abs(got - want).max() == 0


def test_fixed_layout_of_an_axis_with_labelled_minor_ticks_is_matplotlibs(monkeypatch):
    """A log axis spanning under a decade labels its minor ticks (wider than the major ones, and
    anywhere along the axis): fixed_layout cannot hold its ends free, so it lays the figure out as it
    is, where matplotlib's constrained layout puts it, and keeps nothing for it.
    Oracle: matplotlib's constrained layout of the same figure."""
    import ema_rig.plot._render as render
    from ema_rig.plot._render import fixed_layout

    monkeypatch.setattr(render, "_FIXED", {})

    def figure():
        from matplotlib.figure import Figure

        fig = Figure(figsize=(5.0, 3.2), layout="constrained", dpi=64)
        ax = fig.subplots()
        f = np.linspace(100.0, 1000.0, 200)
        ax.semilogy(f, 0.5 + 2.5 * (f - 100.0) / 900.0)  # 0.5 .. 3: one decade tick, labelled minor ticks
        ax.set_title("t", loc="left")
        return fig, ax

    fig, ax = figure()
    # premise: a major label to hold at the ends, and labelled minor ticks
    assert any(ax.yaxis.get_major_formatter().format_ticks([1.0]))
    assert any(ax.yaxis.get_minor_formatter().format_ticks(list(ax.yaxis.get_minorticklocs())))
    assert fixed_layout(fig, [ax.yaxis]) is False
    assert render._FIXED == {}
    want, ref = figure()
    want.get_layout_engine().execute(want)
    assert np.allclose(ax.get_position().bounds, ref.get_position().bounds, atol=1e-9)


def test_glyphs_are_merged_only_where_none_overlaps():
    # a text's glyph bitmaps drawn as one: Agg leaves the pixels of zero coverage alone, so glyphs
    # that cover no common pixel draw the same pixels together; overlapping ones (Agg blends twice
    # there) must stay apart. Oracle: the bitmaps painted one by one at their (left, top) by hand
    from ema_rig.plot._render import _merged

    rng = np.random.default_rng(3)
    a = rng.integers(1, 256, (5, 3), dtype=np.uint8)
    b = rng.integers(1, 256, (4, 2), dtype=np.uint8)
    b[0] = 0  # a glyph's bitmap box has empty rows
    apart = ((a, 10, 20), (b, 13, 22))  # b's box starts right of a's, two rows higher

    def paint(glyphs):
        canvas = np.zeros((40, 40), dtype=int)
        for buf, left, top in glyphs:
            canvas[30 - top:30 - top + buf.shape[0], left:left + buf.shape[1]] += buf
        return canvas

    one = _merged(apart)
    assert len(one) == 1
    np.testing.assert_array_equal(paint(one), paint(apart))
    overlapping = ((a, 10, 20), (b, 11, 20))  # b's covered pixels fall on a's
    assert _merged(overlapping) == overlapping


def test_semilogy_helper_draws_what_axes_semilogy_draws():
    # oracle: matplotlib's own Axes.semilogy, called for every curve (it sets the log scale, and the
    # default locators and formatters, each time). The helper skips that only on a y axis that is
    # already log with its default ticking: a linear axis (first curve) and a log axis given fixed
    # ticks must still be set to the default log scale, as Axes.semilogy does (pixels of both, exact)
    from matplotlib.figure import Figure
    from matplotlib.ticker import FixedLocator

    from ema_rig.plot._render import semilogy

    f = np.linspace(100.0, 1000.0, 800)

    def build(draw):
        fig = Figure(figsize=(4.0, 3.0))
        a, b = fig.subplots(1, 2)
        draw(a, f, 1.0 + 1e3 / (1.0 + ((f - 300.0) / 5.0) ** 2), color="k", lw=0.9)
        draw(a, f, 2.0 + 1e2 / (1.0 + ((f - 600.0) / 9.0) ** 2), color="C3", ls="--")
        b.set_yscale("log")
        b.yaxis.set_major_locator(FixedLocator([1.0, 3.0]))  # not the default ticking: semilogy resets it
        draw(b, f, 1.0 + f / 100.0, color="k")
        return _savefig_pixels(fig, 60)

    want = build(lambda ax, *a, **k: ax.semilogy(*a, **k))
    got = build(semilogy)
    assert got.shape == want.shape
    assert np.abs(got - want).max() == 0


def test_minor_locations_of_a_replay_key_are_matplotlibs():
    # oracle: Axis.get_minorticklocs; the shortcut for a NullLocator must give the same (empty,
    # float) array, and any other locator its own locations
    from matplotlib.figure import Figure
    from matplotlib.ticker import NullLocator

    from ema_rig.plot._render import _minor_locs

    fig = Figure(figsize=(4.0, 3.0))
    ax = fig.add_subplot()
    ax.semilogy([1.0, 10.0], [1.0, 1e4])
    ax.xaxis.set_minor_locator(NullLocator())
    for axis in (ax.xaxis, ax.yaxis):
        want = np.asarray(axis.get_minorticklocs(), dtype=float)
        got = _minor_locs(axis)
        assert got.dtype == want.dtype and got.tobytes() == want.tobytes()
    assert _minor_locs(ax.yaxis).size > 10  # a log axis over four decades has its minor ticks


def test_an_axis_whose_limits_keep_changing_works_out_its_key_only_when_it_records(monkeypatch):
    # between its recordings (_VOLATILE misses in a row, then every _VOLATILE-th draw) such an axis is
    # drawn by matplotlib without its replay key being worked out; the x axes, replayed, need theirs
    # at every draw. Oracle for the pixels: savefig of the last panels built anew
    from matplotlib.figure import Figure

    import ema_rig.plot._render as render

    keys: list = []
    orig = render._replay_key
    monkeypatch.setattr(render, "_replay_key", lambda r, axis: keys.append(axis.axis_name) or orig(r, axis))
    fig = Figure(figsize=(4.0, 6.0), layout="constrained")
    for k in range(7):
        got = _pixels(render_png(_panels(fig, 1, ylim=(-50.0 - k, 50.0 - k)), dpi=72, colors=None))
    # x: 2 axes x 7 draws; y: 2 axes at draws 1, 2, 3 and 6 (at every draw: 2 x 7)
    assert keys.count("x") == 2 * 7
    assert keys.count("y") == 2 * 4
    want = _savefig_pixels(_fresh_panels(1, ylim=(-56.0, 44.0)), 72)
    assert np.abs(got - want).max() == 0


def test_warm_up_leaves_the_one_time_work_done_for_forked_workers() -> None:
    # in a fresh interpreter: before warm_up no Agg backend and no mathtext grammar (the premise);
    # after it both, so a worker forked then inherits them instead of building them again
    import subprocess
    import sys

    code = (
        "import sys\n"
        "from ema_rig.plot._render import warm_up\n"
        "from matplotlib.mathtext import MathTextParser\n"
        "before = ('matplotlib.backends.backend_agg' in sys.modules, MathTextParser._parser is not None)\n"
        "warm_up(80)\n"
        "after = ('matplotlib.backends.backend_agg' in sys.modules, MathTextParser._parser is not None)\n"
        "print(before, after)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split("\n")[0] == "(False, False) (True, True)", out.stdout + out.stderr


def test_png_level_changes_the_bytes_never_the_pixels():
    # oracle: zlib is lossless; the decoded PNG at any level is the image the figure draws. Level 0
    # (stored) must come out larger than the default level, else the level never reached the encoder
    from ema_rig.plot._render import PNG_LEVEL

    stored = render_png(_figure(), dpi=64, colors=64, optimize=False, compress_level=0)
    packed = render_png(_figure(), dpi=64, colors=64, optimize=False)
    best = render_png(_figure(), dpi=64, colors=64, optimize=True)
    assert 0 < PNG_LEVEL <= 9
    assert len(stored) > 2 * len(packed)
    assert np.array_equal(_pixels(stored), _pixels(packed))
    assert np.array_equal(_pixels(best), _pixels(packed))


def test_a_figure_not_kept_works_each_axis_ticks_out_once_per_draw(monkeypatch):
    # matplotlib's Axis.draw updates its ticks, draws them, then updates them again to place the
    # axis label, and Axes.draw does it once more for an axes with a title (its y axis' tight box);
    # drawn by render_png, a figure that is not kept per worker (the campaign figures) updates the
    # ticks of each axis once per draw (measured without the memo: 10 updates for these 4 axes),
    # and draws savefig's pixels
    from matplotlib.axis import Axis

    fig = _figure()
    fig.set_layout_engine("none")  # no layout: only the draw updates ticks
    want = _savefig_pixels(fig, 64)
    calls: list = []
    orig = Axis._update_ticks
    monkeypatch.setattr(Axis, "_update_ticks", lambda self: calls.append(self) or orig(self))
    got = _pixels(render_png(fig, dpi=64, colors=None))
    diff = np.abs(got - want).max(axis=2)
    # as in test_render_matches_savefig_and_reuses_the_layout: the collapsed minor ticks are at
    # most 3 levels of 255 off on a few pixels (measured 3, on 51 of 65280 with or without the
    # tick memo); ticks or labels of another draw would be off by far more
    assert diff.max() <= 4 and (diff > 0).mean() < 1e-3
    drawn = [a for ax in fig.axes for a in (ax.xaxis, ax.yaxis) if a.get_visible()]
    assert sorted(map(id, calls)) == sorted(map(id, drawn))


_LAYOUT_VARIANTS = [{}, {"rotation": 30}, {"rotation": 30, "rotation_mode": "anchor"}, {"ha": "right"},
                    {"va": "top"}, {"va": "baseline", "ha": "center"}, {"fontsize": 13}, {"weight": "bold"},
                    {"family": "monospace"}, {"linespacing": 2.0}, {"multialignment": "right"},
                    {"parse_math": False, "ha": "right"}]


def _one_text(**kw):
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.0, 2.0))
    fig.text(0.6, 0.5, "$k_{TB+MS}$ = 1.25 MN/m\nwide", **kw)  # one string: only its properties differ
    return fig


def test_kept_text_layouts_are_matplotlibs_for_every_property_they_depend_on(monkeypatch):
    # oracle: matplotlib's savefig, which lays every text out anew. The same string drawn with one
    # property changed at a time after the plain one: a layout kept under a key that missed the
    # property would put the text elsewhere or break it otherwise (tens of pixels off)
    from matplotlib.text import Text

    for kw in _LAYOUT_VARIANTS:
        want = _savefig_pixels(_one_text(**kw), 72)
        got = _pixels(render_png(_one_text(**kw), dpi=72, colors=None))
        assert np.abs(got - want).max() == 0, kw  # no log axis: nothing is drawn otherwise
    # and they are kept: drawn again, no text is laid out anew
    own = Text._get_layout
    laid: list = []

    def counted(self, renderer):
        laid.append(self)
        return own(self, renderer)

    monkeypatch.setattr(Text, "_get_layout", counted)
    for kw in _LAYOUT_VARIANTS:
        render_png(_one_text(**kw), dpi=72, colors=None)
    assert laid == []
    assert Text.__dict__["_get_layout"] is counted  # the class' own method back after the renders


def _squeezed(seed_text: str = "a title\nof three\nlines"):
    """A small panel that a constrained layout shrinks a lot (titles, labels): its y axis takes
    fewer ticks after the first pass than before it (a locator takes as many as there is room for)."""
    from matplotlib.figure import Figure

    fig = Figure(figsize=(3.0, 4.0), layout="constrained")
    axs = fig.subplots(2, 1)
    for ax in axs:
        # room for 7 ticks (-0.25 ... 1.25, 4 digits wide) before the layout, for 4 after it (-1 ... 2)
        ax.plot([0.0, 1.0], [0.0, 1.05])
        ax.set_title(seed_text, fontsize=11)
        ax.set_xlabel("frequency\n[Hz]")
        ax.set_ylabel("|H|")
    fig.suptitle("suptitle\nsecond line")
    return fig


def test_a_layout_with_ticks_worked_out_once_per_pass_places_the_axes_as_matplotlib(monkeypatch):
    # oracle: matplotlib's own constrained layout of an identical figure. The layout run by
    # render_png works each axis' ticks out once per layout pass, keyed by the view limits and the
    # axes' box: each pass changes the box, and with it how many ticks there are room for (7
    # labels 4 digits wide before the layout, 4 of 1 digit after it here), so ticks kept from a
    # pass before would place the axes elsewhere
    from matplotlib.axis import Axis
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    want = _squeezed()
    want.draw_without_rendering()
    fig = _squeezed()
    render_png(fig, dpi=100, colors=None, reuse_layout=False)
    for a, b in zip(want.axes, fig.axes, strict=True):
        assert np.allclose(a.get_position().bounds, b.get_position().bounds, atol=1e-12, rtol=0.0)
    # tick updates within the layout: matplotlib's own against render_png's
    calls: list = []
    orig_update = Axis._update_ticks
    monkeypatch.setattr(Axis, "_update_ticks", lambda self: calls.append(self) or orig_update(self))
    counts: list = []
    orig_execute = ConstrainedLayoutEngine.execute

    def counted(self, f):
        calls.clear()
        orig_execute(self, f)
        counts.append(len(calls))

    monkeypatch.setattr(ConstrainedLayoutEngine, "execute", counted)
    _squeezed().draw_without_rendering()
    render_png(_squeezed(), dpi=100, colors=None, reuse_layout=False)
    mpl_own, memo = counts
    assert memo <= mpl_own // 4  # measured: 8 updates (4 axes, 2 passes) against 52


def test_legend_boxes_worked_out_once_per_draw_are_the_pixels_matplotlib_draws():
    # a legend of two columns with a title, lines, markers and a patch, in a figure drawn by Agg:
    # oracle matplotlib's own draw of the same figure on a plain Agg canvas (same size, dpi)
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    from ema_rig.plot._render import _legend_boxes_once

    def figure(label: str):
        fig = Figure(figsize=(4.0, 3.0), dpi=80)
        ax = fig.add_subplot()
        ax.plot([0, 1], [0, 1], color="k", lw=1.0, label="measured")
        ax.plot([0, 1], [1, 0], ls="none", marker="o", color="C3", label=label)
        ax.axvspan(0.2, 0.4, alpha=0.3, label="band")
        ax.legend(ncols=2, title="legend title", loc="upper center", fontsize=8, framealpha=0.9)
        return fig

    def pixels(fig, once: bool) -> np.ndarray:
        canvas = FigureCanvasAgg(fig)
        if once:
            with _legend_boxes_once(fig):
                canvas.draw()
        else:
            canvas.draw()
        return np.asarray(canvas.buffer_rgba()).copy()

    fig = figure("poles (12)")
    assert np.array_equal(pixels(fig, True), pixels(figure("poles (12)"), False))
    # nothing kept past the draw: a legend entry made longer is measured again
    fig.axes[0].get_legend().get_texts()[1].set_text("poles of a much longer label (1234)")
    wider = figure("poles of a much longer label (1234)")
    assert np.array_equal(pixels(fig, True), pixels(wider, False))
    box = fig.axes[0].get_legend()._legend_box
    assert "get_bbox" not in box.__dict__ and "_get_bbox_and_child_offsets" not in box.__dict__
