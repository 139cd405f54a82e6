"""The order of the stages: one command of the command line, from the checks before any work to the manifest."""

from __future__ import annotations

import contextlib
import logging
import time
from collections.abc import Callable, Iterator
from dataclasses import replace
from pathlib import Path
from typing import cast

from .. import mural
from ..command_table import command as command_named
from ..config import ComputeConfig, JobConfig, Mode
from ..config.job import filled, with_margin
from ..errors import UserError
from ..figures import ComputeFigures, MuralFigures
from ..interrupts import CancelToken
from ..model import DotSet, Layers, Picture
from ..names import cut_png, dots_png
from ..output import OutputDir
from ..plan import tiles
from ..plan.cans import can_names
from ..plan.names import LAYERS_NPZ, PLAN_JSON, run_outputs, stage_outputs
from ..plan.picture import load_picture
from ..plan.plan import Plan, capped, painted, planned, primed, whole
from ..plan.saved import SavedPlan, apply_saved, config_digest, plan_json
from ..record import Run
from . import registration
from .build import BuildStarted, check_template, collect_parts, stage_build, start_build
from .cost import stage_cost
from .decompose import plates_of, stage_decompose
from .hard import cutout_spray, hard_config, stage_segment
from .manifest import finish, save_config
from .paints import stage_paints
from .recorder import (
    record_build,
    record_cans,
    record_compute,
    record_cost,
    record_decompose,
    record_dots,
    record_paints,
    record_parts,
    record_picture,
    record_plan,
    record_plate,
    record_plates,
    record_print_estimate,
    record_refine,
    record_registration,
    record_segment,
    record_simulate,
    record_sprays,
    record_stand,
    record_standoff,
    record_stipple,
    record_tasks,
)
from .refine import stage_refine
from .saved import check_dots, check_fresh, check_rows, read_dots, read_layers, read_plan
from .simulate import stage_simulate, stage_simulate_hard
from .slicing import stage_print_estimate
from .stand import stage_stand
from .standoff import stage_standoff
from .stipple import stage_stipple

log = logging.getLogger(__name__)


@contextlib.contextmanager
def computing(
    run: Run, picture_px: int, where: ComputeConfig | None = None, planned: MuralFigures | None = None
) -> Iterator[None]:
    """Open the job's executor (this process, or a Dask cluster: see :mod:`stencil_cad.compute`).

    Args:
        run: The command's state.
        picture_px: Pixels of the working picture (small jobs stay in this process).
        where: The ``compute`` section with the command line applied; defaults to the config's.
        planned: The job's tiling as planned (a tiled mural's estimated work may start a
            cluster), or None.
    """
    from .. import compute

    seconds = planned.mural_seconds if planned is not None else None
    with compute.executor(where or run.cfg.compute, picture_px, run.quiet, seconds) as ex:
        run.executor = ex
        record_compute(run, ComputeFigures(**ex.plan.summary()))
        try:
            yield
        finally:
            run.executor = None


def run_all(run: Run, picture: Picture | None = None) -> tuple[JobConfig, list[Path]]:
    """The whole job: the plan, then every stage in order; ``(the config as the job resolved it, files)``."""
    if picture is None:
        with run.stage("load"):
            picture = load_picture(run.cfg)
    if run.template is None:
        check_template(run)
    size = (picture.width_mm, picture.height_mm)
    plan = plan_job(run, size, picture.shape)
    record_picture(run, picture)
    if plan.cfg.mode == Mode.hard:
        mural.check_mode(plan.grid, plan.cfg)
        save_config(run, plan)
        return run_hard(run, plan, picture)
    plan, layers, dotsets = soft_plates(run, plan, picture)
    record_cost(run, stage_cost(plan, dotsets))
    build_any(run, plan, layers, dotsets, picture)
    return plan.cfg, finished(run, plan, "run", saved_plan(run, plan, plan.cfg))


def finished(run: Run, plan: Plan, command: str, plan_text: str | None = None) -> list[Path]:
    """The job done: figure ``compute`` with the executor's task count (every stage has run), then the manifest (:func:`finish`)."""
    record_tasks(run)
    return finish(run, plan, command, plan_text)


def saved_plan(run: Run, plan: Plan | None, copy: JobConfig, primer: str | None = None) -> str:
    """``plan.json`` of ``plan`` (designed), or of ``decompose``'s primer alone; ``copy``: the folder's config copy."""
    layers_sha = run.out.sha256(LAYERS_NPZ)
    configs = [config_digest(run.cfg), config_digest(copy)]
    names = can_names(run.figures)
    return plan_json(plan, configs, layers_sha, designed=plan is not None, primer=primer, can_names=names)


def plan_job(run: Run, picture_mm: tuple[float, float], shape_px: tuple[int, ...]) -> Plan:
    """The plan before any work (:func:`stencil_cad.plan.plan.planned`): the tiling, checked against the bed, and the thickness.

    Records figures ``mural`` (the tiling and its cost) and ``plate`` (the thickness and why).
    """
    plan, fig = planned(run.cfg, picture_mm, int(shape_px[0]) * int(shape_px[1]))
    record_plan(run, plan, fig)
    return plan


def soft_plates(run: Run, plan: Plan, picture: Picture) -> tuple[Plan, Layers, list[DotSet]]:
    """A soft job up to its holes: ``(the plan with its design, the plates' layers, their holes)``.

    In order: the holes capped and a dark picture's primer (the plan before the decomposition), the
    decomposition, the plate design the trials choose (the plan the later stages take), then the
    holes stippled and refined. What :func:`run_all` builds and simulates; a benchmark that scores
    what the job makes calls it (and :func:`stencil_cad.pipeline.simulate.stage_simulate`) rather
    than repeating the steps.
    """
    plan = primed(capped(plan), picture)
    decomposed = record_decompose(run, stage_decompose(run, plan, picture))
    layers = record_plates(run, plates_of(plan, decomposed))
    plan = design_plates(run, painted(plan, layers.colours, can_names(run.figures)), layers, picture)
    # The saved config records the plate design the job chose.
    save_config(run, plan)
    return plan, layers, plate_holes(run, plan, layers, picture)


def plate_holes(run: Run, plan: Plan, layers: Layers, picture: Picture | None) -> list[DotSet]:
    """Every plate's holes: stippled, refined, saved (``dots_N.csv``), previewed, and the spray order."""
    cfg = plan.cfg
    made, reused = stage_stipple(run, plan, layers)
    if not reused:
        # Figure ``spray_profiles`` stands where the job first sprays a layer: stippling it here,
        # else (the trials' holes reused) simulating it.
        record_sprays(run, plan)
    record_stipple(run, made)
    sets = record_refine(run, *stage_refine(run, plan, layers, made, picture))
    with run.stage("stipple"):
        record_dots(run, made, sets)
        amounts = [ds.amount(cfg.spray.amount) for ds in sets]
        record_paints(run, stage_paints(run, plan, layers.primer, layers.colours, sets, amounts, dots_png))
    return sets


def design_plates(run: Run, plan: Plan, layers: Layers, picture: Picture | None) -> Plan:
    """``plan`` with the plate design left to the job (:func:`stage_standoff`) and the thickness its wall asks for.

    Chosen for the picture when the tiling says so (:func:`stencil_cad.mural.chooses_design`: a
    one-plate job; a mural keeps the config's). Figure ``standoff`` records the trials; figure
    ``plate`` is recorded again when the wall changed the thickness.
    """
    if not mural.chooses_design(plan.grid):
        return plan
    chosen = record_standoff(run, stage_standoff(run, plan, layers, picture))
    if chosen.plate != plan.plate:
        record_plate(run, chosen)
    return chosen


def run_command(
    command: str,
    cfg: JobConfig,
    out_path: Path,
    *,
    src: Path | None = None,
    force: bool = False,
    quiet: bool = False,
    where: ComputeConfig | None = None,
    announce: Callable[[str], None] | None = None,
    progress: Callable[[str, str], None] | None = None,
    cancel: CancelToken | None = None,
) -> tuple[Run, JobConfig, list[Path]]:
    """Run one command of the command line: ``run``, ``hard``, ``decompose`` or a stage command.

    The template is loaded and checked, then the output folder is opened (created, locked,
    probed for writing) before the image is read or any stage runs; on any failure nothing
    is written (the staged files are discarded).

    Args:
        command: ``run``, ``hard``, ``decompose``, ``stipple``, ``build`` or ``simulate``.
        cfg: The resolved job config.
        out_path: The output folder.
        src: Folder whose intermediates a stage command reads. Defaults to ``out_path``.
        force: Replace the files stencil-cad wrote earlier in the folder (unchanged since).
        quiet: No progress bars.
        where: Where the tasks run: the ``compute`` section with ``--workers`` /
            ``--scheduler`` applied. Defaults to the config's.
        announce: Called with one line saying what the job will cost (tiles, plates, holes,
            time), after the input is read and before any work, or None.
        progress: Told ``(event, stage)`` as each stage starts and ends, or None.
        cancel: Stops the run at its next stage edge or progress step (nothing is kept), or None.

    Returns:
        ``(run, config, files)``: the run's state (figures, timings; ``run.cfg`` is ``cfg`` as given),
        the config as the job resolved it (its plan's: thickness, primer, plate design) and the files
        written.
    """
    cmd = command_named(command)
    stage_cmd = cmd.saved
    src = (src or out_path) if stage_cmd else None
    # `decompose` is a stage too: it adds to a run's folder and never removes later stages' files.
    run = Run(cfg=cfg, out=None, quiet=quiet, progress=progress, cancel=cancel)  # type: ignore[arg-type]
    # Everything that can be checked is checked before the first stage: the template (Python
    # code, loaded now), the output folder (created, locked, probed for writing), the image.
    if cmd.builds:
        check_template(run)
    out = OutputDir(out_path, force=force, allow_existing=not cmd.whole)
    run.out = out
    t0 = time.perf_counter()
    try:
        if not stage_cmd:
            out.check_free(run_outputs(cfg, command))
        picture = None
        if cmd.reads_picture:
            try:
                with run.stage("load"):
                    picture = load_picture(cfg)
            except UserError:
                # `simulate` scores, and `stipple` refines, against the decomposition when the image is gone.
                if not cmd.saved:
                    raise
        planned = _planned(cfg, picture) if picture is not None and cmd.whole else None
        if planned is not None and announce is not None:
            announce(tiles.plan_line(planned, cfg))
        if cmd.from_picture:
            assert picture is not None  # load_picture raised otherwise
            with computing(run, picture.shape[0] * picture.shape[1], where, None if cmd.hard else planned):
                resolved, files = run_all(run, picture) if cmd.whole else run_decompose(run, picture)
        else:
            resolved, files = _run_stage_command(run, command, src or out_path, picture, where)
    except BaseException:
        out.abort()
        raise
    run.times["total"] = round(time.perf_counter() - t0, 3)
    return run, resolved, files


def run_decompose(run: Run, picture: Picture) -> tuple[JobConfig, list[Path]]:
    """The ``decompose`` command: the layers saved beside the config; ``(the config as resolved, files)``.

    Its plan is the primer alone (:func:`stencil_cad.plan.plan.primed` on the config as given, one
    tile): a mostly dark picture is decomposed primed with its dark colour.
    """
    # The plate values left null as the config alone fills them in: no tiling is planned.
    given = whole(filled(run.cfg)[0], (picture.width_mm, picture.height_mm))
    save_config(run, given)
    plan = primed(given, picture)
    record_decompose(run, stage_decompose(run, plan, picture))
    return plan.cfg, finished(run, plan, "decompose", saved_plan(run, None, run.cfg, plan.primer))


def _planned(cfg: JobConfig, picture: Picture) -> MuralFigures:
    """The job's tiling as planned before any work: what :func:`tiles.plan_line` prints and where it runs."""
    shape = picture.shape
    cfg = with_margin(cfg)  # the tiles' margin the job fills in: the tiling follows it
    return tiles.plan(cfg, picture.width_mm, picture.height_mm, shape[0] * shape[1])[1]


def _run_stage_command(
    run: Run, command: str, src: Path, picture: Picture | None, where: ComputeConfig | None
) -> tuple[JobConfig, list[Path]]:
    layers = read_layers(src)
    saved = read_plan(src)
    size = (layers.alphas.shape[2] * layers.mm_per_px, layers.alphas.shape[1] * layers.mm_per_px)
    # The tiling and thickness from the same config by the same functions; every decision the
    # run made (the design, the cans' names) from its saved plan.
    plan = plan_job(run, size, layers.alphas.shape[1:])
    cfg = plan.cfg
    layers = record_plates(run, plates_of(plan, layers))
    plan = painted(plan, layers.colours, saved.can_names)
    cmd = command_named(command)
    run.out.check_free(stage_outputs(cfg, command, layers.count, plan.grid))
    if abs(size[0] - cfg.size.width_mm) > 0.01 * cfg.size.width_mm:
        log.warning(
            "the saved layers are %.4g mm wide but the config says size.width_mm %.4g; the saved "
            "layers' size is used (re-run `stencil-cad decompose` to change it)",
            size[0],
            cfg.size.width_mm,
        )
    dotsets = None
    if cmd.reads_dots:
        check_fresh(src, command)
        dotsets = read_dots(src, layers.count, max_time=8.0 * cfg.spray.amount_cap)
        check_rows(cfg, dotsets, size)
        if cmd.builds:
            check_dots(cfg, dotsets, size)
    else:
        # The saved config names the primer the run chose; the holes are capped as the run capped them.
        plan = capped(plan)
    # Every refusal above comes before any worker starts; the tasks then run where the whole
    # job's would (--workers, --scheduler).
    with computing(run, layers.alphas.shape[1] * layers.alphas.shape[2], where, run.figures.mural):
        plan = _saved_design(run, plan, saved, layers, picture)
        text = None
        if dotsets is None:
            record_cost(run, stage_cost(plan, plate_holes(run, plan, layers, picture)))
            configs = saved.configs_sha256 if saved.planned_for(run.cfg) else [config_digest(run.cfg)]
            text = plan_json(plan, configs, saved.layers_sha256, designed=True, can_names=saved.can_names)
        elif cmd.builds:
            record_cost(run, stage_cost(plan, dotsets))
            build_any(run, plan, layers, dotsets, picture, simulate=False)
        else:
            record_sprays(run, plan)
            record_simulate(run, stage_simulate(run, plan, picture, layers, dotsets))
        return plan.cfg, finished(run, plan, command, text)


def _saved_design(run: Run, plan: Plan, saved: SavedPlan, layers: Layers, picture: Picture | None) -> Plan:
    """``plan`` with the plate design the saved plan chose, and its figure ``plate``.

    A plan ``decompose`` saved has no design yet, and one planned for another config (a stage
    command given an edited one) does not fit this one: the design is chosen as the whole run
    chooses it (the same trials on the same layers and seed), so a stage command gives the run's files.
    """
    if saved.design is None or not saved.planned_for(run.cfg):
        if saved.design is not None:
            log.info(
                "%s was planned for another config: the plate design is chosen again for this one", PLAN_JSON
            )
        return design_plates(run, plan, layers, picture)
    chosen = apply_saved(plan, saved)
    record_plate(run, chosen)
    return chosen


def build_any(
    run: Run,
    plan: Plan,
    layers: Layers,
    dotsets: list[DotSet],
    picture: Picture | None = None,
    simulate: bool = True,
) -> None:
    """Build (and simulate) ``plan``'s parts: every tile's plates and walls, one tile for a one-plate job.

    The plates and walls are tasks that need nothing the simulation computes: they start first,
    and this process simulates while they run. The plates are sprayed as made; a mural's
    registration cases start as tasks once the global simulation is there.
    """
    built = start_build(run, plan, layers, dotsets, picture)
    cases = seen = None
    if simulate:
        record_sprays(run, plan)
        try:
            done = stage_simulate(
                run,
                plan,
                picture,
                layers,
                dotsets,
                workers_busy=True,
                # A soft job's holes are round.
                also=lambda sim, ref: registration.start_registration(
                    run,
                    plan,
                    sim,
                    ref,
                    layers,
                    cast("list[DotSet]", built.made),
                    cast("list[list[DotSet]]", built.per_tile),
                ),
            )
            record_simulate(run, done)
        except BaseException:
            built.tasks.cancel()
            raise
        cases, seen = done.started, done.figures
    build_parts(run, plan, built)
    # PrusaSlicer's estimate slices a one-plate job's plates (a mural's parts are estimated by its plan).
    if plan.cfg.export.print_estimate and not mural.has_seams(plan.grid):
        record_print_estimate(run, stage_print_estimate(run, plan, run.figures.build))
    record_registration(run, registration.stage_mural_simulate(run, cases, seen))


def build_parts(run: Run, plan: Plan, built: BuildStarted) -> None:
    """Collect the plates and walls :func:`start_build` started under ``plan``, write a mural's stand, record the build."""
    with run.stage("build"):
        plates, walls = record_parts(run, collect_parts(built))
        stand = record_stand(run, stage_stand(plan, built.laser, built.posts, run.figures.stipple or ()))
    record_build(run, stage_build(built, plates, walls, stand))


def run_hard(run: Run, plan: Plan, picture: Picture) -> tuple[JobConfig, list[Path]]:
    """Hard-stencil mode: segmentation, bridges, plates with polygon cut-outs, simulation.

    ``plan``'s tiling is one tile (hard mode makes one plate per layer).
    """
    # Cut-outs are sprayed from their own nozzle height, with whole passes for full cover.
    plan = replace(plan, cfg=hard_config(plan.cfg))
    cfg = plan.cfg
    with run.stage("segment"):
        cut = stage_segment(run, plan, picture)
        record_cans(run, cut.cans)
        # The plan learns the cut layers' paints: each sprays its own can, in whole passes.
        plan = painted(plan, cut.layers.colours, can_names(run.figures), each=cutout_spray)
        record_sprays(run, plan)
        record_segment(run, cut)
        amounts = [float(sp.amount) for sp in plan.sprays]
        holes = cut.hard.cut_layers
        record_paints(
            run, stage_paints(run, plan, cut.hard.primer, cut.layers.colours, holes, amounts, cut_png)
        )
    build_parts(run, plan, start_build(run, plan, cut.layers, cut.hard.cut_layers))
    record_simulate(run, stage_simulate_hard(run, plan, picture, cut.hard, cut.layers, amounts))
    return cfg, finished(run, plan, "hard")
