"""The tiling: a picture larger than the bed cut into tiles that spray without a seam.

The holes are placed tile by tile, each tile relaxed against the holes its neighbours
placed before it (:mod:`stencil_cad.mural_stipple`; with ``stipple.dots``, one count for the
whole picture, each layer in one piece), so the web rule, the density and the tone hold
across every seam. This module *partitions* them:

* the mural is cut into a grid of ``cols × rows`` equal tiles named by row and column
  (row A at the top, columns from 1 at the left: A1, A2, …, B1, …);
* every hole belongs to exactly one tile, the one whose core rectangle holds its centre
  (half-open intervals, the last row and column closed);
* each tile's plate covers its core plus a *halo* on every side it shares with a
  neighbour: the distance past which a hole's spray is below :data:`HALO_TAIL` of its peak
  (for the largest hole and spray time the job can use). The tile's wall opening is that
  sheet, so a hole near a seam sprays onto the neighbour's area exactly as in the global
  simulation, and the neighbour's own holes are not on this plate (its sheet is solid
  there).

The sprayed opacity of a layer is ``1 - prod_i (1 - N_i)`` over its holes; a product over
tiles of products over their holes is the same product, so the tiled mural at zero
registration error is the global simulation (:func:`simulate_tiles` checks it numerically
with the same tail cut).

Registration. Every tile carries its grid lines (the core's edges, in mural mm): the maker
snaps chalk lines (or sets a laser level) on the wall at the grid positions of
``mural_map.png``; each wall has a 90° sight notch in its outer rim where each of its four
grid lines crosses the rim, and each plate has the same notches in its border, identical on
every layer of a tile. Lay the notches on the lines, mark them with pencil through the
notches, and every layer of every tile lands in register.

Spray order across tiles is layer by layer (layer 1 on every tile, then layer 2, …): at a
seam two tiles' sprays overlap, and only layer-major order keeps the global *over* order
there.

Kernel-free: no build123d here; :mod:`stencil_cad.cad.registration` cuts the wall notches.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ..config.bed import Bed, resolve_bed
from ..config.process import Method
from ..errors import UserError

if TYPE_CHECKING:
    from ..config import JobConfig


class TaskMap(Protocol):
    """Runs a task function over items and yields the results in item order (the job's executor's ``map``)."""

    def __call__(
        self, fn: Callable[[Any], Any], items: Iterable[Any], desc: str, count: int | None = None
    ) -> Iterator[Any]:
        """Apply ``fn`` to every item; yield the results in item order."""
        ...


class Progress(Protocol):
    """A progress bar: told each time a unit of work is done."""

    def update(self, n: int = 1) -> object:
        """Count ``n`` more units done."""
        ...


#: A hole's spray is cut where its paint density falls below this fraction of the
#: peak; the halo is that distance for the largest hole.
HALO_TAIL = 1e-9

#: Depth in mm of the V sight notches: plates (inside the label gap) and walls (inside the rim).
PLATE_NOTCH_MM = 1.0
WALL_NOTCH_MM = 1.5


@dataclass(frozen=True)
class Tile:
    """One tile of a mural.

    Attributes:
        name: Row letter(s) and column number, e.g. ``"B3"`` (row A at the top).
        row: Row index from the top, 0-based.
        col: Column index from the left, 0-based.
        core: ``(x0, y0, x1, y1)`` mm in the mural frame: the holes this tile owns.
        sheet: ``(x0, y0, x1, y1)`` mm in the mural frame: the core grown by the halo on
            the sides shared with a neighbour; the holes' reach (stippling, refining, simulating).
        part: ``(x0, y0, x1, y1)`` mm in the mural frame: the plate's picture area and the
            wall's opening. A mural's tiles grow it by the halo on every side, so every tile's
            plate and wall have one size and one set of notches: one wall serves every tile
            (the halo past the mural's edge is solid plate). The sheet when None.
    """

    name: str
    row: int
    col: int
    core: tuple[float, float, float, float]
    sheet: tuple[float, float, float, float]
    part: tuple[float, float, float, float] | None = None

    @property
    def part_box(self) -> tuple[float, float, float, float]:
        """``(x0, y0, x1, y1)`` mm in the mural frame of the plate's picture area (see :attr:`part`)."""
        return self.part if self.part is not None else self.sheet

    @property
    def part_origin(self) -> tuple[float, float]:
        """Mural mm of the plate's picture area's bottom-left corner (the part frame's origin)."""
        return self.part_box[0], self.part_box[1]

    @property
    def part_size(self) -> tuple[float, float]:
        """``(w, h)`` in mm of the plate's picture area and the wall's opening."""
        x0, y0, x1, y1 = self.part_box
        return x1 - x0, y1 - y0

    def part_lines(self) -> tuple[list[float], list[float]]:
        """The core's edges in the part frame: ``([x_left, x_right], [y_bottom, y_top])`` mm."""
        ox, oy = self.part_origin
        return [self.core[0] - ox, self.core[2] - ox], [self.core[1] - oy, self.core[3] - oy]

    @property
    def origin(self) -> tuple[float, float]:
        """Mural mm of the sheet's bottom-left corner (the tile frame's origin)."""
        return self.sheet[0], self.sheet[1]

    @property
    def size(self) -> tuple[float, float]:
        """``(w, h)`` of the sheet in mm."""
        return self.sheet[2] - self.sheet[0], self.sheet[3] - self.sheet[1]

    def grid_lines(self) -> tuple[list[float], list[float]]:
        """The core's edges in the tile frame: ``([x_left, x_right], [y_bottom, y_top])`` mm."""
        ox, oy = self.origin
        return [self.core[0] - ox, self.core[2] - ox], [self.core[1] - oy, self.core[3] - oy]


@dataclass(frozen=True)
class TileGrid:
    """The tiles of a mural (or one tile for a picture that fits the bed).

    Attributes:
        width_mm: Mural width in mm.
        height_mm: Mural height in mm.
        cols: Tile columns.
        rows: Tile rows.
        halo_mm: How far a sheet reaches past its core into each neighbour, in mm.
        x_edges: ``cols + 1`` grid-line x positions in mm, left to right.
        y_edges: ``rows + 1`` grid-line y positions in mm, bottom to top.
        bed: The bed, or None.
        tiles: Row-major from the top-left (A1, A2, …, B1, …).
        post_pitch_mm: The spacing the posts under a mural's plates aim at, mm, as the job's plan chose
            it from the maker's config (:func:`stencil_cad.plan.tiles.plan`, with
            :func:`stencil_cad.mural.posts.post_pitch_mm`), or None for a grid cut alone (the posts
            then ask the config they are given).
    """

    width_mm: float
    height_mm: float
    cols: int
    rows: int
    halo_mm: float
    x_edges: tuple[float, ...]
    y_edges: tuple[float, ...]
    bed: Bed | None
    tiles: tuple[Tile, ...] = field(default_factory=tuple)
    post_pitch_mm: float | None = None

    @property
    def tiled(self) -> bool:
        """True when the picture is cut into more than one tile."""
        return len(self.tiles) > 1

    @classmethod
    def cut(
        cls, width_mm: float, height_mm: float, cols: int, rows: int, halo_mm: float, bed: Bed | None = None
    ) -> TileGrid:
        """A picture cut into ``cols × rows`` equal tiles, each sheet grown by ``halo_mm`` towards its neighbours."""
        xs = tuple(width_mm * k / cols for k in range(cols + 1))
        ys = tuple(height_mm * k / rows for k in range(rows + 1))
        tiles = []
        for r in range(rows):
            up = rows - 1 - r
            for c in range(cols):
                core = (xs[c], ys[up], xs[c + 1], ys[up + 1])
                sheet = (
                    core[0] - (halo_mm if c > 0 else 0.0),
                    core[1] - (halo_mm if up > 0 else 0.0),
                    core[2] + (halo_mm if c < cols - 1 else 0.0),
                    core[3] + (halo_mm if up < rows - 1 else 0.0),
                )
                part = (core[0] - halo_mm, core[1] - halo_mm, core[2] + halo_mm, core[3] + halo_mm)
                tiles.append(
                    Tile(f"{row_name(r)}{c + 1}", r, c, core, sheet, part if cols * rows > 1 else None)
                )
        halo = halo_mm if cols * rows > 1 else 0.0
        return cls(width_mm, height_mm, cols, rows, halo, xs, ys, bed, tuple(tiles))

    @classmethod
    def whole(cls, width_mm: float, height_mm: float, bed: Bed | None = None) -> TileGrid:
        """The 1 × 1 tiling of a picture that is one plate."""
        return cls.cut(width_mm, height_mm, 1, 1, 0.0, bed)

    def owner(self, xy_mm: np.ndarray) -> np.ndarray:
        """Index into :attr:`tiles` of the tile owning each point (its core holds the point)."""
        xy = np.asarray(xy_mm, dtype=np.float64).reshape(-1, 2)
        col = np.searchsorted(np.asarray(self.x_edges[1:-1]), xy[:, 0], side="right")
        row_up = np.searchsorted(np.asarray(self.y_edges[1:-1]), xy[:, 1], side="right")
        row = self.rows - 1 - row_up
        return row * self.cols + col


def row_name(row: int) -> str:
    """Spreadsheet-style row letters: 0 → A, 25 → Z, 26 → AA."""
    out = ""
    row += 1
    while row:
        row, rem = divmod(row - 1, 26)
        out = chr(ord("A") + rem) + out
    return out


def phases(grid: TileGrid) -> list[list[int]]:
    """Tile indices by phase: the four colours of a 2 × 2 colouring of the grid."""
    out: list[list[int]] = [[], [], [], []]
    for k, t in enumerate(grid.tiles):
        out[(t.row % 2) * 2 + (t.col % 2)].append(k)
    return [p for p in out if p]


def region_bounds(
    tile: Tile, grid: TileGrid, shape: tuple[int, int], g: float, halo: float
) -> tuple[tuple[int, int, int, int], tuple[float, float, float, float]]:
    """Pixel bounds ``(r0, r1, c0, c1)`` of a tile's region on the simulation raster, and its mm box."""
    h, w = shape
    x0, y0, x1, y1 = tile.core
    c0 = 0 if x0 <= 0 else max(0, int(math.floor((x0 - halo) / g)))
    c1 = w if x1 >= grid.width_mm else min(w, int(math.ceil((x1 + halo) / g)))
    r0 = 0 if y1 >= grid.height_mm else max(0, int(math.floor(h - (y1 + halo) / g)))
    r1 = h if y0 <= 0 else min(h, int(math.ceil(h - (y0 - halo) / g)))
    ox, oy = c0 * g, (h - r1) * g
    right = grid.width_mm if c1 == w else c1 * g
    top = grid.height_mm if r0 == 0 else (h - r0) * g
    return (r0, r1, c0, c1), (ox, oy, right, top)


def spray_halo_mm(cfg: JobConfig) -> float:
    """How far a sheet must reach past its tile so that no hole's spray is cut, in mm.

    The job's spray model says (:meth:`stencil_cad.simulate.models.Sprayer.halo_mm`): under the
    paper's, the largest hole's Gaussian at the largest spray time the job can use falls below
    :data:`HALO_TAIL` there.

    Args:
        cfg: The job config.
    """
    from ..simulate.models import sprayer

    return sprayer(cfg.spray).halo_mm(cfg, HALO_TAIL)


def part_sizes(sheet_w: float, sheet_h: float, cfg: JobConfig) -> dict[str, tuple[float, float]]:
    """Bounding-box sizes ``(w, h)`` in mm of a sheet's plate and wall (kernel-free).

    The wall's outside follows the pocket at the wall thickness, or a rounded rectangle
    when the key tabs crowd it (as :func:`stencil_cad.cad.wall.wall_rings` builds it).
    """
    from ..outline import offset_outline

    plate = offset_outline(sheet_w, sheet_h, cfg.plate.outline, 0.0)
    wall = wall_outline(sheet_w, sheet_h, cfg)

    def size(ring: np.ndarray) -> tuple[float, float]:
        w, h = ring.max(axis=0) - ring.min(axis=0)
        return float(w), float(h)

    return {"plate": size(plate), "wall": size(wall)}


def wall_outline(width_mm: float, height_mm: float, cfg: JobConfig) -> np.ndarray:
    """The outer ring of the wall around a plate of this size, ``(N, 2)`` mm.

    The plate's outline grown by the clearance and the wall's rim; where the key tabs crowd that
    offset, the plain outline grown by the tabs' depth too (as :func:`stencil_cad.cad.wall.wall_rings`
    builds it).
    """
    from ..outline import offset_outline

    oc, wc = cfg.plate.outline, cfg.wall
    reach = wc.clearance_mm + wc.wall_thickness_mm
    try:
        return offset_outline(width_mm, height_mm, oc, reach)
    except ValueError:
        plain = oc.model_copy(update={"keys": []})
        return offset_outline(width_mm, height_mm, plain, reach + max(k.depth_mm for k in oc.keys))


def plan_tiles(width_mm: float, height_mm: float, cfg: JobConfig) -> TileGrid:
    """Cut a picture into the fewest equal tiles whose plates and walls fit the bed.

    Args:
        width_mm: Picture width in mm.
        height_mm: Picture height in mm.
        cfg: The job config (``bed``, plate outline, wall, stipple and spray settings).

    Returns:
        The grid: one tile without halo when there is no bed or everything fits it.

    Raises:
        UserError: No tiling fits the bed (naming the bed and the smallest part).
    """
    bed = resolve_bed(cfg.bed)

    def grid(cols: int, rows: int, halo: float) -> TileGrid:
        return TileGrid.cut(width_mm, height_mm, cols, rows, halo, bed)

    if bed is None or bed.fits(*part_sizes(width_mm, height_mm, cfg)["wall"]):
        return grid(1, 1, 0.0)
    halo = spray_halo_mm(cfg)
    # The rim, margin and key add a constant to the sheet; measure it once, check exactly below.
    ref = part_sizes(100.0, 100.0, cfg)["wall"]
    extra = (ref[0] - 100.0, ref[1] - 100.0)

    def sheet(n: int, length: float) -> float:
        # A tiled mural's plates reach a halo past their core on every side (Tile.part).
        return length / n + 2.0 * halo

    best = None
    max_n = int(max(width_mm, height_mm) // 5.0) + 2
    for cols in range(1, max_n + 1):
        sw = sheet(cols, width_mm) + extra[0]
        if sw > max(bed.x_mm, bed.y_mm):
            continue
        for rows in range(1, max_n + 1):
            if best is not None and cols * rows >= best[0]:
                break
            sh = sheet(rows, height_mm) + extra[1]
            if bed.fits(sw, sh):
                g = grid(cols, rows, halo)
                if all(bed.fits(*part_sizes(*t.part_size, cfg)["wall"]) for t in g.tiles):
                    best = (cols * rows, g)
                break
    if best is None:
        small = part_sizes(10.0 + 2 * halo, 10.0 + 2 * halo, cfg)["wall"]
        raise UserError(
            f"bed {bed}: even a 10 mm tile needs a wall of {small[0]:.0f} × {small[1]:.0f} mm (plate margin, "
            f"wall rim and a {halo:.1f} mm spray halo on each side); use a larger bed or smaller "
            "plate.outline.margin_mm / wall.wall_thickness_mm"
        )
    return best[1]


def check_fits_bed(grid: TileGrid, cfg: JobConfig) -> list[dict[str, Any]]:
    """Check every tile's plate and wall against the bed, before any CAD.

    Returns:
        One row per tile: ``tile``, ``plate_mm``, ``wall_mm`` (bounding-box sizes).

    Raises:
        UserError: A part that does not fit, naming both sizes.
    """
    rows = []
    for t in grid.tiles:
        sizes = part_sizes(*t.part_size, cfg)
        for kind in ("plate", "wall"):
            w, h = sizes[kind]
            if grid.bed is not None and not grid.bed.fits(w, h):
                where = f"tile {t.name} " if grid.tiled else ""
                raise UserError(
                    f"{where}{kind} is {w:.1f} × {h:.1f} mm but the bed {grid.bed} is smaller; choose a larger "
                    "`bed`, or a smaller plate.outline.margin_mm / wall.wall_thickness_mm"
                )
        rows.append(
            {
                "tile": t.name,
                "plate_mm": [round(v, 2) for v in sizes["plate"]],
                "wall_mm": [round(v, 2) for v in sizes["wall"]],
            }
        )
    return rows


# --------------------------------------------------------------------------- plan and map


#: Rates for the cost estimate, CPU-seconds per unit, fitted on three jobs of this code (CPU-s of
#: the command and its workers, ``python -m benchmarks mural --case 1m2 --case mural600`` and
#: ``python -m benchmarks e2e``): the 1 m² FDM mural (30 tiles, 120 plates) took 353.8, the 600 x
#: 400 mm coffee mural (8 tiles on its local cluster) 145.6, the bundled example (one tile, eight
#: plates) 24.0. A plate is about 0.6 s to write and check (0.62 per plate in the 1 m² mural's
#: build stage), a notched wall about 1.5 s, and stippling, refining and simulating about 0.5 ms
#: per hole of the estimate (half the full-ink count), the decomposition about 2 s per megapixel
#: and layer. The three estimates: 436 s (+23 %), 83 s (-43 %: the cluster's own cost is not in
#: the rates) and 23 s (-5 %). (The earlier rates, 4 s a plate and 2 ms a hole, from a build that
#: also made and checked an OCCT solid of every plate, estimated 1,867, 349 and 96 s.)
_SECONDS_PER_PLATE = 0.6
_SECONDS_PER_WALL = 1.5
_SECONDS_PER_HOLE = 5e-4
_SECONDS_PER_MPX = 2.0


def plan_cost(grid: TileGrid, cfg: JobConfig, layers: int, work_px: int) -> dict[str, Any]:
    """What a size costs before any work: tiles, plates, walls, holes (at most) and a time estimate.

    The hole count is the upper bound at full ink (every layer packed at the densest tone),
    the time an estimate from measured per-hole and per-pixel rates.
    """
    d = cfg.stipple.densest_pitch_mm
    per_mm2 = 2.0 / (math.sqrt(3.0) * d * d)
    holes_max = int(per_mm2 * grid.width_mm * grid.height_mm * layers)
    # A laser-cut mural stands in a laser-cut frame (:mod:`.laser`): no printed wall.
    walls = 0 if cut_stand(cfg, grid) else len(wall_tiles(grid)) * len(cfg.standoff.walls_mm)
    plates = len(grid.tiles) * layers
    # Half the full-ink count: a photo's layers average about half their densest tone.
    est = (
        _SECONDS_PER_PLATE * plates
        + _SECONDS_PER_WALL * walls
        + _SECONDS_PER_HOLE * holes_max * 0.5
        + _SECONDS_PER_MPX * work_px / 1e6 * layers
    )
    return {
        "tiles": len(grid.tiles),
        "grid": f"{grid.rows} rows × {grid.cols} columns",
        "plates": plates,
        "walls": walls,
        "holes_at_most": holes_max,
        "estimated_seconds": round(est, 1),
    }


def order_of_work(grid: TileGrid, layers: int) -> list[str]:
    """The spray order: layer by layer, each over every tile in reading order."""
    return [f"layer {i + 1:02d}: " + " ".join(t.name for t in grid.tiles) for i in range(layers)]


def manifest_rows(grid: TileGrid) -> list[dict[str, Any]]:
    """Each tile's name, core and sheet in mm from the mural's bottom-left corner."""
    rnd = lambda v: [round(float(x), 3) for x in v]  # noqa: E731
    return [
        {
            "tile": t.name,
            "row": t.row + 1,
            "column": t.col + 1,
            "position_mm": rnd(t.core[:2]),
            "core_mm": rnd(t.core),
            "sheet_mm": rnd(t.sheet),
            "part_mm": rnd(t.part_box),
            "grid_lines_mm": {"x": rnd((t.core[0], t.core[2])), "y": rnd((t.core[1], t.core[3]))},
        }
        for t in grid.tiles
    ]


def cut_stand(cfg: JobConfig, grid: TileGrid) -> bool:
    """Whether the plates stand in a laser-cut frame on laser-cut spacers (:mod:`.laser`), not a printed wall.

    A soft mural of laser-cut plates: every part is cut, none printed.
    """
    return cfg.stipple.process.record.method is Method.cut and grid.tiled and cfg.mode.value == "soft"


def wall_key(t: Tile) -> tuple[float, ...]:
    """What a tile's wall is made from: its part's size and grid lines (mm, to a micrometre)."""
    xs, ys = t.part_lines()
    return tuple(round(float(v), 3) for v in (*t.part_size, *xs, *ys))


def wall_tiles(grid: TileGrid) -> dict[str, list[str]]:
    """Per wall (named by the first tile it serves), the tiles it serves, in reading order."""
    first: dict[tuple[float, ...], str] = {}
    out: dict[str, list[str]] = {}
    for t in grid.tiles:
        name = first.setdefault(wall_key(t), t.name)
        out.setdefault(name, []).append(t.name)
    return out


def has_seams(grid: TileGrid) -> bool:
    """Whether tiles meet at seams: a mural's map, registration cases, per-tile figures and seam checks exist only then."""
    return grid.tiled


def part_name(tile: Tile, grid: TileGrid) -> str | None:
    """The tile's name in its parts' file names (``tile_B3_layer_02``), or None for one tile (``layer_02``)."""
    return tile.name if grid.tiled else None


def sight_lines(tile: Tile) -> tuple[list[float], list[float]]:
    """The grid lines a tile's plate and wall carry as sight notches, in the part frame.

    The core's edges (:meth:`Tile.part_lines`) on a part that reaches past its core; none on a
    one-plate job's part, which ends at the picture.
    """
    return tile.part_lines() if tile.part is not None else ([], [])


def label_band(tile: Tile) -> bool:
    """Whether a tile's plate label may rise into the solid band below its lowest hole.

    A mural's part reaches the spray halo past its core, solid, so its label rises into that band;
    a one-plate job's label stays in the border.
    """
    return tile.part is not None


def chooses_design(grid: TileGrid) -> bool:
    """Whether the job chooses the plate design it leaves to itself (windows, the wall's stand-off) for its picture.

    A one-plate job does; a mural keeps the config's: trials over every tile would cost more than the job.
    """
    return not grid.tiled


def check_mode(grid: TileGrid, cfg: JobConfig) -> None:
    """Refuse a hard-mode job whose picture is cut into tiles: hard mode makes one plate per layer.

    Raises:
        UserError: A hard job whose plate does not fit the bed.
    """
    if cfg.mode.value == "hard" and grid.tiled:
        raise UserError(
            f"hard mode makes one plate per layer, and a {grid.width_mm:.0f} × {grid.height_mm:.0f} mm picture's "
            f"plate does not fit the bed {grid.bed}; use soft mode for a tiled mural, a larger bed or a smaller size"
        )


def light_plates_on(cfg: JobConfig, grid: TileGrid | bool) -> bool:
    """Whether each paint is sprayed through a light and a dark plate (``stipple.light_plates``).

    ``auto``: on for a one-plate soft job under the physical spray model (the dose is what the light
    plate lowers), off for a mural, where the second plate would double the printer-hours.

    Args:
        cfg: The job config.
        grid: The job's tiling, or whether the job is a mural (for a caller without the tiling).
    """
    from ..config.stipple import LightPlates

    choice = cfg.stipple.light_plates
    if cfg.mode.value == "hard" or choice == LightPlates.off:
        return False
    is_mural = grid if isinstance(grid, bool) else grid.tiled
    return choice == LightPlates.on or (not is_mural and cfg.spray.terms.light_plates)


def plate_layers(cfg: JobConfig, grid: TileGrid | bool) -> int:
    """Plates per tile the job plans for: the paint layers (two each with light plates), or one per colour but the primer (hard)."""
    if cfg.mode.value != "hard":
        return cfg.decompose.layers * (2 if light_plates_on(cfg, grid) else 1)
    # A palette given as a list fixes the colours; a can list's length is known once it is read.
    palette = cfg.hard.palette
    return (len(palette) if isinstance(palette, list) else cfg.hard.colours) - 1


def tile_label(tile: Tile | None, grid: TileGrid) -> str:
    """The tile part of a plate label, e.g. ``"B3 of 2x4"``, or empty for one tile."""
    if tile is None or not grid.tiled:
        return ""
    return f"{tile.name} of {grid.rows}x{grid.cols}"
