#!/usr/bin/python3
"""Figures drawn again only when their inputs changed (report/figure_cache.py; issue 46 item 2)
on the synthetic four-fit study of many_fits_test.py (2 materials, images and probes):

- a second report with nothing changed draws no figure (every grid, the forest plot and the
  charts keep their modification times) and writes the same figures.json, summary.md and
  index.html bytes;
- one preview image of one material rewritten with other pixels: that material's grids are
  drawn again, the other material's are not; so with one fit record of a material changed
  (and the charts, drawn from every record);
- a figure file deleted: it is drawn again;
- the drawing shortcuts (report_figures: text measured, math parsed and glyphs drawn once per
  process, markers copied from their names, a log axis's ticks made for its view only, 8-bit
  opaque tiles, font subsets per set of characters, made from a subset of the font to the
  figures' characters) give the PNG pixels and PDF bytes matplotlib's own functions, every
  location's tick, float tiles and the whole font give.

    figure_cache_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import glob
import os
import shutil
import sys

FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)


def stamps(d, pattern):
    return {p: os.stat(p).st_mtime_ns for p in glob.glob(os.path.join(d, "report", "figures",
                                                                      pattern))}


def read(d, name):
    with open(os.path.join(d, "report", name), "rb") as f:
        return f.read()


def drawn(rf, tile, in_view, grid_tile=None):
    """The PNG pixels and PDF bytes of a small figure with what the shortcuts cover: texts, a
    log axis's math tick labels and minor ticks (made for the view's locations only: in_view), a
    legend with markers (laid out once per drawing), an image tile, and grid tiles at extents
    whose edges cut pixels, on a small axes (clipped) and on one spanning the figure (inside it:
    unclipped; across its edge: clipped) (grid_tile: report_grids.add_tile's opaque 8-bit tile,
    resampled once; else imshow's)."""
    import io
    import numpy as np
    fig = rf.plt.figure(figsize=(3.3, 2.0), dpi=rf.DPI)
    ax = fig.add_axes([0.2, 0.2, 0.5, 0.6])
    ax.plot([1, 2, 3], [0.01, 1.0, 30.0], label="blinn-phong@key+mirror60")
    ax.plot([1.5, 2.5], [0.05, 3.0], marker="o", fillstyle="none", label="extrapolated")
    ax.set_yscale("log")
    ax.set_xlabel("theta_h (deg) \u207b\u00b2")
    ax.set_title("gold: fresnel")
    # The title's words again, larger and right-aligned (placed by their measured width): the
    # remembered measures are per font size too.
    fig.text(0.98, 0.9, "gold: fresnel", fontsize=rf.FONT_PT + 3, ha="right")
    # The same words and size laid out otherwise, each pair apart in one property (rotation,
    # horizontal or vertical alignment), and two lines aligned two ways and spaced two ways: the
    # remembered layouts are per each of those.
    words = {"s": "gold: fresnel", "fontsize": rf.FONT_PT + 3}
    fig.text(0.3, 0.3, **words)  # left, baseline
    fig.text(0.3, 0.5, va="top", **words)  # left, top
    fig.text(0.01, 0.98, rotation=90, va="top", **words)  # left, top, rotated
    fig.text(0.5, 0.99, ha="center", va="top", **words)  # centre, top
    lines = "theta_h\n(deg) 10"
    fig.text(0.75, 0.45, lines, multialignment="right")
    fig.text(0.75, 0.6, lines, multialignment="center")
    fig.text(0.98, 0.6, lines, multialignment="center", ha="right")
    fig.text(0.75, 0.75, lines, multialignment="center", linespacing=1.6)
    fig.legend(loc="lower right", frameon=False)
    img = fig.add_axes([0.75, 0.2, 0.2, 0.3])
    img.set_axis_off()
    img.imshow(tile, interpolation="nearest", aspect="auto")
    def place_tile(ax, extent, limits):
        """A tile at `extent` on `ax` (axis off, at `limits`): add_tile's or imshow's."""
        if grid_tile is not None:
            import report_grids
            report_grids.add_tile(ax, grid_tile, extent)
        else:
            ax.imshow(tile, interpolation="nearest", aspect="auto", extent=extent)
            ax.set_xlim(*limits[0])
            ax.set_ylim(*limits[1])

    cell = fig.add_axes([0.031, 0.043, 0.137, 0.113])
    cell.set_axis_off()
    cell.set_xlim(0, 1)
    cell.set_ylim(0, 1)
    place_tile(cell, (0.113, 0.871, 0.097, 0.933), ((0, 1), (0, 1)))
    # A grid's axes spans the figure in inches: tiles inside it (drawn unclipped by add_tile,
    # one artist drawing them in turn) and, on another such axes, one across its right edge
    # (clipped), each at an extent whose edges cut pixels.
    for extents in [((2.403, 2.987, 1.103, 1.771), (2.403, 2.874, 0.057, 0.901),
                     (0.021, 0.333, 1.811, 1.987)), ((3.013, 3.5, 0.071, 0.689),)]:
        sheet = fig.add_axes([0, 0, 1, 1])
        sheet.set_axis_off()
        sheet.set_xlim(0, 3.3)
        sheet.set_ylim(0, 2.0)
        for sheet_extent in extents:
            place_tile(sheet, sheet_extent, ((0, 3.3), (0, 2.0)))
    # Large values that differ little: the y axis writes an offset ("+1e6") above the axes,
    # which its wide title must clear (matplotlib moves the title up); a title over a log axis
    # (no offset) stays where it is.
    offset = fig.add_axes([0.08, 0.6, 0.25, 0.2])
    offset.plot([0, 1, 2], [1e6, 1e6 + 3, 1e6 + 1])
    offset.set_title("a title as wide as the axes", fontsize=5)
    if in_view:
        rf.ticks_in_view(fig)
    fig.canvas.draw()
    check(offset.title.get_position()[1] > 1.0 and ax.title.get_position()[1] == 1.0,
          "titles: the one over an offset text not moved up, or the one over a log axis "
          "moved")
    pixels = np.asarray(fig.canvas.buffer_rgba()).copy()
    pdf = io.BytesIO()
    fig.savefig(pdf, format="pdf", metadata={"CreationDate": None})
    rf.plt.close(fig)
    return pixels, pdf.getvalue()


def check_shortcuts(report_src):
    import numpy as np
    import report_figures as rf  # noqa: E402
    # Every 8-bit value as read_rgb8 keeps it and as read_rgb's float makes it, as imshow gets it.
    k = np.arange(256, dtype=np.uint8).reshape(16, 16, 1).repeat(3, axis=2)
    check(np.array_equal(rf.opaque_rgba(k), rf.opaque_rgba(rf.as_float(k))),
          "opaque_rgba: an 8-bit value differs from its float's")
    rng = np.random.default_rng(7)
    tile8 = rng.integers(0, 256, (40, 30, 3), dtype=np.uint8)
    tile = rf.as_float(tile8)
    rf.use_matplotlib_text(False)
    short = [drawn(rf, rf.opaque_rgba(tile8), True, rf.opaque_rgba(tile8))
             for _ in range(2)]  # the second: caches
    rf.use_matplotlib_text(True)
    try:
        own = drawn(rf, tile, False)
    finally:
        rf.use_matplotlib_text(False)
    for n, (pixels, pdf) in enumerate(short):
        check(np.array_equal(pixels, own[0]), f"shortcuts, drawing {n + 1}: other PNG pixels")
        check(pdf == own[1], f"shortcuts, drawing {n + 1}: other PDF bytes")
    # text_problems on a figure whose tick labels overlap: the overlaps found with the shortcuts
    # (the ticks the drawing drew) are matplotlib's (the ticks made again), and there are some.
    found = []
    for own_text in (False, True):
        rf.use_matplotlib_text(own_text)
        try:
            fig = rf.plt.figure(figsize=(2.0, 1.5), dpi=rf.DPI)
            crowded = fig.add_axes([0.2, 0.3, 0.7, 0.6])
            crowded.plot(range(12), range(12))
            crowded.set_xticks(range(12))
            crowded.set_xticklabels([f"label {k}" for k in range(12)])
            found.append(rf.text_problems(fig))
            if not own_text:
                # The pairs as the test finds them, one by one, from the same drawing's boxes.
                renderer = fig.canvas.get_renderer()
                boxes = [(t.get_text().replace("\n", " "), t.get_window_extent(renderer))
                         for t in rf.drawn_texts(fig)]
                boxes = [(s, b) for s, b in boxes if b.width > 0 and b.height > 0]
                pairs = [[boxes[i][0], boxes[j][0]] for i in range(len(boxes))
                         for j in range(i + 1, len(boxes))
                         if min(boxes[i][1].x1, boxes[j][1].x1)
                         - max(boxes[i][1].x0, boxes[j][1].x0) > 1
                         and min(boxes[i][1].y1, boxes[j][1].y1)
                         - max(boxes[i][1].y0, boxes[j][1].y0) > 1]
                check(found[-1][0] == pairs, f"text_problems: overlaps {found[-1][0]}, the "
                      f"test's {pairs}")
            rf.plt.close(fig)
        finally:
            rf.use_matplotlib_text(False)
    check(found[0] == found[1], "text_problems: other overlaps with the shortcuts than without")
    check(len(found[1][0]) >= 5, f"text_problems: {len(found[1][0])} overlaps of 12 crowded tick "
          "labels found, expected at least 5")
    font = rf.matplotlib.font_manager.findfont("DejaVu Sans")
    check(rf._font_subset(font, "abc10").getvalue() == rf._SUBSET_FONT(font, "01cba").getvalue(),
          "font subset: other bytes than matplotlib's for the same characters")
    check_subset_of_base(rf, font)


def check_subset_of_base(rf, font):
    """Subsets made from the base subset (a shared folder set, as make_report does) are the bytes
    of the same subsets of the whole font, widened to the common characters where the base holds
    the set: random sets of the base characters, the whole base, one character, and a set with a
    character outside the base (made from the whole font, as it is)."""
    import random
    import tempfile
    rng = random.Random(46)
    base = sorted(rf.SUBSET_BASE_CHARACTERS)
    sets = [rng.sample(base, k) for k in (1, 3, 8, 20, 40, 70)] + [base, ["x"], ["a", "\u00e9"]]
    sets.append(list("grid-alum-bronze, part 1 of 5: |error| 0.037 W m\u207b\u00b2 sr\u207b\u00b9"))
    with tempfile.TemporaryDirectory(prefix="shadefit-fonts-test-") as folder:
        rf.share_font_subsets(folder)
        try:
            for chars in sets:
                made = rf._font_subset(font, "".join(chars)).getvalue()
                # A set within the base is widened to the common characters first; one with a
                # character outside it is not.
                want = set(chars)
                if rf.SUBSET_BASE_CHARACTERS.issuperset(want):
                    want |= rf.SUBSET_COMMON_CHARACTERS
                whole = rf._SUBSET_FONT(font, "".join(sorted(want))).getvalue()
                check(made == whole, f"font subset of {''.join(sorted(set(chars)))!r} from the "
                      "base subset: other bytes than the whole font's subset to "
                      f"{''.join(sorted(want))!r}")
            check(any(n.startswith("base-") for n in os.listdir(folder)),
                  "font subsets: no base subset made in the shared folder")
        finally:
            rf.share_font_subsets(None)
    # A figure's PDF with its font widened (the report's shared folder) and without: the same
    # PDF but for the font program (its stream and lengths), every other object the same.
    pdfs = []
    with tempfile.TemporaryDirectory(prefix="shadefit-fonts-test-") as folder:
        for shared in (None, os.path.join(folder, "fonts")):
            if shared:
                os.makedirs(shared)
            rf.share_font_subsets(shared)
            try:
                fig = rf.plt.figure(figsize=(2.0, 1.0))
                fig.text(0.1, 0.5, "Gold: fresnel 0.25 W m\u207b\u00b2", fontsize=7)
                fig.text(0.1, 0.2, "x", fontsize=5)
                rf.save_figure(fig, folder, "font", [], "a caption")
                with open(os.path.join(folder, "font.pdf"), "rb") as f:
                    pdfs.append(pdf_objects(f.read()))
            finally:
                rf.share_font_subsets(None)
    check(pdfs[0][0] == pdfs[1][0] and pdfs[0][1] != pdfs[1][1],
          "a PDF with its font widened: other objects than the font program and its glyph map "
          "differ, or the font program does not (the case tests nothing)")
    # In each, every character drawn maps (CIDToGIDMap) to the glyph the embedded font's own
    # character map gives it.
    import io
    import numpy as np
    from fontTools.ttLib import TTFont
    for (_, fonts, maps), shared in zip(pdfs, ("own", "widened")):
        embedded = TTFont(io.BytesIO(fonts[0]))
        order, cmap = embedded.getGlyphOrder(), embedded.getBestCmap()
        gids = np.frombuffer(maps[0], dtype=">u2")
        wrong = [c for c in set("Gold: fresnel 0.25 W m\u207b\u00b2x")
                 if order[gids[ord(c)]] != cmap.get(ord(c))]
        check(not wrong, f"a PDF's font ({shared}): {wrong} map to other glyphs")


def pdf_objects(pdf):
    """(the PDF's objects but its TrueType font programs and CID-to-glyph maps, with stream
    lengths dropped and streams inflated; its font programs; its CID-to-glyph maps)."""
    import re
    import zlib
    bodies = dict(re.findall(rb"(\d+) 0 obj\n(.*?)endobj", pdf, re.S))
    map_ids = set(re.findall(rb"/CIDToGIDMap (\d+) 0 R", pdf))
    objects, fonts, maps = [], [], []
    for number, body in bodies.items():
        head, _, rest = body.partition(b"stream\n")
        data = rest.rsplit(b"\nendstream", 1)[0] if rest else b""
        if data:
            try:
                data = zlib.decompress(data)
            except zlib.error:
                pass
        if data.startswith(b"\x00\x01\x00\x00"):  # an sfnt (TrueType) font program
            fonts.append(data)
        elif number in map_ids:  # a glyph index per CID (big-endian 16 bits)
            maps.append(data)
        else:
            objects.append((re.sub(rb"/Length1? \d+", b"", head), data))
    return objects, fonts, maps


def main(argv):
    report_src, out = argv[1], os.path.abspath(argv[2])
    here = os.path.dirname(os.path.abspath(__file__))
    sys.path.insert(0, report_src)
    sys.path.insert(0, here)
    check_shortcuts(report_src)
    import make_report  # noqa: E402
    import many_fits_test as mf  # noqa: E402

    shutil.rmtree(out, ignore_errors=True)
    d = os.path.join(out, mf.FOUR.name)
    mf.write_study(d, mf.FOUR)
    red, gold = mf.FOUR.materials
    make_report.make_report(d)
    first = {n: read(d, n) for n in ("figures.json", "summary.md", "index.html")}
    before = stamps(d, "*")
    grids = {m: stamps(d, f"grid-{m}*") for m in (red, gold)}
    check(all(grids.values()), f"no grid files found: {sorted(before)[:4]}")

    make_report.make_report(d)
    after = stamps(d, "*")
    # The per-material grids and the study-level groups (forest plot, charts).
    material_files = [p for m in (red, gold) for p in grids[m]] + sorted(
        stamps(d, "findings-forest*")) + sorted(stamps(d, "chart-*"))
    check(len(material_files) > 6, f"too few figure files to check: {material_files}")
    redrawn = [os.path.basename(p) for p in material_files if after.get(p) != before[p]]
    check(not redrawn, f"unchanged inputs, yet drawn again: {redrawn}")
    for n, text in first.items():
        check(read(d, n) == text, f"unchanged inputs, yet {n} differs")

    def redraws(changed, material, other, before, also=()):
        """A report after `changed` (a file of `material`'s): its grids (and `also`) are drawn
        again, `other`'s are not. Returns the figures' new times."""
        make_report.make_report(d)
        now = stamps(d, "*")
        check(all(now[p] != before[p] for p in grids[material]),
              f"{os.path.basename(changed)} changed, yet {material}'s grids were not drawn again")
        check(all(now[p] == before[p] for p in grids[other]),
              f"only {material}'s {os.path.basename(changed)} changed, yet {other}'s grids were "
              "drawn again")
        check(all(now[p] != before[p] for p in also),
              f"{os.path.basename(changed)} changed, yet {sorted(also)} were not drawn again")
        return now

    # One preview of the second material, new pixels.
    image = sorted(glob.glob(os.path.join(d, "images", f"{gold}-*.png")))[0]
    mf.write_png(image, 0.123)
    after2 = redraws(image, gold, red, after)

    # One fit record of the first material, another number in its file: its figures are keyed
    # by the bytes of its records' files (figure_cache.material_key); so are the charts, drawn
    # from every record.
    import json
    job = sorted(glob.glob(os.path.join(d, "jobs", f"fit.{red}.*.json")))[0]
    with open(job, encoding="utf-8") as f:
        record = json.load(f)
    record["parameters"][0]["value"] += 0.01
    with open(job, "w", encoding="utf-8") as f:
        json.dump(record, f)
    redraws(job, red, gold, after2, also=sorted(stamps(d, "chart-*")))

    victim = sorted(grids[red])[0]
    os.remove(victim)
    make_report.make_report(d)
    check(os.path.exists(victim), f"{os.path.basename(victim)} deleted and not drawn again")

    for f in FAILURES:
        print("FAILED: " + f)
    if not FAILURES:
        print("PASS: unchanged figures kept, a changed material's drawn again, a deleted one "
              "redrawn; the drawing shortcuts draw matplotlib's pixels and bytes")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
