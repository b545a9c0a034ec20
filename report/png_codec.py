"""Deflate and inflate for the report's PNGs, and a reader for the one kind of PNG it reads by
the thousand: the studies' previews (render/src/image.cpp: 8-bit RGB, every row filtered Up).

zlib's inflate and deflate are the report's, through libdeflate where the system has it (Debian
libdeflate0, which Pillow's TIFF library already brings: python3-pil -> libtiff6 ->
libdeflate0), else Python's zlib: the same streams' contents, either way. A grid reads ~290
previews of 256 x 256 per material: Pillow decoded one in ~0.56 ms (zlib's inflate, its row
filters, then a copy of its pixel buffer into bytes), read here in ~0.18 ms (libdeflate's inflate
0.08 ms, then the Up filter undone as a running sum over the rows, modulo 256). Any other PNG
(interlaced, 16-bit, palette, gray, other row filters, damaged) is left to Pillow: read_up_png
returns None for it.

PNG format: W3C Portable Network Graphics Specification, 2nd ed., sec. 5 (chunks), 9 (filters).
"""

import ctypes
import ctypes.util
import os
import struct
import zlib

import numpy as np

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
FILTER_NONE, FILTER_UP = 0, 2


class _Libdeflate:
    """libdeflate's zlib-format functions (libdeflate.h, 1.x), one compressor per level and
    one decompressor per process (they hold state; a forked worker makes its own)."""

    def __init__(self, lib):
        self.lib, self.pid, self.compressors, self.decompressor = lib, None, {}, None
        lib.libdeflate_alloc_decompressor.restype = ctypes.c_void_p
        lib.libdeflate_alloc_decompressor.argtypes = []
        lib.libdeflate_zlib_decompress.restype = ctypes.c_int
        lib.libdeflate_zlib_decompress.argtypes = [
            ctypes.c_void_p, ctypes.c_char_p, ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t,
            ctypes.c_void_p]
        lib.libdeflate_alloc_compressor.restype = ctypes.c_void_p
        lib.libdeflate_alloc_compressor.argtypes = [ctypes.c_int]
        lib.libdeflate_zlib_compress_bound.restype = ctypes.c_size_t
        lib.libdeflate_zlib_compress_bound.argtypes = [ctypes.c_void_p, ctypes.c_size_t]
        lib.libdeflate_zlib_compress.restype = ctypes.c_size_t
        lib.libdeflate_zlib_compress.argtypes = [
            ctypes.c_void_p, ctypes.c_void_p, ctypes.c_size_t, ctypes.c_void_p, ctypes.c_size_t]

    def _this_process(self):
        if self.pid != os.getpid():  # after a fork: the parent's objects are not ours to use
            self.pid, self.compressors, self.decompressor = os.getpid(), {}, None

    def inflate(self, data, size):
        """The `size` bytes `data` (a zlib stream) inflates to, as a uint8 array; None where it
        holds anything else (damaged, shorter or longer)."""
        self._this_process()
        if self.decompressor is None:
            self.decompressor = self.lib.libdeflate_alloc_decompressor()
            if not self.decompressor:
                return None
        out = np.empty(size, dtype=np.uint8)
        status = self.lib.libdeflate_zlib_decompress(self.decompressor, data, len(data),
                                                     out.ctypes.data, size, None)
        return out if status == 0 else None  # LIBDEFLATE_SUCCESS

    def deflate(self, data, level):
        """`data` (a contiguous uint8 array) as a zlib stream at `level`."""
        self._this_process()
        c = self.compressors.get(level)
        if c is None:
            c = self.compressors[level] = self.lib.libdeflate_alloc_compressor(level)
            if not c:
                raise MemoryError("libdeflate: no compressor")
        bound = self.lib.libdeflate_zlib_compress_bound(c, data.nbytes)
        out = ctypes.create_string_buffer(bound)
        n = self.lib.libdeflate_zlib_compress(c, data.ctypes.data, data.nbytes, out, bound)
        if n == 0:
            raise MemoryError("libdeflate: the bound did not hold the stream")
        return ctypes.string_at(out, n)


def _load_libdeflate():
    if os.environ.get("SHADEFIT_NO_LIBDEFLATE", "") not in ("", "0"):  # tests: zlib's path
        return None
    for name in ("libdeflate.so.0", ctypes.util.find_library("deflate")):
        if not name:
            continue
        try:
            return _Libdeflate(ctypes.CDLL(name))
        except (OSError, AttributeError):
            continue
    return None


LIBDEFLATE = _load_libdeflate()
# The fastest level of the deflate in use: zlib's 1; libdeflate's 2, faster than its 1 on the
# report's figures (rows filtered Up) and smaller than either 1.
FAST_LEVEL = 1 if LIBDEFLATE is None else 2


def inflate(data, size):
    """The `size` bytes the zlib stream `data` holds, as a uint8 array; None where it holds
    anything else."""
    if LIBDEFLATE is not None:
        return LIBDEFLATE.inflate(data, size)
    try:
        d = zlib.decompressobj()
        out = d.decompress(data, size)
        if len(out) != size or not d.eof or d.unconsumed_tail:
            return None
        return np.frombuffer(out, dtype=np.uint8)
    except zlib.error:
        return None


def deflate(data, level):
    """`data` (uint8 array) as a zlib stream, at zlib's `level` (1-9; libdeflate's levels are
    zlib's in kind: 1 fastest)."""
    data = np.ascontiguousarray(data, dtype=np.uint8)
    if LIBDEFLATE is not None:
        return LIBDEFLATE.deflate(data, level)
    return zlib.compress(data, level)


def read_up_png(path):
    """The pixels (h x w x 3 or 4, uint8, read-only) of the PNG at `path` where it is 8-bit RGB
    or RGBA, not interlaced, its first row filtered None or Up and every other row Up; None for
    any other file (Pillow's to read, or to report as damaged: a chunk cut short or whose CRC
    does not hold, no IEND, a stream that inflates to other than its rows)."""
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError:
        return None
    if not data.startswith(PNG_SIGNATURE):
        return None
    pos, header, idat, end = len(PNG_SIGNATURE), None, [], False
    while pos + 12 <= len(data):
        n, kind = struct.unpack(">I4s", data[pos:pos + 8])
        if pos + 12 + n > len(data) or struct.unpack(">I", data[pos + 8 + n:pos + 12 + n])[0] != (
                zlib.crc32(data[pos + 4:pos + 8 + n]) & 0xFFFFFFFF):
            return None  # cut short, or a chunk whose CRC does not hold
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            if n != 13:
                return None
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind == b"IEND":
            end = True
            break
        elif kind == b"PLTE" or not (kind[0] & 0x20):
            return None  # a critical chunk this reader does not know
        pos += 12 + n
    if header is None or not idat or not end:
        return None
    width, height, depth, color_type, compression, filtering, interlace = header
    channels = {2: 3, 6: 4}.get(color_type)
    if (channels is None or depth != 8 or compression or filtering or interlace or width == 0
            or height == 0):
        return None
    stride = width * channels + 1
    lines = inflate(b"".join(idat), height * stride)
    if lines is None:
        return None
    lines = lines.reshape(height, stride)
    filters = lines[:, 0]
    if not ((filters[1:] == FILTER_UP).all() and filters[0] in (FILTER_NONE, FILTER_UP)):
        return None
    # Up: each row is its differences from the row above (the first's row above is zeros): the
    # rows' running sum modulo 256, as log2(height) shifted additions.
    pixels = lines[:, 1:].copy()
    step = 1
    while step < height:
        pixels[step:] += pixels[:-step]  # numpy reads the overlap as it was before the sum
        step *= 2
    pixels = pixels.reshape(height, width, channels)
    pixels.flags.writeable = False
    return pixels
