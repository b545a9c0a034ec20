"""Figures for a paper: every figure is one column (3.3 in) or two columns (7 in) wide, saved as a
PNG of exactly width_in x height_in x DPI pixels and as a vector PDF with its fonts embedded
(TrueType, not Type 3); curves use the Okabe-Ito colour-blind-safe palette with a line style
each; no text overlaps other text or leaves the figure (checked here at save time and recorded
in figures.json, which tests/report/ reads).

Called by make_report.py; reads only result files (preview PNGs, job and probe JSON, the
study's parameter charts).
"""

import math
import os
import re
import textwrap

import matplotlib

matplotlib.use("Agg")  # Files only: no display.
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

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
    props = matplotlib.font_manager.FontProperties(family=plt.rcParams["font.family"],
                                                   size=fontsize)
    renderer = _measuring_renderer()
    return max(renderer.get_text_width_height_descent(line, props, ismath=False)[0]
               for line in str(text).split("\n")) / 72.0


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
    width_in: as many columns as fit (matplotlib fills them column by column), at most max_cols."""
    n = len(names)
    if n == 0:
        return 1, 0, 0.0
    em = fontsize / 72.0
    widths = [text_width_in(x, fontsize) for x in names]
    cols = 1
    for c in range(min(n, max_cols or n), 0, -1):
        rows = -(-n // c)
        used = sum(max(widths[k:k + rows]) + (handlelength + handletextpad) * em
                   for k in range(0, n, rows))
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
            for tick in axis._update_ticks():
                texts += [t for t in (tick.label1, tick.label2) if t.get_visible()]
        texts.append(ax.yaxis.get_offset_text())
        texts.append(ax.xaxis.get_offset_text())
    unique = {id(t): t for t in texts}
    return [t for t in unique.values() if t.get_visible() and t.get_text().strip()]


def text_problems(fig):
    """Pairs of overlapping texts and texts outside the figure, in pixels at the figure's DPI."""
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = []
    for t in drawn_texts(fig):
        bb = t.get_window_extent(renderer)
        if bb.width > 0 and bb.height > 0:
            boxes.append((t.get_text().replace("\n", " "), bb))
    w, h = fig.get_size_inches() * fig.dpi
    outside = [s for s, b in boxes if b.x0 < -0.5 or b.y0 < -0.5 or b.x1 > w + 0.5 or b.y1 > h + 0.5]
    overlaps = []
    for i in range(len(boxes)):
        for j in range(i + 1, len(boxes)):
            a, b = boxes[i][1], boxes[j][1]
            # Touching is fine; a shared strip wider than a pixel both ways is an overlap.
            if min(a.x1, b.x1) - max(a.x0, b.x0) > 1 and min(a.y1, b.y1) - max(a.y0, b.y0) > 1:
                overlaps.append([boxes[i][0], boxes[j][0]])
    return overlaps, outside


def save_figure(fig, fig_dir, name, manifest, caption, extra=None):
    """Writes name.png and name.pdf and appends the figure's record to `manifest`; `extra`: more
    fields for the record (a split grid's kind, material and part)."""
    os.makedirs(fig_dir, exist_ok=True)
    # Whole pixels at DPI: Agg truncates width x dpi, so a hair above the pixel count gives
    # exactly the size figures.json records (the PDF moves by a thousandth of a point).
    w_px, h_px = (int(round(v * DPI)) for v in fig.get_size_inches())
    fig.set_size_inches((w_px + 0.01) / DPI, (h_px + 0.01) / DPI)
    fig.set_dpi(DPI)
    overlaps, outside = text_problems(fig)
    png = os.path.join(fig_dir, name + ".png")
    pdf = os.path.join(fig_dir, name + ".pdf")
    # The PNG is the drawing text_problems made at DPI (Agg's buffer), not a second drawing.
    mpimg.imsave(png + ".tmp.png", np.asarray(fig.canvas.buffer_rgba()), format="png", dpi=DPI)
    os.replace(png + ".tmp.png", png)
    # No creation date: a rerun writes the same bytes (docs/studies.md, "Determinism").
    # Each image stays its own (a grid's tiles share one axes; compositing them would resample
    # them into one raster at the PDF's 72 dpi).
    with matplotlib.rc_context({"image.composite_image": False}):
        fig.savefig(pdf + ".tmp.pdf", format="pdf", metadata={"CreationDate": None})
    os.replace(pdf + ".tmp.pdf", pdf)
    plt.close(fig)
    manifest.append({"name": name, "png": f"figures/{name}.png", "pdf": f"figures/{name}.pdf",
                     "width_in": round(w_px / DPI, 3), "height_in": round(h_px / DPI, 3),
                     "width": w_px, "height": h_px,
                     "caption": caption, "text_overlaps": overlaps, "text_outside": outside,
                     **(extra or {})})


# --- Image grids --------------------------------------------------------------------------------


def srgb_to_linear(v):
    return np.where(v <= 0.04045, v / 12.92, ((v + 0.055) / 1.055) ** 2.4)


def linear_to_srgb(v):
    v = np.clip(v, 0.0, 1.0)
    return np.where(v <= 0.0031308, v * 12.92, 1.055 * np.power(v, 1 / 2.4) - 0.055)


def read_rgb(path):
    img = mpimg.imread(path)
    if img.dtype != np.float32 and img.dtype != np.float64:
        img = img.astype(np.float32) / 255.0
    return img[..., :3]


def row_exposure(reference_rgb):
    """Whole stops that bring a dim reference's bright pixels (99th percentile of the lit ones)
    up to mid-grey-to-white; 0 for lightings that already read. At most +6."""
    lin = srgb_to_linear(reference_rgb).mean(axis=2)
    lit = lin[lin > 1e-4]
    if lit.size == 0:
        return 0
    p99 = float(np.percentile(lit, 99))
    if p99 >= 0.25:
        return 0
    return int(min(6, max(0, np.floor(np.log2(0.6 / max(p99, 1e-6))))))


def exposed(rgb, stops):
    return rgb if stops == 0 else linear_to_srgb(srgb_to_linear(rgb) * 2.0 ** stops)


def wrap_at_hyphens(text, width):
    """Lines of at most `width` characters, broken after hyphens and plus signs, before an "@"
    and at spaces, so a fit label fits over a narrow column ("blinn-phong-" / "normalized" /
    "@key+" / "mirror60")."""
    tokens = re.findall(r"@?[^\s@+-]+[-+]?|[@+-]|\s+", text)
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


# Fits in one grid figure: reference, fits and error maps make 1 + 2 n columns, and at 5 fits a
# 7 in page gives each image ~0.5 in. More fits split the grid into parts, one per training set
# (chunks of at most this many where a training set holds more).
GRID_MAX_FITS = 5


def grid_parts(study, labels):
    """[(suffix, labels)]: one part, suffix "", when the labels fit one figure; else one part per
    training set in study order, suffix "-<training set>" ("-key+mirror60"), and "-<k>" after it
    when a training set is chunked."""
    if len(labels) <= GRID_MAX_FITS:
        return [("", labels)]
    train = {f["label"]: "+".join(f.get("train") or []) for f in study["fits"]}
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


def common_at_suffix(labels):
    """The "@..." ending every label shares ("@key+mirror60"), or "" (then titles keep it)."""
    ends = {l[l.rfind("@"):] if "@" in l else "" for l in labels}
    return ends.pop() if len(ends) == 1 and len(labels) > 1 else ""


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
    for k, (suffix, part) in enumerate(parts):
        heading = ""
        if len(parts) > 1:
            train = next((f.get("train") for f in study["fits"] if f["label"] == part[0]), None)
            heading = f"part {k + 1} of {len(parts)}" + (
                f": fits trained on {', '.join(train)}" if train else "")
        fig, caption, rows = grid_figure(study_dir, study, fits, material, part, heading)
        save_figure(fig, fig_dir, f"grid-{material}{suffix}", manifest, caption,
                    {"kind": "grid", "material": material, "part": k + 1, "parts": len(parts),
                     "fits": part, "lightings": rows})


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


def object_box(images, threshold=1.5 / 255):
    """(x0, y0, x1, y1), half-open pixel bounds of the pixels brighter than `threshold` in any of
    `images` (display RGB of one size), grown by GRID_CROP_MARGIN of the larger side and clipped
    to the frame; None when no pixel is. The fits' previews are renders composited over black, so
    their bright pixels are the object's (a photograph's background is not black: the reference
    preview alone cannot say where the object is)."""
    lit = None
    for img in images:
        m = img[..., :3].max(axis=2) > threshold
        lit = m if lit is None else (lit | m if lit.shape == m.shape else lit)
    if lit is None or not lit.any():
        return None
    ys, xs = np.nonzero(lit)
    x0, x1, y0, y1 = int(xs.min()), int(xs.max()) + 1, int(ys.min()), int(ys.max()) + 1
    pad = max(2, int(math.ceil(GRID_CROP_MARGIN * max(x1 - x0, y1 - y0))))
    h, w = lit.shape
    return max(0, x0 - pad), max(0, y0 - pad), min(w, x1 + pad), min(h, y1 + pad)


def grid_crop(study_dir, evals, labels, rows):
    """The crop box of a grid (object_box over every fit preview of its rows; the reference
    previews when there is no fit preview) and the frame's size (w, h); (None, None) when no
    preview can be read."""
    def previews(key, only_labels):
        for light in rows:
            for l in only_labels:
                rel = evals[l].get(light, {}).get("images", {}).get(key)
                if rel and os.path.exists(os.path.join(study_dir, rel)):
                    yield read_rgb(os.path.join(study_dir, rel))

    for key, ls in (("fit", labels), ("reference", labels[:1])):
        frame, lit = None, []
        for img in previews(key, ls):
            frame = frame or (img.shape[1], img.shape[0])
            if (img.shape[1], img.shape[0]) == frame:
                lit.append(img[..., :3].max(axis=2, keepdims=True))  # one channel: less memory
        if frame is not None:
            return object_box(lit) or (0, 0, frame[0], frame[1]), frame
    return None, None


def grid_figure(study_dir, study, fits, material, labels, heading):
    """One grid figure over `labels`, and its caption; `heading` (a split grid's part) goes above
    the column titles and into the caption. Every frame is cropped to the object's bounds
    (grid_crop) and keeps its pixel aspect ratio; many lightings show a subset (grid_lightings)."""
    evals = {l: {e["lighting"]: e for e in fits[(material, l)]["evaluations"]} for l in labels}
    all_lightings = [r["lighting"] for g in study["groups"] if g["material"] == material
                     for r in g["references"]]
    lightings, rows_note = grid_lightings(evals, labels, all_lightings)
    box, frame = grid_crop(study_dir, evals, labels, lightings)
    aspect = (box[3] - box[1]) / (box[2] - box[0]) if box else 1.0  # tile height / width
    ncols = 1 + 2 * len(labels)
    left_in, bar_in, right_in = 0.42, 0.08, 0.52  # Row labels; colour bar; its ticks and label.
    gap_in = 0.03
    cell_w = (PAGE_IN - left_in - bar_in - right_in - gap_in * (ncols + 1)) / ncols
    # A training set every fit of the figure shares is said once, in the heading.
    common = common_at_suffix(labels) if heading else ""
    short = [l[:len(l) - len(common)] if common else l for l in labels]
    if common:
        heading += f" (labels end in {common})"
    heading_in = (FONT_PT * 1.3 + 4) / 72 if heading else 0.0

    def titles_for(width):  # Column titles wrapped to the column, measured.
        return ["reference"] + [wrap_to_width(l, width, FONT_PT - 1) for l in short] + \
            [wrap_to_width(f"|error| {l}", width, FONT_PT - 1) for l in short]

    titles = titles_for(cell_w)
    title_lines = max(t.count("\n") + 1 for t in titles)
    top_in = title_lines * (FONT_PT - 1) * 1.25 / 72 + 0.08 + heading_in
    bottom_in = 0.02
    # The tiles' height follows the crop's aspect; a figure taller than the page shrinks them
    # (the figure stays PAGE_IN wide, the tiles start at the left).
    cell_h = cell_w * aspect
    max_cell_h = (GRID_MAX_HEIGHT_IN - top_in - bottom_in) / len(lightings) - gap_in
    if cell_h > max_cell_h:
        cell_h = max_cell_h
        cell_w = cell_h / aspect
        titles = titles_for(cell_w)
        title_lines = max(t.count("\n") + 1 for t in titles)
        top_in = title_lines * (FONT_PT - 1) * 1.25 / 72 + 0.08 + heading_in
    height = top_in + bottom_in + len(lightings) * (cell_h + gap_in)
    # Shrunk tiles leave the page's width: centre the grid on it (row labels to colour bar).
    left_in += max(0.0, PAGE_IN - bar_in - right_in - gap_in - ncols * (cell_w + gap_in)
                   - left_in) / 2
    bar_x = left_in + gap_in + ncols * (cell_w + gap_in)  # where the last tile's gap ends
    fig = plt.figure(figsize=(PAGE_IN, height))
    fx = lambda inch: inch / PAGE_IN  # noqa: E731
    fy = lambda inch: inch / height  # noqa: E731
    # Every tile is an image of one axes spanning the figure, in inches: one axes per tile (up to
    # 77 in the measured study) made building a grid take ~2 s, most of the report's time.
    tiles = fig.add_axes([0, 0, 1, 1])
    tiles.set_axis_off()
    tiles.set_xticks([])
    tiles.set_yticks([])
    if heading:
        fig.text(fx(left_in + gap_in), fy(height - 0.03), f"{material}, {heading}", ha="left",
                 va="top", fontsize=FONT_PT)

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

    exposures = []
    for i, light in enumerate(lightings):
        y0 = height - top_in - (i + 1) * (cell_h + gap_in) + gap_in
        first = evals[labels[0]].get(light, {}).get("images", {})
        ref_path = os.path.join(study_dir, first["reference"]) if first.get("reference") else None
        ref = read_rgb(ref_path) if ref_path and os.path.exists(ref_path) else None
        stops = row_exposure(cropped(ref)) if ref is not None else 0
        exposures.append((light, stops))
        panels = [("reference", first.get("reference"), False)]
        panels += [(l, evals[l].get(light, {}).get("images", {}).get("fit"), False) for l in labels]
        panels += [(f"|error| {l}", evals[l].get(light, {}).get("images", {}).get("error"), True)
                   for l in labels]
        error_scale = None
        for j, (title, rel, is_error) in enumerate(panels):
            x0 = left_in + gap_in + j * (cell_w + gap_in)
            if i == 0:
                tiles.text(x0 + cell_w / 2, y0 + cell_h + 2 / 72, titles[j], ha="center",
                           va="bottom", fontsize=FONT_PT - 1)
            if not rel or not os.path.exists(os.path.join(study_dir, rel)):
                tiles.text(x0 + cell_w / 2, y0 + cell_h / 2, "missing", ha="center", va="center")
                continue
            img = ref if j == 0 and ref is not None else read_rgb(os.path.join(study_dir, rel))
            if is_error:
                if frame is None:  # No preview to size it: keep the square image part.
                    img = img[:, :img.shape[0]]
                lab = labels[j - 1 - len(labels)]
                error_scale = evals[lab].get(light, {}).get("images", {}).get("error_scale")
                img = cropped(img)
            else:
                img = exposed(cropped(img), stops)
            tiles.imshow(img, interpolation="nearest", aspect="auto",
                         extent=(x0, x0 + cell_w, y0, y0 + cell_h))
        split = next((evals[l].get(light, {}).get("split") for l in labels
                      if evals[l].get(light, {}).get("split")), "")
        row_label = light + (f"\n({split})" if split else "") + (f"\n+{stops} EV" if stops else "")
        fig.text(fx(left_in - 0.02), fy(y0 + cell_h / 2), row_label, ha="right", va="center",
                 fontsize=FONT_PT - 1)
        if error_scale:
            cax = fig.add_axes([fx(bar_x), fy(y0), fx(bar_in), fy(cell_h)])
            sm = matplotlib.cm.ScalarMappable(norm=matplotlib.colors.Normalize(0, error_scale),
                                              cmap="viridis")
            cb = fig.colorbar(sm, cax=cax)
            cb.set_ticks([0, error_scale / 2, error_scale])
            cb.ax.set_yticklabels([f"{t:.2g}" for t in (0, error_scale / 2, error_scale)])
            cb.ax.tick_params(labelsize=FONT_PT - 2, length=2, pad=1)
            # The end labels stay inside the bar's height, clear of the next row's.
            tl = cb.ax.get_yticklabels()
            tl[0].set_verticalalignment("bottom")
            tl[-1].set_verticalalignment("top")
            cb.outline.set_linewidth(0.4)
            if i == 0:
                # Over the bars' column, which no column title reaches (titles are wrapped to
                # their image's width).
                fig.text(fx(bar_x), fy(y0 + cell_h + 0.03), UNITS_RADIANCE, ha="left",
                         va="bottom", fontsize=FONT_PT - 2)
    tiles.set_xlim(0, PAGE_IN)  # imshow widened the limits to its extents; inches again.
    tiles.set_ylim(0, height)
    dim = [f"{l} +{s} EV" for l, s in exposures if s]
    crop_note = ""
    if box is not None and frame is not None and (box[2] - box[0], box[3] - box[1]) != frame:
        crop_note = (f"; frames cropped to the object ({box[2] - box[0]} x {box[3] - box[1]} of "
                     f"{frame[0]} x {frame[1]} px)")
    caption = (f"{material}" + (f", {heading}" if heading else "")
               + ": reference, fits and |fit - reference| (mean RGB, linear radiance, "
               f"colour bar in {UNITS_RADIANCE} shared by the fits of a row) per lighting; "
               "images at the study's display exposure"
               + (f", dim lightings brightened: {', '.join(dim)}" if dim else "") + crop_note
               + (f"; {rows_note}" if rows_note else "") + ".")
    return fig, caption, lightings


# --- Probe curves and bars ----------------------------------------------------------------------

# Lighting shown per probe: one per panel keeps a figure readable (all lightings stay in the JSON
# and the tables). Back light for Fresnel, key light for the highlight shape.
PREFERRED_LIGHTING = {"fresnel": ["rim", "side", "mirror75"], "highlight": ["key", "camera"]}
# The energy probe's sweep (CurveKindName, metrics/probes/src/probe_kind.cpp).
SWEEP_KIND = "sweep of the lobe width"
# Curve kinds drawn on a log y axis whatever the probe says: the sweep spans three decades, and
# the brdf probe's Fresnel rise is a factor over the centre that fits take to 100 or more.
LOG_KINDS = (SWEEP_KIND, "Fresnel rise")


# Series drawn as the ground truth (dashed black, on top): the reference image's, the true BRDF's,
# or the measured BRDF's (the brdf probe).
GROUND_SERIES = ("reference", "truth", "measured")
PANELS_PER_ROW = 3


def plot_curve(ax, c, ys, **style):
    """Draws one curve; points flagged "extrapolated" (MERL beyond theta_d = 75 deg) are drawn
    dotted with open markers from the last measured point on, so they are seen, not hidden.
    Returns the handle of the measured part."""
    flags = c.get("extrapolated") or []
    xs = np.array(c["x"], dtype=float)
    if not flags or not any(flags):
        h, = ax.plot(xs, ys, **style)
        return h, None
    flags = np.array(flags, dtype=bool)
    solid = np.where(flags, np.nan, ys)
    h, = ax.plot(xs, solid, **style)
    # The dotted part starts at the last measured point so that the two join.
    joined = flags.copy()
    joined[:-1] |= flags[1:]
    dotted = np.where(joined, ys, np.nan)
    e, = ax.plot(xs, dotted, color=h.get_color(), linestyle=":", linewidth=1.0, marker="o",
                 markersize=2.5, markerfacecolor="white", markeredgewidth=0.6)
    return h, e


def probe_curve_figure(probe, material, curves, labels):
    """One panel per curve kind, in the order the probe measured them, PANELS_PER_ROW to a row;
    per-reference curves show one reference (PREFERRED_LIGHTING). `curves`: the probe's curve
    records, {"series", "reference", "kind", "x", "y", "x_label", "y_label", "x_scale",
    "y_scale", "extrapolated" (optional)} (ProbeResultToJson, docs/probes.md)."""
    curves = [c for c in curves if c["x"] and len(c["x"]) == len(c["y"])]
    if not curves:
        return None
    kinds = []
    for c in curves:
        if c["kind"] not in kinds:
            kinds.append(c["kind"])
    n = len(kinds)
    cols = min(n, PANELS_PER_ROW)
    rows = (n + cols - 1) // cols
    width = COLUMN_IN if n == 1 else PAGE_IN
    panel_h = 1.9 if rows == 1 else 2.15  # a second row leaves room for the first's x label
    # The legend holds every series and an "extrapolated" entry per series with flagged points,
    # at most three to a row, fewer where the names are too long for the width.
    entries = sorted({c["series"] for c in curves}) + sorted(
        {c["series"] + ", extrapolated" for c in curves if any(c.get("extrapolated") or [])})
    legend_cols, _, legend_in = legend_layout(entries, width, max_cols=3)
    legend_h = max(0.55, legend_in + 0.12)
    height = rows * panel_h + legend_h + 0.25
    label_chars = 40 if cols < 3 else 30
    fig = plt.figure(figsize=(width, height))
    handles = {}
    series = sorted({c["series"] for c in curves if c["series"] not in GROUND_SERIES},
                    key=lambda x: (labels.index(x) if x in labels else len(labels), x))
    for k_i, kind in enumerate(kinds):
        row, col = divmod(k_i, cols)
        left_in = 0.72  # Room for a two-line axis label and its tick labels.
        bottom_in = legend_h + 0.3 + (rows - 1 - row) * panel_h
        ax = fig.add_axes([(left_in + col * width / cols) / width, bottom_in / height,
                           (width / cols - left_in - 0.2) / width, (1.9 - 0.45) / height])
        # Fits in the study's order, the ground truth (dashed black) last, on top of them.
        items = sorted((c for c in curves if c["kind"] == kind), key=lambda c: (
            c["series"] in GROUND_SERIES,
            series.index(c["series"]) if c["series"] in series else len(series)))
        refs = sorted({c["reference"] for c in items if c["reference"]})
        chosen = None
        for want in PREFERRED_LIGHTING.get(probe, []):
            chosen = next((r for r in refs if r.endswith("-" + want)), None)
            if chosen:
                break
        chosen = chosen or (refs[0] if refs else None)
        for c in items:
            lab, ref = c["series"], c["reference"]
            if ref and ref != chosen:
                continue
            ys = np.array([np.nan if y is None else y for y in c["y"]], dtype=float)
            if lab in GROUND_SERIES:
                h, e = plot_curve(ax, c, ys, color="black", linestyle=(0, (2, 1)), linewidth=1.4,
                                  label=lab)
            else:
                h, e = plot_curve(ax, c, ys, linewidth=1.1, label=lab, **style_of(lab, series))
            handles.setdefault(lab, h)
            if e is not None:
                handles.setdefault(f"{lab}, extrapolated", e)
            ax.set_xlabel(textwrap.fill(c["x_label"], label_chars))
            ax.set_ylabel(textwrap.fill(c["y_label"], 26))
            # The highlight falloff and the energy sweep span decades: log y for both.
            if c["y_scale"] == "log" or probe == "highlight" or kind in LOG_KINDS:
                ax.set_yscale("log")
            if c["x_scale"] == "log":
                ax.set_xscale("log")
        if ax.get_yscale() == "log":
            # Five decades below the panel's largest value: a specular part that falls to zero
            # (or below the floor) would otherwise stretch the axis over 1e-15.
            top = max((np.nanmax(l.get_ydata()) for l in ax.get_lines()
                       if np.isfinite(l.get_ydata()).any()), default=None)
            if top and top > 0:
                ax.set_ylim(bottom=max(ax.get_ylim()[0], top * 1e-5))
        title = kind + (f" ({chosen})" if chosen else "")
        ax.set_title(title if len(title) < 48 else title[:45] + "...", fontsize=FONT_PT)
    def legend_order(name):  # ground truth first, then the fits in the study's order
        base = name.split(", extrapolated")[0]
        return (base not in GROUND_SERIES, series.index(base) if base in series else -1, name)
    names = sorted(handles, key=legend_order)
    fig.legend([handles[x] for x in names], names, loc="lower center", ncol=legend_cols,
               frameon=False, bbox_to_anchor=(0.5, 0.0))
    fig.suptitle(f"{material}: {probe}", fontsize=FONT_PT + 1, y=0.99)
    return fig


HATCHES = ["", "///", "...", "xx", "\\\\", "++"]


def bar_style(i, label):
    """Fill of the i-th series of a bar chart: the ground truth black, the fits an Okabe-Ito
    colour and a hatch each (7 x 6 distinct pairs, so more fits than colours still separate)."""
    if label in GROUND_SERIES:
        return {"color": "black", "hatch": "", "edgecolor": "white", "linewidth": 0}
    return {"color": OKABE_ITO[i % len(OKABE_ITO)], "hatch": HATCHES[i % len(HATCHES)],
            "edgecolor": "white", "linewidth": 0}


def probe_bar_figure(probe, material, numbers, flatten, labels=()):
    """Grouped bars of a probe's numbers: the ground truth first, then the fits in the study's
    order (`labels`). Laid out in inches from top to bottom: title, legend (as many rows as its
    names need), axes, the vertical key labels (as deep as the longest)."""
    series = sorted(numbers.keys(), key=lambda x: (
        x not in GROUND_SERIES, labels.index(x) if x in labels else len(labels), x))
    keys = []
    for s in series:
        keys += [k for k in flatten(numbers[s]) if k not in keys]
    keys = keys[:12]
    # Upright-box labels: vertical text, the material's name dropped from per-reference keys.
    short = [k.replace(material + "-", "") for k in keys]
    short = [k if len(k) < 30 else k[:27] + "..." for k in short]
    legend_cols, _, legend_in = legend_layout(series, PAGE_IN - 0.2, handlelength=1.5,
                                              columnspacing=1.5)
    title_in, axes_in = 0.25, 1.3
    ticks_in = max([text_width_in(k, FONT_PT - 2) for k in short], default=0.0) + 0.12
    height = title_in + legend_in + 0.08 + axes_in + ticks_in + 0.05
    fig = plt.figure(figsize=(PAGE_IN, height))
    ax = fig.add_axes([0.6 / PAGE_IN, (ticks_in + 0.05) / height, (PAGE_IN - 0.75) / PAGE_IN,
                       axes_in / height])
    if not keys or not series:
        ax.text(0.5, 0.5, "no numbers reported", ha="center", transform=ax.transAxes)
    else:
        width = 0.8 / len(series)
        x = np.arange(len(keys))
        for i, s in enumerate(series):
            f = flatten(numbers[s])
            # The fit's place in the study picks its fill, as in the other bar figure.
            ax.bar(x + i * width, [f.get(k, np.nan) for k in keys], width, label=s,
                   **bar_style(labels.index(s) if s in labels else i, s))
        ax.set_xticks(x + 0.4 - width / 2)
        ax.set_xticklabels(short, rotation=90, fontsize=FONT_PT - 2)
        fig.legend(*ax.get_legend_handles_labels(), frameon=False, ncol=legend_cols,
                   loc="upper center", bbox_to_anchor=(0.5, 1 - title_in / height),
                   handlelength=1.5, columnspacing=1.5)
    fig.suptitle(f"{material}: {probe}", fontsize=FONT_PT + 1, y=1 - 0.03 / height, va="top")
    return fig


def probe_figures(study, probes, fig_dir, manifest, flatten):
    labels = [f["label"] for f in study["fits"]]
    for material, job in sorted(probes.items()):
        for probe, result in job.get("probes", {}).items():
            curves = result.get("curves") or []
            fig = None
            if probe != "portability" and curves:
                fig = probe_curve_figure(probe, material, curves, labels)
            if fig is None:
                fig = probe_bar_figure(probe, material, result.get("numbers") or {}, flatten,
                                       labels)
            save_figure(fig, fig_dir, f"probe-{probe}-{material}", manifest,
                        f"{material}: {probe} probe (reference or measured BRDF dashed black; "
                        "extrapolated points dotted, open markers)")


# Bars per panel above which the train and test panels stack (each the page's width) instead of
# standing side by side: 40 bars in half a page are ~1 mm each.
SIDE_BY_SIDE_BARS = 40


def metric_bars(study, rows, fig_dir, manifest, to_float, metric="flip_ldr_mean"):
    """Mean metric per material and fit, training lighting and test lightings. Laid out in inches
    from the measured texts: the legend on top with as many rows as its names need, the material
    names (vertical) as deep as the longest."""
    materials = [g["material"] for g in study["groups"]]
    labels = [f["label"] for f in study["fits"]]
    stacked = len(labels) * len(materials) > SIDE_BY_SIDE_BARS
    legend_cols, _, legend_in = legend_layout(labels, PAGE_IN - 0.2, handlelength=1.5,
                                              columnspacing=1.5)
    names_in = max([text_width_in(m, FONT_PT - 1) for m in materials], default=0.0) + 0.1
    left_in, title_in, axes_in = 0.55, 0.2, 1.3
    if stacked:
        # Train above test, the material names under the lower panel only (shared x axis).
        height = legend_in + 2 * (title_in + axes_in) + 0.1 + names_in + 0.05
        boxes = [(left_in, names_in + 0.05 + axes_in + title_in + 0.1, PAGE_IN - left_in - 0.1),
                 (left_in, names_in + 0.05, PAGE_IN - left_in - 0.1)]
    else:
        height = legend_in + title_in + axes_in + names_in + 0.05
        half = PAGE_IN / 2
        boxes = [(left_in, names_in + 0.05, half - left_in - 0.1),
                 (half + left_in, names_in + 0.05, half - left_in - 0.1)]
    fig = plt.figure(figsize=(PAGE_IN, height))
    axes = []
    for (x0, y0, w) in boxes:
        axes.append(fig.add_axes([x0 / PAGE_IN, y0 / height, w / PAGE_IN, axes_in / height],
                                 sharex=axes[0] if axes and stacked else None))
    for ax, split in zip(axes, ["train", "test"]):
        width = 0.8 / max(1, len(labels))
        x = np.arange(len(materials))
        for i, l in enumerate(labels):
            vals = []
            for m in materials:
                v = [to_float(r[metric]) for r in rows
                     if r["material"] == m and r["label"] == l and r["split"] == split]
                v = [a for a in v if a is not None]
                vals.append(np.mean(v) if v else np.nan)
            ax.bar(x + i * width, vals, width, label=l, **bar_style(i, l))
        ax.set_xticks(x + 0.4 - width / 2)
        ax.set_xlim(-0.3, len(materials) - 0.1)
        if stacked and split == "train":
            ax.tick_params(labelbottom=False)
        else:
            ax.set_xticklabels(materials, rotation=90)
        ax.set_title(f"{split} lightings", fontsize=FONT_PT, pad=3)
        ax.set_ylabel(f"{metric} (lower is better)" if split == "train" or stacked else "")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="upper center", ncol=legend_cols,
               frameon=False, bbox_to_anchor=(0.5, 1.0), handlelength=1.5, columnspacing=1.5)
    save_figure(fig, fig_dir, f"metric-{metric}", manifest,
                f"Mean {metric} per material and fit: training lighting "
                f"({'top' if stacked else 'left'}) and test lightings "
                f"({'bottom' if stacked else 'right'})")


# --- Comparative answers ------------------------------------------------------------------------


def paired_errors_figure(rec, study, fig_dir, manifest, title, y_label):
    """One question's errors: each material's errors per fit as grey lines joining that
    material's fits of one training set, over a box per fit (median, quartiles, whiskers at 1.5
    IQR) of the distribution over materials. Log axis for ratio questions."""
    fits = study["fits"]
    used = set()
    for c in rec["comparisons"]:
        used.update([c["fit"], c["baseline"]])
    order = [f["label"] for f in fits if f["label"] in used]
    if not order:
        return
    groups = {}
    for f in fits:
        if f["label"] in used:
            groups.setdefault(tuple(f.get("train") or []), []).append(f["label"])
    errors = {}
    for key, e in rec["errors"].items():
        m, label = key.split("|", 1)
        if e is not None and math.isfinite(e):
            errors[(m, label)] = e
    materials = sorted({m for m, _ in errors})
    log = rec["mode"] == "ratio" and all(e > 0 for e in errors.values())
    wide = len(order) > 4
    width = PAGE_IN if wide else COLUMN_IN
    label_in = max(text_width_in(l, FONT_PT - 1) for l in order) + 0.1
    title_lines = wrap_to_width(title, width - 0.2, FONT_PT)
    title_in = 0.16 * (title_lines.count("\n") + 1) + 0.06
    axes_in = 1.7
    height = title_in + axes_in + label_in + 0.1
    left_in = 0.6
    fig = plt.figure(figsize=(width, height))
    ax = fig.add_axes([left_in / width, (label_in + 0.05) / height,
                       (width - left_in - 0.1) / width, axes_in / height])
    x_of = {l: i for i, l in enumerate(order)}
    for labels in groups.values():
        for m in materials:
            pts = [(x_of[l], errors[(m, l)]) for l in labels if (m, l) in errors]
            if len(pts) >= 2:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], color="#999999",
                        linewidth=0.5, alpha=0.7, zorder=1)
    data = [[errors[(m, l)] for m in materials if (m, l) in errors] for l in order]
    keep = [i for i, d in enumerate(data) if d]
    if keep:
        ax.boxplot([data[i] for i in keep], positions=keep, widths=0.45, showfliers=False,
                   patch_artist=True, zorder=2,
                   boxprops={"facecolor": "none", "linewidth": 0.8},
                   medianprops={"color": "black", "linewidth": 1.2},
                   whiskerprops={"linewidth": 0.8}, capprops={"linewidth": 0.8})
    for i, l in enumerate(order):
        ys = [errors[(m, l)] for m in materials if (m, l) in errors]
        ax.scatter([i] * len(ys), ys, s=5, color=style_of(l, [f["label"] for f in fits])["color"],
                   zorder=3, linewidths=0)
    if log:
        ax.set_yscale("log")
    ax.set_xticks(range(len(order)))
    ax.set_xticklabels(order, rotation=90)
    ax.set_xlim(-0.6, len(order) - 0.4)
    ax.set_ylabel(y_label)
    fig.text(0.5, 1 - 0.04 / height, title_lines, ha="center", va="top", fontsize=FONT_PT)
    save_figure(fig, fig_dir, f"compare-{re.sub(r'[^A-Za-z0-9_-]+', '_', rec['name'])}",
                manifest, f"{title}: each material's error per fit (grey lines join a "
                          f"material's fits of one training set) over the distribution per fit "
                          f"(box: quartiles and median; whiskers: 1.5 IQR)"
                          + (" (log axis)" if log else ""),
                {"kind": "comparison", "question": rec["name"]})
