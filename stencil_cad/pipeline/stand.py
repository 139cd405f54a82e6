"""The stand of a mural's plates beyond the wall's tasks: the printed post, or a laser-cut frame and spacers."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from .. import mural
from ..names import part_file
from ..output import plain as _plain
from ..plan.names import POST_STEM
from ..record import Run

#: A laser-cut stand part's files.
LASER_FORMATS = (".dxf", ".svg")

if TYPE_CHECKING:
    from ..config.bed import Bed
    from ..config.job import JobConfig
    from ..mural.laser import CutPart


def stage_stand(
    run: Run,
    cfg: JobConfig,
    grid: mural.TileGrid,
    laser: list[CutPart] | None,
    posts: dict[tuple[str, int], list[list[float]]],
) -> tuple[dict[str, Any] | None, list[dict[str, Any]] | None]:
    """A mural's stand beyond its walls: the laser-cut frame and spacers ``laser``, or the post its plates stand on.

    Args:
        run: The run.
        cfg: The job's planned config.
        grid: The job's tiling (its bed, and the posts it plans: :func:`stencil_cad.mural.post_plan`).
        laser: The laser-cut stand's parts (:func:`stencil_cad.mural.laser_stand`), or None.
        posts: The posts' sites per (tile, layer) from the build.

    Returns:
        ``(post_row, stand_rows)``: the post's figures, or the laser-cut parts' rows (None when absent).
    """
    plan = mural.post_plan(cfg, grid)
    if laser is not None:
        return None, write_laser_stand(run, cfg, laser, grid.bed)
    if plan is not None and any(posts.values()):
        return write_post(run, cfg, plan, posts), None
    return None, None


def write_post(
    run: Run, cfg: JobConfig, plan: mural.PostPlan, posts: dict[tuple[str, int], list[list[float]]]
) -> dict[str, Any]:
    """Build, check and write the job's post (every post is the same); its figures."""
    from ..cad import post as post_mod

    model = post_mod.build_post(
        plan.radius_mm, plan.height_mm, plan.pin_radius_mm, cfg.plate.planned_thickness_mm
    )
    stem = POST_STEM
    with run.out.open_path(part_file(stem, ".step")) as p:
        post_mod.post_step(model, p)
    with run.out.open_path(part_file(stem, ".stl")) as p:
        post_mod.post_stl(model, p, cfg.export.stl_tolerance_mm)
    dropped = sum(int(s.get("removed_post", 0)) for s in (st.report for st in run.figures.stipple or ()))
    return {
        "file": part_file(stem, ".step"),
        "height_mm": plan.height_mm,
        "radius_mm": plan.radius_mm,
        "pin_radius_mm": plan.pin_radius_mm,
        "pin_hole_mm": plan.pin_hole_mm,
        "keepout_mm": round(plan.keepout_mm, 3),
        "per_plate": {f"{t} {k}": len(v) for (t, k), v in posts.items()},
        "sites_mm": {f"{t} {k}": v for (t, k), v in posts.items()},
        "most": max(len(v) for v in posts.values()),
        "dropped_holes": dropped,
        **_plain(post_mod.check_post(model)),
    }


def write_laser_stand(
    run: Run, cfg: JobConfig, parts: list[CutPart], bed: Bed | None
) -> list[dict[str, Any]]:
    """Write each laser-cut part of the stand (``frame_base``, ``frame_top``, ``spacer``) as DXF and SVG.

    Each part is checked like a plate (a closed outline, its cuts inside it, the bed) before it is
    written; its row gives the count to cut, the sheet, the cut length and the estimated cut time.

    Raises:
        UserError: A part fails its checks.
    """
    from ..errors import UserError
    from ..exchange import dxf
    from ..exchange.writers import PartFiles, write_part
    from ..mural.cost import cut_seconds

    exp = cfg.export
    size = None if bed is None else (bed.x_mm, bed.y_mm)
    rows = []
    for part in parts:
        check = mural.laser.check_cut_part(part, size)
        if not check["ok"]:
            raise UserError(f"{part.name}: the laser-cut part fails its checks: {check}")
        drawing = dxf.DxfStencil(
            outline_ring=part.outline,
            circles_xy_r=part.circles if len(part.circles) else None,
            polygons=[(r, ()) for r in part.inner] or None,
            layer_name=part.name.upper(),
            label=part.name,
        )
        files = PartFiles(name=part.name, drawing=drawing, title=f"{cfg.name} {part.name}")
        write_part(run.out, part.name, files, LASER_FORMATS, exp)
        rows.append(
            {
                "name": part.name,
                "count": part.count,
                "thickness_mm": part.thickness_mm,
                "cut_m": round(part.cut_mm / 1000.0, 3),
                "cut_minutes": round(cut_seconds(part.cut_mm, part.pierces) / 60.0, 2),
                "files": [part_file(part.name, e) for e in LASER_FORMATS],
                **_plain(check),
            }
        )
    return rows
