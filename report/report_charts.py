"""Parameter charts: the study's sphere grids (charts/charts.json, rendered by the study's
parameter_charts.cpp) laid out one column wide, with every material's fitted parameters marked.
Reads result files only; renders nothing.
"""

import json
import math
import os

import matplotlib.pyplot as plt
import numpy as np

import report_figures as rf


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
        sweep = ((job.get("probes", {}).get("energy") or {}).get("numbers") or {}).get("sweep") or {}
        s = sweep.get(model)
        if s and s.get("flux_min") is not None and s.get("flux_max") is not None:
            return (f" Energy probe, white lobe swept over its width: reflected flux "
                    f"{s['flux_min']:.3g} to {s['flux_max']:.3g} (a factor of "
                    f"{s['flux_max'] / max(s['flux_min'], 1e-12):.3g}).")
    return ""


def chart_figures(study_dir, study, fits, fig_dir, manifest_out, charts, probes):
    """`charts`: load_charts' (manifest, path), read before anything is written."""
    manifest, path = charts
    if manifest is None:
        return []
    materials = [g["material"] for g in study["groups"]]
    figures = []
    for c in manifest.get("charts", []):
        model = c["model"]
        fit_labels = [f["label"] for f in study["fits"] if f["model"] == model]
        nx, ny = len(c["x"]["values"]), len(c["y"]["values"])
        left, right, top = 0.42, 0.06, 0.22
        legend_rows = math.ceil(len(materials) / 3)
        bottom = 0.42 + 0.13 * legend_rows
        cell = (rf.COLUMN_IN - left - right) / nx
        height = top + bottom + cell * ny
        fig = plt.figure(figsize=(rf.COLUMN_IN, height))
        ax = fig.add_axes([left / rf.COLUMN_IN, bottom / height, cell * nx / rf.COLUMN_IN,
                           cell * ny / height])
        mosaic = None
        for row in reversed(c["images"]):  # The last y value on top.
            tiles = []
            for rel in row:
                p = os.path.join(study_dir, rel)
                if not os.path.exists(p):
                    raise ChartInputError(f"{path}: images: {rel}: missing")
                tiles.append(rf.read_rgb(p))
            line = np.concatenate(tiles, axis=1)
            mosaic = line if mosaic is None else np.concatenate([mosaic, line], axis=0)
        ax.imshow(mosaic, origin="upper", extent=(-0.5, nx - 0.5, -0.5, ny - 0.5),
                  interpolation="nearest")
        ax.set_xticks(range(nx))
        ax.set_xticklabels([f"{v:g}" for v in c["x"]["values"]])
        ax.set_yticks(range(ny))
        ax.set_yticklabels([f"{v:g}" for v in c["y"]["values"]])
        ax.set_xlabel(c["x"]["parameter"] + (" (log spacing)" if c["x"]["scale"] == "log" else ""))
        ax.set_ylabel(c["y"]["parameter"] + (" (log)" if c["y"]["scale"] == "log" else ""))
        ax.tick_params(length=2, pad=1)
        ax.set_title(model, fontsize=rf.FONT_PT + 1, pad=3)
        notes = []
        for k, m in enumerate(materials):
            for label in fit_labels:
                job = fits.get((m, label))
                if job is None:
                    continue
                x, y = fitted_point(c, job)
                if x is None or y is None:
                    continue
                (gx, ox), (gy, oy) = grid_coordinate(c["x"], x), grid_coordinate(c["y"], y)
                colour = rf.OKABE_ITO[k % len(rf.OKABE_ITO)]
                outside = ox or oy
                # Open marks, so the sphere under one stays visible; a shape per material as
                # well as a colour (more materials than the palette has colours). A fit outside
                # the chart's range sits at its edge and says so in the legend.
                ax.plot([gx], [gy], marker=MARKERS[k % len(MARKERS)], markersize=7,
                        linestyle="none", markerfacecolor="none", markeredgecolor=colour,
                        markeredgewidth=1.6,
                        label=f"{m}" + (f" ({label})" if len(fit_labels) > 1 else "")
                        + (" (outside)" if outside else ""))
                notes.append(f"{m}: {c['x']['parameter']} {x:.3g}, {c['y']['parameter']} {y:.3g}"
                             + (" (outside the chart: marked at its edge)" if outside else ""))
        ax.set_xlim(-0.5, nx - 0.5)
        ax.set_ylim(-0.5, ny - 0.5)
        if notes:
            fig.legend(loc="lower center", ncol=3, frameon=False, handletextpad=0.4,
                       handlelength=1.2, columnspacing=0.8, fontsize=rf.FONT_PT - 2,
                       bbox_to_anchor=(0.5, 0.0))
        caption = (f"{model}: spheres over {c['x']['parameter']} x {c['y']['parameter']} under the "
                   f"{manifest.get('lighting', '')} light, one exposure "
                   f"({manifest.get('exposure_stops', 0):g} EV) for every sphere; "
                   f"{c.get('held', '')}. Fitted: " + ("; ".join(notes) if notes else "none") + "."
                   + sweep_sentence(probes, model))
        rf.save_figure(fig, fig_dir, f"chart-{model}", manifest_out, caption)
        figures.append(manifest_out[-1])
    return figures
