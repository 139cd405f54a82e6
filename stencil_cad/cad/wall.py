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

A job's wall is drawn as faces from its outlines (:mod:`.wall_brep`), written as STEP text and a
mesh by :mod:`stencil_cad.exchange.brep` and checked from that text, without OCCT: the example's
wall (150 mm, 5 mm stand-off) is built, checked and written in 0.03 CPU-s this way, against 0.10 s
through OCCT after the 0.9-1.0 s of its first wall's imports (``time.process_time`` about
``build_wall``, ``check_wall``, ``wall_step`` and ``wall_stl``), and its STEP file passes a check
like the plates' (one closed solid, its genus, the analytic volume to 1e-9); OCCT
cuts it (:func:`wall_solid`) when the maker asks for the kernel's checks and for a mural's
notched walls, and ``tests/cad/test_wall.py`` holds the drawn wall, read back by OCCT, to that
solid: the same volume, box and face count.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, replace
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from ..config.cad import WallConfig
from ..config.outline import OutlineConfig
from ..exchange.brep import Brep
from ..exchange.brep_check import check_brep_text
from ..exchange.mesh import stl_bytes
from ..exchange.step import STEP_TIMESTAMP
from ..outline import Segment, check_key, fits, min_clearance, outline_path, path_area, path_ring
from . import occt
from .solid import check_simple_solid
from .wall_brep import wall_brep

__all__ = ["WallModel", "WallSolid", "build_wall", "wall_solid", "wall_step", "wall_stl"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class WallRings:
    """The three outlines a wall is made of, as exact paths (picture frame, mm).

    Attributes:
        outer: The wall's outside: the pocket grown by the wall thickness.
        pocket: The plate outline grown by the clearance.
        opening: The inner opening, a rectangle around the picture area.
        rim_mm: The rim's thickness on the top side, from the pocket out: the wall thickness, or
            that plus the deepest tab's depth where the rim is a plain rounded rectangle.
    """

    outer: list[Segment]
    pocket: list[Segment]
    opening: list[Segment]
    rim_mm: float


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
    rim = t
    try:
        outer = outline_path(width_mm, height_mm, outline_cfg, c + t)
    except ValueError:
        log.info("wall: the key tabs are too close to fit the rim's shape; using a plain rounded rectangle")
        plain = outline_cfg.model_copy(update={"keys": []})
        rim = t + max(k.depth_mm for k in outline_cfg.keys)
        outer = outline_path(width_mm, height_mm, plain, c + rim)
    o = wall_cfg.opening_margin_mm
    opening = _rect_path(-o, -o, width_mm + o, height_mm + o)
    return WallRings(outer=outer, pocket=pocket, opening=opening, rim_mm=rim)


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
        return _volume(
            self.rings, self.standoff_mm, self.pocket_depth_mm, self.total_height_mm, self.slot_volume_mm3
        )


def _volume(rings: WallRings, standoff: float, depth: float, top: float, slot: float) -> float:
    """A wall's volume in mm³ from the exact outline areas (:attr:`WallSolid.analytic_volume_mm3`)."""
    return (
        path_area(rings.outer) * top
        - path_area(rings.opening) * standoff
        - path_area(rings.pocket) * depth
        - slot
    )


def _check_sizes(
    wall: WallConfig, outline: OutlineConfig, plate_thickness_mm: float, standoff_mm: float
) -> None:
    """Raise ValueError, naming the value, when the sizes make no wall."""
    if plate_thickness_mm <= 0:
        raise ValueError(f"plate thickness must be > 0 mm, got {plate_thickness_mm}")
    if standoff_mm < 0.5:
        raise ValueError(f"wall stand-off must be ≥ 0.5 mm, got {standoff_mm}")
    wall.check_plate(outline, plate_thickness_mm)


def wall_solid(
    width_mm: float,
    height_mm: float,
    outline: OutlineConfig,
    wall: WallConfig,
    plate_thickness_mm: float,
    standoff_mm: float,
) -> WallSolid:
    """The interlocking wall's OCCT solid (:func:`build_wall`'s with ``kernel``, and the build123d part ``Wall``'s).

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
    _check_sizes(wall, outline, plate_thickness_mm, standoff_mm)
    rings = wall_rings(width_mm, height_mm, outline, wall)
    s = float(standoff_mm)
    depth = float(wall.pocket_depth(plate_thickness_mm))
    top = s + depth
    solid = _prism(rings.outer, 0.0, top)
    # Cutters overshoot the faces they open so no coplanar boolean is left to chance.
    cutters = [_prism(rings.opening, -1.0, top + 1.0), _prism(rings.pocket, s, top + 1.0)]
    slot = _finger_slot(width_mm, height_mm, outline, wall, s, top, rings.rim_mm)
    if slot is not None:
        cutters.append(occt.box(slot.corner, slot.size))
    shape = occt.in_compound(occt.unify(occt.cut(solid, cutters)))
    return WallSolid(rings, s, depth, top, 0.0 if slot is None else slot.volume_mm3, shape)


@dataclass(frozen=True)
class SlotBox:
    """The finger slot's cutter: a box from its low corner, its sides, and the volume it takes from the wall (mm)."""

    corner: tuple[float, float, float]
    size: tuple[float, float, float]
    volume_mm3: float

    @property
    def faces(self) -> tuple[float, float, float, float, float]:
        """``(x0, x1, y of its back, y of its far side, z of its floor)``: what :func:`.wall_brep.wall_brep` cuts."""
        (x, y, z), (dx, dy, _) = self.corner, self.size
        return (x, x + dx, y, y + dy, z)


def _finger_slot(
    width_mm: float,
    height_mm: float,
    outline: OutlineConfig,
    wall: WallConfig,
    standoff_mm: float,
    top: float,
    rim_mm: float,
) -> SlotBox | None:
    """The slot cutter at the middle of the top side and its analytic volume, or None.

    It reaches from under the plate out through the rim, ``rim_mm`` thick on the top side.
    """
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
    volume = fw * (rim_mm * (top - z0) + max(under, 0.0) * below)
    corner = (x0, y_pocket - max(under, 0.0), z0)
    return SlotBox(corner, (fw, rim_mm + 1.0 + max(under, 0.0), top + 1.0 - z0), volume)


@dataclass(frozen=True)
class WallModel:
    """A built wall and the figures that check it.

    Attributes:
        volume_mm3: Analytic volume in mm³ from the exact outline areas.
        standoff_mm: Height of the plate's underside above the surface, in mm.
        height_mm: Total height of the wall, in mm.
        pocket_depth_mm: Depth of the plate's pocket, in mm.
        bbox: Expected bounding box ``(xmin, ymin, zmin, xmax, ymax, zmax)`` in mm.
        outer_ring: ``(M, 2)`` ring of the wall's outside (sampled).
        pocket_ring: ``(M, 2)`` ring of the pocket (sampled).
        ledge_mm: Smallest width in mm of the ledge the plate rests on.
        rings: The exact outlines the wall is made of.
        brep: The wall's faces drawn from its outlines (:mod:`.wall_brep`), which its files and
            check are made from without OCCT; None when the wall is OCCT's (notched, or asked for).
        solid: How to make the OCCT solid: the shape itself, or the arguments of :func:`wall_solid`.
    """

    volume_mm3: float
    standoff_mm: float
    height_mm: float
    pocket_depth_mm: float
    bbox: tuple[float, float, float, float, float, float]
    outer_ring: np.ndarray
    pocket_ring: np.ndarray
    ledge_mm: float
    rings: WallRings
    brep: Brep | None
    solid: Any

    @property
    def name(self) -> str:
        """A file-name stem, e.g. ``wall_10mm`` or ``wall_7.5mm``."""
        return f"wall_{self.standoff_mm:g}mm"

    @cached_property
    def shape(self):
        """The OCCT shape (one solid, in a compound when unnotched), picture frame, z = 0 on the surface.

        Made on first use: a job that writes the wall from :attr:`brep` needs none.
        """
        if isinstance(self.solid, tuple):
            return wall_solid(*self.solid).shape
        return self.solid

    @cached_property
    def part(self):
        """The wall as a build123d shape (made on first use: a job needs only :attr:`shape`)."""
        import build123d as bd
        from OCP.TopAbs import TopAbs_COMPOUND

        return bd.Part(self.shape) if self.shape.ShapeType() == TopAbs_COMPOUND else bd.Solid(self.shape)

    @cached_property
    def step_text(self) -> str:
        """The STEP text of a wall drawn from its outlines (:attr:`brep`), made once for its check and its file."""
        if self.brep is None:
            raise ValueError(f"{self.name} is OCCT's solid: OCCT writes its STEP")
        return self.brep.step_text(self.name, "stencil_cad wall")

    def cut(self, shape: Any, removed_mm3: float) -> WallModel:
        """The wall made ``shape`` by OCCT (a mural's notches cut), ``removed_mm3`` less in volume."""
        return replace(self, solid=shape, brep=None, volume_mm3=self.volume_mm3 - removed_mm3)


def build_wall(
    width_mm: float,
    height_mm: float,
    outline_cfg: OutlineConfig,
    wall_cfg: WallConfig,
    plate_thickness_mm: float,
    standoff_mm: float,
    kernel: bool = False,
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
        kernel: Make the wall's OCCT solid now and write and check it through OCCT
            (``plate.check: kernel``); else its faces are drawn from its outlines and OCCT is not
            imported.

    Returns:
        The wall with its analytic volume and expected bounding box.

    Raises:
        ValueError: If the config cannot make a wall, or the key does not stop a wrong placement.
    """
    check_key(width_mm, height_mm, outline_cfg, wall_cfg.clearance_mm)
    args = (width_mm, height_mm, outline_cfg, wall_cfg, plate_thickness_mm, standoff_mm)
    if kernel:
        wall = wall_solid(*args)
        rings, s, depth, top, slot_volume = (
            wall.rings,
            wall.standoff_mm,
            wall.pocket_depth_mm,
            wall.total_height_mm,
            wall.slot_volume_mm3,
        )
        brep = None
    else:
        _check_sizes(wall_cfg, outline_cfg, plate_thickness_mm, standoff_mm)
        rings = wall_rings(width_mm, height_mm, outline_cfg, wall_cfg)
        s = float(standoff_mm)
        depth = float(wall_cfg.pocket_depth(plate_thickness_mm))
        top = s + depth
        slot = _finger_slot(width_mm, height_mm, outline_cfg, wall_cfg, s, top, rings.rim_mm)
        slot_volume = 0.0 if slot is None else slot.volume_mm3
        brep = wall_brep(rings, s, top, None if slot is None else slot.faces)
    tol = outline_cfg.chord_tol_mm
    outer = path_ring(rings.outer, tol)
    pocket = path_ring(rings.pocket, tol)
    opening = np.array([s.start for s in rings.opening], dtype=np.float64)
    ledge = _ledge_width(opening, pocket)
    if ledge < 1.0 - 2.0 * tol:
        raise ValueError(
            f"the ledge under the plate is {ledge:.3f} mm wide at its narrowest, must be ≥ 1 mm: "
            "reduce wall.opening_margin_mm or plate.outline.corner_radius_mm"
        )
    lo, hi = outer.min(axis=0), outer.max(axis=0)
    return WallModel(
        volume_mm3=_volume(rings, s, depth, top, slot_volume),
        standoff_mm=s,
        height_mm=top,
        pocket_depth_mm=depth,
        bbox=(float(lo[0]), float(lo[1]), 0.0, float(hi[0]), float(hi[1]), top),
        outer_ring=outer,
        pocket_ring=pocket,
        ledge_mm=ledge,
        rings=rings,
        brep=brep,
        solid=wall.shape if kernel else args,
    )


def _ledge_width(opening: np.ndarray, pocket: np.ndarray) -> float:
    if not fits(opening, pocket):
        return -math.inf
    return min_clearance(opening, pocket)


def wall_step(model: WallModel, path: str | Path) -> None:
    """Write the wall as STEP (AP214, mm, exact arcs) to ``path``: the same wall, the same bytes.

    The header's time stamp is the plates' fixed one (:data:`~stencil_cad.exchange.step.STEP_TIMESTAMP`).
    """
    if model.brep is not None:
        Path(path).write_text(wall_step_text(model), encoding="ascii", newline="\n")
        return
    occt.write_step(model.shape, path, model.name, "stencil_cad wall", STEP_TIMESTAMP)


def wall_step_text(model: WallModel) -> str:
    """The STEP text of a wall drawn from its outlines (:attr:`WallModel.brep`)."""
    return model.step_text


def wall_stl(
    model: WallModel, path: str | Path, tolerance_mm: float = 0.01, angular_tolerance: float = 0.1
) -> None:
    """Write the wall as binary STL to ``path``.

    A wall drawn from its outlines is meshed by :meth:`~stencil_cad.exchange.brep.Brep.mesh` (each
    arc within ``tolerance_mm``); OCCT's wall by its incremental mesher, quick on a few dozen faces.

    Args:
        model: The wall.
        path: Output file.
        tolerance_mm: Largest chord error in mm. Defaults to 0.01 mm.
        angular_tolerance: Largest angle between neighbouring facets on a curve, in
            radians, for OCCT's mesher. Defaults to 0.1.
    """
    if model.brep is not None:
        Path(path).write_bytes(stl_bytes(model.brep.mesh(tolerance_mm), "stencil wall"))
        return
    occt.write_stl(model.shape, path, tolerance_mm, angular_tolerance)


class WallCheckError(RuntimeError):
    """A built wall failed its checks (not one valid solid, or the volume is off)."""


def check_wall(model: WallModel, rel_tol: float = 1e-6) -> dict:
    """Check a wall against its analytic oracle.

    A wall drawn from its outlines is checked from its STEP text without OCCT
    (:func:`~stencil_cad.exchange.brep_check.check_brep_text`: one closed, oriented solid of genus 1,
    its volume to :data:`~stencil_cad.exchange.step_check.VOLUME_RTOL`, its box to 1e-3 mm); OCCT's
    wall (notched, or ``plate.check: kernel``) by ``BRepCheck_Analyzer``, cheap on a few dozen faces.

    Args:
        model: The wall.
        rel_tol: Largest relative volume error of OCCT's wall. Defaults to 1e-6.

    Returns:
        ``n_solids``, ``valid``, ``volume``, ``analytic_volume``, ``rel_error``, ``bbox``.

    Raises:
        WallCheckError: Naming the failed check.
    """
    if model.brep is None:
        return check_simple_solid(
            model.shape, model.volume_mm3, model.bbox, f"wall {model.name}", WallCheckError, rel_tol
        )
    check = check_brep_text(wall_step_text(model), model.volume_mm3, model.bbox, genus=1, bbox_atol_mm=1e-3)
    fails = check.pop("fails")
    if fails:
        raise WallCheckError(f"wall {model.name}: its STEP file fails its check: " + "; ".join(fails))
    check.pop("faces")
    return check
