"""PNG encoding: the pixels as given, 8-bit, no metadata but the resolution, the same bytes every time."""

import io
import struct

import numpy as np
from PIL import Image

from stencil_cad.exchange.png import png_bytes


def _chunks(png):
    pos, out = 8, []
    while pos < len(png):
        (length,) = struct.unpack_from(">I", png, pos)
        out.append(png[pos + 4 : pos + 8].decode())
        pos += 12 + length
    return out


def test_pixels_round_trip():
    rng = np.random.default_rng(5)
    rgb = rng.integers(0, 256, (37, 53, 3), dtype=np.uint8)
    grey = rng.integers(0, 256, (20, 11), dtype=np.uint8)
    floats = rng.normal(0.5, 0.4, (9, 14, 3))  # some outside [0, 1]: clipped
    for a, mode, want in [
        (rgb, "RGB", rgb),
        (grey, "L", grey),
        (floats, "RGB", (np.clip(floats, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)),
        (rgb[:, ::2], "RGB", rgb[:, ::2]),  # a strided view
    ]:
        png = png_bytes(a)
        with Image.open(io.BytesIO(png)) as im:
            assert im.mode == mode and np.array_equal(np.asarray(im), want)
            assert im.info.get("interlace", 0) == 0 and round(im.info["dpi"][0]) == 72
        assert set(_chunks(png)) == {"IHDR", "pHYs", "IDAT", "IEND"}
        assert png_bytes(a) == png


def test_a_big_picture_keeps_its_pixels():
    a = np.random.default_rng(6).integers(0, 256, (700, 900, 3), dtype=np.uint8)
    with Image.open(io.BytesIO(png_bytes(a))) as im:
        assert np.array_equal(np.asarray(im), a)
