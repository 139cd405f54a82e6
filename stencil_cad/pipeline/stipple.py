"""The stipple stage's glue: the holes of every plate (:mod:`stencil_cad.plan.holes`), not refined yet.

:func:`stage_stipple` stipples (not refined); the recorder (:mod:`stencil_cad.pipeline.recorder`)
records the dark-end and windows figures, and once the refine stage has moved the holes writes them
(``dots_N.csv``, the windows) with the stipple figures. The plate previews and the spray order are
the paints stage's (:mod:`stencil_cad.pipeline.paints`).
"""

from __future__ import annotations

import logging

from ..model import Layers
from ..plan.holes import Stippled, stippled
from ..plan.plan import Plan
from ..record import Run

log = logging.getLogger(__name__)


def stage_stipple(run: Run, plan: Plan, layers: Layers) -> tuple[Stippled, bool]:
    """Stipple every layer's opacity into holes under the design rules (not refined yet): ``(holes, whether reused)``.

    With ``stipple.tone: response`` the density comes from the spray response
    (:mod:`stencil_cad.simulate.tone`); every setting is ``plan``'s. With ``spray.calibrate: spray_time`` each layer also
    gets its own spray time, saved in ``spray.json`` and in the dots' report. The refine stage
    (:func:`stencil_cad.pipeline.refine.stage_refine`) takes the holes on; the recorder writes them.
    """
    made, reused = stippled(run, plan, layers)
    if reused:
        log.info("stipple: the holes the plate-design trials made for this design, reused")
    return made, reused
