"""A small solid of planar and upright cylindrical faces, bounded by lines and arcs about z: its STEP text and its mesh.

The wall (:mod:`stencil_cad.cad.wall_brep`) is a few dozen such faces: prisms of its outlines,
whose arcs are the rounded corners and key tabs, and a finger slot. OCCT made it by Boolean cuts
and wrote it with its STEP writer and mesher, which made every job import OCP (0.6-1.0 CPU-s) and
spend about 0.3 s more in OCCT; here the faces are given by hand, each vertex and edge once (an
edge is found again by its ends, so two faces that meet share it), and written as the plates'
STEP is (:mod:`.step`: AP214, mm, exact circles). :func:`check_brep_text`
(:mod:`.brep_check`) reads the written text back as a solid, and ``tests/cad/test_wall.py`` reads
it with OCCT: one valid solid with the wall's volume, box and faces.

The mesh shares each edge's points between its two faces, so it is closed: an arc is cut into
the fewest equal steps whose chords stay within the tolerance, a planar face is triangulated in
its plane and a cylindrical face unrolled, by manifold3d's polygon triangulator (already the
slicer tiling's dependency).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..model import TriMesh
from .step import StepWriter, begin_solid, end_solid, step_reals

__all__ = ["Brep", "Edge", "Face"]

Point = tuple[float, float, float]
Use = tuple[int, bool]  # an edge and whether the loop runs along it


@dataclass(frozen=True)
class Edge:
    """A line, or an arc counter-clockwise about +z from ``v0`` to ``v1`` (``centre``, ``radius``)."""

    v0: int
    v1: int
    centre: Point | None = None
    radius: float = 0.0


@dataclass
class Face:
    """A plane or an upright cylinder, bounded by loops of edge uses.

    The plane has its outward ``normal``; the cylinder its ``centre`` on its axis, ``radius`` and
    ``outward`` (the material inside it). The outer loop comes first; each runs counter-clockwise
    about the outward normal (a hole's clockwise).
    """

    loops: list[list[Use]]
    normal: Point | None = None
    centre: Point | None = None
    radius: float = 0.0
    outward: bool = True


def _key(p) -> tuple[float, float, float]:
    return (round(float(p[0]), 9), round(float(p[1]), 9), round(float(p[2]), 9))


@dataclass
class Brep:
    """Vertices, edges and faces of one solid (mm), each vertex and edge made once."""

    points: list[Point] = field(default_factory=list)
    edges: list[Edge] = field(default_factory=list)
    faces: list[Face] = field(default_factory=list)
    _vertex: dict = field(default_factory=dict)
    _edge: dict = field(default_factory=dict)

    def vertex(self, p) -> int:
        """The vertex at ``p``, made on first use."""
        k = _key(p)
        if k not in self._vertex:
            self._vertex[k] = len(self.points)
            self.points.append(k)
        return self._vertex[k]

    def line(self, p, q) -> Use:
        """The straight edge from ``p`` to ``q``, as a use running from ``p``."""
        a, b = self.vertex(p), self.vertex(q)
        if a == b:
            raise ValueError(f"an edge from {p} to itself")
        k = ("L", min(a, b), max(a, b))
        if k not in self._edge:
            self._edge[k] = len(self.edges)
            self.edges.append(Edge(a, b))
        e = self._edge[k]
        return e, self.edges[e].v0 == a

    def arc(self, p, q, centre, ccw: bool) -> Use:
        """The arc about +z through ``centre`` from ``p`` to ``q``, counter-clockwise or not, as a use from ``p``."""
        a, b = self.vertex(p), self.vertex(q)
        lo, hi = (a, b) if ccw else (b, a)
        c = _key(centre)
        k = ("A", lo, hi, c)
        if k not in self._edge:
            self._edge[k] = len(self.edges)
            self.edges.append(Edge(lo, hi, c, math.hypot(p[0] - c[0], p[1] - c[1])))
        return self._edge[k], ccw

    def step_text(self, name: str, description: str) -> str:
        """The solid as STEP AP214 text in mm (one MANIFOLD_SOLID_BREP), the same bytes for the same solid."""
        return _step_text(self, name, description)

    def mesh(self, tolerance_mm: float) -> TriMesh:
        """A closed triangle mesh of the solid, each arc within ``tolerance_mm`` of its chords."""
        return _mesh(self, tolerance_mm)


# ----------------------------------------------------------------------------- STEP


def _write_edges(w: StepWriter, br: Brep, ids: dict) -> list[int]:
    """Points, vertices and EDGE_CURVEs of every edge; returns the edges' ids."""
    pts = np.array(br.points, dtype=np.float64).reshape(-1, 3)
    cp = w.points(pts)
    vx = w.many([f"VERTEX_POINT('',#{p})" for p in cp.tolist()])
    out = []
    for e in br.edges:
        p0, p1 = pts[e.v0], pts[e.v1]
        if e.centre is None:
            d = p1 - p0
            length = float(np.linalg.norm(d))
            du = w.directions((d / length)[None])[0]
            vec = w.one(f"VECTOR('',#{du},{step_reals([length])[0]})")
            curve = w.one(f"LINE('',#{cp[e.v0]},#{vec})")
        else:
            c = w.points(np.array([e.centre]))[0]
            ax = w.one(f"AXIS2_PLACEMENT_3D('',#{c},#{ids['dz']},#{ids['dx']})")
            curve = w.one(f"CIRCLE('',#{ax},{step_reals([e.radius])[0]})")
        out.append(w.one(f"EDGE_CURVE('',#{vx[e.v0]},#{vx[e.v1]},#{curve},.T.)"))
    return out


def _write_face(w: StepWriter, face: Face, edge_ids: list[int], ids: dict, pts: np.ndarray, br: Brep) -> int:
    bounds = []
    for k, loop in enumerate(face.loops):
        oes = [w.one(f"ORIENTED_EDGE('',*,*,#{edge_ids[e]},{'.T.' if fwd else '.F.'})") for e, fwd in loop]
        lp = w.one("EDGE_LOOP('',(" + ",".join(f"#{o}" for o in oes) + "))")
        bounds.append(w.one(f"{'FACE_OUTER_BOUND' if k == 0 else 'FACE_BOUND'}('',#{lp},.T.)"))
    if face.normal is not None:
        first = br.edges[face.loops[0][0][0]]
        origin = w.points(pts[first.v0][None])[0]
        n = np.array(face.normal, dtype=np.float64)
        ref = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
        ref = ref - n * float(ref @ n)
        dn, dr = w.directions(np.array([n, ref / np.linalg.norm(ref)]))
        ax = w.one(f"AXIS2_PLACEMENT_3D('',#{origin},#{dn},#{dr})")
        surface, sense = w.one(f"PLANE('',#{ax})"), ".T."
    else:
        assert face.centre is not None
        c = w.points(np.array([face.centre]))[0]
        ax = w.one(f"AXIS2_PLACEMENT_3D('',#{c},#{ids['dz']},#{ids['dx']})")
        surface = w.one(f"CYLINDRICAL_SURFACE('',#{ax},{step_reals([face.radius])[0]})")
        sense = ".T." if face.outward else ".F."
    return w.one("ADVANCED_FACE('',(" + ",".join(f"#{b}" for b in bounds) + f"),#{surface},{sense})")


def _step_text(br: Brep, name: str, description: str) -> str:
    w, head = begin_solid(name, "stencil_part")
    edge_ids = _write_edges(w, br, head.ids)
    pts = np.array(br.points, dtype=np.float64).reshape(-1, 3)
    faces = [_write_face(w, f, edge_ids, head.ids, pts, br) for f in br.faces]
    return end_solid(w, head, faces, description)


# ----------------------------------------------------------------------------- mesh


def _edge_points(br: Brep, tolerance_mm: float) -> tuple[np.ndarray, list[np.ndarray]]:
    """Every mesh point, and per edge the indices of its points from ``v0`` to ``v1``."""
    pts = [np.array(br.points, dtype=np.float64).reshape(-1, 3)]
    n = len(pts[0])
    runs = []
    for e in br.edges:
        if e.centre is None:
            runs.append(np.array([e.v0, e.v1]))
            continue
        c = np.array(e.centre)
        a0 = math.atan2(br.points[e.v0][1] - c[1], br.points[e.v0][0] - c[0])
        a1 = math.atan2(br.points[e.v1][1] - c[1], br.points[e.v1][0] - c[0])
        sweep = (a1 - a0) % (2 * math.pi) or 2 * math.pi
        half = math.acos(max(-1.0, 1.0 - tolerance_mm / e.radius)) if tolerance_mm < e.radius else math.pi / 2
        steps = max(1, math.ceil(sweep / (2 * half) - 1e-9))
        a = a0 + sweep * np.arange(1, steps) / steps
        inner = np.column_stack(
            [c[0] + e.radius * np.cos(a), c[1] + e.radius * np.sin(a), np.full(len(a), c[2])]
        )
        pts.append(inner)
        runs.append(np.concatenate([[e.v0], n + np.arange(len(a)), [e.v1]]))
        n += len(a)
    return np.concatenate(pts), runs


def _loop_points(loop: list[Use], runs: list[np.ndarray]) -> np.ndarray:
    return np.concatenate([(runs[e] if fwd else runs[e][::-1])[:-1] for e, fwd in loop])


def _plane_uv(face: Face, xyz: np.ndarray) -> np.ndarray:
    n = np.array(face.normal, dtype=np.float64)
    u = np.array([1.0, 0.0, 0.0]) if abs(n[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    u = u - n * float(u @ n)
    u /= np.linalg.norm(u)
    return np.column_stack([xyz @ u, xyz @ np.cross(n, u)])


def _cylinder_uv(face: Face, xyz: np.ndarray, start: float) -> np.ndarray:
    assert face.centre is not None
    a = np.unwrap(np.arctan2(xyz[:, 1] - face.centre[1], xyz[:, 0] - face.centre[0]) - start)
    u = face.radius * a * (1.0 if face.outward else -1.0)
    return np.column_stack([u, xyz[:, 2]])


def _mesh(br: Brep, tolerance_mm: float) -> TriMesh:
    import manifold3d

    xyz, runs = _edge_points(br, tolerance_mm)
    tris = []
    for face in br.faces:
        loops = [_loop_points(lp, runs) for lp in face.loops]
        idx = np.concatenate(loops)
        if face.normal is not None:
            uv = [_plane_uv(face, xyz[lp]) for lp in loops]
        else:
            first = xyz[loops[0][0]]
            assert face.centre is not None
            start = math.atan2(first[1] - face.centre[1], first[0] - face.centre[0])
            uv = [_cylinder_uv(face, xyz[lp], start) for lp in loops]
        t = np.asarray(manifold3d.triangulate([np.ascontiguousarray(p) for p in uv], 1e-9), dtype=np.int64)
        tris.append(idx[t.reshape(-1, 3)])
    faces = np.concatenate(tris) if tris else np.zeros((0, 3), dtype=np.int64)
    return TriMesh(vertices=xyz, faces=faces, info={"vertices": len(xyz), "triangles": len(faces)})
