"""run_study() and load_results() against `shadefit study run` on a small study; the probes
against `shadefit probe`."""

import json

import pytest

import shadefit
from conftest import CYCLES, cli_error

STUDY = """
[study]
name = "python_small"
description = "The Python module's test study"

[[group]]
material = "red-plastic"
images = ["{cycles}/red-plastic-key.exr", "{cycles}/red-plastic-camera.exr"]

[fit]
models = ["lambert", "ggx"]
train = [["key"]]
loss = "cuberoot"
starts = 1
max_iterations = 30
pixel_stride = 4

[probes]
run = ["portability"]

[outputs]
previews = false
report = false
"""


@pytest.fixture(scope="module")
def study_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("study") / "python_small.toml"
    path.write_text(STUDY.format(cycles=CYCLES))
    return path


def test_run_study_writes_the_cli_results(cli, study_file, tmp_path):
    study_dir = shadefit.run_study(study_file, tmp_path / "py", jobs=1)
    done = cli("study", "run", study_file, "-o", tmp_path / "cli", "-j", "1", "-q")
    assert done.returncode == 0, done.stderr
    mine = (tmp_path / "py" / "python_small" / "results.csv").read_bytes()
    assert mine == (tmp_path / "cli" / "python_small" / "results.csv").read_bytes()
    rows = shadefit.load_results(study_dir)
    assert len(rows) == 4  # 2 lightings x 2 fits
    assert {r["label"] for r in rows} == {"lambert", "ggx"}
    assert all(isinstance(r["rmse"], float) and isinstance(r["converged"], bool) for r in rows)
    assert shadefit.load_results(tmp_path / "py") == rows  # the out folder of one study
    pandas = pytest.importorskip("pandas")
    frame = pandas.DataFrame(shadefit.load_results(study_dir))
    assert frame.shape[0] == 4 and frame["rmse"].dtype == float
    assert len(shadefit.load_results(study_dir, "timings")) >= 3


def test_bad_study_and_results_raise(cli, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[study]\nname = 'x'\nnmae = 1\n")
    done = cli("study", "run", bad, "-o", tmp_path / "o")
    with pytest.raises(shadefit.Error) as e:
        shadefit.run_study(bad, tmp_path / "o")
    assert str(e.value) == cli_error(done)
    with pytest.raises(shadefit.Error, match="study output folder not found"):
        shadefit.load_results(tmp_path / "nothing")
    with pytest.raises(shadefit.Error, match="unknown table"):
        shadefit.load_results(tmp_path, "fits")


def test_energy_probe_equals_the_cli(cli, tmp_path):
    done = cli("probe", "energy", "--model", "ggx", "--set", "roughness=0.4", "-o", tmp_path)
    assert done.returncode == 0, done.stderr
    expected = json.loads((tmp_path / "energy.json").read_text())
    result = shadefit.probe("energy", models={"model": "ggx", "params": {"roughness": 0.4}})
    assert result["numbers"] == expected["numbers"]
    assert result["schema"] == expected["schema"] == "shadefit.probe/4"


def test_portability_probe_of_a_fit(cli, tmp_path):
    refs = [str(CYCLES / f"red-plastic-{l}.exr") for l in ("key", "side")]
    fitted = shadefit.fit(refs[0], "ggx", starts=1, threads=1, render_outputs=False)
    result = shadefit.probe("portability", refs, [fitted])
    assert set(result["numbers"]) >= {"ggx"}
    with pytest.raises(shadefit.Error) as e:
        shadefit.probe("fresnell", refs)
    assert "did you mean 'fresnel'" in str(e.value)
    done = cli("probe", "fresnel", "-o", tmp_path)
    with pytest.raises(shadefit.Error) as e:
        shadefit.probe("fresnel")
    assert str(e.value) == cli_error(done).replace("--ref", "references")
