"""summary.md: the study's answers first, then the data floor, the verdicts within tolerance, the
verdict matrix, the encoding search and the comparison with Ngan et al. 2005."""

import datetime

import judging
import answer_words
import report_findings
from report_util import labels_of, materials_of, md_escape


def judged_metrics(comparisons):
    return next((r.metrics for r in comparisons if r.source == "metrics"), [])


def not_valid_reasons(summary, name):
    return sorted({s.not_valid for s in summary if s.phenomenon == name and s.not_valid})


def summary_markdown(study, summary, matrix, provenance, answers, data_floor_lines, fits, ngan,
                     figures=()):
    """summary.md's text: the findings first (a table per training set, the forest plot),
    then the sentences. `answers`: report_sections.AnswerSections; `data_floor_lines`: the data floor's
    sentences (none without photographs); `ngan`: report_ngan.ngan_comparison's record, or
    None; `figures`: figures.json's records (the forest plot's is linked)."""
    labels = labels_of(study)
    comparisons = answers.records
    lines = [f"# {study['name']}", "", study["description"], "",
             f"Materials: {', '.join(materials_of(study))}. Fits: {', '.join(labels)}. "
             f"Training lightings: {'; '.join('+'.join(t) for t in study['training_sets'])}.", "",
             "## Findings", ""]
    lines += report_findings.findings_markdown(answers.findings)
    lines += [f"![{f['caption']}]({f['png']})" for f in figures if f.get("kind") == "forest"]
    lines += ["", "## Answers", "", answer_words.method_text(comparisons), ""]
    lines += answer_words.answer_lines(comparisons)
    for _, title, section in answers.sections():
        lines += ["", f"### {title}", ""] + answer_words.markdown_list(section)
    hcols, hrows = judging.human_agreement_table(judged_metrics(comparisons))
    lines += ["", "### Image metrics against human judgments", "",
              f"Spearman rho of each metric with the human distance over "
              f"{judging.HUMAN_AGREEMENT_SOURCE}. {judging.RULE_TEXT}.", "",
              "| " + " | ".join(hcols) + " |", "|---|---:|---:|---|"]
    lines += ["| " + " | ".join(r) + " |" for r in hrows]
    if data_floor_lines:
        lines += ["", "### Data floor", ""] + [f"- {l}" for l in data_floor_lines]
    lines += ["", "## Within tolerance (secondary)", "",
              "Materials whose numbers are within the study's fixed tolerance, out of those "
              "judged.", ""]
    lines += within_tolerance_lines(study, summary) or ["No fixed-tolerance verdicts in this study."]
    if matrix is not None:  # None: no verdict, no row (make_report prints no empty table)
        lines += ["", "## Verdict matrix", "", "| " + " | ".join(matrix[0]) + " |",
                  "|" + "|".join("---" for _ in matrix[0]) + "|"]
        lines += ["| " + " | ".join(md_escape(c) for c in r) + " |" for r in matrix[1]]
    sf = provenance.get("shadefit", {})
    lines += ["", f"shadefit {sf.get('version', '?')}, GL: {provenance.get('gl_renderer', '?')}, "
              f"generated {datetime.date.today().isoformat()}.", ""]
    return ("\n".join(lines) + encoding_markdown(fits) + pin_markdown(fits)
            + ngan_markdown(ngan))


def within_tolerance_lines(study, summary):
    """Per verdict: the materials each fit reproduces within the study's tolerance."""
    labels = labels_of(study)
    lines = []
    for name, v in study["verdicts"].items():
        parts = []
        for label in labels:
            judged = [s for s in summary if s.phenomenon == name and s.fit == label
                      and s.reproduced is not None]
            if not judged:
                continue
            good = [s.material for s in judged if s.reproduced]
            parts.append(f"{label}: {len(good)}/{len(judged)}")
        tol = f"{v['kind']} tolerance {v['tolerance']:g}"
        why = not_valid_reasons(summary, name)
        answer = "; ".join(parts) if parts else (
            f"n/a ({why[0]})" if why else "not measured (no numbers)")
        if parts and why:
            answer += f"; n/a on the other materials ({why[0]})"
        lines.append(f"- **{v['question']}** ({tol}) — materials reproduced: {answer}")
    return lines


PIN_INTRO = ("The exposure is free (a photograph's is unknown), and exposure times the "
             "reflectances is what the pixels determine, so each model pinned one scale "
             "(docs/fitting.md, \"Free exposure\"):")


def pin_sentences(fits):
    """One sentence per fit label with a free exposure: the scale its model pinned
    (fit/exposure_pin.h; docs/fitting.md, "Free exposure")."""
    out, seen = [], set()
    for (material, label), job in sorted(fits.items(), key=lambda kv: kv[0][1]):
        pinned = job.get("fit", {}).get("exposure", {}).get("pinned")
        if pinned and label not in seen:
            seen.add(label)
            out.append((label, pinned))
    return out


def pin_markdown(fits):
    """The free exposure's section: what each fit pinned to keep its reflectances determined."""
    sentences = pin_sentences(fits)
    if not sentences:
        return ""
    return ("\n## Free exposure\n\n" + PIN_INTRO + "\n\n"
            + "\n".join(f"- {label}: {md_escape(pinned)}" for label, pinned in sentences) + "\n")


def encoding_markdown(fits):
    """The encoding search's section, where a fit chose the encoding of its photographs."""
    sentences = encoding_sentences(fits)
    if not sentences:
        return ""
    return ("\n## Encoding of the photographs\n\nScored by the RMSE between the encoded "
            "prediction and the stored values of the training photographs.\n\n"
            + "\n".join(sentences) + "\n")


def ngan_markdown(ngan):
    if ngan is None:
        return ""
    return "\n## Against Ngan, Durand and Matusik 2005\n\n" + "".join(
        f"- {c.fit}: Spearman rho of our {c.ours} with Ngan's {c.ngan} over "
        f"{c.materials} materials: "
        + (f"{c.spearman:.3f}" if c.spearman is not None else "n/a") + "\n"
        for c in ngan.correlations)


# --- Encoding of photographs (fit.encoding = "fit": fit/encoding_search.h) --------------------

def encoding_sentences(fits):
    """One sentence per fit whose encoding was fitted: which encoding won, on what score."""
    out = []
    for (material, label), job in sorted(fits.items()):
        e = job.get("encoding")
        if not isinstance(e, dict):
            continue
        others = "; ".join(f"{c['name']} {255 * c['stored_rmse']:.3f}"
                           for c in e["candidates"] if not c["chosen"])
        out.append(f"- {material} / {label}: the fit chose the encoding **{e['name']}** "
                   f"(RMSE in stored 8-bit codes {255 * e['stored_rmse']:.3f}; "
                   f"{others})")
    return out
