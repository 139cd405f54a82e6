"""A mural's hole refinement tile by tile, each tile a task, with a seam pass.

Refining a mural in one piece holds the whole mural's simulation raster and every hole's
optimisation state at once (a square metre of FDM holes is about 2 MP per layer on the
auto simulation grid; ten square metres, twenty). Here each tile is refined on its own
**region**: the tile's core grown by a halo (:func:`refine_halo_mm`) on the sides it shares
with a neighbour, with the part of the picture and every hole of that region. Only the
holes that started in the tile's core keep their result; the others are context that moves
with them and is thrown away. The halo is wide enough (twice the spray's reach, plus the
edge margin, the largest hole and the eye filter) that a hole missing at the region's
border changes nothing a core hole's spray or gradient touches.

Tiles run in the four phases of :func:`stencil_cad.mural.phases`, by the colour of a 2 × 2
colouring of the grid (A1, A3, … first; then A2, A4, …; then B1, …; then B2, …). Tiles refined in the same phase never share a
region, so they are independent tasks; a later phase sees the refined holes of the phases
before it. Every task is a pure function of its inputs, so 1, 2 or 4 workers give the same
holes, byte for byte.

The add/remove moves are off per tile: they would change which hole is which, and a hole
must stay the same hole in its own tile and in its neighbours' context. Centres and radii
are refined as in :func:`stencil_cad.stipple.refine.refine_dots`.

Seam pass. Within a region the design rules hold at every step; across a seam two tiles'
results can meet closer than the web. Every hole of such a pair goes back to its stippled
state (which passed the rules over the whole mural), and the pass repeats until no pair is
left: it ends, because each round reverts at least one refined hole. The union is then
checked with :func:`stencil_cad.stipple.rules.check_rules` in mural coordinates.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model import DotSet
from . import tiling

if TYPE_CHECKING:
    from ..config import JobConfig
    from ..config.spray import SprayConfig
    from ..stipple.refine import Paused, RefineSettings
    from ..stipple.rules import DesignRules

log = logging.getLogger(__name__)

#: Rule tolerance of the seam pass, mm (as the refinement's own check).
_TOL_MM = 2.5e-4


@dataclass(frozen=True)
class HoleKernels:
    """The spray model's per-hole kernels bound to the spray settings (picklable for a cluster).

    Calls :func:`stencil_cad.simulate.spray.hole_kernels`; see
    :data:`stencil_cad.stipple.refine.Kernels`.
    """

    spray: SprayConfig
    geometry: Any = None

    def __call__(
        self, r_mm: np.ndarray, spray_time: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
        """``(sigma_mm, peak, dsigma_dr, dpeak_dr, combine)`` of holes of radii ``r_mm``."""
        from ..simulate import spray

        return spray.hole_kernels(r_mm, self.spray, spray_time, geometry=self.geometry)


@dataclass(frozen=True)
class Problem:
    """What every tile's refinement shares: the picture on the simulation grid and the settings.

    Attributes:
        target: ``(H, W, 3)`` the picture in [0, 1] on the simulation grid (mural frame).
        alpha_targets: ``(L, H, W)`` each layer's target opacity on that grid, or None.
        mm_per_px: Simulation pixel size in mm.
        primer: ``(3,)`` primer colour.
        colours: ``(L, 3)`` paint colours in spray order.
        rules: The design rules of each layer over the whole mural (picture frame).
        kernels: Per can of the prior (the nominal can first), each layer's per-hole kernels.
        spray_times: Each layer's spray time.
        settings: The refinement settings (add/remove is turned off per tile).
        fixed_trans: ``(L, H, W)`` transmittance of each layer's windows on that grid, or None.
    """

    target: np.ndarray
    alpha_targets: np.ndarray | None
    mm_per_px: float
    primer: np.ndarray
    colours: np.ndarray
    rules: list[DesignRules]
    kernels: tuple[tuple[HoleKernels, ...], ...]
    spray_times: list[float]
    settings: RefineSettings
    fixed_trans: np.ndarray | None = None


@dataclass(frozen=True)
class TileTask:
    """One tile's refinement: its region's picture, holes and rules, in the region's frame.

    Attributes:
        tile: The tile's name.
        offset_mm: Mural mm of the region frame's origin (its bottom-left corner).
        target: ``(h, w, 3)`` the region's picture.
        alpha_targets: ``(L, h, w)`` or None.
        dotsets: Per layer, the region's holes in the region frame.
        core: Per layer, which of those holes the tile owns (their results are kept).
        index: Per layer, each of those holes' index in the mural's hole list.
        rules: Per layer, the region's rules.
        problem: The shared settings (its rasters are not used by the task).
    """

    tile: str
    offset_mm: tuple[float, float]
    target: np.ndarray
    alpha_targets: np.ndarray | None
    dotsets: list[DotSet]
    core: list[np.ndarray]
    index: list[np.ndarray]
    rules: list[DesignRules]
    problem: Problem
    fixed_trans: np.ndarray | None = None


@dataclass(frozen=True)
class TileResult:
    """A tile's refined core holes: per layer their mural indices, centres (mural mm) and radii."""

    tile: str
    index: list[np.ndarray]
    xy_mm: list[np.ndarray]
    r_mm: list[np.ndarray]
    report: dict[str, Any]


def refine_halo_mm(cfg: JobConfig, eye_sigma_mm: float) -> float:
    """How far a tile's refinement region reaches past its core, in mm.

    Twice the spray's reach (:func:`stencil_cad.mural.spray_halo_mm`: a hole left out at the
    region's border and the pixels it would touch, then those pixels and the core holes
    whose gradients read them), plus the edge margin and the largest hole (holes closer
    than that to the region's border are left out), plus three sigma of the eye filter.
    """
    return (
        2.0 * tiling.spray_halo_mm(cfg)
        + cfg.stipple.sizes.edge_margin_mm
        + 2.0 * cfg.refined_max_radius_mm
        + 3.0 * eye_sigma_mm
    )


def tile_tasks(
    problem: Problem,
    grid: tiling.TileGrid,
    tiles: list[int],
    state: list[tuple[np.ndarray, np.ndarray]],
    halo: float,
) -> list[TileTask]:
    """The tasks of one phase, from the mural's current holes (``state``: per layer ``(xy, r)``)."""
    shape = problem.target.shape[:2]
    g = problem.mm_per_px
    # What every task shares, without the mural's rasters (each task carries its own crop).
    shared = replace(problem, target=np.zeros((0, 0, 3)), alpha_targets=None, fixed_trans=None)
    tasks = []
    for k in tiles:
        t = grid.tiles[k]
        (r0, r1, c0, c1), (ox, oy, right, top) = tiling.region_bounds(t, grid, shape, g, halo)
        sets, cores, idx, rules = [], [], [], []
        for (xy, r), rl in zip(state, problem.rules, strict=True):
            reg = replace(
                rl,
                width_mm=right - ox,
                height_mm=top - oy,
                keepouts=tuple((a - ox, b - oy, c - ox, d - oy) for a, b, c, d in rl.keepouts),
            )
            lo = rl.edge_margin_mm + r - _TOL_MM
            inside = (
                (xy[:, 0] - ox >= lo)
                & (right - xy[:, 0] >= lo)
                & (xy[:, 1] - oy >= lo)
                & (top - xy[:, 1] >= lo)
            )
            sel = np.flatnonzero(inside)
            owner = grid.owner(xy[sel]) if len(sel) else np.zeros(0, dtype=np.int64)
            sets.append(DotSet(xy_mm=xy[sel] - np.array([ox, oy]), r_mm=r[sel].copy()))
            cores.append(owner == k)
            idx.append(sel)
            rules.append(reg)
        tasks.append(
            TileTask(
                tile=t.name,
                offset_mm=(ox, oy),
                target=np.ascontiguousarray(problem.target[r0:r1, c0:c1]),
                alpha_targets=None
                if problem.alpha_targets is None
                else np.ascontiguousarray(problem.alpha_targets[:, r0:r1, c0:c1]),
                dotsets=sets,
                core=cores,
                index=idx,
                rules=rules,
                problem=shared,
                fixed_trans=None
                if problem.fixed_trans is None
                else np.ascontiguousarray(problem.fixed_trans[:, r0:r1, c0:c1]),
            )
        )
    return tasks


def refine_tile(task: TileTask) -> TileResult:
    """Refine one tile's region and return its core holes' results (a task: pure, picklable)."""
    from ..stipple import refine

    p = task.problem
    settings = replace(p.settings, add_remove_every=0)
    out, report = refine.refine_dots(
        task.target,
        p.mm_per_px,
        p.primer,
        p.colours,
        task.dotsets,
        task.rules,
        p.kernels,
        p.spray_times,
        settings,
        alpha_targets=task.alpha_targets,
        fixed_trans=task.fixed_trans,
    )
    off = np.array(task.offset_mm)
    idx, xy, r = [], [], []
    for ds, core, index in zip(out, task.core, task.index, strict=True):
        if len(ds) != len(core):
            raise RuntimeError(f"tile {task.tile}: refinement without add/remove changed the hole count")
        idx.append(index[core])
        xy.append(ds.xy_mm[core] + off)
        r.append(ds.r_mm[core])
    px = float(task.target.shape[0] * task.target.shape[1])
    return TileResult(task.tile, idx, xy, r, {**report, "tile": task.tile, "pixels": px})


def web_conflicts(xy: np.ndarray, r: np.ndarray, web_mm: float) -> np.ndarray:
    """Holes closer than the web to another hole (a boolean per hole)."""
    from ..stipple.rules import web_violations

    bad = np.zeros(len(xy), dtype=bool)
    pairs, _ = web_violations(xy, r, web_mm - _TOL_MM)
    bad[pairs.ravel()] = True
    return bad


def seam_pass(
    xy: np.ndarray, r: np.ndarray, xy0: np.ndarray, r0: np.ndarray, web_mm: float
) -> tuple[np.ndarray, np.ndarray, int]:
    """Put back every changed hole that meets another closer than the web, until none does.

    A hole is changed when it differs from ``(xy0, r0)``, a state that passes the web rule
    (the holes before the latest phase): only the changed hole of a conflicting pair goes
    back, so a neighbour tile's earlier refinement is kept.

    Returns:
        ``(xy, r, reverted)``: the holes and how many went back to ``(xy0, r0)``.
    """
    xy, r = xy.copy(), r.copy()
    reverted = 0
    while True:
        bad = web_conflicts(xy, r, web_mm)
        bad &= np.any(xy != xy0, axis=1) | (r != r0)
        if not bad.any():
            return xy, r, reverted
        reverted += int(bad.sum())
        xy[bad], r[bad] = xy0[bad], r0[bad]


def refine_mural(
    problem: Problem,
    grid: tiling.TileGrid,
    dotsets: list[DotSet],
    halo: float,
    tasks_map: tiling.TaskMap,
    bar: tiling.Progress | None = None,
) -> tuple[list[DotSet], dict[str, Any]]:
    """Refine a mural's holes tile by tile in four phases, then the seam pass.

    Args:
        problem: The picture on the simulation grid and the settings.
        grid: The mural's tiles.
        dotsets: One DotSet per layer over the whole mural (each passing its rules).
        halo: How far each region reaches past its core, mm (:func:`refine_halo_mm`).
        tasks_map: ``tasks_map(fn, items, desc)`` running the tasks, yielding results in order
            (the job's executor).
        bar: A progress bar updated once per tile, or None.

    Returns:
        ``(dotsets, report)`` as :func:`stencil_cad.stipple.refine.refine_dots` returns them,
        the report with one row per tile and the seam pass's reverts.
    """
    from ..stipple.rules import check_rules

    state = [(ds.xy_mm.copy(), ds.r_mm.copy()) for ds in dotsets]
    rows: list[dict[str, Any]] = []
    reverted = [0] * len(dotsets)
    for phase in tiling.phases(grid):
        before = [(xy.copy(), r.copy()) for xy, r in state]
        tasks = tile_tasks(problem, grid, phase, state, halo)
        for res in tasks_map(refine_tile, tasks, "refine tiles"):
            for (xy, r), i, p, q in zip(state, res.index, res.xy_mm, res.r_mm, strict=True):
                xy[i], r[i] = p, q
            rows.append(res.report)
            if bar is not None:
                bar.update(1)
        # After every phase, so the next phase's regions start from holes that pass the rules.
        # Only this phase's moves can meet a hole closer than the web (the state before passed).
        for k, ((xy0, r0), (xy, r), rl) in enumerate(zip(before, state, problem.rules, strict=True)):
            xy2, r2, n = seam_pass(xy, r, xy0, r0, rl.web_mm)
            state[k] = (xy2, r2)
            reverted[k] += n
    out = []
    for ds, (xy, r), rl, n in zip(dotsets, state, problem.rules, reverted, strict=True):
        check_rules(xy, r, rl)
        moved = int(np.count_nonzero(np.any(xy != ds.xy_mm, axis=1) | (r != ds.r_mm)))
        out.append(
            replace(
                ds,
                xy_mm=xy,
                r_mm=r,
                report={**ds.report, "n_stippled": len(ds), "refine_seam_reverted": n, "refine_moved": moved},
            )
        )
    px = sum(row["pixels"] for row in rows) or 1.0

    def mean(key: str) -> float:
        # Rounded: a tile's objective is a sum whose last bit depends on the threads of the process
        # that refined it (this one or a worker), and the manifest must not (compare_outputs).
        return round(math.sqrt(sum(row[key] ** 2 * row["pixels"] for row in rows) / px), 9)

    report = {
        "tiled": True,
        "tiles": len(rows),
        "halo_mm": round(halo, 3),
        "iterations": problem.settings.iterations,
        "objective_start": mean("objective_start") if rows else None,
        "objective_end": mean("objective_end") if rows else None,
        "seam_reverted": reverted,
        "seconds": round(sum(row["seconds"] for row in rows), 3),
    }
    log.debug("refined a mural tile by tile: %s", report)
    return out, report


def refine_layers(
    problem: Problem,
    grid: tiling.TileGrid,
    dotsets: list[DotSet],
    cfg: JobConfig,
    tasks_map: tiling.TaskMap,
    progress: Callable[[int, int], None] | None = None,
    resume: Paused | None = None,
    on_pause: Callable[[Paused], None] | None = None,
) -> tuple[list[DotSet], dict[str, Any]]:
    """Refine every layer's holes over a tiling: a 1 × 1 tiling in one piece, a mural tile by tile.

    Args:
        problem: The picture, the layers and the settings.
        grid: The tiling.
        dotsets: Each layer's holes over the whole picture.
        cfg: The job config (a mural's halo follows its spray and holes).
        tasks_map: ``tasks_map(fn, items, desc, count=)`` running a mural's tile tasks.
        progress: ``progress(iteration, total)`` after each iteration of a one-piece refinement.
        resume: A one-piece refinement stopped part way, to carry on
            (:class:`stencil_cad.stipple.refine.Paused`), or None.
        on_pause: Called with a one-piece refinement's state where ``settings.stop_after`` stops it
            short (a mural's tiles are not paused).

    Returns:
        ``(refined holes per layer, report)``.

    Raises:
        ValueError: ``resume`` given for a mural.
    """
    if len(grid.tiles) > 1:
        if resume is not None:
            raise ValueError("a mural's refinement is not carried on from a pause")
        halo = refine_halo_mm(cfg, problem.settings.eye_sigma_mm)
        return refine_mural(problem, grid, dotsets, halo, tasks_map)
    from ..stipple.refine import refine_dots

    return refine_dots(
        problem.target,
        problem.mm_per_px,
        problem.primer,
        problem.colours,
        dotsets,
        problem.rules,
        list(problem.kernels),
        problem.spray_times,
        problem.settings,
        progress=progress,
        alpha_targets=problem.alpha_targets,
        fixed_trans=problem.fixed_trans,
        resume=resume,
        on_pause=on_pause,
    )
