"""Image questions answered under every metric of the judging set (report/judging.py), with one
computed verdict per compared pair (docs/studies.md, "Answers under a set of metrics").

For each image question (the metrics of the training lightings, of the test lightings) and each
compared pair, every metric of the set gives the ratio of errors, its 95% CI, closer-on-k-of-n
and a paired test (report_compare.compare_pair); the p-values are Holm-corrected over the
study's questions and metrics together, one family per pair (report_compare.holm_by_pair). The
verdict is then a word, never one metric's answer:

- "smaller under all N metrics" / "larger under all N metrics": every metric's ratio points the
  same way (how many of them are Holm-significant is said beside it);
- "metric-dependent": the signs disagree and at least one metric is Holm-significant (p < 0.05)
  on each side; the metrics of each side are named;
- "mixed": the signs disagree (or some metric is tied) without significance on both sides.

Fits are paired within one (training set, loss); whether a pair's verdict holds across the
study's losses is said per question and model pair.
"""

import math

import judging
from report_compare import (BOOTSTRAP_RESAMPLES, BOOTSTRAP_SEED, SIGN_TEST_BELOW, compare_pair,
                            comparison_pairs, holm_by_pair, material_errors, metric_mode,
                            question_mode, question_title, questions_of,
                            sentence)
from report_util import materials_of

ALPHA = 0.05  # Holm-adjusted p below this: significant.

WORDS = {"smaller": "smaller under all {n} metrics", "larger": "larger under all {n} metrics",
         "metric-dependent": "metric-dependent", "mixed": "mixed"}


def answer_pair(errors_by_metric, materials, label, base, metrics):
    """The comparison of `label` with `base` under each metric (those where both have errors),
    or None where no metric has one."""
    per = []
    for m in metrics:
        c = compare_pair(errors_by_metric[m], materials, label, base, metric_mode(m))
        if c is not None:
            c["metric"] = m
            per.append(c)
    return {"fit": label, "baseline": base, "per_metric": per} if per else None


def direction(c):
    """+1: the fit's error is smaller; -1: larger; 0: tied."""
    neutral = 1.0 if c["mode"] == "ratio" else 0.0
    return (c["effect"] > neutral) - (c["effect"] < neutral)


def verdict(per_metric, alpha=ALPHA):
    """The pair's verdict over the metrics (each with its Holm-adjusted p_holm)."""
    n = len(per_metric)
    sides = {d: [c["metric"] for c in per_metric if direction(c) == d] for d in (1, -1, 0)}
    sig = {d: [c["metric"] for c in per_metric if direction(c) == d and c["p_holm"] < alpha]
           for d in (1, -1)}
    if len(sides[1]) == n:
        kind = "smaller"
    elif len(sides[-1]) == n:
        kind = "larger"
    elif sig[1] and sig[-1]:
        kind = "metric-dependent"
    else:
        kind = "mixed"
    return {"kind": kind, "word": WORDS[kind].format(n=n), "n": n, "smaller": sides[1],
            "larger": sides[-1], "equal": sides[0], "significant_smaller": sig[1],
            "significant_larger": sig[-1]}


def error_ratio(c):
    """fit error / baseline error (< 1: the fit is closer), or None for a difference."""
    return 1.0 / c["effect"] if c["mode"] == "ratio" and c["effect"] > 0 else None


def ratio_range(per_metric):
    """(lowest, highest) fit/baseline error ratio over the metrics, or None."""
    r = [error_ratio(c) for c in per_metric]
    r = [x for x in r if x is not None]
    return (min(r), max(r)) if r else None


def fmt_range(rng, digits=3):
    """'0.52-0.88x', or '0.5x' where the ends agree at `digits` significant digits."""
    lo, hi = (f"{v:.{digits}g}" for v in rng)
    return f"{lo}x" if lo == hi else f"{lo}-{hi}x"


def names(metrics):
    return ", ".join(judging.metric_name(m) for m in metrics) or "none"


def pair_sentence(pair):
    """One pair's answer on one question, in words; states a metric-dependent or mixed answer
    as such, with the metrics of each side, never as one metric's answer."""
    v, per = pair["verdict"], pair["per_metric"]
    fit, base = pair["fit"], pair["baseline"]
    rng = ratio_range(per)
    ratios = "" if rng is None else f"error ratio {fmt_range(rng)} over the metrics; "
    closer = sorted({c["closer"] for c in per})
    closer = f"{closer[0]}" if len(closer) == 1 else f"{closer[0]}-{closer[-1]}"
    n_mat = max(c["n"] for c in per)
    if v["kind"] in ("smaller", "larger"):
        sig = v["significant_smaller"] if v["kind"] == "smaller" else v["significant_larger"]
        return (f"{fit} vs {base}: {v['word']}: {fit}'s error is {v['kind']} than {base}'s "
                f"under every metric of the judging set ({ratios}closer on {closer} of {n_mat} "
                f"materials; Holm p < {ALPHA:g} under {len(sig)} of {v['n']})")
    text = (f"{fit} vs {base}: {v['word']}: {fit}'s error is smaller under "
            f"{names(v['smaller'])} and larger under {names(v['larger'])}")
    if v["equal"]:
        text += f", equal under {names(v['equal'])}"
    text += (f" (Holm p < {ALPHA:g}: smaller under {names(v['significant_smaller'])}; larger "
             f"under {names(v['significant_larger'])})")
    if v["kind"] == "mixed":
        text += "; no side holds with significance against the other"
    return text


def across_losses(pairs, fit_of):
    """Per (training set, role, model, baseline model): the verdict word under each loss and
    whether it holds (the same all-metric verdict under every loss). Only pairs seen under
    more than one loss."""
    groups = {}
    for p in pairs:
        f, b = fit_of[p["fit"]], fit_of[p["baseline"]]
        key = ("+".join(f["train"]), f["role"], f["model"], b["model"])
        groups.setdefault(key, {})[f["loss"]] = p["verdict"]["kind"]
    out = []
    for (train, role, model, base), by_loss in groups.items():
        if len(by_loss) < 2:
            continue
        kinds = set(by_loss.values())
        holds = len(kinds) == 1 and kinds <= {"smaller", "larger"}
        out.append({"train": train, "role": role, "model": model, "baseline": base,
                    "verdicts": by_loss, "holds": holds})
    return out


def loss_sentence(a):
    per = "; ".join(f"{loss}: {kind}" for loss, kind in a["verdicts"].items())
    where = "floor fits" if a["role"] == "floor" else f"trained on {a['train']}"
    if a["holds"]:
        return (f"{a['model']} vs {a['baseline']} ({where}): the verdict holds across the "
                f"{len(a['verdicts'])} losses ({per})")
    return (f"{a['model']} vs {a['baseline']} ({where}): the verdict does not hold across "
            f"losses ({per})")


# ------------------------------------------------------------------------------------------------
# The study's questions


def compare_study(study, rows, summary, to_float, materials=None):
    """Every question's comparisons over `materials` (default: all the study's), Holm-corrected
    per pair over the questions and metrics. Returns a list of question records; an image
    question's record has `metrics` (the judging set), `judging` (why that set) and per pair
    `per_metric`, `verdict`; `across_losses` where the study has several losses."""
    materials = materials_of(study) if materials is None else materials
    metrics, why = judging.judging_set(study, set(rows[0]) if rows else set())
    pairs = comparison_pairs(study)
    records, tests = [], []
    for q in questions_of(study, rows):
        if q["source"] == "metrics":
            rec = image_record(study, rows, summary, q, to_float, materials, metrics, pairs)
            rec["judging"] = why
            tests += [c for p in rec["comparisons"] for c in p["per_metric"]]
        else:
            rec = probe_record(study, rows, summary, q, to_float, materials, pairs)
            tests += rec["comparisons"]
        records.append(rec)
    holm_by_pair(tests)
    fit_of = {f["label"]: f for f in study["fits"]}
    for rec in records:
        if rec["source"] != "metrics":
            continue
        for p in rec["comparisons"]:
            p["verdict"] = verdict(p["per_metric"])
            f, b = fit_of[p["fit"]], fit_of[p["baseline"]]
            p.update(train=f["train"], loss=f["loss"], role=f["role"], model=f["model"],
                     baseline_model=b["model"])
        rec["across_losses"] = across_losses(rec["comparisons"], fit_of)
    return records


def record_head(q, mode):
    return {"name": q["name"], "question": q.get("question", q["name"]), "default": q["default"],
            "source": q["source"], "split": q.get("split"), "mode": mode}


def image_record(study, rows, summary, q, to_float, materials, metrics, pairs):
    """One image question under every metric of the judging set; where the results have
    all-pixel columns (measured references), the same pairs over every pixel beside."""
    rec = dict(record_head(q, "per metric"), metrics=metrics, n_a=[], errors=[])
    errs, all_errs = {}, {}
    for m in metrics:
        errs[m], _ = material_errors(study, rows, summary, q, to_float, metric=m)
        rec["errors"] += [{"material": mat, "fit": l, "metric": m, "error": e}
                          for (mat, l), e in errs[m].items()]
        col = f"{m}_all"
        if rows and col in rows[0]:
            all_errs[m], _ = material_errors(study, rows, summary, q, to_float, column=col,
                                             metric=m)
    rec["comparisons"] = [p for p in (answer_pair(errs, materials, l, b, metrics)
                                      for l, b in pairs) if p is not None]
    if all_errs and any(all_errs[m] != errs[m] for m in all_errs):
        rec["all_pixels"] = [p for p in (answer_pair(all_errs, materials, l, b, list(all_errs))
                                         for l, b in pairs) if p is not None]
    return rec


def probe_record(study, rows, summary, q, to_float, materials, pairs):
    errors, why = material_errors(study, rows, summary, q, to_float)
    mode = question_mode(q)
    comparisons = [c for c in (compare_pair(errors, materials, l, b, mode) for l, b in pairs)
                   if c is not None]
    what = "error"
    if q["kind"] == "max":
        what = f"excess over the bound {float(q['tolerance']):g}"
    for c in comparisons:
        c["what"] = what
    return dict(record_head(q, mode), n_a=sorted(set(why.values())), comparisons=comparisons,
                errors=[{"material": m, "fit": l, "error": e} for (m, l), e in errors.items()])


# ------------------------------------------------------------------------------------------------
# Words


def all_pixels_text(rec, pair):
    """' [all pixels, extrapolated data included: smaller under 3 and larger under 5 of 8
    metrics]' beside a pair, where the measured references' all-pixel numbers differ."""
    alls = {(a["fit"], a["baseline"]): a for a in rec.get("all_pixels", [])}
    a = alls.get((pair["fit"], pair["baseline"]))
    if a is None:
        return ""
    d = [direction(c) for c in a["per_metric"]]
    return (f" [all pixels, extrapolated data included: smaller under {d.count(1)} and larger "
            f"under {d.count(-1)} of {len(d)} metrics]")


def answer_lines(records):
    """Markdown: each question, then one sentence per comparison, then whether the verdicts
    hold across losses."""
    lines = []
    for rec in records:
        lines.append(f"- **{question_title(rec)}**"
                     + (" (default question)" if rec["default"] else ""))
        if rec["source"] == "metrics":
            lines.append("  - Judged under " + names(rec["metrics"]) + ". " + rec["judging"])
            lines += [f"  - {pair_sentence(p)}.{all_pixels_text(rec, p)}"
                      for p in rec["comparisons"]]
            lines += [f"  - {loss_sentence(a)}." for a in rec.get("across_losses", [])]
        else:
            if rec["n_a"] and not rec["comparisons"]:
                lines.append(f"  - n/a: {rec['n_a'][0]}")
                continue
            lines += [f"  - {sentence(rec, c)}." for c in rec["comparisons"]]
            if rec["n_a"]:
                lines.append(f"  - n/a on some materials: {'; '.join(rec['n_a'])}")
        if not rec["comparisons"]:
            lines.append("  - no fit pair has numbers on this question")
    return lines


def method_text(records):
    """How the answers are computed, in one paragraph (summary.md and index.html)."""
    tests = sum(len(p.get("per_metric", [p])) for r in records for p in r["comparisons"])
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
            "docs/studies.md, \"Answers under a set of metrics\".")


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
           "judging": next((r["metrics"] for r in records if r["source"] == "metrics"), []),
           "questions": records}
    out.update(extra or {})
    return out


# ------------------------------------------------------------------------------------------------
# Every metric measured, judged or not (descriptive: the numbers behind issue 40's table)


def every_metric_table(study, rows, summary, records, to_float, columns):
    """(columns, rows): per compared pair and every metric column results.csv has (`columns`,
    in that order), the error ratio fit / baseline (geometric mean over materials; a mean
    difference for PSNR) and on how many materials the fit is closer, per image question. No
    test and no verdict: it shows how far the judging set's agreement reaches."""
    image = [r for r in records if r["source"] == "metrics" and r["comparisons"]]
    if not image or not rows:
        return None
    materials = materials_of(study)
    metrics = [m for m in columns if m in rows[0]]
    judged = set(image[0]["metrics"])
    cells = {}
    for rec in image:
        for m in metrics:
            errs, _ = material_errors(study, rows, summary, rec, to_float, metric=m)
            for p in rec["comparisons"]:
                cells[(p["fit"], p["baseline"], m, rec["name"])] = describe(
                    errs, materials, p["fit"], p["baseline"], m)
    pairs = list(dict.fromkeys((p["fit"], p["baseline"]) for r in image for p in r["comparisons"]))
    head = ["fit", "baseline", "metric", "in the judging set"] + [
        f"{r['name']}: ratio, closer" for r in image]
    out = [[f, b, judging.metric_name(m), "yes" if m in judged else ""]
           + [cells.get((f, b, m, r["name"]), "") for r in image]
           for f, b in pairs for m in metrics]
    return head, out


def describe(errors, materials, label, base, metric):
    a, b = [], []
    for m in materials:
        ea, eb = errors.get((m, label)), errors.get((m, base))
        if ea is not None and eb is not None:
            a.append(ea)
            b.append(eb)
    if not a:
        return ""
    closer = f"{sum(x < y for x, y in zip(a, b))}/{len(a)}"
    if metric_mode(metric) == "ratio" and min(a) > 0 and min(b) > 0:
        return f"{math.exp(sum(math.log(x / y) for x, y in zip(a, b)) / len(a)):.3g}x, {closer}"
    return f"{sum(x - y for x, y in zip(a, b)) / len(a):+.3g}, {closer}"
