"""The horizontal faces of a plate's STEP text: their bounds' areas and their geometry in plan.

:mod:`stencil_cad.exchange.step_check` checks a plate's STEP text; this module holds what it
asks of the horizontal faces (the top, the bottom, a label's floors and tops): each bound's
signed area (the volume, and the way it runs about its face's normal), and in plan, what OCCT's
analyzer would catch and the topology cannot: polygon bounds that cross or touch
(:func:`~stencil_cad.geometry.rings_cross`: cut-outs, windows, letters, the outline), round holes
that overlap or touch each other (:func:`~stencil_cad.geometry.min_web`) or a polygon bound, and
bounds outside the outer one or inside another hole
(:func:`~stencil_cad.geometry.circles_clear_of_rings`,
:func:`~stencil_cad.geometry.points_in_any_ring`). A round hole must keep the file's distance
accuracy (:data:`CLEARANCE_MM`) from every other bound; two polygon bounds only must not meet
(a shared point is touching: 1e-9 mm apart passes, as it passes OCCT's analyzer). Every test is
near linear in the bounds: a mural plate has 14,000 holes and more, a hard stencil thousands of
cut-outs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..geometry import (
    circles_clear_of_rings,
    min_web,
    points_in_any_ring,
    points_in_circles,
    points_in_ring,
    rings_cross,
)
from .step_brep import Brep, Geometry, Shell

__all__ = ["AXIS_TOL", "CLEARANCE_MM", "Flat", "face_geometry_fails", "flat_faces"]

#: Least distance in mm between two bounds of a face, and most distance of a vertex from its
#: curve or surface: the file's distance accuracy (its UNCERTAINTY_MEASURE_WITH_UNIT).
CLEARANCE_MM = 1e-7

#: A unit direction's z within this of 0 is horizontal, of ±1 vertical.
AXIS_TOL = 1e-9


@dataclass
class Flat:
    """The horizontal faces' bounds: which are circles, their signed areas (mm², CCW about +z positive)."""

    faces: np.ndarray  # indices into the shell's faces
    z: np.ndarray  # their heights, mm
    area: np.ndarray  # their signed areas seen from +z, mm²
    circle: np.ndarray  # per bound of the shell: CIRCLE row, -1 for a polygon bound
    first_use: np.ndarray  # per bound: its first use
    up: np.ndarray  # +1 where the face faces +z, -1 where it faces -z


def flat_faces(br: Brep, g: Geometry, sh: Shell, fails: list[str]) -> Flat:
    """The horizontal faces' bounds and signed areas.

    Fails bounds that mix circles and lines, and bounds that run the wrong way about their face's
    normal or enclose no area.
    """
    n_bounds = len(sh.face_of_bound)
    first_use = np.searchsorted(sh.loop_of_use, np.arange(n_bounds))
    n_uses = np.diff(np.concatenate([first_use, [len(sh.edge)]]))
    is_circle = g.curve_kind[sh.edge] == 1
    plane = sh.surface_kind == 0
    flat = np.flatnonzero(plane & (np.abs(g.plane_normal[np.where(plane, sh.surface, 0), 2]) > 1 - AXIS_TOL))
    on_flat = np.zeros(len(sh.faces), dtype=bool)
    on_flat[flat] = True
    flat_bound = on_flat[sh.face_of_bound]
    circles_in = np.bincount(sh.loop_of_use, weights=is_circle, minlength=n_bounds)
    if (flat_bound & (circles_in > 0) & (n_uses != 1)).any():
        fails.append(
            "a bound of a horizontal face mixes a circle with other edges (a round hole has one circle)"
        )
    only = (circles_in > 0) & (n_uses == 1)
    circle = np.where(only, g.curve[sh.edge[np.minimum(first_use, max(len(sh.edge) - 1, 0))]], -1)
    # Polygon bounds: the shoelace over their vertices in loop order, about each bound's first vertex.
    use = np.flatnonzero(on_flat[sh.face_of_bound[sh.loop_of_use]] & ~is_circle)
    loop = sh.loop_of_use[use]
    ref = g.vertex[sh.start[first_use[loop]], :2]
    a = g.vertex[sh.start[use], :2] - ref
    b = g.vertex[sh.start[sh.nxt[use]], :2] - ref
    area = 0.5 * np.bincount(loop, weights=a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1], minlength=n_bounds)
    perimeter = np.bincount(loop, weights=np.hypot(*(b - a).T), minlength=n_bounds)
    # Circle bounds: exactly pi r^2, signed by the way the loop runs about +z.
    cb = np.flatnonzero((circle >= 0) & flat_bound)
    cu, cr = first_use[cb], circle[cb]
    turn = (
        np.sign(g.circle_axis[cr, 2]) * np.where(g.edge_fwd[sh.edge[cu]], 1, -1) * np.where(sh.fwd[cu], 1, -1)
    )
    area[cb] = turn * math.pi * g.circle_r[cr] ** 2
    perimeter[cb] = 2 * math.pi * g.circle_r[cr]
    area = np.where(sh.bound_fwd, area, -area)
    face_area = np.bincount(sh.face_of_bound, weights=area, minlength=len(sh.faces))[flat]
    up = np.sign(g.plane_normal[:, 2])[np.where(plane, sh.surface, 0)] * np.where(
        br.flag["ADVANCED_FACE"][sh.faces], 1, -1
    )
    # Each bound on its own: an outer bound runs counter-clockwise about the face's normal, a
    # hole's clockwise, and is wider than the file's accuracy (a ring folded flat is no bound).
    bound_up = area * up[sh.face_of_bound] * np.where(sh.bound_outer, 1.0, -1.0)
    wrong = np.flatnonzero(flat_bound & (bound_up <= CLEARANCE_MM * perimeter))
    if len(wrong):
        first = int(sh.loop_id[wrong[0]])
        fails.append(
            f"{len(wrong)} bounds of horizontal faces run the wrong way about their face's normal or "
            f"enclose no area (an outer bound runs counter-clockwise, a hole's clockwise; first #{first})"
        )
    return Flat(flat, g.plane_point[sh.surface[flat], 2], face_area, circle, first_use, up[flat])


def _face_bounds(g: Geometry, sh: Shell, fl: Flat, face: int):
    """One horizontal face's polygon bounds (xy rings, outer first) and circles (centres, radii)."""
    bounds = np.flatnonzero(sh.face_of_bound == face)
    outer = bounds[sh.bound_outer[bounds]]
    order = np.concatenate([outer, bounds[~sh.bound_outer[bounds]]])
    rings = []
    for b in order[fl.circle[order] < 0]:
        uses = np.arange(fl.first_use[b], fl.first_use[b + 1] if b + 1 < len(fl.first_use) else len(sh.edge))
        rings.append(g.vertex[sh.start[uses], :2])
    rows = fl.circle[order][fl.circle[order] >= 0]
    outer_is_polygon = len(outer) == 1 and fl.circle[outer[0]] < 0
    return rings, g.circle_centre[rows, :2], g.circle_r[rows], outer_is_polygon


def _crossings(rings: list[np.ndarray], xy: np.ndarray, r: np.ndarray) -> list[str]:
    """What is wrong with one face's bounds: crossing, touching, outside the outer one, nested."""
    out: list[str] = []
    outer, inner = rings[0], rings[1:]
    if rings_cross(rings):
        out.append(
            "its polygon bounds cross or touch (a cut-out, window or letter over another or the outline)"
        )
    if len(r) > 1 and (web := min_web(xy, r)) <= CLEARANCE_MM:
        out.append(f"its round holes overlap or touch (smallest web {web:.4g} mm)")
    checks = []
    if len(r):
        checks.append(
            (
                circles_clear_of_rings(xy, r, [outer], CLEARANCE_MM, inside=True),
                "crosses, touches or leaves its outer bound",
            )
        )
    if len(r) and inner:
        checks.append(
            (
                circles_clear_of_rings(xy, r, inner, CLEARANCE_MM),
                "crosses, touches or lies in a polygon bound",
            )
        )
    for ok, where in checks:
        if not ok.all():
            x, y = xy[np.flatnonzero(~ok)[0]]
            out.append(f"{int((~ok).sum())} round holes: the one at ({x:.4f}, {y:.4f}) mm {where}")
    if inner:
        # Bounds that neither cross nor touch are each wholly inside or outside another: one
        # vertex tells which.
        firsts = np.array([ring[0] for ring in inner])
        nested = ~points_in_ring(firsts, outer) | points_in_any_ring(firsts, inner, own=np.arange(len(inner)))
        nested |= points_in_circles(firsts, xy, r)
        if nested.any():
            out.append(
                f"{int(nested.sum())} polygon bounds lie outside its outer bound or inside another hole"
            )
    return out


def face_geometry_fails(br: Brep, g: Geometry, sh: Shell, fl: Flat) -> list[str]:
    """Each horizontal face's bounds in plan: one outer polygon, the rest disjoint and inside it.

    A face whose bounds are, in plan, the first bounds of a face already found valid (a plate's
    bottom, and its top with the letters' bounds besides) is valid too, and is not checked again.

    Returns:
        A message per failure, naming the face.
    """
    fails = []
    checked: list[_Plan] = []
    bounds = np.bincount(sh.face_of_bound, minlength=len(sh.faces))
    for face in fl.faces[np.argsort(-bounds[fl.faces], kind="stable")]:  # most bounds first
        rings, xy, r, polygon_outer = _face_bounds(g, sh, fl, int(face))
        name = f"face #{int(br.ids['ADVANCED_FACE'][sh.faces[face]])}"
        if not polygon_outer:
            fails.append(f"{name} has no single polygon outer bound")
            continue
        plan = _Plan.of(rings, xy, r)
        if any(plan.within(seen) for seen in checked):
            continue
        found = _crossings(rings, xy, r)
        fails += [f"{name}: {what}" for what in found]
        if not found:
            checked.append(plan)
    return fails


@dataclass
class _Plan:
    """A face's bounds in plan, its polygon rings canonical and one after another.

    A canonical ring runs counter-clockwise from its lowest-then-leftmost vertex: the same ring
    however a loop runs it.
    """

    lengths: np.ndarray  # vertices per ring, outer first
    rings: np.ndarray  # (sum of lengths, 2)
    xy: np.ndarray
    r: np.ndarray

    @classmethod
    def of(cls, rings: list[np.ndarray], xy: np.ndarray, r: np.ndarray) -> _Plan:
        """The plan of a face's rings and circles (vectorised over the rings)."""
        n = np.array([len(x) for x in rings], dtype=np.int64)
        pts = np.concatenate(rings)
        k = np.repeat(np.arange(len(n)), n)
        start = np.concatenate([[0], np.cumsum(n)[:-1]])
        i = np.arange(len(pts)) - start[k]
        nxt = start[k] + (i + 1) % n[k]
        twice = np.bincount(k, pts[:, 0] * pts[nxt, 1] - pts[nxt, 0] * pts[:, 1], len(n))
        pts = pts[np.where(twice[k] > 0, start[k] + i, start[k] + n[k] - 1 - i)]
        lowest = np.lexsort((pts[:, 0], pts[:, 1], k))[start] - start
        return cls(n, pts[start[k] + (i + lowest[k]) % n[k]], xy, r)

    def within(self, other: _Plan) -> bool:
        """Whether these bounds are the first bounds of ``other``'s, the same in plan and order."""
        k, m = len(self.lengths), len(self.rings)
        return (
            k <= len(other.lengths)
            and np.array_equal(self.lengths, other.lengths[:k])
            and np.array_equal(self.rings, other.rings[:m])
            and np.array_equal(self.xy, other.xy)
            and np.array_equal(self.r, other.r)
        )
