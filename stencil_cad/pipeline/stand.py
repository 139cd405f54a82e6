"""The stand of a mural's plates beyond the wall's tasks: the printed post, or a laser-cut frame and spacers, as files to write."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from .. import mural
from ..names import part_file
from ..output import plain as _plain
from ..plan.names import POST_STEM
from ..plan.plan import Plan
from ..plan.results import Stand

#: A laser-cut stand part's files.
LASER_FORMATS = (".dxf", ".svg")

if TYPE_CHECKING:
    from ..config.bed import Bed
    from ..config.job import JobConfig
    from ..figures import LayerStipple
    from ..mural.laser import CutPart


def stage_stand(
    plan: Plan,
    laser: list[CutPart] | None,
    posts: dict[tuple[str, int], list[list[float]]],
    stipple: Sequence[LayerStipple] = (),
) -> Stand:
    """A mural's stand beyond its walls: the laser-cut frame and spacers ``laser``, or the post its plates stand on.

    The parts are built, checked and exported as bytes here; the recorder writes them.

    Args:
        plan: The job's plan (its config, and its tiling: the bed, and the posts it plans:
            :func:`stencil_cad.mural.post_plan`).
        laser: The laser-cut stand's parts (:func:`stencil_cad.mural.laser_stand`), or None.
        posts: The posts' sites per (tile, layer) from the build.
        stipple: Figure ``stipple`` (the holes each plate's posts dropped).

    Returns:
        The stand's files, and the post's figures or the laser-cut parts' rows (empty when absent).
    """
    cfg, grid = plan.cfg, plan.grid
    post_plan = mural.post_plan(cfg, grid)
    if laser is not None:
        return laser_stand(cfg, laser, grid.bed)
    if post_plan is not None and any(posts.values()):
        return post_stand(cfg, post_plan, posts, stipple)
    return Stand()


def post_stand(
    cfg: JobConfig,
    plan: mural.PostPlan,
    posts: dict[tuple[str, int], list[list[float]]],
    stipple: Sequence[LayerStipple],
) -> Stand:
    """Build, check and export the job's post (every post is the same): its files and figures."""
    from ..cad import post as post_mod
    from ..exchange.writers import path_bytes

    model = post_mod.build_post(
        plan.radius_mm, plan.height_mm, plan.pin_radius_mm, cfg.plate.planned_thickness_mm
    )
    stem = POST_STEM
    step = part_file(stem, ".step")
    stl = part_file(stem, ".stl")
    files = (
        (step, path_bytes(step, lambda p: post_mod.post_step(model, p))[0]),
        (stl, path_bytes(stl, lambda p: post_mod.post_stl(model, p, cfg.export.stl_tolerance_mm))[0]),
    )
    dropped = sum(int(s.get("removed_post", 0)) for s in (st.report for st in stipple))
    row = {
        "file": step,
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
    return Stand(files, post_row=row)


def laser_stand(cfg: JobConfig, parts: list[CutPart], bed: Bed | None) -> Stand:
    """Each laser-cut part of the stand (``frame_base``, ``frame_top``, ``spacer``) as DXF and SVG, and its row.

    Each part is checked like a plate (a closed outline, its cuts inside it, the bed) before it is
    exported; its row gives the count to cut, the sheet, the cut length and the estimated cut time.

    Raises:
        UserError: A part fails its checks.
    """
    from ..errors import UserError
    from ..exchange import dxf
    from ..exchange.writers import PartFiles, part_bytes
    from ..mural.cost import cut_seconds

    exp = cfg.export
    size = None if bed is None else (bed.x_mm, bed.y_mm)
    files: list[tuple[str, bytes]] = []
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
        made = PartFiles(name=part.name, drawing=drawing, title=f"{cfg.name} {part.name}")
        files += part_bytes(part.name, made, LASER_FORMATS, exp)[0]
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
    return Stand(tuple(files), stand_rows=rows)
