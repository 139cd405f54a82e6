"""A kernel-free check of a plate's STEP text: the very file a maker gets, against its description.

A job writes a plate's STEP from its :class:`~stencil_cad.model.PlateGeometry`
(:func:`~stencil_cad.exchange.step.step_text`), not from an OCCT solid, so this check reads that
text (:func:`~stencil_cad.exchange.step_brep.read_brep`) and holds it to what OCCT's checks held
the solid to (:func:`stencil_cad.cad.check_plate`), in time linear in the entities (plus
O(n log n) for the holes' spacing). Each failure is named:

- **one solid**: exactly one MANIFOLD_SOLID_BREP, whose one CLOSED_SHELL lists every
  ADVANCED_FACE of the file once;
- **closed and oriented**: every EDGE_CURVE is used by exactly two ORIENTED_EDGEs of the shell's
  loops, once in each direction; each EDGE_LOOP chains end to start; the faces are connected;
- **Euler–Poincaré**: V − E + F − (L − F) = 2(S − G) with S = 1 holds for G equal to the
  description's through holes (round holes, cut-outs and windows);
- **on their surfaces**: every vertex lies on its face's plane or cylinder, on its lines and
  circles; circles and cylinders agree; planes are horizontal or vertical, cylinders about z;
- **counts**: the faces, the cylindrical faces (one per round hole) and the top face's bounds
  against the description;
- **volume** by the divergence theorem with F = (0, 0, z): only horizontal faces add
  z · (signed area of their bounds), circles exactly πr², against the description's analytic
  volume (relative :data:`VOLUME_RTOL`; the writer's reals have 10 decimals); each horizontal
  face's bounds run counter-clockwise about its normal;
- **bounding box** of the vertices and circles against the description's;
- **geometry OCCT's analyzer would catch** and the topology cannot: on every horizontal face,
  polygon bounds that cross or touch (:func:`~stencil_cad.geometry.rings_cross`: cut-outs,
  windows, letters, the outline), round holes that overlap or touch each other
  (:func:`~stencil_cad.geometry.min_web`) or a polygon bound, and bounds outside the outer one
  or inside another hole (:func:`~stencil_cad.geometry.circles_clear_of_rings`, the test
  :func:`~stencil_cad.stipple.windows.window_clearance` runs on hybrid plates), all to the file's
  distance accuracy (:data:`CLEARANCE_MM`).

The design rules themselves (radius floor, web, edge margin, a window's web) are enforced on the
dots before any CAD (:mod:`stencil_cad.stipple.rules`, :func:`stencil_cad.cad.plate.check_holes`
again in the plate's build); this check only asks whether the file is a valid solid of the
description, which also catches a writer that broke it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..geometry import as_ccw, circles_clear_of_rings, min_web, points_in_ring, rings_cross
from ..model import PlateGeometry
from .step_brep import Brep, Geometry, Shell, StepReadError, geometry_of, read_brep, segments, shell_of

__all__ = ["CLEARANCE_MM", "VOLUME_RTOL", "StepReadError", "check_step_text"]

#: Least distance in mm between two bounds of a face, and most distance of a vertex from its
#: curve or surface: the file's distance accuracy (its UNCERTAINTY_MEASURE_WITH_UNIT).
CLEARANCE_MM = 1e-7

#: Largest relative difference between the file's volume and the description's.
VOLUME_RTOL = 1e-9

#: A unit direction's z within this of 0 is horizontal, of ±1 vertical.
_AXIS_TOL = 1e-9


def _solid_faces(br: Brep, fails: list[str]) -> np.ndarray:
    """The rows of the faces the one solid's shell lists."""
    n_solids = br.count("MANIFOLD_SOLID_BREP")
    if n_solids != 1:
        fails.append(f"expected exactly one MANIFOLD_SOLID_BREP, the file has {n_solids}")
    if n_solids == 0:
        raise StepReadError("the file holds no MANIFOLD_SOLID_BREP")
    shells = br.count("CLOSED_SHELL") + br.count("OPEN_SHELL")
    if shells != 1:
        fails.append(f"expected exactly one shell, the file has {shells}")
    shell = br.rows(br.refs["MANIFOLD_SOLID_BREP"][:1, 0], "CLOSED_SHELL", "the solid's shell")
    _, refs = segments(*br.lists["CLOSED_SHELL"], shell)
    faces = br.rows(refs, "ADVANCED_FACE", "the shell's face")
    listed = np.bincount(faces, minlength=br.count("ADVANCED_FACE"))
    if (listed > 1).any():
        fails.append(f"{int((listed > 1).sum())} ADVANCED_FACEs are listed twice in the shell")
    if (listed == 0).any():
        first = int(br.ids["ADVANCED_FACE"][np.flatnonzero(listed == 0)[0]])
        fails.append(
            f"{int((listed == 0).sum())} ADVANCED_FACEs of the file are not in the solid's shell (first #{first})"
        )
    return faces


def _topology(br: Brep, sh: Shell, fails: list[str]) -> dict[str, int]:
    """Edge uses, loops, connectivity and the Euler–Poincaré count; returns V, E, F, L and the genus."""
    n_edges = br.count("EDGE_CURVE")
    direction = sh.fwd == sh.bound_fwd[sh.loop_of_use]  # a bound reversed reverses its loop
    uses = np.bincount(sh.edge, minlength=n_edges)
    forward = np.bincount(sh.edge, weights=direction, minlength=n_edges)
    if (uses != 2).any():
        bad = np.flatnonzero(uses != 2)
        fails.append(
            f"{len(bad)} EDGE_CURVEs are not used by exactly two ORIENTED_EDGEs (shell not closed): "
            f"{int((uses == 0).sum())} never, {int((uses == 1).sum())} once, {int((uses > 2).sum())} "
            f"three times or more (first #{int(br.ids['EDGE_CURVE'][bad[0]])})"
        )
    two = uses == 2
    if (two & (forward != 1)).any():
        bad = np.flatnonzero(two & (forward != 1))
        fails.append(
            f"{len(bad)} EDGE_CURVEs are used twice in the same direction (shell not consistently "
            f"oriented; first #{int(br.ids['EDGE_CURVE'][bad[0]])})"
        )
    broken = np.flatnonzero(sh.end != sh.start[sh.nxt])
    if len(broken):
        loops = np.unique(sh.loop_of_use[broken])
        fails.append(
            f"{len(loops)} EDGE_LOOPs do not close (an edge does not end where the next starts; "
            f"first #{int(sh.loop_id[loops[0]])})"
        )
    face_of_use = sh.face_of_bound[sh.loop_of_use]
    order = np.argsort(sh.edge, kind="stable")
    paired = two[sh.edge[order]]
    pairs = face_of_use[order][paired].reshape(-1, 2)
    n_faces = len(sh.faces)
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n_faces, n_faces))
    parts = connected_components(graph, directed=False)[0] if n_faces else 0
    if parts != 1:
        fails.append(f"the shell's faces fall into {parts} parts that share no edge")
    used = uses > 0
    ends = br.refs["EDGE_CURVE"][used, :2].reshape(-1)
    v = int(np.count_nonzero(np.bincount(ends, minlength=len(br.kind))))
    e, f, loops_n = int(used.sum()), n_faces, len(sh.face_of_bound)
    chi = v - e + 2 * f - loops_n  # V - E + F - (L - F) = 2 (S - G), S = 1
    return {"vertices": v, "edges": e, "faces": f, "bounds": loops_n, "chi": chi, "genus": 1 - chi // 2}


def _off_curves(g: Geometry) -> list[str]:
    """Vertices off their edges' lines and circles; circle edges that are not whole circles."""
    fails = []
    line = np.flatnonzero(g.curve_kind == 0)
    row = g.curve[line]
    for ends in (g.edge_v1[line], g.edge_v2[line]):
        off = np.linalg.norm(np.cross(g.vertex[ends] - g.line_point[row], g.line_dir[row]), axis=1)
        if (off > CLEARANCE_MM).any():
            fails.append(f"{int((off > CLEARANCE_MM).sum())} line edges have a vertex off their line")
            break
    circ = np.flatnonzero(g.curve_kind == 1)
    row = g.curve[circ]
    rel = g.vertex[g.edge_v1[circ]] - g.circle_centre[row]
    along = (rel * g.circle_axis[row]).sum(axis=1)
    radial = np.linalg.norm(rel - along[:, None] * g.circle_axis[row], axis=1)
    if (np.abs(radial - g.circle_r[row]) > CLEARANCE_MM).any() or (np.abs(along) > CLEARANCE_MM).any():
        fails.append("a circle edge's vertex does not lie on its circle")
    if (g.edge_v1[circ] != g.edge_v2[circ]).any():
        fails.append("a circle edge does not start and end at one vertex (a whole circle)")
    return fails


def _off_surfaces(br: Brep, g: Geometry, sh: Shell) -> list[str]:
    """Planes neither horizontal nor vertical, cylinders not about z, edges off their faces."""
    fails = []
    face = sh.face_of_bound[sh.loop_of_use]
    plane = sh.surface_kind[face] == 0
    row = sh.surface[face]
    nz = np.abs(g.plane_normal[:, 2])
    if ((nz > _AXIS_TOL) & (nz < 1 - _AXIS_TOL)).any():
        fails.append("a planar face is neither horizontal nor vertical (only such plates are written)")
    if (np.abs(np.abs(g.cyl_axis[:, 2]) - 1) > _AXIS_TOL).any():
        fails.append("a cylindrical face is not about the z axis")
    pr = row[plane]
    height = ((g.vertex[sh.start[plane]] - g.plane_point[pr]) * g.plane_normal[pr]).sum(axis=1)
    circ = plane & (g.curve_kind[sh.edge] == 1)
    cr, cp = g.curve[sh.edge[circ]], row[circ]
    tilt = np.linalg.norm(np.cross(g.circle_axis[cr], g.plane_normal[cp]), axis=1)
    centre = ((g.circle_centre[cr] - g.plane_point[cp]) * g.plane_normal[cp]).sum(axis=1)
    if (
        (np.abs(height) > CLEARANCE_MM).any()
        or (tilt > _AXIS_TOL).any()
        or (np.abs(centre) > CLEARANCE_MM).any()
    ):
        bad = np.unique(face[plane][np.abs(height) > CLEARANCE_MM])
        first = f" (first #{int(br.ids['ADVANCED_FACE'][sh.faces[bad[0]]])})" if len(bad) else ""
        fails.append(f"an edge of a planar face is off its plane{first}")
    cyl = ~plane
    yr = row[cyl]
    rel = (g.vertex[sh.start[cyl]] - g.cyl_centre[yr])[:, :2]
    radial = np.hypot(rel[:, 0], rel[:, 1])
    circ = cyl & (g.curve_kind[sh.edge] == 1)
    cr, yc = g.curve[sh.edge[circ]], row[circ]
    moved = np.hypot(*(g.circle_centre[cr] - g.cyl_centre[yc])[:, :2].T)
    if (
        (np.abs(radial - g.cyl_r[yr]) > CLEARANCE_MM).any()
        or (np.abs(g.circle_r[cr] - g.cyl_r[yc]) > CLEARANCE_MM).any()
        or (moved > CLEARANCE_MM).any()
    ):
        fails.append(
            "an edge of a cylindrical face is off its cylinder (a hole's circles and its cylinder differ)"
        )
    return fails


@dataclass
class _Flat:
    """The horizontal faces' bounds: which are circles, their signed areas (mm², CCW about +z positive)."""

    faces: np.ndarray  # indices into the shell's faces
    z: np.ndarray  # their heights, mm
    area: np.ndarray  # their signed areas seen from +z, mm²
    circle: np.ndarray  # per bound of the shell: CIRCLE row, -1 for a polygon bound
    first_use: np.ndarray  # per bound: its first use


def _flat_faces(br: Brep, g: Geometry, sh: Shell, fails: list[str]) -> _Flat:
    """Signed areas of the horizontal faces' bounds; fails bounds that mix circles and lines."""
    n_bounds = len(sh.face_of_bound)
    first_use = np.searchsorted(sh.loop_of_use, np.arange(n_bounds))
    n_uses = np.diff(np.concatenate([first_use, [len(sh.edge)]]))
    is_circle = g.curve_kind[sh.edge] == 1
    plane = sh.surface_kind == 0
    flat = np.flatnonzero(plane & (np.abs(g.plane_normal[np.where(plane, sh.surface, 0), 2]) > 1 - _AXIS_TOL))
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
    # Circle bounds: exactly pi r^2, signed by the way the loop runs about +z.
    cb = np.flatnonzero((circle >= 0) & flat_bound)
    cu, cr = first_use[cb], circle[cb]
    turn = (
        np.sign(g.circle_axis[cr, 2]) * np.where(g.edge_fwd[sh.edge[cu]], 1, -1) * np.where(sh.fwd[cu], 1, -1)
    )
    area[cb] = turn * math.pi * g.circle_r[cr] ** 2
    area = np.where(sh.bound_fwd, area, -area)
    face_area = np.bincount(sh.face_of_bound, weights=area, minlength=len(sh.faces))[flat]
    normal = np.sign(g.plane_normal[sh.surface[flat], 2]) * np.where(
        br.flag["ADVANCED_FACE"][sh.faces[flat]], 1, -1
    )
    against = np.flatnonzero(np.sign(face_area) != normal)
    if len(against):
        first = int(br.ids["ADVANCED_FACE"][sh.faces[flat[against[0]]]])
        fails.append(
            f"{len(against)} horizontal faces are bounded clockwise about their normal (first #{first})"
        )
    return _Flat(flat, g.plane_point[sh.surface[flat], 2], face_area, circle, first_use)


def _face_bounds(g: Geometry, sh: Shell, fl: _Flat, face: int):
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
    inside_outer = circles_clear_of_rings(xy, r, [outer], CLEARANCE_MM, inside=True)
    if rings_cross(rings):
        out.append(
            "its polygon bounds cross or touch (a cut-out, window or letter over another or the outline)"
        )
    if len(r) > 1 and (web := min_web(xy, r)) <= CLEARANCE_MM:
        out.append(f"its round holes overlap or touch (smallest web {web:.4g} mm)")
    checks = [(inside_outer, "crosses, touches or leaves its outer bound")] if len(r) else []
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
        firsts = np.array([ring[0] for ring in inner])
        nested = ~points_in_ring(firsts, outer)
        for j, ring in enumerate(inner):
            inside = points_in_ring(firsts, ring)
            inside[j] = False
            nested |= inside
        if len(r):
            nested |= (np.hypot(*(firsts[:, None, :] - xy[None, :, :]).transpose(2, 0, 1)) < r).any(axis=1)
        if nested.any():
            out.append(
                f"{int(nested.sum())} polygon bounds lie outside its outer bound or inside another hole"
            )
    return out


def _geometry_fails(br: Brep, g: Geometry, sh: Shell, fl: _Flat) -> list[str]:
    """Each horizontal face's bounds: one outer polygon, the rest disjoint and inside it.

    A face with round holes whose bounds are, in plan, the first bounds of a face already found
    valid (a plate's bottom, and its top with the letters' bounds besides) is valid too, and is
    not checked again.
    """
    fails = []
    checked: list[tuple[list[np.ndarray], np.ndarray, np.ndarray]] = []
    bounds = np.bincount(sh.face_of_bound, minlength=len(sh.faces))
    for face in fl.faces[np.argsort(-bounds[fl.faces], kind="stable")]:  # most bounds first
        rings, xy, r, polygon_outer = _face_bounds(g, sh, fl, int(face))
        name = f"face #{int(br.ids['ADVANCED_FACE'][sh.faces[face]])}"
        if not polygon_outer:
            fails.append(f"{name} has no single polygon outer bound")
            continue
        # Only faces with round holes are worth the look-up: the others are checked in no time.
        if len(r) and any(_within(rings, xy, r, seen) for seen in checked):
            continue
        found = _crossings(rings, xy, r)
        fails += [f"{name}: {what}" for what in found]
        if not found and len(r):
            checked.append((rings, xy, r))
    return fails


def _within(rings: list[np.ndarray], xy: np.ndarray, r: np.ndarray, seen: tuple) -> bool:
    """Whether a face's bounds are the first bounds of a face found valid (the same xy, in order)."""
    their_rings, their_xy, their_r = seen
    return (
        len(rings) <= len(their_rings)
        and np.array_equal(xy, their_xy)
        and np.array_equal(r, their_r)
        and all(
            len(a) == len(b) and np.array_equal(_canonical(a), _canonical(b))
            for a, b in zip(rings, their_rings, strict=False)
        )
    )


def _canonical(ring: np.ndarray) -> np.ndarray:
    """A ring counter-clockwise from its lowest-then-leftmost vertex: the same ring, however traversed."""
    ring = as_ccw(ring)
    first = np.lexsort((ring[:, 0], ring[:, 1]))[0]
    return np.roll(ring, -first, axis=0)


def expected_counts(geom: PlateGeometry) -> dict[str, int]:
    """The faces, cylindrical faces, top-face bounds and genus :func:`~stencil_cad.exchange.step.step_text` writes.

    Args:
        geom: The plate's description.

    Returns:
        ``faces``, ``cylinders``, ``top_bounds`` and ``genus`` (the through holes).
    """
    glyphs = geom.glyphs if geom.glyphs and geom.relief_mm != 0.0 else ()
    rings = [geom.outline, *geom.polygons] + [r for outer, inner in glyphs for r in (outer, *inner)]
    sides = sum(len(r) for r in rings)
    relief = sum(1 + len(inner) for _, inner in glyphs)
    n = len(geom.circles_r)
    return {
        "faces": sides + n + 2 + relief,
        "cylinders": n,
        "top_bounds": 1 + geom.hole_count + len(glyphs),
        "genus": geom.hole_count,
    }


def _against(geom: PlateGeometry, topo: dict[str, int], cylinders: int, most_bounds: int) -> list[str]:
    """The file's counts against the description's."""
    want = expected_counts(geom)
    fails = []
    if topo["chi"] % 2 or topo["genus"] != want["genus"]:
        fails.append(
            f"Euler–Poincaré: V {topo['vertices']} − E {topo['edges']} + F {topo['faces']} − (L {topo['bounds']} − F) "
            f"= {topo['chi']} gives genus {topo['chi'] / -2 + 1:g}, but the plate has {want['genus']} through holes"
        )
    if topo["faces"] != want["faces"]:
        fails.append(f"the solid has {topo['faces']} faces, the description {want['faces']}")
    if cylinders != want["cylinders"]:
        fails.append(
            f"the solid has {cylinders} cylindrical hole faces, the description {want['cylinders']} round holes"
        )
    if most_bounds != want["top_bounds"]:
        fails.append(
            f"the top face has {most_bounds} bounds, expected {want['top_bounds']} (outline, holes, letters)"
        )
    return fails


def _bbox(g: Geometry, sh: Shell) -> np.ndarray:
    """``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` mm of the shell's vertices and whole circles."""
    pts = g.vertex[np.unique(sh.start)]
    circ = np.unique(g.curve[sh.edge[g.curve_kind[sh.edge] == 1]])
    c, r = g.circle_centre[circ], g.circle_r[circ][:, None] * np.array([1.0, 1.0, 0.0])
    allp = np.concatenate([pts, c - r, c + r])
    return np.array([allp.min(axis=0), allp.max(axis=0)])


def check_step_text(text: str, geom: PlateGeometry) -> dict[str, Any]:
    """Check a plate's STEP text against its description, without the CAD kernel (see the module doc).

    Args:
        text: The STEP text written by :func:`~stencil_cad.exchange.step.step_text`.
        geom: The description it was written from.

    Returns:
        ``solids``, ``shells``, ``faces``, ``cylinders``, ``edges``, ``vertices``, ``bounds``,
        ``genus``, ``volume`` (mm³), ``analytic_volume`` (mm³), ``rel_error``, ``bbox``
        (``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` mm), ``seconds`` and ``fails``: a message per
        failed check, empty when the file is a valid solid of the description.
    """
    t0 = time.perf_counter()
    fails: list[str] = []
    try:
        br = read_brep(text)
        g = geometry_of(br)
        sh = shell_of(br, g, _solid_faces(br, fails))
    except StepReadError as exc:
        return {
            "solids": 0,
            "fails": [f"the STEP text cannot be read: {exc}"],
            "seconds": time.perf_counter() - t0,
        }
    topo = _topology(br, sh, fails)
    fails += _off_curves(g) + _off_surfaces(br, g, sh)
    fl = _flat_faces(br, g, sh, fails)
    fails += _geometry_fails(br, g, sh, fl)
    cylinders = int((sh.surface_kind == 1).sum())
    most_bounds = int(np.bincount(sh.face_of_bound).max(initial=0)) if len(sh.face_of_bound) else 0
    fails += _against(geom, topo, cylinders, most_bounds)
    volume = float(np.dot(fl.z, fl.area))
    analytic = float(geom.volume)
    rel = abs(volume - analytic) / abs(analytic) if analytic else math.inf
    if not rel <= VOLUME_RTOL:
        fails.append(
            f"volume {volume:.6f} mm³ (divergence theorem over the file's faces) differs from the analytic "
            f"{analytic:.6f} mm³ by {rel:.2e} (> {VOLUME_RTOL:g})"
        )
    bbox = _bbox(g, sh)
    want = np.array(geom.bbox)
    if not np.allclose(bbox, want, rtol=0.0, atol=1e-6):
        fails.append(
            f"bounding box {np.round(bbox, 4).tolist()} differs from the configured {want.round(4).tolist()}"
        )
    return {
        "solids": br.count("MANIFOLD_SOLID_BREP"),
        "shells": br.count("CLOSED_SHELL") + br.count("OPEN_SHELL"),
        **{k: topo[k] for k in ("faces", "edges", "vertices", "bounds", "genus")},
        "cylinders": cylinders,
        "volume": volume,
        "analytic_volume": analytic,
        "rel_error": rel,
        "bbox": bbox.tolist(),
        "seconds": time.perf_counter() - t0,
        "fails": fails,
    }
