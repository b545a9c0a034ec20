#!/usr/bin/python3
"""The report reads, computes, then writes (docs/architecture.md, "report/"): the modules that
compute the answers (the rules, statistics, judging set, model's floor, regions, classes,
verdicts, the data floor and the study's answer set) import no file reader and no writer of
words, tables, figures or pages, and open no file; every metric the report's own tables and
words name is one of results.csv's metric columns (report/results_csv.py, the one list); the
fit/baseline ratio is made from a comparison's effect in answer_rules only (no other module
divides by an effect or its CI) and a geometric mean of ratios there or in answer_stats only (no
other module takes the exp of a mean); and what a compute module hands on is a record
(report_records' dataclasses), not a dict with named keys.

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


# A record a compute module hands to the writers is a dataclass of report_records: inside a
# function of a compute module, no dict display with a string key (what a dict record looks
# like when it is made); tables of names live at module level. report_records' to_json methods,
# which write the records as their JSON files have them, are the exception.
RECORDS_HOME = {"report_records.py"}


def dict_records(tree):
    """(line, function) of each dict display with a string-constant key inside a function."""
    out = []
    for fn in ast.walk(tree):
        if isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)):
            for node in ast.walk(fn):
                if isinstance(node, ast.Dict) and any(
                        isinstance(k, ast.Constant) and isinstance(k.value, str)
                        for k in node.keys):
                    out.append((node.lineno, getattr(fn, "name", "lambda")))
    return sorted(set(out))


def exp_of_mean(tree):
    """Line numbers of an exp() whose argument takes a mean or a sum: a geometric mean made by
    hand (answer_rules.geometric_mean_ratio makes the report's)."""
    out = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Call) and call_name(node) == "exp":
            if any(isinstance(n, ast.Call) and call_name(n) in ("mean", "sum", "fsum", "average")
                   for a in node.args for n in ast.walk(a)):
                out.append(node.lineno)
    return out


def call_name(node):
    f = node.func
    return f.id if isinstance(f, ast.Name) else f.attr if isinstance(f, ast.Attribute) else ""


def main(argv):
    report = argv[1]
    failures = []
    for name in sorted(os.listdir(report)):
        if name.endswith(".py") and name not in RATIO_HOME:
            tree = ast.parse(open(os.path.join(report, name), encoding="utf-8").read())
            for line in inverts_effect(tree):
                failures.append(f"report/{name}:{line} divides by a comparison's effect or CI "
                                "(the fit/baseline ratio is answer_rules.error_ratio's)")
            for line in exp_of_mean(tree):
                failures.append(f"report/{name}:{line} takes the exp of a mean (a geometric "
                                "mean ratio is answer_rules.geometric_mean_ratio's)")
    for name in COMPUTE:
        tree = ast.parse(open(os.path.join(report, name), encoding="utf-8").read())
        bad = sorted(imports(tree) & FORBIDDEN)
        if bad:
            failures.append(f"report/{name} imports {', '.join(bad)} (a reader or writer)")
        bad = sorted(calls(tree) & FILE_CALLS)
        if bad:
            failures.append(f"report/{name} calls {', '.join(bad)} (reads or writes a file)")
        if name not in RECORDS_HOME:
            for line, fn in dict_records(tree):
                failures.append(f"report/{name}:{line} ({fn}) makes a dict with named keys: a "
                                "record handed on is a dataclass of report_records")
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
              "comparison's effect round or makes a geometric mean; the compute modules make "
              "no dict records")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
