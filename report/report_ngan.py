"""Our fitted lobe parameters next to Ngan, Durand and Matusik 2005's BRDF-space fits (measured
studies whose references came from a folder with ngan2005-fits.tsv)."""

import os

from report_inputs import SIDECAR, ReportInputError, read_checked
from report_stats import spearman
from report_util import fmt, materials_of, to_float


def ngan_table_path(study):
    """ngan2005-fits.tsv beside the measured folder the study's references came from, if any."""
    for g in study["groups"]:
        for r in g["references"]:
            sidecar = r["sidecar"]
            if not sidecar or not os.path.exists(sidecar):
                continue
            sc = read_checked(sidecar, SIDECAR)
            if sc.get("kind") != "measured-brdf":
                continue
            if "brdf" not in sc:
                raise ReportInputError(f"{sidecar}: field 'brdf': missing (a measured-brdf "
                                       "sidecar names its BRDF files)")
            for f in sc["brdf"]["files"]:
                candidate = os.path.join(os.path.dirname(os.path.dirname(f["path"])),
                                         "ngan2005-fits.tsv")
                if os.path.exists(candidate):
                    return candidate
    return None


def read_ngan(path):
    with open(path, encoding="utf-8") as f:
        lines = [l.rstrip("\n") for l in f if l.strip() and not l.startswith("#")]
    header = lines[0].split("\t")
    out = {}
    for line in lines[1:]:
        cells = line.split("\t")
        out[cells[0]] = {h: float(c) for h, c in zip(header[1:], cells[1:])}
    return out


# Our fitted quantity set against Ngan's: (our model, our parameter -> number, Ngan's column).
# GGX and Beckmann alpha = roughness^2 (models.md); Ngan's Cook-Torrance m is a Beckmann slope
# width; Blinn-Phong sharpness n is the exponent. Ranks compare across normalisations.
NGAN_PAIRS = [
    ("blinn-phong", "shininess", lambda v: v, "shininess n", "blinn_phong_n", "Blinn-Phong n"),
    ("blinn-phong-normalized", "shininess", lambda v: v, "shininess n", "blinn_phong_n",
     "Blinn-Phong n"),
    ("ggx", "roughness", lambda v: v * v, "alpha", "cook_torrance_m", "Cook-Torrance m"),
    ("beckmann", "roughness", lambda v: v * v, "alpha", "cook_torrance_m", "Cook-Torrance m"),
    # Ngan's own model set (render/models/): the same forms, parameter for parameter.
    ("cook-torrance", "m", lambda v: v, "m", "cook_torrance_m", "Cook-Torrance m"),
    ("ward", "alpha", lambda v: v, "alpha", "ward_alpha", "Ward alpha"),
    ("ward-duer", "alpha", lambda v: v, "alpha", "ward_alpha", "Ward alpha"),
    ("ashikhmin-shirley", "n", lambda v: v, "n", "ashikhmin_shirley_n", "Ashikhmin-Shirley n"),
    ("lafortune", "n", lambda v: v, "n", "lafortune_n", "Lafortune n")]


def ngan_comparison(study, fits):
    """Per fit label with a counterpart in Ngan 2005: our number next to theirs, and rho."""
    path = ngan_table_path(study)
    if path is None:
        return None
    ngan = read_ngan(path)
    rows, correlations = [], []
    for f in study["fits"]:
        for model, pname, to_num, ours_label, col, col_label in NGAN_PAIRS:
            if f["model"] != model:
                continue
            ours, theirs = [], []
            for m in materials_of(study):
                job = fits.get((m, f["label"]))
                if job is None or m not in ngan:
                    continue
                value = next((to_float(p["value"]) for p in job["parameters"] if p["name"] == pname), None)
                if value is None:
                    continue
                num = to_num(value)
                ours.append(num)
                theirs.append(ngan[m][col])
                rows.append([m, f["label"], ours_label, fmt(num), col_label, fmt(ngan[m][col])])
            rho = spearman(ours, theirs)
            correlations.append({"fit": f["label"], "model": model, "ours": ours_label,
                                 "ngan": col, "materials": len(ours), "spearman": rho})
    return {"source": path, "rows": rows, "correlations": correlations}


def ngan_table(ngan):
    """Our number next to Ngan's, per material and fit."""
    return ["material", "fit", "ours", "value", "Ngan 2005", "Ngan's value"], ngan["rows"]


def spearman_table(ngan):
    cols = ["fit", "our parameter", "Ngan 2005", "materials", "Spearman rho"]
    rows = [[c["fit"], c["ours"], c["ngan"], str(c["materials"]),
             fmt(c["spearman"], "{:.3f}") if c["spearman"] is not None else "n/a"]
            for c in ngan["correlations"]]
    return cols, rows
