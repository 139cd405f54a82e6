"""What making a job costs, before any CAD: printer-hours, filament, laser sheets and cut time, paint.

Every part is known from the plan: one plate per tile and layer, one wall per tile and
stand-off, each with its outline (:func:`stencil_cad.outline.offset_outline`) and thickness.
The holes are the stippler's when it has run (still before any CAD), otherwise the plan's
expected count and open area (:data:`EXPECTED_FILL`, :data:`EXPECTED_OPEN`).

**FDM print time and filament** follow PrusaSlicer with the shipped profile
(``templates/prusa_fdm.ini``, timed for the printer the bed names where the project knows it,
:data:`PRINTER_FITS`, else for the profile's generic printer: 0.3 mm layers, 0.45 mm hole loops, 0.75 mm sheet lines and a 0.8 mm first layer, 100 %
infill for plates, walls sparse as :data:`stencil_cad.slicing.WALL_SETTINGS`). A plate's time is mostly its plastic,
``(outline area - open area) x thickness`` at the profile's effective volumetric rate, plus a
term per millimetre of hole edge per layer (each hole is a slow perimeter loop, a travel and a
retraction on every layer) and a fixed overhead (heating, homing, the first layer). A wall is
printed sparse: its shells (2 perimeters on every outline), its solid skins and 10 % infill give
the plastic; its time is that plastic at its own rate plus a fixed overhead. Filament is the
plastic times a fitted factor (the slicer's overlaps and the first layer's squish).

The constants were fitted (least squares, relative error) on PrusaSlicer 2.x's own estimates
(``; estimated printing time (normal mode)``, ``; filament used [mm]``) of parts made by
``stencil-cad run`` and sliced by ``stencil-cad slice``: the bundled example (four 173 mm plates of
0.9 mm, 991-2,493 holes, and its 10 mm wall) and the 600 x 400 mm mural of ``coffee.png`` with
3 layers on ``--bed prusa_mk4`` (8 tiles; 0.6 mm plates on posts and the one wall). ``python -m benchmarks printed``
prints the estimate beside the slicer's per part and in total; the fit and its residuals are
recorded beside the constants.

**Laser**: one sheet per plate; the cut is the outline plus every hole's circumference, timed by
:func:`cut_seconds` (a cutting speed and a pierce per cut, not measured here). A laser-cut mural's
wall and posts are cut too (:mod:`.laser`: the frame's rings and the spacers, their sheets, cuts
and time); a one-plate laser job's wall is printed.

**Paint**: each layer sprays through its open area (holes and windows); every pass is counted
as one coat over that area at ``paints.coverage_m2_per_can`` (1.5 m² per 400 ml can per coat,
the middle of the 1-2 m² a can's label gives). Overspray onto the plate around the holes is not
counted: buy at least one can per colour.

Kernel-free: plain arithmetic over the config and the tiling.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..config.printers import printer_for_bed
from ..config.process import FDM_SINGLE_LAYER_MM, FDM_THIN_LAYER_MM, FDM_THIN_PLATE_MM, Method
from ..figures.cost import CostFigures, PaintCost, PartCost
from ..geometry import polygon_area
from .laser import laser_stand, sheets_needed
from .tiling import TileGrid, wall_outline, wall_tiles

if TYPE_CHECKING:
    from ..config import JobConfig
    from ..model import DotSet

__all__ = [
    "EXPECTED_FILL",
    "EXPECTED_OPEN",
    "GENERIC_RATES",
    "LASER_PIERCE_S",
    "LASER_SPEED_MM_S",
    "PlateSpec",
    "Rates",
    "WallSpec",
    "cut_seconds",
    "hours_text",
    "making_cost",
    "post_count",
    "rates_for",
    "posts_print",
    "plate_print",
    "plate_specs",
    "wall_print",
    "wall_specs",
]

#: Cutting speed assumed for the cut-time estimate, mm/s: a typical vector speed for thin
#: stencil sheet (0.2-0.5 mm PET or card) on a 10-20 W diode or 40 W CO2 laser. Not measured
#: here: set your machine's own speed and power from a test cut.
LASER_SPEED_MM_S = 10.0
#: Time per pierce (each hole and the outline start a cut), s; same caveat.
LASER_PIERCE_S = 0.1

#: The shipped FDM profile's layer height and line widths, mm (``templates/prusa_fdm.ini``): hole
#: loops and shells at :data:`LINE_MM`, the solid sheet (solid and top infill) at
#: :data:`SHEET_LINE_MM`, the first layer at :data:`FIRST_LINE_MM`.
LAYER_MM = 0.3
LINE_MM = 0.45
SHEET_LINE_MM = 0.75
#: The first layer's lines, mm: the whole of a one-layer plate.
FIRST_LINE_MM = 0.8
#: The profile's ``max_volumetric_speed``, mm³/s: it caps the sheet's speed above the first layer.
MAX_FLOW_MM3_S = 11.0
#: Filament: 1.75 mm PLA at 1.24 g/cm³.
FILAMENT_MM2 = math.pi * (1.75 / 2.0) ** 2
PLA_G_PER_MM3 = 1.24e-3

#: Wall slicing (``stencil_cad.slicing.WALL_SETTINGS``): perimeters, skins and infill.
_WALL_PERIMETERS = 2
_WALL_BOTTOM_LAYERS = 2
_WALL_TOP_LAYERS = 3
_WALL_INFILL = 0.10

# Refitted for the profile's 0.75 mm sheet lines (least squares on the relative error, the fixed
# overhead held at 60 s) on PrusaSlicer 2.5's estimates of 12 plates: the bundled example's 4
# (0.9 mm: three layers, 991-2,493 holes) and 8 of the 600 x 400 mm coffee mural's (0.6 mm on
# posts: two layers, 1,043-6,047 holes; a plate of every layer on every tile column). Per plate
# -7.2 % .. +3.9 %, filament -2.7 % .. +2.4 %; the walls' slowdown from the example's wall and the
# mural's (1.21 and 1.22), each within 0.6 %. Each fit before this one's (the 0.45 mm sheet lines
# of before: 17 parts of the example and a 375 x 250 mm mural; a 300 x 200 mm mural's 0.6 mm
# plates for the two-layer edge term) measured the same way: a new profile or a new plate design
# wants the parts measured again (`python -m benchmarks printed --case cost`, ``--case mural600``).
# Checked on plates the fit never saw, the same mural's 0.4 mm plates (two 0.2 mm layers, 4 mm
# margin; 8 of 24 sliced): -11.1 % .. +1.3 %, filament -4.8 % .. +1.9 %, the wall -1.4 %; the dry
# run's 31.9 h and 471 g against the slicer's scaled to all 26 parts +0.7 % and -0.2 %.
#: Fixed seconds per part (the start G-code's moves and purge line), held, not fitted.
FIXED_S = 60.0
#: Plate: filament volume over the plate's plastic (overlapping lines; 1.02-1.10 measured).
PLATE_FILAMENT = 1.047
#: Wall: filament volume over the plastic its sparse slicing lays as modelled (0.960-0.963 measured).
WALL_FILAMENT = 0.961

#: The plan's expected holes per plate, as a share of the full-ink count (the hexagonal packing
#: at the largest hole): measured 0.13-0.33 on the example's plates (mean 0.26) and 0.14-0.76 on
#: the coffee mural's (mean 0.40).
EXPECTED_FILL = 0.35
#: The plan's expected open area per plate, as a share of the tile's picture area: measured
#: 0.04-0.10 on the example (mean 0.08), 0.04-0.26 on the coffee mural (mean 0.14).
EXPECTED_OPEN = 0.12


@dataclass(frozen=True)
class Rates:
    """The speeds a printer lays a part's lines at, and the factors fitted on the slicer's estimates.

    Attributes:
        first_mm_s: First layer, mm/s.
        solid_mm_s: Solid infill, mm/s (under the volumetric cap).
        top_mm_s: Top solid infill, mm/s (under the volumetric cap).
        hole_mm_s: A plate's hole loops (external perimeters), mm/s.
        wall_perimeter_mm_s: A wall's perimeters, mm/s.
        wall_infill_mm_s: A wall's sparse infill, mm/s.
        max_flow_mm3_s: The volumetric cap, mm³/s.
        plate_slowdown: Plate: the slicer's time over the plate's lines at these speeds (acceleration, turns).
        plate_s_per_edge_mm: Plate: seconds per mm of hole edge per layer beyond its loop (travel, retraction).
        plate_s_per_edge_mm_thin: The same for a plate of one or two layers (a mural's plate on posts,
            :mod:`.posts`): there the slicer joins a hole's loops with fewer travels and retractions.
        wall_slowdown: Wall: the slicer's time over the wall's lines at these speeds.
    """

    first_mm_s: float
    solid_mm_s: float
    top_mm_s: float
    hole_mm_s: float
    wall_perimeter_mm_s: float
    wall_infill_mm_s: float
    max_flow_mm3_s: float
    plate_slowdown: float
    plate_s_per_edge_mm: float
    plate_s_per_edge_mm_thin: float
    wall_slowdown: float

    def sheet_speed(self, mm_s: float, layer_mm: float = LAYER_MM) -> float:
        """A solid-sheet speed above the first layer, mm/s, as the volumetric cap lets it print."""
        return min(mm_s, self.max_flow_mm3_s / (layer_mm * SHEET_LINE_MM))


#: The shipped profile's generic printer: its speeds (first layer, solid infill, the top layer, the
#: hole loops as external perimeters, the wall's ``WALL_SETTINGS``) and the factors fitted as above.
GENERIC_RATES = Rates(30.0, 80.0, 60.0, 35.0, 50.0, 80.0, MAX_FLOW_MM3_S, 1.251, 0.0354, 0.0279, 1.215)

#: Per printer a bed preset names (:data:`stencil_cad.config.printers.PRINTERS`), the factors fitted on
#: PrusaSlicer's estimates of parts sliced for it (``plate_slowdown``, ``plate_s_per_edge_mm``,
#: ``plate_s_per_edge_mm_thin``, ``wall_slowdown``); its speeds are the printer's own.
#: The MK4's: least squares on the relative error over 8 two-layer 0.4 mm plates of the 600 x 400 mm
#: coffee mural (1,009-5,898 holes; -8.4 % .. +5.2 %) and its wall; the per-edge term of plates of
#: three layers or more is not fitted (the generic ratio to the two-layer term). Checked on plates the
#: fit never saw, one 0.3 mm layer with an embossed label: the same mural's 8 sliced plates -4.2 % ..
#: +5.2 %, its wall +3.1 %, the dry run +3.8 % (hours) and -0.9 % (filament) of the slicer scaled
#: to every part; the 375 x 250 mm mural's 8 plates -3.3 % .. +8.9 %, in total +1.7 %.
PRINTER_FITS: dict[str, tuple[float, float, float, float]] = {
    "prusa_mk4": (1.423, 0.076, 0.0599, 1.71),
}


def rates_for(bed: object) -> Rates:
    """The :class:`Rates` for a job's ``bed``: its printer's (a preset that names one), else the generic printer's."""
    printer = printer_for_bed(bed)
    fit = PRINTER_FITS.get(bed) if isinstance(bed, str) else None
    if printer is None or fit is None:
        return GENERIC_RATES
    v = printer.speed
    return Rates(
        v["first_layer"],
        v["solid_infill"],
        v["top_solid_infill"],
        v["external_perimeter"],
        v["perimeter"],
        v["infill"],
        printer.max_flow_mm3_s,
        *fit,
    )


def hours_text(hours: float) -> str:
    """``1 h 49 min`` (or ``41 min``) for a time in hours."""
    minutes = int(round(hours * 60))
    return f"{minutes // 60} h {minutes % 60:02d} min" if minutes >= 60 else f"{minutes} min"


def cut_seconds(cut_mm: float, pierces: int) -> float:
    """Estimated laser time in s: the cut length at :data:`LASER_SPEED_MM_S` plus a pierce per cut."""
    return cut_mm / LASER_SPEED_MM_S + LASER_PIERCE_S * pierces


@dataclass(frozen=True)
class PlateSpec:
    """One plate as the cost model sees it.

    Attributes:
        tile: The tile's name (empty for a one-plate job).
        layer: 1-based layer.
        area_mm2: Outline area, mm².
        perimeter_mm: Outline length, mm.
        thickness_mm: Plate thickness, mm.
        holes: Hole count.
        open_mm2: Open area (holes as drawn, and windows), mm².
        edge_mm: Length of every hole's edge, mm.
    """

    tile: str
    layer: int
    area_mm2: float
    perimeter_mm: float
    thickness_mm: float
    holes: int
    open_mm2: float
    edge_mm: float

    @property
    def layer_mm(self) -> float:
        """The layer height it prints at: 0.2 mm for the 0.4 mm plate, else the profile's (0.3 mm is one layer)."""
        thin = FDM_SINGLE_LAYER_MM + 1e-6 < self.thickness_mm <= FDM_THIN_PLATE_MM + 1e-6
        return FDM_THIN_LAYER_MM if thin else LAYER_MM

    @property
    def layers(self) -> int:
        """Printed layers at :attr:`layer_mm`."""
        return max(1, math.ceil(self.thickness_mm / self.layer_mm - 1e-6))

    @property
    def plastic_mm3(self) -> float:
        """The plate's solid volume, mm³."""
        return max(self.area_mm2 - self.open_mm2, 0.0) * self.thickness_mm

    def line_seconds(self, rates: Rates = GENERIC_RATES) -> float:
        """Seconds to lay the plate's lines at the printer's speeds (no acceleration, no travel).

        The first layer at the first-layer speed, the top one at the top-infill speed, the rest at
        the solid-infill speed; each hole's edge is a perimeter loop on every layer.
        """
        sheet = max(self.area_mm2 - self.open_mm2, 0.0)
        n = self.layers
        solid = rates.sheet_speed(rates.solid_mm_s, self.layer_mm)
        top = rates.sheet_speed(rates.top_mm_s, self.layer_mm)
        above = [solid] * max(n - 2, 0) + ([top] if n > 1 else [])
        lines = sheet / FIRST_LINE_MM / rates.first_mm_s + sheet / SHEET_LINE_MM * sum(1.0 / v for v in above)
        return lines + n * self.edge_mm / rates.hole_mm_s


@dataclass(frozen=True)
class WallSpec:
    """One wall as the cost model sees it: its three outlines and its heights.

    ``rings`` holds ``(area mm², length mm)`` of the outer outline, the opening and the pocket.
    """

    tile: str
    standoff_mm: float
    pocket_depth_mm: float
    rings: tuple[tuple[float, float], tuple[float, float], tuple[float, float]]

    @property
    def plastic_mm3(self) -> float:
        """The plastic the sparse slicing lays: shells, skins and infill (at most the solid)."""
        (a_out, l_out), (a_open, l_open), (a_pocket, l_pocket) = self.rings
        s, d = self.standoff_mm, self.pocket_depth_mm
        low, top = a_out - a_open, a_out - a_pocket
        solid = low * s + top * d
        shell = _WALL_PERIMETERS * LINE_MM * (l_out * (s + d) + l_open * s + l_pocket * d)
        skins = LAYER_MM * (_WALL_BOTTOM_LAYERS * low + _WALL_TOP_LAYERS * (top + (a_pocket - a_open)))
        infill = _WALL_INFILL * max(solid - shell - skins, 0.0)
        return min(shell + skins + infill, solid)

    def line_seconds(self, rates: Rates = GENERIC_RATES) -> float:
        """Seconds to lay the wall's lines at the printer's wall speeds (no acceleration, no travel)."""
        (a_out, l_out), (a_open, l_open), (a_pocket, l_pocket) = self.rings
        s, d = self.standoff_mm, self.pocket_depth_mm
        low, top = a_out - a_open, a_out - a_pocket
        shell = _WALL_PERIMETERS * (l_out * (s + d) + l_open * s + l_pocket * d) / LAYER_MM
        skins = _WALL_BOTTOM_LAYERS * low + _WALL_TOP_LAYERS * (top + (a_pocket - a_open))
        bulk = low * s + top * d - LAYER_MM * LINE_MM * shell - LAYER_MM * skins
        infill = _WALL_INFILL * max(bulk, 0.0) / (LAYER_MM * LINE_MM)
        solid = rates.sheet_speed(rates.solid_mm_s)
        return (
            shell / rates.wall_perimeter_mm_s
            + skins / (SHEET_LINE_MM * solid)
            + infill / rates.wall_infill_mm_s
            + low / FIRST_LINE_MM / rates.first_mm_s
            - low / SHEET_LINE_MM / solid
        )


def plate_print(spec: PlateSpec, rates: Rates = GENERIC_RATES) -> tuple[float, float]:
    """``(seconds, filament mm³)`` to print one plate with the shipped FDM profile, as modelled."""
    per_edge = rates.plate_s_per_edge_mm_thin if spec.layers <= 2 else rates.plate_s_per_edge_mm
    seconds = (
        FIXED_S + rates.plate_slowdown * spec.line_seconds(rates) + per_edge * spec.edge_mm * spec.layers
    )
    return seconds, PLATE_FILAMENT * spec.plastic_mm3


def wall_print(spec: WallSpec, rates: Rates = GENERIC_RATES) -> tuple[float, float]:
    """``(seconds, filament mm³)`` to print one wall with the shipped profile's wall settings, as modelled."""
    return FIXED_S + rates.wall_slowdown * spec.line_seconds(rates), WALL_FILAMENT * spec.plastic_mm3


def _ring(ring: np.ndarray) -> tuple[float, float]:
    closed = np.vstack([ring, ring[:1]])
    return float(abs(polygon_area(ring))), float(np.linalg.norm(np.diff(closed, axis=0), axis=1).sum())


def _holes(cfg: JobConfig, r: np.ndarray) -> tuple[float, float]:
    """``(open mm², edge mm)`` of holes of radii ``r`` as drawn (larger by the hole offset when compensated)."""
    st = cfg.stipple
    drawn = np.asarray(r, dtype=np.float64)
    if st.compensate and st.process.record.method is Method.extrude:
        drawn = drawn + max(st.sizes.hole_offset_mm, 0.0)
    return float(np.sum(np.pi * drawn**2)), float(np.sum(2.0 * np.pi * drawn))


def plate_specs(
    grid: TileGrid,
    cfg: JobConfig,
    layers: int,
    dotsets: Sequence[DotSet] | None = None,
) -> list[PlateSpec]:
    """Every plate of the job, tile by tile and layer by layer, before any CAD.

    Args:
        grid: The tiling (one tile for a one-plate job).
        cfg: The job config, its plate thickness filled in for the tiles.
        layers: Plates per tile.
        dotsets: Each layer's holes and windows in mural mm (the stippler's); None for the plan's
            expected holes.
    """
    from ..outline import offset_outline

    st = cfg.stipple
    d = st.densest_pitch_mm
    full_per_mm2 = 2.0 / (math.sqrt(3.0) * d * d)
    owners = [grid.owner(ds.xy_mm) for ds in dotsets] if dotsets is not None else None
    out = []
    for i, t in enumerate(grid.tiles):
        area, perimeter = _ring(offset_outline(*t.part_size, cfg.plate.outline, 0.0))
        core = (t.core[2] - t.core[0]) * (t.core[3] - t.core[1])
        name = t.name if grid.tiled else ""
        for k in range(layers):
            if dotsets is not None and owners is not None:
                r = np.asarray(dotsets[k].r_mm)[owners[k] == i]
                n = len(r)
                open_mm2, edge = _holes(cfg, r)
                for outer, _ in dotsets[k].windows:
                    ring = np.asarray(outer, dtype=np.float64)
                    if int(grid.owner(ring[:1])[0]) == i:
                        a, length = _ring(ring)
                        open_mm2, edge, n = open_mm2 + a, edge + length, n + 1
            else:
                n = int(round(EXPECTED_FILL * full_per_mm2 * core))
                open_mm2 = EXPECTED_OPEN * core
                edge = 2.0 * math.sqrt(math.pi * open_mm2 * n)
            out.append(
                PlateSpec(name, k + 1, area, perimeter, cfg.plate.planned_thickness_mm, n, open_mm2, edge)
            )
    return out


def wall_specs(grid: TileGrid, cfg: JobConfig) -> list[WallSpec]:
    """Every wall of the job: one per stand-off height and distinct tile (:func:`~stencil_cad.mural.wall_tiles`)."""
    from ..outline import offset_outline

    oc, wc = cfg.plate.outline, cfg.wall
    depth = float(wc.pocket_depth(cfg.plate.planned_thickness_mm))
    out = []
    walls = wall_tiles(grid)
    for t in grid.tiles:
        if t.name not in walls:
            continue  # one wall serves every tile of its size and notches
        w, h = t.part_size
        outer = wall_outline(w, h, cfg)
        o = wc.opening_margin_mm
        opening = np.array([[-o, -o], [w + o, -o], [w + o, h + o], [-o, h + o]])
        pocket = offset_outline(w, h, oc, wc.clearance_mm)
        rings = (_ring(outer), _ring(opening), _ring(pocket))
        for s in cfg.standoff.walls_mm:
            out.append(WallSpec(t.name if grid.tiled else "", float(s), depth, rings))
    return out


#: Seconds a layer of a few small posts takes at least (the slicer slows small layers down for
#: cooling): fitted on one 10 mm post sliced alone with the shipped profile (2 min 53 s; 5 s, the
#: profile's ``slowdown_below_layer_time``, gave 4 min).
MIN_LAYER_S = 3.2


def post_count(grid: TileGrid, cfg: JobConfig) -> int:
    """Posts the maker prints: the most any plate stands on (0 when the walls alone carry the plates)."""
    from .posts import post_plan, targets

    plan = post_plan(cfg, grid)
    if plan is None:
        return 0
    return max(len(targets(*t.size, plan.pitch_mm)) for t in grid.tiles)


def posts_print(cfg: JobConfig, grid: TileGrid, n: int, rates: Rates = GENERIC_RATES) -> tuple[float, float]:
    """``(seconds, filament mm³)`` to print ``n`` posts together, solid, as modelled.

    Their plastic at the plates' rate, but never under :data:`MIN_LAYER_S` a layer (the slicer slows
    small layers down for cooling).
    """
    from .posts import post_plan

    plan = post_plan(cfg, grid)
    if plan is None:
        return 0.0, 0.0
    t = cfg.plate.planned_thickness_mm
    one = math.pi * (plan.radius_mm**2 * plan.height_mm + plan.pin_radius_mm**2 * t)
    layers = math.ceil((plan.height_mm + t) / LAYER_MM - 1e-6)
    lines = n * one / (LAYER_MM * SHEET_LINE_MM * rates.sheet_speed(rates.solid_mm_s)) * rates.plate_slowdown
    return FIXED_S + max(lines, layers * MIN_LAYER_S), PLATE_FILAMENT * n * one


def _paint(
    cfg: JobConfig, plates: list[PlateSpec], layers: int, passes: Sequence[float]
) -> tuple[PaintCost, ...]:
    cover = float(cfg.paints.coverage_m2_per_can)
    out = []
    for k in range(layers):
        open_m2 = sum(p.open_mm2 for p in plates if p.layer == k + 1) / 1e6
        n = float(passes[k]) if k < len(passes) else float(cfg.spray.passes)
        out.append(PaintCost(k + 1, round(open_m2, 5), n, round(open_m2 * n / cover, 4)))
    return tuple(out)


def making_cost(
    grid: TileGrid,
    cfg: JobConfig,
    layers: int,
    dotsets: Sequence[DotSet] | None = None,
) -> CostFigures:
    """The job's making cost before any CAD, per part and in total.

    Args:
        grid: The tiling.
        cfg: The job config: the maker's while the tiling is planned (a plate thickness it leaves null
            is filled in here for the tiles, :func:`stencil_cad.config.job.filled`), or the plan's, kept:
            the plates the job builds, at the thickness their wall asks for.
        layers: Plates per tile.
        dotsets: Each layer's holes and windows (mural mm) and its passes (``spray_time``, the
            physical model's whole passes), or None for the plan's expected holes and
            ``spray.passes``.

    Returns:
        The figures for the manifest's ``cost`` section.
    """
    from ..config.job import filled
    from .posts import sag_side_mm

    cfg = filled(cfg, sag_side_mm(grid, cfg))[0]
    laser = cfg.stipple.process.record.method is Method.cut
    rates = rates_for(cfg.bed)
    plates = plate_specs(grid, cfg, layers, dotsets)
    own = cfg.spray.has_cans  # a layer's own amount counts passes
    passes = [float(cfg.spray.passes) if not own else d.amount(cfg.spray.passes) for d in dotsets or ()]
    parts = []
    cut_mm = cut_s = 0.0
    for p in plates:
        seconds, mm3 = plate_print(p, rates)
        cut = p.perimeter_mm + p.edge_mm
        if laser:
            seconds, mm3 = 0.0, 0.0
            cut_mm += cut
            cut_s += cut_seconds(cut, p.holes + 1)
        parts.append(_part("plate", p.tile, p.layer, p.holes, seconds, mm3, cut if laser else None, p.holes))
    stand = laser_stand(cfg, grid)
    sheets = len(plates) if laser else None
    for c in stand or ():
        # A laser-cut mural's frame rings and spacers (layer: how many to cut), instead of a printed wall.
        cut_mm += c.cut_mm * c.count
        cut_s += cut_seconds(c.cut_mm, c.pierces) * c.count
        parts.append(_part(c.name, "", c.count, 0, 0.0, 0.0, c.cut_mm * c.count, c.pierces * c.count - 1))
    if stand:
        sheets = (sheets or 0) + sheets_needed(
            stand, None if grid.bed is None else (grid.bed.x_mm, grid.bed.y_mm)
        )
    for w in wall_specs(grid, cfg) if stand is None else ():
        seconds, mm3 = wall_print(w, rates)
        parts.append(_part("wall", w.tile, 0, 0, seconds, mm3, None, 0))
    n_posts = post_count(grid, cfg) if stand is None else 0
    if n_posts:
        seconds, mm3 = posts_print(cfg, grid, n_posts, rates)
        parts.append(_part("posts", "", n_posts, 0, seconds, mm3, None, 0))
    return CostFigures(
        basis="plan" if dotsets is None else "holes",
        area_m2=round(grid.width_mm * grid.height_mm / 1e6, 6),
        printer_hours=round(sum(p.print_hours for p in parts), 3),
        filament_m=round(sum(p.filament_m for p in parts), 2),
        filament_g=round(sum(p.filament_g for p in parts), 1),
        parts=tuple(parts),
        sheets=sheets,
        cut_m=round(cut_mm / 1000.0, 2) if laser else None,
        cut_hours=round(cut_s / 3600.0, 3) if laser else None,
        paint=_paint(cfg, plates, layers, passes),
        coverage_m2_per_can=float(cfg.paints.coverage_m2_per_can),
    )


def _part(
    kind: str,
    tile: str,
    layer: int,
    holes: int,
    seconds: float,
    mm3: float,
    cut_mm: float | None,
    pierces: int,
) -> PartCost:
    return PartCost(
        kind=kind,
        tile=tile,
        layer=layer,
        holes=holes,
        print_hours=round(seconds / 3600.0, 4),
        filament_m=round(mm3 / FILAMENT_MM2 / 1000.0, 3),
        filament_g=round(mm3 * PLA_G_PER_MM3, 2),
        cut_m=None if cut_mm is None else round(cut_mm / 1000.0, 3),
        cut_minutes=None if cut_mm is None else round(cut_seconds(cut_mm, pierces + 1) / 60.0, 2),
    )
