"""Verdicts: each phenomenon x material x fit judged from the numbers with the study's
tolerances (docs/studies.md, "Verdicts"), never written by hand. Computes only: the records are
report_records' ToleranceVerdict and ToleranceCheck, their tables report_tables.verdict_tables."""

import fnmatch

import numpy as np

import answer_rules
from report_records import ToleranceCheck, ToleranceVerdict
from report_util import flatten, labels_of, materials_of, probe_numbers, rows_by, to_float


def judge(kind, tol, ref, val, floor=0.0):
    """Returns (error, passed) for one quantity; error is what the tolerance bounds. `floor`: a
    relative error's denominator is at least this, so numbers that are both ~0 agree."""
    if val is None or (kind != "max" and ref is None):
        return None, None
    if kind == "max":
        err = val
    elif kind == "absolute":
        err = abs(val - ref)
    else:
        err = abs(val - ref) / max(abs(ref), floor, 1e-12)
    return err, err <= tol


def compute_verdicts(study, rows, probes):
    """([ToleranceVerdict] per phenomenon x material x fit (its worst quantity), [ToleranceCheck]
    per quantity judged)."""
    labels = labels_of(study)
    model_of = {f["label"]: f["model"] for f in study["fits"]}
    detail, summary = [], []
    grouped = rows_by(rows, "material", "label", "split")
    for name, v in study["verdicts"].items():
        tol, kind, source = float(v["tolerance"]), v["kind"], v["source"]
        for m in materials_of(study):
            why = answer_rules.not_valid_reason(study, source, m)
            for label in labels:
                checks = []  # [ToleranceCheck]
                if why:
                    # Not valid on this kind of reference: n/a with its reason, never judged.
                    summary.append(ToleranceVerdict(name, v["question"], m, label, "", None,
                                                    None, None, kind, tol, None, 0, why))
                    continue
                if source == "metrics":
                    vals = [to_float(r[v["metric"]])
                            for r in grouped.get((m, label, v["split"]), ())]
                    vals = [x for x in vals if x is not None]
                    if vals:
                        val = float(np.mean(vals))
                        err, ok = judge("max", tol, 0.0, val)
                        checks.append(ToleranceCheck(
                            name, m, label, f"{v['metric']} ({v['split']}, mean of {len(vals)})",
                            0.0, val, err, kind, tol, ok))
                else:
                    numbers = probe_numbers(probes, m, source)
                    if numbers:
                        # The reference's numbers; probes that measure models only (energy)
                        # report the true BRDF as "truth".
                        # The brdf probe calls the measured BRDF "measured".
                        ref = flatten(numbers.get("reference") or numbers.get("truth")
                                      or numbers.get("measured") or {})
                        mod = flatten(numbers.get(label, {}))
                        # The energy probe's parameter sweep is per model, not per fit: it says
                        # whether the model's form conserves energy over its parameter range.
                        sweep = (numbers.get("sweep") or {}).get(model_of.get(label, ""))
                        if sweep:
                            mod.update(flatten(sweep, "sweep."))
                        patterns = v.get("keys") or []
                        pool = list(mod.keys()) if kind == "max" else \
                            [k for k in ref if k in mod] + [k for k in mod if k not in ref]
                        if patterns:
                            keys = [k for k in pool if any(fnmatch.fnmatchcase(k, p) for p in patterns)]
                        else:
                            keys = [k for k in pool if kind == "max" or k in ref]
                        for k in keys:
                            err, ok = judge(kind, tol, ref.get(k), mod.get(k),
                                            float(v.get("floor", 0.0)))
                            checks.append(ToleranceCheck(name, m, label, k, ref.get(k),
                                                         mod.get(k), err, kind, tol, ok))
                detail += checks
                judged = [c for c in checks if c.reproduced is not None]
                if not judged:
                    summary.append(ToleranceVerdict(name, v["question"], m, label, "", None,
                                                    None, None, kind, tol, None, 0))
                    continue
                worst = max(judged, key=lambda c: c.error / tol if tol > 0 else c.error)
                summary.append(ToleranceVerdict(
                    name, v["question"], m, label, worst.quantity, worst.reference, worst.model,
                    worst.error, kind, tol, all(c.reproduced for c in judged), len(judged)))
    return summary, detail
