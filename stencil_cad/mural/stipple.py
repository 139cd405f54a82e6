"""A mural's hole placement tile by tile, each tile a task, relaxed against its placed neighbours.

Stippling a mural layer in one piece holds the whole layer's opacity, its Lloyd grid (the
input grid refined until a Voronoi cell covers about 100 pixels) and every seed at once, in
one task per layer: a 10 m² mural is four tasks of 40 megapixels each, and two workers are
idle while the biggest layer runs. Here every (layer, tile) pair is a task on the tile's
**region**: its core grown by :func:`stipple_halo_mm` on the sides it shares with a
neighbour.

Tiles run in the four phases of :func:`stencil_cad.mural.phases` (a 2 × 2 colouring
of the grid). In a region, the holes that tiles of earlier phases placed are **fixed Lloyd
generators**: they keep their Voronoi cells, so the new seeds relax against them and meet
them at the seam as they meet each other inside the tile (no seam line of crowded or missing
holes). New seeds are drawn only where no earlier tile owns the pixels; after relaxation the
tile keeps the new holes whose centres its core holds, and the rest (those in the halo of
tiles still to come) are thrown away — those tiles place their own against this one's.
Tiles of one phase are a whole tile apart, so their new holes never meet: they are
independent tasks (a halo wider than a tile only costs work: each keeps its own core's holes).

Rules. The mural's rules hold in every region (its edge margins at the mural's edges, not
at a region's). Each tile's new holes are repaired with
:func:`stencil_cad.stipple.rules.enforce_rules`; then every new hole closer than the web to a
fixed one is dropped (the **seam pass**; counted per layer as ``removed_seam``). The union is
checked with :func:`~stencil_cad.stipple.rules.check_rules` over the whole mural.

Every task is a pure function of its inputs and its own generator (from the job seed, the
layer and the tile), so 1, 2 or 4 workers give the same holes, byte for byte.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model import DotSet
from . import tiling

if TYPE_CHECKING:
    from ..config import JobConfig
    from ..simulate.tone import ToneChoice
    from ..stipple.rules import DesignRules

log = logging.getLogger(__name__)

#: How many hole spacings of the densest tone the halo holds (plus the margin and a hole).
#: Measured on the 500 × 300 mm flat grey and wave of ``tests/mural/test_stipple.py`` (mean
#: nearest-neighbour distance within 5 mm of a seam over that inside the tiles): 2, 4, 8 and
#: 12 spacings gave 0.975 / 0.971, 0.974 / 0.958, 0.976 / 0.962 and 0.981 / 0.966, so beyond
#: two spacings the halo is not what sets the seams; eight leave room for tones that vary.
HALO_SPACINGS = 8.0


def stipple_halo_mm(cfg: JobConfig) -> float:
    """How far a tile's stippling region reaches past its core, in mm.

    :data:`HALO_SPACINGS` centre spacings of the densest tone, plus the edge margin and the
    largest hole's diameter (room for the rules' nudges; the margins themselves hold only at
    the mural's edges).
    """
    from ..resolution import hole_pitch_mm

    sizes = cfg.stipple.sizes
    return HALO_SPACINGS * hole_pitch_mm(cfg) + sizes.edge_margin_mm + 2.0 * sizes.max_radius_mm


@dataclass(frozen=True)
class PlaceTask:
    """One tile of one layer to stipple, in the region's frame.

    Attributes:
        layer: The layer's index.
        tile: The tile's index in the grid.
        offset_mm: Mural mm of the region frame's origin (its bottom-left corner).
        alpha: ``(h, w)`` the region's opacity (on the layer's own grid).
        free: ``(h, w)`` bool: pixels no earlier tile owns (where new seeds are drawn).
        fixed_xy: ``(M, 2)`` the earlier tiles' holes in the region, mural mm.
        fixed_r: ``(M,)`` their radii.
        mm_per_px: Pixel size of ``alpha``.
        grid: The mural's tiles (ownership of the new holes).
        rules: The mural's design rules.
        cfg: The job config.
        tone: The layer's tone choice (its density for ``stipple.tone: response``), or None.
        seed: The task's seed sequence (job seed, layer, tile).
    """

    layer: int
    tile: int
    offset_mm: tuple[float, float]
    alpha: np.ndarray
    free: np.ndarray
    fixed_xy: np.ndarray
    fixed_r: np.ndarray
    mm_per_px: float
    grid: tiling.TileGrid
    rules: DesignRules
    cfg: JobConfig
    tone: ToneChoice | None
    seed: np.random.SeedSequence


@dataclass(frozen=True)
class PlaceResult:
    """A tile's new holes in mural mm and its report."""

    layer: int
    tile: int
    xy_mm: np.ndarray
    r_mm: np.ndarray
    report: dict[str, Any]


def place_tile(task: PlaceTask) -> PlaceResult:
    """Stipple one tile of one layer against its placed neighbours (a task: pure, picklable)."""
    from ..stipple.relax import place_holes
    from ..stipple.rules import enforce_rules, web_violations

    density = None if task.tone is None else task.tone.density_of(task.alpha)
    rng = np.random.default_rng(task.seed)
    off = np.array(task.offset_mm)
    xy, r, report = place_holes(
        task.alpha,
        task.mm_per_px,
        task.cfg.stipple,
        rng,
        task.rules,
        density,
        free=task.free,
        fixed_xy_mm=task.fixed_xy - off,
        origin_mm=task.offset_mm,
    )
    xy = xy + off
    # A new hole that relaxed across a seam into an earlier tile's core goes too: keeping those
    # (13 of 8,000 on the flat grey of tests/mural/test_stipple.py) doubled the share of
    # unusually close neighbours within 5 mm of the seams, to 2 %.
    own = task.grid.owner(xy) == task.tile if len(xy) else np.zeros(0, dtype=bool)
    report["outside_core"] = int((~own).sum())
    # The tile's own count: its seeds after relaxation (``removed_empty`` and
    # ``removed_threshold`` stay the region's, halo included, and are not in ``removed``).
    report["n_region"] = report["n_initial"]
    report["n_initial"] = int(own.sum())
    xy, r, rep = enforce_rules(xy[own], r[own], task.rules)
    report.update({k: v for k, v in rep.items() if k not in ("n_in", "n_out", "min_web_mm")})
    # The seam pass: a new hole closer than the web to a fixed one goes (pairs of new holes
    # passed enforce_rules; fixed pairs passed it in their own tiles).
    n = len(r)
    seam = np.zeros(n, dtype=bool)
    if n and len(task.fixed_r):
        pairs, _ = web_violations(
            np.concatenate([xy, task.fixed_xy]), np.concatenate([r, task.fixed_r]), task.rules.web_mm
        )
        mixed = (pairs[:, 0] < n) != (pairs[:, 1] < n)
        seam[np.minimum(pairs[mixed, 0], pairs[mixed, 1])] = True
    report["removed_seam"] = int(seam.sum())
    report["removed"] = report["removed"] + int(seam.sum())
    xy, r = xy[~seam], r[~seam]
    report["n_final"] = int(len(r))
    return PlaceResult(task.layer, task.tile, xy, r, report)


def _free_mask(
    grid: tiling.TileGrid,
    placed: np.ndarray,
    bounds: tuple[int, int, int, int],
    shape: tuple[int, ...],
    g: float,
) -> np.ndarray:
    """Pixels of a region that no placed tile owns (by their centres)."""
    r0, r1, c0, c1 = bounds
    h = shape[0]
    x, y = np.meshgrid((np.arange(c0, c1) + 0.5) * g, (h - np.arange(r0, r1) - 0.5) * g)
    owner = grid.owner(np.column_stack([x.ravel(), y.ravel()])).reshape(x.shape)
    free: np.ndarray = ~placed[owner]
    return free


def place_tasks(
    cfg: JobConfig,
    alphas: np.ndarray,
    mm_per_px: float,
    grid: tiling.TileGrid,
    tiles: list[int],
    placed: np.ndarray,
    state: list[tuple[np.ndarray, np.ndarray]],
    rules: DesignRules,
    tones: list[ToneChoice | None],
    seeds: list[list[np.random.SeedSequence]],
    halo: float,
) -> Iterator[PlaceTask]:
    """The tasks of one phase, made as the executor consumes them (one region's crop at a time).

    Args:
        cfg: The job config.
        alphas: ``(L, H, W)`` the layers' opacities over the whole mural.
        mm_per_px: Their pixel size.
        grid: The mural's tiles.
        tiles: The phase's tile indices.
        placed: Per tile, True when an earlier phase placed it.
        state: Per layer ``(xy, r)``: the holes placed so far, mural mm.
        rules: The mural's design rules.
        tones: Per layer, the tone choice (None: the tone curve).
        seeds: Per layer, per tile, the task's seed sequence.
        halo: How far a region reaches past its core, mm.
    """
    shape = alphas.shape[1:]
    for k in tiles:
        t = grid.tiles[k]
        bounds, (ox, oy, right, top) = tiling.region_bounds(t, grid, shape, mm_per_px, halo)
        r0, r1, c0, c1 = bounds
        free = _free_mask(grid, placed, bounds, shape, mm_per_px)
        for i, (xy, r) in enumerate(state):
            inside = (xy[:, 0] >= ox) & (xy[:, 0] <= right) & (xy[:, 1] >= oy) & (xy[:, 1] <= top)
            yield PlaceTask(
                layer=i,
                tile=k,
                offset_mm=(ox, oy),
                alpha=np.ascontiguousarray(alphas[i, r0:r1, c0:c1]),
                free=free,
                fixed_xy=xy[inside],
                fixed_r=r[inside],
                mm_per_px=mm_per_px,
                grid=grid,
                rules=rules,
                cfg=cfg,
                tone=tones[i],
                seed=seeds[i][k],
            )


_SUMMED = (
    "n_initial",
    "n_region",
    "removed",
    "removed_empty",
    "removed_threshold",
    "removed_invalid",
    "removed_edge",
    "removed_keepout",
    "removed_web",
    "removed_seam",
    "outside_core",
    "raised",
    "merged",
    "nudged",
    "n_final",
)


def stipple_mural(
    cfg: JobConfig,
    alphas: np.ndarray,
    mm_per_px: float,
    grid: tiling.TileGrid,
    tones: list[ToneChoice | None],
    seeds: list[list[np.random.SeedSequence]],
    tasks_map: tiling.TaskMap,
) -> list[DotSet]:
    """Stipple every layer of a mural tile by tile in four phases (see the module's text).

    Args:
        cfg: The job config.
        alphas: ``(L, H, W)`` the layers' opacities over the whole mural.
        mm_per_px: Their pixel size.
        grid: The mural's tiles (more than one).
        tones: Per layer, the tone choice made over the whole layer (None: the tone curve).
        seeds: Per layer, per tile, a seed sequence.
        tasks_map: ``tasks_map(fn, items, desc, count=)`` running the tasks, yielding results in
            order (the job's executor).

    Returns:
        One DotSet per layer over the whole mural, passing the rules; ``report`` with the
        tiles' figures summed (``n_final = n_initial - removed``; ``n_region`` counts every
        region's seeds, halo included, and ``removed_empty``/``removed_threshold`` are among
        those), ``iterations``, ``mean_move_px``, ``refine`` and ``bucket_px`` their largest,
        ``e_norm`` their mean weighted by holes (each over its region with the fixed cells, so
        not comparable with a one-piece stipple's), ``tiles``, ``halo_mm`` and ``min_web_mm``.
    """
    from ..geometry import min_web
    from ..stipple.rules import check_rules

    h, w = alphas.shape[1:]
    rules = cfg.stipple.design_rules(w * mm_per_px, h * mm_per_px)
    halo = stipple_halo_mm(cfg)
    layers = len(alphas)
    state = [(np.zeros((0, 2)), np.zeros(0)) for _ in range(layers)]
    placed = np.zeros(len(grid.tiles), dtype=bool)
    reports: list[list[dict[str, Any]]] = [[] for _ in range(layers)]
    for phase in tiling.phases(grid):
        tasks = place_tasks(cfg, alphas, mm_per_px, grid, phase, placed, state, rules, tones, seeds, halo)
        new: list[list[PlaceResult]] = [[] for _ in range(layers)]
        for res in tasks_map(place_tile, tasks, "stipple tiles", count=len(phase) * layers):
            new[res.layer].append(res)
            reports[res.layer].append(res.report)
        for i, results in enumerate(new):
            xy, r = state[i]
            state[i] = (
                np.concatenate([xy, *(p.xy_mm for p in results)]),
                np.concatenate([r, *(p.r_mm for p in results)]),
            )
        placed[phase] = True
    out = []
    for (xy, r), rows in zip(state, reports, strict=True):
        # Tile order (row-major), so the holes' order does not depend on the phases' grouping.
        order = np.lexsort((xy[:, 0], -xy[:, 1], grid.owner(xy))) if len(r) else np.zeros(0, dtype=np.int64)
        xy, r = xy[order], r[order]
        check_rules(xy, r, rules)
        report: dict[str, Any] = {key: sum(int(row.get(key, 0)) for row in rows) for key in _SUMMED}
        held = [row for row in rows if row["n_final"] and math.isfinite(row["e_norm"])]
        weight = sum(row["n_final"] for row in held)
        report.update(
            iterations=max((row["iterations"] for row in rows), default=0),
            mean_move_px=max((row["mean_move_px"] for row in rows), default=0.0),
            refine=max((row["refine"] for row in rows), default=1),
            bucket_px=max((row["bucket_px"] for row in rows), default=0),
            e_norm=sum(row["e_norm"] * row["n_final"] for row in held) / weight if weight else math.nan,
            tiles=len(rows),
            halo_mm=round(halo, 3),
            min_web_mm=min_web(xy, r),
        )
        out.append(DotSet(xy_mm=xy, r_mm=r, report=report))
    log.debug("stippled a mural tile by tile: %s", [ds.report for ds in out])
    return out


@dataclass(frozen=True)
class StippleTask:
    """One layer to stipple: its opacity, pixel size, the job config and its own generator.

    ``weight`` weighs each pixel's error when the layer's spray time is chosen: the squared
    colour change a full coat makes there (:func:`stencil_cad.model.coat_contrast`).
    """

    alpha: np.ndarray
    mm_per_px: float
    cfg: JobConfig
    rng: np.random.Generator
    weight: np.ndarray | None = None
    #: ``(H, W)`` bool where no hole may be placed (a hybrid plate's windows and the web around
    #: them), or None. The holes' tone is chosen for the rest of the layer; the spray time for
    #: both, the windows counted as a full coat (:func:`stencil_cad.simulate.tone.choose_tone`).
    closed: np.ndarray | None = None
    #: ``(H, W)`` bool, the windows' own pixels, or None.
    windows: np.ndarray | None = None
    #: ``(M, 2)`` the layer's holes on another wall in mm, for Lloyd to start from
    #: (:func:`stencil_cad.stipple.warm.warm_seeds`), or None. A layer stippled in one piece only.
    start_xy_mm: np.ndarray | None = None

    def holes_alpha(self) -> np.ndarray:
        """The opacity left to the holes: none where they may not go."""
        return self.alpha if self.closed is None else np.where(self.closed, 0.0, self.alpha)


def layer_tone(task: StippleTask) -> tuple[ToneChoice | None, float]:
    """``(tone choice or None, spray time)`` of one layer.

    With ``stipple.tone: response`` the density comes from the spray response, and with
    ``spray.calibrate: spray_time`` the layer gets its own spray time.
    """
    cfg = task.cfg
    if not cfg.stipple.tone_from_response:
        return None, cfg.spray.amount
    from ..simulate import tone

    windows = None if task.windows is None else (task.windows, task.alpha)
    choice = tone.response_tone_for(task.holes_alpha(), task.mm_per_px, cfg, task.weight, windows)
    if cfg.chooses_spray_time:
        return choice, float(choice.spray_time)
    return choice, cfg.spray.amount


def stipple_task(task: StippleTask) -> tuple[DotSet, dict[str, Any] | None]:
    """Stipple one layer (a task): ``(holes, tone choice summary or None)``.

    The spray time (:func:`layer_tone`) is the holes' ``spray_time``.
    """
    from dataclasses import replace

    from ..stipple import stipple_layer
    from ..stipple.warm import WarmStart

    choice, spray_time = layer_tone(task)
    density = None if choice is None else choice.density
    ds = stipple_layer(
        task.holes_alpha(),
        task.mm_per_px,
        task.cfg.stipple,
        task.rng,
        density=density,
        start=None if task.start_xy_mm is None else WarmStart(task.start_xy_mm),
    )
    return replace(ds, spray_time=spray_time), None if choice is None else choice.summary()


def tone_task(task: StippleTask) -> tuple[ToneChoice | None, float]:
    """One layer's tone choice without its density map (a task): ``(choice or None, spray time)``."""
    from dataclasses import replace

    choice, spray_time = layer_tone(task)
    return (None if choice is None else replace(choice, density=np.zeros((0, 0)))), spray_time


def stipple_layers(
    tasks: list[StippleTask],
    alphas: np.ndarray,
    grid: tiling.TileGrid,
    seed_for: Callable[[int, int], np.random.SeedSequence],
    tasks_map: tiling.TaskMap,
) -> tuple[list[DotSet], list[dict[str, Any]]]:
    """Every layer's holes over a tiling, each with its spray time in its report.

    A 1 × 1 tiling stipples each layer in one piece, one task per layer (so does
    ``stipple.dots``, one count for a whole picture); a mural's layers are placed tile by tile
    (:func:`stipple_mural`), one task per layer and tile.

    Args:
        tasks: One per layer.
        alphas: ``(L, H, W)`` the layers' opacities (the tasks' ``alpha``, stacked).
        grid: The tiling.
        seed_for: ``seed_for(layer, tile)``: the seed sequence of one layer on one tile.
        tasks_map: ``tasks_map(fn, items, desc, count=)`` running the tasks (the job's executor).

    Returns:
        ``(holes per layer, summaries of the tone choices)``.
    """
    if not tasks:
        return [], []
    cfg = tasks[0].cfg
    tones: list[dict[str, Any]] = []
    if len(grid.tiles) == 1 or cfg.stipple.dots is not None:
        sets = []
        for ds, tone_summary in tasks_map(stipple_task, tasks, "stipple"):
            sets.append(ds)
            if tone_summary is not None:
                tones.append(tone_summary)
        return sets, tones
    chosen = list(tasks_map(tone_task, tasks, "tone"))
    seeds = [[seed_for(i, k) for k in range(len(grid.tiles))] for i in range(len(tasks))]
    placed = stipple_mural(cfg, alphas, tasks[0].mm_per_px, grid, [c for c, _ in chosen], seeds, tasks_map)
    sets = []
    for ds, (choice, spray_time) in zip(placed, chosen, strict=True):
        sets.append(replace(ds, spray_time=spray_time))
        if choice is not None:
            tones.append(choice.summary())
    return sets, tones
