"""A built plate's files: the kernel-free writers when it has a description, OCCT otherwise.

A plate built from a :class:`~stencil_cad.model.PlateGeometry` is written by the
linear STEP writer and mesher of :mod:`stencil_cad.exchange`; a template's own
solid goes through OCCT's STEP writer and mesher, which are only fast for small plates.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from ..exchange.dxf import DxfStencil
from ..exchange.mesh import stl_bytes, threemf_bytes
from ..exchange.step import step_text
from ..exchange.writers import PartFiles
from ..model import TriMesh

__all__ = ["occt_mesh", "plate_part", "plate_step_text", "write_3mf", "write_step", "write_stl"]


def _name(model) -> str:
    label = getattr(model, "label", None)
    if label is None:
        return "stencil_plate"
    job = label.job or "stencil"
    return f"{job} layer {label.layer} of {label.layers}"


def plate_step_text(model) -> str:
    """The STEP text of a plate with a description, as :func:`write_step` writes it.

    Args:
        model: A :class:`~stencil_cad.cad.plate.PlateModel` whose ``geometry`` is not None.
    """
    return step_text(model.geometry, _name(model))


def plate_part(
    model, drawing: DxfStencil | None = None, title: str = "", step: str | None = None
) -> PartFiles:
    """A built plate as the registry of writers (:mod:`stencil_cad.exchange.writers`) reads it.

    Args:
        model: A :class:`~stencil_cad.cad.plate.PlateModel`.
        drawing: Its cut drawing, for the DXF and SVG. Defaults to none.
        title: The SVG's title. Defaults to none.
        step: The plate's STEP text when the caller made it already (:func:`plate_step_text`,
            checked before writing), written as it is. Defaults to none: made when written.
    """
    return PartFiles(
        name=_name(model),
        step=lambda path: write_step(model, path, step),
        mesh=model.mesh,
        drawing=drawing,
        title=title,
    )


def write_step(model, path: str | os.PathLike, text: str | None = None) -> None:
    """Write a plate as STEP (AP214, mm): one manifold solid with exact circles.

    Args:
        model: A :class:`~stencil_cad.cad.plate.PlateModel`.
        path: Where to write (the caller renames it into place).
        text: The plate's STEP text (:func:`plate_step_text`), when made already. Defaults to none.
    """
    path = Path(path)
    if text is not None:
        path.write_text(text, encoding="ascii")
        return
    if getattr(model, "geometry", None) is not None:
        path.write_text(plate_step_text(model), encoding="ascii")
        return
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.Interface import Interface_Static
    from OCP.STEPControl import STEPControl_AsIs, STEPControl_Writer

    from .occt import STEP_LOCK

    # OCCT's STEP settings are the process's: the wall's writer sets them too, under the same lock.
    with STEP_LOCK:
        writer = STEPControl_Writer()
        Interface_Static.SetCVal_s("write.step.unit", "MM")
        writer.Transfer(model.shape, STEPControl_AsIs)
        if writer.Write(str(path)) != IFSelect_RetDone:
            raise OSError(f"OCCT could not write {path}")


def write_stl(model, path: str | os.PathLike, tolerance_mm: float = 0.02) -> None:
    """Write a plate as binary STL: closed, consistently wound, facing out.

    Args:
        model: A :class:`~stencil_cad.cad.plate.PlateModel`.
        path: Where to write.
        tolerance_mm: Largest distance in mm between a round hole and its polygon.
            Defaults to 0.02 mm.
    """
    Path(path).write_bytes(stl_bytes(model.mesh(tolerance_mm), _name(model)))


def write_3mf(model, path: str | os.PathLike, tolerance_mm: float = 0.02) -> None:
    """Write a plate as 3MF (one mesh object, mm); the same mesh as the STL.

    Args:
        model: A :class:`~stencil_cad.cad.plate.PlateModel`.
        path: Where to write.
        tolerance_mm: Largest distance in mm between a round hole and its polygon.
            Defaults to 0.02 mm.
    """
    Path(path).write_bytes(threemf_bytes(model.mesh(tolerance_mm), _name(model)))


def occt_mesh(part, tolerance_mm: float) -> TriMesh:
    """Mesh any OCCT shape with BRepMesh and merge it into one indexed mesh (slow on big plates).

    Args:
        part: A build123d shape (or anything with ``.wrapped``).
        tolerance_mm: Linear deflection in mm.

    Returns:
        The mesh, vertices merged per shared B-rep vertex/edge node.
    """
    from OCP.BRep import BRep_Tool
    from OCP.BRepMesh import BRepMesh_IncrementalMesh
    from OCP.TopAbs import TopAbs_FACE, TopAbs_REVERSED
    from OCP.TopExp import TopExp_Explorer
    from OCP.TopLoc import TopLoc_Location
    from OCP.TopoDS import TopoDS

    shape = part.wrapped if hasattr(part, "wrapped") else part
    BRepMesh_IncrementalMesh(shape, tolerance_mm, False, 0.5, True)
    verts, faces, offset = [], [], 0
    exp = TopExp_Explorer(shape, TopAbs_FACE)
    while exp.More():
        face = TopoDS.Face_s(exp.Current())
        loc = TopLoc_Location()
        tri = BRep_Tool.Triangulation_s(face, loc)
        if tri is not None:
            trsf = loc.Transformation()
            pts = []
            for i in range(1, tri.NbNodes() + 1):
                p = tri.Node(i).Transformed(trsf)
                pts.append((p.X(), p.Y(), p.Z()))
            ids = []
            for i in range(1, tri.NbTriangles() + 1):
                a, b, c = tri.Triangle(i).Get()
                ids.append(
                    (a - 1, b - 1, c - 1) if face.Orientation() != TopAbs_REVERSED else (a - 1, c - 1, b - 1)
                )
            verts.append(np.asarray(pts, dtype=np.float64))
            faces.append(np.asarray(ids, dtype=np.int64) + offset)
            offset += len(pts)
        exp.Next()
    v = np.concatenate(verts)
    f = np.concatenate(faces)
    # Merge coincident nodes (faces share edge discretisations exactly).
    _, first, inv = np.unique(np.round(v, 9), axis=0, return_index=True, return_inverse=True)
    return TriMesh(v[first], inv.reshape(-1)[f], {"mesher": "occt"})
