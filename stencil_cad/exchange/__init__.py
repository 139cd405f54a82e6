"""Every kernel-free reader and writer: STEP text, mesh + STL + 3MF, DXF, dots CSV, layers NPZ, PNG.

None of these modules imports the CAD kernel, so a laser-only user never loads OCCT.
"""

from .dots_csv import CSV_HEADER, DotFileError, dots_from_csv, dots_to_csv
from .dxf import (
    DxfInfo,
    DxfStencil,
    dxf_from_layers,
    stencil_for,
    write_dxf,
    write_dxf_stencils,
)
from .layers_npz import layers_from_npz, layers_to_npz
from .mesh import MeshError, mesh_checks, plate_mesh, read_stl, stl_bytes, threemf_bytes, write_triangles_stl
from .png import png_bytes
from .step import STEP_TIMESTAMP, step_text

__all__ = [
    "CSV_HEADER",
    "STEP_TIMESTAMP",
    "DotFileError",
    "DxfInfo",
    "DxfStencil",
    "MeshError",
    "dots_from_csv",
    "dots_to_csv",
    "dxf_from_layers",
    "layers_from_npz",
    "layers_to_npz",
    "mesh_checks",
    "plate_mesh",
    "png_bytes",
    "read_stl",
    "step_text",
    "stencil_for",
    "stl_bytes",
    "threemf_bytes",
    "write_dxf",
    "write_dxf_stencils",
    "write_triangles_stl",
]
