"""The study's answers (study_answers.Answers) as every page prints them: the findings tables
and forest plot (report_findings), the every-metric table, the sections after the comparisons
(floors, regions, objects, classes), the answers' tables, figures and comparisons.json's
record. summary.md, index.html and report.tex print the same sections from here. Formats only:
the answers are computed before (study_answers.compute_answers)."""

import answer_words
import report_findings
import report_metric_figures
import section_words


class AnswerSections:
    """The answers' words, tables and figures, each made once from `answers`
    (study_answers.Answers); `records`: the questions' records, as the pages read them."""

    def __init__(self, answers):
        self.answers = answers
        self.study = answers.study
        self.records = answers.records
        self.model_floors = answers.model_floors
        self.regions = answers.regions
        self.objects = answers.objects
        self.classes = answers.classes
        self.findings = report_findings.findings_tables(answers.study, answers.records)
        self.every_metric = answer_words.every_metric_table(answers.records,
                                                            *answers.every_metric_cells)

    def sections(self):
        """[(anchor, title, list items (depth, text))] after the per-question sentences: floors,
        regions, objects and classes, each only where the study has it (classes: always, with
        why not)."""
        out = []
        floors = section_words.model_floor_lines(self.model_floors, self.records)
        if floors:
            out.append(("floors", "Against the model's floor", floors))
        regions = section_words.region_lines(self.regions, self.records)
        if regions:
            out.append(("regions", "Where the difference lies", regions))
        if self.objects:
            out.append(("objects", "Per object", answer_words.object_lines(self.objects)))
        out.append(("classes", "Per material class",
                    section_words.class_lines(self.classes)))
        return out

    def tables(self):
        """{key: (caption, (columns, rows))} of the answers' tables for tables/ and report.tex:
        the findings per training set first."""
        out = {f"findings-{i + 1}": (f"Findings: {title}", t)
               for i, (title, t) in enumerate(self.findings)}
        if self.every_metric:
            out["every_metric"] = ("Every image metric measured, judged or not: error ratio "
                                   "fit / baseline (geometric mean over materials) and closer "
                                   "on k of n materials, per image question; descriptive, no "
                                   "test", self.every_metric)
        if self.model_floors:
            out["floors"] = ("Error over the model's floor per fit, question and metric "
                             "(geometric mean over materials, bootstrap 95% CI)",
                             section_words.model_floor_table(self.model_floors))
        if self.regions:
            out["regions"] = ("Mean luminance error per split, lighting, image region and fit "
                              "(mean over materials; measured pixels)",
                              section_words.region_table(self.regions))
        return out

    def figures(self, labels, fig_dir, manifest):
        """The forest plot, then one region figure per image question."""
        report_findings.forest_plot(self.records, fig_dir, manifest)
        if self.regions:
            for rec in (r for r in self.records if r.source == "metrics" and r.comparisons):
                report_metric_figures.region_figure(self.regions, rec, labels, fig_dir, manifest)

    def json(self):
        return answer_words.to_json(self.records, {
            "findings": [{"title": t, "columns": c, "rows": r} for t, (c, r) in self.findings],
            "floors": self.model_floors,
            "floor_order": section_words.ordering_sentences(self.records),
            "regions": [] if not self.regions else [
                dict(zip(("split", "lighting", "region", "fit"), k), **v.to_json())
                for k, v in sorted(self.regions.items())],
            "classes": self.classes,
            "every_metric": None if not self.every_metric else {
                "columns": self.every_metric[0], "rows": self.every_metric[1]},
            # Only where the rows show several objects: older readers see the same record.
            **({"objects": self.objects} if self.objects
               else {})})
