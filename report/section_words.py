"""The answer sections after the comparisons, in words and tables: the model's floor
(model_floor's ratios and the orderings they reverse), the data floor (data_floor's record),
where the difference lies (report_regions' means) and the material classes (report_classes'
verdicts). Formats what those modules computed; computes no statistic and reads no file."""

import judging
from answer_words import fmt_range
from report_regions import extra_error


def floor_sentence(e):
    """One FloorEntry in words: its ratios over the floor and their CIs."""
    ratios = [v.ratio for v in e.metrics.values()]
    los = [v.ci[0] for v in e.metrics.values() if v.ci[0] is not None]
    his = [v.ci[1] for v in e.metrics.values() if v.ci[1] is not None]
    ci = f"; 95% CIs from {min(los):.3g} to {max(his):.3g}" if los and his else ""
    above = sum(1 for v in e.metrics.values() if v.ci[0] is not None and v.ci[0] > 1)
    what = f"{e.fit} (the BRDF-space fit)" if e.role == "brdf" else e.fit
    return (f"{what}'s error over its floor {e.floor} on {', '.join(e.lightings)}: "
            f"{fmt_range((min(ratios), max(ratios)))} over the {len(ratios)} metrics{ci}; the CI "
            f"lies above 1 under {above} of {len(ratios)}")


def ordering_sentences(records):
    """Where the floors order a model pair otherwise than a training set does: a sentence per
    (question, pair). The floors' verdict is the floor pair's on the training question (the
    floor fits train on every floor lighting)."""
    train_q = next((r for r in records if r.source == "metrics" and r.split == "train"),
                   None)
    if train_q is None:
        return {}
    floors = {(p.model, p.baseline_model, p.loss): p for p in train_q.comparisons
              if p.role == "floor"}
    out = {}
    for rec in (r for r in records if r.source == "metrics"):
        lines = []
        for p in (p for p in rec.comparisons if p.role == "train"):
            fp = floors.get((p.model, p.baseline_model, p.loss))
            if fp is None or fp.verdict.kind == p.verdict.kind:
                continue
            lines.append(f"The floors order {p.model} and {p.baseline_model} otherwise "
                         f"than one training set does: {fp.fit} vs {fp.baseline} is "
                         f"'{fp.verdict.word}', {p.fit} vs {p.baseline} on this "
                         f"question is '{p.verdict.word}'")
        out[rec.name] = lines
    return out


def model_floor_lines(floors, records):
    """List items (depth, text) per question: the ratios over the floor, then the ordering
    sentences."""
    if not floors:
        return []
    order = ordering_sentences(records)
    lines = []
    for rec in (r for r in records if r.source == "metrics"):
        entries = floors.get(rec.name, [])
        if not entries and not order.get(rec.name):
            continue
        lines.append((0, f"**{rec.question}**"))
        lines += [(1, f"{floor_sentence(e)}.") for e in entries]
        lines += [(1, f"{s}.") for s in order.get(rec.name, [])]
    return lines


def model_floor_table(floors):
    cols = ["question", "fit", "floor", "lightings", "metric", "materials",
            "error ratio fit/floor", "95% CI"]
    out = []
    for q, entries in floors.items():
        for e in entries:
            for m, v in e.metrics.items():
                lo, hi = v.ci
                out.append([q, e.fit, e.floor, ", ".join(e.lightings),
                            judging.metric_name(m), str(v.n), f"{v.ratio:.3g}x",
                            "" if lo is None else f"{lo:.3g}-{hi:.3g}"])
    return cols, out


def region_sentence(means, split, pair):
    fit, base = pair.fit, pair.baseline
    where = extra_error(means, split, fit, base)
    if where is None:
        return (f"{fit}'s mean absolute error is not larger than {base}'s in any region of the "
                f"{split} lightings")
    l, g, a, b = where
    side = "brighter" if a.signed > 0 else "darker"
    return (f"{fit}'s largest extra error over {base} is under {l} in the {g}: it is {side} "
            f"than the reference there (mean signed {a.signed:+.3g}, mean |error| "
            f"{a.abs:.3g}; {base}: {b.signed:+.3g}, {b.abs:.3g}; reference mean "
            f"{a.ref:.3g}, luminance over {a.materials} materials)")


def region_lines(means, records):
    """List items (depth, text): per image question, a sentence per compared pair."""
    if means is None:
        return []
    lines = []
    for rec in (r for r in records if r.source == "metrics" and r.comparisons):
        lines.append((0, f"**{rec.question}**"))
        lines += [(1, f"{region_sentence(means, rec.split, p)}.") for p in rec.comparisons]
    return lines


def region_table(means):
    cols = ["split", "lighting", "region", "fit", "materials", "mean signed error",
            "mean |error|", "reference mean"]
    rows = [[s, l, g, f, str(v.materials), f"{v.signed:+.3g}", f"{v.abs:.3g}", f"{v.ref:.3g}"]
            for (s, l, g, f), v in sorted(means.items())]
    return cols, rows


def class_lines(answers):
    """List items (depth, text) of report_classes' ClassAnswers: per class, each image
    question's verdict per pair; then why classes are left out."""
    lines = []
    for c in answers.classes:
        lines.append((0, f"**{c.class_name}** ({c.scheme}; {len(c.materials)} materials: "
                         f"{', '.join(c.materials)})"))
        for q in c.questions:
            lines.append((1, q.question))
            for p in q.pairs:
                rng = p.ratio_range
                r = "" if rng is None else f", {fmt_range(rng)}"
                lines.append((2, f"{p.fit} vs {p.baseline}: {p.verdict.word}{r}"))
    lines += [(0, f"Left out: {s}.") for s in answers.skipped]
    return lines


# --- The data floor (data_floor.compute_floor) ------------------------------------------------


def pct(x):
    return "n/a" if x is None else f"{100.0 * x:.2f} %"


def data_floor_sentences(floor):
    """The data floor (data_floor.compute_floor's DataFloor) in summary.md's and index.html's
    lines: one per material and training set, each fit's test error against the floor's."""
    lines = []
    for rec in floor.materials:
        head = (f"{floor_material_name(rec)} (trained on {'+'.join(rec.train)}): the best "
                f"isotropic BRDF these photographs support (tabulated f(theta_h, theta_d), no "
                f"model) has a test relative RMSE of {pct(rec.test_relative_rmse)} "
                f"(training {pct(rec.train_relative_rmse)})")
        dec = rec.decoding
        if dec:
            how = dec.chosen + (f" {dec.gamma:.3f}" if dec.gamma else "")
            head += f", in the decoding {dec.label} chose ({how})"
        head += "."
        parts = []
        for f in rec.fits:
            d = f.points_above_floor
            if d is None:
                parts.append(f"{f.label}: no test error")
            elif d >= 0:
                parts.append(f"{f.label} is {d:.2f} points above what any isotropic BRDF "
                             f"reaches on these photographs ({pct(f.test_relative_rmse)})")
            else:
                parts.append(f"{f.label} is {-d:.2f} points below the floor "
                             f"({pct(f.test_relative_rmse)}; the table's grid and smoothing "
                             f"cost more than the model's error)")
        above = any(f.points_above_floor is not None and f.points_above_floor >= 0
                    for f in rec.fits)
        tail = "; the rest is the setup." if above else "."
        lines.append(head + (" " + "; ".join(parts) + tail if parts else ""))
    for s in floor.skipped:
        lines.append(f"{s['reference']}: not in the floor ({s['why']}).")
    return lines


def floor_material_name(rec):
    """'red-plastic', or 'red-plastic on teapot' where the photographs show several objects."""
    return rec.material + (f" on {rec.object}" if rec.object else "")


def data_floor_table(floor):
    """The data floor's table: each fit's test error next to the floor's, per material and
    training set."""
    cols = ["material", "training", "fit", "test rel. RMSE", "floor", "points above"]
    rows = []
    for rec in floor.materials:
        train = "+".join(rec.train)
        name = floor_material_name(rec)
        rows.append([name, train, "floor (tabulated, no model)",
                     pct(rec.test_relative_rmse), pct(rec.test_relative_rmse), "0.00"])
        for f in rec.fits:
            d = f.points_above_floor
            rows.append([name, train, f.label, pct(f.test_relative_rmse),
                         pct(rec.test_relative_rmse), "n/a" if d is None else f"{d:.2f}"])
    return cols, rows
