"""Checks of a built plate against analytic oracles, in time that scales.

``BRepCheck_Analyzer`` is roughly quadratic on one face with many holes (500
holes 13 s, 2,000 holes 278 s here), and so is ``BRepCheck_Shell`` (100 s at
14,000 holes). So validity is established in three parts:

1. By construction (:mod:`stencil_cad.cad.plate`): one planar face whose hole
   wires are simple, pairwise disjoint and inside the outer wire, swept by one
   prism; the label added by re-using the same edges. The input properties
   that make such a face valid are checked before building, in O(n log n):
   the dots' design rules (radius floor, web, picture edge) and the letters'
   ring crossings.
2. On the plate itself, linear checks: exactly one solid and one shell; every
   edge bounds exactly two face uses, once in each direction (closed and
   consistently oriented); volume from ``GProp`` equal to the analytic value;
   bounding box; hole count from the B-rep's faces; the mesh closed,
   consistently wound, of genus equal to the hole count.
3. The full ``BRepCheck_Analyzer`` on the whole plate up to
   ``full_check_max_holes`` holes, and above that on tiles: plates built by the
   same code from windows of the same description (a dense window of holes,
   the picture corner, the label; :mod:`.fullcheck`).
"""

from __future__ import annotations

import functools
import logging
import time
from types import SimpleNamespace

import numpy as np

from ..exchange.mesh import mesh_checks
from ..exchange.step_check import check_step_text, expected_counts
from ..model import Holes, PlateGeometry
from . import occt
from .fullcheck import TILE_HOLES, brep_valid, check_tiles, store_plane_pcurves
from .plate import PlateModel

log = logging.getLogger(__name__)

__all__ = [
    "PlateCheckError",
    "brep_valid",
    "check_plate",
    "check_plate_file",
    "store_plane_pcurves",
    "topology_checks",
]

#: Relative tolerances of the volume oracles.
BREP_RTOL = 1e-6
MESH_RTOL = 1e-3


class PlateCheckError(RuntimeError):
    """A built plate failed a check; the message lists every failed check."""


@functools.cache
def _occ():
    """The OCCT names :func:`_face_terms` uses, imported once.

    An import statement in a function runs on every call: seven of them per face cost
    ``topology_checks`` on the example's eight plates (25,095 faces) a tenth of its time:
    0.82 -> 0.73 CPU-s (``time.process_time``, median of three).
    """
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.GeomAbs import GeomAbs_Cylinder, GeomAbs_Plane
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_REVERSED, TopAbs_WIRE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedMapOfShape

    return SimpleNamespace(
        surface=BRepAdaptor_Surface,
        surface_properties=BRepGProp.SurfaceProperties_s,
        cylinder=GeomAbs_Cylinder,
        plane=GeomAbs_Plane,
        props=GProp_GProps,
        reversed=TopAbs_REVERSED,
        wire=TopAbs_WIRE,
        map_shapes=TopExp.MapShapes_s,
        shape_map=TopTools_IndexedMapOfShape,
    )


def _face_terms(face) -> tuple[int, int, float | None, bool]:
    """One face's share of :func:`topology_checks`: ``(is cylinder, wires, flux term, flux ok)``.

    The flux term is ``z n_z area`` of a horizontal plane (None for other faces); flux ok is
    False for a face neither horizontal nor vertical.
    """
    occ = _occ()
    surf = occ.surface(face, False)
    kind = surf.GetType()
    if kind == occ.cylinder:
        return 1, 0, None, not abs(abs(surf.Cylinder().Axis().Direction().Z()) - 1.0) > 1e-12
    if kind != occ.plane:
        return 0, 0, None, False
    wm = occ.shape_map()
    occ.map_shapes(face, occ.wire, wm)
    pos = surf.Plane().Position()
    nz = pos.Direction().Z() * (1.0 if pos.Direct() else -1.0)
    if abs(abs(nz) - 1.0) <= 1e-12:
        if pos.Location().Z() == 0.0:
            # On the plane z = 0 (a plate's bottom) z n_z area is 0 whatever the area, and the
            # area of a face with every hole is the slow part: topology_checks on the example's
            # eight plates took 1.27 CPU-s, 0.88 without the bottoms' areas (time.process_time).
            return 0, wm.Extent(), 0.0, True
        props = occ.props()
        occ.surface_properties(face, props)
        sign = -1.0 if face.Orientation() == occ.reversed else 1.0
        return 0, wm.Extent(), sign * np.sign(nz) * pos.Location().Z() * props.Mass(), True
    return 0, wm.Extent(), None, not abs(nz) > 1e-12


def _count_edge_uses(face, edges, fwd: np.ndarray, rev: np.ndarray) -> None:
    """Add the face's forward and reversed uses of each edge (by its index in ``edges``)."""
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FORWARD, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer

    eexp = TopExp_Explorer(face, TopAbs_EDGE)
    while eexp.More():
        e = eexp.Current()
        i = edges.FindIndex(e)
        o = e.Orientation()
        if o == TopAbs_FORWARD:
            fwd[i] += 1
        elif o == TopAbs_REVERSED:
            rev[i] += 1
        eexp.Next()


def _edge_faults(shape, fwd: np.ndarray, rev: np.ndarray, orientation: bool) -> tuple[int, int | None]:
    """Edges not on exactly two faces, and (with ``orientation``) edges not used once each way."""
    if orientation:
        return int(((fwd + rev) != 2).sum()), int(((fwd != 1) | (rev != 1)).sum())
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedDataMapOfShapeListOfShape

    anc = TopTools_IndexedDataMapOfShapeListOfShape()
    TopExp.MapShapesAndAncestors_s(shape, TopAbs_EDGE, TopAbs_FACE, anc)
    uses = np.fromiter((anc.FindFromIndex(i).Size() for i in range(1, anc.Extent() + 1)), dtype=np.int64)
    return int((uses != 2).sum()), None


def topology_checks(shape, orientation: bool = True) -> dict:
    """Linear topology figures of a shape.

    Args:
        shape: The OCCT shape.
        orientation: Also count each edge's uses per direction (a Python loop over
            every edge of every face: about 1 s at 14,000 holes). When False, only
            the faces per edge are counted (in C++), and ``edges_misoriented`` is None.

    Returns:
        ``solids``, ``shells``, ``faces``, ``edges``, ``cylinders`` (cylindrical
        faces), ``max_face_wires`` (bounds of the face with most holes + 1),
        ``edges_not_two_faces`` and ``edges_misoriented`` (edges not used exactly
        once forward and once reversed), ``flux_volume`` (mm³, from the horizontal
        faces by the divergence theorem, or None when a face is neither
        horizontal nor vertical).
    """
    from OCP.TopAbs import TopAbs_EDGE, TopAbs_FACE, TopAbs_SHELL, TopAbs_SOLID
    from OCP.TopExp import TopExp, TopExp_Explorer
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedMapOfShape

    def count(kind) -> int:
        m = TopTools_IndexedMapOfShape()
        TopExp.MapShapes_s(shape, kind, m)
        return m.Extent()

    edges = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_EDGE, edges)
    fwd = np.zeros(edges.Extent() + 1, dtype=np.int64)
    rev = np.zeros(edges.Extent() + 1, dtype=np.int64)
    ncyl, max_wires, nfaces = 0, 0, 0
    # Divergence theorem with F = (0, 0, z): V = Σ z n_z area over the faces. Vertical faces
    # (cylinders about z, planes parallel to z) add nothing, so only the horizontal planes
    # are integrated: linear, where GProp's volume integrates every cylinder too.
    flux, flux_ok = 0.0, True
    fexp = TopExp_Explorer(shape, TopAbs_FACE)
    while fexp.More():
        face = TopoDS.Face_s(fexp.Current())
        nfaces += 1
        cylinder, wires, term, face_ok = _face_terms(face)
        ncyl += cylinder
        max_wires = max(max_wires, wires)
        if term is not None:
            flux += term
        flux_ok = flux_ok and face_ok
        if orientation:
            _count_edge_uses(face, edges, fwd, rev)
        fexp.Next()
    fwd, rev = fwd[1:], rev[1:]
    not_two, misoriented = _edge_faults(shape, fwd, rev, orientation)
    return {
        "solids": count(TopAbs_SOLID),
        "shells": count(TopAbs_SHELL),
        "faces": nfaces,
        "edges": int(edges.Extent()),
        "cylinders": ncyl,
        "max_face_wires": max_wires,
        "edges_not_two_faces": not_two,
        "edges_misoriented": misoriented,
        "flux_volume": float(flux) if flux_ok else None,
    }


def _curved_area(shape) -> float:
    """Total area in mm² of a shape's faces that are not planes."""
    from OCP.BRepAdaptor import BRepAdaptor_Surface
    from OCP.BRepGProp import BRepGProp
    from OCP.GeomAbs import GeomAbs_Plane
    from OCP.GProp import GProp_GProps
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS

    total = 0.0
    exp = TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():
        face = TopoDS.Face_s(exp.Current())
        if BRepAdaptor_Surface(face, False).GetType() != GeomAbs_Plane:
            props = GProp_GProps()
            BRepGProp.SurfaceProperties_s(face, props)
            total += props.Mass()
        exp.Next()
    return total


def _topology_fails(topo: dict) -> list[str]:
    """One solid with one closed, consistently oriented shell."""
    fails = []
    if topo["solids"] != 1 or topo["shells"] != 1:
        fails.append(
            f"expected exactly one solid with one shell, got {topo['solids']} solids, {topo['shells']} shells"
        )
    if topo["edges_not_two_faces"]:
        fails.append(f"{topo['edges_not_two_faces']} edges do not bound exactly two faces (shell not closed)")
    if topo["edges_misoriented"]:
        fails.append(
            f"{topo['edges_misoriented']} edges are not used once in each direction (shell misoriented)"
        )
    return fails


def _bbox(shape) -> list[list[float]]:
    """``[[xmin, ymin, zmin], [xmax, ymax, zmax]]`` in mm, OCCT's optimal bounding box."""
    box = occt.bounding_box(shape)
    return [list(box[:3]), list(box[3:])]


def _hole_fails(geom: PlateGeometry | None, topo: dict, dots: Holes | None) -> list[str]:
    """Hole faces and top-face bounds against the description, and the holes against the input."""
    fails = []
    if geom is not None:
        holes = geom.hole_count
        n_cyl = topo["cylinders"]
        if n_cyl != len(geom.circles_r):
            fails.append(f"B-rep has {n_cyl} cylindrical hole faces, expected {len(geom.circles_r)}")
        # The top face bounds the outline, every hole and (with a label) every letter.
        top = expected_counts(geom)["top_bounds"]
        if topo["max_face_wires"] != top:
            fails.append(
                f"the top face has {topo['max_face_wires']} bounds, expected {top} "
                f"(outline, {holes} holes, {top - holes - 1} letters)"
            )
    return fails + _input_fails(geom, dots)


def _input_fails(geom: PlateGeometry | None, dots: Holes | None) -> list[str]:
    """The plate's holes against the input it was built from: their count and the round holes themselves."""
    if dots is None:
        return []
    fails = []
    holes = None if geom is None else geom.hole_count
    n_in = dots.hole_count
    # Holes a template added (a hanging hole) come after the input's.
    extra = geom.extra_holes if geom is not None else 0
    if holes is not None and n_in + extra != holes:
        fails.append(
            f"the plate has {holes} holes but the input has {n_in}"
            + (f" and the template added {extra}" if extra else "")
        )
    if geom is not None and len(dots.r_mm):
        n = len(geom.circles_r) - extra
        same = np.array_equal(np.asarray(dots.xy_mm), geom.circles_xy[:n]) and np.array_equal(
            np.asarray(dots.r_mm), geom.circles_r[:n]
        )
        if not same:
            fails.append("the plate's holes are not the given dots")
    return fails


def _allowed_mesh_error(shape, geom: PlateGeometry | None, tolerance_mm: float, mref: float) -> float:
    """Largest relative mesh-volume error accepted.

    A mesh lies within the chord error of the surface, so its volume differs from the
    B-rep's by at most (area of the curved faces) × tolerance. The fast mesher's holes
    are built to the analytic area; OCCT's mesher (a template's own solid) is not.
    """
    if geom is not None:
        return MESH_RTOL
    return max(MESH_RTOL, _curved_area(shape) * tolerance_mm / abs(mref))


def _mesh_fails(mc: dict, holes: int | None, mref: float, allowed: float) -> list[str]:
    """The mesh: watertight, consistently wound, one part, genus = holes, no slivers, its volume."""
    fails = []
    if not mc["watertight"]:
        fails.append("mesh is not watertight (an edge is not shared by exactly two triangles)")
    if not mc["consistent_winding"]:
        fails.append("mesh winding is inconsistent")
    if mc["components"] != 1:
        fails.append(f"mesh has {mc['components']} parts, expected 1")
    if holes is not None and mc["genus"] != holes:
        fails.append(f"mesh genus {mc['genus']} differs from the hole count {holes}")
    if mc["degenerate"]:
        fails.append(f"mesh has {mc['degenerate']} zero-area triangles in float32")
    if mc["rel_error"] > allowed:
        fails.append(
            f"mesh volume {mc['volume']:.4f} mm³ differs from {mref:.4f} mm³ by {mc['rel_error']:.2e}"
        )
    return fails


def _volume_check(shape, topo: dict, n_big: bool, analytic: float | None, sec: dict, fails: list[str]):
    """The B-rep volume, how it was computed and its relative error to ``analytic`` (None without)."""
    t0 = time.perf_counter()
    # GProp's volume integrates every face (1.8 s at 14,000 holes); for a plate of horizontal
    # and vertical faces only, the flux through the horizontal faces is the same integral.
    if n_big and topo["flux_volume"] is not None:
        volume, volume_method = topo["flux_volume"], "divergence theorem over the horizontal faces"
    else:
        volume, volume_method = occt.volume(shape), "GProp"
    sec["volume"] = time.perf_counter() - t0
    rel = None if analytic is None else abs(volume - analytic) / abs(analytic)
    if volume <= 0:
        fails.append(f"volume {volume:.6g} mm³ is not positive (empty or inside-out solid)")
    if rel is not None and rel > BREP_RTOL:
        fails.append(
            f"B-rep volume {volume:.6f} mm³ differs from the analytic {analytic:.6f} mm³ by {rel:.2e} (> {BREP_RTOL})"
        )
    return volume, volume_method, rel


def _bbox_check(shape, geom: PlateGeometry | None, fails: list[str]):
    """The shape's bounding box, compared with the configured one when ``geom`` is known."""
    bbox = _bbox(shape)
    if geom is not None:
        want = np.array(geom.bbox)
        if not np.allclose(np.array(bbox), want, atol=1e-5):
            fails.append(
                f"bounding box {np.round(bbox, 4).tolist()} differs from the configured {want.round(4).tolist()}"
            )
    return bbox


def _full_check(shape, geom, n: int, full_check_max_holes: int, tile_holes: int, fails: list[str]):
    """OCCT's full check on the whole plate (``n`` holes at most the limit) or on tiles; ``(valid, method, tiles)``.

    Appends what fails to ``fails``.
    """
    if n <= full_check_max_holes or geom is None:
        # A plate with a description is written from it, not from its solid, so storing the
        # plane curves on the solid changes no file; a template's own solid is left as it is.
        valid = brep_valid(shape, plane_pcurves=geom is not None)
        method = "BRepCheck_Analyzer (whole plate)"
        if not valid:
            fails.append("BRepCheck_Analyzer: the B-rep is not valid")
        tiles_info: list[dict] = []
    else:
        tiles_info, tile_fails = check_tiles(geom, tile_holes)
        fails += tile_fails
        valid = all(t["valid"] for t in tiles_info) and not fails
        method = (
            "construction + linear checks on the whole plate; BRepCheck_Analyzer on "
            f"{len(tiles_info)} tiles of the same construction"
        )
    return valid, method, tiles_info


def _mesh_report(
    model, shape, geom, tolerance_mm: float, mref: float, holes, sec: dict, fails: list[str]
) -> dict:
    """The plate's mesh checked against the reference volume ``mref``; times into ``sec``, failures into ``fails``."""
    t0 = time.perf_counter()
    mesh = model.mesh(tolerance_mm)
    sec["mesh"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    mc = mesh_checks(mesh)
    sec["mesh_check"] = time.perf_counter() - t0
    mc["rel_error"] = abs(mc["volume"] - mref) / abs(mref)
    mc["allowed_rel_error"] = _allowed_mesh_error(shape, geom, tolerance_mm, mref)
    fails += _mesh_fails(mc, holes, mref, mc["allowed_rel_error"])
    return mc


def check_plate(
    model: PlateModel,
    dots: Holes | None = None,
    tolerance_mm: float | None = None,
    full_check_max_holes: int | None = None,
    tile_holes: int = TILE_HOLES,
) -> dict:
    """Check a built plate; raise if anything is off.

    Args:
        model: A :class:`~stencil_cad.cad.plate.PlateModel`.
        dots: The :class:`~stencil_cad.model.DotSet` or
            :class:`~stencil_cad.model.CutLayer` it was built from, or None.
        tolerance_mm: Mesh tolerance in mm (pass the STL's, so the mesh is built once).
            Defaults to 0.02 mm.
        full_check_max_holes: Up to this many holes, OCCT's full B-rep check runs on
            the whole plate; above, on tiles. Defaults to the config's value recorded
            in the model (``plate.full_check_max_holes``), else 300.
        tile_holes: Holes per tile. Defaults to 120.

    Returns:
        The figures: ``n_solids``, ``valid``, ``valid_method``, ``volume``,
        ``analytic_volume``, ``rel_error``, ``bbox``, ``hole_count``, ``mesh``
        (watertight, consistent_winding, genus, volume, rel_error...), ``seconds``.

    Raises:
        PlateCheckError: Listing every failed check.
    """
    if tolerance_mm is None:
        tolerance_mm = 0.02
    if full_check_max_holes is None:
        full_check_max_holes = int(model.info.get("full_check_max_holes", 300))
    shape = model.shape
    geom: PlateGeometry | None = model.geometry
    n_big = geom is not None and geom.hole_count > full_check_max_holes
    fails: list[str] = []
    sec: dict[str, float] = {}
    t0 = time.perf_counter()
    # Edge orientation per face use is a Python loop; on big plates the tiles' full check
    # covers orientation (same construction) and the closedness count runs in C++.
    topo = topology_checks(shape, orientation=not n_big)
    sec["topology"] = time.perf_counter() - t0
    fails += _topology_fails(topo)

    analytic = model.analytic_volume
    volume, volume_method, rel = _volume_check(shape, topo, n_big, analytic, sec, fails)
    bbox = _bbox_check(shape, geom, fails)
    holes = None if geom is None else geom.hole_count
    fails += _hole_fails(geom, topo, dots)

    # Full B-rep check: whole plate when small, tiles of the same construction when large.
    t0 = time.perf_counter()
    n = holes if holes is not None else topo["faces"]
    valid, method, tiles_info = _full_check(shape, geom, n, full_check_max_holes, tile_holes, fails)
    sec["brep_check"] = time.perf_counter() - t0
    mref = analytic if analytic is not None else volume
    mc = _mesh_report(model, shape, geom, tolerance_mm, mref, holes, sec, fails)

    report = {
        "n_solids": topo["solids"],
        "valid": bool(valid and not fails),
        "valid_method": method,
        "tiles": tiles_info,
        "volume": volume,
        "volume_method": volume_method,
        "analytic_volume": analytic,
        "rel_error": rel,
        "bbox": bbox,
        "hole_count": holes,
        "faces": topo["faces"],
        "mesh": mc,
        "seconds": {k: round(v, 3) for k, v in sec.items()},
    }
    if fails:
        raise PlateCheckError(f"plate check failed ({len(fails)}): " + "; ".join(fails))
    return report


def check_plate_file(
    model: PlateModel, step: str, dots: Holes | None = None, tolerance_mm: float | None = None
) -> dict:
    """Check a plate by the files it is written as, without building its OCCT solid; raise if anything is off.

    The STEP text is checked kernel-free (:func:`stencil_cad.exchange.step_check.check_step_text`:
    one closed, consistently oriented solid of the right genus, edges on their faces, volume,
    bounding box, no bounds crossing or touching), the mesh as :func:`check_plate` checks it,
    and the holes against the input.

    Args:
        model: A :class:`~stencil_cad.cad.plate.PlateModel` with a description.
        step: The STEP text its file will hold.
        dots: The :class:`~stencil_cad.model.DotSet` or :class:`~stencil_cad.model.CutLayer` it
            was built from, or None.
        tolerance_mm: Mesh tolerance in mm (the STL's). Defaults to 0.02 mm.

    Returns:
        The figures :func:`check_plate` returns, ``valid_method`` and ``volume_method`` saying
        what was checked; ``tiles`` is empty.

    Raises:
        PlateCheckError: Listing every failed check.
    """
    geom = model.geometry
    if geom is None:
        raise ValueError("check_plate_file needs a plate with a description (check_plate checks the others)")
    tolerance_mm = 0.02 if tolerance_mm is None else tolerance_mm
    rep = check_step_text(step, geom)
    fails = list(rep["fails"])
    sec = {"step_check": rep["seconds"]}
    fails += _input_fails(geom, dots)
    analytic = geom.volume
    mc = _mesh_report(model, None, geom, tolerance_mm, analytic, geom.hole_count, sec, fails)
    bbox = rep.get("bbox")
    report = {
        "n_solids": rep["solids"],
        "valid": not fails,
        "valid_method": (
            "kernel-free check of the written STEP: one closed, consistently oriented solid, "
            "Euler-Poincare genus = holes, edges on their faces, no bounds crossing or touching"
        ),
        "tiles": [],
        "volume": rep.get("volume"),
        "volume_method": "divergence theorem over the written STEP's horizontal faces (exact circles)",
        "analytic_volume": analytic,
        "rel_error": rep.get("rel_error"),
        "bbox": bbox,
        "hole_count": geom.hole_count,
        "faces": rep.get("faces"),
        "mesh": mc,
        "seconds": {k: round(v, 3) for k, v in sec.items()},
    }
    if fails:
        raise PlateCheckError(f"plate check failed ({len(fails)}): " + "; ".join(fails))
    return report
