"""The stipple stage's glue: one task per layer (or per tile), the tone choice, the dark-end figures, the saved dots."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

import numpy as np

from ..config import JobConfig
from ..model import DotSet, Layers, Picture, coat_contrast
from ..mural import TileGrid
from ..mural.stipple import StippleTask, stipple_layers
from ..output import plain as _plain
from ..record import Run
from .names import dots_name, layer_stem
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

    With ``stipple.tone: calibrated`` the density comes from the spray response
    (:mod:`stencil_cad.simulate.tone`), and with ``spray.calibrate: spray_time`` each layer also
    gets its own spray time, saved in ``spray.json`` and in the dots' report. With
    ``refine.enabled`` the holes are then refined against the spray model
    (:func:`stage_refine`) towards ``picture`` (the decomposition's composite without one).
    """
    from ..exchange.dots_csv import dots_to_csv

    bound_dots(run, picture_mm)
    cfg = run.cfg
    with run.stage("stipple"):
        # One task per layer (on a cluster the layers stipple side by side); each layer's
        # generator comes from the seed, so any number of workers gives the same holes.
        # The colour weights only steer the choice of each layer's spray time.
        weights = (
            coat_contrast(layers.primer, layers.colours, layers.alphas)
            if cfg.chooses_spray_time
            else [None] * layers.count
        )
        # Each layer's tone is chosen under its own paint's can (spray.profile).
        jobs = layer_jobs(cfg, layer_sprays(run, layers.colours))
        tasks = [
            StippleTask(alpha, layers.mm_per_px, jobs[i], run.rng_for("stipple", i), weights[i])
            for i, alpha in enumerate(layers.alphas)
        ]
        tiling = grid or TileGrid.whole(*picture_mm)
        sets, tones = stipple_layers(
            tasks, layers.alphas, tiling, lambda i, k: run.seed_for("stipple", i, k), run.tasks.map
        )
    run.figures["dark_end"] = [
        _dark_end(job, alpha, ds.amount(job.spray.amount))
        for job, alpha, ds in zip(jobs, layers.alphas, sets, strict=True)
    ]
    if cfg.refine.enabled:
        sets = stage_refine(run, layers, sets, picture_mm, picture, grid)
    with run.stage("stipple"):
        cards = plate_cards(run, layers.colours, picture_mm, sets)
        for i, ds in enumerate(sets):
            run.out.write_text(dots_name(i), dots_to_csv(ds))
            run.out.write_png(f"{layer_stem(i)}_dots.png", cards[i])
        write_spray_order(run, layers.primer, layers.colours, [ds.amount(cfg.spray.amount) for ds in sets])
    run.figures["stipple"] = [
        {"layer": i + 1, "dots": len(ds), **_plain(ds.report), "spray_time": ds.spray_time}
        for i, ds in enumerate(sets)
    ]
    for i, ds in enumerate(sets):
        if len(ds) == 0:
            removed = {k: v for k, v in ds.report.items() if k.startswith("removed_") and v}
            log.warning(
                "%s has no holes (%s): its plate sprays nothing; lower stipple.edge_margin_mm or "
                "stipple.opacity_threshold, enlarge the picture, or use fewer decompose.layers",
                layer_stem(i),
                ", ".join(f"{k} {v}" for k, v in removed.items()) or "no ink above the opacity threshold",
            )
    if tones:
        run.figures["tone_calibration"] = tones
    return sets


def layer_jobs(cfg: JobConfig, sprays: list) -> list[JobConfig]:
    """The job config each layer is stippled under: ``cfg`` with the layer's spray settings."""
    return [cfg if sp is cfg.spray else cfg.model_copy(update={"spray": sp}) for sp in sprays]


def _dark_end(cfg: JobConfig, alpha: np.ndarray, spray_time: float) -> dict:
    """How much of a layer is darker than its stencil can spray at its spray time.

    The darkest mean opacity is that of the densest pattern the rules allow, with holes up to
    the refinement's largest radius when it is on (the stippler's otherwise), measured with
    the spray model (:func:`stencil_cad.simulate.tone.tone_response`).
    """
    from ..simulate import tone
    from ..simulate.physical import SprayGeometry

    st = cfg.stipple
    floor = st.resolved_radius_mm
    r1 = st.resolved_max_radius_mm
    if cfg.refine.enabled:
        r1 = max(r1, cfg.refine.max_radius_factor * st.resolved_hole_min_r_mm)
    curve = tone.tone_response(
        floor,
        st.resolved_web_mm,
        cfg.spray,
        spray_time=spray_time,
        max_radius_mm=r1,
        spacing_factor=st.auto_spacing_factor,
        geometry=SprayGeometry.for_job(cfg),
    )
    top = curve.max_opacity
    a = np.asarray(alpha, dtype=np.float64)
    over = a > top + 1e-6
    return {
        "darkest_sprayable": round(top, 4),
        "unreachable_share": round(float(over.mean()), 4),
        "unreachable_by": round(float((a[over] - top).mean()), 4) if over.any() else 0.0,
    }


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
            cfg.stipple.resolved_hole_min_r_mm,
            cfg.stipple.resolved_web_mm,
            picture_mm[0],
            picture_mm[1],
            most,
            most,
        )
        stipple = cfg.stipple.model_copy(update={"dots": most})
        run.cfg = cfg.model_copy(update={"stipple": stipple})
