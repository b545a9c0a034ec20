#!/usr/bin/python3
"""Answers for one object and for several (issue 45 item 6; report/answer_rules.py,
image_units and object_answers) on hand-made result files whose answers are worked out here by
hand, not by the report's code:

- one material on one object (results.csv without an `object` column), 2 training and 8 test
  lightings, ggx's error exactly half blinn-phong's on every lighting under both metrics of the
  study's judging set (rmse, relative_rmse): the units are the 8 test lightings, so the ratio is
  0.5 (effect 2), the exact Wilcoxon p over 8 positive pairs is 2/2^8 = 0.0078125, Holm over the
  pair's 4 tests (2 questions x 2 metrics; the training question's 2 lightings give the sign test
  p = 0.5) makes it 4 x 0.0078125 = 0.03125 < 0.05: "smaller under all 2 metrics" with 2/2
  significant on new lighting; the pages say the answer is about this object under other lights;
  no empty table is printed (the study has no tolerance verdicts: no verdict matrix);
- seven materials (>= 6): the units stay the materials ("of 7 materials", no `unit`);
- one material on two objects (`object` column): on the teapot ggx is 0.5x blinn-phong on every
  test lighting, on the knot 2x; per object "smaller" and "larger under all 2 metrics", each over
  its 4 test lightings; pooled over both (2 material-object pairs, so 8 lightings) the log ratios
  cancel exactly: ratio 1, every metric tied, "mixed".

    objects_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import csv
import json
import os
import shutil
import sys

FAILURES = []
METRICS = ["rmse", "relative_rmse", "psnr", "ssim", "ciede2000_mean", "flip_ldr_mean",
           "flip_hdr_mean"]
TRAIN = ["T1", "T2"]


def check(ok, what):
    if not ok:
        FAILURES.append(what)


def fits():
    return [{"label": m, "model": m, "train": TRAIN, "loss": "l2", "role": "train"}
            for m in ("blinn-phong", "ggx")]


def write_study(d, cells):
    """cells: [(material, object or None, lighting, {label: error})]; rmse and relative_rmse
    are the error, the other metrics equal for both fits. object None: no `object` column."""
    shutil.rmtree(d, ignore_errors=True)
    os.makedirs(os.path.join(d, "jobs"))
    materials = list(dict.fromkeys(c[0] for c in cells))
    lightings = {m: list(dict.fromkeys(c[2] for c in cells if c[0] == m)) for m in materials}
    study = {"name": os.path.basename(d), "description": "synthetic: objects",
             "fits": fits(), "training_sets": [TRAIN], "baseline": "blinn-phong",
             "compare": [], "test_lightings": [],
             "groups": [{"material": m, "references": [{"lighting": l, "sidecar": ""}
                                                       for l in lightings[m]]}
                        for m in materials],
             "probes": [], "verdicts": {}, "losses": ["l2"], "floor": [],
             "judging": ["rmse", "relative_rmse"], "measured": []}
    with open(os.path.join(d, "study.json"), "w") as f:
        json.dump(study, f)
    with_object = cells[0][1] is not None
    rows = []
    for m, obj, l, err in cells:
        for label, e in err.items():
            row = {"material": m, "lighting": l, "label": label,
                   "split": "train" if l in TRAIN else "test", "converged": "1"}
            row.update({k: "30" if k == "psnr" else "0.5" for k in METRICS})
            row.update(rmse=f"{e:.17g}", relative_rmse=f"{e:.17g}")
            if with_object:
                row["object"] = obj
            rows.append(row)
    for m in materials:
        for f in fits():
            with open(os.path.join(d, "jobs", f"fit.{m}.{f['label']}.json"), "w") as fh:
                json.dump({"kind": "fit", "material": m, "label": f["label"],
                           "model": f["model"], "train": TRAIN, "parameters": [],
                           "evaluations": [{"lighting": l, "split": "train" if l in TRAIN
                                            else "test", "metrics": {}} for l in lightings[m]],
                           "exposure": 0.0, "converged": True, "termination": "CONVERGENCE"},
                          fh)
    with open(os.path.join(d, "results.csv"), "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def lights(n):
    return TRAIN + [f"L{i}" for i in range(1, n + 1)]


def errors(i, factor):
    base = 0.1 * (1 + 0.1 * i)  # blinn-phong's; ggx's is `factor` times it
    return {"blinn-phong": base, "ggx": base * factor}


def read(d, name):
    with open(os.path.join(d, "report", name), encoding="utf-8") as f:
        return json.load(f) if name.endswith(".json") else f.read()


def question(comp, split):
    return next(q for q in comp["questions"] if q.get("split") == split)


def no_empty_table(d, tag):
    """Every table of tables/ has a row; summary.md and index.html print no empty matrix."""
    tdir = os.path.join(d, "report", "tables")
    for name in sorted(os.listdir(tdir)):
        if name.endswith(".csv"):
            with open(os.path.join(tdir, name), newline="") as f:
                check(len(list(csv.reader(f))) > 1, f"{tag}: tables/{name} has no row")
    check("## Verdict matrix" not in read(d, "summary.md"), f"{tag}: empty verdict matrix in "
          "summary.md")
    check("<table class='matrix'>" not in read(d, "index.html"),
          f"{tag}: empty verdict matrix in index.html")


def test_one_object(make_report, out):
    d = os.path.join(out, "one_object")
    write_study(d, [("ball", None, l, errors(i, 0.5)) for i, l in enumerate(lights(8))])
    make_report.make_report(d)
    comp, md = read(d, "comparisons.json"), read(d, "summary.md")
    q = question(comp, "test")
    check(q.get("unit") == "lighting", f"one object: unit {q.get('unit')}, want lighting")
    p = q["comparisons"][0]
    rmse = next(c for c in p["per_metric"] if c["metric"] == "rmse")
    check(rmse["n"] == 8, f"one object: {rmse['n']} units, want the 8 test lightings")
    check(abs(rmse["effect"] - 2.0) < 1e-12, f"one object: effect {rmse['effect']}, want 2")
    check(abs(rmse["p"] - 0.0078125) < 1e-12, f"one object: p {rmse['p']}, want 2/2^8")
    check(abs(rmse["p_holm"] - 0.03125) < 1e-12, f"one object: Holm p {rmse['p_holm']}, "
          "want 4 x 2/2^8")
    check(p["verdict"]["kind"] == "smaller" and len(p["verdict"]["significant_smaller"]) == 2,
          f"one object: verdict {p['verdict']}")
    check("closer on 8 of 8 lightings" in md, "one object: no 'closer on 8 of 8 lightings'")
    check("Units: the test lightings (8 per compared pair)" in md,
          "one object: summary.md does not say 'Units: the test lightings (8 per compared pair)'")
    check("the answer is about this object under other lights" in md,
          "one object: summary.md does not say the answer is about this object under other "
          "lights")
    check("smaller under all 2 metrics; 0.5x; 2/2 sig." in md,
          "one object: the findings cell is not 'smaller under all 2 metrics; 0.5x; 2/2 sig.'")
    check("of 1 materials" not in md and "| mixed" not in md,
          "one object: still answered over one material")
    check("CI over materials (over lightings for a question of fewer than 6 materials)"
          in json.dumps(read(d, "figures.json")), "one object: the forest plot's caption does "
          "not say its intervals are over lightings")
    no_empty_table(d, "one object")


def test_seven_materials(make_report, out):
    d = os.path.join(out, "seven")
    write_study(d, [(f"m{k}", None, l, errors(i + k, 0.5)) for k in range(7)
                    for i, l in enumerate(lights(2))])
    make_report.make_report(d)
    comp, md = read(d, "comparisons.json"), read(d, "summary.md")
    q = question(comp, "test")
    check("unit" not in q, f"seven materials: unit {q.get('unit')}, want materials")
    check(q["comparisons"][0]["per_metric"][0]["n"] == 7, "seven materials: not 7 units")
    check("closer on 7 of 7 materials" in md, "seven materials: no 'closer on 7 of 7 materials'")


def test_two_objects(make_report, out):
    d = os.path.join(out, "two_objects")
    cells = [("red", "teapot", l, errors(i, 0.5)) for i, l in enumerate(lights(4))]
    cells += [("red", "knot", l, errors(i, 2.0)) for i, l in enumerate(lights(4))]
    write_study(d, cells)
    make_report.make_report(d)
    comp, md = read(d, "comparisons.json"), read(d, "summary.md")
    q = question(comp, "test")
    p = q["comparisons"][0]
    check(q.get("unit") == "lighting" and p["per_metric"][0]["n"] == 8,
          f"two objects pooled: unit {q.get('unit')}, n {p['per_metric'][0]['n']}; want 8 "
          "lightings")
    check(all(c["effect"] == 1.0 for c in p["per_metric"]),
          f"two objects pooled: effects {[c['effect'] for c in p['per_metric']]}, want 1")
    check(p["verdict"]["kind"] == "mixed", f"two objects pooled: {p['verdict']['kind']}")
    check(q.get("pooled_objects") == 2, "two objects: the pooled record does not say 2 objects")
    objs = {o["object"]: o for o in comp.get("objects", [])}
    check(set(objs) == {"teapot", "knot"}, f"two objects: per object {sorted(objs)}")
    for name, kind in (("teapot", "smaller"), ("knot", "larger")):
        if name not in objs:
            continue
        t = next(x for x in objs[name]["questions"] if x["split"] == "test")
        check(t["unit"] == "lighting" and t["units"] == 4,
              f"{name}: {t['unit']} x {t['units']}, want 4 lightings")
        check(t["pairs"][0]["verdict"]["kind"] == kind,
              f"{name}: {t['pairs'][0]['verdict']['kind']}, want {kind}")
    check("- **teapot** (1 material: red)" in md and "- **knot** (1 material: red)" in md,
          "two objects: no per-object lines in summary.md")
    check("ggx vs blinn-phong: larger under all 2 metrics, error ratio 2x" in md,
          "two objects: the knot's line is not 'larger under all 2 metrics, error ratio 2x'")
    check("Pooled over the 2 objects" in md, "two objects: the pooled answer is not said so")
    check("With 2 material-object pairs" in md and "about these 2 material-object pairs under "
          "other lights" in md, "two objects: the pooled units are not named material-object "
          "pairs")
    no_empty_table(d, "two objects")


def main(argv):
    report_src, out = argv[1], os.path.abspath(argv[2])
    sys.path.insert(0, report_src)
    import make_report  # noqa: E402
    for test in (test_one_object, test_seven_materials, test_two_objects):
        test(make_report, out)
    for f in FAILURES:
        print("FAILED: " + f)
    if not FAILURES:
        print("PASS: one object answered over its lightings, seven materials over materials, "
              "two objects per object and pooled, no empty table")
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
