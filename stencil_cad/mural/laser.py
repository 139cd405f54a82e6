"""A laser-cut mural needs no printer: its wall becomes a frame of stacked rings, its posts stacks of discs.

With ``stipple.process: laser`` a mural's plates are cut from sheet; what holds them off the surface
is cut too, from thicker stock (plywood or acrylic):

* the **frame**: the shared wall (:func:`~stencil_cad.mural.wall_tiles`: every tile's plate has one
  size and one set of notches) cut as rings and glued in a stack. ``base`` rings (the wall's
  outside, notched where the grid lines cross it, less its inner opening) stacked to the stand-off,
  and one ``top`` ring (the outside less the plate's pocket) of the plates' own sheet, so the plate
  drops into the pocket and rests on the base's ledge, as in the printed wall;
* the **spacers**: each post of :mod:`.posts` as a stack of discs of the foot's radius with the
  pin's hole in the middle, threaded with the plate on a 2 mm pin (a steel dowel or a cut nail).

The base stock is the thickest of :data:`FRAME_STOCK_MM` that makes the stand-off in whole
sheets, so the plate stands exactly where the design put it. Every part is a closed outline with
its cuts inside, checked against the laser's bed (:func:`check_cut_part`); cut length and time
follow :func:`~stencil_cad.mural.cost.cut_seconds`.

Kernel-free.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..geometry import polygon_area
from .posts import post_plan, targets
from .seams import notched_ring
from .tiling import WALL_NOTCH_MM, TileGrid, cut_stand, wall_outline, wall_tiles

if TYPE_CHECKING:
    from ..config import JobConfig

__all__ = ["FRAME_STOCK_MM", "CutPart", "check_cut_part", "frame_stock", "laser_stand", "sheets_needed"]

#: Sheet thicknesses for the frame's base rings and the spacers, mm (plywood and acrylic stock).
FRAME_STOCK_MM = (1.5, 2.0, 3.0, 4.0, 5.0, 6.0)
#: Segments of a spacer disc's outline.
_DISC_SEGMENTS = 64


@dataclass(frozen=True)
class CutPart:
    """One laser-cut part of the stand, and how many to cut.

    Attributes:
        name: ``frame_base``, ``frame_top`` or ``spacer``.
        count: How many to cut.
        thickness_mm: The sheet it is cut from, mm.
        outline: ``(M, 2)`` closed outline (counter-clockwise, last point not repeated), mm.
        inner: Rings cut out inside the outline, mm.
        circles: ``(N, 3)`` round holes ``(x, y, r)`` inside the outline, mm.
    """

    name: str
    count: int
    thickness_mm: float
    outline: np.ndarray
    inner: tuple[np.ndarray, ...] = ()
    circles: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    @property
    def cut_mm(self) -> float:
        """Length of one part's cuts, mm: the outline, the inner rings and the holes."""
        rings = [self.outline, *self.inner]
        return sum(_perimeter(r) for r in rings) + float(2.0 * np.pi * np.sum(self.circles[:, 2]))

    @property
    def pierces(self) -> int:
        """Cuts that start anew on one part (one per ring and hole)."""
        return 1 + len(self.inner) + len(self.circles)

    @property
    def size_mm(self) -> tuple[float, float]:
        """``(w, h)`` of the part's bounding box, mm."""
        lo, hi = self.outline.min(axis=0), self.outline.max(axis=0)
        return float(hi[0] - lo[0]), float(hi[1] - lo[1])


def _perimeter(ring: np.ndarray) -> float:
    return float(np.sum(np.linalg.norm(np.roll(ring, -1, axis=0) - ring, axis=1)))


def frame_stock(standoff_mm: float) -> tuple[float, int]:
    """``(sheet mm, sheets)``: the thickest stock that makes ``standoff_mm`` in whole sheets.

    Raises:
        ValueError: No stock of :data:`FRAME_STOCK_MM` divides the stand-off (to 0.01 mm).
    """
    for t in sorted(FRAME_STOCK_MM, reverse=True):
        n = round(standoff_mm / t)
        if n >= 1 and abs(n * t - standoff_mm) <= 0.01:
            return t, n
    raise ValueError(
        f"a laser-cut frame stacks sheets of {', '.join(f'{t:g}' for t in FRAME_STOCK_MM)} mm: "
        f"none makes a {standoff_mm:g} mm stand-off in whole sheets; choose wall.standoff_mm as a multiple of one"
    )


def laser_stand(cfg: JobConfig, grid: TileGrid) -> list[CutPart] | None:
    """The frame's rings and the spacers of a laser-cut mural, or None when the plates are not laser-cut on tiles.

    Raises:
        ValueError: The stand-off cannot be stacked from stock (:func:`frame_stock`).
    """
    from ..outline import offset_outline

    if not cut_stand(cfg, grid):
        return None
    oc, wc = cfg.plate.outline, cfg.wall
    standoff = min(cfg.standoff.walls_mm)
    stock, n = frame_stock(standoff)
    first = next(t for t in grid.tiles if t.name in wall_tiles(grid))
    w, h = first.part_size
    outer, _ = notched_ring(wall_outline(w, h, cfg), first.part_lines(), WALL_NOTCH_MM)
    o = wc.opening_margin_mm
    opening = np.array([[-o, -o], [w + o, -o], [w + o, h + o], [-o, h + o]], dtype=np.float64)
    pocket = offset_outline(w, h, oc, wc.clearance_mm)
    parts = [
        CutPart("frame_base", n, stock, outer, (opening,)),
        CutPart("frame_top", 1, cfg.plate.planned_thickness_mm, outer, (pocket,)),
    ]
    plan = post_plan(cfg, grid)
    if plan is not None:
        most = max(len(targets(*t.size, plan.pitch_mm)) for t in grid.tiles)
        if most:
            a = np.linspace(0.0, 2.0 * np.pi, _DISC_SEGMENTS, endpoint=False)
            disc = plan.radius_mm * np.column_stack([np.cos(a), np.sin(a)])
            hole = np.array([[0.0, 0.0, plan.pin_hole_mm]])
            parts.append(CutPart("spacer", most * n, stock, disc, (), hole))
    return parts


def check_cut_part(part: CutPart, bed: tuple[float, float] | None) -> dict[str, Any]:
    """Check one part as the plates are checked: a closed outline, its cuts inside it, the bed.

    Returns:
        ``closed`` (a ring of at least 3 points, not repeating its first, with area), ``inside``
        (every inner ring and hole within the outline), ``fits`` (the bed either way round, True
        without a bed) and ``ok`` (all three), with the part's ``size_mm``.
    """
    from ..outline import fits as inside_of

    ring = np.asarray(part.outline, dtype=np.float64)
    closed = len(ring) >= 3 and not np.allclose(ring[0], ring[-1]) and abs(polygon_area(ring)) > 0.0
    pts = [np.asarray(r, dtype=np.float64) for r in part.inner]
    for x, y, r in part.circles:
        a = np.linspace(0.0, 2.0 * np.pi, 16, endpoint=False)
        pts.append(np.column_stack([x + r * np.cos(a), y + r * np.sin(a)]))
    # Every cut keeps some sheet between it and the outline.
    inside = all(inside_of(p, ring, clearance_mm=1e-6) for p in pts)
    w, h = part.size_mm
    fits = bed is None or (w <= bed[0] and h <= bed[1]) or (h <= bed[0] and w <= bed[1])
    return {
        "closed": bool(closed),
        "inside": inside,
        "fits": bool(fits),
        "ok": bool(closed and inside and fits),
        "size_mm": [round(w, 3), round(h, 3)],
    }


def sheets_needed(parts: list[CutPart], bed: tuple[float, float] | None) -> int:
    """Sheets of the bed's size the parts take: one per ring, the spacers packed on a grid on their own."""
    rings = sum(p.count for p in parts if p.name != "spacer")
    spacers = [p for p in parts if p.name == "spacer"]
    if not spacers or bed is None:
        return rings + (1 if spacers else 0)
    s = spacers[0]
    pitch = max(s.size_mm) + 2.0
    per_sheet = max(1, int(bed[0] // pitch) * int(bed[1] // pitch))
    return rings + math.ceil(s.count / per_sheet)
