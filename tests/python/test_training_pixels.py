"""One training-pixel rule (fit/training_pixels.h): a measured reference fitted by a study, by
`shadefit fit` and by shadefit.fit() trains on the same pixels (measured only, every 4th) and
ends on the same parameters. The 85 degree plane is measured on about 7% of its pixels, so a
front end that trained on the extrapolated rest would differ by far."""

import json
import subprocess

import pytest

import shadefit
from conftest import ROOT, _cli_path

BRDF = ROOT.parent / "shared" / "brdf-data" / "merl-nbrdf" / "red-plastic.h5"
SCENE = ROOT / "reference_images" / "cycles" / "scenes" / "plane-mirror85.toml"

STUDY = """
[study]
name = "pixels"
[[group]]
material = "red-plastic"
images = ["{ref}"]
[fit]
models = ["ggx"]
train = [["mirror85"]]
loss = "l2"
starts = 1
max_iterations = 30
pixel_stride = 4
exposure = "fixed"
[outputs]
previews = false
report = false
"""


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    if not BRDF.exists():
        pytest.skip(f"measured data absent: {BRDF} (../shared/brdf-data beside the clone)")
    path = tmp_path_factory.mktemp("ref") / "red-plastic-mirror85.exr"
    done = subprocess.run([_cli_path(), "refs", "measured", "--brdf", str(BRDF), "--scene",
                           str(SCENE), "-o", str(path)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return path


def test_study_cli_and_python_train_on_the_same_pixels(cli, reference, out):
    study = out / "pixels.toml"
    study.write_text(STUDY.format(ref=reference))
    done = cli("study", "run", study, "-o", out / "study", "-j", "1", "-q")
    assert done.returncode == 0, done.stderr
    job = json.loads((out / "study" / "pixels" / "jobs" / "fit.red-plastic.ggx.mirror85.json")
                     .read_text())
    study_pixels = job["fit"]["inputs"]["references"][0]["pixels"]
    study_values = job["values"]

    done = cli("fit", "--ref", reference, "--model", "ggx", "--loss", "l2", "--starts", "1",
               "--max-iterations", "30", "--pixel-stride", "4", "--no-images",
               "-o", out / "cli.json")
    assert done.returncode == 0, done.stderr
    cli_fit = json.loads((out / "cli.json").read_text())

    py = shadefit.fit(str(reference), "ggx", loss="l2", starts=1, max_iterations=30,
                      pixel_stride=4)
    py_pixels = py.references[0]["pixels"]

    # The measured pixels at stride 4: far fewer than the stride alone keeps (256^2 / 16 = 4096).
    assert 0 < study_pixels < 1000
    assert cli_fit["inputs"]["references"][0]["pixels"] == study_pixels
    assert py_pixels == study_pixels
    assert list(py.values) == pytest.approx(study_values, rel=1e-6, abs=1e-9)
    for row, value in py.params.items():
        assert cli_fit["values"][row] == pytest.approx(value, rel=1e-6, abs=1e-9), row
