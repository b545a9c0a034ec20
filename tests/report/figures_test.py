#!/usr/bin/python3
"""The report's figures are fit for a paper (docs/studies.md, "Report"): each is one column
(3.3 in) or two columns (7 in) wide; its PNG is exactly its size at 200 dpi; its PDF page is the
same size in points and embeds every font it uses (TrueType or Type 1 font files, no Type 3);
a grid's PDF draws its images as one raster that is the PNG's pixels (pdf_raster_problems); no text overlaps other text or leaves the figure (make_report.py measures that on the laid-out
figure and records it in figures.json); the names a LaTeX document includes are the ones
expected for the --quick default study.

    figures_test.py STUDY_DIR      exit 0 pass, 1 fail
"""

import io
import json
import os
import re
import struct
import sys
import zlib

import numpy as np
import PIL.Image

DPI = 200  # report/report_figures.py
WIDTHS_IN = (3.3, 7.0)
# The --quick default study: materials red-plastic and gold, fits blinn-phong and ggx.
EXPECTED = ["grid-red-plastic", "grid-gold", "metric-flip_ldr_mean", "chart-blinn-phong",
            "chart-ggx"] + [f"probe-{p}-{m}" for p in ("fresnel", "highlight", "energy", "portability")
                            for m in ("red-plastic", "gold")]


def png_size(path):
    with open(path, "rb") as f:
        head = f.read(24)
    if head[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return struct.unpack(">II", head[16:24])


def pdf_problems(path, width_in, height_in):
    with open(path, "rb") as f:
        pdf = f.read()
    problems = []
    box = re.search(rb"/MediaBox\s*\[\s*0\s+0\s+([\d.]+)\s+([\d.]+)\s*\]", pdf)
    if not box:
        problems.append("no MediaBox")
    else:
        w, h = float(box.group(1)), float(box.group(2))
        if abs(w - width_in * 72) > 0.4 or abs(h - height_in * 72) > 0.4:
            problems.append(f"page {w:g} x {h:g} pt, want {width_in * 72:g} x {height_in * 72:g}")
    fonts = re.findall(rb"/Type\s*/Font\b", pdf)
    type3 = re.findall(rb"/Subtype\s*/Type3", pdf)
    descriptors = len(re.findall(rb"/Type\s*/FontDescriptor", pdf))
    files = len(re.findall(rb"/FontFile[23]?\s", pdf))
    if not fonts:
        problems.append("no font (a figure without text?)")
    if type3:
        problems.append(f"{len(type3)} Type 3 font(s): glyphs drawn as procedures, not embedded fonts")
    if descriptors == 0 or files < descriptors:
        problems.append(f"{descriptors} font descriptor(s) but {files} embedded font file(s)")
    return problems


def pdf_streams(pdf):
    """[(object dictionary, stream bytes)] of every stream object of a PDF as matplotlib writes
    them (`N 0 obj`, the dictionary, `stream`, the data, `endstream`)."""
    out = []
    for m in re.finditer(rb"\d+ 0 obj\n(<<(?:(?!endobj).)*?>>)\nstream\n", pdf, re.S):
        out.append((m.group(1), pdf[m.end():pdf.index(b"endstream", m.end())]))
    return out


def decode_idat(idat, width, height, color_type):
    """Pillow's decoding of a PNG made around `idat` (a PNG's IDAT data, or a PDF image's Flate
    stream with PNG predictors; 8 bits per sample; colour type 2: RGB, 0: gray)."""
    def chunk(kind, body):
        return (struct.pack(">I", len(body)) + kind + body
                + struct.pack(">I", zlib.crc32(kind + body) & 0xFFFFFFFF))
    png = (b"\x89PNG\r\n\x1a\n"
           + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0))
           + chunk(b"IDAT", idat) + chunk(b"IEND", b""))
    with PIL.Image.open(io.BytesIO(png)) as im:
        return np.asarray(im)


def pdf_raster_problems(pdf_path, png_path):
    """A grid's PDF draws its tiles and colour bars as one image that is the PNG's pixels where
    the PDF puts it (report_figures.pdf_images_as_drawn): exactly one image XObject; its data
    (FlateDecode with PNG predictors: a PNG's IDAT) decoded by Pillow as a PNG made of it; its
    place (the `cm` before its `Do`, in points) at whole pixels of 200 dpi; its pixels those of
    the PNG there, every one."""
    with open(pdf_path, "rb") as f:
        pdf = f.read()
    streams = pdf_streams(pdf)
    images = [(d, data) for d, data in streams if b"/Subtype /Image" in d]
    if len(images) != 1:
        return [f"{len(images)} images, want one raster"]
    d, data = images[0]
    w = int(re.search(rb"/Width (\d+)", d).group(1))
    h = int(re.search(rb"/Height (\d+)", d).group(1))
    if b"/DeviceRGB" not in d or b"/Predictor 10" not in d or b"/SMask" in d:
        return [f"image dictionary not opaque 8-bit RGB with PNG predictors: {d[:160]!r}"]
    raster = decode_idat(data, w, h, 2)
    content = b"".join(zlib.decompress(data) for dd, data in streams
                       if b"/Subtype" not in dd and b"/Length1" not in dd
                       and b"/FlateDecode" in dd)
    place = re.search(rb"([-\d.]+) ([-\d.]+) ([-\d.]+) ([-\d.]+) ([-\d.]+) ([-\d.]+) cm\s*/\w+ Do",
                      content)
    if not place:
        return ["no `cm ... Do` placing the image"]
    a, b, c, dd, e, f_ = (float(v) for v in place.groups())
    page = np.asarray(PIL.Image.open(png_path).convert("RGB"))
    px = DPI / 72.0
    # Pixel rows count from the PNG's top; the PDF's y from the page's bottom.
    col0, row0 = e * px, page.shape[0] - (f_ + dd) * px
    problems = []
    if b != 0 or c != 0 or abs(a * px - w) > 0.05 or abs(dd * px - h) > 0.05:
        problems.append(f"image {w} x {h} px drawn {a * px:.2f} x {dd * px:.2f} px at 200 dpi")
    if abs(col0 - round(col0)) > 0.05 or abs(row0 - round(row0)) > 0.05:
        problems.append(f"image at ({col0:.3f}, {row0:.3f}) px: not on the PNG's pixels")
    if problems:
        return problems
    col0, row0 = round(col0), round(row0)
    under = page[row0:row0 + h, col0:col0 + w]
    if under.shape != raster.shape:
        return [f"image {raster.shape} runs off the PNG {page.shape} at ({col0}, {row0})"]
    differ = int((under != raster).any(axis=2).sum())
    if differ:
        problems.append(f"{differ} of {w * h} raster pixels differ from the PNG's")
    return problems


def main(argv):
    study_dir = argv[1]
    report = os.path.join(study_dir, "report")
    with open(os.path.join(report, "figures.json"), encoding="utf-8") as f:
        figures = json.load(f)
    failures = []
    names = [f["name"] for f in figures]
    for want in EXPECTED:
        if want not in names:
            failures.append(f"{want}: missing from figures.json")
    for fig in figures:
        name, w_in, h_in = fig["name"], fig["width_in"], fig["height_in"]
        if not any(abs(w_in - w) < 1e-6 for w in WIDTHS_IN):
            failures.append(f"{name}: {w_in} in wide, want one of {WIDTHS_IN}")
        size = png_size(os.path.join(report, fig["png"]))
        want = (round(w_in * DPI), round(h_in * DPI))
        if size is None or size != want or size != (fig["width"], fig["height"]):
            failures.append(f"{name}.png: {size}, want {want}")
        for p in pdf_problems(os.path.join(report, fig["pdf"]), w_in, h_in):
            failures.append(f"{name}.pdf: {p}")
        if fig.get("kind") == "grid":
            for p in pdf_raster_problems(os.path.join(report, fig["pdf"]),
                                         os.path.join(report, fig["png"])):
                failures.append(f"{name}.pdf: {p}")
        for a, b in fig.get("text_overlaps", ["(field missing)"]):
            failures.append(f"{name}: text '{a}' overlaps '{b}'")
        for t in fig.get("text_outside", ["(field missing)"]):
            failures.append(f"{name}: text '{t}' leaves the figure")
    for f in failures:
        print("FAILED: " + f)
    print(f"{len(figures)} figures checked, {len(failures)} problem(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
