"""Where the difference lies: each fit's error per lighting and image region (docs/studies.md,
"Regions").

results.csv carries, per row and region (highlight: the reference's brightest 5% of covered
pixels; rim: n.v < 0.35; body: the rest; measured pixels only), the mean signed luminance error
(fit - reference), the mean absolute one, the mean reference luminance and the pixel count.
Here they are averaged over the materials per (split, lighting, region, fit); per compared pair
of an image question, a sentence names the lighting and region where the fit's absolute error
exceeds the baseline's most and whether the fit is brighter or darker than the reference there
(its words: section_words.region_sentence); one figure per question shows every fit's errors per
lighting and region (report_metric_figures.region_figure). This module computes only.
"""

import numpy as np

from report_records import RegionMean
from results_csv import REGIONS

QUANTITIES = ("signed", "abs", "ref")


def region_means(rows, to_float):
    """{(split, lighting, region, label): RegionMean}: means over the materials; None where
    results.csv has no region columns."""
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
    return {k: RegionMean(**{q: float(np.mean([v[q] for v in cells])) for q in QUANTITIES},
                          materials=len(cells)) for k, cells in acc.items()}


def lightings_of(means, split):
    return sorted({k[1] for k in means if k[0] == split})


def extra_error(means, split, fit, base):
    """(lighting, region, fit cell, baseline cell) where fit's mean |error| exceeds the
    baseline's most, or None where it exceeds it nowhere."""
    best, where = 0.0, None
    for l in lightings_of(means, split):
        for g in REGIONS:
            a, b = means.get((split, l, g, fit)), means.get((split, l, g, base))
            if a is not None and b is not None and a.abs - b.abs > best:
                best, where = a.abs - b.abs, (l, g, a, b)
    return where
