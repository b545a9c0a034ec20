"""The report's tables as (columns, rows of strings): metrics, fitted parameters, probe numbers,
the verdicts (report_verdicts' records) and the encoding search. report_latex writes them out."""

import dataclasses

from report_util import flatten, fmt, labels_of, materials_of, probe_numbers, to_float

METRIC_COLUMNS = [
    ("rmse", "RMSE", "{:.4g}"),
    ("relative_rmse", "rel. RMSE", "{:.3f}"),
    ("psnr", "PSNR [dB]", "{:.2f}"),
    ("ssim", "SSIM", "{:.4f}"),
    ("ciede2000_mean", "$\\Delta E_{00}$", "{:.3f}"),
    ("flip_ldr_mean", "LDR-FLIP", "{:.4f}"),
    ("flip_hdr_mean", "HDR-FLIP", "{:.4f}"),
    ("delta_e_itp_mean", "$\\Delta E_{ITP}$", "{:.3f}"),
]


def metrics_table(study, rows):
    cols = ["material", "lighting", "fit", "split"] + [c[1] for c in METRIC_COLUMNS] + ["converged"]
    out = []
    for r in rows:
        out.append([r["material"], r["lighting"], r["label"], r["split"]]
                   + [fmt(to_float(r.get(k)), f) for k, _, f in METRIC_COLUMNS]
                   + ["yes" if r["converged"] == "1" else "NO"])
    return cols, out


def parameters_table(study, fits):
    cols = ["material", "fit", "parameter", "value", "std. error", "note"]
    out = []
    for m in materials_of(study):
        for label in labels_of(study):
            job = fits.get((m, label))
            if job is None:
                continue
            for p in job["parameters"]:
                note = []
                if p["fixed"]:
                    why = p.get("fixed_by")  # optional (report_inputs.FIT_JOB)
                    note.append(f"fixed ({why})" if why else "fixed")
                if p["at_bound"]:
                    note.append("at bound")
                if p["undetermined"]:
                    note.append("undetermined")
                out.append([m, label, p["name"], fmt(to_float(p["value"])),
                            fmt(to_float(p["std_error"]), "{:.2g}"), ", ".join(note)])
            # A failed fit has no exposure and no termination (report_inputs.FIT_JOB).
            out.append([m, label, "exposure", fmt(job.get("exposure")), "",
                        "converged" if job["converged"]
                        else "NOT CONVERGED: " + (job.get("termination") or "")])
    return cols, out


def probes_table(study, probes):
    labels = labels_of(study)
    cols = ["material", "probe", "quantity", "reference"] + labels
    out = []
    for m in materials_of(study):
        for probe in study["probes"]:
            numbers = probe_numbers(probes, m, probe)
            if not numbers:
                continue
            ref = flatten(numbers.get("reference") or numbers.get("truth")
                          or numbers.get("measured") or {})
            per = {l: flatten(numbers.get(l, {})) for l in labels}
            keys = list(ref.keys())
            for l in labels:
                keys += [k for k in per[l] if k not in keys]
            for k in keys:
                out.append([m, probe, k, fmt(ref.get(k))] + [fmt(per[l].get(k)) for l in labels])
    return cols, out


def encoding_table(fits):
    cols = ["material", "fit", "encoding", "gamma", "stored RMSE x255", "chosen"]
    rows = []
    for (material, label), job in sorted(fits.items()):
        e = job.get("encoding")
        if not isinstance(e, dict):
            continue
        for c in e["candidates"]:
            rows.append([material, label, c["name"], fmt(c["gamma"]), fmt(255 * c["stored_rmse"]),
                         "yes" if c["chosen"] else ""])
    return cols, rows


def yes_no(ok):
    return "n/a" if ok is None else ("yes" if ok else "no")


def verdict_tables(study, summary, detail):
    """(verdicts, verdict details, matrix) tables from report_verdicts.compute_verdicts' records:
    the worst quantity per phenomenon, material and fit; every quantity; and per phenomenon
    and fit, the materials reproduced of those judged."""
    cols = ["phenomenon", "material", "fit", "quantity (worst)", "reference", "model",
            "error", "tolerance", "reproduced"]
    rows = []
    for s in summary:
        err_name = {"relative": "rel.", "absolute": "abs.", "max": "value"}[s.kind]
        rows.append([s.phenomenon, s.material, s.fit, s.quantity, fmt(s.reference),
                     fmt(s.model), fmt(s.error, "{:.3g}"), f"{err_name} <= {s.tolerance:g}",
                     yes_no(s.reproduced)])
    dcols = ["phenomenon", "material", "fit", "quantity", "reference", "model", "error",
             "tolerance", "reproduced"]
    drows = [[d.phenomenon, d.material, d.fit, d.quantity, fmt(d.reference), fmt(d.model),
              fmt(d.error, "{:.3g}"), f"{d.kind} {d.tolerance:g}", yes_no(d.reproduced)]
             for d in detail]
    # The matrix: phenomenon x fit -> materials reproduced / materials judged.
    labels = labels_of(study)
    mcols = ["phenomenon", "question"] + labels
    mrows = []
    for name, v in study["verdicts"].items():
        row = [name, v["question"]]
        for label in labels:
            judged = [s for s in summary if s.phenomenon == name and s.fit == label
                      and s.reproduced is not None]
            good = sum(1 for s in judged if s.reproduced)
            row.append(f"{good}/{len(judged)}" if judged else "n/a")
        mrows.append(row)
    return (cols, rows), (dcols, drows), (mcols, mrows)


# ------------------------------------------------------------------------------------------------
# Against Ngan, Durand and Matusik 2005 (report_ngan.ngan_comparison's NganComparison)


def ngan_table(ngan):
    """Our number next to Ngan's, per material and fit."""
    return (["material", "fit", "ours", "value", "Ngan 2005", "Ngan's value"],
            [[r.material, r.fit, r.ours_label, fmt(r.ours), r.ngan_label, fmt(r.theirs)]
             for r in ngan.rows])


def spearman_table(ngan):
    cols = ["fit", "our parameter", "Ngan 2005", "materials", "Spearman rho"]
    rows = [[c.fit, c.ours, c.ngan, str(c.materials),
             fmt(c.spearman, "{:.3f}") if c.spearman is not None else "n/a"]
            for c in ngan.correlations]
    return cols, rows


def ngan_json(ngan):
    """ngan2005.json's record: the source, the table's rows, the correlations."""
    return {"source": ngan.source, "rows": ngan_table(ngan)[1],
            "correlations": [dataclasses.asdict(c) for c in ngan.correlations]}
