#!/usr/bin/python3
"""The report never hides extrapolated data (issue 12; docs/probes.md, "BRDF-space probes"): a
probe curve whose points carry "extrapolated" flags (MERL beyond theta_d = 75 deg) is drawn with
the measured points on a solid line and the flagged points, joined from the last measured one,
on a dotted line with open markers, and both are in the legend. Built from a hand-written curve
record, so the check does not depend on any probe's numbers.

    extrapolated_curve_test.py REPORT_DIR      exit 0 pass, 1 fail
"""

import math
import sys


def main(argv):
    sys.path.insert(0, argv[1])
    import report_probe_figures as rf  # noqa: E402

    xs = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 80.0, 85.0]
    ys = [1.0, 1.02, 1.1, 1.3, 1.9, 3.2, 4.1, 5.0]
    flags = [x > 75.0 for x in xs]
    measured = {"series": "measured", "reference": None, "kind": "Fresnel rise", "x": xs,
                "y": ys, "x_label": "theta_d (deg)", "y_label": "rise", "x_scale": "linear",
                "y_scale": "linear", "x_ticks": [], "extrapolated": flags}
    model = dict(measured, series="ggx@key", y=[1.0] * len(xs))
    del model["extrapolated"]
    fig = rf.probe_curve_figure("brdf", "test-material", [measured, model], ["ggx@key"])
    problems = []
    lines = [l for ax in fig.axes for l in ax.get_lines()]
    dotted = [l for l in lines if l.get_linestyle() == ":"]
    if len(dotted) != 1:
        problems.append(f"{len(dotted)} dotted lines, want 1 (the measured curve's extrapolated part)")
    else:
        d = dotted[0]
        got = [(x, y) for x, y in zip(d.get_xdata(), d.get_ydata()) if not math.isnan(y)]
        want = [(x, y) for x, y, f in zip(xs, ys, flags) if f or x == 75.0]
        if got != want:
            problems.append(f"dotted part {got}, want {want}")
        if d.get_markerfacecolor() != "white":
            problems.append("extrapolated points are not open markers")
    solid = [l for l in lines if l.get_label() == "measured"]
    if len(solid) != 1:
        problems.append(f"{len(solid)} 'measured' lines, want 1")
    else:
        shown = [x for x, y in zip(solid[0].get_xdata(), solid[0].get_ydata())
                 if not math.isnan(y)]
        if shown != [x for x, f in zip(xs, flags) if not f]:
            problems.append(f"measured line shows x = {shown}: extrapolated points drawn solid")
    legend = [t.get_text() for leg in fig.legends for t in leg.get_texts()]
    if "measured, extrapolated" not in legend:
        problems.append(f"legend {legend} does not name the extrapolated part")
    if any(l.get_label() == "ggx@key" and l.get_linestyle() == ":" for l in lines):
        problems.append("a model's curve (no flags) has a dotted part")
    for p in problems:
        print("extrapolated_curve_test: " + p)
    print("extrapolated_curve_test: " + ("FAIL" if problems else "ok"))
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
