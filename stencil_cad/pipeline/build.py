"""The build stage's glue: every tile's plates and walls as tasks, built, checked and exported.

One path for every job: a one-plate job is the 1 × 1 tiling (:meth:`stencil_cad.mural.TileGrid.whole`),
a mural is N × M, and the tiling decides what differs (names, sight notches, posts, the stand).
Tiles are a layer over the global result: the stipple stage places the holes into one hole set
per layer over the whole picture, :func:`stencil_cad.mural.per_tile` hands each hole to one tile,
and each tile's plates and wall are built in the tile's own frame. Every tile is independent of
the others once the holes are split, so each part is a separate task.
"""

from __future__ import annotations

import gc
import logging
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from .. import mural
from ..colour import to_hex
from ..errors import UserError
from ..figures import BuildFigures
from ..model import CutLayer, DotSet, Holes, Layers, Picture
from ..names import part_file
from ..output import plain as _plain
from ..plan import tiles
from ..plan.names import part_stem, part_wall_stems
from ..plan.plan import Plan, unplanned
from ..plan.results import Built, PartResult, Stand
from ..record import Run

if TYPE_CHECKING:
    from ..cad import LabelInfo
    from ..config.bed import Bed
    from ..config.job import JobConfig
    from ..config.rules import DesignRules

log = logging.getLogger(__name__)


@dataclass
class BuildStarted:
    """A job's plates and walls started as its tasks (:func:`start_build`), not yet collected."""

    asked: list[Holes]
    drawn: list[Holes]
    made: list[Holes]
    holes_tile: list[list[Holes]]
    posts: dict[Any, Any]
    grid: mural.TileGrid
    laser: Any
    tasks: Any
    layers: Layers
    picture: Picture | None
    #: Per tile, per layer, the tile's holes as the process makes them, in the tile frame.
    per_tile: list[list[Holes]]
    #: The job's planned config the parts are built under.
    cfg: JobConfig


def start_build(
    run: Run, plan: Plan, layers: Layers, holes: Sequence[Holes], picture: Picture | None = None
) -> BuildStarted:
    """Start every tile's plates and walls of ``plan`` (its config and tiling) as the job's tasks; :func:`collect_parts` collects them.

    The plates draw the holes compensated for the process (``stipple.compensate``): each hole is
    grown over the whole picture before the holes are split among the tiles, so a hole at a seam
    keeps the web to its neighbours on the next tile's plate too. The holes are checked across
    the seams and split here, before any task starts, so this process can simulate meanwhile.
    """
    cfg, grid = plan.cfg, plan.grid
    asked = list(holes)
    drawn, made = drawn_and_made(cfg, asked, grid)
    mural.check_unions(cfg, grid, {"asked": asked, "made": made, "drawn": drawn})  # type: ignore[dict-item]
    holes_tile = mural.per_tile(drawn, grid)
    per_tile, posts = _with_posts(cfg, asked, holes_tile, grid)
    # A laser-cut mural stands in a frame and on spacers cut from sheet: no printed wall or post.
    laser = mural.laser_stand(cfg, grid)
    heights = cfg.standoff.walls_mm if laser is None else []
    tasks = _part_tasks(cfg, layers, grid, per_tile, heights)
    # Each plate and wall is a task (built, checked and exported where it runs); the files
    # come back as bytes and are staged in task order, so the output is the same whichever
    # process built what.
    started = run.tasks.start(build_part, tasks, "build")
    per_made = mural.per_tile(made, grid)
    return BuildStarted(
        asked, drawn, made, holes_tile, posts, grid, laser, started, layers, picture, per_made, cfg
    )


def collect_parts(started: BuildStarted) -> Iterator[PartResult]:
    """The parts :func:`start_build` started, each as its task finishes, in task order (the recorder stages their files)."""
    yield from started.tasks.results()


def stage_build(
    started: BuildStarted,
    plates: list[dict[str, Any]],
    walls: list[dict[str, Any]],
    stand: Stand,
) -> Built:
    """Figure ``build`` from the parts' rows (collected), and a mural's tiles with its ``stand``'s rows and map.

    The rows are completed here (the tiles a wall serves, a plate's posts, how much larger the
    holes are drawn than asked); the recorder records the figures and writes ``mural_map.png``.
    """
    grid = started.grid
    served = mural.wall_tiles(grid)
    for row in walls:
        if "tile" in row:
            row["tiles"] = served.get(str(row["tile"]), [row["tile"]])
    for row in plates:
        if "tile" in row:
            row["posts"] = len(started.posts.get((str(row["tile"]), int(row["layer"])), []))
        i = int(row["layer"]) - 1
        asked, drawn = started.asked[i], started.drawn[i]
        if isinstance(asked, DotSet) and len(asked):
            row["drawn_minus_asked_mm"] = round(float(np.mean(drawn.r_mm - asked.r_mm)), 4)
    build = BuildFigures.from_rows(plates, walls)
    if not mural.has_seams(grid):
        return Built(build)
    # A mural's holes are round (hard mode makes one plate per layer).
    built = tiles.tile_figures(
        started.cfg,
        cast("list[DotSet]", started.asked),
        cast("list[DotSet]", started.drawn),
        cast("list[list[DotSet]]", started.holes_tile),
        grid,
        stand.post_row,
        stand.stand_rows,
    )
    return Built(build, built, tiles.map_picture(grid, started.layers, started.picture))


def _with_posts(
    cfg: JobConfig, asked: list[Holes], per_tile: list[list[Holes]], grid: mural.TileGrid
) -> tuple[list[list[Holes]], dict[tuple[str, int], list[list[float]]]]:
    """Each plate's drawn holes in its part frame with a pin hole at each of its posts, and the posts' sites per (tile, layer).

    The sites are in mural mm.

    The holes move from the tile's sheet frame to its part frame (:attr:`stencil_cad.mural.Tile.part`).
    The sites come from the saved holes (:func:`stencil_cad.mural.post_sites`, every one clear);
    a pin hole is drawn larger by the process's offset like every hole (``stipple.compensate``).
    """
    plan = mural.post_plan(cfg, grid)
    st = cfg.stipple
    grow = max(st.sizes.hole_offset_mm, 0.0) if st.compensate else 0.0
    out, counts = [], {}
    for k, t in enumerate(grid.tiles):
        shift = np.array(t.origin) - np.array(t.part_origin)
        row = []
        for i, holes in enumerate(per_tile[k]):
            if shift.any() and isinstance(holes, DotSet):
                holes = mural.shifted(holes, *shift)
                if holes.windows:
                    holes = replace(
                        holes, windows=tuple((np.asarray(o) + shift, inner) for o, inner in holes.windows)
                    )
            if plan is not None and isinstance(holes, DotSet):
                sites, _ = mural.post_sites(asked[i], t.sheet, plan)  # type: ignore[arg-type]
                drawn_plan = replace(plan, pin_hole_mm=plan.pin_hole_mm + grow)
                holes = mural.with_pin_holes(holes, sites - np.array(t.part_origin), drawn_plan)
                counts[(t.name, i + 1)] = [[round(float(v), 4) for v in site] for site in sites]
            row.append(holes)
        out.append(row)
    return out, counts


def drawn_and_made(
    cfg: JobConfig, holes: list[Holes], grid: mural.TileGrid
) -> tuple[list[Holes], list[Holes]]:
    """Every layer's holes over the whole picture as the plates draw them and as the process makes them.

    :func:`stencil_cad.stipple.made.drawn_dots` and :func:`~stencil_cad.stipple.made.made_dots`
    over the picture area, the same as the simulation's (:func:`stage_simulate` sprays the made
    holes), so a mural's tiled simulation equals the global one. A hard layer's cut-outs are
    drawn and made as they are.
    """
    from ..stipple.made import drawn_dots, made_dots

    size = (grid.width_mm, grid.height_mm)
    return (
        [drawn_dots(d, cfg.stipple, size) if isinstance(d, DotSet) else d for d in holes],
        [made_dots(d, cfg.stipple, size) if isinstance(d, DotSet) else d for d in holes],
    )


@dataclass(frozen=True)
class PartTask:
    """One plate or wall of a tile: everything a worker needs to build, check and export it.

    Attributes:
        kind: ``"plate"`` or ``"wall"``.
        stem: File stem, e.g. ``layer_02`` or ``tile_B3_layer_02``.
        cfg: The job config.
        size_mm: ``(w, h)`` of the part's picture area in mm.
        lines: The tile's sight lines (none for a one-plate job's parts).
        bed: The bed every part must fit, or None.
        tile: The tile's name in the files and figures, or None for one tile.
        holes: A plate's holes in the part frame (None for a wall).
        label: A plate's label (None for a wall).
        ring: A plate's outline ring, notched on the sight lines (None for a wall).
        notches: A plate's notch count.
        standoff_mm: A wall's stand-off height (None for a plate).
        title: A plate's title in its SVG.
        order: A plate's file extensions in writing order (those the ``export`` config asks for).
        label_band: The plate's label may rise into the solid band below its lowest hole.
        rules: The design rules a plate's holes are checked against again, or None: the plate's own floor.
        cut_name: The name cut into a plate's drawing, or None: its stem in capitals.
        what: The part's name in an error, or None: its stem.
    """

    kind: str
    stem: str
    cfg: JobConfig
    size_mm: tuple[float, float]
    lines: tuple[list[float], list[float]]
    bed: Bed | None
    tile: str | None
    holes: Holes | None = None
    label: LabelInfo | None = None
    ring: np.ndarray | None = None
    notches: int = 0
    standoff_mm: float | None = None
    title: str = ""
    order: tuple[str, ...] = ()
    label_band: bool = False
    rules: DesignRules | None = None
    cut_name: str | None = None
    what: str | None = None


def _part_tasks(
    cfg: JobConfig, layers: Layers, grid: mural.TileGrid, per_tile: list[list[Holes]], heights: list[float]
) -> Iterator[PartTask]:
    """Every tile's plates (one per layer) and walls, tile by tile, made one at a time."""
    from .. import cad, outline
    from ..exchange.writers import ONE_PLATE_ORDER, TILE_ORDER, wanted

    n = len(per_tile[0]) if per_tile else 0
    made_walls: set[Any] = set()
    for k, t in enumerate(grid.tiles):
        w, h = t.part_size
        lines = mural.sight_lines(t)
        ring, notches = mural.notched_ring(
            outline.plate_outline(w, h, cfg.plate.outline), lines, mural.PLATE_NOTCH_MM
        )
        name = mural.part_name(t, grid)
        common: dict[str, Any] = {
            "cfg": cfg,
            "size_mm": (w, h),
            "lines": lines,
            "bed": grid.bed,
            "tile": name,
        }
        # A tile's plate is one of the mural's; a one-plate job's says which of the layers it is.
        order = wanted(cfg.export, ONE_PLATE_ORDER if name is None else TILE_ORDER)
        for i, holes in enumerate(per_tile[k]):
            label = cad.LabelInfo(
                layer=i + 1,
                layers=n,
                colour=to_hex(layers.colours[i]),
                job=cfg.name,
                tile=mural.tile_label(t, grid),
            )
            stem = part_stem(name, i)
            yield PartTask(
                kind="plate",
                stem=stem,
                holes=holes,
                label=label,
                ring=ring,
                notches=notches,
                title=f"{cfg.name} {stem}" + (f" of {n}" if name is None else ""),
                order=tuple(order),
                label_band=mural.label_band(t),
                **common,
            )
        # One wall serves every tile whose plates have its size and notches (every tile of a mural).
        key = mural.wall_key(t)
        if key in made_walls:
            continue
        made_walls.add(key)
        for standoff, stem in zip(heights, part_wall_stems(name, heights), strict=True):
            yield PartTask(kind="wall", stem=stem, standoff_mm=standoff, **common)


def build_part(task: PartTask) -> PartResult:
    """Build, check and export one plate or wall (a task: pure, the same task gives the same bytes).

    Raises:
        UserError: The holes break the rules, the label cannot fit, or the part does not fit the bed.
    """
    with _young_objects_collected():
        return _build_plate(task) if task.kind == "plate" else _build_wall(task)


@contextmanager
def _young_objects_collected() -> Iterator[None]:
    """Let Python's cyclic garbage collector look only at the objects made inside the block.

    A full collection walks every object the process holds, and a job's process holds the earlier
    stages' objects when it builds: in ``stencil-cad run`` on the example, the build stage's three
    full collections took 0.69 of its 10.7 CPU-s, and 0.17 with each part built in this block
    (``gc.callbacks`` timing each collection with ``time.process_time``). ``gc.freeze`` sets the
    objects there are aside and ``gc.unfreeze`` gives them back to the collector, so nothing is
    kept longer than the block; blocks on other threads only lose the gain, as the collector is
    the process's.
    """
    gc.freeze()
    try:
        yield
    finally:
        gc.unfreeze()


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
    from ..exchange.writers import part_bytes, part_figures

    cfg, stem, holes, ring, label = task.cfg, task.stem, task.holes, task.ring, task.label
    if holes is None or ring is None or label is None:
        raise ValueError(f"{stem}: a plate task needs its holes, outline and label")
    exp = cfg.export
    w, h = task.size_mm
    solid = _solid_below(holes, h) if task.label_band else 0.0
    try:
        model = cad.build_plate(
            holes, w, h, cfg.plate, label, rules=task.rules, outline_ring=ring, label_solid_mm=solid
        )
    except ValueError as exc:
        # Holes that break the rules, a label that cannot fit, a bad template.
        raise UserError(f"{task.what or stem}: {exc}") from exc
    step, check = _checked_plate(model, holes, cfg, exp.stl_tolerance_mm)
    (x0, y0, _), (x1, y1, _) = check["bbox"]
    if task.bed is not None and not task.bed.fits(x1 - x0, y1 - y0):
        raise UserError(f"{stem}: plate is {x1 - x0:.1f} × {y1 - y0:.1f} mm, larger than the bed {task.bed}")
    drawing = dxf.stencil_for(holes, ring, task.cut_name or stem.upper(), *model.cut_label())
    cut = round(dxf.cut_length_mm(holes, ring), 1)
    part = cad.plate_part(model, drawing, title=task.title, step=step)
    files, written = part_bytes(stem, part, task.order, exp)
    info = written.get(".dxf")
    sheet = None if info is None else (info.bbox_mm[2] - info.bbox_mm[0], info.bbox_mm[3] - info.bbox_mm[1])
    if sheet is not None and task.bed is not None and not task.bed.fits(*sheet):
        raise UserError(
            f"{stem}.dxf: sheet is {sheet[0]:.1f} × {sheet[1]:.1f} mm, larger than the bed {task.bed}"
        )
    plain = _plain(check)
    row = _plate_row(task, plain, part_figures(written), cut, [round(x1 - x0, 3), round(y1 - y0, 3)], sheet)
    return PartResult("plate", tuple(files), row, plain)


def _checked_plate(
    model: Any, holes: Holes, cfg: JobConfig, tolerance_mm: float
) -> tuple[str | None, dict[str, Any]]:
    """A plate's STEP text (None: made when written) and its check's figures.

    A plate with a description is checked by its written STEP text and mesh (``plate.check: file``,
    no OCCT solid is built), or by OCCT on its solid (``plate.check: kernel``); a template's own
    solid always by OCCT.

    Raises:
        PlateCheckError: A failed check, each one named.
    """
    from .. import cad
    from ..config.cad import PlateCheck

    if model.geometry is None or PlateCheck(cfg.plate.check) is PlateCheck.kernel:
        return None, cad.check_plate(model, holes, tolerance_mm=tolerance_mm)
    step = cad.plate_step_text(model)
    return step, cad.check_plate_file(model, step, holes, tolerance_mm=tolerance_mm)


def _plate_row(
    task: PartTask,
    check: dict[str, Any],
    figures: dict[str, Any],
    cut: float,
    size: list[float],
    sheet: tuple[float, float] | None,
) -> dict[str, Any]:
    """A plate's manifest row: a one-plate job's by layer, a mural's by tile and layer with its file, notches and sheet."""
    assert task.label is not None and task.holes is not None
    holes = task.holes
    # A hybrid plate's windows: through holes beside the round ones.
    windows = len(getattr(holes, "windows", ()))
    if task.tile is None:
        row = {
            "layer": task.label.layer,
            **check,
            **figures,
            "cut_length_mm": cut,
            "bbox_mm": size,
            "windows": windows,
        }
        if isinstance(holes, CutLayer):
            row["cutouts"] = holes.cutout_figures()
        return row
    row = {
        "tile": task.tile,
        "layer": task.label.layer,
        "file": task.stem,
        "notches": task.notches,
        "bbox_mm": size,
        "windows": windows,
        "cut_length_mm": cut,
        **figures,
    }
    if sheet is not None:
        row["dxf_sheet_mm"] = [round(v, 3) for v in sheet]
    return {**row, **check}


def _build_wall(task: PartTask) -> PartResult:
    from ..cad import registration
    from ..cad import wall as wall_mod
    from ..config.cad import PlateCheck
    from ..exchange.writers import path_bytes

    cfg, stem = task.cfg, task.stem
    w, h = task.size_mm
    if task.standoff_mm is None:
        raise ValueError(f"{stem}: a wall task needs its stand-off height")
    # A wall is drawn from its outlines and written and checked without OCCT, unless the maker asked
    # for the kernel's checks (plate.check: kernel); a mural's notches are cut by OCCT.
    kernel = PlateCheck(cfg.plate.check) is PlateCheck.kernel
    wm = wall_mod.build_wall(
        w, h, cfg.plate.outline, cfg.wall, cfg.plate.planned_thickness_mm, task.standoff_mm, kernel=kernel
    )
    wm, wall_notches = registration.notch_wall(wm, task.lines, w, cfg.wall.finger_slot_mm)
    wcheck = wall_mod.check_wall(wm)
    bb = wcheck["bbox"]
    if task.bed is not None and not task.bed.fits(bb[3] - bb[0], bb[4] - bb[1]):
        raise UserError(
            f"{stem}: wall is {bb[3] - bb[0]:.1f} × {bb[4] - bb[1]:.1f} mm, larger than the bed {task.bed}"
        )
    step, stl = part_file(stem, ".step"), part_file(stem, ".stl")
    files = (
        (step, path_bytes(step, lambda p: wall_mod.wall_step(wm, p))[0]),
        (stl, path_bytes(stl, lambda p: wall_mod.wall_stl(wm, p, cfg.export.stl_tolerance_mm))[0]),
    )
    row: dict[str, Any] = {} if task.tile is None else {"tile": task.tile}
    row.update(file=part_file(stem, ".step"), standoff_mm=task.standoff_mm)
    if task.tile is not None:
        row["notches"] = wall_notches
    return PartResult("wall", files, {**row, **wcheck}, wcheck)


def check_template(run: Run) -> None:
    """Load and check the plate template before the first stage; record path and SHA-256.

    Raises:
        UserError: The template is not a Python file, fails to load, or has bad parameters.
    """
    from .. import cad

    try:
        run.template = cad.check_plate_template(unplanned(run.cfg).plate)
    except ValueError as exc:
        raise UserError(f"plate.template: {exc}") from None
    if run.template["builtin"]:
        return
    log.warning(
        "plate template %s (SHA-256 %s) is Python code, not bundled with stencil-cad: it runs with your rights",
        run.template["path"],
        run.template["sha256"],
    )
    try_template(run)


def try_template(run: Run) -> None:
    """Build a one-hole plate with a user's template, so its own errors surface before the first stage.

    Raises:
        UserError: The template's ``build()`` failed (its error, named as the template's).
    """
    from .. import cad
    from ..model import DotSet

    cfg = unplanned(run.cfg)
    w = cfg.size.width_mm
    h = cfg.size.height_mm or w
    r = cfg.stipple.hole_floor_mm
    one = DotSet(xy_mm=np.array([[w / 2.0, h / 2.0]]), r_mm=np.array([r]))
    label = cad.LabelInfo(layer=1, layers=cfg.decompose.layers, colour="#000000", job=cfg.name)
    try:
        cad.build_plate(one, w, h, cfg.plate, label)
    except ValueError as exc:
        raise UserError(f"plate.template: tried on a one-hole {w:g} × {h:g} mm plate: {exc}") from None
