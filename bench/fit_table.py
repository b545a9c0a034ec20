#!/usr/bin/python3
"""Fits one model to many references with `shadefit fit`, one process per fit, and prints one
tab-separated row per reference: name, model, final cost, iterations, solve seconds (the solves
alone, `solver.solve_seconds`), Fit() seconds, termination.

Used for BENCHMARKS.md ("Fitter: iterations and starts") and to write
tests/fit/data/stored_costs.tsv (`--solver ceres` at the defaults of 28afb69: one start).

Usage: /usr/bin/python3 bench/fit_table.py [--model ggx] [--shadefit build/studies/shadefit]
       [--glob 'reference_images/cycles/*.exr'] [REF.exr ...] -- [extra shadefit fit args]
Environment-lit references (*-env) are skipped unless named explicitly.
"""

import argparse
import glob
import json
import os
import subprocess
import sys
import tempfile


def main():
    argv = sys.argv[1:]
    extra = []
    if "--" in argv:
        i = argv.index("--")
        argv, extra = argv[:i], argv[i + 1:]
    ap = argparse.ArgumentParser()
    ap.add_argument("--model", default="ggx")
    ap.add_argument("--shadefit", default="build/studies/shadefit")
    ap.add_argument("--glob", default="reference_images/cycles/*.exr")
    ap.add_argument("refs", nargs="*")
    a = ap.parse_args(argv)
    refs = a.refs or sorted(r for r in glob.glob(a.glob) if not r.endswith("-env.exr"))
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "fit.json")
        for ref in refs:
            cmd = [a.shadefit, "fit", "--ref", ref, "--model", a.model, "--no-images", "-o", out,
                   *extra]
            proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
            if proc.returncode != 0:
                sys.exit(f"failed: {' '.join(cmd)}\n{proc.stderr}")
            with open(out) as f:
                j = json.load(f)
            s = j["solver"]
            name = os.path.splitext(os.path.basename(ref))[0]
            print(f"{name}\t{a.model}\t{j['cost']['final']:.12g}\t{s['iterations']}\t"
                  f"{s.get('solve_seconds', float('nan')):.4f}\t{s['seconds']:.4f}\t"
                  f"{s['termination']}", flush=True)


if __name__ == "__main__":
    main()
