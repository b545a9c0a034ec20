#!/usr/bin/python3
"""The report's figures are fit for a paper (docs/studies.md, "Report"): each is one column
(3.3 in) or two columns (7 in) wide; its PNG is exactly its size at 200 dpi; its PDF page is the
same size in points and embeds every font it uses (TrueType or Type 1 font files, no Type 3);
no text overlaps other text or leaves the figure (make_report.py measures that on the laid-out
figure and records it in figures.json); the names a LaTeX document includes are the ones
expected for the --quick default study.

    figures_test.py STUDY_DIR      exit 0 pass, 1 fail
"""

import json
import os
import re
import struct
import sys

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
