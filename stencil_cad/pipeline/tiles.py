"""The tiles' glue: the plan, every tile's plates and walls as tasks, the tiled simulation.

Tiles are a layer over the global result: the stipple stage places the holes tile by tile
into one hole set per layer over the whole mural (:mod:`stencil_cad.mural.stipple`),
:func:`stencil_cad.mural.seams.split_dots` hands each hole to one tile, and each
tile's plates and wall are built exactly like a one-plate job in the tile's own frame.
Every tile is independent of the others once the dots are split, so each can become a
separate task.
"""

from __future__ import annotations

import contextlib
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import mural
from ..colour import to_hex
from ..errors import UserError
from ..figures import BuildFigures, MuralBed, MuralBuildFigures, MuralFigures, TileRow
from ..model import DotSet, Layers, Picture
from ..names import MURAL_MAP_PNG, part_file
from ..output import plain as _plain
from . import stand
from .names import tile_stem, tile_wall_stems

if TYPE_CHECKING:
    from ..cad import LabelInfo
    from ..config.bed import Bed
    from ..config.job import JobConfig
    from ..record import Run


def light_plates_on(cfg: JobConfig, tiled: bool) -> bool:
    """Whether each paint is sprayed through a light and a dark plate (``stipple.light_plates``).

    ``auto``: on for a one-plate soft job under the physical spray model (the dose is what the light
    plate lowers), off for a mural (``tiled``), where the second plate would double the printer-hours.
    """
    from ..config import Mode
    from ..config.stipple import LightPlates

    choice = cfg.stipple.light_plates
    if cfg.mode == Mode.hard or choice == LightPlates.off:
        return False
    return choice == LightPlates.on or (not tiled and cfg.spray.is_physical)


def plate_layers(cfg: JobConfig, tiled: bool) -> int:
    """Plates per tile the job plans for: the paint layers (two each with light plates), or one per colour but the primer (hard)."""
    from ..config import Mode

    if cfg.mode != Mode.hard:
        return cfg.decompose.layers * (2 if light_plates_on(cfg, tiled) else 1)
    # A palette given as a list fixes the colours; a can list's length is known once it is read.
    palette = cfg.hard.palette
    return (len(palette) if isinstance(palette, list) else cfg.hard.colours) - 1


def plan(
    cfg: JobConfig, width_mm: float, height_mm: float, work_px: int
) -> tuple[mural.TileGrid, MuralFigures]:
    """Tile the picture for the bed and check every part fits, before any work.

    Returns:
        ``(grid, figures)``: the tiles and the plan for the manifest (bed, halo, part sizes, cost).

    Raises:
        UserError: A part cannot fit the bed.
    """
    grid = mural.plan_tiles(width_mm, height_mm, cfg)
    layers = plate_layers(cfg, grid.tiled)
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
        tiled=grid.tiled,
        halo_mm=round(grid.halo_mm, 3),
        cost=cost,
        part_sizes=sizes,
    )
    return grid, fig


def stage_build_tiles(
    run: Run, layers: Layers, dotsets: list[DotSet], grid: mural.TileGrid
) -> list[list[DotSet]]:
    """Build, check and export every tile's plates (one per layer) and wall(s).

    The plates draw the holes compensated for the process (``stipple.compensate``, as a one-plate
    job's): each hole is grown over the whole mural before the holes are split among the tiles,
    so a hole at a seam keeps the web to its neighbours on the next tile's plate too.

    Returns:
        Per tile, per layer, the tile's holes as the process makes them, in the tile frame.
    """
    return finish_build_tiles(run, start_build_tiles(run, layers, dotsets, grid))


@dataclass
class BuildStarted:
    """A mural's plates and walls started as the job's tasks (:func:`start_build_tiles`), not yet collected."""

    dotsets: list[DotSet]
    drawn: list[DotSet]
    made: list[DotSet]
    holes_tile: list[list[DotSet]]
    posts: dict[Any, Any]
    grid: mural.TileGrid
    laser: Any
    tasks: Any
    #: Per tile, per layer, the tile's holes as the process makes them, in the tile frame.
    per_tile: list[list[DotSet]]


def start_build_tiles(run: Run, layers: Layers, dotsets: list[DotSet], grid: mural.TileGrid) -> BuildStarted:
    """Start every tile's plates and walls as the job's tasks (see :func:`stage_build_tiles`).

    The holes are checked and split among the tiles here, before any task starts; the parts
    are collected by :func:`finish_build_tiles`, so this process can simulate meanwhile.
    """
    cfg = run.cfg
    drawn, made = drawn_and_made(cfg, dotsets, grid)
    _check_unions(cfg, grid, {"asked": dotsets, "made": made, "drawn": drawn})
    holes_tile = _per_tile(drawn, grid)
    per_tile, posts = _with_posts(cfg, dotsets, holes_tile, grid)
    # A laser-cut mural stands in a frame and on spacers cut from sheet: no printed wall or post.
    laser = mural.laser_stand(cfg, grid)
    heights = cfg.standoff.walls_mm if laser is None else []
    tasks = _part_tasks(cfg, layers, grid, per_tile, heights)
    # Each plate and wall is a task (built, checked and exported where it runs); the files
    # come back as bytes and are staged in task order, so the output is the same whichever
    # process built what.
    started = run.tasks.start(build_part, tasks, "build tiles")
    return BuildStarted(dotsets, drawn, made, holes_tile, posts, grid, laser, started, _per_tile(made, grid))


def finish_build_tiles(run: Run, started: BuildStarted) -> list[list[DotSet]]:
    """Collect the parts :func:`start_build_tiles` started: stage their files, record the build.

    Returns:
        Per tile, per layer, the tile's holes as the process makes them, in the tile frame.
    """
    cfg = run.cfg
    dotsets, drawn, grid, posts, laser = (
        started.dotsets,
        started.drawn,
        started.grid,
        started.posts,
        started.laser,
    )
    plates: list[dict[str, Any]] = []
    walls: list[dict[str, Any]] = []
    served = mural.wall_tiles(grid)
    with run.stage("build"):
        for res in started.tasks.results():
            for name, data in res.files:
                run.out.write_bytes(name, data)
            (plates if res.kind == "plate" else walls).append(res.row)
        plan = mural.post_plan(cfg, grid)
        post_row = None
        if laser is not None:
            stand_rows = stand.write_laser_stand(run, laser, grid.bed)
        elif plan is not None and any(posts.values()):
            post_row = stand.write_post(run, plan, posts)
    for row in walls:
        row["tiles"] = served.get(str(row["tile"]), [row["tile"]])
    for row in plates:
        row["posts"] = len(posts.get((str(row["tile"]), int(row["layer"])), []))
        i = int(row["layer"]) - 1
        if len(dotsets[i]):
            row["drawn_minus_asked_mm"] = round(float(np.mean(drawn[i].r_mm - dotsets[i].r_mm)), 4)
    run.figures.build = BuildFigures.from_rows(plates, walls)
    built = MuralBuildFigures(
        tiles=tuple(TileRow.from_json(t) for t in mural.manifest_rows(grid)),
        holes_per_tile={
            t.name: [len(started.holes_tile[k][i]) for i in range(len(dotsets))]
            for k, t in enumerate(grid.tiles)
        },
        holes_total=int(sum(len(d) for d in drawn)),
        holes_global=int(sum(len(d) for d in dotsets)),
        union_check_rules="passed",
        compensated=bool(cfg.stipple.compensate),
        seam_density=mural.seam_density(dotsets, grid),
        order_of_work=mural.order_of_work(grid, len(dotsets)),
        posts=post_row,
        laser_stand=stand_rows if laser is not None else None,
    )
    run.figures.mural = replace(_planned(run), built=built)
    return started.per_tile


def _with_posts(
    cfg: JobConfig, dotsets: list[DotSet], per_tile: list[list[DotSet]], grid: mural.TileGrid
) -> tuple[list[list[DotSet]], dict[tuple[str, int], list[list[float]]]]:
    """Each plate's drawn holes in its part frame with a pin hole at each of its posts, and the posts' sites per (tile, layer).

    The sites are in mural mm.

    The holes move from the tile's sheet frame to its part frame (:attr:`stencil_cad.mural.Tile.part`).
    The sites come from the saved holes (:func:`stencil_cad.mural.post_sites`, every one clear);
    a pin hole is drawn larger by the process's offset like every hole (``stipple.compensate``).
    """
    plan = mural.post_plan(cfg, grid)
    st = cfg.stipple
    grow = max(st.resolved_hole_offset_mm, 0.0) if st.compensate else 0.0
    out, counts = [], {}
    for k, t in enumerate(grid.tiles):
        shift = np.array(t.origin) - np.array(t.part_origin)
        row = []
        for i, holes in enumerate(per_tile[k]):
            holes = mural.shifted(holes, *shift) if shift.any() else holes
            if holes.windows and shift.any():
                holes = replace(
                    holes, windows=tuple((np.asarray(o) + shift, inner) for o, inner in holes.windows)
                )
            if plan is not None:
                sites, _ = mural.post_sites(dotsets[i], t.sheet, plan)
                drawn_plan = replace(plan, pin_hole_mm=plan.pin_hole_mm + grow)
                holes = mural.with_pin_holes(holes, sites - np.array(t.part_origin), drawn_plan)
                counts[(t.name, i + 1)] = [[round(float(v), 4) for v in site] for site in sites]
            row.append(holes)
        out.append(row)
    return out, counts


def drawn_and_made(
    cfg: JobConfig, dotsets: list[DotSet], grid: mural.TileGrid
) -> tuple[list[DotSet], list[DotSet]]:
    """Every layer's holes over the whole mural as the plates draw them and as the process makes them.

    :func:`stencil_cad.stipple.made.drawn_dots` and :func:`~stencil_cad.stipple.made.made_dots`
    over the mural's picture area, the same as the simulation's (:func:`stage_simulate` sprays
    the made holes), so the tiled simulation equals the global one.
    """
    from ..stipple.made import drawn_dots, made_dots

    size = (grid.width_mm, grid.height_mm)
    return (
        [drawn_dots(d, cfg.stipple, size) for d in dotsets],
        [made_dots(d, cfg.stipple, size) for d in dotsets],
    )


def _per_tile(dotsets: list[DotSet], grid: mural.TileGrid) -> list[list[DotSet]]:
    """Per tile, per layer, the tile's holes in the tile frame (each hole to the tile owning its centre)."""
    split = [mural.split_dots(ds, grid) for ds in dotsets]  # [layer][tile]
    return [[split[i][k] for i in range(len(dotsets))] for k in range(len(grid.tiles))]


def _check_unions(cfg: JobConfig, grid: mural.TileGrid, sets: dict[str, list[DotSet]]) -> None:
    """The union of the tiles' holes is the global set (same count) and keeps the rules across every seam.

    ``sets`` holds the holes ``asked`` (the design rules), ``made`` by the process (the web never
    under its minimum, the hole never under the 0.5 mm floor by more than the process's offset: a
    hole at the picture's margin is not grown, so it is made a little under the stippler's radius,
    as on a one-plate job) and
    ``drawn`` on the plates (the web less twice the process's offset, which the process gives back).
    """
    from dataclasses import replace

    from ..stipple import rules as dots

    design = cfg.stipple.design_rules(grid.width_mm, grid.height_mm)
    made_less = max(cfg.stipple.resolved_hole_offset_mm, 0.0)
    offset = made_less if cfg.stipple.compensate else 0.0
    floor = design.with_any_floor()
    rules = {"asked": design, "made": floor, "drawn": replace(floor, web_mm=design.web_mm - 2.0 * offset)}
    # A hole the margin keeps from growing (or every hole, uncompensated) is made its radius less
    # the offset: at the 0.5 mm floor of every preset, 0.485 mm under FDM. The made webs lose
    # nothing by the tolerance: each is the drawn web (checked to the 0.001 mm) plus twice the offset.
    tol = {"made": dots.CHECK_TOL_MM + made_less}
    for kind, layer_sets in sets.items():
        for i, ds in enumerate(layer_sets):
            u = mural.to_mural(mural.split_dots(ds, grid), grid)
            if len(u) != len(ds):
                raise RuntimeError(f"layer {i + 1}: tiles hold {len(u)} {kind} holes, the mural {len(ds)}")
            try:
                dots.check_rules(u.xy_mm, u.r_mm, rules[kind], tol.get(kind, dots.CHECK_TOL_MM))
            except ValueError as exc:
                raise UserError(
                    f"layer {i + 1} ({kind} holes, all tiles in mural coordinates): {exc}"
                ) from None


@dataclass(frozen=True)
class PartTask:
    """One plate or wall of a tile: everything a worker needs to build, check and export it.

    Attributes:
        kind: ``"plate"`` or ``"wall"``.
        stem: File stem, e.g. ``tile_B3_layer_02``.
        cfg: The job config.
        size_mm: ``(w, h)`` of the tile's sheet in mm.
        lines: The tile's grid lines (sight notches).
        bed: The bed every part must fit, or None.
        holes: A plate's holes in the tile frame (None for a wall).
        label: A plate's label (None for a wall).
        ring: A plate's notched outline ring (None for a wall).
        notches: A plate's notch count.
        standoff_mm: A wall's stand-off height (None for a plate).
        tile: The tile's name.
    """

    kind: str
    stem: str
    cfg: JobConfig
    size_mm: tuple[float, float]
    lines: tuple[list[float], list[float]]
    bed: Bed | None
    tile: str
    holes: DotSet | None = None
    label: LabelInfo | None = None
    ring: np.ndarray | None = None
    notches: int = 0
    standoff_mm: float | None = None


@dataclass(frozen=True)
class PartResult:
    """What a :class:`PartTask` made: its files (name, bytes) in writing order and its manifest row."""

    kind: str
    files: tuple[Any, ...]
    row: dict[str, Any]


def _part_tasks(
    cfg: JobConfig, layers: Layers, grid: mural.TileGrid, per_tile: list[list[DotSet]], heights: list[float]
) -> Iterator[PartTask]:
    """Every tile's plates (one per layer) and walls, tile by tile, made one at a time."""
    from .. import cad, outline

    n = len(per_tile[0]) if per_tile else 0
    made_walls: set[Any] = set()
    for k, t in enumerate(grid.tiles):
        w, h = t.part_size
        lines = t.part_lines()
        ring, notches = mural.notched_ring(
            outline.plate_outline(w, h, cfg.plate.outline), lines, mural.PLATE_NOTCH_MM
        )
        common: dict[str, Any] = {
            "cfg": cfg,
            "size_mm": (w, h),
            "lines": lines,
            "bed": grid.bed,
            "tile": t.name,
        }
        for i, holes in enumerate(per_tile[k]):
            label = cad.LabelInfo(
                layer=i + 1,
                layers=n,
                colour=to_hex(layers.colours[i]),
                job=cfg.name,
                tile=mural.tile_label(t, grid),
            )
            yield PartTask(
                kind="plate",
                stem=tile_stem(t, i),
                holes=holes,
                label=label,
                ring=ring,
                notches=notches,
                **common,
            )
        # One wall serves every tile whose plates have its size and notches (every tile of a mural).
        key = mural.wall_key(t)
        if key in made_walls:
            continue
        made_walls.add(key)
        for standoff, stem in zip(heights, tile_wall_stems(t, heights), strict=True):
            yield PartTask(kind="wall", stem=stem, standoff_mm=standoff, **common)


def build_part(task: PartTask) -> PartResult:
    """Build, check and export one plate or wall (a task: pure, the same task gives the same bytes).

    Raises:
        UserError: The holes break the rules, the label cannot fit, or the part does not fit the bed.
    """
    return _build_plate(task) if task.kind == "plate" else _build_wall(task)


class _Files:
    """Collects the files a task writes as (name, bytes), through the output folder's ``open_path`` interface.

    Each file is written into a private temporary folder where the task runs (a worker may be
    another machine) and read back, so the files travel with the task's result.
    """

    def __init__(self) -> None:
        self.files: list[tuple[str, bytes]] = []

    @contextlib.contextmanager
    def open_path(self, name: str) -> Iterator[Path]:
        """Yield a temporary path to write ``name`` to; its bytes are kept when the block succeeds."""
        with tempfile.TemporaryDirectory(prefix="stencil-part-") as tmp:
            path = Path(tmp) / name
            yield path
            self.files.append((name, path.read_bytes()))


def _solid_below(holes: Any, height_mm: float) -> float:
    """How far above a tile's part bottom its plate is solid all along, mm: up to its lowest hole or window.

    The part reaches the spray halo past the tile, solid, so a tile's label rises into that band (its
    border is only the ledge, :data:`stencil_cad.config.outline.TILE_MARGIN_MM`). 0 for a hard
    stencil's cut-outs (the label stays in the border); the part's height for a plate with no hole.
    """
    if not isinstance(holes, DotSet):
        return 0.0
    lows = [float(np.min(np.asarray(outer, dtype=np.float64)[:, 1])) for outer, _ in holes.windows]
    if len(holes):
        lows.append(float(np.min(np.asarray(holes.xy_mm)[:, 1] - np.asarray(holes.r_mm))))
    return max(min(lows), 0.0) if lows else float(height_mm)


def _build_plate(task: PartTask) -> PartResult:
    from .. import cad
    from ..exchange import dxf
    from ..exchange.writers import TILE_ORDER, part_figures, wanted, write_part

    cfg, stem, holes, ring = task.cfg, task.stem, task.holes, task.ring
    if holes is None or ring is None or task.label is None:
        raise ValueError(f"{stem}: a plate task needs its holes, outline and label")
    exp = cfg.export
    w, h = task.size_mm
    try:
        model = cad.build_plate(
            holes, w, h, cfg.plate, task.label, outline_ring=ring, label_solid_mm=_solid_below(holes, h)
        )
    except ValueError as exc:
        raise UserError(f"{stem}: {exc}") from exc
    check = cad.check_plate(model, holes, tolerance_mm=exp.stl_tolerance_mm)
    (x0, y0, _), (x1, y1, _) = check["bbox"]
    if task.bed is not None and not task.bed.fits(x1 - x0, y1 - y0):
        raise UserError(f"{stem}: plate is {x1 - x0:.1f} × {y1 - y0:.1f} mm, larger than the bed {task.bed}")
    files = _Files()
    row = {
        "tile": task.tile,
        "layer": task.label.layer,
        "file": stem,
        "notches": task.notches,
        "bbox_mm": [round(x1 - x0, 3), round(y1 - y0, 3)],
        # A hybrid plate's windows: through holes beside the round ones.
        "windows": len(getattr(holes, "windows", ())),
    }
    drawing = dxf.stencil_for(holes, ring, stem.upper(), *model.cut_label())
    row["cut_length_mm"] = round(dxf.cut_length_mm(holes, ring), 1)
    part = cad.plate_part(model, drawing, title=f"{cfg.name} {stem}")
    written = write_part(files, stem, part, wanted(exp, TILE_ORDER), exp)
    row.update(part_figures(written))
    info = written.get(".dxf")
    if info is not None:
        bx = info.bbox_mm
        sheet = (bx[2] - bx[0], bx[3] - bx[1])
        row["dxf_sheet_mm"] = [round(v, 3) for v in sheet]
        if task.bed is not None and not task.bed.fits(*sheet):
            raise UserError(
                f"{stem}.dxf: sheet is {sheet[0]:.1f} × {sheet[1]:.1f} mm, larger than the bed {task.bed}"
            )
    return PartResult("plate", tuple(files.files), {**row, **_plain(check)})


def _build_wall(task: PartTask) -> PartResult:
    from ..cad import registration
    from ..cad import wall as wall_mod

    cfg, stem = task.cfg, task.stem
    w, h = task.size_mm
    if task.standoff_mm is None:
        raise ValueError(f"{stem}: a wall task needs its stand-off height")
    wm = wall_mod.build_wall(w, h, cfg.plate.outline, cfg.wall, cfg.plate.thickness_mm, task.standoff_mm)
    wm, wall_notches = registration.notch_wall(wm, task.lines, w, cfg.wall.finger_slot_mm)
    wcheck = wall_mod.check_wall(wm)
    bb = wcheck["bbox"]
    if task.bed is not None and not task.bed.fits(bb[3] - bb[0], bb[4] - bb[1]):
        raise UserError(
            f"{stem}: wall is {bb[3] - bb[0]:.1f} × {bb[4] - bb[1]:.1f} mm, larger than the bed {task.bed}"
        )
    files = _Files()
    with files.open_path(part_file(stem, ".step")) as p:
        wall_mod.wall_step(wm, p)
    with files.open_path(part_file(stem, ".stl")) as p:
        wall_mod.wall_stl(wm, p, cfg.export.stl_tolerance_mm)
    row = {
        "tile": task.tile,
        "file": part_file(stem, ".step"),
        "standoff_mm": task.standoff_mm,
        "notches": wall_notches,
        **wcheck,
    }
    return PartResult("wall", tuple(files.files), row)


def write_map(run: Run, grid: mural.TileGrid, layers: Layers, picture: Picture | None) -> None:
    """Write ``mural_map.png``: the grid over the picture, names, positions, order of work."""
    preview = picture.rgb if picture is not None else layers.composite()
    run.out.write_png(MURAL_MAP_PNG, mural.mural_map(grid, layers.count, preview))


def _planned(run: Run) -> MuralFigures:
    """The mural's plan as the run recorded it (every tiled job is planned before its stages)."""
    fig = run.figures.mural
    if fig is None:
        raise AssertionError("a tiled stage ran before the mural was planned")
    return fig


def plan_line(plan: MuralFigures) -> str:
    """One line, printed before the work starts: what this size costs."""
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
    if c.get("sheets") is not None:
        line += f", {c['sheets']} laser sheet(s), {c['cut_m']:.1f} m of cut in about {c['cut_hours']:.1f} h"
    return line
