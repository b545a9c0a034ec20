"""results.csv: its columns, declared once for Python, and the one reader of its text.

The C++ writer owns the columns (WriteResultsCsv, studies/runner/src/outputs.cpp; the metric and
region names in studies/runner/src/metric_columns.h). Python declares them here, once, and
tests/report/columns_test.py fails when the two differ: the lists against metric_columns.h, the
whole header against outputs.cpp and a real results.csv.

Both the report (report_inputs.read_results) and the Python module (shadefit.load_results, via
python/shadefit/_results.py) read results.csv through `read_rows`. This module imports nothing of
shadefit's and writes nothing.
"""

import csv

# kMetricColumns (metric_columns.h): every image metric a fit job records per lighting.
METRIC_COLUMNS = ["rmse", "relative_rmse", "log_rmse", "mae", "psnr", "ssim", "ms_ssim",
                  "ciede2000_mean", "flip_ldr_mean", "flip_hdr_mean", "delta_e_itp_mean"]
# The same metrics over every covered pixel (measured references: extrapolated data included).
ALL_PIXEL_COLUMNS = [c + "_all" for c in METRIC_COLUMNS]
# kRegionNames and kRegionColumns (metric_columns.h): region_<name>_<quantity>.
REGIONS = ("highlight", "rim", "body")
REGION_QUANTITIES = ("signed", "abs", "ref", "pixels")
REGION_COLUMNS = [f"region_{r}_{q}" for r in REGIONS for q in REGION_QUANTITIES]

# The text columns that open every row (AppendResultRows' row_start).
KEY_COLUMNS = ["material", "lighting", "reference", "label", "model", "train", "loss", "split",
               "converged", "status"]
# Every number column: the metrics, measured_fraction, the all-pixel metrics, the regions.
NUMBER_COLUMNS = METRIC_COLUMNS + ["measured_fraction"] + ALL_PIXEL_COLUMNS + REGION_COLUMNS
# Columns added at the end of a row after the files some studies hold were written: absent in
# those files. `object`: the object a reference shows (a mesh, a data set's object); empty for
# the analytic sphere and plane.
LATER_COLUMNS = ["object"]
# The header as the C++ writer writes it now, in order.
HEADER = KEY_COLUMNS + NUMBER_COLUMNS + LATER_COLUMNS


def read_rows(path, error):
    """(header, rows): results.csv (or any RFC 4180 table the runner writes) as a list of field
    names and rows as {column: text}. Raises `error` (an exception class) with one line naming
    the file (and line) where it cannot be read, has no header or a row has the wrong number of
    cells. Checks no cell's type: the caller declares what it reads."""
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            header = reader.fieldnames
            if header is None:
                raise error(f"{path}: header: missing (empty file)")
            rows = []
            for line, row in enumerate(reader, start=2):
                if None in row or any(v is None for v in row.values()):
                    raise error(f"{path}:{line}: row: {len(header)} cells expected")
                rows.append(row)
    except (OSError, csv.Error, UnicodeDecodeError) as e:
        raise error(f"{path}: cannot read ({e})") from None
    return list(header), rows
