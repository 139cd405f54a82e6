"""A kernel-free check of a part's STEP text written by :class:`~stencil_cad.exchange.brep.Brep`: the wall's file.

It holds the file to what OCCT's checks held the wall's solid to (one valid solid, its analytic
volume, its box), as :mod:`.step_check` does a plate's, and reuses that module's reading and
checks: the product's one closed, oriented solid in mm (every edge used twice, once each way;
loops that close; connected faces), its Euler–Poincaré genus, every vertex on its edges' curves
and its faces' surfaces, planes horizontal or vertical and cylinders about z, each side face's
normal with its loop, and each horizontal face's with its bounds (an outer bound counter-clockwise
about the face's outward normal, a hole clockwise). What differs from a plate: a horizontal face's
bound may mix lines and arcs, so its area is the shoelace over its vertices plus each arc's circular segment,
``r² (θ − sin θ) / 2`` signed by the way the loop turns; and the box takes each arc's extreme
points that its sweep passes. The volume is the divergence theorem with F = (0, 0, z) over the
horizontal faces, against the analytic one to :data:`~.step_check.VOLUME_RTOL`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from .step_brep import Geometry, Shell, StepReadError
from .step_check import VOLUME_RTOL, off_curves, off_surfaces, read_solid, sides_outward, topology
from .step_faces import AXIS_TOL

__all__ = ["check_brep_text"]


def _turns(g: Geometry, sh: Shell, uses: np.ndarray) -> np.ndarray:
    """+1 where an arc use runs counter-clockwise about +z, -1 where clockwise."""
    cr = g.curve[sh.edge[uses]]
    return (
        np.sign(g.circle_axis[cr, 2])
        * np.where(g.edge_fwd[sh.edge[uses]], 1, -1)
        * np.where(sh.fwd[uses], 1, -1)
    )


def _sweeps(g: Geometry, sh: Shell, uses: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each arc use's centre row, start angle and signed sweep (radians, a whole circle ±2π)."""
    cr = g.curve[sh.edge[uses]]
    c = g.circle_centre[cr]
    a0 = np.arctan2(*(g.vertex[sh.start[uses]] - c)[:, 1::-1].T)
    a1 = np.arctan2(*(g.vertex[sh.end[uses]] - c)[:, 1::-1].T)
    turn = _turns(g, sh, uses)
    sweep = np.mod((a1 - a0) * turn, 2 * math.pi)
    sweep = np.where(sweep <= 1e-12, 2 * math.pi, sweep)
    return cr, a0, turn * sweep


def _flat_bounds(g: Geometry, sh: Shell) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The horizontal faces' bounds: each one's face, its signed area seen from +z (mm², arcs' segments in) and its z."""
    planar = sh.surface_kind == 0
    row = np.where(planar, sh.surface, 0)
    flat = planar & (np.abs(g.plane_normal[row, 2]) > 1 - AXIS_TOL)
    face = sh.face_of_bound[sh.loop_of_use]
    use = np.flatnonzero(flat[face])
    loop = sh.loop_of_use[use]
    first = np.searchsorted(sh.loop_of_use, np.arange(len(sh.face_of_bound)))
    ref = g.vertex[sh.start[np.minimum(first, max(len(sh.start) - 1, 0))[loop]], :2]
    a, b = g.vertex[sh.start[use], :2] - ref, g.vertex[sh.end[use], :2] - ref
    area = 0.5 * (a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1])
    arc = g.curve_kind[sh.edge[use]] == 1
    if arc.any():
        cr, _, sweep = _sweeps(g, sh, use[arc])
        area[arc] += 0.5 * g.circle_r[cr] ** 2 * (sweep - np.sin(sweep))
    area *= np.where(sh.bound_fwd[loop], 1.0, -1.0)
    bounds = np.flatnonzero(flat[sh.face_of_bound])
    per_bound = np.bincount(loop, weights=area, minlength=len(sh.face_of_bound))[bounds]
    return bounds, per_bound, g.plane_point[row[sh.face_of_bound[bounds]], 2]


def _volume(g: Geometry, sh: Shell) -> float:
    """The divergence theorem over the horizontal faces: z times each face's signed area seen from +z."""
    _, area, z = _flat_bounds(g, sh)
    return float(np.sum(z * area))


def _flats_outward(br, g: Geometry, sh: Shell) -> list[str]:
    """Horizontal faces whose normal is against their bounds, or a bound that encloses no area.

    An outer bound runs counter-clockwise about its face's outward normal, a hole's clockwise.
    Neither the edge uses (which tie the loops to one another) nor the volume (from the loops' way
    round) see a face whose own normal is turned into the material; the side faces are checked
    for that by :func:`~.step_check.sides_outward`.
    """
    bounds, area, _ = _flat_bounds(g, sh)
    face = sh.face_of_bound[bounds]
    up = np.sign(g.plane_normal[sh.surface[face], 2]) * np.where(
        br.flag["ADVANCED_FACE"][sh.faces[face]], 1, -1
    )
    seen = area * up * np.where(sh.bound_outer[bounds], 1.0, -1.0)
    bad = np.flatnonzero(~(seen > 0))
    if not len(bad):
        return []
    return [
        f"{len(np.unique(face[bad]))} horizontal faces have a bound that runs the wrong way about the "
        f"face's normal or encloses no area (first #{int(br.ids['ADVANCED_FACE'][sh.faces[face[bad[0]]]])})"
    ]


def _bbox(g: Geometry, sh: Shell) -> np.ndarray:
    """``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` mm of the vertices and the arcs' extreme points."""
    pts = [g.vertex[np.unique(sh.start)]]
    arcs = np.flatnonzero(g.curve_kind[sh.edge] == 1)
    if len(arcs):
        cr, a0, sweep = _sweeps(g, sh, arcs)
        for k in range(4):  # the arc's points at 0, 90, 180 and 270 degrees, where it passes them
            at = k * math.pi / 2
            lo = np.minimum(a0, a0 + sweep)
            passes = np.mod(at - lo, 2 * math.pi) <= np.abs(sweep)
            xy = g.circle_centre[cr] + g.circle_r[cr][:, None] * np.array([math.cos(at), math.sin(at), 0.0])
            pts.append(xy[passes])
    allp = np.concatenate(pts)
    return np.array([allp.min(axis=0), allp.max(axis=0)])


def check_brep_text(
    text: str, volume_mm3: float, bbox: tuple[float, ...], genus: int, bbox_atol_mm: float = 1e-6
) -> dict[str, Any]:
    """Check a part's STEP text against its analytic volume, box and genus, without the CAD kernel.

    Args:
        text: The STEP text written by :meth:`~stencil_cad.exchange.brep.Brep.step_text`.
        volume_mm3: The part's analytic volume in mm³.
        bbox: Its expected bounding box ``(xmin, ymin, zmin, xmax, ymax, zmax)`` in mm.
        genus: Its through holes (a wall's opening: 1).
        bbox_atol_mm: How far the box may stray from ``bbox`` (a box from a sampled outline: its chord tolerance).

    Returns:
        ``n_solids``, ``valid``, ``volume``, ``analytic_volume``, ``rel_error``, ``bbox``, ``faces``
        and ``fails``: a message per failed check, empty when the file is a valid solid of them.
    """
    fails: list[str] = []
    try:
        br, g, sh = read_solid(text, fails)
    except StepReadError as exc:
        return {"n_solids": 0, "valid": False, "fails": [f"the STEP text cannot be read: {exc}"]}
    topo = topology(br, sh, fails)
    if topo["genus"] != genus:
        fails.append(
            f"the solid has genus {topo['genus']} (V - E + 2F - L = {topo['chi']}), expected {genus}"
        )
    whole = "a circle edge does not start and end at one vertex (a whole circle)"
    fails += [f for f in off_curves(g) if f != whole] + off_surfaces(br, g, sh) + sides_outward(br, g, sh)
    fails += _flats_outward(br, g, sh)
    volume = _volume(g, sh)
    rel = abs(volume - volume_mm3) / abs(volume_mm3) if volume_mm3 else math.inf
    if not rel <= VOLUME_RTOL:
        fails.append(
            f"volume {volume:.6f} mm³ (divergence theorem over the file's faces) differs from the analytic "
            f"{volume_mm3:.6f} mm³ by {rel:.2e} (> {VOLUME_RTOL:g})"
        )
    got = _bbox(g, sh).reshape(-1)
    if not np.allclose(got, np.asarray(bbox, dtype=np.float64), rtol=0.0, atol=bbox_atol_mm):
        fails.append(f"bounding box {np.round(got, 4).tolist()} differs from the expected {list(bbox)}")
    return {
        "n_solids": br.count("MANIFOLD_SOLID_BREP"),
        "valid": not fails,
        "volume": round(volume, 4),
        "analytic_volume": round(volume_mm3, 4),
        "rel_error": rel,
        "bbox": [round(float(v), 4) for v in got],
        "faces": topo["faces"],
        "fails": fails,
    }
