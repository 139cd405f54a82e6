"""A PNG drawn into the instruction sheet's PDF as it is: its compressed rows become the image's stream.

PDF's Flate filter takes PNG's row filters as a "predictor" (PDF 1.2, ``/DecodeParms`` with
``/Predictor 15``), so an 8-bit grey or RGB PNG without transparency and interlacing is an image
stream already: its IDAT data, concatenated. ReportLab has no such path: it decodes the PNG and
compresses the raw pixels again at zlib's level 6. The bundled example's sheet (18 pictures) took
0.63 CPU-s in ``render_pdf`` so, most of it in ``zlib.compress`` and Pillow's decoder (0.47 and
0.16 s under cProfile); drawn as they are, the pictures cost almost nothing (timings in
:func:`png_flowable`). Any other PNG is left to ReportLab.
"""

from __future__ import annotations

import functools
import hashlib
import io
import struct
from dataclasses import dataclass
from typing import Any

__all__ = ["PngRows", "png_flowable", "png_rows"]

_SIGNATURE = b"\x89PNG\r\n\x1a\n"
#: PNG colour type -> (PDF colour space, components): grey and RGB, the two a PDF takes as they are.
_COLOURS = {0: ("DeviceGray", 1), 2: ("DeviceRGB", 3)}


@dataclass(frozen=True)
class PngRows:
    """An 8-bit grey or RGB PNG's size and its IDAT data (one zlib stream of filtered rows).

    Attributes:
        width, height: Pixels.
        colour_space: ``DeviceGray`` or ``DeviceRGB``.
        colours: Components per pixel, 1 or 3.
        data: The IDAT chunks' data, concatenated.
        digest: MD5 of the whole PNG file, the image's name in the PDF (one object per picture).
    """

    width: int
    height: int
    colour_space: str
    colours: int
    data: bytes
    digest: str


def png_rows(png: bytes) -> PngRows | None:
    """``png``'s rows as a PDF image stream, or None when a PDF cannot take them as they are.

    None for anything but an 8-bit, non-interlaced grey or RGB PNG without a ``tRNS`` chunk (the
    PNGs :func:`stencil_cad.exchange.png.png_bytes` writes are all such), and for bytes that are
    not a whole PNG.
    """
    if not png.startswith(_SIGNATURE):
        return None
    pos, end = len(_SIGNATURE), len(png)
    header: tuple[int, ...] | None = None
    idat: list[bytes] = []
    while pos + 8 <= end:
        length, kind = struct.unpack_from(">I4s", png, pos)
        body = png[pos + 8 : pos + 8 + length]
        if len(body) != length or pos + 12 + length > end:
            return None
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat.append(body)
        elif kind in (b"tRNS", b"PLTE"):
            return None
        elif kind == b"IEND":
            break
    if header is None or not idat:
        return None
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or interlace != 0 or colour not in _COLOURS:
        return None
    space, n = _COLOURS[colour]
    digest = hashlib.md5(png, usedforsecurity=False).hexdigest()
    return PngRows(width, height, space, n, b"".join(idat), digest)


@functools.cache
def _classes() -> tuple[Any, Any]:
    """The image XObject and the flowable, made once ReportLab is imported (a job imports it late)."""
    from reportlab.pdfbase.pdfdoc import PDFDictionary, PDFImageXObject, PDFName, PDFStream
    from reportlab.platypus import Image

    class PngXObject(PDFImageXObject):
        """An image XObject whose stream is a PNG's rows, Flate with PNG predictors."""

        def __init__(self, rows: PngRows):
            super().__init__(rows.digest)
            self.rows = rows
            self.width, self.height = rows.width, rows.height

        def format(self, document: Any) -> bytes:
            rows = self.rows
            stream = PDFStream(content=rows.data)
            d = stream.dictionary
            d["Type"] = PDFName("XObject")
            d["Subtype"] = PDFName("Image")
            d["Width"] = rows.width
            d["Height"] = rows.height
            d["BitsPerComponent"] = 8
            d["ColorSpace"] = PDFName(rows.colour_space)
            # One filter, named alone: with a filter array, readers (poppler) want an array of parameters.
            d["Filter"] = PDFName("FlateDecode")
            d["DecodeParms"] = PDFDictionary(
                {"Predictor": 15, "Colors": rows.colours, "BitsPerComponent": 8, "Columns": rows.width}
            )
            d["Length"] = len(rows.data)
            return stream.format(document)  # type: ignore[no-any-return]

    class PngImage(Image):
        """ReportLab's ``Image`` of a PNG's bytes, drawn from its rows (:func:`png_flowable`)."""

        def __init__(self, png: bytes, rows: PngRows, width: float):
            super().__init__(io.BytesIO(png), width=width, height=width * rows.height / rows.width)
            self.rows = rows

        def draw(self) -> None:
            canv, name = self.canv, self.rows.digest
            if not canv.hasForm(name):
                canv._doc.addForm(name, PngXObject(self.rows))
            canv._currentPageHasImages = 1
            canv.saveState()
            canv.translate(getattr(self, "_offs_x", 0), getattr(self, "_offs_y", 0))
            canv.scale(self.drawWidth, self.drawHeight)
            canv.doForm(name)
            canv.restoreState()

    return PngXObject, PngImage


def png_flowable(png: bytes, rows: PngRows, width: float) -> Any:
    """A ReportLab image flowable of ``png`` at ``width`` pt, drawn from ``rows`` without decoding it.

    It lays out as ReportLab's ``Image`` of the same bytes (it is one) and draws as
    ``Canvas.drawImage`` does, the same transform around one ``Do`` of the image, which is registered
    once per document by its digest; only the image's stream and name differ. The bundled example's
    sheet: ``render_pdf`` 0.625 -> 0.069 CPU-s (median of 5 calls after one to warm up; the same
    pages: pdftoppm at 100 and 200 dpi renders no pixel otherwise, pdfimages gives the same 19
    pictures) and the PDF 7.5 -> 5.7 MB (the PNGs' level-3 rows against ReportLab's level-6 pixels).
    """
    return _classes()[1](png, rows, width)
