"""Findings first: one compact table per training set (rows: questions; columns: compared
pairs; cells: the verdict word, the range of error ratios over the judging set and how many
metrics are Holm-significant) and one forest plot (each pair's error ratio with its 95% CI, one
marker per metric), which summary.md, index.html and report.tex open with (docs/studies.md,
"Findings")."""

import math

import judging
import answer_rules
from answer_words import fmt_range
from report_records import PairAnswer
from matplotlib.ticker import FixedLocator, FuncFormatter, NullFormatter

from report_figures import (FONT_PT, OKABE_ITO, PAGE_IN, legend_layout, plt, save_figure,
                            text_width_in, wrap_to_width)

MARKERS = ["o", "s", "^", "D", "v", "P", "X", "*", "<", ">", "h"]
METRIC_COLOURS = OKABE_ITO + ["#000000", "#777777", "#999933", "#882255"]


def set_key(pair, fit_of):
    f = fit_of[pair.fit]
    return ("+".join(f["train"]), f["role"])


def set_title(key):
    train, role = key
    return {"floor": "Floor fits (every floor lighting)", "brdf": "BRDF-space fits"}.get(
        role, f"Trained on {train}")


def column(pair, fit_of, several_losses):
    """'ggx vs blinn-phong', and '(log)' after it where the study has several losses."""
    f, b = fit_of[pair.fit], fit_of[pair.baseline]
    col = f"{f['model']} vs {b['model']}"
    return col + (f" ({f['loss']})" if several_losses and f["role"] != "brdf" else "")


def cell(pair):
    """The verdict in a few words: 'smaller under all 8 metrics; 0.52-0.88x; 8/8 sig.'; a
    probe question's single comparison: '2.3x smaller; sig.'."""
    if isinstance(pair, PairAnswer):
        v = pair.verdict
        rng = answer_rules.ratio_range(pair.per_metric)
        r = "" if rng is None else f"; {fmt_range(rng, 2)}"
        if v.kind in ("smaller", "larger"):
            sig = len(v.significant())
            return f"{v.word}{r}; {sig}/{v.n} sig."
        a, b = len(v.significant_smaller), len(v.significant_larger)
        return f"{v.word}{r}; " + (f"sig.: {a} smaller, {b} larger" if a or b else "none sig.")
    sig = "; sig." if (1 if pair.p_holm is None else pair.p_holm) < answer_rules.ALPHA else ""
    if pair.mode == "ratio":
        r = answer_rules.error_ratio(pair)
        r = math.inf if r is None else r
        if r == 1:
            return "equal"
        return f"{'smaller' if r < 1 else 'larger'}; {r:.2g}x{sig}"
    if pair.effect == 0:
        return "equal"
    side = "smaller" if pair.effect > 0 else "larger"
    return f"{side}; {-pair.effect:+.2g}{sig}"


def findings_tables(study, records):
    """[(title, (columns, rows))]: per training set, rows the questions, columns the compared
    pairs (model vs model, per loss), cells `cell`; then "Across losses" where there are
    several."""
    fit_of = {f["label"]: f for f in study["fits"]}
    several = len(study.get("losses") or []) > 1
    sets = {}
    for rec in records:
        for p in rec.comparisons:
            col = column(p, fit_of, several)
            sets.setdefault(set_key(p, fit_of), {}).setdefault(rec.name, {})[col] = cell(p)
    out = []
    for key, by_q in sets.items():
        cols = []
        for cells in by_q.values():
            cols += [c for c in cells if c not in cols]
        rows = [[next(r.question for r in records if r.name == q)]
                + [cells.get(c, "") for c in cols] for q, cells in by_q.items()]
        out.append((set_title(key), (["question"] + cols, rows)))
    losses = losses_table(records)
    return out + ([("Across losses", losses)] if losses else [])


def losses_table(records):
    """(columns, rows) or None: per image question and training set (a row each), per model
    pair (a column each), whether the verdict holds across the study's losses, else each
    loss's verdict."""
    cells = {}
    for rec in (r for r in records if r.source == "metrics"):
        for a in rec.across_losses:
            where = "floor fits" if a.role == "floor" else f"trained on {a.train}"
            verdicts = ", ".join(f"{loss} {kind}" for loss, kind in a.verdicts.items())
            cells.setdefault(f"{rec.question} ({where})", {})[
                f"{a.model} vs {a.baseline}"] = (
                f"holds: {next(iter(a.verdicts.values()))}" if a.holds
                else f"differs: {verdicts}")
    cols = list(dict.fromkeys(c for by in cells.values() for c in by))
    if not cols:
        return None
    return (["question (training set)"] + cols,
            [[q] + [by.get(c, "") for c in cols] for q, by in cells.items()])


# What a findings cell says, and how far it may be taken: summary.md, index.html and report.tex
# print this one text above the tables.
FINDINGS_LEGEND = (
    "Cells: the verdict, the range of error ratios (fit / baseline) over the judging set, and how "
    "many metrics are Holm-significant (p < 0.05). How far a verdict holds: one whose metrics "
    "are none of them significant (\"0/8 sig.\", \"none sig.\") describes these materials only "
    "and may turn on others; \"mixed\" and \"metric-dependent\" are no metric's answer; with "
    "several losses, the Across losses table says whether a verdict holds under each.")


def findings_markdown(tables):
    lines = [FINDINGS_LEGEND, ""]
    for title, (cols, rows) in tables:
        lines += [f"**{title}**", "", "| " + " | ".join(cols) + " |",
                  "|" + "|".join("---" for _ in cols) + "|"]
        lines += ["| " + " | ".join(r) + " |" for r in rows] + [""]
    return lines


# --- Forest plot --------------------------------------------------------------------------------


def forest_rows(records):
    """[(pair label, {question name: [(metric, ratio, lo, hi)]})] in reading order."""
    rows = {}
    for rec in (r for r in records if r.source == "metrics"):
        for p in rec.comparisons:
            label = f"{p.fit} vs {p.baseline}"
            pts = []
            for c in p.per_metric:
                r = answer_rules.error_ratio(c)
                if r is not None:
                    pts.append((c.metric, r, *answer_rules.error_ratio_ci(c)))
            rows.setdefault(label, {})[rec.name] = pts
    return list(rows.items())


def forest_plot(records, fig_dir, manifest):
    """Log error ratio (fit / baseline) with its 95% CI: a row per pair, a marker per metric,
    a panel per image question."""
    questions = [r for r in records if r.source == "metrics" and r.comparisons]
    rows = forest_rows(records)
    if not questions or not rows:
        return
    metrics = questions[0].metrics
    names = [judging.metric_name(m) for m in metrics]
    # "fit vs" over "baseline": two short lines instead of one that takes half the page.
    labels = [pair_label(label) for label, _ in rows]
    label_in = max(text_width_in(l, FONT_PT - 1) for l in labels) + 0.15
    cols, _, legend_in = legend_layout(names, PAGE_IN - 0.2, handlelength=1.0)
    row_in = max(0.3, 0.055 * len(metrics) + 0.1)
    axes_in = row_in * len(rows)
    title_in, bottom_in = 0.25, 0.4
    height = legend_in + title_in + axes_in + bottom_in
    panel_w = (PAGE_IN - label_in - 0.15 * len(questions)) / len(questions)
    fig = plt.figure(figsize=(PAGE_IN, height))
    for k, rec in enumerate(questions):
        x0 = label_in + k * (panel_w + 0.15)
        ax = fig.add_axes([x0 / PAGE_IN, bottom_in / height, (panel_w - 0.05) / PAGE_IN,
                           axes_in / height])
        draw_panel(ax, rows, rec.name, metrics)
        ax.set_yticks(range(len(rows)))
        ax.set_yticklabels(labels if k == 0 else [""] * len(rows))
        ax.set_title(wrap_to_width(f"{rec.name}: {rec.split} lightings", panel_w - 0.1,
                                   FONT_PT), fontsize=FONT_PT, pad=3)
        ax.set_xlabel("error ratio fit / baseline (log)")
    handles = [plt.Line2D([], [], marker=MARKERS[j % len(MARKERS)], linestyle="",
                          color=METRIC_COLOURS[j % len(METRIC_COLOURS)]) for j in range(len(names))]
    fig.legend(handles, names, loc="upper center", ncol=cols, frameon=False,
               bbox_to_anchor=(0.5, 1.0), handlelength=1.0)
    save_figure(fig, fig_dir, "findings-forest", manifest,
                "Findings: each compared pair's error ratio (fit / baseline; < 1: the fit is "
                "closer) under every metric of the judging set, with its bootstrap 95% CI over "
                "materials" + (" (over lightings for a question of fewer than "
                               f"{answer_rules.MIN_MATERIALS_FOR_PAIRED_TEST} materials)"
                               if any(r.unit == "lighting" for r in questions) else "")
                + "; one panel per image question",
                {"kind": "forest"})


def pair_label(label):
    """'ggx@key vs\nblinn-phong@key', each side wrapped at 2 in."""
    fit, base = label.split(" vs ", 1)
    return (wrap_to_width(fit, 2.0, FONT_PT - 1) + " vs\n"
            + wrap_to_width(base, 2.0, FONT_PT - 1))



def log_ticks(lo, hi):
    """Ticks of a log axis over [lo, hi] that do not crowd a panel a third of a page wide: 1, 2, 3
    and 5 per decade over about a decade, 1, 2 and 5 over two, then powers of ten only, every
    n-th one so that at most six are labelled (10^0 always among them)."""
    decades = math.log10(hi / lo)
    ks = (1, 2, 3, 5) if decades <= 1.2 else (1, 2, 5) if decades <= 2.0 else (1,)
    step = max(1, math.ceil(decades / 6)) if ks == (1,) else 1
    e0, e1 = math.floor(math.log10(lo)), math.ceil(math.log10(hi))
    return [k * 10.0 ** e for e in range(e0, e1 + 1) if e % step == 0 for k in ks
            if lo <= k * 10.0 ** e <= hi]

def draw_panel(ax, rows, question, metrics):
    m = len(metrics)
    lows, highs = [], []
    for i, (_, by_q) in enumerate(rows):
        for metric, r, lo, hi in by_q.get(question, []):
            j = metrics.index(metric)
            y = i + (j - (m - 1) / 2) * (0.8 / max(m, 1))
            colour = METRIC_COLOURS[j % len(METRIC_COLOURS)]
            if lo is not None:
                ax.plot([lo, hi], [y, y], color=colour, linewidth=0.8)
                lows.append(lo)
                highs.append(hi)
            ax.plot([r], [y], marker=MARKERS[j % len(MARKERS)], color=colour, markersize=3,
                    linestyle="")
            lows.append(r)
            highs.append(r)
    ax.axvline(1.0, color="#555555", linewidth=0.6)
    ax.set_xscale("log")
    lo, hi = (min(lows + [1.0]), max(highs + [1.0])) if lows else (0.5, 2.0)
    pad = (math.log(hi) - math.log(lo)) * 0.08 + 0.02
    lo, hi = math.exp(math.log(lo) - pad), math.exp(math.log(hi) + pad)
    ax.set_xlim(lo, hi)
    # Plain numbers (0.5, 1, 2), no minor labels, as many per decade as the range leaves room for.
    ax.xaxis.set_major_locator(FixedLocator(log_ticks(lo, hi)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_ylim(len(rows) - 0.5, -0.5)
    for i in range(1, len(rows)):
        ax.axhline(i - 0.5, color="#dddddd", linewidth=0.4)
