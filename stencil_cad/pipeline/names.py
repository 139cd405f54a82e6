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
    "tile_outputs",
    "tile_stem",
    "tile_wall_stems",
    "wall_stems",
    "windows_name",
]

log = logging.getLogger(__name__)


def simulated_stems(cfg: JobConfig) -> list[str]:
    """Extra simulated pictures, one per wall, when the physical model sees several stand-offs."""
    heights = cfg.standoff.walls_mm
    if not cfg.spray.is_physical or len(heights) == 1:
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


def stage_outputs(cfg: JobConfig, command: str, count: int, grid: mural.TileGrid | None = None) -> list[str]:
    """Names a stage command will write, so it can refuse before doing the work."""
    cmd = command_named(command)
    if not cmd.saved:
        return []
    if cmd.builds and grid is not None and grid.tiled:
        return tile_outputs(cfg, grid, count)
    if cmd.stipples:
        return [n for i in range(count) for n in (dots_name(i), dots_png(layer_stem(i)))] + [
            SPRAY_JSON,
            SWATCH_PNG,
        ]
    if cmd.builds:
        exts = cfg.export.plate_extensions()
        names = [part_file(layer_stem(i), e) for i in range(count) for e in exts]
        return names + [part_file(s, e) for s in wall_stems(cfg.standoff.walls_mm) for e in (".step", ".stl")]
    if cmd.simulates:
        return [SIMULATED_PNG, PREVIEW_PNG, SWEEP_PNG, *simulated_stems(cfg)] + [
            step_name(i) for i in range(count)
        ]
    return []


#: Commands that run one stage on the intermediates a previous command saved.
STAGE_COMMANDS = SAVED_STAGES


def tile_stem(tile: mural.Tile, i: int) -> str:
    """Stem of a tile's layer files, e.g. ``tile_B3_layer_02`` (layer ``i`` 0-based)."""
    return _tile_stem(tile.name, i)


def tile_wall_stems(tile: mural.Tile, heights: list[float]) -> list[str]:
    """Stems of a tile's walls: ``tile_B3_wall`` or ``tile_B3_wall_10mm`` … for several heights."""
    return _tile_wall_stems(tile.name, heights)


def tile_outputs(cfg: JobConfig, grid: mural.TileGrid, count: int) -> list[str]:
    """Names the tiled build writes (so a stage command can refuse before the work)."""
    exts = cfg.export.plate_extensions()
    names = []
    from ..mural import laser_stand, post_plan, wall_tiles

    walls = wall_tiles(grid)
    laser = laser_stand(cfg, grid)
    for t in grid.tiles:
        names += [part_file(tile_stem(t, i), e) for i in range(count) for e in exts]
        if t.name in walls and laser is None:
            names += [
                part_file(s, e) for s in tile_wall_stems(t, cfg.standoff.walls_mm) for e in (".step", ".stl")
            ]
    if laser is not None:
        names += [part_file(p.name, e) for p in laser for e in (".dxf", ".svg")]
    elif post_plan(cfg, grid) is not None:
        names += [part_file(POST_STEM, e) for e in (".step", ".stl")]
    return names + [MURAL_MAP_PNG]
