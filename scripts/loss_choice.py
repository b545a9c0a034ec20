#!/usr/bin/env python3
"""Which loss carries over best: the held-out error of each loss's fits under every metric of the
report's judging set, from a study that fits the same models under several losses (docs/fitting.md,
"Which loss for measured materials"; studies/merl_losses.toml).

    /usr/bin/python3 scripts/loss_choice.py OUT/merl_losses [--md table.md]

Per metric of the judging set, per loss: the geometric mean over every (material, model) of the
fit's error over the test lightings divided by the first loss's (the study's first; < 1: the loss
carries over better), and on how many (material, model) the loss has the lowest error of all
losses. The criterion: the loss with the lowest mean log ratio over the judging set. Reads
study.json and results.csv only, with the report's readers; the judging set and the error orientation are the report's
(report/judging.py, report/answer_rules.py)."""

import argparse
import math
import os
import sys

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "report"))
import judging  # noqa: E402
from answer_rules import metric_error  # noqa: E402
from report_inputs import ReportInputError, check_study, load_json, read_results  # noqa: E402


def held_out_errors(rows, metric):
    """{(material, model, loss): error over the fit's test lightings, smaller is better}."""
    values = {}
    for r in rows:
        if r["split"] != "test" or r[metric] == "":
            continue
        values.setdefault((r["material"], r["model"], r["loss"]), []).append(float(r[metric]))
    return {k: metric_error(metric, v) for k, v in values.items()}


def loss_table(study, rows):
    losses = study["losses"] or sorted({r["loss"] for r in rows})
    metrics, why = judging.judging_set(study, set(rows[0]))
    table = {}
    for m in metrics:
        err = held_out_errors(rows, m)
        keys = sorted({(a, b) for a, b, _ in err})
        keys = [k for k in keys if all(err.get((*k, l), 0) > 0 for l in losses)]
        for l in losses:
            logs = [math.log(err[(*k, l)] / err[(*k, losses[0])]) for k in keys]
            best = sum(1 for k in keys if min(losses, key=lambda x: err[(*k, x)]) == l)
            table[(m, l)] = (math.exp(sum(logs) / len(logs)), best, len(keys))
    score = {l: sum(math.log(table[(m, l)][0]) for m in metrics) / len(metrics) for l in losses}
    return losses, metrics, why, table, score


def markdown(losses, metrics, table, score):
    head = ["loss"] + [judging.metric_name(m) for m in metrics] + ["mean ratio"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for l in losses:
        cells = [f"{table[(m, l)][0]:.2f} ({table[(m, l)][1]}/{table[(m, l)][2]})" for m in metrics]
        lines.append(f"| {l} | " + " | ".join(cells) + f" | {math.exp(score[l]):.2f} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("study_dir")
    ap.add_argument("--md", help="also write the table to this Markdown file")
    a = ap.parse_args()
    try:
        study_path = os.path.join(a.study_dir, "study.json")
        study = load_json(study_path)
        check_study(study, study_path)
        rows = read_results(os.path.join(a.study_dir, "results.csv"))
    except ReportInputError as e:
        sys.exit(f"loss_choice: error: {e}")
    if not rows or "loss" not in rows[0]:
        sys.exit(f"loss_choice: error: {a.study_dir}/results.csv: loss: no such column")
    losses, metrics, why, table, score = loss_table(study, rows)
    text = markdown(losses, metrics, table, score)
    best = min(losses, key=lambda l: score[l])
    print(f"Judging set: {why}")
    print(text)
    print(f"\nLowest held-out error under the judging set: {best} "
          f"(mean ratio to {losses[0]} {math.exp(score[best]):.2f})")
    if a.md:
        tmp = a.md + ".tmp"
        with open(tmp, "w") as f:
            f.write(text + "\n")
        os.replace(tmp, a.md)


if __name__ == "__main__":
    main()
