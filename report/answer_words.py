"""The comparative answers in words, tables and JSON: sentences per pair and question, the
comparisons table, the method paragraph, comparisons.json's record, and the every-metric table.
Formats what answer_rules computed; computes no statistic and decides no answer."""

import judging
from answer_rules import (ALPHA, MIN_MATERIALS_FOR_PAIRED_TEST, comparisons_of, direction, error_ratio, error_ratio_ci,
                          ratio_range)
from answer_stats import BOOTSTRAP_RESAMPLES, BOOTSTRAP_SEED, SIGN_TEST_BELOW

# Names of the metrics and their agreement with people: report/judging.py, the one place.
METRIC_NAMES = judging.METRIC_NAMES


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
    lo, hi = c.ci
    none = "no CI: fewer than 3 materials"
    if c.mode == "ratio":
        r = c.effect
        prefix, ci = "", (lo, hi)
        if 0.995 <= r <= 1.005:
            words, prefix = "within 0.5% of", "ratio "
        elif r >= 1:
            words = f"{fmt_effect(r)}x smaller than"
        else:
            words, ci = f"{fmt_effect(error_ratio(c))}x larger than", error_ratio_ci(c)
        ci_text = none if ci[0] is None else f"{prefix}95% CI {fmt_effect(ci[0])}-{fmt_effect(ci[1])}"
        return f"{words} {c.baseline}'s", ci_text
    d = c.effect
    # The interval in the sentence's own direction: of how much lower (or higher).
    lo_s, hi_s = (lo, hi) if d >= 0 else (None if hi is None else -hi, None if lo is None else -lo)
    ci_text = none if lo is None else f"95% CI {lo_s + 0.0:.3g} to {hi_s + 0.0:.3g}"  # no "-0"
    side = "lower" if d >= 0 else "higher"
    return f"{side} than {c.baseline}'s by {abs(d):.3g} on average", ci_text


def effect_words(c):
    """'ggx's error is 2.3x smaller than blinn-phong's (95% CI 1.8-3.0)' and the like."""
    relation, ci_text = effect_parts(c)
    return f"{c.fit}'s {c.what or 'error'} is {relation} ({ci_text})"


def sentence(rec, c):
    if c.test == "all tied":
        return (f"{c.fit}'s {c.what or 'error'} equals {c.baseline}'s on every one of "
                f"the {c.n} materials (p = 1)")
    test = {"Wilcoxon": "Wilcoxon", "sign test": "exact sign test"}[c.test]
    return (f"{effect_words(c)}; {c.fit} is closer on {c.closer} of {c.n} materials "
            f"({test} p = {fmt_p(c.p if c.p_holm is None else c.p_holm)}, Holm)")


def question_title(rec):
    if rec.source == "metrics":
        return f"{rec.question} [judged under {len(rec.metrics)} metrics]"
    return rec.question


def error_label(rec):
    """The y axis of a probe question's figure: what its error is."""
    if rec.mode == "difference":
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
        for pair in rec.comparisons:
            per = comparisons_of(pair)
            word = pair.verdict.word if getattr(pair, "verdict", None) else ""
            out += [comparison_row(rec, c, fmt, word) for c in per]
    return cols, out


def comparison_row(rec, c, fmt, word):
    def med(q):
        return f"{fmt(q[0])} [{fmt(q[1])}, {fmt(q[2])}]"
    lo, hi = c.ci
    effect = (f"{c.effect:.3g}x" if c.mode == "ratio" else f"{c.effect:+.3g}")
    ci = "" if lo is None else (f"{lo:.3g}-{hi:.3g}" if c.mode == "ratio"
                                else f"{lo:+.3g} to {hi:+.3g}")
    metric = "" if c.metric is None else METRIC_NAMES.get(c.metric, c.metric)
    # The same ratio the other way round, as issue 40's table and the findings read it.
    ratio = error_ratio(c)
    inverse = "" if ratio is None else f"{ratio:.3g}"
    return [rec.name, c.fit, c.baseline, metric, str(c.n), med(c.fit_quartiles),
            med(c.baseline_quartiles), effect, ci, inverse, f"{c.closer}/{c.n}",
            c.test, fmt_p(c.p), fmt_p(c.p_holm), word]


def fmt_range(rng, digits=3):
    """'0.52-0.88x', or '0.5x' where the ends agree at `digits` significant digits."""
    lo, hi = (f"{v:.{digits}g}" for v in rng)
    return f"{lo}x" if lo == hi else f"{lo}-{hi}x"


def names(metrics):
    return ", ".join(judging.metric_name(m) for m in metrics) or "none"


def pair_sentence(pair, unit="material"):
    """One pair's answer on one question, in words; states a metric-dependent or mixed answer
    as such, with the metrics of each side, never as one metric's answer. `unit`: what the
    question compares over (the record's `unit`: materials, or lightings)."""
    v, per = pair.verdict, pair.per_metric
    fit, base = pair.fit, pair.baseline
    rng = ratio_range(per)
    ratios = "" if rng is None else f"error ratio {fmt_range(rng)} over the metrics; "
    closer = sorted({c.closer for c in per})
    closer = f"{closer[0]}" if len(closer) == 1 else f"{closer[0]}-{closer[-1]}"
    n_mat = max(c.n for c in per)
    if v.kind in ("smaller", "larger"):
        sig = v.significant()
        return (f"{fit} vs {base}: {v.word}: {fit}'s error is {v.kind} than {base}'s "
                f"under every metric of the judging set ({ratios}closer on {closer} of {n_mat} "
                f"{unit}s; Holm p < {ALPHA:g} under {len(sig)} of {v.n})")
    text = (f"{fit} vs {base}: {v.word}: {fit}'s error is smaller under "
            f"{names(v.smaller)} and larger under {names(v.larger)}")
    if v.equal:
        text += f", equal under {names(v.equal)}"
    text += (f" (Holm p < {ALPHA:g}: smaller under {names(v.significant_smaller)}; larger "
             f"under {names(v.significant_larger)})")
    if v.kind == "mixed":
        text += "; no side holds with significance against the other"
    return text


def loss_sentence(a):
    """One LossAgreement in words."""
    per = "; ".join(f"{loss}: {kind}" for loss, kind in a.verdicts.items())
    where = "floor fits" if a.role == "floor" else f"trained on {a.train}"
    if a.holds:
        return (f"{a.model} vs {a.baseline} ({where}): the verdict holds across the "
                f"{len(a.verdicts)} losses ({per})")
    return (f"{a.model} vs {a.baseline} ({where}): the verdict does not hold across "
            f"losses ({per})")


def all_pixels_text(rec, pair):
    """' [all pixels, extrapolated data included: smaller under 3 and larger under 5 of 8
    metrics]' beside a pair, where the measured references' all-pixel numbers differ."""
    alls = {(a.fit, a.baseline): a for a in rec.all_pixels or []}
    a = alls.get((pair.fit, pair.baseline))
    if a is None:
        return ""
    d = [direction(c) for c in a.per_metric]
    return (f" [all pixels, extrapolated data included: smaller under {d.count(1)} and larger "
            f"under {d.count(-1)} of {len(d)} metrics]")


def markdown_list(items):
    """Markdown lines of list items (depth, text): two spaces per level, then "- "."""
    return ["  " * depth + "- " + text for depth, text in items]


def answer_items(rec):
    """List items (depth, text) of one question: its title, then one sentence per comparison,
    then whether the verdicts hold across losses."""
    items = [(0, f"**{question_title(rec)}**" + (" (default question)" if rec.default else ""))]
    if rec.source == "metrics":
        items.append((1, "Judged under " + names(rec.metrics) + ". " + rec.judging))
        if rec.pooled_objects:
            items.append((1, f"Pooled over the {rec.pooled_objects} objects (each material on "
                             "each object a unit); each object alone: \"Per object\" below"))
        if rec.unit == "lighting":
            items.append((1, lighting_units_text(rec)))
        items += [(1, f"{pair_sentence(p, rec.unit)}."
                      f"{all_pixels_text(rec, p)}") for p in rec.comparisons]
        items += [(1, f"{loss_sentence(a)}.") for a in rec.across_losses]
    else:
        if rec.n_a and not rec.comparisons:
            return items + [(1, f"n/a: {rec.n_a[0]}")]
        items += [(1, f"{sentence(rec, c)}.") for c in rec.comparisons]
        if rec.n_a:
            items.append((1, f"n/a on some materials: {'; '.join(rec.n_a)}"))
    if not rec.comparisons:
        items.append((1, "no fit pair has numbers on this question"))
    return items


def answer_lines(records):
    """summary.md's answers: every question's items as a Markdown list."""
    return [line for rec in records for line in markdown_list(answer_items(rec))]


def lighting_units_text(rec):
    """What an image question answered over its lightings is about, said plainly: how many
    (material, lighting) units its pairs have (each pair is compared over the lightings of the
    split both its fits have: a fit trained on more lightings has more training units)."""
    n = rec.unit_materials
    ns = sorted({c.n for p in rec.comparisons for c in p.per_metric})
    count = "" if not ns else f"{ns[0]}" if len(ns) == 1 else f"{ns[0]}-{ns[-1]}"
    which = "test" if rec.split == "test" else "training"
    # Pooled over several objects a unit's first part is a material on an object.
    noun = "material-object pair" if rec.pooled_objects else "material"
    who = "this object" if n == 1 else f"these {n} {noun}s"
    lights = ("other lights" if rec.split == "test" else
              f"the lights {'it was' if n == 1 else 'they were'} fitted to")
    return (f"Units: the {which} lightings ({count} per compared pair). With {n} "
            f"{noun}{'s' if n > 1 else ''} (fewer than {MIN_MATERIALS_FOR_PAIRED_TEST}, too "
            f"few for a paired test over materials) each (material, {which} lighting) is a unit "
            f"of the paired test: the answer is about {who} under {lights}, not about other "
            "materials")


def method_text(records):
    """How the answers are computed, in one paragraph (summary.md and index.html)."""
    tests = sum(len(comparisons_of(p)) for r in records for p in r.comparisons)
    few = any(r.unit == "lighting" for r in records)
    return ("Every fit is compared with the baseline fit of its training set and loss over the "
            "materials, from each material's continuous error (an image metric's mean over the "
            "lightings of the split; a probe's largest error over the question's quantities). "
            "Image questions are answered under every metric of the judging set: per metric the "
            "error ratio is the geometric mean of the per-material ratios (a mean difference "
            "where an error can be 0) with a bootstrap 95% confidence interval over materials, "
            "and p is a paired Wilcoxon signed-rank test (an exact sign test below "
            f"{SIGN_TEST_BELOW} materials), Holm-corrected for each pair over the study's "
            f"questions and metrics ({tests} tests). A pair's verdict is 'smaller (larger) "
            "under all N metrics' when every metric points the same way, 'metric-dependent' when "
            "they disagree with a Holm-significant metric (p < 0.05) on each side, else "
            "'mixed'. The pass counts at fixed tolerances follow as a secondary table. Rules: "
            "docs/studies.md, \"Answers under a set of metrics\"."
            + (f" An image question of fewer than {MIN_MATERIALS_FOR_PAIRED_TEST} materials is "
               "answered over its lightings instead (each material and lighting of the split a "
               "unit): an answer about these objects under these lights." if few else ""))


def to_json(records, extra=None):
    # /3: image questions under a judging set of metrics, per pair `per_metric` and `verdict`;
    # `across_losses`; floors, regions and classes beside (issue 40). /2: errors as records.
    out = {"schema": "shadefit.comparisons/3",
           "method": {"effect": "ratio: geometric mean over materials of baseline error / fit "
                                "error (> 1: the fit is closer); difference: mean of baseline "
                                "error - fit error",
                      "ci": f"bootstrap over materials, {BOOTSTRAP_RESAMPLES} resamples, BCa "
                            f"(percentile where BCa is undefined), seed {BOOTSTRAP_SEED}",
                      "test": f"Wilcoxon signed-rank (scipy.stats.wilcoxon, zeros dropped); "
                              f"exact sign test (scipy.stats.binomtest) below "
                              f"{SIGN_TEST_BELOW} untied materials",
                      "correction": "Holm over the study's questions and judging metrics, one "
                                    "family per compared pair (statsmodels multipletests)",
                      "verdict": f"smaller/larger under all N metrics: every metric's ratio on "
                                 f"one side; metric-dependent: both sides have a metric with "
                                 f"Holm p < {ALPHA:g}; mixed: otherwise",
                      "judging_rule": judging.RULE_TEXT},
           "judging": next((r.metrics for r in records if r.source == "metrics"), []),
           "questions": records}
    out.update(extra or {})
    return out


# ------------------------------------------------------------------------------------------------
# Every metric measured, judged or not (descriptive: the numbers behind issue 40's table)


def every_metric_table(records, cells, metrics):
    """(columns, rows) or None: per compared pair and every metric column results.csv has
    (`metrics`, in that order), the error ratio fit / baseline (geometric mean over the units; a
    mean difference for PSNR) and on how many units the fit is closer, per image question
    (`cells`: answer_rules.every_metric_cells). No test and no verdict: it shows how far the
    judging set's agreement reaches."""
    image = [r for r in records if r.source == "metrics" and r.comparisons]
    if cells is None:
        return None
    judged = set(image[0].metrics)
    pairs = list(dict.fromkeys((p.fit, p.baseline) for r in image for p in r.comparisons))
    head = ["fit", "baseline", "metric", "in the judging set"] + [
        f"{r.name}: ratio, closer" for r in image]
    out = [[f, b, judging.metric_name(m), "yes" if m in judged else ""]
           + [describe(cells.get((f, b, m, r.name))) for r in image]
           for f, b in pairs for m in metrics]
    return head, out


def describe(d):
    if d is None:
        return ""
    value, kind, closer, n = d
    return f"{value:.3g}x, {closer}/{n}" if kind == "ratio" else f"{value:+.3g}, {closer}/{n}"


def object_lines(objects):
    """List items (depth, text) of answer_rules.object_answers: per object its materials, then
    per image question what it is answered over and each pair's verdict with its ratio range."""
    lines = []
    for o in objects:
        name = o.object or "(no object named)"
        lines.append((0, f"**{name}** ({len(o.materials)} material"
                         f"{'s' if len(o.materials) != 1 else ''}: {', '.join(o.materials)})"))
        for q in o.questions:
            over = (f"over its {q.units} {'test' if q.split == 'test' else 'training'} "
                    "lightings: about this object under "
                    + ("other lights" if q.split == "test" else "the lights it was fitted to")
                    if q.unit == "lighting" else f"over its {q.units} materials")
            lines.append((1, f"{q.question} ({over})"))
            for p in q.pairs:
                r = "" if p.ratio_range is None else f", error ratio {fmt_range(p.ratio_range)}"
                lines.append((2, f"{p.fit} vs {p.baseline}: {p.verdict.word}{r}"))
            if not q.pairs:
                lines.append((2, "no fit pair has numbers on this question"))
    return lines
