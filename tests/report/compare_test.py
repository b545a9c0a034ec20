#!/usr/bin/python3
"""Comparative answers (report/answer_rules.py and answer_stats.py, docs/studies.md "Comparative
answers") on result files with known answers, written here:

- a fit better by exactly 2x on every one of 20 materials under every metric of the judging set:
  ratio 2, a 95% CI containing 2, closer on 20 of 20, p < 0.001, "smaller under all 8 metrics";
- identical fits: ratio 1, p = 1;
- noisy errors: the effect, CI, closer count, Wilcoxon p and Holm-corrected p (one family of 16:
  two questions under 8 metrics) equal independent calls of numpy, scipy.stats and a
  hand-written Holm step-down here;
- five materials: the exact sign test (scipy.stats.binomtest);
- a probe not valid on measured references (image-space Fresnel) reads "n/a" with its reason in
  the verdicts, the matrix and summary.md, and is never judged;
- a study without [verdicts] still answers image closeness and new lighting, first in
  summary.md and index.html;
- all-pixel metric columns (measured references) are compared beside the measured-pixel ones,
  and the viewer shows each reference's measured domain.

    compare_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import csv
import json
import math
import os
import shutil
import sys

import numpy as np
from scipy import stats

FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)
    return ok


def write_json(path, obj):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(obj, f, indent=1)


def write_png(path):
    import matplotlib.image as mpimg
    os.makedirs(os.path.dirname(path), exist_ok=True)
    mpimg.imsave(path, np.full((8, 8, 3), 0.5))


def write_study(d, materials, errors, verdicts=None, measured=False, all_errors=None):
    """A study of two fits ("blinn-phong" baseline, "ggx") trained on "key", tested on "rim":
    `errors[label][i]` is material i's relative RMSE under both lightings (and LDR-FLIP = half
    of it). `all_errors`: the all-pixel column, as measured references have it."""
    shutil.rmtree(d, ignore_errors=True)
    fits = [{"label": m, "model": m, "train": ["key"]} for m in ("blinn-phong", "ggx")]
    study = {"name": os.path.basename(d), "description": "synthetic: comparative answers",
             "fits": fits, "training_sets": [["key"]], "baseline": "blinn-phong", "compare": [],
             "test_lightings": [],
             "groups": [{"material": m, "references": [{"lighting": l, "sidecar": ""}
                                                       for l in ("key", "rim")]}
                        for m in materials],
             "probes": [], "verdicts": verdicts or {},
             "measured": [{"folder": "x", "present": True, "materials": materials}] if measured else []}
    write_json(os.path.join(d, "study.json"), study)
    rows = []
    for i, m in enumerate(materials):
        for f in fits:
            evaluations = []
            for l in ("key", "rim"):
                split = "train" if l == "key" else "test"
                images = {}
                if measured:  # The viewer shows the measured domain beside the fits.
                    images = {k: f"images/{m}-{l}.{k}.png" for k in ("reference", "fit", "domain")}
                    for rel in images.values():
                        write_png(os.path.join(d, rel))
                evaluations.append({"lighting": l, "split": split, "images": images,
                                    "metrics": {}, "measured_fraction": 0.5})
                e = errors[f["label"]][i]
                # Every metric of the default judging set scales with e (1 - SSIM too), so a
                # fit's ratio is the same under each.
                row = {"material": m, "lighting": l, "label": f["label"], "split": split,
                       "converged": "1", "rmse": f"{e / 10:.17g}", "relative_rmse": f"{e:.17g}",
                       "log_rmse": f"{e / 3:.17g}", "psnr": "30", "ssim": f"{1 - e / 4:.17g}",
                       "ms_ssim": f"{1 - e / 5:.17g}", "ciede2000_mean": f"{e * 4:.17g}",
                       "flip_ldr_mean": f"{e / 2:.17g}", "flip_hdr_mean": f"{e / 6:.17g}",
                       "delta_e_itp_mean": f"{e * 3:.17g}"}
                if all_errors is not None:
                    row["relative_rmse_all"] = f"{all_errors[f['label']][i]:.17g}"
                rows.append(row)
            write_json(os.path.join(d, "jobs", f"fit.{m}.{f['model']}.key.json"),
                       {"kind": "fit", "material": m, "label": f["label"], "model": f["model"],
                        "train": f["train"],
                        "parameters": [{"name": "kd", "value": 0.2, "std_error": 0.01,
                                        "fixed": False, "at_bound": False,
                                        "undetermined": False}],
                        "evaluations": evaluations, "exposure": 0.0, "converged": True,
                        "termination": "CONVERGENCE"})
    with open(os.path.join(d, "results.csv"), "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)


def run(make_report, d):
    make_report.make_report(d)
    with open(os.path.join(d, "report", "comparisons.json"), encoding="utf-8") as f:
        comp = json.load(f)
    with open(os.path.join(d, "report", "summary.md"), encoding="utf-8") as f:
        md = f.read()
    with open(os.path.join(d, "report", "index.html"), encoding="utf-8") as f:
        page = f.read()
    return comp, md, page


def question(comp, name):
    return next(q for q in comp["questions"] if q["name"] == name)


def holm(p):
    """Holm's step-down adjustment, written out here as the independent check: sort, multiply
    the k-th smallest by (m - k), take running maxima, cap at 1, unsort."""
    m = len(p)
    order = sorted(range(m), key=lambda i: p[i])
    out, running = [0.0] * m, 0.0
    for k, i in enumerate(order):
        running = max(running, min(1.0, (m - k) * p[i]))
        out[i] = running
    return out


def main(argv):
    report_src, out = argv[1], os.path.abspath(argv[2])
    sys.path.insert(0, report_src)
    import make_report  # noqa: E402
    materials = [f"material-{i:02d}" for i in range(20)]
    rng = np.random.default_rng(11)
    base = rng.uniform(0.05, 0.5, 20)

    # 1. Better by exactly 2x everywhere.
    d = os.path.join(out, "twice")
    write_study(d, materials, {"blinn-phong": base, "ggx": base / 2})
    comp, md, page = run(make_report, d)
    pair = question(comp, "image")["comparisons"][0]
    check(pair["fit"] == "ggx" and pair["baseline"] == "blinn-phong",
          f"2x: pair {pair['fit']}/{pair['baseline']}")
    judged = question(comp, "image")["metrics"]
    check(len(pair["per_metric"]) == 8 and [c["metric"] for c in pair["per_metric"]] == judged,
          f"2x: not answered under the 8 metrics of the default set: {judged}")
    want_p = stats.wilcoxon(np.full(20, math.log(2.0))).pvalue
    for c in pair["per_metric"]:
        m = c["metric"]
        check(abs(c["effect"] - 2) < 1e-9, f"2x: {m}: ratio {c['effect']}, want 2")
        check(c["ci"][0] is not None and c["ci"][0] <= 2 + 1e-9 <= c["ci"][1] + 2e-9,
              f"2x: {m}: CI {c['ci']} does not contain 2")
        check(c["closer"] == 20 and c["n"] == 20, f"2x: {m}: closer {c['closer']} of {c['n']}")
        check(c["p"] < 0.001 and c["p_holm"] < 0.001, f"2x: {m}: p {c['p']}, Holm {c['p_holm']}")
        check(abs(c["p"] - want_p) <= 1e-12 * max(1, want_p), f"2x: p {c['p']} != scipy {want_p}")
    check(pair["verdict"]["word"] == "smaller under all 8 metrics",
          f"2x: verdict {pair['verdict']['word']}")
    # The answers come first, as sentences, in both pages.
    answers = md.split("## Answers", 1)[-1].split("\n## ", 1)[0]
    check("ggx vs blinn-phong: smaller under all 8 metrics" in answers,
          "2x: summary.md's Answers do not say 'ggx vs blinn-phong: smaller under all 8 metrics'")
    check("error ratio 0.5x over the metrics" in answers and "closer on 20 of 20 materials" in answers,
          "2x: summary.md: no ratio range 0.5-0.5x, closer on 20 of 20")
    check(md.index("## Answers") < md.index("## Within tolerance (secondary)"), "2x: Answers not first")
    check("id='answers'" in page and page.index("id='answers'") < page.index("id='verdicts'"),
          "2x: index.html does not open with the answers")
    check("smaller under all 8 metrics" in page, "2x: index.html: no sentence")
    # The human-agreement table of the metrics, with the judging set marked, in both pages.
    check("| relative RMSE | 0.62 | 0.35 to 0.79 | yes |" in md
          and "| mean LDR-FLIP | 0.34 | -0.06 to 0.63 |  |" in md,
          "2x: summary.md's human-agreement table does not mark the judging set")
    check("id='human-agreement'" in page and "Lavoue" in page,
          "2x: index.html has no human-agreement table")
    # Each material's error per fit and metric is a record, as fields (schema /3).
    errs = [r for r in question(comp, "image")["errors"] if r["metric"] == "relative_rmse"]
    check(comp["schema"] == "shadefit.comparisons/3" and len(errs) == 40
          and all(set(r) == {"material", "fit", "metric", "error"} for r in errs)
          and {r["fit"] for r in errs} == {"blinn-phong", "ggx"},
          f"2x: errors are not 40 records {{material, fit, metric, error}}: {errs[:2]}")
    ratio = {r["material"]: r["error"] for r in errs if r["fit"] == "blinn-phong"}
    check(all(abs(ratio[r["material"]] / r["error"] - 2) < 1e-9 for r in errs if r["fit"] == "ggx"),
          "2x: the records' errors are not the 2x pair")

    # 2. Identical fits.
    d = os.path.join(out, "same")
    write_study(d, materials, {"blinn-phong": base, "ggx": base.copy()})
    comp, md, _ = run(make_report, d)
    pair = question(comp, "image")["comparisons"][0]
    for c in pair["per_metric"]:
        check(c["effect"] == 1.0 and c["p"] == 1.0 and c["p_holm"] == 1.0 and c["closer"] == 0,
              f"identical: ratio {c['effect']}, p {c['p']}, Holm {c['p_holm']}, "
              f"closer {c['closer']}")
    check(pair["verdict"]["kind"] == "mixed" and len(pair["verdict"]["equal"]) == 8,
          f"identical: verdict {pair['verdict']}")

    # 3. Noisy errors against independent calls.
    factor = np.exp(rng.normal(0.4, 0.6, 20))
    ggx = base / factor
    d = os.path.join(out, "noisy")
    verdicts = {"image_flip": {"question": "Image (LDR-FLIP)?", "source": "metrics",
                               "metric": "flip_ldr_mean", "split": "train", "kind": "max",
                               "tolerance": 0.05}}
    write_study(d, materials, {"blinn-phong": base, "ggx": ggx}, verdicts=verdicts)
    comp, md, _ = run(make_report, d)
    logs = np.log(base / ggx)
    per = question(comp, "image_flip")["comparisons"][0]["per_metric"]
    c = next(c for c in per if c["metric"] == "relative_rmse")
    check(abs(c["effect"] - math.exp(np.mean(logs))) < 1e-9,
          f"noisy: effect {c['effect']} != {math.exp(np.mean(logs))}")
    check(c["closer"] == int(np.sum(ggx < base)), f"noisy: closer {c['closer']}")
    p_w = stats.wilcoxon(logs).pvalue
    check(abs(c["p"] - p_w) < 1e-12, f"noisy: p {c['p']} != scipy {p_w}")
    boot = stats.bootstrap((logs,), np.mean, n_resamples=10000, method="BCa",
                           random_state=np.random.default_rng(20261204)).confidence_interval
    check(abs(c["ci"][0] - math.exp(boot.low)) < 1e-9 and abs(c["ci"][1] - math.exp(boot.high)) < 1e-9,
          f"noisy: CI {c['ci']} != scipy {math.exp(boot.low)}-{math.exp(boot.high)}")
    check(math.exp(boot.low) < c["effect"] < math.exp(boot.high), "noisy: effect outside its CI")
    # Holm over the study's 16 tests (two questions, each under 8 metrics: image_flip, the
    # study's metric verdict on train, names the train question; the default transfer is added).
    names = [q["name"] for q in comp["questions"]]
    check(names == ["image_flip", "transfer"], f"noisy: questions {names}")
    tests = [c for q in comp["questions"] for c in q["comparisons"][0]["per_metric"]]
    want = holm([c["p"] for c in tests])
    got = [c["p_holm"] for c in tests]
    check(len(tests) == 16 and all(c["holm_family"] == 16 for c in tests),
          f"noisy: Holm family of {len(tests)} tests, want 16")
    check(all(abs(a - b) < 1e-12 for a, b in zip(got, want)), f"noisy: Holm {got} != {want}")

    # 4. Few materials: the exact sign test.
    d = os.path.join(out, "few")
    five = base[:5]
    worse = five * np.array([0.5, 0.6, 0.7, 1.5, 0.8])
    write_study(d, materials[:5], {"blinn-phong": five, "ggx": worse})
    comp, md, _ = run(make_report, d)
    c = question(comp, "image")["comparisons"][0]["per_metric"][0]
    p_b = stats.binomtest(4, 5, 0.5).pvalue
    check(c["test"] == "sign test" and abs(c["p"] - p_b) < 1e-12,
          f"few: {c['test']} p {c['p']}, want sign test {p_b}")
    check("exact sign test" in md, "few: summary.md does not name the sign test")

    # 5. A probe not valid on measured references: n/a with its reason, never judged.
    d = os.path.join(out, "measured")
    verdicts = {"fresnel": {"question": "Is the Fresnel effect reproduced?", "source": "fresnel",
                            "kind": "relative", "tolerance": 0.25}}
    write_study(d, materials, {"blinn-phong": base, "ggx": base / 2}, verdicts=verdicts,
                measured=True, all_errors={"blinn-phong": base * 3, "ggx": base * 6})
    # A probe job with numbers that would be judged (and fail) if the probe were used.
    for m in materials:
        write_json(os.path.join(d, "jobs", f"probe.{m}.json"), {
            "kind": "probe", "material": m, "probes": {"fresnel": {
                "schema": "shadefit.probe/4", "curves": [],
                "numbers": {"reference": {"rim_to_centre": 2.0},
                            "blinn-phong": {"rim_to_centre": -1.0},
                            "ggx": {"rim_to_centre": -3.0}}}}})
    comp, md, page = run(make_report, d)
    verd = json.load(open(os.path.join(d, "report", "verdicts.json"), encoding="utf-8"))
    fres = [s for s in verd["summary"] if s["phenomenon"] == "fresnel"]
    check(len(fres) == 40 and all(s["reproduced"] is None and s.get("not_valid") for s in fres),
          "measured: the image-space Fresnel probe was judged on a measured reference")
    check(not question(comp, "fresnel")["comparisons"], "measured: fresnel compared")
    check("image-space Fresnel probe" in md and "n/a" in md, "measured: summary.md gives no reason")
    matrix = md.split("## Verdict matrix", 1)[1]
    check("| fresnel |" in matrix and "n/a" in matrix.split("| fresnel |", 1)[1].split("\n")[0],
          "measured: the matrix row of fresnel is not n/a")
    check("n/a: the image-space Fresnel probe" in page, "measured: index.html gives no reason")
    check("images/material-00-rim.domain.png" in page and "50.0% of the covered pixels measured"
          in page, "measured: the viewer does not show the measured domain")
    # The all-pixel numbers beside the measured-pixel ones.
    img = question(comp, "image")
    check(abs(img["comparisons"][0]["per_metric"][0]["effect"] - 2) < 1e-9,
          "measured: measured-pixel ratio")
    check("all_pixels" in img
          and abs(img["all_pixels"][0]["per_metric"][0]["effect"] - 0.5) < 1e-9,
          f"measured: all-pixel comparison {img.get('all_pixels')}")
    check("all pixels, extrapolated data included: smaller under 0 and larger under 1 of 1 "
          "metrics" in md,
          "measured: summary.md does not print the all-pixel comparison beside")

    for f in FAILURES:
        print("FAILED: " + f)
    if not FAILURES:
        print("PASS: comparative answers (2x, identical, noisy vs scipy, sign test, n/a, "
              "all pixels)")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
