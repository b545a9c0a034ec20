#!/usr/bin/python3
"""The report reads, computes, then writes (docs/architecture.md, "report/"): the modules that
compute the answers (the rules, statistics, judging set, model's floor, regions, classes,
verdicts, the data floor and the study's answer set) import no file reader and no writer of
words, tables, figures or pages, and open no file; every metric the report's own tables and
words name is one of results.csv's metric columns (report/results_csv.py, the one list); and the
fit/baseline ratio is made from a comparison's effect in answer_rules only (no other module
divides by an effect or its CI).

    layers_test.py REPORT_DIR      exit 0 pass, 1 fail
"""

import ast
import os
import sys

# The compute core: the rules that decide an answer, their statistics, the judging set.
COMPUTE = ["answer_rules.py", "answer_stats.py", "judging.py", "model_floor.py",
           "report_regions.py", "report_classes.py", "report_verdicts.py", "data_floor.py",
           "study_answers.py", "report_ngan.py", "report_records.py"]
# What a compute module must not import: readers, writers and drawing (results_csv's column
# names may be imported; its reader may not be called).
FORBIDDEN = {"report_inputs", "floor_inputs", "section_words", "figure_cache",
             "report_figures", "report_page", "report_latex", "report_summary", "answer_words",
             "report_findings", "report_sections", "report_grids", "report_probe_figures",
             "report_metric_figures", "report_charts", "report_tables", "make_report",
             "matplotlib", "csv", "glob", "json", "os", "shutil", "pathlib", "progress"}
# Calls that read or write files.
FILE_CALLS = {"open", "write_text", "load_json", "read_checked", "read_rows", "read_results",
              "load", "loadtxt", "genfromtxt", "fromfile", "save", "imread", "read_rgb",
              "read_geometry", "load_study", "load_charts", "classifications"}


def imports(tree):
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name.split(".")[0] for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module:
            out.add(node.module.split(".")[0])
    return out


def calls(tree):
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Call):
            f = node.func
            out.add(f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute)
                    else "")
    return out


# The one fit/baseline ratio (answer_rules.error_ratio, error_ratio_ci): a comparison's effect
# (baseline / fit) and its interval are turned round there and nowhere else.
RATIO_HOME = {"answer_rules.py", "answer_stats.py"}


def inverts_effect(tree):
    """Line numbers where a division's divisor reads a comparison's `effect` or `ci`."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.BinOp) and isinstance(node.op, ast.Div):
            if any(isinstance(n, ast.Attribute) and n.attr in ("effect", "ci")
                   for n in ast.walk(node.right)):
                out.append(node.lineno)
    return out


def main(argv):
    report = argv[1]
    failures = []
    for name in sorted(os.listdir(report)):
        if name.endswith(".py") and name not in RATIO_HOME:
            tree = ast.parse(open(os.path.join(report, name), encoding="utf-8").read())
            for line in inverts_effect(tree):
                failures.append(f"report/{name}:{line} divides by a comparison's effect or CI "
                                "(the fit/baseline ratio is answer_rules.error_ratio's)")
    for name in COMPUTE:
        tree = ast.parse(open(os.path.join(report, name), encoding="utf-8").read())
        bad = sorted(imports(tree) & FORBIDDEN)
        if bad:
            failures.append(f"report/{name} imports {', '.join(bad)} (a reader or writer)")
        bad = sorted(calls(tree) & FILE_CALLS)
        if bad:
            failures.append(f"report/{name} calls {', '.join(bad)} (reads or writes a file)")
    sys.path.insert(0, report)
    import judging
    import report_tables
    import results_csv
    named = ({m for m, _, _ in report_tables.METRIC_COLUMNS} | set(judging.METRIC_NAMES)
             | set(judging.HUMAN_AGREEMENT))
    stray = sorted(named - set(results_csv.METRIC_COLUMNS))
    if stray:
        failures.append(f"metrics named by report_tables/judging but not results.csv columns: "
                        f"{stray}")
    for f in failures:
        print("FAILED: " + f)
    if not failures:
        print(f"PASS: {', '.join(COMPUTE)} import no reader or writer and open no file; every "
              "metric named is a results.csv column; no module but answer_rules turns a "
              "comparison's effect round")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
