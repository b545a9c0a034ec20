"""Where the difference lies: each fit's error per lighting and image region (docs/studies.md,
"Regions").

results.csv carries, per row and region (highlight: the reference's brightest 5% of covered
pixels; rim: n.v < 0.35; body: the rest; measured pixels only), the mean signed luminance error
(fit - reference), the mean absolute one, the mean reference luminance and the pixel count.
Here they are averaged over the materials per (split, lighting, region, fit); per compared pair
of an image question, a sentence names the lighting and region where the fit's absolute error
exceeds the baseline's most and whether the fit is brighter or darker than the reference there;
one figure per question shows every fit's errors per lighting and region.
"""

import re

import numpy as np

from report_figures import (FONT_PT, PAGE_IN, bar_style, legend_layout, plt, save_figure,
                            text_width_in)
from results_csv import REGIONS

QUANTITIES = ("signed", "abs", "ref")


def region_means(rows, to_float):
    """{(split, lighting, region, label): {signed, abs, ref, materials}}: means over the
    materials; None where results.csv has no region columns."""
    if not rows or f"region_{REGIONS[0]}_abs" not in rows[0]:
        return None
    acc = {}
    for r in rows:
        for g in REGIONS:
            vals = {q: to_float(r.get(f"region_{g}_{q}")) for q in QUANTITIES}
            pixels = to_float(r.get(f"region_{g}_pixels"))
            if any(v is None for v in vals.values()) or not pixels:
                continue
            cell = acc.setdefault((r["split"], r["lighting"], g, r["label"]), [])
            cell.append(vals)
    return {k: {q: float(np.mean([v[q] for v in cells])) for q in QUANTITIES}
            | {"materials": len(cells)} for k, cells in acc.items()}


def lightings_of(means, split):
    return sorted({k[1] for k in means if k[0] == split})


def extra_error(means, split, fit, base):
    """(lighting, region, fit cell, baseline cell) where fit's mean |error| exceeds the
    baseline's most, or None where it exceeds it nowhere."""
    best, where = 0.0, None
    for l in lightings_of(means, split):
        for g in REGIONS:
            a, b = means.get((split, l, g, fit)), means.get((split, l, g, base))
            if a is not None and b is not None and a["abs"] - b["abs"] > best:
                best, where = a["abs"] - b["abs"], (l, g, a, b)
    return where


def region_sentence(means, split, pair):
    fit, base = pair["fit"], pair["baseline"]
    where = extra_error(means, split, fit, base)
    if where is None:
        return (f"{fit}'s mean absolute error is not larger than {base}'s in any region of the "
                f"{split} lightings")
    l, g, a, b = where
    side = "brighter" if a["signed"] > 0 else "darker"
    return (f"{fit}'s largest extra error over {base} is under {l} in the {g}: it is {side} "
            f"than the reference there (mean signed {a['signed']:+.3g}, mean |error| "
            f"{a['abs']:.3g}; {base}: {b['signed']:+.3g}, {b['abs']:.3g}; reference mean "
            f"{a['ref']:.3g}, luminance over {a['materials']} materials)")


def region_lines(means, records):
    """List items (depth, text): per image question, a sentence per compared pair."""
    if means is None:
        return []
    lines = []
    for rec in (r for r in records if r["source"] == "metrics" and r["comparisons"]):
        lines.append((0, f"**{rec['question']}**"))
        lines += [(1, f"{region_sentence(means, rec['split'], p)}.") for p in rec["comparisons"]]
    return lines


def region_table(means):
    cols = ["split", "lighting", "region", "fit", "materials", "mean signed error",
            "mean |error|", "reference mean"]
    rows = [[s, l, g, f, str(v["materials"]), f"{v['signed']:+.3g}", f"{v['abs']:.3g}",
             f"{v['ref']:.3g}"] for (s, l, g, f), v in sorted(means.items())]
    return cols, rows


def region_figure(means, rec, labels, fig_dir, manifest):
    """One question's regions: a panel per region (rows), lightings along x, a bar per fit of
    its mean |error| with a black tick at its mean signed error."""
    split = rec["split"]
    used = {x for p in rec["comparisons"] for x in (p["fit"], p["baseline"])}
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
            ax.bar(xs, [c["abs"] if c else np.nan for c in cells], width,
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
