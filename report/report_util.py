"""Small helpers every report module shares: the one atomic writer, the study's labels and
materials in its order, results.csv's rows grouped, number formatting, and the flattening of
nested probe numbers, and the heap left out of the collector's passes."""

import contextlib
import gc
import math
import os


def temporary_path(path):
    """Where a file for `path` is written before its rename: hidden, in the same folder, this
    process's (a study killed mid-write leaves only dot-files, which a rerun removes and no
    reader takes for a result)."""
    return os.path.join(os.path.dirname(path), f".{os.path.basename(path)}.{os.getpid()}.tmp")


def write_text(path, text):
    """Writes through a temporary file in the same folder and a rename: never a partial file."""
    tmp = temporary_path(path)
    with open(tmp, "w", encoding="utf-8", newline="") as f:
        f.write(text)
    os.replace(tmp, path)


@contextlib.contextmanager
def frozen_heap():
    """The objects alive on entry are left out of the garbage collector's passes until the block
    ends (gc.freeze): the passes that many short-lived objects set off no longer walk a large heap
    that holds no garbage. The garbage there is collected first, so none is kept frozen. Inside
    another such block, the outer one ends the freeze."""
    outer = gc.get_freeze_count() > 0
    if not outer:
        gc.collect()
    gc.freeze()
    try:
        yield
    finally:
        if not outer:
            gc.unfreeze()


@contextlib.contextmanager
def collector_thresholds(*thresholds):
    """gc.set_threshold(*thresholds) until the block ends. A figure's drawing makes and drops
    hundreds of thousands of small objects: with the first generation collected after 700 more
    allocations than frees (Python's default), each of its many passes also walks whatever
    survived since the last. (50000, 20, 10), a measured study's figures, 10 materials in one
    process: 0.92 -> 0.52 s in the collector, the same peak memory (533 MB)."""
    old = gc.get_threshold()
    gc.set_threshold(*thresholds)
    try:
        yield
    finally:
        gc.set_threshold(*old)


def labels_of(study):
    return [f["label"] for f in study["fits"]]


def materials_of(study):
    return [g["material"] for g in study["groups"]]


def rows_by(rows, *fields):
    """{(row[f] for f in fields): [its rows, in their order]}: one pass over results.csv's rows
    where a loop per material and fit would scan them all each time (100 materials x 14 fits
    x 9,800 rows: seconds)."""
    groups = {}
    for r in rows:
        groups.setdefault(tuple(r[f] for f in fields), []).append(r)
    return groups


def to_float(x):
    """A number cell of results.csv or a JSON number (both checked by report_inputs) as a float;
    None where it is empty, null or not finite."""
    if x is None or x == "":
        return None
    v = float(x)
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


def fmt(v, spec="{:.4g}"):
    return "" if v is None else spec.format(v)


def md_escape(s):
    return str(s).replace("|", "\\|")


def probe_numbers(probes, material, probe):
    """The numbers `probe` measured on `material` (its probe job's record); None without."""
    job = probes.get(material)
    if job is None or probe not in job["probes"]:
        return None
    return job["probes"][probe]["numbers"]
