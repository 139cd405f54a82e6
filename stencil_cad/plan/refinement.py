"""The refinement as the job runs it: the holes moved and resized against the spray model, whole or tile by tile.

What the refine stage computes (:func:`refine_holes`), with the settings it reads from the config;
:func:`stencil_cad.plan.holes.refined` keeps its result for the run. It writes no file.
"""

from __future__ import annotations

import logging
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..model import DotSet, Layers, Picture
from ..output import plain as _plain
from ..record import Run
from .picture import source_reference
from .plan import Plan

if TYPE_CHECKING:
    from ..config import JobConfig
    from ..config.spray import SprayConfig
    from ..simulate.physical import SprayGeometry

log = logging.getLogger(__name__)


def refine_holes(
    run: Run,
    plan: Plan,
    layers: Layers,
    dotsets: list[DotSet],
    picture: Picture | None = None,
    stop_after: int | None = None,
) -> tuple[list[DotSet], dict[str, Any]]:
    """Refine every layer's holes against the spray model so the composite matches the picture.

    The objective lives on the simulation grid, its eye filter is the viewer's at
    ``view.distance_m``, and the holes keep the stipple rules (the largest radius is
    ``refine.max_radius_factor`` times the hole floor), all read from ``plan``'s config. A mural (a tiling of several tiles)
    is refined tile by tile (:mod:`stencil_cad.mural.refine`), each tile a task. A hybrid
    plate's windows (each DotSet's ``windows``) spray with the holes and stay fixed; the holes
    refined too close to one are left out. With ``stop_after``, the refinement stops after that
    many of its steps (:class:`stencil_cad.stipple.refine.RefineSettings`).

    Returns:
        ``(holes, report)``: every layer's refined holes, and the refinement's figure ``refine``
        (which the recorder records: :func:`stencil_cad.pipeline.recorder.record_refine`).
    """
    from .. import resolution
    from ..simulate import spray
    from ..simulate.physical import SprayGeometry

    cfg, picture_mm = plan.cfg, plan.picture_mm
    # The simulation's grid: with ``size.px_per_mm: auto`` it follows the dots' spray sigma
    # (8x fewer pixels than 4 px/mm for FDM holes, which keeps a mural's refinement in memory).
    grid_mm = resolution.sim_mm_per_px(cfg) or 1.0 / cfg.spray.px_per_mm
    shape = spray.sim_shape(layers.alphas.shape[1:], layers.mm_per_px, grid_mm)
    # The picture the simulation is scored against: the source image on the simulation grid.
    target = source_reference(cfg, picture, layers, shape, grid_mm)
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
        out, report = mural_refine.refine_layers(
            problem, tiling, dotsets, cfg, run.tasks.map, progress=lambda it, total: bar.update(1)
        )
    from ..stipple.windows import with_windows

    web = cfg.stipple.sizes.window_web_mm
    return [with_windows(ds, w, web) for ds, w in zip(out, windows, strict=True)], _plain(report)


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
