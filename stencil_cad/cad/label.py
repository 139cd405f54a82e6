"""The plate's label: what it says, and its glyphs (an up-arrow and the text) laid out in the border.

The text is shrunk to fit its area, shortened when it still does not fit, and its glyph
rings are checked for crossings; :mod:`.solid` turns them into the relief.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..geometry import as_ccw, as_cw, rings_cross
from .solid import PlateBuildError
from .text import FONT_LOCK, text_rings


@dataclass(frozen=True)
class LabelInfo:
    """What the label on a plate says.

    Attributes:
        layer: Layer number, 1-based.
        layers: How many layers the job has.
        colour: Paint colour, a name or ``#rrggbb``.
        job: Job name.
        spray_order: Position in the spray order (defaults to the layer number).
        tile: A mural tile's name and grid, e.g. ``"B3 of 2x4"``, or empty.
    """

    layer: int
    layers: int
    colour: str = ""
    job: str = ""
    spray_order: int | None = None
    tile: str = ""

    @property
    def order(self) -> int:
        """Spray order (1 = first)."""
        return self.layer if self.spray_order is None else int(self.spray_order)


def label_text(label: LabelInfo) -> str:
    """The label's text, e.g. ``"L2/4  SPRAY 2  #1A2B3C  portrait"``."""
    parts = [f"L{label.layer}/{label.layers}", f"SPRAY {label.order}"]
    if label.tile:
        parts.insert(0, f"TILE {label.tile}")
    if label.colour:
        parts.append(str(label.colour).upper() if str(label.colour).startswith("#") else str(label.colour))
    if label.job:
        parts.append(str(label.job))
    return "  ".join(parts)


# ----------------------------------------------------------------------------- label glyphs


def _face_rings(face, tol: float) -> tuple[np.ndarray | None, list[np.ndarray]]:
    """Polygon rings of a planar face's outer and inner wires (chord error ≤ tol)."""
    from OCP.BRepAdaptor import BRepAdaptor_Curve
    from OCP.BRepTools import BRepTools, BRepTools_WireExplorer
    from OCP.GCPnts import GCPnts_QuasiUniformDeflection
    from OCP.TopAbs import TopAbs_REVERSED, TopAbs_WIRE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    outer_w = BRepTools.OuterWire_s(face)
    rings_out: np.ndarray | None = None
    rings_in: list[np.ndarray] = []
    exp = TopExp_Explorer(face, TopAbs_WIRE)
    while exp.More():
        wire = TopoDS.Wire_s(exp.Current())
        pts = []
        wexp = BRepTools_WireExplorer(wire, face)
        while wexp.More():
            edge = wexp.Current()
            curve = BRepAdaptor_Curve(edge)
            u0, u1 = curve.FirstParameter(), curve.LastParameter()
            disc = GCPnts_QuasiUniformDeflection(curve, tol, u0, u1)
            us = [disc.Parameter(k) for k in range(1, disc.NbPoints() + 1)] if disc.IsDone() else [u0, u1]
            if edge.Orientation() == TopAbs_REVERSED:
                us = us[::-1]
            for u in us[:-1]:
                p = curve.Value(u)
                pts.append((p.X(), p.Y()))
            wexp.Next()
        ring = _clean_ring(np.asarray(pts, dtype=np.float64))
        if len(ring) >= 3:
            if wire.IsSame(outer_w):
                rings_out = as_ccw(ring)
            else:
                rings_in.append(as_cw(ring))
        exp.Next()
    return rings_out, rings_in


def _clean_ring(ring: np.ndarray, eps: float = 1e-6) -> np.ndarray:
    """Drop repeated vertices (and a repeated closing vertex) of a ring."""
    if len(ring) == 0:
        return ring
    keep = np.linalg.norm(np.diff(ring, axis=0, append=ring[:1]), axis=1) > eps
    return ring[keep]


def _arrow(width: float, height: float) -> np.ndarray:
    """An up-arrow polygon in ``[0, width] x [0, height]``, counter-clockwise."""
    sw, hh = 0.34 * width, 0.48 * height
    cx = 0.5 * width
    return np.array(
        [
            [cx - sw / 2, 0.0],
            [cx + sw / 2, 0.0],
            [cx + sw / 2, height - hh],
            [width, height - hh],
            [cx, height],
            [0.0, height - hh],
            [cx - sw / 2, height - hh],
        ]
    )


DEFAULT_FONT = "DejaVu Sans"


def _bundled_font() -> str | None:
    from importlib import resources

    path = resources.files("stencil_cad") / "data" / "DejaVuSans-Bold.ttf"
    return str(path) if path.is_file() else None


def _text_glyphs(text: str, size: float, font: str, tol: float) -> list:
    """Glyph polygons of a text line, its ink's low corner at the origin."""
    # The default font ships with the package, so labels do not depend on the system's fonts;
    # its letters are read from the file by fontTools (:mod:`.text`), without the CAD kernel.
    font_path = _bundled_font() if font == DEFAULT_FONT else None
    if font_path is not None:
        glyphs = text_rings(text, size, font_path, tol)
    else:
        glyphs = []
        for f in _build123d_faces(text, size, font):
            outer, inner = _face_rings(f, tol)
            if outer is not None:
                glyphs.append((outer, inner))
    # OCCT lists another font's faces in an order that differs between processes (the dot and
    # the stem of an "i" swap places), so sort them all: the same label gives the same file bytes
    # in every process and on every worker.
    glyphs.sort(key=lambda g: (*np.round(g[0].min(axis=0), 6), *np.round(g[0].max(axis=0), 6)))
    return glyphs


def _build123d_faces(text: str, size: float, font: str) -> list:
    """The faces of ``text`` in a system font, by build123d's ``Text`` (which knows its single-stroke fonts)."""
    from build123d import Align, FontStyle, Text

    with FONT_LOCK:  # OCCT's font manager is one per process and not thread-safe
        sketch = Text(
            text, font_size=size, font=font, font_style=FontStyle.BOLD, align=(Align.MIN, Align.MIN)
        )
    return [f.wrapped for f in sketch.faces()]


def _label_candidates(label: LabelInfo) -> list[str]:
    """The label's texts, longest first: a small plate still gets its layer number and order."""
    candidates = [label_text(label)]
    for shorter in (replace(label, job=""), replace(label, job="", colour="")):
        if label_text(shorter) not in candidates:
            candidates.append(label_text(shorter))
    candidates.append((f"{label.tile.split()[0]} " if label.tile else "") + f"L{label.layer}/{label.layers}")
    return candidates


@dataclass(frozen=True)
class _FittedText:
    """A label text set at a size that fits its area, with the layout figures of that size (mm)."""

    text: str
    size: float
    pad: float
    glyphs: list
    tlo: np.ndarray
    thi: np.ndarray
    cap: float
    arrow_w: float
    gap: float


def _fit_text(
    text: str, aw: float, ah: float, height_mm: float, min_height_mm: float, font: str, tolerance_mm: float
) -> _FittedText | None:
    """``text`` with the arrow set at ``height_mm``, shrunk to fit ``aw`` x ``ah`` mm; None below ``min_height_mm``."""
    size = float(height_mm)
    for _ in range(4):
        pad = max(0.3, 0.1 * size)
        glyphs = _text_glyphs(text, size, font, tolerance_mm)
        allp = np.concatenate([g[0] for g in glyphs]) if glyphs else np.zeros((1, 2))
        tlo, thi = allp.min(axis=0), allp.max(axis=0)
        cap = 0.72 * size
        arrow_w, gap = 0.7 * cap, 0.5 * size
        need_w = arrow_w + gap + (thi[0] - tlo[0]) + 2 * pad
        need_h = max(thi[1], cap) - min(tlo[1], 0.0) + 2 * pad
        scale = min(aw / need_w, ah / need_h, 1.0)
        if scale >= 1.0:
            return _FittedText(text, size, pad, glyphs, tlo, thi, cap, arrow_w, gap)
        size = size * scale * 0.98
        if size < min_height_mm:
            return None
    return None


def label_glyphs(
    label: LabelInfo,
    area: tuple[float, float, float, float],
    height_mm: float,
    min_height_mm: float,
    font: str,
    tolerance_mm: float,
) -> tuple[list, tuple[float, float, float, float], dict]:
    """The label's glyphs (up-arrow, then the text) laid out in the label area.

    The text is set at ``height_mm`` and shrunk to fit the area, never below
    ``min_height_mm``. The arrow points to the picture's top (+y); the text
    reads correctly only from above, so both show which way up the plate goes.

    Args:
        label: What the label says.
        area: ``(x0, y0, x1, y1)`` mm, the free rectangle in the border.
        height_mm: Font size in mm.
        min_height_mm: Smallest font size in mm.
        font: Font family.
        tolerance_mm: Chord error of the letter polygons in mm.

    Returns:
        ``(glyphs, box, info)``: glyph rings ``(outer, inners)`` in mm, the box
        ``(x0, y0, x1, y1)`` that holds them with a small pad, and layout figures.

    Raises:
        PlateBuildError: When the label does not fit at ``min_height_mm``.
    """
    x0, y0, x1, y1 = (float(v) for v in area)
    aw, ah = x1 - x0, y1 - y0
    candidates = _label_candidates(label)
    fit = None
    for text in candidates:
        fit = _fit_text(text, aw, ah, height_mm, min_height_mm, font, tolerance_mm)
        if fit is not None:
            break
    if fit is None:
        raise PlateBuildError(
            f"even the shortest label {candidates[-1]!r} does not fit the label area {aw:.1f} x {ah:.1f} mm at "
            f"the smallest font size {min_height_mm} mm (plate.label_min_height_mm); widen "
            "plate.outline.margin_mm, lower plate.label_min_height_mm, or set plate.label: none"
        )
    text, size, pad, glyphs = fit.text, fit.size, fit.pad, fit.glyphs
    tlo, thi, cap, arrow_w, gap = fit.tlo, fit.thi, fit.cap, fit.arrow_w, fit.gap
    # Vertical placement: centre the text's ink (and the arrow) in the area.
    ink_lo, ink_hi = min(tlo[1], 0.0), max(thi[1], cap)
    dy = y0 + 0.5 * (ah - (ink_hi - ink_lo)) - ink_lo
    dx = x0 + pad
    arrow = _arrow(arrow_w, cap) + [dx, dy]
    shift = np.array([dx + arrow_w + gap - tlo[0], dy])
    placed = [(arrow, [])] + [(o + shift, [i + shift for i in inn]) for o, inn in glyphs]
    if rings_cross([r for outer, inner in placed for r in (outer, *inner)]):
        raise PlateBuildError(
            f"the label's letters overlap or self-intersect at font size {size:.2f} mm with font {font!r}; "
            "choose another plate.label_font"
        )
    allp = np.concatenate([g[0] for g in placed])
    lo, hi = allp.min(axis=0) - pad, allp.max(axis=0) + pad
    box = (max(lo[0], x0), max(lo[1], y0), min(hi[0], x1), min(hi[1], y1))
    info = {"text": text, "font_size_mm": round(size, 3), "font": font, "glyphs": len(placed)}
    return placed, box, info
