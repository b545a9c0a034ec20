"""The model's floor and the transfer penalty (docs/studies.md, "Floors").

A study with `[fit] floor = [...]` fits each model jointly to every lighting of that list (role
"floor", label `<model>@floor`): the best that model does on these views. Floor vs floor is an
ordinary pair of the training question (the floor set is a training set of its own). Here, per
image question and per metric of the judging set:

- each training set's **error over the floor**: for a fit trained on T, per material the ratio
  of its error to the floor fit's (same model and loss), each the mean of the metric over the
  floor lightings of the question (the training question: the floor lightings T trains on; the
  new-lighting question: those T does not train on), as every question's material error is;
  then the geometric mean over materials with a bootstrap 95% CI (the same bootstrap as every
  comparison, answer_stats);
- the BRDF-space fit (role "brdf") likewise against each floor fit of its model, on the
  new-lighting question (it trains on no image);
- where the floors' verdict on a model pair differs from the verdict of the same pair trained on
  one training set, a sentence says so.
"""

import math

from answer_rules import geometric_mean_ratio, log_error_ratio, metric_error
from answer_stats import bootstrap_ci
from report_records import FloorEntry, FloorRatio
from report_util import materials_of


def lighting_errors(rows, metrics, to_float):
    """{(material, label, lighting): {metric: error oriented smaller-is-better}}."""
    out = {}
    for r in rows:
        cell = out.setdefault((r["material"], r["label"], r["lighting"]), {})
        for m in metrics:
            v = to_float(r.get(m))
            if v is not None:
                cell[m] = metric_error(m, [v])
    return out


def floor_lightings(fit, floor, split):
    """The floor lightings a question judges `fit` on: trained ones for the training question,
    the others for the new-lighting question."""
    trained = set(fit["train"])
    if split == "train":
        return [l for l in floor if l in trained]
    return [l for l in floor if l not in trained]


def ratio_over_floor(errs, materials, label, floor_label, lightings, metric):
    """Per material, error(label) / error(floor), each the mean of the metric over
    `lightings` (as every question's material error is: answer_rules.image_errors); then
    the geometric mean over materials and its bootstrap 95% CI: a FloorRatio, None without a
    material."""
    logs, used = [], []
    for mat in materials:
        pairs = [(errs.get((mat, label, l), {}).get(metric),
                  errs.get((mat, floor_label, l), {}).get(metric)) for l in lightings]
        pairs = [(a, b) for a, b in pairs if a is not None and b is not None]
        a, b = sum(p[0] for p in pairs), sum(p[1] for p in pairs)
        if pairs and a > 0 and b > 0:
            logs.append(log_error_ratio(a, b))
            used.append(mat)
    if not logs:
        return None
    lo, hi = bootstrap_ci(logs)
    return FloorRatio(geometric_mean_ratio(logs), len(logs),
                      [None, None] if lo is None else [math.exp(lo), math.exp(hi)],
                      {m: math.exp(x) for m, x in zip(used, logs)})


def floor_fits_of(study, fit):
    """The floor fits a fit is measured against: the same model's floor under the fit's loss;
    for the BRDF fit, the model's floor under every loss."""
    floors = [f for f in study["fits"] if f["role"] == "floor" and f["model"] == fit["model"]]
    if fit["role"] == "brdf":
        return floors
    return [f for f in floors if f["loss"] == fit["loss"]]


def model_floors(study, rows, records, to_float):
    """{question name: [FloorEntry per (fit, floor fit)]}: each entry's lightings and, per
    metric, the ratio over the floor with its CI. Empty without floor fits."""
    if not study.get("floor") or not any(f["role"] == "floor" for f in study["fits"]):
        return {}
    image = [r for r in records if r.source == "metrics"]
    metrics = image[0].metrics if image else []
    errs = lighting_errors(rows, metrics, to_float)
    materials = materials_of(study)
    out = {}
    for rec in image:
        entries = []
        for fit in (f for f in study["fits"] if f["role"] in ("train", "brdf")):
            lightings = floor_lightings(fit, study["floor"], rec.split)
            for fl in floor_fits_of(study, fit) if lightings else []:
                per = {m: ratio_over_floor(errs, materials, fit["label"], fl["label"],
                                           lightings, m) for m in metrics}
                per = {m: v for m, v in per.items() if v is not None}
                if per:
                    entries.append(FloorEntry(fit["label"], fl["label"], fit["role"], lightings,
                                              per))
        out[rec.name] = entries
    return out
