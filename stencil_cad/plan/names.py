"""The names each command may write for its config, built from :mod:`stencil_cad.names` (every file name)."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .. import mural

import logging

from ..command_table import SAVED_STAGES
from ..command_table import command as command_named
from ..config import JobConfig
from ..names import (
    CARD_JSON,
    CONFIG_COPY,
    DECOMPOSE_FILES,
    INSTRUCTIONS,
    LAYERS_NPZ,
    MURAL_MAP_PNG,
    PLAN_JSON,
    POST_STEM,
    PREVIEW_PNG,
    RUN_FILES,
    RUN_PATTERNS,
    SIMULATED_PNG,
    SPRAY_JSON,
    STAGE_FILES,
    SWATCH_PNG,
    SWEEP_PNG,
    card_stems,
    dots_name,
    dots_png,
    layer_stem,
    part_file,
    simulated_wall_name,
    step_name,
    wall_stems,
    windows_name,
)
from ..names import tile_stem as _tile_stem
from ..names import tile_wall_stems as _tile_wall_stems

__all__ = [
    "CARD_JSON",
    "CONFIG_COPY",
    "INSTRUCTIONS",
    "LATER_STAGES",
    "LAYERS_NPZ",
    "PLAN_JSON",
    "POST_STEM",
    "RUN_FILES",
    "SPRAY_JSON",
    "STAGE_COMMANDS",
    "STAGE_FILES",
    "card_stems",
    "dots_name",
    "layer_stem",
    "run_outputs",
    "simulated_stems",
    "stage_outputs",
    "step_name",
    "build_outputs",
    "part_stem",
    "part_wall_stems",
    "wall_stems",
    "windows_name",
]

log = logging.getLogger(__name__)


def simulated_stems(cfg: JobConfig) -> list[str]:
    """Extra simulated pictures, one per wall, when the spray model sees several stand-offs (the physical one)."""
    heights = cfg.standoff.walls_mm
    if not cfg.spray.has_wall or len(heights) == 1:
        return []
    return [simulated_wall_name(stem) for stem in wall_stems(heights)]


#: The stages that read what each stage writes, directly or through another.
LATER_STAGES = {
    "decompose": ("stipple", "build", "simulate"),
    "stipple": ("build", "simulate"),
    "build": (),
    "simulate": (),
}


def run_outputs(cfg: JobConfig, command: str) -> list[str]:
    """Names and patterns of the files a whole run or `decompose` may write (checked before work)."""
    if not command_named(command).whole:
        return list(DECOMPOSE_FILES)
    return [*RUN_FILES, *RUN_PATTERNS]


def stage_outputs(cfg: JobConfig, command: str, count: int, grid: mural.TileGrid) -> list[str]:
    """Names a stage command will write for the job's tiling, so it can refuse before doing the work."""
    cmd = command_named(command)
    if not cmd.saved:
        return []
    if cmd.builds:
        return build_outputs(cfg, grid, count)
    if cmd.stipples:
        # `stipple` brings the saved plan up to date with the design it chose.
        return [n for i in range(count) for n in (dots_name(i), dots_png(layer_stem(i)))] + [
            SPRAY_JSON,
            SWATCH_PNG,
            PLAN_JSON,
        ]
    if cmd.simulates:
        return [SIMULATED_PNG, PREVIEW_PNG, SWEEP_PNG, *simulated_stems(cfg)] + [
            step_name(i) for i in range(count)
        ]
    return []


#: Commands that run one stage on the intermediates a previous command saved.
STAGE_COMMANDS = SAVED_STAGES


def part_stem(tile: str | None, i: int) -> str:
    """Stem of a plate's files: ``layer_02`` for one tile (``tile`` None), ``tile_B3_layer_02`` on a mural."""
    return layer_stem(i) if tile is None else _tile_stem(tile, i)


def part_wall_stems(tile: str | None, heights: list[float]) -> list[str]:
    """Stems of a tile's walls: ``wall`` (``wall_10mm`` …) for one tile (``tile`` None), ``tile_B3_wall`` … on a mural."""
    return wall_stems(heights) if tile is None else _tile_wall_stems(tile, heights)


def build_outputs(cfg: JobConfig, grid: mural.TileGrid, count: int) -> list[str]:
    """Names the build writes for a tiling (so a stage command can refuse before the work)."""
    from ..exchange.writers import wanted

    exts = wanted(cfg.export)
    names = []
    from ..mural import has_seams, laser_stand, part_name, post_plan, wall_tiles

    walls = wall_tiles(grid)
    laser = laser_stand(cfg, grid)
    for t in grid.tiles:
        name = part_name(t, grid)
        names += [part_file(part_stem(name, i), e) for i in range(count) for e in exts]
        if t.name in walls and laser is None:
            names += [
                part_file(s, e)
                for s in part_wall_stems(name, cfg.standoff.walls_mm)
                for e in (".step", ".stl")
            ]
    if laser is not None:
        names += [part_file(p.name, e) for p in laser for e in (".dxf", ".svg")]
    elif post_plan(cfg, grid) is not None:
        names += [part_file(POST_STEM, e) for e in (".step", ".stl")]
    return names + ([MURAL_MAP_PNG] if has_seams(grid) else [])
