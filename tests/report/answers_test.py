#!/usr/bin/python3
"""Answers that hold (issue 40; report/judging.py, answer_rules.py, model_floor.py,
report_regions.py, report_classes.py, report_findings.py) on tiny synthetic studies written here:

- two metrics of the judging set say the fit's error is larger, six say smaller, each
  Holm-significant: the verdict is "metric-dependent", naming the metrics of each side, and no
  sentence states the question as one metric's answer (summary.md, index.html, report.tex);
- one metric the other way without significance: "mixed"; all metrics one way: "smaller under
  all 8 metrics"; a study's own judging set replaces the default, and one naming a metric that
  is no column is one error line;
- two losses: pairs within each loss, and whether the verdict holds across them;
- the default judging set follows from the human-agreement table by the stated rule;
- a lighting neither trained on nor in [fit] test (split "other") runs end to end;
- the error over the floor equals the per-material geometric means computed here by hand, the
  BRDF fit's likewise, and a floor ordering unlike the one-image ordering is said in words;
- the region sentence names the lighting and region of the extra error and its sign;
- classes with >= 4 materials get their own verdicts, smaller classes are named as left out.

    answers_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import csv
import json
import math
import os
import shutil
import subprocess
import sys

import numpy as np

FAILURES = []
METRICS = ["rmse", "relative_rmse", "log_rmse", "mae", "psnr", "ssim", "ms_ssim",
           "ciede2000_mean", "flip_ldr_mean", "flip_hdr_mean", "delta_e_itp_mean"]
SIMILARITY = {"ssim", "ms_ssim"}
DEFAULT_SET = ["relative_rmse", "ms_ssim", "rmse", "delta_e_itp_mean", "flip_hdr_mean", "ssim",
               "ciede2000_mean", "log_rmse"]


def check(ok, what):
    if not ok:
        FAILURES.append(what)
    return ok


def write_json(path, obj):
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w", encoding="utf-8") as f:
        json.dump(obj, f, indent=1)


def fit(model, train, loss="l2", role="train", label=None):
    return {"label": label or model, "model": model, "train": train, "loss": loss, "role": role}


def split_of(f, lighting, test):
    if lighting in f["train"]:
        return "train"
    return "test" if not test or lighting in test else "other"


def write_study(d, materials, fits, lightings, error, test=(), floor=(), judging=None,
                losses=("l2",), measured_folder=None, regions=None):
    """A study whose every metric of fit f on material i under lighting l is error(metric, i,
    f, l) (an error: 1 - value for the SSIM family). `regions(i, f, l)`: {region: (signed,
    abs, ref, pixels)}, written as results.csv's region columns."""
    shutil.rmtree(d, ignore_errors=True)
    study = {"name": os.path.basename(d), "description": "synthetic: answers that hold",
             "fits": fits, "training_sets": sorted({tuple(f["train"]) for f in fits}),
             "baseline": "blinn-phong", "compare": [], "test_lightings": list(test),
             "groups": [{"material": m, "references": [{"lighting": l, "sidecar": ""}
                                                       for l in lightings]} for m in materials],
             "probes": [], "verdicts": {}, "losses": list(losses), "floor": list(floor),
             "judging": judging,
             "measured": ([{"folder": measured_folder, "present": True, "materials": materials}]
                          if measured_folder else [])}
    write_json(os.path.join(d, "study.json"), study)
    rows = []
    for i, m in enumerate(materials):
        for f in fits:
            evaluations = []
            for l in lightings:
                split = split_of(f, l, test)
                evaluations.append({"lighting": l, "split": split, "metrics": {}})
                row = {"material": m, "lighting": l, "label": f["label"], "split": split,
                       "converged": "1"}
                for metric in METRICS:
                    e = error(metric, i, f, l)
                    row[metric] = f"{1 - e if metric in SIMILARITY else e:.17g}"
                for g, (s, a, ref, px) in (regions(i, f, l) if regions else {}).items():
                    row.update({f"region_{g}_signed": f"{s:.17g}", f"region_{g}_abs": f"{a:.17g}",
                                f"region_{g}_ref": f"{ref:.17g}", f"region_{g}_pixels": str(px)})
                rows.append(row)
            write_json(os.path.join(d, "jobs", f"fit.{m}.{f['label'].replace('@', '_')}.json"),
                       {"kind": "fit", "material": m, "label": f["label"], "model": f["model"],
                        "train": f["train"], "parameters": [], "evaluations": evaluations,
                        "exposure": 0.0, "converged": True, "termination": "CONVERGENCE"})
    with open(os.path.join(d, "results.csv"), "w", newline="", encoding="utf-8") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0].keys()))
        w.writeheader()
        w.writerows(rows)


def read(d, name):
    with open(os.path.join(d, "report", name), encoding="utf-8") as f:
        return json.load(f) if name.endswith(".json") else f.read()


def question(comp, name):
    return next(q for q in comp["questions"] if q["name"] == name)


def pair_of(comp, qname, fit_label):
    return next(p for p in question(comp, qname)["comparisons"] if p["fit"] == fit_label)


BASE = np.random.default_rng(7).uniform(0.05, 0.4, 12)
MATERIALS = [f"material-{i:02d}" for i in range(12)]
TWO = fit("blinn-phong", ["key"]), fit("ggx", ["key"])


def scaled(factors):
    """error(): blinn-phong's error is BASE[i]; ggx's is BASE[i] times factors[metric]
    (default 0.5), with a little per-material jitter so the ratios are not all tied."""
    def error(metric, i, f, l):
        if f["model"] == "blinn-phong":
            return BASE[i] * 0.5
        jitter = 1 + 0.01 * ((i * 7) % 5)
        return BASE[i] * 0.5 * factors.get(metric, 0.5) * jitter
    return error


def one_metric_sentences(text):
    """Sentences that state a pair's image answer under one metric: the old 'ggx's error is
    2x larger than blinn-phong's' form."""
    return [s for s in text.split("\n") if "x larger than blinn-phong" in s
            or "x smaller than blinn-phong" in s]


def test_metric_dependent(make_report, out):
    d = os.path.join(out, "metric_dependent")
    write_study(d, MATERIALS, list(TWO), ["key", "side"],
                scaled({"rmse": 2.0, "relative_rmse": 2.0}))
    make_report.make_report(d)
    comp, md, page = read(d, "comparisons.json"), read(d, "summary.md"), read(d, "index.html")
    tex = read(d, "report.tex")
    p = pair_of(comp, "transfer", "ggx")
    v = p["verdict"]
    check([c["metric"] for c in p["per_metric"]] == DEFAULT_SET,
          f"metric-dependent: metrics {[c['metric'] for c in p['per_metric']]}")
    check(v["word"] == "metric-dependent", f"metric-dependent: verdict '{v['word']}'")
    check(sorted(v["larger"]) == ["relative_rmse", "rmse"]
          and sorted(v["significant_larger"]) == ["relative_rmse", "rmse"]
          and len(v["significant_smaller"]) == 6,
          f"metric-dependent: sides {v}")
    sentence = next((l for l in md.split("\n") if "ggx vs blinn-phong: metric-dependent" in l), "")
    check("larger under relative RMSE, RMSE" in sentence and "smaller under MS-SSIM" in sentence,
          f"metric-dependent: summary.md does not name the metrics of each side: '{sentence}'")
    for where, text in (("summary.md", md), ("index.html", page)):
        check(not one_metric_sentences(text),
              f"metric-dependent: {where} states one metric's answer: {one_metric_sentences(text)}")
    check("metric-dependent" in md.split("## Answers")[0],
          "metric-dependent: the findings table before the answers has no 'metric-dependent'")
    check(page.index("id='findings'") < page.index("id='answers'") and "<details>" in page,
          "metric-dependent: index.html does not open with the findings, sentences folded")
    check(tex.index("Findings") < tex.index("section*{Tables}")
          and "findings-forest" in tex.split("section*{Tables}")[0],
          "metric-dependent: report.tex does not open with the findings and the forest plot")
    figs = read(d, "figures.json")
    check(figs[0].get("kind") == "forest", "metric-dependent: the forest plot is not first")
    # Every metric measured, judged or not, in one descriptive table (issue 40's table).
    every = {(r[2], r[3]): r for r in comp["every_metric"]["rows"]}
    flip, rmse = every.get(("mean LDR-FLIP", "")), every.get(("RMSE", "yes"))
    check(flip is not None and rmse is not None and flip[5].startswith("0.5")
          and rmse[5].startswith("2.0") and rmse[5].endswith(", 0/12"),
          f"metric-dependent: every-metric table rows {flip}, {rmse}")

    # One metric the other way, not significant: "mixed" (never one metric's answer either).
    d = os.path.join(out, "mixed")

    def error(metric, i, f, l):
        if metric == "rmse" and f["model"] == "ggx":  # around 1x, half the materials each way
            return BASE[i] * 0.5 * (1.3 if i % 2 else 0.8)
        return scaled({})(metric, i, f, l)
    write_study(d, MATERIALS, list(TWO), ["key", "side"], error)
    make_report.make_report(d)
    v = pair_of(read(d, "comparisons.json"), "transfer", "ggx")["verdict"]
    check(v["word"] == "mixed" and v["larger"] == ["rmse"] and not v["significant_larger"],
          f"mixed: verdict {v}")

    # All metrics one way.
    d = os.path.join(out, "all_agree")
    write_study(d, MATERIALS, list(TWO), ["key", "side"], scaled({}))
    make_report.make_report(d)
    v = pair_of(read(d, "comparisons.json"), "image", "ggx")["verdict"]
    check(v["word"] == "smaller under all 8 metrics" and len(v["significant_smaller"]) == 8,
          f"all agree: verdict {v}")


def test_judging_set(make_report, out):
    sys.path.insert(0, os.path.dirname(make_report.__file__))
    import judging
    check(judging.default_judging_set() == DEFAULT_SET,
          f"default set {judging.default_judging_set()}, want {DEFAULT_SET}")
    # The edge: log RMSE's rho equals the CI's lower bound (inside); a tie for best uses the
    # CIs of both; PSNR is counted as RMSE.
    table = {"a": (0.6, 0.4, 0.8), "b": (0.6, 0.3, 0.7), "c": (0.3, 0.0, 0.5),
             "rmse": (0.5, 0.2, 0.6), "psnr": (0.55, 0.2, 0.7)}
    check(judging.default_judging_set(table) == ["a", "b", "psnr", "c"],
          f"rule on a hand table: {judging.default_judging_set(table)}")
    d = os.path.join(out, "own_set")
    write_study(d, MATERIALS, list(TWO), ["key", "side"], scaled({"rmse": 2.0}),
                judging=["rmse", "ssim"])
    make_report.make_report(d)
    p = pair_of(read(d, "comparisons.json"), "transfer", "ggx")
    check([c["metric"] for c in p["per_metric"]] == ["rmse", "ssim"]
          and p["verdict"]["word"] == "metric-dependent",
          f"own set: {[c['metric'] for c in p['per_metric']]} {p['verdict']['word']}")
    write_study(d, MATERIALS, list(TWO), ["key", "side"], scaled({}), judging=["sharpness"])
    r = subprocess.run(["/usr/bin/python3", make_report.__file__, d], capture_output=True,
                       text=True)
    check(r.returncode == 1 and "field 'judging[0]': 'sharpness' is not a metric column"
          in r.stderr and len(r.stderr.strip().splitlines()) == 1,
          f"own set, unknown metric: exit {r.returncode}: {r.stderr.strip()}")


def test_old_study(make_report, out):
    """A study.json from before losses and floors: each fit's loss is its model's fit-settings
    loss, its role "brdf" for train == ["brdf"], else "train"."""
    import report_inputs
    study = {"fits": [{"label": "ggx@key", "model": "ggx", "train": ["key"]},
                      {"label": "ggx@brdf", "model": "ggx", "train": ["brdf"]},
                      {"label": "bp@key", "model": "bp", "train": ["key"]}],
             "fit_settings": {"ggx": {"loss": "log"}, "bp": {}}}
    report_inputs.normalise_fits(study)
    got = [(f["loss"], f["role"]) for f in study["fits"]]
    check(got == [("log", "train"), ("log", "brdf"), ("l2", "train")]
          and study["losses"] == ["l2", "log"] and study["floor"] == []
          and study["judging"] is None, f"old study.json: {got}, {study}")


def test_losses(make_report, out):
    fits = [fit(m, ["key"], loss, label=f"{m}:{loss}") for loss in ("l2", "log")
            for m in ("blinn-phong", "ggx")]

    def error(metric, i, f, l):
        if f["loss"] == "l2":
            return scaled({"rmse": 2.0, "relative_rmse": 2.0})(metric, i, f, l)
        return scaled({})(metric, i, f, l)
    d = os.path.join(out, "losses")
    write_study(d, MATERIALS, fits, ["key", "side"], error, losses=("l2", "log"))
    make_report.make_report(d)
    comp = read(d, "comparisons.json")
    q = question(comp, "transfer")
    pairs = {(p["fit"], p["baseline"]) for p in q["comparisons"]}
    check(pairs == {("ggx:l2", "blinn-phong:l2"), ("ggx:log", "blinn-phong:log")},
          f"losses: pairs {pairs} are not within one loss")
    a = q["across_losses"]
    check(len(a) == 1 and not a[0]["holds"]
          and a[0]["verdicts"] == {"l2": "metric-dependent", "log": "smaller"},
          f"losses: across losses {a}")
    check("the verdict does not hold across losses" in read(d, "summary.md"),
          "losses: summary.md does not say the verdict does not hold across losses")
    check("(trained on key) | differs: l2 metric-dependent, log smaller |" in read(d, "summary.md"),
          "losses: the findings have no 'Across losses' table saying the verdict differs")


def test_other_split(make_report, out):
    d = os.path.join(out, "other")
    write_study(d, MATERIALS, list(TWO), ["key", "side", "back"], scaled({}), test=["side"])
    with open(os.path.join(d, "results.csv"), encoding="utf-8") as f:
        check(",other," in f.read(), "other: the synthetic study has no 'other' row")
    r = subprocess.run(["/usr/bin/python3", make_report.__file__, d], capture_output=True,
                       text=True)
    check(r.returncode == 0 and os.path.exists(os.path.join(d, "report", "index.html")),
          f"other: make_report.py exit {r.returncode}: {r.stderr.strip()[-300:]}")
    if r.returncode == 0:
        metrics = read(d, os.path.join("tables", "metrics.csv"))
        check(",other," in metrics, "other: the metrics table drops the 'other' rows")
    # A split the runner never writes is still one error line naming the cell.
    path = os.path.join(d, "results.csv")
    with open(path, encoding="utf-8") as f:
        text = f.read()
    with open(path, "w", encoding="utf-8") as f:
        f.write(text.replace(",other,", ",elsewhere,", 1))
    shutil.rmtree(os.path.join(d, "report"))
    r = subprocess.run(["/usr/bin/python3", make_report.__file__, d], capture_output=True,
                       text=True)
    check(r.returncode == 1 and "field 'split': expected 'train' or 'test' or 'other', got "
          "'elsewhere'" in r.stderr and not os.path.exists(os.path.join(d, "report")),
          f"other: a bad split: exit {r.returncode}: {r.stderr.strip()}")


def test_floor(make_report, out):
    floor = ["key", "side", "back"]
    fits = [fit("blinn-phong", ["key"], label="blinn-phong@key"),
            fit("ggx", ["key"], label="ggx@key"),
            fit("blinn-phong", floor, role="floor", label="blinn-phong@floor"),
            fit("ggx", floor, role="floor", label="ggx@floor"),
            fit("ggx", ["brdf"], role="brdf", label="ggx@brdf")]
    rng = np.random.default_rng(3)
    k = {(i, f["label"], l): float(rng.uniform(0.5, 3.0))
         for i in range(12) for f in fits for l in floor}

    def error(metric, i, f, l):
        e = BASE[i] * k[(i, f["label"], l)]
        if f["label"] == "ggx@key":   # one image: ggx worse than blinn-phong everywhere
            e *= 4
        if f["label"] == "ggx@floor":  # floors: ggx better
            e *= 0.25
        return e * (2 if metric == "rmse" else 1)
    d = os.path.join(out, "floor")
    write_study(d, MATERIALS, fits, floor, error, floor=floor)
    make_report.make_report(d)
    comp = read(d, "comparisons.json")
    entries = comp["floors"]["transfer"]
    e = next(x for x in entries if x["fit"] == "ggx@key")
    check(e["floor"] == "ggx@floor" and e["lightings"] == ["side", "back"],
          f"floor: ggx@key against {e['floor']} on {e['lightings']}")
    def by_hand(fit_, floor_, lightings):
        """Per material: mean error over the lightings, fit over floor; geometric mean."""
        return math.exp(np.mean([math.log(sum(error("ssim", i, fit_, l) for l in lightings)
                                          / sum(error("ssim", i, floor_, l) for l in lightings))
                                 for i in range(12)]))
    want = by_hand(fits[1], fits[3], ("side", "back"))
    got = e["metrics"]["relative_rmse"]["ratio"]
    check(abs(got - want) < 1e-9 * want, f"floor: ratio over the floor {got}, by hand {want}")
    lo, hi = e["metrics"]["relative_rmse"]["ci"]
    check(lo is not None and lo <= want <= hi, f"floor: CI {lo}-{hi} does not hold {want}")
    b = next(x for x in entries if x["fit"] == "ggx@brdf")
    want = by_hand(fits[4], fits[3], floor)
    check(b["lightings"] == floor and abs(b["metrics"]["rmse"]["ratio"] - want) < 1e-9 * want,
          f"floor: BRDF fit over the floor {b['metrics']['rmse']['ratio']}, by hand {want}")
    image = comp["floors"]["image"]
    check([x["lightings"] for x in image if x["fit"] == "ggx@key"] == [["key"]],
          "floor: the training question is not judged on the trained floor lighting")
    pairs = {(p["fit"], p["baseline"]) for p in question(comp, "image")["comparisons"]}
    check(("ggx@floor", "blinn-phong@floor") in pairs, f"floor: no floor vs floor pair: {pairs}")
    order = comp["floor_order"]["transfer"]
    check(any("The floors order ggx and blinn-phong otherwise" in s for s in order),
          f"floor: no ordering sentence: {order}")
    check("The floors order ggx and blinn-phong otherwise" in read(d, "summary.md"),
          "floor: summary.md has no ordering sentence")


def test_regions(make_report, out):
    def regions(i, f, l):
        rim = (0.3, 0.3, 1.0, 50) if f["model"] == "ggx" and l == "side" else (-0.05, 0.1, 1.0, 50)
        return {"highlight": (0.0, 0.1, 5.0, 10), "rim": rim, "body": (0.01, 0.05, 0.5, 400)}
    d = os.path.join(out, "regions")
    write_study(d, MATERIALS, list(TWO), ["key", "side", "back"], scaled({}), regions=regions)
    make_report.make_report(d)
    md = read(d, "summary.md")
    check("ggx's largest extra error over blinn-phong is under side in the rim: it is brighter "
          "than the reference there (mean signed +0.3" in md,
          "regions: summary.md has no sentence naming side, rim, brighter, +0.3")
    figs = read(d, "figures.json")
    check(sum(1 for f in figs if f.get("kind") == "regions") == 2,
          "regions: not one region figure per image question")
    check(all(not f["text_overlaps"] and not f["text_outside"] for f in figs
              if f.get("kind") in ("regions", "forest")),
          "regions: text overlaps in the region or forest figures")


def test_classes(make_report, out):
    metals = ["alum-bronze", "aluminium", "brass", "chrome", "nickel"]
    plastics = ["blue-acrylic", "delrin", "pvc", "teflon"]
    paints = ["gold-metallic-paint", "red-metallic-paint"]
    materials = metals + plastics + paints
    brdf = os.path.join(out, "brdf-data")
    os.makedirs(os.path.join(brdf, "nbrdf"), exist_ok=True)
    with open(os.path.join(brdf, "merl-material-types.tsv"), "w", encoding="utf-8") as f:
        f.write("# synthetic copy for the test\nmaterial\ttype\n" + "".join(
            f"{m}\t{'Dielectric' if m in plastics else 'Metal'}\n" for m in materials))

    def error(metric, i, f, l):
        factor = 0.5 if materials[i] in metals + paints else 2.0  # ggx better on metals only
        e = 0.1 + 0.01 * i
        return e * (factor * (1 + 0.01 * i) if f["model"] == "ggx" else 1)
    d = os.path.join(out, "classes")
    write_study(d, materials, list(TWO), ["key", "side"], error,
                measured_folder=os.path.join(brdf, "nbrdf"))
    make_report.make_report(d)
    classes = read(d, "comparisons.json")["classes"]
    got = {(c["scheme"], c["class"]): c for c in classes["classes"]}
    check(set(got) == {("Metal/Dielectric", "Metal"), ("Metal/Dielectric", "Dielectric"),
                       ("finer classes", "metals"), ("finer classes", "plastics and phenolics")},
          f"classes: {sorted(got)}")
    word = {k: c["questions"][1]["pairs"][0]["verdict"]["word"] for k, c in got.items()}
    check(word.get(("finer classes", "metals")) == "smaller under all 8 metrics"
          and word.get(("finer classes", "plastics and phenolics")) == "larger under all 8 metrics",
          f"classes: verdicts {word}")
    check(any("paints" in s for s in classes["skipped"]),
          f"classes: the paints (2 materials) are not named as left out: {classes['skipped']}")
    md = read(d, "summary.md")
    check("**metals** (finer classes; 5 materials" in md, "classes: summary.md has no metals line")


def test_bootstrap_indices(make_report, out):
    """answer_stats.bootstrap_ci, its resample indices drawn once per sample size
    (_BootstrapRng), gives scipy's interval with a generator seeded anew for every sample, to the
    bit: samples of many sizes in an order that returns to each size, ties, a constant sample;
    and the generator's later draws are a freshly seeded generator's."""
    import warnings
    from scipy import stats
    import answer_stats

    def scipy_own(values):
        values = np.asarray(values, dtype=float)
        if len(values) < answer_stats.MIN_MATERIALS_FOR_CI:
            return None, None
        if np.ptp(values) == 0:
            return float(values[0]), float(values[0])
        rng = np.random.default_rng(answer_stats.BOOTSTRAP_SEED)
        for method in ("BCa", "percentile"):
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = stats.bootstrap((values,), np.mean, confidence_level=0.95, method=method,
                                      n_resamples=answer_stats.BOOTSTRAP_RESAMPLES,
                                      random_state=rng)
            lo, hi = res.confidence_interval
            if np.isfinite(lo) and np.isfinite(hi):
                return float(lo), float(hi)
        return None, None

    rng = np.random.default_rng(11)
    samples = [rng.normal(size=n) for n in (20, 6, 12, 20, 3, 8, 6, 19, 12)]
    samples += [np.array([1.0, 1.0, 1.0, 2.0]), np.array([0.5] * 7), np.array([1.0, 2.0]),
                np.array([0.0, 0.0, 0.0, 0.0, 1e-3]), np.round(rng.normal(size=20), 1)]
    for values in samples:
        got, want = answer_stats.bootstrap_ci(values), scipy_own(values)
        check(got == want, f"bootstrap_ci of {len(values)} values: {got}, scipy's own {want}")
    # The generator itself: its draws are a freshly seeded one's, whether its first draw was
    # served from what an earlier generator drew or it draws something else first.
    for first in ("integers", "random"):
        for _ in range(2):  # the second time, the indices come from the first's draw
            mine = answer_stats._BootstrapRng()
            plain = np.random.default_rng(answer_stats.BOOTSTRAP_SEED)
            if first == "random":
                check(mine.random(3).tolist() == plain.random(3).tolist(),
                      "_BootstrapRng: a first draw of floats differs")
            a, b = mine.integers(0, 7, (50, 7)), plain.integers(0, 7, (50, 7))
            c, d = mine.integers(0, 7, (50, 7)), plain.integers(0, 7, (50, 7))
            check(np.array_equal(a, b) and np.array_equal(c, d)
                  and mine.random(4).tolist() == plain.random(4).tolist(),
                  f"_BootstrapRng (first draw {first}): other draws than default_rng's")


def main(argv):
    report_src, out = argv[1], os.path.abspath(argv[2])
    sys.path.insert(0, report_src)
    import make_report  # noqa: E402
    for test in (test_bootstrap_indices, test_metric_dependent, test_judging_set, test_old_study,
                 test_losses, test_other_split, test_floor, test_regions, test_classes):
        test(make_report, out)
    for f in FAILURES:
        print("FAILED: " + f)
    if not FAILURES:
        print("PASS: answers that hold (metric-dependent, mixed, all agree, judging set, losses, "
              "split other, floors, regions, classes)")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
