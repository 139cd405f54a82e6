"""The instruction sheet as a PDF (``instructions.pdf``), drawn with ReportLab's page layout engine."""

from __future__ import annotations

import contextlib
import html
import io
import threading
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from ..names import INPUT_PNG, MURAL_MAP_PNG, PREVIEW_PNG, SIMULATED_PNG
from . import mural
from .content import _NO_CAN, Sheet, _amount, _drop, _plate_caption, _plates_text, _unit_note
from .pdf_png import png_flowable, png_rows

#: One sheet is made at a time: :func:`_binary_streams` changes a process-wide ReportLab setting.
_SHEET_LOCK = threading.Lock()


def _pdf_fonts() -> tuple[str, str]:
    """Body and bold fonts: Helvetica for text, the bundled DejaVu Sans Bold for headings and symbols."""
    from importlib import resources

    from reportlab.pdfbase import pdfmetrics
    from reportlab.pdfbase.ttfonts import TTFont

    if "StencilBold" not in pdfmetrics.getRegisteredFontNames():
        path = resources.files("stencil_cad") / "data" / "DejaVuSans-Bold.ttf"
        with resources.as_file(path) as p:
            pdfmetrics.registerFont(TTFont("StencilBold", str(p)))
    return "Helvetica", "StencilBold"


def _latin(text: object) -> str:
    """Helvetica (a standard PDF font) has no Δ, → or ≥: spell them."""
    return (
        str(text)
        .replace("ΔE", "dE")
        .replace("Δ", "d")
        .replace("→", "->")
        .replace("≥", ">=")
        .replace("≤", "<=")
    )


class _PdfKit:
    """The PDF's page width, styles and the flowables every section is made of."""

    def __init__(self, images: Mapping[str, bytes]):
        from reportlab.lib import colors
        from reportlab.lib.pagesizes import A4
        from reportlab.lib.styles import ParagraphStyle
        from reportlab.lib.units import mm
        from reportlab.platypus import TableStyle

        self.images = images
        body_font, bold_font = _pdf_fonts()
        self.h1 = ParagraphStyle("h1", fontName=bold_font, fontSize=18, leading=22, spaceAfter=4)
        self.h2 = ParagraphStyle(
            "h2", fontName=bold_font, fontSize=13, leading=16, spaceBefore=10, spaceAfter=4
        )
        self.h3 = ParagraphStyle(
            "h3", fontName=bold_font, fontSize=10.5, leading=13, spaceBefore=6, spaceAfter=2
        )
        self.body = ParagraphStyle("body", fontName=body_font, fontSize=9, leading=11.5)
        self.small = ParagraphStyle(
            "small", fontName=body_font, fontSize=7.5, leading=9.5, textColor=colors.HexColor("#555555")
        )
        self.page_w = A4[0] - 30 * mm
        self.half = self.page_w / 2 - 3 * mm
        self.grid = TableStyle(
            [
                ("GRID", (0, 0), (-1, -1), 0.4, colors.HexColor("#bbbbbb")),
                ("BACKGROUND", (0, 0), (-1, 0), colors.HexColor("#eeeeee")),
                ("VALIGN", (0, 0), (-1, -1), "TOP"),
                ("FONTNAME", (0, 0), (-1, -1), body_font),
                ("FONTSIZE", (0, 0), (-1, -1), 8),
            ]
        )

    def p(self, text: object, style: Any = None) -> Any:
        """A paragraph of plain text (body style unless given)."""
        from reportlab.platypus import Paragraph

        return Paragraph(html.escape(_latin(text)), self.body if style is None else style)

    def heading(self, text: str, style: Any) -> Any:
        """A heading of the sheet's own fixed text, as given."""
        from reportlab.platypus import Paragraph

        return Paragraph(text, style)

    def img(self, name: str, width: float) -> Any:
        """The named picture at ``width`` pt, or a note that it is missing.

        A PNG that a PDF takes as it is goes in undecoded (:mod:`stencil_cad.instructions.pdf_png`).
        """
        from reportlab.lib.utils import ImageReader
        from reportlab.platypus import Image

        data = self.images.get(name)
        if not data:
            return self.p("(no image)", self.small)
        rows = png_rows(data)
        if rows is not None:
            return png_flowable(data, rows, width)
        reader = ImageReader(io.BytesIO(data))
        iw, ih = reader.getSize()
        return Image(io.BytesIO(data), width=width, height=width * ih / iw)

    def table(
        self,
        head: Sequence[str],
        rows: Sequence[Sequence[str]],
        widths: Sequence[float] | None = None,
        extra: Sequence[Any] = (),
    ) -> Any:
        """A gridded table with a header row repeated on every page."""
        from reportlab.platypus import Table, TableStyle

        data = [[self.p(h, self.small) for h in head]] + [
            [self.p(c) if isinstance(c, str) else c for c in r] for r in rows
        ]
        t = Table(data, colWidths=widths, repeatRows=1)
        t.setStyle(self.grid)
        if extra:
            t.setStyle(TableStyle(list(extra)))
        return t


def _pdf_paints(sheet: Sheet, k: _PdfKit) -> list[Any]:
    """The paints in spray order, each with its colour chip, and the notes under them."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm

    story = [k.heading("Paints, in spray order", k.h2)]
    rows = [["", "0", sheet.primer_hex, sheet.primer_name or _NO_CAN, "none: the whole surface", "full coat"]]
    for s in sheet.steps:
        rows.append(
            [
                "",
                str(s.number),
                s.hex,
                s.name or _NO_CAN,
                s.plate,
                _amount(s, sheet.unit, bare=True),
            ]
        )
    chips: list[tuple[Any, ...]] = [("BACKGROUND", (0, 1), (0, 1), colors.HexColor(sheet.primer_hex))]
    chips += [
        ("BACKGROUND", (0, j + 2), (0, j + 2), colors.HexColor(s.hex)) for j, s in enumerate(sheet.steps)
    ]
    chips += [("BOX", (0, j), (0, j), 1.2, colors.black) for j in range(1, len(rows) + 1)]
    story.append(
        k.table(
            ["colour", "#", "hex", "can", "plate", sheet.unit],
            rows,
            [14 * mm, 8 * mm, 22 * mm, 45 * mm, 45 * mm, 25 * mm],
            chips,
        )
    )
    if sheet.order_note:
        story.append(k.p(f"Why this order: {sheet.order_note}.", k.small))
    story.append(k.p(_unit_note(sheet.unit), k.small))
    if sheet.snap:
        story.append(k.heading("Snapped to your cans", k.h3))
        story += [k.p(x) for x in sheet.snap]
    return story


def _pdf_steps(sheet: Sheet, k: _PdfKit) -> list[Any]:
    """Spray, plate by plate: per step its colour, what to do, the plate and the simulated result."""
    from reportlab.lib import colors
    from reportlab.lib.units import mm
    from reportlab.platypus import KeepTogether, Spacer, Table, TableStyle

    story = [k.heading("Spray, plate by plate", k.h2)]
    for s in sheet.steps:
        t = _amount(s, sheet.unit)
        head = Table(
            [["", k.p(f"Step {s.number}: plate {s.plate}, paint {s.hex} {s.name}".rstrip(), k.h3)]],
            colWidths=[8 * mm, k.page_w - 8 * mm],
        )
        head.setStyle(
            TableStyle(
                [
                    ("BACKGROUND", (0, 0), (0, 0), colors.HexColor(s.hex)),
                    ("BOX", (0, 0), (0, 0), 1.2, colors.black),
                ]
            )
        )
        pair = Table(
            [
                [k.img(s.plate_image, k.half), k.img(s.after_image, k.half * 0.8)],
                [
                    k.p(_plate_caption(s, len(sheet.mural.sections) if sheet.mural else 0), k.small),
                    k.p(f"After step {s.number} (simulated)", k.small),
                ],
            ],
            colWidths=[k.page_w / 2, k.page_w / 2],
        )
        story.append(
            KeepTogether(
                [
                    head,
                    k.p(
                        f"{_drop(sheet, s)}, label readable; spray evenly{t}; let it dry, lift it out."
                        + (f" {s.how}" if s.how else ""),
                        k.small,
                    ),
                    pair,
                    Spacer(1, 6),
                ]
            )
        )
    return story


def _pdf_checks(sheet: Sheet, k: _PdfKit) -> list[Any]:
    """The simulated quality, the preview, every check passed or failed, the warnings."""
    from reportlab.lib.units import mm
    from reportlab.platypus import Spacer

    story = [k.heading("Checks", k.h2)]
    if sheet.scores:
        story.append(
            k.table(
                ["quality, simulated spray vs picture", "value"],
                [list(r) for r in sheet.scores],
                [110 * mm, 40 * mm],
            )
        )
        story.append(Spacer(1, 4))
    if k.images.get(PREVIEW_PNG):
        story.append(k.img(PREVIEW_PNG, k.page_w))
    for text, ok in sheet.checks:
        story.append(k.p(f"{'passed' if ok else 'FAILED'}: {text}"))
    if sheet.warnings:
        story.append(k.heading("Warnings", k.h3))
        story += [k.p(w) for w in sheet.warnings]
    return story


def render_pdf(sheet: Sheet, images: Mapping[str, bytes]) -> bytes:
    """The instruction sheet as a PDF (A4), the same content as :func:`render_html`.

    Returns:
        The PDF bytes.
    """
    from reportlab.lib.pagesizes import A4
    from reportlab.lib.units import mm
    from reportlab.platypus import Paragraph, SimpleDocTemplate, Spacer, Table

    k = _PdfKit(images)
    story = [
        Paragraph(html.escape(f"{sheet.job}: how to spray it"), k.h1),
        k.p(
            f"{'Stippled' if sheet.mode == 'soft' else 'Hard-edged cut'} stencils, {_plates_text(sheet)}. "
            f"Picture {sheet.width_mm:g} × {sheet.height_mm:g} mm; viewing distance: {sheet.viewing}."
        ),
        Spacer(1, 4),
        Table(
            [
                [k.img(INPUT_PNG, k.half), k.img(SIMULATED_PNG, k.half)],
                [k.p("The picture", k.small), k.p("What the plates give, simulated", k.small)],
            ],
            colWidths=[k.page_w / 2, k.page_w / 2],
        ),
    ]
    story += _pdf_paints(sheet, k)
    story.append(k.heading("Set up the wall", k.h2))
    story += [k.p(f"{j + 1}. {x}") for j, x in enumerate(sheet.wall)]
    if sheet.tiles:
        story.append(k.heading("Tile map", k.h3))
        story.append(_tile_drawing(sheet.tiles, sheet.width_mm, sheet.height_mm, k.page_w * 0.6))
        if k.images.get(MURAL_MAP_PNG):
            story.append(k.img(MURAL_MAP_PNG, k.page_w))
    if sheet.mural is not None:
        story += mural.mural_pdf(sheet.mural, k)
    story += _pdf_steps(sheet, k)
    story.append(k.heading("Print or cut the plates", k.h2))
    story.append(
        k.table(sheet.print_head, sheet.prints, [26 * mm, 14 * mm, 40 * mm, 16 * mm, k.page_w - 96 * mm])
    )
    if sheet.paint:
        story.append(k.heading("Paint to buy", k.h2))
        story.append(k.table(["coat", "paint", "covered m²", "mean opacity", "ml", "cans"], sheet.paint))
        story.append(k.p(sheet.paint_note, k.small))
    story += _pdf_checks(sheet, k)
    story.append(k.heading("Files", k.h2))
    story.append(k.p(", ".join(sheet.files), k.small))
    buf = io.BytesIO()
    doc = SimpleDocTemplate(
        buf,
        pagesize=A4,
        leftMargin=15 * mm,
        rightMargin=15 * mm,
        topMargin=14 * mm,
        bottomMargin=14 * mm,
        title=f"{sheet.job}: stencil instructions",
        author="stencil_cad",
        invariant=1,
    )
    with _binary_streams():
        doc.build(story)
    return buf.getvalue()


@contextlib.contextmanager
def _binary_streams() -> Iterator[None]:
    """ReportLab's streams left binary (only Flate), not also ASCII85-encoded, while the sheet is made.

    ASCII85 makes a stream 25 % longer and costs time to encode: the bundled example's sheet took 0.81
    CPU-s and 9.3 MB with it, 0.61 CPU-s and 7.5 MB without (median of 5 ``render_pdf`` calls, the same
    pages). ``useA85`` is a process-wide ReportLab setting, so one sheet is made at a time (the studio
    makes sheets in threads) and the setting is put back afterwards.
    """
    from reportlab import rl_config

    with _SHEET_LOCK:
        before = rl_config.useA85
        rl_config.useA85 = 0
        try:
            yield
        finally:
            rl_config.useA85 = before


def _tile_drawing(tiles: Sequence[mural.MapTile], width_mm: float, height_mm: float, width_pt: float) -> Any:
    from reportlab.graphics.shapes import Drawing, Rect, String
    from reportlab.lib import colors

    s = width_pt / max(width_mm, height_mm, 1e-9)
    d = Drawing(width_mm * s + 2, height_mm * s + 2)
    d.add(
        Rect(1, 1, width_mm * s, height_mm * s, fillColor=colors.HexColor("#f4f4f4"), strokeColor=colors.grey)
    )
    for t in tiles:
        x, y, tw, th = t.x_mm, t.y_mm, t.width_mm, t.height_mm
        d.add(
            Rect(
                1 + x * s,
                1 + y * s,
                tw * s,
                th * s,
                fillColor=None,
                strokeColor=colors.black,
                strokeWidth=1.2,
            )
        )
        name = t.name
        d.add(String(1 + (x + tw / 2) * s, 1 + (y + th / 2) * s, name, textAnchor="middle", fontSize=9))
    return d
