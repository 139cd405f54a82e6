"""The wall's stand-off chosen for the picture, when the config leaves it to the job (``wall.standoff_mm: null``).

The process's stand-off (10 mm for SLA and laser holes, 15 for FDM) is where plates of holes
score best on photos: their dots blend. On a picture whose paint goes mostly through windows (a
logo, flat-colour art) the windows' edges carry the error, and they stay sharp only low down, as
a hard stencil's do: the generated logo of the quality benchmark scored 2.00 at 10 mm, 0.92 at
4 mm and 0.88 at 1 mm (S-CIELAB at 1 m, SLA rules), while the generated dark sky, whose paint also
goes mostly through windows but whose glows are holes, scored 1.84, 2.52 at 10 and 4 mm.

So a share of the paint through windows decides whether to look further, and the stand-offs are
then ranked by what they spray: each candidate's plates are stippled (without the refinement) and
sprayed in simulation, and scored at the viewing distance like the job's result. Photos (windows
carry well under :data:`WINDOW_SHARE` of their paint) keep the process's stand-off and pay nothing.
"""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from ..config import JobConfig
from ..figures import StandoffFigures
from ..model import Layers, Picture
from ..record import Run

if TYPE_CHECKING:
    from ..output import OutputDir

log = logging.getLogger(__name__)

#: Share of the layers' paint (opacity summed over layers and pixels) that must go through windows
#: before lower stand-offs are tried: the logo and the dark sky 0.97, the river of rocket 0.39,
#: coffee 0.22, the bundled example, astronaut and chelsea under 0.01.
WINDOW_SHARE = 0.5
#: The lower stand-offs tried beside the process's, in mm: a hard stencil's (1 mm) and one between.
TRIAL_STANDOFFS_MM = (1.0, 4.0)


class _Discard:
    """An output folder that keeps nothing: the trial stipples write no files."""

    def __getattr__(self, name: str) -> Any:
        def discard(*args: Any, **kwargs: Any) -> None:
            return None

        return discard


def window_share(cfg: JobConfig, layers: Layers, tiling: Any, picture_mm: tuple[float, float]) -> float:
    """Share of the layers' paint that goes through their windows, in [0, 1].

    The paint is each layer's opacity above ``stipple.opacity_threshold``, summed over layers and
    pixels; windows as the stipple stage finds them (:func:`stencil_cad.pipeline.stipple.layer_windows`).
    """
    from .stipple import layer_windows

    windows, _ = layer_windows(cfg, layers, tiling, picture_mm)
    paint = through = 0.0
    for alpha, w in zip(layers.alphas, windows, strict=True):
        a = np.where(alpha < cfg.stipple.opacity_threshold, 0.0, np.asarray(alpha, dtype=np.float64))
        paint += float(a.sum())
        through += float(a[w.mask].sum())
    return through / paint if paint > 0.0 else 0.0


def _trial_score(
    run: Run, cfg: JobConfig, layers: Layers, picture_mm: tuple[float, float], picture: Picture | None
) -> float:
    """S-CIELAB at the viewing distance of the plates stippled (not refined) and sprayed at ``cfg``'s stand-off."""
    from .. import resolution, simulate
    from ..simulate.physical import SprayGeometry
    from ..simulate.scielab import scielab
    from ..stipple.made import made_dots
    from .picture import source_reference
    from .profiles import layer_sprays
    from .stipple import stage_stipple

    trial_cfg = cfg.model_copy(update={"refine": cfg.refine.model_copy(update={"enabled": False})})
    # The trial's stipple writes nothing: an output folder that discards every call stands in.
    trial = Run(cfg=trial_cfg, out=cast("OutputDir", _Discard()), quiet=True, executor=run.executor)
    dotsets = stage_stipple(trial, layers, picture_mm, picture)
    made = [made_dots(d, cfg.stipple, picture_mm) for d in dotsets]
    sim = simulate.simulate(
        layers,
        made,
        cfg.spray,
        resolution.sim_mm_per_px(cfg),
        geometry=SprayGeometry.for_job(cfg),
        layer_sprays=layer_sprays(trial, layers.colours),
    )
    ref = source_reference(cfg, picture, layers, sim.composite.shape[:2], sim.mm_per_px)
    return float(scielab(ref, sim.composite, sim.mm_per_px, cfg.view.distance_m))


def choose_standoff(
    run: Run, layers: Layers, picture_mm: tuple[float, float], picture: Picture | None
) -> JobConfig:
    """The job's config with its wall at the stand-off this picture's plates spray best from.

    Only when the config leaves the stand-off to the job (:attr:`JobConfig.chooses_standoff`), on a
    one-plate job whose windows carry at least :data:`WINDOW_SHARE` of the paint; otherwise the
    config comes back as it is. The run calls it for one-plate jobs only. Records figure
    ``standoff``: the share, the trials' scores and the choice. Sets ``run.cfg``.
    """
    from ..mural import TileGrid

    cfg = run.cfg
    if not cfg.chooses_standoff:
        return cfg
    default = float(cfg.wall.standoff_mm[0])
    with run.stage("standoff"):
        share = window_share(cfg, layers, TileGrid.whole(*picture_mm), picture_mm)
        best, trials = default, {}
        if share >= WINDOW_SHARE:
            scores = {
                g: _trial_score(run, cfg.with_standoff(g), layers, picture_mm, picture)
                for g in sorted({default, *TRIAL_STANDOFFS_MM})
            }
            best = min(scores, key=lambda g: (scores[g], -g))
            trials = {f"{g:g}": round(v, 3) for g, v in scores.items()}
            if best != default:
                log.info(
                    "wall: %g mm stand-off (windows carry %.0f %% of the paint; S-CIELAB of the unrefined "
                    "plates %s)",
                    best,
                    100.0 * share,
                    ", ".join(f"{v:.2f} at {g:g} mm" for g, v in scores.items()),
                )
                run.cfg = cfg.with_standoff(best)
    run.figures.standoff = StandoffFigures(
        window_share=round(share, 3),
        standoff_mm=best,
        trials=trials,
        reason=(
            "left to the job: the process's stand-off"
            if share < WINDOW_SHARE
            else "left to the job: windows carry most of the paint, so the stand-off whose plates score best"
        ),
    )
    return run.cfg
