#!/usr/bin/python3
"""The report reads its inputs by a schema (report/report_inputs.py): a required field removed or
mistyped in the quick study's own result files ends in exactly one line,
`make_report: error: <file>: field '<name>': expected <type>, got <type>` (or `: missing`), a
non-zero exit, and no file written anywhere in the study folder (no report/, no temporary). And
the fields the runner legitimately leaves out (previews, measured_fraction, the encoding search,
a metric with no lit pixel) are optional: a study without them gets its report.

    report_schema_test.py STUDY_DIR SCRATCH_DIR      exit 0 pass, 1 fail
"""

import csv
import json
import os
import shutil
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "report",
                      "make_report.py")


def copy_study(src, dst):
    """The result files the runner wrote, without the report made from them."""
    if os.path.exists(dst):
        shutil.rmtree(dst)
    shutil.copytree(src, dst, ignore=lambda folder, names: ["report"] if folder == src else [])


def files_under(d):
    return sorted(os.path.relpath(os.path.join(root, n), d)
                  for root, _, names in os.walk(d) for n in names)


def edit_json(path, change):
    with open(path, encoding="utf-8") as f:
        j = json.load(f)
    change(j)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(j, f)


def edit_csv_cell(path, row, column, value):
    with open(path, newline="", encoding="utf-8") as f:
        reader = csv.DictReader(f)
        rows, header = list(reader), reader.fieldnames
    rows[row][column] = value
    with open(path, "w", newline="", encoding="utf-8") as f:
        w = csv.DictWriter(f, fieldnames=header, lineterminator="\n")
        w.writeheader()
        w.writerows(rows)


def first_fit_job(d):
    name = sorted(n for n in os.listdir(os.path.join(d, "jobs"))
                  if n.startswith("fit.") and not n.endswith(".timing.json"))[0]
    return os.path.join(d, "jobs", name)


def every_fit_job(d, change):
    for n in os.listdir(os.path.join(d, "jobs")):
        if n.startswith("fit.") and not n.endswith(".timing.json"):
            edit_json(os.path.join(d, "jobs", n), change)


# (name, how to break the copy, the file the error names relative to the copy, the rest of the
# line after "<file>: "). Each line is compared whole.
BROKEN = [
    ("a fit job without a required field",
     lambda d: edit_json(first_fit_job(d), lambda j: j["evaluations"][0].pop("split")),
     first_fit_job, "field 'evaluations[0].split': missing"),
    ("a fit job with a number written as a string",
     lambda d: edit_json(first_fit_job(d), lambda j: j["parameters"][0].update(value="0.5")),
     first_fit_job, "field 'parameters[0].value': expected number, got string"),
    ("a fit job with a flag written as a number",
     lambda d: edit_json(first_fit_job(d), lambda j: j.update(converged=1)),
     first_fit_job, "field 'converged': expected boolean, got number"),
    ("study.json with a fit's label missing",
     lambda d: edit_json(os.path.join(d, "study.json"), lambda j: j["fits"][0].pop("label")),
     lambda d: os.path.join(d, "study.json"), "field 'fits[0].label': missing"),
    ("results.csv with text in a metric cell",
     lambda d: edit_csv_cell(os.path.join(d, "results.csv"), 0, "rmse", "bright"),
     lambda d: os.path.join(d, "results.csv") + ":2", "field 'rmse': expected number, "
                                                      "got 'bright'"),
]


def drop_optional(j):
    """What the runner leaves out of some fit jobs: previews (previews = false), the measured
    fraction, the encoding search; and null metrics (a lighting with no lit pixel)."""
    j.pop("encoding", None)
    for e in j["evaluations"]:
        e.pop("images", None)
        e.pop("measured_fraction", None)
        e["metrics"]["ssim"] = None


def run_report(d):
    p = subprocess.run(["/usr/bin/python3", SCRIPT, d], capture_output=True, text=True)
    return p.returncode, p.stderr.strip()


def main(argv):
    src, scratch = os.path.abspath(argv[1]), os.path.abspath(argv[2])
    d = os.path.join(scratch, "case")
    failures = []
    for name, breaker, file_of, rest in BROKEN:
        copy_study(src, d)
        breaker(d)
        before = files_under(d)
        code, err = run_report(d)
        want = f"make_report: error: {file_of(d)}: {rest}"
        written = sorted(set(files_under(d)) - set(before))
        ok = code != 0 and err == want and not written
        print(f"{'ok' if ok else 'FAILED'}: {name}: exit {code}: {err[-300:]}"
              + ("" if err == want else f"\n    want: {want}")
              + (f"\n    written: {written[:5]}" if written else ""))
        if not ok:
            failures.append(name)
    copy_study(src, d)
    every_fit_job(d, drop_optional)
    code, err = run_report(d)
    ok = code == 0 and os.path.exists(os.path.join(d, "report", "index.html"))
    print(f"{'ok' if ok else 'FAILED'}: optional fields left out: exit {code}: {err[-300:]}")
    if not ok:
        failures.append("optional fields")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
