"""The one recorder of the stages: each stage's returned result written as files and recorded as figures.

A stage's glue computes and returns a frozen result (:mod:`stencil_cad.plan.results`, or its
figures); :mod:`stencil_cad.pipeline.run` calls the matching ``record_*`` here right after it, in
the order the job writes its files, so the file table and the manifest's sections keep their order.
Nothing here computes what a maker receives: it stages files through the output folder
(:mod:`stencil_cad.output`) and sets ``run.figures``. The manifest, the config copy and the
instruction sheet are :mod:`stencil_cad.pipeline.manifest`'s. A build's part files are staged here
as its tasks finish (:func:`record_parts`), so the simulation still runs while they build.
"""

from __future__ import annotations

import logging
from collections.abc import Iterable
from dataclasses import replace
from typing import Any

import numpy as np

from ..colour import to_hex
from ..figures import (
    BuildFigures,
    CansFigures,
    ComputeFigures,
    CostFigures,
    LayerStipple,
    LayerWindows,
    MuralFigures,
    MuralSimulation,
    PictureFigures,
)
from ..model import DotSet, Layers, Picture
from ..names import (
    COMPOSITE_PNG,
    ENERGY_CSV,
    PREVIEW_PNG,
    SEGMENTATION_PNG,
    SIMULATED_PNG,
    SWEEP_PNG,
    opacity_png,
)
from ..output import plain as _plain
from ..plan.holes import Refined, Stippled
from ..plan.names import LAYERS_NPZ, SPRAY_JSON, dots_name, layer_stem, step_name, windows_name
from ..plan.plan import Plan
from ..plan.results import (
    Built,
    CardMade,
    Decomposed,
    Designed,
    PaintOrder,
    PartResult,
    Segmented,
    Simulated,
    Stand,
)
from ..record import Run

log = logging.getLogger(__name__)


def record_compute(run: Run, where: ComputeFigures) -> None:
    """Figure ``compute``: where the job's tasks run (its executor's plan)."""
    run.figures.compute = where


def record_tasks(run: Run) -> None:
    """Figure ``compute`` again, with the executor's task count: known only once every stage has run."""
    if run.executor is not None and run.figures.compute is not None:
        run.figures.compute = replace(run.figures.compute, tasks=run.executor.tasks)


def record_plan(run: Run, plan: Plan, tiling: MuralFigures) -> None:
    """The plan before any work: figures ``mural`` (the tiling and its cost) and ``plate`` (the thickness and why)."""
    run.figures.mural = tiling
    run.figures.plate = plan.plate


def record_picture(run: Run, picture: Picture) -> None:
    """Figure ``picture`` (its source, size and pixels) and the picture as the instruction sheet shows it."""
    from ..exchange.png import png_bytes
    from ..names import INPUT_PNG

    run.sheet_images[INPUT_PNG] = png_bytes(np.asarray(picture.rgb, dtype=np.float64))
    run.figures.picture = PictureFigures(
        source=picture.source,
        width_mm=round(picture.width_mm, 3),
        height_mm=round(picture.height_mm, 3),
        pixels=picture.shape,
        mm_per_px=picture.mm_per_px,
    )


def record_plate(run: Run, plan: Plan) -> None:
    """Figure ``plate`` again: the thickness ``plan``'s design asks for, and why."""
    run.figures.plate = plan.plate


def record_standoff(run: Run, done: Designed) -> Plan:
    """Figure ``standoff`` of the plate-design trials ``done`` (none when nothing was tried). Returns the plan designed."""
    if done.figures is not None:
        run.figures.standoff = done.figures
    return done.plan


def record_sprays(run: Run, plan: Plan) -> None:
    """Figure ``spray_profiles``: each layer's spray settings as the plan resolved them, once per run."""
    if run.figures.spray_profiles is None and plan.paints is not None:
        run.figures.spray_profiles = plan.paints.rows


def record_decompose(run: Run, done: Decomposed, save: bool = True) -> Layers:
    """The decompose stage's ``done``: figures ``cans`` (a catalogue's) and ``decompose``; saved when ``save``.

    Saving writes ``layers.npz``, each layer's opacity card, the composite and the energy trace.
    Returns the layers.
    """
    if save:
        _save_layers(run, done)
    record_cans(run, done.cans)
    run.figures.decompose = done.figures
    return done.layers


def record_cans(run: Run, cans: CansFigures | None) -> None:
    """Figure ``cans``: what ``cans`` knows (a can list, a catalogue, the snap to it) added to what the run knew."""
    if cans is None:
        return
    known = {k: v for k, v in vars(cans).items() if v is not None}
    run.figures.cans = replace(run.figures.cans or CansFigures(), **known)


def _save_layers(run: Run, done: Decomposed) -> None:
    """Write ``layers.npz``, each layer's opacity card, the composite and the energy trace."""
    from ..simulate import labelled

    layers, out = done.layers, run.out
    out.write_npz(LAYERS_NPZ, done.saved)
    for i, a in enumerate(layers.alphas):
        out.write_png(
            opacity_png(layer_stem(i)),
            labelled.opacity_card(a, layers.mm_per_px, i + 1, layers.count, to_hex(layers.colours[i])),
        )
    out.write_png(COMPOSITE_PNG, layers.composite())
    trace = "iteration,energy\n" + "".join(f"{k},{e:.10g}\n" for k, e in enumerate(layers.energy_trace))
    out.write_text(ENERGY_CSV, trace)


def record_plates(run: Run, plates: Layers) -> Layers:
    """Figure ``decompose.plates``: how many plates the job stipples from its layers. Returns ``plates``."""
    if run.figures.decompose is not None:
        run.figures.decompose = replace(run.figures.decompose, plates=plates.count)
    return plates


def record_segment(run: Run, cut: Segmented) -> None:
    """Hard mode's segmentation: ``segmentation.png``, and figure ``hard`` (its report, warnings, each cut layer's)."""
    from ..figures import HardFigures

    run.out.write_png(SEGMENTATION_PNG, cut.segmentation)
    report = cut.hard.report
    run.figures.hard = HardFigures.from_json(
        {
            **_plain(report),
            "warnings": [str(w) for w in report.get("warnings", [])],
            "per_layer": [_plain(r) for r in report.get("per_layer", [])],
        }
    )


def record_stipple(run: Run, made: Stippled) -> None:
    """Figures ``dark_end`` and ``windows`` of the stipple stage's holes ``made``."""
    run.figures.dark_end = made.dark_end
    run.figures.windows = tuple(LayerWindows(i + 1, _plain(w.report)) for i, w in enumerate(made.windows))


def record_refine(run: Run, done: Refined, reused: bool) -> list[DotSet]:
    """Figure ``refine`` of the refine stage's holes ``done`` (none when ``refine.enabled`` is off). Returns the holes.

    Holes the plate-design trials refined and the stage ``reused`` are recorded in a ``refine``
    stage of their own, so the manifest times the refinement either way.
    """
    if done.report is None:
        return done.sets
    if reused:
        with run.stage("refine"):
            run.figures.refine = done.report
    else:
        run.figures.refine = done.report
    return done.sets


def record_dots(run: Run, made: Stippled, sets: list[DotSet]) -> None:
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


def record_paints(run: Run, done: PaintOrder) -> None:
    """The paints stage's ``done``: each plate's preview, ``spray.json``, figure ``spray_order``, ``swatch.png``."""
    from ..names import SWATCH_PNG

    for name, card in done.cards:
        run.out.write_png(name, card)
    run.out.write_json(SPRAY_JSON, done.spray)
    run.figures.spray_order = done.figures
    run.out.write_png(SWATCH_PNG, done.swatch)


def record_cost(run: Run, made: CostFigures) -> CostFigures:
    """Figure ``cost``: what making the job's plates and walls costs. Returns ``made``."""
    run.figures.cost = made
    return made


def record_simulate(run: Run, done: Simulated) -> None:
    """The simulate stage's ``done``: ``simulated.png``, ``preview.png``, ``sweep.png``, the steps, each wall's picture.

    Figures ``paint`` (with the steps), ``simulate`` and ``spraying``.
    """
    run.out.write_bytes(SIMULATED_PNG, done.composite)
    run.out.write_bytes(PREVIEW_PNG, done.preview)
    if done.sweep is not None:
        run.out.write_bytes(SWEEP_PNG, done.sweep)
    for i, step in enumerate(done.steps):
        run.out.write_bytes(step_name(i), step)
    run.figures.paint = done.paint
    for name, picture in done.walls:
        run.out.write_bytes(name, picture)
    run.figures.simulate = done.figures
    run.figures.spraying = done.spraying


def record_parts(run: Run, parts: Iterable[PartResult]) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Stage each built part's files as it comes (in task order): ``(plates' rows, walls' rows)``."""
    plates: list[dict[str, Any]] = []
    walls: list[dict[str, Any]] = []
    for res in parts:
        for name, data in res.files:
            run.out.write_bytes(name, data)
        (plates if res.kind == "plate" else walls).append(res.row)
    return plates, walls


def record_build(run: Run, done: Built) -> None:
    """Figure ``build``; a mural's ``mural.built`` and ``mural_map.png``."""
    from ..names import MURAL_MAP_PNG

    run.figures.build = done.build
    if done.mural is not None:
        run.figures.mural = replace(_recorded_tiling(run), built=done.mural)
    if done.mural_map is not None:
        run.out.write_png(MURAL_MAP_PNG, done.mural_map)


def record_stand(run: Run, stand: Stand) -> Stand:
    """A mural's stand: the post's or the laser-cut parts' files, in order. Returns ``stand``."""
    for name, data in stand.files:
        run.out.write_bytes(name, data)
    return stand


def record_print_estimate(run: Run, build: BuildFigures) -> None:
    """Figure ``build`` again, with the slicer's print estimates."""
    run.figures.build = build


def record_registration(run: Run, simulation: MuralSimulation | None) -> None:
    """Figure ``mural.simulation``: a mural's registration cases (None: no case, nothing recorded)."""
    if simulation is not None:
        run.figures.mural = replace(_recorded_tiling(run), simulation=simulation)


def _recorded_tiling(run: Run) -> MuralFigures:
    """The mural's plan as the run recorded it (every tiled job is planned before its stages)."""
    fig = run.figures.mural
    if fig is None:
        raise AssertionError("a tiled stage ran before the mural was planned")
    return fig


def record_card(run: Run, made: CardMade) -> None:
    """The calibration card ``made``: the plate's and walls' files, the sheet (PNG, PDF), ``card.json``, figure ``card``."""
    from ..names import CARD_SHEET_PDF, CARD_SHEET_PNG
    from ..plan.names import CARD_JSON

    for name, data in made.parts:
        run.out.write_bytes(name, data)
    run.out.write_png(CARD_SHEET_PNG, made.sheet_png)
    run.out.write_bytes(CARD_SHEET_PDF, made.sheet_pdf)
    run.out.write_json(CARD_JSON, made.description)
    run.figures.card = made.figures
