#!/usr/bin/python3
"""A bar chart's series drawn as one path (report_figures.bars) makes the pixels its bars make
drawn one by one (report_figures.ONE_PATH_BARS off): the probe's bar figure of the report (saved:
the same PNG bytes), and bar charts chosen to reach the rule's edges: a log axis, stroked edges,
missing values, many bars. Where one path would change a pixel (bars that overlap, see-through)
or where Agg would draw it otherwise (more vertices than it snaps, bars of several colours), the
bars are drawn one by one: the test checks that they are, and that one path there would indeed
differ, so the case can catch a rule that lets it through. The bars' data limits, found without
splitting each bar into curves (report_figures._patch_limits), are matplotlib's to the bit.
Compared with the same chart drawn bar by bar, or made by matplotlib's own code, not with any
stored drawing.

    bars_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import os
import shutil
import sys

import numpy as np

FAILURES = []


def check(ok, what):
    if not ok:
        FAILURES.append(what)
        print(f"FAIL: {what}")


def drawn(rf, fig):
    fig.canvas.draw()
    return np.asarray(fig.canvas.buffer_rgba()).copy()


class OnePaths:
    """Counts, while it is on, the series drawn as one path and those drawn bar by bar."""

    def __init__(self, rf):
        self.rf, self.one, self.apart = rf, 0, 0

    def __enter__(self):
        self.saved = self.rf._BarSeries._one_path
        counter = self

        def counted(series):
            path = counter.saved(series)
            if path is None:
                counter.apart += 1
            else:
                counter.one += 1
            return path
        self.rf._BarSeries._one_path = counted
        return self

    def __exit__(self, *exc):
        self.rf._BarSeries._one_path = self.saved


def chart(rf, series=6, keys=12, log=False, linewidth=0.0, width=None, step=1.0, alpha=None,
          colours=None, seed=1):
    """A grouped bar chart through report_figures.bars: `series` calls of `keys` bars each,
    a NaN in every series, the report's fills (bar_style)."""
    fig = rf.plt.figure(figsize=(rf.PAGE_IN, 2.5), dpi=rf.DPI)
    ax = fig.add_axes([0.08, 0.15, 0.9, 0.75])
    rng = np.random.default_rng(seed)
    w = width or 0.8 / series
    x = np.arange(keys) * step
    for i in range(series):
        heights = 10.0 ** rng.uniform(-2, 1, keys) if log else rng.uniform(0.05, 1.0, keys)
        heights[(3 * i) % keys] = np.nan
        style = rf.bar_style(i, f"fit {i}")
        style["linewidth"] = linewidth
        if alpha is not None:
            style["alpha"] = alpha
        if colours is not None:
            style["color"] = [colours[k % len(colours)] for k in range(keys)]
        rf.bars(ax, x + i * w, heights, w, label=f"fit {i}", **style)
    if log:
        ax.set_yscale("log")
    fig.legend(ncol=6, loc="upper center", frameon=False)
    return fig


def both_ways(rf, make):
    """(pixels bar by bar, pixels with one path per series, OnePaths of the second)."""
    rf.ONE_PATH_BARS = False
    fig = make()
    apart = drawn(rf, fig)
    rf.plt.close(fig)
    rf.ONE_PATH_BARS = True
    fig = make()
    with OnePaths(rf) as counts:
        one = drawn(rf, fig)
    rf.plt.close(fig)
    return apart, one, counts


def differ(a, b):
    return int((a != b).any(axis=-1).sum())


def main(report_dir, out_dir):
    sys.path.insert(0, report_dir)
    import report_figures as rf
    import report_probe_figures
    from report_util import flatten

    # Charts one path draws: the same pixels, and each series was one path.
    for name, kw in [("linear", {}), ("log axis", {"log": True}),
                     ("stroked edges", {"linewidth": 0.6}),
                     ("many bars", {"series": 3, "keys": 60}),
                     ("wide bars", {"series": 2, "keys": 30, "width": 0.45}),
                     ("one series", {"series": 1, "keys": 40})]:
        apart, one, counts = both_ways(rf, lambda: chart(rf, **kw))
        check(differ(apart, one) == 0, f"{name}: {differ(apart, one)} pixels differ")
        series = kw.get("series", 6)
        check(counts.one == series and counts.apart == 0,
              f"{name}: {counts.one} of {series} series drawn as one path")

    # Charts drawn bar by bar: the same pixels, no series as one path, and one path would
    # change them (forced through, the rule off).
    for name, kw, rule in [
            ("overlapping see-through bars", {"series": 2, "width": 1.5, "step": 1.0,
                                              "alpha": 0.5}, "BAR_APART_PX"),
            ("more vertices than Agg snaps", {"series": 1, "keys": 210, "width": 0.4,
                                              "linewidth": 0.3},
             "BAR_PATH_VERTICES"),
            ("a colour per bar", {"series": 2, "colours": ["#E69F00", "#0072B2"]}, "style")]:
        apart, one, counts = both_ways(rf, lambda: chart(rf, **kw))
        check(differ(apart, one) == 0, f"{name}: {differ(apart, one)} pixels differ")
        check(counts.one == 0, f"{name}: {counts.one} series drawn as one path")
        saved = rf.BAR_APART_PX, rf.BAR_PATH_VERTICES, rf._bar_style
        if rule == "BAR_APART_PX":
            rf.BAR_APART_PX = -1e9
        elif rule == "BAR_PATH_VERTICES":
            rf.BAR_PATH_VERTICES = 1 << 30
        else:
            rf._bar_style = lambda r: ()
        try:
            _, forced, counts = both_ways(rf, lambda: chart(rf, **kw))
        finally:
            rf.BAR_APART_PX, rf.BAR_PATH_VERTICES, rf._bar_style = saved
        check(counts.one > 0 and differ(apart, forced) > 0,
              f"{name}: one path forced through changes no pixel ({counts.one} series): the "
              "case cannot catch the rule")

    # The bars' data limits (report_figures._patch_limits) are matplotlib's own: random charts
    # of negative, zero, missing and offset bars, linear and log, a bar of no height beyond
    # the others, and a rectangle in axes coordinates, every limit the same double.
    for seed in range(12):
        for log in (False, True):
            got = []
            for own in (True, False):
                rf.use_matplotlib_text(own)
                fig = rf.plt.figure(figsize=(3, 2))
                ax = fig.add_axes([0.1, 0.1, 0.8, 0.8])
                rng = np.random.default_rng(seed)
                for i in range(9):
                    heights = rng.normal(size=10) * 10.0 ** rng.uniform(-3, 3)
                    heights[i % 10], heights[(i + 3) % 10] = np.nan, 0.0
                    ax.bar(np.arange(10) + i * 0.09 + rng.uniform(-1e-9, 1e-9), heights, 0.09,
                           bottom=rng.uniform(-1, 1) if i % 3 == 0 else 0.0)
                ax.bar([1000.0], [0.0], 0.5)  # no height, right of the others: widens x
                # In axes coordinates, left of and below the view: matplotlib takes its corners
                # to data coordinates through the view it has then.
                ax.set_xlim(-1.0, 30.0)
                ax.set_ylim(-5.0, 5.0)
                ax.add_patch(rf.matplotlib.patches.Rectangle((-40.0, -40.0), 5.0, 5.0,
                                                             transform=ax.transAxes))
                ax.autoscale(True)
                if log:
                    ax.set_yscale("log")
                got.append([np.array(v, dtype=float) for v in (
                    ax.dataLim.get_points(), ax.dataLim.minpos, ax.get_xlim(), ax.get_ylim())])
                rf.plt.close(fig)
            rf.use_matplotlib_text(False)
            check(all(np.array_equal(a, b) for a, b in zip(*got)),
                  f"data limits of bar chart {seed} (log {log}): {got[1]} against matplotlib's "
                  f"{got[0]}")

    # The report's probe bar figure, saved: the same PNG bytes, a PDF each way.
    labels = [f"fit-{i}@key" for i in range(12)]
    rng = np.random.default_rng(7)
    numbers = {s: {f"obj-{k}": {"ratio": float(rng.uniform(0.2, 2.0))} for k in range(12)}
               for s in ["reference"] + labels}
    numbers[labels[3]]["obj-5"]["ratio"] = None
    files = {}
    for one_path in (False, True):
        rf.ONE_PATH_BARS = one_path
        folder = os.path.join(out_dir, "one-path" if one_path else "bar-by-bar")
        fig = report_probe_figures.probe_bar_figure("portability", "obj", numbers, flatten,
                                                    labels)
        with OnePaths(rf) as counts:
            rf.save_figure(fig, folder, "probe-portability-obj", [], "caption")
        files[one_path] = [open(os.path.join(folder, "probe-portability-obj." + ext), "rb").read()
                           for ext in ("png", "pdf")]
        if one_path:
            check(counts.one >= len(numbers), f"probe figure: {counts.one} series as one path")
    rf.ONE_PATH_BARS = True
    check(files[True][0] == files[False][0], "probe figure: the PNGs differ")
    check(files[True][1].startswith(b"%PDF") and len(files[True][1]) > 1000,
          "probe figure: no PDF")

    print("bars: " + ("FAIL" if FAILURES else "ok"))
    return 1 if FAILURES else 0


if __name__ == "__main__":
    out = sys.argv[2]
    shutil.rmtree(out, ignore_errors=True)
    os.makedirs(out)
    sys.exit(main(sys.argv[1], out))
