"""The stipple stage's glue: one task per layer (or per tile), the tone choice, the dark-end figures, the saved dots."""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..config import JobConfig, SprayConfig
from ..figures import DarkEnd, LayerStipple, LayerWindows
from ..model import DotSet, Layers, Picture, coat_contrast
from ..mural import TileGrid, clear_post_sites, post_plan
from ..mural.stipple import StippleTask, stipple_layers
from ..names import dots_png
from ..output import plain as _plain
from ..record import Run
from ..stipple.windows import with_windows
from .names import dots_name, layer_stem, windows_name
from .paints import plate_cards, write_spray_order
from .profiles import layer_sprays
from .refine import stage_refine

if TYPE_CHECKING:
    from .. import mural

log = logging.getLogger(__name__)


def stage_stipple(
    run: Run,
    layers: Layers,
    picture_mm: tuple[float, float],
    picture: Picture | None = None,
    grid: mural.TileGrid | None = None,
) -> list[DotSet]:
    """Stipple every layer's opacity into holes, enforce the design rules, refine, save CSV + previews.

    With ``stipple.tone: response`` the density comes from the spray response
    (:mod:`stencil_cad.simulate.tone`), and with ``spray.calibrate: spray_time`` each layer also
    gets its own spray time, saved in ``spray.json`` and in the dots' report. With
    ``refine.enabled`` the holes are then refined against the spray model
    (:func:`stage_refine`) towards ``picture`` (the decomposition's composite without one).
    """
    from ..exchange.dots_csv import dots_to_csv, windows_to_json

    made, reused = stippled(run, layers, picture_mm, picture, grid)
    cfg = run.cfg
    if reused:
        log.info("stipple: the holes the plate-design trials made for this design, reused")
        if made.refine is not None:
            with run.stage("refine"):
                run.figures.refine = made.refine
    sets, tones, windows = made.sets, made.tones, made.windows
    run.figures.dark_end = made.dark_end
    run.figures.windows = tuple(LayerWindows(i + 1, _plain(w.report)) for i, w in enumerate(windows))
    with run.stage("stipple"):
        cards = plate_cards(run, layers.colours, picture_mm, sets)
        for i, ds in enumerate(sets):
            run.out.write_text(dots_name(i), dots_to_csv(ds))
            if ds.windows:
                run.out.write_text(windows_name(i), windows_to_json(ds.windows))
            run.out.write_png(dots_png(layer_stem(i)), cards[i])
        write_spray_order(run, layers.primer, layers.colours, [ds.amount(cfg.spray.amount) for ds in sets])
    run.figures.stipple = tuple(
        LayerStipple(layer=i + 1, dots=len(ds), report=_plain(ds.report), spray_time=ds.spray_time)
        for i, ds in enumerate(sets)
    )
    for i, ds in enumerate(sets):
        if len(ds) == 0 and not ds.windows:
            removed = {k: v for k, v in ds.report.items() if k.startswith("removed_") and v}
            log.warning(
                "%s has no holes (%s): its plate sprays nothing; lower stipple.edge_margin_mm or "
                "stipple.opacity_threshold, enlarge the picture, or use fewer decompose.layers",
                layer_stem(i),
                ", ".join(f"{k} {v}" for k, v in removed.items()) or "no ink above the opacity threshold",
            )
    if tones:
        run.figures.tone_calibration = tones
    return sets


def stippled(
    run: Run,
    layers: Layers,
    picture_mm: tuple[float, float],
    picture: Picture | None = None,
    grid: mural.TileGrid | None = None,
) -> tuple[_Stippled, bool]:
    """What the stipple stage computes, without its files: ``(the holes and figures, whether kept)``.

    ``stipple.dots`` is capped first (:func:`bound_dots`, which may set ``run.cfg``). The plate-design
    trials call this and the job's stage then writes what they made for the design it keeps: the
    same config, layers, picture and tiling give the same holes, so they are kept in ``run.kept``
    (the second value says they were).
    """
    bound_dots(run, picture_mm)
    tiling = grid or TileGrid.whole(*picture_mm)
    key = ("stipple", run.cfg.model_dump_json(), id(layers), id(picture), picture_mm, repr(tiling))
    made, kept = run.keep(key, lambda: _stippled(run, layers, picture_mm, picture, tiling))
    return cast("_Stippled", made), kept


@dataclass(frozen=True)
class _Stippled:
    """What the stipple stage computes before it writes: the holes (refined), tones, windows, figures."""

    sets: list[DotSet]
    tones: Any
    windows: list[Any]
    dark_end: tuple[DarkEnd, ...]
    refine: Any


def _stippled(
    run: Run, layers: Layers, picture_mm: tuple[float, float], picture: Picture | None, tiling: TileGrid
) -> _Stippled:
    """Every layer's holes: stippled under its own can, with its windows, refined, clear of the posts."""
    cfg = run.cfg
    # Each layer's tone is chosen under its own paint's can (spray.profile).
    jobs = layer_jobs(cfg, layer_sprays(run, layers.colours))
    sets, tones, windows = _holes(run, layers, picture_mm, tiling, jobs)
    dark_end = tuple(
        _dark_end(job, alpha, ds.amount(job.spray.amount), w.mask)
        for job, alpha, ds, w in zip(jobs, layers.alphas, sets, windows, strict=True)
    )
    sets = [
        with_windows(ds, w.polygons, cfg.stipple.window_web_mm()) for ds, w in zip(sets, windows, strict=True)
    ]
    refine = None
    if cfg.refine.enabled:
        sets = stage_refine(run, layers, sets, picture_mm, picture, tiling)
        refine = run.figures.refine
    # A mural's plates stand on posts: the few holes a post would shade go before anything scores them.
    sets, _ = clear_post_sites(sets, tiling, post_plan(cfg, tiling))
    return _Stippled(sets, tones, windows, dark_end, refine)


def _holes(
    run: Run, layers: Layers, picture_mm: tuple[float, float], tiling: TileGrid, jobs: list[JobConfig]
) -> tuple[list[DotSet], Any, list[Any]]:
    """Every layer's holes as stippled, before the refinement: ``(sets, tones, windows)``.

    The stippler reads no ``refine`` setting, so the plate-design trials' unrefined screen and their
    refined trial of the same design stipple alike: the holes are kept by the config without its
    ``refine`` section, and the refined trial starts from the screen's (on the bundled example two
    of its six stipples).
    """

    def make() -> tuple[list[DotSet], Any, list[Any]]:
        with run.stage("stipple"):
            tasks, windows, hole_alphas = _tasks(run, layers, tiling, picture_mm, jobs)
            sets, tones = stipple_layers(
                tasks, hole_alphas, tiling, lambda i, k: run.seed_for("stipple", i, k), run.tasks.map
            )
        return sets, tones, windows

    key = ("holes", run.cfg.model_dump_json(exclude={"refine"}), id(layers), picture_mm, repr(tiling))
    return cast("tuple[list[DotSet], Any, list[Any]]", run.keep(key, make)[0])


def layer_jobs(cfg: JobConfig, sprays: Sequence[SprayConfig]) -> list[JobConfig]:
    """The job config each layer is stippled under: ``cfg`` with the layer's spray settings."""
    return [cfg if sp is cfg.spray else cfg.model_copy(update={"spray": sp}) for sp in sprays]


def _tasks(
    run: Run, layers: Layers, tiling: TileGrid, picture_mm: tuple[float, float], jobs: list[JobConfig]
) -> tuple[list[StippleTask], list[Any], np.ndarray]:
    """One stipple task per layer (under its own can: ``jobs``), its windows and the opacities left to the holes."""
    cfg = run.cfg
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
    tasks = [
        StippleTask(
            alpha,
            layers.mm_per_px,
            jobs[i],
            run.rng_for("stipple", i),
            weights[i],
            closed[i],
            windows[i].mask if closed[i] is not None else None,
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
    clear = cfg.stipple.hole_floor_mm + cfg.stipple.resolved_web_mm
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


def bound_dots(run: Run, picture_mm: tuple[float, float]) -> None:
    """Cap ``stipple.dots`` at the most holes that fit the picture under the design rules.

    Too many dots cost memory and time in the relaxation and are then removed by the
    rules anyway; the cap is named in a warning.
    """
    from ..bounds import max_dots

    cfg = run.cfg
    if cfg.stipple.dots is None:
        return
    most = max_dots(cfg.stipple, *picture_mm)
    if cfg.stipple.dots > most:
        log.warning(
            "stipple.dots %d cannot fit: at most %d holes of radius %g mm with %g mm webs fit in %.4g × %.4g mm; "
            "using %d (set stipple.dots ≤ %d, or null to derive it from the picture)",
            cfg.stipple.dots,
            most,
            cfg.stipple.hole_floor_mm,
            cfg.stipple.resolved_web_mm,
            picture_mm[0],
            picture_mm[1],
            most,
            most,
        )
        stipple = cfg.stipple.model_copy(update={"dots": most})
        run.cfg = cfg.model_copy(update={"stipple": stipple})
