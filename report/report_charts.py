"""Parameter charts: the study's sphere grids (charts/charts.json, rendered by the study's
parameter_charts.cpp) laid out one column wide, with every material's fitted parameters marked.
Reads result files only; renders nothing.
"""

import json
import math
import os

import matplotlib.lines
import matplotlib.pyplot as plt
import numpy as np

import report_figures as rf
from report_util import materials_of


MARKERS = ["o", "s", "^", "D", "v", "P", "X", "h", "<", ">"]


class ChartInputError(Exception):
    pass


def fitted_value(job, name):
    """A fitted parameter: a scalar row, or the mean of a colour row's channels."""
    vals = [p["value"] for p in job["parameters"]
            if (p["name"] == name or p["name"].startswith(name + ".")) and p["value"] is not None]
    return float(np.mean(vals)) if vals else None


def metallic_equivalent(kd, f0, f0_dielectric=0.04):
    """The metallic m of ggx-metallic that gives this (kd, f0), channel means: kd = b (1 - m),
    f0 = d (1 - m) + b m, so with s = kd + f0: d m^2 + (s - 2 d) m - (f0 - d) = 0."""
    if kd is None or f0 is None:
        return None
    d, s = f0_dielectric, kd + f0
    a, b, c = d, s - 2 * d, -(f0 - d)
    disc = b * b - 4 * a * c
    if disc < 0:
        return None
    return min(1.0, max(0.0, (-b + math.sqrt(disc)) / (2 * a)))


def fitted_point(chart, job):
    x = fitted_value(job, chart["x"]["parameter"])
    y = fitted_value(job, chart["y"]["parameter"])
    if chart["y"]["parameter"] == "metallic" and y is None:
        y = metallic_equivalent(fitted_value(job, "kd"), fitted_value(job, "f0"))
    return x, y


def grid_coordinate(axis, v):
    """Position of value v on an axis of sphere centres 0..n-1 (log or linear between them);
    clamped to the ends, with whether it was outside."""
    vals = axis["values"]
    f = np.log if axis["scale"] == "log" else (lambda t: t)
    if axis["scale"] == "log" and v <= 0:
        return 0.0, True
    pos = float(np.interp(f(v), [f(a) for a in vals], range(len(vals))))
    outside = v < min(vals) * (1 - 1e-9) or v > max(vals) * (1 + 1e-9)
    return pos, outside


def load_charts(study_dir):
    path = os.path.join(study_dir, "charts", "charts.json")
    if not os.path.exists(path):
        return None, path
    try:
        with open(path, encoding="utf-8") as f:
            manifest = json.load(f)
    except ValueError as e:
        raise ChartInputError(f"{path}: not JSON ({e})")
    for i, c in enumerate(manifest.get("charts", [])):
        for field in ["model", "x", "y", "images"]:
            if field not in c:
                raise ChartInputError(f"{path}: charts[{i}].{field}: missing")
        for ax in ["x", "y"]:
            if not c[ax].get("values") or c[ax].get("scale") not in ("log", "linear"):
                raise ChartInputError(f"{path}: charts[{i}].{ax}: want values and scale log|linear")
        if len(c["images"]) != len(c["y"]["values"]) or any(
                len(r) != len(c["x"]["values"]) for r in c["images"]):
            raise ChartInputError(f"{path}: charts[{i}].images: not {len(c['y']['values'])} rows "
                                  f"of {len(c['x']['values'])}")
        for row in c["images"]:
            for rel in row:
                if not os.path.exists(os.path.join(study_dir, rel)):
                    raise ChartInputError(f"{path}: charts[{i}].images: {rel}: missing")
    return manifest, path


def sweep_sentence(probes, model):
    """The energy probe's sweep of this model's lobe width, as a sentence for the caption."""
    for job in probes.values():
        energy = job["probes"].get("energy")  # the energy probe, where the study ran it
        sweep = (energy["numbers"].get("sweep") or {}) if energy else {}
        s = sweep.get(model)
        if s and s.get("flux_min") is not None and s.get("flux_max") is not None:
            return (f" Energy probe, white lobe swept over its width: reflected flux "
                    f"{s['flux_min']:.3g} to {s['flux_max']:.3g} (a factor of "
                    f"{s['flux_max'] / max(s['flux_min'], 1e-12):.3g}).")
    return ""


# The keys under a chart: small text, tight spacing (a column holds 20 materials in 3 columns).
KEY_PT = rf.FONT_PT - 2
KEY_SPACING = {"handlelength": 1.2, "handletextpad": 0.4, "columnspacing": 0.8}
# How a mark shows which of a model's fits it is (study order): open, filled, half filled.
FIT_FILLS = ["none", "full", "left", "bottom"]


def mark_style(k, fill):
    """The k-th material's mark: a shape and a colour each (more materials than the palette has
    colours), drawn open over the sphere under it unless `fill` says otherwise."""
    colour = rf.OKABE_ITO[k % len(rf.OKABE_ITO)]
    return {"marker": MARKERS[k % len(MARKERS)], "markersize": 7 if fill == "none" else 5,
            "markeredgecolor": colour, "markerfacecolor": "none" if fill == "none" else colour,
            "markerfacecoloralt": "none", "fillstyle": "full" if fill == "none" else fill,
            "markeredgewidth": 1.6 if fill == "none" else 1.0}


def chart_marks(chart, fits, materials, fit_labels):
    """Every fit of the chart's model as a mark: {"k" (material index), "material", "label",
    "gx", "gy" (grid coordinates), "outside"}, and the caption's (label, note) on each."""
    marks, notes = [], []
    xp, yp = chart["x"]["parameter"], chart["y"]["parameter"]
    for k, m in enumerate(materials):
        for label in fit_labels:
            job = fits.get((m, label))
            if job is None:
                continue
            x, y = fitted_point(chart, job)
            if x is None or y is None:
                # Said in the caption, never dropped silently.
                notes.append((label, f"{m} not placed (no {xp if x is None else yp})"))
                continue
            (gx, ox), (gy, oy) = grid_coordinate(chart["x"], x), grid_coordinate(chart["y"], y)
            marks.append({"k": k, "material": m, "label": label, "gx": gx, "gy": gy,
                          "outside": ox or oy})
            notes.append((label, f"{m} ({x:.3g}, {y:.3g})" + ("*" if ox or oy else "")))
    return marks, notes


def fitted_sentence(chart, notes):
    """The caption's list of fitted values, grouped by fit: short enough for LaTeX's one-line
    caption trial (\\@makecaption sets it in one box; 40 long notes passed \\maxdimen)."""
    if not notes:
        return "Fitted: none."
    by_label = {}
    for label, text in notes:
        by_label.setdefault(label, []).append(text)
    return (f"Fitted ({chart['x']['parameter']}, {chart['y']['parameter']}; * outside the chart, "
            "marked at its edge): " + "; ".join(f"{label}: {', '.join(t)}"
                                               for label, t in by_label.items()) + ".")


def material_key(marks, materials):
    """(name, material index) per marked material in study order; a name ends in " *" where one
    of its fits lies outside the chart's range."""
    key = []
    for k, m in enumerate(materials):
        own = [mk for mk in marks if mk["k"] == k]
        if own:
            key.append((m + (" *" if any(mk["outside"] for mk in own) else ""), k))
    return key


def chart_mosaic(c, study_dir, path):
    """One chart's sphere images as one image, the last y value on top."""
    mosaic = None
    for row in reversed(c["images"]):
        tiles = []
        for rel in row:
            p = os.path.join(study_dir, rel)
            if not os.path.exists(p):
                raise ChartInputError(f"{path}: images: {rel}: missing")
            tiles.append(rf.read_rgb(p))
        line = np.concatenate(tiles, axis=1)
        mosaic = line if mosaic is None else np.concatenate([mosaic, line], axis=0)
    return mosaic


def chart_figures(study_dir, study, fits, fig_dir, manifest_out, charts, probes):
    """`charts`: load_charts' (manifest, path), read before anything is written."""
    manifest, path = charts
    if manifest is None:
        return []
    materials = materials_of(study)
    figures = []
    for c in manifest.get("charts", []):
        model = c["model"]
        fit_labels = [f["label"] for f in study["fits"] if f["model"] == model]
        nx, ny = len(c["x"]["values"]), len(c["y"]["values"])
        marks, notes = chart_marks(c, fits, materials, fit_labels)
        key = material_key(marks, materials)
        fit_key = [(label, FIT_FILLS[j % len(FIT_FILLS)]) for j, label in enumerate(fit_labels)
                   if any(mk["label"] == label for mk in marks)] if len(fit_labels) > 1 else []
        any_outside = any(mk["outside"] for mk in marks)
        # Under the axes, top to bottom: tick labels and axis label, the fits' fill key (when a
        # model has several fits), the materials' key, the note on marks outside the chart.
        width_in = rf.COLUMN_IN - 0.1
        key_cols, _, key_in = rf.legend_layout([k[0] for k in key], width_in, KEY_PT, **KEY_SPACING)
        fit_cols, _, fit_in = rf.legend_layout([k[0] for k in fit_key], width_in, KEY_PT,
                                               **KEY_SPACING)
        note_in = 0.12 if any_outside else 0.0
        left, right, top = 0.42, 0.06, 0.22
        axis_in = 0.36
        bottom = axis_in + fit_in + key_in + note_in + 0.04
        cell = (rf.COLUMN_IN - left - right) / nx
        height = top + bottom + cell * ny
        fig = plt.figure(figsize=(rf.COLUMN_IN, height))
        ax = fig.add_axes([left / rf.COLUMN_IN, bottom / height, cell * nx / rf.COLUMN_IN,
                           cell * ny / height])
        ax.imshow(chart_mosaic(c, study_dir, path), origin="upper", extent=(-0.5, nx - 0.5, -0.5, ny - 0.5),
                  interpolation="nearest")
        ax.set_xticks(range(nx))
        ax.set_xticklabels([f"{v:g}" for v in c["x"]["values"]])
        ax.set_yticks(range(ny))
        ax.set_yticklabels([f"{v:g}" for v in c["y"]["values"]])
        ax.set_xlabel(c["x"]["parameter"] + (" (log spacing)" if c["x"]["scale"] == "log" else ""))
        ax.set_ylabel(c["y"]["parameter"] + (" (log)" if c["y"]["scale"] == "log" else ""))
        ax.tick_params(length=2, pad=1)
        ax.set_title(model, fontsize=rf.FONT_PT + 1, pad=3)
        for mk in marks:
            ax.plot([mk["gx"]], [mk["gy"]], linestyle="none", **mark_style(
                mk["k"], FIT_FILLS[fit_labels.index(mk["label"]) % len(FIT_FILLS)]))
        ax.set_xlim(-0.5, nx - 0.5)
        ax.set_ylim(-0.5, ny - 0.5)
        y_in = note_in + 0.02
        if key:
            handles = [matplotlib.lines.Line2D([], [], linestyle="none", **mark_style(k, "none"))
                       for _, k in key]
            fig.legend(handles, [name for name, _ in key], loc="lower center", ncol=key_cols,
                       frameon=False, fontsize=KEY_PT, bbox_to_anchor=(0.5, y_in / height),
                       markerscale=0.6, **KEY_SPACING)
        if fit_key:
            handles = [matplotlib.lines.Line2D([], [], linestyle="none", marker="o",
                                               markersize=4.5, color="0.3", fillstyle=fill,
                                               markeredgewidth=1.2) for _, fill in fit_key]
            fig.legend(handles, [label for label, _ in fit_key], loc="lower center",
                       ncol=fit_cols, frameon=False, fontsize=KEY_PT,
                       bbox_to_anchor=(0.5, (y_in + key_in) / height), **KEY_SPACING)
        if any_outside:
            fig.text(0.5, 0.02 / height, "* a fit outside the chart's range, marked at its edge",
                     ha="center", va="bottom", fontsize=KEY_PT)
        caption = (f"{model}: spheres over {c['x']['parameter']} x {c['y']['parameter']} under the "
                   f"{manifest.get('lighting', '')} light, one exposure "
                   f"({manifest.get('exposure_stops', 0):g} EV) for every sphere; "
                   f"{c.get('held', '')}. " + fitted_sentence(c, notes)
                   + sweep_sentence(probes, model))
        rf.save_figure(fig, fig_dir, f"chart-{model}", manifest_out, caption)
        figures.append(manifest_out[-1])
    return figures
