"""The wall's solid, its checks and its files, made through OCP (OCCT's Python binding) alone.

A job draws its walls' faces from their outlines (:mod:`.wall_brep`) and imports no OCP; this
route makes the wall when the maker asks for the kernel's checks (``plate.check: kernel``), for a
mural's walls whose sight notches build123d cuts, and for the tests that hold the drawn wall to it.

Importing build123d costs a job over a second of CPU beyond OCP's own extension (its modules and
what they import: scikit-learn for its STL reader, IPython for its notebook display), and every job
builds a wall: with the label's letters set without it too (:mod:`.text`), ``stencil-cad build``
on the example's saved stage took 11.6 CPU-s, 10.4 without build123d (user + system, medians of
five and four runs alternated with the other code). So the wall is made here from OCCT's
documented classes: edges and a wire from points, a planar face bounded by the wire, a prism
swept from it, one Boolean cut of every cutter, the faces on one plane merged, and OCCT's STEP
and STL writers. ``tests/cad/test_occt.py`` holds these helpers to their contracts, and
``tests/cad/test_wall.py`` holds the wall read back from its STEP file to one valid solid with the
analytic volume and the volume, box and face count of the same wall made with build123d.
Lengths are in mm throughout.
"""

from __future__ import annotations

import logging
import os
import threading
from collections.abc import Iterable, Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

__all__ = [
    "STEP_LOCK",
    "arc_edge",
    "bounding_box",
    "box",
    "compound",
    "cut",
    "faces",
    "in_compound",
    "is_valid",
    "line_edge",
    "planar_face",
    "prism",
    "solids",
    "unify",
    "volume",
    "wire",
    "write_step",
    "write_stl",
]

log = logging.getLogger(__name__)

Point = Sequence[float]

#: OCCT's STEP settings (``Interface_Static``) and its message printers are one per process:
#: one STEP file is written at a time.
STEP_LOCK = threading.Lock()


def _pnt(p: Point):
    from OCP.gp import gp_Pnt

    x, y, z = map(float, p)
    return gp_Pnt(x, y, z)


def line_edge(p0: Point, p1: Point):
    """A straight edge from ``p0`` to ``p1``."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge

    return BRepBuilderAPI_MakeEdge(_pnt(p0), _pnt(p1)).Edge()


def arc_edge(p0: Point, mid: Point, p1: Point):
    """The circular arc from ``p0`` through ``mid`` to ``p1``.

    Raises:
        ValueError: The three points lie on one line (or two of them coincide).
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.GC import GC_MakeArcOfCircle

    arc = GC_MakeArcOfCircle(_pnt(p0), _pnt(mid), _pnt(p1))
    if not arc.IsDone():
        raise ValueError(f"no circular arc through {p0}, {mid}, {p1}")
    return BRepBuilderAPI_MakeEdge(arc.Value()).Edge()


def wire(edges: Iterable):
    """The wire of ``edges``, each one starting where the one before it ends.

    Raises:
        ValueError: An edge does not meet the wire made so far.
    """
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeWire

    builder = BRepBuilderAPI_MakeWire()
    for i, edge in enumerate(edges):
        builder.Add(edge)
        if not builder.IsDone():
            raise ValueError(f"edge {i} does not meet the wire (OCCT error {builder.Error()})")
    return builder.Wire()


def planar_face(outer):
    """The face bounded by a closed wire that lies in one plane.

    OCCT finds the plane through the wire and keeps the face inside the wire whichever way the
    wire runs, so the face's normal may point either way along the plane's axis.

    Raises:
        ValueError: The wire is open, or lies in no plane.
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace

    if not BRep_Tool.IsClosed_s(outer):
        raise ValueError("a face needs a closed wire")
    builder = BRepBuilderAPI_MakeFace(outer, True)  # True: a plane or nothing
    if not builder.IsDone():
        raise ValueError(f"no planar face inside the wire (OCCT error {builder.Error()})")
    return builder.Face()


def prism(face, dz: float):
    """The solid a face sweeps when moved ``dz`` mm along z (either sign)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Vec
    from OCP.TopoDS import TopoDS

    return TopoDS.Solid_s(BRepPrimAPI_MakePrism(face, gp_Vec(0.0, 0.0, float(dz))).Shape())


def box(corner: Point, size: Point):
    """The box with its low corner at ``corner`` and sides ``size`` = (dx, dy, dz) along x, y, z."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.TopoDS import TopoDS

    dx, dy, dz = map(float, size)
    return TopoDS.Solid_s(BRepPrimAPI_MakeBox(_pnt(corner), dx, dy, dz).Shape())


def compound(shapes: Iterable):
    """A compound of the shapes."""
    from OCP.BRep import BRep_Builder
    from OCP.TopoDS import TopoDS_Compound

    comp = TopoDS_Compound()
    builder = BRep_Builder()
    builder.MakeCompound(comp)
    for s in shapes:
        builder.Add(comp, s)
    return comp


def in_compound(shape):
    """``shape`` if it is a compound, else a compound holding it (the shape a build123d ``Part`` wraps)."""
    from OCP.TopAbs import TopAbs_COMPOUND
    from OCP.TopoDS import TopoDS

    return TopoDS.Compound_s(shape) if shape.ShapeType() == TopAbs_COMPOUND else compound([shape])


def cut(shape, tools: Iterable):
    """``shape`` with every tool cut away, in one Boolean operation (the tools may overlap each other).

    Raises:
        ValueError: OCCT's Boolean operation failed.
    """
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut
    from OCP.TopTools import TopTools_ListOfShape

    objects, cutters = TopTools_ListOfShape(), TopTools_ListOfShape()
    objects.Append(shape)
    for tool in tools:
        cutters.Append(tool)
    operation = BRepAlgoAPI_Cut()
    operation.SetArguments(objects)
    operation.SetTools(cutters)
    operation.Build()
    if not operation.IsDone():
        raise ValueError("OCCT's Boolean cut failed")
    return operation.Shape()


def unify(shape):
    """``shape`` with the faces on one surface merged into one face, and the edges on one curve.

    A Boolean operation may leave one plane's face in pieces (where two cutters met); merged, a
    solid has the faces it would have if drawn by hand. Where OCCT fails to merge them, the shape
    is kept as it is (a valid solid with more faces than needed) and a warning says so.
    """
    from OCP.ShapeUpgrade import ShapeUpgrade_UnifySameDomain
    from OCP.Standard import Standard_Failure

    upgrader = ShapeUpgrade_UnifySameDomain(shape)  # edges and faces merged, internal edges removed
    try:
        upgrader.Build()
    except Standard_Failure as err:
        log.warning("OCCT could not merge the faces of a solid (%s): its faces are kept as they are", err)
        return shape
    return upgrader.Shape()


def solids(shape) -> list:
    """The distinct solids of ``shape``."""
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedMapOfShape

    found = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_SOLID, found)
    return [TopoDS.Solid_s(found.FindKey(i)) for i in range(1, found.Extent() + 1)]


def faces(shape) -> int:
    """How many distinct faces ``shape`` has."""
    from OCP.TopAbs import TopAbs_FACE
    from OCP.TopExp import TopExp
    from OCP.TopTools import TopTools_IndexedMapOfShape

    found = TopTools_IndexedMapOfShape()
    TopExp.MapShapes_s(shape, TopAbs_FACE, found)
    return found.Extent()


def volume(solid) -> float:
    """A solid's volume in mm³."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(solid, props)
    return float(props.Mass())


def bounding_box(shape) -> tuple[float, float, float, float, float, float]:
    """``(xmin, ymin, zmin, xmax, ymax, zmax)`` of ``shape`` in mm, from its exact geometry."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib

    bb = Bnd_Box()
    BRepBndLib.AddOptimal_s(shape, bb, False, False)  # neither a mesh nor the tolerances
    return tuple(bb.Get()) if not bb.IsVoid() else (0.0,) * 6


def is_valid(shape) -> bool:
    """OCCT's full B-rep check (``BRepCheck_Analyzer``)."""
    from OCP.BRepCheck import BRepCheck_Analyzer

    return bool(BRepCheck_Analyzer(shape).IsValid())


@contextmanager
def _quiet() -> Iterator[None]:
    """OCCT's messages short of failures kept off the console (its STEP writer prints statistics)."""
    from OCP.Message import Message, Message_Gravity

    printers = list(Message.DefaultMessenger_s().Printers())
    levels = [p.GetTraceLevel() for p in printers]
    for p in printers:
        p.SetTraceLevel(Message_Gravity.Message_Fail)
    try:
        yield
    finally:
        for p, level in zip(printers, levels, strict=True):
            p.SetTraceLevel(level)


def write_step(shape, path: str | os.PathLike, name: str, description: str, timestamp: str) -> None:
    """Write ``shape`` as STEP AP214 in mm, with its curves on the faces' surfaces (OCCT's STEP writer).

    The product and the header's file name are ``name``; the header gives ``description``,
    ``timestamp`` and stencil_cad as the originating system, and no author, so the same shape
    gives the same bytes.

    Args:
        shape: The OCCT shape.
        path: The file.
        name: The part's name (plain ASCII).
        description: The header's file description.
        timestamp: The header's time stamp (ISO 8601).

    Raises:
        OSError: OCCT could not translate the shape or write the file.
    """
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    with STEP_LOCK, _quiet():
        writer = STEPControl_Writer()
        for key, value in (
            ("write.step.schema", "AP214IS"),
            ("write.step.unit", "MM"),
            ("write.surfacecurve.mode", "On"),
        ):
            if not Interface_Static.SetCVal_s(key, value):
                raise OSError(f"OCCT's STEP writer has no setting {key} = {value}")
        if writer.Transfer(shape, STEPControl_AsIs) != IFSelect_RetDone:
            raise OSError(f"STEP export failed: OCCT could not translate the shape for {path}")
        _name_step(writer.Model(), name, description, timestamp)
        if writer.Write(os.fsdecode(path)) != IFSelect_RetDone:
            raise OSError(f"STEP export failed: {path}")


def _name_step(model, name: str, description: str, timestamp: str) -> None:
    """Name the STEP model's products and fill its header (see :func:`write_step`)."""
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.StepBasic import StepBasic_Product
    from OCP.TCollection import TCollection_HAsciiString as Text

    products = model.Entities()
    products.SelectType(StepBasic_Product.get_type_descriptor_s(), True)
    products.Start()
    while products.More():
        products.Value().SetId(Text(name))
        products.Value().SetName(Text(name))
        products.Next()
    header = APIHeaderSection_MakeHeader(model)
    header.SetName(Text(name))
    header.SetTimeStamp(Text(timestamp))
    header.SetAuthorValue(1, Text(""))
    header.SetOrganizationValue(1, Text(""))
    header.SetOriginatingSystem(Text("stencil_cad"))
    header.SetAuthorisation(Text(""))
    header.SetDescriptionValue(1, Text(description))
    header.Apply(model)


def write_stl(shape, path: str | os.PathLike, tolerance: float, angular_tolerance: float) -> None:
    """Mesh ``shape`` and write it as binary STL.

    Args:
        shape: The OCCT shape.
        path: The file.
        tolerance: Largest distance in mm between the mesh and the surface.
        angular_tolerance: Largest angle in radians between neighbouring facets on a curve.

    Raises:
        OSError: The folder does not exist, or OCCT could not write the file.
    """
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.StlAPI import StlAPI_Writer

    out = Path(os.fsdecode(path))
    if not out.parent.is_dir():
        raise OSError(f"STL export failed: no folder {out.parent}")
    BRepMesh_IncrementalMesh(shape, tolerance, False, angular_tolerance, False)  # absolute, one thread
    writer = StlAPI_Writer()
    writer.ASCIIMode = False
    if not writer.Write(shape, str(out)):
        raise OSError(f"STL export failed: {path}")
