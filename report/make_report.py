#!/usr/bin/python3
"""Tables, figures, verdicts, index.html and summary.md from a study's result files.

    /usr/bin/python3 report/make_report.py out/<study>

Reads only what `shadefit study run` wrote (study.json, results.csv, jobs/*.json, images/,
probes/, provenance.json) and writes <study dir>/report/. Links no renderer. Needs matplotlib and
numpy (Debian: python3-matplotlib python3-numpy). Format and verdict rules: docs/studies.md.

This file runs the steps in order: read (report_inputs, results_csv), compute, then write; each
concern has its module, mapped in docs/architecture.md ("report/").
"""

import gc
import glob
import json
import multiprocessing
import os
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import answer_rules  # noqa: E402
import answer_words  # noqa: E402
import data_floor  # noqa: E402
import figure_cache  # noqa: E402
import floor_inputs  # noqa: E402
import report_charts  # noqa: E402
import report_figures  # noqa: E402
import report_grids  # noqa: E402
import report_latex  # noqa: E402
import report_metric_figures  # noqa: E402
import report_ngan  # noqa: E402
import report_page  # noqa: E402
import report_probe_figures  # noqa: E402
import report_sections  # noqa: E402
import report_summary  # noqa: E402
import report_tables  # noqa: E402
import report_verdicts  # noqa: E402
import study_answers  # noqa: E402
import report_inputs  # noqa: E402
import section_words  # noqa: E402
from report_inputs import ReportInputError, load_study  # noqa: E402
from progress import Progress  # noqa: E402
from report_util import (collector_thresholds, flatten, fmt, frozen_heap, materials_of, to_float,  # noqa: E402
                         write_text)


def report_jobs():
    """Processes that draw the per-material figures: $SHADEFIT_REPORT_JOBS, else one per CPU this
    process may use (at most 8): its affinity mask's, and inside a Slurm job no more than its
    allocation ($SLURM_CPUS_PER_TASK; a cluster that does not bind tasks to CPUs leaves the mask
    at the whole node), as the C++ side counts them (shadefit/base/cpus.h)."""
    env = os.environ.get("SHADEFIT_REPORT_JOBS", "").strip()
    if env:
        try:
            jobs = int(env)
        except ValueError:
            jobs = 0
        if jobs < 1:
            raise ReportInputError(
                f"SHADEFIT_REPORT_JOBS: expected a whole number >= 1, got '{env}'")
        return jobs
    cpus = len(os.sched_getaffinity(0))
    allocated = os.environ.get("SLURM_CPUS_PER_TASK", "")
    if os.environ.get("SLURM_JOB_ID") and allocated.isdigit() and int(allocated) > 0:
        cpus = min(cpus, int(allocated))
    return max(1, min(8, cpus))


# What the forked figure workers read (set before the pool starts; fork shares it unpickled).
_FIGURE_INPUTS = None


def material_figures(task):
    """One part of a material's figures, drawn and saved: task (material, "grids"): its image
    grids; (material, "probes"): its probe figures. Returns their figures.json records."""
    material, part = task
    study_dir, study, fits, probes, fig_dir = _FIGURE_INPUTS
    records = []
    if part == "grids":
        report_grids.image_grid(study_dir, study, fits, material, fig_dir, records)
    elif material in probes:
        report_probe_figures.probe_figures(study, {material: probes[material]}, fig_dir,
                                           records, flatten)
    return records


def worker_material_figures(task):
    """material_figures in a figure worker, then what survives it (the kept probe figures, the
    text caches) frozen for the collector: a material's figures set off ~120 young and ~10
    middle passes, which otherwise walk every earlier material's survivors, and their garbage
    (closed figures) is collected here once. 20 materials' figures in one process: collection
    2.1-3.5 -> 1.4-1.6 s, peak 631 -> 581 MB. The worker ends with the pool, frozen heap and all."""
    records = material_figures(task)
    gc.collect()
    gc.freeze()
    return records


class MaterialFigures:
    """Every material's grids (in the study's order), then every probe figure (by material
    name): the same records, in the same order, with one process or several. A material whose
    figure inputs hash as at the last report (figure_cache) is not drawn again. The workers
    start at once; finish() collects them, so that the caller draws the study-level figures
    meanwhile. `digests`: report_inputs.read_jobs' (the cache keys); `progress`: a callable
    told each material as it is done."""

    def __init__(self, study_dir, study, fits, probes, fig_dir, jobs, digests, progress=None):
        global _FIGURE_INPUTS
        _FIGURE_INPUTS = (study_dir, study, fits, probes, fig_dir)
        self.grid_order = list(materials_of(study))
        self.probed = sorted(probes)
        materials = self.grid_order + sorted(m for m in probes if m not in self.grid_order)
        code = figure_cache.code_fingerprint()
        self.keys = {m: figure_cache.material_key(study_dir, study, fits, probes, m, code,
                                                  digests)
                     for m in materials}
        self.fig_dir, self.progress, self.done = fig_dir, progress, {}
        for m in materials:
            cached = figure_cache.load(fig_dir, m, self.keys[m])
            if cached is not None:
                self.done[m] = cached
                if progress:
                    progress(m)
        self.todo = [m for m in materials if m not in self.done]
        # A material's grids and its probe figures are two tasks (~1.3 and ~1.2 CPU-s in the
        # measured study): the last task to finish keeps one core busy alone for half as long.
        self.tasks = [(m, part) for m in self.todo for part in ("grids", "probes")]
        jobs = min(jobs, len(self.tasks))
        self.pool = None
        if jobs > 1:
            report_figures.warm_up()  # once here, not once per worker
            try:
                # Fork: the workers inherit the inputs and matplotlib's state; no figure is
                # open yet.
                self.pool = multiprocessing.get_context("fork").Pool(jobs)
            except OSError:
                pass  # No POSIX semaphores here (a container without /dev/shm): one process.
        self.drawn = (self.pool.imap(worker_material_figures, self.tasks, chunksize=1)
                      if self.pool is not None else None)

    def abandon(self):
        """Stops the workers (the report failed before it collected them)."""
        global _FIGURE_INPUTS
        if self.pool is not None:
            self.pool.terminate()
            self.pool.join()
            self.pool = None
        _FIGURE_INPUTS = None

    def finish(self):
        """The records, in figures.json's order, once every material is drawn."""
        global _FIGURE_INPUTS
        drawn = self.drawn if self.drawn is not None else map(material_figures, self.tasks)
        try:
            grids = None
            for (m, part), records in zip(self.tasks, drawn):
                if part == "grids":
                    grids = records
                    continue
                self.done[m] = (grids, records)
                figure_cache.store(self.fig_dir, m, self.keys[m], self.done[m], write_text)
                if self.progress:
                    self.progress(m)
        finally:
            if self.pool is not None:
                self.pool.close()
                self.pool.join()
        _FIGURE_INPUTS = None
        return ([r for m in self.grid_order for r in self.done[m][0]] +
                [r for m in self.probed for r in self.done[m][1]])


CAPTIONS = {
    "comparisons": "Comparative answers: each fit against the baseline fit over the materials "
                   "(effect: baseline error / fit error, geometric mean; p: Wilcoxon or exact "
                   "sign test; Holm-corrected)",
    "metrics": "Image metrics per reference and fit (linear radiance; display metrics at exposure 0)",
    "parameters": "Fitted parameters with standard errors",
    "probes": "Phenomenon probe numbers: reference and each fit",
    "verdicts": "Verdicts: worst quantity per phenomenon, material and fit",
    "verdict_details": "Verdicts per quantity",
    "matrix": "Materials reproduced within tolerance per phenomenon and fit",
    "ngan2005": "Our fitted lobe parameters next to Ngan, Durand and Matusik 2005's BRDF-space fits",
    "ngan2005_spearman": "Rank correlation of our fitted lobe widths with Ngan et al. 2005 "
                         "(Spearman)",
    "floor": "Data floor: each fit's mean test relative RMSE next to the best isotropic BRDF's "
             "(tabulated f(theta_h, theta_d), no model)",
    "encoding": "Encoding of the photographs: each candidate's RMSE in stored values",
}
# Columns of words set as wrapped paragraphs in report.tex: {table: {column: width in pt}} (fit
# labels, which a study with several losses makes 165 pt long; verdicts; lightings).
WRAP_PT = {"comparisons": {1: 80.0, 2: 80.0, 14: 60.0},
           "floors": {1: 80.0, 2: 70.0, 3: 60.0}}
# The columns before the first numeric one (left-aligned) per table.
NUMERIC_FROM = {"comparisons": 4, "every_metric": 4, "floors": 5, "regions": 4, "metrics": 4,
                "parameters": 3, "probes": 3, "verdicts": 4,
                "verdict_details": 4, "matrix": 2, "ngan2005": 3, "ngan2005_spearman": 3,
                "floor": 3, "encoding": 3}


class Inputs:
    """Everything the report reads, read and checked before the first file is written."""

    def __init__(self, study_dir):
        self.study_dir = study_dir
        self.jobs = report_jobs()
        # The SHA-256 of each fit and probe record's file (report_inputs.read_jobs): the figure
        # cache's keys.
        self.digests = {}
        (self.study, self.rows, self.fits, self.probes,
         self.provenance) = load_study(study_dir, self.digests)
        self.charts = report_charts.load_charts(study_dir)
        self.ngan = report_ngan.ngan_comparison(self.study, self.fits,
                                                report_inputs.read_ngan_fits(self.study))
        # The photographs' geometry, where the runner wrote geometry/ (the data floor's input).
        self.geometry = floor_inputs.read_geometry(study_dir)
        # The material classes' tables (report_classes: beside the measured folder, and ours).
        self.classified = report_inputs.classifications(self.study, study_dir)


def study_tables(inp, summary, detail, answers, floor):
    """({key: (columns, rows)} of every table the study has, in report.tex's order of keys,
    the answers' tables first; {key: caption})."""
    verdicts, verdict_details, matrix = report_tables.verdict_tables(inp.study, summary, detail)
    captions = dict(CAPTIONS)
    tables = {}
    for key, (caption, t) in answers.tables().items():
        captions[key] = caption
        tables[key] = t
    tables.update({"comparisons": answer_words.comparison_table(answers.records, fmt),
                   "metrics": report_tables.metrics_table(inp.study, inp.rows),
                   "parameters": report_tables.parameters_table(inp.study, inp.fits),
                   "probes": report_tables.probes_table(inp.study, inp.probes),
                   "verdicts": verdicts, "verdict_details": verdict_details, "matrix": matrix})
    if inp.ngan is not None:
        tables["ngan2005"] = report_tables.ngan_table(inp.ngan)
        tables["ngan2005_spearman"] = report_tables.spearman_table(inp.ngan)
    if floor is not None:
        tables["floor"] = section_words.data_floor_table(floor)
    tables["encoding"] = report_tables.encoding_table(inp.fits)
    # No empty table anywhere: one without rows (no verdicts, no encoding search) is left out of
    # tables/, summary.md, index.html and report.tex.
    return {k: t for k, t in tables.items() if t[1]}, captions


def write_tables(table_dir, tables, captions):
    for key, (cols, trows) in tables.items():
        # Findings: the question, then a column per compared pair, all words: wrapped.
        findings = key.startswith("findings")
        numeric_from = 1 if findings else NUMERIC_FROM[key]
        wrap = ({i: 110.0 if i == 0 else 85.0 for i in range(len(cols))} if findings
                else WRAP_PT.get(key))
        # A part of the probes table without the reference column would compare with nothing.
        report_latex.write_table(table_dir, key, cols, trows, captions[key], numeric_from,
                                 keep=4 if key == "probes" else None, wrap=wrap)


def write_json(report_dir, name, value):
    write_text(os.path.join(report_dir, name),
               json.dumps(value, indent=1, default=answer_rules.to_jsonable))


def draw_figures(inp, answers, fig_dir, materials, progress=None):
    """(figures, charts): the records of figures.json, in the page's order: the findings'
    forest plot first. `materials`: the per-material figures (MaterialFigures), drawing in
    their workers since the inputs were read. Each group of figures is drawn only where a hash
    of its inputs differs from the last report's (figure_cache)."""
    code = figure_cache.code_fingerprint()
    labels = [f["label"] for f in inp.study["fits"]]
    answers_json = answers.json()

    def group(name, inputs, draw, files=()):
        key = figure_cache.group_key(code, {"study": inp.study, "inputs": inputs}, files)
        records = figure_cache.cached_group(fig_dir, name, key, draw, write_text)
        if progress:
            progress(name)
        return records

    def answer_figures(manifest):
        answers.figures(labels, fig_dir, manifest)
        for rec in (r for r in answers.records if r["source"] != "metrics"):
            report_metric_figures.paired_errors_figure(
                rec, inp.study, fig_dir, manifest, answer_words.question_title(rec),
                answer_words.error_label(rec))

    figures = group("answers", answers_json, answer_figures)
    bars = group("metric-bars", inp.rows, lambda manifest: report_metric_figures.metric_bars(
        inp.study, inp.rows, fig_dir, manifest, to_float))
    # The charts are drawn from the files under charts/ (report_charts.load_charts).
    chart_files = glob.glob(os.path.join(inp.study_dir, "charts", "**", "*"), recursive=True)
    # Every fit and probe record, by its file's SHA-256 (report_inputs.read_jobs).
    charts = group("charts", {"charts": inp.charts, "jobs": sorted(inp.digests.items())},
                   lambda manifest: manifest.extend(report_charts.chart_figures(
                       inp.study_dir, inp.study, inp.fits, fig_dir, [], inp.charts, inp.probes)),
                   chart_files)
    return figures + materials.finish() + bars, charts


def make_report(study_dir, quiet=True):
    """Writes the report; returns index.html's path. `quiet`: no progress line (progress.py)."""
    inp = Inputs(study_dir)  # Every input is read and checked before the first file is written.
    # The inputs (a measured study's ~50 MB of records) live until the end: frozen, the
    # collector's full passes, which the figures' many short-lived objects set off ~100 times, no
    # longer walk them. In a one-process report of the measured study those passes took 9.2 of
    # 51.8 s, 4.2 after (most of it now freeing the closed figures). The collector's thresholds
    # are raised meanwhile (report_util.collector_thresholds). The figure workers fork inside
    # both blocks and inherit them; a caller that makes several reports keeps nothing frozen.
    with frozen_heap(), collector_thresholds(50000, 20, 10):
        return _make_report(inp, study_dir, quiet)


def _make_report(inp, study_dir, quiet):
    materials = set(materials_of(inp.study)) | set(inp.probes)
    # Steps: the inputs, the answers and tables, each material's figures, the three study-level
    # figure groups, the pages.
    progress = Progress(len(materials) + 6, quiet=quiet)
    progress.step("inputs read")
    report_dir = os.path.join(study_dir, "report")
    fig_dir = os.path.join(report_dir, "figures")
    os.makedirs(fig_dir, exist_ok=True)
    # The per-material figures (most of the report's time) need the inputs only: their workers
    # start now, and this process computes the answers, writes the tables and draws the
    # study-level figures meanwhile.
    # The PDFs' font subsets, made once for all the report's processes (report_figures).
    with tempfile.TemporaryDirectory(prefix="shadefit-report-fonts-") as font_dir:
        report_figures.share_font_subsets(font_dir)
        material_figs = MaterialFigures(inp.study_dir, inp.study, inp.fits, inp.probes,
                                        fig_dir, inp.jobs, inp.digests, progress.step)
        try:
            return _write_report(inp, report_dir, fig_dir, material_figs, progress)
        except BaseException:
            material_figs.abandon()
            raise
        finally:
            report_figures.share_font_subsets(None)


def _write_report(inp, report_dir, fig_dir, material_figs, progress):
    summary, detail = report_verdicts.compute_verdicts(inp.study, inp.rows, inp.probes)
    # Computed (study_answers: no file, no word), then formatted once for every page.
    answers = report_sections.AnswerSections(study_answers.compute_answers(
        inp.study, inp.rows, summary, to_float, inp.classified))
    # The data floor (data_floor.py) from the photographs' geometry (None without photographs).
    floor = data_floor.compute_floor(inp.geometry, inp.study, inp.fits)
    tables, captions = study_tables(inp, summary, detail, answers, floor)
    write_tables(os.path.join(report_dir, "tables"), tables, captions)
    # The verdicts also as JSON for tools and tests.
    write_json(report_dir, "verdicts.json", {"summary": summary, "detail": detail})
    write_json(report_dir, "comparisons.json", answers.json())
    progress.step("answers and tables")
    figures, charts = draw_figures(inp, answers, fig_dir, material_figs, progress.step)
    write_json(report_dir, "figures.json", figures + charts)
    if inp.ngan is not None:
        write_json(report_dir, "ngan2005.json", report_tables.ngan_json(inp.ngan))
    # Right after the comparative answers, each fit's test error next to the floor's.
    data_floor_lines = []
    if floor is not None:
        write_json(report_dir, "floor.json", floor)
        data_floor_lines = section_words.data_floor_sentences(floor)
    write_text(os.path.join(report_dir, "summary.md"), report_summary.summary_markdown(
        inp.study, summary, tables.get("matrix"), inp.provenance, answers, data_floor_lines,
        inp.fits, inp.ngan, figures))
    report_page.write_index(report_dir, inp.study, tables, figures, inp.provenance, summary,
                            inp.rows, inp.fits, charts, write_text, answers, data_floor_lines)
    report_latex.write_latex_document(report_dir, tables, figures + charts)
    progress.step("pages")
    progress.end()
    return os.path.join(report_dir, "index.html")


def main(argv):
    """make_report.py [-q] OUT/STUDY: -q (or $SHADEFIT_REPORT_QUIET=1), no progress line."""
    args = argv[1:]
    quiet = os.environ.get("SHADEFIT_REPORT_QUIET", "") not in ("", "0")
    if args and args[0] in ("-q", "--quiet"):
        quiet, args = True, args[1:]
    if len(args) != 1:
        print("usage: make_report.py [-q] OUT/STUDY", file=sys.stderr)
        return 2
    study_dir = os.path.abspath(args[0])
    for need_file in ["study.json", "results.csv"]:
        if not os.path.exists(os.path.join(study_dir, need_file)):
            print(f"make_report: error: {study_dir}/{need_file}: missing (run the study first)",
                  file=sys.stderr)
            return 1
    try:
        print(make_report(study_dir, quiet=quiet))
    except (ReportInputError, report_charts.ChartInputError, floor_inputs.FloorInputError) as e:
        print(f"make_report: error: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
