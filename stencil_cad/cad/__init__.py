"""The CAD stage: stencil plates (and the wall) as build123d/OCP solids, and their files.

This is the only package that imports build123d / OCP. Public API for plates:

* :func:`build_plate` – a plate per layer, through the (editable) plate template;
* :func:`check_plate` – validity, volume, bbox, hole count and mesh checks on the OCCT solid;
* :func:`check_plate_file` – the same checks on the written STEP text and mesh, kernel-free;
* :func:`write_step`, :func:`write_stl`, :func:`write_3mf` – the files.
"""

from .plate import (
    LabelInfo,
    PlateBuildError,
    PlateModel,
    check_holes,
    label_text,
    make_solid,
    perforated_plate,
)
from .template import build_plate, check_plate_template
from .validate import PlateCheckError, check_plate, check_plate_file
from .writers import plate_part, plate_step_text, write_3mf, write_step, write_stl

__all__ = [
    "LabelInfo",
    "PlateBuildError",
    "PlateCheckError",
    "PlateModel",
    "build_plate",
    "check_plate_template",
    "check_holes",
    "check_plate",
    "check_plate_file",
    "label_text",
    "make_solid",
    "perforated_plate",
    "plate_part",
    "plate_step_text",
    "write_3mf",
    "write_step",
    "write_stl",
]
