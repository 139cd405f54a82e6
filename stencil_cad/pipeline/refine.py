"""The refine stage's glue: the stippled holes moved and resized against the spray model (:mod:`stencil_cad.plan.holes`)."""

from __future__ import annotations

import logging

from ..model import DotSet, Layers, Picture
from ..plan.holes import Stippled, refined
from ..plan.plan import Plan
from ..record import Run

log = logging.getLogger(__name__)


def stage_refine(
    run: Run, plan: Plan, layers: Layers, made: Stippled, picture: Picture | None = None
) -> list[DotSet]:
    """The stipple stage's holes ``made`` refined towards ``picture`` and clear of a mural's posts; figure ``refine``.

    With ``refine.enabled`` the holes are refined against the spray model (whole, or a mural tile by
    tile: :func:`stencil_cad.plan.refinement.refine_holes`) towards ``picture`` (the
    decomposition's composite without one); the holes the plate-design trials refined for this
    design are reused.
    """
    done, reused = refined(run, plan, layers, made, picture)
    if reused and done.report is not None:
        log.info("refine: the holes the plate-design trials refined for this design, reused")
        with run.stage("refine"):
            run.figures.refine = done.report
    return done.sets
