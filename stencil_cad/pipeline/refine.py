"""The refine stage's glue: the stippled holes moved and resized against the spray model (:mod:`stencil_cad.plan.holes`)."""

from __future__ import annotations

import logging
from typing import TYPE_CHECKING

from ..model import DotSet, Layers, Picture
from ..plan.holes import Stippled, refined
from ..record import Run

if TYPE_CHECKING:
    from .. import mural

log = logging.getLogger(__name__)


def stage_refine(
    run: Run,
    layers: Layers,
    made: Stippled,
    picture_mm: tuple[float, float],
    picture: Picture | None = None,
    grid: mural.TileGrid | None = None,
) -> list[DotSet]:
    """The stipple stage's holes ``made`` refined towards ``picture`` and clear of a mural's posts; figure ``refine``.

    With ``refine.enabled`` the holes are refined against the spray model (whole, or a mural tile by
    tile: :func:`stencil_cad.plan.refinement.refine_holes`) towards ``picture`` (the
    decomposition's composite without one); the holes the plate-design trials refined for this
    design are reused.
    """
    done, reused = refined(run, layers, made, picture_mm, picture, grid)
    if reused and done.report is not None:
        log.info("refine: the holes the plate-design trials refined for this design, reused")
        with run.stage("refine"):
            run.figures.refine = done.report
    return done.sets
