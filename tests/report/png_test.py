#!/usr/bin/python3
"""The report's own PNG encoding (report/report_figures.py: write_png, png_idat and the PDF's RGB
and gray images) decodes, with Pillow's PNG decoder, to exactly the pixels it was given: random
8-bit images of awkward sizes (one pixel, odd widths; rows whose differences wrap modulo 256), a
figure saved by save_figure against Agg's buffer of the same drawing, and the Flate streams the
PDF embeds.

    png_test.py REPORT_DIR      exit 0 pass, 1 fail
"""

import os
import sys
import tempfile

import numpy as np
import PIL.Image

from figures_test import decode_idat  # the same folder


def main(argv):
    sys.path.insert(0, argv[1])
    import matplotlib.pyplot as plt
    import report_figures as rf

    failures = []
    rng = np.random.default_rng(7)
    with tempfile.TemporaryDirectory(prefix="shadefit-png-test-") as tmp:
        # Random pixels, every value and every wrap of an Up difference likely; one image of a
        # single pixel, and constant rows after varying ones.
        images = [rng.integers(0, 256, size=(h, w, c), dtype=np.uint8)
                  for h, w, c in ((1, 1, 4), (1, 9, 3), (7, 5, 4), (33, 64, 3), (40, 17, 4))]
        ramp = np.zeros((6, 4, 4), dtype=np.uint8)
        ramp[:3] = 255
        ramp[3:, :, 3] = 255
        images.append(ramp)
        for i, pixels in enumerate(images):
            path = os.path.join(tmp, f"random-{i}.png")
            rf.write_png(path, pixels, rf.DPI)
            with PIL.Image.open(path) as im:
                got = np.asarray(im)
                mode, dpi = im.mode, im.info.get("dpi")
            want_mode = {3: "RGB", 4: "RGBA"}[pixels.shape[2]]
            if mode != want_mode or got.shape != pixels.shape or not np.array_equal(got, pixels):
                failures.append(f"write_png {pixels.shape}: decoded {mode} {got.shape}, "
                                f"{np.count_nonzero(got != pixels) if got.shape == pixels.shape else '?'}"
                                " samples differ")
            if dpi is None or abs(dpi[0] - rf.DPI) > 0.01 or abs(dpi[1] - rf.DPI) > 0.01:
                failures.append(f"write_png {pixels.shape}: dpi {dpi}, want {rf.DPI}")
            if os.path.exists(path + ".tmp.png"):
                failures.append(f"write_png {pixels.shape}: its temporary was left behind")

        # A figure through save_figure: its PNG is Agg's buffer of that drawing.
        fig = plt.figure(figsize=(3.3, 1.5))
        ax = fig.add_subplot()
        ax.plot([0, 1, 2], [0, 2, 1], color="tab:red")
        ax.imshow(rng.random((8, 8, 3)), extent=(0, 1, 0, 1))
        ax.set_title("a title")
        fig.set_size_inches((660 + 0.01) / rf.DPI, (300 + 0.01) / rf.DPI)
        fig.set_dpi(rf.DPI)
        fig.canvas.draw()
        buffer = np.asarray(fig.canvas.buffer_rgba()).copy()
        manifest = []
        rf.save_figure(fig, tmp, "figure", manifest, "a figure")
        with PIL.Image.open(os.path.join(tmp, "figure.png")) as im:
            got = np.asarray(im)
        # Opaque: RGB, Agg's buffer less its alpha (all 255).
        if (got.shape != buffer.shape[:2] + (3,) or not (buffer[..., 3] == 255).all()
                or not np.array_equal(got, buffer[..., :3])):
            failures.append(f"save_figure: the PNG {got.shape} is not Agg's buffer "
                            f"{buffer.shape} of the same drawing, as RGB")
        # A see-through figure keeps its alpha: RGBA, the buffer itself.
        fig = plt.figure(figsize=(1.0, 0.5))
        fig.patch.set_alpha(0.0)
        fig.add_subplot().plot([0, 1], [1, 0])
        fig.set_size_inches((200 + 0.01) / rf.DPI, (100 + 0.01) / rf.DPI)
        fig.set_dpi(rf.DPI)
        fig.canvas.draw()
        buffer = np.asarray(fig.canvas.buffer_rgba()).copy()
        rf.save_figure(fig, tmp, "clear", manifest, "a see-through figure")
        with PIL.Image.open(os.path.join(tmp, "clear.png")) as im:
            got, mode = np.asarray(im), im.mode
        if mode != "RGBA" or got.shape != buffer.shape or not np.array_equal(got, buffer):
            failures.append(f"save_figure: a see-through figure's PNG is {mode} {got.shape}, "
                            f"not Agg's RGBA buffer {buffer.shape}")

        # The PDF's images: RGB and gray through png_idat, a palette image through Pillow.
        for mode, shape, color_type in (("RGB", (21, 13, 3), 2), ("L", (9, 30), 0)):
            pixels = rng.integers(0, 256, size=shape, dtype=np.uint8)
            data, depth, palette = rf._pdf_write_png(None, PIL.Image.fromarray(pixels, mode))
            got = decode_idat(data, shape[1], shape[0], color_type)
            if depth != 8 or palette is not None or not np.array_equal(got, pixels):
                failures.append(f"PDF image {mode}: depth {depth}, palette {palette is not None}, "
                                f"pixels equal {np.array_equal(got, pixels)}")
        few = PIL.Image.fromarray(rng.integers(0, 4, size=(5, 6), dtype=np.uint8) * 60, "L")
        data, depth, palette = rf._pdf_write_png(None, few.convert("P"))
        if palette is None or depth is None:
            failures.append(f"PDF palette image: depth {depth}, palette {palette}")
    for f in failures:
        print("FAILED: " + f)
    print(f"png_test: {len(failures)} problem(s)")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
