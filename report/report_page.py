"""index.html: the verdicts first, then one section per question led by the figure that answers
it, one image comparison viewer per material, the detail tables (collapsed, sortable) and the
provenance. Self-contained: the style sheet and script (report/page/) are inlined and every image
is a relative path inside the study folder, so the page works from file:// with no network.

Called by make_report.py; reads only what make_report.py hands it (tables, verdicts, figures,
results rows, the study's job files).
"""

import html
import json
import os
import re

import judging
import answer_words
import report_findings
import report_summary
from report_util import materials_of

PAGE_DIR = os.path.join(os.path.dirname(os.path.abspath(__file__)), "page")

# The questions a shading report answers, in reading order, and which verdicts answer each:
# a verdict belongs to the first family whose test accepts it (source, and split for metrics).
FAMILIES = [
    ("fresnel", "Fresnel", lambda v: v["source"] == "fresnel"),
    ("energy", "Energy", lambda v: v["source"] == "energy"),
    ("lobe", "Lobe shape", lambda v: v["source"] == "highlight"),
    ("image", "Image closeness", lambda v: v["source"] == "metrics" and v.get("split") == "train"),
    ("transfer", "New lighting",
     lambda v: v["source"] == "portability" or (v["source"] == "metrics" and v.get("split") == "test")),
]


def esc(s):
    return html.escape(str(s), quote=True)


def anchor(*parts):
    return "-".join(re.sub(r"[^A-Za-z0-9_-]+", "_", str(p)) for p in parts)


def read_asset(name):
    with open(os.path.join(PAGE_DIR, name), encoding="utf-8") as f:
        return f.read()


def html_table(t, sortable=False, cls=""):
    cols, rows = t
    classes = " ".join(c for c in [cls, "sortable" if sortable else ""] if c)
    out = [f"<table class='{classes}'><thead><tr>" if classes else "<table><thead><tr>"]
    out[0] += "".join(f"<th>{esc(c)}</th>" for c in cols) + "</tr></thead><tbody>"
    for r in rows:
        cells = []
        for c in r:
            k = {"yes": " class='yes'", "no": " class='no'", "NO": " class='no'"}.get(c, "")
            cells.append(f"<td{k}>{esc(c)}</td>")
        out.append("<tr>" + "".join(cells) + "</tr>")
    out.append("</tbody></table>")
    return "\n".join(out)


def lazy_table(key, t):
    """A sortable table whose rows are JSON in the page, built by the script when its <details>
    first opens: a long table costs half the bytes and no layout until someone reads it."""
    cols, rows = t
    data = json.dumps([[str(c) for c in r] for r in rows], separators=(",", ":"))
    data = data.replace("</", "<\\/")  # Never ends the script element early.
    return (f"<table class='sortable' data-rows='{esc(anchor('data', key))}'><thead><tr>"
            + "".join(f"<th>{esc(c)}</th>" for c in cols) + "</tr></thead><tbody></tbody></table>"
            f"<script type='application/json' id='{esc(anchor('data', key))}'>{data}</script>")


def family_of(verdict):
    for key, title, test in FAMILIES:
        if test(verdict):
            return key
    return None


def fmt_num(v):
    return "n/a" if v is None else f"{v:.3g}"


def statement(name, v, summary, labels):
    """Two sentences computed from the verdict records: the count per fit, then the worst case
    (or, when every fit reproduces everything, the closest margin)."""
    counts, judged_all = [], []
    for label in labels:
        judged = [s for s in summary if s.phenomenon == name and s.fit == label
                  and s.reproduced is not None]
        judged_all += judged
        if judged:
            counts.append(f"{label} on {sum(1 for s in judged if s.reproduced)} of {len(judged)}")
    if not judged_all:
        return (f"No fit could be judged on this question: the numbers it needs were not "
                f"measured (tolerance {v['kind']} {v['tolerance']:g}).")
    first = (f"Within the tolerance ({v['kind']} {v['tolerance']:g}), the phenomenon is "
             f"reproduced by {', '.join(counts)} materials.")
    failed = [s for s in judged_all if not s.reproduced]
    tol = v["tolerance"]
    ratio = (lambda s: s.error / tol) if tol > 0 else (lambda s: s.error)
    if failed:
        w = max(failed, key=ratio)
        ref = "" if v["kind"] == "max" else f" against the reference's {fmt_num(w.reference)}"
        second = (f"Furthest off is {w.fit} on {w.material}: {w.quantity} = "
                  f"{fmt_num(w.model)}{ref} (error {fmt_num(w.error)}, "
                  f"{ratio(w):.1f} times the tolerance).")
    else:
        w = max(judged_all, key=ratio)
        second = (f"Every judged fit is within it; the closest to the limit is {w.fit} on "
                  f"{w.material} ({w.quantity}: error {fmt_num(w.error)}, "
                  f"{ratio(w):.2f} of the tolerance).")
    return first + " " + second


def lead_figure(family, verdict_names, summary, figures, materials):
    """The figures that answer a family's question: the probe figure of the material where the
    fits disagree most (or the first material); the metric bars for the image questions (and,
    for new lighting, the portability probe of one material after them)."""
    by_name = {f["name"]: f for f in figures}
    metric = [f for f in figures if f["name"].startswith("metric-")][:1]
    if family == "image":
        return metric
    probe = {"fresnel": "fresnel", "energy": "energy", "lobe": "highlight",
             "transfer": "portability"}.get(family)
    if probe is None:
        return []

    def disagreement(m):
        outcomes = {s.reproduced for s in summary
                    if s.material == m and s.phenomenon in verdict_names
                    and s.reproduced is not None}
        return len(outcomes)

    candidates = [m for m in materials if f"probe-{probe}-{m}" in by_name]
    if not candidates:
        return metric if family == "transfer" else []
    best = max(candidates, key=lambda m: (disagreement(m), -materials.index(m)))
    # New lighting: the training-vs-test bars first (every material), then one material's.
    return (metric if family == "transfer" else []) + [by_name[f"probe-{probe}-{best}"]]


def figure_html(f, extra_caption=""):
    return (f"<figure><img src='{esc(f['png'])}' "
            f"alt='{esc(f['caption'])}' width='{f['width']}' height='{f['height']}' "
            f"style='width:{round(f['width_in'] * 128)}px;max-width:100%;height:auto'>"
            f"<figcaption>{esc(f['caption'])}{esc(extra_caption)} "
            f"(<a href='{esc(f['pdf'])}'>PDF</a>, {f['width_in']:g} in)</figcaption></figure>")


# At most this many fit columns in one matrix table: more (the measured study's 10 fits) are
# shown as one table per training set, so the question column keeps its width at 1400 px.
MATRIX_MAX_FITS = 6


def matrix_groups(study, labels):
    """[(heading, [(label, column name)])]: one group, or one per training set (columns named by
    model) when there are more than MATRIX_MAX_FITS fits."""
    if len(labels) <= MATRIX_MAX_FITS:
        return [("", [(l, l) for l in labels])]
    groups = {}
    several = len(study.get("losses") or []) > 1
    for f in study["fits"]:
        if f["label"] in labels:
            # One column per model: with several losses, a group per (training set, loss).
            key = "+".join(f["train"]) + (f", loss {f['loss']}" if several
                                          and f["role"] != "brdf" else "")
            groups.setdefault(key, []).append((f["label"], f["model"]))
    return [(f"Trained on {k}", cols) for k, cols in groups.items()]


def matrix_html(study, summary, labels):
    """The verdict matrix; each cell links to the question's section, where its evidence is. An
    "n/a" cell says why in its title (a probe not valid on the material's kind of reference).
    Nothing without a verdict: no empty table."""
    if not study["verdicts"]:
        return "<p>No fixed-tolerance verdicts in this study.</p>"
    order = [k for k, _, _ in FAMILIES]
    verdicts = sorted(study["verdicts"].items(),  # Questions in reading order.
                      key=lambda kv: order.index(family_of(kv[1])) if family_of(kv[1]) else len(order))
    out = []
    for heading, cols in matrix_groups(study, labels):
        if heading:
            out.append(f"<h3 class='matrix-group'>{esc(heading)}</h3>")
        out.append("<table class='matrix'><thead><tr><th>phenomenon</th><th>question</th>"
                   + "".join(f"<th>{esc(c)}</th>" for _, c in cols) + "</tr></thead><tbody>")
        for name, v in verdicts:
            fam = family_of(v)
            target = anchor("q", fam) if fam else anchor("v", name)
            row = [f"<td class='key'>{esc(name)}</td>",
                   f"<td class='question'><a href='#{target}'>{esc(v['question'])}</a></td>"]
            for label, _ in cols:
                mine = [s for s in summary if s.phenomenon == name and s.fit == label]
                judged = [s for s in mine if s.reproduced is not None]
                why = sorted({s.not_valid for s in mine if s.not_valid})
                good = sum(1 for s in judged if s.reproduced)
                text = f"{good}/{len(judged)}" if judged else "n/a"
                cls = "" if not judged else (" class='yes'" if good == len(judged) else
                                             (" class='no'" if good == 0 else " class='some'"))
                title = f"evidence: {name}, {label}" + (f"; n/a: {why[0]}" if why else "")
                row.append(f"<td{cls}><a href='#{anchor('v', name)}' title='{esc(title)}'>"
                           f"{text}</a></td>")
            out.append("<tr>" + "".join(row) + "</tr>")
        out.append("</tbody></table>")
    reasons = sorted({s.not_valid for s in summary if s.not_valid})
    if reasons:
        out.append("<p class='na'>n/a: " + " ".join(f"{esc(r)}." for r in reasons) + "</p>")
    return "\n".join(out)


def findings_html(answers, figures):
    """The findings, first on the page: a table per training set and the forest plot."""
    out = ["<section id='findings'><h2>Findings</h2><p class='method'>"
           + esc(report_findings.FINDINGS_LEGEND)
           + " The sentences, per question and pair, follow under Answers.</p>"]
    for title, t in answers.findings:
        out.append(f"<h3>{esc(title)}</h3>" + html_table(t, cls="findings"))
    out += [figure_html(f) for f in figures if f.get("kind") == "forest"]
    out.append("</section>")
    return "\n".join(out)


def folded(summary, inner):
    return [f"<details><summary>{esc(summary)}</summary>"] + inner + ["</details>"]


def answers_html(answers, figures, data_floor_lines=()):
    """The comparative answers after the findings: how they are computed, then per question its
    sentences (folded) and its figure; the floors, regions and classes (folded); then the data
    floor's sentences (section_words.data_floor_sentences), if any."""
    comparisons = answers.records
    out = ["<section id='answers'><h2>Answers</h2>",
           f"<p class='method'>{esc(answer_words.method_text(comparisons))}</p>"]
    by_question = {f.get("question"): f for f in figures
                   if f.get("kind") in ("comparison", "regions")}
    for rec in comparisons:
        items = answer_words.answer_items(rec)
        title = answer_words.question_title(rec)
        out.append(f"<h3 id='{anchor('a', rec.name)}'>{esc(title)}"
                   + (" <span class='default'>(default question)</span>" if rec.default else "")
                   + "</h3>")
        out += folded(f"{len(items) - 1} sentences", ["<ul class='answers'>"]
                      + [f"<li>{esc(text)}</li>" for _, text in items[1:]] + ["</ul>"])
        f = by_question.get(rec.name)
        if f is not None:
            out.append(figure_html(f))
    for key, title, items in answers.sections():
        out.append(f"<h3 id='{anchor('a', key)}'>{esc(title)}</h3>")
        out += folded(f"{len(items)} lines", ["<ul class='answers'>"]
                      + [f"<li>{esc(text)}</li>" for _, text in items] + ["</ul>"])
    if data_floor_lines:
        out.append("<h3 id='data-floor'>Data floor</h3><ul class='answers'>")
        out += [f"<li>{esc(line)}</li>" for line in data_floor_lines]
        out.append("</ul>")
    out.append("</section>")
    return "\n".join(out)


def rows_by_image(rows):
    """{(material, lighting, fit label): the first results.csv row of that image}: one pass,
    where a look-up per pane scanned every row (80 materials: ~10^4 panes x 10^4 rows)."""
    index = {}
    for r in rows:
        index.setdefault((r["material"], r["lighting"], r["label"]), r)
    return index


def excluded_words(evaluation):
    """An object's pixels outside the measured domain, by reason (fit_job.cpp's
    excluded_pixels: a shadow's edge, strong interreflection), as a share of its covered pixels;
    "" for a sphere or a plane, whose records have none."""
    excluded, covered = evaluation.get("excluded_pixels"), evaluation.get("covered_pixels")
    if not excluded or not covered:
        return ""
    parts = [f"{100 * excluded[k] / covered:.1f}% of the covered pixels {words}"
             for k, words in (("shadow_edge", "on a shadow's edge"),
                              ("interreflection", "with strong interreflection"))
             if excluded.get(k)]
    return f" (left out of fits and metrics: {', '.join(parts)})" if parts else ""


def metric_of(row, key):
    """`key` of a results.csv row as a number; None without the row or a number."""
    if row is None:
        return None
    try:
        return float(row[key])
    except (TypeError, ValueError):
        return None


def viewer_html(material, study, fits, row_of, labels):
    """Reference and each fit of one material at one exposure, stacked so one shows at a time;
    the error map of the fit shown (or last shown); an exposure slider (an SVG filter in linear
    RGB, so the slider scales radiance, not display values). `row_of`: rows_by_image's."""
    have = [l for l in labels if (material, l) in fits]
    if not have:
        return ""
    evals = {l: {e["lighting"]: e for e in fits[(material, l)]["evaluations"]} for l in have}
    lightings = [r["lighting"] for g in study["groups"] if g["material"] == material
                 for r in g["references"]]
    fid = anchor("exposure", material)
    out = [f"<div class='viewer' tabindex='0' id='{esc(anchor('viewer', material))}' "
           f"data-filter='{esc(fid)}' data-material='{esc(material)}'>",
           f"<svg width='0' height='0' style='position:absolute'><filter id='{esc(fid)}' "
           "color-interpolation-filters='linearRGB'><feComponentTransfer>"
           "<feFuncR type='linear' slope='1'/><feFuncG type='linear' slope='1'/>"
           "<feFuncB type='linear' slope='1'/></feComponentTransfer></filter></svg>",
           "<div class='lightings'>"
           + "".join(f"<button type='button'>{esc(l)}</button>" for l in lightings) + "</div>",
           "<div class='controls'><label>exposure <input class='exposure' type='range' "
           "min='-4' max='6' step='0.5' value='0'></label> <span class='ev'>0 EV</span></div>"]
    for light in lightings:
        first = evals[have[0]].get(light, {}).get("images", {})
        panes = [("reference", first.get("reference"),
                  "reference" + excluded_words(evals[have[0]].get(light, {})))]
        for l in have:
            e = evals[l].get(light, {})
            row = row_of.get((material, light, l))
            flip = metric_of(row, "flip_ldr_mean")
            rel = metric_of(row, "relative_rmse")
            desc = f"{l} ({e.get('split', '')}): LDR-FLIP {fmt_num(flip)}, rel. RMSE {fmt_num(rel)}"
            panes.append((l, e.get("images", {}).get("fit"), desc))
        # A measured reference's domain (docs/measured_and_imported.md, "The measured domain"),
        # last, so the keys 1-9 still pick the fits.
        e0 = evals[have[0]].get(light, {})
        if first.get("domain"):
            frac = e0.get("measured_fraction")
            share = f"{100 * frac:.1f}% of the covered pixels measured" if frac is not None else ""
            panes.append(("measured domain", first["domain"],
                          "measured domain: magenta pixels depend on the BRDF beyond theta_d = 75 "
                          "deg, where MERL did not measure, and are left out of the metrics"
                          + (f" ({share})" if share else "")))
        stack, thumbs, errors = [], [], []
        for i, (name, src, desc) in enumerate(panes):
            if not src:
                continue
            rel_src = "../" + src
            stack.append(f"<img src='{esc(rel_src)}' alt='{esc(material)} {esc(light)}: "
                         f"{esc(name)}' data-name='{esc(name)}'"
                         + (" class='hidden'" if i else "") + ">")
            thumbs.append(f"<div class='thumb{' on' if i == 0 else ''}' data-label='{esc(desc)}'"
                          f" title='key {i}'><img src='{esc(rel_src)}' alt=''>{esc(name)}</div>")
        for j, l in enumerate(have):
            images = evals[l].get(light, {}).get("images", {})
            src, scale = images.get("error"), images.get("error_scale")
            hidden = " class='hidden'" if j else ""
            bar = f"0 to {scale:.3g} W m<sup>-2</sup> sr<sup>-1</sup>, " if scale else ""
            errors.append(f"<figure{hidden}>" + (
                f"<img src='../{esc(src)}' alt='{esc(material)} {esc(light)}: |error| {esc(l)}'>"
                if src else "no error map") +
                f"<figcaption>|{esc(l)} - reference| (mean RGB, linear radiance; colour bar "
                f"{bar}the same for every fit of this reference)</figcaption></figure>")
        out.append(f"<div class='lighting-group' data-lighting='{esc(light)}'>"
                   f"<div class='shown-label'>{esc(panes[0][2])}</div><div class='panes'><div>"
                   f"<div class='stack'>{''.join(stack)}</div>"
                   f"<div class='thumbs'>{''.join(thumbs)}</div></div>"
                   f"<div class='error'>{''.join(errors)}</div></div></div>")
    out.append("<p class='help'>Keys (click the viewer or point at it): space or f flips between "
               "the reference and the last fit; 1-9 pick a fit, 0 or r the reference; left/right "
               "step through them; [ and ] change the lighting; + and - change the exposure. "
               "Hovering a thumbnail shows it. Previews are 8-bit at the study's display "
               "exposure: raising the exposure brightens dim lightings, clipped pixels stay "
               "clipped.</p></div>")
    return "\n".join(out)


def question_families(verdicts):
    """{family anchor: verdict names}, in FAMILIES' reading order, empty families dropped."""
    families = {k: [] for k, _, _ in FAMILIES}
    for name, v in verdicts.items():
        families.setdefault(family_of(v) or anchor("other", name), []).append(name)
    return {k: names for k, names in families.items() if names}


def nav_html(families, titles, charts, materials):
    nav = ["<nav><a href='#findings'>Findings</a><a href='#answers'>Answers</a>"
           "<a href='#verdicts'>Within tolerance</a>"]
    nav += [f"<a href='#{anchor('q', k)}'>{esc(titles.get(k, k))}</a>" for k in families]
    if charts:
        nav.append("<a href='#charts'>Parameter charts</a>")
    nav += [f"<a href='#{anchor('m', m)}'>{esc(m)}</a>" for m in materials]
    nav += ["<a href='#details'>Tables</a><a href='#provenance'>Provenance</a></nav>"]
    return "".join(nav)


def within_tolerance_html(study, summary, labels, comparisons):
    """The tolerance matrix, then why the image questions judge by their metric: each metric
    against human judgments."""
    hcols, hrows = judging.human_agreement_table(
        next((r.metrics for r in comparisons if r.source == "metrics"), []))
    return ["<h2 id='verdicts'>Within tolerance</h2><p>Secondary: materials whose numbers "
            "are within the study's fixed tolerance, out of those judged, per question and "
            "fit. Every number is computed from the result files (rules: docs/studies.md). A "
            "cell links to its evidence.</p>",
            matrix_html(study, summary, labels),
            "<h3 id='human-agreement'>Image metrics against human judgments</h3>"
            f"<p class='method'>Spearman rho of each metric with the human distance over "
            f"{esc(judging.HUMAN_AGREEMENT_SOURCE)}. {esc(judging.RULE_TEXT)}.</p>"
            + html_table((hcols, hrows), cls="agreement")]


def encoding_html(tables):
    """Photographs whose encoding was fitted (fit.encoding = "fit"): which one won, in words."""
    if "encoding" not in tables:
        return []
    chosen = [r for r in tables["encoding"][1] if r[5] == "yes"]
    return ["<h2 id='encoding'>Encoding of the photographs</h2><p>"
            + " ".join(f"{esc(r[0])} / {esc(r[1])}: the fit chose the encoding "
                       f"<b>{esc(r[2])}</b> (RMSE {esc(r[4])} in stored 8-bit codes)."
                       for r in chosen)
            + " Every candidate is in the table 'Encoding of the photographs' below; "
            "each is scored by the RMSE between the encoded prediction and the stored "
            "values of the training photographs.</p>"]


def pin_html(fits):
    """What each fit pinned with a free exposure (report_summary.pin_sentences), in words."""
    sentences = report_summary.pin_sentences(fits)
    if not sentences:
        return []
    return ["<h2 id='free-exposure'>Free exposure</h2><p>" + esc(report_summary.PIN_INTRO)
            + "</p><ul>" + "".join(f"<li>{esc(label)}: {esc(pinned)}</li>" for label, pinned in sentences)
            + "</ul>"]


def question_sections_html(study, families, titles, tables, summary, figures, charts, labels):
    """One section per family of questions, led by the figure that answers it."""
    verdicts, materials = study["verdicts"], materials_of(study)
    parts = []
    for fam, names in families.items():
        parts.append(f"<section id='{anchor('q', fam)}'><h2>{esc(titles.get(fam, names[0]))}</h2>")
        for f in lead_figure(fam, names, summary, figures, materials):
            parts.append(figure_html(f))
        for name in names:
            v = verdicts[name]
            parts.append(f"<h3 id='{anchor('v', name)}'>{esc(v['question'])}</h3>"
                         f"<p class='statement'>{esc(statement(name, v, summary, labels))}</p>")
            rows_v = [r for r in tables["verdicts"][1] if r[0] == name]
            parts.append(f"<details><summary>Per material ({len(rows_v)} rows)</summary>"
                         + html_table((tables["verdicts"][0], rows_v), sortable=True)
                         + "</details>")
        if fam == "energy" and charts:
            parts.append("<p>The parameter charts below show the same on spheres: "
                         "<a href='#charts'>Parameter charts</a>.</p>")
        parts.append("</section>")
    return parts


def charts_html(charts):
    if not charts:
        return []
    return (["<section id='charts'><h2>Parameter charts</h2><p>Each fitted model "
             "rendered over its two main parameters under one light and one exposure; "
             "the fitted materials are marked. A normalised lobe keeps its energy as "
             "it narrows (the highlight gets brighter as it gets smaller); the classic "
             "Blinn-Phong lobe keeps its peak and loses energy.</p>"]
            + [figure_html(f) for f in charts] + ["</section>"])


def material_sections_html(study, figures, fits, rows, labels):
    """Per material: the image comparison viewer and links to its grid figures."""
    parts = []
    row_of = rows_by_image(rows)
    for m in materials_of(study):
        parts.append(f"<section id='{anchor('m', m)}'><h2>{esc(m)}</h2>")
        parts.append(viewer_html(m, study, fits, row_of, labels))
        # A study with many fits splits a material's grid into parts (one per training set).
        grids = [f for f in figures if f.get("kind") == "grid" and f.get("material") == m]
        if len(grids) == 1:
            g = grids[0]
            parts.append(f"<p>All lightings at once: <a href='{esc(g['png'])}'>grid figure</a> "
                         f"(<a href='{esc(g['pdf'])}'>PDF</a>).</p>")
        elif grids:
            parts.append("<p>All lightings at once, in " + str(len(grids)) + " parts: " + "; ".join(
                f"<a href='{esc(g['png'])}'>{esc(g['name'])}</a> "
                f"(<a href='{esc(g['pdf'])}'>PDF</a>)" for g in grids) + ".</p>")
        parts.append("</section>")
    return parts


def details_html(tables, figures, charts):
    """The detail tables, collapsed and built when opened, and the list of every figure."""
    parts = ["<h2 id='details'>Tables</h2><p>Click a heading to open a table, a column "
             "heading to sort it. The same rows are in tables/ as CSV, Markdown and "
             "LaTeX.</p>"]
    # The worst-quantity verdict rows are in the question sections already.
    named = [("comparisons", "Comparative answers, every comparison"),
             ("every_metric", "Every image metric measured, judged or not (descriptive)"),
             ("floors", "Error over the model's floor"),
             ("regions", "Error per lighting and image region"),
             ("matrix", "Within tolerance: verdict matrix"), ("verdict_details", "Verdicts per quantity"),
             ("metrics", "Image metrics per reference and fit"),
             ("parameters", "Fitted parameters"), ("probes", "Probe numbers"),
             ("encoding", "Encoding of the photographs (fitted)"),
             ("ngan2005_spearman", "Against Ngan, Durand and Matusik 2005: rank correlation"),
             ("ngan2005", "Against Ngan, Durand and Matusik 2005: per material")]
    for key, title in named:
        if key in tables:
            parts.append(f"<details id='{anchor('t', key)}'><summary>{esc(title)} "
                         f"({len(tables[key][1])} rows)</summary>"
                         + lazy_table(key, tables[key]) + "</details>")
    parts.append("<details id='all-figures'><summary>Every figure "
                 f"({len(figures) + len(charts)})</summary>"
                 + "".join(f"<p><a href='{esc(f['png'])}'>{esc(f['name'])}</a> "
                           f"(<a href='{esc(f['pdf'])}'>PDF</a>): {esc(f['caption'])}</p>"
                           for f in figures + charts) + "</details>")
    return parts


def provenance_html(provenance):
    """provenance.json (optional, like each of its fields: report_inputs.PROVENANCE)."""
    sf = provenance.get("shadefit", {})
    prov = {k: provenance.get(k) for k in ["shadefit", "dependencies", "gl_renderer", "machine"]}
    return ("<h2 id='provenance'>Provenance</h2>"
            f"<p>shadefit {esc(sf.get('version', '?'))}; GL renderer "
            f"{esc(provenance.get('gl_renderer', '?'))}. Inputs and their SHA-256 are in "
            "provenance.json.</p><details><summary>Versions and machine</summary><pre>"
            + esc(json.dumps(prov, indent=2)) + "</pre></details>")


def write_index(report_dir, study, tables, figures, provenance, summary, rows, fits, charts,
                write_text, answers, data_floor_lines=()):
    labels = [f["label"] for f in study["fits"]]
    materials = materials_of(study)
    families = question_families(study["verdicts"])  # Reading order: the FAMILIES order.
    titles = {k: t for k, t, _ in FAMILIES}
    parts = ["<!doctype html><html lang='en'><head><meta charset='utf-8'>"
             "<meta name='viewport' content='width=device-width, initial-scale=1'>"
             f"<title>{esc(study['name'])}</title><style>{read_asset('report.css')}</style>"
             "</head><body>",
             f"<h1>{esc(study['name'])}</h1><p>{esc(study['description'])}</p>",
             nav_html(families, titles, charts, materials),
             findings_html(answers, figures), answers_html(answers, figures, data_floor_lines)]
    parts += within_tolerance_html(study, summary, labels, answers.records)
    parts += encoding_html(tables)
    parts += pin_html(fits)
    parts += question_sections_html(study, families, titles, tables, summary, figures, charts,
                                    labels)
    parts += charts_html(charts)
    parts += material_sections_html(study, figures, fits, rows, labels)
    parts += details_html(tables, figures, charts)
    parts.append(provenance_html(provenance))
    parts.append(f"<script>{read_asset('viewer.js')}</script></body></html>")
    write_text(os.path.join(report_dir, "index.html"), "\n".join(parts))
