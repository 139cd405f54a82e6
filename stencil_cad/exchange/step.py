"""The plate as STEP text (AP214, exact circles, one solid), without the CAD kernel.

OCCT's STEP writer is quadratic in the holes of one face (measured here:
transfer of a 1,000-hole plate 10.6 s, 14,000 holes 710 s), so plates described
by a :class:`~stencil_cad.model.PlateGeometry` are written by a small linear
AP214 writer of our own. The B-rep it writes uses only planes, cylinders, lines
and circles: each through hole is one cylindrical face bounded by two circles
and a seam line; each polygon edge (outline, cut-outs, letters) one planar side
face; the top and bottom are planar faces with one bound per hole. Every edge
is written once and used by exactly two faces, once in each direction. The
tests read these files back with OCCT and compare them with the solid built in
:mod:`stencil_cad.cad.plate` (volume, faces, validity).

Shapes that did not come from a description (a template's own solid) go
through OCCT's writer instead (:mod:`stencil_cad.cad.writers`), which is only
fast for small plates.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..geometry import as_ccw, as_cw
from ..model import PlateGeometry

__all__ = ["STEP_TIMESTAMP", "SolidHead", "StepWriter", "begin_solid", "end_solid", "step_reals", "step_text"]

#: Fixed timestamp in the STEP header, so the same plate gives the same file.
STEP_TIMESTAMP = "2026-01-01T00:00:00"


def step_reals(a) -> list[str]:
    """STEP reals: fixed notation (a decimal point is required), 1e-10 mm resolution."""
    return [f"{v:.10f}" for v in np.asarray(a, dtype=np.float64).reshape(-1).tolist()]


class StepWriter:
    """Accumulates numbered STEP entity lines (a plate's, and :class:`~.brep.Brep`'s solid)."""

    def __init__(self) -> None:
        self.lines: list[str] = []
        self.next = 1

    def one(self, body: str) -> int:
        """Write one entity; returns its id."""
        i = self.next
        self.lines.append(f"#{i}={body};")
        self.next += 1
        return i

    def many(self, bodies: list[str]) -> np.ndarray:
        """Write entities in order; returns their ids."""
        n = len(bodies)
        ids = np.arange(self.next, self.next + n)
        self.lines.extend(f"#{i}={b};" for i, b in zip(ids.tolist(), bodies, strict=True))
        self.next += n
        return ids

    def points(self, xyz: np.ndarray) -> np.ndarray:
        """A CARTESIAN_POINT per row of ``(n, 3)`` mm; returns their ids."""
        s = step_reals(xyz)
        return self.many(
            [f"CARTESIAN_POINT('',({x},{y},{z}))" for x, y, z in zip(s[0::3], s[1::3], s[2::3], strict=True)]
        )

    def directions(self, xyz: np.ndarray) -> np.ndarray:
        """A DIRECTION per row of ``(n, 3)`` unit vectors; returns their ids."""
        s = step_reals(xyz)
        return self.many(
            [f"DIRECTION('',({x},{y},{z}))" for x, y, z in zip(s[0::3], s[1::3], s[2::3], strict=True)]
        )


def _oe(edges: np.ndarray, forward: bool) -> list[str]:
    flag = ".T." if forward else ".F."
    return [f"ORIENTED_EDGE('',*,*,#{e},{flag})" for e in np.asarray(edges).tolist()]


class _Ring:
    """One polygon ring of side faces, material on its left, from z0 to z1.

    Attributes after writing: ``eb``/``et`` bottom and top edge ids in ring order
    (one id for a circle).
    """

    def __init__(self, xy: np.ndarray, z0: float = 0.0, z1: float = 1.0):
        self.xy = xy
        self.z0, self.z1 = float(z0), float(z1)
        self.eb = self.et = np.zeros(0, dtype=np.int64)


def _write_polygon_rings(w: StepWriter, rings: list[_Ring], dz: int, faces: list) -> None:
    """Vertices, edges and planar side faces of polygon rings (vectorised over all rings)."""
    if not rings:
        return
    xy = np.concatenate([r.xy for r in rings])
    ring_of = np.repeat(np.arange(len(rings)), [len(r.xy) for r in rings])
    z0 = np.array([r.z0 for r in rings])[ring_of]
    z1 = np.array([r.z1 for r in rings])[ring_of]
    n = len(xy)
    idx = np.arange(n)
    starts = np.concatenate([[0], np.cumsum([len(r.xy) for r in rings])])
    nxt = idx + 1
    nxt[starts[1:] - 1] = starts[:-1]
    d = xy[nxt] - xy
    length = np.hypot(d[:, 0], d[:, 1])
    u = d / length[:, None]
    p0 = w.points(np.column_stack([xy, z0]))
    p1 = w.points(np.column_stack([xy, z1]))
    vb = w.many([f"VERTEX_POINT('',#{p})" for p in p0.tolist()])
    vt = w.many([f"VERTEX_POINT('',#{p})" for p in p1.tolist()])
    du = w.directions(np.column_stack([u, np.zeros(n)]))
    dn = w.directions(np.column_stack([u[:, 1], -u[:, 0], np.zeros(n)]))  # outward: right of the ring
    ls = step_reals(length)
    vec = w.many([f"VECTOR('',#{a},{b})" for a, b in zip(du.tolist(), ls, strict=True)])
    lb = w.many([f"LINE('',#{p},#{v})" for p, v in zip(p0.tolist(), vec.tolist(), strict=True)])
    lt = w.many([f"LINE('',#{p},#{v})" for p, v in zip(p1.tolist(), vec.tolist(), strict=True)])
    hs = step_reals(z1 - z0)
    vz = w.many([f"VECTOR('',#{dz},{h})" for h in hs])
    lv = w.many([f"LINE('',#{p},#{v})" for p, v in zip(p0.tolist(), vz.tolist(), strict=True)])
    eb = w.many(
        [
            f"EDGE_CURVE('',#{a},#{b},#{c},.T.)"
            for a, b, c in zip(vb.tolist(), vb[nxt].tolist(), lb.tolist(), strict=True)
        ]
    )
    et = w.many(
        [
            f"EDGE_CURVE('',#{a},#{b},#{c},.T.)"
            for a, b, c in zip(vt.tolist(), vt[nxt].tolist(), lt.tolist(), strict=True)
        ]
    )
    ev = w.many(
        [
            f"EDGE_CURVE('',#{a},#{b},#{c},.T.)"
            for a, b, c in zip(vb.tolist(), vt.tolist(), lv.tolist(), strict=True)
        ]
    )
    ax = w.many(
        [
            f"AXIS2_PLACEMENT_3D('',#{p},#{a},#{b})"
            for p, a, b in zip(p0.tolist(), dn.tolist(), du.tolist(), strict=True)
        ]
    )
    pl = w.many([f"PLANE('',#{a})" for a in ax.tolist()])
    faces.extend(_side_faces(w, eb, ev[nxt], et, ev, pl, ".T."))
    for k, r in enumerate(rings):
        r.eb = eb[starts[k] : starts[k + 1]]
        r.et = et[starts[k] : starts[k + 1]]


def _side_faces(
    w: StepWriter,
    bottom: np.ndarray,
    up: np.ndarray,
    top: np.ndarray,
    down: np.ndarray,
    surfaces: np.ndarray,
    sense: str,
) -> list:
    """One four-edge side face per entry: bottom edge, rising edge, top edge reversed, falling edge reversed.

    Returns:
        The new ADVANCED_FACE ids.
    """
    o1 = w.many(_oe(bottom, True))
    o2 = w.many(_oe(up, True))
    o3 = w.many(_oe(top, False))
    o4 = w.many(_oe(down, False))
    loops = w.many(
        [
            f"EDGE_LOOP('',(#{a},#{b},#{c},#{d}))"
            for a, b, c, d in zip(o1.tolist(), o2.tolist(), o3.tolist(), o4.tolist(), strict=True)
        ]
    )
    bounds = w.many([f"FACE_OUTER_BOUND('',#{lp},.T.)" for lp in loops.tolist()])
    return w.many(
        [
            f"ADVANCED_FACE('',(#{b}),#{p},{sense})"
            for b, p in zip(bounds.tolist(), surfaces.tolist(), strict=True)
        ]
    ).tolist()


def _write_circle_rings(
    w: StepWriter, xy: np.ndarray, rad: np.ndarray, z0: float, z1: float, ids: dict, faces: list
):
    """Round through holes: two circles about -z, a seam line and a cylindrical face each.

    Returns:
        ``(eb, et)`` ``(N,)`` bottom and top circle edge ids.
    """
    n = len(rad)
    if n == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    c0 = w.points(np.column_stack([xy, np.full(n, z0)]))
    c1 = w.points(np.column_stack([xy, np.full(n, z1)]))
    dzn, dz, dx = ids["dzn"], ids["dz"], ids["dx"]
    a0 = w.many([f"AXIS2_PLACEMENT_3D('',#{p},#{dzn},#{dx})" for p in c0.tolist()])
    a1 = w.many([f"AXIS2_PLACEMENT_3D('',#{p},#{dzn},#{dx})" for p in c1.tolist()])
    rs = step_reals(rad)
    k0 = w.many([f"CIRCLE('',#{a},{r})" for a, r in zip(a0.tolist(), rs, strict=True)])
    k1 = w.many([f"CIRCLE('',#{a},{r})" for a, r in zip(a1.tolist(), rs, strict=True)])
    start = xy + np.column_stack([rad, np.zeros(n)])  # the circles' parameter 0
    p0 = w.points(np.column_stack([start, np.full(n, z0)]))
    p1 = w.points(np.column_stack([start, np.full(n, z1)]))
    vb = w.many([f"VERTEX_POINT('',#{p})" for p in p0.tolist()])
    vt = w.many([f"VERTEX_POINT('',#{p})" for p in p1.tolist()])
    eb = w.many([f"EDGE_CURVE('',#{v},#{v},#{c},.T.)" for v, c in zip(vb.tolist(), k0.tolist(), strict=True)])
    et = w.many([f"EDGE_CURVE('',#{v},#{v},#{c},.T.)" for v, c in zip(vt.tolist(), k1.tolist(), strict=True)])
    vec = ids["vz"][(z0, z1)]
    ls = w.many([f"LINE('',#{p},#{vec})" for p in p0.tolist()])
    ev = w.many(
        [
            f"EDGE_CURVE('',#{a},#{b},#{c},.T.)"
            for a, b, c in zip(vb.tolist(), vt.tolist(), ls.tolist(), strict=True)
        ]
    )
    ac = w.many([f"AXIS2_PLACEMENT_3D('',#{p},#{dz},#{dx})" for p in c0.tolist()])
    cyl = w.many([f"CYLINDRICAL_SURFACE('',#{a},{r})" for a, r in zip(ac.tolist(), rs, strict=True)])
    # The material is outside the cylinder: the face's normal points to the axis (.F.).
    faces.extend(_side_faces(w, eb, ev, et, ev, cyl, ".F."))
    return eb, et


def _loop(w: StepWriter, edges: np.ndarray, forward: bool, outer: bool) -> int:
    """One bound from a ring's edges, in ring order (forward) or reversed."""
    seq = np.asarray(edges) if forward else np.asarray(edges)[::-1]
    oes = w.many(_oe(seq, forward))
    lp = w.one("EDGE_LOOP('',(" + ",".join(f"#{o}" for o in oes.tolist()) + "))")
    kind = "FACE_OUTER_BOUND" if outer else "FACE_BOUND"
    return w.one(f"{kind}('',#{lp},.T.)")


def _loops_many(w: StepWriter, edge_ids: np.ndarray, forward: bool) -> np.ndarray:
    """Single-edge bounds (circles), vectorised."""
    oes = w.many(_oe(edge_ids, forward))
    lps = w.many([f"EDGE_LOOP('',(#{o}))" for o in oes.tolist()])
    return w.many([f"FACE_BOUND('',#{lp},.T.)" for lp in lps.tolist()])


def _plane_face(w: StepWriter, z: float, up: bool, bounds: list[int], ids: dict) -> int:
    pt = w.points(np.array([[0.0, 0.0, z]]))[0]
    ax = w.one(f"AXIS2_PLACEMENT_3D('',#{pt},#{ids['dz']},#{ids['dx']})")
    pl = w.one(f"PLANE('',#{ax})")
    return w.one(
        "ADVANCED_FACE('',(" + ",".join(f"#{b}" for b in bounds) + f"),#{pl},{'.T.' if up else '.F.'})"
    )


def _glyph_top_bounds(
    w: StepWriter,
    glyph_rings: list[tuple[_Ring, list[_Ring]]],
    relief: float,
    t: float,
    ids: dict,
    faces: list,
) -> list[int]:
    """The letters' bounds in the top face; the islands inside letters get top faces of their own."""
    bounds = []
    for outer, inner in glyph_rings:
        if relief < 0:
            bounds.append(_loop(w, outer.et, True, False))
            for r in inner:  # islands inside letters stay at the top
                faces.append(_plane_face(w, t, True, [_loop(w, r.et, True, True)], ids))
        else:
            bounds.append(_loop(w, outer.eb, False, False))
            for r in inner:
                faces.append(_plane_face(w, t, True, [_loop(w, r.eb, False, True)], ids))
    return bounds


def _relief_far_faces(
    w: StepWriter,
    glyph_rings: list[tuple[_Ring, list[_Ring]]],
    relief: float,
    t: float,
    ids: dict,
    faces: list,
) -> None:
    """Far faces of the relief: an engraving's floor, an emboss's top; both face +z."""
    for outer, inner in glyph_rings:
        if relief < 0:
            b = [_loop(w, outer.eb, False, True)] + [_loop(w, r.eb, False, False) for r in inner]
        else:
            b = [_loop(w, outer.et, True, True)] + [_loop(w, r.et, True, False) for r in inner]
        faces.append(_plane_face(w, t + relief, True, b, ids))


def _unit_context(w: StepWriter) -> int:
    """Millimetres, radians, steradians and a 1e-7 mm uncertainty: the representation context."""
    mm = w.one("( LENGTH_UNIT() NAMED_UNIT(*) SI_UNIT(.MILLI.,.METRE.) )")
    rad = w.one("( NAMED_UNIT(*) PLANE_ANGLE_UNIT() SI_UNIT($,.RADIAN.) )")
    sr = w.one("( NAMED_UNIT(*) SI_UNIT($,.STERADIAN.) SOLID_ANGLE_UNIT() )")
    unc = w.one(
        f"UNCERTAINTY_MEASURE_WITH_UNIT(LENGTH_MEASURE(1.E-07),#{mm},'distance_accuracy_value','confusion accuracy')"
    )
    return w.one(
        f"( GEOMETRIC_REPRESENTATION_CONTEXT(3) GLOBAL_UNCERTAINTY_ASSIGNED_CONTEXT((#{unc})) "
        f"GLOBAL_UNIT_ASSIGNED_CONTEXT((#{mm},#{rad},#{sr})) "
        "REPRESENTATION_CONTEXT('Context #1','3D Context with UNIT and UNCERTAINTY') )"
    )


def _write_head(w: StepWriter, safe: str) -> tuple[int, int, dict[str, Any]]:
    """The product records and the solid's placement (#1 to #15 and -z).

    Returns:
        ``(line of #10, line of #15, ids)``: #10 and #15 are filled in once the context and
        the shell exist; ``ids`` holds the directions and a cache of z vectors.
    """
    head = [
        "APPLICATION_PROTOCOL_DEFINITION('international standard','automotive_design',2000,#2)",
        "APPLICATION_CONTEXT('core data for automotive mechanical design processes')",
        "SHAPE_DEFINITION_REPRESENTATION(#4,#10)",
        "PRODUCT_DEFINITION_SHAPE('','',#5)",
        "PRODUCT_DEFINITION('design','',#6,#9)",
        "PRODUCT_DEFINITION_FORMATION('','',#7)",
        f"PRODUCT('{safe}','{safe}','',(#8))",
        "PRODUCT_CONTEXT('',#2,'mechanical')",
        "PRODUCT_DEFINITION_CONTEXT('part definition',#2,'design')",
    ]
    for body in head:
        w.one(body)
    rep_line = len(w.lines)
    w.one("ADVANCED_BREP_SHAPE_REPRESENTATION('',(#11,#15),#CTX)")  # #10, context filled in below
    w.one("AXIS2_PLACEMENT_3D('',#12,#13,#14)")  # 11
    w.one("CARTESIAN_POINT('',(0.,0.,0.))")  # 12
    dz = w.one("DIRECTION('',(0.,0.,1.))")  # 13
    dx = w.one("DIRECTION('',(1.,0.,0.))")  # 14
    msb_line = len(w.lines)
    w.one("MANIFOLD_SOLID_BREP('',#SHELL)")  # 15
    dzn = w.one("DIRECTION('',(0.,0.,-1.))")
    return rep_line, msb_line, {"dz": dz, "dx": dx, "dzn": dzn, "vz": {}}


@dataclass(frozen=True)
class SolidHead:
    """A solid's file begun by :func:`begin_solid`: its product name and what :func:`end_solid` fills in.

    Attributes:
        name: The product's name as written (letters, digits, space, ``_-.``; at most 60).
        rep_line: The line of #10, the shape representation, whose context comes last.
        msb_line: The line of #15, the solid, whose shell comes last.
        ids: The ids of the +z, +x and -z directions (``dz``, ``dx``, ``dzn``) and a cache of z vectors (``vz``).
    """

    name: str
    rep_line: int
    msb_line: int
    ids: dict[str, Any]


def begin_solid(name: str, default: str) -> tuple[StepWriter, SolidHead]:
    """A writer holding one solid's product records and placement (#1 to #15), named ``name`` (else ``default``)."""
    w = StepWriter()
    safe = "".join(ch for ch in name if ch.isalnum() or ch in " _-.")[:60] or default
    rep_line, msb_line, ids = _write_head(w, safe)
    return w, SolidHead(safe, rep_line, msb_line, ids)


def end_solid(w: StepWriter, head: SolidHead, faces: list[int], description: str) -> str:
    """The file's text: the solid's closed shell of ``faces``, its context in mm, the header with ``description``."""
    shell = w.one("CLOSED_SHELL('',(" + ",".join(f"#{f}" for f in faces) + "))")
    w.lines[head.msb_line] = f"#15=MANIFOLD_SOLID_BREP('',#{shell});"
    ctx = _unit_context(w)
    w.lines[head.rep_line] = f"#10=ADVANCED_BREP_SHAPE_REPRESENTATION('',(#11,#15),#{ctx});"
    w.one("PRODUCT_RELATED_PRODUCT_CATEGORY('part',$,(#7))")
    desc = "".join(ch for ch in description if ch.isalnum() or ch in " _-.")
    header = (
        f"ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('{desc}'),'2;1');\n"
        f"FILE_NAME('{head.name}','{STEP_TIMESTAMP}',(''),(''),'stencil_cad','stencil_cad','');\n"
        "FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\nENDSEC;\nDATA;\n"
    )
    return header + "\n".join(w.lines) + "\nENDSEC;\nEND-ISO-10303-21;\n"


def _vector_z(w: StepWriter, ids: dict[str, Any], z0: float, z1: float) -> int:
    """The VECTOR from ``z0`` to ``z1`` along +z, written once per pair."""
    key = (z0, z1)
    if key not in ids["vz"]:
        ids["vz"][key] = w.one(f"VECTOR('',#{ids['dz']},{step_reals([z1 - z0])[0]})")
    return ids["vz"][key]


def _glyph_rings(w: StepWriter, ids: dict[str, Any], geom: PlateGeometry, relief: float, t: float) -> list:
    """The letters' rings ``(outer, [inners])`` between the top and the relief, material on the left."""
    glyph_rings: list = []
    if relief != 0.0:
        za, zb = (t + relief, t) if relief < 0 else (t, t + relief)
        _vector_z(w, ids, za, zb)
        for outer, inner in geom.glyphs:
            oc = np.asarray(outer, dtype=np.float64)
            oc = as_ccw(oc)
            ic = [np.asarray(i, dtype=np.float64) for i in inner]
            ic = [as_cw(i) for i in ic]
            if relief < 0:  # engraved: the sheet is outside the glyph
                oc, ic = oc[::-1], [i[::-1] for i in ic]
            glyph_rings.append((_Ring(xy=oc, z0=za, z1=zb), [_Ring(xy=i, z0=za, z1=zb) for i in ic]))
    return glyph_rings


def step_text(geom: PlateGeometry, name: str = "stencil_plate") -> str:
    """The STEP AP214 text of a plate description (one manifold solid, mm).

    Args:
        geom: The plate.
        name: Product name in the file.

    Returns:
        The file's text.
    """
    w, head = begin_solid(name, "stencil_plate")
    ids = head.ids
    dz = ids["dz"]
    t = float(geom.thickness_mm)
    relief = float(geom.relief_mm) if geom.glyphs else 0.0
    faces: list[int] = []
    _vector_z(w, ids, 0.0, t)
    outline = as_ccw(geom.outline)
    out_ring = _Ring(xy=np.asarray(outline, dtype=np.float64), z0=0.0, z1=t)
    hole_rings = []
    for p in geom.polygons:
        p = np.asarray(p, dtype=np.float64)
        hole_rings.append(_Ring(xy=as_cw(p), z0=0.0, z1=t))
    glyph_rings = _glyph_rings(w, ids, geom, relief, t)
    all_poly = [out_ring, *hole_rings] + [r for g in glyph_rings for r in (g[0], *g[1])]
    _write_polygon_rings(w, all_poly, dz, faces)
    ceb, cet = _write_circle_rings(
        w,
        np.asarray(geom.circles_xy, dtype=np.float64).reshape(-1, 2),
        np.asarray(geom.circles_r),
        0.0,
        t,
        ids,
        faces,
    )

    # Bottom (facing -z): every ring's bottom edges, reversed.
    bounds = [_loop(w, out_ring.eb, False, True)]
    bounds += [_loop(w, r.eb, False, False) for r in hole_rings]
    bounds += _loops_many(w, ceb, False).tolist()
    faces.append(_plane_face(w, 0.0, False, bounds, ids))
    # Top (facing +z) at the thickness.
    bounds = [_loop(w, out_ring.et, True, True)]
    bounds += [_loop(w, r.et, True, False) for r in hole_rings]
    bounds += _loops_many(w, cet, True).tolist()
    bounds += _glyph_top_bounds(w, glyph_rings, relief, t, ids, faces)
    faces.append(_plane_face(w, t, True, bounds, ids))
    _relief_far_faces(w, glyph_rings, relief, t, ids, faces)

    return end_solid(w, head, faces, "stencil_cad plate")
