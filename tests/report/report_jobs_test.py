#!/usr/bin/python3
"""The report is the same with one figure process or several (make_report.py draws the
per-material figures in a forked pool, SHADEFIT_REPORT_JOBS): figures.json and every figure's PNG
are the same bytes. A bad SHADEFIT_REPORT_JOBS is one line naming it, exit 1, and no report.
Without it, the processes are the CPUs this process may use, no more than a Slurm job's
allocation (report_jobs).

    report_jobs_test.py STUDY_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import filecmp
import json
import os
import shutil
import subprocess
import sys

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "report",
                      "make_report.py")


def make(study_dir, out_dir, name, jobs):
    """A copy of the study's results (no report) in out_dir/name, reported with `jobs`."""
    copy = os.path.join(out_dir, name, os.path.basename(study_dir))
    shutil.rmtree(os.path.dirname(copy), ignore_errors=True)
    shutil.copytree(study_dir, copy, ignore=shutil.ignore_patterns("report"))
    env = dict(os.environ, SHADEFIT_REPORT_JOBS=jobs)
    proc = subprocess.run(["/usr/bin/python3", SCRIPT, copy], env=env, capture_output=True,
                          text=True)
    return copy, proc


def default_jobs_failures():
    """report_jobs() under Slurm's variables: the allocation inside a job, the affinity mask's
    CPUs (at most 8) otherwise or when the allocation is not a count; the variable wins."""
    sys.path.insert(0, os.path.dirname(SCRIPT))
    import make_report  # noqa: E402 (the report's own folder)
    mask = min(8, len(os.sched_getaffinity(0)))
    cases = [({"SLURM_JOB_ID": "7", "SLURM_CPUS_PER_TASK": "1"}, 1),
             ({"SLURM_CPUS_PER_TASK": "1"}, mask),  # not in a job: not ours
             ({"SLURM_JOB_ID": "7", "SLURM_CPUS_PER_TASK": "64"}, mask),
             ({"SLURM_JOB_ID": "7", "SLURM_CPUS_PER_TASK": "two"}, mask),
             ({"SLURM_JOB_ID": "7", "SLURM_CPUS_PER_TASK": "0"}, mask),
             ({"SLURM_JOB_ID": "7", "SLURM_CPUS_PER_TASK": "1", "SHADEFIT_REPORT_JOBS": "3"}, 3)]
    names = ("SLURM_JOB_ID", "SLURM_CPUS_PER_TASK", "SHADEFIT_REPORT_JOBS")
    saved = {n: os.environ.get(n) for n in names}
    failures = []
    try:
        for env, want in cases:
            for n in names:
                os.environ.pop(n, None)
            os.environ.update(env)
            got = make_report.report_jobs()
            if got != want:
                failures.append(f"report_jobs() under {env}: {got}, want {want}")
    finally:
        for n, v in saved.items():
            if v is None:
                os.environ.pop(n, None)
            else:
                os.environ[n] = v
    return failures


def main(argv):
    study_dir, out_dir = argv[1], argv[2]
    failures = default_jobs_failures()
    one, p1 = make(study_dir, out_dir, "jobs1", "1")
    two, p2 = make(study_dir, out_dir, "jobs2", "2")
    for p, jobs in ((p1, 1), (p2, 2)):
        if p.returncode != 0:
            failures.append(f"SHADEFIT_REPORT_JOBS={jobs}: exit {p.returncode}: {p.stderr.strip()}")
    if not failures:
        f1 = json.load(open(os.path.join(one, "report", "figures.json")))
        f2 = json.load(open(os.path.join(two, "report", "figures.json")))
        if f1 != f2:
            failures.append("figures.json differs between 1 and 2 figure processes")
        for f in f1:
            a = os.path.join(one, "report", f["png"])
            b = os.path.join(two, "report", f["png"])
            if not filecmp.cmp(a, b, shallow=False):
                failures.append(f"{f['png']} differs between 1 and 2 figure processes")
        print(f"{len(f1)} figures compared")
    bad, pb = make(study_dir, out_dir, "jobs0", "0")
    lines = pb.stderr.strip().splitlines()
    if pb.returncode != 1 or len(lines) != 1 or "SHADEFIT_REPORT_JOBS" not in lines[0]:
        failures.append(f"SHADEFIT_REPORT_JOBS=0: exit {pb.returncode}, stderr {pb.stderr!r}")
    if os.path.exists(os.path.join(bad, "report", "index.html")):
        failures.append("SHADEFIT_REPORT_JOBS=0 left a report")
    for f in failures:
        print("FAIL:", f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
