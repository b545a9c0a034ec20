"""fit(): the CLI's fit for the same inputs (paths or arrays with their scenes), every start,
bad input, refused arrays; and FitResult's render."""

import json

import numpy as np
import pytest

import shadefit
from conftest import CYCLES, cli_error

REF = CYCLES / "red-plastic-key.exr"
SCENE = CYCLES / "scenes" / "sphere-key.toml"
# One Ceres thread: the CLI and the module then sum in one fixed order (docs/studies.md).
OPTIONS = dict(starts=2, threads=1, loss="cuberoot")


@pytest.fixture(scope="module")
def cli_fit(tmp_path_factory):
    def run(cli, model, *extra):
        path = tmp_path_factory.mktemp("fit") / f"{model}.json"
        done = cli("fit", "--ref", REF, "--model", model, "--starts", "2", "--threads", "1",
                   "--loss", "cuberoot", "--no-images", *extra, "-o", path)
        assert done.returncode == 0, done.stderr
        return json.loads(path.read_text())

    return run


@pytest.mark.parametrize("model", ["blinn-phong", "ggx"])
def test_fit_equals_the_cli_fit(cli, cli_fit, model):
    expected = cli_fit(cli, model)
    result = shadefit.fit(str(REF), model, **OPTIONS)
    assert result.model == model and result.converged == expected["converged"]
    for name, value in result.parameters.items():
        assert value == pytest.approx(_value(expected, name), rel=1e-9, abs=1e-12), name
    assert result.final_cost == pytest.approx(expected["cost"]["final"], rel=1e-9)
    assert result.rmse == pytest.approx(expected["rmse"]["overall"], rel=1e-9)
    assert len(result.starts) == 2 == len(expected["starts"]["results"])
    for mine, theirs in zip(result.starts, expected["starts"]["results"]):
        assert mine["final_cost"] == pytest.approx(theirs["final_cost"], rel=1e-9)
    assert result.json["values"].keys() == expected["values"].keys()
    # The attributes FitResult reads from the record, against the CLI's record and the options.
    assert result.loss == "cuberoot" and result.exposure_free is False
    assert result.path == expected["derivative_path"]
    assert (result.iterations, result.termination, result.solver) == (
        expected["solver"]["iterations"], expected["solver"]["termination"],
        expected["solver"]["method"])
    assert result.starts_reached_best == expected["starts"]["reached_best"]
    assert all(s["converged"] in (True, False) for s in result.starts)


def test_free_exposure_is_said():
    result = shadefit.fit(str(REF), "ggx", exposure="free", **OPTIONS)
    assert result.exposure_free is True and result.json["exposure"]["mode"] == "free"


def _value(fit_json, entry):
    row, _, channel = entry.partition(".")
    v = fit_json["values"][row]
    return v["rgb".index(channel)] if channel else v


def test_array_reference_with_its_scene_equals_the_file(cli, cli_fit):
    by_path = shadefit.fit(REF, "ggx", **OPTIONS)
    image = shadefit.read_image(REF)
    for scene in (SCENE, SCENE.read_text()):
        by_array = shadefit.fit((image, scene), "ggx", **OPTIONS)
        np.testing.assert_allclose(by_array.values, by_path.values, rtol=1e-9)


def test_fit_result_renders_back_its_prediction():
    result = shadefit.fit(REF, "ggx", **OPTIONS)
    pred = result.references[0]["prediction"]
    assert pred.dtype == np.float32 and pred.shape == (256, 256, 4)
    np.testing.assert_allclose(shadefit.render(SCENE, "ggx", result), pred, atol=1e-6)
    np.testing.assert_allclose(shadefit.render(SCENE, "ggx", result.params), pred, atol=1e-6)
    assert result.rmse == pytest.approx(result.references[0]["rmse"])
    assert set(result.std_errors) == set(result.parameters)
    assert "rmse" in repr(result)


def test_pixel_stride_and_fixed_parameters():
    strided = shadefit.fit(REF, "ggx", pixel_stride=4, fixed={"kd": (0.5, 0.05, 0.05)},
                           render_outputs=False, **OPTIONS)
    assert strided.parameters["kd.r"] == 0.5 and strided.estimates[0]["fixed"]
    assert strided.references[0]["prediction"] is None
    whole = shadefit.fit(REF, "ggx", fixed=["kd=0.5,0.05,0.05"], render_outputs=False, **OPTIONS)
    assert strided.references[0]["pixels"] * 10 < whole.references[0]["pixels"]


def test_bad_input_raises_the_cli_message(cli, tmp_path):
    done = cli("fit", "--ref", REF, "--model", "ggxx", "-o", tmp_path / "x.json")
    with pytest.raises(shadefit.Error) as e:
        shadefit.fit(REF, "ggxx")
    assert str(e.value) == cli_error(done)
    done = cli("fit", "--ref", "no-such.exr", "--model", "ggx", "-o", tmp_path / "x.json")
    with pytest.raises(shadefit.Error) as e:
        shadefit.fit("no-such.exr", "ggx")
    assert str(e.value) == cli_error(done)
    done = cli("fit", "--ref", REF, "--model", "ggx", "--loss", "l3", "-o", tmp_path / "x.json")
    with pytest.raises(shadefit.Error) as e:
        shadefit.fit(REF, "ggx", loss="l3")
    # The same rule and words; the field is named as the keyword argument, not the flag.
    assert str(e.value) == cli_error(done).replace("--loss:", "loss:", 1)
    with pytest.raises(shadefit.Error, match="^starts: must be >= 1$"):
        shadefit.fit(REF, "ggx", starts=0)
    with pytest.raises(shadefit.Error, match="needs its scene"):
        shadefit.fit({"image": shadefit.read_image(REF)}, "ggx")


def test_wrong_arrays_are_refused():
    image = shadefit.read_image(REF)
    with pytest.raises(TypeError, match=r"references\[0\]: expected dtype float32 \(linear radiance\), got float64"):
        shadefit.fit((image.astype(np.float64), SCENE), "ggx")
    with pytest.raises(ValueError, match=r"references\[0\]: expected shape .* got \(256, 256\)"):
        shadefit.fit((image[..., 0], SCENE), "ggx")
    with pytest.raises(shadefit.Error, match=r"ref0: image: 128 x 256 pixels, but the scene"):
        shadefit.fit((np.ascontiguousarray(image[:, :128]), SCENE), "ggx")
    with pytest.raises(TypeError, match=r"references\[0\]: unknown key"):
        shadefit.fit({"image": image, "scene": SCENE, "sceen": 1}, "ggx")


def test_fit_releases_the_gil_and_reuses_the_context():
    # While a fit runs on another thread, this thread keeps running Python: the longest pause
    # between its steps is a small share of the fit's time (holding the GIL, it is all of it).
    import threading
    import time
    done = threading.Event()
    seconds = []

    def work():
        start = time.monotonic()
        for _ in range(3):
            shadefit.fit(REF, "blinn-phong", render_outputs=False, **OPTIONS)
        seconds.append(time.monotonic() - start)
        done.set()

    thread = threading.Thread(target=work)
    thread.start()
    last, longest = time.monotonic(), 0.0
    while not done.is_set():
        time.sleep(0.001)
        now = time.monotonic()
        longest, last = max(longest, now - last), now
    thread.join()
    assert seconds and longest < 0.25 * seconds[0], (longest, seconds)
    assert shadefit._shadefit.gl_contexts_created() == 1
