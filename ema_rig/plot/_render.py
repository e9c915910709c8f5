"""Render a finished figure to a compact PNG with less work for the same picture.

Functions
---------
render_png
    A figure as palette PNG bytes: drawn once by Agg, quantized from the pixel buffer (no PNG
    written and read back), the minor ticks of log axes drawn as one artist per kind.
palette_indices
    An image as indices into a palette of its own colours: its most frequent, then the farthest.
kept_figure, reuse_axes
    One figure per kind per worker thread, its axes and tick objects kept from one measurement
    to the next: only the data, limits and texts are drawn anew.
warm_up
    A process' one-time figure work (matplotlib's modules, the mathtext grammar, font lookups)
    done before it forks a pool, so that every worker inherits it instead of doing it again.
fixed_layout
    A constrained layout that keeps the room for the outermost tick labels of chosen axes (log
    magnitudes), so that where those land does not change it: computed once per key and process,
    the figure's layout engine then switched off.

Notes
-----
Most of the time matplotlib spends on a small report figure goes to the minor ticks of its log
axes: every minor tick is a ``Tick`` object (two marker lines, a gridline and two labels, each
transformed and drawn on its own), eight per decade per log axis, and a constrained layout walks
them twice more to measure their (empty) labels. Once a figure is finished (limits and styles no
longer change), :func:`collapse_minor_ticks` replaces the unlabelled minor ticks of each log axis by
one marker line per tick side and one line collection for the gridlines, with the style of the
axis' own minor tick (size, width, colour, direction, grid colour, width, style and alpha) at the
positions the axis would draw (``get_minorticklocs`` inside the view interval). The picture is the
same; minor ticks that carry labels (a log axis spanning about a decade or less) are left alone.

A constrained layout measures every tick label, title and legend twice per save. Report figures of
one kind differ only in their data, so :func:`render_png` keeps, per process, the axes positions a
constrained layout gave, keyed by everything the layout reads: figure size and dpi, the texts the
layout measures with their digits folded to ``0`` (digits are equally wide in the default font),
the tick labels each axis will draw and, to the pixel, how far the outermost labels sit from the
axis ends (a label at an end sticks out of the axes), the legends and titles (line counts, and
whether they fit their axes). A figure with the same key gets the same positions without the
layout being run again; any other figure is laid out in full and its positions kept for the next.
How close a y tick label sits to an end of its axis is left out of the key where something the
layout measures anyway reaches further beyond that end (a title above, x tick labels below): the
label there cannot move the layout. A title narrower than its axes (centre, left or right) is
keyed by its line count only. Reused positions are within 0.5 px of a fresh layout of the same
figure (bundled demo: at most 0.41 px over 36 reused figures). The layout runs before the minor
ticks are collapsed: a log axis' locator asks the axis how much room it has, so the ticks are
those of the axes as drawn (collapsed at the size before the layout, the synthesis and rig-model
figures lost the minor gridlines matplotlib's own ``savefig`` draws).

Building the axes of a report figure (``add_subplot``, twins, shared axes) and the tick objects
its first draw makes cost as much as drawing it. :func:`kept_figure` keeps one figure per kind
in each worker thread; the plot functions given it (``figure=``) take its axes back emptied by
:func:`reuse_axes` and draw only the new measurement's artists, limits and texts. A reused
figure draws the same pixels as a new one (``tests/test_plot_reuse.py``: identical for two
simulated measurements drawn in sequence).

Most texts of a figure come again figure after figure (tick labels, axis labels, legends), and
matplotlib shapes each and renders its glyphs with FreeType at every draw: the canvases here draw
every text with its origin at the nearest whole pixel (as matplotlib's Agg renderer did up to
3.10; a text moves by at most half a pixel), keep the glyph bitmaps of every text
(:func:`_text_cached`) and blend them again wherever the text comes again, the pixels
matplotlib draws for the text at that whole pixel. A text not drawn before is mostly glyphs drawn
before: each glyph's bitmap is kept by font, size, rotation and its position within the pixel
(1/64 px, as FreeType takes it), and each text's shaping by its string and font. The palette is the figure's own colours, the most frequent
and then those farthest from the chosen ones (:func:`palette_indices`): exact where a figure has
few colours, within a few levels of 255 elsewhere, in a third to a half of the time of PIL's
adaptive palettes.

An axis of a kept figure (ticks, gridlines, tick labels, its label) is mostly drawn as it was for
the previous measurement (a campaign's band is the same for all its measurements): its calls into
Agg's C renderer are recorded and made again when nothing the axis' drawing reads changed
(:func:`_axes_replayed`), the same pixels without matplotlib's few hundred Python calls per tick.
The axes of figures not kept (the campaign figures) work their ticks and tick label boxes out
once per draw instead of three to five times (label and title placement measure them again).

A text's layout (its lines measured, its box rotated and aligned) does not depend on where it is
drawn, and matplotlib makes it anew at each draw and each measure of the text: during a render
the layouts are kept per renderer under everything they read (:func:`_layouts_kept`): 200 per
measurement's three figures, 18 of them new (bundled demo). An axis' tick locations are worked out once
per state over a fixed layout and over a render (:func:`_locs_once`): the layout keys, the
minor-tick collapse, the replay keys and matplotlib's tick update ask for them in turn. The PNG data is zlib's level 3
(:data:`PNG_LEVEL`): lossless as any level, half the encoding time of level 6.
"""

from __future__ import annotations

import contextlib
import copy
import gc
import io
import math
import os
import threading
from collections.abc import Iterator
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.axis import Axis
    from matplotlib.figure import Figure

__all__ = ["PNG_LEVEL", "collapse_minor_ticks", "fixed_layout", "gc_paused", "kept_figure", "palette_indices", "plot_line",
           "render_png", "reuse_axes", "semilogy", "warm_up"]

#: zlib level of :func:`render_png`'s PNG data. Level 3 against zlib's default 6, the bundled demo's 63
#: figures encoded at each (``benchmarks/results/demo.txt``, 2026-12-07 x_fig8): 57 palette figures 145
#: against 305 ms CPU for 2.87 against 2.50 MB (+15 %), 6 campaign figures (RGB) 49 against 69 ms for
#: 267 against 255 kB; levels 1-2 saved only 20 ms more for +23-29 % bytes.
PNG_LEVEL = 3
#: Layouts kept per process (structure -> [(key, positions)]), newest last; a few per figure kind.
_LAYOUTS: dict[Any, list[tuple[Any, Any]]] = {}
_MAX_LAYOUTS = 8
#: One Agg canvas per figure size [px] and dpi, reused for every figure of that size, and one
#: figure per kind (:func:`kept_figure`), in the thread of the process that made them only (see
#: :func:`_canvas`): ``canvases``, ``figures`` and ``pid``.
_LOCAL = threading.local()


def render_png(fig: Figure, *, dpi: float, colors: int | None = 128, optimize: bool = True,
               reuse_layout: bool = True, compress_level: int = PNG_LEVEL) -> bytes:
    """Draw ``fig`` once and return it as PNG bytes.

    Parameters
    ----------
    fig : Figure
        A finished figure (it is modified: minor ticks collapsed, an Agg canvas attached).
    dpi : float
        Pixel density [dots per inch].
    colors : int or None, optional
        Palette size, at most 256 (default 128; :func:`palette_indices`); None keeps full RGB.
    optimize : bool, optional
        Let the PNG encoder search for the smallest encoding (default True).
    reuse_layout : bool, optional
        Take the positions of an earlier constrained layout with the same key (module notes)
        instead of laying the figure out again (default True).
    compress_level : int, optional
        zlib level 0-9 of the PNG data when not ``optimize`` (default :data:`PNG_LEVEL`); lossless
        at every level: the same pixels, only the bytes and the time to make them differ.

    Returns
    -------
    bytes
        The PNG image, the same pixels ``fig.savefig(format="png", dpi=dpi)`` gives (before the
        palette).
    """
    with gc_paused():
        return _render_png(fig, dpi=dpi, colors=colors, optimize=optimize, reuse_layout=reuse_layout,
                           compress_level=compress_level)


@contextlib.contextmanager
def gc_paused() -> Iterator[None]:
    """Python's cyclic garbage collector held off for the block (as it was before, afterwards).

    Drawing a report figure allocates tens of thousands of short-lived objects (transforms, paths,
    text layouts) beside the long-lived ones of the kept figures, canvases and caches, and the
    collector's passes, set off by the allocation count alone, walk those again and again: held off
    while drawing, the figures of a measurement took 2-7 % less CPU (bundled demo,
    ``benchmarks/profile_figures.py``, paired). The objects a draw leaves behind are collected at
    the collector's next pass after the block; nothing drawn depends on it. The collector is one
    per process: the thread that turned it off turns it on again when it is done, another thread
    may still be drawing then (only slower for it, nothing else).
    """
    enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if enabled:
            gc.enable()


def _render_png(fig: Figure, *, dpi: float, colors: int | None, optimize: bool, reuse_layout: bool,
                compress_level: int) -> bytes:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from PIL import Image  # a matplotlib dependency

    fig.set_dpi(dpi)
    canvas = _canvas(fig, float(dpi), FigureCanvasAgg)
    with _layouts_kept(canvas.get_renderer()), _locs_once(fig):
        _draw(fig, canvas, reuse_layout)
    w, h = canvas.get_width_height()
    rgba = canvas.buffer_rgba()
    if colors is None:
        img = Image.frombuffer("RGBA", (w, h), rgba, "raw", "RGBA", 0, 1).convert("RGB")
    else:
        index, palette = palette_indices(np.frombuffer(rgba, dtype="<u4").reshape(h, w), colors)
        img = Image.frombuffer("P", (w, h), index, "raw", "P", 0, 1)
        img.putpalette(palette.tobytes())
    out = io.BytesIO()
    if optimize:
        img.save(out, format="PNG", optimize=True)
    else:
        img.save(out, format="PNG", compress_level=compress_level)
    return out.getvalue()


def _draw(fig: Figure, canvas: Any, reuse_layout: bool) -> None:
    """Lay ``fig`` out (or take a kept layout) and draw it on ``canvas`` (:func:`render_png`)."""
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    for ax in fig.axes:  # the kept lines not taken again (:func:`plot_line`): the figure is finished
        ax.__dict__.pop("_ema_rig_spare", None)
    engine = fig.get_layout_engine()
    constrained = isinstance(engine, ConstrainedLayoutEngine)
    reused = constrained and reuse_layout and _reuse_layout(fig)
    if constrained:
        assert engine is not None
        if not reused:
            off = _minor_off(fig)  # nothing the layout measures
            with _figure_ticks_once(fig):
                engine.execute(fig)  # what the draw would do first
            _minor_on(off)
        fig.set_layout_engine("none")
    # the minor ticks where the axes are drawn: a log axis' locator asks how much room it has
    collapse_minor_ticks(fig)
    with _axes_replayed(fig), _legend_boxes_once(fig):
        canvas.draw()
    if constrained:
        fig.set_layout_engine(engine)  # switched off for this draw only: laid out again if drawn again
        if reuse_layout and not reused:
            _keep_layout(fig)


# ----------------------------------------------------------------------------- text layouts
#: Text layouts kept per renderer at most (:func:`_layouts_kept`); all dropped when full.
_MAX_TEXT_LAYOUTS = 4096
#: rcParams a text's layout reads besides its own properties: how its font is found and hinted,
#: and how mathtext sets it (part of every kept layout's key).
_TEXT_RC = ("font.family", "font.sans-serif", "font.serif", "font.monospace", "font.cursive", "font.fantasy",
            "text.hinting", "text.hinting_factor", "text.kerning_factor", "text.parse_math", "mathtext.fontset",
            "mathtext.default", "mathtext.fallback", "mathtext.rm", "mathtext.it", "mathtext.bf", "mathtext.bfit",
            "mathtext.sf", "mathtext.tt", "mathtext.cal")
#: Text layouts kept (:func:`_layouts_kept`) per matplotlib renderer class and :data:`_TEXT_RC` values: plain
#: numbers (boxes, line extents), the same for every renderer of a class at a dpi (part of each key),
#: so kept for the process and inherited by the workers it forks.
_TEXT_LAYOUTS: dict[Any, dict[Any, Any]] = {}
#: Renders in progress in this process that keep text layouts (:func:`_layouts_kept`), and
#: matplotlib's own ``Text._get_layout`` while they do.
_KEEPING: dict[str, Any] = {"n": 0, "own": None}
_KEEPING_LOCK = threading.Lock()


@contextlib.contextmanager
def _layouts_kept(renderer: Any) -> Iterator[None]:
    """Texts drawn on ``renderer`` within the block take their layout from one kept before.

    matplotlib lays a text out (``Text._get_layout``: its lines measured, its box rotated and
    aligned) at each draw and again at each measure of its box (tick label boxes, legends, the
    layout): the font found by its properties and its height read from the font's tables each
    time, the text's size from a cache behind a copy of its font properties. A report figure
    draws some 70 texts, most of them measurement after measurement the same strings (tick
    labels, axis labels, legend entries): 200 layouts per measurement's three figures, 18 of
    them new (bundled demo). The layout does not depend on where the text is (the position is
    added afterwards): it is kept per renderer class for the process (:data:`_TEXT_LAYOUTS`: an Agg
    renderer's text metrics depend on the fonts and the dpi, nothing else of it), keyed by what it
    reads (:func:`_text_layout_key`: the string, font properties, line spacing, alignments,
    rotation and its mode, dpi, whether math is parsed, and the rcParams of fonts and mathtext),
    and handed out as a copy; wrapped and TeX texts are laid out by matplotlib. The same numbers,
    so the same pixels (``tests/test_plot_render.py``).

    matplotlib's method is replaced on the ``Text`` class while any render keeps layouts (a count
    under a lock, for renders in several threads), and only texts drawn on a renderer given here
    use the kept ones: any other draws as matplotlib does.
    """
    from matplotlib import rcParams
    from matplotlib.text import Text

    params: Any = rcParams  # typed by literal keys only
    rc = tuple(repr(params[k]) for k in _TEXT_RC)
    # by matplotlib's renderer class (the canvases here subclass it per canvas, drawing only)
    measures = next((c for c in type(renderer).__mro__ if c.__module__.startswith("matplotlib.")), type(renderer))
    store = _TEXT_LAYOUTS.setdefault((measures, rc), {})
    before = renderer.__dict__.get("_ema_rig_layouts")
    renderer._ema_rig_layouts = store
    with _KEEPING_LOCK:
        if _KEEPING["n"] == 0:
            own = Text.__dict__["_get_layout"]
            _KEEPING["own"] = own
            setattr(Text, "_get_layout", _kept_layout(own))  # noqa: B010 (private: untyped)
        _KEEPING["n"] += 1
    try:
        yield
    finally:
        with _KEEPING_LOCK:
            _KEEPING["n"] -= 1
            if _KEEPING["n"] == 0:
                setattr(Text, "_get_layout", _KEEPING["own"])  # noqa: B010
                _KEEPING["own"] = None
        if before is None:
            del renderer._ema_rig_layouts
        else:
            renderer._ema_rig_layouts = before


def _kept_layout(own: Any) -> Any:
    """``Text._get_layout`` (``own``) answered from the renderer's kept layouts (:func:`_layouts_kept`)."""
    def get_layout(text: Any, renderer: Any) -> Any:
        store: dict[Any, Any] | None = getattr(renderer, "_ema_rig_layouts", None)
        key = None if store is None else _text_layout_key(text, renderer)
        if store is None or key is None:
            return own(text, renderer)
        kept = store.get(key)
        if kept is None:
            kept = own(text, renderer)
            if len(store) >= _MAX_TEXT_LAYOUTS:
                store.clear()
            store[key] = kept
        bbox, lines, corner = kept
        return bbox.frozen(), list(lines), corner  # a Bbox is mutable: each caller its own

    return get_layout


def _text_layout_key(text: Any, renderer: Any) -> Any:
    """Everything ``Text._get_layout`` reads of ``text`` but the rcParams; None: lay it out anew."""
    if text.get_wrap() or text.get_usetex():
        return None
    fig = text.get_figure(root=True)
    if fig is None:
        return None
    return (text.get_text(), _font_key(text.get_fontproperties()), text._linespacing, text._get_multialignment(),
            float(text.get_rotation()), text.get_rotation_mode(), text._horizontalalignment,
            text._verticalalignment, float(fig.dpi), float(renderer.dpi), bool(text.get_parse_math()))


#: Colour ids of this thread (:func:`_colour_ids`): a table from 24-bit colour to id (0: none yet), lazily
#: zero pages until written, and the colours by id; renumbered from scratch when the ids run out.
_MAX_COLOUR_IDS = 0xFFFF


def palette_indices(packed: np.ndarray, colors: int) -> tuple[np.ndarray, np.ndarray]:
    """An image as indices into a palette of at most ``colors`` of its own colours.

    Every colour of the image is in the palette when it has no more than ``colors``: the image
    is then exact. Otherwise the palette holds its ``colors // 2`` most frequent colours (the
    background, the lines, the texts: what covers areas) and then, one at a time, the colour
    farthest from every colour chosen so far (the farthest-point heuristic of Gonzalez 1985 for
    the least largest error), and every pixel takes its nearest palette colour (Euclidean in RGB). A report figure has a few
    hundred to a few thousand colours, mostly the antialiasing blends of a few: the largest
    error on the bundled demo's figures is 2-12 levels of 255 on 0.2-3 % of the pixels, where an
    adaptive palette of 128 (maximum coverage) moves up to 14 levels on 4-60 % of them.

    The result depends on the image alone (ties go to the lower 24-bit colour value), not on
    what this thread drew before: the colour ids that make counting fast (:func:`_colour_ids`)
    are never compared.

    Parameters
    ----------
    packed : ndarray of uint32, shape (h, w)
        Pixels as little-endian RGBA words (an Agg buffer read as ``"<u4"``); alpha is ignored.
    colors : int
        Palette size, 1 to 256.

    Returns
    -------
    index : ndarray of uint8, shape (h, w)
        Palette index of every pixel.
    palette : ndarray of uint8, shape (m, 3)
        RGB of the palette entries, m <= ``colors``.
    """
    if not 1 <= colors <= 256:
        raise ValueError(f"colors must be 1 to 256, got {colors}")
    flat = packed.reshape(-1)
    # most of a figure is its background (the first pixel's colour): counted as one number, the
    # look-ups and counts below walk the other pixels only, and the background's index is filled in
    background = flat[:1]
    other = flat != background
    n_other = int(np.count_nonzero(other))
    # the other pixels' colours, then the background's (once)
    rgb24 = np.bitwise_and(np.concatenate([flat[other], background]), 0xFFFFFF)
    ids, colours = _colour_ids(rgb24)
    counts = np.bincount(ids, minlength=colours.size)
    counts[ids[-1]] += flat.size - n_other - 1
    present = np.flatnonzero(counts)
    # in order of the colour value: nothing below depends on the ids' order
    present = present[np.argsort(colours[present], kind="stable")]
    value = colours[present]
    # whole numbers below 256 in float32: every difference, square and sum of three is exact
    rgb = np.stack([value & 0xFF, (value >> 8) & 0xFF, value >> 16], axis=1).astype(np.float32)
    if present.size <= colors:
        nearest = np.arange(present.size)
        chosen = nearest
    else:
        # most frequent first, ties to the lower colour value (stable sort of value-ordered colours)
        chosen = np.argsort(-counts[present], kind="stable")[: colors // 2]
        nearest, d = _nearest(rgb, rgb[chosen])
        r, g, b = (np.ascontiguousarray(rgb[:, i]) for i in range(3))
        t1, t2 = np.empty_like(d), np.empty_like(d)
        closer = np.empty(d.shape, dtype=bool)
        extra = []
        for j in range(chosen.size, colors):
            k = int(np.argmax(d))  # the first of equal distances: the lower colour value
            if d[k] == 0.0:
                break
            extra.append(k)
            np.subtract(r, r[k], out=t1)
            np.multiply(t1, t1, out=t1)
            np.subtract(g, g[k], out=t2)
            np.multiply(t2, t2, out=t2)
            np.add(t1, t2, out=t1)
            np.subtract(b, b[k], out=t2)
            np.multiply(t2, t2, out=t2)
            np.add(t1, t2, out=t1)
            np.less(t1, d, out=closer)  # strictly: of equal distances the earlier palette colour
            nearest[closer] = j
            np.minimum(d, t1, out=d)
        chosen = np.concatenate([chosen, np.asarray(extra, dtype=np.intp)])
    table = np.zeros(colours.size, dtype=np.uint8)
    table[present] = nearest
    index = np.full(flat.size, table[ids[-1]], dtype=np.uint8)
    index[other] = table[ids[:-1]]
    return index.reshape(packed.shape), rgb[chosen].astype(np.uint8)


def _nearest(x: np.ndarray, centres: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Index of the nearest of ``centres`` (m, 3) for every row of ``x`` (n, 3), the first of equal
    ones, and its squared distance (float32 of whole numbers below 256: exact)."""
    index = np.empty(x.shape[0], dtype=np.intp)
    dist = np.empty(x.shape[0], dtype=np.float32)
    for i in range(0, x.shape[0], 2048):  # at most 2048 x 256 distances at once
        xi = x[i:i + 2048]
        d = np.square(xi[:, 0:1] - centres[:, 0])
        d += np.square(xi[:, 1:2] - centres[:, 1])
        d += np.square(xi[:, 2:3] - centres[:, 2])
        index[i:i + 2048] = np.argmin(d, axis=1)
        dist[i:i + 2048] = d[np.arange(xi.shape[0]), index[i:i + 2048]]
    return index, dist


def _colour_ids(rgb24: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A small id for every pixel's colour (0x000000-0xFFFFFF), and the colour of every id.

    A thread keeps a table from colour to id across images: report figures of one kind share
    most of their colours, so after the first image only the few new colours are looked for
    (``np.unique`` of those), and an image is counted with one table look-up and one
    ``np.bincount`` instead of a sort of all its pixels. Id 0 is unused (a colour not seen yet).
    """
    local = _local()
    table, colours = local.get("colour_ids", (None, None))
    if table is None:
        table, colours = np.zeros(1 << 24, dtype=np.uint16), np.zeros(1, dtype=np.uint32)
    ids = table[rgb24]
    if not ids.all():
        new = np.unique(rgb24[ids == 0])
        if colours.size + new.size > _MAX_COLOUR_IDS:
            table, colours = np.zeros(1 << 24, dtype=np.uint16), np.zeros(1, dtype=np.uint32)
            new = np.unique(rgb24)
            if 1 + new.size > _MAX_COLOUR_IDS:  # more colours than ids: this image alone, by a sort
                inverse = np.unique(rgb24, return_inverse=True)[1]
                return inverse.reshape(-1), new
        table[new] = np.arange(colours.size, colours.size + new.size)
        colours = np.concatenate([colours, new.astype(np.uint32)])
        ids = table[rgb24]
    local["colour_ids"] = (table, colours)
    return ids, colours


def _canvas(fig: Figure, dpi: float, canvas_class: Any) -> Any:
    """The Agg canvas of this process for ``fig``'s size, attached to ``fig``.

    One canvas (and renderer) per size: matplotlib's text metrics and mathtext caches are per
    renderer. Never one made by another process: a renderer's mathtext parses (log tick labels,
    ``$...$``) hold the FreeType fonts they were laid out with, and a font's glyphs are read on
    demand through the file descriptor it opened. A forked child shares that descriptor's file
    offset with its parent and its siblings, so two processes loading glyphs through the same
    font read each other's positions ("FT_Load_Glyph ... invalid outline"). matplotlib clears its
    own font cache in a forked child for this reason; the canvases kept here are dropped likewise.
    Nor one of another thread: two figures drawn at once on one canvas draw into one pixel buffer
    (threads of an executor drawing a campaign's figures); the canvases are kept per thread.
    """
    canvases: dict[tuple[int, int, float], Any] = _local()["canvases"]
    size = (round(fig.bbox.width), round(fig.bbox.height), dpi)
    canvas = canvases.get(size)
    if canvas is None:
        canvas = canvases[size] = _text_cached(canvas_class)(fig)
    else:
        canvas.figure = fig
        fig.set_canvas(canvas)
    return canvas


#: Glyph bitmaps of texts drawn before (:func:`_text_cached`), at most _MAX_TEXTS texts.
_TEXTS: dict[Any, Any] = {}
_MAX_TEXTS = 4096
#: Each glyph's bitmap by font, size, rotation and position within its pixel [1/64 px], and the
#: glyphs of each text shaped before (:func:`_text_cached`): a text not drawn before at this
#: place is mostly glyphs drawn before at the same position within a pixel.
_GLYPHS: dict[Any, Any] = {}
_MAX_GLYPHS = 32768
_SHAPES: dict[Any, Any] = {}


def _text_cached(canvas_class: Any) -> Any:
    """``canvas_class`` (an Agg canvas) whose renderer draws a text seen before from its glyph bitmaps.

    Report figures of one kind draw the same texts measurement after measurement (tick labels,
    axis labels, legends, the log tick labels of magnitude axes whose limits follow the data):
    matplotlib lays each text out (shaping) and renders every glyph of it with FreeType at every
    draw. The renderer here draws every text with its origin at the nearest whole pixel, as
    matplotlib's Agg renderer did up to 3.10 (it rendered a text's glyphs into one bitmap and
    placed that at a rounded position): a text moves by at most half a pixel, its glyphs are
    rendered as matplotlib renders them there, and a text drawn before anywhere is the same
    bitmaps whole pixels away. The renderer keeps, per text, font, size and angle, the glyph
    bitmaps and their offsets, and only blends them onto the canvas when the text comes again
    (the pixels of matplotlib's own draw of the text at that whole pixel:
    ``tests/test_plot_render.py``). Drawn at the exact place, a text not drawn before at the same
    position within its pixel (every log tick label of a magnitude axis whose limits follow the
    data) was rendered glyph by glyph again: 57 of the 82 texts each measurement's figures drew
    in the bundled demo, a tenth of their drawing time. Texts with rules (mathtext fractions,
    roots) are drawn by matplotlib. Needs matplotlib's glyph-wise Agg text drawing (3.11); with
    another the canvas class is returned unchanged.
    """
    from matplotlib import rcParams
    from matplotlib.backends import backend_agg

    hinting_flag: Any = backend_agg.get_hinting_flag  # untyped in matplotlib

    base = backend_agg.RendererAgg
    if not hasattr(base, "_draw_text_glyphs_and_boxes") or not hasattr(base, "_prepare_font"):
        return canvas_class

    class Renderer(base):  # type: ignore[misc, valid-type]
        def draw_text(self, gc: Any, x: float, y: float, s: str, prop: Any, angle: float,
                      ismath: Any = False, mtext: Any = None) -> None:
            if ismath == "TeX":
                super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
                return None
            up = self.height - y  # FreeType's y is upwards
            # the text's origin at the nearest whole pixel (:func:`_text_cached`): its bitmaps
            # are then those of every other place it was drawn at
            ix, iy = math.floor(x + 0.5), math.floor(up + 0.5)
            fx = fy = 0.0
            features = mtext.get_fontfeatures() if mtext is not None and hasattr(mtext, "get_fontfeatures") else None
            language = mtext.get_language() if mtext is not None and hasattr(mtext, "get_language") else None
            key = (s, bool(ismath), _font_key(prop), float(angle), float(self.dpi), bool(gc.get_antialiased()),
                   hinting_flag(), None if features is None else tuple(features), language,
                   fx, fy)
            glyphs: Any = _TEXTS.get(key)
            if glyphs is None:
                try:
                    glyphs = self._glyph_bitmaps(s, prop, angle, ismath, features, language, gc.get_antialiased(),
                                                 fx, fy)
                except (AttributeError, TypeError):  # another matplotlib's private text API
                    glyphs = False
                if glyphs:
                    glyphs = _merged(glyphs)
                if len(_TEXTS) >= _MAX_TEXTS:
                    _TEXTS.clear()
                _TEXTS[key] = glyphs
            if glyphs is False:
                super().draw_text(gc, x, y, s, prop, angle, ismath, mtext)
                return None
            height = int(self.height)
            draw = self._renderer.draw_text_image
            for buf, left, top in glyphs:
                draw(buf, left + ix, height - (top + iy) + buf.shape[0], 0, gc)
            return None

        def _glyph_bitmaps(self, s: str, prop: Any, angle: float, ismath: Any, features: Any, language: Any,
                           antialiased: bool, fx: float, fy: float) -> Any:
            """(bitmap, left [px], top [px, upwards]) of every glyph of ``s`` drawn at (fx, fy) [px]."""
            from matplotlib.font_manager import get_font
            from matplotlib.ft2font import RenderMode

            items: Any
            if ismath:
                parse = self.mathtext_parser.parse(s, self.dpi, prop, antialiased=antialiased)
                if parse.rects:
                    return False
                items = [(font, size, idx, dx, dy) for font, size, _c, idx, dx, dy in parse.glyphs]
            else:
                size = prop.get_size_in_points()
                shape_key = (s, _font_key(prop), float(self.dpi), hinting_flag(),
                             None if features is None else tuple(features), language)
                items = _SHAPES.get(shape_key)
                if items is None:
                    font = self._prepare_font(prop)
                    kw = {} if features is None and language is None else {"features": features, "language": language}
                    items = [(it.ft_object, size, it.glyph_index, it.x, it.y)
                             for it in font._layout(s, flags=hinting_flag(), **kw)]
                    # kept by font file, not font object: a font object is this thread's and
                    # this process' (:func:`_canvas`); one of the first face of its file only
                    if all(getattr(f, "face_index", 0) == 0 for f, *_ in items):
                        if len(_SHAPES) >= _MAX_TEXTS:
                            _SHAPES.clear()
                        _SHAPES[shape_key] = [(f.fname, *rest) for f, *rest in items]
            cos, sin = math.cos(math.radians(angle)), math.sin(math.radians(angle))
            matrix = (0x10000 * np.array([[cos, -sin], [sin, cos]])).round().astype(int)
            flags = hinting_flag()
            mode = RenderMode.NORMAL if antialiased else RenderMode.MONO
            common = (float(self.dpi), tuple(matrix.ravel().tolist()), flags, bool(antialiased),
                      rcParams["text.hinting_factor"])
            out = []
            for font, size, idx, dx, dy in items:  # as matplotlib's _draw_text_glyphs_and_boxes
                fname = font if isinstance(font, str) else font.fname
                # where the glyph's origin falls [1/64 px, as FreeType takes it]: its bitmap depends
                # on the position within the pixel only, whole pixels move it
                gx = round(0x40 * (fx + dx * cos - dy * sin))
                gy = round(0x40 * (fy + dx * sin + dy * cos))
                gkey = (fname, 0 if isinstance(font, str) else getattr(font, "face_index", 0), float(size), int(idx),
                        gx & 0x3F, gy & 0x3F, common)
                glyph = _GLYPHS.get(gkey)
                if glyph is None:
                    if isinstance(font, str):
                        font = get_font(font)  # this thread's
                    font.set_size(size, self.dpi)
                    font._set_transform(matrix, [gx & 0x3F, gy & 0x3F])
                    bitmap = font._render_glyph(idx, flags, mode)
                    buf = np.array(bitmap.buffer, copy=True)
                    if not antialiased:
                        buf *= 0xFF
                    glyph = (buf, int(bitmap.left), int(bitmap.top))
                    if len(_GLYPHS) >= _MAX_GLYPHS:
                        _GLYPHS.clear()
                    _GLYPHS[gkey] = glyph
                buf, left, top = glyph
                out.append((buf, left + (gx >> 6), top + (gy >> 6)))
            return tuple(out)

    class Canvas(canvas_class):  # type: ignore[misc]
        def get_renderer(self) -> Any:
            w, h = self.get_width_height(physical=True)
            key = w, h, self.figure.dpi
            if getattr(self, "_lastKey", None) != key:
                self.renderer = Renderer(w, h, self.figure.dpi)
                self._lastKey = key
            return self.renderer

    return Canvas


def _merged(glyphs: tuple[tuple[np.ndarray, int, int], ...]) -> tuple[tuple[np.ndarray, int, int], ...]:
    """The glyph bitmaps of a text as one bitmap, when no two of them cover the same pixel.

    Agg blends a glyph's bitmap onto the canvas pixel by pixel by its coverage and leaves the
    pixels of zero coverage as they are: bitmaps that share no covered pixel, put side by side in
    one, draw the same pixels with one call instead of one per glyph (a few calls per text instead
    of one per character, for every text and every replayed tick label). Glyphs that do overlap
    (kerned pairs, accents) are left as they are, each drawn on its own as matplotlib does.

    ``glyphs``: (bitmap (h, w) uint8, left [px], top [px, upwards]) per glyph, as drawn.
    """
    if len(glyphs) < 2:
        return glyphs
    x0 = min(left for _, left, _ in glyphs)
    top0 = max(top for _, _, top in glyphs)
    x1 = max(left + buf.shape[1] for buf, left, _ in glyphs)
    y1 = max(top0 - top + buf.shape[0] for buf, _, top in glyphs)
    if x1 <= x0 or y1 <= 0 or (x1 - x0) * y1 > 1 << 20:
        return glyphs
    out = np.zeros((y1, x1 - x0), dtype=np.uint8)
    for buf, left, top in glyphs:
        r, c = top0 - top, left - x0
        region = out[r:r + buf.shape[0], c:c + buf.shape[1]]
        if np.any(region[buf > 0]):
            return glyphs  # two glyphs cover one pixel: Agg blends twice there
        np.maximum(region, buf, out=region)
    return ((out, x0, top0),)


def _font_key(prop: Any) -> tuple[Any, ...]:
    return (tuple(prop.get_family()), prop.get_style(), prop.get_variant(), prop.get_weight(), prop.get_stretch(),
            prop.get_size_in_points(), prop.get_file(), prop.get_math_fontfamily())


def _local() -> dict[str, Any]:
    """This thread's canvases, kept figures and colour ids, new in a new thread.

    In a child forked by this thread (a pool's worker) the canvases are new (:func:`_canvas`: a
    renderer's mathtext parses hold its process' fonts), and the figures kept by the parent are
    taken over, each put on a canvas of the child: their axes, ticks and layouts are plain Python
    objects (each process its copy), nothing of them reads a font. A worker's first measurement then
    finds its figures built and laid out, as the parent's next one would.
    """
    pid = os.getpid()
    kept: dict[str, Any] | None = getattr(_LOCAL, "kept", None)
    if kept is None or getattr(_LOCAL, "pid", None) != pid:
        inherited: dict[str, Any] = {} if kept is None else kept["figures"]
        fresh: dict[str, Any] = {"canvases": {}, "figures": {}}
        if kept is not None and "colour_ids" in kept:  # numbers only
            fresh["colour_ids"] = kept["colour_ids"]
        _LOCAL.kept, _LOCAL.pid = fresh, pid
        if inherited:
            from matplotlib.backends.backend_agg import FigureCanvasAgg

            for kind, fig in inherited.items():
                _canvas(fig, float(fig.dpi), FigureCanvasAgg)  # off the parent's canvas
                fresh["figures"][kind] = fig
        kept = fresh
    return kept


def warm_up(dpi: float) -> None:
    """Do the one-time work of a process' first figure now, before it forks the workers that draw.

    A process' first report figure pays, besides its own drawing, matplotlib's imports (figure,
    axes, ticker, Agg), the mathtext grammar (log tick labels are mathtext; built once per process)
    and the font lookups: about half a second of CPU, paid again by every worker of a pool that
    forks before it (the campaign's workers draw each measurement's figures, and this process the
    campaign figures). Done here, once, the workers inherit the modules, the grammar and the
    font-lookup cache. What a fork must not share is not kept: the small figure drawn here is
    thrown away with its plain Agg canvas and renderer (so no glyph of it goes to this module's
    caches and no mathtext layout outlives it), and matplotlib drops its FreeType font objects in a
    forked child (:func:`_canvas`). Nothing drawn later depends on it: the same pixels either way.

    Parameters
    ----------
    dpi : float
        Pixel density [dots per inch] of the figures the workers will draw.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    with gc_paused():
        fig = Figure(figsize=(2.0, 1.5), dpi=dpi)
        ax = fig.add_subplot()
        semilogy(ax, [1.0, 2.0], [1.0, 1e3], label="a")  # mathtext tick labels: the grammar
        ax.set_title("a", fontsize=9)
        ax.legend(fontsize=8)
        canvas: Any = FigureCanvasAgg(fig)
        canvas.draw()


def kept_figure(kind: str, figsize: tuple[float, float]) -> Figure:
    """The figure this thread keeps for ``kind``, else a new constrained-layout one, kept from now on.

    A process forked by this thread takes the figures kept until then over (:func:`_local`).

    A plot function given it (``figure=``) finds the axes it built for the previous measurement
    of that kind (:func:`reuse_axes`) and only replaces the data, limits and texts: no new axes,
    no new tick objects. Kept per thread and per process like the canvases (:func:`_canvas`): a
    figure is never drawn by two threads at once. Draw one figure of a kind to PNG before asking
    for the next: it is the same object.

    Parameters
    ----------
    kind : str
        Any name of a figure kind (``"stabilization"`` ...).
    figsize : (float, float)
        Size [inch]; a kept figure of another size is replaced.

    Returns
    -------
    Figure
    """
    from matplotlib.figure import Figure

    figures: dict[str, Any] = _local()["figures"]
    fig = figures.get(kind)
    if fig is None or tuple(fig.get_size_inches()) != tuple(float(x) for x in figsize):
        fig = figures[kind] = Figure(figsize=figsize, layout="constrained")
    return fig


def reuse_axes(fig: Figure, signature: str) -> list[Axes] | None:
    """The axes of ``fig`` reset to fresh ones when it holds a figure of ``signature``, else None.

    A plot function that lays out its axes itself marks the figure with a signature of that
    layout (``fig.set_label``). Called again with the same figure and signature it gets the same
    axes back, emptied: every artist, legend and title text removed, the data limits forgotten and
    autoscaling on again, log axes given their default locators back (:func:`collapse_minor_ticks`
    replaced them); the axes themselves, their tick objects and tick styles stay: the figure draws as one built
    anew with the same calls (``tests/test_plot_render.py``). With another signature the figure
    is cleared, marked with this one, and None returned: build the axes.

    Parameters
    ----------
    fig : Figure
    signature : str
        What the plot function's axes layout depends on (function, number of panels ...).

    Returns
    -------
    list of Axes or None
        ``fig.axes`` in the order they were added, or None when they must be built.
    """
    from matplotlib.transforms import Bbox

    if fig.get_label() != signature or not fig.axes:
        fig.clear()
        fig.set_label(signature)
        return None
    for ax in fig.axes:
        # the data lines drawn by :func:`semilogy` and :func:`plot_line`, as they were made: taken
        # again (new data only) by the next call with the same style (:func:`_spare_line`)
        spare = [ln for ln in ax.lines if ln.__dict__.get("_ema_rig_made") == _line_state(ln)]
        for group in (ax.lines, ax.collections, ax.patches, ax.texts, ax.images, ax.artists, ax.tables):
            for child in list(group):
                child.remove()
        ax.__dict__["_ema_rig_spare"] = spare
        if ax.legend_ is not None:
            ax.legend_.remove()
        ax.containers.clear()
        ax.dataLim.set_points(Bbox.null().get_points())
        ax.ignore_existing_data_limits = True
        ax.set_autoscale_on(True)
        for t in _titles(ax):
            t.set_text("")
        ax.xaxis.label.set_text("")
        ax.yaxis.label.set_text("")
        # a log axis' default locators and formatters, minor ticks back
        if ax.get_xscale() == "log":
            ax.set_xscale("log")
        if ax.get_yscale() == "log":
            ax.set_yscale("log")
    for t in fig.texts:
        t.set_text("")
    return list(fig.axes)


def semilogy(ax: Axes, *args: Any, **kwargs: Any) -> list[Any]:
    """``ax.semilogy(*args, **kwargs)``, without making the log scale again on a y axis that has it.

    ``Axes.semilogy`` sets the log scale at every call: a new scale object, locators and
    formatters, the same as those a log axis with its default ticking already has (a figure's
    second curve, or an axes emptied by :func:`reuse_axes`), the transforms invalidated. On such an
    axis only the curve is added (``Axes.plot``); any other gets ``Axes.semilogy``. The same figure
    (``tests/test_plot_reuse.py``), a tenth less time to build a report's model figure.

    Returns
    -------
    list of Line2D
        As ``Axes.plot``.
    """
    y = ax.yaxis
    if (ax.get_yscale() == "log" and y.isDefault_majloc and y.isDefault_minloc and y.isDefault_majfmt
            and y.isDefault_minfmt and getattr(y.get_transform(), "base", None) == 10):
        return plot_line(ax, *args, **kwargs)
    made: list[Any] = ax.semilogy(*args, **kwargs)
    return made


#: The properties of a line the plot functions set (``Axes.plot`` keywords) or that a drawing reads
#: and a caller might change afterwards: a kept line is taken again only when they are as made.
_LINE_STATE = ("color", "linewidth", "linestyle", "dashes", "drawstyle", "marker", "markersize", "markeredgewidth",
               "markeredgecolor", "markerfacecolor", "markerfacecoloralt", "fillstyle", "markevery", "alpha",
               "zorder", "label", "visible", "clip_on", "antialiased", "solid_capstyle", "solid_joinstyle",
               "dash_capstyle", "dash_joinstyle", "gapcolor", "path_effects", "sketch_params", "snap",
               "rasterized", "agg_filter", "gid", "url", "picker", "pickradius", "in_layout", "animated")


def _line_state(line: Any) -> tuple[Any, ...]:
    """What of ``line`` a kept one must still have to be taken again (:data:`_LINE_STATE`, its transform, clip).

    The clip box only as there or not: ``set_clip_path`` makes a new one each time (the axes patch's
    transform composed anew), the same box.
    """
    dashes = line._unscaled_dash_pattern  # the on/off sequence "dashes" sets and "linestyle" names
    return (*(repr(getattr(line, f"get_{k}")()) if k != "dashes" else repr(dashes) for k in _LINE_STATE),
            id(line.get_transform()), id(line.get_clip_path()), line.get_clip_box() is None)


def plot_line(ax: Axes, x: Any, y: Any, **style: Any) -> list[Any]:
    """``ax.plot(x, y, **style)`` for one line with its colour given, taking a line of a kept figure again.

    The axes of a kept figure (:func:`reuse_axes`) keep the data lines they had, as made: the first
    one made with the same ``style`` (its label aside) that nothing changed since is given ``x``,
    ``y`` (``set_data``) and the label and added back where ``Axes.plot`` would add a new one (data limits, autoscale
    request), instead of building a new ``Line2D`` through ``Axes.plot``'s argument parsing: the
    same artist, the same pixels (``tests/test_plot_reuse.py``). Lines taken again come back in the
    order they were made, so the axes' children are in the order ``Axes.plot`` gives. Kept lines not
    taken again are dropped when the figure is rendered (:func:`render_png`). With no colour given
    ``Axes.plot`` is called (it takes one from the property cycle).

    Parameters
    ----------
    ax : Axes
    x, y : array_like, shape (n,)
        Data coordinates.
    **style
        ``Axes.plot`` keywords; must include ``color``.

    Returns
    -------
    list of Line2D
        One line, as ``Axes.plot``.
    """
    key = repr(sorted((k, v) for k, v in style.items() if k != "label"))
    spare: list[Any] = ax.__dict__.get("_ema_rig_spare") or []
    line = next((ln for ln in spare if ln.__dict__.get("_ema_rig_style") == key), None) if "color" in style else None
    if line is None:
        made: list[Any] = ax.plot(x, y, **style)
        if "color" in style and len(made) == 1:
            made[0]._ema_rig_style = key
            made[0]._ema_rig_made = _line_state(made[0])
        return made
    spare.remove(line)
    label = style.get("label")
    if label is not None and str(label) != line.get_label():  # None: the "_child<n>" label add_line gave it
        line.set_label(label)
        line._ema_rig_made = _line_state(line)
    line.set_data(np.asarray(x), np.asarray(y))
    ax.add_line(line)
    axes: Any = ax  # as Axes.plot does after adding its lines (private)
    axes._request_autoscale_view("x")
    axes._request_autoscale_view("y")
    return [line]


def collapse_minor_ticks(fig: Figure) -> int:
    """Replace the unlabelled minor ticks of every log axis by two artists; returns how many axes.

    Call on a finished figure: the positions are those of the current view limits.
    """
    n = 0
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        for axis in (ax.xaxis, ax.yaxis):
            n += _collapse(axis)
    return n


def _unlabelled_minor(axis: Axis) -> Any:
    """The minor tick locations a log axis would draw [data], when none carries a label; else None."""
    from matplotlib.ticker import NullLocator

    if axis.get_scale() != "log" or isinstance(axis.get_minor_locator(), NullLocator) or not axis.get_visible():
        return None
    locs = np.asarray(axis.get_minorticklocs(), dtype=float)
    # the ticks matplotlib would draw: inside the view interval (its own test, in log space)
    lo, hi = sorted(axis.get_view_interval())
    if not (lo > 0 and np.isfinite(hi)):
        return None
    a, b = np.log10(lo), np.log10(hi)
    tol = (b - a) * 1e-10
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.log10(locs)
    locs = locs[(t >= a - tol) & (t <= b + tol)]
    if locs.size and any(axis.get_minor_formatter().format_ticks(list(locs))):
        return None  # labelled minor ticks: keep matplotlib's own
    return locs


def _minor_off(fig: Figure) -> list[tuple[Any, Any, bool]]:
    """Switch off the unlabelled minor ticks of log axes (a layout only measures their empty
    labels, one ``Tick`` each); returns what :func:`_minor_on` needs to switch them on again."""
    from matplotlib.ticker import NullLocator

    off = []
    for ax in fig.axes:
        if ax.get_visible():
            for axis in (ax.xaxis, ax.yaxis):
                if _unlabelled_minor(axis) is not None:
                    off.append((axis, axis.get_minor_locator(), axis.isDefault_minloc))
                    axis.set_minor_locator(NullLocator())
    return off


def _minor_on(off: list[tuple[Any, Any, bool]]) -> None:
    for axis, locator, default in off:
        axis.set_minor_locator(locator)
        axis.isDefault_minloc = default


def _collapse(axis: Axis) -> int:
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D
    from matplotlib.ticker import NullLocator

    locs = _unlabelled_minor(axis)
    if locs is None:
        return 0
    ax = axis.axes
    axis.set_minor_locator(NullLocator())
    if not locs.size:
        return 1
    tick = axis.get_minor_ticks(1)[0]  # styled as this axis' minor ticks; not drawn (no locations)
    is_x = axis is ax.xaxis
    zorder = axis.get_zorder()
    for line in (tick.tick1line, tick.tick2line):
        if not line.get_visible():
            continue
        pos = float(np.asarray(line.get_xdata() if not is_x else line.get_ydata())[0])
        xy = (locs, np.full(locs.size, pos)) if is_x else (np.full(locs.size, pos), locs)
        marks = Line2D(*xy, transform=line.get_transform(), ls="none", marker=line.get_marker(),
                       ms=line.get_markersize(), mew=line.get_markeredgewidth(), color=line.get_color(),
                       mec=line.get_markeredgecolor(), alpha=line.get_alpha(), zorder=zorder, clip_on=False)
        ax.add_artist(marks)
    g = tick.gridline
    if g.get_visible():
        seg = np.empty((locs.size, 2, 2))
        if is_x:
            seg[:, :, 0] = locs[:, None]
            seg[:, :, 1] = [0.0, 1.0]
        else:
            seg[:, :, 0] = [0.0, 1.0]
            seg[:, :, 1] = locs[:, None]
        grid: Any = LineCollection(list(seg), transform=g.get_transform(), colors=[g.get_color()],
                                   linewidths=g.get_linewidth(), linestyles=g.get_linestyle(),
                                   alpha=g.get_alpha(), zorder=zorder, antialiased=g.get_antialiased())
        grid.set_clip_path(ax.patch)
        grid.set_capstyle(g.get_solid_capstyle())
        ax.add_collection(grid, autolim=False)
    return 1


# ----------------------------------------------------------------------------- axis replay
#: What Agg's C renderer is asked to draw (:func:`_axes_replayed`): these calls are recorded.
_AGG_DRAWS = ("draw_path", "draw_markers", "draw_path_collection", "draw_text_image", "draw_image",
              "draw_quad_mesh", "draw_gouraud_triangles")
#: Recordings kept per axis (the newest last): the few limits an axis of a report figure takes.
_MAX_RECORDINGS = 4
#: An axis that found no recording to replay this many draws in a row (a log magnitude axis whose
#: limits follow the data) is recorded at every _VOLATILE-th draw only: recording costs about a
#: fifth of such an axis' drawing (bundled demo, synthesis figure) and is then rarely replayed.
_VOLATILE = 3


class _Recorder:
    """Stands in for Agg's C renderer while an axis draws: passes every call on and records it.

    A graphics context is copied as it is at the call (matplotlib changes one between the calls of
    one artist, a line and then its markers); everything else is kept by reference (paths,
    frozen transforms, glyph bitmaps: made for the call, never changed afterwards). Any other use
    of the renderer than drawing (reading pixels back, filters) marks the recording unusable.
    """

    def __init__(self, target: Any) -> None:
        self._target = target
        self.calls: list[tuple[str, tuple[Any, ...]]] = []
        self.usable = True
        for name in _AGG_DRAWS:
            setattr(self, name, self._recording(name))

    def _recording(self, name: str) -> Any:
        from matplotlib.backend_bases import GraphicsContextBase

        method = getattr(self._target, name)

        def call(*args: Any) -> Any:
            if not all(isinstance(a, GraphicsContextBase) or not hasattr(a, "__dict__") or _immutable(a)
                       for a in args):
                self.usable = False
            self.calls.append((name, tuple(_snapshot(a) for a in args)))
            return method(*args)

        return call

    def __getattr__(self, name: str) -> Any:  # anything but a draw: pass it on, do not replay
        self.usable = False
        return getattr(self._target, name)


def _immutable(a: Any) -> bool:
    """Objects a recorded call may keep by reference: matplotlib makes them for the call."""
    from matplotlib.path import Path
    from matplotlib.transforms import Affine2DBase, IdentityTransform

    return isinstance(a, (Path, Affine2DBase, IdentityTransform))


def _snapshot(a: Any) -> Any:
    from matplotlib.backend_bases import GraphicsContextBase

    if isinstance(a, GraphicsContextBase):
        g: Any = copy.copy(a)
        box = g.get_clip_rectangle()
        if box is not None:
            g.set_clip_rectangle(box.frozen())
        return g
    return a


def _replay_key(renderer: Any, axis: Any) -> Any:
    """Everything an axis' drawing depends on (report figures: see :func:`_axes_replayed`); None: draw it."""
    from matplotlib import rcParams

    ax = axis.axes
    fig = ax.get_figure(root=True)
    try:
        groups = fig._align_label_groups  # axes whose labels are aligned with this one's
        alone = all(list(g.get_siblings(ax)) == [ax] for g in groups.values())
    except (AttributeError, KeyError, TypeError):
        return None
    if not alone:
        return None
    lo, hi = axis.get_view_interval()
    major = np.asarray(axis.get_majorticklocs(), dtype=float)
    minor = _minor_locs(axis)
    labels = tuple(axis.get_major_formatter().format_ticks(list(major)))
    offset = axis.get_major_formatter().get_offset()
    minor_labels = tuple(axis.get_minor_formatter().format_ticks(list(minor))) if minor.size else ()
    lab = axis.label
    scale = axis._scale
    return (int(renderer.width), int(renderer.height), float(renderer.dpi), tuple(ax.bbox.bounds),
            float(lo), float(hi), type(scale).__name__, getattr(scale, "base", None),
            major.tobytes(), minor.tobytes(), labels, minor_labels, offset,
            repr(sorted(axis._major_tick_kw.items())), repr(sorted(axis._minor_tick_kw.items())),
            lab.get_text(), lab.get_visible(), lab.get_fontsize(), str(lab.get_color()), lab.get_rotation(),
            axis.get_label_position(), axis.labelpad, axis._autolabelpos,
            None if axis._autolabelpos else tuple(lab.get_position()),
            axis.offsetText.get_visible(), tuple(str(sp.get_position()) for sp in ax.spines.values()),
            tuple(rcParams[k] for k in ("text.hinting", "text.hinting_factor", "text.antialiased", "path.snap",
                                        "path.simplify", "path.simplify_threshold", "agg.path.chunksize")))


def _minor_locs(axis: Any) -> np.ndarray:
    """``axis.get_minorticklocs()`` as floats; with no minor ticks (a ``NullLocator``, as every
    collapsed log axis has) without locating the major ticks again to take out those that
    coincide with them (what ``get_minorticklocs`` does in any case)."""
    from matplotlib.ticker import NullLocator

    if type(axis.get_minor_locator()) is NullLocator:
        return np.asarray(NullLocator()(), dtype=float)
    return np.asarray(axis.get_minorticklocs(), dtype=float)


@contextlib.contextmanager
def _axes_replayed(fig: Figure) -> Iterator[None]:
    """Draw each axis of a report figure from the renderer calls it made before, when nothing it
    depends on changed.

    The axes of a figure kept per worker (:func:`kept_figure`, marked ``ema_rig.`` by
    :func:`reuse_axes`) are the same objects measurement after measurement, and most of them show
    the same ticks at the same place (a campaign's band is the same for all its measurements). An
    axis (ticks, gridlines, tick labels, label, offset text) drawn by matplotlib is a few hundred
    Python calls per tick for a few calls into Agg's C renderer: those calls are recorded
    (:class:`_Recorder`) with the key of everything the drawing reads (:func:`_replay_key`: canvas,
    axes box, view limits, scale, tick locations and labels, tick styles, label, spine positions,
    the rcParams of text and path rendering) and made again, the same calls with the same
    arguments, when an axis comes with the same key: the same pixels. An axis whose label is
    aligned with other axes' (``align_labels``), any figure not kept, and a recording that used
    the renderer otherwise are drawn by matplotlib. An axis that missed its recordings _VOLATILE
    draws in a row (limits that follow the data) is looked up and recorded at every _VOLATILE-th
    draw only. The axes of any other figure (the campaign figures) work their ticks and tick label
    boxes out once for the whole draw (:func:`_ticks_once`): matplotlib does it again to place each
    axis label and, for every axes with a title, to place the title.
    """
    from matplotlib.axis import Axis

    label = fig.get_label()
    if not (isinstance(label, str) and label.startswith("ema_rig.")):
        with _figure_ticks_once(fig):
            yield
        return
    patched = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if axis.get_visible():
                axis.draw = _replaying(axis, Axis.draw)  # type: ignore[method-assign]
                patched.append(axis)
    try:
        yield
    finally:
        for axis in patched:
            del axis.draw


def _replaying(axis: Any, draw: Any) -> Any:
    def replay(renderer: Any) -> None:
        misses = axis.__dict__.get("_ema_rig_misses", 0)
        if misses >= _VOLATILE and (misses + 1) % _VOLATILE:
            # an axis whose limits follow the data, between its recordings: drawn by matplotlib
            # without working out its key (a replay would give the same pixels, and rarely comes)
            axis._ema_rig_misses = misses + 1
            with _ticks_once(axis):
                draw(axis, renderer)
            return None
        try:
            key = _replay_key(renderer, axis)
        except (ValueError, TypeError, AttributeError):
            key = None
        kept: list[tuple[Any, Any]] = axis.__dict__.setdefault("_ema_rig_recorded", [])
        real = renderer._renderer
        if key is not None:
            for k, calls in kept:
                if k == key:
                    for name, args in calls:
                        getattr(real, name)(*args)
                    axis.stale = False
                    axis._ema_rig_misses = 0
                    return None
        misses = axis.__dict__.get("_ema_rig_misses", 0) + 1
        axis._ema_rig_misses = misses
        if key is None or (misses >= _VOLATILE and misses % _VOLATILE):
            with _ticks_once(axis):
                draw(axis, renderer)
            return None
        rec = _Recorder(real)
        renderer._renderer = rec
        for name in _AGG_DRAWS:  # Agg binds these to its C renderer at creation
            if name in renderer.__dict__:
                setattr(renderer, name, getattr(rec, name))
        try:
            with _ticks_once(axis):
                draw(axis, renderer)
        finally:
            renderer._renderer = real
            for name in _AGG_DRAWS:
                if name in renderer.__dict__:
                    setattr(renderer, name, getattr(real, name))
        if rec.usable:
            kept.append((key, rec.calls))
            del kept[:-_MAX_RECORDINGS]
        return None

    return replay


@contextlib.contextmanager
def _figure_ticks_once(fig: Figure) -> Iterator[None]:
    """:func:`_ticks_once` for every axis of ``fig`` within the block."""
    with contextlib.ExitStack() as stack:
        for ax in fig.axes:
            for axis in (ax.xaxis, ax.yaxis):
                stack.enter_context(_ticks_once(axis))
        yield


@contextlib.contextmanager
def _locs_once(fig: Figure) -> Iterator[None]:
    """Every axis' major and minor tick locations worked out once per state within the block.

    A finished report figure's tick locations are asked for again and again between its last
    change and its PNG: the keys of a kept layout (:func:`fixed_layout`, once per kept layout tried,
    and the layout's own passes), whether a log axis' minor ticks carry labels (twice), the minor
    ticks collapsed (:func:`collapse_minor_ticks`), an axis' replay key (:func:`_axes_replayed`) and
    matplotlib's own tick update: each time the locator (a log locator: every decade's candidates
    formatted to pick the ticks) and, for the minor ones, the major locator again to drop those
    that coincide. Within the block an axis' locations are kept under everything a locator reads
    that can change there: the locators themselves (a layout puts stand-ins in, the collapse a
    ``NullLocator``), the view limits, the axes' box [px] and the dpi (a locator takes as many
    ticks as the axis has room for). Each caller gets its own copy; the kept ones go with the
    block. The same locations, so the same pixels.
    """
    patched: list[Any] = []
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            if "get_majorticklocs" in axis.__dict__:
                continue  # within another such block: its memo holds
            memo: dict[Any, Any] = {}
            for name in ("get_majorticklocs", "get_minorticklocs"):
                setattr(axis, name, _locs_kept(axis, name, getattr(axis, name), memo))
            patched.append(axis)
    try:
        yield
    finally:
        for axis in patched:
            del axis.get_majorticklocs, axis.get_minorticklocs


def _locs_kept(axis: Any, name: str, own: Any, memo: dict[Any, Any]) -> Any:
    """``own`` (an axis' ``get_majorticklocs`` or ``get_minorticklocs``) kept in ``memo`` (:func:`_locs_once`)."""
    def call() -> Any:
        key = (name, axis.major.locator, axis.minor.locator, tuple(axis.get_view_interval()),
               tuple(axis.axes.bbox.bounds), float(axis.get_figure(root=True).dpi), axis.remove_overlapping_locs)
        if key not in memo:
            memo[key] = own()
        return copy.copy(memo[key])

    return call


@contextlib.contextmanager
def _ticks_once(axis: Any) -> Iterator[None]:
    """The axis' ticks and tick label boxes worked out once within the block (a draw of a finished figure).

    matplotlib's ``Axis.draw`` updates the ticks and measures their labels, then, to place the
    axis label clear of the tick labels of every axes aligned with it (``_get_tick_boxes_siblings``;
    this axis alone unless ``align_labels``), updates and measures them all again: the same ticks
    and boxes, nothing changed between; ``Axes.draw`` does it all once more for every axes with a
    title (its y axis' tight box, to place the title clear of an offset text), and a constrained
    layout measures them all for each of its passes. Within the block the second time takes the
    first's, kept by what they read that a draw or a layout pass changes: the view limits and the
    axes' box (the ticks and their labels: a locator takes as many ticks as the axis has room
    for), and the renderer (the label boxes).
    """
    update, boxes = axis._update_ticks, axis._get_ticklabel_bboxes
    memo: dict[Any, Any] = {}

    def update_ticks() -> Any:
        k = ("ticks", tuple(axis.get_view_interval()), tuple(axis.axes.bbox.bounds))
        if k not in memo:
            memo[k] = update()
        return memo[k]

    def ticklabel_bboxes(ticks: Any, renderer: Any = None) -> Any:
        k = (id(ticks), id(renderer), tuple(axis.axes.bbox.bounds))
        if k not in memo:
            memo[k] = boxes(ticks, renderer)
        return memo[k]

    axis._update_ticks, axis._get_ticklabel_bboxes = update_ticks, ticklabel_bboxes
    try:
        yield
    finally:
        del axis._update_ticks, axis._get_ticklabel_bboxes


@contextlib.contextmanager
def _legend_boxes_once(fig: Figure) -> Iterator[None]:
    """The boxes of every legend of ``fig`` worked out once within the block (a draw of a finished figure).

    A legend is a tree of offset boxes (a packer of columns, each a packer of rows, each a packer
    of a handle's drawing area and a text area), and matplotlib works out the size of every box of
    it from its children's at each level of the draw: the legend's extent first (the whole tree),
    then each box again when it is drawn (its own subtree), a text's size as often as it has
    ancestors. Within the block the second time takes the first's, per renderer: nothing a box's
    size reads (texts, handle sizes, pads in points, dpi) changes during a draw, only where the
    boxes are put (their offsets, not part of a size). The same numbers, so the same pixels
    (``tests/test_plot_render.py``).
    """
    from matplotlib.offsetbox import OffsetBox

    patched: list[tuple[Any, str]] = []

    def once(box: Any, name: str) -> None:
        own = getattr(box, name)
        memo: dict[int, Any] = {}

        def call(renderer: Any) -> Any:
            key = id(renderer)
            if key not in memo:
                memo[key] = own(renderer)
            return memo[key]

        setattr(box, name, call)
        patched.append((box, name))

    def walk(box: Any) -> None:
        if not isinstance(box, OffsetBox):
            return
        once(box, "get_bbox")
        name = "_get_bbox_and_child_offsets"  # private: untyped
        if getattr(type(box), name) is not getattr(OffsetBox, name):
            once(box, name)
        for child in box.get_children():
            walk(child)

    legends = [*(ax.get_legend() for ax in fig.axes), *fig.legends]
    for leg in legends:
        box = getattr(leg, "_legend_box", None)  # private: untyped
        if isinstance(box, OffsetBox):
            walk(box)
    try:
        yield
    finally:
        for box, name in patched:
            del box.__dict__[name]


# ----------------------------------------------------------------------------- layout reuse
_DIGITS = str.maketrans("0123456789", "0000000000")


def _fold(text: Any) -> str:
    return str(text).translate(_DIGITS)


def _structure(fig: Figure) -> tuple[Any, ...]:
    """Figure size [px], dpi and the grid place of every axes: which layouts can apply at all."""
    geo = []
    for ax in fig.axes:
        ss = ax.get_subplotspec()
        gs = None if ss is None else ss.get_gridspec()
        geo.append(None if ss is None or gs is None else
                   (ss.get_geometry(), repr(gs.get_height_ratios()), repr(gs.get_width_ratios())))
    return (round(fig.bbox.width), round(fig.bbox.height), float(fig.dpi), tuple(geo))


def _positions(fig: Figure) -> tuple[Any, ...]:
    axes = tuple(tuple(ax.get_position(original=False).bounds) for ax in fig.axes)
    texts = tuple((tuple(np.asarray(t.get_position(), dtype=float)), t.get_verticalalignment()) for t in fig.texts)
    return axes, texts


def _apply(fig: Figure, positions: tuple[Any, ...]) -> None:
    axes, texts = positions
    for ax, bounds in zip(fig.axes, axes, strict=True):
        ax.set_position(bounds, which="both")
        ax.set_in_layout(True)  # set_position takes the axes out of the layout; keep it in
    for t, (xy, va) in zip(fig.texts, texts, strict=True):
        t.set_position(xy)
        t.set_verticalalignment(va)


def _text_key(t: Any, room_px: float | None) -> Any:
    """What a layout reads of a text: folded content, or only its lines and size when it fits ``room_px``."""
    if not t.get_visible() or not t.get_text():
        return None
    s = str(t.get_text())
    size = float(t.get_fontsize())
    if room_px is not None:
        # generous estimate of the widest line (0.7 em per character): narrower than its room, only
        # the height counts
        wide = max(len(line) for line in s.split("\n")) * 0.7 * size * t.figure.dpi / 72.0
        if wide < room_px:
            return ("fits", s.count("\n"), size, t.get_rotation())
    return (_fold(s), size, t.get_rotation(), t.get_in_layout())


def _axis_key(axis: Any, length_px: float, covered: tuple[bool, bool] = (False, False)) -> Any:
    """Tick labels an axis will draw (folded) and where its outermost ones sit, to the pixel.

    ``covered`` (low end, high end): something the layout measures anyway reaches further beyond
    that end than a tick label there can (:func:`_covered`), so how close the label sits to it
    changes nothing and is left out of the key.
    """
    if not axis.get_visible():
        return None
    params = axis.get_tick_params(which="major")
    shown = tuple(sorted((k, bool(v)) for k, v in params.items() if k.startswith("label") and k[5:] in
                         ("top", "bottom", "left", "right")))
    lo, hi = axis.get_view_interval()
    locs = np.asarray(axis.get_majorticklocs(), dtype=float)
    tr = axis.get_transform()
    ends = tr.transform(np.array([min(lo, hi), max(lo, hi)]))
    with np.errstate(all="ignore"):
        t = tr.transform(locs) if locs.size else locs
    span = ends[1] - ends[0]
    inside = (t >= ends[0] - 1e-10 * span) & (t <= ends[1] + 1e-10 * span) if span > 0 else np.zeros(locs.size, bool)
    locs, t = locs[inside], t[inside]
    labels = [_fold(x) for x in axis.get_major_formatter().format_ticks(list(locs))] if locs.size else []
    # a label sticks out of the axes only when it sits within half its extent of an end: half
    # its height along a vertical axis, half its width along a horizontal one
    size = params.get("labelsize")
    if not isinstance(size, (int, float)):
        from matplotlib import rcParams
        from matplotlib.font_manager import FontProperties

        rc = rcParams["xtick.labelsize"] if axis.axis_name == "x" else rcParams["ytick.labelsize"]
        size = FontProperties(size=rc).get_size_in_points()
    em = float(size) * axis.figure.dpi / 72.0
    widest = max((len(x) for x in labels), default=0)
    cap = math.ceil(0.5 * em) if axis.axis_name == "y" else math.ceil(0.2 * em * widest)  # [2 px]
    if t.size and span > 0:
        frac = (t - ends[0]) / span
        # to 2 px: the constrained layout's pads (3 pt) absorb the rest
        near: Any = tuple(None if cov else min(round(float(d) * length_px / 2), cap)
                          for d, cov in zip((frac.min(), 1.0 - frac.max()), covered, strict=True))
    else:
        near = None
    widths = tuple(sorted(set(labels)))  # only the widest matters, and which are at the ends (near)
    return (axis.get_scale(), shown, widths, near, _fold(axis.get_major_formatter().get_offset()),
            _text_key(axis.label, None), axis.get_label_position())


def _layout_key(fig: Figure) -> Any:
    """Everything a constrained layout reads, at the current axes positions; None: do not reuse.

    :func:`_fixed_key` with no axis reserved: every tick label's position counts.
    """
    return _fixed_key(fig, set())


def _titles(ax: Any) -> tuple[Any, ...]:
    """The centre, left and right titles of ``ax`` (matplotlib keeps the last two private)."""
    return (ax.title, *(getattr(ax, name) for name in ("_left_title", "_right_title")))


def _covered(fig: Figure, ax: Any) -> tuple[bool, bool]:
    """Whether the layout measures, below and above ``ax``, something that reaches further out than
    a y tick label at that end can (half its height): x tick labels below (tick, pad and a whole
    label height), a title above (pad and its height), on this axes or another in its grid cell
    (a twin). The layout's margin on a side is the largest extent of everything in the cell.
    """
    ss = ax.get_subplotspec()
    cell = [a for a in fig.axes if a is ax or (ss is not None and a.get_visible() and a.get_subplotspec() == ss)]
    below = above = False
    for a in cell:
        xa = a.xaxis
        if xa.get_visible() and xa.get_ticks_position() in ("bottom", "default") and xa.get_label_position() == "bottom":
            labelled = xa.get_tick_params(which="major").get("labelbottom", True)
            lo, hi = sorted(xa.get_view_interval())
            ticks = np.asarray(xa.get_majorticklocs(), dtype=float)
            below |= bool(labelled and np.any((ticks >= lo) & (ticks <= hi)))
        above |= any(t.get_visible() and t.get_text() for t in _titles(a))
    return below, above


def _reuse_layout(fig: Figure) -> bool:
    """Apply a kept layout whose key this figure has; True when one did (the engine is then off)."""
    for key, positions in reversed(_LAYOUTS.get(_structure(fig), [])):
        _apply(fig, positions)
        try:
            same = _layout_key(fig) == key
        except (ValueError, TypeError, AttributeError):
            same = False
        if same:
            fig.set_layout_engine("none")
            return True
    return False


def _keep_layout(fig: Figure) -> None:
    """Keep the positions of the layout just drawn under this figure's key."""
    try:
        key = _layout_key(fig)
    except (ValueError, TypeError, AttributeError):
        return
    kept = _LAYOUTS.setdefault(key[0], [])
    kept.append((key, _positions(fig)))
    del kept[:-_MAX_LAYOUTS]


# ----------------------------------------------------------------------------- fixed layouts
#: Layouts of :func:`fixed_layout` per process (structure -> [(key, positions)]), newest last.
_FIXED: dict[Any, list[tuple[Any, Any]]] = {}


def fixed_layout(fig: Figure, reserve: list[Axis]) -> bool:
    """Place the axes of ``fig`` as a constrained layout would, the ends of ``reserve`` held free.

    A constrained layout makes room for a tick label that sticks out beyond an end of its axis
    (one within half its height of the end): where the lowest label of a log axis lands changes
    the layout from one measurement to the next, and :func:`render_png` lays such figures out
    again each time (its key holds that distance). Here the layout is computed with the tick
    labels of every axis in ``reserve`` replaced by the widest of its own labels at both ends of
    the axis: the room for a label sticking out there is always kept, and the positions depend
    on what the layout measures (figure size and dpi, texts, legends, the widest tick label of
    each axis, the others' labels as :func:`render_png` keys them) but not on where those labels
    land. Layouts are kept per process under that key: a figure with the same key is placed
    without running the layout. The figure's layout engine is switched off (the positions are
    for its current size and dpi: set the dpi it will be drawn at first).

    Parameters
    ----------
    fig : Figure
        A finished figure (texts, limits and ticks final) on a gridspec.
    reserve : list of Axis
        Axes' axes whose outermost tick labels must not move the layout (log magnitude axes).

    Returns
    -------
    bool
        True when a kept layout was applied, False when the layout was computed.
    """
    with _locs_once(fig):
        return _fixed_layout(fig, reserve)


def _fixed_layout(fig: Figure, reserve: list[Axis]) -> bool:
    from matplotlib.layout_engine import ConstrainedLayoutEngine

    engine = fig.get_layout_engine()
    ids = {id(a) for a in reserve}
    structure = _structure(fig)
    for key, positions in reversed(_FIXED.get(structure, [])):
        _apply(fig, positions)
        if _fixed_key(fig, ids) == key:
            fig.set_layout_engine("none")
            return True
    layout = engine if isinstance(engine, ConstrainedLayoutEngine) else ConstrainedLayoutEngine()
    proxies = [p for p in (_proxy_ends(a) for a in reserve) if p is not None]
    # an axis whose ends cannot be held free (no major label, labelled minor ticks): laid out as
    # it is, and not kept (its key does not say where its labels sit)
    keep = len(proxies) == sum(1 for a in reserve if a.get_visible() and a.axes.get_visible())
    off = _minor_off(fig)  # nothing the layout measures
    try:
        with _figure_ticks_once(fig):
            layout.execute(fig)
    finally:
        _minor_on(off)
        for axis, saved in proxies:
            axis.set_major_locator(saved[0])
            axis.set_major_formatter(saved[1])
            axis.isDefault_majloc, axis.isDefault_majfmt = saved[2], saved[3]
    fig.set_layout_engine("none")
    if keep:
        kept = _FIXED.setdefault(structure, [])
        kept.append((_fixed_key(fig, ids), _positions(fig)))
        del kept[:-_MAX_LAYOUTS]
    return False


def _fixed_key(fig: Figure, reserve: set[int]) -> Any:
    """What :func:`fixed_layout` measures: :func:`_layout_key` without where the labels of
    ``reserve`` (ids of Axis objects) sit (their ends counted as covered)."""
    keys: list[Any] = [_structure(fig)]
    keys.append(tuple(_text_key(t, fig.bbox.width * 0.9) for t in fig.texts))
    for ax in fig.axes:
        if not ax.get_visible():
            keys.append(None)
            continue
        box = ax.get_window_extent()
        heads = _titles(ax)
        titles = tuple(_text_key(t, box.width * 0.95) for t in (*heads, *ax.texts) if t in heads or not t.get_clip_on())
        leg = ax.get_legend()
        legend = None if leg is None else (tuple(_fold(x.get_text()) for x in leg.get_texts()),
                                           tuple(leg.get_bbox_to_anchor().bounds), leg.get_visible())
        cov_y = (True, True) if id(ax.yaxis) in reserve else _covered(fig, ax)
        cov_x = (True, True) if id(ax.xaxis) in reserve else (False, False)
        # a reserved axis with labelled minor ticks is laid out as it is (:func:`_proxy_ends`)
        minor = tuple(_minor_labelled(a) for a in (ax.xaxis, ax.yaxis) if id(a) in reserve)
        keys.append((ax.get_in_layout(), titles, legend, _axis_key(ax.xaxis, box.width, cov_x),
                     _axis_key(ax.yaxis, box.height, cov_y), minor))
    return tuple(keys)


def _minor_labelled(axis: Axis) -> bool:
    """Whether a log axis draws labelled minor ticks (a span of about a decade or less)."""
    return bool(axis.get_scale() == "log" and _unlabelled_minor(axis) is None and axis.get_minorticklocs().size)


def _proxy_ends(axis: Axis) -> tuple[Axis, tuple[Any, Any, bool, bool]] | None:
    """Put the widest of ``axis``' tick labels at both ends of it (for a layout); what to restore."""
    from matplotlib.ticker import FixedFormatter, FixedLocator

    if not axis.get_visible() or not axis.axes.get_visible():
        return None
    if _minor_labelled(axis):
        return None  # they can stick out too, and be wider
    lo, hi = sorted(axis.get_view_interval())
    locs = [x for x in np.asarray(axis.get_majorticklocs(), dtype=float) if lo <= x <= hi]
    labels = axis.get_major_formatter().format_ticks(locs) if locs else []
    if not any(labels):
        return None
    widest = max(labels, key=lambda s: len(_fold(s)))
    saved = (axis.get_major_locator(), axis.get_major_formatter(), axis.isDefault_majloc, axis.isDefault_majfmt)
    axis.set_major_locator(FixedLocator([lo, hi]))
    axis.set_major_formatter(FixedFormatter([widest, widest]))
    return axis, saved

