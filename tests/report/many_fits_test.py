#!/usr/bin/python3
"""The report's figures stay clean with many fits (docs/studies.md, "Report"): a synthetic
study shaped like the measured-materials study (studies/merl_vs_blinn_phong.toml: 5 models x 2
training sets = 10 fits labelled `model@training`, 20 materials with names as long as MERL's)
is written as result files, make_report.py lays out its report, and figures.json must record no
text overlap and no text outside any figure; every figure is 3.3 or 7 in wide; each material's
grid names every fit in the parts it is split into, and index.html and report.tex show every
part, and report.tex compiles with nothing wider than the page (latex_test.py). Needs no
shadefit build: the result files are written here, with fixed values.

    many_fits_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import csv
import json
import math
import os
import re
import shutil
import sys

import numpy as np

MODELS = ["blinn-phong", "blinn-phong-normalized", "ggx", "ggx-metallic", "beckmann"]
TRAINING_SETS = [["key"], ["key", "mirror60"]]
# MERL names, the longest ones included (they set the legends' and labels' widths).
MATERIALS = ["alum-bronze", "aluminium", "black-obsidian", "black-phenolic", "blue-acrylic",
             "blue-fabric", "brass", "chrome", "delrin", "gold-metallic-paint", "nickel", "pvc",
             "red-metallic-paint", "red-plastic", "specular-red-phenolic", "steel", "teflon",
             "white-diffuse-bball", "white-fabric", "yellow-matte-plastic"]
# Few lightings keep the run short; the columns (fits) are what this test is about.
LIGHTINGS = ["key", "mirror60", "mirror85"]
# Sphere chart axes per model: (x parameter, values, scale), (y parameter, values, scale).
CHART_AXES = {
    "blinn-phong": (("shininess", [4, 16, 64, 256, 1024], "log"), ("ks", [0.02, 0.05, 0.15, 0.4, 1], "log")),
    "ggx": (("roughness", [0.05, 0.2, 0.4, 0.6, 0.8], "linear"), ("metallic", [0, 0.25, 0.5, 0.75, 1], "linear")),
}


class Shape:
    """What a synthetic study holds: models x training sets are its fits."""

    def __init__(self, name, models, training_sets, materials, losses=(None,)):
        self.name, self.models, self.training_sets = name, models, training_sets
        self.materials, self.probed, self.losses = materials, materials[:2], losses

    def fits(self):
        """The study's fit records: label `model@training`, or `model@training:loss` with
        several losses (as the measured study labels them)."""
        return [{"label": f"{m}@{'+'.join(t)}" + (f":{loss}" if loss else ""), "model": m,
                 "train": t, "loss": loss}
                for t in self.training_sets for m in self.models for loss in self.losses]

    def labels(self):
        return [f["label"] for f in self.fits()]


# The measured study's shape, and the default study's (4 fits, one grid figure a material).
MANY = Shape("many_fits", MODELS, TRAINING_SETS, MATERIALS)
FOUR = Shape("four_fits", ["blinn-phong", "ggx"], TRAINING_SETS, ["red-plastic", "gold"])
# Two losses per model and training set: labels end in ":cuberoot" and ":l2", and 6 fits per
# training set make a part of 5 fits (11 columns, the narrowest) and one of 1, as in the
# measured study, whose column titles overlapped ("@key:cuberoot" kept whole, wider than its
# column).
LOSSES = Shape("losses", MODELS[:3], TRAINING_SETS, ["alum-bronze", "white-diffuse-bball"],
               losses=("cuberoot", "l2"))


def write_json(path, obj):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(obj, f, indent=1)


def write_png(path, value):
    import matplotlib.image as mpimg
    os.makedirs(os.path.dirname(path), exist_ok=True)
    y, x = np.mgrid[0:32, 0:32]
    disc = ((x - 15.5) ** 2 + (y - 15.5) ** 2 < 14 ** 2).astype(float)
    img = np.clip(np.stack([disc * value] * 3, axis=2), 0, 1)
    mpimg.imsave(path, img)


def write_study(d, shape):
    """Result files as `shadefit study run` writes them (study.json, results.csv, jobs/,
    images/, charts/), with values drawn from a fixed seed."""
    rng = np.random.default_rng(7)
    # A fit record names its loss where the study has several (as the runner's study.json).
    fits = [{k: v for k, v in f.items() if k != "loss" or v} for f in shape.fits()]
    losses = {f["label"]: f["loss"] for f in shape.fits()}
    write_json(os.path.join(d, "study.json"), {
        "name": shape.name, "description": "synthetic: report layout test",
        "fits": fits, "training_sets": shape.training_sets, "test_lightings": [],
        "baseline": None, "compare": [], "measured": [],
        "groups": [{"material": m, "references": [{"lighting": l, "sidecar": ""}
                                                  for l in LIGHTINGS]}
                   for m in shape.materials],
        "probes": ["highlight", "portability", "brdf"],
        # The measured study's questions (a tolerance matrix of 10 fit columns), so that the
        # page's layout is checked with them (browser_test.py --layout).
        "verdicts": {
            "highlight": {"question": "Is the specular lobe (shape, tails, grazing stretch) "
                                      "accurate?", "source": "highlight", "kind": "relative",
                          "tolerance": 0.25},
            "brdf_highlight": {"question": "Does the model's highlight match the measured "
                                           "BRDF's (half-width, tail; BRDF space)?",
                               "source": "brdf", "kind": "relative", "tolerance": 0.25},
            "image": {"question": "How close can the model get to a reference image (training "
                                  "lighting)?", "source": "metrics", "metric": "flip_ldr_mean",
                      "split": "train", "kind": "max", "tolerance": 0.05},
            "transfer": {"question": "Do fitted parameters carry over to new lighting (image "
                                     "error under test lightings)?", "source": "metrics",
                         "metric": "flip_ldr_mean", "split": "test", "kind": "max",
                         "tolerance": 0.08}}})
    rows = []
    for m in shape.materials:
        write_png(os.path.join(d, "images", f"{m}-ref.png"), 0.8)
        for f in fits:
            evaluations = []
            for l in LIGHTINGS:
                split = "train" if l in f["train"] else "test"
                base = os.path.join("images", f"{m}-{l}.{f['label']}")
                write_png(os.path.join(d, base + ".png"), 0.6)
                write_png(os.path.join(d, base + ".error.png"), 0.3)
                evaluations.append({"lighting": l, "split": split, "metrics": {}, "images": {
                    "reference": f"images/{m}-ref.png", "fit": base + ".png",
                    "error": base + ".error.png", "error_scale": 0.05}})
                rows.append({"material": m, "lighting": l, "label": f["label"], "split": split,
                             "converged": "1", "rmse": "0.01",
                             "relative_rmse": f"{rng.uniform(0.02, 0.4):.4f}",
                             "psnr": "30", "ssim": "0.9", "ciede2000_mean": "2",
                             "flip_ldr_mean": f"{rng.uniform(0.01, 0.6):.4f}",
                             "flip_hdr_mean": "0.2"})
            axes = CHART_AXES.get(f["model"])
            flags = {"fixed": False, "at_bound": False, "undetermined": False}
            params = [{"name": "kd", "value": 0.2, "std_error": 0.01, **flags}]
            if axes:
                # Some fits beyond the chart's range: they are marked at its edge.
                for (name, values, _) in axes:
                    v = float(rng.uniform(values[0], values[-1] * 1.3))
                    params.append({"name": name, "value": v, "std_error": 0.01, **flags})
            loss = f".{losses[f['label']]}" if losses[f["label"]] else ""
            write_json(os.path.join(d, "jobs",
                                    f"fit.{m}.{f['model']}.{'+'.join(f['train'])}{loss}.json"),
                       {"kind": "fit", "material": m, "label": f["label"], "model": f["model"],
                        "train": f["train"], "parameters": params, "evaluations": evaluations,
                        "exposure": 0.0,
                        "converged": True, "termination": "CONVERGENCE"})
    with open(os.path.join(d, "results.csv"), "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)
    for m in shape.probed:
        write_json(os.path.join(d, "jobs", f"probe.{m}.json"),
                   {"kind": "probe", "material": m, "probes": probe_results(m, shape.labels(), rng)})
    charts = []
    for model, ((xp, xv, xs), (yp, yv, ys)) in CHART_AXES.items():
        if model not in shape.models:
            continue
        images = [[f"charts/{model}-{i}-{j}.png" for j in range(len(xv))] for i in range(len(yv))]
        for row in images:
            for rel in row:
                write_png(os.path.join(d, rel), 0.5)
        charts.append({"model": model, "held": "diffuse albedo 0.25",
                       "x": {"parameter": xp, "values": xv, "scale": xs},
                       "y": {"parameter": yp, "values": yv, "scale": ys}, "images": images})
    write_json(os.path.join(d, "charts", "charts.json"),
               {"schema": "shadefit.study.charts/1", "lighting": "key", "exposure_stops": 0,
                "charts": charts})


def curve(series, reference, kind, xs, ys, x_label, y_label, extrapolated=None):
    c = {"series": series, "reference": reference,
         "lighting": reference.rsplit("-", 1)[1] if reference else None, "kind": kind,
         "x": list(xs), "y": list(ys),
         "x_label": x_label, "y_label": y_label, "x_scale": "linear", "y_scale": "linear"}
    if extrapolated is not None:
        c["extrapolated"] = extrapolated
    return c


def probe_results(m, labels, rng):
    """A highlight probe (one panel: a 3.3 in figure), a brdf probe (five panels, measured points
    flagged extrapolated) and portability numbers (bars), for the reference and every fit."""
    schema = "shadefit.probe/4"
    th = np.linspace(0, 60, 31)
    highlight = [curve(s, f"{m}-key", "falloff", th, np.exp(-th / rng.uniform(2, 20)),
                       "theta_h (deg)", "specular / peak (mean per bin)")
                 for s in ["reference"] + labels]
    td = np.linspace(0, 89, 30)
    flags = [bool(t > 75) for t in td]
    brdf = []
    for kind, y_label in [("Fresnel rise", "Fresnel rise: (f - floor) cos^2 theta_d / centre mean"),
                          ("specular peak", "specular peak f (1/sr)"),
                          ("highlight f", "f (1/sr)"),
                          ("highlight specular", "specular (f - floor) n.l n.v / peak"),
                          ("directional albedo", "directional albedo (Y)")]:
        for s in ["measured"] + labels:
            # Decades, as measured: a fit's Fresnel rise reaches 100x its centre.
            ys = 1 + rng.uniform(1, 500) * (td / 89) ** 4
            brdf.append(curve(s, None, kind, td, ys, "theta_d (deg), theta_h = 0", y_label,
                              flags if s == "measured" else None))
    numbers = {l: {"rmse": {f"{m}-{x}": float(rng.uniform(0, 2)) for x in LIGHTINGS},
                   "test_over_train": float(rng.uniform(1, 400)), "train_rmse": 0.1,
                   "test_rmse": 0.5} for l in labels}
    return {"highlight": {"schema": schema, "curves": highlight, "numbers": {}},
            "portability": {"schema": schema, "curves": [], "numbers": numbers},
            "brdf": {"schema": schema, "curves": brdf, "numbers": {}}}


def check(shape, out, make_report, pdf_problems, png_size):
    """Lays out the report of a synthetic study of this shape; returns its problems."""
    d = os.path.join(out, shape.name)
    shutil.rmtree(d, ignore_errors=True)
    write_study(d, shape)
    make_report.make_report(d)
    report = os.path.join(d, "report")
    with open(os.path.join(report, "figures.json"), encoding="utf-8") as f:
        figures = json.load(f)
    with open(os.path.join(report, "index.html"), encoding="utf-8") as f:
        page = f.read()
    with open(os.path.join(report, "report.tex"), encoding="utf-8") as f:
        tex = f.read()
    failures = []
    labels = shape.labels()
    names = [f["name"] for f in figures]
    want = ["metric-flip_ldr_mean"] + [f"chart-{m}" for m in CHART_AXES if m in shape.models] + [
        f"probe-{p}-{m}" for p in ("highlight", "portability", "brdf") for m in shape.probed]
    failures += [f"{w}: missing from figures.json" for w in want if w not in names]
    split = len(labels) > 5  # report_figures.GRID_MAX_FITS
    for m in shape.materials:
        grids = [f for f in figures if f.get("kind") == "grid" and f.get("material") == m]
        if not split and [g["name"] for g in grids] != [f"grid-{m}"]:
            # Few fits keep one grid a material, under the name report.tex users include.
            failures.append(f"grid of {m}: {[g['name'] for g in grids]}, want [grid-{m}]")
        shown = [l for g in grids for l in g.get("fits", [])]
        if sorted(shown) != sorted(labels):
            failures.append(f"grid of {m}: its parts show {shown}, want every fit once")
        for g in grids:
            if g["png"] not in page:
                failures.append(f"{g['name']}: not linked from index.html")
        # A split grid: one part per training set, named by it (and numbered where a training
        # set holds more fits than a part).
        for t in shape.training_sets if split else []:
            name = f"grid-{m}-{'+'.join(t)}"
            if not any(re.fullmatch(re.escape(name) + r"(-\d+)?", g["name"]) for g in grids):
                failures.append(f"grid of {m}: no part {name}")
    for fig in figures:
        name, w_in, h_in = fig["name"], fig["width_in"], fig["height_in"]
        if not any(abs(w_in - w) < 1e-6 for w in (3.3, 7.0)):
            failures.append(f"{name}: {w_in} in wide, want 3.3 or 7")
        size = png_size(os.path.join(report, fig["png"]))
        if size != (fig["width"], fig["height"]):
            failures.append(f"{name}.png: {size}, want {(fig['width'], fig['height'])}")
        failures += [f"{name}.pdf: {p}" for p in pdf_problems(
            os.path.join(report, fig["pdf"]), w_in, h_in)]
        if fig["pdf"] not in tex:
            failures.append(f"{name}: not in report.tex")
        for a, b in fig.get("text_overlaps", [("(field missing)", "")]):
            failures.append(f"{name}: text '{a}' overlaps '{b}'")
        for t in fig.get("text_outside", ["(field missing)"]):
            failures.append(f"{name}: text '{t}' leaves the figure")
    print(f"{shape.name}: {len(figures)} figures of {len(labels)} fits x "
          f"{len(shape.materials)} materials checked, {len(failures)} problem(s)")
    return [f"{shape.name}: {x}" for x in failures]


def main(argv):
    report_src, out = argv[1], os.path.abspath(argv[2])
    sys.path.insert(0, report_src)
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    import make_report  # noqa: E402
    from figures_test import pdf_problems, png_size  # noqa: E402
    failures = []
    for shape in (MANY, FOUR, LOSSES):
        failures += check(shape, out, make_report, pdf_problems, png_size)
    # Its tables too: 10 fits are as many columns, which report.tex must fit on the page.
    import latex_test  # noqa: E402
    rc = latex_test.main([None, os.path.join(out, MANY.name)])
    if rc == 1:
        failures.append(f"{MANY.name}: report.tex (above)")
    for f in failures:
        print("FAILED: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
