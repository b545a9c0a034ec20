#!/usr/bin/python3
"""Metrics worth their name: variants of the human-agreement check (issue 34, item 3;
docs/metrics.md "Human agreement", "Variants").

Reads the renders that bench/human_agreement.py cached (run it first; nothing is rendered here),
computes shadefit's metrics in-process (`shadefit.metrics` on numpy arrays) on transformed images
and pools its per-pixel error maps in other ways, fits combinations of metrics on some materials
and judges them on the others, and reports every variant with the statistics of
bench/human_agreement.py (Spearman rho with a material-resampling bootstrap 95% CI, exact-order
fraction and mean Kendall tau within materials):

  a. *Display encodings*, the images as a viewer saw them rather than linear radiance: the same
     transform on reference and test, its parameters taken from the reference (per material, as
     an exposure would be set), then every metric that is meaningful on the result:
     "exposed, clipped" (exposure putting the 99th percentile of the reference's luminance on
     the sphere at 1, clipped, sRGB-encoded by the display metrics), "Reinhard" (Reinhard et al.
     2002's global operator, key 0.18, white = the reference's brightest pixel), "filmic"
     (Narkowicz 2015's ACES fit on the same exposure) and "PQ" (SMPTE ST 2084 codes of absolute
     luminance, linear 1.0 = 100 cd/m^2; RMSE and MAE on the codes, PSNR / SSIM / MS-SSIM with the
     codes as the display values).
  b. *Pooling* of the error maps of `shadefit.metrics(maps=True)` (absolute and relative error,
     1 - SSIM, CIEDE2000, dE_ITP, LDR- and HDR-FLIP) on the sphere, from the linear images and
     from the exposed, clipped ones: Minkowski means (p = 2, 4), percentiles (50, 90, 99), and
     weighted means that give half the weight to the highlight (the reference's brightest 5 % of
     sphere pixels), half to the rim (n.v < 0.35, n.v from the pixel's distance to the sphere's
     centre, orthographic approximation), or a third each to highlight, rim and the rest.
  c. *Combinations* fitted on part of the materials and reported on held-out materials ONLY:
     non-negative least squares (scipy.optimize.nnls) of the human distance on centred features,
     the features rank-normalised against the training pairs, or z-scored logs, from a small set
     (the five headline metrics of results.csv) or from every variant above; the same on z-scored
     logs centred per material (fits only the order within materials, which no single metric
     gets right); and "select the best single variant on the training materials", the honest
     version of picking the best row of the table. Splits are by material (a material's three
     pairs share a reference): leave one material out (the 57 held-out predictions, each from a
     fit that never saw its material, are then scored like a metric; they come from 19 fits, so
     their rho across materials also asks that the fits agree in scale), and repeated random
     splits (13 training / 6 held-out materials; median and 2.5-97.5 % range over splits).
     The ten best single variants and every combination are compared with relative RMSE by a
     paired bootstrap of the difference in rho (the same resampled materials for both).

    /usr/bin/python3 bench/human_agreement_variants.py [--renders out/human_agreement]
        [--out out/human_agreement_variants] [--shared ../shared] [--samples 1024]
        [--resamples 2000] [--splits 200] [--seed 34]

--renders is bench/human_agreement.py's --out folder and --samples its reference samples (they
name the cached files). Writes OUT/human_agreement_variants.{md,json}. `import shadefit` needs the
built module (docs/python.md); without the .pth the script adds ROOT/build/python to the path.
"""
import argparse
import math
import pathlib
import sys
import time

import numpy as np
import scipy.optimize
import scipy.stats

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
import human_agreement as ha  # noqa: E402  (the pairs, the renders' names and the statistics)

ROOT = pathlib.Path(__file__).resolve().parent.parent
LUMINANCE = np.array([0.2126, 0.7152, 0.0722])  # Rec. 709 Y, as docs/metrics.md "Conventions".
ITP_WHITE = 100.0  # cd/m^2 of linear 1.0, shadefit's dE_ITP default (docs/metrics.md).

# ----------------------------------------------------------------------------- a. encodings


def pq_encode(luminance):
    """SMPTE ST 2084 inverse EOTF: absolute cd/m^2 -> code values in [0, 1]."""
    m1, m2 = 2610 / 16384, 2523 / 4096 * 128
    c1, c2, c3 = 3424 / 4096, 2413 / 4096 * 32, 2392 / 4096 * 32
    y = np.clip(luminance / 10000.0, 0.0, 1.0) ** m1
    return ((c1 + c2 * y) / (1 + c3 * y)) ** m2


def srgb_decode(code):
    """IEC 61966-2-1 EOTF, the inverse of the display transform's OETF: passing srgb_decode(v)
    at exposure 0 makes PSNR, SSIM and MS-SSIM see exactly v."""
    return np.where(code <= 0.04045, code / 12.92, ((code + 0.055) / 1.055) ** 2.4)


def luminance(rgb):
    return rgb[..., :3] @ LUMINANCE


def exposed(rgb, ref, on):
    """Exposure that puts the 99th percentile of the reference's luminance on the sphere at 1
    (bench/human_agreement.py's auto exposure), then clipped: an sRGB display's image."""
    return np.clip(rgb / max(np.percentile(luminance(ref)[on], 99), 1e-6), 0.0, 1.0)


def reinhard(rgb, ref, on):
    """Reinhard, Stark, Shirley, Ferwerda 2002, "Photographic Tone Reproduction for Digital
    Images": Eq. 1 (log-average luminance of the reference's sphere, delta 1e-4), Eq. 2 (key
    a = 0.18), Eq. 4 (L_white = the reference's brightest scaled luminance); RGB scaled by
    L_d / L_w per pixel, so hue is kept."""
    y_ref = luminance(ref)[on]
    scale = 0.18 / math.exp(np.mean(np.log(1e-4 + y_ref)))
    white = max(scale * y_ref.max(), 1e-6)
    y = luminance(rgb)
    lum = scale * y
    display = lum * (1 + lum / white ** 2) / (1 + lum)
    ratio = np.divide(display, y, out=np.zeros_like(y), where=y > 0)
    return np.clip(rgb[..., :3] * ratio[..., None], 0.0, 1.0)


def filmic(rgb, ref, on):
    """Narkowicz 2015, "ACES Filmic Tone Mapping Curve" (the rational fit, per channel), after
    the exposure of exposed(): highlights roll off instead of clipping."""
    x = rgb[..., :3] / max(np.percentile(luminance(ref)[on], 99), 1e-6)
    return np.clip(x * (2.51 * x + 0.03) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0)


def pq_codes(rgb, ref, on):
    """PQ code values per channel of absolute luminance (linear 1.0 = ITP_WHITE cd/m^2)."""
    return pq_encode(np.maximum(rgb[..., :3], 0.0) * ITP_WHITE)


# name -> (transform to display-linear RGB, metrics that mean something on it). The display
# transform of shadefit.metrics is clip(OETF_sRGB(x)) at exposure 0, so a display-linear image in
# [0, 1] is shown by PSNR / SSIM / MS-SSIM exactly as an sRGB display shows it, and CIEDE2000,
# LDR-FLIP and dE_ITP (100 cd/m^2 white) see the light the display emits. HDR-FLIP is left out:
# it would re-expose an image that is already tone-mapped.
DISPLAYED = ("RMSE", "relative RMSE", "log RMSE", "MAE", "PSNR", "SSIM luminance", "SSIM RGB",
             "MS-SSIM", "CIEDE2000 mean", "CIEDE2000 p95", "dE_ITP mean", "dE_ITP p95",
             "LDR-FLIP mean", "LDR-FLIP p95")
ENCODINGS = {
    "exposed, clipped": (exposed, DISPLAYED),
    "Reinhard": (reinhard, DISPLAYED),
    "filmic": (filmic, DISPLAYED),
}
# PQ codes are a perceptual encoding, not a display image: RMSE and MAE on the codes, and the
# windowed metrics with the codes as display values (through srgb_decode).
PQ_ON_CODES = ("RMSE", "MAE")
PQ_AS_DISPLAY = ("PSNR", "SSIM luminance", "SSIM RGB", "MS-SSIM")

# ----------------------------------------------------------------------------- b. pooling

HIGHLIGHT_FRACTION = 0.05  # The reference's brightest 5 % of sphere pixels.
RIM_NOV = 0.35  # n.v below this (the outer ~12 % of the disc's area) is the rim.
# Error maps of shadefit.metrics(maps=True), each oriented so that larger is worse.
MAPS = {"absolute error": ("absolute_error", False), "relative error": ("relative_error", False),
        "1 - SSIM": ("ssim", True), "CIEDE2000": ("ciede2000", False),
        "dE_ITP": ("delta_e_itp", False), "LDR-FLIP": ("flip_ldr", False),
        "HDR-FLIP": ("flip_hdr", False)}


def sphere_regions(ref, on):
    """(highlight, rim) boolean images: the reference's brightest pixels on the sphere, and the
    pixels near the silhouette. n.v = sqrt(1 - (r / R)^2) with r the distance to the mask's
    centroid and R = sqrt(area / pi) (orthographic; the camera at 6 radii sees the limb within
    sin^-1(1/6) of it)."""
    y = luminance(ref)
    highlight = on & (y >= np.quantile(y[on], 1.0 - HIGHLIGHT_FRACTION))
    rows, cols = np.nonzero(on)
    r = np.hypot(*np.indices(on.shape) - np.array([rows.mean(), cols.mean()])[:, None, None])
    nov = np.sqrt(np.clip(1.0 - (r / math.sqrt(on.sum() / math.pi)) ** 2, 0.0, 1.0))
    return highlight, on & (nov < RIM_NOV)


def region_weights(on, parts):
    """Weights over the sphere giving each region of parts (disjoint after earlier parts take
    their pixels) and the remaining sphere an equal share."""
    w = np.zeros(on.shape)
    left = on.copy()
    regions = []
    for part in parts:
        regions.append(part & left)
        left &= ~part
    regions.append(left)
    regions = [r for r in regions if r.any()]
    for r in regions:
        w[r] = 1.0 / (len(regions) * r.sum())
    return w


def pool(error, on, highlight, rim):
    """{pooling name: value} of one error map over the sphere."""
    e = np.nan_to_num(error, nan=0.0)
    v = e[on]
    return {
        "Minkowski p=2": float(np.mean(v ** 2) ** 0.5),
        "Minkowski p=4": float(np.mean(v ** 4) ** 0.25),
        "p50": float(np.percentile(v, 50)),
        "p90": float(np.percentile(v, 90)),
        "p99": float(np.percentile(v, 99)),
        "highlight-weighted": float(np.sum(region_weights(on, [highlight]) * e)),
        "rim-weighted": float(np.sum(region_weights(on, [rim]) * e)),
        "highlight+rim-weighted": float(np.sum(region_weights(on, [highlight, rim]) * e)),
    }


# ----------------------------------------------------------------------------- the features


def distance(label, value):
    """A metric's value as a non-negative distance (larger = worse), for the log features:
    1 - SSIM for the SSIM family, the display MSE 10^(-PSNR/10) for PSNR."""
    if "SSIM" in label:
        return 1.0 - value
    if "PSNR" in label:
        return 10.0 ** (-value / 10.0) if math.isfinite(value) else 0.0
    return value


def compute_features(rows, images):
    """(names, matrix pairs x features of distances, larger = worse) for every variant."""
    import shadefit  # Only here: the statistics and the test need no build.

    columns = {}

    def add(name, i, value):
        columns.setdefault(name, np.full(len(rows), np.nan))[i] = value

    def add_report(report, labels, suffix, i):
        for label, path, _ in ha.METRICS:
            if label in labels:
                add(f"{label} ({suffix})", i, distance(label, ha.metric_value(report, path)))

    for i, row in enumerate(rows):
        ref, test = images[(row["material"], row["approximation"])]
        on = ref[..., 3] > 0.5
        mask = on.astype(np.float32)
        highlight, rim = sphere_regions(ref, on)
        # The plain metrics, as results.csv has them (for the combination), and the linear
        # masked call whose maps are pooled.
        plain = shadefit.metrics(ref, test)
        add_report(plain, [m[0] for m in ha.METRICS], "plain", i)
        linear = shadefit.metrics(ref, test, mask, maps=True)
        add_report(linear, [m[0] for m in ha.METRICS], "masked", i)
        for name, (key, similarity) in MAPS.items():
            error = 1.0 - linear["maps"][key] if similarity else linear["maps"][key]
            for pooling, value in pool(error, on, highlight, rim).items():
                add(f"{name} {pooling} (linear)", i, value)
        for encoding, (transform, labels) in ENCODINGS.items():
            r = transform(ref.astype(np.float64), ref, on).astype(np.float32)
            t = transform(test.astype(np.float64), ref, on).astype(np.float32)
            shown = shadefit.metrics(r, t, mask, maps=encoding == "exposed, clipped")
            add_report(shown, labels, encoding, i)
            if "maps" in shown:
                for name, (key, similarity) in MAPS.items():
                    if name == "HDR-FLIP":
                        continue
                    error = 1.0 - shown["maps"][key] if similarity else shown["maps"][key]
                    for pooling, value in pool(error, on, highlight, rim).items():
                        add(f"{name} {pooling} ({encoding})", i, value)
        r, t = pq_codes(ref, ref, on), pq_codes(test, ref, on)
        add_report(shadefit.metrics(r.astype(np.float32), t.astype(np.float32), mask),
                   PQ_ON_CODES, "PQ codes", i)
        add_report(shadefit.metrics(srgb_decode(r).astype(np.float32),
                                    srgb_decode(t).astype(np.float32), mask),
                   PQ_AS_DISPLAY, "PQ codes", i)
    names = list(columns)
    return names, np.column_stack([columns[n] for n in names])


# ----------------------------------------------------------------------------- c. combinations


WITHIN = ", within material"  # Suffix of a fit_combination mode: fit within-material order.


def rank_transform(train, values):
    """Values placed on the training values' ranks scaled to [0, 1] (linear between them, and
    extended linearly beyond the range so held-out extremes keep their order)."""
    s = np.sort(train)
    q = np.linspace(0.0, 1.0, len(s))
    span = max(s[-1] - s[0], 1e-300)
    out = np.interp(values, s, q)
    out = np.where(values > s[-1], 1.0 + (values - s[-1]) / span, out)
    return np.where(values < s[0], (values - s[0]) / span, out)


def normalise(mode, train, test):
    """Features of the training and test pairs, normalised with the training pairs only."""
    if mode == "rank":
        return (np.column_stack([rank_transform(train[:, k], train[:, k])
                                 for k in range(train.shape[1])]),
                np.column_stack([rank_transform(train[:, k], test[:, k])
                                 for k in range(train.shape[1])]))
    if mode == "log":
        train, test = np.log(np.maximum(train, 1e-9)), np.log(np.maximum(test, 1e-9))
    elif mode != "linear":
        raise ValueError(f"unknown normalisation {mode!r}")
    mean, std = train.mean(axis=0), train.std(axis=0)
    std[std == 0] = 1.0
    return (train - mean) / std, (test - mean) / std


def fit_combination(features, human, mode, groups=None):
    """Non-negative weights and a predictor: least squares of the centred human distance (its
    ranks in rank mode) on centred normalised features, weights >= 0 because every feature is
    oriented so that larger is worse. A mode ending in WITHIN centres features and target per
    material (groups) instead, so that the fit explains only the order within materials, the
    part no single metric gets right. Returns (weights, predict(test_features))."""
    within = mode.endswith(WITHIN)
    base = mode[:-len(WITHIN)] if within else mode
    target = rank_transform(human, human) if base == "rank" else human
    x, _ = normalise(base, features, features)
    if within:
        target = target.copy()
        for g in np.unique(groups):
            x[groups == g] -= x[groups == g].mean(axis=0)
            target[groups == g] -= target[groups == g].mean()
    centre = x.mean(axis=0)
    weights, _ = scipy.optimize.nnls(x - centre, target - target.mean())

    def predict(test):
        return (normalise(base, features, test)[1] - centre) @ weights + target.mean()

    return weights, predict


def select_best(features, human, mode, groups=None):
    """The 'best of many' rule: the single feature with the highest Spearman rho on the
    training pairs (mode unused; the same signature as fit_combination). It predicts the
    feature's rank among the training pairs, so that folds that pick different metrics give
    predictions on one scale."""
    rho = [scipy.stats.spearmanr(features[:, k], human).correlation
           for k in range(features.shape[1])]
    best = int(np.nanargmax(rho))
    weights = np.zeros(features.shape[1])
    weights[best] = 1.0
    return weights, lambda test: rank_transform(features[:, best], test[:, best])


def held_out_predictions(features, human, groups, fit, mode):
    """Leave one material out: each material's pairs predicted by a fit on the other
    materials only. Returns (predictions, weights per fold)."""
    prediction = np.empty(len(human))
    weights = []
    for g in np.unique(groups):
        test = groups == g
        w, predict = fit(features[~test], human[~test], mode, groups[~test])
        prediction[test] = predict(features[test])
        weights.append(w)
    return prediction, np.array(weights)


def repeated_splits(features, human, groups, fit, mode, splits, test_materials, seed):
    """Random material-level splits: per split the held-out Spearman rho and mean
    within-material tau of a fit on the other materials. Returns arrays (rho, tau)."""
    rng = np.random.default_rng(seed)
    names = np.unique(groups)
    rhos, taus = [], []
    for _ in range(splits):
        test = np.isin(groups, rng.choice(names, test_materials, replace=False))
        _, predict = fit(features[~test], human[~test], mode, groups[~test])
        p = predict(features[test])
        rhos.append(scipy.stats.spearmanr(p, human[test]).correlation)
        taus.append(ha.within_material(p, human[test], groups[test])[1])
    return np.array(rhos), np.array(taus)


def rho_difference_ci(metric, baseline, human, groups, resamples=2000, seed=34):
    """rho(metric) - rho(baseline) with the human distance and a percentile bootstrap 95% CI
    that resamples materials once for both (paired: the same resampled pairs for both), as
    ha.spearman_with_ci resamples them for one."""
    def rho(x, idx):
        return scipy.stats.spearmanr(x[idx], human[idx]).correlation

    names = np.unique(groups)
    members = [np.flatnonzero(groups == g) for g in names]
    everything = np.arange(len(human))
    rng = np.random.default_rng(seed)
    diffs = []
    for _ in range(resamples):
        idx = np.concatenate([members[k] for k in rng.integers(0, len(names), len(names))])
        diffs.append(rho(metric, idx) - rho(baseline, idx))
    lo, hi = np.nanpercentile(diffs, [2.5, 97.5])
    return float(rho(metric, everything) - rho(baseline, everything)), float(lo), float(hi)


# ----------------------------------------------------------------------------- main

# What a variant must beat: the best of the plain metrics (tied with MS-SSIM at 0.62).
BASELINE = "relative RMSE (plain)"
# The five headline metrics of results.csv, as `shadefit metrics` gives them (no mask).
HEADLINE = ("relative RMSE (plain)", "MS-SSIM (plain)", "CIEDE2000 mean (plain)",
            "dE_ITP mean (plain)", "HDR-FLIP mean (plain)")


def load_images(args, rows):
    """{(material, approximation): (reference, test)} float32 RGBA from the cached renders."""
    import shadefit

    renders = args.renders / "renders"
    images, missing = {}, []
    for row in rows:
        ref = renders / f"{row['material']}-nbrdf-{args.samples}spp.exr"
        test = renders / f"{row['material']}-{row['approximation'].lower()}.exr"
        missing += [str(p) for p in (ref, test) if not p.exists()]
        if not missing:
            images[(row["material"], row["approximation"])] = (shadefit.read_image(ref),
                                                                shadefit.read_image(test))
    if missing:
        raise SystemExit(f"{len(missing)} cached renders missing (first {missing[0]}); run "
                         f"/usr/bin/python3 bench/human_agreement.py --out {args.renders} first")
    return images


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--renders", type=pathlib.Path, default=ROOT / "out" / "human_agreement")
    ap.add_argument("--out", type=pathlib.Path, default=ROOT / "out" / "human_agreement_variants")
    ap.add_argument("--shared", type=pathlib.Path, default=ROOT.parent / "shared")
    ap.add_argument("--samples", type=int, default=1024, help="the references' samples")
    ap.add_argument("--resamples", type=int, default=2000, help="bootstrap resamples")
    ap.add_argument("--splits", type=int, default=200, help="repeated material-level splits")
    ap.add_argument("--test-materials", type=int, default=6, help="held out per split")
    ap.add_argument("--seed", type=int, default=34)
    args = ap.parse_args(argv)
    try:
        import shadefit  # noqa: F401
    except ImportError:
        sys.path.insert(0, str(ROOT / "build" / "python"))

    rows = ha.read_scores(args.shared / "brdf-data" / "lavoue2021-human-scores.tsv")
    human = np.array([r["human_distance"] for r in rows])
    groups = np.array([r["material"] for r in rows])
    kinds = np.array([r["approximation"] for r in rows])
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    images = load_images(args, rows)
    names, features = compute_features(rows, images)
    t1 = time.time()

    # Single variants: every column but the plain and masked calls, which bench/
    # human_agreement.py's table already lists.
    singles = [(n, features[:, k]) for k, n in enumerate(names)
               if not n.endswith(("(plain)", "(masked)"))]
    table = ha.agreement_table(singles, human, groups, kinds, args.resamples, args.seed)[:-3]

    # Combinations, held out by material.
    headline = np.array([names.index(n) for n in HEADLINE])
    candidates = {"headline 5": headline, "all variants": np.arange(len(names))}
    combos, splits, fold_weights = [], [], {}
    for set_name, columns in candidates.items():
        for label, fit, mode in (("NNLS on ranks", fit_combination, "rank"),
                                 ("NNLS on z-scored logs", fit_combination, "log"),
                                 ("NNLS on z-scored logs within materials", fit_combination,
                                  "log" + WITHIN),
                                 ("best single variant on the training materials", select_best,
                                  "linear")):
            name = f"held out: {label}, {set_name}"
            x = features[:, columns]
            prediction, weights = held_out_predictions(x, human, groups, fit, mode)
            combos.append((name, prediction))
            picked = (weights > 0).mean(axis=0)
            fold_weights[name] = {names[columns[k]]: round(float(picked[k]), 3)
                                  for k in np.argsort(-picked) if picked[k] > 0}
            rho, tau = repeated_splits(x, human, groups, fit, mode, args.splits,
                                       args.test_materials, args.seed)
            splits.append((name, rho, tau))
    combo_table = ha.agreement_table(combos, human, groups, kinds, args.resamples, args.seed)

    # Paired differences to relative RMSE as results.csv has it, for the ten best single
    # variants by rho and every combination.
    ranked = sorted(table, key=lambda r: -r[1])
    baseline = features[:, names.index(BASELINE)]
    values = dict(singles + combos)
    differences = [(r[0], *rho_difference_ci(values[r[0]], baseline, human, groups,
                                             args.resamples, args.seed))
                   for r in ranked[:10] + combo_table[:len(combos)]]
    t3 = time.time()
    difference_lines = [f"| variant | rho - rho({BASELINE}) [95% CI] |", "|---|---|"] + [
        f"| {n} | {d:+.2f} [{lo:+.2f}, {hi:+.2f}] |" for n, d, lo, hi in differences]
    split_lines = ["| combination | held-out rho, median [2.5 %, 97.5 %] | held-out tau, median "
                   "[2.5 %, 97.5 %] |", "|---|---|---|"]
    for name, rho, tau in splits:
        q = np.nanpercentile
        split_lines.append(f"| {name[len('held out: '):]} | {q(rho, 50):.2f} [{q(rho, 2.5):.2f}, "
                           f"{q(rho, 97.5):.2f}] | {q(tau, 50):.2f} [{q(tau, 2.5):.2f}, "
                           f"{q(tau, 97.5):.2f}] |")
    report = "\n".join([
        f"{len(rows)} pairs, {len(np.unique(groups))} materials; renders of {args.renders}; "
        f"{len(singles)} single variants, {len(combos)} held-out combinations",
        "", "Single variants (every one tried; the plain and masked metrics are in "
        "human_agreement.md):", "", ha.format_table(table), "",
        "Combinations, leave one material out (each material predicted by a fit on the other "
        "18; held-out predictions only):", "", ha.format_table(combo_table), "",
        f"Combinations, {args.splits} random splits ({len(np.unique(groups)) - args.test_materials}"
        f" training / {args.test_materials} held-out materials; statistics on held-out pairs):",
        "", "\n".join(split_lines), "",
        f"Paired bootstrap of the difference to {BASELINE} (same resampled materials for "
        "both):", "", "\n".join(difference_lines), "",
        "Variants given weight (fraction of the 19 leave-one-out folds):", "",
        "\n".join(f"- {n[len('held out: '):]}: " + ", ".join(
            f"{k} {v:.2f}" for k, v in list(picks.items())[:6]) for n, picks in
            fold_weights.items()), "",
        "best single variants by rho: " + "; ".join(f"{r[0]} {r[1]:.2f} [{r[2]:.2f}, {r[3]:.2f}] "
                                                    f"tau {r[5]:.2f}" for r in ranked[:5]),
        "best single variants by tau: " + "; ".join(
            f"{r[0]} {r[5]:.2f} (rho {r[1]:.2f})" for r in sorted(table, key=lambda r: -r[5])[:5]),
        "", f"time: metrics {t1 - t0:.0f} s, statistics {t3 - t1:.0f} s",
    ])
    print(report)
    (args.out / "human_agreement_variants.md").write_text(report + "\n")
    keys = ("metric", "rho", "ci_low", "ci_high", "exact_order", "mean_tau", "materials")
    (args.out / "human_agreement_variants.json").write_text(ha.json_text({
        "single_variants": [dict(zip(keys, r)) for r in table],
        "held_out_leave_one_material_out": [dict(zip(keys, r)) for r in combo_table],
        "held_out_repeated_splits": [
            {"combination": n, "rho_median": float(np.nanmedian(r)),
             "tau_median": float(np.nanmedian(t)), "rho": r.tolist(), "tau": t.tolist()}
            for n, r, t in splits],
        "difference_to_baseline": [dict(zip(("variant", "rho_difference", "ci_low", "ci_high"),
                                            d)) for d in differences],
        "fraction_of_folds_picking": fold_weights,
        "seconds": {"metrics": t1 - t0, "statistics": t3 - t1},
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
