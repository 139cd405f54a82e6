"""The perforated stencil plate as an OCCT solid, built in time linear in the hole count.

Construction (measured here, OCP 7.9, 14,000 holes): one planar face from the
outline wire, each hole wire added with ``BRepBuilderAPI_MakeFace.Add`` (0.2 s),
then one ``BRepPrimAPI_MakePrism`` (0.4 s). A boolean per hole, build123d's
``Face(outer, inner_wires)`` (97 s) or even one boolean of the label against the
perforated plate (14 s at 2,000 holes, 540 s at 14,000: the boolean re-splits
the top face with all its holes) are avoided.

The label is built by local surgery instead of a boolean: the glyphs (letters
and an up-arrow, as polygons) become faces at the top, a small prism of them
gives the relief's walls and far faces, and the plate's top face gets the glyph
outlines as extra holes; the shell is then re-assembled from the same edge
objects, so every edge is shared by exactly two faces by construction.

Why the result is valid (see :mod:`stencil_cad.cad.validate` for the checks):
a face built this way is valid when its wires are simple, pairwise disjoint
and the holes lie inside the outer wire. The dots are re-checked here (radius
floor, no overlap, inside the picture) in O(n log n), and the glyph rings are
checked for crossings; those are exactly the properties BRepCheck's quadratic
wire-intersection test would check.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config.stipple import HOLE_FLOOR_MM
from ..config.thickness import LABEL_FLOOR_MM
from ..exchange.mesh import plate_mesh
from ..geometry import as_ccw, point_ring_distance, points_in_ring, polygon_area, rings_cross
from ..model import Holes, PlateGeometry, TriMesh
from ..stipple.rules import DesignRules, DotRuleError, check_rules
from ..stipple.windows import window_clearance
from . import occt
from .label import LabelInfo, label_glyphs, label_text
from .solid import PlateBuildError, make_solid

if TYPE_CHECKING:
    from build123d import Part

log = logging.getLogger(__name__)

__all__ = [
    "LabelInfo",
    "PlateBuildError",
    "PlateModel",
    "label_glyphs",
    "label_text",
    "make_solid",
    "perforated_plate",
]


# ----------------------------------------------------------------------------- model


@dataclass(init=False)
class PlateModel:
    """A built plate: the solid plus what the exporters and checks need.

    Made from a build123d shape (``part``), an OCCT one (``shape``) or a description alone
    (``geometry``). The OCCT solid of a description is built (:func:`make_solid`) only when
    :attr:`shape` or :attr:`part` is first asked for (OCCT's check, a template editing the
    solid): a job writes and checks a plate from its description, so it builds no solid; and
    the build123d ``Part`` is made only when :attr:`part` is asked for, so a job whose template
    returns :func:`perforated_plate`'s model never imports build123d.

    Attributes:
        geometry: The plate's kernel-free description (fast STEP and mesh), or
            None when a template returned its own shape.
        label: What the label says, or None.
        info: Figures for the manifest (timings, label text and size).
    """

    geometry: PlateGeometry | None
    label: LabelInfo | None
    info: dict
    _shape: Any = field(repr=False)
    _part: Any = field(repr=False)
    _meshes: dict = field(repr=False)

    def __init__(
        self,
        part: object = None,
        geometry: PlateGeometry | None = None,
        label: LabelInfo | None = None,
        info: dict | None = None,
        *,
        shape: object = None,
    ):
        if part is not None and shape is not None:
            raise TypeError("a PlateModel takes a build123d part or an OCCT shape, not both")
        if part is None and shape is None and geometry is None:
            raise TypeError("a PlateModel needs a build123d part, an OCCT shape or a description")
        self.geometry, self.label = geometry, label
        self.info = {} if info is None else info
        self._part = part
        self._shape = None if shape is None else occt.in_compound(_unwrap(shape))
        self._meshes = {}

    @property
    def part(self) -> Part:
        """The plate as a build123d ``Part`` (its ``.wrapped`` is :attr:`shape`), made on first use.

        :attr:`shape` is a compound because ``Part(TopoDS_Solid)`` reports a volume of 0 in
        build123d 0.12.
        """
        if self._part is None:
            from build123d import Part

            self._part = Part(self.shape)
        return self._part

    @property
    def shape(self):
        """The plate's OCCT shape: the solid in a compound (the part's, once a part is made).

        A description's solid is built on first use (:func:`make_solid`, linear in the holes).
        """
        if self._part is not None:
            return self._part.wrapped
        if self._shape is None:
            assert self.geometry is not None
            t0 = time.perf_counter()
            self._shape = occt.in_compound(make_solid(self.geometry))
            self.info.setdefault("seconds", {})["solid"] = round(time.perf_counter() - t0, 3)
        return self._shape

    @property
    def analytic_volume(self) -> float | None:
        """Volume in mm³ from the description (outline − holes) × t + relief, or None."""
        return None if self.geometry is None else self.geometry.volume

    def cut_label(self) -> tuple[str, tuple]:
        """The label's text and glyph rings ``(outer, inners)`` (picture frame), for a cut file's score layer."""
        text = str((self.info.get("label") or {}).get("text", ""))
        return text, tuple(self.geometry.glyphs) if self.geometry is not None else ()

    @property
    def hole_count(self) -> int | None:
        """Number of through holes, or None for a template's own shape."""
        return None if self.geometry is None else self.geometry.hole_count

    def mesh(self, tolerance_mm: float = 0.02) -> TriMesh:
        """The plate's triangle mesh (cached per tolerance).

        Args:
            tolerance_mm: Largest distance in mm between a round hole and its polygon.
                Defaults to 0.02 mm.

        Returns:
            The mesh. For a template's own shape, OCCT's mesher is used (slow on big plates).
        """
        key = round(float(tolerance_mm), 9)
        if key not in self._meshes:
            t0 = time.perf_counter()
            if self.geometry is not None:
                self._meshes[key] = plate_mesh(self.geometry, tolerance_mm)
            else:
                from .writers import occt_mesh

                self._meshes[key] = occt_mesh(self.shape, tolerance_mm)
            self.info.setdefault("mesh_seconds", {})[str(key)] = round(time.perf_counter() - t0, 3)
        return self._meshes[key]

    def with_holes(self, xy_mm, r_mm, web_mm: float = 1.0) -> PlateModel:
        """This plate with extra round through-holes (a hanging hole, say), kept kernel-free.

        The holes join the plate's description, so the plate keeps its fast STEP writer,
        mesher and scalable checks however many dots it has (an OCCT boolean on the solid,
        :meth:`with_part`, makes the whole plate go through OCCT's slow writers).

        Args:
            xy_mm: ``(K, 2)`` hole centres in mm, picture frame (or one ``(x, y)``).
            r_mm: Radius in mm, one for all or ``(K,)``.
            web_mm: Least material in mm to the plate's edge, other holes and the label.
                Defaults to 1.0 mm.

        Returns:
            A new model.

        Raises:
            PlateBuildError: A hole is too small, leaves the plate, or comes closer than
                ``web_mm`` to another hole, the plate's edge or the label.
        """
        if self.geometry is None:
            raise PlateBuildError("with_holes needs the plate of perforated_plate (call it before with_part)")
        geom = self.geometry
        xy = np.asarray(xy_mm, dtype=np.float64).reshape(-1, 2)
        r = np.broadcast_to(np.asarray(r_mm, dtype=np.float64), (len(xy),)).copy()
        for (x, y), ri in zip(xy, r, strict=True):
            where = f"extra hole at ({x:g}, {y:g}) mm, r {ri:g} mm"
            if not ri >= HOLE_FLOOR_MM:
                raise PlateBuildError(f"{where}: radius must be ≥ {HOLE_FLOOR_MM} mm")
            ring = geom.outline
            if not _point_in_ring(x, y, ring) or _ring_distance(x, y, ring) < ri + web_mm:
                raise PlateBuildError(f"{where}: must lie inside the plate, ≥ {web_mm:g} mm from its edge")
            if len(geom.circles_r):
                gap = np.hypot(*(geom.circles_xy - (x, y)).T) - geom.circles_r - ri
                if gap.min() < web_mm:
                    raise PlateBuildError(
                        f"{where}: only {gap.min():.3g} mm from another hole (< {web_mm:g} mm)"
                    )
            for poly in geom.polygons:
                if _point_in_ring(x, y, poly) or _ring_distance(x, y, poly) < ri + web_mm:
                    raise PlateBuildError(f"{where}: too close to a cut-out")
            if geom.label_box is not None:
                x0, y0, x1, y1 = geom.label_box
                dx, dy = max(x0 - x, 0.0, x - x1), max(y0 - y, 0.0, y - y1)
                if np.hypot(dx, dy) < ri + web_mm:
                    raise PlateBuildError(f"{where}: too close to the label")
        new = replace(
            geom,
            circles_xy=np.vstack([geom.circles_xy.reshape(-1, 2), xy]),
            circles_r=np.concatenate([geom.circles_r.reshape(-1), r]),
            extra_holes=geom.extra_holes + len(r),
        )
        info = {**self.info, "extra_holes": new.extra_holes}
        return PlateModel(geometry=new, label=self.label, info=info)

    def with_part(self, shape: object) -> PlateModel:
        """This model with its solid replaced by an edited one.

        Args:
            shape: A build123d or CadQuery shape (anything with ``.wrapped``), a
                CadQuery ``Workplane`` or a ``TopoDS_Shape``.

        Returns:
            ``self`` when the shape is the same solid; otherwise a model without a
            kernel-free description, exported through OCCT's writers.
        """
        wrapped = _unwrap(shape)
        if wrapped.IsSame(self.shape):
            return self
        return PlateModel(shape=wrapped, geometry=None, label=self.label, info=dict(self.info))


def _point_in_ring(x: float, y: float, ring: np.ndarray) -> bool:
    return bool(points_in_ring(np.array([[x, y]]), ring)[0])


def _ring_distance(x: float, y: float, ring: np.ndarray) -> float:
    return float(point_ring_distance(np.array([[x, y]]), ring)[0])


def _unwrap(shape):
    """The ``TopoDS_Shape`` inside a build123d/CadQuery object or Workplane."""
    if hasattr(shape, "vals") and hasattr(shape, "val"):  # CadQuery Workplane
        vals = shape.vals()
        if len(vals) != 1:
            return occt.compound(_unwrap(v) for v in vals)
        shape = vals[0]
    return shape.wrapped if hasattr(shape, "wrapped") else shape


# ----------------------------------------------------------------------------- input checks


def check_holes(
    holes: Holes, width_mm: float, height_mm: float, min_web_mm: float, rules: DesignRules | None = None
) -> None:
    """Check the holes again before any CAD: radius floor, overlap, picture edge.

    Round holes are checked against the design rules, polygon cut-outs for islands,
    extent, degeneracy and crossings (a layer has one kind or the other).

    Args:
        holes: A :class:`DotSet` or a :class:`CutLayer`.
        width_mm: Picture width in mm.
        height_mm: Picture height in mm.
        min_web_mm: Smallest web in mm between holes (every hole lies inside the picture).
        rules: Optional stricter :class:`stencil_cad.stipple.rules.DesignRules` (the job's rules).

    Raises:
        PlateBuildError: Listing the first offending dots or polygons.
    """
    if len(holes.r_mm):
        if rules is None:
            rules = DesignRules.any_job(width_mm, height_mm, min_web_mm)
        try:
            check_rules(holes.xy_mm, holes.r_mm, rules)
        except DotRuleError as exc:
            raise PlateBuildError(f"dots rejected by the plate: {exc}") from None
    if holes.polygons:
        bad = []
        for i, poly in enumerate(holes.polygons):
            outer, inner = poly
            outer = np.asarray(outer, dtype=np.float64)
            if len(inner):
                bad.append(f"polygon {i}: has {len(inner)} island(s) not held by bridges")
            lo, hi = outer.min(axis=0), outer.max(axis=0)
            # To 0.001 mm, as the holes' rules: a window saved to its file (4 decimals) and moved into
            # a tile's frame may end a rounding past the tile's edge it was cut to.
            tol = 1e-3
            if lo[0] < -tol or lo[1] < -tol or hi[0] > width_mm + tol or hi[1] > height_mm + tol:
                bad.append(
                    f"polygon {i}: reaches outside the picture area [0, {width_mm:g}] x [0, {height_mm:g}] mm "
                    f"(bbox {lo.round(3).tolist()}..{hi.round(3).tolist()})"
                )
            if len(outer) < 3 or abs(polygon_area(outer)) <= 0:
                bad.append(f"polygon {i}: degenerate ({len(outer)} vertices)")
        if not bad and holes.polygons and rings_cross([p[0] for p in holes.polygons]):
            bad.append("cut-out polygons cross each other or themselves")
        if not bad and len(holes.r_mm):
            # A hybrid plate: every round hole keeps a web of sheet from every window.
            web = min_web_mm if rules is None else rules.web_mm
            ok = window_clearance(holes.xy_mm, holes.r_mm, holes.polygons, web)
            for i in np.flatnonzero(~ok)[:5]:
                x, y = holes.xy_mm[i]
                bad.append(f"hole {i} at ({x:.3f}, {y:.3f}) mm is closer than {web:g} mm to a window")
        if bad:
            raise PlateBuildError(
                f"{len(bad)} cut-out problem(s); first:\n  " + "\n  ".join(bad[:5]),
            )


# ----------------------------------------------------------------------------- the builder


def perforated_plate(
    holes: Holes,
    outline: np.ndarray,
    label_area: tuple[float, float, float, float] | None,
    label: LabelInfo | None,
    *,
    thickness_mm: float = 1.2,
    label_mode: str = "engrave",
    label_depth_mm: float = 0.4,
    label_height_mm: float = 4.0,
    label_min_height_mm: float = 2.0,
    label_font: str = "DejaVu Sans",
    label_tolerance_mm: float = 0.01,
    width_mm: float | None = None,
    height_mm: float | None = None,
) -> PlateModel:
    """Build a perforated plate: outline, a hole per dot or cut-out, a label.

    Args:
        holes: A :class:`DotSet` (round holes) or a :class:`CutLayer` (polygons).
        outline: ``(M, 2)`` ring of the plate's boundary in picture mm.
        label_area: ``(x0, y0, x1, y1)`` mm, the free rectangle for the label.
        label: What the label says, or None for no label.
        thickness_mm: Plate thickness. Defaults to 1.2 mm.
        label_mode: ``"engrave"``, ``"emboss"`` or ``"none"``. Defaults to engrave.
        label_depth_mm: Depth (engrave) or height (emboss). Defaults to 0.4 mm.
        label_height_mm: Font size. Defaults to 4 mm.
        label_min_height_mm: Smallest font size when shrinking to fit. Defaults to 2 mm.
        label_font: Font family. Defaults to DejaVu Sans.
        label_tolerance_mm: Chord error of the letters. Defaults to 0.01 mm.
        width_mm: Picture width in mm (for the record). Defaults to the outline's.
        height_mm: Picture height in mm. Defaults to the outline's.

    Returns:
        The plate model.
    """
    t0 = time.perf_counter()
    outline = np.asarray(outline, dtype=np.float64)
    mode = getattr(label_mode, "value", label_mode)
    if mode not in ("engrave", "emboss", "none"):
        raise PlateBuildError(f"label mode must be engrave, emboss or none, got {mode!r}")
    if mode == "engrave" and label_depth_mm > thickness_mm - LABEL_FLOOR_MM + 1e-9:
        raise PlateBuildError(
            f"label depth must be ≤ thickness - {LABEL_FLOOR_MM:g} ({thickness_mm - LABEL_FLOOR_MM:g} mm), "
            f"got {label_depth_mm}"
        )
    glyphs: tuple = ()
    box: tuple[float, float, float, float] | None = None
    linfo: dict = {}
    if label is not None and mode != "none" and label_area is not None:
        placed, box, linfo = label_glyphs(
            label, label_area, label_height_mm, label_min_height_mm, label_font, label_tolerance_mm
        )
        glyphs = tuple(placed)
    relief = 0.0 if not glyphs else (-label_depth_mm if mode == "engrave" else label_depth_mm)
    cxy = np.asarray(holes.xy_mm, dtype=np.float64).reshape(-1, 2)
    cr = np.asarray(holes.r_mm, dtype=np.float64).reshape(-1)
    polys = tuple(as_ccw(p[0]) for p in holes.polygons)
    lo, hi = outline.min(axis=0), outline.max(axis=0)
    geom = PlateGeometry(
        width_mm=float(width_mm if width_mm is not None else hi[0] - lo[0]),
        height_mm=float(height_mm if height_mm is not None else hi[1] - lo[1]),
        thickness_mm=float(thickness_mm),
        outline=as_ccw(outline),
        circles_xy=cxy,
        circles_r=cr,
        polygons=polys,
        glyphs=glyphs,
        relief_mm=float(relief),
        label_box=box,
    )
    info = {
        "holes": geom.hole_count,
        "label": linfo,
        "seconds": {"label": round(time.perf_counter() - t0, 3)},
    }
    # The OCCT solid is built when first asked for (PlateModel.shape): a job never asks.
    return PlateModel(geometry=geom, label=label, info=info)
