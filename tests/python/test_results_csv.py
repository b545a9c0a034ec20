"""results.csv and timings.csv are RFC 4180: a material named with a comma and a double quote
stays one quoted field, read back whole by Python's csv module and by shadefit.load_results()."""

import csv

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
