#!/usr/bin/python3
"""Do shadefit's image metrics agree with people? (issue 34, docs/metrics.md "Human agreement")

For every (material, approximation) pair of ../shared/brdf-data/lavoue2021-human-scores.tsv
(Lavoue et al. 2021's human judgments of Ngan 2005's Blinn-Phong, Ward and Lafortune fits of MERL
materials): render the material's Neural-BRDF network (`shadefit refs measured`) and the
approximation (`shadefit render`, shadefit's own models) on a sphere under an environment map,
run `shadefit metrics REF TEST --json` in several variants, and report per metric

  * Spearman rho with the human distance over all pairs, with a bootstrap 95% CI that resamples
    materials (a material's three pairs share one reference, so they are not independent);
  * the fraction of materials whose three approximations the metric ranks in the humans' exact
    order (pairs the humans tied may go either way);
  * the mean Kendall tau (tau-b) within materials;

next to the baselines: chance (exact order 1/6, tau 0) and the "average order" (rank every
material's approximations by the approximation types' mean human distance, over all materials and
leaving the material out). Renders and metric JSON are cached in the output folder.

    /usr/bin/python3 bench/human_agreement.py [--shadefit build/studies/shadefit]
        [--shared ../shared] [--out out/human_agreement] [--materials a,b,...]
"""
import argparse
import json
import math
import pathlib
import subprocess
import sys
import time

import numpy as np
import scipy.stats

# The published albedos lack MERL's per-channel scale, which the networks carry (the TSV header).
COLOUR_SCALE = (1.0, 1.15, 1.66)
APPROXIMATIONS = ("BLINN-PHONG", "WARD", "LAFORTUNE")

# (label, JSON path, +1 if larger is worse, -1 if larger is better). Every number is oriented so
# that a larger "distance" means a worse approximation before it is correlated.
METRICS = (
    ("RMSE", ("linear", "rmse"), 1),
    ("relative RMSE", ("linear", "relative_rmse"), 1),
    ("log RMSE", ("linear", "log_rmse"), 1),
    ("MAE", ("linear", "mae"), 1),
    ("PSNR", ("display", "psnr_db"), -1),
    ("SSIM luminance", ("display", "ssim_luminance"), -1),
    ("SSIM RGB", ("display", "ssim_rgb", "mean"), -1),
    ("MS-SSIM", ("display", "ms_ssim", "value"), -1),
    ("CIEDE2000 mean", ("ciede2000", "mean"), 1),
    ("CIEDE2000 p95", ("ciede2000", "p95"), 1),
    ("dE_ITP mean", ("delta_e_itp", "mean"), 1),
    ("dE_ITP p95", ("delta_e_itp", "p95"), 1),
    ("LDR-FLIP mean", ("flip_ldr", "mean"), 1),
    ("LDR-FLIP p95", ("flip_ldr", "p95"), 1),
    ("HDR-FLIP mean", ("flip_hdr", "mean"), 1),
    ("HDR-FLIP p95", ("flip_hdr", "p95"), 1),
)

# Metrics that a variant changes: the mask moves every windowed metric and the pooled colour
# differences (a linear mean over the mask is the plain mean times a constant: same ranks); the
# exposure moves only the display-transform metrics (dE_ITP and HDR-FLIP ignore it).
DISPLAY = {"PSNR", "SSIM luminance", "SSIM RGB", "MS-SSIM", "CIEDE2000 mean", "CIEDE2000 p95",
           "LDR-FLIP mean", "LDR-FLIP p95"}
CHANGED_BY = {
    "plain": lambda label: True,
    "masked": lambda label: label not in {"RMSE", "relative RMSE", "log RMSE", "MAE"},
    "auto-exposure": lambda label: label in DISPLAY,
}

# Variants of the metric call: name -> (use the sphere mask, exposure rule). "auto" exposes each
# material so that the 99th percentile of its reference's luminance on the sphere is display
# white (a tone mapping like the one the participants' renders had); 0 is the default transform.
VARIANTS = {
    "plain": (False, "0"),
    "masked": (True, "0"),
    "auto-exposure": (False, "auto"),
}

SCENE = """# Unit sphere under {env} (Debian blender-data, CC0), for bench/human_agreement.py.
[camera]
type = "perspective"
position = [0.0, -6.0, 0.0]
look_at = [0.0, 0.0, 0.0]
up = [0.0, 0.0, 1.0]
fov_y = 22.0
resolution = [{res}, {res}]
supersample = 1

[[objects]]
type = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0

[[lights]]
type = "environment"
file = "{env}"
strength = 1.0
rotation_z = 0.0
samples = {gl_samples}

[background]
transparent = true
"""


# ----------------------------------------------------------------------------- the pairs


def read_scores(path):
    """Rows of the TSV as dicts; numbers as float (None where empty)."""
    lines = [l.rstrip("\n") for l in open(path) if l.strip() and not l.startswith("#")]
    header = lines[0].split("\t")
    rows = []
    for line in lines[1:]:
        cells = line.split("\t") + [""] * len(header)
        row = {}
        for key, cell in zip(header, cells):
            if key in ("material", "approximation"):
                row[key] = cell
            else:
                row[key] = float(cell) if cell.strip() else None
        rows.append(row)
    return rows


def colour(row, prefix):
    return [row[f"{prefix}_{c}"] * s for c, s in zip("rgb", COLOUR_SCALE)]


def model_arguments(row):
    """shadefit model and --set values for a row, and notes where a value had to be clamped to
    the model's parameter table (render/models/*.glsl)."""
    kd, ks = colour(row, "kd"), colour(row, "ks")
    notes = []
    kind = row["approximation"]
    if kind in ("BLINN-PHONG", "LAFORTUNE"):
        # Both are the Lafortune lobe ks (n + 2) / (2 pi) max(C . (wi, wo), 0)^n: "BLINN-PHONG"
        # (Lafortune and Willems' modified Phong) is C = (-1, 1); Ngan's Lafortune divides C by
        # max(|Cxy|, |Cz|), which lafortune.glsl's bounds |C| <= 1 take as they are.
        if kind == "BLINN-PHONG":
            cxy, cz = -1.0, 1.0
        else:
            m = max(abs(row["Cxy"]), abs(row["Cz"]))
            cxy, cz = row["Cxy"] / m, row["Cz"] / m
        n = row["sharpness"]
        if n > 1e5:
            notes.append(f"n {n:g} -> 1e5 (lafortune.glsl's maximum)")
            n = 1e5
        sets = {"kd": kd, "ks": ks, "cxy": cxy, "cz": cz, "n": n}
        return "lafortune", sets, notes
    if kind == "WARD":
        alpha = row["roughness"]
        if alpha < 0.01:
            notes.append(f"alpha {alpha:g} -> 0.01 (ward.glsl's minimum)")
            alpha = 0.01
        if max(ks) > 1.0:
            notes.append(f"ks {max(ks):g} -> 1 (ward.glsl's maximum)")
            ks = [min(k, 1.0) for k in ks]
        return "ward", {"kd": kd, "ks": ks, "alpha": alpha}, notes
    raise ValueError(f"unknown approximation {kind!r}")


# ----------------------------------------------------------------------------- rendering


def run(cmd):
    result = subprocess.run(cmd, capture_output=True, text=True)
    if result.returncode != 0:
        raise RuntimeError(f"{' '.join(map(str, cmd))}\n{result.stdout}{result.stderr}")
    return result.stdout


def set_value(v):
    return ",".join(f"{x:.9g}" for x in v) if isinstance(v, list) else f"{v:.9g}"


def read_exr(path):
    """An EXR's pixels as float64 (height, width, channels), rows top to bottom, from oiiotool's
    --dumpdata (nine decimals), cached as .npy beside it."""
    cache = path.with_suffix(".npy")
    if cache.exists() and cache.stat().st_mtime >= path.stat().st_mtime:
        return np.load(cache)
    lines = run(["oiiotool", "--dumpdata", str(path)]).splitlines()
    size = lines[0].split(":")[1].split(",")[0].split("x")
    width, height = int(size[0]), int(size[1])
    values = [line.split(":", 1)[1].split() for line in lines[1:] if "Pixel (" in line]
    image = np.array(values, dtype=np.float64).reshape(height, width, -1)
    np.save(cache, image)
    return image


def render_all(args, rows, out):
    renders = out / "renders"
    renders.mkdir(parents=True, exist_ok=True)
    scene = out / f"sphere-{args.resolution}.toml"
    text = SCENE.format(env=args.environment, res=args.resolution, gl_samples=args.gl_samples)
    if not scene.exists() or scene.read_text() != text:
        scene.write_text(text)
    timings = {"reference": [], "approximation": []}
    refs = {}
    for material in sorted({r["material"] for r in rows}):
        exr = renders / f"{material}-nbrdf-{args.samples}spp.exr"
        if not exr.exists():
            t = time.time()
            run([args.shadefit, "refs", "measured", "--brdf",
                 str(args.shared / "brdf-data" / "merl-nbrdf" / f"{material}.h5"),
                 "--scene", str(scene), "-o", str(exr), "--samples", str(args.samples)])
            timings["reference"].append(time.time() - t)
            print(f"  reference {material}: {timings['reference'][-1]:.1f} s", flush=True)
        refs[material] = exr
    tests = {}
    for row in rows:
        model, sets, notes = model_arguments(row)
        key = (row["material"], row["approximation"])
        exr = renders / f"{row['material']}-{row['approximation'].lower()}.exr"
        cmd = [args.shadefit, "render", "--scene", str(scene), "--model", model, "-o", str(exr),
               "--no-preview"]
        for name, value in sets.items():
            cmd += ["--set", f"{name}={set_value(value)}"]
        stamp = exr.with_suffix(".cmd")
        if not exr.exists() or not stamp.exists() or stamp.read_text() != " ".join(cmd[1:]):
            t = time.time()
            run(cmd)
            stamp.write_text(" ".join(cmd[1:]))
            timings["approximation"].append(time.time() - t)
        tests[key] = (exr, notes)
    return refs, tests, timings


def sphere_mask(ref_exr):
    mask = ref_exr.with_name(ref_exr.stem + "-mask.exr")
    if not mask.exists():
        run(["oiiotool", str(ref_exr), "--ch", "A", "-o", str(mask)])
    return mask


def auto_exposure(ref_exr):
    """Stops that put the 99th percentile of the reference's luminance on the sphere at 1."""
    image = read_exr(ref_exr)
    y = (image[..., :3] @ np.array([0.2126, 0.7152, 0.0722]))[image[..., 3] > 0.5]
    return float(-math.log2(max(np.percentile(y, 99), 1e-6)))


def compute_metrics(args, refs, tests, out):
    """{variant: {(material, approximation): metrics JSON}}; cached beside the renders."""
    results = {}
    exposure = {m: auto_exposure(exr) for m, exr in refs.items()}
    for variant, (masked, rule) in VARIANTS.items():
        results[variant] = {}
        for (material, kind), (exr, _) in tests.items():
            cache = out / "metrics" / variant / f"{material}-{kind.lower()}.json"
            cache.parent.mkdir(parents=True, exist_ok=True)
            e = exposure[material] if rule == "auto" else 0.0
            cmd = [args.shadefit, "metrics", str(refs[material]), str(exr), "--json",
                   "--exposure", f"{e:.6f}"]
            if masked:
                cmd += ["--mask", str(sphere_mask(refs[material]))]
            if cache.exists() and cache.stat().st_mtime >= exr.stat().st_mtime:
                results[variant][(material, kind)] = json.loads(cache.read_text())
                continue
            text = run(cmd)
            cache.write_text(text)
            results[variant][(material, kind)] = json.loads(text)
    return results, exposure


def metric_value(report, path):
    v = report
    for key in path:
        v = v[key]
    return float("inf") if v is None else float(v)  # PSNR null = identical images.


# ----------------------------------------------------------------------------- statistics


def exact_order(metric, human):
    """True when every pair the humans ordered is ordered the same way by the metric (pairs the
    humans tied may go either way; a metric tie where the humans differ is wrong)."""
    n = len(metric)
    for i in range(n):
        for j in range(i + 1, n):
            h = np.sign(human[i] - human[j])
            if h != 0 and np.sign(metric[i] - metric[j]) != h:
                return False
    return True


def within_material(metric, human, groups):
    """(fraction of groups in exact order, mean Kendall tau-b over groups, groups counted)."""
    exact, taus = [], []
    for g in np.unique(groups):
        sel = groups == g
        exact.append(exact_order(metric[sel], human[sel]))
        tau = scipy.stats.kendalltau(metric[sel], human[sel]).correlation
        if np.isfinite(tau):  # Undefined when a side is constant.
            taus.append(tau)
    return float(np.mean(exact)), float(np.mean(taus)) if taus else float("nan"), len(exact)


def spearman_with_ci(metric, human, groups, resamples=2000, seed=34):
    """Spearman rho over all pairs and a percentile bootstrap 95% CI from resampled groups."""
    rho = scipy.stats.spearmanr(metric, human).correlation
    names = np.unique(groups)
    members = [np.flatnonzero(groups == g) for g in names]

    def statistic(picked):
        idx = np.concatenate([members[int(k)] for k in picked])
        return scipy.stats.spearmanr(metric[idx], human[idx]).correlation

    ci = scipy.stats.bootstrap((np.arange(len(names)),), statistic, vectorized=False,
                               n_resamples=resamples, method="percentile",
                               random_state=np.random.default_rng(seed)).confidence_interval
    return float(rho), float(ci.low), float(ci.high)


def average_order(kinds, human, groups, leave_out):
    """The baseline predictor: each pair's value is its approximation type's mean human distance
    (over the other materials when leave_out)."""
    pred = np.empty(len(human))
    for i in range(len(human)):
        sel = kinds == kinds[i]
        if leave_out:
            sel &= groups != groups[i]
        pred[i] = human[sel].mean()
    return pred


def agreement_table(named_metrics, human, groups, kinds, resamples, seed):
    """Rows (name, rho, lo, hi, exact, tau, groups) for every metric and the baselines."""
    rows = []
    for name, values in named_metrics:
        rho, lo, hi = spearman_with_ci(values, human, groups, resamples, seed)
        exact, tau, n = within_material(values, human, groups)
        rows.append((name, rho, lo, hi, exact, tau, n))
    for label, leave_out in (("baseline: average order", False),
                             ("baseline: average order, material left out", True)):
        values = average_order(kinds, human, groups, leave_out)
        exact, tau, n = within_material(values, human, groups)
        rho, lo, hi = spearman_with_ci(values, human, groups, resamples, seed)
        rows.append((label, rho, lo, hi, exact, tau, n))
    rows.append(("baseline: chance", 0.0, float("nan"), float("nan"), 1.0 / 6.0, 0.0, 0))
    return rows


def format_table(rows):
    lines = ["| metric | Spearman rho [95% CI] | exact order | mean within-material tau |",
             "|---|---|---|---|"]
    for name, rho, lo, hi, exact, tau, n in rows:
        ci = f" [{lo:.2f}, {hi:.2f}]" if np.isfinite(lo) else ""
        count = f" ({round(exact * n)}/{n})" if n else ""
        lines.append(f"| {name} | {rho:.2f}{ci} | {exact:.2f}{count} | {tau:.2f} |")
    return "\n".join(lines)


# ----------------------------------------------------------------------------- sanity print


def sanity(refs, tests, materials):
    """Mean linear RGB on the sphere of the network and its approximations: a factor of pi or a
    colour-scale slip shows as a constant ratio."""
    lines = []
    for material in materials:
        if material not in refs:
            continue
        image = read_exr(refs[material])
        alpha = image[..., 3] > 0.5
        ref = image[..., :3][alpha].mean(axis=0)
        lines.append(f"  {material:<22} network       " + " ".join(f"{v:.4f}" for v in ref))
        for kind in APPROXIMATIONS:
            if (material, kind) not in tests:
                continue
            exr, notes = tests[(material, kind)]
            t = read_exr(exr)[..., :3][alpha].mean(axis=0)
            ratio = " ".join(f"{a / b:.2f}" for a, b in zip(t, ref))
            lines.append(f"  {'':<22} {kind.lower():<13} " + " ".join(f"{v:.4f}" for v in t) +
                         f"   / network {ratio}" + (f"   ({'; '.join(notes)})" if notes else ""))
    return "\n".join(lines)


# ----------------------------------------------------------------------------- main


def json_text(value):
    """JSON with every non-finite number as null (json.dumps writes NaN, which is not JSON, and
    never calls its default= for floats)."""
    def clean(v):
        if isinstance(v, dict):
            return {k: clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, (float, np.floating)):
            return float(v) if math.isfinite(v) else None
        return v
    return json.dumps(clean(value), indent=1)


def main(argv=None):
    root = pathlib.Path(__file__).resolve().parent.parent
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shadefit", default=str(root / "build" / "studies" / "shadefit"))
    ap.add_argument("--shared", type=pathlib.Path, default=root.parent / "shared")
    ap.add_argument("--out", type=pathlib.Path, default=root / "out" / "human_agreement")
    ap.add_argument("--environment",
                    default="/usr/share/blender/datafiles/studiolights/world/interior.exr")
    ap.add_argument("--resolution", type=int, default=128)
    ap.add_argument("--samples", type=int, default=1024, help="reference samples per technique")
    ap.add_argument("--gl-samples", type=int, default=1024, help="GL environment samples")
    ap.add_argument("--materials", default="", help="comma-separated subset (default: all)")
    ap.add_argument("--resamples", type=int, default=2000, help="bootstrap resamples")
    ap.add_argument("--seed", type=int, default=34)
    args = ap.parse_args(argv)

    tsv = args.shared / "brdf-data" / "lavoue2021-human-scores.tsv"
    rows = read_scores(tsv)
    if args.materials:
        keep = set(args.materials.split(","))
        rows = [r for r in rows if r["material"] in keep]
    materials = sorted({r["material"] for r in rows})
    print(f"{len(rows)} pairs, {len(materials)} materials; environment {args.environment}, "
          f"{args.resolution}^2, {args.samples} reference samples", flush=True)
    args.out.mkdir(parents=True, exist_ok=True)
    t0 = time.time()
    refs, tests, timings = render_all(args, rows, args.out)
    t1 = time.time()
    results, exposure = compute_metrics(args, refs, tests, args.out)
    t2 = time.time()

    human = np.array([r["human_distance"] for r in rows])
    groups = np.array([r["material"] for r in rows])
    kinds = np.array([r["approximation"] for r in rows])
    named = []
    for variant in VARIANTS:
        for label, path, sign in METRICS:
            if not CHANGED_BY[variant](label):
                continue
            values = np.array([sign * metric_value(results[variant][(r["material"],
                                                                     r["approximation"])], path)
                               for r in rows])
            named.append((label if variant == "plain" else f"{label} ({variant})", values))
    table = agreement_table(named, human, groups, kinds, args.resamples, args.seed)
    t3 = time.time()

    best_rho = max((r for r in table if not r[0].startswith("baseline")), key=lambda r: r[1])
    best_tau = max((r for r in table if not r[0].startswith("baseline")), key=lambda r: r[5])
    check = sanity(refs, tests, [m for m in ("blue-fabric", "teflon", "chrome") if m in refs])
    report = "\n".join([
        f"{len(rows)} pairs, {len(materials)} materials; {args.environment}; sphere "
        f"{args.resolution}^2; reference {args.samples} samples/technique, GL {args.gl_samples}",
        "", format_table(table), "",
        f"best Spearman: {best_rho[0]} {best_rho[1]:.2f}; best within-material tau: "
        f"{best_tau[0]} {best_tau[5]:.2f}", "",
        "sanity, mean linear RGB on the sphere:", check, "",
        f"time: renders {t1 - t0:.0f} s (references {sum(timings['reference']):.0f} s for "
        f"{len(timings['reference'])}, approximations {sum(timings['approximation']):.0f} s for "
        f"{len(timings['approximation'])}), metrics {t2 - t1:.0f} s, statistics {t3 - t2:.0f} s",
    ])
    print(report)
    (args.out / "human_agreement.md").write_text(report + "\n")
    (args.out / "human_agreement.json").write_text(json_text({
        "rows": [dict(zip(("metric", "rho", "ci_low", "ci_high", "exact_order", "mean_tau",
                           "materials"), r)) for r in table],
        "auto_exposure_stops": exposure,
    }))
    return 0


if __name__ == "__main__":
    sys.exit(main())
