"""Figures over the whole study: the mean metric per material and fit, and each comparative
question's errors per material and fit."""

import math
import re

import numpy as np

from report_figures import (COLUMN_IN, FONT_PT, PAGE_IN, bar_style, bars, legend_layout, plt,
                            save_figure, style_of, text_width_in, wrap_to_width)
from report_regions import lightings_of
from report_util import materials_of, rows_by
from results_csv import REGIONS



# Bars per panel above which the train and test panels stack (each the page's width) instead of
# standing side by side: 40 bars in half a page are ~1 mm each.
SIDE_BY_SIDE_BARS = 40


def metric_bars(study, rows, fig_dir, manifest, to_float, metric="flip_ldr_mean"):
    """Mean metric per material and fit, training lighting and test lightings. Laid out in inches
    from the measured texts: the legend on top with as many rows as its names need, the material
    names (vertical) as deep as the longest."""
    materials = materials_of(study)
    labels = [f["label"] for f in study["fits"]]
    stacked = len(labels) * len(materials) > SIDE_BY_SIDE_BARS
    legend_cols, _, legend_in = legend_layout(labels, PAGE_IN - 0.2, handlelength=1.5,
                                              columnspacing=1.5)
    names_in = max([text_width_in(m, FONT_PT - 1) for m in materials], default=0.0) + 0.1
    left_in, title_in, axes_in = 0.55, 0.2, 1.3
    if stacked:
        # Train above test, the material names under the lower panel only (shared x axis).
        height = legend_in + 2 * (title_in + axes_in) + 0.1 + names_in + 0.05
        boxes = [(left_in, names_in + 0.05 + axes_in + title_in + 0.1, PAGE_IN - left_in - 0.1),
                 (left_in, names_in + 0.05, PAGE_IN - left_in - 0.1)]
    else:
        height = legend_in + title_in + axes_in + names_in + 0.05
        half = PAGE_IN / 2
        boxes = [(left_in, names_in + 0.05, half - left_in - 0.1),
                 (half + left_in, names_in + 0.05, half - left_in - 0.1)]
    fig = plt.figure(figsize=(PAGE_IN, height))
    axes = []
    for (x0, y0, w) in boxes:
        axes.append(fig.add_axes([x0 / PAGE_IN, y0 / height, w / PAGE_IN, axes_in / height],
                                 sharex=axes[0] if axes and stacked else None))
    grouped = rows_by(rows, "material", "label", "split")
    for ax, split in zip(axes, ["train", "test"]):
        width = 0.8 / max(1, len(labels))
        x = np.arange(len(materials))
        for i, l in enumerate(labels):
            vals = []
            for m in materials:
                v = [to_float(r[metric]) for r in grouped.get((m, l, split), ())]
                v = [a for a in v if a is not None]
                vals.append(np.mean(v) if v else np.nan)
            bars(ax, x + i * width, vals, width, label=l, **bar_style(i, l))
        ax.set_xticks(x + 0.4 - width / 2)
        ax.set_xlim(-0.3, len(materials) - 0.1)
        if stacked and split == "train":
            ax.tick_params(labelbottom=False)
        else:
            ax.set_xticklabels(materials, rotation=90)
        ax.set_title(f"{split} lightings", fontsize=FONT_PT, pad=3)
        ax.set_ylabel(f"{metric} (lower is better)" if split == "train" or stacked else "")
    fig.legend(*axes[0].get_legend_handles_labels(), loc="upper center", ncol=legend_cols,
               frameon=False, bbox_to_anchor=(0.5, 1.0), handlelength=1.5, columnspacing=1.5)
    save_figure(fig, fig_dir, f"metric-{metric}", manifest,
                f"Mean {metric} per material and fit: training lighting "
                f"({'top' if stacked else 'left'}) and test lightings "
                f"({'bottom' if stacked else 'right'})")


# --- Comparative answers ------------------------------------------------------------------------


def paired_errors_figure(rec, study, fig_dir, manifest, title, y_label):
    """One question's errors: each material's errors per fit as grey lines joining that
    material's fits of one training set, over a box per fit (median, quartiles, whiskers at 1.5
    IQR) of the distribution over materials. Log axis for ratio questions."""
    fits = study["fits"]
    used = set()
    for c in rec["comparisons"]:
        used.update([c.fit, c.baseline])
    order = [f["label"] for f in fits if f["label"] in used]
    if not order:
        return
    groups = {}
    for f in fits:
        if f["label"] in used:
            groups.setdefault(tuple(f["train"]), []).append(f["label"])
    errors = {}
    for r in rec["errors"]:
        e = r["error"]
        if e is not None and math.isfinite(e):
            errors[(r["material"], r["fit"])] = e
    materials = sorted({m for m, _ in errors})
    log = rec["mode"] == "ratio" and all(e > 0 for e in errors.values())
    wide = len(order) > 4
    width = PAGE_IN if wide else COLUMN_IN
    label_in = max(text_width_in(l, FONT_PT - 1) for l in order) + 0.1
    title_lines = wrap_to_width(title, width - 0.2, FONT_PT)
    title_in = 0.16 * (title_lines.count("\n") + 1) + 0.06
    axes_in = 1.7
    height = title_in + axes_in + label_in + 0.1
    left_in = 0.6
    fig = plt.figure(figsize=(width, height))
    ax = fig.add_axes([left_in / width, (label_in + 0.05) / height,
                       (width - left_in - 0.1) / width, axes_in / height])
    x_of = {l: i for i, l in enumerate(order)}
    for labels in groups.values():
        for m in materials:
            pts = [(x_of[l], errors[(m, l)]) for l in labels if (m, l) in errors]
            if len(pts) >= 2:
                ax.plot([p[0] for p in pts], [p[1] for p in pts], color="#999999",
                        linewidth=0.5, alpha=0.7, zorder=1)
    data = [[errors[(m, l)] for m in materials if (m, l) in errors] for l in order]
    keep = [i for i, d in enumerate(data) if d]
    if keep:
        ax.boxplot([data[i] for i in keep], positions=keep, widths=0.45, showfliers=False,
                   patch_artist=True, zorder=2,
                   boxprops={"facecolor": "none", "linewidth": 0.8},
                   medianprops={"color": "black", "linewidth": 1.2},
                   whiskerprops={"linewidth": 0.8}, capprops={"linewidth": 0.8})
    for i, l in enumerate(order):
        ys = [errors[(m, l)] for m in materials if (m, l) in errors]
        ax.scatter([i] * len(ys), ys, s=5, color=style_of(l, [f["label"] for f in fits])["color"],
                   zorder=3, linewidths=0)
    if log:
        ax.set_yscale("log")
    ax.set_xticks(range(len(order)))
    ax.set_xticklabels(order, rotation=90)
    ax.set_xlim(-0.6, len(order) - 0.4)
    ax.set_ylabel(y_label)
    fig.text(0.5, 1 - 0.04 / height, title_lines, ha="center", va="top", fontsize=FONT_PT)
    save_figure(fig, fig_dir, f"compare-{re.sub(r'[^A-Za-z0-9_-]+', '_', rec['name'])}",
                manifest, f"{title}: each material's error per fit (grey lines join a "
                          f"material's fits of one training set) over the distribution per fit "
                          f"(box: quartiles and median; whiskers: 1.5 IQR)"
                          + (" (log axis)" if log else ""),
                {"kind": "comparison", "question": rec["name"]})


def region_figure(means, rec, labels, fig_dir, manifest):
    """One question's regions: a panel per region (rows), lightings along x, a bar per fit of
    its mean |error| with a black tick at its mean signed error."""
    split = rec["split"]
    used = {x for p in rec["comparisons"] for x in (p.fit, p.baseline)}
    fits = [l for l in labels if l in used]
    lightings = lightings_of(means, split)
    if not fits or not lightings:
        return
    cols, _, legend_in = legend_layout(fits, PAGE_IN - 0.2, handlelength=1.5, columnspacing=1.5)
    label_in = max(text_width_in(g, FONT_PT) for g in REGIONS) + 0.55
    panel_in, gap_in = 1.1, 0.3
    height = legend_in + 0.1 + len(REGIONS) * (panel_in + gap_in) + 0.15
    fig = plt.figure(figsize=(PAGE_IN, height))
    width = 0.8 / len(fits)
    x = np.arange(len(lightings))
    for k, g in enumerate(REGIONS):
        y0 = (height - legend_in - 0.1 - (k + 1) * (panel_in + gap_in) + gap_in) / height
        ax = fig.add_axes([label_in / PAGE_IN, y0, 1 - (label_in + 0.1) / PAGE_IN,
                           panel_in / height])
        for i, f in enumerate(fits):
            cells = [means.get((split, l, g, f)) for l in lightings]
            xs = x + (i - (len(fits) - 1) / 2) * width
            bars(ax, xs, [c["abs"] if c else np.nan for c in cells], width,
                 label=f if k == 0 else None, **bar_style(i, f))
            ax.scatter(xs, [c["signed"] if c else np.nan for c in cells], marker="_",
                       color="black", s=30, linewidths=1.0, zorder=3)
        ax.axhline(0, color="#555555", linewidth=0.5)
        ax.set_xticks(x)
        ax.set_xticklabels(lightings if k == len(REGIONS) - 1 else [""] * len(lightings))
        ax.set_ylabel(f"{g}\nluminance error", fontsize=FONT_PT - 1)
    fig.legend(loc="upper center", ncol=cols, frameon=False, bbox_to_anchor=(0.5, 1.0),
               handlelength=1.5, columnspacing=1.5)
    name = f"regions-{re.sub(r'[^A-Za-z0-9_-]+', '_', rec['name'])}"
    save_figure(fig, fig_dir, name, manifest,
                f"{rec['question']}: each fit's mean absolute luminance error (bars) and mean "
                f"signed error (black ticks; above 0: brighter than the reference) per "
                f"{split} lighting and image region (highlight: the reference's brightest 5%; "
                f"rim: n.v < 0.35; body: the rest; measured pixels; mean over materials)",
                {"kind": "regions", "question": rec["name"]})
