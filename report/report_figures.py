"""Figures for a paper: every figure is one column (3.3 in) or two columns (7 in) wide, saved as a
PNG of exactly width_in x height_in x DPI pixels and as a vector PDF with its fonts embedded
(TrueType, not Type 3); curves use the Okabe-Ito colour-blind-safe palette with a line style
each; no text overlaps other text or leaves the figure (checked here at save time and recorded
in figures.json, which tests/report/ reads).

This module holds what every figure shares: the style, measured text, legend layout, saving
with its text checks, image reading and bar fills. The figures themselves: report_grids.py
(image grids), report_probe_figures.py (probe curves and bars), report_metric_figures.py
(metric bars and comparative answers), report_charts.py (parameter charts).
"""

import functools
import hashlib
import io
import math
import os
import re
import struct
import types
import zlib

import matplotlib

matplotlib.use("Agg")  # Files only: no display.
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.backends import _backend_pdf_ps  # noqa: E402
import numpy as np  # noqa: E402
import PIL.Image  # noqa: E402

import png_codec  # noqa: E402
from report_util import temporary_path  # noqa: E402

# The version whose internals the drawing shortcuts below replace or follow (use_matplotlib_text,
# ticks_in_view, report_grids.add_tile); on any other, matplotlib's own code runs.
MATPLOTLIB_3_6 = matplotlib.__version__.startswith("3.6.")

DPI = 200
COLUMN_IN = 3.3  # One column of a two-column paper (ACM, IEEE: 3.3-3.5 in).
PAGE_IN = 7.0    # Both columns.
FONT_PT = 7      # Text at the printed size (captions of the paper itself are ~8-9 pt).

plt.rcParams.update({
    "pdf.fonttype": 42,  # TrueType fonts embedded in the PDF (journals reject Type 3).
    "ps.fonttype": 42,
    "font.family": "DejaVu Sans",
    "font.size": FONT_PT,
    "axes.titlesize": FONT_PT + 1,
    "axes.labelsize": FONT_PT,
    "xtick.labelsize": FONT_PT - 1,
    "ytick.labelsize": FONT_PT - 1,
    "legend.fontsize": FONT_PT - 1,
    "axes.linewidth": 0.6,
    "lines.linewidth": 1.2,
    "svg.fonttype": "none",
})

# Okabe and Ito 2008, "Color Universal Design": distinguishable with any colour vision
# deficiency. Black is kept for the reference; fits take the others in study order, each with
# its own line style so the curves also separate in greyscale.
OKABE_ITO = ["#E69F00", "#56B4E9", "#009E73", "#0072B2", "#D55E00", "#CC79A7", "#F0E442"]
LINE_STYLES = ["-", "--", "-.", ":", (0, (5, 1, 1, 1)), (0, (3, 1, 1, 1, 1, 1)), (0, (1, 1))]
UNITS_RADIANCE = "W m\u207b\u00b2 sr\u207b\u00b9"  # W m^-2 sr^-1, as Unicode superscripts.


def style_of(label, labels):
    """Colour and line style of the i-th fit; distinct pairs for up to 49 fits (the style steps
    once more on each pass through the colours)."""
    i = labels.index(label) if label in labels else len(labels)
    n = len(OKABE_ITO)
    return {"color": OKABE_ITO[i % n], "linestyle": LINE_STYLES[(i + i // n) % len(LINE_STYLES)]}


# --- Measured text ------------------------------------------------------------------------------
# Layouts are computed in inches from the widths of the texts they hold, so a study with many fits
# or long labels gets more legend rows or a taller margin instead of text on text.


def text_width_in(text, fontsize):
    """Width in inches of one line (the widest line of a multi-line text) in the figure font."""
    return _line_widths_in(str(text), fontsize, tuple(plt.rcParams["font.family"]))


@functools.lru_cache(maxsize=1 << 14)
def _line_widths_in(text, fontsize, family):
    # Remembered: wrapping a grid's column titles measures the same label at every width tried.
    props = matplotlib.font_manager.FontProperties(family=list(family), size=fontsize)
    renderer = _measuring_renderer()
    return max(renderer.get_text_width_height_descent(line, props, ismath=False)[0]
               for line in text.split("\n")) / 72.0


def _measuring_renderer():
    global _RENDERER
    if _RENDERER is None:
        from matplotlib.backends.backend_agg import RendererAgg
        _RENDERER = RendererAgg(10, 10, 72)  # 72 dpi: one pixel is one point.
    return _RENDERER


_RENDERER = None


def legend_layout(names, width_in, fontsize=FONT_PT - 1, handlelength=2.0, handletextpad=0.8,
                  columnspacing=2.0, max_cols=None):
    """(columns, rows, height in inches) of a frameless legend of `names` no wider than
    width_in: as many columns as fit, at most max_cols. matplotlib fills the columns in order,
    the first n % columns of them one name longer than the others (4 names in 3 columns: 2, 1,
    1)."""
    n = len(names)
    if n == 0:
        return 1, 0, 0.0
    em = fontsize / 72.0
    widths = [text_width_in(x, fontsize) for x in names]
    cols = 1
    for c in range(min(n, max_cols or n), 0, -1):
        short, long_cols = divmod(n, c)
        starts = [k * short + min(k, long_cols) for k in range(c + 1)]
        used = sum(max(widths[a:b]) + (handlelength + handletextpad) * em
                   for a, b in zip(starts, starts[1:]))
        # Border padding 0.4 em each side (legend.borderpad), and a little slack.
        if used + (c - 1) * columnspacing * em + 0.8 * em + 0.05 <= width_in:
            cols = c
            break
    rows = -(-n // cols)
    # A row is a line of text (1.2 em) and 0.5 em between rows (legend.labelspacing).
    return cols, rows, (rows * 1.2 + (rows - 1) * 0.5 + 0.8) * em


# --- Saving and checking ------------------------------------------------------------------------


def drawn_texts(fig):
    """The texts a renderer draws: figure texts, legends, axes titles, labels and texts, and the
    tick labels of the ticks inside the view (matplotlib keeps labels of ticks outside it)."""
    texts = list(fig.texts) + [t for lg in fig.legends for t in lg.get_texts()]
    if fig._suptitle is not None:
        texts.append(fig._suptitle)
    for ax in fig.axes:
        if not ax.get_visible():
            continue
        texts += [ax.title, ax._left_title, ax._right_title, ax.xaxis.label, ax.yaxis.label]
        texts += list(ax.texts)
        if ax.get_legend() is not None:
            texts += list(ax.get_legend().get_texts())
        for axis in (ax.xaxis, ax.yaxis):
            # The ticks this figure's last drawing drew (text_problems draws it just before),
            # else made again.
            drawn = axis.__dict__.get("_drawn_ticks")
            for tick in drawn if drawn is not None else axis._update_ticks():
                texts += [t for t in (tick.label1, tick.label2) if t.get_visible()]
        texts.append(ax.yaxis.get_offset_text())
        texts.append(ax.xaxis.get_offset_text())
    unique = {id(t): t for t in texts}
    return [t for t in unique.values() if t.get_visible() and t.get_text().strip()]


def text_problems(fig):
    """Pairs of overlapping texts and texts outside the figure, in pixels at the figure's DPI."""
    for ax in fig.axes:  # what an earlier drawing of a kept figure recorded (_tick_boxes)
        for axis in (ax.xaxis, ax.yaxis):
            axis.__dict__.pop("_drawn_ticks", None)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = []
    for t in drawn_texts(fig):
        bb = t.get_window_extent(renderer)
        if bb.width > 0 and bb.height > 0:
            boxes.append((t.get_text().replace("\n", " "), bb))
    w, h = fig.get_size_inches() * fig.dpi
    outside = [s for s, b in boxes if b.x0 < -0.5 or b.y0 < -0.5 or b.x1 > w + 0.5 or b.y1 > h + 0.5]
    # Every pair (i < j, in that order): touching is fine; a shared strip wider than a pixel both
    # ways is an overlap.
    x0, y0, x1, y1 = np.array([[b.x0, b.y0, b.x1, b.y1] for _, b in boxes]).reshape(-1, 4).T
    shared = ((np.minimum.outer(x1, x1) - np.maximum.outer(x0, x0) > 1)
              & (np.minimum.outer(y1, y1) - np.maximum.outer(y0, y0) > 1))
    pairs = zip(*np.nonzero(np.triu(shared, k=1)))
    overlaps = [[boxes[i][0], boxes[j][0]] for i, j in pairs]
    return overlaps, outside


def warm_up():
    """Loads what every figure needs once (the font and its glyphs, the Agg and PDF backends) by
    drawing a small figure with text to memory, so that worker processes forked after it share
    it instead of each loading it again."""
    fig = plt.figure(figsize=(1, 1))
    fig.text(0.1, 0.5, "Warm-up 0123456789 abcdefghijklmnopqrstuvwxyz", fontsize=FONT_PT)
    fig.canvas.draw()
    fig.savefig(io.BytesIO(), format="pdf")
    plt.close(fig)


# --- The PDF's embedded font ----------------------------------------------------------------------
# matplotlib subsets the TrueType font (fontTools) for every PDF it writes: 60-90 ms per figure,
# a tenth of the report's drawing time, and the figures of a study use a few sets of characters
# over and over (the same labels, digits and units). The subset is a pure function of the font
# file and the set of characters (fontTools takes them as a set; matplotlib passes a Python set's
# order, which differs between equal sets), so a subset made once per set is the same bytes:
# remembered per process, and shared between the report's processes through a folder
# (share_font_subsets), where each would otherwise make the same ones again.
_FONT_SUBSETS = {}
_SUBSET_FONT = _backend_pdf_ps.get_glyphs_subset
_FONT_SUBSET_DIR = None


def share_font_subsets(folder):
    """Font subsets are read from and written to `folder` (None: this process's memory only).
    Set before the figure workers fork; the caller removes the folder."""
    global _FONT_SUBSET_DIR
    _FONT_SUBSET_DIR = folder


def _font_subset(fontfile, characters):
    """matplotlib's get_glyphs_subset, remembered per (font file, set of characters); a set the
    base subset holds is widened to SUBSET_COMMON_CHARACTERS first."""
    characters = set(characters)
    if _FONT_SUBSET_DIR and SUBSET_BASE_CHARACTERS.issuperset(characters):
        characters |= SUBSET_COMMON_CHARACTERS
    key = (fontfile, "".join(sorted(characters)))
    data = _FONT_SUBSETS.get(key)
    if data is not None:
        return io.BytesIO(data)
    path = None
    if _FONT_SUBSET_DIR:
        path = os.path.join(_FONT_SUBSET_DIR,
                            hashlib.sha256(repr(key).encode()).hexdigest() + ".ttf")
        data = _read_bytes(path)
    if data is None:
        data = _SUBSET_FONT(_subset_source(fontfile, key[1]), key[1]).getvalue()
        if path:
            _write_bytes(path, data)
    _FONT_SUBSETS[key] = data
    return io.BytesIO(data)


# Most figures still use a set of characters of their own (a material's name, the numbers of its
# ticks), so most subsets are made once: from the whole font, fontTools reads ~6000 glyphs and
# their tables for each (70-100 ms). They are made instead from a subset of the font to every
# character the figures' words use (SUBSET_BASE_CHARACTERS, made once per report: ~100 glyphs,
# 10-30 ms a subset). Subsetting that subset gives the same bytes as subsetting the whole font:
# fontTools keeps the glyphs' order and prunes the tables to what the characters reach, the same
# either way (figure_cache_test compares the two over many sets). A set with a character outside
# it is made from the whole font.
SUBSET_BASE_CHARACTERS = frozenset(chr(c) for c in range(32, 127)) | frozenset(
    "\u00b0\u00b1\u00b2\u00b3\u00b9\u00d7\u2013\u2014\u2212\u207b\u2070\u2074\u2075\u2076"
    "\u2077\u2078\u2079\u03b1\u03b8\u03c6\u03c1")
# Still, the measured report's 213 figures used 60 sets (a material's name, its ticks' numbers):
# 60 subsets of ~25 ms. Widened to the lower-case letters, digits and common punctuation that
# most figures use anyway, they are 13 sets (the report's PDFs 35.48 -> 35.75 MB in all, ~1.3 KB
# a file). The PDF draws the same glyphs (its widths and character map are still the figure's
# characters').
SUBSET_COMMON_CHARACTERS = frozenset("abcdefghijklmnopqrstuvwxyz0123456789 .,:;-+()=/%_")


def _subset_source(fontfile, characters):
    """The font file to subset to `characters`: the font's base subset (in the shared folder,
    made by the first process that needs it) where it holds every one of them, else the font."""
    if (not _FONT_SUBSET_DIR or fontfile.endswith(".ttc")
            or not SUBSET_BASE_CHARACTERS.issuperset(characters)):
        return fontfile
    path = os.path.join(_FONT_SUBSET_DIR,
                        "base-" + hashlib.sha256(fontfile.encode()).hexdigest() + ".ttf")
    if not os.path.exists(path):
        _write_bytes(path, _SUBSET_FONT(fontfile, "".join(sorted(SUBSET_BASE_CHARACTERS)))
                     .getvalue())
    return path if os.path.exists(path) else fontfile  # not written (a full disk): the font


def _read_bytes(path):
    try:
        with open(path, "rb") as f:
            return f.read()
    except OSError:
        return None


def _write_bytes(path, data):
    """Whole or absent for a reader in another process."""
    tmp = f"{path}.{os.getpid()}.tmp"
    try:
        with open(tmp, "wb") as f:
            f.write(data)
        os.replace(tmp, path)
    except OSError:
        pass


_backend_pdf_ps.get_glyphs_subset = _font_subset


# --- Text laid out once per process -----------------------------------------------------------------
# matplotlib remembers a text's extent and a parsed math text per renderer, and every figure (and
# each of its two files) gets a new renderer: the report's ~200 figures measured the same tick
# labels, fit labels and units ~50000 times, and parsed the log axes' "10^-2" labels (pyparsing)
# ~1000 times. Each is a pure function of the renderer's kind and resolution, the text and its
# font (Agg: RendererAgg.get_text_width_height_descent and draw_text read nothing else; the PDF
# renderer measures at 72 points per inch whatever the figure), so remembered per process they
# give the same numbers and the same pixels (issue 46 item 2: PNG pixels and PDF bytes unchanged).
# Only renderers known to be pure are shared; anything else goes through matplotlib's own cache.
from matplotlib import mathtext as _mathtext  # noqa: E402
from matplotlib import text as _mtext  # noqa: E402
from matplotlib.backends import backend_agg as _backend_agg  # noqa: E402
from matplotlib.backends import backend_pdf as _backend_pdf  # noqa: E402
from matplotlib.ft2font import KERNING_DEFAULT  # noqa: E402
try:
    from matplotlib import _text_helpers  # noqa: E402
except ImportError:  # another matplotlib: its own layout, every time
    _text_helpers = None

_PURE_RENDERERS = (_backend_agg.RendererAgg, _backend_pdf.RendererPdf)
_TEXT_METRICS = _mtext._get_text_metrics_with_cache


_TEXT_METRICS_RENDERER = {}
_TEXT_METRICS_SEEN = {}
_TEXT_METRICS_AT_MOST = 1 << 15


def _font_key(fontprop):
    """What a FontProperties' hash and equality read (matplotlib 3.6), as a tuple: a key made
    without copying the properties and hashed once (hashing them, the cache's lookups took a
    third of the time they saved)."""
    return (tuple(fontprop.get_family()), fontprop.get_slant(), fontprop.get_variant(),
            fontprop.get_weight(), fontprop.get_stretch(), fontprop.get_size(),
            fontprop.get_file(), fontprop.get_math_fontfamily())


def _shared_text_metrics(renderer, text, fontprop, ismath, dpi):
    """matplotlib.text._get_text_metrics_with_cache, remembered across renderers of one kind."""
    kind = type(renderer)
    if kind not in _PURE_RENDERERS or ismath == "TeX":
        return _TEXT_METRICS(renderer, text, fontprop, ismath, dpi)
    key = (kind, renderer.dpi, text, _font_key(fontprop), ismath, dpi,
           str(plt.rcParams["text.hinting"]))
    metrics = _TEXT_METRICS_SEEN.get(key)
    if metrics is None:
        # The renderer that measures is any one of its kind at its resolution (kept alive here).
        measuring = _TEXT_METRICS_RENDERER.setdefault((kind, renderer.dpi), renderer)
        metrics = measuring.get_text_width_height_descent(text, fontprop.copy(), ismath)
        if len(_TEXT_METRICS_SEEN) >= _TEXT_METRICS_AT_MOST:
            _TEXT_METRICS_SEEN.clear()
        _TEXT_METRICS_SEEN[key] = metrics
    return metrics


# A text's layout (Text._get_layout: its lines' sizes and offsets and its box around the anchor)
# is a function of the text, its font, line spacing, rotation, alignments and rotation mode, the
# figure's resolution and the measures above; the report lays out the same tick labels, legend
# entries and titles ~20000 times per 8 materials, each time measuring every line again and
# rotating its box with a new Affine2D. Remembered per process under those properties (the
# callers read the layout's box and lines and never change them).
_TEXT_LAYOUT = _mtext.Text._get_layout
_TEXT_LAYOUTS = {}


def _shared_layout(self, renderer):
    """Text._get_layout (matplotlib 3.6) remembered across texts and renderers of one kind."""
    kind = type(renderer)
    if kind not in _PURE_RENDERERS or self.get_usetex():
        return _TEXT_LAYOUT(self, renderer)
    key = (kind, renderer.dpi, self.get_text(), _font_key(self._fontproperties),
           self._linespacing, self.figure.dpi, self.get_rotation(), self._get_multialignment(),
           self._horizontalalignment, self._verticalalignment, self.get_rotation_mode(),
           self.get_parse_math(), str(plt.rcParams["text.hinting"]))
    layout = _TEXT_LAYOUTS.get(key)
    if layout is None:
        layout = _TEXT_LAYOUT(self, renderer)
        if len(_TEXT_LAYOUTS) >= _TEXT_METRICS_AT_MOST:
            _TEXT_LAYOUTS.clear()
        _TEXT_LAYOUTS[key] = layout
    return layout


_PARSE_CACHED = _mathtext.MathTextParser._parse_cached


@functools.lru_cache(maxsize=1024)
def _math_parse(output_type, s, dpi, prop, hinting, antialiased):
    return _PARSE_CACHED.__wrapped__(_MATH_PARSERS[output_type], s, dpi, prop)


_MATH_PARSERS = {}


def _shared_math_parse(self, s, dpi, prop):
    """MathTextParser._parse_cached remembered across parsers of one output type (it reads only
    the type, the text, the resolution, the font and the hinting and antialiasing settings)."""
    _MATH_PARSERS.setdefault(self._output_type, self)
    return _math_parse(self._output_type, s, dpi, prop, str(plt.rcParams["text.hinting"]),
                       bool(plt.rcParams["text.antialiased"]))


@functools.lru_cache(maxsize=1 << 13)
def _glyph_bitmap(s, prop, dpi, hinting_flag, antialiased):
    """The bitmap RendererAgg.draw_text draws for `s` (a copy), its descent and offset."""
    font = _backend_agg.get_font(_backend_agg._fontManager._find_fonts_by_props(prop))
    font.clear()
    font.set_size(prop.get_size_in_points(), dpi)
    font.set_text(s, 0, flags=hinting_flag)
    font.draw_glyphs_to_bitmap(antialiased=antialiased)
    xo, yo = font.get_bitmap_offset()
    return np.array(font.get_image(), dtype=np.uint8), font.get_descent() / 64.0, xo / 64.0, yo / 64.0


def _agg_draw_text(self, gc, x, y, s, prop, angle, ismath=False, mtext=None):
    """RendererAgg.draw_text (matplotlib 3.6) with the glyph bitmap remembered per text, font,
    size and resolution: the same arithmetic on the same bitmap."""
    if ismath:
        return self.draw_mathtext(gc, x, y, s, prop, angle)
    image, d, xo, yo = _glyph_bitmap(s, prop.copy(), self.dpi, _backend_agg.get_hinting_flag(),
                                     bool(plt.rcParams["text.antialiased"]))
    xd = d * math.sin(math.radians(angle))
    yd = d * math.cos(math.radians(angle))
    x = round(x + xo + xd)
    y = round(y + yo + yd)
    self._renderer.draw_text_image(image, x, y + 1, angle, gc)


_AGG_DRAW_TEXT = _backend_agg.RendererAgg.draw_text


from matplotlib import markers as _markers  # noqa: E402

_SET_MARKER = _markers.MarkerStyle._set_marker


def _set_marker_from_spec(self, marker):
    """MarkerStyle._set_marker (matplotlib 3.6) that, given another MarkerStyle made from a
    named marker alone (a string or a number: the ticks' markers, "" for none), makes this one
    from the same name, fill style and cap and join styles instead of deep-copying the other's
    dictionary: the same state, since a 3.6 MarkerStyle's state is a function of those (its
    setters are deprecated: it does not change after it is made). Line2D.update_from copies
    every new tick's three lines' markers this way (Axis._copy_tick_props): a fifth of a probe
    figure's drawing went to those deep copies."""
    if (type(marker) is _markers.MarkerStyle and marker._user_transform is None
            and isinstance(marker._marker, (str, int)) and not isinstance(marker._marker, bool)
            and marker._marker in _markers.MarkerStyle.markers):
        self._user_transform = None
        self._user_capstyle = marker._user_capstyle
        self._user_joinstyle = marker._user_joinstyle
        self._fillstyle = marker._fillstyle
        return _SET_MARKER(self, marker._marker)
    return _SET_MARKER(self, marker)


# --- A legend laid out once per drawing ----------------------------------------------------------
# A legend is a tree of packers (offsetbox: VPacker, HPacker, PaddedBox) over its entries' text
# and handle boxes. Drawing it measures the tree for its window extent, then each packer measures
# its subtree again to place its children, and each child its own: a leaf is measured once per
# level above it, ~4 times in a probe figure's legend of ~24 entries. Within one Legend.draw
# nothing a measure reads changes (the texts, their fonts, the renderer and its resolution), so
# each box's extent is measured once and remembered until the draw ends: the same numbers, the
# same pixels and PDF bytes (figure_cache_test draws a legend both ways). A TextArea's measure
# also sets its baseline transform, the same each time. A probe figure's legends: ~6% of its
# drawing, both files.
from matplotlib import legend as _mlegend  # noqa: E402
from matplotlib import offsetbox as _offsetbox  # noqa: E402

_LEGEND_EXTENTS = None  # {(box id, method): its result} while a legend draws
_EXTENT_METHODS = [(cls, name, getattr(cls, name)) for cls, name in (
    (_offsetbox.HPacker, "get_extent_offsets"), (_offsetbox.VPacker, "get_extent_offsets"),
    (_offsetbox.PaddedBox, "get_extent_offsets"), (_offsetbox.TextArea, "get_extent"),
    (_offsetbox.DrawingArea, "get_extent"))]
_LEGEND_DRAW = _mlegend.Legend.draw


def _remembered_extent(name, measure):
    def extent(self, renderer):
        memo = _LEGEND_EXTENTS
        if memo is None:
            return measure(self, renderer)
        key = (id(self), name)
        if key not in memo:
            memo[key] = measure(self, renderer)
        return memo[key]
    return extent


def _legend_draw_once(self, renderer):
    """Legend.draw with every box of the legend measured once (see above)."""
    global _LEGEND_EXTENTS
    if _LEGEND_EXTENTS is not None:  # a legend inside a legend: the outer one's memo
        return _LEGEND_DRAW(self, renderer)
    _LEGEND_EXTENTS = {}
    try:
        return _LEGEND_DRAW(self, renderer)
    finally:
        _LEGEND_EXTENTS = None


_legend_draw_once._supports_rasterization = True  # as matplotlib's (allow_rasterization)


# --- An axis's tick label boxes measured once per drawing ---------------------------------------
# Axis.draw measures its tick labels' boxes (to place the offset text), draws the ticks, then
# places its label clear of the labels of the axes aligned with it (Figure.align_xlabels): for
# an axis aligned with no other, that makes its ticks again and measures the same boxes a
# second time (~3% of the report's drawing). The ticks' drawing between the two changes neither
# (matplotlib 3.6): such an axis takes the boxes its drawing measured first.
from matplotlib import axis as _maxis  # noqa: E402

_AXIS_DRAW = _maxis.Axis.draw
_TICK_BOXES = _maxis.Axis._get_ticklabel_bboxes
_SIBLING_BOXES = _maxis.Axis._get_tick_boxes_siblings


def _axis_draw(self, renderer, *args, **kwargs):
    """Axis.draw, remembering the first tick label boxes it measures (_tick_boxes)."""
    self._drawn_boxes = []
    try:
        return _AXIS_DRAW(self, renderer, *args, **kwargs)
    finally:
        del self._drawn_boxes


_axis_draw._supports_rasterization = True  # as matplotlib's (allow_rasterization)


def _tick_boxes(self, ticks, renderer=None):
    """Axis._get_ticklabel_bboxes; the first call of an axis's drawing also records its boxes
    (_sibling_boxes) and its ticks (drawn_texts: the ticks the drawing drew)."""
    boxes = _TICK_BOXES(self, ticks, renderer)
    drawn = self.__dict__.get("_drawn_boxes")
    if drawn == [] and renderer is not None:
        drawn.append((renderer, boxes))
        self._drawn_ticks = ticks
    return boxes


def _sibling_boxes(self, renderer):
    """Axis._get_tick_boxes_siblings: inside this axis's drawing, when it is aligned with no
    other axis, the boxes that drawing measured; otherwise matplotlib's."""
    drawn = self.__dict__.get("_drawn_boxes")
    if drawn and drawn[0][0] is renderer:
        names = [name for name, axis in self.axes._axis_map.items()
                 if name in self.figure._align_label_groups and axis is self]
        if (len(names) == 1 and self.figure._align_label_groups[names[0]].get_siblings(
                self.axes) == [self.axes]):
            tlb1, tlb2 = drawn[0][1]
            return list(tlb1), list(tlb2)
    return _SIBLING_BOXES(self, renderer)


# An axes with a title places it clear of its y axis's offset text ("1e6", "+1e6") when they
# would overlap (Axes._update_title_position); to know that text, it asks the y axis for its
# whole tight box: the ticks made, their labels measured, the label placed (3.6 ms an axes, ~1.2
# of the measured report's ~42 CPU-s), all of which the axis's drawing does again. The text and
# its place need less: the major formatter given the major locations (as the ticks' update
# leaves it) and YAxis' place for it, above the axes (which reads no tick label box). The same
# text at the same place: the title where matplotlib puts it.
from matplotlib.axes import _base as _axes_base  # noqa: E402

_TITLE_POSITION = _axes_base._AxesBase._update_title_position


def _y_offset_text(axis, renderer=None, **kwargs):
    """What YAxis.get_tightbbox leaves of the offset text, without the box."""
    if not axis.get_visible():
        return None
    formatter = axis.major.formatter
    formatter.set_locs(axis.get_majorticklocs())
    axis._update_offset_text_position([], [])
    axis.offsetText.set_text(formatter.get_offset())
    return None  # the title's placement reads only the offset text


def _title_position(self, renderer):
    """Axes._update_title_position, its y axes' offset texts made by _y_offset_text."""
    taken = []
    for ax in self._twinned_axes.get_siblings(self) + self.child_axes:
        y = ax.yaxis
        if (type(y) is _maxis.YAxis and type(y).get_tightbbox is _maxis.Axis.get_tightbbox
                and "get_tightbbox" not in y.__dict__):
            y.get_tightbbox = functools.partial(_y_offset_text, y)
            taken.append(y)
    try:
        return _TITLE_POSITION(self, renderer)
    finally:
        for y in taken:
            del y.get_tightbbox


# Axes.add_patch widens the data limits by the patch's path: for a bar (a Rectangle, its path
# the unit square) it splits the square into four Bezier segments, finds their extrema and
# evaluates them, then works out the patch transform left of the axes' data transform: ~0.2 ms a
# bar, half a bar chart's making (~5600 bars in the measured report). Those vertices are the same
# for every Rectangle (found once, the same way), and for one drawn in the axes' data coordinates
# what is left of its transform is its patch transform: the same points, the same limits.
from matplotlib import patches as _mpatches  # noqa: E402
from matplotlib import path as _mpath  # noqa: E402

_PATCH_LIMITS = _axes_base._AxesBase._update_patch_limits
_UNIT_SQUARE = _mpath.Path.unit_rectangle()


@functools.lru_cache(maxsize=1)
def _unit_square_points():
    """The vertices Axes._update_patch_limits finds on the unit square (matplotlib 3.6's way)."""
    points = []
    for curve, _ in _UNIT_SQUARE.iter_bezier(simplify=False):
        _, extrema = curve.axis_aligned_extrema()
        points.append(curve([0, *extrema, 1]))
    return np.row_stack(points)


def _patch_limits(self, patch):
    if (type(patch) is _mpatches.Rectangle and self.name == "rectilinear"
            and patch.get_path() is _UNIT_SQUARE and patch._transform is self.transData):
        if not patch.get_width() and not patch.get_height():
            return  # as matplotlib: a rectangle of no size widens nothing
        self.update_datalim(patch.get_patch_transform().transform(_unit_square_points()))
        return
    _PATCH_LIMITS(self, patch)


def use_matplotlib_text(own):
    """own=True: matplotlib's own text measuring and layout, math parsing, Agg text drawing,
    marker copies, legend layout, tick label boxes, titles' places and bars' data limits (for the
    tests that the shortcuts above draw the same pixels and bytes); False: the shortcuts (on
    3.6)."""
    if own or not MATPLOTLIB_3_6:
        _mtext._get_text_metrics_with_cache = _TEXT_METRICS
        _mtext.Text._get_layout = _TEXT_LAYOUT
        _mathtext.MathTextParser._parse_cached = _PARSE_CACHED
        _backend_agg.RendererAgg.draw_text = _AGG_DRAW_TEXT
        _markers.MarkerStyle._set_marker = _SET_MARKER
        _mlegend.Legend.draw = _LEGEND_DRAW
        _maxis.Axis.draw = _AXIS_DRAW
        _maxis.Axis._get_ticklabel_bboxes = _TICK_BOXES
        _maxis.Axis._get_tick_boxes_siblings = _SIBLING_BOXES
        _axes_base._AxesBase._update_title_position = _TITLE_POSITION
        _axes_base._AxesBase._update_patch_limits = _PATCH_LIMITS
        for cls, name, measure in _EXTENT_METHODS:
            setattr(cls, name, measure)
    else:
        # The functions replaced are matplotlib 3.6's (their bodies copied above where needed);
        # on another version the report runs on matplotlib's own, slower and the same.
        _mtext._get_text_metrics_with_cache = _shared_text_metrics
        _mtext.Text._get_layout = _shared_layout
        _mathtext.MathTextParser._parse_cached = _shared_math_parse
        _backend_agg.RendererAgg.draw_text = _agg_draw_text
        _markers.MarkerStyle._set_marker = _set_marker_from_spec
        _mlegend.Legend.draw = _legend_draw_once
        _maxis.Axis.draw = _axis_draw
        _maxis.Axis._get_ticklabel_bboxes = _tick_boxes
        _maxis.Axis._get_tick_boxes_siblings = _sibling_boxes
        _axes_base._AxesBase._update_title_position = _title_position
        _axes_base._AxesBase._update_patch_limits = _patch_limits
        for cls, name, measure in _EXTENT_METHODS:
            setattr(cls, name, _remembered_extent(name, measure))


use_matplotlib_text(False)


# zlib's level for the figures' PNGs that Pillow writes (the PDF's palette images): 1 instead of
# Pillow's 6 deflates a report's ~200 page-wide figures in about half the time (45 vs 82 ms each)
# for files ~17% larger; the pixels are the same. Our own (png_idat) take png_codec.FAST_LEVEL.
PNG_COMPRESS_LEVEL = 1
PNG_SIGNATURE = png_codec.PNG_SIGNATURE


# --- PNG files and the PDF's images -----------------------------------------------------------
# The figures' PNGs and the PDF's RGB images (Flate streams with PNG predictors) are filtered and
# deflated here rather than by Pillow. Pillow chooses each row's filter by trying the five of the
# PNG format (W3C PNG specification, 2nd ed., sec. 9.2), then deflates: 55 ms for a grid of 1400 x
# 936 pixels at level 1. Every row filtered "Up" (the row above subtracted, modulo 256) is one
# numpy subtraction: 25 ms, and over a measured study's report's figures 3.8 against 10.2 s for
# 1% smaller files (68.5 against 69.3 MB; "None" on every row: 3.5 s, 9% larger). The pixels are
# the same; tests/report/png_test.py decodes them with Pillow.


def png_idat(pixels, level=None):
    """The deflated, filtered scanlines of an 8-bit image of shape (h, w, channels) or (h, w)
    (a PNG's IDAT data): every row filtered Up, the first (whose row above is zeros) as it is."""
    pixels = np.asarray(pixels, dtype=np.uint8)
    if pixels.ndim == 3 and not pixels.flags.c_contiguous:
        # An RGBA buffer's RGB (save_figure's opaque figures) made contiguous a channel at a
        # time: 2 ms for a page-wide figure against 8 ms for numpy's copy of three bytes in four.
        packed = np.empty(pixels.shape, dtype=np.uint8)
        for c in range(pixels.shape[2]):
            packed[..., c] = pixels[..., c]
        pixels = packed
    pixels = np.ascontiguousarray(pixels)
    rows = pixels.reshape(pixels.shape[0], -1)
    lines = np.empty((rows.shape[0], rows.shape[1] + 1), dtype=np.uint8)
    lines[:, 0] = 2  # filter type Up
    lines[0, 1:] = rows[0]
    np.subtract(rows[1:], rows[:-1], out=lines[1:, 1:])  # uint8: modulo 256
    return png_codec.deflate(lines, png_codec.FAST_LEVEL if level is None else level)


def _png_chunk(kind, data):
    return (struct.pack(">I", len(data)) + kind + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def write_png(path, pixels, dpi):
    """`pixels` (h x w x 3 or 4, 8-bit) as an RGB or RGBA PNG at `path`, written to a temporary
    beside it and renamed; its pHYs says `dpi` and its Software text matplotlib's, as
    matplotlib.image.imsave writes them."""
    h, w, channels = pixels.shape
    color_type = {3: 2, 4: 6}[channels]
    ppm = int(dpi / 0.0254 + 0.5)  # pixels per metre
    data = (PNG_SIGNATURE
            + _png_chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, color_type, 0, 0, 0))
            + _png_chunk(b"tEXt", b"Software\0" + (
                f"Matplotlib version{matplotlib.__version__}, https://matplotlib.org/").encode())
            + _png_chunk(b"pHYs", struct.pack(">IIB", ppm, ppm, 1))
            + _png_chunk(b"IDAT", png_idat(pixels))
            + _png_chunk(b"IEND", b""))
    tmp = temporary_path(path)
    with open(tmp, "wb") as f:
        f.write(data)
    os.replace(tmp, path)


# The PDF's images: matplotlib's PdfFile._writePng saves each as a PNG with Pillow at its default
# level, 6, and embeds its IDAT data (a grid's raster, ~1.3 million pixels, pdf_images_as_drawn,
# took ~80 ms). An RGB or gray image's data is png_idat's here; a palette image (matplotlib makes
# one of an image of <= 256 colours, at Pillow's bit depth for their count) is still Pillow's, at
# PNG_COMPRESS_LEVEL. The same pixels.
_PDF_WRITE_PNG = _backend_pdf.PdfFile._writePng


def _pdf_write_png(self, img):
    if img.mode in ("RGB", "L"):
        return png_idat(np.asarray(img)), 8, None
    save = img.save
    img.save = lambda fp, format=None, **params: save(
        fp, format=format, **{"compress_level": PNG_COMPRESS_LEVEL, **params})
    return _PDF_WRITE_PNG(self, img)


_backend_pdf.PdfFile._writePng = _pdf_write_png


class _PdfRaster(matplotlib.artist.Artist):
    """8-bit RGBA pixels (rows from the bottom up) drawn as they are, one pixel per 1/DPI in,
    their lower left corner at (x, y) in `ax`'s data coordinates: for a vector renderer (the
    PDF's draws an image of w x h pixels w x h x 72 / DPI points large). AxesImage would
    resample them (interpolation "nearest", ~identity) or, uninterpolated, stretch them to
    whole points."""

    def __init__(self, ax, rgba, x, y):
        super().__init__()
        self._ax, self._rgba, self._corner = ax, rgba, (x, y)

    def draw(self, renderer):
        if not self.get_visible():
            return
        x, y = self._ax.transData.transform(self._corner)
        gc = renderer.new_gc()
        renderer.draw_image(gc, x, y, self._rgba)
        gc.restore()


def _raster_images(ax):
    """The images of `ax` that the PDF takes as one raster (none where it has fewer than two)."""
    images = [im for im in ax.get_images() if im.get_visible()]
    return images if sum(getattr(im, "tile_count", 1) for im in images) >= 2 else []


def _drawn_raster(fig, images):
    """(x, y, rgba): Agg's pixels over the bounding box of `images` once the figure is drawn,
    rows from the bottom up (as a renderer's draw_image takes them), their lower left corner at
    (x, y) in pixels; None without images or where the box holds no pixel."""
    if not images:
        return None
    renderer = fig.canvas.get_renderer()
    box = matplotlib.transforms.Bbox.union([im.get_window_extent(renderer) for im in images])
    pixels = np.asarray(fig.canvas.buffer_rgba())
    rows, cols = pixels.shape[:2]
    # Agg places an image's rows from its integer height down (RendererAgg::draw_image): pixel
    # row r covers display y from rows - r - 1 to rows - r.
    c0, c1 = max(0, math.floor(box.x0)), min(cols, math.ceil(box.x1))
    r0, r1 = max(0, rows - math.ceil(box.y1)), min(rows, rows - math.floor(box.y0))
    if c1 <= c0 or r1 <= r0:
        return None
    return c0, rows - r1, np.array(pixels[r0:r1, c0:c1][::-1])


def pdf_images_as_drawn(fig, ax):
    """Replaces the images of `ax` (once the figure is drawn at DPI by Agg) by one image for the
    PDF: Agg's pixels over the images' bounding box, embedded as they are (no resampling), at
    the place they cover. A grid's ~70 tiles and colour bars were each resampled for the PDF and
    embedded as an image of their own (encoded, most of them quantised to a palette): half of
    a grid's PDF. The PDF's raster is then the PNG's pixels; its text and lines stay vectors
    over it. Anything Agg drew inside the box (a tile's "missing", the bars' outlines) is in
    the raster too, under its vector. Returns the number of images replaced."""
    images = _raster_images(ax)
    drawn = _drawn_raster(fig, images)
    if drawn is None:
        return 0
    x_px, y_px, rgba = drawn
    x, y = ax.transData.inverted().transform((x_px, y_px))
    for im in images:
        im.set_visible(False)
    raster = _PdfRaster(ax, rgba, x, y)
    raster.set_zorder(-1)  # under the axes, so under every text and line of the figure
    fig.add_artist(raster)
    return len(images)


class _InViewLocator(matplotlib.ticker.Locator):
    """A log axis's tick locator that gives the locations of `locator` in the axis' view and a
    thousandth of its span (in log space) around it. matplotlib makes a tick (three lines and
    two texts, ~1 ms) for every location its locator gives, and draws those in the view; a
    LogLocator gives a decade and more beyond each end (80 minor locations for a view of six
    decades, 42 in it), most of a probe figure's first drawing. The ticks drawn are the same
    (matplotlib keeps those within 1e-10 of the view; it drops a minor location within 1e-5 of
    a major one: both are in the margin): the same pixels and PDF bytes. Its log formatters
    label from the view, not from the locations."""

    def __init__(self, locator):
        self.locator = locator

    def set_axis(self, axis):
        super().set_axis(axis)
        self.locator.set_axis(axis)

    def __call__(self):
        locs = np.asarray(self.locator())
        if locs.ndim != 1 or locs.size == 0:
            return locs
        transform = self.axis.get_transform()
        lo, hi = sorted(transform.transform(np.asarray(self.axis.get_view_interval(), float)))
        if not (math.isfinite(lo) and math.isfinite(hi)):
            return locs
        margin = (hi - lo) * 1e-3
        with np.errstate(divide="ignore", invalid="ignore"):
            t = transform.transform(locs.astype(float))
        return locs[(t >= lo - margin) & (t <= hi + margin)]

    def tick_values(self, vmin, vmax):
        return self.locator.tick_values(vmin, vmax)

    def nonsingular(self, v0, v1):
        return self.locator.nonsingular(v0, v1)

    def view_limits(self, vmin, vmax):
        return self.locator.view_limits(vmin, vmax)


def ticks_in_view(fig):
    """Every log axis of `fig` gets its ticks at the locations in its view only (_InViewLocator),
    on matplotlib 3.6 (the version whose tick code the equality was checked on)."""
    if not MATPLOTLIB_3_6:
        return
    for ax in fig.axes:
        for axis in (ax.xaxis, ax.yaxis):
            for ticker, setter in ((axis.major, axis.set_major_locator),
                                   (axis.minor, axis.set_minor_locator)):
                if isinstance(ticker.locator, matplotlib.ticker.LogLocator):
                    setter(_InViewLocator(ticker.locator))


# --- One drawing for both files ------------------------------------------------------------------
# matplotlib draws a figure twice for its two files: once by Agg at DPI (the PNG, and the drawing
# text_problems measures) and once for the PDF at 72 points per inch, laying everything out again
# (ticks located and formatted, every text measured, legends packed): half of the report's
# drawing time. Here the Agg drawing's calls to its renderer are also kept, in PDF points (every
# position and transform scaled by 72 / DPI; line widths, dashes and font sizes are in points
# for both), and the PDF is written from them by matplotlib's own PDF renderer: the same
# operations in the same order, the same fonts, images and graphics states, placed where the PNG
# places them. matplotlib's own PDF measures its text at 72 dpi with hinting, so its layout moved
# from the PNG's (a probe figure's legend by ~6 pt); this one is the PNG's drawing, the one the
# overlap check measured. tests/report/one_drawing_test.py compares the two PDFs operation by
# operation. A figure that asks for anything else of the renderer (Gouraud shading, a quad mesh,
# TeX, rasterised artists, Agg filters) is drawn for its PDF by matplotlib as before.
ONE_DRAWING = MATPLOTLIB_3_6

_TO_POINTS = np.diag([72.0 / DPI, 72.0 / DPI, 1.0])
_KEPT_CALLS = ("draw_path", "draw_markers", "draw_path_collection", "draw_image", "draw_text")
_OTHER_CALLS = ("draw_gouraud_triangle", "draw_gouraud_triangles", "draw_quad_mesh", "draw_tex",
                "start_rasterizing", "start_filter")


def _in_points(transform):
    """An affine transform to Agg's pixels, to PDF points instead."""
    return matplotlib.transforms.Affine2D(_TO_POINTS @ transform.get_matrix())


class _PdfCalls:
    """The calls an Agg renderer gets while it draws one figure, kept in PDF points (install()
    before the drawing, remove() after it), then made on a PDF renderer (write()). `png_only`:
    while > 0, calls are Agg's alone (a grid's tiles, which the PDF takes as one raster)."""

    def __init__(self, renderer):
        self.renderer, self.calls, self.complete, self.png_only = renderer, [], True, 0
        # Clip boxes and paths by the identity of Agg's: the PDF renderer sets a clip again only
        # where a call's object is another (GraphicsContextPdf.delta), as in its own drawing.
        # The originals are kept, so that no id is reused while the figure draws.
        self._clips = {}

    def install(self):
        r = self.renderer
        for name in _KEPT_CALLS:
            setattr(r, name, functools.partial(self._kept, name, getattr(r, name)))
        for name in _OTHER_CALLS:
            setattr(r, name, functools.partial(self._other, getattr(r, name)))

    def remove(self):
        r = self.renderer
        for name in _KEPT_CALLS + _OTHER_CALLS:
            del r.__dict__[name]
        r._update_methods()  # Agg's C++ methods, as its constructor set them

    def _other(self, call, *args, **kwargs):
        self.complete = False
        return call(*args, **kwargs)

    def _kept(self, name, call, gc, *args, **kwargs):
        if not self.png_only:
            self.calls.append((name, self._gc(gc), getattr(self, "_" + name)(*args, **kwargs)))
        return call(gc, *args, **kwargs)

    def _clip(self, kind, obj, scaled):
        held = self._clips.get((kind, id(obj)))
        if held is None:
            held = self._clips[(kind, id(obj))] = (obj, scaled())
        return held[1]

    def _gc(self, gc):
        kept = matplotlib.backend_bases.GraphicsContextBase()
        kept.copy_properties(gc)
        if gc._cliprect is not None:
            kept._cliprect = self._clip("rect", gc._cliprect, lambda: matplotlib.transforms.Bbox(
                gc._cliprect.get_points() * _TO_POINTS[0, 0]))
        if gc._clippath is not None:
            kept._clippath = self._clip("path", gc._clippath, lambda: (
                lambda path, affine: matplotlib.transforms.TransformedPath(
                    path, _in_points(affine)))(*gc._clippath.get_transformed_path_and_affine()))
        return kept

    # Each kept call's arguments after the gc, in points.
    @staticmethod
    def _draw_path(path, transform, rgbFace=None):
        return path, _in_points(transform), rgbFace

    @staticmethod
    def _draw_markers(marker_path, marker_trans, path, trans, rgbFace=None):
        return marker_path, _in_points(marker_trans), path, _in_points(trans), rgbFace

    @staticmethod
    def _draw_path_collection(master_transform, paths, all_transforms, offsets, offset_trans,
                              *rest):
        return (_in_points(master_transform), paths, all_transforms, offsets,
                _in_points(offset_trans), *rest)

    def _draw_image(self, x, y, im, transform=None):
        if transform is not None:  # Agg takes none (option_scale_image)
            self.complete = False
        return x * _TO_POINTS[0, 0], y * _TO_POINTS[0, 0], im

    def _draw_text(self, x, y, s, prop, angle, ismath=False, mtext=None):
        # Agg's text is placed from the top (flipy: Text.draw passed the canvas height less y).
        # No mtext: the PDF renderer would read its position from the figure, at Agg's DPI.
        y = self.renderer.height - y
        return x * _TO_POINTS[0, 0], y * _TO_POINTS[0, 0], s, prop, angle, ismath

    def add_image(self, at, x, y, im):
        """An image of the PDF's alone (the grid's raster) at index `at` of the calls (a
        _RasterSlot's), its lower left corner at (x, y) in Agg's pixels."""
        self.calls.insert(at, ("draw_image", matplotlib.backend_bases.GraphicsContextBase(),
                               (x * _TO_POINTS[0, 0], y * _TO_POINTS[0, 0], im)))

    def write(self, fig, path):
        """The PDF of the calls at `path`, as FigureCanvasPdf.print_pdf writes a figure's;
        nothing left there if it fails."""
        width, height = fig.get_size_inches()
        pdf = _backend_pdf.PdfFile(path, metadata={"CreationDate": None})
        try:
            try:
                pdf.newPage(width, height)
                renderer = _backend_pdf.RendererPdf(pdf, DPI, height, width)
                if _text_helpers is not None:
                    _text_helpers.layout = _pdf_layout
                _backend_pdf.zlib = _ZLIB_WHOLE_STREAMS
                for name, kept, args in self.calls:
                    gc = renderer.new_gc()
                    gc.copy_properties(kept)
                    # draw_text's (x, y, s, prop, ...): the size its font is set to
                    _PDF_TEXT_SIZE[0] = args[3].get_size_in_points() if name == "draw_text" \
                        else None
                    getattr(renderer, name)(gc, *args)
                    gc.restore()
                renderer.finalize()
                pdf.finalize()
            finally:
                if _text_helpers is not None:
                    _text_helpers.layout = _LAYOUT
                _backend_pdf.zlib = zlib
                _PDF_TEXT_SIZE[0] = None
                pdf.close()
        except BaseException:
            if os.path.exists(path):
                os.remove(path)
            raise


# A PDF text's glyphs laid out once per process: RendererPdf.draw_text lays every text out
# (matplotlib._text_helpers.layout: per character a glyph loaded and a kerning asked of FreeType)
# in its font, which it has just set to the text's size at 72 dpi; the report's PDFs lay out the
# same tick labels, legend names and titles again and again (~130000 characters for the measured
# study: ~1 of its ~7 CPU-s of PDF writing). While _PdfCalls writes, a layout is remembered per
# text, font object (kept with it: an id is not reused while it lives) and size: the same glyphs,
# positions and kerns, the same bytes.
_LAYOUT = _text_helpers.layout if _text_helpers is not None else None
_PDF_LAYOUTS = {}
_PDF_LAYOUTS_AT_MOST = 1 << 15
_PDF_TEXT_SIZE = [None]  # the size of the text _PdfCalls.write is drawing (None: another call)


def _pdf_layout(string, font, *, kern_mode=KERNING_DEFAULT):
    size = _PDF_TEXT_SIZE[0]
    if size is None:
        return _LAYOUT(string, font, kern_mode=kern_mode)
    key = (string, id(font), size, kern_mode)
    held = _PDF_LAYOUTS.get(key)
    if held is None or held[0] is not font:
        if len(_PDF_LAYOUTS) >= _PDF_LAYOUTS_AT_MOST:
            _PDF_LAYOUTS.clear()
        held = _PDF_LAYOUTS[key] = (font, list(_LAYOUT(string, font, kern_mode=kern_mode)))
    return iter(held[1])


class _WholeStream:
    """zlib.compressobj(level) for a PDF stream, given its data at once when it ends: the PDF
    renderer writes a figure's content stream an operator at a time (~1600 a probe figure), each
    through the compressor (~0.3 of the measured report's ~7 CPU-s of PDF writing). The same
    bytes: deflate's output does not depend on how its input is cut while nothing is flushed."""

    def __init__(self, level):
        self._level, self._parts = level, []

    def compress(self, data):
        self._parts.append(data)
        return b""

    def flush(self):
        c = zlib.compressobj(self._level)
        return c.compress(b"".join(self._parts)) + c.flush()


# The zlib that backend_pdf sees while _PdfCalls writes (its one use of zlib: compressobj).
_ZLIB_WHOLE_STREAMS = types.SimpleNamespace(compressobj=_WholeStream)


class _RasterSlot(matplotlib.artist.Artist):
    """Where the grid's raster goes among the PDF's calls: drawn under the axes (zorder -1),
    as pdf_images_as_drawn's _PdfRaster is; Agg draws nothing for it."""

    def __init__(self, calls):
        super().__init__()
        self._calls, self.at = calls, None
        self.set_zorder(-1)
        self.set_in_layout(False)

    def draw(self, renderer):
        self.at = len(self._calls.calls)


def _png_only(calls, image, renderer):
    calls.png_only += 1
    try:
        type(image).draw(image, renderer)
    finally:
        calls.png_only -= 1


def save_figure(fig, fig_dir, name, manifest, caption, extra=None, pdf_raster=None):
    """Writes name.png and name.pdf and appends the figure's record to `manifest`; `extra`: more
    fields for the record (a split grid's kind, material and part). `pdf_raster`: an axes whose
    images the PDF takes from the PNG's drawing, as one image (pdf_images_as_drawn)."""
    os.makedirs(fig_dir, exist_ok=True)
    # Whole pixels at DPI: Agg truncates width x dpi, so a hair above the pixel count gives
    # exactly the size figures.json records (the PDF moves by a thousandth of a point).
    w_px, h_px = (int(round(v * DPI)) for v in fig.get_size_inches())
    fig.set_size_inches((w_px + 0.01) / DPI, (h_px + 0.01) / DPI)
    fig.set_dpi(DPI)
    ticks_in_view(fig)
    calls, slot, raster_images = None, None, []
    if ONE_DRAWING:
        calls = _PdfCalls(fig.canvas.get_renderer())
        if pdf_raster is not None:
            raster_images = _raster_images(pdf_raster)
        if raster_images:
            slot = _RasterSlot(calls)
            fig.add_artist(slot)
            for im in raster_images:
                im.draw = functools.partial(_png_only, calls, im)
        calls.install()
    try:
        overlaps, outside = text_problems(fig)
    finally:
        if calls is not None:
            calls.remove()
            for im in raster_images:
                del im.draw
            if slot is not None:
                slot.remove()
    # The titles stay where that drawing put them (matplotlib 3.6's flag; elsewhere it is only
    # an attribute): the PDF's drawing would place them again, measuring the axes' tick labels
    # once more for it, and the two files' titles agree by construction.
    for ax in fig.axes:
        ax._autotitlepos = False
    png = os.path.join(fig_dir, name + ".png")
    pdf = os.path.join(fig_dir, name + ".pdf")
    pdf_tmp = temporary_path(pdf)
    # The PNG is the drawing text_problems made at DPI (Agg's buffer), not a second drawing; an
    # opaque one (every figure here: white behind it) as RGB, a quarter less to deflate (the
    # measured report's PNGs ~10% smaller, 15-20% faster to write), the same pixels.
    rgba = np.asarray(fig.canvas.buffer_rgba())
    write_png(png, rgba[..., :3] if (rgba[..., 3] == 255).all() else rgba, DPI)
    # The kept calls hold the artists' paths, fonts and colour arrays as the drawing passed them,
    # by reference: nothing between the drawing and the PDF may change the figure (a spine's path,
    # say, is rewritten in place when it is drawn again).
    written = False
    if calls is not None and calls.complete and fig.canvas.get_renderer() is calls.renderer:
        raster = _drawn_raster(fig, raster_images) if slot is None or slot.at is not None else None
        if raster is not None or not raster_images:
            if raster is not None:
                calls.add_image(slot.at, *raster)
            calls.write(fig, pdf_tmp)
            written = True
    if not written:  # matplotlib's own PDF drawing
        if pdf_raster is not None:
            pdf_images_as_drawn(fig, pdf_raster)
        # No creation date: a rerun writes the same bytes (docs/studies.md, "Determinism").
        # Other figures' images (a chart's) stay their own, not composited by matplotlib, and
        # are resampled at the PNG's resolution: without `dpi` matplotlib resamples a PDF's
        # images at the figure's first resolution (100 dpi). Text and lines stay vectors. A
        # grid's tiles are one raster of the PNG's pixels by now (pdf_raster above).
        with matplotlib.rc_context({"image.composite_image": False}):
            fig.savefig(pdf_tmp, format="pdf", dpi=DPI, metadata={"CreationDate": None})
    os.replace(pdf_tmp, pdf)
    plt.close(fig)
    manifest.append({"name": name, "png": f"figures/{name}.png", "pdf": f"figures/{name}.pdf",
                     "width_in": round(w_px / DPI, 3), "height_in": round(h_px / DPI, 3),
                     "width": w_px, "height": h_px,
                     "caption": caption, "text_overlaps": overlaps, "text_outside": outside,
                     **(extra or {})})


# --- Images and label text --------------------------------------------------------------------


def srgb_to_linear(v):
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(v):
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def opaque_rgba(rgb):
    """An RGB image (float in [0, 1], or 8-bit from read_rgb8) as opaque 8-bit RGBA, as imshow
    would make it after its nearest-neighbour resampling ((v * 255).astype(uint8), matplotlib's
    to_rgba(bytes=True)): the same pixels in the PNG and the same bytes in the PDF, for a quarter
    of the memory that every drawing copies and resamples (twice per figure). An 8-bit value k
    is taken as is: its float, float32(k / 255), times 255 truncates to k again for every k
    (figures_test checks it)."""
    if rgb.ndim != 3 or rgb.shape[2] != 3 or rgb.dtype.kind not in "fu":
        return rgb
    if rgb.dtype == np.uint8:
        # Pillow's RGB to RGBA (alpha 255) is one C loop: a material's ~300 cropped tiles in
        # ~0.10 s against ~0.15 s for numpy's copy into three of every four bytes.
        return np.asarray(PIL.Image.fromarray(np.ascontiguousarray(rgb), "RGB").convert("RGBA"))
    rgba = np.empty(rgb.shape[:2] + (4,), dtype=np.uint8)
    rgba[..., :3] = rgb * rgb.dtype.type(255)
    rgba[..., 3] = 255
    return rgba


def read_rgb8(path):
    """read_rgb's image as it is stored where the file holds 8-bit RGB or RGBA (as_float gives
    read_rgb's floats exactly); read_rgb's floats otherwise. A grid reads ~6000 previews: the
    float conversion and the copies of floats were a tenth of its time. The previews' own kind
    of PNG (png_codec.read_up_png) is read without Pillow, in a third of its time."""
    pixels = png_codec.read_up_png(path)
    if pixels is not None:
        return pixels[..., :3]
    with PIL.Image.open(path) as im:
        if im.mode in ("RGB", "RGBA"):
            return np.asarray(im)[..., :3]
    return read_rgb(path)


def as_float(img):
    """read_rgb's floats of a read_rgb8 image: k / 255 in float32, as matplotlib's imread
    divides an 8-bit PNG."""
    return np.divide(img, 255, dtype=np.float32) if img.dtype == np.uint8 else img


def read_rgb(path):
    img = mpimg.imread(path)
    if img.dtype != np.float32 and img.dtype != np.float64:
        img = img.astype(np.float32) / 255.0
    return img[..., :3]


def wrap_at_hyphens(text, width):
    """Lines of at most `width` characters, broken after hyphens, plus signs and colons, before
    an "@" and at spaces, so a fit label fits over a narrow column ("blinn-phong-" /
    "normalized" / "@key+" / "mirror60:" / "cuberoot")."""
    tokens = re.findall(r"@?[^\s@+:-]+[-+:]?|[@+:-]|\s+", text)
    lines, line = [], ""
    for t in tokens:
        if t.isspace():
            if line:
                line += " "
            continue
        if line and len(line) + len(t) > width:
            lines.append(line.rstrip())
            line = ""
        line += t
    if line:
        lines.append(line.rstrip())
    return "\n".join(lines)


def wrap_to_width(text, width_in, fontsize):
    """wrap_at_hyphens with the most characters a line whose every line is at most width_in wide
    (measured); a single token wider than that stays whole."""
    for chars in range(max(len(text), 1), 0, -1):
        wrapped = wrap_at_hyphens(text, chars)
        if text_width_in(wrapped, fontsize) <= width_in:
            return wrapped
    return wrap_at_hyphens(text, 1)


# --- Bars -------------------------------------------------------------------------------------


# Series drawn as the ground truth (dashed black, on top): the reference image's, the true BRDF's,
# or the measured BRDF's (the brdf probe).
GROUND_SERIES = ("reference", "truth", "measured")

HATCHES = ["", "///", "...", "xx", "\\\\", "++"]


def bar_style(i, label):
    """Fill of the i-th series of a bar chart: the ground truth black, the fits an Okabe-Ito
    colour and a hatch each (7 x 6 distinct pairs, so more fits than colours still separate)."""
    if label in GROUND_SERIES:
        return {"color": "black", "hatch": "", "edgecolor": "white", "linewidth": 0}
    return {"color": OKABE_ITO[i % len(OKABE_ITO)], "hatch": HATCHES[i % len(HATCHES)],
            "edgecolor": "white", "linewidth": 0}


# A bar chart's bars drawn one series at a time: Agg fills a hatched patch by drawing its hatch
# into a scratch tile of 1 x 1 in (200 x 200 pixels) and repeating it, the tile drawn anew for
# every patch: a probe's bar figure of ~250 hatched bars took ~0.25 s to draw, ~0.09 s with each
# series' bars one path (one tile per series). The same pixels: Agg repeats the hatch from the
# canvas's origin, not the patch's; it snaps a path of horizontal and vertical edges to whole
# pixels, bar by bar as over one path of up to 1024 vertices (matplotlib's limit for snapping);
# and bars that share no pixel fill as one path as they do one by one (tests/report/bars_test.py
# compares the two). Bars closer than BAR_APART_PX, more than BAR_PATH_VERTICES of them, or of
# styles that differ within one call are drawn one by one.
BAR_APART_PX = 2.0
BAR_PATH_VERTICES = 1024
ONE_PATH_BARS = True  # False: every bar drawn by itself (the test's reference drawing)


def _no_draw(renderer):
    """A bar drawn by its series' _BarSeries instead."""


def _bar_style(r):
    return (tuple(r.get_facecolor()), tuple(r.get_edgecolor()), r.get_hatch(), r.get_linewidth(),
            r.get_linestyle(), r.get_alpha(), r.get_zorder(), r.get_visible(), r.get_fill(),
            r.get_clip_on(), r.get_clip_path() is None, r.get_clip_box() is None or tuple(
                r.get_clip_box().bounds), r.get_data_transform(), r.get_antialiased(),
            r.get_snap(), r.get_capstyle(), r.get_joinstyle())


class _BarSeries(matplotlib.patches.PathPatch):
    """The bars of one Axes.bar call, drawn as one path in their style. The bars stay in the axes
    as they were (data limits, sticky edges, the legend's handles), drawing nothing themselves."""

    def __init__(self, ax, rects):
        super().__init__(matplotlib.path.Path(np.zeros((1, 2))))
        self._rects = rects
        self.update_from(rects[0])
        self.set_zorder(rects[0].get_zorder())
        for r in rects:
            r.draw = _no_draw
        ax.add_artist(self)

    def _one_path(self):
        """Every bar's path in data coordinates, when they share a style and lie apart at this
        drawing's scale; else None."""
        first = _bar_style(self._rects[0])
        if any(_bar_style(r) != first for r in self._rects[1:]):
            return None
        if sum(len(r.get_path().vertices) for r in self._rects) > BAR_PATH_VERTICES:
            return None
        paths = [r.get_path().transformed(r.get_patch_transform()) for r in self._rects]
        # Each bar's left and right edge on the canvas (bars with a NaN corner draw nothing).
        shown = [p.vertices for p in paths if np.isfinite(p.vertices).all()]
        if not shown:
            return None
        x = np.array([[v[:, 0].min(), v[:, 0].max()] for v in shown])
        px = self._rects[0].get_data_transform().transform(
            np.column_stack([x.ravel(), np.ones(x.size)]))[:, 0].reshape(-1, 2)
        if not np.isfinite(px).all():
            return None
        lo, hi = np.sort(px, axis=1).T
        order = np.argsort(lo)
        stroke = self._rects[0].get_linewidth() * self.figure.dpi / 72.0
        if (lo[order][1:] - hi[order][:-1] < BAR_APART_PX + stroke).any():
            return None
        return matplotlib.path.Path.make_compound_path(*paths)

    def draw(self, renderer):
        path = self._one_path()
        if path is None:
            for r in self._rects:
                type(r).draw(r, renderer)
            return
        self.update_from(self._rects[0])
        self._path = path
        super().draw(renderer)


def bars(ax, x, heights, width, **style):
    """ax.bar(x, heights, width, **style), its bars drawn as one path (_BarSeries). Returns
    Axes.bar's container."""
    container = ax.bar(x, heights, width, **style)
    if ONE_PATH_BARS and len(container.patches) > 1:
        _BarSeries(ax, list(container.patches))
    return container
