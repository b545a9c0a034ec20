"""The answers per material class (docs/studies.md, "Material classes").

Two classifications: the coarse Metal/Dielectric split of Lavoue, Bonneel, Farrugia, Soler 2021
(`merl-material-types.tsv`, found beside a study's measured folder, i.e. in the parent of
study.json's measured[].folder), and the finer classes compiled in
report/material_classes.tsv (metals, plastics and phenolics, paints, fabrics and diffuse, ...;
each row with its source). Every image question is answered again over the materials of each
class that has at least MIN_MATERIALS of the study's materials, by the same rules
(answer_rules.compare_study: the judging set, Holm per pair within the class). The tables are
read with the other inputs (report_inputs.classifications), the words are section_words'.
"""

import answer_rules
from report_records import ClassAnswers, MaterialClass
from report_util import materials_of

MIN_MATERIALS = 4


def class_answers(study, rows, summary, to_float, classified):
    """ClassAnswers: the image questions' verdicts per class of >= MIN_MATERIALS (a
    MaterialClass each), and why a classification or class is left out. `classified`:
    report_inputs.classifications(), read with the report's other inputs."""
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
            out.append(MaterialClass(scheme, source, cls, ms,
                                     [answer_rules.class_question(r) for r in records
                                      if r.source == "metrics"]))
    return ClassAnswers(out, skipped)
