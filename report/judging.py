"""The judging set: which image metrics a study's image questions are answered under, and why.

One place holds the human-agreement table (how well each image metric agrees with people judging
renders of BRDF approximations) and the rule that picks the default judging set from it
(docs/studies.md, "Answers under a set of metrics"). A study overrides the set with
`[verdicts] judging = [...]` (study.json `judging`).

The rule: every metric whose Spearman rho point estimate lies inside the 95% CI of the best
metric (closed interval: a rho equal to a bound is inside; where several metrics tie for best,
inside any of their CIs), one per monotone family (PSNR is a per-image decreasing function of
RMSE, so it ranks every pair of images as RMSE does and counts as RMSE; the family keeps its
member of higher rho). The human check cannot tell these metrics apart, so an answer that holds
for one of them and not for another is an answer about the metric, not the models.
"""

# How well each image metric agrees with people judging renders of BRDF approximations against
# the measured material: Spearman rho with the human distance and its 95% bootstrap CI over the
# 57 (material, approximation) pairs of Lavoue, Bonneel, Farrugia, Soler 2021 that
# ../shared/brdf-data holds, as measured by bench/human_agreement.py on 2026-12-04
# (docs/metrics.md, "Human agreement"; rerun it to update these).
HUMAN_AGREEMENT = {"relative_rmse": (0.62, 0.35, 0.79), "ms_ssim": (0.62, 0.41, 0.76),
                   "rmse": (0.55, 0.23, 0.73), "ssim": (0.53, 0.25, 0.70),
                   "psnr": (0.47, 0.13, 0.71), "ciede2000_mean": (0.52, 0.15, 0.76),
                   "delta_e_itp_mean": (0.54, 0.24, 0.72), "flip_ldr_mean": (0.34, -0.06, 0.63),
                   "flip_hdr_mean": (0.54, 0.27, 0.71), "log_rmse": (0.35, -0.02, 0.61),
                   "mae": (0.20, -0.19, 0.52)}

HUMAN_AGREEMENT_SOURCE = ("57 (material, approximation) pairs of Lavoue, Bonneel, Farrugia, "
                          "Soler 2021 (Ngan 2005's Blinn-Phong, Ward and Lafortune fits of 19 "
                          "MERL materials), rendered by shadefit under blender-data's interior "
                          "map; bench/human_agreement.py, docs/metrics.md \"Human agreement\"")

# Metric -> the metric whose per-image monotone function it is (same ranking of any two images).
MONOTONE_FAMILY = {"psnr": "rmse"}

RULE_TEXT = ("The default judging set is every image metric whose Spearman rho with human "
             "judgments lies inside the 95% CI of the best metric's (bounds included), one per "
             "monotone family (PSNR counts as RMSE)")

METRIC_NAMES = {"rmse": "RMSE", "relative_rmse": "relative RMSE", "log_rmse": "log RMSE",
                "mae": "MAE", "psnr": "PSNR", "ssim": "SSIM", "ms_ssim": "MS-SSIM",
                "ciede2000_mean": "mean CIEDE2000", "flip_ldr_mean": "mean LDR-FLIP",
                "flip_hdr_mean": "mean HDR-FLIP", "delta_e_itp_mean": "mean dE_ITP"}


def metric_name(metric):
    return METRIC_NAMES.get(metric, metric)


def default_judging_set(agreement=None, family=None):
    """The metrics the rule picks from `agreement` ({metric: (rho, ci_low, ci_high)}), best
    first (ties in rho kept in the table's order)."""
    agreement = HUMAN_AGREEMENT if agreement is None else agreement
    family = MONOTONE_FAMILY if family is None else family
    top = max(v[0] for v in agreement.values())
    best = [v for v in agreement.values() if v[0] == top]
    inside = [m for m, v in agreement.items() if any(lo <= v[0] <= hi for _, lo, hi in best)]
    inside.sort(key=lambda m: -agreement[m][0])  # stable: ties keep the table's order
    out, seen = [], set()
    for m in inside:
        root = family.get(m, m)
        if root not in seen:
            seen.add(root)
            out.append(m)
    return out


def judging_set(study, columns):
    """(metrics, why): the study's own set where it lists one, else the default set less the
    metrics results.csv has no column for (`columns`), and one line saying which set it is."""
    if study.get("judging"):
        return list(study["judging"]), "the study's own judging set ([verdicts] judging)"
    chosen = default_judging_set()
    missing = [m for m in chosen if m not in columns]
    have = [m for m in chosen if m in columns]
    why = RULE_TEXT + "."
    if missing:
        why += (" Not in this study's results.csv, so left out: "
                + ", ".join(metric_name(m) for m in missing) + ".")
    return have, why


def human_agreement_table(judged):
    """(columns, rows): every measured metric's agreement with human judgments, best first; the
    metrics of the judging set (`judged`) marked."""
    cols = ["metric", "Spearman rho with human distance", "95% CI", "in the judging set"]
    rows = [[metric_name(m), f"{v[0]:.2f}", f"{v[1]:.2f} to {v[2]:.2f}",
             "yes" if m in judged else ""]
            for m, v in sorted(HUMAN_AGREEMENT.items(), key=lambda kv: -kv[1][0])]
    return cols, rows
