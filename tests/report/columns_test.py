#!/usr/bin/python3
"""Python's results.csv columns (report/results_csv.py) against the C++ side that owns them: the
metric and region lists against studies/runner/src/metric_columns.h (kMetrics,
kRegionNames, kRegionColumns), the whole header against the one WriteResultsCsv
(studies/runner/src/outputs.cpp) writes and, where given, against a real results.csv's first
line. A column added or removed on one side and not the other fails here. The metric names the
report words (report/judging.py) cover exactly the metric list.

    columns_test.py SOURCE_DIR [RESULTS_CSV]      exit 0 pass, 1 fail

A column of results_csv.LATER_COLUMNS may be missing from the end of the C++ header (files
written before it; a writer not yet updated); any other difference fails.
"""

import os
import re
import sys


def cpp_list(text, name, path):
    """The string literals of `inline const std::vector<std::string> name = {...};`."""
    m = re.search(r"\b" + name + r"\s*=\s*\{([^}]*)\}", text)
    if not m:
        raise SystemExit(f"FAIL: {path}: {name}: not found")
    return re.findall(r'"([^"]*)"', m.group(1))


def cpp_table_names(text, name, path):
    """The names of `inline const std::vector<...> name = { {"a", ...}, {"b", ...}, };`: the
    first string literal of each entry (entries may hold braces of their own)."""
    m = re.search(r"\b" + name + r"\s*=\s*\{", text)
    if not m:
        raise SystemExit(f"FAIL: {path}: {name}: not found")
    depth, i, entries, start = 1, m.end(), [], None
    while depth > 0 and i < len(text):
        if text[i] == "{":
            depth += 1
            if depth == 2:
                start = i
        elif text[i] == "}":
            depth -= 1
            if depth == 1:
                entries.append(text[start:i + 1])
        i += 1
    names = [re.search(r'"([^"]*)"', e) for e in entries]
    if not all(names):
        raise SystemExit(f"FAIL: {path}: {name}: an entry without a name")
    return [n.group(1) for n in names]


def writer_header(text, metrics, regions, quantities, path):
    """The header WriteResultsCsv writes, statement by statement: literals, the metric loops
    (plain and _all) and the region loop."""
    m = re.search(r"void WriteResultsCsv\(.*?\{(.*?)\n  for \(const Job& job", text, re.S)
    if not m:
        raise SystemExit(f"FAIL: {path}: WriteResultsCsv's header: not found")
    out = []
    body = m.group(1)
    for stmt in re.split(r";", body):
        stmt = " ".join(stmt.split())
        if not stmt or stmt == "}":
            continue
        if "kRegionNames" in stmt:
            out += [f"region_{r}_{q}" for r in regions for q in quantities]
        elif "kRegionColumns" in stmt or stmt.startswith("std::ostringstream"):
            continue
        elif "kMetricColumns" in stmt:
            suffix = re.search(r'<< c << "([^"]*)"', stmt)
            out += [c + (suffix.group(1) if suffix else "") for c in metrics]
        else:
            for lit in re.findall(r'"((?:[^"\\]|\\.)*)"', stmt):
                out += [c for c in lit.replace("\\n", "").split(",") if c]
    return out


def compare(python, cpp, later, where):
    """'' when `cpp` equals `python` or lacks only a tail of `later`; else what differs."""
    for k in range(len(later) + 1):
        want = python[:len(python) - k] if k else python
        if cpp == want and all(c in later for c in python[len(want):]):
            return ""
    extra = [c for c in cpp if c not in python]
    missing = [c for c in python if c not in cpp]
    return (f"{where}: written but not declared in report/results_csv.py: {extra}; declared "
            f"but not written: {missing}" + ("" if extra or missing else "; order differs"))


def main(argv):
    if len(argv) not in (2, 3):
        print(__doc__)
        return 2
    src = argv[1]
    sys.path.insert(0, os.path.join(src, "report"))
    import judging
    import results_csv as rc

    failures = []
    header_path = os.path.join(src, "studies", "runner", "src", "metric_columns.h")
    h = open(header_path, encoding="utf-8").read()
    metrics = cpp_table_names(h, "kMetrics", header_path)
    regions = cpp_list(h, "kRegionNames", header_path)
    quantities = cpp_list(h, "kRegionColumns", header_path)
    for name, cpp, py in (("kMetricColumns", metrics, rc.METRIC_COLUMNS),
                          ("kRegionNames", regions, list(rc.REGIONS)),
                          ("kRegionColumns", quantities, list(rc.REGION_QUANTITIES))):
        if cpp != py:
            failures.append(f"{header_path}: {name} is {cpp}; report/results_csv.py has {py}")
    if set(judging.METRIC_NAMES) != set(rc.METRIC_COLUMNS):
        failures.append(f"report/judging.py: METRIC_NAMES names {sorted(judging.METRIC_NAMES)}; "
                        f"the metric list is {sorted(rc.METRIC_COLUMNS)}")
    if not set(judging.HUMAN_AGREEMENT) <= set(rc.METRIC_COLUMNS):
        failures.append("report/judging.py: HUMAN_AGREEMENT names a metric results.csv lacks")

    writer_path = os.path.join(src, "studies", "runner", "src", "outputs.cpp")
    written = writer_header(open(writer_path, encoding="utf-8").read(), metrics, regions,
                            quantities, writer_path)
    diff = compare(rc.HEADER, written, rc.LATER_COLUMNS, writer_path)
    if diff:
        failures.append(diff)
    if len(argv) == 3:
        with open(argv[2], encoding="utf-8") as f:
            real = f.readline().rstrip("\r\n").split(",")
        diff = compare(rc.HEADER, real, rc.LATER_COLUMNS, argv[2])
        if diff:
            failures.append(diff)
    for f in failures:
        print("FAIL:", f)
    if not failures:
        print(f"ok: {len(rc.HEADER)} columns declared; the C++ writer writes "
              f"{len(written)}" + (" and so does the real results.csv" if len(argv) == 3 else ""))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
