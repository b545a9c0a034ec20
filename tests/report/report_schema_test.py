#!/usr/bin/python3
"""The report reads its inputs by a schema (report/report_inputs.py): a required field removed or
mistyped in the quick study's own result files ends in exactly one line,
`make_report: error: <file>: field '<name>': expected <type>, got <type>` (or `: missing`), a
non-zero exit, and no file written anywhere in the study folder (no report/, no temporary). And
the fields the runner legitimately leaves out (previews, measured_fraction, the encoding search,
a metric with no lit pixel) are optional: a study without them gets its report.

The other direction (issue 47: a field added on one side fails a test on the other): every JSON
file the runner wrote is walked strictly against the schema (report_inputs.strict_problems): a
field present in a file and declared nowhere fails, naming the file and the field's path, and so
does a file no schema covers. Then both ways are broken on purpose: a field added to a copied
fit job, and a field taken out of the schema, must each fail the walk (and the added field must
not stop the report's own reader, which stays tolerant).

    report_schema_test.py STUDY_DIR SCRATCH_DIR      exit 0 pass, 1 fail
"""

import csv
import fnmatch
import json
import os
import shutil
import subprocess
import sys

REPORT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "report")
SCRIPT = os.path.join(REPORT, "make_report.py")
sys.path.insert(0, REPORT)
import report_inputs  # noqa: E402

# JSON files of a study folder that report_inputs' schema does not declare, and who does.
NOT_REPORT_INPUTS = [
    ("jobs/*.timing.json", "a job's times (WriteTiming): timings.csv's source; the report reads "
                           "neither"),
    ("charts/*.json", "the parameter charts, read by report_charts.load_charts"),
    ("geometry/*.json", "the photographs' geometry, read by floor_inputs.read_geometry"),
    ("references/*.json", "the measured references' sidecars (reference_images); the report "
                          "reads two of their fields (SIDECAR)"),
    ("report/*", "the report itself"),
]


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


def first_probe_job(d):
    name = sorted(n for n in os.listdir(os.path.join(d, "jobs"))
                  if n.startswith("probe.") and not n.endswith(".timing.json"))[0]
    return os.path.join(d, "jobs", name)


def first_curve(j):
    """The first curve of a probe job (its probes by name) and that probe's name."""
    name = sorted(p for p in j["probes"] if j["probes"][p]["curves"])[0]
    return j["probes"][name]["curves"][0], name


def curve_value_as(value):
    def change(j):
        first_curve(j)[0]["y"][1] = value
    return change


def curve_field(d):
    """The name of the first curve's y in the first probe job ('probes.fresnel.curves[0].y')."""
    return f"probes.{first_curve(report_inputs.load_json(first_probe_job(d)))[1]}.curves[0].y"


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
    ("a probe job with a curve's number written as a string",
     lambda d: edit_json(first_probe_job(d), curve_value_as("0.5")),
     first_probe_job, lambda d: f"field '{curve_field(d)}[1]': expected number, got string"),
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


def schema_of(study_dir, rel):
    """(schema or None, why not): the schema a study's JSON file is held to."""
    if rel == "study.json":
        return report_inputs.STUDY, ""
    if rel == "provenance.json":
        return report_inputs.PROVENANCE, ""
    if fnmatch.fnmatch(rel, "probes/*/*.json"):
        return report_inputs.PROBE_RESULT, ""  # WriteProbeOutputs: the probe job's own record
    for pattern, why in NOT_REPORT_INPUTS:
        if fnmatch.fnmatch(rel, pattern):
            return None, why
    if fnmatch.fnmatch(rel, "jobs/*.json"):
        job = report_inputs.load_json(os.path.join(study_dir, rel))
        kind = job.get("kind") if isinstance(job, dict) else None
        if kind in report_inputs.JOB_SCHEMAS:
            return report_inputs.JOB_SCHEMAS[kind], ""
        return None, f"a job of kind {kind!r}, which report_inputs.JOB_SCHEMAS does not declare"
    return None, "no schema in report/report_inputs.py covers it"


def strict_walk(study_dir):
    """(problems, files walked): every JSON file of the study folder against its schema."""
    problems, walked = [], 0
    for rel in files_under(study_dir):
        if not rel.endswith(".json"):
            continue
        schema, why = schema_of(study_dir, rel)
        if schema is None:
            if any(fnmatch.fnmatch(rel, p) for p, _ in NOT_REPORT_INPUTS):
                continue
            problems.append(f"{os.path.join(study_dir, rel)}: {why}")
            continue
        path = os.path.join(study_dir, rel)
        problems += report_inputs.strict_problems(report_inputs.load_json(path), schema, path)
        walked += 1
    return problems, walked


def check_strict(src, scratch):
    """The strict walk over the study's own files passes; a field added to a copied fit job and
    a field taken out of the schema each fail it with the file and the field's path."""
    failures = []
    problems, walked = strict_walk(src)
    print(f"{'ok' if not problems and walked else 'FAILED'}: strict walk: {walked} files, "
          f"{len(problems)} problems" + "".join(f"\n    {p}" for p in problems[:20]))
    if problems or not walked:
        failures.append("strict walk")
    d = os.path.join(scratch, "strict")
    copy_study(src, d)
    job = first_fit_job(d)
    edit_json(job, lambda j: j["evaluations"][0].update(lit_area_mm2=1.5))
    problems, _ = strict_walk(d)
    want = [f"{job}: field 'evaluations[0].lit_area_mm2': not declared in "
            "report/report_inputs.py's schema"]
    try:
        report_inputs.load_study(d)
        tolerant = True
    except report_inputs.ReportInputError as e:
        tolerant = False
        print(f"    the reader refused it: {e}")
    ok = problems == want and tolerant
    print(f"{'ok' if ok else 'FAILED'}: a field the runner adds: {problems}"
          + ("" if problems == want else f"\n    want: {want}"))
    if not ok:
        failures.append("a field added to a job")
    # A field the runner writes taken out of the schema: every fit job names it.
    evaluation = report_inputs.FIT_JOB.fields["evaluations"].kind.item
    removed = evaluation.fields.pop("lit_pixels")
    try:
        problems, _ = strict_walk(src)
    finally:
        evaluation.fields["lit_pixels"] = removed
    fit_jobs = sorted(os.path.join(src, "jobs", n) for n in os.listdir(os.path.join(src, "jobs"))
                      if n.startswith("fit.") and not n.endswith(".timing.json"))
    named = sorted({p.split(": field ")[0] for p in problems
                    if ".lit_pixels': not declared" in p})
    ok = bool(fit_jobs) and named == fit_jobs and all(".lit_pixels'" in p for p in problems)
    print(f"{'ok' if ok else 'FAILED'}: a field taken out of the schema: {len(problems)} "
          f"problems in {len(named)} of {len(fit_jobs)} fit jobs, e.g. "
          f"{problems[0] if problems else None}")
    if not ok:
        failures.append("a field removed from the schema")
    return failures


def main(argv):
    src, scratch = os.path.abspath(argv[1]), os.path.abspath(argv[2])
    d = os.path.join(scratch, "case")
    failures = check_strict(src, scratch)
    for name, breaker, file_of, rest in BROKEN:
        copy_study(src, d)
        breaker(d)
        before = files_under(d)
        code, err = run_report(d)
        want = f"make_report: error: {file_of(d)}: {rest(d) if callable(rest) else rest}"
        written = sorted(set(files_under(d)) - set(before))
        ok = code != 0 and err == want and not written
        print(f"{'ok' if ok else 'FAILED'}: {name}: exit {code}: {err[-300:]}"
              + ("" if err == want else f"\n    want: {want}")
              + (f"\n    written: {written[:5]}" if written else ""))
        if not ok:
            failures.append(name)
    copy_study(src, d)
    every_fit_job(d, drop_optional)
    edit_json(first_probe_job(d), curve_value_as(None))  # a value that is not finite: null
    code, err = run_report(d)
    ok = code == 0 and os.path.exists(os.path.join(d, "report", "index.html"))
    print(f"{'ok' if ok else 'FAILED'}: optional fields left out: exit {code}: {err[-300:]}")
    if not ok:
        failures.append("optional fields")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
