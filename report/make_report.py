#!/usr/bin/python3
"""Tables, figures, verdicts, index.html and summary.md from a study's result files.

    /usr/bin/python3 report/make_report.py out/<study>

Reads only what `shadefit study run` wrote (study.json, results.csv, jobs/*.json, images/,
probes/, provenance.json) and writes <study dir>/report/. Links no renderer. Needs matplotlib and
numpy (Debian: python3-matplotlib python3-numpy). Format and verdict rules: docs/studies.md.
"""

import csv
import fnmatch
import datetime
import glob
import io
import json
import math
import multiprocessing
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import report_charts  # noqa: E402
import data_floor  # noqa: E402
import report_compare  # noqa: E402
import report_figures  # noqa: E402
import report_page  # noqa: E402

METRIC_COLUMNS = [
    ("rmse", "RMSE", "{:.4g}"),
    ("relative_rmse", "rel. RMSE", "{:.3f}"),
    ("psnr", "PSNR [dB]", "{:.2f}"),
    ("ssim", "SSIM", "{:.4f}"),
    ("ciede2000_mean", "$\\Delta E_{00}$", "{:.3f}"),
    ("flip_ldr_mean", "LDR-FLIP", "{:.4f}"),
    ("flip_hdr_mean", "HDR-FLIP", "{:.4f}"),
    ("delta_e_itp_mean", "$\\Delta E_{ITP}$", "{:.3f}"),
]
# Columns a results.csv may lack (written by a shadefit older than the metric): shown empty.
OPTIONAL_METRICS = {"delta_e_itp_mean"}


# ------------------------------------------------------------------------------------------------
# Reading


class ReportInputError(Exception):
    """Bad input: the message is one line naming the file and the field."""


def load_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as e:
        raise ReportInputError(f"{path}: cannot read ({e.strerror})")
    except ValueError as e:
        raise ReportInputError(f"{path}: not JSON ({e})")


def need(obj, field, path, kind, where=""):
    """obj[field], which must be a `kind`; else a ReportInputError naming path and field."""
    name = f"{where}.{field}" if where else field
    if not isinstance(obj, dict) or field not in obj:
        raise ReportInputError(f"{path}: {name}: missing")
    if not isinstance(obj[field], kind):
        raise ReportInputError(f"{path}: {name}: want {getattr(kind, '__name__', 'a value')}, "
                               f"got {type(obj[field]).__name__}")
    return obj[field]


RESULT_COLUMNS = ["material", "lighting", "label", "split", "converged"] + \
    [c[0] for c in METRIC_COLUMNS if c[0] not in OPTIONAL_METRICS]


def check_study(study, path):
    need(study, "name", path, str)
    for i, f in enumerate(need(study, "fits", path, list)):
        need(f, "label", path, str, f"fits[{i}]")
        need(f, "model", path, str, f"fits[{i}]")
    for i, g in enumerate(need(study, "groups", path, list)):
        need(g, "material", path, str, f"groups[{i}]")
        for j, r in enumerate(need(g, "references", path, list, f"groups[{i}]")):
            need(r, "lighting", path, str, f"groups[{i}].references[{j}]")
    need(study, "training_sets", path, list)
    models = [f["model"] for f in study["fits"]]
    if study.get("baseline") is not None and need(study, "baseline", path, str) not in models:
        raise ReportInputError(f"{path}: baseline: '{study['baseline']}' is not a fitted model")
    for i, pair in enumerate(study.get("compare") or []):
        if not (isinstance(pair, list) and len(pair) == 2 and all(p in models for p in pair)):
            raise ReportInputError(f"{path}: compare[{i}]: want a pair of fitted models")
    for name, v in (study.get("verdicts") or {}).items():
        for field, kind in [("source", str), ("kind", str), ("tolerance", (int, float))]:
            need(v, field, path, kind, f"verdicts.{name}")
        if v["kind"] not in ("relative", "absolute", "max"):
            raise ReportInputError(f"{path}: verdicts.{name}.kind: unknown kind '{v['kind']}'")


def check_fit_job(job, path):
    for field, kind in [("material", str), ("label", str), ("parameters", list),
                        ("evaluations", list)]:
        need(job, field, path, kind)
    for i, p in enumerate(job["parameters"]):
        need(p, "name", path, str, f"parameters[{i}]")
        if "value" not in p:
            raise ReportInputError(f"{path}: parameters[{i}].value: missing")
    for i, e in enumerate(job["evaluations"]):
        need(e, "lighting", path, str, f"evaluations[{i}]")


PROBE_SCHEMA = "shadefit.probe/3"  # kProbeResultSchema, metrics/probes/include/shadefit/probes


def check_probe_result(result, path, where):
    """A probe result as ProbeResultToJson writes it: curves are records, never parsed names."""
    schema = result.get("schema") if isinstance(result, dict) else None
    if schema != PROBE_SCHEMA:
        raise ReportInputError(f"{path}: {where}.schema: want {PROBE_SCHEMA}, got {schema!r} "
                               "(written by an older shadefit: run the study again)")
    for i, c in enumerate(need(result, "curves", path, list, where)):
        for field, kind in (("series", str), ("kind", str), ("x", list), ("y", list),
                            ("x_label", str), ("y_label", str), ("x_scale", str),
                            ("y_scale", str)):
            need(c, field, path, kind, f"{where}.curves[{i}]")
        if c.get("reference") is not None:
            need(c, "reference", path, str, f"{where}.curves[{i}]")


def load_study(study_dir):
    study_path = os.path.join(study_dir, "study.json")
    study = load_json(study_path)
    check_study(study, study_path)
    csv_path = os.path.join(study_dir, "results.csv")
    try:
        with open(csv_path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            rows = list(reader)
            missing = [c for c in RESULT_COLUMNS if c not in (reader.fieldnames or [])]
    except (OSError, csv.Error, UnicodeDecodeError) as e:
        raise ReportInputError(f"{csv_path}: cannot read ({e})")
    if missing:
        raise ReportInputError(f"{csv_path}: column {missing[0]}: missing")
    for n, r in enumerate(rows, 2):
        if None in r or any(r[c] is None for c in RESULT_COLUMNS):
            raise ReportInputError(f"{csv_path}:{n}: wrong number of cells")
    fits, probes = {}, {}
    for path in sorted(glob.glob(os.path.join(study_dir, "jobs", "*.json"))):
        job = load_json(path)
        if job.get("kind") == "fit":
            check_fit_job(job, path)
            fits[(job["material"], job["label"])] = job
        elif job.get("kind") == "probe":
            need(job, "material", path, str)
            for probe, result in need(job, "probes", path, dict).items():
                check_probe_result(result, path, f"probes.{probe}")
            probes[job["material"]] = job
    prov_path = os.path.join(study_dir, "provenance.json")
    provenance = load_json(prov_path) if os.path.exists(prov_path) else {}
    return study, rows, fits, probes, provenance


def write_text(path, text):
    """Writes through a temporary file in the same folder and a rename: never a partial file."""
    tmp = os.path.join(os.path.dirname(path), f".{os.path.basename(path)}.{os.getpid()}.tmp")
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    os.replace(tmp, path)


def labels_of(study):
    return [f["label"] for f in study["fits"]]


def materials_of(study):
    return [g["material"] for g in study["groups"]]


def to_float(x):
    if x is None or x == "":
        return None
    try:
        v = float(x)
    except (TypeError, ValueError):
        return None
    return v if math.isfinite(v) else None


def flatten(d, prefix=""):
    """Numeric leaves of nested dicts as {"a.b": value}; lists of numbers become "a[i]"."""
    out = {}
    if isinstance(d, dict):
        for k, v in d.items():
            out.update(flatten(v, f"{prefix}{k}."))
    elif isinstance(d, list) and len(d) <= 8 and all(isinstance(x, (int, float)) for x in d):
        for i, v in enumerate(d):
            out[f"{prefix[:-1]}[{i}]"] = float(v)
    elif isinstance(d, bool):
        out[prefix[:-1]] = 1.0 if d else 0.0
    elif isinstance(d, (int, float)) and math.isfinite(float(d)):
        out[prefix[:-1]] = float(d)
    return out


# ------------------------------------------------------------------------------------------------
# Tables: each is (columns, rows of strings) written as CSV, Markdown and LaTeX (booktabs).


def latex_escape(s):
    s = str(s)
    if s.startswith("$") and s.endswith("$"):
        return s
    repl = {"\\": "\\textbackslash{}", "&": "\\&", "%": "\\%", "$": "\\$", "#": "\\#",
            "_": "\\_", "{": "\\{", "}": "\\}", "~": "\\textasciitilde{}",
            "^": "\\textasciicircum{}"}
    # Text mode has no |, and the figure captions' units use Unicode superscripts.
    repl.update({"|": "$|$", "\u207b": "$^{-}$", "\u00b2": "$^{2}$", "\u00b9": "$^{1}$",
                 "±": "$\\pm$", "\u2212": "$-$"})
    # Adjacent superscripts join: m$^{-}$$^{2}$ -> m$^{-2}$.
    return "".join(repl.get(c, c) for c in s).replace("}$$^{", "")


def md_escape(s):
    return str(s).replace("|", "\\|")


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


def long_table_parts(plain_cols, rows, keep):
    """How report.tex lays out a table that may be wider than the page: (rotate, parts), where
    `rotate` sets the numeric columns' headers on their side and each part is the list of
    other column indices one longtable holds; every part repeats the `keep` leading columns.
    Headers are rotated only when the table does not fit with them upright, and a table is split
    only when it does not fit with them rotated (the measured study's 10 fits)."""
    cell = [max([latex_width_pt(r[i]) for r in rows] + [0.0]) for i in range(len(plain_cols))]
    upright = [LATEX_COLUMN_SEP_PT + max(c, latex_width_pt(h)) for c, h in zip(cell, plain_cols)]
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


def long_table(caption, columns, plain_cols, rows, numeric_from, keep):
    """<name>.long.tex for report.tex: one longtable (header repeated on every page), or, when
    the table is wider than the page, one per group of numeric columns (long_table_parts)."""
    rotate, parts = long_table_parts(plain_cols, rows, keep)
    lines = [f"% {caption}. Generated by report/make_report.py; needs booktabs and longtable"
             + (" and graphicx." if rotate else ".")]
    for n, part in enumerate(parts):
        cols = list(range(keep)) + part
        align = "".join("l" if i < numeric_from else "r" for i in cols)
        head = " & ".join(
            f"\\rotatebox{{90}}{{{latex_escape(columns[i])}}}" if rotate and i >= numeric_from
            else latex_escape(columns[i]) for i in cols) + " \\\\"
        body = [" & ".join(latex_escape(r[i]) for i in cols) + " \\\\" for r in rows]
        span = plain_cols[part[0]] + ("" if len(part) == 1 else f" to {plain_cols[part[-1]]}")
        title = caption if len(parts) == 1 else f"{caption} (part {n + 1} of {len(parts)}: {span})"
        lines += [f"\\begin{{longtable}}{{{align}}}", f"\\caption{{{latex_escape(title)}}}\\\\",
                  "\\toprule", head, "\\midrule", "\\endfirsthead", "\\toprule", head,
                  "\\midrule", "\\endhead", "\\bottomrule", "\\endfoot"] + body
        lines += ["\\end{longtable}"]
    return "\n".join(lines) + "\n"


def write_table(out_dir, name, columns, rows, caption, numeric_from=1, keep=None):
    """tables/<name>.{csv,md,tex}; the .tex is a booktabs tabular for \\input, and
    <name>.long.tex the same rows as a longtable (header repeated on every page) for report.tex,
    split into parts that repeat the first `keep` columns (default: the non-numeric ones) where
    it is wider than the page."""
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
                          numeric_from if keep is None else keep))
    return {"name": name, "caption": caption, "columns": plain_cols, "rows": rows}


def fmt(v, spec="{:.4g}"):
    return "" if v is None else spec.format(v)


def metrics_table(study, rows):
    cols = ["material", "lighting", "fit", "split"] + [c[1] for c in METRIC_COLUMNS] + ["converged"]
    out = []
    for r in rows:
        out.append([r["material"], r["lighting"], r["label"], r["split"]]
                   + [fmt(to_float(r.get(k)), f) for k, _, f in METRIC_COLUMNS]
                   + ["yes" if r["converged"] == "1" else "NO"])
    return cols, out


def parameters_table(study, fits):
    cols = ["material", "fit", "parameter", "value", "std. error", "note"]
    out = []
    for m in materials_of(study):
        for label in labels_of(study):
            job = fits.get((m, label))
            if job is None:
                continue
            for p in job["parameters"]:
                note = []
                if p.get("fixed"):
                    note.append("fixed")
                if p.get("at_bound"):
                    note.append("at bound")
                if p.get("undetermined"):
                    note.append("undetermined")
                out.append([m, label, p["name"], fmt(to_float(p["value"])),
                            fmt(to_float(p["std_error"]), "{:.2g}"), ", ".join(note)])
            out.append([m, label, "exposure", fmt(job.get("exposure")), "",
                        "converged" if job.get("converged") else "NOT CONVERGED: " + job.get("termination", "")])
    return cols, out


def probe_numbers(probes, material, probe):
    job = probes.get(material)
    if job is None or probe not in job.get("probes", {}):
        return None
    return job["probes"][probe].get("numbers", {})


def probes_table(study, probes):
    labels = labels_of(study)
    cols = ["material", "probe", "quantity", "reference"] + labels
    out = []
    for m in materials_of(study):
        for probe in study.get("probes", []):
            numbers = probe_numbers(probes, m, probe)
            if not numbers:
                continue
            ref = flatten(numbers.get("reference") or numbers.get("truth")
                          or numbers.get("measured") or {})
            per = {l: flatten(numbers.get(l, {})) for l in labels}
            keys = list(ref.keys())
            for l in labels:
                keys += [k for k in per[l] if k not in keys]
            for k in keys:
                out.append([m, probe, k, fmt(ref.get(k))] + [fmt(per[l].get(k)) for l in labels])
    return cols, out


# ------------------------------------------------------------------------------------------------
# Verdicts: computed from the numbers with the study's tolerances, never written by hand.


def judge(kind, tol, ref, val, floor=0.0):
    """Returns (error, passed) for one quantity; error is what the tolerance bounds. `floor`: a
    relative error's denominator is at least this, so numbers that are both ~0 agree."""
    if val is None or (kind != "max" and ref is None):
        return None, None
    if kind == "max":
        err = val
    elif kind == "absolute":
        err = abs(val - ref)
    else:
        err = abs(val - ref) / max(abs(ref), floor, 1e-12)
    return err, err <= tol


def compute_verdicts(study, rows, probes):
    """One record per phenomenon x material x fit (worst quantity), plus every quantity."""
    labels = labels_of(study)
    model_of = {f["label"]: f["model"] for f in study["fits"]}
    detail, summary = [], []
    for name, v in study.get("verdicts", {}).items():
        tol, kind, source = float(v["tolerance"]), v["kind"], v["source"]
        for m in materials_of(study):
            why = report_compare.not_valid_reason(study, source, m)
            for label in labels:
                checks = []  # (quantity, reference, value, error, passed)
                if why:
                    # Not valid on this kind of reference: n/a with its reason, never judged.
                    summary.append({"phenomenon": name, "question": v.get("question", name),
                                    "material": m, "fit": label, "quantity": "",
                                    "reference": None, "model": None, "error": None,
                                    "kind": kind, "tolerance": tol, "reproduced": None,
                                    "quantities": 0, "not_valid": why})
                    continue
                if source == "metrics":
                    vals = [to_float(r[v["metric"]]) for r in rows
                            if r["material"] == m and r["label"] == label and r["split"] == v["split"]]
                    vals = [x for x in vals if x is not None]
                    if vals:
                        val = float(np.mean(vals))
                        err, ok = judge("max", tol, 0.0, val)
                        checks.append((f"{v['metric']} ({v['split']}, mean of {len(vals)})", 0.0, val, err, ok))
                else:
                    numbers = probe_numbers(probes, m, source)
                    if numbers:
                        # The reference's numbers; probes that measure models only (energy)
                        # report the true BRDF as "truth".
                        # The brdf probe calls the measured BRDF "measured".
                        ref = flatten(numbers.get("reference") or numbers.get("truth")
                                      or numbers.get("measured") or {})
                        mod = flatten(numbers.get(label, {}))
                        # The energy probe's parameter sweep is per model, not per fit: it says
                        # whether the model's form conserves energy over its parameter range.
                        sweep = (numbers.get("sweep") or {}).get(model_of.get(label, ""))
                        if sweep:
                            mod.update(flatten({"sweep": sweep}))
                        patterns = v.get("keys") or []
                        pool = list(mod.keys()) if kind == "max" else \
                            [k for k in ref if k in mod] + [k for k in mod if k not in ref]
                        if patterns:
                            keys = [k for k in pool if any(fnmatch.fnmatchcase(k, p) for p in patterns)]
                        else:
                            keys = [k for k in pool if kind == "max" or k in ref]
                        for k in keys:
                            err, ok = judge(kind, tol, ref.get(k), mod.get(k),
                                            float(v.get("floor", 0.0)))
                            checks.append((k, ref.get(k), mod.get(k), err, ok))
                for q, r, val, err, ok in checks:
                    detail.append({"phenomenon": name, "material": m, "fit": label, "quantity": q,
                                   "reference": r, "model": val, "error": err, "kind": kind,
                                   "tolerance": tol, "reproduced": ok})
                judged = [c for c in checks if c[4] is not None]
                if not judged:
                    summary.append({"phenomenon": name, "question": v.get("question", name),
                                    "material": m, "fit": label, "quantity": "", "reference": None,
                                    "model": None, "error": None, "kind": kind, "tolerance": tol,
                                    "reproduced": None, "quantities": 0})
                    continue
                worst = max(judged, key=lambda c: c[3] / tol if tol > 0 else c[3])
                summary.append({"phenomenon": name, "question": v.get("question", name),
                                "material": m, "fit": label, "quantity": worst[0],
                                "reference": worst[1], "model": worst[2], "error": worst[3],
                                "kind": kind, "tolerance": tol,
                                "reproduced": all(c[4] for c in judged), "quantities": len(judged)})
    return summary, detail


def yes_no(ok):
    return "n/a" if ok is None else ("yes" if ok else "no")


def verdict_tables(study, summary, detail):
    cols = ["phenomenon", "material", "fit", "quantity (worst)", "reference", "model",
            "error", "tolerance", "reproduced"]
    rows = []
    for s in summary:
        err_name = {"relative": "rel.", "absolute": "abs.", "max": "value"}[s["kind"]]
        rows.append([s["phenomenon"], s["material"], s["fit"], s["quantity"], fmt(s["reference"]),
                     fmt(s["model"]), fmt(s["error"], "{:.3g}"),
                     f"{err_name} <= {s['tolerance']:g}", yes_no(s["reproduced"])])
    dcols = ["phenomenon", "material", "fit", "quantity", "reference", "model", "error",
             "tolerance", "reproduced"]
    drows = [[d["phenomenon"], d["material"], d["fit"], d["quantity"], fmt(d["reference"]),
              fmt(d["model"]), fmt(d["error"], "{:.3g}"), f"{d['kind']} {d['tolerance']:g}",
              yes_no(d["reproduced"])] for d in detail]
    # The matrix: phenomenon x fit -> materials reproduced / materials judged.
    labels = labels_of(study)
    mcols = ["phenomenon", "question"] + labels
    mrows = []
    for name, v in study.get("verdicts", {}).items():
        row = [name, v.get("question", name)]
        for label in labels:
            judged = [s for s in summary if s["phenomenon"] == name and s["fit"] == label
                      and s["reproduced"] is not None]
            good = sum(1 for s in judged if s["reproduced"])
            row.append(f"{good}/{len(judged)}" if judged else "n/a")
        mrows.append(row)
    return (cols, rows), (dcols, drows), (mcols, mrows)


# ------------------------------------------------------------------------------------------------
# Pages


def not_valid_reasons(summary, name):
    return sorted({s["not_valid"] for s in summary if s["phenomenon"] == name and s.get("not_valid")})


def summary_markdown(study, summary, matrix, provenance, comparisons, floor_lines=()):
    labels = labels_of(study)
    lines = [f"# {study['name']}", "", study.get("description", ""), "",
             f"Materials: {', '.join(materials_of(study))}. Fits: {', '.join(labels)}. "
             f"Training lightings: {'; '.join('+'.join(t) for t in study['training_sets'])}.", "",
             "## Answers", "", report_compare.method_text(comparisons), ""]
    lines += report_compare.answer_lines(comparisons)
    hcols, hrows = report_compare.human_agreement_table(comparisons)
    lines += ["", "### Image metrics against human judgments", "",
              f"Spearman rho of each metric with the human distance over "
              f"{report_compare.HUMAN_AGREEMENT_SOURCE}.", "",
              "| " + " | ".join(hcols) + " |", "|---|---:|---:|---|"]
    lines += ["| " + " | ".join(r) + " |" for r in hrows]
    if floor_lines:
        lines += ["", "### Data floor", ""] + [f"- {l}" for l in floor_lines]
    lines += ["", "## Within tolerance (secondary)", "",
              "Materials whose numbers are within the study's fixed tolerance, out of those "
              "judged.", ""]
    for name, v in study.get("verdicts", {}).items():
        parts = []
        for label in labels:
            judged = [s for s in summary if s["phenomenon"] == name and s["fit"] == label
                      and s["reproduced"] is not None]
            if not judged:
                continue
            good = [s["material"] for s in judged if s["reproduced"]]
            parts.append(f"{label}: {len(good)}/{len(judged)}")
        tol = f"{v['kind']} tolerance {v['tolerance']:g}"
        why = not_valid_reasons(summary, name)
        answer = "; ".join(parts) if parts else (
            f"n/a ({why[0]})" if why else "not measured (no numbers)")
        if parts and why:
            answer += f"; n/a on the other materials ({why[0]})"
        lines.append(f"- **{v.get('question', name)}** ({tol}) — materials reproduced: {answer}")
    lines += ["", "## Verdict matrix", "", "| " + " | ".join(matrix[0]) + " |",
              "|" + "|".join("---" for _ in matrix[0]) + "|"]
    lines += ["| " + " | ".join(md_escape(c) for c in r) + " |" for r in matrix[1]]
    sf = provenance.get("shadefit", {})
    lines += ["", f"shadefit {sf.get('version', '?')}, GL: {provenance.get('gl_renderer', '?')}, "
              f"generated {datetime.date.today().isoformat()}.", ""]
    return "\n".join(lines)


# --- Encoding of photographs (fit.encoding = "fit": fit/encoding_search.h) --------------------

def encoding_sentences(fits):
    """One sentence per fit whose encoding was fitted: which encoding won, on what score."""
    out = []
    for (material, label), job in sorted(fits.items()):
        e = job.get("encoding")
        if not isinstance(e, dict):
            continue
        others = "; ".join(f"{c.get('name')} {255 * c.get('stored_rmse', float('nan')):.3f}"
                           for c in e.get("candidates", []) if not c.get("chosen"))
        out.append(f"- {material} / {label}: the fit chose the encoding **{e.get('name')}** "
                   f"(RMSE in stored 8-bit codes {255 * e.get('stored_rmse', float('nan')):.3f}; "
                   f"{others})")
    return out


def encoding_table(fits):
    cols = ["material", "fit", "encoding", "gamma", "stored RMSE x255", "chosen"]
    rows = []
    for (material, label), job in sorted(fits.items()):
        e = job.get("encoding")
        if not isinstance(e, dict):
            continue
        for c in e.get("candidates", []):
            rows.append([material, label, str(c.get("name")), fmt(c.get("gamma")),
                         fmt(255 * c.get("stored_rmse", float("nan"))),
                         "yes" if c.get("chosen") else ""])
    return cols, rows


# --- Ngan, Durand and Matusik 2005 side by side (measured studies) ----------------------------

def ranks(values):
    """Ranks 1..n, ties given their average rank (for Spearman's rho)."""
    order = sorted(range(len(values)), key=lambda i: values[i])
    r = [0.0] * len(values)
    i = 0
    while i < len(order):
        j = i
        while j + 1 < len(order) and values[order[j + 1]] == values[order[i]]:
            j += 1
        for k in range(i, j + 1):
            r[order[k]] = (i + j) / 2.0 + 1.0
        i = j + 1
    return r


def spearman(x, y):
    """Spearman's rank correlation: Pearson's correlation of the ranks (ties averaged)."""
    if len(x) < 3:
        return None
    rx, ry = ranks(x), ranks(y)
    mx, my = sum(rx) / len(rx), sum(ry) / len(ry)
    sxy = sum((a - mx) * (b - my) for a, b in zip(rx, ry))
    sxx = sum((a - mx) ** 2 for a in rx)
    syy = sum((b - my) ** 2 for b in ry)
    return sxy / math.sqrt(sxx * syy) if sxx > 0 and syy > 0 else None


def ngan_table_path(study):
    """ngan2005-fits.tsv beside the measured folder the study's references came from, if any."""
    for g in study["groups"]:
        for r in g["references"]:
            sidecar = r.get("sidecar")
            if not sidecar or not os.path.exists(sidecar):
                continue
            sc = load_json(sidecar)
            if sc.get("kind") != "measured-brdf":
                continue
            for f in sc.get("brdf", {}).get("files", []):
                candidate = os.path.join(os.path.dirname(os.path.dirname(f["path"])),
                                         "ngan2005-fits.tsv")
                if os.path.exists(candidate):
                    return candidate
    return None


def read_ngan(path):
    with open(path, encoding="utf-8") as f:
        lines = [l.rstrip("\n") for l in f if l.strip() and not l.startswith("#")]
    header = lines[0].split("\t")
    out = {}
    for line in lines[1:]:
        cells = line.split("\t")
        out[cells[0]] = {h: float(c) for h, c in zip(header[1:], cells[1:])}
    return out


# Our fitted quantity set against Ngan's: (our model, our parameter -> number, Ngan's column).
# GGX and Beckmann alpha = roughness^2 (models.md); Ngan's Cook-Torrance m is a Beckmann slope
# width; Blinn-Phong sharpness n is the exponent. Ranks compare across normalisations.
NGAN_PAIRS = [
    ("blinn-phong", "shininess", lambda v: v, "shininess n", "blinn_phong_n", "Blinn-Phong n"),
    ("blinn-phong-normalized", "shininess", lambda v: v, "shininess n", "blinn_phong_n",
     "Blinn-Phong n"),
    ("ggx", "roughness", lambda v: v * v, "alpha", "cook_torrance_m", "Cook-Torrance m"),
    ("beckmann", "roughness", lambda v: v * v, "alpha", "cook_torrance_m", "Cook-Torrance m"),
    # Ngan's own model set (render/models/): the same forms, parameter for parameter.
    ("cook-torrance", "m", lambda v: v, "m", "cook_torrance_m", "Cook-Torrance m"),
    ("ward", "alpha", lambda v: v, "alpha", "ward_alpha", "Ward alpha"),
    ("ward-duer", "alpha", lambda v: v, "alpha", "ward_alpha", "Ward alpha"),
    ("ashikhmin-shirley", "n", lambda v: v, "n", "ashikhmin_shirley_n", "Ashikhmin-Shirley n"),
    ("lafortune", "n", lambda v: v, "n", "lafortune_n", "Lafortune n")]


def ngan_comparison(study, fits):
    """Per fit label with a counterpart in Ngan 2005: our number next to theirs, and rho."""
    path = ngan_table_path(study)
    if path is None:
        return None
    ngan = read_ngan(path)
    rows, correlations = [], []
    for f in study["fits"]:
        for model, pname, to_num, ours_label, col, col_label in NGAN_PAIRS:
            if f["model"] != model:
                continue
            ours, theirs = [], []
            for m in materials_of(study):
                job = fits.get((m, f["label"]))
                if job is None or m not in ngan:
                    continue
                value = next((to_float(p["value"]) for p in job["parameters"] if p["name"] == pname), None)
                if value is None:
                    continue
                num = to_num(value)
                ours.append(num)
                theirs.append(ngan[m][col])
                rows.append([m, f["label"], ours_label, fmt(num), col_label, fmt(ngan[m][col])])
            rho = spearman(ours, theirs)
            correlations.append({"fit": f["label"], "model": model, "ours": ours_label,
                                 "ngan": col, "materials": len(ours), "spearman": rho})
    return {"source": path, "rows": rows, "correlations": correlations}


FLOATS_PER_FLUSH = 8  # Figures between two \clearpage in report.tex, under LaTeX's 18 slots.


def write_latex_document(report_dir, tables, figures):
    """report.tex: every table (longtable, booktabs) and every figure at its printed size, so
    the text in a figure reads at the size it was laid out for (compiles with pdflatex)."""
    body = ["\\documentclass[10pt]{article}", "\\usepackage[a4paper,margin=1.5cm]{geometry}",
            "\\usepackage{booktabs}", "\\usepackage{longtable}", "\\usepackage{graphicx}",
            "\\setlength{\\LTcapwidth}{\\textwidth}", "\\begin{document}",
            "\\section*{Tables}"]
    for key in ["comparisons", "matrix", "verdicts", "verdict_details", "metrics", "parameters", "probes",
                "ngan2005_spearman", "ngan2005"]:
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
                 f"\\caption{{{latex_escape(f['caption'])}}}\\end{{figure}}"]
    body.append("\\end{document}")
    write_text(os.path.join(report_dir, "report.tex"), "\n".join(body) + "\n")


def report_jobs():
    """Processes that draw the per-material figures: $SHADEFIT_REPORT_JOBS, else one per CPU this
    process may use (at most 8)."""
    env = os.environ.get("SHADEFIT_REPORT_JOBS", "").strip()
    if env:
        try:
            jobs = int(env)
        except ValueError:
            jobs = 0
        if jobs < 1:
            raise ReportInputError(f"SHADEFIT_REPORT_JOBS: expected a whole number >= 1, got '{env}'")
        return jobs
    return max(1, min(8, len(os.sched_getaffinity(0))))


# What the forked figure workers read (set before the pool starts; fork shares it unpickled).
_FIGURE_INPUTS = None


def material_figures(material):
    """The image grids and probe figures of one material, drawn and saved; their figures.json
    records (grids, probes)."""
    study_dir, study, fits, probes, fig_dir = _FIGURE_INPUTS
    grids, probe_figs = [], []
    report_figures.image_grid(study_dir, study, fits, material, fig_dir, grids)
    if material in probes:
        report_figures.probe_figures(study, {material: probes[material]}, fig_dir, probe_figs,
                                     flatten)
    return grids, probe_figs


def per_material_figures(study_dir, study, fits, probes, fig_dir, jobs):
    """Every material's grids (in the study's order), then every probe figure (by material
    name): the same records, in the same order, with one process or several."""
    global _FIGURE_INPUTS
    _FIGURE_INPUTS = (study_dir, study, fits, probes, fig_dir)
    grid_order = list(materials_of(study))
    materials = grid_order + sorted(m for m in probes if m not in grid_order)
    jobs = min(jobs, len(materials))
    pool = None
    if jobs > 1:
        try:
            # Fork: the workers inherit the inputs and matplotlib's state; no figure is open yet.
            pool = multiprocessing.get_context("fork").Pool(jobs)
        except OSError:
            pool = None  # No POSIX semaphores here (a container without /dev/shm): one process.
    if pool is not None:
        with pool:
            done = dict(zip(materials, pool.map(material_figures, materials, chunksize=1)))
    else:
        done = {m: material_figures(m) for m in materials}
    _FIGURE_INPUTS = None
    return ([r for m in grid_order for r in done[m][0]] +
            [r for m in sorted(probes) for r in done[m][1]])


def make_report(study_dir):
    # Every input is read and checked before the first file is written.
    jobs = report_jobs()
    study, rows, fits, probes, provenance = load_study(study_dir)
    charts_in = report_charts.load_charts(study_dir)
    report_dir = os.path.join(study_dir, "report")
    table_dir = os.path.join(report_dir, "tables")
    fig_dir = os.path.join(report_dir, "figures")
    os.makedirs(fig_dir, exist_ok=True)

    summary, detail = compute_verdicts(study, rows, probes)
    verdicts, verdict_details, matrix = verdict_tables(study, summary, detail)
    comparisons = report_compare.compare_study(study, rows, summary, to_float)
    tables = {"comparisons": report_compare.comparison_table(comparisons, fmt),
              "metrics": metrics_table(study, rows), "parameters": parameters_table(study, fits),
              "probes": probes_table(study, probes), "verdicts": verdicts,
              "verdict_details": verdict_details, "matrix": matrix}
    captions = {"comparisons": "Comparative answers: each fit against the baseline fit over "
                               "the materials (effect: baseline error / fit error, geometric "
                               "mean; p: Wilcoxon or exact sign test; Holm-corrected)",
                "metrics": "Image metrics per reference and fit (linear radiance; display metrics at exposure 0)",
                "parameters": "Fitted parameters with standard errors",
                "probes": "Phenomenon probe numbers: reference and each fit",
                "verdicts": "Verdicts: worst quantity per phenomenon, material and fit",
                "verdict_details": "Verdicts per quantity",
                "matrix": "Materials reproduced within tolerance per phenomenon and fit"}
    for key, (cols, trows) in tables.items():
        numeric_from = {"comparisons": 3, "metrics": 4, "parameters": 3, "probes": 3, "verdicts": 4,
                        "verdict_details": 4, "matrix": 2}[key]
        # A part of the probes table without the reference column would compare with nothing.
        write_table(table_dir, key, cols, trows, captions[key], numeric_from,
                    keep=4 if key == "probes" else None)
    # The verdicts also as JSON for tools and tests.
    write_text(os.path.join(report_dir, "verdicts.json"),
               json.dumps({"summary": summary, "detail": detail}, indent=1))
    write_text(os.path.join(report_dir, "comparisons.json"),
               json.dumps(report_compare.to_json(comparisons), indent=1))

    figures = []
    for rec in comparisons:
        report_figures.paired_errors_figure(
            rec, study, fig_dir, figures, report_compare.question_title(rec),
            report_compare.error_label(rec))
    figures += per_material_figures(study_dir, study, fits, probes, fig_dir, jobs)
    report_figures.metric_bars(study, rows, fig_dir, figures, to_float)
    charts = report_charts.chart_figures(study_dir, study, fits, fig_dir, [], charts_in,
                                          probes)
    write_text(os.path.join(report_dir, "figures.json"), json.dumps(figures + charts, indent=1))

    ngan = ngan_comparison(study, fits)
    if ngan is not None:
        cols = ["material", "fit", "ours", "value", "Ngan 2005", "Ngan's value"]
        tables["ngan2005"] = (cols, ngan["rows"])
        write_table(table_dir, "ngan2005", cols, ngan["rows"],
                    "Our fitted lobe parameters next to Ngan, Durand and Matusik 2005's BRDF-space fits", 3)
        corr_cols = ["fit", "our parameter", "Ngan 2005", "materials", "Spearman rho"]
        corr_rows = [[c["fit"], c["ours"], c["ngan"], str(c["materials"]),
                      fmt(c["spearman"], "{:.3f}") if c["spearman"] is not None else "n/a"]
                     for c in ngan["correlations"]]
        tables["ngan2005_spearman"] = (corr_cols, corr_rows)
        write_table(table_dir, "ngan2005_spearman", corr_cols, corr_rows,
                    "Rank correlation of our fitted lobe widths with Ngan et al. 2005 (Spearman)", 3)
        write_text(os.path.join(report_dir, "ngan2005.json"), json.dumps(ngan, indent=1))
    # The data floor (report/data_floor.py), where the runner wrote geometry/ (photographs):
    # right after the comparative answers, each fit's test error next to the floor's.
    floor_lines = []
    floor = data_floor.compute_floor(study_dir, study, fits)
    if floor is not None:
        write_text(os.path.join(report_dir, "floor.json"), json.dumps(floor, indent=1))
        tables["floor"] = data_floor.floor_table(floor)
        write_table(table_dir, "floor", *tables["floor"],
                    "Data floor: each fit's mean test relative RMSE next to the best isotropic "
                    "BRDF's (tabulated f(theta_h, theta_d), no model)", 3)
        floor_lines = data_floor.floor_sentences(floor)
    summary_md = summary_markdown(study, summary, matrix, provenance, comparisons, floor_lines)
    enc_rows = encoding_table(fits)
    if enc_rows[1]:
        tables["encoding"] = enc_rows
        write_table(table_dir, "encoding", enc_rows[0], enc_rows[1],
                    "Encoding of the photographs: each candidate's RMSE in stored values", 3)
        summary_md += ("\n## Encoding of the photographs\n\nScored by the RMSE between the "
                       "encoded prediction and the stored values of the training "
                       "photographs.\n\n" + "\n".join(encoding_sentences(fits)) + "\n")
    if ngan is not None:
        summary_md += "\n## Against Ngan, Durand and Matusik 2005\n\n" + "".join(
            f"- {c['fit']}: Spearman rho of our {c['ours']} with Ngan's {c['ngan']} over "
            f"{c['materials']} materials: "
            + (f"{c['spearman']:.3f}" if c["spearman"] is not None else "n/a") + "\n"
            for c in ngan["correlations"])
    write_text(os.path.join(report_dir, "summary.md"), summary_md)
    report_page.write_index(report_dir, study, tables, figures, provenance, summary, rows, fits,
                            charts, write_text, comparisons, floor_lines)
    write_latex_document(report_dir, tables, figures + charts)
    return os.path.join(report_dir, "index.html")


def main(argv):
    if len(argv) != 2:
        print("usage: make_report.py OUT/STUDY", file=sys.stderr)
        return 2
    study_dir = os.path.abspath(argv[1])
    for need_file in ["study.json", "results.csv"]:
        if not os.path.exists(os.path.join(study_dir, need_file)):
            print(f"make_report: {study_dir}/{need_file}: missing (run the study first)",
                  file=sys.stderr)
            return 1
    try:
        print(make_report(study_dir))
    except (ReportInputError, report_charts.ChartInputError) as e:
        print(f"make_report: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
