"""The study's answers, computed once and handed to every page: the image and probe questions
(report_answers), the findings tables and forest plot (report_findings), the floors
(report_floors), the regions (report_regions) and the material classes (report_classes).
summary.md, index.html and report.tex print the same sections from here."""

import report_answers
import report_classes
import report_findings
import report_floors
import report_regions
from results_csv import METRIC_COLUMNS


class Answers:
    def __init__(self, study, rows, summary, to_float, study_dir):
        self.study = study
        self.records = report_answers.compare_study(study, rows, summary, to_float)
        self.floors = report_floors.floor_study(study, rows, self.records, to_float)
        self.regions = report_regions.region_means(rows, to_float)
        self.classes = report_classes.class_answers(study, rows, summary, to_float, study_dir)
        self.findings = report_findings.findings_tables(study, self.records)
        self.every_metric = report_answers.every_metric_table(study, rows, summary, self.records,
                                                              to_float, METRIC_COLUMNS)

    def sections(self):
        """[(anchor, title, markdown lines)] after the per-question sentences: floors, regions
        and classes, each only where the study has it (classes: always, with why not)."""
        out = []
        floors = report_floors.floor_lines(self.floors, self.records)
        if floors:
            out.append(("floors", "Against the model's floor", floors))
        regions = report_regions.region_lines(self.regions, self.records)
        if regions:
            out.append(("regions", "Where the difference lies", regions))
        out.append(("classes", "Per material class",
                    report_classes.class_lines(self.classes)))
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
        if self.floors:
            out["floors"] = ("Error over the model's floor per fit, question and metric "
                             "(geometric mean over materials, bootstrap 95% CI)",
                             report_floors.floor_table(self.floors))
        if self.regions:
            out["regions"] = ("Mean luminance error per split, lighting, image region and fit "
                              "(mean over materials; measured pixels)",
                              report_regions.region_table(self.regions))
        return out

    def figures(self, labels, fig_dir, manifest):
        """The forest plot, then one region figure per image question."""
        report_findings.forest_plot(self.records, fig_dir, manifest)
        if self.regions:
            for rec in (r for r in self.records if r["source"] == "metrics" and r["comparisons"]):
                report_regions.region_figure(self.regions, rec, labels, fig_dir, manifest)

    def json(self):
        return report_answers.to_json(self.records, {
            "findings": [{"title": t, "columns": c, "rows": r} for t, (c, r) in self.findings],
            "floors": self.floors,
            "floor_order": report_floors.ordering_sentences(self.records),
            "regions": [] if not self.regions else [
                dict(zip(("split", "lighting", "region", "fit"), k), **v)
                for k, v in sorted(self.regions.items())],
            "classes": self.classes,
            "every_metric": None if not self.every_metric else {
                "columns": self.every_metric[0], "rows": self.every_metric[1]}})
