#!/usr/bin/python3
"""A figure's PDF written from its Agg drawing (report_figures.ONE_DRAWING, _PdfCalls) is
matplotlib's own PDF of it, placed where the PNG places things:

- the PNG is the same bytes with and without the calls kept (keeping them changes no drawing);
- every content stream (the page, markers, hatches) is matplotlib's own, token by token: the
  same operators, names and strings in the same order, every number outside text within 0.01 pt
  (paths, markers, clips and images; the figures here place their axes without measuring text),
  text positions, and the lines a legend, an arrow or a text box places by its text, within
  1.5 pt (matplotlib's own PDF measures text at 72 dpi, hinted);
- the images are the same size, and a grid's one raster is the PNG's pixels (figures_test's
  check);
- a legend's texts start where the PNG's drawing put them (Agg's window extent, less nothing:
  left and baseline aligned), within 0.05 pt; matplotlib's own PDF lays the legend out again at
  72 dpi and puts them up to several points away;
- a figure that asks the renderer for a call not kept (a quad mesh) gets matplotlib's own PDF,
  the same bytes.

The figures use what the report's do and more: dashes, markers, log axes with mathtext labels,
rotated labels (90 degrees and 30 with rotation_mode "anchor"), clipped lines, a scatter, a
filled band, error bars, hatched bars, an arrow, a text box, an image, a legend, and a grid's
tiles taken as one raster.

    one_drawing_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import os
import re
import sys
import zlib

import numpy as np

from figures_test import pdf_raster_problems, pdf_streams  # the same folder

TOKEN = re.compile(rb"<[0-9a-fA-F]*>|\((?:\\.|[^\\)])*\)|\[|\]|/[^\s/\[\]<>()]+"
                   rb"|[-+]?(?:\d+\.?\d*|\.\d+)|[A-Za-z'\"*]+")
NUMBER = re.compile(rb"[-+]?(?:\d+\.?\d*|\.\d+)$")


def content_streams(path):
    """The decompressed streams of a PDF that are drawing operations (not fonts, images or
    metadata), in file order."""
    with open(path, "rb") as f:
        pdf = f.read()
    out = []
    for d, data in pdf_streams(pdf):
        if b"/Subtype /Image" in d or b"/Length1" in d or b"/FlateDecode" not in d:
            continue
        out.append(zlib.decompress(data))
    return out


def image_sizes(path):
    with open(path, "rb") as f:
        pdf = f.read()
    return [(int(re.search(rb"/Width (\d+)", d).group(1)),
             int(re.search(rb"/Height (\d+)", d).group(1)))
            for d, _ in pdf_streams(pdf) if b"/Subtype /Image" in d]


def compare_pdfs(ours, theirs, tolerance=0.01):
    """Problems of our PDF against matplotlib's own of the same figure: numbers outside text
    within `tolerance` pt (more where the figure places lines by its text, as a legend does)."""
    a, b = content_streams(ours), content_streams(theirs)
    if len(a) != len(b):
        return [f"{len(a)} content streams, matplotlib's own PDF has {len(b)}"]
    problems = []
    worst_text = 0.0
    for k, (sa, sb) in enumerate(zip(a, b)):
        ta, tb = TOKEN.findall(sa), TOKEN.findall(sb)
        if len(ta) != len(tb):
            problems.append(f"stream {k}: {len(ta)} tokens, matplotlib's {len(tb)}")
            continue
        # A text's numbers: its placing matrix (`q a b c d x y cm BT`) and those inside BT/ET.
        text = set()
        for i in range(len(ta) - 1):
            if ta[i] == b"cm" and ta[i + 1] == b"BT":
                text.update(range(i - 6, i))
        in_text = False
        for i, (x, y) in enumerate(zip(ta, tb)):
            if x == b"BT":
                in_text = True
            elif x == b"ET":
                in_text = False
            if NUMBER.match(x) and NUMBER.match(y):
                placing = in_text or i in text
                diff = abs(float(x) - float(y))
                if placing:
                    worst_text = max(worst_text, diff)
                if diff > (1.5 if placing else tolerance):
                    context = b" ".join(ta[max(0, i - 6):i + 3]).decode("latin-1")
                    problems.append(f"stream {k} token {i}: {x.decode()} against matplotlib's "
                                    f"{y.decode()} (in '{context}')")
            elif x != y:
                context = b" ".join(ta[max(0, i - 6):i + 3]).decode("latin-1")
                problems.append(f"stream {k} token {i}: {x!r} against matplotlib's {y!r} "
                                f"(in '{context}')")
            if len(problems) > 5:
                return problems
    if image_sizes(ours) != image_sizes(theirs):
        problems.append(f"images {image_sizes(ours)}, matplotlib's {image_sizes(theirs)}")
    print(f"  {os.path.basename(ours)}: text positions within {worst_text:.3f} pt of "
          "matplotlib's own")
    return problems


def text_starts(path):
    """(x, y) of each unrotated text of the page (`q 1 0 -0 1 x y cm BT`), in points."""
    return [(float(m.group(1)), float(m.group(2))) for s in content_streams(path)
            for m in re.finditer(rb"1 0 -?0 1 ([-\d.]+) ([-\d.]+) cm\s+BT", s)]


def main(argv):
    sys.path.insert(0, argv[1])
    out = argv[2]
    os.makedirs(out, exist_ok=True)
    import matplotlib.pyplot as plt
    import report_figures as rf

    if not rf.MATPLOTLIB_3_6:
        print("SKIP: matplotlib is not 3.6 (the PDF is matplotlib's own drawing there)")
        return 0
    def lines_figure():
        rng = np.random.default_rng(3)
        fig = plt.figure(figsize=(rf.COLUMN_IN, 2.6))
        ax = fig.add_axes([0.18, 0.2, 0.5, 0.65])
        x = np.linspace(0.0, 80.0, 60)
        for k in range(4):
            ax.plot(x, np.exp(-x / (5 + 10 * k)) + 1e-4, linestyle=rf.LINE_STYLES[k],
                    color=rf.OKABE_ITO[k])
        ax.plot(x[::6], np.exp(-x[::6] / 12), "o:", markersize=3, mfc="white", color="black")
        ax.plot([-20, 120], [1e-5, 10], color="grey", lw=0.8)  # clipped at the axes
        ax.set_yscale("log")
        ax.set_ylim(1e-5, 2)
        ax.set_xlim(0, 80)
        ax.set_xlabel("theta_h (deg)")
        ax.set_ylabel("specular / peak")
        ax.set_title("falloff")
        ax2 = fig.add_axes([0.75, 0.2, 0.22, 0.65])
        ax2.scatter(rng.random(12), rng.random(12), s=rng.uniform(4, 30, 12), c="tab:blue")
        ax2.fill_between([0, 0.5, 1], [0.1, 0.3, 0.2], [0.4, 0.8, 0.6], alpha=0.3)
        ax2.errorbar([0.2, 0.5, 0.8], [0.5, 0.4, 0.6], yerr=0.1, fmt="none", ecolor="k")
        ax2.set_xticks([0, 0.5, 1])
        ax2.set_xticklabels(["low", "mid", "high"], rotation=30, ha="right",
                            rotation_mode="anchor")
        fig.text(0.02, 0.03, "a note $\\theta_d = 5$")
        return fig, None

    def bars_figure():
        rng = np.random.default_rng(4)
        fig = plt.figure(figsize=(rf.COLUMN_IN, 2.0))
        ax = fig.add_axes([0.15, 0.25, 0.5, 0.6])
        ax.bar(np.arange(4), [0.3, 0.5, 0.2, 0.7], color=rf.OKABE_ITO[:4], hatch="//",
               edgecolor="black", linewidth=0.5)
        ax.set_xticks(np.arange(4))
        ax.set_xticklabels(["blinn-phong", "ggx", "beckmann", "phong"], rotation=90)
        ax3 = fig.add_axes([0.72, 0.25, 0.25, 0.6])
        ax3.imshow(rng.random((9, 7, 3)), interpolation="nearest", aspect="auto")
        ax3.set_title("an image")
        return fig, None

    def legend_figure():
        fig = plt.figure(figsize=(rf.COLUMN_IN, 2.4))
        ax = fig.add_axes([0.15, 0.45, 0.8, 0.45])
        for k in range(5):
            ax.plot([0, 1], [k, k + 1], linestyle=rf.LINE_STYLES[k], color=rf.OKABE_ITO[k],
                    label=f"model-{k}@key:cuberoot")
        fig.legend(loc="lower center", ncol=2, frameon=False)
        ax.annotate("peak", xy=(0.5, 3), xytext=(0.1, 4.5),
                    arrowprops={"arrowstyle": "->", "lw": 0.6})
        fig.text(0.7, 0.93, "a boxed note", bbox={"boxstyle": "round", "fc": "0.9", "lw": 0.5})
        return fig, None

    def grid_figure():
        rng = np.random.default_rng(5)
        fig = plt.figure(figsize=(rf.COLUMN_IN, 1.2))
        tiles = fig.add_axes([0, 0, 1, 1])
        tiles.set_xlim(0, 4)
        tiles.set_ylim(0, 1)
        tiles.set_axis_off()
        for k in range(4):
            tiles.imshow((rng.random((20, 20, 3)) * 255).astype(np.uint8),
                         extent=(k + 0.05, k + 0.95, 0.1, 0.8), interpolation="nearest",
                         aspect="auto")
            tiles.text(k + 0.5, 0.9, f"tile {k}", ha="center", va="center")
        return fig, tiles

    def mesh_figure():  # a quad mesh: not kept, so the PDF is matplotlib's own drawing
        fig = plt.figure(figsize=(rf.COLUMN_IN, 1.5))
        ax = fig.add_axes([0.15, 0.2, 0.7, 0.7])
        ax.pcolormesh(np.arange(5), np.arange(4), np.arange(12).reshape(3, 4))
        return fig, None

    figures = {"lines": lines_figure, "bars": bars_figure, "legend": legend_figure,
               "grid": grid_figure, "mesh": mesh_figure}
    failures = []
    for name, make in figures.items():
        paths = {}
        for one in (True, False):
            rf.ONE_DRAWING = one
            fig, raster = make()
            folder = os.path.join(out, "ours" if one else "matplotlib")
            manifest = []
            if name == "legend" and one:
                legend_fig = fig
            rf.save_figure(fig, folder, name, manifest, name, pdf_raster=raster)
            paths[one] = (os.path.join(folder, name + ".png"), os.path.join(folder, name + ".pdf"))
        rf.ONE_DRAWING = rf.MATPLOTLIB_3_6
        with open(paths[True][0], "rb") as f, open(paths[False][0], "rb") as g:
            if f.read() != g.read():
                failures.append(f"{name}: the PNG differs with the calls kept")
        if name == "mesh":
            with open(paths[True][1], "rb") as f, open(paths[False][1], "rb") as g:
                if f.read() != g.read():
                    failures.append("mesh: a figure with a quad mesh is not matplotlib's own "
                                    "PDF")
            continue
        # The legend figure's lines, arrow and box are placed by its text: as its text.
        failures += [f"{name}: {p}" for p in compare_pdfs(
            paths[True][1], paths[False][1], 1.5 if name == "legend" else 0.01)]
        if name == "grid":
            failures += [f"{name}: {p}" for p in pdf_raster_problems(paths[True][1],
                                                                      paths[True][0])]
        if name == "legend":
            # Where the PNG's drawing put each legend text: its Agg extent's left and its
            # baseline (the extent's bottom plus the text's descent, measured by Agg).
            renderer = legend_fig.canvas.get_renderer()
            scale = 72.0 / rf.DPI
            starts = text_starts(paths[True][1])
            theirs = text_starts(paths[False][1])
            worst_theirs = 0.0
            for t in legend_fig.legends[0].get_texts():
                box = t.get_window_extent(renderer)
                _, _, descent = renderer.get_text_width_height_descent(
                    t.get_text(), t.get_fontproperties(), ismath=False)
                want = (box.x0 * scale, (box.y0 + descent) * scale)
                near = min(starts, key=lambda s: abs(s[0] - want[0]) + abs(s[1] - want[1]))
                if abs(near[0] - want[0]) > 0.05 or abs(near[1] - want[1]) > 0.05:
                    failures.append(f"legend text '{t.get_text()}' starts at {near} pt, the "
                                    f"PNG's drawing at ({want[0]:.3f}, {want[1]:.3f})")
                worst_theirs = max(worst_theirs, min(abs(s[0] - want[0]) + abs(s[1] - want[1])
                                                     for s in theirs))
            print(f"  legend: matplotlib's own PDF puts its texts up to {worst_theirs:.2f} pt "
                  "from the PNG's")
    for f in failures:
        print("FAIL:", f)
    if not failures:
        print(f"PASS: {len(figures)} figures' PDFs from their Agg drawing")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
