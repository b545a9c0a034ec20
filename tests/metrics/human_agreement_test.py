#!/usr/bin/python3
"""bench/human_agreement.py: its statistics on synthetic scores with known answers, its mapping
of the published fits onto shadefit's models, and (when ../shared and the built shadefit exist)
the real check on two materials.

Usage: human_agreement_test.py SOURCE_DIR SHADEFIT OUTPUT_DIR. Exit 0 pass, 1 fail, 77 when the
real check cannot run (the statistics checks ran and passed first).
"""
import importlib.util
import itertools
import pathlib
import sys

import numpy as np
import scipy.stats

SOURCE, SHADEFIT, OUTPUT = (pathlib.Path(a) for a in sys.argv[1:4])
spec = importlib.util.spec_from_file_location("human_agreement",
                                              SOURCE / "bench" / "human_agreement.py")
ha = importlib.util.module_from_spec(spec)
spec.loader.exec_module(ha)

failures = []


def check(condition, what):
    print(("ok    " if condition else "FAIL  ") + what)
    if not condition:
        failures.append(what)


# ------------------------------------------------------------------ synthetic scores
rng = np.random.default_rng(7)
groups = np.repeat([f"m{i}" for i in range(12)], 3)
kinds = np.tile(["A", "B", "C"], 12)
human = rng.permutation(36) / 36.0 + 0.01  # Distinct: no ties.

for name, metric, rho, exact, tau in (("identity", human, 1.0, 1.0, 1.0),
                                      ("monotone 2x+5", 2 * human + 5, 1.0, 1.0, 1.0),
                                      ("reversed", -human, -1.0, 0.0, -1.0)):
    r, lo, hi = ha.spearman_with_ci(metric, human, groups, resamples=300)
    e, t, n = ha.within_material(metric, human, groups)
    check(abs(r - rho) < 1e-12 and abs(e - exact) < 1e-12 and abs(t - tau) < 1e-12 and n == 12,
          f"{name}: rho {r}, exact {e}, tau {t} (expected {rho}, {exact}, {tau})")
    check(abs(lo - rho) < 1e-12 and abs(hi - rho) < 1e-12, f"{name}: CI [{lo}, {hi}] is a point")

# A noisy metric against independent scipy calls and a brute-force exact-order count.
noisy = human + rng.normal(0.0, 0.2, 36)
r, lo, hi = ha.spearman_with_ci(noisy, human, groups, resamples=500)
check(abs(r - scipy.stats.spearmanr(noisy, human)[0]) < 1e-12, f"noisy: rho {r} is scipy's")
check(-1 <= lo < r < hi <= 1, f"noisy: CI [{lo:.3f}, {hi:.3f}] brackets rho {r:.3f}")
e, t, _ = ha.within_material(noisy, human, groups)
taus, exact = [], 0
for g in np.unique(groups):
    s = groups == g
    taus.append(scipy.stats.kendalltau(noisy[s], human[s])[0])
    exact += list(np.argsort(noisy[s])) == list(np.argsort(human[s]))
check(abs(t - np.mean(taus)) < 1e-12, f"noisy: mean tau {t} is scipy's per material")
check(abs(e - exact / 12) < 1e-12, f"noisy: exact order {e} = argsort count {exact}/12")

# Human ties: either order of the tied pair is exact; a metric tie where people differ is not.
check(ha.exact_order(np.array([1.0, 2.0, 3.0]), np.array([0.2, 0.2, 0.5])), "tie: 1 2 3 ok")
check(ha.exact_order(np.array([2.0, 1.0, 3.0]), np.array([0.2, 0.2, 0.5])), "tie: 2 1 3 ok")
check(not ha.exact_order(np.array([1.0, 1.0, 3.0]), np.array([0.1, 0.2, 0.5])),
      "metric tie where people differ is wrong")
# Chance: over all 6 orders of 3 distinct values, exactly one is right.
right = sum(ha.exact_order(np.array(p, dtype=float), np.array([1.0, 2.0, 3.0]))
            for p in itertools.permutations([1, 2, 3]))
check(right == 1, f"one of six orders is exact ({right})")

# Average order: when every material orders its approximations A < B < C, the baseline (and the
# left-out baseline) gets every material right.
ordered = np.tile([0.1, 0.2, 0.3], 12) + np.repeat(rng.uniform(0, 0.5, 12), 3)
for leave_out in (False, True):
    pred = ha.average_order(kinds, ordered, groups, leave_out)
    e, t, _ = ha.within_material(pred, ordered, groups)
    check(e == 1.0 and t == 1.0, f"average order (leave out {leave_out}): exact {e}, tau {t}")

# ------------------------------------------------------------------ the published fits
row = {"approximation": "LAFORTUNE", "kd_r": 0.1, "kd_g": 0.1, "kd_b": 0.1, "ks_r": 0.2,
       "ks_g": 0.2, "ks_b": 0.2, "sharpness": 630.0, "roughness": None, "Cxy": -0.579, "Cz": 0.5}
model, sets, notes = ha.model_arguments(row)
check(model == "lafortune" and abs(sets["cxy"] + 1.0) < 1e-12
      and abs(sets["cz"] - 0.5 / 0.579) < 1e-12, f"Lafortune C divided by max |C|: {sets}")
check(np.allclose(sets["kd"], [0.1, 0.115, 0.166]) and np.allclose(sets["ks"], [0.2, 0.23, 0.332]),
      "colour scale (1, 1.15, 1.66) on kd and ks")
row.update(approximation="BLINN-PHONG", sharpness=104000.0)
model, sets, notes = ha.model_arguments(row)
check(model == "lafortune" and sets["cxy"] == -1.0 and sets["cz"] == 1.0 and sets["n"] == 1e5
      and notes, f"modified Phong is Lafortune C = (-1, 1), n clamped with a note: {notes}")
row.update(approximation="WARD", roughness=0.0072)
model, sets, notes = ha.model_arguments(row)
check(model == "ward" and sets["alpha"] == 0.01 and notes, f"Ward alpha clamped: {notes}")

if failures:
    print(f"{len(failures)} check(s) failed")
    sys.exit(1)

# ------------------------------------------------------------------ the real check, small
tsv = SOURCE.parent / "shared" / "brdf-data" / "lavoue2021-human-scores.tsv"
if not tsv.exists() or not SHADEFIT.exists():
    print(f"SKIP the real check: needs {tsv} and {SHADEFIT}")
    sys.exit(77)
out = OUTPUT / "human_agreement"
ha.main(["--shadefit", str(SHADEFIT), "--shared", str(tsv.parent.parent), "--out", str(out),
         "--materials", "teflon,chrome", "--samples", "64", "--gl-samples", "256",
         "--resamples", "200"])
report = (out / "human_agreement.md").read_text()
for label, _, _ in ha.METRICS:
    check(f"| {label} |" in report, f"real check reports {label}")
# Sanity: teflon is near-diffuse; its fits must match the network's mean colour within a factor
# far from pi (a lost or doubled 1/pi), channel by channel within 1.3 of each other (a colour-
# scale slip moves blue by 1.66).
refs = {"teflon": out / "renders" / "teflon-nbrdf-64spp.exr"}
image = ha.read_exr(refs["teflon"])
alpha = image[..., 3] > 0.5
network = image[..., :3][alpha].mean(axis=0)
for kind in ha.APPROXIMATIONS:
    test = ha.read_exr(out / "renders" / f"teflon-{kind.lower()}.exr")[..., :3][alpha].mean(axis=0)
    ratio = test / network
    check(np.all((ratio > 0.5) & (ratio < 2.0)) and ratio.max() / ratio.min() < 1.3,
          f"teflon {kind}: approximation / network {np.round(ratio, 3)}")
sys.exit(1 if failures else 0)
