"""Every answer of a study, computed once from what was read and handed to the writers: the
image and probe questions (answer_rules), per object where the references show several, the
model's floor (model_floor: the joint fit to every floor lighting), the regions
(report_regions), the material classes (report_classes) and the cells of the every-metric
table. Computes only: no file opened, no word written (report_sections.py formats these)."""

import dataclasses

import answer_rules
import model_floor
import report_classes
import report_regions
from results_csv import METRIC_COLUMNS


@dataclasses.dataclass(frozen=True)
class Answers:
    study: dict
    # The records are report_records' dataclasses.
    records: list             # ImageQuestionRecord or ProbeQuestionRecord per question
    model_floors: dict        # model_floor.model_floors: {question name: [FloorEntry]}
    regions: dict             # report_regions.region_means: {(split, lighting, region, fit): ..}
    objects: list             # ObjectAnswer per object, where the rows show several
    classes: object           # report_classes.class_answers: ClassAnswers
    every_metric_cells: tuple  # answer_rules.every_metric_cells: (cells, metrics)


def compute_answers(study, rows, summary, to_float, classified):
    """The study's Answers from its rows, verdicts' summary and class tables."""
    records = answer_rules.compare_study(study, rows, summary, to_float)
    return Answers(
        study=study, records=records,
        model_floors=model_floor.model_floors(study, rows, records, to_float),
        regions=report_regions.region_means(rows, to_float),
        objects=answer_rules.object_answers(study, rows, summary, to_float),
        classes=report_classes.class_answers(study, rows, summary, to_float, classified),
        every_metric_cells=answer_rules.every_metric_cells(study, rows, records, to_float,
                                                           METRIC_COLUMNS))
