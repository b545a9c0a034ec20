"""Tables as files (CSV, Markdown, booktabs LaTeX, and a longtable for report.tex laid out to fit
the page) and report.tex, which sets every table and figure at its printed size."""

import csv
import io
import os

import report_findings
from report_util import md_escape, write_text


# ------------------------------------------------------------------------------------------------
# Tables: each is (columns, rows of strings) written as CSV, Markdown and LaTeX (booktabs).


_LATEX_REPL = {"\\": "\\textbackslash{}", "&": "\\&", "%": "\\%", "$": "\\$", "#": "\\#",
               "_": "\\_", "{": "\\{", "}": "\\}", "~": "\\textasciitilde{}",
               "^": "\\textasciicircum{}",
               # Text mode has no |, and the figure captions' units use Unicode superscripts.
               "|": "$|$", "\u207b": "$^{-}$", "\u00b2": "$^{2}$", "\u00b9": "$^{1}$",
               "±": "$\\pm$", "\u2212": "$-$"}
# One str.translate per cell (the measured study's tables escape ~600000 cells).
_LATEX_TABLE = str.maketrans(_LATEX_REPL)


def latex_escape(s):
    s = str(s)
    if s.startswith("$") and s.endswith("$"):
        return s
    # Adjacent superscripts join: m$^{-}$$^{2}$ -> m$^{-2}$.
    return s.translate(_LATEX_TABLE).replace("}$$^{", "")



# report.tex sets its tables in \scriptsize with \tabcolsep 3pt on an A4 page with 1.5 cm
# margins (write_latex_document): 512 pt of text width, of which 4 pt are kept for kerning.
LATEX_TEXT_WIDTH_PT = 508.0
LATEX_COLUMN_SEP_PT = 6.0  # 2 x \tabcolsep
LATEX_ROTATED_HEADER_PT = 8.0  # a header set on its side is one line of \scriptsize wide
# Widths in pt of the printable ASCII characters in \scriptsize (cmr7), as latex_escape sets
# them, measured with \settowidth (pdfTeX, TeX Live 2022); anything else counts as an M.
_CMR7_WIDTHS = dict(zip(
    " !\"#$%&'()*+,-./0123456789:;<=>?@ABCDEFGHIJKLMNOPQRSTUVWXYZ[\\]^_`abcdefghijklmnopqrstuvwxyz{|}~",
    [2.69, 2.26, 3.99, 6.57, 3.99, 6.57, 6.14, 2.26, 3.13, 3.13, 3.99, 6.14, 2.26, 2.69, 2.26,
     3.99] + [3.99] * 10 + [2.26, 2.26, 2.26, 6.14, 3.77, 3.77, 6.14,
     5.9, 5.59, 5.71, 6.02, 5.38, 5.16, 6.19, 5.9, 2.89, 4.08, 6.12, 4.94, 7.19, 5.9, 6.14, 5.38,
     6.14, 5.81, 4.42, 5.71, 5.9, 5.9, 8.06, 5.9, 5.9, 4.85, 2.26, 4.1, 2.26, 3.99, 2.87, 2.26,
     3.99, 4.42, 3.56, 4.42, 3.56, 2.48, 3.99, 4.42, 2.26, 2.48, 4.2, 2.26, 6.57, 4.42, 3.99, 4.42,
     4.2, 3.13, 3.17, 3.13, 4.42, 4.2, 5.71, 4.2, 4.2, 3.56, 4.1, 2.38, 4.1, 3.99]))


def latex_width_pt(text):
    """`text`'s width in report.tex's tables (plain text, before escaping)."""
    return sum(_CMR7_WIDTHS.get(c, 7.19) for c in str(text))


def long_table_parts(plain_cols, rows, keep, wrap=None):
    """How report.tex lays out a table that may be wider than the page: (rotate, parts), where
    `rotate` sets the numeric columns' headers on their side and each part is the list of
    other column indices one longtable holds; every part repeats the `keep` leading columns.
    Headers are rotated only when the table does not fit with them upright, and a table is split
    only when it does not fit with them rotated (the measured study's 10 fits)."""
    wrap = wrap or {}
    cell = [max([latex_width_pt(r[i]) for r in rows] + [0.0]) for i in range(len(plain_cols))]
    cell = [wrap.get(i, c) for i, c in enumerate(cell)]  # a paragraph column is its width
    upright = [LATEX_COLUMN_SEP_PT + (wrap[i] if i in wrap else max(c, latex_width_pt(h)))
               for i, (c, h) in enumerate(zip(cell, plain_cols))]
    side = [LATEX_COLUMN_SEP_PT + max(c, LATEX_ROTATED_HEADER_PT) for c in cell]
    keys = sum(upright[:keep])
    numeric = list(range(keep, len(plain_cols)))
    if sum(upright) <= LATEX_TEXT_WIDTH_PT:
        return False, [numeric]
    # The fewest parts that fit, with the columns shared out evenly (11 columns in two parts are
    # 6 + 5, not 10 + 1); a part holds at least one column even where it cannot fit.
    for count in range(1, len(numeric) + 1):
        size, extra = divmod(len(numeric), count)
        parts, at = [], 0
        for n in range(count):
            parts.append(numeric[at:at + size + (n < extra)])
            at += len(parts[-1])
        if all(keys + sum(side[i] for i in part) <= LATEX_TEXT_WIDTH_PT for part in parts):
            break
    return True, parts


def wrapped(text):
    """A cell of a paragraph column: a fit label may also break after '@', '+' and ':'
    ("ggx-metallic@key+mirror60:relative" has no space)."""
    out = latex_escape(text)
    for c in "@+:":
        out = out.replace(c, c + "\\allowbreak{}")
    return out


def long_table(caption, columns, plain_cols, rows, numeric_from, keep, wrap=None):
    """<name>.long.tex for report.tex: one longtable (header repeated on every page), or, when
    the table is wider than the page, one per group of numeric columns (long_table_parts).
    `wrap`: {column index: width in pt} of columns set as wrapped paragraphs (p{...})."""
    wrap = wrap or {}
    rotate, parts = long_table_parts(plain_cols, rows, keep, wrap)
    lines = [f"% {caption}. Generated by report/make_report.py; needs booktabs and longtable"
             + (" and graphicx." if rotate else ".")]
    for n, part in enumerate(parts):
        cols = list(range(keep)) + part
        align = "".join(f"p{{{wrap[i]:g}pt}}" if i in wrap else "l" if i < numeric_from
                        else "r" for i in cols)
        head = " & ".join(
            f"\\rotatebox{{90}}{{{latex_escape(columns[i])}}}"
            if rotate and i >= numeric_from and i not in wrap
            else latex_escape(columns[i]) for i in cols) + " \\\\"
        body = [" & ".join(wrapped(r[i]) if i in wrap else latex_escape(r[i]) for i in cols)
                + " \\\\" for r in rows]
        span = plain_cols[part[0]] + ("" if len(part) == 1 else f" to {plain_cols[part[-1]]}")
        title = caption if len(parts) == 1 else f"{caption} (part {n + 1} of {len(parts)}: {span})"
        lines += [f"\\begin{{longtable}}{{{align}}}", f"\\caption{{{latex_escape(title)}}}\\\\",
                  "\\toprule", head, "\\midrule", "\\endfirsthead", "\\toprule", head,
                  "\\midrule", "\\endhead", "\\bottomrule", "\\endfoot"] + body
        lines += ["\\end{longtable}"]
    return "\n".join(lines) + "\n"


def write_table(out_dir, name, columns, rows, caption, numeric_from=1, keep=None, wrap=None):
    """tables/<name>.{csv,md,tex}; the .tex is a booktabs tabular for \\input, and
    <name>.long.tex the same rows as a longtable (header repeated on every page) for report.tex,
    split into parts that repeat the first `keep` columns (default: the non-numeric ones) where
    it is wider than the page; `wrap` as long_table's."""
    os.makedirs(out_dir, exist_ok=True)
    plain_cols = [c.replace("$\\Delta E_{00}$", "dE00").replace("$\\Delta E_{ITP}$", "dE_ITP")
                  for c in columns]
    buf = io.StringIO()
    w = csv.writer(buf)
    w.writerow(plain_cols)
    w.writerows(rows)
    write_text(os.path.join(out_dir, name + ".csv"), buf.getvalue())
    md = [f"<!-- {caption} -->",
          "| " + " | ".join(md_escape(c) for c in plain_cols) + " |",
          "|" + "|".join("---" if i < numeric_from else "---:" for i in range(len(columns))) + "|"]
    md += ["| " + " | ".join(md_escape(c) for c in r) + " |" for r in rows]
    write_text(os.path.join(out_dir, name + ".md"), "\n".join(md) + "\n")
    align = "l" * numeric_from + "r" * (len(columns) - numeric_from)
    head = " & ".join(latex_escape(c) for c in columns) + " \\\\"
    body = [" & ".join(latex_escape(c) for c in r) + " \\\\" for r in rows]
    write_text(os.path.join(out_dir, name + ".tex"), "\n".join(
        [f"% {caption}. Generated by report/make_report.py; needs \\usepackage{{booktabs}}.",
         f"\\begin{{tabular}}{{{align}}}", "\\toprule", head, "\\midrule"] + body
        + ["\\bottomrule", "\\end{tabular}"]) + "\n")
    write_text(os.path.join(out_dir, name + ".long.tex"),
               long_table(caption, columns, plain_cols, rows, numeric_from,
                          numeric_from if keep is None else keep, wrap))
    return {"name": name, "caption": caption, "columns": plain_cols, "rows": rows}


# LaTeX sets a caption on one line to measure it first: past ~16000 pt (TeX's largest
# dimension) it stops with "Dimension too large". A parameter chart of the measured study's 35
# fits lists every fitted point in its caption; report.tex cuts it, figures.json keeps it whole.
CAPTION_MAX_CHARS = 1200


def figure_caption(f):
    c = f["caption"]
    if len(c) <= CAPTION_MAX_CHARS:
        return c
    return c[:CAPTION_MAX_CHARS].rsplit(" ", 1)[0] + " ... (the whole caption: figures.json)"


FLOATS_PER_FLUSH = 8  # Figures between two \clearpage in report.tex, under LaTeX's 18 slots.


def write_latex_document(report_dir, tables, figures):
    """report.tex: every table (longtable, booktabs) and every figure at its printed size, so
    the text in a figure reads at the size it was laid out for (compiles with pdflatex)."""
    body = ["\\documentclass[10pt]{article}", "\\usepackage[a4paper,margin=1.5cm]{geometry}",
            "\\usepackage{booktabs}", "\\usepackage{longtable}", "\\usepackage{graphicx}",
            "\\setlength{\\LTcapwidth}{\\textwidth}", "\\begin{document}",
            "\\section*{Findings}", latex_escape(report_findings.FINDINGS_LEGEND)]
    # Findings first: a verdict table per training set, then the forest plot.
    for key in (k for k in tables if k.startswith("findings")):
        body += ["{\\scriptsize\\setlength{\\tabcolsep}{3pt}",
                 f"\\input{{tables/{key}.long.tex}}", "}"]
    for f in (f for f in figures if f.get("kind") == "forest"):
        body += ["\\begin{figure}[h]\\centering",
                 f"\\includegraphics[width={f['width_in']:g}in,height=0.85\\textheight,"
                 f"keepaspectratio]{{{f['pdf']}}}",
                 f"\\caption{{{latex_escape(figure_caption(f))}}}\\end{{figure}}", "\\clearpage"]
    figures = [f for f in figures if f.get("kind") != "forest"]
    body.append("\\section*{Tables}")
    for key in ["comparisons", "every_metric", "floors", "regions", "matrix", "verdicts",
                "verdict_details", "metrics", "parameters", "probes", "ngan2005_spearman", "ngan2005"]:
        if key in tables:
            body += ["{\\scriptsize\\setlength{\\tabcolsep}{3pt}",
                     f"\\input{{tables/{key}.long.tex}}", "}"]
    body += ["\\clearpage", "\\section*{Figures}"]
    for i, f in enumerate(figures):
        if i and i % FLOATS_PER_FLUSH == 0:
            # Only floats follow, no text to break pages at: LaTeX holds them all back until its
            # 18 float slots run out (the measured study's 146 figures end in "Output loop---100
            # consecutive dead cycles"); a \clearpage now and then places the held ones.
            body.append("\\clearpage")
        # Natural size: 3.3 in (one column) or 7 in (two); a page here is 6.9 in wide.
        body += ["\\begin{figure}[p]\\centering",
                 f"\\includegraphics[width={f['width_in']:g}in,height=0.85\\textheight,"
                 f"keepaspectratio]{{{f['pdf']}}}",
                 f"\\caption{{{latex_escape(figure_caption(f))}}}\\end{{figure}}"]
    body.append("\\end{document}")
    write_text(os.path.join(report_dir, "report.tex"), "\n".join(body) + "\n")
