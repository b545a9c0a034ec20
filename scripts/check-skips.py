#!/usr/bin/python3
"""Skip policy (docs/testing.md, "Skips in CI"): lists every skipped test of a CTest JUnit file
with its reason, and under CI=true fails on a skip that no line of tests/ci-allowed-skips.txt
allows (its test name glob matches and its skip output contains that line's reason).

    check-skips.py JUNIT_XML ALLOWED_SKIPS CI      (CI: "true" or anything else)

Called after ctest by scripts/bootstrap.sh test and scripts/sanitizer-check.sh.
"""
import fnmatch, sys, xml.etree.ElementTree as ET
junit, allow_file, ci = sys.argv[1], sys.argv[2], sys.argv[3] == "true"
allowed = []  # (test name glob, reason the skip output must contain)
for n, line in enumerate(open(allow_file, encoding="utf-8"), 1):
    line = line.strip()
    if not line or line.startswith("#"):
        continue
    name, sep, reason = (x.strip() for x in line.partition("|"))
    if not sep or not name or not reason:
        sys.exit(f"{allow_file}:{n}: want '<test name glob> | <reason in the skip output>'")
    allowed.append((name, reason))
bad = []
for case in ET.parse(junit).getroot().iter("testcase"):
    if case.get("status") != "notrun" and case.find("skipped") is None:
        continue
    name, out = case.get("name"), case.findtext("system-out") or ""
    lines = [l.strip() for l in out.splitlines()]
    # gtest prints "<file>:<line>: Skipped" and then the message; scripts print "SKIP: ...".
    why = next((lines[i + 1] for i, l in enumerate(lines[:-1]) if l.endswith(": Skipped")),
               next((l for l in lines if l.startswith("SKIP")), "(no skip message)"))
    ok = any(fnmatch.fnmatchcase(name, g) and r in out for g, r in allowed)
    print(f"skipped: {name}: {why}" + (" [allowed in CI]" if ok else ""))
    if not ok:
        bad.append(name)
if ci and bad:
    print(f"FAILED: CI=true and {len(bad)} test(s) skipped without an allowed reason "
          f"({allow_file}): " + ", ".join(bad))
    sys.exit(1)
