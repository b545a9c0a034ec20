"""shadefit from Python: render, fit, compare and probe shading models (docs/python.md).

The same C++ libraries as the `shadefit` command line, called in-process. Images are numpy
arrays of shape (H, W, C), dtype float32, linear radiance in W m^-2 sr^-1 (the renderer's unit;
Cycles' references use the same), row 0 on top, RGBA with alpha = coverage (premultiplied).
Bad input raises shadefit.Error (a ValueError) whose message is the CLI's one line
"<file>: <field>: <problem>"; arrays of the wrong dtype raise TypeError, of the wrong shape
ValueError. Renders, fits, metrics and studies release the GIL. The process keeps one GL context
(EGL, headless), made on the first render and reused by every later call and thread.
"""

import atexit as _atexit
import os as _os
import subprocess as _subprocess
import sys as _sys

import numpy as _np

from . import _results
from . import _shadefit
from . import _toml
from ._shadefit import Error, GlContextLostError, MeasuredBrdf

__version__ = _shadefit.__version__
__all__ = [
    "Error", "GlContextLostError", "FitResult", "MeasuredBrdf", "models", "render", "fit",
    "fit_brdf", "metrics", "probe", "probe_names", "load_brdf", "read_image", "write_exr",
    "run_study",
    "load_results", "gl_info", "scene_toml",
]

# The context goes with the interpreter, while EGL is still loaded.
_atexit.register(_shadefit.close_gl)


def _scene_args(scene, what="scene"):
    """(path, text, name) of a scene given as a path, TOML text or a dict."""
    if isinstance(scene, dict):
        return "", _toml.dumps(scene), "<dict>"
    if isinstance(scene, _os.PathLike):
        return _os.fspath(scene), "", ""
    if isinstance(scene, str):
        # TOML text has an '=' or a newline; a file name has neither.
        if "=" in scene or "\n" in scene:
            return "", scene, "<text>"
        return scene, "", ""
    raise TypeError(f"{what}: expected a path, TOML text or a dict, got {type(scene).__name__}")


def scene_toml(scene):
    """The TOML text of a scene given as a dict (what render() passes to the parser)."""
    return _toml.dumps(scene)


def models():
    """Every shading model with its parameter table.

    Returns a list of dicts: name, description, parameters (rows: name, size 1 or 3 (RGB),
    min, max, default, log_scale, description; the units are in each description) and entries
    (the flattened names, "kd.r", "roughness", ..., in the order of FitResult.values).
    """
    return _shadefit.models()


def _params_arg(params):
    if isinstance(params, FitResult):
        return params.values
    return params


def render(scene, model, params=None):
    """Renders `scene` with `model` on the GPU (or llvmpipe): linear radiance.

    scene: a path (str or pathlib.Path) to a scene TOML file, TOML text, or a dict of the same
    tables (docs/scenes.md; relative file names in text or a dict resolve against the working
    directory). model: a name from models(). params: None (the table's defaults), a dict
    {row: value or (r, g, b)} in the table's units, a flat sequence of every entry
    (FitResult.values) or a FitResult.

    Returns a numpy array (H, W, 4) float32: RGB linear radiance (W m^-2 sr^-1, premultiplied on
    a transparent background), A coverage in [0, 1]; row 0 on top. The array owns the renderer's
    buffer (no copy).
    """
    path, text, name = _scene_args(scene)
    return _shadefit.render(path, text, name, model, _params_arg(params))


def read_image(path):
    """Reads an image as the CLI does: (H, W, C) float32; EXR linear, 8-bit files in [0, 1]."""
    return _shadefit.read_image(_os.fspath(path))


def write_exr(path, image):
    """Writes an (H, W), (H, W, 1), (H, W, 3) or (H, W, 4) float32 array as a float EXR
    (linear values as they are; atomic: a temporary file renamed)."""
    _shadefit.write_exr(_os.fspath(path), image)


def gl_info():
    """The EGL device and GL strings in use (`shadefit info`): a dict."""
    return _shadefit.gl_info()


def _image_arg(x):
    return _os.fspath(x) if isinstance(x, (str, _os.PathLike)) else x


def metrics(reference, test, mask=None, *, exposure=0.0, ppd=67.0, itp_white=100.0, maps=False):
    """Every image metric between a reference and a test image (`shadefit metrics --json`).

    reference, test: paths, or arrays (H, W, 3) or (H, W, 4) float32 of linear HDR RGB
    (alpha ignored). mask: None, a path, or an array (H, W) / (H, W, 1) float32 (> 0.5 = use) or
    (H, W) bool. exposure: display-transform exposure in stops (PSNR, SSIM, MS-SSIM, CIEDE2000,
    LDR-FLIP); ppd: FLIP's observer pixels per degree; itp_white: cd/m^2 of the linear value 1.0
    for dE_ITP.

    Returns the dict of schema shadefit.metrics/1 (docs/metrics.md; the CLI's JSON, byte for
    byte the same numbers; a non-finite number is None). With maps=True, also "maps": the
    per-pixel maps as (H, W) float32 arrays: absolute_error and relative_error (linear,
    mean over RGB; NaN outside the mask), ssim, ciede2000, delta_e_itp, flip_ldr, flip_hdr.
    """
    return _shadefit.metrics(_image_arg(reference), _image_arg(test), _image_arg(mask),
                             float(exposure), float(ppd), float(itp_white), bool(maps))


def _number(x):
    """A number of fit.json, where JSON's null stands for NaN (not computed)."""
    return float("nan") if x is None else x


class FitResult:
    """A fit's outcome (fit::FitResult; the CLI's fit.json is FitResult.json).

    model: the model name. parameters: {entry: value} in natural units (the table's units).
    std_errors: {entry: standard error} (NaN when fixed, undetermined or not computed).
    estimates: per entry a dict (name, value, std_error, fixed, undetermined, at_bound,
    spread_min/max/std over the starts that reached the best cost). values: the flattened
    parameters as a float64 array (for render()). params: {row: value or [r, g, b]}.
    exposure, exposure_std_error, exposure_free: the global scale (1 when fixed).
    converged, termination, solver_message, solver, path, loss: how the solve ended.
    iterations, initial_cost, final_cost (Ceres' 0.5 sum rho(r^2)), rmse (linear radiance,
    W m^-2 sr^-1, over every reference's valid pixels), seconds (wall time).
    starts: every start as a dict (start, params, exposure, initial_cost, final_cost,
    iterations, termination, converged, reached_best, coarse_cost, polished).
    starts_reached_best, covariance_status.
    references: per reference a dict (name, pixels, rmse, prediction: the fitted render
    (H, W, 4) float32 or None, abs_error: |prediction - reference| with alpha = validity).
    json: the whole result as the CLI writes it (schema in docs/fitting.md); every attribute
    above but values and references is read from it.
    """

    def __init__(self, raw):
        # Every attribute but the arrays is read from the one record of a fit result, the CLI's
        # fit.json (fit/src/fit_output.cpp, FitResultToJson): a field renamed there fails here.
        j = raw["json"]
        self.json = j
        self.model = j["model"]
        self.values = raw["values"]
        self.estimates = [{"name": p["name"], "value": p["value"],
                           "std_error": _number(p["std_error"]), "fixed": p["fixed"],
                           "fixed_by": p["fixed_by"], "undetermined": p["undetermined"],
                           "at_bound": p["at_bound"], "spread_min": _number(p["spread"]["min"]),
                           "spread_max": _number(p["spread"]["max"]),
                           "spread_std": _number(p["spread"]["std"])}
                          for p in j["parameters"]]
        self.parameters = {e["name"]: e["value"] for e in self.estimates}
        self.std_errors = {e["name"]: e["std_error"] for e in self.estimates}
        self.starts = [dict(s) for s in j["starts"]["results"]]
        self.references = raw["references"]
        self.loss = j["loss"]["name"]
        self.path = j["derivative_path"]
        solver = j["solver"]
        self.solver = solver["method"]
        self.iterations = solver["iterations"]
        self.termination = solver["termination"]
        self.solver_message = solver["message"]
        self.seconds = solver["seconds"]
        self.converged = j["converged"]
        self.exposure = _number(j["exposure"]["value"])
        self.exposure_std_error = _number(j["exposure"]["std_error"])
        self.exposure_free = j["exposure"]["mode"] == "free"
        self.initial_cost = _number(j["cost"]["initial"])
        self.final_cost = _number(j["cost"]["final"])
        self.rmse = _number(j["rmse"]["overall"])
        self.starts_reached_best = j["starts"]["reached_best"]
        self.covariance_status = j["covariance"]["status"]

    @property
    def params(self):
        """{row: value or [r, g, b]}: the fitted parameters by row, as render() takes them."""
        table = next(m for m in models() if m["name"] == self.model)
        out, i = {}, 0
        for row in table["parameters"]:
            v = [float(x) for x in self.values[i:i + row["size"]]]
            out[row["name"]] = v[0] if row["size"] == 1 else v
            i += row["size"]
        return out

    def __repr__(self):
        values = ", ".join(f"{k}={v:.4g}" for k, v in self.parameters.items())
        state = "converged" if self.converged else f"NOT converged ({self.termination})"
        return f"<FitResult {self.model}: {values}; rmse {self.rmse:.4g}, {state}>"


def _reference_arg(item, index):
    """One reference as _shadefit.fit takes it."""
    out = {"image": None, "scene_path": "", "scene_text": "", "scene_name": "", "mask": None,
           "name": ""}
    if isinstance(item, (str, _os.PathLike)):
        out["image"] = _os.fspath(item)
        return out
    if isinstance(item, tuple):
        if len(item) not in (2, 3):
            raise TypeError(f"references[{index}]: expected (image, scene) or (image, scene, mask)")
        item = dict(zip(("image", "scene", "mask"), item))
    if not isinstance(item, dict):
        raise TypeError(f"references[{index}]: expected a path, (image, scene[, mask]) or a dict, "
                        f"got {type(item).__name__}")
    unknown = set(item) - {"image", "scene", "mask", "name"}
    if unknown:
        raise TypeError(f"references[{index}]: unknown key(s) {sorted(unknown)}; "
                        "expected image, scene, mask, name")
    if "image" not in item:
        raise TypeError(f"references[{index}]: 'image' is missing")
    out["image"] = _image_arg(item["image"])
    if item.get("scene") is not None:
        out["scene_path"], out["scene_text"], out["scene_name"] = _scene_args(
            item["scene"], f"references[{index}].scene")
    out["mask"] = _image_arg(item.get("mask"))
    out["name"] = str(item.get("name") or "")
    return out


def _fixed_arg(fixed):
    if fixed is None:
        return []
    if isinstance(fixed, dict):
        out = []
        for k, v in fixed.items():
            v = v.tolist() if hasattr(v, "tolist") else v
            text = ",".join(repr(float(x)) for x in v) if isinstance(v, (list, tuple)) else repr(float(v))
            out.append(f"{k}={text}")
        return out
    return [str(x) for x in fixed]


def fit(references, model, *, fixed=None, loss="l2", loss_scale=0.0, starts=None, seed=1,
        exposure="fixed", path="auto", solver="auto", max_iterations=None, threads=None,
        pixel_stride=1, env_samples=0, env_pixels=None, env_twin_samples=None, env_rounds=None,
        central_differences=False, render_outputs=True, covariance=True):
    """Fits `model` jointly to one material's references (`shadefit fit`, docs/fitting.md).

    references: one or a list of: a path to an image whose sidecar (<image>.json) names its
    scene (the shipped reference_images/cycles/*.exr); a tuple (image, scene) or (image, scene,
    mask); or a dict with image, scene, mask, name. image: a path or an (H, W, 3|4) float32
    array of linear radiance (W m^-2 sr^-1; alpha = coverage); scene: a path, TOML text or dict
    (required with an array; with a path image it overrides the sidecar's); mask: a path or an
    array (> 0.5 = fit the pixel).

    fixed: parameters held constant, {row: value or (r, g, b)} or ["row=value", ...].
    loss: l2 | log | cuberoot | huber | cauchy; loss_scale: Huber/Cauchy scale in radiance
    units (0 = automatic). starts: number of starts (start 0 = table defaults, then scrambled
    Halton points from seed). exposure: fixed | free (fit a global scale). path: auto | gbuffer
    | gl; solver: auto | bounded-lm | ceres. pixel_stride: fit every n-th pixel in x and y (a
    mask, as a study's pixel_stride; the RMSE and the outputs still use every pixel).
    max_iterations (per start), threads (Ceres threads), env_*: as the CLI's --env-* options.
    render_outputs: render the fitted images (FitResult.references[i]["prediction"]).

    Returns a FitResult. A fit that does not converge is returned with converged False.
    """
    if isinstance(references, (str, _os.PathLike, tuple, dict)):
        references = [references]
    refs = [_reference_arg(r, i) for i, r in enumerate(references)]
    options = {"loss": loss, "loss_scale": float(loss_scale), "starts": starts, "seed": seed,
               "exposure": exposure, "path": path, "solver": solver,
               "max_iterations": max_iterations, "threads": threads,
               "pixel_stride": int(pixel_stride), "env_samples": env_samples,
               "env_pixels": env_pixels, "env_twin_samples": env_twin_samples,
               "env_rounds": env_rounds, "central_differences": bool(central_differences),
               "render_outputs": bool(render_outputs), "covariance": bool(covariance)}
    return FitResult(_shadefit.fit(refs, model, _fixed_arg(fixed), options))


def fit_brdf(path, model, *, fixed=None, cells=(90, 45, 45), max_theta=80.0, starts=None,
             seed=1, solver="auto", max_iterations=None, threads=None):
    """Fits `model` to a measured BRDF in BRDF space (`shadefit fit --brdf`, Ngan et al. 2005).

    path: a MERL .binary or a Neural-BRDF .h5 (its .json beside it). cells: theta_h, theta_d,
    phi_d cell counts; max_theta: cells with theta_i or theta_o above this (degrees) are left
    out. The objective is Ngan's cosine-weighted L2 over the cells (f in 1/sr). Returns a
    FitResult whose one reference is "brdf-space" (no images).
    """
    options = {"starts": starts, "seed": seed, "solver": solver, "max_iterations": max_iterations,
               "threads": threads, "render_outputs": False}
    return FitResult(_shadefit.fit_brdf(_os.fspath(path), model, _fixed_arg(fixed),
                                        [int(c) for c in cells], float(max_theta), options))


def load_brdf(path):
    """Opens a measured BRDF: MERL .binary or Neural-BRDF .h5 (with its .json).

    Returns a MeasuredBrdf: eval(wi, wo) takes unit directions in the local frame (normal +z)
    as arrays (..., 3) (broadcast against each other) and returns f(wi, wo) per RGB channel in
    1/sr, shape (..., 3) float64, without the cosine factor; 0 below the horizon. format
    ("merl-binary" or "neural-brdf") and files say what was read.
    """
    return _shadefit.load_brdf(_os.fspath(path))


def _eval_brdf(self, wi, wo):
    wi = _np.asarray(wi)
    wo = _np.asarray(wo)
    for name, a in (("wi", wi), ("wo", wo)):
        if a.dtype.kind not in "fiu":
            raise TypeError(f"{name}: expected real numbers, got dtype {a.dtype}")
        if a.ndim == 0 or a.shape[-1] != 3:
            raise ValueError(f"{name}: expected shape (..., 3), got {a.shape}")
    try:
        wi, wo = _np.broadcast_arrays(wi, wo)
    except ValueError:
        raise ValueError(f"wi {wi.shape} and wo {wo.shape} do not broadcast") from None
    shape = wi.shape
    flat_i = _np.ascontiguousarray(wi, dtype=_np.float64).reshape(-1, 3)
    flat_o = _np.ascontiguousarray(wo, dtype=_np.float64).reshape(-1, 3)
    return _shadefit.MeasuredBrdf._eval(self, flat_i, flat_o).reshape(shape)


_eval_brdf.__doc__ = """f(wi, wo) in 1/sr per RGB channel, shape (..., 3) float64.

wi, wo: unit directions (..., 3) in the local frame (normal +z), broadcast against each other;
either below the horizon gives 0. The GIL is released during the evaluation."""
MeasuredBrdf._eval = MeasuredBrdf.eval
MeasuredBrdf.eval = _eval_brdf


def probe_names():
    """The probe names: fresnel, highlight, energy, portability, brdf (docs/probes.md)."""
    return _shadefit.probe_names()


def _model_arg(m, index):
    if isinstance(m, FitResult):
        return {"model": m.model, "params": m.values, "label": m.model,
                "exposure": float(m.exposure), "trained_on": [r["name"] for r in m.references]}
    if isinstance(m, str):
        m = {"model": m}
    if not isinstance(m, dict) or "model" not in m:
        raise TypeError(f"models[{index}]: expected a FitResult, a model name or a dict with "
                        "'model' (and params, label, exposure, trained_on)")
    return {"model": m["model"], "params": m.get("params"), "label": m.get("label"),
            "exposure": float(m.get("exposure", 1.0)),
            "trained_on": list(m.get("trained_on", []))}


def probe(name, references=(), models=(), *, truth_from_sidecar=False, brdf=None):
    """Runs one phenomenon probe (`shadefit probe`, docs/probes.md) and returns its JSON as a dict.

    name: fresnel | highlight | energy | portability (on references) or brdf (on a measured
    BRDF file, `brdf`). references: paths of reference images with their sidecars. models:
    FitResults, model names (table defaults) or dicts {model, params, label, exposure,
    trained_on}. truth_from_sidecar: add the first reference's Cycles material as "truth".
    Returns the schema shadefit.probe/4 dict: numbers (per series), curves (x, y, labels),
    notes; radiance in W m^-2 sr^-1, angles in degrees.
    """
    if isinstance(references, (str, _os.PathLike)):
        references = [references]
    if isinstance(models, (str, dict, FitResult)):
        models = [models]
    return _shadefit.probe(name, [_os.fspath(r) for r in references],
                           [_model_arg(m, i) for i, m in enumerate(models)],
                           bool(truth_from_sidecar), "" if brdf is None else _os.fspath(brdf))


def run_study(path, out="out", *, quick=False, jobs=0, force=False, report=True, quiet=True):
    """Runs (or resumes) a study file as `shadefit study run` does (docs/studies.md).

    path: the study TOML; out: the output folder (results go to <out>/<study name>/). quick:
    apply the study's [quick] table; jobs: worker threads, each with its own GL context (0 =
    CPU count); force: rerun unchanged jobs; report: make the report (report/make_report.py
    with /usr/bin/python3, when the study asks for one); quiet: no progress lines.
    Returns the study folder (pass it to load_results). A failed job raises shadefit.Error
    naming study.log.
    """
    s = _shadefit.run_study(_os.fspath(path), _os.fspath(out), bool(quick), int(jobs),
                            bool(force), bool(quiet))
    if s["nothing_run"]:
        return None
    if report and s["report"]:
        python = _os.environ.get("SHADEFIT_PYTHON") or "/usr/bin/python3"
        script = _os.path.join(_shadefit.SOURCE_DIR, "report", "make_report.py")
        done = _subprocess.run([python, script, s["study_dir"]], stdout=_subprocess.DEVNULL
                               if quiet else None)
        if done.returncode != 0:
            raise Error(f"{script}: report failed (exit status {done.returncode})")
    return s["study_dir"]


def load_results(study, table="results"):
    """A study's result table as records: a list of dicts, one per row (pandas.DataFrame(...)
    takes it as it is; pandas is not needed).

    study: the study folder (<out>/<study name>) or an output folder holding one study.
    table: "results" (results.csv: one row per reference x fit, metrics in their units,
    docs/studies.md) or "timings" (timings.csv). Numbers are int or float, converged is a bool,
    an empty cell is None.
    """
    if table not in ("results", "timings"):
        raise Error(f"table: unknown table '{table}' (results or timings)")
    return _results.read_table(_os.path.join(_results.study_dir_of(study), table + ".csv"))
