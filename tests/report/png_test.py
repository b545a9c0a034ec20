#!/usr/bin/python3
"""The report's own PNG encoding (report/report_figures.py: write_png, png_idat and the PDF's RGB
and gray images) decodes, with Pillow's PNG decoder, to exactly the pixels it was given: random
8-bit images of awkward sizes (one pixel, odd widths; rows whose differences wrap modulo 256), a
figure saved by save_figure against Agg's buffer of the same drawing, and the Flate streams the
PDF embeds. The previews' reader (report/png_codec.py read_up_png) reads what Pillow reads, with
libdeflate and with zlib, and leaves every other kind and every damaged file to Pillow. A figure
whose saving is stopped before a rename leaves only a hidden temporary that the study runner
sweeps.

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
            if [n for n in os.listdir(tmp) if n.startswith(".")]:
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

        # A report killed between writing a figure and its rename leaves only hidden
        # temporaries named as the study runner sweeps a dead process's (".<name>.<pid>.tmp",
        # studies/runner/src/temporaries.cpp): the PNG's, then the PDF's (the rename fails here
        # as a kill would stop it).
        import re
        for stop_at in (1, 2):
            folder = os.path.join(tmp, f"killed-{stop_at}")
            renames, replace = [0], os.replace

            def killed(src, dst, stop_at=stop_at):
                renames[0] += 1
                if renames[0] == stop_at:
                    raise KeyboardInterrupt("killed")
                return replace(src, dst)
            fig = plt.figure(figsize=(1.0, 0.5))
            fig.add_subplot().plot([0, 1], [1, 0])
            os.replace = killed
            try:
                rf.save_figure(fig, folder, "killed", [], "a figure killed while saved")
            except KeyboardInterrupt:
                pass
            finally:
                os.replace = replace
                plt.close(fig)
            left = sorted(n for n in os.listdir(folder) if n not in ("killed.png", "killed.pdf"))
            if not left or not all(re.fullmatch(rf"\.killed\.(png|pdf)\.{os.getpid()}\.tmp", n)
                                   for n in left):
                failures.append(f"save_figure killed at rename {stop_at}: left {left}, want "
                                "one hidden .<name>.<pid>.tmp")

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
    failures += check_reader(rf, rng)
    for f in failures:
        print("FAILED: " + f)
    print(f"png_test: {len(failures)} problem(s)")
    return 1 if failures else 0


def png_file(path, width, height, color_type, depth, lines, idat_parts=1, extra=()):
    """A PNG of the given header and filtered rows (`lines`: bytes, each row's filter byte
    first), its stream split over `idat_parts` IDAT chunks, `extra` chunks before them."""
    import struct
    import zlib

    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    stream = zlib.compress(lines, 6)
    step = -(-len(stream) // idat_parts)
    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n"
                + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, depth, color_type, 0, 0, 0))
                + b"".join(chunk(k, d) for k, d in extra)
                + b"".join(chunk(b"IDAT", stream[i:i + step]) for i in range(0, len(stream), step))
                + chunk(b"IEND", b""))


def up_lines(pixels, first_filter=2):
    """The rows of `pixels` filtered Up (the first with `first_filter`: 0 or 2, the same bytes)."""
    rows = pixels.reshape(pixels.shape[0], -1).astype(np.int16)
    diff = np.vstack([rows[:1], rows[1:] - rows[:-1]]) % 256
    return np.hstack([np.full((len(rows), 1), 2), diff]).astype(np.uint8).copy(), first_filter


def check_reader(rf, rng):
    """png_codec.read_up_png (the previews' reader) against Pillow's decoder, through libdeflate
    where the system has it and through zlib: the pixels of Up-filtered RGB and RGBA files of
    awkward sizes, split streams and ancillary chunks; None (Pillow's to read) for every other
    kind, and for damaged files, which read_rgb8 then reads or rejects as Pillow does."""
    import png_codec
    failures = []
    with tempfile.TemporaryDirectory(prefix="shadefit-png-reader-") as tmp:
        def pillow(path):
            with PIL.Image.open(path) as im:
                return np.asarray(im)

        saved = png_codec.LIBDEFLATE
        for library in (["libdeflate"] if saved is not None else []) + ["zlib"]:
            png_codec.LIBDEFLATE = saved if library == "libdeflate" else None
            cases = []
            for k, (h, w, c) in enumerate(((1, 1, 3), (1, 9, 4), (7, 5, 3), (300, 7, 3),
                                           (64, 33, 4), (2, 256, 3))):
                pixels = rng.integers(0, 256, size=(h, w, c), dtype=np.uint8)
                if h > 2:
                    pixels[h // 2:] = pixels[h // 2]  # constant rows: differences of zero
                lines, _ = up_lines(pixels)
                if k % 2:
                    lines[0, 0] = 0  # the first row filtered None: the same bytes
                path = os.path.join(tmp, f"up-{k}.png")
                png_file(path, w, h, {3: 2, 4: 6}[c], 8, lines.tobytes(), idat_parts=1 + k % 3,
                         extra=[(b"tEXt", b"Software\0test")] if k % 2 else [])
                cases.append((path, pixels))
            path = os.path.join(tmp, "written.png")
            figure = rng.integers(0, 256, size=(40, 17, 4), dtype=np.uint8)
            rf.write_png(path, figure, rf.DPI)  # the figures' own writer (png_idat)
            cases.append((path, figure))
            for path, pixels in cases:
                got = png_codec.read_up_png(path)
                if got is None or got.shape != pixels.shape or not np.array_equal(got, pixels) \
                        or not np.array_equal(got, pillow(path)):
                    failures.append(f"{library}: read_up_png {os.path.basename(path)} "
                                    f"{pixels.shape}: {None if got is None else got.shape}, "
                                    "not the pixels written")
                elif got.flags.writeable:
                    failures.append(f"{library}: read_up_png's pixels are writeable (a cache "
                                    "shares them)")
                if not np.array_equal(rf.read_rgb8(path), pixels[..., :3]):
                    failures.append(f"{library}: read_rgb8 {os.path.basename(path)}: other pixels")

            # Other kinds: Pillow's (its own filters, gray, palette, 16 bits, interlaced rows
            # are not written here), and a row filtered other than Up.
            pixels = rng.integers(0, 256, size=(20, 30, 3), dtype=np.uint8)
            others = {}
            for name, image in (("pillow-rgb", PIL.Image.fromarray(pixels, "RGB")),
                                ("gray", PIL.Image.fromarray(pixels[..., 0], "L")),
                                ("palette", PIL.Image.fromarray(pixels, "RGB").convert("P"))):
                others[name] = os.path.join(tmp, name + ".png")
                image.save(others[name], optimize=False, compress_level=6)
            sixteen = os.path.join(tmp, "sixteen.png")
            PIL.Image.fromarray(pixels[..., 0].astype(np.uint16) * 257).save(sixteen)
            others["16-bit"] = sixteen
            lines, _ = up_lines(pixels)
            lines[5, 0] = 1  # one row filtered Sub
            others["a Sub row"] = os.path.join(tmp, "sub.png")
            png_file(others["a Sub row"], 30, 20, 2, 8, lines.tobytes())
            for name, path in others.items():
                if png_codec.read_up_png(path) is not None:
                    failures.append(f"{library}: read_up_png read {name}, not its kind")
            want = pillow(others["pillow-rgb"])
            if not np.array_equal(rf.read_rgb8(others["pillow-rgb"]), want):
                failures.append(f"{library}: read_rgb8 of Pillow's own PNG: other pixels")

            # Damaged: a CRC that does not hold, a cut stream, a stream of too few rows.
            good = open(cases[3][0], "rb").read()
            damaged = {"bad CRC": good[:40] + bytes([good[40] ^ 1]) + good[41:],
                       "cut short": good[:len(good) // 2]}
            lines, _ = up_lines(cases[3][1])
            short = os.path.join(tmp, "short.png")
            png_file(short, 7, 300, 2, 8, lines[:-1].tobytes())
            damaged["a row missing"] = open(short, "rb").read()
            for name, data in damaged.items():
                path = os.path.join(tmp, "damaged.png")
                with open(path, "wb") as f:
                    f.write(data)
                if png_codec.read_up_png(path) is not None:
                    failures.append(f"{library}: read_up_png read a damaged file ({name})")
                # read_rgb8 does with it what Pillow does: the same error, or the same pixels.
                outcome = []
                for read in (rf.read_rgb8, lambda p: pillow(p)[..., :3]):
                    try:
                        outcome.append(read(path))
                    except Exception as e:
                        outcome.append(type(e))
                same = (outcome[0] is outcome[1] if isinstance(outcome[1], type) else
                        isinstance(outcome[0], np.ndarray) and np.array_equal(*outcome))
                if not same:
                    failures.append(f"{library}: read_rgb8 of a damaged file ({name}): "
                                    "not what Pillow does")

            # Every cut and every one-bit flip of a small file: never an exception, never read
            # (a cut loses IEND or a chunk; a chunk's CRC, or the signature, catches a flip).
            small = open(cases[2][0], "rb").read()
            path = os.path.join(tmp, "flipped.png")
            trials = [small[:cut] for cut in range(len(small))]
            trials += [small[:i] + bytes([small[i] ^ (1 << b)]) + small[i + 1:]
                       for i in range(len(small)) for b in range(8)]
            for k, data in enumerate(trials):
                with open(path, "wb") as f:
                    f.write(data)
                try:
                    got = png_codec.read_up_png(path)
                except Exception as e:
                    failures.append(f"{library}: read_up_png raised {type(e).__name__} on a "
                                    f"damaged file (trial {k})")
                    break
                if got is not None:
                    failures.append(f"{library}: read_up_png read a damaged file (trial {k})")
                    break

            # deflate: streams zlib inflates to the same bytes, at each level.
            data = rng.integers(0, 4, size=100000, dtype=np.uint8)
            for level in (1, 2, png_codec.FAST_LEVEL, 6, 9):
                import zlib
                if zlib.decompress(png_codec.deflate(data, level)) != data.tobytes():
                    failures.append(f"{library}: deflate at level {level}: another stream")
        png_codec.LIBDEFLATE = saved
    return failures


if __name__ == "__main__":
    sys.exit(main(sys.argv))
