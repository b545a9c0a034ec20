"""models() and render(): the CLI's tables and images, scenes in three forms, the numpy view, bad
input, and one GL context however many renders."""

import threading
import tomllib

import numpy as np
import pytest

import shadefit
from conftest import CYCLES, SCENE, cli_error, open_fds

GGX = {"roughness": 0.3, "f0": (0.04, 0.04, 0.04), "kd": (0.8, 0.3, 0.1)}


def test_models_match_the_cli_table(cli):
    done = cli("models")
    assert done.returncode == 0
    names = [line for line in done.stdout.splitlines() if line and not line.startswith(" ")]
    tables = shadefit.models()
    assert [m["name"] for m in tables] == names
    ggx = next(m for m in tables if m["name"] == "ggx")
    rows = {p["name"]: p for p in ggx["parameters"]}
    assert rows["roughness"]["size"] == 1 and rows["kd"]["size"] == 3
    assert 0 <= rows["roughness"]["min"] < rows["roughness"]["max"] <= 1
    assert len(ggx["entries"]) == sum(p["size"] for p in ggx["parameters"])
    # Every row's min, max and default as `shadefit models` prints them (%g).
    for row in ggx["parameters"]:
        line = next(l for l in done.stdout.splitlines() if l.split()[:1] == [row["name"]])
        fields = line.split()
        assert fields[1] == str(row["size"])
        assert [float(f) for f in fields[2:5]] == pytest.approx(
            [row["min"], row["max"], row["default"]], rel=1e-5)


def test_render_equals_the_cli_render(cli, out):
    exr = out / "ggx.exr"
    done = cli("render", "--scene", SCENE, "--model", "ggx", "--set", "roughness=0.3",
               "--set", "f0=0.04,0.04,0.04", "--set", "kd=0.8,0.3,0.1", "-o", exr, "--no-preview")
    assert done.returncode == 0, done.stderr
    from_cli = shadefit.read_image(exr)
    image = shadefit.render(SCENE, "ggx", GGX)
    assert image.dtype == np.float32 and image.shape == from_cli.shape
    assert image.shape[2] == 4
    # The same program on the same device: equal to float precision, channel by channel.
    np.testing.assert_allclose(image, from_cli, rtol=0, atol=1e-6)
    # And against the file as the C++ side reads it (read_image shares the array conversion
    # with render; the metrics read the path themselves): a swapped or shifted view fails here.
    assert shadefit.metrics(str(exr), image)["linear"]["rmse"] < 1e-6
    assert image[..., 0].max() > 0 and not np.array_equal(image[..., 0], image[..., 2])


def test_render_channels_are_rgba_rows_top_down():
    # A red Lambert sphere lit from above right (the key light at x = 4, z = 3; camera up +z,
    # right +x): red dominates, blue is 0, alpha is coverage, and the top-right quadrant is the
    # bright one (row 0 on top, column 0 on the left).
    image = shadefit.render(SCENE, "lambert", {"kd": (0.8, 0.1, 0.0)})
    scene = tomllib.loads(SCENE.read_text())
    width, height = scene["camera"]["resolution"]
    assert image.shape == (height, width, 4)
    covered = image[..., 3] > 0.999
    assert covered.any() and image[..., 3].min() == 0 and image[..., 3].max() == 1
    assert (image[covered, 0] >= image[covered, 1]).all() and (image[..., 2] == 0).all()
    red = image[..., 0]
    assert red[: height // 2].sum() > 2 * red[height // 2:].sum()
    assert red[:, width // 2:].sum() > 2 * red[:, : width // 2].sum()


def test_render_is_a_view_without_copy():
    image = shadefit.render(SCENE, "ggx", GGX)
    assert not image.flags.owndata and image.base is not None
    assert image.flags.c_contiguous and image.flags.writeable


def test_scene_as_path_text_and_dict_agree():
    text = SCENE.read_text()
    by_path = shadefit.render(str(SCENE), "ggx", GGX)
    by_text = shadefit.render(text, "ggx", GGX)
    by_dict = shadefit.render(tomllib.loads(text), "ggx", GGX)
    np.testing.assert_array_equal(by_path, by_text)
    np.testing.assert_array_equal(by_path, by_dict)


def test_params_as_flat_values_and_fit_result():
    ggx = next(m for m in shadefit.models() if m["name"] == "ggx")
    flat = []
    for row in ggx["parameters"]:
        v = GGX.get(row["name"], row["default"])
        flat += list(v) if isinstance(v, tuple) else [v] * row["size"]
    np.testing.assert_array_equal(shadefit.render(SCENE, "ggx", flat),
                                  shadefit.render(SCENE, "ggx", GGX))


@pytest.mark.parametrize("args, extra", [
    (("ggxx", None), ["--model", "ggxx"]),
    (("ggx", {"roughness": 7.0}), ["--model", "ggx", "--set", "roughness=7"]),
    (("ggx", {"roughnes": 0.3}), ["--model", "ggx", "--set", "roughnes=0.3"]),
])
def test_bad_model_or_parameter_raises_the_cli_message(cli, out, args, extra):
    done = cli("render", "--scene", SCENE, *extra, "-o", out / "x.exr")
    with pytest.raises(shadefit.Error) as e:
        shadefit.render(SCENE, *args)
    message = cli_error(done).replace("--set", "params")
    assert str(e.value) == message


def test_malformed_scene_raises_the_cli_message(cli, out):
    bad = SCENE.parent / "malformed.toml"
    done = cli("render", "--scene", bad, "--model", "ggx", "-o", out / "x.exr")
    with pytest.raises(shadefit.Error) as e:
        shadefit.render(bad, "ggx")
    assert str(e.value) == cli_error(done)
    missing = SCENE.parent / "no-such-scene.toml"
    done = cli("render", "--scene", missing, "--model", "ggx", "-o", out / "x.exr")
    with pytest.raises(shadefit.Error) as e:
        shadefit.render(str(missing), "ggx")
    assert str(e.value) == cli_error(done)
    assert isinstance(e.value, ValueError)


def test_bad_params_types_are_refused():
    with pytest.raises(TypeError, match="params: roughness: expected a number"):
        shadefit.render(SCENE, "ggx", {"roughness": "rough"})
    with pytest.raises(shadefit.Error, match="params: 3 values given; model ggx has"):
        shadefit.render(SCENE, "ggx", [0.1, 0.2, 0.3])
    with pytest.raises(TypeError, match="scene: expected a path, TOML text or a dict"):
        shadefit.render(42, "ggx")


def test_many_renders_reuse_one_gl_context():
    shadefit.render(SCENE, "lambert")
    contexts = shadefit._shadefit.gl_contexts_created()
    fds = open_fds()
    for i in range(50):
        shadefit.render(SCENE, "ggx", {"roughness": 0.1 + 0.01 * i})
    assert shadefit._shadefit.gl_contexts_created() == contexts == 1
    assert open_fds() <= fds  # no descriptor per render (a context holds DRM/pipe files)


def test_renders_from_threads_share_the_context_and_agree():
    expected = shadefit.render(SCENE, "ggx", GGX)
    results = [None] * 4
    errors = []

    def work(k):
        try:
            results[k] = shadefit.render(SCENE, "ggx", GGX)
        except Exception as e:  # noqa: BLE001 - reported below
            errors.append(e)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert not errors
    for r in results:
        np.testing.assert_array_equal(r, expected)
    assert shadefit._shadefit.gl_contexts_created() == 1


def test_gl_info_names_the_renderer(cli):
    info = shadefit.gl_info()
    done = cli("info")
    assert info["gl_renderer"] in done.stdout
