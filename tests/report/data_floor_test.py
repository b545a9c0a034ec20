#!/usr/bin/python3
"""The data floor (issue 33, item 5; report/data_floor.py; docs/measured_and_imported.md, "Data
floor"), end to end on the real executable: photographs of a sphere under eight directional
lights of different RGB intensities, imported with `refs import`, run as a photograph study
(free exposure: the runner writes geometry/), the report's floor read back.

- analytic: the photographs are GGX renders (`shadefit render`): an isotropic BRDF explains
  them, so the floor's test relative RMSE is near zero (< FLOOR_MAX_ANALYTIC), and the GGX fit,
  the right model, is not below the floor by more than noise (MAX_BELOW).
- varying: the same sphere with kd differing between its left and right halves (linear 16-bit
  PNGs written here): no isotropic BRDF explains it, so the floor's test error is clearly above
  zero (> FLOOR_MIN_VARYING).
The report's summary.md and index.html carry the floor's sentence, and tables/floor.csv its rows.

    data_floor_test.py SHADEFIT_EXE OUT_DIR      exit 0 pass, 1 fail
"""

import json
import math
import os
import shutil
import struct
import subprocess
import sys
import zlib

import numpy as np

W = H = 96
CAMERA = ("[camera]\ntype = \"orthographic\"\nposition = [0.0, -10.0, 0.0]\n"
          "look_at = [0.0, 0.0, 0.0]\nup = [0.0, 0.0, 1.0]\nheight = 2.4\n"
          f"resolution = [{W}, {H}]\nsupersample = 4\n")
SPHERE = "\n[[objects]]\ntype = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0\n"
TRAIN = ["L0", "L3", "L4", "L7"]
FLOOR_MAX_ANALYTIC = 0.02   # relative RMSE: the table's grid and smoothing, on exact data
MAX_BELOW = 0.015           # how far (relative RMSE) a fit may sit below the floor: its noise
FLOOR_MIN_VARYING = 0.05    # kd 0.7 vs 0.3 on the two halves: no isotropic table explains both


def lights():
    """(name, unit vector to the light, RGB irradiance): 30 or 50 degrees off the view axis."""
    out = []
    for i in range(8):
        theta = math.radians(30.0 if i % 2 == 0 else 50.0)
        phi = math.radians(45.0 * i)
        to_light = (math.sin(theta) * math.cos(phi), -math.cos(theta),
                    math.sin(theta) * math.sin(phi))
        rgb = (1.0 + 0.1 * i, 1.0, 1.2 - 0.05 * i)
        out.append((f"L{i}", to_light, rgb))
    return out


def scene_text(to_light, rgb):
    d = ", ".join(f"{-c:.17g}" for c in to_light)
    e = ", ".join(f"{c:.17g}" for c in rgb)
    return (CAMERA + SPHERE + "\n[background]\ntransparent = true\n\n[[lights]]\n"
            f"type = \"directional\"\ndirection = [{d}]\nirradiance = [{e}]\n")


def run(cmd, cwd):
    r = subprocess.run(cmd, cwd=cwd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stderr}")
    return r.stdout


def write_png16(path, rgb):
    """A 16-bit RGB PNG of values in [0, 1] (linear: imported with --encoding linear)."""
    h, w, _ = rgb.shape
    q = np.clip(np.round(rgb * 65535.0), 0, 65535).astype(">u2")
    raw = b"".join(b"\x00" + q[y].tobytes() for y in range(h))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 16, 2, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def write_mask_png(path, mask):
    h, w = mask.shape
    q = (mask * 255).astype(np.uint8)
    raw = b"".join(b"\x00" + q[y].tobytes() for y in range(h))

    def chunk(kind, data):
        c = struct.pack(">I", len(data)) + kind + data
        return c + struct.pack(">I", zlib.crc32(kind + data) & 0xffffffff)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0))
                + chunk(b"IDAT", zlib.compress(raw, 6)) + chunk(b"IEND", b""))


def varying_photo(to_light, rgb):
    """The sphere of the scenes, seen by their orthographic camera (pixel centres), Lambert with
    kd (0.7, 0.5, 0.3) on the left half (x < 0) and (0.3, 0.5, 0.7) on the right, plus a
    Blinn-Phong-like lobe 0.3 (n.h)^40 shared by both; and the disc's mask (1.5 px inside the
    rim, so that every pixel used is fully covered)."""
    px = 2.4 / H
    y, x = np.mgrid[0:H, 0:W]
    X = (x + 0.5 - W / 2) * px
    Z = (H / 2 - y - 0.5) * px
    r2 = X * X + Z * Z
    inside = r2 < 1.0
    n = np.stack([X, -np.sqrt(np.clip(1 - r2, 0, 1)), Z], axis=-1)
    l = np.array(to_light)
    v = np.array([0.0, -1.0, 0.0])
    h = (l + v) / np.linalg.norm(l + v)
    nol = np.clip(n @ l, 0, None)
    noh = np.clip(n @ h, 0, None)
    kd = np.where((X < 0)[..., None], np.array([0.7, 0.5, 0.3]), np.array([0.3, 0.5, 0.7]))
    f = kd / math.pi + 0.3 * noh[..., None] ** 40
    img = f * nol[..., None] * np.array(rgb) * 0.5
    img[~inside] = 0
    mask = (np.sqrt(r2) < 1.0 - 1.5 * px).astype(float)
    return img, mask


STUDY = """[study]
name = "floor_set"
description = "Data floor test set"

[[group]]
material = "sphere"
images = ["refs/sphere-*.exr"]

[fit]
models = ["ggx", "blinn-phong-normalized"]
train = [["L0", "L3", "L4", "L7"]]
loss = "l2"
starts = 2
exposure = "free"
max_iterations = 60

[fit.override.ggx]
fixed = ["f0=0.04"]

[outputs]
previews = false
report = true
"""


def make_set(exe, d, kind):
    shutil.rmtree(d, ignore_errors=True)
    for sub in ("scenes", "truth", "refs"):
        os.makedirs(os.path.join(d, sub))
    for name, to_light, rgb in lights():
        scene = f"scenes/sphere-{name}.toml"
        with open(os.path.join(d, scene), "w") as f:
            f.write(scene_text(to_light, rgb))
        if kind == "analytic":
            src = f"truth/sphere-{name}.exr"
            run([exe, "render", "--scene", scene, "--model", "ggx", "--set", "kd=0.6,0.4,0.25",
                 "--set", "f0=0.04", "--set", "roughness=0.35", "-o", src, "--no-preview"], d)
            extra = []
        else:
            img, mask = varying_photo(to_light, rgb)
            src = f"truth/sphere-{name}.png"
            write_png16(os.path.join(d, src), img)
            write_mask_png(os.path.join(d, "mask.png"), mask)
            extra = ["--mask", "mask.png"]
        run([exe, "refs", "import", src, "--scene", scene, "--encoding", "linear"] + extra
            + ["-o", f"refs/sphere-{name}.exr"], d)
    with open(os.path.join(d, "floor.toml"), "w") as f:
        f.write(STUDY)
    run([exe, "study", "run", "floor.toml", "-o", "out", "-j", "1", "-q"], d)
    study_dir = os.path.join(d, "out", "floor_set")
    with open(os.path.join(study_dir, "report", "floor.json")) as f:
        floor = json.load(f)
    return study_dir, floor


def check_report(study_dir, failures, name):
    with open(os.path.join(study_dir, "report", "summary.md")) as f:
        md = f.read()
    with open(os.path.join(study_dir, "report", "index.html")) as f:
        html = f.read()
    for what, text in (("summary.md", md), ("index.html", html)):
        if "Data floor" not in text or "above what any isotropic BRDF" not in text \
                and "below the floor" not in text:
            failures.append(f"{name}: {what} has no data floor sentence")
    if not os.path.exists(os.path.join(study_dir, "report", "tables", "floor.csv")):
        failures.append(f"{name}: no tables/floor.csv")


def main(argv):
    exe, out = os.path.abspath(argv[1]), os.path.abspath(argv[2])
    failures = []

    study_dir, floor = make_set(exe, os.path.join(out, "analytic"), "analytic")
    rec = floor["materials"][0]
    f_test = rec["test_relative_rmse"]
    print(f"analytic: floor train {rec['train_relative_rmse']:.4f} test {f_test:.4f} "
          f"(lambda {rec['lambda']:g})")
    for f in rec["fits"]:
        print(f"  {f['label']}: test {f['test_relative_rmse']:.4f} "
              f"({f['points_above_floor']:+.2f} points)")
        if f["test_relative_rmse"] < f_test - MAX_BELOW:
            failures.append(f"analytic: {f['label']} beats the floor by more than noise "
                            f"({f['test_relative_rmse']:.4f} < {f_test:.4f} - {MAX_BELOW})")
    if not f_test < FLOOR_MAX_ANALYTIC:
        failures.append(f"analytic: the floor's test error {f_test:.4f} is not near zero "
                        f"(want < {FLOOR_MAX_ANALYTIC})")
    if not any(f["label"] == "ggx" for f in rec["fits"]):
        failures.append("analytic: the ggx fit is not next to the floor")
    check_report(study_dir, failures, "analytic")

    study_dir, floor = make_set(exe, os.path.join(out, "varying"), "varying")
    rec = floor["materials"][0]
    print(f"varying: floor train {rec['train_relative_rmse']:.4f} test "
          f"{rec['test_relative_rmse']:.4f} (lambda {rec['lambda']:g})")
    for f in rec["fits"]:
        print(f"  {f['label']}: test {f['test_relative_rmse']:.4f}")
    if not rec["test_relative_rmse"] > FLOOR_MIN_VARYING:
        failures.append(f"varying: the floor's test error {rec['test_relative_rmse']:.4f} is "
                        f"not clearly above zero (want > {FLOOR_MIN_VARYING})")
    check_report(study_dir, failures, "varying")

    for f in failures:
        print("FAILED: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
