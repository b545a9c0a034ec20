"""The report's inputs and their schema: every field the report reads from a study's result files
(study.json, results.csv, jobs/*.json, provenance.json) is declared here once, with its type, and
checked when the file is read, before the first output is written.

A missing or mistyped field is a ReportInputError whose message is one line naming the file and
the field (`<file>: field 'fits[0].label': expected string, got number`); make_report.py prints it
and exits non-zero. Optional fields are the ones the runner legitimately leaves out (a fit without
previews has no `images`; only a fitted encoding writes `encoding`; a metric with no lit pixel is
null); readers take them with `.get(name)` and handle their absence, never with a default that
hides a required field's absence.

Writers: studies/runner/src/study.cpp (study.json), fit_job.cpp (fit jobs), probe_job.cpp and
metrics/probes/src/output.cpp (probe jobs), outputs.cpp (results.csv, provenance.json).
"""

import csv
import glob
import json
import os

import results_csv


class ReportInputError(Exception):
    """Bad input: the message is one line naming the file and the field."""


# ------------------------------------------------------------------------------------------------
# Schema vocabulary: a field's kind is a JSON scalar type name, an Object of fields, an Array of
# items, a Map from names to values, or ANY (read, but its inside is not the report's contract).

STRING, NUMBER, BOOLEAN, ANY = "string", "number", "boolean", "any"
SPLIT = "split"  # a results.csv cell kind: one of SPLITS


class Field:
    """One field: its kind; `optional`: may be absent; `nullable`: may be null; `one_of`: the
    values it may take; `hint`: said after a wrong value (how to get a good one)."""

    def __init__(self, kind, optional=False, nullable=False, one_of=None, hint=""):
        self.kind, self.optional, self.nullable = kind, optional, nullable
        self.one_of, self.hint = one_of, hint


def Optional(kind, nullable=False, one_of=None):
    return Field(kind, optional=True, nullable=nullable, one_of=one_of)


class Object:
    def __init__(self, fields):
        self.fields = {k: v if isinstance(v, Field) else Field(v) for k, v in fields.items()}


class Array:
    def __init__(self, item):
        self.item = item


class Map:
    def __init__(self, value):
        self.value = value


def json_type(value):
    """The JSON name of a parsed value's type."""
    if value is None:
        return "null"
    if isinstance(value, bool):
        return BOOLEAN
    if isinstance(value, (int, float)):
        return NUMBER
    if isinstance(value, str):
        return STRING
    return "array" if isinstance(value, list) else "object"


def expected_name(kind):
    if isinstance(kind, str):
        return kind
    return {Object: "object", Map: "object", Array: "array"}[type(kind)]


def check(value, kind, path, where):
    """Raises ReportInputError unless `value` (at `where` in the file `path`) is a `kind` (a kind
    or a Field)."""
    if isinstance(kind, Field):
        check_field(value, kind, path, where)
        return
    if kind == ANY:
        return
    got = json_type(value)
    if got != expected_name(kind):
        raise ReportInputError(f"{path}: field '{where}': expected {expected_name(kind)}, "
                               f"got {got}")
    if isinstance(kind, Array):
        for i, item in enumerate(value):
            check(item, kind.item, path, f"{where}[{i}]")
    elif isinstance(kind, Map):
        for name, item in value.items():
            check(item, kind.value, path, f"{where}.{name}")
    elif isinstance(kind, Object):
        check_object(value, kind, path, where)


def check_field(value, field, path, where):
    """A present field's value: null where nullable, one of its values where it has a list."""
    if value is None and field.nullable:
        return
    if field.one_of is not None and value not in field.one_of:
        want = " or ".join(repr(v) for v in field.one_of)
        raise ReportInputError(f"{path}: field '{where}': expected {want}, got {value!r}"
                               + (f" ({field.hint})" if field.hint else ""))
    check(value, field.kind, path, where)


def check_object(obj, schema, path, where=""):
    for name, field in schema.fields.items():
        at = f"{where}.{name}" if where else name
        if name in obj:
            check_field(obj[name], field, path, at)
        elif not field.optional:
            raise ReportInputError(f"{path}: field '{at}': missing"
                                   + (f" ({field.hint})" if field.hint else ""))


# ------------------------------------------------------------------------------------------------
# study.json (StudySpec's JSON, studies/runner/src/study.cpp)

VERDICT_KINDS = ("relative", "absolute", "max")
# A fit's role (FitRoleName, studies/runner/src/study.cpp): an ordinary training set; the joint
# fit to every lighting of [fit] floor (the model's best on these views); the BRDF-space fit.
FIT_ROLES = ("train", "floor", "brdf")
# What the runner calls a lighting of a fit (job_graph.cpp): trained on, listed in [fit] test,
# or neither ("other").
SPLITS = ("train", "test", "other")

STUDY = Object({
    "name": STRING,
    "description": STRING,
    # label: what results.csv and the jobs call the fit; model and train: the label's parts, as
    # fields (the label is composed from them in C++, StudySpec::Label; read these, never split
    # the label).
    # loss and role: absent in study.json files written before a study could list several
    # losses or floor fits; normalise_fits fills them in (never read them with a default).
    "fits": Array(Object({"label": STRING, "model": STRING, "train": Array(STRING),
                          "loss": Optional(STRING),
                          "role": Optional(STRING, one_of=FIT_ROLES)})),
    "groups": Array(Object({
        "material": STRING,
        "references": Array(Object({"lighting": STRING, "sidecar": STRING})),
    })),
    "training_sets": Array(Array(STRING)),
    "test_lightings": Array(STRING),  # empty: every lighting not trained on
    "baseline": Field(STRING, nullable=True),
    "compare": Array(Array(STRING)),
    "losses": Optional(Array(STRING)),   # absent before several losses: the models' own
    "floor": Optional(Array(STRING)),    # the floor fits' lightings; [] or absent: none
    "judging": Optional(Array(STRING), nullable=True),  # [verdicts] judging; null: the default
    "fit_settings": Optional(Map(Object({"loss": Optional(STRING)}))),
    "probes": Array(STRING),
    "measured": Array(Object({"materials": Array(STRING), "folder": Optional(STRING)})),
    "verdicts": Map(Object({
        "source": STRING,
        "kind": Field(STRING, one_of=VERDICT_KINDS),
        "tolerance": NUMBER,
        "question": STRING,
        "metric": Optional(STRING),  # source "metrics" only
        "split": Optional(STRING),   # source "metrics" only
        "keys": Optional(Array(STRING)),  # quantities judged (fnmatch patterns); absent: all
        "floor": Optional(NUMBER),  # a relative error's least denominator; absent: 0
    })),
})


def check_document(value, schema, path):
    """A whole file: an object whose fields `schema` declares."""
    if not isinstance(value, dict):
        raise ReportInputError(f"{path}: expected object, got {json_type(value)}")
    check_object(value, schema, path)


def normalise_fits(study):
    """Fills each fit's `loss` and `role` where an older study.json has none: the loss of the
    model's fit settings (absent: "l2", the runner's default), and "brdf" for train == ["brdf"],
    else "train". Also `losses` and `floor` at the top level."""
    settings = study.get("fit_settings") or {}
    for f in study["fits"]:
        if "loss" not in f:
            f["loss"] = (settings.get(f["model"]) or {}).get("loss", "l2")
        if "role" not in f:
            f["role"] = "brdf" if f["train"] == ["brdf"] else "train"
    if "losses" not in study:
        study["losses"] = sorted({f["loss"] for f in study["fits"]})
    study.setdefault("floor", [])
    study.setdefault("judging", None)


def check_study(study, path):
    check_document(study, STUDY, path)
    normalise_fits(study)
    models = [f["model"] for f in study["fits"]]
    if study["baseline"] is not None and study["baseline"] not in models:
        raise ReportInputError(f"{path}: field 'baseline': '{study['baseline']}' is not a "
                               "fitted model")
    for i, pair in enumerate(study["compare"]):
        if not (len(pair) == 2 and all(p in models for p in pair)):
            raise ReportInputError(f"{path}: field 'compare[{i}]': expected a pair of fitted "
                                   "models")


# ------------------------------------------------------------------------------------------------
# jobs/fit.*.json (RunFitJob and WriteFailedFit, studies/runner/src/fit_job.cpp). A failed fit has
# no exposure, termination or fit record, and empty parameters and evaluations.

NUMBERS = Map(Field(NUMBER, nullable=True))  # metrics: null where a pass had no pixel

FIT_JOB = Object({
    "kind": Field(STRING, one_of=("fit",)),
    "material": STRING,
    "label": STRING,
    "model": STRING,
    "train": Array(STRING),
    "converged": BOOLEAN,
    "exposure": Optional(NUMBER),      # absent on a failed fit
    "termination": Optional(STRING),   # absent on a failed fit
    "parameters": Array(Object({
        "name": STRING,
        "value": Field(NUMBER, nullable=True),      # null: not finite
        "std_error": Field(NUMBER, nullable=True),  # null: not determined
        "fixed": BOOLEAN,
        # why a fit fixed it when the study did not ("free exposure", "no ambient light"), else
        # ""; absent in jobs written before shadefit wrote it
        "fixed_by": Optional(STRING),
        "at_bound": BOOLEAN,
        "undetermined": BOOLEAN,
    })),
    "evaluations": Array(Object({
        "lighting": STRING,
        "split": Field(STRING, one_of=SPLITS),
        "metrics": NUMBERS,
        "measured_fraction": Optional(NUMBER),
        # Absent when the study writes no previews; "domain" on measured references only.
        "images": Optional(Object({"reference": Optional(STRING), "fit": Optional(STRING),
                                   "error": Optional(STRING), "error_scale": Optional(NUMBER),
                                   "domain": Optional(STRING)})),
    })),
    # The fitter's own record (FitResultToJson, fit/src/fit_output.cpp); the report reads what a
    # free exposure pinned (fit/exposure_pin.h), absent in jobs written before it was recorded.
    "fit": Optional(Object({
        "exposure": Object({"mode": Field(STRING, one_of=("fixed", "free")),
                            "pinned": Optional(STRING)}),
    })),
    # The encoding search's record (fit.encoding = "fit" only; fit/src/encoding_search.cpp).
    "encoding": Optional(Object({
        "chosen": STRING,
        "name": STRING,
        "gamma": Field(NUMBER, nullable=True),
        "stored_rmse": NUMBER,
        "candidates": Array(Object({"name": STRING, "gamma": Field(NUMBER, nullable=True),
                                    "stored_rmse": NUMBER, "chosen": BOOLEAN})),
    })),
})

# jobs/probe.*.json: the probes' results as ProbeResultToJson writes them
# (metrics/probes/src/output.cpp): curves are records, never parsed names.
PROBE_SCHEMA = "shadefit.probe/4"  # kProbeResultSchema, metrics/probes/include/shadefit/probes

PROBE_RESULT = Object({
    "schema": Field(STRING, one_of=(PROBE_SCHEMA,),
                    hint="written by an older shadefit: run the study again"),
    "numbers": Map(ANY),  # per series, nested numbers; flattened by report_util.flatten
    "curves": Array(Object({
        "series": STRING, "kind": STRING, "x": Array(ANY), "y": Array(ANY),
        "x_label": STRING, "y_label": STRING, "x_scale": STRING, "y_scale": STRING,
        "reference": Field(STRING, nullable=True),  # null: a curve of no reference image
        "lighting": Field(STRING, nullable=True),  # that reference's lighting; null with it
        "extrapolated": Optional(Array(BOOLEAN)),
    })),
})

PROBE_JOB = Object({
    "kind": Field(STRING, one_of=("probe",)),
    "material": STRING,
    "probes": Map(PROBE_RESULT),
})

# provenance.json (outputs.cpp): shown at the page's foot; the file itself may be absent.
PROVENANCE = Object({
    "shadefit": Optional(Object({"version": Optional(STRING)})),
    "gl_renderer": Optional(STRING),
    "dependencies": Optional(ANY),  # shown as they are
    "machine": Optional(ANY),
})

# A reference's sidecar (reference_images/; LoadReference): the Ngan et al. 2005 comparison looks
# for the measured folder the study's references came from. "brdf" on measured references only.
SIDECAR = Object({
    "kind": Optional(STRING),
    "brdf": Optional(Object({"files": Array(Object({"path": STRING}))})),
})

# ------------------------------------------------------------------------------------------------
# results.csv (AppendResultRows, outputs.cpp): one row per fit and reference. Cells are text; a
# number cell is empty where the metric has no value (no lit pixel, a failed fit).

# The columns' names: report/results_csv.py, the one Python list (checked against the C++ writer
# by tests/report/columns_test.py).
METRIC_COLUMNS = results_csv.METRIC_COLUMNS
NUMBER_COLUMNS = results_csv.NUMBER_COLUMNS
REGIONS = results_csv.REGIONS
REGION_COLUMNS = results_csv.REGION_COLUMNS
# What a verdict or the judging set may name: a metric, its all-pixel twin, measured_fraction.
VERDICT_COLUMNS = (results_csv.METRIC_COLUMNS + ["measured_fraction"]
                   + results_csv.ALL_PIXEL_COLUMNS)
# The columns the report needs (its metrics table, figures and verdicts); the other number
# columns are checked where present (a verdict or question may name any of them).
RESULT_COLUMNS = {"material": STRING, "lighting": STRING, "label": STRING, "split": SPLIT,
                  "converged": BOOLEAN, "rmse": NUMBER, "relative_rmse": NUMBER, "psnr": NUMBER,
                  "ssim": NUMBER, "ciede2000_mean": NUMBER, "flip_ldr_mean": NUMBER,
                  "flip_hdr_mean": NUMBER}


def check_cell(text, kind, path, line, column):
    if kind == SPLIT and text not in SPLITS:
        raise ReportInputError(f"{path}:{line}: field '{column}': expected "
                               + " or ".join(repr(s) for s in SPLITS) + f", got '{text}'")
    if kind == BOOLEAN and text not in ("0", "1"):
        raise ReportInputError(f"{path}:{line}: field '{column}': expected 0 or 1, got '{text}'")
    if kind == NUMBER and text != "":
        try:
            float(text)
        except ValueError:
            raise ReportInputError(f"{path}:{line}: field '{column}': expected number, "
                                   f"got '{text}'") from None


def read_results(path):
    """results.csv's rows as dicts of text, every declared cell checked; `object` is "" in every
    row of a file written before the column (one object, named after nothing)."""
    header, rows = results_csv.read_rows(path, ReportInputError)
    missing = [c for c in RESULT_COLUMNS if c not in header]
    if missing:
        raise ReportInputError(f"{path}: column '{missing[0]}': missing")
    checked = dict(RESULT_COLUMNS)
    checked.update({c: NUMBER for c in NUMBER_COLUMNS if c in header})
    for line, row in enumerate(rows, 2):
        for column, kind in checked.items():
            check_cell(row[column], kind, path, line, column)
        row.setdefault("object", "")
    return rows


# ------------------------------------------------------------------------------------------------
# Reading


def load_json(path):
    try:
        with open(path, encoding="utf-8") as f:
            return json.load(f)
    except OSError as e:
        raise ReportInputError(f"{path}: cannot read ({e.strerror})")
    except ValueError as e:
        raise ReportInputError(f"{path}: not JSON ({e})")


def read_checked(path, schema):
    value = load_json(path)
    check_document(value, schema, path)
    return value


def read_jobs(study_dir):
    """(fits by (material, label), probe jobs by material); other job kinds are not the
    report's."""
    fits, probes = {}, {}
    for path in sorted(glob.glob(os.path.join(study_dir, "jobs", "*.json"))):
        if path.endswith(".timing.json"):
            continue  # wall-clock times (WriteTiming), not results
        job = load_json(path)
        kind = job.get("kind") if isinstance(job, dict) else None
        if kind == "fit":
            check_object(job, FIT_JOB, path)
            fits[(job["material"], job["label"])] = job
        elif kind == "probe":
            check_object(job, PROBE_JOB, path)
            probes[job["material"]] = job
    return fits, probes


def check_verdict_columns(study, study_path, rows, csv_path):
    """A verdict on the metrics names a number column of results.csv, and a split; so does
    every metric of the study's judging set."""
    for i, m in enumerate(study.get("judging") or []):
        if m not in VERDICT_COLUMNS or (rows and m not in rows[0]):
            raise ReportInputError(f"{study_path}: field 'judging[{i}]': '{m}' is not a "
                                   f"metric column of {csv_path}")
    for name, v in study["verdicts"].items():
        if v["source"] != "metrics":
            continue
        for field in ("metric", "split"):
            if field not in v:
                raise ReportInputError(f"{study_path}: field 'verdicts.{name}.{field}': missing")
        if v["metric"] not in VERDICT_COLUMNS or (rows and v["metric"] not in rows[0]):
            raise ReportInputError(f"{study_path}: field 'verdicts.{name}.metric': "
                                   f"'{v['metric']}' is not a column of {csv_path}")


def load_study(study_dir):
    """(study, results rows, fits, probes, provenance), every field the report reads checked."""
    study_path = os.path.join(study_dir, "study.json")
    study = load_json(study_path)
    check_study(study, study_path)
    csv_path = os.path.join(study_dir, "results.csv")
    rows = read_results(csv_path)
    check_verdict_columns(study, study_path, rows, csv_path)
    fits, probes = read_jobs(study_dir)
    prov_path = os.path.join(study_dir, "provenance.json")
    provenance = read_checked(prov_path, PROVENANCE) if os.path.exists(prov_path) else {}
    return study, rows, fits, probes, provenance


# ------------------------------------------------------------------------------------------------
# Material classes (report_classes.py answers per class; docs/studies.md, "Material classes"):
# the coarse Metal/Dielectric split of Lavoue et al. 2021, found beside the study's measured
# folder, and the finer classes compiled in report/material_classes.tsv.

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
