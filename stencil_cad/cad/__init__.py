"""The CAD stage: stencil plates (and the wall) as build123d/OCP solids, and their files.

This is the only package that imports build123d / OCP. Public API for plates:

* :func:`build_plate` – a plate per layer, through the (editable) plate template;
* :func:`check_plate` – validity, volume, bbox, hole count and mesh checks;
* :func:`write_step`, :func:`write_stl`, :func:`write_3mf` – the files.
"""

from __future__ import annotations

import time

from .export import write_3mf, write_step, write_stl
from .mesh import MeshError, PlateGeometry, TriMesh, mesh_checks
from .plate import (
    LabelInfo,
    PlateBuildError,
    PlateModel,
    check_holes,
    label_text,
    make_solid,
    perforated_plate,
)
from .validate import PlateCheckError, check_plate

__all__ = [
    "LabelInfo",
    "MeshError",
    "PlateBuildError",
    "PlateCheckError",
    "PlateGeometry",
    "PlateModel",
    "TriMesh",
    "build_plate",
    "check_holes",
    "check_plate",
    "label_text",
    "make_solid",
    "mesh_checks",
    "perforated_plate",
    "write_3mf",
    "write_step",
    "write_stl",
]


def build_plate(
    holes, width_mm: float, height_mm: float, cfg, label: LabelInfo | None, *, rules=None
) -> PlateModel:
    """Build one layer's plate: check the holes again, then run the plate template.

    Args:
        holes: A :class:`~stencil_cad.model.DotSet` (round holes) or a
            :class:`~stencil_cad.model.CutLayer` (polygon cut-outs, hard mode).
        width_mm: Picture width in mm (the picture area is ``[0, w] x [0, h]``).
        height_mm: Picture height in mm.
        cfg: The ``plate`` config section (:class:`~stencil_cad.config.PlateConfig`).
        label: What the label says, or None for no label.
        rules: Optional :class:`~stencil_cad.dots.DesignRules` to re-check the dots
            with (the job's process rules); by default the plate's own floor:
            radius ≥ 0.5 mm, web ≥ ``cfg.min_web_mm``, inside the picture.

    Returns:
        The plate model (build123d Part, description, analytic volume).

    Raises:
        PlateBuildError: Bad dots (listing the first offenders), a label that does not
            fit, or a template problem. Nothing is built in that case.
    """
    from .. import outline as outline_mod
    from .template import builtin_template, config_overrides, run_template

    t0 = time.perf_counter()
    check_holes(holes, width_mm, height_mm, cfg.min_web_mm, rules)
    t1 = time.perf_counter()
    ring = outline_mod.plate_outline(width_mm, height_mm, cfg.outline)
    area = outline_mod.label_region(width_mm, height_mm, cfg.outline)
    path = cfg.template if cfg.template is not None else builtin_template()
    model = run_template(
        path, holes, ring, area, label, config_overrides(cfg), strict=set(cfg.template_params)
    )
    if model.geometry is not None:
        model.geometry = _with_size(model.geometry, width_mm, height_mm)
    model.info["full_check_max_holes"] = cfg.full_check_max_holes
    model.info["template"] = str(path)
    secs = model.info.setdefault("seconds", {})
    secs["check_holes"] = round(t1 - t0, 3)
    secs["build"] = round(time.perf_counter() - t0, 3)
    return model


def _with_size(geom: PlateGeometry, width_mm: float, height_mm: float) -> PlateGeometry:
    from dataclasses import replace

    return replace(geom, width_mm=float(width_mm), height_mm=float(height_mm))
