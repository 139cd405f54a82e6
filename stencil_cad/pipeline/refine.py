"""The refine stage's glue: the stippled holes moved and resized against the spray model (:mod:`stencil_cad.plan.holes`)."""

from __future__ import annotations

import logging

from ..model import Layers, Picture
from ..plan.holes import Refined, Stippled, refined
from ..plan.plan import Plan
from ..record import Run

log = logging.getLogger(__name__)


def stage_refine(
    run: Run, plan: Plan, layers: Layers, made: Stippled, picture: Picture | None = None
) -> tuple[Refined, bool]:
    """The stipple stage's holes ``made`` refined towards ``picture`` and clear of a mural's posts: ``(holes, whether reused)``.

    With ``refine.enabled`` the holes are refined against the spray model (whole, or a mural tile by
    tile: :func:`stencil_cad.plan.refinement.refine_holes`, which records figure ``refine`` as it
    runs) towards ``picture`` (the decomposition's composite without one); the holes the
    plate-design trials refined for this design are reused, and the recorder records their figure.
    """
    done, reused = refined(run, plan, layers, made, picture)
    if reused and done.report is not None:
        log.info("refine: the holes the plate-design trials refined for this design, reused")
    return done, reused
