"""Murals: the tiling every stage takes, its seams, and the map a maker follows.

A picture larger than the bed is cut into tiles (:mod:`.tiling`); each hole belongs to one
tile and the tiles register on chalk lines through sight notches (:mod:`.seams`); the holes
are placed (:mod:`.stipple`) and refined (:mod:`.refine`) tile by tile, each tile a task;
:mod:`.cost` says what making the plates and walls costs, before any CAD; a mural's plates are
carried by posts between their holes (:mod:`.posts`), so they can be thin.
A one-plate job is a 1 × 1 tiling.
"""

from . import laser
from .cost import cut_seconds, making_cost
from .laser import laser_stand
from .map import mural_map
from .posts import (
    PostPlan,
    clear_post_sites,
    post_pitch_mm,
    post_plan,
    post_sites,
    sag_side_mm,
    with_pin_holes,
    with_post_pitch,
)
from .seams import (
    check_unions,
    notch_triangles,
    notched_ring,
    per_tile,
    registration_offsets,
    seam_density,
    shifted,
    simulate_tiles,
    split_dots,
    to_mural,
)
from .tiling import (
    HALO_TAIL,
    PLATE_NOTCH_MM,
    WALL_NOTCH_MM,
    Tile,
    TileGrid,
    check_fits_bed,
    check_mode,
    chooses_design,
    has_seams,
    label_band,
    light_plates_on,
    manifest_rows,
    order_of_work,
    part_name,
    part_sizes,
    phases,
    plan_cost,
    plan_tiles,
    plate_layers,
    region_bounds,
    row_name,
    sight_lines,
    spray_halo_mm,
    tile_label,
    wall_key,
    wall_tiles,
)

__all__ = [
    "HALO_TAIL",
    "laser",
    "laser_stand",
    "PostPlan",
    "clear_post_sites",
    "post_pitch_mm",
    "with_post_pitch",
    "post_plan",
    "post_sites",
    "sag_side_mm",
    "with_pin_holes",
    "wall_key",
    "wall_tiles",
    "PLATE_NOTCH_MM",
    "Tile",
    "TileGrid",
    "WALL_NOTCH_MM",
    "check_fits_bed",
    "check_mode",
    "check_unions",
    "chooses_design",
    "has_seams",
    "label_band",
    "light_plates_on",
    "part_name",
    "per_tile",
    "plate_layers",
    "sight_lines",
    "cut_seconds",
    "making_cost",
    "manifest_rows",
    "mural_map",
    "notch_triangles",
    "notched_ring",
    "order_of_work",
    "part_sizes",
    "phases",
    "plan_cost",
    "plan_tiles",
    "region_bounds",
    "registration_offsets",
    "row_name",
    "seam_density",
    "shifted",
    "simulate_tiles",
    "split_dots",
    "spray_halo_mm",
    "tile_label",
    "to_mural",
]
