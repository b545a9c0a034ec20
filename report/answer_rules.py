"""The rules that decide the study's comparative answers (docs/studies.md, "Comparative answers"
and "Answers under a set of metrics"): its questions (one image question per split, answered under
every metric of the judging set; then every probe verdict), each unit's continuous error per fit,
the pairs compared, the one ratio convention (fit error / baseline error, < 1: the fit is closer:
error_ratio from a comparison, geometric_mean_ratio over units without one), and a pair's verdict
over the metrics:

- "smaller under all N metrics" / "larger under all N metrics": every metric's ratio points the
  same way (how many of them are Holm-significant is said beside it);
- "metric-dependent": the signs disagree and at least one metric is Holm-significant (p < ALPHA)
  on each side;
- "mixed": the signs disagree (or some metric is tied) without significance on both sides.

The p-values are Holm-corrected per compared pair over the study's questions and, for an image
question, its metrics together: one family per pair (answer_stats.holm_by_pair). The statistics
themselves are answer_stats'; the words, tables and JSON answer_words'. Nothing here reads a file
or writes a word: it is handed the rows make_report.py read.
"""

import dataclasses
import math

import numpy as np

import judging
from answer_stats import compare_pair, holm_by_pair
from report_records import (ClassQuestion, ImageQuestionRecord, LossAgreement, ObjectAnswer,
                            PairAnswer, PairVerdict, ProbeQuestionRecord, Question,
                            QuestionAnswer, UnitError, Verdict)
from report_util import materials_of

# An image question over fewer materials (material-object pairs) than this is answered over its
# lightings instead: a paired test over 1-5 materials cannot reach significance (the exact sign
# test's least p over 5 pairs is 0.0625), while a study of one object under 96 lights has 88
# held-out comparisons. The answer is then about these objects under these lights.
MIN_MATERIALS_FOR_PAIRED_TEST = 6

ALPHA = 0.05  # Holm-adjusted p below this: significant.


WORDS = {"smaller": "smaller under all {n} metrics", "larger": "larger under all {n} metrics",
         "metric-dependent": "metric-dependent", "mixed": "mixed"}

# Image metrics whose larger value is better: their error is 1 - value (SSIM family) or the
# difference is taken the other way round (PSNR, in dB).
SIMILARITY_METRICS = {"ssim", "ms_ssim"}


HIGHER_IS_BETTER_DB = {"psnr"}

# The image questions' splits: one question per split, answered under every metric of the judging
# set (compare_study); and each one's name and words where no metric verdict of the study names it.
IMAGE_SPLITS = ("train", "test")
DEFAULT_IMAGE_QUESTIONS = {
    "train": ("image", "How close can the model get to a reference image (training lighting)?"),
    "test": ("transfer", "Do fitted parameters carry over to new lighting (image error under "
                         "test lightings)?")}

# The probe questions' reading order after the image questions: BRDF space first (on measured
# references it is where the lobe and the Fresnel rise are measured), then any other source.
PROBE_ORDER = {"brdf": 2, "highlight": 3, "fresnel": 4, "energy": 5}


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
# Questions and each unit's continuous error


def questions_of(study, rows):
    """The study's questions: one image question per split of IMAGE_SPLITS the results have
    (named by the study's first metric verdict on that split, else "image" and "transfer"; worded
    without a metric), answered under the judging set; then every probe verdict: a Question
    each."""
    out = [Question(name, v["question"], v["source"], v["kind"], False, v.get("split"),
                    float(v["tolerance"]))
           for name, v in study["verdicts"].items() if v["source"] != "metrics"]
    splits = {r["split"] for r in rows}
    image = []
    for split in IMAGE_SPLITS:
        named = [n for n, v in study["verdicts"].items()
                 if v["source"] == "metrics" and v.get("split") == split]
        if named or split in splits:
            # The question in words of no metric (a verdict's text may name the metric its
            # tolerance is on; the answer is under every metric of the judging set).
            default_name, text = DEFAULT_IMAGE_QUESTIONS[split]
            name = named[0] if named else default_name
            image.append(Question(name, text, "metrics", "max", not named, split))
    # Reading order: image closeness, new lighting, then the phenomena (PROBE_ORDER).
    return image + sorted(out, key=lambda q: PROBE_ORDER.get(q.source, 6))


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


def probe_errors(study, summary, question, materials):
    """{(material, label): error or None} and {(material, label): why n/a} for one probe
    question: the verdict's worst-quantity error (what the tolerance bounds); a `max` verdict of
    a probe (energy) becomes the excess over its bound, 0 when within."""
    errors, why = {}, {}
    labels = [f["label"] for f in study["fits"]]
    judged = {(s.material, s.fit): s for s in summary if s.phenomenon == question.name}
    for m in materials:
        reason = not_valid_reason(study, question.source, m)
        for label in labels:
            if reason:
                errors[(m, label)], why[(m, label)] = None, reason
            else:
                errors[(m, label)] = probe_error(judged.get((m, label)), question)
    return errors, why


def unit_name(material, obj, lighting=None):
    """How a unit is named in the records: 'red-plastic', 'red-plastic on teapot', and with a
    lighting 'red-plastic on teapot, L07'. An empty object is the analytic sphere or plane."""
    name = f"{material} on {obj}" if obj else material
    return name if lighting is None else f"{name}, {lighting}"


def image_units(rows, split, materials, lighting_units=True):
    """('material', [(material, object)]) or ('lighting', [(material, object, lighting)]): the
    units an image question on `split` compares fits over. A unit is a material on an object
    (every material of `materials`, in that order, even one without rows); below
    MIN_MATERIALS_FOR_PAIRED_TEST of them with rows (and `lighting_units`), each lighting of the
    split of each of them, in the rows' order."""
    chosen = set(materials)
    seen = [(r["material"], r.get("object", ""), r["lighting"]) for r in rows
            if r["split"] == split and r["material"] in chosen]
    pairs = list(dict.fromkeys((m, o) for m, o, _ in seen))
    if lighting_units and pairs and len(pairs) < MIN_MATERIALS_FOR_PAIRED_TEST:
        return "lighting", list(dict.fromkeys(seen))
    objects = {}
    for m, o in pairs:
        objects.setdefault(m, []).append(o)
    return "material", [(m, o) for m in materials for o in objects.get(m, [""])]


def image_errors(rows, question, to_float, unit, units, labels, metric, column=None):
    """{(unit name, label): error or None} for one image question (a Question or its record:
    its split) and metric over `units` of kind `unit` (image_units): the metric's mean over the
    unit's lightings of the split (one lighting for a lighting unit), oriented so that smaller
    is better; `column` overrides the results.csv column (the all-pixel one)."""
    col, values = column or metric, {}
    by_lighting = unit == "lighting"
    for r in rows:
        if r["split"] == question.split:
            x = to_float(r.get(col))
            if x is not None:
                key = (r["material"], r.get("object", ""))
                key = key + (r["lighting"],) if by_lighting else key
                values.setdefault((key, r["label"]), []).append(x)
    errors = {}
    for u in units:
        for label in labels:
            vals = values.get((u, label))
            errors[(unit_name(*u), label)] = metric_error(metric, vals) if vals else None
    return errors


def probe_error(s, question):
    """A probe verdict's error on one material (`s`: its ToleranceVerdict): the worst
    quantity's; for a `max` verdict the excess over its bound, 0 when within; None without a
    number."""
    if s is None or s.error is None:
        return None
    if question.kind == "max":
        return max(0.0, s.error - question.tolerance)
    return s.error


def question_mode(question):
    if question.source == "metrics":
        return "per metric"
    return "difference" if question.kind == "max" else "ratio"


# ------------------------------------------------------------------------------------------------
# Pairs and verdicts


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


def comparisons_of(pair):
    """The Comparisons a question's entry holds: an image pair's per metric, or a probe
    question's one."""
    return pair.per_metric if isinstance(pair, PairAnswer) else [pair]


def answer_pair(errors_by_metric, materials, label, base, metrics):
    """The comparison of `label` with `base` under each metric (those where both have errors),
    or None where no metric has one."""
    per = []
    for m in metrics:
        c = compare_pair(errors_by_metric[m], materials, label, base, metric_mode(m))
        if c is not None:
            c.metric = m
            per.append(c)
    return PairAnswer(label, base, per) if per else None


def direction(c):
    """+1: the fit's error is smaller; -1: larger; 0: tied."""
    neutral = 1.0 if c.mode == "ratio" else 0.0
    return (c.effect > neutral) - (c.effect < neutral)


def verdict(per_metric, alpha=ALPHA):
    """The pair's Verdict over the metrics (each with its Holm-adjusted p_holm)."""
    n = len(per_metric)
    sides = {d: [c.metric for c in per_metric if direction(c) == d] for d in (1, -1, 0)}
    sig = {d: [c.metric for c in per_metric if direction(c) == d and c.p_holm < alpha]
           for d in (1, -1)}
    if len(sides[1]) == n:
        kind = "smaller"
    elif len(sides[-1]) == n:
        kind = "larger"
    elif sig[1] and sig[-1]:
        kind = "metric-dependent"
    else:
        kind = "mixed"
    return Verdict(kind, WORDS[kind].format(n=n), n, sides[1], sides[-1], sides[0], sig[1],
                   sig[-1])


def error_ratio(c):
    """The one ratio convention of the report: fit error / baseline error (< 1: the fit is
    closer), from a comparison whose statistic is baseline / fit (answer_stats.compare_pair's
    `effect`, as comparisons.json records it); None for a difference."""
    return 1.0 / c.effect if c.mode == "ratio" and c.effect > 0 else None


def error_ratio_ci(c):
    """The 95% CI of error_ratio (the effect's interval inverted), (None, None) where there is
    none or the comparison is a difference."""
    lo, hi = c.ci
    if c.mode != "ratio" or lo is None:
        return None, None
    return 1 / hi, 1 / lo


def log_error_ratio(fit_error, base_error):
    """log(fit error / baseline error) of one unit: < 0 where the fit is closer."""
    return math.log(fit_error / base_error)


def geometric_mean_ratio(log_ratios):
    """The fit/baseline ratio over units without a comparison (the every-metric table, the
    model's floor): the geometric mean of their error ratios, from log_error_ratio's logs."""
    return math.exp(float(np.mean(log_ratios)))


def ratio_range(per_metric):
    """(lowest, highest) fit/baseline error ratio over the metrics, or None."""
    r = [error_ratio(c) for c in per_metric]
    r = [x for x in r if x is not None]
    return (min(r), max(r)) if r else None


def across_losses(pairs, fit_of):
    """Per (training set, role, model, baseline model): the verdict word under each loss and
    whether it holds (the same all-metric verdict under every loss). Only pairs seen under
    more than one loss."""
    groups = {}
    for p in pairs:
        f, b = fit_of[p.fit], fit_of[p.baseline]
        key = ("+".join(f["train"]), f["role"], f["model"], b["model"])
        groups.setdefault(key, {})[f["loss"]] = p.verdict.kind
    out = []
    for (train, role, model, base), by_loss in groups.items():
        if len(by_loss) < 2:
            continue
        kinds = set(by_loss.values())
        holds = len(kinds) == 1 and kinds <= {"smaller", "larger"}
        out.append(LossAgreement(train, role, model, base, by_loss, holds))
    return out


# ------------------------------------------------------------------------------------------------
# The study's questions


def compare_study(study, rows, summary, to_float, materials=None, lighting_units=True,
                  image_only=False):
    """Every question's comparisons over `materials` (default: all the study's), Holm-corrected
    per pair over the questions and metrics. Returns a record per question:
    ImageQuestionRecord (`metrics`: the judging set, `judging`: why that set; per pair its
    comparison per metric and verdict; `across_losses` where the study has several losses) or
    ProbeQuestionRecord.
    `lighting_units`: an image question of few materials is answered over its lightings
    (image_units); False keeps the materials as the units (the classes' answers).
    `image_only`: the image questions only (an object's answers: probes are per material).
    Where the rows show several objects, each image record says how many it pools
    (`pooled_objects`)."""
    materials = materials_of(study) if materials is None else materials
    metrics, why = judging.judging_set(study, set(rows[0]) if rows else set())
    pairs = comparison_pairs(study)
    records, tests = [], []
    objects = objects_of(rows)
    for q in questions_of(study, rows):
        if image_only and q.source != "metrics":
            continue
        if q.source == "metrics":
            rec = image_record(study, rows, q, to_float, materials, metrics, pairs,
                               lighting_units)
            rec.judging = why
            if len(objects) > 1:
                rec.pooled_objects = len(objects)
            tests += [c for p in rec.comparisons for c in p.per_metric]
        else:
            rec = probe_record(study, rows, summary, q, to_float, materials, pairs)
            tests += rec.comparisons
        records.append(rec)
    holm_by_pair(tests)
    fit_of = {f["label"]: f for f in study["fits"]}
    for rec in records:
        if rec.source != "metrics":
            continue
        for p in rec.comparisons:
            p.verdict = verdict(p.per_metric)
            f, b = fit_of[p.fit], fit_of[p.baseline]
            p.train, p.loss, p.role = f["train"], f["loss"], f["role"]
            p.model, p.baseline_model = f["model"], b["model"]
        rec.across_losses = across_losses(rec.comparisons, fit_of)
    return records


def image_record(study, rows, q, to_float, materials, metrics, pairs, lighting_units=True):
    """One image question under every metric of the judging set, over its units (image_units:
    the materials, or below MIN_MATERIALS_FOR_PAIRED_TEST of them their lightings, then `unit`
    is "lighting" in the record); where the results have all-pixel columns (measured
    references), the same pairs over every pixel beside."""
    rec = ImageQuestionRecord(q.name, q.question, q.default, q.split, metrics)
    unit, units = image_units(rows, q.split, materials, lighting_units)
    names = [unit_name(*u) for u in units]
    if unit == "lighting":
        rec.unit = unit
        rec.unit_materials = len({u[:2] for u in units})
    labels = [f["label"] for f in study["fits"]]
    errs, all_errs = {}, {}
    for m in metrics:
        errs[m] = image_errors(rows, q, to_float, unit, units, labels, m)
        rec.errors += [unit_error(u, l, m, errs[m][(unit_name(*u), l)])
                       for u in units for l in labels]
        col = f"{m}_all"
        if rows and col in rows[0]:
            all_errs[m] = image_errors(rows, q, to_float, unit, units, labels, m, column=col)
    rec.comparisons = [p for p in (answer_pair(errs, names, l, b, metrics)
                                   for l, b in pairs) if p is not None]
    if all_errs and any(all_errs[m] != errs[m] for m in all_errs):
        rec.all_pixels = [p for p in (answer_pair(all_errs, names, l, b, list(all_errs))
                                      for l, b in pairs) if p is not None]
    return rec


def unit_error(u, label, metric, error):
    """One unit's error: the material, then its object and lighting where the unit has them."""
    return UnitError(u[0], label, error, object=u[1] or None,
                     lighting=u[2] if len(u) > 2 else None, metric=metric)


def probe_record(study, rows, summary, q, to_float, materials, pairs):
    errors, why = probe_errors(study, summary, q, materials_of(study))
    mode = question_mode(q)
    comparisons = [c for c in (compare_pair(errors, materials, l, b, mode) for l, b in pairs)
                   if c is not None]
    what = "error"
    if q.kind == "max":
        what = f"excess over the bound {q.tolerance:g}"
    for c in comparisons:
        c.what = what
    return ProbeQuestionRecord(q.name, q.question, q.default, q.source, q.split, mode,
                               sorted(set(why.values())), comparisons,
                               [UnitError(m, l, e) for (m, l), e in errors.items()])


def describe_pair(errors, units, label, base, metric):
    """(value, kind, closer, n) of one pair under one metric, descriptive (no test): kind
    "ratio": the geometric mean over the units of fit error / baseline error; "difference": the
    mean of fit error - baseline error (PSNR, or an error of 0); None where no unit has both."""
    a, b = [], []
    for m in units:
        ea, eb = errors.get((m, label)), errors.get((m, base))
        if ea is not None and eb is not None:
            a.append(ea)
            b.append(eb)
    if not a:
        return None
    closer = sum(x < y for x, y in zip(a, b))
    if metric_mode(metric) == "ratio" and min(a) > 0 and min(b) > 0:
        return (geometric_mean_ratio([log_error_ratio(x, y) for x, y in zip(a, b)]), "ratio",
                closer, len(a))
    return sum(x - y for x, y in zip(a, b)) / len(a), "difference", closer, len(a)


def every_metric_cells(study, rows, records, to_float, columns):
    """({(fit, baseline, metric, question name): describe_pair's tuple or None}, metrics) for
    every metric column results.csv has (`columns`, in that order), over each image question's
    own units; (None, []) without an answered image question."""
    image = [r for r in records if r.source == "metrics" and r.comparisons]
    if not image or not rows:
        return None, []
    materials = materials_of(study)
    labels = [f["label"] for f in study["fits"]]
    metrics = [m for m in columns if m in rows[0]]
    cells = {}
    for rec in image:
        unit, units = image_units(rows, rec.split, materials)
        names = [unit_name(*u) for u in units]
        for m in metrics:
            errs = image_errors(rows, rec, to_float, unit, units, labels, m)
            for p in rec.comparisons:
                cells[(p.fit, p.baseline, m, rec.name)] = describe_pair(
                    errs, names, p.fit, p.baseline, m)
    return cells, metrics


# ------------------------------------------------------------------------------------------------
# Objects: a study whose references show several objects (results.csv's `object`) is answered
# pooled over them (compare_study on every row: a unit is a material on an object) and per object.


def objects_of(rows):
    """The objects the rows show, in their order; [""] (one object, named after nothing: the
    analytic sphere or plane, or a results.csv from before the column) when none is named."""
    return list(dict.fromkeys(r.get("object", "") for r in rows)) or [""]


def object_answers(study, rows, summary, to_float):
    """[ObjectAnswer] per object, where the rows show more than one; [] otherwise. Each object
    is answered by the same rules over its own rows (fewer than MIN_MATERIALS_FOR_PAIRED_TEST
    materials on it: over its lightings), Holm per pair over its own image questions."""
    objects = objects_of(rows)
    if len(objects) < 2:
        return []
    out = []
    for obj in objects:
        mine = [r for r in rows if r.get("object", "") == obj]
        present = {r["material"] for r in mine}
        materials = [m for m in materials_of(study) if m in present]
        records = compare_study(study, mine, summary, to_float, materials=materials,
                                image_only=True)
        questions = []
        for rec in records:
            n = len({e.material + "\0" + (e.lighting or "") for e in rec.errors
                     if e.error is not None})
            questions.append(QuestionAnswer(rec.name, rec.question, rec.split, rec.unit, n,
                                            pair_verdicts(rec)))
        out.append(ObjectAnswer(obj, materials, questions))
    return out


def pair_verdicts(rec):
    """[PairVerdict] of an image question's record: each pair's verdict and ratio range."""
    return [PairVerdict(p.fit, p.baseline, p.verdict, ratio_range(p.per_metric))
            for p in rec.comparisons]


def class_question(rec):
    """ClassQuestion of an image question's record over one material class."""
    return ClassQuestion(rec.name, rec.question, pair_verdicts(rec))


def to_jsonable(value):
    """json.dumps' `default`: a record (Comparison, PairAnswer, Verdict, ObjectAnswer) as its
    fields, in their order (to_json where it leaves some out)."""
    if hasattr(value, "to_json"):
        return value.to_json()
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return dataclasses.asdict(value)
    raise TypeError(f"{type(value).__name__} is not JSON serializable")
