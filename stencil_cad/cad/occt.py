"""The few build123d operations the wall and the simple parts' checks use, made through OCP alone.

Importing build123d costs a job over a second of CPU beyond OCP's own extension (its modules and
what they import: scikit-learn for its STL reader, IPython for its notebook display), and every job
builds a wall: with the label's letters set without it too (:mod:`.text`), ``stencil-cad build``
on the example's saved stage took 11.6 CPU-s, 10.4 without build123d (user + system, medians of
five and four runs alternated with the other code). So the wall is made here by the same OCCT calls, with the same arguments and in the
same order, as build123d 0.12 makes it (``Edge.make_line``, ``Edge.make_three_point_arc``,
``Wire(edges)``, ``Face(wire)``, ``Solid.extrude``, ``fuse``, ``cut``, ``clean``, ``Solid.make_box``,
``moved``, ``export_step``, ``export_stl``, ``is_valid``, ``volume``, ``bounding_box``): the same
solid, and the same bytes in its files (``tests/cad/test_wall.py`` holds them to build123d's).
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from pathlib import Path

__all__ = [
    "arc_edge",
    "bounding_box",
    "box",
    "compound",
    "cut",
    "fuse",
    "in_compound",
    "is_valid",
    "line_edge",
    "moved",
    "planar_face",
    "prism",
    "solids",
    "unify",
    "volume",
    "wire",
    "write_step",
    "write_stl",
]

Point = Sequence[float]


def line_edge(p0: Point, p1: Point):
    """A straight edge from ``p0`` to ``p1`` (``Edge.make_line``)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.gp import gp_Pnt

    return BRepBuilderAPI_MakeEdge(gp_Pnt(*map(float, p0)), gp_Pnt(*map(float, p1))).Edge()


def arc_edge(p0: Point, mid: Point, p1: Point):
    """A circular arc from ``p0`` through ``mid`` to ``p1`` (``Edge.make_three_point_arc``)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeEdge
    from OCP.GC import GC_MakeArcOfCircle
    from OCP.gp import gp_Pnt

    pts = (gp_Pnt(*map(float, p)) for p in (p0, mid, p1))
    return BRepBuilderAPI_MakeEdge(GC_MakeArcOfCircle(*pts).Value()).Edge()


def wire(edges: Iterable):
    """A wire of edges given in order (``Wire(edges)``)."""
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeWire
    from OCP.TopTools import TopTools_ListOfShape

    builder = BRepBuilderAPI_MakeWire()
    listed = TopTools_ListOfShape()
    for e in edges:
        listed.Append(e)
    builder.Add(listed)
    builder.Build()
    if not builder.IsDone():
        raise ValueError(f"the edges make no wire (OCCT error {builder.Error()})")
    return builder.Wire()


def planar_face(outer):
    """The planar face inside a closed wire (``Face(wire)``: the wire fixed, the face's orientation fixed)."""
    from OCP.BRep import BRep_Tool
    from OCP.BRepBuilderAPI import BRepBuilderAPI_MakeFace
    from OCP.BRepLib import BRepLib_FindSurface
    from OCP.ShapeFix import ShapeFix_Face, ShapeFix_Shape
    from OCP.TopoDS import TopoDS

    if not BRep_Tool.IsClosed_s(outer):
        raise ValueError("a face needs a closed wire")
    if not BRepLib_FindSurface(compound([outer]), OnlyPlane=True).Found():
        raise ValueError("the wire is not planar")
    fix = ShapeFix_Shape(outer)
    fix.Perform()
    builder = BRepBuilderAPI_MakeFace(TopoDS.Wire_s(fix.Shape()), True)
    builder.Build()
    if not builder.IsDone():
        raise ValueError(f"no face from the wire (OCCT error {builder.Error()})")
    face_fix = ShapeFix_Face(builder.Face())
    face_fix.FixOrientation()
    face_fix.Perform()
    return TopoDS.Face_s(face_fix.Result())


def prism(face, dz: float):
    """The solid swept by a face along z by ``dz`` mm (``Solid.extrude``)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakePrism
    from OCP.gp import gp_Vec
    from OCP.TopoDS import TopoDS

    return TopoDS.Solid_s(BRepPrimAPI_MakePrism(face, gp_Vec(0.0, 0.0, float(dz))).Shape())


def box(length: float, width: float, height: float):
    """A box of the sizes in mm from the origin along +x, +y, +z (``Solid.make_box`` on the XY plane)."""
    from OCP.BRepPrimAPI import BRepPrimAPI_MakeBox
    from OCP.gp import gp_Ax2, gp_Dir, gp_Pnt
    from OCP.TopoDS import TopoDS

    axes = gp_Ax2(gp_Pnt(0.0, 0.0, 0.0), gp_Dir(0.0, 0.0, 1.0), gp_Dir(1.0, 0.0, 0.0))
    return TopoDS.Solid_s(BRepPrimAPI_MakeBox(axes, length, width, height).Shape())


def moved(shape, offset: Point):
    """``shape`` moved by ``offset`` in mm (``moved(Location(offset))``: a location, the geometry kept)."""
    from OCP.gp import gp_Trsf, gp_Vec
    from OCP.TopLoc import TopLoc_Location

    trsf = gp_Trsf()
    trsf.SetTranslationPart(gp_Vec(*map(float, offset)))
    return _downcast(shape.Moved(TopLoc_Location(trsf)))


def compound(shapes: Iterable):
    """A compound of the shapes."""
    from OCP.TopoDS import TopoDS_Builder, TopoDS_Compound

    comp = TopoDS_Compound()
    builder = TopoDS_Builder()
    builder.MakeCompound(comp)
    for s in shapes:
        builder.Add(comp, s)
    return comp


def in_compound(shape):
    """``shape`` if it is a compound, else a compound holding it (the shape a build123d ``Part`` wraps)."""
    from OCP.TopAbs import TopAbs_COMPOUND

    return shape if shape.ShapeType() == TopAbs_COMPOUND else compound([shape])


def fuse(a, b):
    """``a`` fused with ``b``, its faces unified (``a.fuse(b)``)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Fuse

    return _boolean(BRepAlgoAPI_Fuse(), a, b)


def cut(a, b):
    """``a`` with ``b`` cut away, its faces unified (``a.cut(b)``)."""
    from OCP.BRepAlgoAPI import BRepAlgoAPI_Cut

    return _boolean(BRepAlgoAPI_Cut(), a, b)


def _boolean(operation, a, b):
    from OCP.TopTools import TopTools_ListOfShape

    args, tools = TopTools_ListOfShape(), TopTools_ListOfShape()
    args.Append(a)
    tools.Append(b)
    operation.SetArguments(args)
    operation.SetTools(tools)
    operation.SetRunParallel(True)
    operation.Build()
    return _unwrapped(unify(_downcast(operation.Shape())))


def unify(shape):
    """``shape`` with its coplanar faces and collinear edges merged (``clean``)."""
    from OCP.ShapeUpgrade import ShapeUpgrade_UnifySameDomain

    upgrader = ShapeUpgrade_UnifySameDomain(shape, True, True, True)
    upgrader.AllowInternalEdges(False)
    upgrader.Build()
    return _downcast(upgrader.Shape())


def _downcast(shape):
    from OCP.TopAbs import TopAbs_COMPOUND, TopAbs_FACE, TopAbs_SHELL, TopAbs_SOLID, TopAbs_WIRE
    from OCP.TopoDS import TopoDS

    cast = {
        TopAbs_COMPOUND: TopoDS.Compound_s,
        TopAbs_SOLID: TopoDS.Solid_s,
        TopAbs_SHELL: TopoDS.Shell_s,
        TopAbs_FACE: TopoDS.Face_s,
        TopAbs_WIRE: TopoDS.Wire_s,
    }.get(shape.ShapeType())
    return shape if cast is None else cast(shape)


def _unwrapped(shape):
    """The one shape inside nested one-child compounds, or the shape."""
    from OCP.TopAbs import TopAbs_COMPOUND
    from OCP.TopoDS import TopoDS_Iterator

    while shape.ShapeType() == TopAbs_COMPOUND and shape.NbChildren() == 1:
        shape = _downcast(TopoDS_Iterator(shape).Value())
    return shape


def solids(shape) -> list:
    """The distinct solids of ``shape`` (``solids()``)."""
    from OCP.TopAbs import TopAbs_SOLID
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopoDS import TopoDS
    from OCP.TopTools import TopTools_IndexedMapOfShape

    seen = TopTools_IndexedMapOfShape()
    exp = TopExp_Explorer(shape, TopAbs_SOLID)
    while exp.More():
        seen.Add(exp.Current())
        exp.Next()
    return [TopoDS.Solid_s(seen.FindKey(i)) for i in range(1, seen.Extent() + 1)]


def volume(solid) -> float:
    """A solid's volume in mm³ (``volume``)."""
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.VolumeProperties_s(solid, props)
    return float(props.Mass())


def bounding_box(shape) -> tuple[float, float, float, float, float, float]:
    """``(xmin, ymin, zmin, xmax, ymax, zmax)`` of ``shape`` in mm (``bounding_box()``: optimal, mesh dropped)."""
    from OCP.Bnd import Bnd_Box
    from OCP.BRepBndLib import BRepBndLib
    from OCP.BRepTools import BRepTools

    bb = Bnd_Box()
    BRepTools.Clean_s(shape)
    BRepBndLib.AddOptimal_s(shape, bb)
    return tuple(bb.Get()) if not bb.IsVoid() else (0.0,) * 6


def is_valid(shape) -> bool:
    """OCCT's full B-rep check (``is_valid``)."""
    from OCP.BRepCheck import BRepCheck_Analyzer

    check = BRepCheck_Analyzer(shape)
    check.SetParallel(True)
    return bool(check.IsValid())


def write_step(shape, path: str | os.PathLike, timestamp: str) -> None:
    """Write ``shape`` as STEP (AP214, mm, with its plane curves) as ``export_step`` does for an unnamed part.

    Raises:
        OSError: OCCT could not write the file.
    """
    from OCP.APIHeaderSection import APIHeaderSection_MakeHeader
    from OCP.IFSelect import IFSelect_ReturnStatus
    from OCP.IGESControl import IGESControl_Controller
    from OCP.Interface import Interface_Static
    from OCP.Message import Message, Message_Gravity
    from OCP.STEPCAFControl import STEPCAFControl_Controller, STEPCAFControl_Writer
    from OCP.STEPControl import STEPControl_Controller, STEPControl_StepModelType
    from OCP.TCollection import TCollection_HAsciiString
    from OCP.XSControl import XSControl_WorkSession

    doc = _xde(shape)
    for printer in Message.DefaultMessenger_s().Printers():
        printer.SetTraceLevel(Message_Gravity.Message_Fail)
    writer = STEPCAFControl_Writer(XSControl_WorkSession(), False)
    writer.SetColorMode(True)
    writer.SetLayerMode(True)
    writer.SetNameMode(True)
    header = APIHeaderSection_MakeHeader(writer.Writer().Model())
    if not header.IsDone():
        header = APIHeaderSection_MakeHeader(0)
        header.Apply(writer.Writer().Model())
    header.SetTimeStamp(TCollection_HAsciiString(timestamp))
    header.SetOriginatingSystem(TCollection_HAsciiString("build123d"))
    STEPCAFControl_Controller.Init_s()
    STEPControl_Controller.Init_s()
    IGESControl_Controller.Init_s()
    Interface_Static.SetIVal_s("write.surfacecurve.mode", 1)
    Interface_Static.SetIVal_s("write.precision.mode", 0)
    writer.Transfer(doc, STEPControl_StepModelType.STEPControl_AsIs)
    if writer.Write(os.fsdecode(path)) != IFSelect_ReturnStatus.IFSelect_RetDone:
        raise OSError(f"STEP export failed: {path}")


def _xde(shape):
    """An XCAF document (mm) holding ``shape`` as one free shape, named automatically."""
    from OCP.TCollection import TCollection_ExtendedString
    from OCP.TDocStd import TDocStd_Document
    from OCP.XCAFApp import XCAFApp_Application
    from OCP.XCAFDoc import XCAFDoc_DocumentTool

    doc = TDocStd_Document(TCollection_ExtendedString("XmlOcaf"))
    application = XCAFApp_Application.GetApplication_s()
    application.NewDocument(TCollection_ExtendedString("MDTV-XCAF"), doc)
    application.InitDocument(doc)
    XCAFDoc_DocumentTool.SetLengthUnit_s(doc, 1 / 1000)
    shape_tool = XCAFDoc_DocumentTool.ShapeTool_s(doc.Main())
    XCAFDoc_DocumentTool.ColorTool_s(doc.Main())
    shape_tool.SetAutoNaming_s(True)
    shape_tool.AddShape(shape, False)
    shape_tool.UpdateAssemblies()
    return doc


def write_stl(shape, path: str | os.PathLike, tolerance: float, angular_tolerance: float) -> None:
    """Mesh ``shape`` and write it as binary STL (``export_stl``).

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
    mesh = BRepMesh_IncrementalMesh(shape, tolerance, True, angular_tolerance, True)
    mesh.Perform()
    writer = StlAPI_Writer()
    writer.ASCIIMode = False
    if not writer.Write(shape, str(out)):
        raise OSError(f"STL export failed: {path}")
