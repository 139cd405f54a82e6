"""A kernel-free check of a plate's STEP text: the very file a maker gets, against its description.

A job writes a plate's STEP from its :class:`~stencil_cad.model.PlateGeometry`
(:func:`~stencil_cad.exchange.step.step_text`), not from an OCCT solid, so this check reads that
text (:func:`~stencil_cad.exchange.step_brep.read_brep`) and holds it to what OCCT's checks held
the solid to (:func:`stencil_cad.cad.check_plate`), in time near linear in the entities (a plate
of 15,000 holes: 0.35 CPU-s). Each failure is named:

- **one solid**: exactly one MANIFOLD_SOLID_BREP, whose one CLOSED_SHELL lists every
  ADVANCED_FACE of the file once, and which is an item of the shape representation the product
  names, in millimetres (:func:`~stencil_cad.exchange.step_brep.shape_items`: else an importer
  finds no solid, or one a thousand times too big);
- **closed and oriented**: every EDGE_CURVE is used by exactly two ORIENTED_EDGEs of the shell's
  loops, once in each direction; each EDGE_LOOP chains end to start; the faces are connected;
  every face's normal agrees with its loops: each bound of a horizontal face runs
  counter-clockwise about the normal (a hole's clockwise), a vertical face's loop has its Newell
  vector along its normal, a hole's cylinder faces its axis (neither the edge uses nor the volume
  see a side face turned inside out, nor does OCCT's analyzer);
- **Euler–Poincaré**: V − E + F − (L − F) = 2(S − G) with S = 1 holds for G equal to the
  description's through holes (round holes, cut-outs and windows);
- **on their surfaces**: every vertex lies on its face's plane or cylinder, on its lines and
  circles; circles and cylinders agree; planes are horizontal or vertical, cylinders about z; no
  line edge without length, no circle of radius within the file's accuracy;
- **counts**: the faces, the cylindrical faces (one per round hole) and the top face's bounds
  against the description;
- **heights**: the bottom at 0 facing down, every other horizontal face up at the thickness or
  the label's relief, an engraving's floor above the bottom;
- **volume** by the divergence theorem with F = (0, 0, z): only horizontal faces add
  z · (signed area of their bounds), circles exactly πr², against the description's analytic
  volume (relative :data:`VOLUME_RTOL`; the writer's reals have 10 decimals);
- **bounding box** of the vertices and circles against the description's;
- **geometry OCCT's analyzer would catch** and the topology cannot
  (:func:`~stencil_cad.exchange.step_faces.face_geometry_fails`): on every horizontal face,
  bounds that cross, touch, overlap, nest or leave the outer one (a round hole within the file's
  distance accuracy, :data:`CLEARANCE_MM`, of another bound touches it), and bounds that enclose
  no area.

The reader refuses text it does not read as the writer writes it (an unknown entity where one
of its own belongs, a labelled entity, a value that is not a finite number, a point with the
wrong number of coordinates): the check then fails with the reason, never passes.

The design rules themselves (radius floor, web, edge margin, a window's web) are enforced on the
dots before any CAD (:mod:`stencil_cad.stipple.rules`, :func:`stencil_cad.cad.plate.check_holes`
again in the plate's build); this check only asks whether the file is a valid solid of the
description, which also catches a writer that broke it.
"""

from __future__ import annotations

import math
import time
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from ..model import PlateGeometry
from .step_brep import (
    Brep,
    Geometry,
    Shell,
    StepReadError,
    geometry_of,
    read_brep,
    segments,
    shape_items,
    shell_of,
)
from .step_faces import AXIS_TOL, CLEARANCE_MM, Flat, face_geometry_fails, flat_faces

__all__ = [
    "CLEARANCE_MM",
    "VOLUME_RTOL",
    "StepReadError",
    "check_step_text",
    "expected_counts",
    "off_curves",
    "off_surfaces",
    "read_solid",
    "sides_outward",
    "solid_faces",
    "topology",
]

#: Largest relative difference between the file's volume and the description's.
VOLUME_RTOL = 1e-9


def solid_faces(br: Brep, fails: list[str]) -> np.ndarray:
    """The rows of the faces the one solid's shell lists.

    Raises:
        StepReadError: No solid, or no product shape in millimetres (:func:`shape_items`).
    """
    n_solids = br.count("MANIFOLD_SOLID_BREP")
    if n_solids != 1:
        fails.append(f"expected exactly one MANIFOLD_SOLID_BREP, the file has {n_solids}")
    if n_solids == 0:
        raise StepReadError("the file holds no MANIFOLD_SOLID_BREP")
    solid = int(br.ids["MANIFOLD_SOLID_BREP"][0])
    if solid not in shape_items(br):
        fails.append(f"the solid #{solid} is not an item of the product's shape (an importer finds no solid)")
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


def topology(br: Brep, sh: Shell, fails: list[str]) -> dict[str, int]:
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


def off_curves(g: Geometry) -> list[str]:
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
    length = np.linalg.norm(g.vertex[g.edge_v2[line]] - g.vertex[g.edge_v1[line]], axis=1)
    if (length <= CLEARANCE_MM).any():
        fails.append(f"{int((length <= CLEARANCE_MM).sum())} line edges have no length (degenerate edges)")
    if (g.circle_r <= CLEARANCE_MM).any() or (g.cyl_r <= CLEARANCE_MM).any():
        fails.append(f"a circle or cylinder has a radius of at most {CLEARANCE_MM:g} mm (a degenerate hole)")
    return fails


def off_surfaces(br: Brep, g: Geometry, sh: Shell) -> list[str]:
    """Planes neither horizontal nor vertical, cylinders not about z, edges off their faces."""
    fails = []
    face = sh.face_of_bound[sh.loop_of_use]
    plane = sh.surface_kind[face] == 0
    row = sh.surface[face]
    nz = np.abs(g.plane_normal[:, 2])
    if ((nz > AXIS_TOL) & (nz < 1 - AXIS_TOL)).any():
        fails.append("a planar face is neither horizontal nor vertical (only such plates are written)")
    if (np.abs(np.abs(g.cyl_axis[:, 2]) - 1) > AXIS_TOL).any():
        fails.append("a cylindrical face is not about the z axis")
    pr = row[plane]
    height = ((g.vertex[sh.start[plane]] - g.plane_point[pr]) * g.plane_normal[pr]).sum(axis=1)
    circ = plane & (g.curve_kind[sh.edge] == 1)
    cr, cp = g.curve[sh.edge[circ]], row[circ]
    tilt = np.linalg.norm(np.cross(g.circle_axis[cr], g.plane_normal[cp]), axis=1)
    centre = ((g.circle_centre[cr] - g.plane_point[cp]) * g.plane_normal[cp]).sum(axis=1)
    if (
        (np.abs(height) > CLEARANCE_MM).any()
        or (tilt > AXIS_TOL).any()
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


def sides_outward(br: Brep, g: Geometry, sh: Shell) -> list[str]:
    """Side faces whose normal points into the material: vertical planes and the holes' cylinders.

    The edge uses tie every loop's direction to the horizontal faces' (checked in
    :func:`_flat_faces`); this checks that each side face's own normal agrees with its loop,
    which neither the edge uses nor the volume (z-flux only) see.
    """
    fails = []
    flag = np.where(br.flag["ADVANCED_FACE"][sh.faces], 1.0, -1.0)
    face = sh.face_of_bound[sh.loop_of_use]
    runs = np.where(sh.bound_fwd[sh.loop_of_use], 1.0, -1.0)
    planar = sh.surface_kind == 0
    row = np.where(planar, sh.surface, 0)
    vertical = planar & (np.abs(g.plane_normal[row, 2]) <= AXIS_TOL)
    # A vertical face's loop runs counter-clockwise about its normal: their Newell vector agrees.
    use = np.flatnonzero(vertical[face])
    p = g.plane_point[row[face[use]]]
    turn = np.cross(g.vertex[sh.start[use]] - p, g.vertex[sh.end[use]] - p) * runs[use, None]
    newell = np.stack([np.bincount(face[use], turn[:, k], len(sh.faces)) for k in range(3)], axis=1)
    along = (newell * g.plane_normal[row] * flag[:, None]).sum(axis=1)
    bad = np.flatnonzero(vertical & (along <= 0))
    if len(bad):
        fails.append(
            f"{len(bad)} vertical faces have their normal against their loop "
            f"(first #{int(br.ids['ADVANCED_FACE'][sh.faces[bad[0]]])})"
        )
    # A cylinder with its normal out of the axis (.T.) runs its lower circle counter-clockwise
    # about +z and its upper clockwise; with its normal to the axis (a hole), the other way.
    use = np.flatnonzero(~planar[face] & (g.curve_kind[sh.edge] == 1))
    cr = g.curve[sh.edge[use]]
    turn = np.sign(g.circle_axis[cr, 2]) * np.where(g.edge_fwd[sh.edge[use]], 1, -1)
    turn = turn * np.where(sh.fwd[use], 1, -1) * runs[use]
    z = g.circle_centre[cr, 2]
    n = np.bincount(face[use], minlength=len(sh.faces))
    mid = np.bincount(face[use], z, len(sh.faces)) / np.maximum(n, 1)
    rise = np.bincount(face[use], turn * (z - mid[face[use]]), len(sh.faces))
    bad = np.flatnonzero(~planar & (rise * flag >= 0))
    if len(bad):
        fails.append(
            f"{len(bad)} cylindrical faces have their normal against their loop "
            f"(first #{int(br.ids['ADVANCED_FACE'][sh.faces[bad[0]]])})"
        )
    return fails


def _heights(geom: PlateGeometry, fl: Flat) -> list[str]:
    """Horizontal faces where the description has none: the bottom at 0 facing down, the rest up.

    The volume and the box cannot see an engraving as deep as the plate: its floor would lie on
    the bottom face, facing the other way (a sheet of no thickness).
    """
    t = float(geom.thickness_mm)
    relief = float(geom.relief_mm) if geom.glyphs else 0.0
    allowed = [(0.0, -1.0), (t, 1.0)] + ([(t + relief, 1.0)] if relief else [])
    ok = np.zeros(len(fl.z), dtype=bool)
    for z, up in allowed:
        ok |= (np.abs(fl.z - z) <= CLEARANCE_MM) & (fl.up == up)
    fails = []
    if not ok.all():
        i = np.flatnonzero(~ok)[0]
        fails.append(
            f"{int((~ok).sum())} horizontal faces lie where the description has none (first at "
            f"z = {fl.z[i]:.6f} mm, facing {'up' if fl.up[i] > 0 else 'down'})"
        )
    if not t + min(relief, 0.0) > CLEARANCE_MM:
        fails.append(f"the plate is {t:g} mm thick and its engraving {-relief:g} mm deep: none is left below")
    return fails


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


def read_solid(text: str, fails: list[str]) -> tuple[Brep, Geometry, Shell]:
    """The STEP text's entities, their geometry and its solid's shell; a solid beyond the first is a fail.

    Raises:
        StepReadError: Text this reader does not take (not the writers' entities, not mm, no closed shell).
    """
    br = read_brep(text)
    g = geometry_of(br)
    return br, g, shell_of(br, g, solid_faces(br, fails))


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
        br, g, sh = read_solid(text, fails)
    except StepReadError as exc:
        return {
            "solids": 0,
            "fails": [f"the STEP text cannot be read: {exc}"],
            "seconds": time.perf_counter() - t0,
        }
    topo = topology(br, sh, fails)
    fails += off_curves(g) + off_surfaces(br, g, sh)
    fl = flat_faces(br, g, sh, fails)
    fails += sides_outward(br, g, sh) + _heights(geom, fl)
    fails += face_geometry_fails(br, g, sh, fl)
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
