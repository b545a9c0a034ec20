"""The records the report's compute modules hand to its writers, declared in one place (issue 47
item 5): each a dataclass whose fields say what it holds. Compute modules make them; the words,
tables, figures and pages only format them. Nothing here reads a file or writes a word; a record
that comparisons.json or another JSON file holds says how (to_json), in the order the file has
always had."""

from dataclasses import dataclass, field, fields


# ------------------------------------------------------------------------------------------------
# Ngan, Durand and Matusik 2005 (report_ngan.ngan_comparison)


@dataclass(frozen=True)
class NganRow:
    """One material and fit: our number (`ours_label`: what it is) next to Ngan's (`ngan_label`:
    which of their fits)."""
    material: str
    fit: str
    ours_label: str
    ours: float
    ngan_label: str
    theirs: float


@dataclass(frozen=True)
class NganCorrelation:
    """Spearman's rho of one fit's `ours` quantity with Ngan's column `ngan` over `materials`
    materials; None where it is undefined (report_stats.spearman)."""
    fit: str
    model: str
    ours: str
    ngan: str
    materials: int
    spearman: float


@dataclass(frozen=True)
class NganComparison:
    """Every row and correlation; `source`: the ngan2005-fits.tsv read."""
    source: str
    rows: list
    correlations: list


class Readable:
    """A record read as a mapping as well (rec["name"], rec.get("unit")): for the writers that
    still index the dicts these records replaced (report_metric_figures, make_report's probe
    figures). New code reads the attributes."""

    def __getitem__(self, key):
        try:
            return getattr(self, key)
        except AttributeError:
            raise KeyError(key) from None

    def get(self, key, default=None):
        return getattr(self, key, default)


def present(record, names, optional=()):
    """{name: value} of `record`'s fields `names`, in that order, leaving out each of `optional`
    that is None: comparisons.json's records, as the dicts before them were written."""
    out = {}
    for n in names:
        v = getattr(record, n)
        if v is None and n in optional:
            continue
        out[n] = v
    return out


# ------------------------------------------------------------------------------------------------
# The comparative answers (answer_rules, answer_stats)


@dataclass(frozen=True)
class Question(Readable):
    """A question of the study (answer_rules.questions_of): an image question (source
    "metrics", kind "max", answered under the judging set over `split`'s lightings), or a probe
    verdict's ([verdicts] of study.json: its source, kind and tolerance). `default`: an image
    question the study did not name (a verdict names it otherwise); `split`: the verdict's, as
    study.json has it (None where it has none)."""
    name: str
    question: str
    source: str
    kind: str
    default: bool
    split: str = None
    tolerance: float = None


@dataclass
class Comparison(Readable):
    """A pair of fits compared over the units both have an error on (answer_stats.compare_pair):
    `effect` is the geometric mean of baseline error / fit error (mode "ratio"; > 1: the fit is
    closer) or the mean of baseline error - fit error ("difference"), `ci` its bootstrap 95%
    interval, `p` the paired test's and `p_holm` its Holm-adjusted p (holm_by_pair); `metric`
    (an image question's) or `what` (a probe question's error, in words) beside. The report's
    one fit/baseline ratio is answer_rules.error_ratio of it. comparisons.json records it by
    to_json(), without the fields it does not have."""
    fit: str
    baseline: str
    materials: list  # the units compared (materials, or "material, lighting")
    n: int
    mode: str
    effect: float
    ci: list
    closer: int
    farther: int
    tied: int
    p: float
    test: str
    fit_quartiles: tuple
    baseline_quartiles: tuple
    errors: dict
    metric: str = None
    what: str = None
    p_holm: float = None
    holm_family: int = None

    def to_json(self):
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        return {k: v for k, v in out.items()
                if v is not None or k not in ("metric", "what", "p_holm", "holm_family")}


@dataclass(frozen=True)
class Verdict(Readable):
    """A compared pair's verdict on an image question over the judging set: `kind` one of
    answer_rules.WORDS' keys and `word` its words; the metrics on each side (the fit's error
    smaller, larger, equal) and those of each side that are Holm-significant."""
    kind: str
    word: str
    n: int
    smaller: list
    larger: list
    equal: list
    significant_smaller: list
    significant_larger: list

    def significant(self):
        """The significant metrics on the verdict's own side (smaller or larger), else []."""
        return {"smaller": self.significant_smaller,
                "larger": self.significant_larger}.get(self.kind, [])


@dataclass
class PairAnswer(Readable):
    """A compared pair on an image question: a Comparison per metric of the judging set, then
    (on the question's own pairs, not the all-pixel ones) its Verdict and what the two fits
    are: training set, loss, role, models."""
    fit: str
    baseline: str
    per_metric: list
    verdict: Verdict = None
    train: list = None
    loss: str = None
    role: str = None
    model: str = None
    baseline_model: str = None

    def to_json(self):
        out = {f.name: getattr(self, f.name) for f in fields(self)}
        return {k: v for k, v in out.items() if v is not None}


@dataclass(frozen=True)
class UnitError(Readable):
    """One unit's error under one fit, as comparisons.json records it: the material, then its
    object and lighting where the unit has them (an image question's units), the metric (an
    image question's; None for a probe question's) and the error (None: no number)."""
    material: str
    fit: str
    error: float
    object: str = None
    lighting: str = None
    metric: str = None

    def to_json(self):
        return present(self, ("material", "object", "lighting", "fit", "metric", "error"),
                       optional=("object", "lighting", "metric"))


@dataclass(frozen=True)
class LossAgreement(Readable):
    """One model pair of one training set and role under the study's losses: the verdict kind
    under each loss, and whether it holds (the same all-metric verdict under every loss)."""
    train: str  # the training set's lightings joined by "+"
    role: str
    model: str
    baseline: str  # the baseline's model
    verdicts: dict  # {loss: verdict kind}
    holds: bool


@dataclass
class ImageQuestionRecord(Readable):
    """One image question answered under every metric of the judging set (`metrics`, chosen
    as `judging` says): each unit's error per fit and metric, the compared pairs
    (PairAnswer), where measured references have them the same pairs over every pixel
    (`all_pixels`), and the verdicts across losses. `unit`: "material", or "lighting" where
    the question has fewer than answer_rules.MIN_MATERIALS_FOR_PAIRED_TEST materials
    (`unit_materials` of them); `pooled_objects`: how many objects it pools, where several."""
    name: str
    question: str
    default: bool
    split: str
    metrics: list
    errors: list = field(default_factory=list)      # [UnitError]
    comparisons: list = field(default_factory=list)  # [PairAnswer]
    unit: str = "material"
    unit_materials: int = None
    all_pixels: list = None
    judging: str = None
    pooled_objects: int = None
    across_losses: list = field(default_factory=list)  # [LossAgreement]
    source: str = "metrics"
    mode: str = "per metric"
    n_a: list = field(default_factory=list)  # always empty: every image has an error

    def to_json(self):
        out = present(self, ("name", "question", "default", "source", "split", "mode",
                             "metrics", "n_a", "errors"))
        if self.unit == "lighting":
            out.update(unit=self.unit, unit_materials=self.unit_materials)
        out["comparisons"] = self.comparisons
        if self.all_pixels is not None:
            out["all_pixels"] = self.all_pixels
        out["judging"] = self.judging
        if self.pooled_objects is not None:
            out["pooled_objects"] = self.pooled_objects
        out["across_losses"] = self.across_losses
        return out


@dataclass
class ProbeQuestionRecord(Readable):
    """One probe verdict's question: each material's error per fit (the verdict's worst
    quantity; a `max` verdict's excess over its bound), the compared pairs (a Comparison
    each), and why the probe is not valid on some materials (`n_a`). `mode`: "ratio", or
    "difference" for a `max` verdict; `split`: the verdict's, as study.json has it."""
    name: str
    question: str
    default: bool
    source: str
    split: str
    mode: str
    n_a: list
    comparisons: list  # [Comparison]
    errors: list       # [UnitError]
    unit: str = "material"

    def to_json(self):
        return present(self, ("name", "question", "default", "source", "split", "mode", "n_a",
                              "comparisons", "errors"))


@dataclass(frozen=True)
class PairVerdict(Readable):
    """One compared pair's verdict on a question over a subset (an object, a material class):
    its Verdict and the lowest and highest error ratio (fit / baseline) over the metrics."""
    fit: str
    baseline: str
    verdict: Verdict
    ratio_range: tuple = None


@dataclass
class QuestionAnswer(Readable):
    """One image question over one object's units: `unit` "material" or "lighting", `units`
    how many."""
    name: str
    question: str
    split: str
    unit: str
    units: int
    pairs: list = field(default_factory=list)  # [PairVerdict]


@dataclass
class ObjectAnswer(Readable):
    """One object's answers: its materials (in the study's order) and its image questions."""
    object: str
    materials: list
    questions: list = field(default_factory=list)  # [QuestionAnswer]


@dataclass(frozen=True)
class ClassQuestion(Readable):
    """One image question over one material class: each pair's verdict."""
    name: str
    question: str
    pairs: list  # [PairVerdict]


@dataclass(frozen=True)
class MaterialClass(Readable):
    """One class of a classification (`scheme`, from `source`) with at least
    report_classes.MIN_MATERIALS of the study's materials, and its image questions."""
    scheme: str
    source: str
    class_name: str
    materials: list
    questions: list  # [ClassQuestion]

    def to_json(self):
        return {"scheme": self.scheme, "source": self.source, "class": self.class_name,
                "materials": self.materials, "questions": self.questions}


@dataclass(frozen=True)
class ClassAnswers(Readable):
    """The answers per material class, and why a classification or class is left out."""
    classes: list  # [MaterialClass]
    skipped: list  # [str]

    def to_json(self):
        return {"classes": self.classes, "skipped": self.skipped}


# ------------------------------------------------------------------------------------------------
# The model's floor (model_floor.model_floors)


@dataclass(frozen=True)
class FloorRatio(Readable):
    """A fit's error over its model's floor under one metric: the geometric mean over the
    materials (`n`) of fit error / floor error, its bootstrap 95% CI, and each material's."""
    ratio: float
    n: int
    ci: list
    per_material: dict


@dataclass(frozen=True)
class FloorEntry(Readable):
    """One fit against one floor fit of its model on one image question: the floor lightings
    it is judged on and, per metric of the judging set, its FloorRatio."""
    fit: str
    floor: str
    role: str
    lightings: list
    metrics: dict  # {metric: FloorRatio}


# ------------------------------------------------------------------------------------------------
# The fixed-tolerance verdicts (report_verdicts.compute_verdicts; verdicts.json)

CHECK_KEYS = ("phenomenon", "material", "fit", "quantity", "reference", "model", "error",
              "kind", "tolerance", "reproduced")


@dataclass(frozen=True)
class ToleranceCheck(Readable):
    """One quantity of a phenomenon x material x fit judged against the verdict's tolerance:
    the reference's number and the model's (`reference` None for a `max` verdict's bound), the
    error the tolerance bounds (`kind`: relative, absolute or max) and whether it is within
    (None: no number to judge). verdicts.json's "detail" records it by to_json()."""
    phenomenon: str
    material: str
    fit: str
    quantity: str
    reference: float
    model: float
    error: float
    kind: str
    tolerance: float
    reproduced: bool

    def to_json(self):
        return present(self, CHECK_KEYS)


@dataclass(frozen=True)
class ToleranceVerdict(Readable):
    """A phenomenon x material x fit: its worst quantity's ToleranceCheck numbers, whether every
    judged quantity is within the tolerance (`reproduced`; None where none was judged) and how
    many were judged (`quantities`); `not_valid`: why the probe is not valid on this kind of
    reference (answer_rules.NOT_VALID), never judged then. verdicts.json's "summary" records it
    by to_json(), `not_valid` only where it has one."""
    phenomenon: str
    question: str
    material: str
    fit: str
    quantity: str
    reference: float
    model: float
    error: float
    kind: str
    tolerance: float
    reproduced: bool
    quantities: int
    not_valid: str = None

    def to_json(self):
        return present(self, ("phenomenon", "question", "material", "fit", "quantity",
                              "reference", "model", "error", "kind", "tolerance", "reproduced",
                              "quantities", "not_valid"), optional=("not_valid",))


# ------------------------------------------------------------------------------------------------
# Where the difference lies (report_regions.region_means)


@dataclass(frozen=True)
class RegionMean(Readable):
    """One fit's luminance error in one image region under one lighting, each the mean over the
    `materials` that have the region: `signed` (fit - reference; > 0: brighter), `abs` (mean
    |error|) and `ref` (the reference's mean luminance). comparisons.json's "regions" records
    it after its key (split, lighting, region, fit) by to_json()."""
    signed: float
    abs: float
    ref: float
    materials: int

    def to_json(self):
        return present(self, ("signed", "abs", "ref", "materials"))


# ------------------------------------------------------------------------------------------------
# The data floor (data_floor.compute_floor; floor.json). Not the model's floor above: the best
# tabulated isotropic BRDF the photographs support, fitted without a model.


@dataclass(frozen=True)
class DataFloorDecoding:
    """The decoding a fit with encoding = "fit" chose (`label`: which fit), in which the floor
    is scored: `chosen` "srgb", "linear" or "gamma" with its `gamma`."""
    chosen: str
    gamma: float
    label: str

    def to_json(self):
        return present(self, ("chosen", "gamma", "label"))


@dataclass(frozen=True)
class DataFloorFit:
    """A fit of the material and training set next to the floor: its mean test relative RMSE
    over the floor's test lightings and how far above the floor's that is, in points (100 x
    the difference); None where it has no test error."""
    label: str
    test_relative_rmse: float
    points_above_floor: float

    def to_json(self):
        return present(self, ("label", "test_relative_rmse", "points_above_floor"))


@dataclass(frozen=True)
class DataFloorMaterial:
    """The data floor of one material (on one `object`, where the photographs show several) and
    training set: the smoothness weight chosen (`lam`, floor.json's "lambda") and each
    candidate's leave-one-lighting-out error (`loo_sse`, keyed by "%g"), the decoding, the
    table's relative RMSE over the training and the test lightings and per lighting, each
    channel's largest table value, and the fits beside it (DataFloorFit)."""
    material: str
    object: str
    train: list
    lam: float
    decoding: DataFloorDecoding
    loo_sse: dict
    train_relative_rmse: float
    test_relative_rmse: float
    per_lighting: dict
    test_lightings: list
    table_max: list
    fits: list  # [DataFloorFit]

    def to_json(self):
        out = {"material": self.material, **({"object": self.object} if self.object else {}),
               "train": self.train, "lambda": self.lam}
        return out | present(self, ("decoding", "loo_sse", "train_relative_rmse",
                                    "test_relative_rmse", "per_lighting", "test_lightings",
                                    "table_max", "fits"))


@dataclass(frozen=True)
class DataFloor:
    """floor.json: the table's shape (`bins`: theta_h x theta_d nodes, theta_h on
    `theta_h_spacing`), the smoothness weights tried, the relative RMSE's epsilon, a
    DataFloorMaterial per material and training set, and the references left out
    (`skipped`: floor_inputs.Geometry's, {"reference", "why"})."""
    schema: str
    bins: list
    theta_h_spacing: str
    lambdas: list
    relative_epsilon: float
    materials: list  # [DataFloorMaterial]
    skipped: list

    def to_json(self):
        return present(self, ("schema", "bins", "theta_h_spacing", "lambdas",
                              "relative_epsilon", "materials", "skipped"))
