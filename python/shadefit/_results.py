"""A study's result tables as records (lists of dicts) that pandas.DataFrame takes directly."""

import csv

from ._shadefit import Error
import os

# Columns of results.csv and timings.csv that hold numbers or booleans (docs/studies.md,
# "Outputs"); every other column stays text. An empty cell is None.
_BOOLEAN = {"converged"}


def _convert(column, text):
    if text == "":
        return None
    if column in _BOOLEAN:
        if text in ("true", "True", "1"):
            return True
        if text in ("false", "False", "0"):
            return False
        return text
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


def read_table(path):
    """Rows of a CSV file as dicts, numbers converted; raises shadefit.Error naming the file."""
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        if reader.fieldnames is None:
            raise Error(f"{path}: header: missing (empty file)")
        rows = []
        for line, row in enumerate(reader, start=2):
            if None in row or any(v is None for v in row.values()):
                raise Error(f"{path}:{line}: row: {len(reader.fieldnames)} columns expected")
            rows.append({k: _convert(k, v) for k, v in row.items()})
        return rows


def study_dir_of(out):
    """The study folder: `out` itself when it holds results.csv, else its only child that does."""
    out = os.fspath(out)
    if os.path.isfile(os.path.join(out, "results.csv")):
        return out
    if not os.path.isdir(out):
        raise Error(f"{out}: study output folder not found")
    found = sorted(d for d in os.listdir(out)
                   if os.path.isfile(os.path.join(out, d, "results.csv")))
    if len(found) == 1:
        return os.path.join(out, found[0])
    if not found:
        raise Error(f"{out}: results.csv: missing (run the study to completion first)")
    raise Error(f"{out}: several studies ({', '.join(found)}); pass one of their folders")
