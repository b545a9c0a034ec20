"""Image grids: per material, the reference, each fit and its error map per lighting, cropped
to the object (docs/studies.md, "Figures")."""

import functools
import math
import os
import types

import numpy as np

from report_figures import (FONT_PT, MATPLOTLIB_3_6, PAGE_IN, UNITS_RADIANCE, as_float,
                            linear_to_srgb, matplotlib, opaque_rgba, plt, read_rgb8, save_figure,
                            srgb_to_linear, wrap_to_width)


@functools.lru_cache(maxsize=None)
def _srgb8_to_linear():
    """srgb_to_linear of as_float's value for each 8-bit value: the same floats, looked up."""
    return srgb_to_linear(as_float(np.arange(256, dtype=np.uint8)))


@functools.lru_cache(maxsize=None)
def _exposed8(stops):
    """The 8-bit value opaque_rgba makes of exposed()'s float for each 8-bit value at `stops`."""
    return opaque_rgba(exposed(np.arange(256, dtype=np.uint8).reshape(1, 256, 1).repeat(3, 2),
                               stops))[0, :, 0]


def row_exposure(reference_rgb):
    """Whole stops that bring a dim reference's bright pixels (99th percentile of the lit ones)
    up to mid-grey-to-white; 0 for lightings that already read. At most +6. `reference_rgb`:
    read_rgb8's image (8-bit values are looked up: the same floats) or floats."""
    if reference_rgb.dtype == np.uint8:
        lin = _srgb8_to_linear()[reference_rgb[..., :3]].mean(axis=2)
    else:
        lin = srgb_to_linear(reference_rgb).mean(axis=2)
    lit = lin[lin > 1e-4]
    if lit.size == 0:
        return 0
    p99 = float(np.percentile(lit, 99))
    if p99 >= 0.25:
        return 0
    return int(min(6, max(0, np.floor(np.log2(0.6 / max(p99, 1e-6))))))


def exposed(rgb, stops):
    """`rgb` (read_rgb8's or floats) brightened by whole stops; as it is at 0."""
    return rgb if stops == 0 else linear_to_srgb(srgb_to_linear(as_float(rgb)) * 2.0 ** stops)


def exposed_rgba(rgb, stops):
    """opaque_rgba(exposed(rgb, stops)); 8-bit values looked up (_exposed8: the same bytes)."""
    if stops != 0 and rgb.dtype == np.uint8 and rgb.ndim == 3 and rgb.shape[2] == 3:
        return opaque_rgba(_exposed8(stops)[rgb])
    return opaque_rgba(exposed(rgb, stops))


# 7 in page gives each image ~0.5 in. More fits split the grid into parts, one per training set
# (chunks of at most this many where a training set holds more).
GRID_MAX_FITS = 5


def grid_parts(study, labels):
    """[(suffix, labels)]: one part, suffix "", when the labels fit one figure; else one part per
    training set in study order, suffix "-<training set>" ("-key+mirror60"), and "-<k>" after it
    when a training set is chunked."""
    if len(labels) <= GRID_MAX_FITS:
        return [("", labels)]
    train = {f["label"]: "+".join(f["train"]) for f in study["fits"]}
    groups = {}
    for l in labels:
        groups.setdefault(train.get(l, ""), []).append(l)
    parts = []
    for t, ls in groups.items():
        chunks = [ls[i:i + GRID_MAX_FITS] for i in range(0, len(ls), GRID_MAX_FITS)]
        for k, chunk in enumerate(chunks):
            suffix = (f"-{t}" if t else "") + (f"-{k + 1}" if len(chunks) > 1 or not t else "")
            parts.append((suffix, chunk))
    return parts


def image_grid(study_dir, study, fits, material, fig_dir, manifest):
    """Rows = lightings (a chosen subset of many: grid_lightings); columns = reference, each fit,
    each fit's error map, cropped to the object (grid_crop); one colour bar per row (the error
    maps of a reference share their range) with its ticks in radiance units.
    More fits than GRID_MAX_FITS: one figure per training set (grid_parts), each named in
    figures.json with its material and part, so the page and report.tex show every part."""
    labels = [f["label"] for f in study["fits"] if (material, f["label"]) in fits]
    if not labels:
        return
    parts = grid_parts(study, labels)
    # Every preview of the material read once, as stored (8-bit: a material's ~300 previews of
    # 256^2 are ~60 MB).
    read = functools.lru_cache(maxsize=None)(read_rgb8)
    for k, (suffix, part) in enumerate(parts):
        heading = ""
        if len(parts) > 1:
            train = next((f["train"] for f in study["fits"] if f["label"] == part[0]), None)
            heading = f"part {k + 1} of {len(parts)}" + (
                f": fits trained on {', '.join(train)}" if train else "")
        fig, caption, rows = grid_figure(study_dir, study, fits, material, part, heading, read,
                                         keep=KEEP_GRID)
        save_figure(fig, fig_dir, f"grid-{material}{suffix}", manifest, caption,
                    {"kind": "grid", "material": material, "part": k + 1, "parts": len(parts),
                     "fits": part, "lightings": rows}, pdf_raster=fig.axes[0])


# Rows of one grid figure: past this many lightings the figure shows a chosen subset (the
# training lightings and the test lightings with the lowest and highest error); the HTML viewer
# keeps every lighting.
GRID_MAX_ROWS = 12
# The tallest grid figure: a printed page's text height (7 x 9 in), so a grid of many lightings
# shrinks its tiles rather than run over the page.
GRID_MAX_HEIGHT_IN = 9.0
# Around the object's bounds, a share of its larger side (at least 2 px).
GRID_CROP_MARGIN = 0.06


def lighting_error(evals, labels, light):
    """The mean relative RMSE of the fits in `labels` under `light` (None where none has one)."""
    values = []
    for l in labels:
        v = (evals[l].get(light, {}).get("metrics") or {}).get("relative_rmse")
        if isinstance(v, (int, float)) and math.isfinite(v):
            values.append(float(v))
    return sum(values) / len(values) if values else None


def grid_lightings(evals, labels, lightings, max_rows=GRID_MAX_ROWS):
    """(rows, note): the lightings a grid shows, and a caption note ("" when it shows all). With
    more than max_rows: the training lightings of any fit in `labels` (in study order; at most
    max_rows - 2 of them), then the test lightings with the lowest and the highest error
    (lighting_error), half the remaining rows each, lowest first; tests without an error fill
    from the study order."""
    if len(lightings) <= max_rows:
        return list(lightings), ""
    train = [x for x in lightings
             if any(evals[l].get(x, {}).get("split") == "train" for l in labels)]
    train = train[:max(0, max_rows - 2)]
    tests = [x for x in lightings if x not in train]
    known = sorted((e, i, x) for i, x in enumerate(tests)
                   if (e := lighting_error(evals, labels, x)) is not None)
    by_error = [x for _, _, x in known]
    free = max_rows - len(train)
    low_n = (free + 1) // 2
    low, high = by_error[:low_n], by_error[low_n:][-(free - low_n):] if free > low_n else []
    chosen = low + [x for x in high if x not in low]
    for x in tests:  # Tests without numbers, when too few have one.
        if len(chosen) >= free:
            break
        if x not in chosen:
            chosen.append(x)
    note = (f"rows: {len(train)} training and {len(chosen)} of {len(tests)} test lightings "
            f"(the {len(low)} with the lowest and {len(chosen) - len(low)} with the highest mean "
            f"relative RMSE, lowest first); the HTML viewer shows all {len(lightings)}")
    return train + chosen, note


# A display value above this is the object's (object_box).
LIT_THRESHOLD = 1.5 / 255


def lit_pixels(img):
    """Where any channel of `img` (display RGB: read_rgb8's 8-bit values or floats) is above
    LIT_THRESHOLD. For 8-bit values, k / 255 > 1.5 / 255 is k >= 2: compared as they are, with
    no float copy (a grid's crop reads ~150 previews)."""
    if img.dtype == np.uint8:
        return np.maximum(np.maximum(img[..., 0], img[..., 1]), img[..., 2]) >= 2
    return img[..., :3].max(axis=2) > LIT_THRESHOLD


def object_box(images):
    """(x0, y0, x1, y1), half-open pixel bounds of the pixels lit (lit_pixels) in any of
    `images` (display RGB of one size), grown by GRID_CROP_MARGIN of the larger side and clipped
    to the frame; None when no pixel is. The fits' previews are renders composited over black, so
    their bright pixels are the object's (a photograph's background is not black: the reference
    preview alone cannot say where the object is)."""
    lit = None
    for img in images:
        m = lit_pixels(img)
        lit = m if lit is None else (lit | m if lit.shape == m.shape else lit)
    if lit is None or not lit.any():
        return None
    ys, xs = np.nonzero(lit)
    x0, x1, y0, y1 = int(xs.min()), int(xs.max()) + 1, int(ys.min()), int(ys.max()) + 1
    pad = max(2, int(math.ceil(GRID_CROP_MARGIN * max(x1 - x0, y1 - y0))))
    h, w = lit.shape
    return max(0, x0 - pad), max(0, y0 - pad), min(w, x1 + pad), min(h, y1 + pad)


def grid_crop(study_dir, evals, labels, rows, read=read_rgb8):
    """The crop box of a grid (object_box over every fit preview of its rows; the reference
    previews when there is no fit preview) and the frame's size (w, h); (None, None) when no
    preview can be read."""
    def previews(key, only_labels):
        for light in rows:
            for l in only_labels:
                rel = evals[l].get(light, {}).get("images", {}).get(key)
                if rel and os.path.exists(os.path.join(study_dir, rel)):
                    yield read(os.path.join(study_dir, rel))

    for key, ls in (("fit", labels), ("reference", labels[:1])):
        frame, lit = None, []
        for img in previews(key, ls):
            frame = frame or (img.shape[1], img.shape[0])
            if (img.shape[1], img.shape[0]) == frame:
                lit.append(img)
        if frame is not None:
            return object_box(lit) or (0, 0, frame[0], frame[1]), frame
    return None, None


# Inches of a grid figure's margins: row labels at the left, the colour bar and its ticks and
# label at the right, between tiles, under the last row.
GRID_LEFT_IN, GRID_BAR_IN, GRID_RIGHT_IN, GRID_GAP_IN, GRID_BOTTOM_IN = 0.42, 0.08, 0.52, 0.03, 0.02


def training_suffix(study, labels):
    """The part every label of `labels` adds to its model's name for a training set they all
    share ("@key+mirror60"), read from the study's fit records (label, model, train); "" when
    the fits' training sets differ or a label is its model's name (one training set)."""
    records = {f["label"]: f for f in study["fits"]}
    fits = [records[l] for l in labels]
    if len(fits) < 2 or len({tuple(f["train"]) for f in fits}) != 1:
        return ""
    suffixes = {f["label"][len(f["model"]):] if f["label"].startswith(f["model"]) else None
                for f in fits}
    suffix = suffixes.pop() if len(suffixes) == 1 else None
    return suffix or ""


def grid_layout(study, labels, heading, aspect, rows):
    """The figure's size and its tiles' places, in inches: column titles wrapped to the tile
    width, tiles at the crop's `aspect` (height / width) shrunk where `rows` of them would run
    over GRID_MAX_HEIGHT_IN, and the grid centred on the page."""
    g = types.SimpleNamespace(ncols=1 + 2 * len(labels), heading=heading)
    g.cell_w = (PAGE_IN - GRID_LEFT_IN - GRID_BAR_IN - GRID_RIGHT_IN
                - GRID_GAP_IN * (g.ncols + 1)) / g.ncols
    # A training set every fit of the figure shares is said once, in the heading.
    common = training_suffix(study, labels) if heading else ""
    short = [l[:len(l) - len(common)] if common else l for l in labels]
    if common:
        g.heading += f" (labels end in {common})"
    heading_in = (FONT_PT * 1.3 + 4) / 72 if g.heading else 0.0

    def titles_for(width):  # Column titles wrapped to the column, measured, and the top margin.
        titles = ["reference"] + [wrap_to_width(l, width, FONT_PT - 1) for l in short] + \
            [wrap_to_width(f"|error| {l}", width, FONT_PT - 1) for l in short]
        title_lines = max(t.count("\n") + 1 for t in titles)
        return titles, title_lines * (FONT_PT - 1) * 1.25 / 72 + 0.08 + heading_in

    g.titles, g.top_in = titles_for(g.cell_w)
    # The tiles' height follows the crop's aspect; a figure taller than the page shrinks them
    # (the figure stays PAGE_IN wide, the tiles start at the left).
    g.cell_h = g.cell_w * aspect
    max_cell_h = (GRID_MAX_HEIGHT_IN - g.top_in - GRID_BOTTOM_IN) / rows - GRID_GAP_IN
    if g.cell_h > max_cell_h:
        g.cell_h = max_cell_h
        g.cell_w = g.cell_h / aspect
        g.titles, g.top_in = titles_for(g.cell_w)
    g.height = g.top_in + GRID_BOTTOM_IN + rows * (g.cell_h + GRID_GAP_IN)
    # Shrunk tiles leave the page's width: centre the grid on it (row labels to colour bar).
    g.left_in = GRID_LEFT_IN + max(0.0, PAGE_IN - GRID_BAR_IN - GRID_RIGHT_IN - GRID_GAP_IN
                                   - g.ncols * (g.cell_w + GRID_GAP_IN) - GRID_LEFT_IN) / 2
    g.bar_x = g.left_in + GRID_GAP_IN + g.ncols * (g.cell_w + GRID_GAP_IN)  # last tile's gap end
    return g


def cropper(box, frame):
    """A function that crops a preview to the grid's box (an error PNG to its frame first)."""
    def cropped(img):
        if box is None:
            return img
        if frame is not None and img.shape[1] > frame[0]:
            # The error PNG carries its own small bar right of the frame: keep the frame; the
            # row's bar is drawn here, readable in print.
            img = img[:, :frame[0]]
        if (img.shape[1], img.shape[0]) != frame:
            return img
        return img[box[1]:box[3], box[0]:box[2]]
    return cropped


# The colour bar's ticks and their labels, in points: out of the bar's right edge, as a colour
# bar's axis draws them (matplotlib's default major tick width).
BAR_TICK_PT, BAR_TICK_WIDTH_PT, BAR_LABEL_PAD_PT = 2.0, 0.8, 1.0
@functools.lru_cache(maxsize=1)
def _bar_rgba():
    """viridis in 256 steps from the bottom (0) to the top (the row's error scale) as 8-bit
    RGBA: the bands a colour bar of the map draws."""
    return matplotlib.colormaps["viridis"](np.arange(256)[::-1, None], bytes=True)


def row_colour_bar(fig, tiles, g, y0, error_scale, first_row):
    """The error maps' colour bar of one row, in radiance units; the units over the first. Drawn
    on the tiles' axes (in inches) as an image, its outline, three ticks and their labels: a
    colour bar's own axes (one per row, 700 in the measured study's grids) cost about a third
    of the grids' drawing time."""
    x1, y1 = g.bar_x + GRID_BAR_IN, y0 + g.cell_h
    add_tile(tiles, _bar_rgba(), (g.bar_x, x1, y0, y1))
    tiles.add_patch(matplotlib.patches.Rectangle((g.bar_x, y0), GRID_BAR_IN, g.cell_h,
                                                 fill=False, linewidth=0.4, edgecolor="black",
                                                 clip_on=False))
    ticks = (0, error_scale / 2, error_scale)
    ys = [y0 + g.cell_h * t / error_scale for t in ticks]
    tiles.add_collection(matplotlib.collections.LineCollection(
        [[(x1, y), (x1 + BAR_TICK_PT / 72, y)] for y in ys], colors="black",
        linewidths=BAR_TICK_WIDTH_PT, capstyle="butt", clip_on=False))
    # The end labels stay inside the bar's height, clear of the next row's.
    for t, y, va in zip(ticks, ys, ("bottom", "center_baseline", "top")):
        tiles.text(x1 + (BAR_TICK_PT + BAR_LABEL_PAD_PT) / 72, y, f"{t:.2g}", ha="left", va=va,
                   fontsize=FONT_PT - 2)
    if first_row:
        # Over the bars' column, which no column title reaches (titles are wrapped to their
        # image's width).
        fig.text(g.bar_x / PAGE_IN, (y1 + 0.03) / g.height, UNITS_RADIANCE,
                 ha="left", va="bottom", fontsize=FONT_PT - 2)


# The tiles resampled once (_OpaqueTile._make_image); False: matplotlib's two resamplings.
_ONE_RESAMPLE = MATPLOTLIB_3_6


class _OpaqueTile(matplotlib.image.AxesImage):
    """An image of opaque 8-bit RGBA (opaque_rgba's), kept as given: AxesImage.set_data copies
    it, masks its invalid values (8-bit values have none), checks its range (0-255 by type) and
    the axes' imshow scales a colour norm over it (unused by RGBA), ~1 ms a tile of the ~350 of
    a material's grids. Anything else goes through set_data."""

    def set_data(self, A):
        if isinstance(A, np.ndarray) and A.dtype == np.uint8 and A.ndim == 3 and A.shape[2] == 4:
            self._A = A
            self._imcache = None
            self.stale = True
        else:
            super().set_data(A)

    def _make_image(self, A, *args, **kwargs):
        """AxesImage's, with one resampling of the tile instead of two. matplotlib 3.6 resamples
        an RGBA image's alpha plane, then a copy of its RGB made RGBA again (alpha 255), and
        puts the first's result into the second's alpha: for an opaque tile the copy is the
        tile itself and the alpha plane's result is the tile's resampled alpha, so the tile is
        resampled once, as it is, for both (the same pixels: figure_cache_test compares them)."""
        if not (_ONE_RESAMPLE and A is self._A):
            return super()._make_image(A, *args, **kwargs)
        resample, rgb_to_rgba = matplotlib.image._resample, matplotlib.image._rgb_to_rgba
        done = []

        def view_of(data, channels, first):
            """Is `data` A[..., first:first + channels] (channels 1: the plane A[..., first])?"""
            at = A.__array_interface__["data"][0] + first
            return (data.__array_interface__["data"][0] == at and data.strides[:2] == A.strides[:2]
                    and data.shape == (A.shape[:2] if channels == 1 else A.shape[:2] + (channels,)))

        def once(image_obj, data, out_shape, transform, **kw):
            if not done and data.ndim == 2 and view_of(data, 1, 3):  # alpha: the tile, once
                done.append(resample(image_obj, A, out_shape, transform, **kw))
                return done[0][..., 3]
            if data is A and done:  # the RGB made RGBA: the same tile
                return done[0]
            return resample(image_obj, data, out_shape, transform, **kw)

        def same_tile(rgb):
            return A if done and rgb.ndim == 3 and view_of(rgb, 3, 0) else rgb_to_rgba(rgb)

        matplotlib.image._resample, matplotlib.image._rgb_to_rgba = once, same_tile
        try:
            return super()._make_image(A, *args, **kwargs)
        finally:
            matplotlib.image._resample, matplotlib.image._rgb_to_rgba = resample, rgb_to_rgba


def _inside(ax, extent):
    """Does an image at `extent` lie inside `ax`, an axes spanning the whole figure? Clipping it
    to the axes' patch then leaves every pixel as it is: the patch's edges are the canvas's. (An
    axes of automatic aspect and no locator is where it was put: its original position, read
    without get_position's copy and apply_aspect, 0.07 ms a tile.)"""
    if ax.get_aspect() == "auto" and ax.get_axes_locator() is None:
        bounds = ax._originalPosition.bounds
    else:
        bounds = ax.get_position().bounds
    if tuple(bounds) != (0.0, 0.0, 1.0, 1.0):
        return False
    (xa, xb), (ya, yb) = sorted(ax.get_xlim()), sorted(ax.get_ylim())
    x0, x1, y0, y1 = extent
    return xa <= min(x0, x1) and max(x0, x1) <= xb and ya <= min(y0, y1) and max(y0, y1) <= yb


def add_tile(ax, rgba, extent):
    """ax.imshow(rgba, interpolation="nearest", aspect="auto", extent=extent) for opaque 8-bit
    RGBA (_OpaqueTile) on an axes whose limits are set: the same image, drawn the same. A tile
    inside a grid's axes (which spans the figure: _inside) is not clipped to it, which would
    change no pixel: setting the clip path (a transformed copy of the patch's path per tile) took
    0.5 of the 4.7 s that making the measured study's 100 grids took (their previews read), and
    Agg drew each tile through the clip's mask. Such tiles are drawn by one artist of the axes
    (_TileSet); others are an image each. Returns the artist that draws the tile."""
    if not MATPLOTLIB_3_6:  # the steps below are 3.6's imshow's
        return ax.imshow(rgba, interpolation="nearest", aspect="auto", extent=extent)
    ax.set_aspect("auto")
    if _inside(ax, extent) and _TileSet.takes(rgba):
        tiles = getattr(ax, "_shadefit_tiles", None)
        if tiles is None or tiles.axes is not ax:
            tiles = ax._shadefit_tiles = _TileSet(ax)
            ax.add_image(tiles)
        tiles.add(rgba, extent)
        return tiles
    im = _OpaqueTile(ax, interpolation="nearest", extent=extent)
    im.set_data(rgba)
    if not _inside(ax, extent):
        im.set_clip_path(ax.patch)
    im.set_extent(im.get_extent())
    ax.add_image(im)
    return im


class _TileSet(_OpaqueTile):
    """The unclipped tiles of an axes, drawn in the order they were added, each by this one
    image as an _OpaqueTile of its own would draw it (the same steps: the same pixels): an
    AxesImage made per tile (its colour map, norm and callbacks, its extent set) took ~0.3 ms,
    2 of the ~10 CPU-s that making the measured study's 100 grids took (~7700 tiles). Counts
    as one image of the axes per tile (tile_count: the PDF's raster, _raster_images)."""

    def __init__(self, ax):
        super().__init__(ax, interpolation="nearest")
        self._tiles = []

    @staticmethod
    def takes(rgba):
        return (isinstance(rgba, np.ndarray) and rgba.dtype == np.uint8 and rgba.ndim == 3
                and rgba.shape[2] == 4 and rgba.size > 0)

    @property
    def tile_count(self):
        return len(self._tiles)

    def add(self, rgba, extent):
        """As set_data and set_extent would leave an image: the axes' data limits and sticky
        edges take the extent in (the axes' limits, set, stay)."""
        x0, x1, y0, y1 = (float(v) for v in extent)
        self._tiles.append((rgba, (x0, x1, y0, y1)))
        self._A, self._extent = rgba, (x0, x1, y0, y1)
        self.axes.update_datalim(((x0, y0), (x1, y1)))
        self.sticky_edges.x[:] = [min(x0, x1), max(x0, x1)]  # the last tile's, as set_extent
        self.sticky_edges.y[:] = [min(y0, y1), max(y0, y1)]
        self.stale = True

    def get_window_extent(self, renderer=None):
        return matplotlib.transforms.Bbox.union([
            matplotlib.transforms.Bbox.from_extents(x0, y0, x1, y1).transformed(
                self.get_transform()) for _, (x0, x1, y0, y1) in self._tiles])

    def draw(self, renderer, *args, **kwargs):
        if not isinstance(renderer, matplotlib.backends.backend_agg.RendererAgg):
            # A vector renderer may composite an axes' adjacent images into one (PDF, SVG with
            # image.composite_image): it gets the tiles as the images add_tile made of each.
            matplotlib.image._draw_list_compositing_images(renderer, self.axes, [
                self._one_tile(rgba, extent) for rgba, extent in self._tiles])
        else:
            for rgba, extent in self._tiles:
                self._A, self._imcache, self._extent = rgba, None, extent
                super().draw(renderer, *args, **kwargs)
        self.stale = False

    def _one_tile(self, rgba, extent):
        im = _OpaqueTile(self.axes, interpolation="nearest", extent=extent)
        im.set_data(rgba)
        im.set_figure(self.figure)
        im.set_transform(self.get_transform())
        return im


def grid_row(fig, tiles, g, study_dir, evals, labels, i, light, cropped, frame, read=read_rgb8):
    """Row i of the grid: the reference, each fit and each fit's error map under `light`, its
    label, and its colour bar. Returns the whole stops the row's images were brightened by.
    `read`: reads a preview (read_rgb8, or a cache of it)."""
    y0 = g.height - g.top_in - (i + 1) * (g.cell_h + GRID_GAP_IN) + GRID_GAP_IN
    first = evals[labels[0]].get(light, {}).get("images", {})
    ref_path = os.path.join(study_dir, first["reference"]) if first.get("reference") else None
    ref = read(ref_path) if ref_path and os.path.exists(ref_path) else None
    stops = row_exposure(cropped(ref)) if ref is not None else 0
    panels = [("reference", first.get("reference"), False)]
    panels += [(l, evals[l].get(light, {}).get("images", {}).get("fit"), False) for l in labels]
    panels += [(f"|error| {l}", evals[l].get(light, {}).get("images", {}).get("error"), True)
               for l in labels]
    error_scale = None
    for j, (title, rel, is_error) in enumerate(panels):
        x0 = g.left_in + GRID_GAP_IN + j * (g.cell_w + GRID_GAP_IN)
        if i == 0:
            tiles.text(x0 + g.cell_w / 2, y0 + g.cell_h + 2 / 72, g.titles[j], ha="center",
                       va="bottom", fontsize=FONT_PT - 1)
        if not rel or not os.path.exists(os.path.join(study_dir, rel)):
            tiles.text(x0 + g.cell_w / 2, y0 + g.cell_h / 2, "missing", ha="center",
                       va="center")
            continue
        img = ref if j == 0 and ref is not None else read(os.path.join(study_dir, rel))
        if is_error:
            if frame is None:  # No preview to size it: keep the square image part.
                img = img[:, :img.shape[0]]
            lab = labels[j - 1 - len(labels)]
            error_scale = evals[lab].get(light, {}).get("images", {}).get("error_scale")
            img = opaque_rgba(cropped(img))
        else:
            img = exposed_rgba(cropped(img), stops)
        add_tile(tiles, img, (x0, x0 + g.cell_w, y0, y0 + g.cell_h))
    split = next((evals[l].get(light, {}).get("split") for l in labels
                  if evals[l].get(light, {}).get("split")), "")
    row_label = light + (f"\n({split})" if split else "") + (f"\n+{stops} EV" if stops else "")
    fig.text((g.left_in - 0.02) / PAGE_IN, (y0 + g.cell_h / 2) / g.height, row_label,
             ha="right", va="center", fontsize=FONT_PT - 1)
    if error_scale:
        row_colour_bar(fig, tiles, g, y0, error_scale, i == 0)
    return stops


def grid_caption(material, heading, exposures, box, frame, rows_note):
    dim = [f"{l} +{s} EV" for l, s in exposures if s]
    crop_note = ""
    if box is not None and frame is not None and (box[2] - box[0], box[3] - box[1]) != frame:
        crop_note = (f"; frames cropped to the object ({box[2] - box[0]} x {box[3] - box[1]} of "
                     f"{frame[0]} x {frame[1]} px)")
    return (f"{material}" + (f", {heading}" if heading else "")
            + ": reference, fits and |fit - reference| (mean RGB, linear radiance, "
            f"colour bar in {UNITS_RADIANCE} shared by the fits of a row) per lighting; "
            "images at the study's display exposure"
            + (f", dim lightings brightened: {', '.join(dim)}" if dim else "") + crop_note
            + (f"; {rows_note}" if rows_note else "") + ".")


# The grid figure kept from one grid to the next in a process and emptied, as the probe figures
# are (report_probe_figures.KEEP_FIGURES): making its axes (its spines, axes and their first
# ticks: ~15 ms) took ~1.5 of the ~8 CPU-s of making the measured study's 100 grids. It draws
# what a new figure would, byte for byte (tests/report/grid_fit_test.py draws both). Only
# image_grid keeps it (it has saved and closed a grid before it makes the next); matplotlib 3.6
# only, as the other shortcuts.
KEEP_GRID = MATPLOTLIB_3_6
_kept_grid = []  # [(figure, its tiles' axes, the axes' first _autotitlepos)]


def _grid_canvas(height, keep):
    """A figure PAGE_IN x `height` in and its one axes spanning it in inches, axis off: with
    `keep`, the last kept one emptied where there is one, and kept for the next; else new."""
    if keep and _kept_grid:
        fig, tiles, titlepos = _kept_grid.pop()
        for artist in (list(fig.texts) + list(tiles.texts) + list(tiles.patches)
                       + list(tiles.collections) + list(tiles.images) + list(tiles.lines)
                       + list(tiles.artists)):
            artist.remove()
        tiles.__dict__.pop("_shadefit_tiles", None)
        tiles.dataLim = matplotlib.transforms.Bbox.null()
        tiles.ignore_existing_data_limits = True
        tiles._autotitlepos = titlepos
        fig.set_dpi(matplotlib.rcParams["figure.dpi"])
        fig.set_size_inches(PAGE_IN, height)
    else:
        fig = plt.figure(figsize=(PAGE_IN, height))
        # Every tile is an image of one axes spanning the figure, in inches: one axes per tile
        # (up to 77 in the measured study) made building a grid take ~2 s.
        tiles = fig.add_axes([0, 0, 1, 1])
        tiles.set_axis_off()
        tiles.set_xticks([])
        tiles.set_yticks([])
        titlepos = tiles._autotitlepos
    # Inches, set before the tiles: fixed limits are not widened by each image's extent (an
    # autoscaled axes set its limits again for every tile).
    tiles.set_xlim(0, PAGE_IN)
    tiles.set_ylim(0, height)
    if keep:
        _kept_grid[:] = [(fig, tiles, titlepos)]
    return fig, tiles


def grid_figure(study_dir, study, fits, material, labels, heading, read=None, keep=False):
    """One grid figure over `labels`, and its caption; `heading` (a split grid's part) goes above
    the column titles and into the caption. Every frame is cropped to the object's bounds
    (grid_crop) and keeps its pixel aspect ratio; many lightings show a subset (grid_lightings).
    `keep`: the figure may be the last one kept, emptied (the caller has saved and closed it),
    and is kept for the next (KEEP_GRID)."""
    evals = {l: {e["lighting"]: e for e in fits[(material, l)]["evaluations"]} for l in labels}
    all_lightings = [r["lighting"] for g in study["groups"] if g["material"] == material
                     for r in g["references"]]
    lightings, rows_note = grid_lightings(evals, labels, all_lightings)
    # Each preview read once per figure (`read`: image_grid's, once per material): the crop reads
    # the fits' previews and the rows read them again, every part the references.
    read = read or functools.lru_cache(maxsize=None)(read_rgb8)
    box, frame = grid_crop(study_dir, evals, labels, lightings, read)
    aspect = (box[3] - box[1]) / (box[2] - box[0]) if box else 1.0  # tile height / width
    g = grid_layout(study, labels, heading, aspect, len(lightings))
    fig, tiles = _grid_canvas(g.height, keep)
    if g.heading:
        fig.text((g.left_in + GRID_GAP_IN) / PAGE_IN, (g.height - 0.03) / g.height,
                 f"{material}, {g.heading}", ha="left", va="top", fontsize=FONT_PT)
    cropped = cropper(box, frame)
    exposures = [(light, grid_row(fig, tiles, g, study_dir, evals, labels, i, light, cropped,
                                  frame, read)) for i, light in enumerate(lightings)]
    return fig, grid_caption(material, g.heading, exposures, box, frame, rows_note), lightings
