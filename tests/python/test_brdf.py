"""load_brdf().eval and fit_brdf(): a constant MERL table (known answers), the CLI's BRDF-space
fit, the measured Neural-BRDF files when ../shared has them, refused directions."""

import json
import math
import pathlib

import numpy as np
import pytest

import shadefit
from conftest import ROOT, cli_error

MERL_SCALE = np.array([1 / 1500, 1.15 / 1500, 1.66 / 1500])  # MERL's per-channel scale
STORED = np.array([300.0, 200.0, 100.0])                     # the constant table, per channel
NBRDF = ROOT.parent / "shared" / "brdf-data" / "merl-nbrdf" / "red-plastic.h5"


@pytest.fixture(scope="module")
def constant_merl(tmp_path_factory):
    """A MERL .binary whose every cell stores STORED: f = STORED * MERL_SCALE, a Lambertian."""
    path = tmp_path_factory.mktemp("merl") / "constant.binary"
    dims = np.array([90, 90, 180], np.int32)
    table = np.repeat(STORED, 90 * 90 * 180).astype("<f8")
    with open(path, "wb") as f:
        f.write(dims.astype("<i4").tobytes())
        f.write(table.tobytes())
    return path


def _directions(n, seed=1):
    rng = np.random.default_rng(seed)
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2]) + 0.05
    return v / np.linalg.norm(v, axis=1, keepdims=True)


def test_constant_table_evaluates_to_its_value(constant_merl):
    brdf = shadefit.load_brdf(constant_merl)
    assert brdf.format == "merl-binary" and brdf.files == [str(constant_merl)]
    wi, wo = _directions(100, 1), _directions(100, 2)
    f = brdf.eval(wi, wo)
    assert f.shape == (100, 3) and f.dtype == np.float64
    np.testing.assert_allclose(f, np.broadcast_to(STORED * MERL_SCALE, f.shape), rtol=1e-12)
    below = wo * np.array([1, 1, -1])
    assert (brdf.eval(wi, below) == 0).all()


def test_eval_broadcasts_and_refuses_bad_directions(constant_merl):
    brdf = shadefit.load_brdf(constant_merl)
    grid = _directions(12).reshape(3, 4, 3)
    normal = np.array([0.0, 0.0, 1.0])
    assert brdf.eval(grid, normal).shape == (3, 4, 3)
    assert brdf.eval(normal, normal).shape == (3,)
    with pytest.raises(ValueError, match=r"wi: expected shape \(\.\.\., 3\), got \(4, 2\)"):
        brdf.eval(np.zeros((4, 2)), normal)
    with pytest.raises(TypeError, match="wo: expected real numbers"):
        brdf.eval(normal, np.array(["a", "b", "c"]))
    with pytest.raises(ValueError, match="do not broadcast"):
        brdf.eval(np.zeros((4, 3)), np.zeros((5, 3)))


def test_fit_brdf_recovers_the_lambertian_and_equals_the_cli(cli, constant_merl, tmp_path):
    result = shadefit.fit_brdf(constant_merl, "lambert", threads=1)
    kd = [result.parameters[f"kd.{c}"] for c in "rgb"]
    np.testing.assert_allclose(kd, math.pi * STORED * MERL_SCALE, rtol=1e-6)
    assert result.converged and result.references[0]["name"] == "brdf-space"
    out = tmp_path / "fit.json"
    done = cli("fit", "--brdf", constant_merl, "--model", "lambert", "--threads", "1", "-o", out)
    assert done.returncode == 0, done.stderr
    expected = json.loads(out.read_text())
    np.testing.assert_allclose(kd, expected["values"]["kd"], rtol=1e-9)


def test_bad_brdf_files_raise_the_cli_message(cli, tmp_path):
    for path in (tmp_path / "none.binary", tmp_path / "x.txt"):
        done = cli("fit", "--brdf", path, "--model", "ggx", "-o", tmp_path / "x.json")
        with pytest.raises(shadefit.Error) as e:
            shadefit.fit_brdf(path, "ggx")
        assert str(e.value) == cli_error(done)
        with pytest.raises(shadefit.Error):
            shadefit.load_brdf(path)


@pytest.mark.skipif(not NBRDF.exists(), reason="../shared/brdf-data is not present")
def test_neural_brdf_of_red_plastic_is_red():
    brdf = shadefit.load_brdf(NBRDF)
    assert brdf.format == "neural-brdf" and len(brdf.files) == 2  # the .h5 and its .json
    wi, wo = _directions(256, 3), _directions(256, 4)
    f = brdf.eval(wi, wo)
    assert np.isfinite(f).all() and (f >= 0).all()
    assert f[:, 0].mean() > 2 * f[:, 2].mean()
