"""The holes a plate design gets, computed and kept, written nowhere: stippled, then refined.

What the stipple and refine stages compute before they record or write anything. The job's stages
(:mod:`stencil_cad.pipeline.stipple`, :mod:`stencil_cad.pipeline.refine`), the plate-design trials
(:mod:`stencil_cad.pipeline.standoff`) and the fast preview (:mod:`stencil_cad.pipeline.preview`) each
call :func:`stippled`, then :func:`refined`, with the plan they stipple under (its config and tiling).
Both keep their result in ``run.kept`` by what it reads: the same config, layers, picture and tiling give the same holes, so the job's stages reuse the holes
the trials made for the design the job keeps.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, cast

import numpy as np

from ..config import JobConfig, SprayConfig
from ..figures import DarkEnd
from ..model import DotSet, Layers, Picture, coat_contrast
from ..mural import TileGrid, clear_post_sites, post_plan
from ..mural.stipple import StippleTask, stipple_layers
from ..record import Run
from ..stipple.windows import with_windows
from .names import layer_stem
from .plan import Plan
from .refinement import refine_holes

__all__ = ["Refined", "Stippled", "layer_jobs", "layer_windows", "refined", "stippled"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Stippled:
    """What the stipple stage computes before it writes: the holes (not refined, windows in), tones, windows, figures."""

    sets: list[DotSet]
    tones: Any
    windows: list[Any]
    dark_end: tuple[DarkEnd, ...]


@dataclass(frozen=True)
class Refined:
    """The plates' holes as the job builds them: refined (when ``refine.enabled``), clear of a mural's posts.

    ``report`` is the refinement's figure ``refine`` (None when it is off).
    """

    sets: list[DotSet]
    report: Any


def stippled(run: Run, plan: Plan, layers: Layers, start: Stippled | None = None) -> tuple[Stippled, bool]:
    """Every layer's holes as the stipple stage makes them, not refined: ``(the holes and figures, whether kept)``.

    Under ``plan``'s config (``stipple.dots`` capped already: :func:`stencil_cad.plan.plan.capped`) and
    tiling. Kept in ``run.kept`` by the config, layers and tiling (the second value says they were).
    ``start``: the same layers' holes under another design (the plate-design trials' first wall), from
    which each layer's Lloyd relaxation starts on a one-piece tiling
    (:func:`stencil_cad.stipple.warm.warm_seeds`). It is not part of the key: the trials stipple each
    wall once, and the job's stages reuse the wall they keep as it was made.
    """
    picture_mm, tiling = plan.picture_mm, plan.grid
    key = ("stipple", plan.cfg.model_dump_json(), id(layers), picture_mm, repr(tiling))
    made, kept = run.keep(
        key, lambda: _stippled(run, plan.cfg, layers, picture_mm, tiling, plan.sprays, start)
    )
    return cast("Stippled", made), kept


def refined(
    run: Run,
    plan: Plan,
    layers: Layers,
    made: Stippled,
    picture: Picture | None = None,
    stop_after: int | None = None,
) -> tuple[Refined, bool]:
    """``made``'s holes refined towards ``picture`` (when ``refine.enabled``) and clear of the posts: ``(holes, whether kept)``.

    ``made`` is :func:`stippled`'s for the same run, plan and layers. Kept in ``run.kept`` by the
    config, layers, picture and tiling (the second value says they were), and ``stop_after``: the
    refinement stopped after that many of its steps, as the plate-design trials rank walls (None:
    the whole refinement, the job's). A refinement of one piece stopped so is kept paused too, and
    the whole refinement of the same holes carries it on rather than take its first steps again
    (the same holes: on the bundled example the job refines 60 steps, not 90, after the trials' 30; its
    refine stage took 3.9 s rather than 6.1 and the job 37.4 CPU-s rather than 39.9, medians of three
    runs of ``stencil-cad run`` alternated with the commit before).
    """
    cfg, picture_mm, tiling = plan.cfg, plan.picture_mm, plan.grid
    key = ("refine", cfg.model_dump_json(), id(layers), id(picture), picture_mm, repr(tiling), stop_after)
    # By ``made`` too: the paused state is of those holes (kept in ``run.kept``, so the id stays theirs).
    paused = ("refine-paused", *key[1:-1], id(made))

    def make() -> Refined:
        sets, report = made.sets, None
        if cfg.refine.enabled:
            one = len(tiling.tiles) == 1
            resume = run.kept.pop(paused, None) if one and stop_after is None else None
            on_pause = (lambda state: run.kept.__setitem__(paused, state)) if one and stop_after else None
            sets, report = refine_holes(run, plan, layers, sets, picture, stop_after, resume, on_pause)
        # A mural's plates stand on posts: the few holes a post would shade go before anything scores them.
        sets, _ = clear_post_sites(sets, tiling, post_plan(cfg, tiling))
        return Refined(sets, report)

    done, kept = run.keep(key, make)
    return cast("Refined", done), kept


def _stippled(
    run: Run,
    cfg: JobConfig,
    layers: Layers,
    picture_mm: tuple[float, float],
    tiling: TileGrid,
    sprays: Sequence[SprayConfig],
    start: Stippled | None = None,
) -> Stippled:
    """Every layer's holes: stippled under its own can (``sprays``, the plan's), with its windows (not refined)."""
    # Each layer's tone is chosen under its own paint's can (spray.profile).
    jobs = layer_jobs(cfg, sprays)
    sets, tones, windows = _holes(run, cfg, layers, picture_mm, tiling, jobs, start)
    dark_end = tuple(
        _dark_end(job, alpha, ds.amount(job.spray.amount), w.mask)
        for job, alpha, ds, w in zip(jobs, layers.alphas, sets, windows, strict=True)
    )
    sets = [
        with_windows(ds, w.polygons, cfg.stipple.sizes.window_web_mm)
        for ds, w in zip(sets, windows, strict=True)
    ]
    return Stippled(sets, tones, windows, dark_end)


def _holes(
    run: Run,
    cfg: JobConfig,
    layers: Layers,
    picture_mm: tuple[float, float],
    tiling: TileGrid,
    jobs: list[JobConfig],
    start: Stippled | None = None,
) -> tuple[list[DotSet], Any, list[Any]]:
    """Every layer's holes as stippled, before the refinement: ``(sets, tones, windows)``.

    The stippler reads no ``refine`` setting, so the plate-design trials' unrefined screen and their
    refined trial of the same design stipple alike: the holes are kept by the config without its
    ``refine`` section, and the refined trial starts from the screen's (on the bundled example two
    of its six stipples). ``start``: :func:`stippled`'s.
    """

    def make() -> tuple[list[DotSet], Any, list[Any]]:
        with run.stage("stipple"):
            tasks, windows, hole_alphas = _tasks(run, cfg, layers, tiling, picture_mm, jobs, start)
            sets, tones = stipple_layers(
                tasks, hole_alphas, tiling, lambda i, k: run.seed_for("stipple", i, k), run.tasks.map
            )
        return sets, tones, windows

    key = ("holes", cfg.model_dump_json(exclude={"refine"}), id(layers), picture_mm, repr(tiling))
    return cast("tuple[list[DotSet], Any, list[Any]]", run.keep(key, make)[0])


def layer_jobs(cfg: JobConfig, sprays: Sequence[SprayConfig]) -> list[JobConfig]:
    """The job config each layer is stippled under: ``cfg`` with the layer's spray settings."""
    return [cfg if sp is cfg.spray else cfg.model_copy(update={"spray": sp}) for sp in sprays]


def _tasks(
    run: Run,
    cfg: JobConfig,
    layers: Layers,
    tiling: TileGrid,
    picture_mm: tuple[float, float],
    jobs: list[JobConfig],
    start: Stippled | None = None,
) -> tuple[list[StippleTask], list[Any], np.ndarray]:
    """One stipple task per layer (under its own can: ``jobs``), its windows and the opacities left to the holes.

    With ``start`` (another design's holes of the same layers) a one-piece layer's Lloyd starts from its holes there.
    """
    # One task per layer (on a cluster the layers stipple side by side); each layer's
    # generator comes from the seed, so any number of workers gives the same holes.
    # The colour weights only steer the choice of each layer's spray time.
    weights = (
        coat_contrast(layers.primer, layers.colours, layers.alphas)
        if cfg.chooses_spray_time
        else [None] * layers.count
    )
    # Hybrid plates: each layer's wide solid regions become windows; the holes take the rest.
    windows, closed = layer_windows(cfg, layers, tiling, picture_mm, jobs)
    warm = start is not None and len(tiling.tiles) == 1 and len(start.sets) == layers.count
    starts = [ds.xy_mm for ds in start.sets] if start is not None and warm else [None] * layers.count
    tasks = [
        StippleTask(
            alpha,
            layers.mm_per_px,
            jobs[i],
            run.rng_for("stipple", i),
            weights[i],
            closed[i],
            windows[i].mask if closed[i] is not None else None,
            starts[i],
        )
        for i, alpha in enumerate(layers.alphas)
    ]
    hole_alphas = np.stack(
        [a if c is None else np.where(c, 0.0, a) for a, c in zip(layers.alphas, closed, strict=True)]
    ).astype(layers.alphas.dtype, copy=False)
    return tasks, windows, hole_alphas


def layer_windows(
    cfg: JobConfig,
    layers: Layers,
    tiling: TileGrid,
    picture_mm: tuple[float, float],
    jobs: list[JobConfig] | None = None,
) -> tuple[list[Any], list[Any]]:
    """Every layer's windows (:mod:`stencil_cad.hardstencil.windows`) and where its holes may not go.

    A window stays inside one tile's core; two tiles' windows meet at their seam.

    Returns:
        ``(windows per layer, per layer an (H, W) bool mask closed to holes or None)``.
    """
    from ..hardstencil.windows import tile_windows
    from ..stipple.windows import closed_to_holes

    s = layers.mm_per_px
    keepouts = cfg.stipple.design_rules(*picture_mm).keepouts
    cores = [t.core for t in tiling.tiles]
    clear = cfg.stipple.hole_floor_mm + cfg.stipple.sizes.web_mm
    # Each window's edge is pulled in by its own paint's blur (spray.profile).
    jobs = jobs or [cfg] * layers.count
    windows = [
        tile_windows(a, s, cfg.stipple, cores, picture_mm, keepouts, window_inset_mm(job))
        for a, job in zip(layers.alphas, jobs, strict=True)
    ]
    closed = [closed_to_holes(w.mask, s, clear) if w.polygons else None for w in windows]
    for i, w in enumerate(windows):
        if w.polygons:
            log.info(
                "%s: %d window(s), %.0f mm² open", layer_stem(i), len(w.polygons), w.report["window_area_mm2"]
            )
    return windows, closed


def window_inset_mm(cfg: JobConfig) -> float:
    """How far a window's edge stays inside its solid region: the stand-off blur's sigma, in mm.

    A window running right to the region's edge threw its blurred coat past it: on the generated
    logo the white around the shapes came out pink and grey, and the hybrid plates scored worse
    than holes alone. Under the paper's model (no stand-off) no inset.
    """
    from ..simulate.physical import SprayGeometry, spread_sigma_mm

    geometry = SprayGeometry.for_job(cfg)
    return 0.0 if geometry is None else float(spread_sigma_mm(cfg.spray, geometry.standoff_mm))


def _dark_end(
    cfg: JobConfig, alpha: np.ndarray, spray_time: float, windows: np.ndarray | None = None
) -> DarkEnd:
    """How much of a layer is darker than its holes can spray at its spray time (its windows left out).

    The darkest mean opacity is that of the densest pattern the rules allow, with holes up to
    the refinement's largest radius when it is on (the stippler's otherwise), measured with
    the spray model (:func:`stencil_cad.simulate.tone.tone_response`).
    """
    from ..simulate import tone

    curve = tone.plate_response(cfg, spray_time)
    top = curve.max_opacity
    a = np.asarray(alpha, dtype=np.float64)
    over = a > top + 1e-6
    if windows is not None:
        over &= ~windows
    return DarkEnd(
        darkest_sprayable=round(top, 4),
        unreachable_share=round(float(over.mean()), 4),
        unreachable_by=round(float((a[over] - top).mean()), 4) if over.any() else 0.0,
    )
