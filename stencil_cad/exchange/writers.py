"""The writers of a part's files by extension: one registry every plate, card and stand part goes through.

A new file format is one entry of :data:`WRITERS`: its writer, its manifest figures and the
``export`` setting that turns it on (a field of :class:`~stencil_cad.config.ExportConfig`, the
maker's key). The orders parts are written in follow the registry; the callers name extensions,
never writers.
"""

from __future__ import annotations

import tempfile
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

from ..config import ExportConfig
from ..model import TriMesh
from ..names import part_file
from .dxf import DxfInfo, DxfStencil, write_dxf_stencils
from .mesh import stl_bytes, threemf_bytes
from .svg import SvgInfo, write_svg

__all__ = [
    "ONE_PLATE_ORDER",
    "TILE_ORDER",
    "WRITERS",
    "PartFiles",
    "Writer",
    "part_bytes",
    "part_figures",
    "path_bytes",
    "wanted",
    "write_part",
]


class _Folder(Protocol):
    def open_path(self, name: str) -> Any: ...


@dataclass(frozen=True)
class PartFiles:
    """What a part's writers read; a part without a field is never asked for the formats that need it.

    Attributes:
        name: The model's name inside its STEP, STL and 3MF.
        step: Writes the part's STEP to a path (the kernel-free writer, or OCCT's for a template's solid).
        mesh: The part's mesh for a chord tolerance in mm (STL, 3MF).
        drawing: The part's cut drawing (DXF, SVG).
        title: The SVG's title.
    """

    name: str = ""
    step: Callable[[Path], None] | None = None
    mesh: Callable[[float], TriMesh] | None = None
    drawing: DxfStencil | None = None
    title: str = ""


@dataclass(frozen=True)
class Writer:
    """One format's writer.

    Attributes:
        write: Writes a part to a path with the ``export`` settings; returns what it wrote, or None.
        figures: The manifest's keys for what it wrote (empty for most formats).
        flag: The ``export`` setting that turns the format on.
    """

    write: Callable[[PartFiles, Path, ExportConfig], Any]
    figures: Callable[[Any], dict[str, Any]]
    #: The ``export`` setting (a boolean field of :class:`~stencil_cad.config.ExportConfig`) that turns it on.
    flag: str


def _none(_: Any) -> dict[str, Any]:
    return {}


def _need(value: Any, part: PartFiles, what: str) -> Any:
    if value is None:
        raise ValueError(f"{part.name or 'this part'} has no {what} to write")
    return value


def _step(part: PartFiles, path: Path, export: ExportConfig) -> None:
    _need(part.step, part, "STEP")(path)


def _stl(part: PartFiles, path: Path, export: ExportConfig) -> None:
    path.write_bytes(stl_bytes(_need(part.mesh, part, "mesh")(export.stl_tolerance_mm), part.name))


def _3mf(part: PartFiles, path: Path, export: ExportConfig) -> None:
    path.write_bytes(threemf_bytes(_need(part.mesh, part, "mesh")(export.stl_tolerance_mm), part.name))


def _dxf(part: PartFiles, path: Path, export: ExportConfig) -> DxfInfo:
    # Fixed dates and GUIDs: the same job writes the same bytes, wherever it ran.
    drawing = _need(part.drawing, part, "drawing")
    return write_dxf_stencils(path, [drawing], kerf_mm=export.kerf_mm, deterministic=True)


def _dxf_figures(info: DxfInfo) -> dict[str, Any]:
    # Laser software wants +X/+Y: the drawing is shifted by this much from the picture frame.
    return {"dxf_offset_mm": [round(float(v), 4) for v in info.offset_mm]}


def _svg(part: PartFiles, path: Path, export: ExportConfig) -> SvgInfo:
    return write_svg(path, _need(part.drawing, part, "drawing"), kerf_mm=export.kerf_mm, title=part.title)


def _svg_figures(info: SvgInfo) -> dict[str, Any]:
    return {"svg_offset_mm": [round(float(v), 4) for v in info.offset_mm], "svg_circles": info.circles}


#: Every format a part is written in, by extension, in the order a one-plate job writes them.
WRITERS: dict[str, Writer] = {
    ".step": Writer(_step, _none, "step"),
    ".stl": Writer(_stl, _none, "stl"),
    ".3mf": Writer(_3mf, _none, "three_mf"),
    ".dxf": Writer(_dxf, _dxf_figures, "dxf"),
    ".svg": Writer(_svg, _svg_figures, "svg"),
}


def _tile_order(order: tuple[str, ...]) -> tuple[str, ...]:
    """A mural tile's order: the one-plate order with its SVG before its DXF, as a tile always wrote them."""
    out = list(order)
    i, j = out.index(".dxf"), out.index(".svg")
    out[i], out[j] = out[j], out[i]
    return tuple(out)


#: The order a one-plate job writes a plate's files in (the manifest's file table keeps it).
ONE_PLATE_ORDER = tuple(WRITERS)
#: The order a mural's tile plate writes its files in: its SVG before its DXF, as it always has.
TILE_ORDER = _tile_order(ONE_PLATE_ORDER)


def wanted(export: ExportConfig, order: Iterable[str] = ONE_PLATE_ORDER) -> list[str]:
    """The extensions the ``export`` config turns on, in ``order``."""
    return [e for e in order if bool(getattr(export, WRITERS[e].flag))]


def write_part(
    folder: _Folder, stem: str, part: PartFiles, extensions: Iterable[str], export: ExportConfig
) -> dict[str, Any]:
    """Write ``part`` as ``stem`` plus each extension, in order, through an output folder's ``open_path``.

    Returns:
        What each writer wrote, by extension (None for most formats).

    Raises:
        KeyError: An extension without a writer.
    """
    out: dict[str, Any] = {}
    for ext in extensions:
        writer = WRITERS[ext]
        with folder.open_path(part_file(stem, ext)) as p:
            out[ext] = writer.write(part, Path(p), export)
    return out


def path_bytes(name: str, write: Callable[[Path], Any]) -> tuple[bytes, Any]:
    """The bytes ``write`` writes to a file named ``name``, and what it returned.

    For a part built where a task runs (a worker may be another machine): its files travel back
    as bytes with the task's result, and the caller writes them. The writer writes a path (OCCT's
    writers take nothing else) in a private temporary folder, removed at once.
    """
    with tempfile.TemporaryDirectory(prefix="stencil-part-") as tmp:
        path = Path(tmp) / name
        got = write(path)
        return path.read_bytes(), got


def _writing(writer: Writer, part: PartFiles, export: ExportConfig) -> Callable[[Path], Any]:
    return lambda path: writer.write(part, path, export)


def part_bytes(
    stem: str, part: PartFiles, extensions: Iterable[str], export: ExportConfig
) -> tuple[list[tuple[str, bytes]], dict[str, Any]]:
    """``part``'s files as ``stem`` plus each extension, in order, as ``(name, bytes)``; the caller writes them.

    Returns:
        ``(files, written)``: the files, and what each writer wrote by extension (None for most formats).

    Raises:
        KeyError: An extension without a writer.
    """
    files: list[tuple[str, bytes]] = []
    written: dict[str, Any] = {}
    for ext in extensions:
        writer, name = WRITERS[ext], part_file(stem, ext)
        data, written[ext] = path_bytes(name, _writing(writer, part, export))
        files.append((name, data))
    return files, written


def part_figures(written: dict[str, Any]) -> dict[str, Any]:
    """The manifest's keys for what :func:`write_part` (or :func:`part_bytes`) wrote, in the order it wrote them."""
    figures: dict[str, Any] = {}
    for ext, info in written.items():
        figures.update(WRITERS[ext].figures(info))
    return figures
