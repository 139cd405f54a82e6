"""SVG of a stencil plate for cutters whose software takes SVG but not DXF (kernel-free).

Glowforge's app, Cricut Design Space and Silhouette Studio read SVG (and PDF) but not DXF.
The SVG holds the same drawing as the DXF (:mod:`stencil_cad.dxf`): the same kerf
compensation and the same shift into the +X/+Y quadrant, so a point at ``(x, y)`` in the
DXF is at ``(x, H - y)`` in the SVG, where ``H`` is the drawing's height (SVG's y axis
points down). Units are millimetres: ``width``/``height`` carry ``mm`` and the
``viewBox`` spans the drawing one user unit per mm.

Each round hole is one ``<circle>``; each hard-mode cut-out is one ``<path>`` (its outer
ring and the rings of the islands it keeps, even-odd filled); the plate outline is the last
``<path>``, so software that cuts in document order frees the plate last. Holes and outline
are the cut group ``#cut`` in red; the label (the plate's own letters, as outlines) is the
score group ``#score`` in blue, first in the document, to engrave or score. Every element
is stroked, not filled: cutters read strokes as cut lines.
"""

from __future__ import annotations

import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .dxf import DxfStencil, _extent, _iter_polygons, _prepare

__all__ = ["SvgInfo", "write_svg"]

# Stroke width in mm: thin enough to read as a cut line, wide enough to see on screen.
STROKE_MM = 0.1
CUT_COLOUR = "#ff0000"
#: The outline is cut like the holes: the same colour, so a cutter runs it in the same operation.
OUTLINE_COLOUR = CUT_COLOUR
#: The label (letters as outlines) to engrave or score: a colour of its own.
SCORE_COLOUR = "#0000ff"


@dataclass(frozen=True)
class SvgInfo:
    """What was written.

    Attributes:
        path: The file written.
        offset_mm: ``(dx, dy)`` added to picture-frame coordinates (the same as the DXF's).
        size_mm: ``(width, height)`` of the drawing in mm.
        circles: ``<circle>`` elements written (one per hole).
        paths: ``<path>`` elements written (cut-outs and the outline).
        score_paths: ``<path>`` elements of the label on the score group.
    """

    path: str
    offset_mm: tuple[float, float]
    size_mm: tuple[float, float]
    circles: int
    paths: int
    score_paths: int = 0


def _ring_d(ring: np.ndarray, height: float) -> str:
    pts = [f"{x:.4f},{height - y:.4f}" for x, y in np.asarray(ring, dtype=np.float64).tolist()]
    return "M" + " L".join(pts) + " Z"


def write_svg(path: str | Path, stencil: DxfStencil, kerf_mm: float = 0.0, title: str = "") -> SvgInfo:
    """Write one stencil as an SVG cut file in millimetres.

    Args:
        path: Output file.
        stencil: The plate's outline and cuts in the picture frame (as for the DXF).
        kerf_mm: Cutter kerf in mm to compensate for, as in the DXF. Defaults to 0.
        title: Text of the SVG ``<title>`` (e.g. the job and layer). Defaults to none.

    Returns:
        What was written.

    Raises:
        ValueError: On bad input (negative kerf, kerf wider than a hole).
    """
    if kerf_mm < 0:
        raise ValueError(f"kerf_mm must be ≥ 0, got {kerf_mm}")
    outline, circles, rings = _prepare(stencil, kerf_mm)
    lo, hi = _extent(outline, circles, rings)
    shift = -lo
    width, height = (hi - lo).tolist()
    buf = io.StringIO()
    buf.write('<?xml version="1.0" encoding="UTF-8"?>\n')
    buf.write(
        f'<svg xmlns="http://www.w3.org/2000/svg" version="1.1" width="{width:.4f}mm" height="{height:.4f}mm" '
        f'viewBox="0 0 {width:.4f} {height:.4f}">\n'
    )
    if title:
        safe = title.replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")
        buf.write(f"<title>{safe}</title>\n")
    score = stencil.score_rings()
    if score:
        # The label first: software that works in document order scores it while the sheet is whole.
        label = (
            stencil.label.replace("&", "&amp;")
            .replace("<", "&lt;")
            .replace(">", "&gt;")
            .replace('"', "&quot;")
        )
        buf.write(
            f'<g id="score" fill="none" stroke="{SCORE_COLOUR}" stroke-width="{STROKE_MM}" '
            f'data-layer="{stencil.score_layer}" data-label="{label}">\n'
        )
        buf.write("".join(f'<path d="{_ring_d(r + shift, height)}"/>\n' for r in score))
        buf.write("</g>\n")
    buf.write(f'<g id="cut" data-layer="{stencil.layer_name}">\n')
    buf.write(
        f'<g id="cuts" fill="none" stroke="{CUT_COLOUR}" stroke-width="{STROKE_MM}" data-layer="{stencil.layer_name}">\n'
    )
    if len(circles):
        moved = circles.copy()
        moved[:, :2] += shift
        moved[:, 1] = height - moved[:, 1]
        buf.write("".join(f'<circle cx="{x:.4f}" cy="{y:.4f}" r="{r:.4f}"/>\n' for x, y, r in moved.tolist()))
    # _prepare returns each cut-out's outer ring followed by its islands; group them per cut-out.
    n_paths = 0
    k = 0
    for _outer, holes in _iter_polygons(stencil.polygons):
        group = rings[k : k + 1 + len(holes)]
        k += 1 + len(holes)
        d = " ".join(_ring_d(r + shift, height) for r in group)
        buf.write(f'<path fill-rule="evenodd" d="{d}"/>\n')
        n_paths += 1
    buf.write("</g>\n")
    buf.write(
        f'<path id="outline" fill="none" stroke="{OUTLINE_COLOUR}" stroke-width="{STROKE_MM}" '
        f'd="{_ring_d(outline + shift, height)}"/>\n'
    )
    buf.write("</g>\n</svg>\n")
    Path(path).write_text(buf.getvalue(), encoding="utf-8")
    return SvgInfo(
        path=str(path),
        offset_mm=(float(shift[0]), float(shift[1])),
        size_mm=(float(width), float(height)),
        circles=len(circles),
        paths=n_paths + 1,
        score_paths=len(score),
    )
