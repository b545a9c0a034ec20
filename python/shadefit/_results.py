"""A study's result tables as records (lists of dicts) that pandas.DataFrame takes directly.

The text of results.csv and timings.csv is read by the one reader the report uses too
(report/results_csv.py, found through the source tree the module was built from); here its cells
become numbers and booleans."""

import importlib.util
import os

from . import _shadefit
from ._shadefit import Error

# Columns of results.csv and timings.csv that hold numbers or booleans (docs/studies.md,
# "Outputs"); every other column stays text. An empty cell is None.
_BOOLEAN = {"converged"}


def _load_results_csv():
    """report/results_csv.py of the source tree this module was built from (the module is used
    from the build tree, never copied: python/CMakeLists.txt)."""
    path = os.path.join(_shadefit.SOURCE_DIR, "report", "results_csv.py")
    spec = importlib.util.spec_from_file_location("_shadefit_results_csv", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


results_csv = _load_results_csv()


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
    _, rows = results_csv.read_rows(path, Error)
    return [{k: _convert(k, v) for k, v in row.items()} for row in rows]


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
