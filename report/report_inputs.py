"""The report's inputs and their schema: every field the report reads from a study's result files
(study.json, results.csv, jobs/*.json, provenance.json) is declared here once, with its type, and
checked when the file is read, before the first output is written.

A missing or mistyped field is a ReportInputError whose message is one line naming the file and
the field (`<file>: field 'fits[0].label': expected string, got number`); make_report.py prints it
and exits non-zero. Optional fields are the ones the runner legitimately leaves out (a fit without
previews has no `images`; only a fitted encoding writes `encoding`; a metric with no lit pixel is
null); readers take them with `.get(name)` and handle their absence, never with a default that
hides a required field's absence.

Every other field the runner writes is declared too, as Written: the report neither requires nor
checks it, but tests/report/report_schema_test.py walks a real study's files strictly
(strict_problems) and fails on any field present in a file and declared nowhere here, naming the
file and the field's path. So a field the runner adds fails a test until it is declared here; the
report's own reading stays tolerant of it.

Writers: studies/runner/src/study.cpp (study.json), fit_job.cpp (fit jobs), probe_job.cpp and
metrics/probes/src/output.cpp (probe jobs), outputs.cpp (results.csv, provenance.json).
"""

import csv
import dataclasses
import glob
import hashlib
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
    values it may take; `hint`: said after a wrong value (how to get a good one); `unread`: the
    runner writes it and the report does not read it (see Written)."""

    def __init__(self, kind, optional=False, nullable=False, one_of=None, hint="",
                 unread=False):
        self.kind, self.optional, self.nullable = kind, optional, nullable
        self.one_of, self.hint, self.unread = one_of, hint, unread


def Optional(kind, nullable=False, one_of=None):
    return Field(kind, optional=True, nullable=nullable, one_of=one_of)


def Written(kind, nullable=False):
    """A field the runner writes that the report does not read: declared, so that the strict
    walk (strict_problems, tests/report/report_schema_test.py) fails on a field the runner adds
    and this schema lacks; never required nor checked when the report reads the file (an older
    or newer runner's file still gets its report)."""
    return Field(kind, optional=True, nullable=nullable, unread=True)


class Object:
    def __init__(self, fields):
        self.fields = {k: v if isinstance(v, Field) else Field(v) for k, v in fields.items()}


class Array:
    def __init__(self, item):
        self.item = item


class Map:
    def __init__(self, value):
        self.value = value


_JSON_TYPES = {type(None): "null", bool: BOOLEAN, int: NUMBER, float: NUMBER, str: STRING,
               list: "array", dict: "object"}
_KIND_NAMES = {Object: "object", Map: "object", Array: "array"}
# The Python types json.loads makes of a scalar kind's values (an array of them is checked by
# its set of types).
_PYTHON_TYPES = {NUMBER: frozenset((int, float)), STRING: frozenset((str,)),
                 BOOLEAN: frozenset((bool,))}


def json_type(value):
    """The JSON name of a parsed value's type."""
    name = _JSON_TYPES.get(type(value))
    if name is not None:
        return name
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
    return _KIND_NAMES[type(kind)]


# A field's place in its file is said only in an error: while checking it is `where`, a string
# ("" at the top, or a top-level field's name) or (the parent's place, "." or "[", the name or
# index), made into 'evaluations[0].images.fit' by where_text. A study's ~2,000 job files hold
# ~5 million checked values (their curves' numbers): formatting every place took half of the
# check.
def where_text(where):
    if isinstance(where, str):
        return where
    parent, sep, key = where
    return f"{where_text(parent)}[{key}]" if sep == "[" else f"{where_text(parent)}.{key}"


def check(value, kind, path, where, strict=False):
    """Raises ReportInputError unless `value` (at `where` in the file `path`) is a `kind` (a kind
    or a Field). `strict`: the fields the report does not read (Written) are checked too."""
    if isinstance(kind, Field):
        check_field(value, kind, path, where, strict)
        return
    if kind == ANY:
        return
    want = expected_name(kind)
    got = json_type(value)
    if got != want:
        raise ReportInputError(f"{path}: field '{where_text(where)}': expected {want}, "
                               f"got {got}")
    if isinstance(kind, Array):
        item = kind.item
        # Scalars (a curve's numbers), nullable or not: their types here; a wrong one through
        # check, which says why.
        scalar, nullable = item, False
        if isinstance(item, Field):
            scalar = item.kind if item.one_of is None and not item.unread else None
            nullable = item.nullable
        ok = _PYTHON_TYPES.get(scalar) if isinstance(scalar, str) else None
        if ok is not None:
            ok = ok | {type(None)} if nullable else ok
            if not set(map(type, value)) <= ok:
                for i, x in enumerate(value):
                    if type(x) not in ok:
                        check(x, item, path, (where, "[", i), strict)
        else:
            for i, x in enumerate(value):
                check(x, item, path, (where, "[", i), strict)
    elif isinstance(kind, Map):
        for name, x in value.items():
            check(x, kind.value, path, (where, ".", name), strict)
    elif isinstance(kind, Object):
        check_object(value, kind, path, where, strict)


def check_field(value, field, path, where, strict=False):
    """A present field's value: null where nullable, one of its values where it has a list."""
    if field.unread and not strict:
        return
    if value is None and field.nullable:
        return
    if field.one_of is not None and value not in field.one_of:
        want = " or ".join(repr(v) for v in field.one_of)
        raise ReportInputError(f"{path}: field '{where_text(where)}': expected {want}, got "
                               f"{value!r}" + (f" ({field.hint})" if field.hint else ""))
    check(value, field.kind, path, where, strict)


def check_object(obj, schema, path, where="", strict=False):
    for name, field in schema.fields.items():
        if name in obj:
            check_field(obj[name], field, path, (where, ".", name) if where else name, strict)
        elif not field.optional:
            at = f"{where_text(where)}.{name}" if where else name
            raise ReportInputError(f"{path}: field '{at}': missing"
                                   + (f" ({field.hint})" if field.hint else ""))


def undeclared_fields(value, kind, where=""):
    """The paths ('evaluations[0].images.domain') of the fields in `value` that `kind` does not
    declare: the strict walk's half that the report's own reading never does (it reads what it
    declares and passes over the rest). ANY's inside is not the report's contract; a Map's
    names are data."""
    if isinstance(kind, Field):
        kind = kind.kind
    if isinstance(kind, Object) and isinstance(value, dict):
        for name, item in value.items():
            at = f"{where}.{name}" if where else name
            if name not in kind.fields:
                yield at
            else:
                yield from undeclared_fields(item, kind.fields[name], at)
    elif isinstance(kind, Array) and isinstance(value, list):
        for i, item in enumerate(value):
            yield from undeclared_fields(item, kind.item, f"{where}[{i}]")
    elif isinstance(kind, Map) and isinstance(value, dict):
        for name, item in value.items():
            yield from undeclared_fields(item, kind.value, f"{where}.{name}")


def strict_problems(value, schema, path):
    """Every way `value` (the file `path`) departs from `schema`, held strictly: one line per
    field present in the file and declared nowhere, then the first field of a wrong type or
    missing (the fields the report does not read included). [] when the file is exactly what
    the schema declares. For tests: the report's reader stays tolerant of fields it does not
    know."""
    out = [f"{path}: field '{at}': not declared in report/report_inputs.py's schema"
           for at in undeclared_fields(value, schema)]
    try:
        if isinstance(schema, Object) and isinstance(value, dict):
            check_object(value, schema, path, strict=True)
        else:
            check(value, schema, path, "", strict=True)
    except ReportInputError as e:
        out.append(str(e))
    return out


# ------------------------------------------------------------------------------------------------
# study.json (StudySpec's JSON, studies/runner/src/study.cpp)

VERDICT_KINDS = ("relative", "absolute", "max")
# A fit's role (FitRoleName, studies/runner/src/study.cpp): an ordinary training set; the joint
# fit to every lighting of [fit] floor (the model's best on these views); the BRDF-space fit.
FIT_ROLES = ("train", "floor", "brdf")
# What the runner calls a lighting of a fit (job_graph.cpp): trained on, listed in [fit] test,
# or neither ("other").
SPLITS = ("train", "test", "other")

# A model's fit settings (FitSettings::ToJson, study.cpp): the report reads the loss of studies
# written before fits carried theirs (normalise_fits).
FIT_SETTINGS = Object({
    "loss": Optional(STRING),
    "loss_scale": Written(NUMBER), "starts": Written(NUMBER), "seed": Written(NUMBER),
    "exposure": Written(STRING), "path": Written(STRING), "max_iterations": Written(NUMBER),
    "pixel_stride": Written(NUMBER), "environment_samples": Written(NUMBER),
    "fixed": Written(Array(STRING)),
    "encoding": Written(STRING),  # only when not the default ("as imported")
    "start": Written(STRING),     # only when not the default: "brdf"
})

STUDY = Object({
    "schema": Written(STRING),
    "name": STRING,
    "description": STRING,
    "path": Written(STRING),  # the study file
    "quick": Written(BOOLEAN),
    "shadefit_version": Written(STRING),  # WriteStudyJson (outputs.cpp), absent in provenance
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
        "object": Written(STRING),  # a group of a named object only (results.csv has it too)
        "references": Array(Object({"lighting": STRING, "sidecar": STRING,
                                    "name": Written(STRING), "image": Written(STRING)})),
    })),
    "models": Written(Array(STRING)),
    "training_sets": Array(Array(STRING)),
    "test_lightings": Array(STRING),  # empty: every lighting not trained on
    "baseline": Field(STRING, nullable=True),
    "compare": Array(Array(STRING)),
    "losses": Optional(Array(STRING)),   # absent before several losses: the models' own
    "floor": Optional(Array(STRING)),    # the floor fits' lightings; [] or absent: none
    "judging": Optional(Array(STRING), nullable=True),  # [verdicts] judging; null: the default
    "fit_settings": Optional(Map(FIT_SETTINGS)),
    "metrics": Written(Object({"exposure_stops": NUMBER, "ppd": NUMBER})),
    "probes": Array(STRING),
    "measured": Array(Object({"materials": Array(STRING), "folder": Optional(STRING),
                              "present": Written(BOOLEAN), "lightings": Written(Array(STRING)),
                              "scenes": Written(Array(STRING)), "samples": Written(NUMBER),
                              # [[measured]] object = "...": the mesh its materials are on
                              "object": Written(STRING)})),
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
    "outputs": Written(Object({"previews": BOOLEAN, "report": BOOLEAN,
                               "floor": Field(BOOLEAN, nullable=True)})),
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

# A pass's metrics (MetricsSummary, fit_job.cpp): every metric column of results.csv, null where
# the pass had no pixel.
NUMBERS = Object({m: Optional(NUMBER, nullable=True) for m in results_csv.METRIC_COLUMNS})

# The head of every job record (BaseJson, job_records.cpp).
JOB_HEAD = {"schema": Written(STRING), "id": Written(STRING), "hash": Written(STRING),
            "shadefit_version": Written(STRING), "outputs": Written(Array(STRING))}

# Where a fit's error lies (RegionErrors, region_errors.cpp): per region of REGIONS (results_csv),
# the means over its pixels, null where it has none.
REGION_ERRORS = Object({name: Object({"signed": Field(NUMBER, nullable=True),
                                      "abs": Field(NUMBER, nullable=True),
                                      "ref": Field(NUMBER, nullable=True), "pixels": NUMBER})
                        for name in results_csv.REGIONS})

FIT_JOB = Object({
    **JOB_HEAD,
    "kind": Field(STRING, one_of=("fit",)),
    "material": STRING,
    "label": STRING,
    "model": STRING,
    "train": Array(STRING),
    "status": Written(STRING),  # FitStatusName (fit_status.h)
    "error": Written(STRING),   # a failed fit only: why it left no parameters
    "converged": BOOLEAN,
    # The rest of the head only where the fit left parameters (HasFit): absent on a failed fit.
    "settings": Written(FIT_SETTINGS),
    "values": Written(Array(Field(NUMBER, nullable=True))),
    "exposure": Optional(NUMBER),
    "termination": Optional(STRING),
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
    # One per reference of the material (Evaluate, fit_job.cpp; EvaluationRecord, job_records.h).
    "evaluations": Array(Object({
        "reference": Written(STRING),
        "lighting": STRING,
        "split": Field(STRING, one_of=SPLITS),
        "metrics": NUMBERS,                  # over the measured pixels
        "metrics_all": Written(NUMBERS),     # over every covered pixel (results.csv's *_all)
        "measured_fraction": Optional(NUMBER),
        "rmse_fitter": Written(NUMBER, nullable=True),
        "metrics_pixels": Written(STRING),   # "covered", or "covered and measured"
        "covered_pixels": Written(NUMBER), "measured_pixels": Written(NUMBER),
        "lit_pixels": Written(NUMBER), "measured_lit_pixels": Written(NUMBER),
        "metrics_masked": Written(BOOLEAN, nullable=True),
        "metrics_all_masked": Written(BOOLEAN, nullable=True),
        # Every metric's full report (MetricsToJson, metrics/src/report.cpp): the metrics'
        # record, of which results.csv takes the summary; its inside is not the report's.
        "metrics_full": Written(ANY),
        "metrics_none": Written(STRING),      # why "metrics" has no numbers
        # Objects only: covered pixels outside the measured domain by reason (a shadow's edge,
        # strong interreflection; docs/scenes.md, "Shadows"), worded on the material's page.
        "excluded_pixels": Optional(Object({"shadow_edge": NUMBER, "interreflection": NUMBER})),
        "metrics_all_none": Written(STRING),  # why "metrics_all" has none
        "regions": Written(REGION_ERRORS, nullable=True),  # results.csv's region_* columns
        # Absent when the study writes no previews; "domain" on measured references only.
        "images": Optional(Object({"reference": Optional(STRING), "fit": Optional(STRING),
                                   "error": Optional(STRING), "error_scale": Optional(NUMBER),
                                   "domain": Optional(STRING)})),
    })),
    # The fitter's own record (FitResultToJson, fit/src/fit_output.cpp; Python's FitResult holds
    # its keys); the report reads what a free exposure pinned (fit/exposure_pin.h), absent in
    # jobs written before it was recorded. Its other parts are fit/'s: declared by name.
    "fit": Optional(Object({
        "exposure": Object({"mode": Field(STRING, one_of=("fixed", "free")),
                            "pinned": Optional(STRING),
                            "value": Written(NUMBER, nullable=True),
                            "std_error": Written(NUMBER, nullable=True)}),
        "shadefit_version": Written(STRING), "model": Written(STRING),
        "derivative_path": Written(STRING), "parameters": Written(ANY), "values": Written(ANY),
        "held": Written(ANY),  # only where the fit held values
        "loss": Written(ANY), "cost": Written(ANY), "rmse": Written(ANY), "solver": Written(ANY),
        "converged": Written(BOOLEAN), "starts": Written(ANY), "covariance": Written(ANY),
        "evaluations": Written(ANY), "inputs": Written(ANY),
    })),
    # The encoding search's record (fit.encoding = "fit" only; EncodingSearchToJson,
    # fit/src/encoding_search.cpp).
    "encoding": Optional(Object({
        "mode": Written(STRING),
        "chosen": STRING,
        "name": STRING,
        "gamma": Field(NUMBER, nullable=True),
        "stored_rmse": NUMBER,
        "scored_values": Written(NUMBER),
        "score": Written(STRING),  # what stored_rmse measures, in words
        "candidates": Array(Object({"name": STRING, "gamma": Field(NUMBER, nullable=True),
                                    "stored_rmse": NUMBER, "chosen": BOOLEAN,
                                    "encoding": Written(STRING),
                                    "linear_rmse": Written(NUMBER, nullable=True),
                                    "exposure": Written(NUMBER, nullable=True),
                                    "converged": Written(BOOLEAN)})),
        "gamma_search": Written(Array(Array(Field(NUMBER, nullable=True)))),  # [gamma, score]
    })),
})

# jobs/probe.*.json: the probes' results as ProbeResultToJson writes them
# (metrics/probes/src/output.cpp): curves are records, never parsed names.
PROBE_SCHEMA = "shadefit.probe/4"  # kProbeResultSchema, metrics/probes/include/shadefit/probes

PROBE_RESULT = Object({
    "schema": Field(STRING, one_of=(PROBE_SCHEMA,),
                    hint="written by an older shadefit: run the study again"),
    "probe": Written(STRING),
    "numbers": Map(ANY),  # per series, nested numbers; flattened by report_util.flatten
    "curves": Array(Object({
        # Numbers; null where not finite (internal::Num).
        "series": STRING, "kind": STRING, "x": Array(Field(NUMBER, nullable=True)),
        "y": Array(Field(NUMBER, nullable=True)),
        "x_label": STRING, "y_label": STRING, "x_scale": STRING, "y_scale": STRING,
        "reference": Field(STRING, nullable=True),  # null: a curve of no reference image
        "lighting": Field(STRING, nullable=True),  # that reference's lighting; null with it
        "x_ticks": Written(Array(STRING)),  # names of x = 0, 1, ...; empty where x is a number
        "extrapolated": Optional(Array(BOOLEAN)),
    })),
    "notes": Written(Array(STRING)),
})

PROBE_JOB = Object({
    **JOB_HEAD,
    "kind": Field(STRING, one_of=("probe",)),
    "material": STRING,
    "status": Written(STRING),  # "ok", or "no-fit" when no fit of the material left parameters
    "fits_without_parameters": Written(Array(STRING)),
    "probes_skipped": Written(Array(Object({"probe": STRING, "why": STRING}))),
    "probes": Map(PROBE_RESULT),
})

# A job record's schema by its `kind` (read_jobs); other kinds are not the report's.
JOB_SCHEMAS = {"fit": FIT_JOB, "probe": PROBE_JOB}

# provenance.json (outputs.cpp): shown at the page's foot; the file itself may be absent.
PROVENANCE = Object({
    "schema": Written(STRING),
    "study": Written(Object({"name": STRING, "path": STRING, "sha256": STRING, "text": STRING,
                             "quick": BOOLEAN})),
    "shadefit": Optional(Object({"version": Optional(STRING),
                                 "git_revision": Written(STRING)})),
    "options": Written(STUDY),  # the study as study.json has it, less shadefit_version
    "inputs": Written(Array(Object({
        "reference": STRING,
        **{part: Object({"path": STRING, "sha256": STRING})
           for part in ("image", "sidecar", "scene")}}))),
    "jobs": Written(Array(Object({"id": STRING, "hash": STRING}))),
    "gl_renderer": Optional(STRING),
    "dependencies": Optional(ANY),  # shown as they are
    "machine": Optional(ANY),
    # merged_shards: a merge of shards only (MergedShards, outputs.cpp)
    "run": Written(Object({"workers": NUMBER, "ceres_threads_per_fit": NUMBER,
                           "merged_shards": Optional(ANY)})),
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


def load_json(path, digest=None):
    """The JSON document at `path`; `digest`: a list that receives the SHA-256 (hex) of the
    bytes it was parsed from."""
    try:
        with open(path, "rb") as f:
            raw = f.read()
        if digest is not None:
            digest.append(hashlib.sha256(raw).hexdigest())
        return json.loads(raw.decode("utf-8"))
    except OSError as e:
        raise ReportInputError(f"{path}: cannot read ({e.strerror})")
    except ValueError as e:
        raise ReportInputError(f"{path}: not JSON ({e})")


def read_checked(path, schema):
    value = load_json(path)
    check_document(value, schema, path)
    return value


def read_jobs(study_dir, digests=None):
    """(fits by (material, label), probe jobs by material); other job kinds are not the
    report's. `digests`: a dict that receives the SHA-256 of each kept record's file, under the
    record's key (("fit", material, label), ("probe", material)): what the
    figure cache keys figures by (figure_cache.py), the bytes the record was read from."""
    fits, probes = {}, {}
    for path in sorted(glob.glob(os.path.join(study_dir, "jobs", "*.json"))):
        if path.endswith(".timing.json"):
            continue  # wall-clock times (WriteTiming), not results
        digest = []
        job = load_json(path, digest)
        kind = job.get("kind") if isinstance(job, dict) else None
        if kind in JOB_SCHEMAS:
            check_object(job, JOB_SCHEMAS[kind], path)
        if kind == "fit":
            fits[(job["material"], job["label"])] = job
            key = ("fit", job["material"], job["label"])
        elif kind == "probe":
            key = ("probe", job["material"])
            probes[job["material"]] = job
        else:
            continue
        if digests is not None:
            digests[key] = digest[0]
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


def load_study(study_dir, digests=None):
    """(study, results rows, fits, probes, provenance), every field the report reads checked;
    `digests`: read_jobs'."""
    study_path = os.path.join(study_dir, "study.json")
    study = load_json(study_path)
    check_study(study, study_path)
    csv_path = os.path.join(study_dir, "results.csv")
    rows = read_results(csv_path)
    check_verdict_columns(study, study_path, rows, csv_path)
    fits, probes = read_jobs(study_dir, digests)
    prov_path = os.path.join(study_dir, "provenance.json")
    provenance = read_checked(prov_path, PROVENANCE) if os.path.exists(prov_path) else {}
    return study, rows, fits, probes, provenance


# ------------------------------------------------------------------------------------------------
# Ngan, Durand and Matusik 2005's BRDF-space fits (report_ngan.ngan_comparison compares our fits
# with them): ngan2005-fits.tsv beside the measured folder the study's references came from.

NGAN_NAME = "ngan2005-fits.tsv"


@dataclasses.dataclass(frozen=True)
class NganFits:
    path: str
    fits: dict  # {material: {column: number}}


def ngan_table_path(study):
    """ngan2005-fits.tsv beside the measured folder the study's references came from, if any."""
    for g in study["groups"]:
        for r in g["references"]:
            sidecar = r["sidecar"]
            if not sidecar or not os.path.exists(sidecar):
                continue
            sc = read_checked(sidecar, SIDECAR)
            if sc.get("kind") != "measured-brdf":
                continue
            if "brdf" not in sc:
                raise ReportInputError(f"{sidecar}: field 'brdf': missing (a measured-brdf "
                                       "sidecar names its BRDF files)")
            for f in sc["brdf"]["files"]:
                candidate = os.path.join(os.path.dirname(os.path.dirname(f["path"])), NGAN_NAME)
                if os.path.exists(candidate):
                    return candidate
    return None


def read_ngan_fits(study):
    """NganFits of the study's measured folder, or None where it has no ngan2005-fits.tsv."""
    path = ngan_table_path(study)
    if path is None:
        return None
    with open(path, encoding="utf-8") as f:
        lines = [l.rstrip("\n") for l in f if l.strip() and not l.startswith("#")]
    header = lines[0].split("\t")
    out = {}
    for line in lines[1:]:
        cells = line.split("\t")
        out[cells[0]] = {h: float(c) for h, c in zip(header[1:], cells[1:])}
    return NganFits(path, out)


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
