"""The answers per material class (docs/studies.md, "Material classes").

Two classifications: the coarse Metal/Dielectric split of Lavoue, Bonneel, Farrugia, Soler 2021
(`merl-material-types.tsv`, found beside a study's measured folder, i.e. in the parent of
study.json's measured[].folder, and read by path), and the finer classes compiled in
report/material_classes.tsv (metals, plastics and phenolics, paints, fabrics and diffuse, ...;
each row with its source). Every image question is answered again over the materials of each
class that has at least MIN_MATERIALS of the study's materials, by the same rules
(answer_rules.compare_study: the judging set, Holm per pair within the class).
"""

import csv
import os

import answer_rules
from answer_words import fmt_range
from report_util import materials_of

MIN_MATERIALS = 4
FINE_TSV = os.path.join(os.path.dirname(os.path.abspath(__file__)), "material_classes.tsv")
COARSE_NAME = "merl-material-types.tsv"


def read_tsv(path, column):
    """{material: value of `column`} of a tab-separated file whose comment lines start '#'."""
    with open(path, encoding="utf-8") as f:
        lines = [l for l in f if l.strip() and not l.startswith("#")]
    return {r["material"]: r[column] for r in csv.DictReader(lines, delimiter="\t")}


def coarse_path(study, study_dir):
    """merl-material-types.tsv beside the first measured folder that has one, or None. The
    runner writes the folder joined to the study file's folder (study_materials.cpp), so a
    relative one is relative to where the study ran; failing that, to the study's out folder."""
    for src in study["measured"]:
        folder = src.get("folder")
        if not folder:
            continue
        for where in ([folder] if os.path.isabs(folder)
                      else [os.path.abspath(folder), os.path.join(study_dir, folder)]):
            path = os.path.join(os.path.dirname(os.path.normpath(where)), COARSE_NAME)
            if os.path.exists(path):
                return path
    return None


def classifications(study, study_dir, fine_path=FINE_TSV):
    """([(name, source, {material: class})], [why a classification is left out])."""
    out, skipped = [], []
    path = coarse_path(study, study_dir)
    if path is None:
        skipped.append(f"Metal/Dielectric (Lavoue et al. 2021): no {COARSE_NAME} beside the "
                       "study's measured folder")
    else:
        out.append(("Metal/Dielectric", f"Lavoue et al. 2021, {path}", read_tsv(path, "type")))
    if os.path.exists(fine_path):
        out.append(("finer classes", f"report/{os.path.basename(fine_path)} (sources per row)",
                    read_tsv(fine_path, "class")))
    else:
        skipped.append(f"finer classes: {fine_path} is missing")
    return out, skipped


def class_answers(study, rows, summary, to_float, classified):
    """{"classes": [{scheme, source, class, materials, questions: [{name, pairs}]}],
    "skipped": [why]}: the image questions' verdicts per class of >= MIN_MATERIALS.
    `classified`: classifications(), read with the report's other inputs."""
    schemes, skipped = classified[0], list(classified[1])
    materials = materials_of(study)
    out = []
    for scheme, source, of in schemes:
        groups = {}
        for m in materials:
            if m in of:
                groups.setdefault(of[m], []).append(m)
        if not groups:
            skipped.append(f"{scheme}: none of the study's materials is classified there")
        small = [c for c, ms in groups.items() if len(ms) < MIN_MATERIALS]
        if small:
            skipped.append(f"{scheme}: {', '.join(sorted(small))} have fewer than "
                           f"{MIN_MATERIALS} of the study's materials")
        for cls, ms in sorted(groups.items()):
            if len(ms) < MIN_MATERIALS:
                continue
            records = answer_rules.compare_study(study, rows, summary, to_float, materials=ms)
            out.append({"scheme": scheme, "source": source, "class": cls, "materials": ms,
                        "questions": [class_question(r) for r in records
                                      if r["source"] == "metrics"]})
    return {"classes": out, "skipped": skipped}


def class_question(rec):
    return {"name": rec["name"], "question": rec["question"],
            "pairs": [{"fit": p["fit"], "baseline": p["baseline"], "verdict": p["verdict"],
                       "ratio_range": answer_rules.ratio_range(p["per_metric"])}
                      for p in rec["comparisons"]]}


def class_lines(answers):
    """List items (depth, text): per class, each image question's verdict per pair; then why
    classes are left out."""
    lines = []
    for c in answers["classes"]:
        lines.append((0, f"**{c['class']}** ({c['scheme']}; {len(c['materials'])} materials: "
                         f"{', '.join(c['materials'])})"))
        for q in c["questions"]:
            lines.append((1, q["question"]))
            for p in q["pairs"]:
                rng = p["ratio_range"]
                r = "" if rng is None else f", {fmt_range(rng)}"
                lines.append((2, f"{p['fit']} vs {p['baseline']}: {p['verdict'].word}{r}"))
    lines += [(0, f"Left out: {s}.") for s in answers["skipped"]]
    return lines
