#!/usr/bin/python3
"""The report's report.tex compiles with pdflatex into a PDF holding every table and figure
(docs/studies.md, "Report"): every figure of figures.json is included as its PDF, every table as
its longtable piece, the \\input-able booktabs tabular pieces exist beside them, and the PDF
embeds each figure (pdfTeX's log names every graphic it embeds), and nothing in it is wider than
the page.

    latex_test.py STUDY_DIR      exit 0 pass, 1 fail, 77 skip (no pdflatex)
"""

import json
import os
import re
import shutil
import subprocess
import sys


def main(argv):
    report = os.path.join(argv[1], "report")
    if shutil.which("pdflatex") is None:
        print("SKIP: pdflatex not installed (Debian: texlive-latex-base texlive-latex-recommended; "
              "scripts/bootstrap.sh test installs them)")
        return 77
    failures = []
    with open(os.path.join(report, "report.tex"), encoding="utf-8") as f:
        tex = f.read()
    with open(os.path.join(report, "figures.json"), encoding="utf-8") as f:
        figures = json.load(f)
    included = re.findall(r"\\includegraphics\[[^\]]*\]\{([^}]*)\}", tex)
    for fig in figures:
        if fig["pdf"] not in included:
            failures.append(f"figure {fig['pdf']} is not in report.tex")
    inputs = re.findall(r"\\input\{([^}]*)\}", tex)
    tables = sorted(n[:-len(".csv")] for n in os.listdir(os.path.join(report, "tables"))
                    if n.endswith(".csv"))
    for t in tables:
        if f"tables/{t}.long.tex" not in inputs:
            failures.append(f"table {t} is not in report.tex")
        piece = os.path.join(report, "tables", t + ".tex")
        if not os.path.exists(piece) or "\\begin{tabular}" not in open(piece, encoding="utf-8").read():
            failures.append(f"tables/{t}.tex: no booktabs tabular piece to \\input")
    pdf = os.path.join(report, "report.pdf")
    if os.path.exists(pdf):
        os.remove(pdf)
    log = os.path.join(report, "pdflatex.txt")
    # Twice: longtable settles its column widths on the second run.
    for _ in range(2):
        with open(log, "w", encoding="utf-8") as out:
            rc = subprocess.call(["pdflatex", "-interaction=nonstopmode", "-halt-on-error",
                                  "report.tex"], cwd=report, stdout=out, stderr=subprocess.STDOUT)
        if rc != 0:
            break
    if rc != 0:
        tail = open(log, encoding="utf-8", errors="replace").read()[-2000:]
        failures.append(f"pdflatex exit {rc}; the end of {log}:\n{tail}")
    elif not os.path.exists(pdf):
        failures.append("pdflatex wrote no report.pdf")
    else:
        # pdfTeX compresses its page objects; its log says how many it wrote.
        with open(os.path.join(report, "report.log"), encoding="utf-8", errors="replace") as f:
            texlog = f.read()
        m = re.search(r"Output written on report\.pdf \((\d+) pages?", texlog)
        pages = int(m.group(1)) if m else 0
        # pdfTeX logs every graphic it embeds as <file>; a float LaTeX dropped is not there.
        flat = texlog.replace("\n", "")
        for fig in figures:
            if "<" + fig["pdf"] not in flat:
                failures.append(f"{fig['pdf']} was not embedded in report.pdf")
        # Nothing wider than the page: a table or figure that runs off it is not publication
        # ready (report_latex.long_table splits wide tables and sets their headers on their side).
        for m in re.finditer(r"Overfull \\hbox \(([0-9.]+)pt too wide\) ([^\n]*)", texlog):
            if float(m.group(1)) > 1.0:
                failures.append(f"report.pdf: a box {m.group(1)} pt wider than the page "
                                f"({m.group(2).strip()}; {os.path.join(report, 'report.log')})")
        if "Float(s) lost" in texlog or pages < 2:
            failures.append(f"report.pdf: {pages} pages, floats lost: {'Float(s) lost' in texlog}")
        print(f"report.pdf: {pages} pages, {len(figures)} figures, {len(tables)} tables, "
              f"{os.path.getsize(pdf)} bytes")
    for f in failures:
        print("FAILED: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
