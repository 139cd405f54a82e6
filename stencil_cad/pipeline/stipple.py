"""The stipple stage's glue: the holes of every plate (:mod:`stencil_cad.plan.holes`), their figures and saved dots.

:func:`stage_stipple` stipples (not refined), :func:`record_stipple` records the dark-end and windows figures; once the
refine stage has moved the holes, :func:`save_dots` writes them (``dots_N.csv``, the windows) and
records the stipple figures. The plate previews and the spray order are the paints stage's
(:mod:`stencil_cad.pipeline.paints`).
"""

from __future__ import annotations

import logging

from ..figures import LayerStipple, LayerWindows
from ..model import DotSet, Layers
from ..output import plain as _plain
from ..plan.holes import Stippled, stippled
from ..plan.names import dots_name, layer_stem, windows_name
from ..plan.plan import Plan
from ..record import Run

log = logging.getLogger(__name__)


def stage_stipple(run: Run, plan: Plan, layers: Layers) -> tuple[Stippled, bool]:
    """Stipple every layer's opacity into holes under the design rules (not refined yet): ``(holes, whether reused)``.

    With ``stipple.tone: response`` the density comes from the spray response
    (:mod:`stencil_cad.simulate.tone`); every setting is ``plan``'s. With ``spray.calibrate: spray_time`` each layer also
    gets its own spray time, saved in ``spray.json`` and in the dots' report. The refine stage
    (:func:`stencil_cad.pipeline.refine.stage_refine`) takes the holes on; :func:`save_dots` writes them.
    """
    made, reused = stippled(run, plan, layers)
    if reused:
        log.info("stipple: the holes the plate-design trials made for this design, reused")
    return made, reused


def record_stipple(run: Run, made: Stippled) -> None:
    """Figures ``dark_end`` and ``windows`` of the stipple stage's holes ``made``."""
    run.figures.dark_end = made.dark_end
    run.figures.windows = tuple(LayerWindows(i + 1, _plain(w.report)) for i, w in enumerate(made.windows))


def save_dots(run: Run, made: Stippled, sets: list[DotSet]) -> None:
    """Write every plate's holes ``sets`` (``made``'s, refined) and windows; figures ``stipple`` and ``tone_calibration``."""
    from ..exchange.dots_csv import dots_to_csv, windows_to_json

    for i, ds in enumerate(sets):
        run.out.write_text(dots_name(i), dots_to_csv(ds))
        if ds.windows:
            run.out.write_text(windows_name(i), windows_to_json(ds.windows))
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
    if made.tones:
        run.figures.tone_calibration = made.tones
