"""Every file name a job writes, in one place: stems per layer, wall, tile and step, and the sets each command may write."""

from __future__ import annotations

from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from .. import mural

import logging

from ..config import JobConfig
from ..output import MANIFEST

log = logging.getLogger(__name__)


LAYERS_NPZ = "layers.npz"
#: The stem of a mural's post (:mod:`stencil_cad.mural.posts`; every post is the same part).
POST_STEM = "post"
CONFIG_COPY = "config.yaml"


def dots_name(i: int) -> str:
    """File name of layer ``i``'s dots (0-based index, 1-based in the name)."""
    return f"layer_{i + 1:02d}_dots.csv"


def windows_name(i: int) -> str:
    """File name of layer ``i``'s windows (a hybrid plate's cut-outs), written when it has any."""
    return f"layer_{i + 1:02d}_windows.json"


def wall_stems(heights: list[float]) -> list[str]:
    """File stems of the walls (``heights``: :meth:`~stencil_cad.config.WallConfig.heights`).

    ``wall`` for one stand-off height, ``wall_10mm`` … for several.
    """
    return ["wall"] if len(heights) == 1 else [f"wall_{h:g}mm" for h in heights]


def layer_stem(i: int) -> str:
    """Stem of layer ``i``'s files (0-based index, 1-based in the name)."""
    return f"layer_{i + 1:02d}"


SPRAY_JSON = "spray.json"


def simulated_stems(cfg: JobConfig) -> list[str]:
    """Extra simulated pictures, one per wall, when the physical model sees several stand-offs."""
    heights = cfg.wall.heights()
    if not cfg.spray.is_physical or len(heights) == 1:
        return []
    return [f"simulated_{stem}.png" for stem in wall_stems(heights)]


def step_name(i: int) -> str:
    """File name of the simulated picture after layer ``i`` (0-based)."""
    return f"{layer_stem(i)}_after.png"


INSTRUCTIONS = ("instructions.html", "instructions.pdf")


#: The files each stage writes (shell patterns), for telling which files a re-run makes stale.
STAGE_FILES = {
    "stipple": ("layer_*_dots.csv", "layer_*_windows.json", "layer_*_dots.png", SPRAY_JSON, "swatch.png"),
    "build": ("layer_[0-9][0-9].*", "wall*.step", "wall*.stl", "tile_*", "mural_map.png"),
    "simulate": ("simulated*.png", "preview.png", "sweep.png", "layer_*_after.png"),
    "instructions": INSTRUCTIONS,
}
#: The stages that read what each stage writes, directly or through another.
LATER_STAGES = {
    "decompose": ("stipple", "build", "simulate"),
    "stipple": ("build", "simulate"),
    "build": (),
    "simulate": (),
}


CARD_JSON = "card.json"


def card_stems(standoffs_mm: list[float]) -> list[str]:
    """File stems of the card's walls: ``card_wall_6mm`` … (one per stand-off)."""
    return [f"card_wall_{h:g}mm" for h in sorted(set(standoffs_mm))]


#: Files a whole run writes besides the ``layer_NN*`` and ``wall*`` files.
RUN_FILES = (
    CONFIG_COPY,
    LAYERS_NPZ,
    SPRAY_JSON,
    MANIFEST,
    "swatch.png",
    "composite.png",
    "energy.csv",
    "simulated.png",
    "preview.png",
    "sweep.png",
    "segmentation.png",
)


def run_outputs(cfg: JobConfig, command: str) -> list[str]:
    """Names and patterns of the files a whole run or `decompose` may write (checked before work)."""
    if command == "decompose":
        return [
            CONFIG_COPY,
            LAYERS_NPZ,
            MANIFEST,
            "swatch.png",
            "composite.png",
            "energy.csv",
            "layer_*_opacity.png",
        ]
    return [*RUN_FILES, "layer_*", "wall*", "tile_*", "mural_map.png"]


def stage_outputs(cfg: JobConfig, command: str, count: int, grid: mural.TileGrid | None = None) -> list[str]:
    """Names a stage command will write, so it can refuse before doing the work."""
    if command == "build" and grid is not None and grid.tiled:
        return tile_outputs(cfg, grid, count)
    if command == "stipple":
        return [n for i in range(count) for n in (dots_name(i), f"{layer_stem(i)}_dots.png")] + [
            SPRAY_JSON,
            "swatch.png",
        ]
    if command == "build":
        exts = cfg.export.plate_extensions()
        names = [layer_stem(i) + e for i in range(count) for e in exts]
        return names + [s + e for s in wall_stems(cfg.wall.heights()) for e in (".step", ".stl")]
    if command == "simulate":
        return ["simulated.png", "preview.png", "sweep.png", *simulated_stems(cfg)] + [
            step_name(i) for i in range(count)
        ]
    return []


#: Commands that run one stage on the intermediates a previous command saved.
STAGE_COMMANDS = ("stipple", "build", "simulate")


def tile_stem(tile: mural.Tile, i: int) -> str:
    """Stem of a tile's layer files, e.g. ``tile_B3_layer_02`` (layer ``i`` 0-based)."""
    return f"tile_{tile.name}_layer_{i + 1:02d}"


def tile_wall_stems(tile: mural.Tile, heights: list[float]) -> list[str]:
    """Stems of a tile's walls: ``tile_B3_wall`` or ``tile_B3_wall_10mm`` … for several heights."""
    return (
        [f"tile_{tile.name}_wall"]
        if len(heights) == 1
        else [f"tile_{tile.name}_wall_{h:g}mm" for h in heights]
    )


def tile_outputs(cfg: JobConfig, grid: mural.TileGrid, count: int) -> list[str]:
    """Names the tiled build writes (so a stage command can refuse before the work)."""
    exts = cfg.export.plate_extensions()
    names = []
    from ..mural import laser_stand, post_plan, wall_tiles

    walls = wall_tiles(grid)
    laser = laser_stand(cfg, grid)
    for t in grid.tiles:
        names += [tile_stem(t, i) + e for i in range(count) for e in exts]
        if t.name in walls and laser is None:
            names += [s + e for s in tile_wall_stems(t, cfg.wall.heights()) for e in (".step", ".stl")]
    if laser is not None:
        names += [p.name + e for p in laser for e in (".dxf", ".svg")]
    elif post_plan(cfg, grid) is not None:
        names += [POST_STEM + e for e in (".step", ".stl")]
    return names + ["mural_map.png"]
