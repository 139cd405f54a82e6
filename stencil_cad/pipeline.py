"""The orchestrator: calls the stages in order, reports progress, writes through :mod:`output`.

Stages are pure functions; this module is the only one that knows their order, which
intermediates a stage command reads back, and which files a run writes.
"""

from __future__ import annotations

import contextlib
import logging
import math
import platform
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

from . import __version__, interrupts
from .colour import to_hex
from .config import ComputeConfig, JobConfig, Mode
from .config.spray import SprayModel
from .errors import ConfigError, OutputError, UserError
from .model import CutLayer, DotSet, Holes, Layers, Picture, coat_contrast
from .output import MANIFEST, OutputDir, manifest_header
from .output import plain as _plain
from .stipple.made import drawn_dots, made_dots

if TYPE_CHECKING:
    from . import mural
    from .compute import Executor
    from .slicing import SliceResult
    from .slicing.gcode import GcodeEstimate

log = logging.getLogger(__name__)

LAYERS_NPZ = "layers.npz"
CONFIG_COPY = "config.yaml"


def dots_name(i: int) -> str:
    """File name of layer ``i``'s dots (0-based index, 1-based in the name)."""
    return f"layer_{i + 1:02d}_dots.csv"


def wall_stems(standoffs_mm: list[float]) -> list[str]:
    """File stems of the walls: ``wall`` for one stand-off height, ``wall_10mm`` … for several."""
    heights = sorted(set(standoffs_mm))
    return ["wall"] if len(heights) == 1 else [f"wall_{h:g}mm" for h in heights]


def layer_stem(i: int) -> str:
    """Stem of layer ``i``'s files (0-based index, 1-based in the name)."""
    return f"layer_{i + 1:02d}"


@dataclass
class Run:
    """State of one command: config, output folder, timings and the figures for the manifest."""

    cfg: JobConfig
    out: OutputDir
    quiet: bool = False
    executor: Executor | None = None
    times: dict = field(default_factory=dict)
    figures: dict = field(default_factory=dict)
    summary: list = field(default_factory=list)
    #: The plate template in use: ``{"path", "sha256", "builtin"}`` (None before it is checked).
    template: dict | None = None
    #: Images for the instruction sheet that are not result files (PNG bytes by name).
    sheet_images: dict = field(default_factory=dict)
    #: Files of later stages this stage command left in the folder, made from older inputs.
    stale: list = field(default_factory=list)

    def rng_for(self, stage: str, index: int = 0) -> np.random.Generator:
        """An independent generator per stage and layer, derived from the seed.

        A stage command re-run on saved intermediates therefore gives the same result as
        the same stage inside a whole run.
        """
        return np.random.default_rng(self.seed_for(stage, index))

    def seed_for(self, stage: str, *index: int) -> np.random.SeedSequence:
        """The seed sequence of :meth:`rng_for`, for any number of indices (layer, tile, …)."""
        import zlib

        key = (zlib.crc32(stage.encode()), *index)
        return np.random.SeedSequence(self.cfg.seed, spawn_key=key)

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time a stage; a signal whose exception was dropped stops the run at its edges."""
        interrupts.check()
        log.info("stage %s …", name)
        t0 = time.perf_counter()
        yield
        interrupts.check()
        self.times[name] = round(self.times.get(name, 0.0) + time.perf_counter() - t0, 3)

    @property
    def tasks(self) -> Executor:
        """Where tile tasks run: the executor :func:`computing` opened, else this process."""
        if self.executor is None:
            from . import compute

            self.executor = compute.Executor(
                compute.Plan("in_process", reason="no cluster opened"), self.quiet
            )
        return self.executor

    def bar(self, total: int | None, desc: str):
        """A progress bar on stderr (silent with -q)."""
        from tqdm.auto import tqdm

        # disable=None: no bar when stderr is not a terminal (logs, CI).
        return tqdm(total=total, desc=desc, disable=True if self.quiet else None, leave=False, unit="it")


# --------------------------------------------------------------------------- stages


def load_picture(cfg: JobConfig) -> Picture:
    """Load the configured image (or the bundled example) onto the working grid.

    Transparent areas are flattened onto white (bare surface) unless the decomposition
    takes its opacity from the alpha channel, where the paint is the image's own colour.
    """
    from dataclasses import replace

    from . import resolution
    from .imaging import MAX_UPSCALE
    from .imaging import load_picture as _load

    px = 1.0 / resolution.working_mm_per_px(cfg)
    pic = _load(
        cfg.image, cfg.size.width_mm, cfg.size.height_mm, px, resolution.max_upscale(cfg, MAX_UPSCALE)
    )
    source = getattr(cfg.decompose.opacity_source, "value", cfg.decompose.opacity_source)
    if pic.alpha is not None and source != "alpha":
        a = pic.alpha[..., None]
        pic = replace(pic, rgb=pic.rgb * a + (1.0 - a))
    return pic


def stage_decompose(run: Run, picture: Picture) -> Layers:
    """Decompose the picture into a primer and paint layers, and save them."""
    from dataclasses import replace

    from . import decompose as dec
    from .exchange.layers_npz import layers_from_npz, layers_to_npz

    with run.stage("decompose"):
        # Iterations run per pyramid level, so the total is not known in advance.
        with run.bar(None, "decompose") as bar:

            def progress(_iteration: int, energy: float) -> None:
                bar.update(1)
                bar.set_postfix(energy=f"{energy:.4g}", refresh=False)

            dcfg = _with_can_list(run, run.cfg.decompose, "decompose.palette")
            try:
                tiles = _decompose_tiles(run, picture)

                def solve(section) -> Layers:
                    if tiles is None:
                        return dec.decompose(picture, section, run.rng_for("decompose"), progress=progress)
                    return _decompose_tiled(run, picture, tiles, progress, section)

                layers = solve(dcfg)
                if dcfg.palette == "auto" and run.cfg.paints.catalogue is not None:
                    layers = _snap_to_catalogue(run, dcfg, layers, solve)
            except ValueError as exc:
                # A config that does not suit this image (e.g. opacity_source: alpha on RGB).
                raise UserError(str(exc)) from exc
        out = run.out
        # Timings go to the manifest only, so the same job writes the same bytes.
        saved = layers_to_npz(replace(layers, info={k: v for k, v in layers.info.items() if k != "seconds"}))
        out.write_npz(LAYERS_NPZ, saved)
        # Go on with exactly what was saved (float32 opacities), so a stage command run later
        # on layers.npz gives the same dots as this run.
        layers = layers_from_npz(saved)
        from .simulate import labelled

        for i, a in enumerate(layers.alphas):
            out.write_png(
                f"{layer_stem(i)}_opacity.png",
                labelled.opacity_card(a, layers.mm_per_px, i + 1, layers.count, to_hex(layers.colours[i])),
            )
        out.write_png("composite.png", layers.composite())
        trace = "iteration,energy\n" + "".join(f"{k},{e:.10g}\n" for k, e in enumerate(layers.energy_trace))
        out.write_text("energy.csv", trace)
    info = dict(layers.info)
    run.figures["decompose"] = {
        "layers": layers.count,
        "primer": to_hex(layers.primer),
        "colours": [to_hex(c) for c in layers.colours],
        "iterations": layers.iterations,
        **{k: v for k, v in info.items() if isinstance(v, (int, float, str, list))},
    }
    if "tiled" in info:
        run.figures["decompose"]["tiled"] = _plain(info["tiled"])
    return layers


def _decompose_tiles(run: Run, picture: Picture):
    """The decomposition's tiles for a big picture (None: solved whole), checked against the memory per task."""
    from . import compute
    from .decompose import tiled

    cfg = run.cfg
    if not tiled.applies(picture, cfg.decompose):
        return None
    n = cfg.decompose.layers
    tiles = tiled.plan(picture.shape, n, cfg.compute.memory_per_task_bytes)
    if tiles is None:
        return None
    side = tiles.tile_px + 2 * tiles.halo_px
    compute.check_fits(
        f"a decomposition tile of {side} x {side} px with {n} layers",
        tiled.tile_bytes(tiles.tile_px, n),
        cfg.compute,
    )
    ch, cw = tiles.coarse_shape
    compute.check_fits(
        f"the colour solve on {ch} x {cw} px with {n} layers", tiled.whole_bytes((ch, cw), n), cfg.compute
    )
    return tiles


def _decompose_tiled(run: Run, picture: Picture, tiles, progress, cfg=None) -> Layers:
    """Colours on a small copy of the picture, then the opacities tile by tile as tasks.

    ``cfg`` is the decompose section to solve with (defaults to the job's; a can list or the
    catalogue's cans replace its palette).
    """
    from . import decompose as dec
    from .decompose import tiled

    cfg = run.cfg.decompose if cfg is None else cfg
    coarse = dec.decompose(
        tiled.coarse_picture(picture, tiles), cfg, run.rng_for("decompose"), progress=progress
    )
    results = run.tasks.map(
        tiled.solve_tile, tiled.tasks(picture, coarse, tiles, cfg), "decompose tiles", count=tiles.count
    )
    return tiled.assemble(coarse, tiles, results, picture.mm_per_px)


@contextlib.contextmanager
def computing(run: Run, picture_px: int, where: ComputeConfig | None = None) -> Iterator[None]:
    """Open the job's executor (this process, or a Dask cluster: see :mod:`stencil_cad.compute`).

    Args:
        run: The command's state.
        picture_px: Pixels of the working picture (small jobs stay in this process).
        where: The ``compute`` section with the command line applied; defaults to the config's.
    """
    from . import compute

    with compute.executor(where or run.cfg.compute, picture_px, run.quiet) as ex:
        run.executor = ex
        run.figures["compute"] = ex.plan.summary()
        try:
            yield
        finally:
            run.executor = None


def _with_can_list(run: Run, section, where: str):
    """A config section whose palette CSV (a can list) is replaced by its colours; the cans are noted."""
    from .decompose import paints

    if not isinstance(section.palette, Path):
        return section
    try:
        cans = paints.load_cans(section.palette)
    except (ValueError, ConfigError) as exc:
        raise ConfigError(f"{where}: {exc}") from None
    run.figures.setdefault("cans", {})["list"] = [c.__dict__ for c in cans]
    hexes = paints.to_hex_list(cans)
    return section.model_copy(update={"palette": hexes if where.startswith("decompose") else list(hexes)})


def _catalogue(run: Run) -> list:
    from .decompose import paints

    catalogue = run.cfg.paints.catalogue
    assert catalogue is not None, "snapping to a catalogue needs paints.catalogue"
    try:
        cans = paints.load_cans(catalogue)
    except (ValueError, ConfigError) as exc:
        raise ConfigError(f"paints.catalogue: {exc}") from None
    run.figures.setdefault("cans", {})["catalogue"] = [c.__dict__ for c in cans]
    return cans


def _snap_to_catalogue(run: Run, dcfg, layers: Layers, solve) -> Layers:
    """Snap the solved paints (and an 'auto' primer) to their nearest cans and solve the opacities again.

    ``solve(section)`` decomposes the picture with a decompose section (whole or in tiles).
    """
    from .decompose import paints

    cans = _catalogue(run)
    paint_snap = paints.snap_report(layers.colours, cans)
    update: dict[str, object] = {"order": "given"}
    primer_snap = None
    if dcfg.primer == "auto":
        primer_snap = paints.snap_report(layers.primer[None, :], cans)[0]
        update["primer"] = primer_snap["can"]
    chosen: list[str] = []
    for row in paint_snap:
        if row["can"] not in chosen and row["can"] != update.get("primer", dcfg.primer):
            chosen.append(row["can"])
    if not chosen:
        raise ValueError(
            "paints.catalogue: every solved paint snaps to the primer's can; add cans closer to the "
            "picture's colours, or set decompose.palette to a list"
        )
    update["palette"] = tuple(chosen)
    snapped = solve(dcfg.model_validate({**dcfg.model_dump(), **update}))
    before = float(layers.info.get("rmse", float("nan")))
    after = float(snapped.info.get("rmse", float("nan")))
    run.figures.setdefault("cans", {})["snap"] = {
        "paints": paint_snap,
        "primer": primer_snap,
        "rmse_solved": before,
        "rmse_snapped": after,
        "rmse_cost": after - before,
        "de2000_mean_shift": float(sum(r["delta_e2000"] for r in paint_snap) / len(paint_snap)),
    }
    log.info("paints: snapped to the catalogue, composite RMSE %.2f → %.2f (0-255 units)", before, after)
    return snapped


def can_names(figures: dict) -> dict[str, str]:
    """``{hex: can label}`` of every can this job knows (its can list and catalogue)."""
    from .decompose import paints

    known = figures.get("cans", {})
    rows = [*known.get("list", []), *known.get("catalogue", [])]
    return paints.names_by_hex([paints.Can(**r) for r in rows])


def read_layers(folder: Path) -> Layers:
    """Read the decomposition a previous `decompose` or `run` saved."""
    from .exchange.layers_npz import layers_from_npz
    from .files import DATA_LIMIT, open_input

    path = folder / LAYERS_NPZ
    import zipfile

    fix = "run `stencil-cad decompose` first, or pass --from DIR"
    try:
        with open_input(path, "decomposition", limit=DATA_LIMIT, fix=fix) as fh, np.load(fh) as data:
            return layers_from_npz(dict(data))
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise UserError(
            f"{path}: not a readable decomposition ({exc}); re-run `stencil-cad decompose`"
        ) from None


SPRAY_JSON = "spray.json"


@dataclass(frozen=True)
class StippleTask:
    """One layer to stipple: its opacity, pixel size, the job config and its own generator.

    ``weight`` weighs each pixel's error when the layer's spray time is chosen: the squared
    colour change a full coat makes there (:func:`stencil_cad.model.coat_contrast`).
    """

    alpha: np.ndarray
    mm_per_px: float
    cfg: JobConfig
    rng: np.random.Generator
    weight: np.ndarray | None = None


def _calibrated(cfg: JobConfig) -> bool:
    return getattr(cfg.stipple.tone, "value", cfg.stipple.tone) == "calibrated"


def _chooses_spray_time(cfg: JobConfig) -> bool:
    """Whether each layer gets its own spray time (calibrated tone and ``calibrate: spray_time``)."""
    return _calibrated(cfg) and getattr(cfg.spray.calibrate, "value", cfg.spray.calibrate) == "spray_time"


def _layer_tone(task: StippleTask):
    """``(tone choice or None, spray time)`` of one layer.

    With ``stipple.tone: calibrated`` the density comes from the spray response, and with
    ``spray.calibrate: spray_time`` the layer gets its own spray time.
    """
    cfg = task.cfg
    if not _calibrated(cfg):
        return None, cfg.spray.amount
    from .simulate import tone

    choice = tone.calibrated_tone_for(task.alpha, task.mm_per_px, cfg, task.weight)
    if _chooses_spray_time(cfg):
        return choice, float(choice.spray_time)
    return choice, cfg.spray.amount


def stipple_task(task: StippleTask) -> tuple[DotSet, dict | None]:
    """Stipple one layer (a task): ``(holes, tone choice summary or None)``.

    The spray time (:func:`_layer_tone`) is in the holes' report.
    """
    from dataclasses import replace

    from . import stipple

    choice, spray_time = _layer_tone(task)
    density = None if choice is None else choice.density
    ds = stipple.stipple_layer(task.alpha, task.mm_per_px, task.cfg.stipple, task.rng, density=density)
    return replace(
        ds, report={**ds.report, "spray_time": spray_time}
    ), None if choice is None else choice.summary()


def tone_task(task: StippleTask):
    """One layer's tone choice without its density map (a task): ``(choice or None, spray time)``."""
    from dataclasses import replace

    choice, spray_time = _layer_tone(task)
    return (None if choice is None else replace(choice, density=np.zeros((0, 0)))), spray_time


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
    from .exchange.dots_csv import dots_to_csv

    bound_dots(run, picture_mm)
    cfg = run.cfg
    sets: list[DotSet] = []
    tones: list[dict] = []
    with run.stage("stipple"):
        # One task per layer (on a cluster the layers stipple side by side); each layer's
        # generator comes from the seed, so any number of workers gives the same holes.
        # The colour weights only steer the choice of each layer's spray time.
        weights = (
            coat_contrast(layers.primer, layers.colours, layers.alphas)
            if _chooses_spray_time(cfg)
            else [None] * layers.count
        )
        tasks = [
            StippleTask(alpha, layers.mm_per_px, cfg, run.rng_for("stipple", i), weights[i])
            for i, alpha in enumerate(layers.alphas)
        ]
        if grid is not None and grid.tiled and cfg.stipple.dots is None:
            # A mural: one task per layer and tile (stipple.dots fixes one count for a whole
            # picture, so with it the layers stipple in one piece).
            from dataclasses import replace

            from . import mural_stipple

            chosen = list(run.tasks.map(tone_task, tasks, "tone"))
            seeds = [
                [run.seed_for("stipple", i, k) for k in range(len(grid.tiles))] for i in range(layers.count)
            ]
            placed = mural_stipple.stipple_mural(
                cfg, layers.alphas, layers.mm_per_px, grid, [c for c, _ in chosen], seeds, run.tasks.map
            )
            for ds, (choice, spray_time) in zip(placed, chosen, strict=True):
                sets.append(replace(ds, report={**ds.report, "spray_time": spray_time}))
                if choice is not None:
                    tones.append(choice.summary())
        else:
            for ds, tone_summary in run.tasks.map(stipple_task, tasks, "stipple"):
                sets.append(ds)
                if tone_summary is not None:
                    tones.append(tone_summary)
    run.figures["dark_end"] = [
        _dark_end(cfg, alpha, float(ds.report["spray_time"]))
        for alpha, ds in zip(layers.alphas, sets, strict=True)
    ]
    if cfg.refine.enabled:
        sets = stage_refine(run, layers, sets, picture_mm, picture, grid)
    with run.stage("stipple"):
        cards = plate_cards(run, layers.colours, picture_mm, sets)
        for i, ds in enumerate(sets):
            run.out.write_text(dots_name(i), dots_to_csv(ds))
            run.out.write_png(f"{layer_stem(i)}_dots.png", cards[i])
        write_spray_order(run, layers.primer, layers.colours, [ds.report["spray_time"] for ds in sets])
    run.figures["stipple"] = [
        {"layer": i + 1, "dots": len(ds), **_plain(ds.report)} for i, ds in enumerate(sets)
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


def _dark_end(cfg: JobConfig, alpha: np.ndarray, spray_time: float) -> dict:
    """How much of a layer is darker than its stencil can spray at its spray time.

    The darkest mean opacity is that of the densest pattern the rules allow, with holes up to
    the refinement's largest radius when it is on (the stippler's otherwise), measured with
    the spray model (:func:`stencil_cad.simulate.tone.tone_response`).
    """
    from .simulate import tone
    from .simulate.physical import SprayGeometry

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
        geometry=SprayGeometry.of_job(cfg) if cfg.spray.model == SprayModel.physical else None,
    )
    top = curve.max_opacity
    a = np.asarray(alpha, dtype=np.float64)
    over = a > top + 1e-6
    return {
        "darkest_sprayable": round(top, 4),
        "unreachable_share": round(float(over.mean()), 4),
        "unreachable_by": round(float((a[over] - top).mean()), 4) if over.any() else 0.0,
    }


def stage_refine(
    run: Run,
    layers: Layers,
    dotsets: list[DotSet],
    picture_mm: tuple[float, float],
    picture: Picture | None = None,
    grid: mural.TileGrid | None = None,
) -> list[DotSet]:
    """Refine every layer's holes against the spray model so the composite matches the picture.

    The objective lives on the simulation grid, its eye filter is the viewer's at
    ``view.distance_m``, and the holes keep the stipple rules (the largest radius is
    ``refine.max_radius_factor`` times the hole floor). A mural (``grid`` of several tiles)
    is refined tile by tile (:mod:`stencil_cad.mural_refine`), each tile a task.
    """
    from . import resolution
    from .simulate import scielab, spray
    from .simulate.physical import SprayGeometry
    from .stipple import refine
    from .stipple.rules import rules_from_config

    cfg = run.cfg
    # The simulation's grid: with ``size.px_per_mm: auto`` it follows the dots' spray sigma
    # (8x fewer pixels than 4 px/mm for FDM holes, which keeps a mural's refinement in memory).
    grid_mm = resolution.sim_mm_per_px(cfg) or 1.0 / cfg.spray.px_per_mm
    shape = spray.sim_shape(layers.alphas.shape[1:], layers.mm_per_px, grid_mm)
    # The picture the simulation is scored against: the source image on the simulation grid.
    target = source_reference(cfg, picture, layers, shape, grid_mm)
    rules = rules_from_config(cfg.stipple, *picture_mm)
    rc = cfg.refine
    settings = refine.RefineSettings(
        iterations=rc.iterations,
        step_mm=rc.step_mm,
        radius_step_mm=rc.radius_step_mm,
        max_radius_mm=max(rc.max_radius_factor * rules.hole_min_r_mm, cfg.stipple.resolved_max_radius_mm),
        add_remove_every=rc.add_remove_every,
        eye_sigma_mm=scielab.smallest_sigma_mm(cfg.view.distance_m),
        layer_weight=rc.layer_weight,
        view=(
            refine.ViewFilters(scielab.filters_mm(cfg.view.distance_m), rc.pixel_weight)
            if rc.objective == "viewer"
            else None
        ),
    )
    alpha_targets = np.stack([spray.resample(a, shape) for a in layers.alphas]) if layers.count else None

    from . import mural_refine
    from .simulate.cans import can_prior

    geometry = SprayGeometry.of_job(cfg) if cfg.spray.model == SprayModel.physical else None
    # refine.cans: prior refines for the expected error over a prior of cans (without a measured can).
    cans = can_prior(cfg.spray) if rc.cans == "prior" else [("nominal", cfg.spray)]
    kernels = [mural_refine.HoleKernels(sp, geometry) for _, sp in cans]

    times = [float(ds.report.get("spray_time", cfg.spray.amount)) for ds in dotsets]
    if grid is not None and grid.tiled:
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
        )
        halo = mural_refine.refine_halo_mm(cfg, settings.eye_sigma_mm)
        with run.stage("refine"):
            out, report = mural_refine.refine_mural(problem, grid, dotsets, halo, run.tasks.map)
        run.figures["refine"] = _plain(report)
        return out
    with run.stage("refine"):
        with run.bar(rc.iterations, "refine") as bar:
            out, report = refine.refine_dots(
                target,
                grid_mm,
                layers.primer,
                layers.colours,
                dotsets,
                [rules] * layers.count,
                kernels,
                times,
                settings,
                progress=lambda it, total: bar.update(1),
                alpha_targets=alpha_targets,
            )
    run.figures["refine"] = _plain(report)
    return out


def _order_note(cfg: JobConfig) -> str:
    """Why the paints come in this order, in one line for the swatch card."""
    if cfg.mode == Mode.hard:
        return {
            "light_to_dark": "light to dark: each darker paint covers the lighter ones",
            "dark_to_light": "dark to light (hard.order)",
            "given": "the order of hard.palette",
        }[cfg.hard.order.value]
    return {
        "auto": "each coat covers the ones before; this order reconstructs the picture best (decompose.order: auto)",
        "light_to_dark": "lightest paint first (decompose.order: light_to_dark)",
        "given": "the order of decompose.palette (decompose.order: given)",
    }[cfg.decompose.order.value]


def write_spray_order(run: Run, primer: np.ndarray, colours: np.ndarray, spray_times: list[float]) -> None:
    """Write ``spray.json`` (spray order, paints, spray times) and the swatch card ``swatch.png``."""
    from .simulate import labelled

    names = can_names(run.figures)
    if run.cfg.paints.can_names:
        from .decompose import paints

        hexes = [to_hex(c) for c in (primer, *colours)]
        names = {**paints.colour_names([h for h in hexes if h not in names]), **names}
    order = [
        {
            "step": i + 1,
            "plate": layer_stem(i),
            "hex": to_hex(c),
            "name": names.get(to_hex(c), ""),
            "spray_time": float(t),
        }
        for i, (c, t) in enumerate(zip(colours, spray_times, strict=True))
    ]
    sp = run.cfg.spray
    how: dict = {"unit": sp.amount_unit}
    if sp.model == SprayModel.physical:
        for o, t in zip(order, spray_times, strict=True):
            o["passes"] = max(1, round(float(t)))
        how.update(can_distance_cm=sp.can_distance_mm / 10.0, pass_speed_m_s=sp.pass_speed_m_s)
    else:
        how["nozzle_height"] = sp.nozzle_height
    run.out.write_json(
        SPRAY_JSON,
        {
            "primer": {"hex": to_hex(primer), "name": names.get(to_hex(primer), "")},
            "order": order,
            "spray_times": [float(t) for t in spray_times],
            **how,
        },
    )
    run.figures["spray_order"] = {
        "primer": {"hex": to_hex(primer), "name": names.get(to_hex(primer), "")},
        "note": _order_note(run.cfg),
        "unit": run.cfg.spray.amount_unit,
        "steps": order,
    }
    run.out.write_png(
        "swatch.png",
        labelled.swatch_card(
            to_hex(primer),
            [{**o, "note": f"plate {o['plate']}"} for o in order],
            order_note=_order_note(run.cfg),
            unit=run.cfg.spray.amount_unit,
            primer_name=names.get(to_hex(primer), ""),
        ),
    )


def plate_cards(
    run: Run, colours: np.ndarray, picture_mm: tuple[float, float], holes: list
) -> list[np.ndarray]:
    """The plate previews: outline with key tabs and label area, holes or cut-outs, header and scale."""
    from . import outline
    from .simulate import labelled

    cfg = run.cfg
    ring = outline.plate_outline(*picture_mm, cfg.plate.outline)
    box = outline.label_region(*picture_mm, cfg.plate.outline)
    names = can_names(run.figures)
    cards = []
    for i, h in enumerate(holes):
        hx = to_hex(colours[i])
        kw = (
            {"circles_xy_r": np.column_stack([h.xy_mm, h.r_mm]) if len(h) else np.zeros((0, 3))}
            if isinstance(h, DotSet)
            else {"polygons": h.polygons}
        )
        cards.append(
            labelled.plate_card(
                ring, box, picture_mm, i + 1, len(holes), hx, names.get(hx, ""), job=cfg.name, **kw
            )
        )
    return cards


def read_dots(folder: Path, count: int | None = None, max_time: float = 800.0) -> list[DotSet]:
    """Read the dots CSV files of a folder, in layer order, with ``spray.json``'s spray times.

    Args:
        folder: The run folder.
        count: Layers of the decomposition (the files must match), or None.
        max_time: Largest spray time ``spray.json`` may give a layer (8 x the config's cap:
            the tone calibration chooses up to 8 x the base amount).
    """
    from .exchange.dots_csv import dots_from_csv
    from .files import DATA_LIMIT
    from .files import read_text as read_checked

    files = sorted(folder.glob("layer_*_dots.csv"))
    if not files:
        raise UserError(
            f"no layer_NN_dots.csv in {folder} (run `stencil-cad stipple` first, or pass --from DIR)"
        )
    if count is not None and len(files) != count:
        raise UserError(f"{folder} has {len(files)} dots files but the decomposition has {count} layers")
    out = []
    for f in files:
        text = read_checked(f, "dots file", limit=DATA_LIMIT, fix="re-run `stencil-cad stipple`")
        try:
            out.append(dots_from_csv(text))
        except ValueError as exc:
            raise UserError(f"{f}: {str(exc)[:300]}") from None
        if len(out[-1]) == 0:
            log.warning(
                "%s has no holes: its plate will spray nothing (re-run `stencil-cad stipple`, or add rows "
                "x_mm,y_mm,r_mm)",
                f,
            )
    spray = folder / SPRAY_JSON
    if spray.exists() or spray.is_symlink():
        from dataclasses import replace

        times = read_spray_times(spray, len(out), max_time)
        out = [replace(ds, report={**ds.report, "spray_time": t}) for ds, t in zip(out, times, strict=True)]
    return out


def read_spray_times(path: Path, layers: int, max_time: float) -> list[float]:
    """The per-layer spray times of a ``spray.json``: one per layer, each in (0, ``max_time``].

    Raises:
        UserError: Not a regular file, not JSON, or the list's length or a value is wrong (named).
    """
    import math

    from .config.io import parse_json
    from .files import read_text as read_checked

    fix = "fix it, or delete it to use spray.spray_time"
    bad = f"{path}: not a valid spray-time file"
    try:
        data = parse_json(read_checked(path, "spray-time file", fix=fix), str(path))
    except ConfigError as exc:
        raise UserError(f"{bad} ({str(exc).removeprefix(f'{path}: ')}); {fix}") from None
    times = data.get("spray_times") if isinstance(data, dict) else None
    if not isinstance(times, list) or not all(
        isinstance(t, (int, float)) and not isinstance(t, bool) for t in times
    ):
        raise UserError(f"{bad}: spray_times must be a list of numbers, one per layer; {fix}")
    if len(times) != layers:
        raise UserError(f"{bad}: spray_times has {len(times)} values but there are {layers} layers; {fix}")
    for i, t in enumerate(times):
        if not (math.isfinite(t) and 0 < t <= max_time):
            raise UserError(f"{bad}: spray_times[{i}] must be in (0, {max_time:g}], got {t!r}; {fix}")
    return [float(t) for t in times]


def stage_build(run: Run, layers: Layers, holes: Sequence[Holes], picture_mm: tuple[float, float]) -> None:
    """Build, check and export one plate per layer and the wall(s)."""
    from . import cad, outline
    from .cad import wall as wall_mod
    from .exchange import dxf, svg

    cfg = run.cfg
    width_mm, height_mm = picture_mm
    exp = cfg.export
    results = []
    with run.stage("build"):
        ring = outline.plate_outline(width_mm, height_mm, cfg.plate.outline)
        with run.bar(len(holes), "build") as bar:
            for i, asked in enumerate(holes):
                # The plate draws each hole larger by what the process takes off (stipple.compensate).
                h = drawn_dots(asked, cfg.stipple, picture_mm) if isinstance(asked, DotSet) else asked
                label = cad.LabelInfo(
                    layer=i + 1,
                    layers=len(holes),
                    colour=to_hex(layers.colours[i]),
                    job=cfg.name,
                )
                try:
                    model = cad.build_plate(h, width_mm, height_mm, cfg.plate, label)
                except ValueError as exc:
                    # Holes that break the rules, a label that cannot fit, a bad template.
                    raise UserError(f"{layer_stem(i)}: {exc}") from exc
                check = cad.check_plate(model, h, tolerance_mm=exp.stl_tolerance_mm)
                stem = layer_stem(i)
                cad.write_mesh_files(run.out, model, stem, exp)
                dxf_info = {}
                drawing = dxf.stencil_for(h, ring, stem.upper(), *model.cut_label())
                if exp.dxf:
                    with run.out.open_path(f"{stem}.dxf") as p:
                        info = dxf.write_dxf_stencils(
                            p,
                            [drawing],
                            kerf_mm=exp.kerf_mm,
                            # Fixed dates and GUIDs: the same job writes the same bytes, wherever it ran.
                            deterministic=True,
                        )
                    # Laser software wants +X/+Y: the drawing is shifted by this much from the picture frame.
                    dxf_info = {"dxf_offset_mm": [round(float(v), 4) for v in info.offset_mm]}
                if exp.svg:
                    with run.out.open_path(f"{stem}.svg") as p:
                        sinfo = svg.write_svg(
                            p, drawing, kerf_mm=exp.kerf_mm, title=f"{cfg.name} {stem} of {len(holes)}"
                        )
                    dxf_info["svg_offset_mm"] = [round(float(v), 4) for v in sinfo.offset_mm]
                    dxf_info["svg_circles"] = sinfo.circles  # type: ignore[assignment]
                cut = round(dxf.cut_length_mm(h, ring), 1)
                (x0, y0, _), (x1, y1, _) = check["bbox"]
                size = [round(x1 - x0, 3), round(y1 - y0, 3)]
                row = {"layer": i + 1, **_plain(check), **dxf_info, "cut_length_mm": cut, "bbox_mm": size}
                if isinstance(h, CutLayer):
                    row["cutouts"] = h.cutout_figures()
                elif len(h.r_mm):
                    row["drawn_minus_asked_mm"] = round(float(np.mean(h.r_mm - asked.r_mm)), 4)
                results.append(row)
                bar.update(1)
        walls = []
        heights = wall_mod.wall_heights(cfg.wall)
        for standoff, stem in zip(heights, wall_stems(heights), strict=True):
            wm = wall_mod.build_wall(
                width_mm, height_mm, cfg.plate.outline, cfg.wall, cfg.plate.thickness_mm, standoff
            )
            with run.out.open_path(f"{stem}.step") as p:
                wall_mod.wall_step(wm, p)
            with run.out.open_path(f"{stem}.stl") as p:
                wall_mod.wall_stl(wm, p, exp.stl_tolerance_mm)
            walls.append({"file": f"{stem}.step", "standoff_mm": standoff, **wall_mod.check_wall(wm)})
    run.figures["build"] = {"plates": results, "walls": walls}


def simulated_stems(cfg: JobConfig) -> list[str]:
    """Extra simulated pictures, one per wall, when the physical model sees several stand-offs."""
    heights = cfg.wall.heights()
    if cfg.spray.model != SprayModel.physical or len(heights) == 1:
        return []
    return [f"simulated_{stem}.png" for stem in wall_stems(heights)]


def stage_simulate(
    run: Run,
    picture: Picture | None,
    layers: Layers,
    dotsets: list[DotSet],
    keep: bool = False,
    as_made: bool = True,
):
    """Spray every plate in simulation, composite, score against the input, save previews.

    Returns the scores, or with ``keep`` the simulation and the reference on its grid. With
    ``as_made`` (a one-plate job) the holes are sprayed as the process makes them
    (:func:`stencil_cad.stipple.made.made_dots`); a mural's are sprayed as asked.

    Under the physical model every wall height gets its own simulation and score
    (``simulated_wall_10mm.png`` …); the main pictures and scores are those of the design
    stand-off (``wall.standoff_mm[0]``), which the tone calibration designed the dots for.
    """
    from . import resolution, simulate
    from .simulate.physical import SprayGeometry

    cfg = run.cfg
    physical = cfg.spray.model == SprayModel.physical
    design = SprayGeometry.of_job(cfg) if physical else None
    if as_made:
        # Spray the holes as the process makes them (stipple.hole_offset_mm), not as asked.
        size_mm = (layers.alphas.shape[2] * layers.mm_per_px, layers.alphas.shape[1] * layers.mm_per_px)
        dotsets = [made_dots(d, cfg.stipple, size_mm) if isinstance(d, DotSet) else d for d in dotsets]
    with run.stage("simulate"):
        grid_mm = resolution.sim_mm_per_px(cfg)
        sim = simulate.simulate(layers, dotsets, cfg.spray, grid_mm, geometry=design)
        ref = source_reference(cfg, picture, layers, sim.composite.shape[:2], sim.mm_per_px)
        scores = _scores(run, ref, sim.composite, sim.mm_per_px)
        by_can = _scores_by_can(run, layers, dotsets, ref, grid_mm, design, scores)
        run.out.write_png("simulated.png", sim.composite)
        ideal = _resample(layers.composite(), sim.composite.shape[:2])
        write_previews(run, ref, ideal, sim.composite, sim.mm_per_px, scores)
        factors = tuple(cfg.spray.sweep_factors)
        panels = simulate.sweep_panels(layers, dotsets, cfg.spray, grid_mm, factors=factors, geometry=design)
        from .simulate import labelled

        run.out.write_png(
            "sweep.png", labelled.sweep_card(panels, factors, sim.mm_per_px, unit=cfg.spray.amount_unit)
        )
        write_steps(run, layers.primer, layers.colours, sim.alphas, sim.mm_per_px)
        per_wall = []
        stems = simulated_stems(cfg)
        for h, name in zip(cfg.wall.heights() if stems else [], stems, strict=True):
            # Extra walls exist only under the physical model, where design is set.
            assert design is not None
            if h == design.standoff_mm:
                other, other_scores = sim, scores
            else:
                other = simulate.simulate(
                    layers, dotsets, cfg.spray, grid_mm, geometry=SprayGeometry.of_job(cfg, h)
                )
                other_scores = simulate.score(ref, other.composite)
            run.out.write_png(name, other.composite)
            per_wall.append(
                {
                    "standoff_mm": h,
                    "file": name,
                    "blur_sigma_mm": other.info["blur_sigma_mm"],
                    **_plain(other_scores),
                }
            )
    run.figures["simulate"] = {
        **_plain(scores),
        **_dot_visibility(run, layers, dotsets),
        "layer_rmse": [float(x) for x in sim.layer_rmse],
        **{k: v for k, v in _plain(sim.info).items() if k not in scores},
    }
    if by_can:
        run.figures["simulate"]["scielab_by_can"] = by_can
        run.figures["simulate"]["scielab_worst"] = max(by_can.values())
    if per_wall:
        run.figures["simulate"]["walls"] = per_wall
    run.figures["spraying"] = spraying_steps(
        cfg, layers, [float(ds.report.get("spray_time", cfg.spray.amount)) for ds in dotsets]
    )
    return (sim, ref) if keep else scores


#: Overshoot of a sweep past each edge of the picture, mm: a pass starts and ends off the plate.
SWEEP_OVERSHOOT_MM = 50.0


def sweep_seconds(cfg: JobConfig, width_mm: float, height_mm: float) -> float:
    """About how long one pass over the picture takes, in seconds.

    A pass is sweeps across the picture's width, each starting and ending ``SWEEP_OVERSHOOT_MM``
    off it, in rows half the can distance apart (the band a can sprays evenly is about half its
    distance wide), at ``spray.pass_speed_m_s``.
    """
    sp = cfg.spray
    rows = max(1, math.ceil(height_mm / (0.5 * sp.can_distance_mm)))
    return rows * (width_mm + 2.0 * SWEEP_OVERSHOOT_MM) / (1000.0 * sp.pass_speed_m_s)


def source_reference(
    cfg: JobConfig, picture: Picture | None, layers: Layers, shape: tuple[int, int], mm_per_px: float
) -> np.ndarray:
    """The picture every simulation is scored against: the source image resized to the simulated grid.

    Scoring against the picture at the job's working resolution would hide every detail that
    resolution lost (the bundled example: 5.60 against the working picture, 5.87 against the
    source, S-CIELAB at 1 m under the paper model). Without a picture (a stage command run on
    saved layers), the decomposition's own composite.
    """
    if picture is None:
        return _resample(layers.composite(), shape)
    if picture.source != ("bundled example" if cfg.image is None else str(cfg.image)):
        # A picture that does not come from the job's image file (made in code): its own pixels.
        return _resample(picture.rgb, shape)
    from dataclasses import replace

    from .imaging import load_picture as _load

    h_mm = shape[0] * mm_per_px
    src = _load(cfg.image, shape[1] * mm_per_px, h_mm, 1.0 / mm_per_px, max_upscale=math.inf)
    if src.alpha is not None and cfg.decompose.opacity_source != "alpha":
        a = src.alpha[..., None]
        src = replace(src, rgb=src.rgb * a + (1.0 - a))
    return _resample(src.rgb, shape)


def _scores_by_can(
    run: Run, layers: Layers, dotsets: list[DotSet], ref, grid_mm, design, nominal: dict
) -> dict:
    """S-CIELAB at the viewing distance for every can of the prior (:mod:`.simulate.cans`), by name.

    Empty when the prior is one can (the paper model, or a measured spray profile).
    """
    from . import simulate
    from .simulate import scielab
    from .simulate.cans import can_prior

    cans = can_prior(run.cfg.spray)
    if len(cans) < 2:
        return {}
    out = {}
    for name, sp in cans:
        if name == "nominal":  # the job's own can, already simulated and scored
            out[name] = float(nominal["scielab"])
            continue
        other = simulate.simulate(layers, dotsets, sp, grid_mm, geometry=design)
        out[name] = float(
            scielab.scielab(
                ref, other.composite, other.mm_per_px, run.cfg.view.distance_m, tasks_map=run.tasks.map
            )
        )
    return out


def spraying_steps(cfg: JobConfig, layers: Layers, amounts: Sequence[float]) -> list[dict]:
    """What the hand does for each layer, in the maker's units (physical model) or the model's.

    Args:
        cfg: The job config.
        layers: The decomposition (for the paint colours and the picture's size).
        amounts: Each layer's amount of paint: passes (physical) or spray time (paper).

    Returns:
        One dict per layer: ``layer``, ``paint``, and ``passes``, ``can_distance_cm``,
        ``pass_speed_m_s``, ``spray_seconds`` (physical) or ``spray_time`` (paper), and ``text``.
    """
    sp = cfg.spray
    out = []
    h_px, w_px = layers.alphas.shape[1:] if layers.count else (0, 0)
    per_pass = sweep_seconds(cfg, w_px * layers.mm_per_px, h_px * layers.mm_per_px)
    for i, amount in enumerate(amounts):
        paint = to_hex(layers.colours[i])
        if sp.model == SprayModel.physical:
            n = max(1, round(amount))
            cm = sp.can_distance_mm / 10.0
            seconds = n * per_pass
            text = (
                f"spray layer {i + 1} ({paint}): {n} light pass{'' if n == 1 else 'es'} from {cm:g} cm at "
                f"about {sp.pass_speed_m_s:g} m/s (about {seconds:.0f} s of spraying)"
                + ("; let each pass flash off (about a minute) before the next" if n > 1 else "")
            )
            out.append(
                {
                    "layer": i + 1,
                    "paint": paint,
                    "passes": n,
                    "can_distance_cm": cm,
                    "pass_speed_m_s": sp.pass_speed_m_s,
                    "spray_seconds": round(seconds, 1),
                    "text": text,
                }
            )
        else:
            text = (
                f"spray layer {i + 1} ({paint}) for spray time {amount:.3g} (paper model units; "
                "spray.model: physical gives passes and distances)"
            )
            out.append({"layer": i + 1, "paint": paint, "spray_time": round(amount, 4), "text": text})
    return out


def _scores(run: Run, reference: np.ndarray, sprayed: np.ndarray, mm_per_px: float) -> dict:
    """Pixel scores and S-CIELAB at the viewing distance and twice it, on one grid."""
    from . import simulate
    from .simulate import scielab

    scores = simulate.score(reference, sprayed)
    scores.update(scielab.view_scores(reference, sprayed, mm_per_px, run.cfg.view.distance_m, run.tasks.map))
    return scores


def _dot_visibility(run: Run, layers: Layers, dotsets: list[DotSet]) -> dict:
    """From how far the smallest holes in the most contrasting paint blend (see :mod:`.simulate.visibility`)."""
    from .simulate.physical import SprayGeometry
    from .simulate.visibility import blend_distance_m

    cfg = run.cfg
    if layers.count == 0:
        return {}
    lum = np.array([0.2126, 0.7152, 0.0722])
    k = int(np.argmax(np.abs((layers.colours - layers.primer) @ lum)))
    r = cfg.stipple.resolved_hole_min_r_mm
    a = float(dotsets[k].report.get("spray_time", cfg.spray.amount))
    d = blend_distance_m(
        r,
        cfg.stipple.resolved_web_mm,
        cfg.spray,
        a,
        layers.colours[k],
        layers.primer,
        cfg.stipple.auto_spacing_factor,
        geometry=SprayGeometry.of_job(cfg) if cfg.spray.model == SprayModel.physical else None,
    )
    return {"dots_blend_m": d, "dots_blend_layer": k + 1, "dots_hole_r_mm": r}


def _score_line(scores: dict) -> str:
    """The scores under the preview: what a viewer sees (S-CIELAB) and pixel by pixel (ΔE2000)."""
    d = scores["view_distance_m"]
    return (
        f"S-CIELAB at {d:g} m {scores['scielab']:.2f}, at {2 * d:g} m {scores['scielab_2x']:.2f}   ·   "
        f"ΔE2000 per pixel: mean {scores['de2000_mean']:.2f}, 95 % below {scores['de2000_p95']:.1f}"
    )


def write_previews(run: Run, reference, ideal, sprayed, mm_per_px: float, scores: dict) -> None:
    """The labelled four-panel ``preview.png``: input, ideal layers, simulated spray, error map."""
    from . import simulate
    from .simulate import labelled

    de_max = 30.0
    notes = [
        _score_line(scores),
        f"PSNR {scores['psnr']:.1f} dB, SSIM {scores['ssim']:.2f}  ·  "
        f"picture {sprayed.shape[1] * mm_per_px:g} × {sprayed.shape[0] * mm_per_px:g} mm",
    ]
    run.out.write_png(
        "preview.png",
        labelled.job_preview(
            reference,
            ideal,
            sprayed,
            simulate.delta_e_map(reference, sprayed),
            simulate.colour_map,
            de_max,
            mm_per_px,
            notes=notes,
        ),
    )


def step_name(i: int) -> str:
    """File name of the simulated picture after layer ``i`` (0-based)."""
    return f"{layer_stem(i)}_after.png"


def write_steps(
    run: Run, primer: np.ndarray, colours: np.ndarray, alphas: np.ndarray, mm_per_px: float
) -> None:
    """Per layer, the simulated picture after it is sprayed, and its paint estimate."""
    from .decompose import paints
    from .model import composite

    cfg = run.cfg.paints
    area = float(alphas.shape[1] * alphas.shape[2]) * mm_per_px**2
    rows = []
    for i in range(alphas.shape[0]):
        run.out.write_png(
            step_name(i), np.clip(composite(primer, colours[: i + 1], alphas[: i + 1]), 0.0, 1.0)
        )
        mean = float(np.mean(alphas[i]))
        est = paints.paint_estimate(area, mean, cfg.coverage_m2_per_can, cfg.can_ml)
        rows.append({"layer": i + 1, "hex": to_hex(colours[i]), "mean_opacity": mean, **est})
    run.figures["paint"] = {
        "sprayed_area_m2": area * 1e-6,
        "coverage_m2_per_can": cfg.coverage_m2_per_can,
        "can_ml": cfg.can_ml,
        "layers": rows,
    }


def _resample(img: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    from skimage.transform import resize

    if img.shape[:2] == tuple(shape):
        return img
    return np.clip(resize(img, (*shape, img.shape[2]), order=1, anti_aliasing=True), 0, 1)


# --------------------------------------------------------------------------- commands


def check_template(run: Run) -> None:
    """Load and check the plate template before the first stage; record path and SHA-256.

    Raises:
        UserError: The template is not a Python file, fails to load, or has bad parameters.
    """
    from . import cad

    try:
        run.template = cad.check_plate_template(run.cfg.plate)
    except ValueError as exc:
        raise UserError(f"plate.template: {exc}") from None
    if not run.template["builtin"]:
        log.info("plate template %s is Python code and runs with your rights", run.template["path"])


def bound_dots(run: Run, picture_mm: tuple[float, float]) -> None:
    """Cap ``stipple.dots`` at the most holes that fit the picture under the design rules.

    Too many dots cost memory and time in the relaxation and are then removed by the
    rules anyway; the cap is named in a warning.
    """
    from .bounds import max_dots

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


def save_config(run: Run) -> None:
    """Write the resolved config beside the results, so stage commands can re-read it."""
    data = run.cfg.model_dump(mode="json")
    # Absolute paths, so the copy runs from anywhere.
    if run.cfg.image is not None:
        data["image"] = str(Path(run.cfg.image).resolve())
    if run.cfg.plate.template is not None:
        data["plate"]["template"] = str(Path(run.cfg.plate.template).resolve())
    run.out.write_text(CONFIG_COPY, yaml.safe_dump(data, sort_keys=False))


def finish(run: Run, command: str) -> list[Path]:
    """Write the manifest and move every file into place."""
    if run.executor is not None and "compute" in run.figures:
        run.figures["compute"]["tasks"] = run.executor.tasks
    manifest = {
        **manifest_header(),
        "command": command,
        "stencil_cad": __version__,
        "versions": _versions(),
        "config": run.cfg.model_dump(mode="json"),
        "seconds": run.times,
        **run.figures,
        "files": run.out.file_table(),
    }
    if run.template is not None:
        manifest["template"] = run.template
    old_path = run.out.path / MANIFEST
    if command != "run" and command != "hard" and old_path.exists():
        manifest = _merge_manifest(old_path, manifest, run.out)
        run.stale = manifest.get("stale", {}).get("files", [])
    if command in ("run", "hard") and run.cfg.export.instructions:
        with run.stage("instructions"):
            write_instructions(run, manifest)
        manifest["seconds"] = run.times
        manifest["files"] = run.out.file_table()
    run.out.write_json(MANIFEST, manifest)
    return run.out.commit()


INSTRUCTIONS = ("instructions.html", "instructions.pdf")


def write_instructions(run: Run, manifest: dict, tiles: list | None = None) -> None:
    """Write the instruction sheet (HTML and PDF) from the manifest and the job's preview images.

    Args:
        run: The command's state; its staged PNGs and ``sheet_images`` are the pictures.
        manifest: The manifest as it will be written (its file list so far).
        tiles: A mural's tiles (see :func:`stencil_cad.sheet.sheet_from_manifest`); None takes
            them from the manifest when present.
    """
    from . import sheet

    listed = [*manifest.get("files", []), *({"name": n} for n in INSTRUCTIONS)]
    data = sheet.sheet_from_manifest({**manifest, "files": listed}, tiles=tiles)
    images = dict(run.sheet_images)
    for name in run.out.files:
        if name.endswith(".png"):
            images[name] = (run.out.stage / name).read_bytes()
    run.out.write_text(INSTRUCTIONS[0], sheet.render_html(data, images))
    run.out.write_bytes(INSTRUCTIONS[1], sheet.render_pdf(data, images))


def _merge_manifest(old_path: Path, new: dict, out: OutputDir) -> dict:
    """A stage command adds its figures and files to the folder's existing manifest."""
    from .output import read_manifest

    old = read_manifest(old_path)
    if old is None:
        return new
    merged = {**old, **{k: v for k, v in new.items() if k not in ("seconds", "files")}}
    merged.update(manifest_header())
    merged["command"] = f"{old.get('command', '?')} + {new['command']}"
    merged["seconds"] = {**old.get("seconds", {}), **new["seconds"]}
    written = {row["name"] for row in new["files"]}
    kept = [
        row
        for row in old.get("files", [])
        if isinstance(row, dict)
        and row.get("name") not in written
        and (out.path / str(row.get("name"))).is_file()
    ]
    merged["files"] = kept + new["files"]
    merged.pop("stale", None)
    stale = stale_files(new["command"], [str(r["name"]) for r in kept], old.get("stale"), written)
    if stale:
        later = ", ".join(f"`stencil-cad {c}`" for c in LATER_STAGES.get(new["command"], ()))
        merged["stale"] = {
            "files": stale,
            "why": f"made before `stencil-cad {new['command']}` ran again; re-run {later or 'them'} (or `stencil-cad run`)",
        }
    return merged


#: The files each stage writes (shell patterns), for telling which files a re-run makes stale.
STAGE_FILES = {
    "stipple": ("layer_*_dots.csv", "layer_*_dots.png", SPRAY_JSON, "swatch.png"),
    "build": ("layer_[0-9][0-9].*", "wall*.step", "wall*.stl", "tile_*", "mural_map.png"),
    "simulate": ("simulated*.png", "preview.png", "sweep.png", "layer_*_after.png"),
    "instructions": INSTRUCTIONS,
}
#: The stages that read what each stage writes, directly or through another.
LATER_STAGES = {
    "decompose": ("stipple", "build", "simulate"),
    "stipple": ("build", "simulate"),
    "build": (),
    "simulate": (),
}


def stale_files(command: str, kept: list[str], earlier: object, written: set[str]) -> list[str]:
    """Files left in a folder that a re-run of ``command`` made out of date.

    Args:
        command: The stage command that just ran.
        kept: Names of the files it left in place.
        earlier: The manifest's ``stale`` record before this run (its files stay stale).
        written: Names this run wrote (no longer stale).

    Returns:
        Sorted names: files of later stages (and the instruction sheet, which shows every stage).
    """
    import fnmatch

    before = set(earlier.get("files", [])) if isinstance(earlier, dict) else set()
    stages = (*LATER_STAGES.get(command, ()), "instructions")
    now = {n for n in kept if any(fnmatch.fnmatch(n, p) for s in stages for p in STAGE_FILES[s])}
    return sorted(((before & set(kept)) | now) - written)


def _versions() -> dict:
    from importlib.metadata import PackageNotFoundError, version

    out: dict[str, str | None] = {"python": platform.python_version()}
    for dist in ("build123d", "cadquery-ocp", "numpy", "scipy", "scikit-image", "ezdxf", "numba"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = None
    out["OCP"] = out.pop("cadquery-ocp")
    return out


def run_all(run: Run, picture: Picture | None = None) -> list[Path]:
    """The whole job: every stage in order."""
    if picture is None:
        with run.stage("load"):
            picture = load_picture(run.cfg)
    if run.template is None:
        check_template(run)
    cfg = run.cfg
    save_config(run)
    run.sheet_images["input.png"] = _png(picture.rgb)
    size = (picture.width_mm, picture.height_mm)
    run.figures["picture"] = {
        "source": picture.source,
        "width_mm": round(size[0], 3),
        "height_mm": round(size[1], 3),
        "pixels": list(picture.shape),
        "mm_per_px": picture.mm_per_px,
    }
    grid = plan_mural(run, size, picture.shape)
    if cfg.mode == Mode.hard:
        if grid.tiled:
            raise UserError(
                f"hard mode makes one plate per layer, and a {size[0]:.0f} × {size[1]:.0f} mm picture's plate does "
                f"not fit the bed {grid.bed}; use soft mode for a tiled mural, a larger bed or a smaller size"
            )
        return run_hard(run, picture)
    bound_dots(run, size)
    layers = stage_decompose(run, picture)
    dotsets = stage_stipple(run, layers, size, picture, grid)
    build_any(run, layers, dotsets, size, grid, picture)
    return finish(run, "run")


CARD_JSON = "card.json"


def card_stems(standoffs_mm: list[float]) -> list[str]:
    """File stems of the card's walls: ``card_wall_6mm`` … (one per stand-off)."""
    return [f"card_wall_{h:g}mm" for h in sorted(set(standoffs_mm))]


def run_card(run: Run, standoffs_mm: list[float] | None = None, paper: str = "a4") -> list[Path]:
    """`stencil-cad card`: the calibration plate, a wall per stand-off, the sheet and ``card.json``.

    The plate takes the job's hole radii, web, plate and key; it is built, checked and exported
    exactly like a layer's plate, and its walls like the job's.
    """
    from dataclasses import replace

    from . import cad, outline
    from . import stipple as stipple_mod
    from .cad import wall as wall_mod
    from .exchange import dxf
    from .testcard import layout as card_mod
    from .testcard import sheet as sheet_mod

    cfg = run.cfg
    try:
        card = card_mod.card_layout(cfg, standoffs_mm)
    except ValueError as exc:
        raise UserError(f"card: {exc}") from exc
    w, h = card.width_mm, card.height_mm
    exp = cfg.export
    with run.stage("card"):
        # The job's process rules, without its picture's keep-outs.
        rules = replace(stipple_mod.rules_from_config(cfg.stipple, w, h), keepouts=())
        label = cad.LabelInfo(layer=1, layers=1, colour="", job="CARD")
        try:
            model = cad.build_plate(card.dots, w, h, cfg.plate, label, rules=rules)
        except ValueError as exc:
            raise UserError(f"card plate: {exc}") from exc
        check = cad.check_plate(model, card.dots, tolerance_mm=exp.stl_tolerance_mm)
        with run.out.open_path("card_plate.step") as p:
            cad.write_step(model, p)
        with run.out.open_path("card_plate.stl") as p:
            cad.write_stl(model, p, exp.stl_tolerance_mm)
        ring = outline.plate_outline(w, h, cfg.plate.outline)
        with run.out.open_path("card_plate.dxf") as p:
            drawing = dxf.stencil_for(card.dots, ring, "CARD", *model.cut_label())
            dxf.write_dxf_stencils(p, [drawing], kerf_mm=exp.kerf_mm)
        walls = []
        heights = [fp.standoff_mm for fp in card.footprints]
        for g, stem in zip(heights, card_stems(heights), strict=True):
            wm = wall_mod.build_wall(w, h, cfg.plate.outline, cfg.wall, cfg.plate.thickness_mm, g)
            with run.out.open_path(f"{stem}.step") as p:
                wall_mod.wall_step(wm, p)
            with run.out.open_path(f"{stem}.stl") as p:
                wall_mod.wall_stl(wm, p, exp.stl_tolerance_mm)
            walls.append({"file": f"{stem}.step", "standoff_mm": g, **wall_mod.check_wall(wm)})
        run.out.write_png("card_sheet.png", sheet_mod.sheet_png(card))
        sp = cfg.spray
        steps = sheet_mod.card_steps(card, sp.can_distance_mm, sp.pass_speed_m_s)
        try:
            pdf = sheet_mod.sheet_pdf(card, paper=paper, steps=steps)
        except ValueError as exc:
            raise UserError(f"card sheet: {exc}") from exc
        run.out.write_bytes("card_sheet.pdf", pdf)
        run.out.write_json(
            CARD_JSON,
            card_mod.card_description(
                card,
                {
                    "job": cfg.name,
                    "spray": {
                        "can_distance_mm": sp.can_distance_mm,
                        "pass_speed_m_s": sp.pass_speed_m_s,
                        "passes": card.passes,
                    },
                    "files": {
                        "plate": "card_plate.step",
                        "walls": [f"{s}.step" for s in card_stems(heights)],
                        "sheet": "card_sheet.pdf",
                    },
                },
            ),
        )
    size = ring.max(axis=0) - ring.min(axis=0)
    run.figures["card"] = {
        "holes": len(card.dots),
        "plate_mm": [round(float(v), 2) for v in size],
        "standoffs_mm": heights,
        "features": [
            {
                "kind": f.kind,
                "holes": len(f.index),
                "r_mm": f.r_mm,
                "open_fraction": round(f.open_fraction, 4),
            }
            for f in card.features
        ],
        "plate": _plain(check),
        "walls": walls,
        "sheet_mm": [round(v, 1) for v in card.sheet_mm],
        "paper": paper,
        "passes": card.passes,
    }
    return finish(run, "card")


def plan_mural(run: Run, picture_mm: tuple[float, float], shape_px: tuple[int, int]):
    """Tile the picture for the bed (one tile when it fits) and check every part fits, before any work."""
    from . import mural_stages

    grid, fig = mural_stages.plan(
        run.cfg, *picture_mm, plate_layers(run.cfg), int(shape_px[0]) * int(shape_px[1])
    )
    run.figures["mural"] = fig
    return grid


def plate_layers(cfg: JobConfig) -> int:
    """Plates per tile the job plans for: the paint layers, or in hard mode one per colour but the primer."""
    if cfg.mode != Mode.hard:
        return cfg.decompose.layers
    # A palette given as a list fixes the colours; a can list's length is known once it is read.
    palette = cfg.hard.palette
    return (len(palette) if isinstance(palette, list) else cfg.hard.colours) - 1


def build_any(
    run: Run,
    layers: Layers,
    dotsets: list[DotSet],
    picture_mm: tuple[float, float],
    grid,
    picture=None,
    simulate: bool = True,
) -> None:
    """Build (and simulate): one plate per layer, or per tile and layer for a mural."""
    from . import mural_stages

    if not grid.tiled:
        stage_build(run, layers, dotsets, picture_mm)
        if run.cfg.export.print_estimate:
            stage_print_estimate(run)
        if simulate:
            stage_simulate(run, picture, layers, dotsets)
        return
    per_tile = mural_stages.stage_build_tiles(run, layers, dotsets, grid)
    mural_stages.write_map(run, grid, layers, picture)
    if not simulate:
        return
    # A mural's plates are drawn as asked (no compensation yet) and sprayed so.
    sim, ref = stage_simulate(run, picture, layers, dotsets, keep=True, as_made=False)
    mural_stages.stage_mural_simulate(run, sim, ref, layers, dotsets, grid, per_tile)


def run_hard(run: Run, picture: Picture) -> list[Path]:
    """Hard-stencil mode: segmentation, bridges, plates with polygon cut-outs, simulation."""
    from . import hardstencil

    # Cut-outs are sprayed from their own nozzle height: the simulation, the spray order and
    # the maker's spraying steps all read it from the spray section.
    # Under the physical model a cut-out gets whole passes enough for full cover.
    spray = run.cfg.spray.model_copy(update={"nozzle_height": run.cfg.hard.nozzle_height})
    if spray.is_physical:
        spray = spray.model_copy(update={"passes": float(spray.full_cover_passes())})
    cfg = run.cfg = run.cfg.model_copy(update={"spray": spray})
    size = (picture.width_mm, picture.height_mm)
    with run.stage("segment"):
        rules = _process_rules(cfg)
        hcfg = _with_can_list(run, cfg.hard, "hard.palette")
        try:
            hard = hardstencil.make_hard_stencils(
                picture, hcfg, rules["min_feature_mm"], rules["bridge_min_mm"], run.rng_for("hard")
            )
        except ValueError as exc:
            raise UserError(f"hard mode: {exc}") from exc
        if hard.count == 0:
            raise UserError(
                "hard mode: the image has a single flat colour, so there is nothing to cut "
                "(prime the surface with it, or use an image with more colours)"
            )
        run.out.write_png("segmentation.png", hard.palette[hard.labels])
        colours = np.array([cl.colour for cl in hard.cut_layers]).reshape(-1, 3)
        for i, card in enumerate(plate_cards(run, colours, size, hard.cut_layers)):
            run.out.write_png(f"{layer_stem(i)}_cut.png", card)
        write_spray_order(run, hard.primer, colours, [float(cfg.spray.amount)] * hard.count)
    run.figures["hard"] = _plain(hard.report)
    run.figures["hard"]["warnings"] = [str(w) for w in hard.report.get("warnings", [])]
    run.figures["hard"]["per_layer"] = [_plain(r) for r in hard.report.get("per_layer", [])]
    layers = Layers(
        primer=hard.primer,
        colours=np.array([cl.colour for cl in hard.cut_layers]).reshape(-1, 3),
        alphas=hard.cut_masks.astype(np.float64),
        mm_per_px=picture.mm_per_px,
    )
    stage_build(run, layers, hard.cut_layers, size)
    with run.stage("simulate"):
        from .simulate.physical import SprayGeometry

        geometry = SprayGeometry.of_job(cfg) if cfg.spray.model == SprayModel.physical else None
        alphas, comp = hardstencil.simulate_hard(hard, cfg.spray, geometry=geometry)
        scores = _scores(run, picture.rgb, comp, picture.mm_per_px)
        run.out.write_png("simulated.png", comp)
        write_previews(run, picture.rgb, hardstencil.render_ideal(hard), comp, picture.mm_per_px, scores)
        write_steps(run, hard.primer, hard.colours, alphas, picture.mm_per_px)
    run.figures["simulate"] = _plain(scores)
    run.figures["spraying"] = spraying_steps(cfg, layers, [float(cfg.spray.amount)] * layers.count)
    return finish(run, "hard")


#: Files a whole run writes besides the ``layer_NN*`` and ``wall*`` files.
RUN_FILES = (
    CONFIG_COPY,
    LAYERS_NPZ,
    SPRAY_JSON,
    MANIFEST,
    "swatch.png",
    "composite.png",
    "energy.csv",
    "simulated.png",
    "preview.png",
    "sweep.png",
    "segmentation.png",
)


def run_outputs(cfg: JobConfig, command: str) -> list[str]:
    """Names and patterns of the files a whole run or `decompose` may write (checked before work)."""
    if command == "decompose":
        return [
            CONFIG_COPY,
            LAYERS_NPZ,
            MANIFEST,
            "swatch.png",
            "composite.png",
            "energy.csv",
            "layer_*_opacity.png",
        ]
    return [*RUN_FILES, "layer_*", "wall*", "tile_*", "mural_map.png"]


def stage_outputs(cfg: JobConfig, command: str, count: int, grid=None) -> list[str]:
    """Names a stage command will write, so it can refuse before doing the work."""
    if command == "build" and grid is not None and grid.tiled:
        from . import mural_stages

        return mural_stages.tile_outputs(cfg, grid, count)
    if command == "stipple":
        return [n for i in range(count) for n in (dots_name(i), f"{layer_stem(i)}_dots.png")] + [
            SPRAY_JSON,
            "swatch.png",
        ]
    if command == "build":
        exts = cfg.export.plate_extensions()
        names = [layer_stem(i) + e for i in range(count) for e in exts]
        return names + [s + e for s in wall_stems(cfg.wall.standoff_mm) for e in (".step", ".stl")]
    if command == "simulate":
        return ["simulated.png", "preview.png", "sweep.png", *simulated_stems(cfg)] + [
            step_name(i) for i in range(count)
        ]
    return []


def check_dots(cfg: JobConfig, dotsets: list[DotSet], picture_mm: tuple[float, float]) -> None:
    """Check dots read from files against the design rules before any CAD.

    Raises:
        UserError: Naming the file's layer and the first offending dots.
    """
    from .stipple import rules as rules_mod

    rules = rules_mod.rules_from_config(cfg.stipple, *picture_mm)
    for i, ds in enumerate(dotsets):
        try:
            rules_mod.check_rules(ds.xy_mm, ds.r_mm, rules)
        except ValueError as exc:
            raise UserError(f"{dots_name(i)}: {exc}") from None


def _process_rules(cfg: JobConfig) -> dict:
    from .stipple.rules import rules_from_config

    rules = rules_from_config(cfg.stipple, cfg.size.width_mm, cfg.size.height_mm or cfg.size.width_mm)
    return {"min_feature_mm": 2 * rules.hole_min_r_mm, "bridge_min_mm": max(rules.web_mm, 1.0)}


# --------------------------------------------------------------------------- helpers


def _png(image: np.ndarray) -> bytes:
    """PNG bytes of a float image in [0, 1]."""
    import io

    from PIL import Image

    a = (np.clip(np.asarray(image, dtype=np.float64), 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, format="PNG")
    return buf.getvalue()


# --------------------------------------------------------------------------- the commands

#: Commands that run one stage on the intermediates a previous command saved.
STAGE_COMMANDS = ("stipple", "build", "simulate")


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
) -> tuple[Run, list[Path]]:
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

    Returns:
        ``(run, files)``: the run's state (figures, timings) and the files written.
    """
    stage_cmd = command in STAGE_COMMANDS
    src = (src or out_path) if stage_cmd else None
    # `decompose` is a stage too: it adds to a run's folder and never removes later stages' files.
    run = Run(cfg=cfg, out=None, quiet=quiet)  # type: ignore[arg-type]
    # Everything that can be checked is checked before the first stage: the template (Python
    # code, loaded now), the output folder (created, locked, probed for writing), the image.
    if command in ("run", "hard", "build"):
        check_template(run)
    out = OutputDir(out_path, force=force, allow_existing=stage_cmd or command == "decompose")
    run.out = out
    t0 = time.perf_counter()
    try:
        if not stage_cmd:
            out.check_free(run_outputs(cfg, command))
        picture = None
        if command in ("run", "decompose", "hard", "simulate", "stipple"):
            try:
                with run.stage("load"):
                    picture = load_picture(cfg)
            except UserError:
                # `simulate` scores, and `stipple` refines, against the decomposition when the image is gone.
                if command not in ("simulate", "stipple"):
                    raise
        if picture is not None and command in ("run", "hard") and announce is not None:
            from . import mural_stages

            shape = picture.shape
            _, plan = mural_stages.plan(
                cfg, picture.width_mm, picture.height_mm, plate_layers(cfg), shape[0] * shape[1]
            )
            announce(mural_stages.plan_line(plan))
        if command in ("run", "hard", "decompose"):
            assert picture is not None  # load_picture raised otherwise
            with computing(run, picture.shape[0] * picture.shape[1], where):
                if command == "decompose":
                    save_config(run)
                    stage_decompose(run, picture)
                    files = finish(run, "decompose")
                else:
                    files = run_all(run, picture)
        else:
            files = _run_stage_command(run, command, src or out_path, picture, where)
    except BaseException:
        out.abort()
        raise
    run.times["total"] = round(time.perf_counter() - t0, 3)
    return run, files


def _run_stage_command(
    run: Run, command: str, src: Path, picture: Picture | None, where: ComputeConfig | None
) -> list[Path]:
    cfg = run.cfg
    layers = read_layers(src)
    size = (layers.alphas.shape[2] * layers.mm_per_px, layers.alphas.shape[1] * layers.mm_per_px)
    grid = plan_mural(run, size, layers.alphas.shape[1:])
    run.out.check_free(stage_outputs(cfg, command, layers.count, grid))
    if abs(size[0] - cfg.size.width_mm) > 0.01 * cfg.size.width_mm:
        log.warning(
            "the saved layers are %.4g mm wide but the config says size.width_mm %.4g; the saved "
            "layers' size is used (re-run `stencil-cad decompose` to change it)",
            size[0],
            cfg.size.width_mm,
        )
    dotsets = None
    if command != "stipple":
        dotsets = read_dots(src, layers.count, max_time=8.0 * cfg.spray.amount_cap)
        if command == "build":
            check_dots(cfg, dotsets, size)
    # Every refusal above comes before any worker starts; the tasks then run where the whole
    # job's would (--workers, --scheduler).
    with computing(run, layers.alphas.shape[1] * layers.alphas.shape[2], where):
        if dotsets is None:
            stage_stipple(run, layers, size, picture, grid)
        elif command == "build":
            build_any(run, layers, dotsets, size, grid, picture, simulate=False)
        else:
            stage_simulate(run, picture, layers, dotsets, as_made=not grid.tiled)
        return finish(run, command)


def slice_plates(
    stls: list[Path],
    profile: str,
    *,
    force: bool = False,
    timeout_s: float = 600.0,
    bed: str | tuple[float, float] | None = None,
) -> Iterator[tuple[Path, Path, SliceResult]]:
    """Slice exported plates with a shipped profile, each beside its STL.

    Every STL is checked, and every output name found free (or ``force``), before the
    first slice runs; a failed slice leaves no output file.

    Args:
        stls: The plates' STL files.
        profile: A shipped profile name (``prusa_fdm``, ``prusa_sla``, ``cura_fdm``).
        force: Replace existing outputs.
        timeout_s: Seconds before a slicer run is killed. Defaults to 600 s.
        bed: The printer's bed (a preset name or ``(x_mm, y_mm)``) replacing the profile's,
            so each mural tile is sliced on the bed it was sized for; None keeps the profile's.

    Yields:
        ``(stl, output, result)`` per plate, in order, as each slice finishes.

    Raises:
        UserError: An STL is missing, an output exists, or the slicer is not installed.
    """
    from . import slicing

    prof = slicing.get_profile(profile)
    overrides = _bed_overrides(prof, bed)
    jobs = _slice_jobs(stls, prof, bed, prof.suffix, force=force, timeout_s=timeout_s)
    for stl, out, turn in jobs:
        # A slice killed earlier (SIGKILL, power loss) may have left these: they are ours by name.
        tmp = out.with_name(f".{out.name}.partial{prof.suffix}")
        slicing.remove_partial(tmp)
        try:
            # A wall prints sparse (it only holds the plates off the surface): slicing.WALL_SETTINGS.
            settings = {**slicing.part_settings(prof, stl), **overrides}
            result = slicing.slice_plate(
                stl, tmp, prof, timeout_s=timeout_s, overrides=settings, rotate_deg=turn
            )
        except slicing.SlicerNotFoundError as exc:
            slicing.remove_partial(tmp)
            raise UserError(f"{exc}") from None
        except BaseException:
            slicing.remove_partial(tmp)
            raise
        if result.ok:
            tmp.replace(out)
        slicing.remove_partial(tmp)
        yield stl, out, result


def plate_projects(
    stls: list[Path],
    profile: str,
    *,
    force: bool = False,
    timeout_s: float = 300.0,
    bed: str | tuple[float, float] | None = None,
) -> Iterator[tuple[Path, Path, str | None]]:
    """Write a PrusaSlicer 3MF project (plate as tiles, every setting inside) beside each STL.

    Args:
        stls: The plates' STL files.
        profile: A shipped PrusaSlicer profile name (``prusa_fdm``, ``prusa_sla``).
        force: Replace existing ``.3mf`` files.
        timeout_s: Seconds before a PrusaSlicer run is killed. Defaults to 300 s.
        bed: The printer's bed (a preset name or ``(x_mm, y_mm)``) replacing the profile's.

    Yields:
        ``(stl, output, error)`` per plate; ``error`` is None when the project was written.

    Raises:
        UserError: An STL is missing, an output exists, the profile is not PrusaSlicer's, or
            PrusaSlicer is not installed.
    """
    import subprocess

    from . import slicing

    prof = slicing.get_profile(profile)
    if prof.slicer is not slicing.Slicer.PRUSA:
        raise UserError(f"--project writes PrusaSlicer projects; {profile} is a CuraEngine profile")
    overrides = _bed_overrides(prof, bed)
    jobs = _slice_jobs(stls, prof, bed, ".3mf", force=force, timeout_s=timeout_s)
    for stl, out, turn in jobs:
        tmp = out.with_name(f".{out.name}.partial.3mf")
        slicing.remove_partial(tmp)
        try:
            slicing.plate_project(
                stl,
                tmp,
                prof,
                timeout_s=timeout_s,
                overrides={**slicing.part_settings(prof, stl), **overrides},
                rotate_deg=turn or 0,
            )
        except slicing.SlicerNotFoundError as exc:
            slicing.remove_partial(tmp)
            raise UserError(f"{exc}") from None
        except (RuntimeError, subprocess.TimeoutExpired) as exc:
            slicing.remove_partial(tmp)
            yield stl, out, str(exc)
            continue
        except BaseException:
            slicing.remove_partial(tmp)
            raise
        tmp.replace(out)
        yield stl, out, None


def _slice_jobs(
    stls: list[Path], prof, bed, suffix: str, *, force: bool, timeout_s: float
) -> list[tuple[Path, Path, int]]:
    """``(stl, output, turn)`` per plate, every input and output checked before the first slicer run.

    ``turn`` is 0, or 90 for a part that fits the bed only turned a quarter turn.

    Raises:
        UserError: A bad ``--timeout``, an STL missing, not a regular file, not an STL or larger
            than the bed, or an output in the way (a folder, device, FIFO, or a file without ``force``).
    """
    import math

    from . import slicing
    from .files import DATA_LIMIT, check_input, check_target

    if not (math.isfinite(timeout_s) and timeout_s > 0):
        raise UserError(f"--timeout must be a positive number of seconds, got {timeout_s}")
    bed = slicing.bed_size(prof) if bed is None else _bed_xy(bed)
    jobs = []
    for stl in stls:
        check_input(stl, "STL", limit=DATA_LIMIT, fix="run `stencil-cad run` first, or check the path")
        try:
            size = slicing.stl_footprint(stl)
        except ValueError:
            raise UserError(f"{stl} is not an STL file (give a plate's layer_NN.stl)") from None
        except OSError as exc:
            raise UserError(f"cannot read {stl}: {exc.strerror} (check the file)") from None
        # A part that fits only turned (a portrait tile on a landscape bed) is sliced turned.
        lay = slicing.place(size, bed)
        if lay.rotate_deg is None:
            fits = [
                f"{name} ({w:g} × {h:g} mm)"
                for name, (w, h) in ((n, slicing.bed_size(n)) for n in slicing.PROFILES)
                if slicing.place(size, (w, h)).fits
            ]
            raise UserError(
                f"{stl} is {size[0]:.1f} × {size[1]:.1f} mm but the {prof.name} bed is {bed[0]:g} × "
                f"{bed[1]:g} mm, either way round: use a smaller picture (size.width_mm)"
                + (f", another profile (--profile {' or '.join(fits)})" if fits else "")
                + ", or a printer with a larger bed (copy the profile and edit its bed size)"
            )
        out = stl.with_suffix(suffix)
        if out.is_dir():
            raise OutputError(f"{out} is a folder where the sliced file goes (move it away)")
        check_target(out, "sliced file", force=force, error=OutputError)
        jobs.append((stl, out, lay.rotate_deg))
    return jobs


def stage_print_estimate(run: Run) -> None:
    """Slice every plate and wall the build staged and record the slicer's estimates (``export.print_estimate``).

    Each part is sliced as ``stencil-cad slice`` would (walls sparse, on the job's bed); its
    ``print_hours`` and ``filament_m`` go into its build row and the sums into ``build.print``.

    Raises:
        UserError: PrusaSlicer is not installed, the STLs were not exported, or a slice failed.
    """
    import tempfile

    from . import slicing

    cfg = run.cfg
    prof = slicing.get_profile("prusa_fdm")
    if not cfg.export.stl:
        raise UserError("export.print_estimate slices the STL files: set export.stl: true")
    if slicing.find_slicer(prof.slicer) is None:
        raise UserError("export.print_estimate needs PrusaSlicer (Debian/Ubuntu: apt install prusa-slicer)")
    build = run.figures["build"]
    parts = [(row, f"layer_{int(row['layer']):02d}") for row in build["plates"]]
    parts += [(row, str(row["file"]).rsplit(".", 1)[0]) for row in build["walls"]]
    bed = _bed_overrides(prof, cfg.bed) if cfg.bed is not None else {}
    bed_xy = slicing.bed_size(prof) if cfg.bed is None else _bed_xy(cfg.bed)
    total_h = total_m = 0.0
    with run.stage("print_estimate"), tempfile.TemporaryDirectory(prefix="stencil_print_") as tmp:
        for row, stem in parts:
            stl = run.out.stage / f"{stem}.stl"
            lay = slicing.place(slicing.stl_footprint(stl), bed_xy)
            if lay.rotate_deg is None:
                row["print"] = "larger than the bed either way round: not sliced"
                continue
            out = Path(tmp) / f"{stem}.gcode"
            settings = {**slicing.part_settings(prof, stl), **bed}
            result = slicing.slice_plate(stl, out, prof, overrides=settings, rotate_deg=lay.rotate_deg)
            if not result.ok:
                raise UserError(
                    f"export.print_estimate: slicing {stem}.stl failed: {'; '.join(result.errors)[:300]}"
                )
            est = slicing.read_estimate(out)
            row["print_hours"] = None if est.print_hours is None else round(est.print_hours, 3)
            row["filament_m"] = None if est.filament_m is None else round(est.filament_m, 2)
            total_h += est.print_hours or 0.0
            total_m += est.filament_m or 0.0
            out.unlink()
    build["print"] = {"profile": prof.name, "hours": round(total_h, 3), "filament_m": round(total_m, 2)}


def print_estimate(path: Path) -> GcodeEstimate:
    """The slicer's estimated print time and filament (G-code) or resin (``.sl1``) in a sliced file."""
    from .slicing.gcode import read_estimate, read_sl1_estimate

    return read_sl1_estimate(path) if path.suffix == ".sl1" else read_estimate(path)


def _bed_xy(bed) -> tuple[float, float]:
    from .config.bed import resolve_bed

    b = resolve_bed(bed)
    if b is None:
        raise UserError("--bed: no bed given (name a preset such as prusa_mk4, or XxY mm)")
    return (b.x_mm, b.y_mm)


def _bed_overrides(prof, bed) -> dict:
    """Slicer settings that set the bed size (PrusaSlicer ``bed_shape``, Cura machine width/depth)."""
    from . import slicing
    from .config.bed import resolve_bed

    try:
        b = resolve_bed(bed)
    except ValueError as exc:
        raise UserError(f"--bed: {exc}") from None
    if b is None:
        return {}
    if prof.slicer is slicing.Slicer.CURA:
        return {"machine_width": b.x_mm, "machine_depth": b.y_mm}
    return {"bed_shape": f"0x0,{b.x_mm:g}x0,{b.x_mm:g}x{b.y_mm:g},0x{b.y_mm:g}"}


def write_default_config(path: Path, *, force: bool = False) -> None:
    """Write the commented default config (every key, its unit, range and default) to ``path``.

    Raises:
        OutputError: ``path`` is a folder, its folder does not exist, or it exists and not ``force``.
    """
    from .config import io as cfg_io
    from .files import write_text_over

    if path.is_dir():
        raise OutputError(f"{path} is a folder; give a file path such as {path / 'stencil.yaml'}")
    write_text_over(path, cfg_io.default_yaml(), "config", force=force, error=OutputError)
