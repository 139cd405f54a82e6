"""The tiling planned before any work, and what a mural's build records beyond its parts (for the recorder).

The plate thickness the tiling asks for is the plan's (:func:`stencil_cad.plan.plan.planned`).

The parts themselves (every tile's plates and walls, one tile for a one-plate job) are built by
:mod:`stencil_cad.pipeline.build`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from .. import mural
from ..figures import MuralBed, MuralBuildFigures, MuralFigures, TileRow
from ..model import DotSet, Layers, Picture

if TYPE_CHECKING:
    from ..config.job import JobConfig


def light_plates_on(cfg: JobConfig, tiled: bool) -> bool:
    """Whether each paint gets a light and a dark plate on a job with (``tiled``) or without tiles.

    The tiling decides (:func:`stencil_cad.mural.light_plates_on`); this is for a caller without the
    tiling at hand (the plate-design trials of a one-plate job).
    """
    return mural.light_plates_on(cfg, tiled)


def plan(
    cfg: JobConfig, width_mm: float, height_mm: float, work_px: int
) -> tuple[mural.TileGrid, MuralFigures]:
    """Tile the picture for the bed and check every part fits, before any work.

    ``cfg`` is the maker's config with its label and margin filled in (:func:`stencil_cad.plan.plan.planned`).

    Returns:
        ``(grid, figures)``: the tiles and the plan for the manifest (bed, halo, part sizes, cost).

    Raises:
        UserError: A part cannot fit the bed.
    """
    # The posts' spacing is decided here, from the maker's config: whether the plan fills the plate's
    # thickness in (its config has it filled in, :func:`stencil_cad.plan.plan.planned`); a mural's only.
    grid = mural.with_post_pitch(mural.plan_tiles(width_mm, height_mm, cfg), cfg)
    layers = mural.plate_layers(cfg, grid)
    sizes = mural.check_fits_bed(grid, cfg)
    made = mural.making_cost(grid, cfg, layers)
    cost = {
        **mural.plan_cost(grid, cfg, layers, work_px),
        "printer_hours": made.printer_hours,
        "filament_m": made.filament_m,
        "filament_g": made.filament_g,
    }
    if made.sheets is not None:
        cost.update(sheets=made.sheets, cut_m=made.cut_m, cut_hours=made.cut_hours)
    fig = MuralFigures(
        bed=None if grid.bed is None else MuralBed(grid.bed.name, grid.bed.x_mm, grid.bed.y_mm),
        tiled=mural.has_seams(grid),
        halo_mm=round(grid.halo_mm, 3),
        cost=cost,
        part_sizes=sizes,
    )
    return grid, fig


def tile_figures(
    cfg: JobConfig,
    asked: list[DotSet],
    drawn: list[DotSet],
    holes_tile: list[list[DotSet]],
    grid: mural.TileGrid,
    post_row: dict[str, Any] | None,
    stand_rows: list[dict[str, Any]] | None,
) -> MuralBuildFigures:
    """A mural's build beyond its parts' rows: the tiles, holes per tile, seams, order of work, the stand.

    Figure ``mural.built``, which the recorder records with ``mural_map.png`` (:func:`map_picture`).

    Args:
        cfg: The job's planned config.
        asked: Every layer's holes over the whole mural, as the stippler placed them.
        drawn: The same as the plates draw them.
        holes_tile: Per tile, per layer, the tile's drawn holes.
        grid: The tiles.
        post_row: The post's figures, or None.
        stand_rows: The laser-cut stand's rows, or None.
    """
    return MuralBuildFigures(
        tiles=tuple(TileRow.from_json(t) for t in mural.manifest_rows(grid)),
        holes_per_tile={
            t.name: [len(holes_tile[k][i]) for i in range(len(asked))] for k, t in enumerate(grid.tiles)
        },
        holes_total=int(sum(len(d) for d in drawn)),
        holes_global=int(sum(len(d) for d in asked)),
        union_check_rules="passed",
        compensated=bool(cfg.stipple.compensate),
        seam_density=mural.seam_density(asked, grid),
        order_of_work=mural.order_of_work(grid, len(asked)),
        posts=post_row,
        laser_stand=stand_rows,
    )


def map_picture(grid: mural.TileGrid, layers: Layers, picture: Picture | None) -> np.ndarray:
    """``mural_map.png``: the grid over the picture (the decomposition's composite without one), names, positions, order of work."""
    preview = picture.rgb if picture is not None else layers.composite()
    return mural.mural_map(grid, layers.count, preview)


def plan_line(plan: MuralFigures, cfg: JobConfig | None = None) -> str:
    """One line, printed before the work starts: what this size costs.

    With the job's ``cfg``: a one-plate job whose wall and plate thickness are left to it says its
    printer-hours are for the process's wall (the trials may choose a lower one, whose plates are
    thicker: the summary's cost after the trials counts those).
    """
    c = plan.cost
    bed = plan.bed
    where = f"bed {bed.name} ({bed.x_mm:g} × {bed.y_mm:g} mm)" if bed else "no bed given"
    if bed and "×" in bed.name:
        where = f"bed {bed.name}"
    line = (
        f"stencil-cad: plan: {c['tiles']} tile(s) ({c['grid']}, {where}), {c['plates']} plates, {c['walls']} wall(s), "
        f"at most {c['holes_at_most']:,} holes, about {c['estimated_seconds']:.0f} s"
    )
    if c.get("printer_hours") is not None:
        line += (
            f"; to make: about {c['printer_hours']:.1f} printer-hours, {c['filament_m']:.0f} m of filament "
            f"({c['filament_g']:.0f} g PLA)"
        )
        if cfg is not None and c["tiles"] == 1 and cfg.chooses_standoff and cfg.fills_thickness:
            line += " for the process's wall (a lower wall the job may choose takes thicker plates)"
    if c.get("sheets") is not None:
        line += f", {c['sheets']} laser sheet(s), {c['cut_m']:.1f} m of cut in about {c['cut_hours']:.1f} h"
    return line
