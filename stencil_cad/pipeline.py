"""The orchestrator: calls the stages in order, reports progress, writes through :mod:`output`.

Stages are pure functions; this module is the only one that knows their order, which
intermediates a stage command reads back, and which files a run writes.
"""

from __future__ import annotations

import contextlib
import logging
import platform
import time
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import yaml

from . import __version__
from .colour import to_hex
from .config import ComputeConfig, JobConfig, Mode
from .config.spray import SprayModel
from .errors import OutputError, UserError
from .model import DotSet, Holes, Layers, Picture
from .output import MANIFEST, OutputDir, manifest_header

if TYPE_CHECKING:
    from .compute import Executor
    from .slicing import SliceResult

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

    def rng_for(self, stage: str, index: int = 0) -> np.random.Generator:
        """An independent generator per stage and layer, derived from the seed.

        A stage command re-run on saved intermediates therefore gives the same result as
        the same stage inside a whole run.
        """
        import zlib

        key = (zlib.crc32(stage.encode()), index)
        return np.random.default_rng(np.random.SeedSequence(self.cfg.seed, spawn_key=key))

    @contextlib.contextmanager
    def stage(self, name: str) -> Iterator[None]:
        """Time a stage."""
        log.info("stage %s …", name)
        t0 = time.perf_counter()
        yield
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

    from .imaging import load_picture as _load

    pic = _load(cfg.image, cfg.size.width_mm, cfg.size.height_mm, cfg.size.px_per_mm)
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
    from .simulate.previews import swatch

    with run.stage("decompose"):
        # Iterations run per pyramid level, so the total is not known in advance.
        with run.bar(None, "decompose") as bar:

            def progress(_iteration: int, energy: float) -> None:
                bar.update(1)
                bar.set_postfix(energy=f"{energy:.4g}", refresh=False)

            try:
                tiles = _decompose_tiles(run, picture)
                if tiles is None:
                    layers = dec.decompose(
                        picture, run.cfg.decompose, run.rng_for("decompose"), progress=progress
                    )
                else:
                    layers = _decompose_tiled(run, picture, tiles, progress)
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
        for i, a in enumerate(layers.alphas):
            out.write_png(f"{layer_stem(i)}_opacity.png", 1.0 - a)
        out.write_png("swatch.png", swatch(layers))
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


def _decompose_tiled(run: Run, picture: Picture, tiles, progress) -> Layers:
    """Colours on a small copy of the picture, then the opacities tile by tile as tasks."""
    from . import decompose as dec
    from .decompose import tiled

    cfg = run.cfg.decompose
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


def read_layers(folder: Path) -> Layers:
    """Read the decomposition a previous `decompose` or `run` saved."""
    from .exchange.layers_npz import layers_from_npz

    path = folder / LAYERS_NPZ
    if not path.exists():
        raise UserError(f"{path} not found (run `stencil-cad decompose` first, or pass --from DIR)")
    import zipfile

    try:
        with np.load(path) as data:
            return layers_from_npz(dict(data))
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile) as exc:
        raise UserError(
            f"{path}: not a readable decomposition ({exc}); re-run `stencil-cad decompose`"
        ) from None


SPRAY_JSON = "spray.json"


def stage_stipple(
    run: Run, layers: Layers, picture_mm: tuple[float, float], picture: Picture | None = None
) -> list[DotSet]:
    """Stipple every layer's opacity into holes, enforce the design rules, refine, save CSV + previews.

    With ``stipple.tone: calibrated`` the density comes from the spray response
    (:mod:`stencil_cad.simulate.tone`), and with ``spray.calibrate: spray_time`` each layer also
    gets its own spray time, saved in ``spray.json`` and in the dots' report. With
    ``refine.enabled`` the holes are then refined against the spray model
    (:func:`stage_refine`) towards ``picture`` (the decomposition's composite without one).
    """
    from dataclasses import replace

    from . import stipple
    from .exchange.dots_csv import dots_to_csv
    from .simulate.previews import dots_preview

    bound_dots(run, picture_mm)
    width_mm, height_mm = picture_mm
    cfg = run.cfg
    calibrated = getattr(cfg.stipple.tone, "value", cfg.stipple.tone) == "calibrated"
    sets: list[DotSet] = []
    tones: list[dict] = []
    with run.stage("stipple"):
        with run.bar(layers.count, "stipple") as bar:
            for i, alpha in enumerate(layers.alphas):
                density = None
                spray_time = cfg.spray.amount
                if calibrated:
                    from .simulate import tone

                    choice = tone.calibrated_tone_for(alpha, layers.mm_per_px, cfg)
                    density = choice.density
                    if getattr(cfg.spray.calibrate, "value", cfg.spray.calibrate) == "spray_time":
                        spray_time = float(choice.spray_time)
                    tones.append(choice.summary())
                ds = stipple.stipple_layer(
                    alpha, layers.mm_per_px, cfg.stipple, run.rng_for("stipple", i), density=density
                )
                ds = replace(ds, report={**ds.report, "spray_time": spray_time})
                sets.append(ds)
                bar.update(1)
    run.figures["dark_end"] = [
        _dark_end(cfg, alpha, float(ds.report["spray_time"]))
        for alpha, ds in zip(layers.alphas, sets, strict=True)
    ]
    if cfg.refine.enabled:
        sets = stage_refine(run, layers, sets, picture_mm, picture)
    with run.stage("stipple"):
        for i, ds in enumerate(sets):
            run.out.write_text(dots_name(i), dots_to_csv(ds))
            run.out.write_png(f"{layer_stem(i)}_dots.png", dots_preview(ds, width_mm, height_mm))
        run.out.write_json(
            SPRAY_JSON,
            {
                "spray_times": [ds.report["spray_time"] for ds in sets],
                "unit": cfg.spray.amount_unit,
                "nozzle_height": cfg.spray.nozzle_height,
            },
        )
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
) -> list[DotSet]:
    """Refine every layer's holes against the spray model so the composite matches the picture.

    The objective lives on the simulation grid, its eye filter is the viewer's at
    ``view.distance_m``, and the holes keep the stipple rules (the largest radius is
    ``refine.max_radius_factor`` times the hole floor).
    """
    from .simulate import scielab, spray
    from .simulate.physical import SprayGeometry
    from .stipple import refine
    from .stipple.rules import rules_from_config

    cfg = run.cfg
    grid = 1.0 / cfg.spray.px_per_mm
    shape = spray.sim_shape(layers.alphas.shape[1:], layers.mm_per_px, grid)
    reference = picture.rgb if picture is not None else layers.composite()
    target = spray.resample(np.clip(reference, 0.0, 1.0), shape)
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
    )
    alpha_targets = np.stack([spray.resample(a, shape) for a in layers.alphas]) if layers.count else None

    geometry = SprayGeometry.of_job(cfg) if cfg.spray.model == SprayModel.physical else None

    def kernels(r_mm: np.ndarray, spray_time: float) -> tuple:
        return spray.hole_kernels(r_mm, cfg.spray, spray_time, geometry=geometry)

    times = [float(ds.report.get("spray_time", cfg.spray.amount)) for ds in dotsets]
    with run.stage("refine"):
        with run.bar(rc.iterations, "refine") as bar:
            out, report = refine.refine_dots(
                target,
                grid,
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


def read_dots(folder: Path, count: int | None = None) -> list[DotSet]:
    """Read the dots CSV files of a folder, in layer order."""
    from .exchange.dots_csv import dots_from_csv

    files = sorted(folder.glob("layer_*_dots.csv"))
    if not files:
        raise UserError(
            f"no layer_NN_dots.csv in {folder} (run `stencil-cad stipple` first, or pass --from DIR)"
        )
    if count is not None and len(files) != count:
        raise UserError(f"{folder} has {len(files)} dots files but the decomposition has {count} layers")
    out = []
    for f in files:
        try:
            out.append(dots_from_csv(f.read_text(encoding="utf-8")))
        except (ValueError, UnicodeDecodeError) as exc:
            raise UserError(f"{f}: {str(exc)[:300]}") from None
        if len(out[-1]) == 0:
            log.warning(
                "%s has no holes: its plate will spray nothing (re-run `stencil-cad stipple`, or add rows "
                "x_mm,y_mm,r_mm)",
                f,
            )
    spray = folder / SPRAY_JSON
    if spray.exists():
        import json
        import math
        from dataclasses import replace

        try:
            times = json.loads(spray.read_text(encoding="utf-8"))["spray_times"]
            times = [float(t) for t in times]
            if not all(math.isfinite(t) and t > 0 for t in times):
                raise ValueError("spray times must be positive numbers")
        except (ValueError, KeyError, TypeError, UnicodeDecodeError):
            raise UserError(
                f"{spray}: not a valid spray-time file (a list of positive numbers under spray_times); "
                "fix it, or delete it to use spray.spray_time"
            ) from None
        if len(times) == len(out):
            out = [
                replace(ds, report={**ds.report, "spray_time": float(t)})
                for ds, t in zip(out, times, strict=True)
            ]
    return out


def stage_build(run: Run, layers: Layers, holes: Sequence[Holes], picture_mm: tuple[float, float]) -> None:
    """Build, check and export one plate per layer and the wall(s)."""
    from . import cad, outline
    from .cad import wall as wall_mod
    from .exchange import dxf

    cfg = run.cfg
    width_mm, height_mm = picture_mm
    exp = cfg.export
    results = []
    with run.stage("build"):
        ring = outline.plate_outline(width_mm, height_mm, cfg.plate.outline)
        with run.bar(len(holes), "build") as bar:
            for i, h in enumerate(holes):
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
                if exp.step:
                    with run.out.open_path(f"{stem}.step") as p:
                        cad.write_step(model, p)
                if exp.stl:
                    with run.out.open_path(f"{stem}.stl") as p:
                        cad.write_stl(model, p, exp.stl_tolerance_mm)
                if exp.three_mf:
                    with run.out.open_path(f"{stem}.3mf") as p:
                        cad.write_3mf(model, p, exp.stl_tolerance_mm)
                dxf_info = {}
                if exp.dxf:
                    with run.out.open_path(f"{stem}.dxf") as p:
                        info = dxf.write_dxf_stencils(
                            p,
                            [dxf.stencil_for(h, ring, stem.upper())],
                            kerf_mm=exp.dxf_kerf_mm,
                            # Fixed dates and GUIDs: the same job writes the same bytes, wherever it ran.
                            deterministic=True,
                        )
                    # Laser software wants +X/+Y: the drawing is shifted by this much from the picture frame.
                    dxf_info = {"dxf_offset_mm": [round(float(v), 4) for v in info.offset_mm]}
                results.append({"layer": i + 1, **_plain(check), **dxf_info})
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


def stage_simulate(run: Run, picture: Picture | None, layers: Layers, dotsets: list[DotSet]) -> dict:
    """Spray every plate in simulation, composite, score against the input, save previews.

    Under the physical model every wall height gets its own simulation and score
    (``simulated_wall_10mm.png`` …); the main pictures and scores are those of the design
    stand-off (``wall.standoff_mm[0]``), which the tone calibration designed the dots for.
    """
    from . import simulate
    from .simulate.physical import SprayGeometry

    cfg = run.cfg
    physical = cfg.spray.model == SprayModel.physical
    design = SprayGeometry.of_job(cfg) if physical else None
    with run.stage("simulate"):
        sim = simulate.simulate(layers, dotsets, cfg.spray, geometry=design)
        reference = picture.rgb if picture is not None else layers.composite()
        ref = _resample(reference, sim.composite.shape[:2])
        scores = _scores(run, ref, sim.composite, sim.mm_per_px)
        run.out.write_png("simulated.png", sim.composite)
        run.out.write_png(
            "preview.png",
            simulate.preview(
                ref,
                _resample(layers.composite(), sim.composite.shape[:2]),
                sim.composite,
                text=_score_line(scores),
            ),
        )
        run.out.write_png("sweep.png", simulate.sweep(layers, dotsets, cfg.spray, geometry=design))
        per_wall = []
        stems = simulated_stems(cfg)
        for h, name in zip(cfg.wall.heights() if stems else [], stems, strict=True):
            # Extra walls exist only under the physical model, where design is set.
            assert design is not None
            if h == design.standoff_mm:
                other, other_scores = sim, scores
            else:
                other = simulate.simulate(layers, dotsets, cfg.spray, geometry=SprayGeometry.of_job(cfg, h))
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
    if per_wall:
        run.figures["simulate"]["walls"] = per_wall
    run.figures["spraying"] = spraying_steps(cfg, layers, dotsets)
    return scores


def spraying_steps(cfg: JobConfig, layers: Layers, dotsets: list[DotSet]) -> list[dict]:
    """What the hand does for each layer, in the maker's units (physical model) or the model's.

    Args:
        cfg: The job config.
        layers: The decomposition (for the paint colours).
        dotsets: The layers' holes (their ``report["spray_time"]`` is the layer's amount).

    Returns:
        One dict per layer: ``layer``, ``paint``, and ``passes``, ``can_distance_mm``,
        ``pass_speed_m_s`` (physical) or ``spray_time`` (paper), and ``text``.
    """
    sp = cfg.spray
    out = []
    for i, ds in enumerate(dotsets):
        amount = float(ds.report.get("spray_time", sp.amount))
        paint = to_hex(layers.colours[i])
        if sp.model == SprayModel.physical:
            n = round(amount, 2)
            text = (
                f"spray layer {i + 1} ({paint}) from {sp.can_distance_mm:g} mm, {n:g} "
                f"pass{'' if n == 1 else 'es'} at about {sp.pass_speed_m_s:g} m/s"
            )
            out.append(
                {
                    "layer": i + 1,
                    "paint": paint,
                    "passes": n,
                    "can_distance_mm": sp.can_distance_mm,
                    "pass_speed_m_s": sp.pass_speed_m_s,
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
    scores.update(scielab.view_scores(reference, sprayed, mm_per_px, run.cfg.view.distance_m))
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
    d = scores["view_distance_m"]
    return (
        f"input | decomposition | simulated spray | ΔE2000 map    ΔE2000 {scores['de2000_mean']:.2f}   "
        f"S-CIELAB at {d:g} m {scores['scielab']:.2f}, at {2 * d:g} m {scores['scielab_2x']:.2f}"
    )


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
    run.out.write_json(MANIFEST, manifest)
    return run.out.commit()


def _merge_manifest(old_path: Path, new: dict, out: OutputDir) -> dict:
    """A stage command adds its figures and files to the folder's existing manifest."""
    import json

    try:
        old = json.loads(old_path.read_text())
    except (OSError, ValueError):
        return new
    if not isinstance(old, dict):
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
    return merged


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
    size = (picture.width_mm, picture.height_mm)
    run.figures["picture"] = {
        "source": picture.source,
        "width_mm": round(size[0], 3),
        "height_mm": round(size[1], 3),
        "pixels": list(picture.shape),
        "mm_per_px": picture.mm_per_px,
    }
    if cfg.mode == Mode.hard:
        return run_hard(run, picture)
    bound_dots(run, size)
    layers = stage_decompose(run, picture)
    dotsets = stage_stipple(run, layers, size, picture)
    stage_build(run, layers, dotsets, size)
    stage_simulate(run, picture, layers, dotsets)
    return finish(run, "run")


CARD_JSON = "card.json"


def card_stems(standoffs_mm: list[float]) -> list[str]:
    """File stems of the card's walls: ``card_wall_6mm`` … (one per stand-off)."""
    return [f"card_wall_{h:g}mm" for h in sorted(set(standoffs_mm))]


def run_card(run: Run, standoffs_mm: list[float] | None = None) -> list[Path]:
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
            dxf.write_dxf_stencils(p, [dxf.stencil_for(card.dots, ring, "CARD")], kerf_mm=exp.dxf_kerf_mm)
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
        run.out.write_bytes("card_sheet.pdf", sheet_mod.sheet_pdf(card))
        sp = cfg.spray
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
        "passes": card.passes,
    }
    return finish(run, "card")


def run_hard(run: Run, picture: Picture) -> list[Path]:
    """Hard-stencil mode: segmentation, bridges, plates with polygon cut-outs, simulation."""
    from . import hardstencil, simulate

    cfg = run.cfg
    size = (picture.width_mm, picture.height_mm)
    with run.stage("segment"):
        rules = _process_rules(cfg)
        try:
            hard = hardstencil.make_hard_stencils(
                picture, cfg.hard, rules["min_feature_mm"], rules["bridge_min_mm"], run.rng_for("hard")
            )
        except ValueError as exc:
            raise UserError(f"hard mode: {exc}") from exc
        if hard.count == 0:
            raise UserError(
                "hard mode: the image has a single flat colour, so there is nothing to cut "
                "(prime the surface with it, or use an image with more colours)"
            )
        run.out.write_png("segmentation.png", hard.palette[hard.labels])
    run.figures["hard"] = _plain(hard.report)
    run.figures["hard"]["warnings"] = [str(w) for w in hard.report.get("warnings", [])]
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
        _, comp = hardstencil.simulate_hard(hard, cfg.spray, geometry=geometry)
        scores = _scores(run, picture.rgb, comp, picture.mm_per_px)
        run.out.write_png("simulated.png", comp)
        run.out.write_png(
            "preview.png",
            simulate.preview(picture.rgb, hardstencil.render_ideal(hard), comp, text=_score_line(scores)),
        )
    run.figures["simulate"] = _plain(scores)
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
    return [*RUN_FILES, "layer_*", "wall*"]


def stage_outputs(cfg: JobConfig, command: str, count: int) -> list[str]:
    """Names a stage command will write, so it can refuse before doing the work."""
    if command == "stipple":
        return [n for i in range(count) for n in (dots_name(i), f"{layer_stem(i)}_dots.png")] + [SPRAY_JSON]
    if command == "build":
        exts = [
            e
            for e, on in (
                (".step", cfg.export.step),
                (".stl", cfg.export.stl),
                (".dxf", cfg.export.dxf),
                (".3mf", cfg.export.three_mf),
            )
            if on
        ]
        names = [layer_stem(i) + e for i in range(count) for e in exts]
        return names + [s + e for s in wall_stems(cfg.wall.standoff_mm) for e in (".step", ".stl")]
    if command == "simulate":
        return ["simulated.png", "preview.png", "sweep.png", *simulated_stems(cfg)]
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


def _plain(d: Mapping[str, object] | None) -> dict[str, object]:
    """Keep the JSON-friendly scalars of a report dict."""
    out: dict[str, object] = {}
    for k, v in (d or {}).items():
        if isinstance(v, np.generic):
            v = v.item()
        if isinstance(v, float) and not np.isfinite(v):
            v = None
        if isinstance(v, (int, float, str, bool, type(None))):
            out[k] = v
        elif isinstance(v, (list, tuple)) and all(isinstance(x, (int, float, str, bool)) for x in v):
            out[k] = list(v)
        elif isinstance(v, Mapping):
            out[k] = _plain(v)
    return out


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

    Returns:
        ``(run, files)``: the run's state (figures, timings) and the files written.
    """
    stage_cmd = command in STAGE_COMMANDS
    src = (src or out_path) if stage_cmd else None
    run = Run(cfg=cfg, out=None, quiet=quiet)  # type: ignore[arg-type]
    # Everything that can be checked is checked before the first stage: the template (Python
    # code, loaded now), the output folder (created, locked, probed for writing), the image.
    if command in ("run", "hard", "build"):
        check_template(run)
    out = OutputDir(out_path, force=force, allow_existing=stage_cmd)
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
            files = _run_stage_command(run, command, src or out_path, picture)
    except BaseException:
        out.abort()
        raise
    run.times["total"] = round(time.perf_counter() - t0, 3)
    return run, files


def _run_stage_command(run: Run, command: str, src: Path, picture: Picture | None) -> list[Path]:
    cfg = run.cfg
    layers = read_layers(src)
    run.out.check_free(stage_outputs(cfg, command, layers.count))
    size = (layers.alphas.shape[2] * layers.mm_per_px, layers.alphas.shape[1] * layers.mm_per_px)
    if abs(size[0] - cfg.size.width_mm) > 0.01 * cfg.size.width_mm:
        log.warning(
            "the saved layers are %.4g mm wide but the config says size.width_mm %.4g; the saved "
            "layers' size is used (re-run `stencil-cad decompose` to change it)",
            size[0],
            cfg.size.width_mm,
        )
    if command == "stipple":
        stage_stipple(run, layers, size, picture)
    else:
        dotsets = read_dots(src, layers.count)
        if command == "build":
            check_dots(cfg, dotsets, size)
            stage_build(run, layers, dotsets, size)
        else:
            stage_simulate(run, picture, layers, dotsets)
    return finish(run, command)


def slice_plates(
    stls: list[Path], profile: str, *, force: bool = False, timeout_s: float = 600.0
) -> Iterator[tuple[Path, Path, SliceResult]]:
    """Slice exported plates with a shipped profile, each beside its STL.

    Every STL is checked, and every output name found free (or ``force``), before the
    first slice runs; a failed slice leaves no output file.

    Args:
        stls: The plates' STL files.
        profile: A shipped profile name (``prusa_fdm``, ``prusa_sla``, ``cura_fdm``).
        force: Replace existing outputs.
        timeout_s: Seconds before a slicer run is killed. Defaults to 600 s.

    Yields:
        ``(stl, output, result)`` per plate, in order, as each slice finishes.

    Raises:
        UserError: An STL is missing, an output exists, or the slicer is not installed.
    """
    import math

    from . import slicing

    prof = slicing.get_profile(profile)
    if not (math.isfinite(timeout_s) and timeout_s > 0):
        raise UserError(f"--timeout must be a positive number of seconds, got {timeout_s}")
    bed = slicing.bed_size(prof)
    jobs = []
    for stl in stls:
        if not stl.is_file():
            raise UserError(f"STL not found: {stl} (run `stencil-cad run` first, or check the path)")
        try:
            size = slicing.stl_footprint(stl)
        except ValueError:
            raise UserError(f"{stl} is not an STL file (give a plate's layer_NN.stl)") from None
        except OSError as exc:
            raise UserError(f"cannot read {stl}: {exc.strerror} (check the file)") from None
        if not (size[0] <= bed[0] + 1e-6 and size[1] <= bed[1] + 1e-6):
            fits = [
                f"{name} ({w:g} × {h:g} mm)"
                for name, (w, h) in ((n, slicing.bed_size(n)) for n in slicing.PROFILES)
                if size[0] <= w and size[1] <= h
            ]
            raise UserError(
                f"{stl} is {size[0]:.1f} × {size[1]:.1f} mm but the {prof.name} bed is {bed[0]:g} × "
                f"{bed[1]:g} mm: use a smaller picture (size.width_mm)"
                + (f", another profile (--profile {' or '.join(fits)})" if fits else "")
                + ", or a printer with a larger bed (copy the profile and edit its bed size)"
            )
        out = stl.with_suffix(prof.suffix)
        if out.is_dir():
            raise OutputError(f"{out} is a folder where the sliced file goes (move it away)")
        if out.exists() and not force:
            raise OutputError(f"{out} already exists (use --force to replace it)")
        jobs.append((stl, out))
    for stl, out in jobs:
        tmp = out.with_name(f".{out.name}.partial{prof.suffix}")
        try:
            result = slicing.slice_plate(stl, tmp, prof, timeout_s=timeout_s)
        except slicing.SlicerNotFoundError as exc:
            tmp.unlink(missing_ok=True)
            raise UserError(f"{exc}") from None
        except BaseException:
            tmp.unlink(missing_ok=True)
            raise
        if result.ok:
            tmp.replace(out)
        else:
            tmp.unlink(missing_ok=True)
        yield stl, out, result


def write_default_config(path: Path, *, force: bool = False) -> None:
    """Write the commented default config (every key, its unit, range and default) to ``path``.

    Raises:
        OutputError: ``path`` is a folder, its folder does not exist, or it exists and not ``force``.
    """
    from .config import io as cfg_io

    if path.is_dir():
        raise OutputError(f"{path} is a folder; give a file path such as {path / 'stencil.yaml'}")
    if not path.parent.is_dir():
        raise OutputError(f"folder {path.parent} does not exist (create it first, or give another path)")
    if path.exists() and not force:
        raise OutputError(f"{path} already exists (use --force to replace it, or give another path)")
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(cfg_io.default_yaml(), encoding="utf-8")
    tmp.replace(path)
