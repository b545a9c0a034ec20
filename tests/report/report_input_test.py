#!/usr/bin/python3
"""Bad input to report/make_report.py ends in one line naming the file and the field, a non-zero
exit, and no report written (every input is read and checked before the first file is written).
Each case copies the quick study's result files into a fresh folder and breaks one of them.

    report_input_test.py STUDY_DIR SCRATCH_DIR      exit 0 pass, 1 fail
"""

import json
import os
import shutil
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "report",
                      "make_report.py")


def copy_study(src, dst):
    if os.path.exists(dst):
        shutil.rmtree(dst)
    os.makedirs(dst)
    for name in ["study.json", "results.csv", "provenance.json"]:
        shutil.copy(os.path.join(src, name), dst)
    for name in ["jobs", "images", "charts", "probes"]:
        if os.path.isdir(os.path.join(src, name)):
            shutil.copytree(os.path.join(src, name), os.path.join(dst, name))


def edit_json(path, change):
    with open(path, encoding="utf-8") as f:
        j = json.load(f)
    change(j)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(j, f)


def drop_column(path, column):
    with open(path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    i = lines[0].split(",").index(column)
    out = [",".join(c for k, c in enumerate(l.split(",")) if k != i) for l in lines]
    with open(path, "w", encoding="utf-8") as f:
        f.write("\n".join(out) + "\n")


def first_fit_job(d):
    return sorted(n for n in os.listdir(os.path.join(d, "jobs")) if n.startswith("fit."))[0]


def first_probe_job(d):
    return sorted(n for n in os.listdir(os.path.join(d, "jobs")) if n.startswith("probe."))[0]


def old_curves(j):
    """A probe result as shadefit.probe/1 wrote it: no schema, curves keyed by a built name."""
    r = j["probes"]["fresnel"]
    r.pop("schema")
    r["curves"] = {f"{c['series']}: {c['kind']}": c for c in r["curves"]}


CASES = [
    ("study.json not JSON", lambda d: open(os.path.join(d, "study.json"), "w").write("{nope"),
     "study.json", "not JSON"),
    ("study.json without fits", lambda d: edit_json(os.path.join(d, "study.json"),
                                                     lambda j: j.pop("fits")),
     "study.json", "field 'fits': missing"),
    ("unknown verdict kind", lambda d: edit_json(
        os.path.join(d, "study.json"),
        lambda j: next(iter(j["verdicts"].values())).update(kind="median")),
     "study.json", ".kind': expected 'relative' or 'absolute' or 'max', got 'median'"),
    ("results.csv without a metric column",
     lambda d: drop_column(os.path.join(d, "results.csv"), "flip_ldr_mean"),
     "results.csv", "column 'flip_ldr_mean': missing"),
    ("fit job without parameters", lambda d: edit_json(
        os.path.join(d, "jobs", first_fit_job(d)), lambda j: j.pop("parameters")),
     "jobs/fit.", "field 'parameters': missing"),
    ("probe result of an older shadefit", lambda d: edit_json(
        os.path.join(d, "jobs", first_probe_job(d)), old_curves),
     "jobs/probe.",
     "field 'probes.fresnel.schema': missing (written by an older shadefit: run the study"),
    ("probe curve without a kind", lambda d: edit_json(
        os.path.join(d, "jobs", first_probe_job(d)),
        lambda j: j["probes"]["fresnel"]["curves"][0].pop("kind")),
     "jobs/probe.", "field 'probes.fresnel.curves[0].kind': missing"),
    ("chart manifest with a short row", lambda d: edit_json(
        os.path.join(d, "charts", "charts.json"), lambda j: j["charts"][0]["images"][0].pop()),
     "charts/charts.json", "charts[0].images"),
]


def main(argv):
    src, scratch = os.path.abspath(argv[1]), os.path.abspath(argv[2])
    failures = []
    for name, breaker, want_file, want_field in CASES:
        d = os.path.join(scratch, "case")
        copy_study(src, d)
        breaker(d)
        p = subprocess.run(["/usr/bin/python3", SCRIPT, d], capture_output=True, text=True)
        err = p.stderr.strip()
        ok = (p.returncode != 0 and len(err.splitlines()) == 1 and want_file in err
              and want_field in err and not os.path.exists(os.path.join(d, "report")))
        print(f"{'ok' if ok else 'FAILED'}: {name}: exit {p.returncode}: {err[-300:]}")
        if not ok:
            failures.append(name)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
