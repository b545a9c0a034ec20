#!/usr/bin/python3
"""What a second lobe buys, per material class (issue 32, item 3; docs/studies.md, "Ngan 2005's
models").

Reads the output folder of `shadefit study run studies/ngan2005_models.toml` (results.csv and the
fit jobs' JSON) and, for every pair of a one-lobe model and its two-lobe sibling in it (ggx and
ggx-2lobe, cook-torrance and cook-torrance-2lobe), prints per material class (the classes that
../shared/brdf-data/README.md gives its materials: metals, dielectrics, paints, fabrics,
near-Lambertian):

  * the median relative RMSE on the training lightings and on the new (test) lightings, one lobe
    and two, and their ratio (two over one; below 1: the second lobe helps);
  * on how many materials the second lobe lowers the new-lighting error by more than 5%;
  * how many two-lobe fits have every free parameter determined (a finite standard error, not
    flagged undetermined): whether the data pins the extra lobe down;
  * with the study's `brdf` probe (docs/probes.md, "BRDF-space probes"), the fitted BRDF against
    the measured one: the median over the class of |log hwhm_ratio| (the highlight's half-width,
    model over measured; 0 is exact), of |tail_fraction_difference| (the highlight's tail) and of
    |log rim_centre_ratio_to_limit_ratio| (the Fresnel rise to theta_d = 75 degrees), one lobe
    and two. (The image probes are not valid on measured references.)

    /usr/bin/python3 bench/second_lobe.py STUDY_OUT [--shared ../shared] [--train key+mirror60]
        [--markdown OUT.md]
"""
import argparse
import csv
import json
import math
import pathlib
import re
import statistics
import sys

PAIRS = (("ggx", "ggx-2lobe"), ("cook-torrance", "cook-torrance-2lobe"))
HELPS = 0.95  # "the second lobe helps": new-lighting error below 95% of the one-lobe fit's


def material_classes(readme):
    """{material: class} from the data README's 'Materials here: a, b (class); c (class).'"""
    text = readme.read_text()
    start = text.find("Materials here:")
    if start < 0:
        sys.exit(f"second_lobe: error: {readme}: no 'Materials here:' line")
    block = text[start + len("Materials here:"):text.find("\n\n", start)]
    classes = {}
    for names, cls in re.findall(r"([^()]+)\(([^)]+)\)", " ".join(block.split())):
        for name in names.replace(";", ",").split(","):
            if name.strip():
                classes[name.strip()] = cls.strip()
    return classes


def read_errors(out, train):
    """{(material, model): {"train": [...], "test": [...]}} of relative RMSE for one training set."""
    errors = {}
    with open(out / "results.csv", newline="") as f:
        for row in csv.DictReader(f):
            if row["train"] != train or row["status"] != "ok" or row["relative_rmse"] == "":
                continue
            split = "train" if row["split"] == "train" else "test"
            errors.setdefault((row["material"], row["model"]), {"train": [], "test": []})
            errors[(row["material"], row["model"])][split].append(float(row["relative_rmse"]))
    return errors


def determined(out, material, model, train):
    """Whether every free parameter of the fit has a finite standard error."""
    path = out / "jobs" / f"fit.{material}.{model}.{train}.json"
    if not path.exists():
        return None
    fit = json.loads(path.read_text())["fit"]
    for p in fit["parameters"]:
        if p.get("fixed"):
            continue
        if p.get("undetermined") or p.get("std_error") is None:
            return False
    return True


def brdf_probe(out, material, model, train):
    """The brdf probe's vs_measured numbers of one fit (None without the probe)."""
    path = out / "jobs" / f"probe.{material}.json"
    if not path.exists():
        return None
    probes = json.loads(path.read_text())["probes"]
    if "brdf" not in probes:
        return None
    numbers = probes["brdf"]["numbers"].get(f"{model}@{train}")
    return None if numbers is None else numbers.get("vs_measured")


def probe_medians(out, mats, model, train):
    """Median |log hwhm ratio|, |tail difference|, |log rim ratio| over the materials."""
    logs = {"hwhm": [], "tail": [], "rim": []}
    for m in mats:
        v = brdf_probe(out, m, model, train)
        if not v:
            continue
        if v.get("hwhm_ratio"):
            logs["hwhm"].append(abs(math.log(v["hwhm_ratio"])))
        if v.get("tail_fraction_difference") is not None:
            logs["tail"].append(abs(v["tail_fraction_difference"]))
        if v.get("rim_centre_ratio_to_limit_ratio"):
            logs["rim"].append(abs(math.log(v["rim_centre_ratio_to_limit_ratio"])))
    return {k: statistics.median(x) if x else float("nan") for k, x in logs.items()}


def class_rows(out, classes, train):
    errors = read_errors(out, train)
    rows = []
    for one, two in PAIRS:
        by_class = {}
        for (material, model), e in errors.items():
            if model != one or (material, two) not in errors:
                continue
            by_class.setdefault(classes.get(material, "unclassified"), []).append(material)
        for cls in sorted(by_class):
            mats = sorted(by_class[cls])

            def med(model, split):
                # NaN where the split is empty (a BRDF-space training set has no training image).
                means = [statistics.mean(errors[(m, model)][split]) for m in mats
                         if errors[(m, model)][split]]
                return statistics.median(means) if means else float("nan")

            helps = sum(statistics.mean(errors[(m, two)]["test"]) <
                        HELPS * statistics.mean(errors[(m, one)]["test"]) for m in mats)
            det = [determined(out, m, two, train) for m in mats]
            rows.append({
                "pair": f"{one} -> {two}", "class": cls, "materials": len(mats),
                "train_one": med(one, "train"), "train_two": med(two, "train"),
                "test_one": med(one, "test"), "test_two": med(two, "test"),
                "helps": helps, "determined": sum(1 for d in det if d),
                "probe_one": probe_medians(out, mats, one, train),
                "probe_two": probe_medians(out, mats, two, train),
            })
    return rows


def markdown(rows, train):
    lines = [f"Training set {train}; relative RMSE, median over the class's materials "
             "(each material's mean over its lightings).", "",
             "| models | class | materials | training: 1 lobe / 2 lobes | new lightings: 1 lobe / "
             f"2 lobes (ratio) | 2nd lobe lowers new-lighting error > {100 * (1 - HELPS):.0f}% | "
             "2-lobe fits fully determined |",
             "|---|---|---|---|---|---|---|"]
    for r in rows:
        lines.append(
            f"| {r['pair']} | {r['class']} | {r['materials']} | {r['train_one']:.3f} / "
            f"{r['train_two']:.3f} | {r['test_one']:.3f} / {r['test_two']:.3f} "
            f"({r['test_two'] / r['test_one']:.2f}) | {r['helps']} of {r['materials']} | "
            f"{r['determined']} of {r['materials']} |")
    if any(not math.isnan(r["probe_one"]["hwhm"]) for r in rows):
        lines += ["", "Fitted BRDF against the measured one (brdf probe; medians over the class; "
                  "0 is exact):", "",
                  "| models | class | abs log HWHM ratio: 1 / 2 lobes | abs tail-fraction "
                  "difference: 1 / 2 | abs log Fresnel-rise ratio: 1 / 2 |", "|---|---|---|---|---|"]
        for r in rows:
            a, b = r["probe_one"], r["probe_two"]
            lines.append(f"| {r['pair']} | {r['class']} | {a['hwhm']:.2f} / {b['hwhm']:.2f} | "
                         f"{a['tail']:.3f} / {b['tail']:.3f} | {a['rim']:.2f} / {b['rim']:.2f} |")
    return "\n".join(lines) + "\n"


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("study_out", type=pathlib.Path)
    ap.add_argument("--shared", type=pathlib.Path,
                    default=pathlib.Path(__file__).resolve().parents[2] / "shared")
    ap.add_argument("--train", default="key+mirror60")
    ap.add_argument("--markdown", type=pathlib.Path)
    args = ap.parse_args()
    if not (args.study_out / "results.csv").exists():
        sys.exit(f"second_lobe: error: {args.study_out}: no results.csv (a study's output folder)")
    classes = material_classes(args.shared / "brdf-data" / "README.md")
    rows = class_rows(args.study_out, classes, args.train)
    if not rows:
        sys.exit(f"second_lobe: error: {args.study_out}: no one- and two-lobe pair trained on "
                 f"{args.train}")
    text = markdown(rows, args.train)
    print(text, end="")
    if args.markdown:
        tmp = args.markdown.with_name("." + args.markdown.name + ".tmp")
        tmp.write_text(text)
        tmp.replace(args.markdown)


if __name__ == "__main__":
    main()
