#!/usr/bin/python3
"""The report's progress line (report/progress.py; issue 46 item 6), as the jobs' (progress_log.cpp):

- on a pipe, a line at each quarter and none at the end: 8 steps, one every 30 s of a fake
  clock, give exactly "report: 2/8 steps (25%), 2.0 steps/min, 3:00 left" (2 steps in 60 s;
  3/4 left of 60 s per quarter = 180 s), then 4/8 and 6/8, nothing at 8/8;
- on a terminal, one live line redrawn in place ("\\r\\033[K[####...] 1/8 ...") and cleared at the end;
- quiet: nothing;
- make_report.py end to end on a pipe: the quarter lines on stderr, stdout only index.html's
  path; with -q, stderr empty.

    progress_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import io
import os
import subprocess
import sys

FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)


class Clock:
    def __init__(self):
        self.t = 0.0

    def __call__(self):
        return self.t


def run_steps(progress_cls, **kw):
    clock, out = Clock(), io.StringIO()
    p = progress_cls(8, stream=out, clock=clock, **kw)
    for i in range(8):
        clock.t += 30.0
        p.step(f"material-{i}")
    p.end()
    return out.getvalue()


def main(argv):
    report_src, out = argv[1], os.path.abspath(argv[2])
    sys.path.insert(0, report_src)
    from progress import Progress  # noqa: E402

    pipe = run_steps(Progress, bar=False)
    want = ("report: 2/8 steps (25%), 2.0 steps/min, 3:00 left\n"
            "report: 4/8 steps (50%), 2.0 steps/min, 2:00 left\n"
            "report: 6/8 steps (75%), 2.0 steps/min, 1:00 left\n")
    check(pipe == want, f"pipe: {pipe!r}, want {want!r}")

    term = run_steps(Progress, bar=True)
    frames = term.split("\r\033[K")
    check(len(frames) == 10 and frames[0] == "" and frames[-1] == "",
          f"terminal: {len(frames) - 2} redraws and a clear expected, got {term[:200]!r}")
    check("\n" not in term, "terminal: the live line wrote a newline")
    check(frames[1].startswith("[" + "#" * 4 + "-" * 24 + "] 1/8  2.0 steps/min  ")
          and frames[1].endswith("material-0"), f"terminal: first frame {frames[1]!r}")
    check(frames[8].startswith("[" + "#" * 28 + "] 8/8"), f"terminal: last frame {frames[8]!r}")

    check(run_steps(Progress, bar=False, quiet=True) == "", "quiet: wrote something")

    # End to end on a pipe, on the synthetic four-fit study.
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import many_fits_test as mf  # noqa: E402
    d = os.path.join(out, mf.FOUR.name)
    mf.write_study(d, mf.FOUR)
    script = os.path.join(report_src, "make_report.py")
    env = dict(os.environ)
    env.pop("SHADEFIT_REPORT_QUIET", None)
    r = subprocess.run([sys.executable, script, d], capture_output=True, text=True, env=env)
    lines = r.stderr.splitlines()
    check(r.returncode == 0 and r.stdout.strip() == os.path.join(d, "report", "index.html"),
          f"make_report: exit {r.returncode}, stdout {r.stdout!r}")
    check(len(lines) == 3 and all(l.startswith("report: ") and " steps (" in l for l in lines),
          f"make_report on a pipe: stderr {r.stderr!r}, want 3 quarter lines")
    r = subprocess.run([sys.executable, script, "-q", d], capture_output=True, text=True, env=env)
    check(r.returncode == 0 and r.stderr == "", f"make_report -q: exit {r.returncode}, stderr "
          f"{r.stderr!r}")

    for f in FAILURES:
        print("FAILED: " + f)
    if not FAILURES:
        print("PASS: a line per quarter on a pipe, one live line on a terminal, none when quiet")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
