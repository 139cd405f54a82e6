"""The card's printout, the paper it is sprayed on: wall outlines, ArUco markers, flat-field patches.

The printout (``card_sheet.pdf``; not the job's instruction sheet) is drawn as reflectance (1 = paper white, 0 = full black) in the sheet frame
(mm, x right, y up, origin at the sheet's bottom-left); :func:`printout_pdf` writes it at its
true size for printing at 100 %.
"""

from __future__ import annotations

import io
import math

import numpy as np

from ..frames import mm_to_px
from .layout import ARUCO_DICT, MARKER_MM, CardLayout, Footprint

__all__ = [
    "PAPER_MM",
    "aruco_dictionary",
    "card_steps",
    "printout_pdf",
    "printout_png",
    "printout_reflectance",
    "srgb_encode",
    "srgb_decode",
]

#: Resolution the sheet is drawn at (px per mm, 304.8 dpi).
SHEET_PX_PER_MM = 12.0


def aruco_dictionary():
    """The card's ArUco dictionary (``cv2.aruco``, OpenCV ≥ 4.7)."""
    import cv2

    return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, ARUCO_DICT))


def srgb_encode(linear: np.ndarray) -> np.ndarray:
    """Linear reflectance in [0, 1] to sRGB-encoded values in [0, 1] (IEC 61966-2-1)."""
    x = np.clip(linear, 0.0, 1.0)
    return np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)


def srgb_decode(encoded: np.ndarray) -> np.ndarray:
    """sRGB-encoded values in [0, 1] to linear light (IEC 61966-2-1)."""
    v = np.clip(encoded, 0.0, 1.0)
    return np.where(v <= 0.04045, v / 12.92, np.power((v + 0.055) / 1.055, 2.4))


def _fill_rect(img: np.ndarray, x0: float, y0: float, x1: float, y1: float, value: float, ppm: float) -> None:
    h = img.shape[0]
    c0, c1 = int(round(x0 * ppm)), int(round(x1 * ppm))
    r0, r1 = int(round(h - y1 * ppm)), int(round(h - y0 * ppm))
    img[max(r0, 0) : max(r1, 0), max(c0, 0) : max(c1, 0)] = value


def _draw_marker(img: np.ndarray, fp: Footprint, k: int, ppm: float) -> None:
    import cv2

    side = int(round(MARKER_MM * ppm))
    mark = (
        cv2.aruco.generateImageMarker(aruco_dictionary(), int(fp.marker_ids[k]), side).astype(np.float64)
        / 255.0
    )
    cx, cy = fp.origin_mm[0] + fp.markers[k, 0], fp.origin_mm[1] + fp.markers[k, 1]
    c0 = int(round((cx - MARKER_MM / 2.0) * ppm))
    r0 = int(round(img.shape[0] - (cy + MARKER_MM / 2.0) * ppm))
    img[r0 : r0 + side, c0 : c0 + side] = mark


def _draw_ring(img: np.ndarray, ring_mm: np.ndarray, width_mm: float, value: float, ppm: float) -> None:
    from skimage.draw import polygon_perimeter

    rc = mm_to_px(ring_mm, img.shape[0], 1.0 / ppm)
    for d in range(max(1, int(round(width_mm * ppm)))):
        rr, cc = polygon_perimeter(rc[:, 0] + d, rc[:, 1], shape=img.shape, clip=True)
        img[rr, cc] = value


def _text(img: np.ndarray, text: str, x_mm: float, y_mm: float, size_mm: float, ppm: float) -> None:
    from importlib.resources import files

    from PIL import Image, ImageDraw, ImageFont

    font = ImageFont.truetype(str(files("stencil_cad") / "data" / "DejaVuSans-Bold.ttf"), int(size_mm * ppm))
    layer = Image.new("L", (img.shape[1], img.shape[0]), 255)
    ImageDraw.Draw(layer).text((x_mm * ppm, img.shape[0] - y_mm * ppm), text, fill=0, font=font, anchor="ls")
    img[...] = np.minimum(img, np.asarray(layer, dtype=np.float64) / 255.0 * 0.75 + 0.25)


def printout_reflectance(
    layout: CardLayout, px_per_mm: float = SHEET_PX_PER_MM, text: bool = True
) -> np.ndarray:
    """The sheet as reflectance, row 0 at the top.

    Args:
        layout: The card.
        px_per_mm: Resolution. Defaults to :data:`SHEET_PX_PER_MM`.
        text: Draw the instructions and labels (the synthetic photos of the tests may leave them out).

    Returns:
        ``(H, W)`` float ndarray in [0, 1].
    """
    w, h = layout.sheet_mm
    img = np.ones((int(math.ceil(h * px_per_mm)), int(math.ceil(w * px_per_mm))), dtype=np.float64)
    for fp in layout.footprints:
        ox, oy = fp.origin_mm
        _draw_ring(img, fp.outer_ring + np.array([ox, oy]), 0.3, 0.55, px_per_mm)
        for k in range(4):
            _draw_marker(img, fp, k, px_per_mm)
        for level, x0, y0, x1, y1 in fp.flat_patches:
            if level < 1.0:
                _fill_rect(img, ox + x0, oy + y0, ox + x1, oy + y1, level, px_per_mm)
        if text:
            lo = fp.outer_ring.min(axis=0)
            _text(
                img,
                f"wall {fp.standoff_mm:g} mm: set the wall on this outline",
                ox + lo[0],
                oy + lo[1] - 4.0,
                3.0,
                px_per_mm,
            )
    if text:
        # A 50 mm bar to check that the sheet was printed at 100 %.
        _fill_rect(img, w - 58.0, 2.0, w - 8.0, 3.0, 0.0, px_per_mm)
        _text(img, "50 mm (print at 100 %)", w - 58.0, 4.0, 2.2, px_per_mm)
    return img


def printout_png(layout: CardLayout, px_per_mm: float = SHEET_PX_PER_MM) -> np.ndarray:
    """The sheet as an sRGB ``(H, W, 3)`` float image in [0, 1] for :meth:`OutputDir.write_png`."""
    ref = srgb_encode(printout_reflectance(layout, px_per_mm))
    return np.repeat(ref[..., None], 3, axis=2)


#: Paper sizes the card's page is printed on, in mm (ISO 216 A4, US Letter).
PAPER_MM: dict[str, tuple[float, float]] = {"a4": (210.0, 297.0), "letter": (215.9, 279.4)}
#: White border of the page around the sheet and the steps, mm (inside most printers' margins).
PAGE_MARGIN_MM = 10.0


def card_steps(layout: CardLayout, distance_mm: float, speed_m_s: float, paint: str = "") -> list[str]:
    """The steps printed on the card's page: set it up, spray it, photograph it, fit it.

    Args:
        layout: The card.
        distance_mm: Can distance the card is sprayed from, mm.
        speed_m_s: Sweep speed, m/s.
        paint: The paint being measured (free text), or empty.

    Returns:
        One sentence per step.
    """
    walls = ", ".join(f"{fp.standoff_mm:g} mm" for fp in layout.footprints)
    n = layout.passes
    return [
        "Print this page at 100 % (no 'fit to page'); check the 50 mm bar with a ruler. Tape it flat on "
        "the surface or on a board painted with your primer.",
        f"Set each wall ({walls}) on its printed outline; its rim covers the markers and grey patches.",
        f"Drop the card plate into a wall and spray {paint or 'the paint to measure'} with the cap you will "
        f"use: {n} even passes from about {distance_mm / 10.0:g} cm at about {speed_m_s:g} m/s, each pass "
        "starting and ending off the plate, each let to flash off before the next. Lift the plate "
        "straight up, repeat in the next wall, let the page dry.",
        "Photograph the whole page square on, in diffuse light, no flash or glare, filling most of the "
        "frame, in focus, every marker in view.",
        f"Run: stencil-cad calibrate PHOTO --card card.json --passes {n} --out my_can.yaml, then set "
        "spray.profile: my_can.yaml in your job.",
    ]


def printout_pdf(
    layout: CardLayout,
    px_per_mm: float = SHEET_PX_PER_MM,
    paper: str = "a4",
    steps: list[str] | None = None,
) -> bytes:
    """The sheet on an A4 or Letter page at its true size (print at 100 %), with the steps printed.

    The steps go under the sheet when they fit on its page, else on a second page.

    Args:
        layout: The card.
        px_per_mm: Resolution the sheet's raster is drawn at.
        paper: ``a4`` or ``letter``.
        steps: The steps (:func:`card_steps`), or None for none.

    Returns:
        The PDF's bytes.

    Raises:
        ValueError: An unknown paper, or a sheet larger than the page's printable area.
    """
    from PIL import Image
    from reportlab.lib.styles import ParagraphStyle
    from reportlab.lib.units import mm
    from reportlab.lib.utils import ImageReader
    from reportlab.pdfgen import canvas
    from reportlab.platypus import Frame, Paragraph

    if paper not in PAPER_MM:
        raise ValueError(f"paper must be one of {', '.join(PAPER_MM)}, got {paper!r}")
    pw, ph = PAPER_MM[paper]
    sw, sh = layout.sheet_mm
    if sw > pw - 2 * PAGE_MARGIN_MM or sh > ph - 2 * PAGE_MARGIN_MM:
        raise ValueError(
            f"the card's sheet ({sw:g} x {sh:g} mm) does not fit a {paper} page with {PAGE_MARGIN_MM:g} mm "
            "margins: use fewer stand-offs"
        )
    ref = srgb_encode(printout_reflectance(layout, px_per_mm))
    im = Image.fromarray((ref * 255.0 + 0.5).astype(np.uint8), mode="L")
    buf = io.BytesIO()
    c = canvas.Canvas(buf, pagesize=(pw * mm, ph * mm), invariant=1, pageCompression=1)
    c.setTitle("stencil-cad calibration card")
    x0 = (pw - sw) / 2.0
    top = ph - PAGE_MARGIN_MM
    c.drawImage(ImageReader(im), x0 * mm, (top - sh) * mm, sw * mm, sh * mm)
    style = ParagraphStyle("step", fontName="Helvetica", fontSize=9, leading=11.5, spaceAfter=3)
    head = ParagraphStyle("head", parent=style, fontName="Helvetica-Bold", fontSize=11, leading=14)
    paras = [Paragraph("Calibration card: how to spray and photograph it", head)] + [
        Paragraph(f"{k}. {_escape(t)}", style) for k, t in enumerate(steps or [], 1)
    ]
    room = top - sh - 5.0 - PAGE_MARGIN_MM
    need = sum(p.wrap((pw - 2 * PAGE_MARGIN_MM) * mm, ph * mm)[1] + 3 for p in paras) / mm
    if steps and need > room:
        c.showPage()
        room = ph - 2 * PAGE_MARGIN_MM
    if steps:
        frame = Frame(
            PAGE_MARGIN_MM * mm,
            PAGE_MARGIN_MM * mm,
            (pw - 2 * PAGE_MARGIN_MM) * mm,
            room * mm,
            showBoundary=0,
        )
        frame.addFromList(paras, c)
    c.showPage()
    c.save()
    return buf.getvalue()


def _escape(text: str) -> str:
    return text.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
