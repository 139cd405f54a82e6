"""The interlocking wall: a frame on the surface that holds every plate at its stand-off height.

Cross-section, from the surface (z = 0) up::

    z = s + p  ┌──rim──┐            pocket (plate outline + clearance), depth p
               │       └────ledge───┐
    z = s      │                    │ inner opening (picture area + opening margin)
    z = 0      └────────────────────┘

The frame's inner face is the picture's edge (or just beyond it), so it never shadows the
picture and keeps overspray inside it. The pocket is the plate outline offset outward by the
clearance, notches included, so the keyed plate drops in one way only and every layer's
plate sits in the same place. The wall prints as built: base on the bed, pocket on top, no
overhangs. Coordinates are the picture frame (mm, picture area ``[0, w] x [0, h]``), the
frame the plates use, so a plate moved up by the stand-off sits exactly in its pocket.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..config.cad import WallConfig
from ..config.outline import OutlineConfig
from ..exchange.step import STEP_TIMESTAMP
from ..outline import Segment, check_key, fits, min_clearance, outline_path, path_area, path_ring
from . import occt
from .solid import check_simple_solid

__all__ = ["WallModel", "WallSolid", "build_wall", "wall_solid", "wall_step", "wall_stl"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WallRings:
    """The three outlines a wall is made of, as exact paths (picture frame, mm).

    Attributes:
        outer: The wall's outside: the pocket grown by the wall thickness.
        pocket: The plate outline grown by the clearance.
        opening: The inner opening, a rectangle around the picture area.
    """

    outer: list[Segment]
    pocket: list[Segment]
    opening: list[Segment]


def _rect_path(x0: float, y0: float, x1: float, y1: float) -> list[Segment]:
    pts = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    return [Segment(pts[i], pts[(i + 1) % 4]) for i in range(4)]


def wall_rings(
    width_mm: float, height_mm: float, outline_cfg: OutlineConfig, wall_cfg: WallConfig
) -> WallRings:
    """The outer, pocket and opening outlines of a wall.

    The outer outline follows the pocket (tabs included) at the wall thickness; where the
    grown tabs would reach a corner or each other, it falls back to a rounded rectangle that
    encloses every notch with at least the wall thickness.
    """
    c, t = wall_cfg.clearance_mm, wall_cfg.wall_thickness_mm
    pocket = outline_path(width_mm, height_mm, outline_cfg, c)
    try:
        outer = outline_path(width_mm, height_mm, outline_cfg, c + t)
    except ValueError:
        log.info("wall: the key tabs are too close to fit the rim's shape; using a plain rounded rectangle")
        plain = outline_cfg.model_copy(update={"keys": []})
        outer = outline_path(width_mm, height_mm, plain, c + t + max(k.depth_mm for k in outline_cfg.keys))
    o = wall_cfg.opening_margin_mm
    opening = _rect_path(-o, -o, width_mm + o, height_mm + o)
    return WallRings(outer=outer, pocket=pocket, opening=opening)


def _wire(path: list[Segment], z: float):
    edges = []
    for s in path:
        p0, p1 = (*s.start, z), (*s.end, z)
        edges.append(occt.arc_edge(p0, (*s.midpoint(), z), p1) if s.is_arc else occt.line_edge(p0, p1))
    return occt.wire(edges)


def _prism(path: list[Segment], z0: float, z1: float):
    # The face's normal follows the wire's sense and may point down, so the extrusion is given
    # as a signed height along z; the wall's box is checked by its caller.
    return occt.prism(occt.planar_face(_wire(path, z0)), z1 - z0)


@dataclass(frozen=True)
class WallSolid:
    """A wall's OCCT solid and the figures it was made from.

    Attributes:
        rings: The wall's outlines.
        standoff_mm: Height of the plate's underside above the surface, in mm.
        pocket_depth_mm: Depth of the plate's pocket, in mm.
        total_height_mm: The wall's height, in mm.
        slot_volume_mm3: The finger slot's volume in mm³ (0 without one).
        shape: A compound of the one solid (the shape a build123d ``Part`` wraps), picture frame.
    """

    rings: WallRings
    standoff_mm: float
    pocket_depth_mm: float
    total_height_mm: float
    slot_volume_mm3: float
    shape: Any

    @property
    def analytic_volume_mm3(self) -> float:
        """Volume in mm³ from the exact outline areas: A_outer·H − A_open·s − A_pocket·p − finger slot."""
        r = self.rings
        return (
            path_area(r.outer) * self.total_height_mm
            - path_area(r.opening) * self.standoff_mm
            - path_area(r.pocket) * self.pocket_depth_mm
            - self.slot_volume_mm3
        )


def wall_solid(
    width_mm: float,
    height_mm: float,
    outline: OutlineConfig,
    wall: WallConfig,
    plate_thickness_mm: float,
    standoff_mm: float,
) -> WallSolid:
    """The interlocking wall's solid (the kernel of :func:`build_wall` and of the build123d part ``Wall``).

    Args:
        width_mm: Picture width in mm.
        height_mm: Picture height in mm.
        outline: The plate's outline config (margin, key).
        wall: Wall config (clearance, thickness, opening, pocket depth).
        plate_thickness_mm: The plate's thickness in mm.
        standoff_mm: Height in mm of the plate's underside above the surface.

    Raises:
        ValueError: If the sizes do not make a wall (naming the value and its limit).
    """
    if plate_thickness_mm <= 0:
        raise ValueError(f"plate thickness must be > 0 mm, got {plate_thickness_mm}")
    if standoff_mm < 0.5:
        raise ValueError(f"wall stand-off must be ≥ 0.5 mm, got {standoff_mm}")
    wall.check_plate(outline, plate_thickness_mm)
    rings = wall_rings(width_mm, height_mm, outline, wall)
    s = float(standoff_mm)
    depth = float(wall.pocket_depth(plate_thickness_mm))
    top = s + depth
    solid = _prism(rings.outer, 0.0, top)
    # Cutters overshoot the faces they open so no coplanar boolean is left to chance.
    cutters = [_prism(rings.opening, -1.0, top + 1.0), _prism(rings.pocket, s, top + 1.0)]
    slot = _finger_slot(width_mm, height_mm, outline, wall, s, top)
    if slot is not None:
        cutters.append(slot[0])
    shape = occt.in_compound(occt.unify(occt.cut(solid, cutters)))
    return WallSolid(rings, s, depth, top, 0.0 if slot is None else slot[1], shape)


def _finger_slot(
    width_mm: float,
    height_mm: float,
    outline: OutlineConfig,
    wall: WallConfig,
    standoff_mm: float,
    top: float,
) -> tuple[Any, float] | None:
    """The slot cutter at the middle of the top side and its analytic volume, or None."""
    fw = wall.finger_slot_mm
    if fw <= 0:
        return None
    m, c, t = outline.border_mm, wall.clearance_mm, wall.wall_thickness_mm
    if fw > 0.5 * width_mm:
        # On pictures under about 13 mm wide the slot's analytic volume stopped matching the
        # B-rep (measured); a slot wider than half the picture is no use anyway, so leave it out.
        log.warning(
            "wall.finger_slot_mm (%.3g mm) left out: it needs a picture at least twice as wide (%.3g mm)",
            fw,
            width_mm,
        )
        return None
    x0, x1 = 0.5 * (width_mm - fw), 0.5 * (width_mm + fw)
    if x0 < -m + outline.corner_radius_mm:
        raise ValueError(
            f"wall.finger_slot_mm ({fw} mm) must leave the rounded corners alone: at most "
            f"{width_mm + 2 * (m - outline.corner_radius_mm):g} mm for this plate"
        )
    for i, k in enumerate(outline.keys):
        if k.side.value != "top":
            continue
        a = k.position * width_mm - 0.5 * k.width_mm - c - t
        b = k.position * width_mm + 0.5 * k.width_mm + c + t
        if a < x1 and b > x0:
            raise ValueError(
                f"wall.finger_slot_mm ({fw} mm) meets plate.outline.keys[{i}] on the top side: "
                "move the tab, narrow the slot, or set finger_slot_mm to 0"
            )
    ledge = m + c - wall.opening_margin_mm
    under = min(3.0, ledge - 1.0)  # keeps ≥ 1 mm of ledge under the plate at the slot
    below = min(1.5, 0.5 * standoff_mm)
    y_pocket = height_mm + m + c
    z0 = standoff_mm - below
    volume = fw * (t * (top - z0) + max(under, 0.0) * below)
    corner = (x0, y_pocket - max(under, 0.0), z0)
    return occt.box(corner, (fw, t + 1.0 + max(under, 0.0), top + 1.0 - z0)), volume


@dataclass(frozen=True)
class WallModel:
    """A built wall and the figures that check it.

    Attributes:
        shape: The OCCT shape (one solid, in a compound when unnotched), picture frame, z = 0
            on the surface.
        volume_mm3: Analytic volume in mm³ from the exact outline areas.
        standoff_mm: Height of the plate's underside above the surface, in mm.
        height_mm: Total height of the wall, in mm.
        pocket_depth_mm: Depth of the plate's pocket, in mm.
        bbox: Expected bounding box ``(xmin, ymin, zmin, xmax, ymax, zmax)`` in mm.
        outer_ring: ``(M, 2)`` ring of the wall's outside (sampled).
        pocket_ring: ``(M, 2)`` ring of the pocket (sampled).
        ledge_mm: Smallest width in mm of the ledge the plate rests on.
        rings: The exact outlines the wall is made of.
    """

    shape: Any
    volume_mm3: float
    standoff_mm: float
    height_mm: float
    pocket_depth_mm: float
    bbox: tuple[float, float, float, float, float, float]
    outer_ring: np.ndarray
    pocket_ring: np.ndarray
    ledge_mm: float
    rings: WallRings

    @property
    def name(self) -> str:
        """A file-name stem, e.g. ``wall_10mm`` or ``wall_7.5mm``."""
        return f"wall_{self.standoff_mm:g}mm"

    @cached_property
    def part(self):
        """The wall as a build123d shape (made on first use: a job needs only :attr:`shape`)."""
        import build123d as bd
        from OCP.TopAbs import TopAbs_COMPOUND

        return bd.Part(self.shape) if self.shape.ShapeType() == TopAbs_COMPOUND else bd.Solid(self.shape)


def build_wall(
    width_mm: float,
    height_mm: float,
    outline_cfg: OutlineConfig,
    wall_cfg: WallConfig,
    plate_thickness_mm: float,
    standoff_mm: float,
) -> WallModel:
    """Build the wall for one stand-off height.

    Args:
        width_mm: Picture width in mm.
        height_mm: Picture height in mm.
        outline_cfg: The plate's outline config.
        wall_cfg: Wall config.
        plate_thickness_mm: The plate's thickness in mm.
        standoff_mm: Height in mm of the plate's underside above the surface (one of
            :meth:`~stencil_cad.config.WallConfig.heights`).

    Returns:
        The wall with its analytic volume and expected bounding box.

    Raises:
        ValueError: If the config cannot make a wall, or the key does not stop a wrong placement.
    """
    check_key(width_mm, height_mm, outline_cfg, wall_cfg.clearance_mm)
    wall = wall_solid(width_mm, height_mm, outline_cfg, wall_cfg, plate_thickness_mm, standoff_mm)
    tol = outline_cfg.chord_tol_mm
    outer = path_ring(wall.rings.outer, tol)
    pocket = path_ring(wall.rings.pocket, tol)
    opening = np.array([s.start for s in wall.rings.opening], dtype=np.float64)
    ledge = _ledge_width(opening, pocket)
    if ledge < 1.0 - 2.0 * tol:
        raise ValueError(
            f"the ledge under the plate is {ledge:.3f} mm wide at its narrowest, must be ≥ 1 mm: "
            "reduce wall.opening_margin_mm or plate.outline.corner_radius_mm"
        )
    lo, hi = outer.min(axis=0), outer.max(axis=0)
    bbox = (float(lo[0]), float(lo[1]), 0.0, float(hi[0]), float(hi[1]), wall.total_height_mm)
    return WallModel(
        shape=wall.shape,
        volume_mm3=wall.analytic_volume_mm3,
        standoff_mm=wall.standoff_mm,
        height_mm=wall.total_height_mm,
        pocket_depth_mm=wall.pocket_depth_mm,
        bbox=bbox,
        outer_ring=outer,
        pocket_ring=pocket,
        ledge_mm=ledge,
        rings=wall.rings,
    )


def _ledge_width(opening: np.ndarray, pocket: np.ndarray) -> float:
    if not fits(opening, pocket):
        return -math.inf
    return min_clearance(opening, pocket)


def wall_step(model: WallModel, path: str | Path) -> None:
    """Write the wall as STEP (AP214, mm, exact arcs) to ``path``: the same wall, the same bytes.

    The header's time stamp is the plates' fixed one (:data:`~stencil_cad.exchange.step.STEP_TIMESTAMP`).
    """
    occt.write_step(model.shape, path, model.name, "stencil_cad wall", STEP_TIMESTAMP)


def wall_stl(
    model: WallModel, path: str | Path, tolerance_mm: float = 0.01, angular_tolerance: float = 0.1
) -> None:
    """Write the wall as binary STL to ``path``.

    The wall has a few dozen faces, so OCCT's incremental mesher is quick here (unlike the
    perforated plate).

    Args:
        model: The wall.
        path: Output file.
        tolerance_mm: Largest chord error in mm. Defaults to 0.01 mm.
        angular_tolerance: Largest angle between neighbouring facets on a curve, in
            radians. Defaults to 0.1.
    """
    occt.write_stl(model.shape, path, tolerance_mm, angular_tolerance)


class WallCheckError(RuntimeError):
    """A built wall failed its checks (not one valid solid, or the volume is off)."""


def check_wall(model: WallModel, rel_tol: float = 1e-6) -> dict:
    """Check a wall against its analytic oracle.

    The wall has a few dozen faces, so the full ``BRepCheck_Analyzer`` is cheap here.

    Args:
        model: The wall.
        rel_tol: Largest relative volume error. Defaults to 1e-6.

    Returns:
        ``n_solids``, ``valid``, ``volume``, ``analytic_volume``, ``rel_error``, ``bbox``.

    Raises:
        WallCheckError: Naming the failed check.
    """
    return check_simple_solid(
        model.shape, model.volume_mm3, model.bbox, f"wall {model.name}", WallCheckError, rel_tol
    )
