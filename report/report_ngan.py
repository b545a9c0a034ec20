"""Our fitted lobe parameters next to Ngan, Durand and Matusik 2005's BRDF-space fits (measured
studies whose references came from a folder with ngan2005-fits.tsv). Computes only: the table is
read with the other inputs (report_inputs.read_ngan_fits), the comparison is a record
(report_records.NganComparison) and its tables and JSON are report_tables'."""

from report_records import NganComparison, NganCorrelation, NganRow
from report_stats import spearman
from report_util import materials_of, to_float

# Our fitted quantity set against Ngan's: (our model, our parameter -> number, Ngan's column).
# GGX and Beckmann alpha = roughness^2 (models.md); Ngan's Cook-Torrance m is a Beckmann slope
# width; Blinn-Phong sharpness n is the exponent. Ranks compare across normalisations.
NGAN_PAIRS = [
    ("blinn-phong", "shininess", lambda v: v, "shininess n", "blinn_phong_n", "Blinn-Phong n"),
    ("blinn-phong-normalized", "shininess", lambda v: v, "shininess n", "blinn_phong_n",
     "Blinn-Phong n"),
    ("ggx", "roughness", lambda v: v * v, "alpha", "cook_torrance_m", "Cook-Torrance m"),
    ("beckmann", "roughness", lambda v: v * v, "alpha", "cook_torrance_m", "Cook-Torrance m"),
    # Ngan's own model set (render/models/): the same forms, parameter for parameter.
    ("cook-torrance", "m", lambda v: v, "m", "cook_torrance_m", "Cook-Torrance m"),
    ("ward", "alpha", lambda v: v, "alpha", "ward_alpha", "Ward alpha"),
    ("ward-duer", "alpha", lambda v: v, "alpha", "ward_alpha", "Ward alpha"),
    ("ashikhmin-shirley", "n", lambda v: v, "n", "ashikhmin_shirley_n", "Ashikhmin-Shirley n"),
    ("lafortune", "n", lambda v: v, "n", "lafortune_n", "Lafortune n")]


def ngan_comparison(study, fits, ngan):
    """NganComparison: per fit label with a counterpart in Ngan 2005, our number next to
    theirs per material, and Spearman's rho over the materials; None without Ngan's table
    (`ngan`: report_inputs.read_ngan_fits, or None)."""
    if ngan is None:
        return None
    rows, correlations = [], []
    for f in study["fits"]:
        for model, pname, to_num, ours_label, col, col_label in NGAN_PAIRS:
            if f["model"] != model:
                continue
            ours, theirs = [], []
            for m in materials_of(study):
                job = fits.get((m, f["label"]))
                if job is None or m not in ngan.fits:
                    continue
                value = next((to_float(p["value"]) for p in job["parameters"]
                              if p["name"] == pname), None)
                if value is None:
                    continue
                num = to_num(value)
                ours.append(num)
                theirs.append(ngan.fits[m][col])
                rows.append(NganRow(m, f["label"], ours_label, num, col_label,
                                    ngan.fits[m][col]))
            correlations.append(NganCorrelation(f["label"], model, ours_label, col, len(ours),
                                                spearman(ours, theirs)))
    return NganComparison(ngan.path, rows, correlations)
