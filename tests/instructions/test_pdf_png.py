"""The instruction sheet's PNGs drawn into the PDF undecoded: which PNGs go so, and that they look the same."""

import io
import struct
import zlib

import numpy as np
import pytest
from PIL import Image
from readers import need, run

from stencil_cad.exchange.png import png_bytes
from stencil_cad.instructions.pdf_png import png_flowable, png_rows


def _noise(shape, seed=0):
    return np.random.default_rng(seed).integers(0, 256, shape, dtype=np.uint8)


def _chunks(png):
    pos, out = 8, []
    while pos < len(png):
        (length,) = struct.unpack_from(">I", png, pos)
        out.append(png[pos + 4 : pos + 8])
        pos += 12 + length
    return out


def test_rgb_and_grey_pngs_are_their_rows():
    for a, space, n in [(_noise((300, 400, 3)), "DeviceRGB", 3), (_noise((50, 70)), "DeviceGray", 1)]:
        png = png_bytes(a)
        rows = png_rows(png)
        assert rows is not None
        h, w = a.shape[:2]
        assert (rows.width, rows.height, rows.colour_space, rows.colours) == (w, h, space, n)
        raw = np.frombuffer(zlib.decompress(rows.data), np.uint8).reshape(a.shape[0], -1)
        assert raw.shape[1] == 1 + a.shape[1] * n and set(raw[:, 0]) <= {0, 1, 2, 3, 4}
    # A big picture's rows come in many IDAT chunks, joined in order.
    assert _chunks(png_bytes(_noise((300, 400, 3)))).count(b"IDAT") > 1


def _saved(image, **kw):
    buf = io.BytesIO()
    image.save(buf, format="PNG", **kw)
    return buf.getvalue()


def _interlaced(png):
    """``png`` with its header saying Adam7 (Pillow writes no interlaced PNG; the CRC is made again)."""
    at = 8 + 8 + 12  # signature, IHDR's length and type, then width, height, depth, colour, method, filter
    head = png[12:at] + b"\x01"
    return png[:at] + b"\x01" + struct.pack(">I", zlib.crc32(head)) + png[at + 5 :]


def test_other_pngs_are_left_to_reportlab():
    rgb = Image.fromarray(_noise((20, 30, 3)))
    assert png_rows(_saved(rgb)) is not None
    others = [
        _saved(Image.fromarray(_noise((20, 30, 4)))),  # alpha
        _saved(rgb.convert("P")),  # palette
        _saved(Image.fromarray(_noise((20, 30)).astype(np.uint16) * 257)),  # 16-bit grey
        _saved(rgb.convert("1")),  # 1-bit
        _interlaced(_saved(rgb)),  # Adam7
        _saved(rgb, transparency=(0, 0, 0)),  # a transparent colour
        _saved(rgb)[:-40],  # cut short
        b"GIF89a" + bytes(40),
        b"",
    ]
    assert [png_rows(p) for p in others] == [None] * len(others)


def _pdf(flowables):
    from reportlab.lib.pagesizes import A4
    from reportlab.platypus import SimpleDocTemplate

    buf = io.BytesIO()
    SimpleDocTemplate(buf, pagesize=A4, invariant=1).build(flowables)
    return buf.getvalue()


@pytest.mark.parametrize("shape", [(120, 90, 3), (64, 80)])
def test_a_png_drawn_undecoded_looks_as_reportlab_draws_it(tmp_path, shape):
    from reportlab.platypus import Image as RLImage
    from reportlab.platypus import Table

    pdftoppm = need("pdftoppm")
    png = png_bytes(_noise(shape, seed=3))
    rows = png_rows(png)
    assert rows is not None
    width = 200.0
    height = width * shape[0] / shape[1]
    ours = _pdf([png_flowable(png, rows, width), Table([[png_flowable(png, rows, width / 2)]])])
    theirs = _pdf(
        [RLImage(io.BytesIO(png), width, height), Table([[RLImage(io.BytesIO(png), width / 2, height / 2)]])]
    )
    assert ours.count(b"/Subtype /Image") == 1  # one object, drawn twice
    pages = []
    for name, pdf in (("ours", ours), ("theirs", theirs)):
        path = tmp_path / f"{name}.pdf"
        path.write_bytes(pdf)
        r = run([pdftoppm, "-r", "150", "-png", "-singlefile", str(path), str(tmp_path / name)])
        assert r.returncode == 0, r.stderr
        with Image.open(tmp_path / f"{name}.png") as page:
            pages.append(np.asarray(page.convert("RGB")))
    assert pages[0].shape == pages[1].shape
    assert (pages[0] != 255).any() and np.array_equal(pages[0], pages[1])
