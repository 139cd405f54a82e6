"""The build stage's glue: plates and walls built, checked and exported, one plate per layer or per tile and layer."""

from __future__ import annotations

import logging
from collections.abc import Sequence

import numpy as np

from ..colour import to_hex
from ..errors import UserError
from ..figures import BuildFigures
from ..model import CutLayer, DotSet, Holes, Layers
from ..names import part_file
from ..output import plain as _plain
from ..record import Run
from ..stipple.made import drawn_dots
from .names import layer_stem, wall_stems

log = logging.getLogger(__name__)


def stage_build(run: Run, layers: Layers, holes: Sequence[Holes], picture_mm: tuple[float, float]) -> None:
    """Build, check and export one plate per layer and the wall(s)."""
    from .. import cad, outline
    from ..cad import wall as wall_mod
    from ..exchange import dxf
    from ..exchange.writers import ONE_PLATE_ORDER, part_figures, wanted, write_part

    cfg = run.cfg
    width_mm, height_mm = picture_mm
    exp = cfg.export
    results = []
    with run.stage("build"):
        ring = outline.plate_outline(width_mm, height_mm, cfg.plate.outline)
        with run.bar(len(holes), "build") as bar:
            for i, asked in enumerate(holes):
                # The plate draws each hole larger by what the process takes off (stipple.compensate).
                h = drawn_dots(asked, cfg.stipple, picture_mm) if isinstance(asked, DotSet) else asked
                label = cad.LabelInfo(
                    layer=i + 1,
                    layers=len(holes),
                    colour=to_hex(layers.colours[i]),
                    job=cfg.name,
                )
                try:
                    model = cad.build_plate(h, width_mm, height_mm, cfg.plate, label)
                except ValueError as exc:
                    # Holes that break the rules, a label that cannot fit, a bad template.
                    raise UserError(f"{layer_stem(i)}: {exc}") from exc
                check = cad.check_plate(model, h, tolerance_mm=exp.stl_tolerance_mm)
                stem = layer_stem(i)
                drawing = dxf.stencil_for(h, ring, stem.upper(), *model.cut_label())
                part = cad.plate_part(model, drawing, title=f"{cfg.name} {stem} of {len(holes)}")
                written = write_part(run.out, stem, part, wanted(exp, ONE_PLATE_ORDER), exp)
                dxf_info = part_figures(written)
                cut = round(dxf.cut_length_mm(h, ring), 1)
                (x0, y0, _), (x1, y1, _) = check["bbox"]
                size = [round(x1 - x0, 3), round(y1 - y0, 3)]
                row = {"layer": i + 1, **_plain(check), **dxf_info, "cut_length_mm": cut, "bbox_mm": size}
                row["windows"] = len(getattr(h, "windows", ()))
                if isinstance(h, CutLayer):
                    row["cutouts"] = h.cutout_figures()
                elif len(h.r_mm):
                    row["drawn_minus_asked_mm"] = round(float(np.mean(h.r_mm - asked.r_mm)), 4)
                results.append(row)
                bar.update(1)
        walls = []
        heights = cfg.standoff.walls_mm
        for standoff, stem in zip(heights, wall_stems(heights), strict=True):
            wm = wall_mod.build_wall(
                width_mm, height_mm, cfg.plate.outline, cfg.wall, cfg.plate.thickness_mm, standoff
            )
            with run.out.open_path(part_file(stem, ".step")) as p:
                wall_mod.wall_step(wm, p)
            with run.out.open_path(part_file(stem, ".stl")) as p:
                wall_mod.wall_stl(wm, p, exp.stl_tolerance_mm)
            walls.append(
                {"file": part_file(stem, ".step"), "standoff_mm": standoff, **wall_mod.check_wall(wm)}
            )
    run.figures.build = BuildFigures.from_rows(results, walls)


def check_template(run: Run) -> None:
    """Load and check the plate template before the first stage; record path and SHA-256.

    Raises:
        UserError: The template is not a Python file, fails to load, or has bad parameters.
    """
    from .. import cad

    try:
        run.template = cad.check_plate_template(run.cfg.plate)
    except ValueError as exc:
        raise UserError(f"plate.template: {exc}") from None
    if run.template["builtin"]:
        return
    log.warning(
        "plate template %s (SHA-256 %s) is Python code, not bundled with stencil-cad: it runs with your rights",
        run.template["path"],
        run.template["sha256"],
    )
    try_template(run)


def try_template(run: Run) -> None:
    """Build a one-hole plate with a user's template, so its own errors surface before the first stage.

    Raises:
        UserError: The template's ``build()`` failed (its error, named as the template's).
    """
    from .. import cad
    from ..model import DotSet

    cfg = run.cfg
    w = cfg.size.width_mm
    h = cfg.size.height_mm or w
    r = cfg.stipple.hole_floor_mm
    one = DotSet(xy_mm=np.array([[w / 2.0, h / 2.0]]), r_mm=np.array([r]))
    label = cad.LabelInfo(layer=1, layers=cfg.decompose.layers, colour="#000000", job=cfg.name)
    try:
        cad.build_plate(one, w, h, cfg.plate, label)
    except ValueError as exc:
        raise UserError(f"plate.template: tried on a one-hole {w:g} × {h:g} mm plate: {exc}") from None
