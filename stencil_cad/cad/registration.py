"""Sight notches for murals: V notches in a tile's wall rim on the tile's grid lines.

The notch shapes come from :func:`stencil_cad.mural.notch_triangles` (kernel-free); this
module only cuts them through the wall's full height and keeps the wall's analytic volume
exact (each notch removes its triangle times the wall height).
"""

from __future__ import annotations

import logging

import numpy as np

from ..geometry import point_ring_distance as _point_ring_distance
from ..geometry import points_in_ring as _inside
from ..mural.seams import notch_triangles
from ..mural.tiling import WALL_NOTCH_MM
from .wall import WallModel

log = logging.getLogger(__name__)

#: How far a notch prism reaches outside the rim and above/below the wall, in mm, so its
#: faces never coincide with the wall's.
_OVERCUT_MM = 0.5


def notch_wall(
    model: WallModel,
    lines: tuple[list[float], list[float]],
    sheet_w: float,
    finger_slot_mm: float,
    depth_mm: float = WALL_NOTCH_MM,
) -> tuple[WallModel, int]:
    """Cut a 90° V sight notch where each grid line crosses the wall's outer rim.

    Args:
        model: The wall (tile frame).
        lines: ``(xs, ys)`` grid lines in the tile frame, mm.
        sheet_w: Width of the tile's sheet in mm (the finger slot sits at its middle, on top).
        finger_slot_mm: Width of the finger slot in mm (no notch in it).
        depth_mm: Notch depth in mm. Defaults to :data:`~stencil_cad.mural.WALL_NOTCH_MM`.

    Returns:
        ``(wall, notches)``: the notched wall (analytic volume updated) and the count cut.
    """
    h = model.height_mm
    top = float(model.outer_ring[:, 1].max())
    cutters = []
    removed = 0.0
    triangles = notch_triangles(model.outer_ring, lines, depth_mm)
    if not triangles:
        return model, 0
    import build123d as bd  # a mural's walls only: a job's walls need no build123d

    for _, tri in triangles:
        apex = tri[1:2]
        if _inside(apex, model.pocket_ring)[0] or _point_ring_distance(apex, model.pocket_ring)[0] < 0.5:
            log.info("wall %s: no sight notch at %s (the rim is too thin there)", model.name, tri[1])
            continue
        on_top = abs(tri[0, 1] - top) < 1e-6
        if (
            on_top
            and finger_slot_mm > 0
            and abs(tri[1, 0] - 0.5 * sheet_w) < 0.5 * finger_slot_mm + depth_mm + 1.0
        ):
            continue
        u = (tri[2] - tri[0]) / np.hypot(*(tri[2] - tri[0]))
        n = tri[1] - 0.5 * (tri[0] + tri[2])
        n = n / np.hypot(*n)
        e = _OVERCUT_MM
        pts = [tri[0] - e * u - e * n, tri[1], tri[2] + e * u - e * n]
        wire = bd.Wire.make_polygon([bd.Vector(float(x), float(y), -e) for x, y in pts], close=True)
        cutters.append(bd.Solid.extrude(bd.Face(wire), bd.Vector(0, 0, h + 2 * e)))
        removed += depth_mm * depth_mm * h  # the triangle inside the rim: mouth 2d, depth d
    if not cutters:
        return model, 0
    part = model.part
    for c in cutters:
        part = part - c
    return model.cut(part.wrapped, removed), len(cutters)
