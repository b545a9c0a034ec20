#!/usr/bin/python3
"""Image grids that fit the data (issue 33, item 4; docs/studies.md, "Report"): a photograph set
of 612 x 512 frames under 40 lightings, written here as result files (previews and job records,
fixed values), drawn by report_grids.image_grid. The grid must
- be one figure under 3000 px tall (at most GRID_MAX_ROWS rows: the training lightings and the
  test lightings with the lowest and the highest error, which the test knows from its own numbers),
- keep the pixel aspect ratio: the ball, a disc in every frame, is round in the PNG (its width
  and height measured on the reference, fit and error tiles of every row),
- crop each frame to the object: the disc fills most of its tile (uncropped it would fill 0.36
  of the width), although the reference photograph's background is not black; and where a lit
  backdrop fills the frame, keep the whole frame at its 612 : 512 ratio,
- record no overlapping or clipped text,
- draw its tiles in the PDF as one raster that is the PNG's pixels, where the PNG has them,
- give every row a colour bar: viridis from 0 at the bottom of the row's tiles to the row's error
  scale at their top (read from the PNG's pixels), with its three labels, "0", half the scale and
  the scale, at the bottom, middle and top of that bar;
- be the same bytes drawn on the figure kept from the grid before (report_grids.KEEP_GRID) as on
  a new one.

    grid_fit_test.py REPORT_DIR OUT_DIR      exit 0 pass, 1 fail
"""

import os
import shutil
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import figures_test  # noqa: E402  (pdf_raster_problems)
import kept_figure_test  # noqa: E402  (kept_against_new)

W, H = 612, 512                   # The frame, as the data set's photographs.
CX, CY, R = 250.0, 280.0, 110.0   # The ball: off centre, radius 110 px.
N_LIGHTINGS = 40
TRAIN = [f"L{i:02d}" for i in range(0, N_LIGHTINGS, 5)]  # 8 training lightings.
LABELS = ["blinn-phong", "ggx"]
REF_RGB = (0.9, 0.25, 0.2)        # The ball in the reference: red on a noisy dark-blue ground.
# Colours no viridis colour bar holds, so that only the discs match them.
FIT_RGB = (0.85, 0.3, 0.85)       # In the fits: magenta on black (renders over black).
ERR_RGB = (1.0, 0.55, 0.0)        # In the error maps: orange on the masked grey.
BAR_PX = 48                       # The error PNG's own colour bar, right of the frame.
ERROR_SCALE = 0.05                # Every error map's scale (its colour bar's top).


def disc_mask(w=W, h=H):
    y, x = np.mgrid[0:h, 0:w]
    return (x + 0.5 - CX) ** 2 + (y + 0.5 - CY) ** 2 < R ** 2


def save_png(path, img):
    import matplotlib.image as mpimg
    os.makedirs(os.path.dirname(path), exist_ok=True)
    mpimg.imsave(path, np.clip(img, 0, 1))


def write_set(d, labels, fit_ground):
    """previews and job records; returns (study, fits, errors per test lighting). `fit_ground`:
    the fits' background (0: black, the object alone; > 0: a lit backdrop filling the frame, as a
    plane would, so the crop keeps the whole 612 x 512 frame)."""
    rng = np.random.default_rng(33)
    disc = disc_mask()[..., None]
    lightings = [f"L{i:02d}" for i in range(N_LIGHTINGS)]
    ground = np.array([0.03, 0.04, 0.16]) + rng.uniform(0, 0.03, (H, W, 3))
    ref = np.where(disc, np.array(REF_RGB), ground)
    fit = np.where(disc, np.array(FIT_RGB), fit_ground)
    err = np.full((H, W + BAR_PX, 3), 0.5)
    err[:, :W] = np.where(disc, np.array(ERR_RGB), 0.5)
    err[:, W:] = np.linspace(1, 0, H)[:, None, None] * np.array([0.3, 0.6, 0.9])
    errors = {l: float(rng.uniform(0.05, 0.12)) for l in lightings}
    fits = {}
    for label in labels:
        evaluations = []
        for l in lightings:
            base = f"images/ball-{l}"
            save_png(os.path.join(d, base + ".reference.png"), ref) if label == labels[0] else None
            save_png(os.path.join(d, f"{base}.{label}.png"), fit)
            save_png(os.path.join(d, f"{base}.{label}.error.png"), err)
            # The second fit a little worse everywhere: the order of lightings is the first's.
            rel = errors[l] * (1.0 if label == labels[0] else 1.05)
            evaluations.append({"lighting": l, "split": "train" if l in TRAIN else "test",
                                "metrics": {"relative_rmse": rel},
                                "images": {"reference": base + ".reference.png",
                                           "fit": f"{base}.{label}.png",
                                           "error": f"{base}.{label}.error.png",
                                           "error_scale": ERROR_SCALE}})
        fits[("ball", label)] = {"label": label, "evaluations": evaluations}
    study = {"fits": [{"label": l, "model": l, "train": TRAIN} for l in labels],
             "groups": [{"material": "ball", "references": [{"lighting": l} for l in lightings]}]}
    tests = {l: e for l, e in errors.items() if l not in TRAIN}
    return study, fits, tests


def runs(flags):
    """[(start, end)] of the True runs of a 1-D boolean array."""
    out, start = [], None
    for i, f in enumerate(list(flags) + [False]):
        if f and start is None:
            start = i
        elif not f and start is not None:
            out.append((start, i))
            start = None
    return out


def discs(png, colour, tol=0.12):
    """(width, height, x0, x1, y0, y1) of every region of `colour` in the PNG: one per row band
    and column band (tiles never touch: a gap separates them)."""
    hit = np.all(np.abs(png[..., :3] - np.array(colour)) < tol, axis=2)
    out = []
    for y0, y1 in runs(hit.any(axis=1)):
        band = hit[y0:y1]
        for x0, x1 in runs(band.any(axis=0)):
            ys = np.nonzero(band[:, x0:x1].any(axis=1))[0]
            out.append((x1 - x0, ys.max() - ys.min() + 1, x0, x1, y0 + ys.min(), y0 + ys.max() + 1))
    return out


def bar_problems(report_grids, d, study, fits, labels, png, rows):
    """The rows' colour bars: in the PNG, a run of viridis pixels per row in one column, its
    colour index falling from the top (the scale) to the bottom (0); in the figure, the labels
    "0", "0.025" and "0.05" (ERROR_SCALE) level with the run's bottom, middle and top."""
    import matplotlib
    from report_figures import DPI, drawn_texts
    # Each pixel's viridis entry where its 8-bit colour is one (the bar's pixels are the
    # colour map's own: drawn without resampling between entries; the tiles hold none of them).
    lut = matplotlib.colormaps["viridis"](np.arange(256), bytes=True)[:, :3].astype(np.int64)
    keys = (lut[:, 0] << 16) | (lut[:, 1] << 8) | lut[:, 2]
    order = np.argsort(keys)
    rgb = np.round(png[..., :3] * 255).astype(np.int64)
    pix = (rgb[..., 0] << 16) | (rgb[..., 1] << 8) | rgb[..., 2]
    at = np.minimum(np.searchsorted(keys[order], pix), 255)
    index = np.where(keys[order][at] == pix, order[at], -1)
    column = int(np.argmax((index >= 0).sum(axis=0)))
    bars = runs(index[:, column] >= 0)
    problems = []
    if len(bars) != len(rows):
        return [f"{len(bars)} colour bars in column {column}, want one per row ({len(rows)})"]
    for (y0, y1), light in zip(bars, rows):
        steps = index[y0:y1, column]
        # Its end pixels are the outline's: the ends of the map within a few entries.
        if steps[0] < 245 or steps[-1] > 10 or np.any(np.diff(steps) > 0):
            problems.append(f"row {light}: the bar runs from viridis {steps[0]} at its top to "
                            f"{steps[-1]} at its bottom, want 255 down to 0 without a rise")
    # The labels, from the figure the grid draws, drawn at the PNG's resolution: each label's
    # box, in PNG rows (row 0 at the top), its bottom on the bar's bottom ("0"), its middle on
    # the bar's middle, its top on the bar's top (the scale).
    evals = {l: {e["lighting"]: e for e in fits[("ball", l)]["evaluations"]} for l in labels}
    fig, _, shown = report_grids.grid_figure(d, study, fits, "ball", labels, "")
    fig.set_dpi(DPI)
    fig.canvas.draw()
    renderer = fig.canvas.get_renderer()
    boxes = [(t.get_text(), t.get_window_extent(renderer)) for t in drawn_texts(fig)]
    png_h = png.shape[0]
    for (y0, y1), light in zip(bars, shown):
        scale = evals[labels[0]][light]["images"]["error_scale"]
        want = {"0": (y1, lambda b: png_h - b.y0),
                "0.025": ((y0 + y1) / 2, lambda b: png_h - (b.y0 + b.y1) / 2),
                "0.05": (y0, lambda b: png_h - b.y1)}
        for text, (row, edge) in want.items():
            at = sorted(round(edge(b)) for x, b in boxes if x == text)
            near = [r for r in at if abs(r - row) <= 3]
            if scale != ERROR_SCALE or len(near) != 1:
                problems.append(f"row {light}: {len(near)} label(s) '{text}' level with PNG "
                                f"row {row:.0f} of its colour bar, want 1 (labels at {at})")
    import matplotlib.pyplot as plt
    plt.close(fig)
    return problems


SETS = {}  # name -> (folder, study, fits) of each set check() wrote


def kept_problems(report_grids, out):
    """Grids drawn on a kept figure (report_grids.KEEP_GRID: one figure emptied for the next)
    are the bytes and records of grids drawn on new figures: grids of other heights, fits and
    headings in turn, the kept figure drawn again after a taller and a shorter one."""
    import matplotlib.pyplot as plt
    from report_figures import save_figure
    order = [("ball", LABELS, ""), ("backdrop", LABELS[:1], ""),
             ("ball", LABELS[:1], "part 1 of 2: fits trained on L00"), ("ball", LABELS, "")]
    drawn, problems = {}, []
    for keep in (False, True):
        folder = os.path.join(out, "kept" if keep else "new")
        records, figures = [], []
        for i, (name, labels, heading) in enumerate(order):
            d, study, fits = SETS[name]
            fig, caption, _ = report_grids.grid_figure(d, study, fits, "ball", labels, heading,
                                                       keep=keep)
            figures.append(id(fig))
            save_figure(fig, folder, f"grid-{i}", records, caption)
            plt.close(fig)
        drawn[keep] = records
        if keep and len(set(figures)) != 1:
            problems.append(f"keep=True made {len(set(figures))} figures, want 1 (the "
                            "comparison would test nothing)")
    return problems + [f"kept grid {p}" for p in
                       kept_figure_test.kept_against_new(out, drawn[False], drawn[True])]


def check(report_grids, out, name, labels, fit_ground, min_fill):
    """Draws the grid of one synthetic set; returns its problems."""
    import matplotlib.image as mpimg
    d = os.path.join(out, name)
    shutil.rmtree(d, ignore_errors=True)
    study, fits, tests = write_set(d, labels, fit_ground)
    SETS[name] = (d, study, fits)
    manifest = []
    report_grids.image_grid(d, study, fits, "ball", os.path.join(d, "figures"), manifest)
    failures = []
    if len(manifest) != 1:
        return [f"{len(manifest)} grid figures, want 1"]
    fig = manifest[0]
    png = mpimg.imread(os.path.join(d, fig["png"]))
    height, width = png.shape[:2]
    print(f"{name}: grid {width} x {height} px, {len(labels)} fit(s), rows {fig['lightings']}")
    if height >= 3000:
        failures.append(f"the grid is {height} px tall, want under 3000")
    rows = fig["lightings"]
    if len(rows) > report_grids.GRID_MAX_ROWS:
        failures.append(f"{len(rows)} rows, want at most {report_grids.GRID_MAX_ROWS}")
    missing = [l for l in TRAIN if l not in rows]
    if missing:
        failures.append(f"training lightings {missing} not in the grid")
    ranked = sorted(tests, key=tests.get)
    for want, why in ((ranked[:2], "lowest"), (ranked[-2:], "highest")):
        if any(l not in rows for l in want):
            failures.append(f"the test lightings of the {why} error {want} not all in {rows}")
    for a, b in fig.get("text_overlaps", [("(field missing)", "")]):
        failures.append(f"text '{a}' overlaps '{b}'")
    for t in fig.get("text_outside", ["(field missing)"]):
        failures.append(f"text '{t}' leaves the figure")
    # The discs: one reference, the fits and their error maps per row, each round.
    for what, colour, per_row in (("reference", REF_RGB, 1), ("fit", FIT_RGB, len(labels)),
                                  ("error", ERR_RGB, len(labels))):
        found = discs(png, colour)
        if len(found) != per_row * len(rows):
            failures.append(f"{len(found)} {what} discs, want {per_row * len(rows)}")
        ratios = [w / h for (w, h, *_) in found]
        if ratios:
            print(f"  {what} discs: width / height {min(ratios):.3f} .. {max(ratios):.3f}")
        for (w, h, *_) in found:
            if not 0.96 <= w / h <= 1.04:
                failures.append(f"a {what} disc is {w} x {h} px (ratio {w / h:.3f}): not round")
                break
        if what == "reference" and found:
            # The tile around the first reference disc: the run of the photograph's dark-blue
            # ground through the disc's centre, 3 px above the disc (inside the crop's margin).
            w, h, x0, x1, y0, y1 = found[0]
            ground = np.all(np.abs(png[y0 - 3, :, :3] - np.array([0.045, 0.055, 0.175])) < 0.06,
                            axis=1)
            centre = (x0 + x1) // 2
            spans = [(a, b) for a, b in runs(ground) if a <= centre < b]
            tile_w = spans[0][1] - spans[0][0] if spans else None
            fill = w / tile_w if tile_w else 0.0
            print(f"  reference disc {w} x {h} px in a tile {tile_w} px wide: fills {fill:.2f}")
            if fill < min_fill:
                failures.append(f"the disc fills {fill:.2f} of its tile's width, want >= "
                                f"{min_fill}")
            # The PDF's tiles are the PNG's pixels, one raster where the PDF draws them (not
            # resampled again, at a lower resolution or a shifted place).
            failures += [f"{fig['pdf']}: {p}" for p in figures_test.pdf_raster_problems(
                os.path.join(d, fig["pdf"]), os.path.join(d, fig["png"]))]
    failures += bar_problems(report_grids, d, study, fits, labels, png, rows)
    return [f"{name}: {f}" for f in failures]


def main(argv):
    report_src, out = argv[1], os.path.abspath(argv[2])
    sys.path.insert(0, report_src)
    import report_grids  # noqa: E402
    # The ball alone (fits rendered over black): cropped to it, two fits.
    failures = check(report_grids, out, "ball", LABELS, 0.0, 0.8)
    # A backdrop filling the frame (a plane would): the whole 612 x 512 frame is the object, so
    # only the aspect ratio keeps the disc round (a square tile draws it 0.84 as wide as tall);
    # one fit, whose wide columns would make 12 rows 3900 px tall without the page's limit. The
    # disc spans 220 of 612 px: 0.36 of the tile.
    failures += check(report_grids, out, "backdrop", LABELS[:1], 0.1, 0.3)
    failures += kept_problems(report_grids, os.path.join(out, "kept-grids"))
    for f in failures:
        print("FAILED: " + f)
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
