"""metrics(): the CLI's JSON for the same inputs, paths or arrays, masks, maps, refused arrays."""

import math

import numpy as np
import pytest

import shadefit
from conftest import CYCLES, cli_error

REF = CYCLES / "red-plastic-key.exr"
TEST = CYCLES / "red-plastic-camera.exr"


def _without_names(d):
    return {k: v for k, v in d.items() if k not in ("reference", "test", "mask")}


def _same(a, b):
    """Equal dicts; floats equal to the last printed digit of the CLI's JSON (17 significant)."""
    assert a.keys() == b.keys()
    for k in a:
        if isinstance(a[k], dict):
            _same(a[k], b[k])
        elif isinstance(a[k], float):
            assert a[k] == pytest.approx(b[k], rel=1e-15, abs=0), k
        else:
            assert a[k] == b[k], k


def test_metrics_of_files_equal_the_cli_json(cli_json):
    from_cli = cli_json("metrics", REF, TEST, "--json")
    _same(shadefit.metrics(str(REF), str(TEST)), from_cli)


def test_metrics_of_arrays_equal_the_cli_json(cli_json):
    from_cli = cli_json("metrics", REF, TEST, "--json", "--exposure", "1.5", "--ppd", "40")
    result = shadefit.metrics(shadefit.read_image(REF), shadefit.read_image(TEST),
                              exposure=1.5, ppd=40)
    _same(result, _without_names(from_cli))
    assert result["schema"] == "shadefit.metrics/1"


def test_masked_metrics_equal_the_cli_json(cli_json, out):
    ref = shadefit.read_image(REF)
    mask = np.zeros(ref.shape[:2], np.float32)
    mask[40:200, 60:180] = 1
    # The same mask as a file for the CLI.
    path = out / "mask.exr"
    _write_exr(path, mask[..., None])
    from_cli = cli_json("metrics", REF, TEST, "--mask", path, "--json")
    by_array = shadefit.metrics(ref, shadefit.read_image(TEST), mask)
    by_bool = shadefit.metrics(ref, shadefit.read_image(TEST), mask > 0.5)
    _same(by_array, _without_names(from_cli))
    _same(by_bool, by_array)
    assert by_array["valid_pixels"] == int(mask.sum())


def _write_exr(path, rgb):
    shadefit.write_exr(path, rgb)


def test_maps_are_arrays_that_agree_with_the_numbers():
    r = shadefit.metrics(str(REF), str(TEST), maps=True)
    maps = r["maps"]
    assert set(maps) == {"absolute_error", "relative_error", "ssim", "ciede2000", "delta_e_itp",
                         "flip_ldr", "flip_hdr"}
    for m in maps.values():
        assert m.dtype == np.float32 and m.shape == (256, 256)
    assert float(np.nanmean(maps["absolute_error"], dtype=np.float64)) == pytest.approx(
        r["linear"]["mae"], rel=1e-5)
    assert float(np.mean(maps["flip_ldr"], dtype=np.float64)) == pytest.approx(
        r["flip_ldr"]["mean"], rel=1e-5)


def test_identical_images_have_zero_error_and_infinite_psnr():
    a = shadefit.read_image(REF)
    r = shadefit.metrics(a, a.copy())
    assert r["linear"]["rmse"] == 0 and r["display"]["psnr_db"] is None
    assert r["display"]["ssim_luminance"] == 1


@pytest.mark.parametrize("array, kind, message", [
    (np.zeros((256, 256, 4), np.float64), TypeError, "reference: expected dtype float32"),
    (np.zeros((256, 256, 4), np.uint8), TypeError, "reference: expected dtype float32"),
    (np.zeros((256, 256, 2), np.float32), ValueError,
     r"reference: expected shape \(H, W, 3\) or \(H, W, 4\), got \(256, 256, 2\)"),
    (np.zeros((256, 256), np.float32), ValueError, r"got \(256, 256\)"),
    (np.zeros(12, np.float32), ValueError, r"got \(12,\)"),
    ([[1.0, 2.0, 3.0]], TypeError, "reference: expected a numpy array, got list"),
])
def test_wrong_arrays_are_refused(array, kind, message):
    with pytest.raises(kind, match=message):
        shadefit.metrics(array, shadefit.read_image(TEST))


def test_wrong_masks_are_refused():
    a = shadefit.read_image(REF)
    with pytest.raises(TypeError, match="mask: expected dtype float32 or bool, got int64"):
        shadefit.metrics(a, a, np.ones((256, 256), np.int64))
    with pytest.raises(ValueError, match=r"mask: expected shape \(H, W, 1\) or \(H, W\)"):
        shadefit.metrics(a, a, np.ones((256, 256, 3), np.float32))


def test_size_mismatch_raises_the_cli_message(cli, out):
    a = str(REF)
    other = out / "small.exr"
    _write_exr(other, np.zeros((16, 16, 3), np.float32))
    done = cli("metrics", a, other)
    with pytest.raises(shadefit.Error) as e:
        shadefit.metrics(a, str(other))
    assert str(e.value) == cli_error(done)
    done = cli("metrics", a, "no-such.exr")
    with pytest.raises(shadefit.Error) as e:
        shadefit.metrics(a, "no-such.exr")
    assert str(e.value) == cli_error(done)


def test_bad_options_are_refused():
    a = shadefit.read_image(REF)
    with pytest.raises(shadefit.Error, match=r"^exposure: nan stops is not in \[-64, 64\]$"):
        shadefit.metrics(a, a, exposure=math.nan)
    with pytest.raises(shadefit.Error, match=r"^ppd: "):
        shadefit.metrics(a, a, ppd=0)
