"""The refinement as the job runs it: the holes moved and resized against the spray model, whole or tile by tile.

What the refine stage computes (:func:`refine_holes`), with the settings it reads from the config;
:func:`stencil_cad.plan.holes.refined` keeps its result for the run. It writes no file.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model import DotSet, Layers, Picture
from ..output import plain as _plain
from ..record import Run
from .picture import kept_reference
from .plan import Plan

if TYPE_CHECKING:
    from ..config import JobConfig
    from ..config.spray import SprayConfig
    from ..simulate.physical import SprayGeometry
    from ..stipple.refine import Paused

log = logging.getLogger(__name__)

#: Refinement pixels per sigma of the narrowest hole deposit (:func:`refine_grid`). The bundled
#: example (sigma 0.70 mm from its 5 mm wall) refined on 0.25 mm pixels (the simulation's 4 px/mm),
#: 1/3, 0.4 and 0.5 mm: S-CIELAB at 1 m 2.676, 2.667, 2.677 and 2.693 (at 2 m 1.653, 1.646, 1.653,
#: 1.668), the job's CPU about 76 against 52 CPU-seconds at 0.4 mm (three runs of each, alternated,
#: ``/usr/bin/time stencil-cad run``). 1.75 takes 0.4 mm there; 1.4 (0.5 mm) starts to cost.
REFINE_PX_PER_SIGMA = 1.75
#: How far from a whole number of pixels the picture's height may be on the refinement's grid. The
#: example on 0.333 mm pixels (450.45 across its 150 mm, rounded to 450) scored 2.81 where exactly
#: 1/3 mm scored 2.67: the target stretched 0.1 % over the grid put the holes 0.15 mm off at its edge.
GRID_SLACK_PX = 0.02


def refine_holes(
    run: Run,
    plan: Plan,
    layers: Layers,
    dotsets: list[DotSet],
    picture: Picture | None = None,
    stop_after: int | None = None,
    resume: Paused | None = None,
    on_pause: Callable[[Paused], None] | None = None,
) -> tuple[list[DotSet], dict[str, Any]]:
    """Refine every layer's holes against the spray model so the composite matches the picture.

    The objective lives on the simulation grid, its eye filter is the viewer's at
    ``view.distance_m``, and the holes keep the stipple rules (the largest radius is
    ``refine.max_radius_factor`` times the hole floor), all read from ``plan``'s config. A mural (a tiling of several tiles)
    is refined tile by tile (:mod:`stencil_cad.mural.refine`), each tile a task. A hybrid
    plate's windows (each DotSet's ``windows``) spray with the holes and stay fixed; the holes
    refined too close to one are left out. With ``stop_after``, the refinement stops after that
    many of its steps (:class:`stencil_cad.stipple.refine.RefineSettings`), and ``on_pause`` is
    called with its state there; ``resume`` carries on such a refinement of a 1 × 1 tiling to its end
    (:class:`stencil_cad.stipple.refine.Paused`).

    Returns:
        ``(holes, report)``: every layer's refined holes, and the refinement's figure ``refine``
        (which the recorder records: :func:`stencil_cad.pipeline.recorder.record_refine`).
    """
    from ..simulate import spray
    from ..simulate.physical import SprayGeometry

    cfg, picture_mm = plan.cfg, plan.picture_mm
    shape, grid_mm = refine_grid(plan, layers)
    # The picture the simulation is scored against: the source image on the simulation grid (kept in the run).
    target = kept_reference(run, cfg, picture, layers, shape, grid_mm)
    rules = cfg.stipple.design_rules(*picture_mm)
    rc = cfg.refine
    settings = replace(refine_settings(cfg), stop_after=stop_after)
    alpha_targets = np.stack([spray.resample(a, shape) for a in layers.alphas]) if layers.count else None

    from ..mural import refine as mural_refine
    from ..simulate.cans import CAP_PRIOR, layer_can_prior

    geometry = SprayGeometry.for_job(cfg)
    # refine.cans: prior refines for the expected error over the prior's caps (without a measured
    # can); each layer sprays with its own paint's profile, and a measured layer keeps its can.
    sprays = plan.sprays
    cans = layer_can_prior(sprays, CAP_PRIOR) if rc.cans == "prior" else [("nominal", sprays)]
    kernels = [tuple(mural_refine.HoleKernels(sp, geometry) for sp in per_layer) for _, per_layer in cans]

    times = [ds.amount(cfg.spray.amount) for ds in dotsets]
    windows = [ds.windows for ds in dotsets]
    fixed = windows_transmittance(sprays, windows, times, shape, grid_mm, geometry)
    problem = mural_refine.Problem(
        target=target,
        alpha_targets=alpha_targets,
        mm_per_px=grid_mm,
        primer=layers.primer,
        colours=layers.colours,
        rules=[rules] * layers.count,
        kernels=tuple(kernels),
        spray_times=times,
        settings=settings,
        fixed_trans=fixed,
    )
    tiling = plan.grid
    with run.stage("refine"), run.bar(rc.iterations, "refine") as bar:
        bar.update(0 if resume is None else resume.step)
        out, report = mural_refine.refine_layers(
            problem,
            tiling,
            dotsets,
            cfg,
            run.tasks.map,
            progress=lambda it, total: bar.update(1),
            resume=resume,
            on_pause=on_pause,
        )
    from ..stipple.windows import with_windows

    web = cfg.stipple.sizes.window_web_mm
    return [with_windows(ds, w, web) for ds, w in zip(out, windows, strict=True)], _plain(report)


def refine_grid(plan: Plan, layers: Layers) -> tuple[tuple[int, int], float]:
    """The refinement's grid, ``(shape, pixel in mm)``: as coarse as the holes' deposits allow.

    The refinement moves holes whose deposits are Gaussians no narrower than the smallest hole's
    under the job's own sprays (its paints' profiles, at the wall's stand-off), so the composite it
    can change, and the part of the error it can answer, are sampled well at
    :data:`REFINE_PX_PER_SIGMA` pixels per that sigma; the grid is never finer than the simulation's
    (``spray.px_per_mm``, or the auto grid). The pixel is then made a little finer where needed so
    that whole pixels span the picture's width and height both (:func:`exact_grid`): the target is
    the source image stretched over the grid, and a grid a fraction of a pixel short of the picture
    misplaces the holes against it.
    """
    from .. import resolution
    from ..simulate import spray
    from ..simulate.physical import SprayGeometry

    cfg = plan.cfg
    fine = resolution.sim_mm_per_px(cfg) or 1.0 / cfg.spray.px_per_mm
    geometry = SprayGeometry.for_job(cfg)
    r = cfg.stipple.sizes.radius_mm
    sigma = min(float(spray.hole_kernels(r, sp, sp.amount, geometry=geometry)[0]) for sp in plan.sprays)
    h, w = layers.alphas.shape[1:]
    return exact_grid(
        (h * layers.mm_per_px, w * layers.mm_per_px), max(fine, sigma / REFINE_PX_PER_SIGMA), fine
    )


def exact_grid(
    size_mm: tuple[float, float], want_mm: float, finest_mm: float
) -> tuple[tuple[int, int], float]:
    """The coarsest square pixel up to ``want_mm`` (not under ``finest_mm``) whose whole pixels span ``size_mm``.

    Pixels across the width go up from the fewest that ``want_mm`` allows until the height is a
    whole number of them too, to within :data:`GRID_SLACK_PX` of a pixel; past the count of
    ``finest_mm``'s pixels, that one (the simulation's own grid: :func:`stencil_cad.simulate.spray.sim_shape`).
    """
    from ..simulate.spray import sim_shape

    height, width = size_mm
    fine = sim_shape(size_mm, 1.0, finest_mm)  # the simulation's own grid, rounded as it rounds
    for n in range(max(1, math.ceil(width / want_mm - 1e-9)), fine[1]):
        rows = height * n / width
        if abs(rows - round(rows)) <= GRID_SLACK_PX:
            return (max(1, int(round(rows))), n), width / n
    return fine, finest_mm


def refine_settings(cfg: JobConfig) -> Any:
    """The refinement's settings from the ``refine`` section and the viewer's filters at ``view.distance_m``."""
    from ..simulate import scielab
    from ..stipple import refine

    rc = cfg.refine
    return refine.RefineSettings(
        iterations=rc.iterations,
        step_mm=rc.step_mm,
        radius_step_mm=rc.radius_step_mm,
        max_radius_mm=cfg.refined_max_radius_mm,
        add_remove_every=rc.add_remove_every,
        eye_sigma_mm=scielab.smallest_sigma_mm(cfg.view.distance_m),
        layer_weight=rc.layer_weight,
        view=(
            refine.ViewFilters(scielab.filters_mm(cfg.view.distance_m), rc.pixel_weight)
            if rc.objective == "viewer"
            else None
        ),
    )


def windows_transmittance(
    sprays: list[SprayConfig],
    windows: list[Any] | None,
    times: list[float],
    shape: tuple[int, int],
    grid_mm: float,
    geometry: SprayGeometry | None,
) -> np.ndarray | None:
    """``(L, H, W)`` transmittance of each layer's windows (sprayed with its own can), or None without windows."""
    if not windows or not any(len(w) for w in windows):
        return None
    from ..simulate.opacity import windows_opacity

    return np.stack(
        [
            1.0 - windows_opacity(w, shape, grid_mm, sp, spray_time=t, geometry=geometry)
            for w, t, sp in zip(windows, times, sprays, strict=True)
        ]
    )
