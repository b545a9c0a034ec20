"""Probe figures: a probe's curves (one panel per curve kind) or, without curves, its numbers
as grouped bars."""

import collections
import textwrap

import numpy as np
from matplotlib.transforms import Bbox

from report_figures import (COLUMN_IN, FONT_PT, GROUND_SERIES, MATPLOTLIB_3_6, PAGE_IN,
                            bar_style, bars, legend_layout, plt, save_figure, style_of,
                            text_width_in)


# --- Probe curves and bars ----------------------------------------------------------------------

# Lighting shown per probe: one per panel keeps a figure readable (all lightings stay in the JSON
# and the tables). Back light for Fresnel, key light for the highlight shape.
PREFERRED_LIGHTING = {"fresnel": ["rim", "side", "mirror75"], "highlight": ["key", "camera"]}
# The energy probe's sweep (CurveKindName, metrics/probes/src/probe_kind.cpp).
SWEEP_KIND = "sweep of the lobe width"
# Curve kinds drawn on a log y axis whatever the probe says: the sweep spans three decades, and
# the brdf probe's Fresnel rise is a factor over the centre that fits take to 100 or more.
LOG_KINDS = (SWEEP_KIND, "Fresnel rise")

PANELS_PER_ROW = 3


def plot_curve(ax, c, ys, **style):
    """Draws one curve; points flagged "extrapolated" (MERL beyond theta_d = 75 deg) are drawn
    dotted with open markers from the last measured point on, so they are seen, not hidden.
    Returns the handle of the measured part."""
    flags = c.get("extrapolated") or []
    xs = np.array(c["x"], dtype=float)
    if not flags or not any(flags):
        h, = ax.plot(xs, ys, **style)
        return h, None
    flags = np.array(flags, dtype=bool)
    solid = np.where(flags, np.nan, ys)
    h, = ax.plot(xs, solid, **style)
    # The dotted part starts at the last measured point so that the two join.
    joined = flags.copy()
    joined[:-1] |= flags[1:]
    dotted = np.where(joined, ys, np.nan)
    e, = ax.plot(xs, dotted, color=h.get_color(), linestyle=":", linewidth=1.0, marker="o",
                 markersize=2.5, markerfacecolor="white", markeredgewidth=0.6)
    return h, e


def shown_reference(probe, curves):
    """The reference whose curves a panel shows: the first of PREFERRED_LIGHTING's lightings
    for the probe that a curve's reference is of (its `lighting` field), else the first by
    name; None for curves of no reference."""
    lighting = {c["reference"]: c["lighting"] for c in curves if c["reference"]}
    refs = sorted(lighting)
    for want in PREFERRED_LIGHTING.get(probe, []):
        chosen = next((r for r in refs if lighting[r] == want), None)
        if chosen:
            return chosen
    return refs[0] if refs else None


def clip_log_axis(ax):
    """Five decades below the panel's largest value: a specular part that falls to zero (or
    below the floor) would otherwise stretch a log axis over 1e-15."""
    top = max((np.nanmax(l.get_ydata()) for l in ax.get_lines()
               if np.isfinite(l.get_ydata()).any()), default=None)
    if top and top > 0:
        ax.set_ylim(bottom=max(ax.get_ylim()[0], top * 1e-5))


# --- Curve figures kept from one material to the next --------------------------------------------
# A process draws the same probe figures for material after material, and making a figure was a
# quarter of their time: the axes, and on the first drawing their ticks (a brdf figure's five log
# axes make ~200, of five artists each). So a figure of the same layout (probe, panel grid, size)
# is kept and emptied for the next material: its axes keep their ticks, and it draws what a new
# figure would, byte for byte (tests/report/kept_figure_test.py draws both). The measured study's
# 100 probe figures in one process: 23.4-25.9 s made anew, 19.3 s kept. Only probe_figures keeps
# them (it has saved and closed a figure before it asks for the next). Emptying sets matplotlib's
# own state (a title's automatic placement): under matplotlib 3.6 only, as the report's other
# shortcuts (report_figures); any other version makes every figure anew.
KEEP_FIGURES = MATPLOTLIB_3_6
_KEPT_AT_MOST = 8  # layouts per process (a study has one per probe)
_kept = collections.OrderedDict()  # layout -> (figure, each axes' first _autotitlepos)


def _empty(fig, width, height, titlepos):
    """`fig` as plt.figure(figsize=(width, height)) followed by the same add_axes calls left it:
    no data, lines, legend or scale, the limits and autoscaling of a new axes, the title placed
    by matplotlib again (save_figure fixes it after drawing); the axes and their ticks kept."""
    for legend in list(fig.legends):
        legend.remove()
    fig.set_size_inches(width, height)  # save_figure rounds it to whole pixels
    for ax, pos in zip(fig.axes, titlepos):
        for artist in (list(ax.lines) + list(ax.collections) + list(ax.patches) + list(ax.texts)
                       + list(ax.images)):
            artist.remove()
        ax.set_xscale("linear")
        ax.set_yscale("linear")
        # A new axes' data and view limits: a null box (its smallest positive value too, which a
        # log axis without data would read), the unit box, both autoscaled.
        ax.dataLim = Bbox.null()
        ax.ignore_existing_data_limits = True
        ax.set_xlim(0.0, 1.0)
        ax.set_ylim(0.0, 1.0)
        ax.set_autoscale_on(True)
        ax.set_title("")
        ax.set_xlabel("")
        ax.set_ylabel("")
        ax._autotitlepos = pos


def _curve_figure(layout, width, height, rects, keep):
    """A figure of `width` x `height` in with an axes at each of `rects` (figure fractions):
    with `keep`, the last figure of this `layout` emptied where there was one, and kept for the
    next; else new."""
    kept = _kept.pop(layout, None) if keep else None
    if kept is not None:
        fig, titlepos = kept
        _empty(fig, width, height, titlepos)
    else:
        fig = plt.figure(figsize=(width, height))
        for rect in rects:
            fig.add_axes(rect)
        titlepos = [ax._autotitlepos for ax in fig.axes]
    if keep:
        _kept[layout] = (fig, titlepos)
        while len(_kept) > _KEPT_AT_MOST:
            _kept.popitem(last=False)
    return fig


def probe_curve_figure(probe, material, curves, labels, keep=False):
    """One panel per curve kind, in the order the probe measured them, PANELS_PER_ROW to a row;
    per-reference curves show one reference (PREFERRED_LIGHTING). `curves`: the probe's curve
    records, {"series", "reference", "kind", "x", "y", "x_label", "y_label", "x_scale",
    "y_scale", "extrapolated" (optional)} (ProbeResultToJson, docs/probes.md). `keep`: the
    figure may be the last one of its layout, emptied (the caller is done with that one), and is
    kept for the next (KEEP_FIGURES)."""
    curves = [c for c in curves if c["x"] and len(c["x"]) == len(c["y"])]
    if not curves:
        return None
    kinds = []
    for c in curves:
        if c["kind"] not in kinds:
            kinds.append(c["kind"])
    n = len(kinds)
    cols = min(n, PANELS_PER_ROW)
    rows = (n + cols - 1) // cols
    width = COLUMN_IN if n == 1 else PAGE_IN
    panel_h = 1.9 if rows == 1 else 2.15  # a second row leaves room for the first's x label
    # The legend holds every series and an "extrapolated" entry per series with flagged points,
    # at most three to a row, fewer where the names are too long for the width.
    entries = sorted({c["series"] for c in curves}) + sorted(
        {c["series"] + ", extrapolated" for c in curves if any(c.get("extrapolated") or [])})
    legend_cols, _, legend_in = legend_layout(entries, width, max_cols=3)
    legend_h = max(0.55, legend_in + 0.12)
    height = rows * panel_h + legend_h + 0.25
    label_chars = 40 if cols < 3 else 30
    rects = []
    for k_i in range(n):
        row, col = divmod(k_i, cols)
        left_in = 0.72  # Room for a two-line axis label and its tick labels.
        bottom_in = legend_h + 0.3 + (rows - 1 - row) * panel_h
        rects.append([(left_in + col * width / cols) / width, bottom_in / height,
                      (width / cols - left_in - 0.2) / width, (1.9 - 0.45) / height])
    fig = _curve_figure((probe, tuple(tuple(r) for r in rects), width, height), width, height,
                        rects, keep)
    handles, series_of = {}, {}  # legend entry -> its handle, and the series it belongs to
    series = sorted({c["series"] for c in curves if c["series"] not in GROUND_SERIES},
                    key=lambda x: (labels.index(x) if x in labels else len(labels), x))
    for kind, ax in zip(kinds, fig.axes):
        # Fits in the study's order, the ground truth (dashed black) last, on top of them.
        items = sorted((c for c in curves if c["kind"] == kind), key=lambda c: (
            c["series"] in GROUND_SERIES,
            series.index(c["series"]) if c["series"] in series else len(series)))
        chosen = shown_reference(probe, items)
        for c in items:
            lab, ref = c["series"], c["reference"]
            if ref and ref != chosen:
                continue
            ys = np.array([np.nan if y is None else y for y in c["y"]], dtype=float)
            if lab in GROUND_SERIES:
                h, e = plot_curve(ax, c, ys, color="black", linestyle=(0, (2, 1)), linewidth=1.4,
                                  label=lab)
            else:
                h, e = plot_curve(ax, c, ys, linewidth=1.1, label=lab, **style_of(lab, series))
            handles.setdefault(lab, h)
            series_of.setdefault(lab, lab)
            if e is not None:
                handles.setdefault(f"{lab}, extrapolated", e)
                series_of.setdefault(f"{lab}, extrapolated", lab)
            ax.set_xlabel(textwrap.fill(c["x_label"], label_chars))
            ax.set_ylabel(textwrap.fill(c["y_label"], 26))
            # The highlight falloff and the energy sweep span decades: log y for both.
            if c["y_scale"] == "log" or probe == "highlight" or kind in LOG_KINDS:
                ax.set_yscale("log")
            if c["x_scale"] == "log":
                ax.set_xscale("log")
        if ax.get_yscale() == "log":
            clip_log_axis(ax)
        title = kind + (f" ({chosen})" if chosen else "")
        ax.set_title(title if len(title) < 48 else title[:45] + "...", fontsize=FONT_PT)

    def legend_order(name):  # ground truth first, then the fits in the study's order
        base = series_of[name]
        return (base not in GROUND_SERIES, series.index(base) if base in series else -1, name)
    names = sorted(handles, key=legend_order)
    fig.legend([handles[x] for x in names], names, loc="lower center", ncol=legend_cols,
               frameon=False, bbox_to_anchor=(0.5, 0.0))
    fig.suptitle(f"{material}: {probe}", fontsize=FONT_PT + 1, y=0.99)
    return fig

def probe_bar_figure(probe, material, numbers, flatten, labels=()):
    """Grouped bars of a probe's numbers: the ground truth first, then the fits in the study's
    order (`labels`). Laid out in inches from top to bottom: title, legend (as many rows as its
    names need), axes, the vertical key labels (as deep as the longest)."""
    series = sorted(numbers.keys(), key=lambda x: (
        x not in GROUND_SERIES, labels.index(x) if x in labels else len(labels), x))
    keys = []
    for s in series:
        keys += [k for k in flatten(numbers[s]) if k not in keys]
    keys = keys[:12]
    # Upright-box labels: vertical text, the material's name dropped from per-reference keys.
    short = [k.replace(material + "-", "") for k in keys]
    short = [k if len(k) < 30 else k[:27] + "..." for k in short]
    legend_cols, _, legend_in = legend_layout(series, PAGE_IN - 0.2, handlelength=1.5,
                                              columnspacing=1.5)
    title_in, axes_in = 0.25, 1.3
    ticks_in = max([text_width_in(k, FONT_PT - 2) for k in short], default=0.0) + 0.12
    height = title_in + legend_in + 0.08 + axes_in + ticks_in + 0.05
    fig = plt.figure(figsize=(PAGE_IN, height))
    ax = fig.add_axes([0.6 / PAGE_IN, (ticks_in + 0.05) / height, (PAGE_IN - 0.75) / PAGE_IN,
                       axes_in / height])
    if not keys or not series:
        ax.text(0.5, 0.5, "no numbers reported", ha="center", transform=ax.transAxes)
    else:
        width = 0.8 / len(series)
        x = np.arange(len(keys))
        for i, s in enumerate(series):
            f = flatten(numbers[s])
            # The fit's place in the study picks its fill, as in the other bar figure.
            bars(ax, x + i * width, [f.get(k, np.nan) for k in keys], width, label=s,
                 **bar_style(labels.index(s) if s in labels else i, s))
        ax.set_xticks(x + 0.4 - width / 2)
        ax.set_xticklabels(short, rotation=90, fontsize=FONT_PT - 2)
        fig.legend(*ax.get_legend_handles_labels(), frameon=False, ncol=legend_cols,
                   loc="upper center", bbox_to_anchor=(0.5, 1 - title_in / height),
                   handlelength=1.5, columnspacing=1.5)
    fig.suptitle(f"{material}: {probe}", fontsize=FONT_PT + 1, y=1 - 0.03 / height, va="top")
    return fig


def probe_figures(study, probes, fig_dir, manifest, flatten):
    labels = [f["label"] for f in study["fits"]]
    for material, job in sorted(probes.items()):
        for probe, result in job["probes"].items():
            curves = result["curves"]
            fig = None
            if probe != "portability" and curves:
                fig = probe_curve_figure(probe, material, curves, labels, keep=KEEP_FIGURES)
            if fig is None:
                fig = probe_bar_figure(probe, material, result["numbers"], flatten,
                                       labels)
            save_figure(fig, fig_dir, f"probe-{probe}-{material}", manifest,
                        f"{material}: {probe} probe (reference or measured BRDF dashed black; "
                        "extrapolated points dotted, open markers)")
