#!/usr/bin/python3
"""A numpy + scipy peer of `shadefit fit` (point and directional lights, L2, fixed exposure).

Fits shadefit's `ggx` model (or `blinn-phong`) to one reference image with
scipy.optimize.least_squares(method='trf', bounds=..., x_scale='jac') and an analytic Jacobian,
one start at shadefit's table defaults, on the same valid pixels as shadefit's fitter. It exists
to measure shadefit's fitter against a plain, competently written Python fit
(bench/peer/compare.py, BENCHMARKS.md "Fitter vs a numpy/scipy peer").

The model, matched term by term to render/include/shadefit/render/brdf.h, models_inl.h and the
tables in render/src/models.cpp:
  ggx:  f_c = kd_c / pi + F_c D V, with alpha = roughness^2,
        D = a2 / (pi (|n x h|^2 + (n.h)^2 a2)^2), a2 = alpha^2       (Walter et al. 2007, eq. 33)
        V = 0.5 / (n.l sqrt((n.v)^2 (1 - a2) + a2) + n.v sqrt((n.l)^2 (1 - a2) + a2))
                                                      (height-correlated Smith, Heitz 2014, eq. 99)
        F_c = f0_c + (1 - f0_c) (1 - l.h)^5                                   (Schlick 1994)
        bounds kd, f0 in [0, 1], roughness in [0.01, 1]; defaults 0.5, 0.04, 0.5.
  blinn-phong: L_c = ka_c A_c + sum_lights E_c (kd_c (n.l) + ks_c max(n.h, 0)^shininess)
        bounds ka, kd in [0, 1], ks in [0, 1e5], shininess in [1, 1e5]; defaults 0, 0.5, 0.5, 32.
  Radiance L_c = sum over lights of f_c (n.l) E_c, E = I / d^2 for a point light of intensity
  I = P / (4 pi) (power P, docs/scenes.md), E = irradiance for a directional light; a light
  contributes only where n.l > 0 and n.v > 0.

Inputs. The reference EXR (linear radiance, RGBA) and its sidecar JSON (`scene_file`, relative to
the sidecar) as shadefit reads them. Per-pixel geometry comes from shadefit itself:
`shadefit render --scene S --aov gbuffer.exr` writes P.XYZ (world position), N.XYZ (unit normal
facing the camera), V.XYZ (unit direction to the eye) and coverage. Valid pixels, as in
fit/src/fitter.cpp Prepare: G-buffer coverage >= 1 and reference alpha >= 1 - 1e-5, finite RGB.
Single-object scenes only (no shadow rays, as shadefit casts none with one object).

Debian 12 packages: python3-numpy, python3-scipy, python3-openimageio (EXR reading).

Output: one JSON object on stdout (parameters, cost, RMSE, timings, evaluation counts).
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time
import tomllib

import numpy as np
import OpenImageIO as oiio
from scipy.optimize import least_squares

FULL_COVERAGE = 1.0 - 1e-5  # fit/src/fitter.cpp kFullCoverage
INV_PI = 1.0 / math.pi

# name -> (parameter names per entry, lower, upper, default): render/src/models.cpp tables.
MODELS = {
    "ggx": (
        ["kd.r", "kd.g", "kd.b", "f0.r", "f0.g", "f0.b", "roughness"],
        [0, 0, 0, 0, 0, 0, 0.01],
        [1, 1, 1, 1, 1, 1, 1],
        [0.5, 0.5, 0.5, 0.04, 0.04, 0.04, 0.5],
    ),
    "blinn-phong": (
        ["ka.r", "ka.g", "ka.b", "kd.r", "kd.g", "kd.b", "ks.r", "ks.g", "ks.b", "shininess"],
        [0, 0, 0, 0, 0, 0, 0, 0, 0, 1],
        [1, 1, 1, 1, 1, 1, 1e5, 1e5, 1e5, 1e5],
        [0, 0, 0, 0.5, 0.5, 0.5, 0.5, 0.5, 0.5, 32],
    ),
}


def read_exr(path):
    """Returns (float64 array H x W x C, channel names)."""
    inp = oiio.ImageInput.open(path)
    if inp is None:
        sys.exit(f"{path}: cannot open ({oiio.geterror()})")
    spec = inp.spec()
    pixels = inp.read_image(0, 0, 0, spec.nchannels, "float")
    inp.close()
    if pixels is None:
        sys.exit(f"{path}: cannot read pixels")
    return np.asarray(pixels, dtype=np.float64), list(spec.channelnames)


def channels(image, names, wanted, path):
    idx = []
    for w in wanted:
        if w not in names:
            sys.exit(f"{path}: no channel {w} (has {names})")
        idx.append(names.index(w))
    return image[..., idx]


def load_lights(scene):
    """Point/directional lights as (kind, position or direction, RGB value); ambient summed."""
    lights, ambient = [], np.zeros(3)
    for light in scene.get("lights", []):
        kind = light["type"]

        def rgb(key):
            v = light[key]
            return np.array([v, v, v] if np.isscalar(v) else v, dtype=np.float64)

        if kind == "point":
            value = rgb("power") / (4 * math.pi) if "power" in light else rgb("intensity")
            lights.append(("point", np.array(light["position"], dtype=np.float64), value))
        elif kind == "directional":
            d = np.array(light["direction"], dtype=np.float64)
            lights.append(("directional", d / np.linalg.norm(d), rgb("irradiance")))
        elif kind == "ambient":
            ambient += rgb("radiance")
        else:
            sys.exit(f"scene: light type {kind} is not supported by the peer (point lights only)")
    if len(scene.get("objects", [])) != 1:
        sys.exit("scene: the peer handles single-object scenes only (no shadow rays)")
    return lights, ambient


def normalize(a):
    return a / np.linalg.norm(a, axis=-1, keepdims=True)


class Geometry:
    """Everything about the valid pixels that does not depend on the parameters."""

    def __init__(self, p, n, v, lights, ambient):
        self.ambient = ambient
        self.terms = []  # per light: mask-free arrays over pixels
        for kind, pos_or_dir, value in lights:
            if kind == "point":
                d = pos_or_dir[None, :] - p
                d2 = np.einsum("ij,ij->i", d, d)
                l = d / np.sqrt(d2)[:, None]
                e = value[None, :] / d2[:, None]
            else:
                l = np.broadcast_to(-pos_or_dir, p.shape)
                e = np.broadcast_to(value, p.shape)
            nol = np.einsum("ij,ij->i", n, l)
            nov = np.einsum("ij,ij->i", n, v)
            lit = (nol > 0) & (nov > 0)
            h = normalize(l[lit] + v[lit])
            nl, nv = nol[lit], nov[lit]
            nh = np.einsum("ij,ij->i", n[lit], h)
            lh = np.einsum("ij,ij->i", l[lit], h)
            nxh = np.cross(n[lit], h)
            t = {
                "idx": np.nonzero(lit)[0],
                "NoL": nl,
                "NoV": nv,
                "NoH": nh,
                "omNoH2": np.einsum("ij,ij->i", nxh, nxh),
                "w": (1.0 - lh) ** 5,  # Schlick weight (1 - LoH)^5
                "ENoL": e[lit] * nl[:, None],  # irradiance times n.l, per channel
                "E": np.array(e[lit]),
                "NoV2": nv * nv,
                "NoL2": nl * nl,
            }
            self.terms.append(t)
        self.count = p.shape[0]


def ggx_residual_and_jacobian(x, g, target, want_jac):
    kd, f0, r = x[0:3], x[3:6], x[6]
    alpha = max(r * r, 1e-4)  # brdf.h kMinAlpha clamp (inactive for roughness >= 0.01)
    a2 = alpha * alpha
    pred = np.zeros((g.count, 3))
    jac = np.zeros((g.count, 3, 7)) if want_jac else None
    for t in g.terms:
        idx = t["idx"]
        d = t["omNoH2"] + t["NoH"] ** 2 * a2
        D = a2 / (math.pi * d * d)
        sv = np.sqrt(t["NoV2"] * (1 - a2) + a2)
        sl = np.sqrt(t["NoL2"] * (1 - a2) + a2)
        s = t["NoL"] * sv + t["NoV"] * sl
        V = 0.5 / s
        dv = D * V
        w = t["w"]
        F = f0[None, :] + (1 - f0[None, :]) * w[:, None]
        pred[idx] += t["ENoL"] * (kd[None, :] * INV_PI + F * dv[:, None])
        if want_jac:
            dD = (t["omNoH2"] - a2 * t["NoH"] ** 2) / (math.pi * d**3)  # dD/da2
            ds = t["NoL"] * (1 - t["NoV2"]) / (2 * sv) + t["NoV"] * (1 - t["NoL2"]) / (2 * sl)
            dV = -0.5 * ds / (s * s)  # dV/da2
            da2_dr = 4 * r**3 if r * r > 1e-4 else 0.0
            ddv = (dD * V + D * dV) * da2_dr
            for c in range(3):
                jac[idx, c, c] += t["ENoL"][:, c] * INV_PI
                jac[idx, c, 3 + c] += t["ENoL"][:, c] * (1 - w) * dv
                jac[idx, c, 6] += t["ENoL"][:, c] * F[:, c] * ddv
    res = (pred - target).reshape(-1)
    return res, (jac.reshape(-1, 7) if want_jac else None)


def blinn_phong_residual_and_jacobian(x, g, target, want_jac):
    ka, kd, ks, n = x[0:3], x[3:6], x[6:9], x[9]
    pred = np.broadcast_to(ka * g.ambient, (g.count, 3)).copy()
    jac = np.zeros((g.count, 3, 10)) if want_jac else None
    if want_jac:
        for c in range(3):
            jac[:, c, c] = g.ambient[c]
    for t in g.terms:
        idx = t["idx"]
        nh = np.maximum(t["NoH"], 0.0)
        spec = np.where(nh > 0, nh ** n, 0.0)
        pred[idx] += t["ENoL"] * kd[None, :] + t["E"] * ks[None, :] * spec[:, None]
        if want_jac:
            dspec = np.where(nh > 0, spec * np.log(np.where(nh > 0, nh, 1.0)), 0.0)
            for c in range(3):
                jac[idx, c, 3 + c] += t["ENoL"][:, c]
                jac[idx, c, 6 + c] += t["E"][:, c] * spec
                jac[idx, c, 9] += t["E"][:, c] * ks[c] * dspec
    res = (pred - target).reshape(-1)
    return res, (jac.reshape(-1, 10) if want_jac else None)


RESIDUALS = {"ggx": ggx_residual_and_jacobian, "blinn-phong": blinn_phong_residual_and_jacobian}


def render_gbuffer(shadefit, scene_path, out_dir):
    aov = os.path.join(out_dir, "gbuffer.exr")
    subprocess.run(
        [shadefit, "render", "--scene", scene_path, "--model", "ggx", "--no-preview",
         "-o", os.path.join(out_dir, "beauty.exr"), "--aov", aov],
        check=True, stdout=subprocess.DEVNULL)
    return aov


def main():
    t_process = time.perf_counter()
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--ref", required=True, help="reference EXR with a sidecar JSON")
    ap.add_argument("--model", default="ggx", choices=sorted(MODELS))
    ap.add_argument("--gbuffer", help="G-buffer AOV EXR (default: render it with shadefit)")
    ap.add_argument("--shadefit", default="build/studies/shadefit")
    ap.add_argument("--ftol", type=float, default=1e-9)   # shadefit: function_tolerance 1e-9
    ap.add_argument("--xtol", type=float, default=1e-8)   # parameter_tolerance 1e-8
    ap.add_argument("--gtol", type=float, default=1e-10)  # gradient_tolerance 1e-10
    args = ap.parse_args()

    sidecar_path = os.path.splitext(args.ref)[0] + ".json"
    with open(sidecar_path) as f:
        sidecar = json.load(f)
    scene_path = os.path.join(os.path.dirname(sidecar_path), sidecar["scene_file"])
    with open(scene_path, "rb") as f:
        scene = tomllib.load(f)
    lights, ambient = load_lights(scene)

    t_gbuffer = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="peer-") as tmp:
        gbuffer_path = args.gbuffer or render_gbuffer(args.shadefit, scene_path, tmp)
        gb, gb_names = read_exr(gbuffer_path)
    gbuffer_seconds = time.perf_counter() - t_gbuffer if not args.gbuffer else 0.0
    ref, ref_names = read_exr(args.ref)
    if ref.shape[:2] != gb.shape[:2]:
        sys.exit(f"{args.ref}: size {ref.shape[:2]} differs from the G-buffer {gb.shape[:2]}")

    t_prep = time.perf_counter()
    rgb = channels(ref, ref_names, ["R", "G", "B"], args.ref)
    alpha = channels(ref, ref_names, ["A"], args.ref)[..., 0] if "A" in ref_names else None
    coverage = channels(gb, gb_names, ["coverage"], gbuffer_path)[..., 0]
    valid = coverage >= 1.0  # PrepareShading(..., min_coverage = 1)
    if alpha is not None:
        valid &= alpha >= FULL_COVERAGE
    valid &= np.all(np.isfinite(rgb), axis=-1)
    p = channels(gb, gb_names, ["P.X", "P.Y", "P.Z"], gbuffer_path)[valid]
    n = normalize(channels(gb, gb_names, ["N.X", "N.Y", "N.Z"], gbuffer_path)[valid])
    v = normalize(channels(gb, gb_names, ["V.X", "V.Y", "V.Z"], gbuffer_path)[valid])
    target = rgb[valid]
    geometry = Geometry(p, n, v, lights, ambient)
    prep_seconds = time.perf_counter() - t_prep

    names, lower, upper, x0 = MODELS[args.model]
    residual = RESIDUALS[args.model]
    def fun(x):
        return residual(x, geometry, target, False)[0]

    def jac(x):  # trf asks for it only at accepted points
        return residual(x, geometry, target, True)[1]

    initial_cost = 0.5 * float(np.sum(residual(np.array(x0, float), geometry, target, False)[0] ** 2))
    t_solve = time.perf_counter()
    sol = least_squares(fun, np.array(x0, dtype=np.float64), jac=jac,
                        bounds=(np.array(lower, float), np.array(upper, float)),
                        method="trf", x_scale="jac",
                        ftol=args.ftol, xtol=args.xtol, gtol=args.gtol)
    solve_seconds = time.perf_counter() - t_solve

    res = sol.fun
    rmse = float(np.sqrt(np.mean(res**2)))
    rms_ref = float(np.sqrt(np.mean(target**2)))
    out = {
        "tool": "bench/peer/peer_fit.py",
        "reference": args.ref,
        "model": args.model,
        "pixels": int(target.shape[0]),
        "parameters": dict(zip(names, map(float, sol.x))),
        "cost": {"initial": initial_cost, "final": float(sol.cost)},
        "rmse": rmse,
        "rms_reference": rms_ref,
        "relative_rmse": rmse / rms_ref,
        "solver": {"method": "scipy.optimize.least_squares trf, x_scale=jac, analytic jac",
                   "status": int(sol.status), "message": sol.message,
                   "nfev": int(sol.nfev), "njev": int(sol.njev),
                   "seconds": solve_seconds},
        "seconds": {"gbuffer_render": gbuffer_seconds, "prepare": prep_seconds,
                    "solve": solve_seconds, "process": time.perf_counter() - t_process},
        "versions": {"numpy": np.__version__, "scipy": __import__("scipy").__version__,
                     "python": sys.version.split()[0]},
    }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
