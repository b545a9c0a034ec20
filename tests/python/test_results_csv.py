"""results.csv and timings.csv are RFC 4180: a material named with a comma and a double quote
stays one quoted field, read back whole by Python's csv module and by shadefit.load_results()."""

import csv

import pytest

import shadefit
from conftest import CYCLES

NAME = 'red, "plastic"'

STUDY = """
[study]
name = "quoted"
[[group]]
material = '{name}'
images = ["{cycles}/red-plastic-key.exr", "{cycles}/red-plastic-camera.exr"]
[fit]
models = ["lambert"]
train = [["key"]]
loss = "l2"
starts = 1
max_iterations = 20
pixel_stride = 4
[outputs]
previews = false
report = false
"""


def test_a_material_name_with_comma_and_quote_is_one_field(cli, out):
    study = out / "quoted.toml"
    study.write_text(STUDY.format(name=NAME, cycles=CYCLES))
    done = cli("study", "run", study, "-o", out / "o", "-j", "1", "-q")
    assert done.returncode == 0, done.stderr
    for table in ("results.csv", "timings.csv"):
        with open(out / "o" / "quoted" / table, newline="") as f:
            rows = list(csv.reader(f))
        assert all(len(r) == len(rows[0]) for r in rows), table
        column = rows[0].index("material")
        assert {r[column] for r in rows[1:]} == {NAME}, table
    assert {r["material"] for r in shadefit.load_results(out / "o" / "quoted")} == {NAME}


def test_load_results_reads_through_the_reports_reader(out):
    """One results.csv reader in Python (report/results_csv.py): shadefit.load_results converts
    what it reads, and a row with a missing cell is one error naming the file and the line."""
    study = out / "one_reader"
    study.mkdir()
    (study / "results.csv").write_text("material,converged,rmse,object\n"
                                       "red,1,0.25,\n"
                                       "gold,0,,teapot\n")
    rows = shadefit.load_results(study)
    assert rows == [{"material": "red", "converged": True, "rmse": 0.25, "object": None},
                    {"material": "gold", "converged": False, "rmse": None, "object": "teapot"}]
    assert shadefit._results.results_csv.__file__.endswith("report/results_csv.py")
    (study / "results.csv").write_text("material,converged,rmse\nred,1\n")
    with pytest.raises(shadefit.Error, match=r"results\.csv:2: row: 3 cells expected"):
        shadefit.load_results(study)
