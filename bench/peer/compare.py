#!/usr/bin/python3
"""Fits the same references with `shadefit fit` and the numpy/scipy peer, side by side.

For every reference, `--repeat` times, one after the other: `shadefit fit --ref X --model M
--no-images -o tmp.json` (one start, L2, fixed exposure: the defaults), the same with
`--max-iterations 1`, then
`bench/peer/peer_fit.py --ref X --model M` (which renders its G-buffer with `shadefit render
--aov` inside its own process). Prints one Markdown row per reference with medians over the
repeats:

  shadefit Fit() s   `solver.seconds` of the JSON: the whole Fit() call (G-buffer render, valid
                     pixels, coarse + full solve, covariance, input hashes), not the solve alone
  at 1 iteration s   `solver.seconds` of the same fit with `--max-iterations 1`: what Fit() spends
                     outside the iterations (G-buffer, pixels, covariance, hashes) plus ~2
                     iterations; "sf solve est." = Fit() s - this (slightly flatters shadefit)
  iterations         `solver.iterations` (coarse + polish iterations of the start), and the
                     residual / Jacobian evaluation counts from `evaluations`
  peer solve s       the least_squares call alone (analytic Jacobian)
  evals              least_squares nfev / njev
  rel. RMSE          RMSE / RMS(reference) over the valid pixels (the same pixels for both: the
                     script checks the pixel counts agree)
  cost peer/sf       ratio of the final costs (1 = same minimum)
  solve ratios       peer solve s / shadefit Fit() s, and / shadefit solve est. (> 1: shadefit
                     faster). Meaningless where the two end at different costs
  wall               whole-process wall time of each command, measured here; the peer's includes
                     Python start, imports, its `shadefit render` for the G-buffer and EXR reading
  wall ratio         peer wall / shadefit wall
  sf solve s         `solver.solve_seconds`: shadefit's solves alone, timed inside Fit() (every
                     start, coarse and polish; no G-buffer, covariance or hashes); absent ("-")
                     from binaries before it existed
  peer / sf solve    peer solve s / sf solve s (> 1: shadefit faster)
  --sf-args "..."    extra `shadefit fit` arguments for every shadefit run (e.g. "--starts 1")

Usage: /usr/bin/python3 bench/peer/compare.py [--model ggx] [--repeat 3] [--json out.json]
       [REF.exr ...]   (default: the point-lit list below)
Debian 12 packages: python3-numpy, python3-scipy, python3-openimageio.
"""

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
DEFAULT_REFS = [
    "reference_images/cycles/red-plastic-key.exr",
    "reference_images/cycles/copper-side.exr",
    "reference_images/cycles/gold-key.exr",
    "reference_images/cycles/black-glossy-rim.exr",
    "reference_images/cycles/white-glossy-key.exr",
    "reference_images/cycles/aluminium-key.exr",
    "reference_images/cycles/blue-rough-key.exr",
]


def timed(cmd):
    t = time.perf_counter()
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    wall = time.perf_counter() - t
    if proc.returncode != 0:
        sys.exit(f"failed ({proc.returncode}): {' '.join(cmd)}\n{proc.stderr}")
    return proc.stdout, wall


def run_shadefit(shadefit, ref, model, tmp, extra=()):
    out = os.path.join(tmp, "shadefit.json")
    _, wall = timed([shadefit, "fit", "--ref", ref, "--model", model, "--no-images", "-o", out,
                     *extra])
    with open(out) as f:
        j = json.load(f)
    return {
        "wall": wall,
        "seconds": j["solver"]["seconds"],
        "iterations": j["solver"]["iterations"],
        "termination": j["solver"]["termination"],
        "residual_evaluations": j["evaluations"]["residual_evaluations"],
        "jacobian_evaluations": j["evaluations"]["jacobian_evaluations"],
        "cost": j["cost"]["final"],
        "rmse": j["rmse"]["per_reference"][0]["rmse"],
        "pixels": j["rmse"]["per_reference"][0]["pixels"],
        "values": j["values"],
        "solve_seconds": j["solver"].get("solve_seconds"),
        "version": j.get("shadefit_version", "?"),
    }


def run_peer(shadefit, ref, model):
    stdout, wall = timed([sys.executable, os.path.join(HERE, "peer_fit.py"), "--ref", ref,
                          "--model", model, "--shadefit", shadefit])
    j = json.loads(stdout)
    j["wall"] = wall
    return j


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("refs", nargs="*", default=DEFAULT_REFS)
    ap.add_argument("--model", default="ggx")
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--shadefit", default="build/studies/shadefit")
    ap.add_argument("--json", help="also write every run's numbers here")
    ap.add_argument("--sf-args", default="", help="extra shadefit fit arguments")
    args = ap.parse_args()

    refs = [r for r in args.refs if os.path.exists(r)]
    missing = sorted(set(args.refs) - set(refs))
    if missing:
        print(f"skipped (missing): {', '.join(missing)}", file=sys.stderr)
    print(f"model {args.model}, {args.repeat} repeat(s), medians; shadefit: {args.shadefit}")
    print()
    print("| reference | shadefit Fit() s | at 1 iteration s | iterations (resid./Jac. evals) | "
          "shadefit rel. RMSE | peer solve s | peer evals (f/J) | peer rel. RMSE | "
          "cost peer/sf | peer solve / sf Fit() | peer solve / sf solve est. | "
          "wall sf s | wall peer s | wall ratio | sf solve s | peer / sf solve |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    sf_args = args.sf_args.split()
    everything = []
    with tempfile.TemporaryDirectory(prefix="peer-compare-") as tmp:
        for ref in refs:
            sf_runs, fixed_runs, peer_runs = [], [], []
            for _ in range(args.repeat):
                sf_runs.append(run_shadefit(args.shadefit, ref, args.model, tmp, sf_args))
                fixed_runs.append(run_shadefit(args.shadefit, ref, args.model, tmp,
                                               [*sf_args, "--max-iterations", "1"]))
                peer_runs.append(run_peer(args.shadefit, ref, args.model))
            sf, pe = sf_runs[-1], peer_runs[-1]
            if sf["pixels"] != pe["pixels"]:
                sys.exit(f"{ref}: pixel counts differ: shadefit {sf['pixels']}, peer {pe['pixels']}")
            med = statistics.median
            sf_s = med(r["seconds"] for r in sf_runs)
            sf_fixed = med(r["seconds"] for r in fixed_runs)
            sf_solve = max(1e-3, sf_s - sf_fixed)
            sf_wall = med(r["wall"] for r in sf_runs)
            pe_s = med(r["solver"]["seconds"] for r in peer_runs)
            pe_wall = med(r["wall"] for r in peer_runs)
            rms_ref = pe["rms_reference"]
            solves = [r["solve_seconds"] for r in sf_runs if r["solve_seconds"] is not None]
            sf_pure = med(solves) if solves else None
            pure = (f"{sf_pure:.4f} | {pe_s / max(sf_pure, 1e-6):.1f}" if sf_pure is not None
                    else "- | -")
            name = os.path.splitext(os.path.basename(ref))[0]
            term = "" if sf["termination"] == "CONVERGENCE" else f" {sf['termination']}"
            print(f"| {name} | {sf_s:.3f} | {sf_fixed:.3f} | {sf['iterations']} "
                  f"({sf['residual_evaluations']}/{sf['jacobian_evaluations']}){term} | "
                  f"{sf['rmse'] / rms_ref:.4g} | {pe_s:.3f} | "
                  f"{pe['solver']['nfev']}/{pe['solver']['njev']} | {pe['relative_rmse']:.4g} | "
                  f"{pe['cost']['final'] / sf['cost']:.4g} | {pe_s / sf_s:.2f} | "
                  f"{pe_s / sf_solve:.2f} | "
                  f"{sf_wall:.2f} | {pe_wall:.2f} | {pe_wall / sf_wall:.2f} | {pure} |",
                  flush=True)
            everything.append({"reference": ref, "model": args.model, "shadefit": sf_runs,
                               "shadefit_max_iterations_1": fixed_runs, "peer": peer_runs})
    versions = sorted({r["version"] for e in everything for r in e["shadefit"]})
    print(f"\nshadefit_version {', '.join(versions)}; numpy {everything[0]['peer'][0]['versions']['numpy']}, "
          f"scipy {everything[0]['peer'][0]['versions']['scipy']}" if everything else "")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(everything, f, indent=1)


if __name__ == "__main__":
    main()
