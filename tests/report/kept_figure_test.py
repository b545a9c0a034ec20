#!/usr/bin/python3
"""A probe figure kept from one material and emptied for the next (report_probe_figures,
KEEP_FIGURES) is saved as the same bytes as a new figure: PNG, PDF and figures.json record. The
materials, hand-written curve records of one layout, are chosen to carry state from one to the
next if the emptying missed any: a log axis that turns linear and back, a panel whose data reach
below zero after a log one, ranges of many decades then of a few (fewer ticks than the axis has
made), a log x axis, a panel with no finite value (the limits of an axes without data), a long
title over an axis offset in one material and not the next, an extrapolated part in every
material. Compared with a figure made anew for each, not with any
stored drawing.

    kept_figure_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import json
import os
import shutil
import sys

import numpy as np

SERIES = ["ggx@key", "blinn-phong@key"]
LONG_TITLE = "second panel, a title as wide as its axes"


def curve(series, kind, x, y, x_scale="linear", y_scale="linear", flags=None):
    c = {"series": series, "reference": None, "kind": kind, "x": list(map(float, x)),
         "y": [None if y_i is None or not np.isfinite(y_i) else float(y_i) for y_i in y],
         "x_label": "theta_d (deg)" if x_scale == "linear" else "lobe width",
         "y_label": f"{kind} value", "x_scale": x_scale, "y_scale": y_scale, "x_ticks": []}
    if flags is not None:
        c["extrapolated"] = list(flags)
    return c


def material(seed, span, first_log, x_log, empty_panel):
    """Three panels: `span` decades on the first (log when `first_log`, else linear values
    that go below zero), a linear one, and one with a log x axis when `x_log` (every value
    missing when `empty_panel`)."""
    rng = np.random.default_rng(seed)
    x = np.linspace(0.0, 85.0, 18)
    flags = x > 75.0
    out = []
    for i, s in enumerate(["measured"] + SERIES):
        scale = 1.0 + 0.3 * i + 0.1 * rng.random()
        if first_log:
            y1 = scale * np.logspace(0, span, len(x))
        else:
            y1 = scale * np.sin(x / 20.0) - 0.4 * i
        out.append(curve(s, "first", x, y1, y_scale="log" if first_log else "linear",
                         flags=flags if s == "measured" else None))
        # Large values that differ little: the y axis writes an offset ("+1e6") above it,
        # which a long title must clear (matplotlib moves it up, on a new figure's axes).
        big = 1e6 if seed % 2 == 0 else 0.0
        out.append(curve(s, LONG_TITLE, x, big + 0.2 * scale + 0.01 * x * (i + seed)))
        wx = np.logspace(-2, 0, 12) if x_log else np.linspace(0.01, 1.0, 12)
        y3 = [None] * len(wx) if empty_panel else list(scale * wx ** 0.5)
        out.append(curve(s, "third", wx, y3, x_scale="log" if x_log else "linear"))
    return out


MATERIALS = [
    ("wide-log", dict(seed=1, span=9, first_log=True, x_log=True, empty_panel=False)),
    ("linear-negative", dict(seed=2, span=0, first_log=False, x_log=False, empty_panel=False)),
    ("few-decades", dict(seed=3, span=1.5, first_log=True, x_log=True, empty_panel=True)),
    ("wide-log-again", dict(seed=4, span=7, first_log=True, x_log=False, empty_panel=False)),
]


def draw_all(rpf, rf, out_dir, keep):
    """Each material's brdf figure saved to out_dir; (records, figures drawn)."""
    os.makedirs(out_dir, exist_ok=True)
    manifest, figs = [], []
    for name, kwargs in MATERIALS:
        fig = rpf.probe_curve_figure("brdf", name, material(**kwargs), SERIES, keep=keep)
        figs.append(fig)
        rf.save_figure(fig, out_dir, f"probe-brdf-{name}", manifest, "a kept figure test")
    return manifest, figs


def kept_against_new(out, new_records, kept_records):
    """Problems where figures saved under out/kept (drawn on kept figures) are not the records
    and the PNG and PDF bytes of the same figures saved under out/new (drawn on new ones)."""
    problems = []
    for a, b in zip(new_records, kept_records):
        if json.dumps(a, sort_keys=True) != json.dumps(b, sort_keys=True):
            problems.append(f"{a['name']}: figures.json records differ: {a} against {b}")
        for ext in ("png", "pdf"):
            with open(os.path.join(out, "new", f"{a['name']}.{ext}"), "rb") as f:
                want = f.read()
            with open(os.path.join(out, "kept", f"{a['name']}.{ext}"), "rb") as f:
                got = f.read()
            if got != want:
                problems.append(f"{a['name']}.{ext}: the kept figure's bytes differ from a new "
                                f"figure's ({len(got)} against {len(want)} bytes)")
    return problems


def main(argv):
    sys.path.insert(0, argv[1])
    import report_figures as rf  # noqa: E402
    import report_probe_figures as rpf  # noqa: E402

    out = argv[2]
    shutil.rmtree(out, ignore_errors=True)
    problems = []
    new_records, new_figs = draw_all(rpf, rf, os.path.join(out, "new"), keep=False)
    kept_records, kept_figs = draw_all(rpf, rf, os.path.join(out, "kept"), keep=True)
    if len({id(f) for f in new_figs}) != len(new_figs):
        problems.append("keep=False handed out a figure twice")
    if len({id(f) for f in kept_figs}) != 1:
        problems.append(f"keep=True made {len({id(f) for f in kept_figs})} figures for one "
                        "layout, want 1 (the comparison below would test nothing)")
    problems += kept_against_new(out, new_records, kept_records)
    for p in problems:
        print("kept_figure_test: " + p)
    print("kept_figure_test: " + ("FAIL" if problems else "ok"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
