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

import gc
import math
import warnings

import numpy as np
from scipy import stats
from statsmodels.stats.multitest import multipletests

import judging

BOOTSTRAP_RESAMPLES = 10000
BOOTSTRAP_SEED = 20261204  # Fixed: a rerun of the report writes the same numbers.
SIGN_TEST_BELOW = 6        # Fewer non-tied materials than this: the exact sign test (the
                           # exact signed-rank test cannot reach p < 0.05 below 6 pairs).
MIN_MATERIALS_FOR_CI = 3   # Two materials give no meaningful interval.

# Image metrics whose larger value is better: their error is 1 - value (SSIM family) or the
# difference is taken the other way round (PSNR, in dB).
SIMILARITY_METRICS = {"ssim", "ms_ssim"}
HIGHER_IS_BETTER_DB = {"psnr"}

# Names of the metrics and their agreement with people: report/judging.py, the one place.
METRIC_NAMES = judging.METRIC_NAMES

# The image questions' splits: one question per split, answered under every metric of the judging
# set (report_answers.py).
IMAGE_SPLITS = ("train", "test")

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
    """The study's questions: one image question per split of IMAGE_SPLITS the results have
    (named by the study's first metric verdict on that split, else "image" and "transfer"; worded
    without a metric), answered under the judging set; then every probe verdict. Each is a dict
    with the verdict's fields plus `name` and `default` (True for the added ones)."""
    out = [dict(v, name=name, default=False) for name, v in study["verdicts"].items()
           if v["source"] != "metrics"]
    splits = {r["split"] for r in rows}
    defaults = {"train": ("image", "How close can the model get to a reference image "
                                   "(training lighting)?"),
                "test": ("transfer", "Do fitted parameters carry over to new lighting (image "
                                     "error under test lightings)?")}
    image = []
    for split in IMAGE_SPLITS:
        named = [n for n, v in study["verdicts"].items()
                 if v["source"] == "metrics" and v.get("split") == split]
        if named or split in splits:
            # The question in words of no metric (a verdict's text may name the metric its
            # tolerance is on; the answer is under every metric of the judging set).
            name, text = named[0] if named else defaults[split][0], defaults[split][1]
            image.append({"name": name, "default": not named, "source": "metrics",
                          "split": split, "kind": "max", "question": text})
    # Reading order: image closeness, new lighting, then the phenomena (BRDF space first: on
    # measured references it is where the lobe and the Fresnel rise are measured).
    rank = {"brdf": 2, "highlight": 3, "fresnel": 4, "energy": 5}
    return image + sorted(out, key=lambda q: rank.get(q["source"], 6))


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


def material_errors(study, rows, summary, question, to_float, column=None, metric=None):
    """{(material, label): error or None} and {(material, label): why n/a} for one question.
    Metrics: the mean of the metric over the fit's lightings of the split (`column` overrides
    the results.csv column, e.g. the all-pixel one). Probes: the verdict's worst-quantity error
    (what the tolerance bounds); a `max` verdict of a probe (energy) becomes the excess over its
    bound, 0 when within. `metric`: the image metric of a metrics question."""
    errors, why = {}, {}
    labels = [f["label"] for f in study["fits"]]
    materials = [g["material"] for g in study["groups"]]
    source = question["source"]
    # One pass over the rows (or the summary) per question: a scan per (material, fit) is
    # quadratic, minutes on the measured study's 35 fits.
    if source == "metrics":
        col, values = column or metric, {}
        for r in rows:
            if r["split"] == question["split"]:
                x = to_float(r.get(col))
                if x is not None:
                    values.setdefault((r["material"], r["label"]), []).append(x)
    else:
        judged = {(s["material"], s["fit"]): s for s in summary
                  if s["phenomenon"] == question["name"]}
    for m in materials:
        reason = not_valid_reason(study, source, m)
        for label in labels:
            if reason:
                errors[(m, label)], why[(m, label)] = None, reason
            elif source == "metrics":
                vals = values.get((m, label))
                errors[(m, label)] = metric_error(metric, vals) if vals else None
            else:
                errors[(m, label)] = probe_error(judged.get((m, label)), question)
    return errors, why


def probe_error(s, question):
    """A probe verdict's error on one material: the worst quantity's; for a `max` verdict the
    excess over its bound, 0 when within; None without a number."""
    if s is None or s["error"] is None:
        return None
    if question["kind"] == "max":
        return max(0.0, s["error"] - float(question["tolerance"]))
    return s["error"]


def question_mode(question):
    if question["source"] == "metrics":
        return "per metric"
    return "difference" if question["kind"] == "max" else "ratio"


# ------------------------------------------------------------------------------------------------
# Pairs


def comparison_pairs(study):
    """(label, baseline label) pairs within each (training set, loss): every fit against the
    baseline model's fit, then the study's `compare` pairs. A floor set and the BRDF fit are
    training sets of their own, so their fits pair with each other (floor vs floor)."""
    fits = study["fits"]
    baseline = study["baseline"] or (fits[0]["model"] if fits else None)
    by_train = {}
    for f in fits:
        by_train.setdefault((tuple(f["train"]), f["loss"]), {})[f["model"]] = f["label"]
    pairs = []
    for models in by_train.values():
        base = models.get(baseline)
        if base is None:
            continue
        pairs += [(label, base) for model, label in models.items() if model != baseline]
    for a, b in study["compare"]:
        for models in by_train.values():
            if a in models and b in models and (models[a], models[b]) not in pairs:
                pairs.append((models[a], models[b]))
    return pairs


# ------------------------------------------------------------------------------------------------
# Statistics of one pair on one question


def bootstrap_ci(values):
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
        lo, hi = bootstrap_ci(x)
        ci = (None, None) if lo is None else (math.exp(lo), math.exp(hi))
    else:
        x = b - a
        effect = float(np.mean(x))
        ci = bootstrap_ci(x)
    p, test = paired_test(x)
    return {"fit": label, "baseline": base, "materials": used, "n": n, "mode": mode,
            "effect": effect, "ci": list(ci), "closer": int(np.sum(a < b)),
            "farther": int(np.sum(a > b)), "tied": int(np.sum(a == b)), "p": p, "test": test,
            "fit_quartiles": quartiles(a), "baseline_quartiles": quartiles(b),
            "errors": {m: [float(ea), float(eb)] for m, ea, eb in zip(used, a, b)}}


def holm_by_pair(tests):
    """Holm's step-down correction over `tests` (comparison records with `fit`, `baseline`,
    `p`), one family per compared pair: sets each record's `p_holm` and `holm_family`."""
    families = {}
    for c in tests:
        families.setdefault((c["fit"], c["baseline"]), []).append(c)
    # statsmodels' Holm branch calls gc.collect() on every call (0.15 s each with the report's
    # heap: 20 s for the measured study's 140 families); frozen objects are not traversed.
    gc.freeze()
    try:
        for family in families.values():
            adjusted = multipletests([c["p"] for c in family], method="holm")[1]
            for c, p in zip(family, adjusted):
                c["p_holm"] = float(p)
                c["holm_family"] = len(family)
    finally:
        gc.unfreeze()


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
        return f"{rec['question']} [judged under {len(rec['metrics'])} metrics]"
    return rec["question"]


def error_label(rec):
    """The y axis of a probe question's figure: what its error is."""
    if rec["mode"] == "difference":
        return "excess over the bound"
    return "largest relative error"


def comparison_table(records, fmt):
    """(columns, rows) of every comparison, for tables/comparisons.{csv,md,tex}: a pair on an
    image question has one row per metric of the judging set, with the pair's verdict. Errors as
    the comparison uses them: smaller is better (1 - SSIM for the SSIM family, -PSNR for
    PSNR)."""
    cols = ["question", "fit", "baseline", "metric", "materials", "fit error median [IQR]",
            "baseline error median [IQR]", "effect", "95% CI", "error ratio fit/baseline",
            "closer", "test", "p", "p (Holm)", "verdict"]
    out = []
    for rec in records:
        for pair in rec["comparisons"]:
            per = pair.get("per_metric", [pair])
            word = pair["verdict"]["word"] if "verdict" in pair else ""
            out += [comparison_row(rec, c, fmt, word) for c in per]
    return cols, out


def comparison_row(rec, c, fmt, word):
    def med(q):
        return f"{fmt(q[0])} [{fmt(q[1])}, {fmt(q[2])}]"
    lo, hi = c["ci"]
    effect = (f"{c['effect']:.3g}x" if c["mode"] == "ratio" else f"{c['effect']:+.3g}")
    ci = "" if lo is None else (f"{lo:.3g}-{hi:.3g}" if c["mode"] == "ratio"
                                else f"{lo:+.3g} to {hi:+.3g}")
    metric = METRIC_NAMES.get(c["metric"], c["metric"]) if "metric" in c else ""
    # The same ratio the other way round, as issue 40's table and the findings read it.
    inverse = f"{1 / c['effect']:.3g}" if c["mode"] == "ratio" and c["effect"] > 0 else ""
    return [rec["name"], c["fit"], c["baseline"], metric, str(c["n"]), med(c["fit_quartiles"]),
            med(c["baseline_quartiles"]), effect, ci, inverse, f"{c['closer']}/{c['n']}",
            c["test"], fmt_p(c["p"]), fmt_p(c.get("p_holm")), word]
