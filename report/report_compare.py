"""Comparative answers: for every question of a study, each material's continuous error per fit,
compared between fits over the materials (docs/studies.md, "Comparative answers").

A pass count at a fixed tolerance says nothing about which of two models is closer when neither
passes. Here every question gets, for each fit against the study's baseline fit (and each pair
the study asks for): the median error per fit with its interquartile range, the paired ratio of
errors (geometric mean of the per-material ratios; a mean difference where an error can be 0)
with a bootstrap 95% confidence interval over materials, on how many materials each fit is
closer, and a paired test (Wilcoxon signed-rank; an exact sign test when fewer than
SIGN_TEST_BELOW materials differ) whose p-values are corrected with Holm's step-down method over
the study's questions (one family per compared pair). The statistics are scipy's and statsmodels' (Debian python3-scipy,
python3-statsmodels); nothing here is a hand-written statistic.

Called by make_report.py; reads only the records make_report.py hands it.
"""

import math
import warnings

import numpy as np
from scipy import stats
from statsmodels.stats.multitest import multipletests

BOOTSTRAP_RESAMPLES = 10000
BOOTSTRAP_SEED = 20261204  # Fixed: a rerun of the report writes the same numbers.
SIGN_TEST_BELOW = 6        # Fewer non-tied materials than this: the exact sign test (the
                           # exact signed-rank test cannot reach p < 0.05 below 6 pairs).
MIN_MATERIALS_FOR_CI = 3   # Two materials give no meaningful interval.

# Image metrics whose larger value is better: their error is 1 - value (SSIM family) or the
# difference is taken the other way round (PSNR, in dB).
SIMILARITY_METRICS = {"ssim", "ms_ssim"}
HIGHER_IS_BETTER_DB = {"psnr"}

METRIC_NAMES = {"rmse": "RMSE", "relative_rmse": "relative RMSE", "log_rmse": "log RMSE",
                "mae": "MAE", "psnr": "PSNR", "ssim": "SSIM", "ms_ssim": "MS-SSIM",
                "ciede2000_mean": "mean CIEDE2000", "flip_ldr_mean": "mean LDR-FLIP",
                "flip_hdr_mean": "mean HDR-FLIP", "delta_e_itp_mean": "mean dE_ITP"}

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

# The metric of the default questions of a study without metric verdicts (item 5 of the issue):
# relative RMSE is scale-free, so materials of any albedo weigh alike.
DEFAULT_METRIC = "relative_rmse"

# Probes that do not measure what they claim on some kinds of reference: (source, kind) -> why.
# A verdict or comparison of that probe on such a reference reads "n/a" with the reason.
NOT_VALID = {
    ("fresnel", "measured"):
        "the image-space Fresnel probe splits a measured reference into diffuse and specular by "
        "a fit, which gives negative rim/centre ratios on measured BRDFs; see the BRDF-space "
        "Fresnel probe (brdf_fresnel)",
    ("highlight", "measured"):
        "the image-space lobe probe reads the highlight off the same fitted split, not valid on "
        "measured references; see the BRDF-space highlight probe (brdf_highlight)",
}


def reference_kind(study, material):
    """"measured" for a [[measured]] material (rendered from a measured BRDF), else "image"."""
    for src in study["measured"]:
        if material in src["materials"]:
            return "measured"
    return "image"


def not_valid_reason(study, source, material):
    return NOT_VALID.get((source, reference_kind(study, material)))


# ------------------------------------------------------------------------------------------------
# Questions and each material's continuous error


def questions_of(study, rows):
    """The study's questions: every verdict, then the default questions a study without metric
    verdicts still answers (image closeness on the training lightings; the error under new
    lightings, when there are test lightings). Each is a dict with the verdict's fields plus
    `name` and `default` (True for the added ones, which have no tolerance)."""
    out = []
    for name, v in study["verdicts"].items():
        out.append(dict(v, name=name, default=False))
    splits = {r["split"] for r in rows}
    has = {q.get("split") for q in out if q["source"] == "metrics"}
    if "train" not in has and "train" in splits:
        out.append({"name": "image", "default": True, "source": "metrics", "split": "train",
                    "metric": DEFAULT_METRIC, "kind": "max",
                    "question": "How close can the model get to a reference image "
                                "(training lighting)?"})
    if "test" not in has and "test" in splits:
        out.append({"name": "transfer", "default": True, "source": "metrics", "split": "test",
                    "metric": DEFAULT_METRIC, "kind": "max",
                    "question": "Do fitted parameters carry over to new lighting (image error "
                                "under test lightings)?"})
    # Reading order: image closeness, new lighting, then the phenomena (BRDF space first: on
    # measured references it is where the lobe and the Fresnel rise are measured).
    rank = {("metrics", "train"): 0, ("metrics", "test"): 1, ("brdf", None): 2,
            ("highlight", None): 3, ("fresnel", None): 4, ("energy", None): 5}
    return sorted(out, key=lambda q: rank.get(
        (q["source"], q.get("split") if q["source"] == "metrics" else None), 6))


def metric_mode(metric):
    if metric in HIGHER_IS_BETTER_DB:
        return "difference"
    return "ratio"


def metric_error(metric, values):
    """A fit's error on one material: the mean of `metric` over its lightings of the split,
    oriented so that smaller is better."""
    mean = float(np.mean(values))
    if metric in SIMILARITY_METRICS:
        return 1.0 - mean
    if metric in HIGHER_IS_BETTER_DB:
        return -mean
    return mean


def material_errors(study, rows, summary, question, to_float, column=None):
    """{(material, label): error or None} and {(material, label): why n/a} for one question.
    Metrics: the mean of the metric over the fit's lightings of the split (`column` overrides
    the results.csv column, e.g. the all-pixel one). Probes: the verdict's worst-quantity error
    (what the tolerance bounds); a `max` verdict of a probe (energy) becomes the excess over its
    bound, 0 when within."""
    errors, why = {}, {}
    labels = [f["label"] for f in study["fits"]]
    materials = [g["material"] for g in study["groups"]]
    source = question["source"]
    for m in materials:
        reason = not_valid_reason(study, source, m)
        for label in labels:
            if reason:
                errors[(m, label)], why[(m, label)] = None, reason
                continue
            if source == "metrics":
                col = column or question["metric"]
                vals = [to_float(r.get(col)) for r in rows
                        if r["material"] == m and r["label"] == label
                        and r["split"] == question["split"]]
                vals = [x for x in vals if x is not None]
                errors[(m, label)] = metric_error(question["metric"], vals) if vals else None
                continue
            s = next((s for s in summary if s["phenomenon"] == question["name"]
                      and s["material"] == m and s["fit"] == label), None)
            if s is None or s["error"] is None:
                errors[(m, label)] = None
            elif question["kind"] == "max":
                errors[(m, label)] = max(0.0, s["error"] - float(question["tolerance"]))
            else:
                errors[(m, label)] = s["error"]
    return errors, why


def question_mode(question):
    if question["source"] == "metrics":
        return metric_mode(question["metric"])
    return "difference" if question["kind"] == "max" else "ratio"


# ------------------------------------------------------------------------------------------------
# Pairs


def comparison_pairs(study):
    """(label, baseline label) pairs: every fit against the baseline model's fit of the same
    training set, then the study's `compare` pairs (per training set)."""
    fits = study["fits"]
    baseline = study["baseline"] or (fits[0]["model"] if fits else None)
    by_train = {}
    for f in fits:
        by_train.setdefault(tuple(f["train"]), {})[f["model"]] = f["label"]
    pairs = []
    for train, models in by_train.items():
        base = models.get(baseline)
        if base is None:
            continue
        pairs += [(label, base) for model, label in models.items() if model != baseline]
    for a, b in study["compare"]:
        for train, models in by_train.items():
            if a in models and b in models and (models[a], models[b]) not in pairs:
                pairs.append((models[a], models[b]))
    return pairs


# ------------------------------------------------------------------------------------------------
# Statistics of one pair on one question


def _bootstrap_ci(values):
    """95% bootstrap interval of the mean of `values` (materials resampled; BCa, or the
    percentile interval where BCa is undefined). Constant values: the value itself."""
    values = np.asarray(values, dtype=float)
    if len(values) < MIN_MATERIALS_FOR_CI:
        return None, None
    if np.ptp(values) == 0:
        return float(values[0]), float(values[0])
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    for method in ("BCa", "percentile"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = stats.bootstrap((values,), np.mean, n_resamples=BOOTSTRAP_RESAMPLES,
                                  confidence_level=0.95, method=method, random_state=rng)
        lo, hi = res.confidence_interval
        if np.isfinite(lo) and np.isfinite(hi):
            return float(lo), float(hi)
    return None, None


def paired_test(x):
    """(p, test name) for paired values x (log ratios or differences; 0 = no difference): the
    Wilcoxon signed-rank test (zeros dropped), or the exact sign test when fewer than
    SIGN_TEST_BELOW are non-zero; p = 1 when every pair is tied (no evidence either way)."""
    x = np.asarray(x, dtype=float)
    nonzero = x[x != 0]
    if len(nonzero) == 0:
        return 1.0, "all tied"
    if len(nonzero) < SIGN_TEST_BELOW:
        wins = int(np.sum(nonzero > 0))
        return float(stats.binomtest(wins, len(nonzero), 0.5).pvalue), "sign test"
    return float(stats.wilcoxon(nonzero, zero_method="wilcox").pvalue), "Wilcoxon"


def quartiles(values):
    q1, med, q3 = np.percentile(np.asarray(values, dtype=float), [25, 50, 75])
    return float(med), float(q1), float(q3)


def compare_pair(errors, materials, label, base, mode):
    """The comparison of fit `label` with `base` over the materials where both have an error."""
    a, b, used = [], [], []
    for m in materials:
        ea, eb = errors.get((m, label)), errors.get((m, base))
        if ea is None or eb is None or not (math.isfinite(ea) and math.isfinite(eb)):
            continue
        a.append(ea)
        b.append(eb)
        used.append(m)
    n = len(used)
    if n == 0:
        return None
    a, b = np.asarray(a), np.asarray(b)
    if mode == "ratio" and not (np.all(a > 0) and np.all(b > 0)):
        mode = "difference"  # An error of 0 has no ratio.
    if mode == "ratio":
        x = np.log(b / a)  # > 0: `label` is closer.
        effect = float(np.exp(np.mean(x)))
        lo, hi = _bootstrap_ci(x)
        ci = (None, None) if lo is None else (math.exp(lo), math.exp(hi))
    else:
        x = b - a
        effect = float(np.mean(x))
        ci = _bootstrap_ci(x)
    p, test = paired_test(x)
    return {"fit": label, "baseline": base, "materials": used, "n": n, "mode": mode,
            "effect": effect, "ci": list(ci), "closer": int(np.sum(a < b)),
            "farther": int(np.sum(a > b)), "tied": int(np.sum(a == b)), "p": p, "test": test,
            "fit_quartiles": quartiles(a), "baseline_quartiles": quartiles(b),
            "errors": {m: [float(ea), float(eb)] for m, ea, eb in zip(used, a, b)}}


def compare_study(study, rows, summary, to_float):
    """Every question's comparisons, Holm-corrected per pair over the questions. Returns a
    list of question records: {name, question, default, metric?, mode, errors, na, comparisons,
    all_pixels?}."""
    materials = [g["material"] for g in study["groups"]]
    pairs = comparison_pairs(study)
    records = []
    for q in questions_of(study, rows):
        errors, why = material_errors(study, rows, summary, q, to_float)
        mode = question_mode(q)
        comparisons = [c for c in (compare_pair(errors, materials, l, b, mode)
                                   for l, b in pairs) if c is not None]
        what = "error"
        if q["source"] != "metrics" and q["kind"] == "max":
            what = f"excess over the bound {float(q['tolerance']):g}"
        elif q["source"] == "metrics" and q["metric"] in HIGHER_IS_BETTER_DB:
            what = "PSNR deficit [dB]"
        for c in comparisons:
            c["what"] = what
        rec = {"name": q["name"], "question": q.get("question", q["name"]),
               "default": q["default"], "source": q["source"], "metric": q.get("metric"),
               "split": q.get("split"), "mode": mode, "n_a": sorted(set(why.values())),
               "errors": [{"material": m, "fit": l, "error": e} for (m, l), e in errors.items()],
               "comparisons": comparisons}
        # Measured references: the metrics above are over measured pixels; the same comparison
        # over every pixel (extrapolated data included) is printed beside it.
        all_col = f"{q.get('metric')}_all"
        if q["source"] == "metrics" and rows and all_col in rows[0]:
            all_errors, _ = material_errors(study, rows, summary, q, to_float, column=all_col)
            if any(all_errors.get(k) != errors.get(k) for k in errors):
                rec["all_pixels"] = [c for c in (compare_pair(all_errors, materials, l, b, mode)
                                                 for l, b in pairs) if c is not None]
        records.append(rec)
    # Holm across the study's questions: one family per compared pair (a sentence is one pair
    # on one question; the family is every question the study asks of that pair).
    families = {}
    for r in records:
        for c in r["comparisons"]:
            families.setdefault((c["fit"], c["baseline"]), []).append(c)
    for tests in families.values():
        adjusted = multipletests([c["p"] for c in tests], method="holm")[1]
        for c, p in zip(tests, adjusted):
            c["p_holm"] = float(p)
            c["holm_family"] = len(tests)
    return records


# ------------------------------------------------------------------------------------------------
# Words


def fmt_p(p):
    if p is None:
        return "n/a"
    if p >= 0.001:
        return f"{p:.2g}"
    mant, exp = f"{p:.0e}".split("e")
    return f"{mant}e{int(exp)}"


def fmt_effect(v):
    return f"{v:.3g}" if abs(v) < 1000 else f"{v:.0f}"


def effect_parts(c):
    """('2.3x smaller than blinn-phong's', '95% CI 1.8-3.0') and the like: how the fit's error
    stands to the baseline's, and its interval in the same direction."""
    lo, hi = c["ci"]
    none = "no CI: fewer than 3 materials"
    if c["mode"] == "ratio":
        r = c["effect"]
        prefix, ci = "", (lo, hi)
        if 0.995 <= r <= 1.005:
            words, prefix = "within 0.5% of", "ratio "
        elif r >= 1:
            words = f"{fmt_effect(r)}x smaller than"
        else:
            words, ci = f"{fmt_effect(1 / r)}x larger than", (None, None) if lo is None else (1 / hi, 1 / lo)
        ci_text = none if ci[0] is None else f"{prefix}95% CI {fmt_effect(ci[0])}-{fmt_effect(ci[1])}"
        return f"{words} {c['baseline']}'s", ci_text
    d = c["effect"]
    # The interval in the sentence's own direction: of how much lower (or higher).
    lo_s, hi_s = (lo, hi) if d >= 0 else (None if hi is None else -hi, None if lo is None else -lo)
    ci_text = none if lo is None else f"95% CI {lo_s + 0.0:.3g} to {hi_s + 0.0:.3g}"  # no "-0"
    side = "lower" if d >= 0 else "higher"
    return f"{side} than {c['baseline']}'s by {abs(d):.3g} on average", ci_text


def effect_words(c):
    """'ggx's error is 2.3x smaller than blinn-phong's (95% CI 1.8-3.0)' and the like."""
    relation, ci_text = effect_parts(c)
    return f"{c['fit']}'s {c.get('what', 'error')} is {relation} ({ci_text})"


def sentence(rec, c):
    if c["test"] == "all tied":
        return (f"{c['fit']}'s {c.get('what', 'error')} equals {c['baseline']}'s on every one of "
                f"the {c['n']} materials (p = 1)")
    test = {"Wilcoxon": "Wilcoxon", "sign test": "exact sign test"}[c["test"]]
    return (f"{effect_words(c)}; {c['fit']} is closer on {c['closer']} of {c['n']} materials "
            f"({test} p = {fmt_p(c.get('p_holm', c['p']))}, Holm)")


def question_title(rec):
    if rec["source"] == "metrics":
        metric = METRIC_NAMES.get(rec["metric"], rec["metric"])
        return f"{rec['question']} [{metric}]"
    return rec["question"]


def error_label(rec):
    """The y axis of a question's figure: what its error is."""
    if rec["source"] == "metrics":
        m = rec["metric"]
        name = METRIC_NAMES.get(m, m)
        if m in SIMILARITY_METRICS:
            return f"1 - {name} ({rec['split']})"
        if m in HIGHER_IS_BETTER_DB:
            return f"-{name} [dB] ({rec['split']})"
        return f"{name} ({rec['split']} lightings)"
    if rec["mode"] == "difference":
        return "excess over the bound"
    return "largest relative error"


def human_agreement_table(records):
    """(columns, rows): how well each image metric of the study's questions, and every other one
    measured, agrees with human judgments (HUMAN_AGREEMENT), best first; the metrics the study's
    questions judge by are marked."""
    used = {r["metric"] for r in records if r["source"] == "metrics"}
    cols = ["metric", "Spearman rho with human distance", "95% CI", "judges a question here"]
    rows = [[METRIC_NAMES.get(m, m), f"{v[0]:.2f}", f"{v[1]:.2f} to {v[2]:.2f}",
             "yes" if m in used else ""]
            for m, v in sorted(HUMAN_AGREEMENT.items(), key=lambda kv: -kv[1][0])]
    return cols, rows


HUMAN_AGREEMENT_SOURCE = ("57 (material, approximation) pairs of Lavoue, Bonneel, Farrugia, "
                          "Soler 2021 (Ngan 2005's Blinn-Phong, Ward and Lafortune fits of 19 "
                          "MERL materials), rendered by shadefit under blender-data's interior "
                          "map; bench/human_agreement.py, docs/metrics.md \"Human agreement\"")


def answer_lines(records):
    """Markdown: each question, then one sentence per comparison."""
    lines = []
    for rec in records:
        lines.append(f"- **{question_title(rec)}**" + (" (default question)" if rec["default"] else ""))
        agree = HUMAN_AGREEMENT.get(rec.get("metric")) if rec["source"] == "metrics" else None
        if agree:
            lines.append(f"  - Judged by {METRIC_NAMES.get(rec['metric'], rec['metric'])}, which "
                         f"agrees with human judgments of BRDF approximations at Spearman rho = "
                         f"{agree[0]:.2f} (95% CI {agree[1]:.2f} to {agree[2]:.2f}; Lavoue et al. "
                         f"2021 data, docs/metrics.md \"Human agreement\")")
        if rec["n_a"] and not rec["comparisons"]:
            lines.append(f"  - n/a: {rec['n_a'][0]}")
            continue
        if not rec["comparisons"]:
            lines.append("  - no fit pair has numbers on this question")
        for c in rec["comparisons"]:
            extra = ""
            alls = {(a["fit"], a["baseline"]): a for a in rec.get("all_pixels", [])}
            a = alls.get((c["fit"], c["baseline"]))
            if a is not None:
                extra = (f" [all pixels, extrapolated data included: "
                         f"{effect_parts(a)[0]}, closer on "
                         f"{a['closer']} of {a['n']}]")
            lines.append(f"  - {sentence(rec, c)}.{extra}")
        if rec["n_a"]:
            lines.append(f"  - n/a on some materials: {'; '.join(rec['n_a'])}")
    return lines


def comparison_table(records, fmt):
    """(columns, rows) of every comparison, for tables/comparisons.{csv,md,tex}. Errors as the
    comparison uses them: smaller is better (1 - SSIM for the SSIM family, -PSNR for PSNR)."""
    cols = ["question", "fit", "baseline", "materials", "fit error median [IQR]",
            "baseline error median [IQR]", "effect", "95% CI", "closer", "test", "p",
            "p (Holm)"]
    out = []
    for rec in records:
        for c in rec["comparisons"]:
            def med(q):
                return f"{fmt(q[0])} [{fmt(q[1])}, {fmt(q[2])}]"
            lo, hi = c["ci"]
            effect = (f"{c['effect']:.3g}x" if c["mode"] == "ratio" else f"{c['effect']:+.3g}")
            ci = "" if lo is None else (f"{lo:.3g}-{hi:.3g}" if c["mode"] == "ratio"
                                        else f"{lo:+.3g} to {hi:+.3g}")
            out.append([rec["name"], c["fit"], c["baseline"], str(c["n"]),
                        med(c["fit_quartiles"]), med(c["baseline_quartiles"]), effect, ci,
                        f"{c['closer']}/{c['n']}", c["test"], fmt_p(c["p"]),
                        fmt_p(c.get("p_holm"))])
    return cols, out


def method_text(records):
    """How the answers are computed, in one paragraph (summary.md and index.html)."""
    questions = sum(1 for r in records if r["comparisons"])
    return ("Every fit is compared with the baseline fit of its training set over the "
            "materials, from each material's continuous error (an image metric's mean over the "
            "lightings of the split; a probe's largest error over the question's quantities): "
            "the error ratio is the geometric mean of the per-material ratios (a mean "
            "difference where an error can be 0) with a bootstrap 95% confidence interval over "
            "materials; p is a paired Wilcoxon signed-rank test (an exact sign test below "
            f"{SIGN_TEST_BELOW} materials), Holm-corrected for each pair over the study's "
            f"{questions} questions. The "
            "pass counts at fixed tolerances follow as a secondary table. Rules: "
            "docs/studies.md, \"Comparative answers\".")


def to_json(records):
    # /2: each material's error per fit is a record {material, fit, error}, no longer a
    # "material|fit" key (issue 35: labels carried as fields, not composed strings).
    return {"schema": "shadefit.comparisons/2",
            "method": {"effect": "ratio: geometric mean over materials of baseline error / fit "
                                 "error (> 1: the fit is closer); difference: mean of baseline "
                                 "error - fit error",
                       "ci": f"bootstrap over materials, {BOOTSTRAP_RESAMPLES} resamples, BCa "
                             f"(percentile where BCa is undefined), seed {BOOTSTRAP_SEED}",
                       "test": f"Wilcoxon signed-rank (scipy.stats.wilcoxon, zeros dropped); "
                               f"exact sign test (scipy.stats.binomtest) below "
                               f"{SIGN_TEST_BELOW} untied materials",
                       "correction": "Holm over the study's questions, one family per compared "
                                     "pair (statsmodels multipletests)"},
            "questions": records}
