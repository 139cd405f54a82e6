"""The simulate stage's glue: spray every plate in simulation, score as a viewer sees it, the previews and spraying steps to write."""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from ..colour import to_hex
from ..config import JobConfig
from ..exchange.png import png_bytes
from ..figures import PaintFigures, PaintLayer, SimulateFigures, SprayStep
from ..model import DotSet, Layers, Picture
from ..output import plain as _plain
from ..plan.names import simulated_stems
from ..plan.picture import _resample, kept_reference
from ..plan.plan import Plan
from ..plan.results import Simulated
from ..record import Run
from ..stipple.made import made_dots

if TYPE_CHECKING:
    from ..config.spray import SprayConfig
    from ..simulate.physical import SprayGeometry

log = logging.getLogger(__name__)


def stage_simulate(
    run: Run,
    plan: Plan,
    picture: Picture | None,
    layers: Layers,
    dotsets: list[DotSet],
    keep: bool = False,
    also: Callable[[Any, np.ndarray], Any] | None = None,
    workers_busy: bool = False,
) -> Simulated:
    """Spray every plate in simulation, composite, score against the input, make the previews.

    Returns the pictures and figures the recorder writes, and with ``keep`` the simulation and the
    reference on its grid too (and what ``also`` returned, when given). The holes are sprayed as the process makes them
    (:func:`stencil_cad.stipple.made.made_dots`), a mural's as a one-plate job's.

    Under the physical model every wall height gets its own simulation and score
    (``simulated_wall_10mm.png`` …); the main pictures and scores are those of the design
    stand-off (``cfg.standoff.design_mm``), which the tone calibration designed the dots for.

    The long computations that need nothing this process computes next (every other can's
    simulation and score, where the holes show most, and what ``also`` starts) are started as
    the job's tasks (:meth:`stencil_cad.compute.Executor.start`) once the design stand-off is
    simulated, and collected when the stage's own work is done: on a cluster they run on its
    workers meanwhile.

    Args:
        run: The run.
        plan: The job's plan (its config says how the plates spray and are seen).
        picture: The picture (the reference is its source), or None: the decomposition.
        layers: The decomposition.
        dotsets: The holes per layer.
        keep: Keep the simulation and the reference in the result.
        also: ``also(sim, reference)``, called once the design stand-off is simulated (a
            mural's registration cases start their tasks there), or None.
        workers_busy: The job's workers are busy with tasks started before (a mural's plates):
            the scores and the other cans are then computed in this process, where the
            reference's filtered blocks and the cans' doses are shared, rather than sent to
            the workers and computed there again.
    """
    from .. import resolution, simulate
    from ..simulate.physical import SprayGeometry

    cfg = plan.cfg
    design = SprayGeometry.for_job(cfg)
    sprays = plan.sprays
    # Spray the holes as the process makes them (stipple.hole_offset_mm), not as asked.
    size_mm = (layers.alphas.shape[2] * layers.mm_per_px, layers.alphas.shape[1] * layers.mm_per_px)
    dotsets = [made_dots(d, cfg.stipple, size_mm) if isinstance(d, DotSet) else d for d in dotsets]
    with run.stage("simulate"):
        grid_mm = resolution.sim_mm_per_px(cfg)
        sim = simulate.simulate(layers, dotsets, cfg.spray, grid_mm, geometry=design, layer_sprays=sprays)
        ref = kept_reference(run, cfg, picture, layers, sim.composite.shape[:2], sim.mm_per_px)
        started = also(sim, ref) if also is not None else None
        cans = _start_cans(run, cfg, layers, dotsets, ref, grid_mm, design, sprays, here=workers_busy)
        visible = _start_visibility(run, cfg, layers, dotsets, sim)
        scores, de = _scores(run, cfg, ref, sim.composite, sim.mm_per_px, here=workers_busy)
        ideal = _resample(layers.composite(), sim.composite.shape[:2])
        # Each picture is kept as its PNG's bytes, as small as the file, until the recorder writes it.
        preview = png_bytes(preview_card(ref, ideal, sim.composite, sim.mm_per_px, scores, de))
        sweep = png_bytes(sweep_card(cfg, layers, dotsets, sim, grid_mm, design, sprays))
        sprayed = png_bytes(sim.composite)
        steps, paint = paint_steps(cfg, layers.primer, layers.colours, sim.alphas, sim.mm_per_px, sprayed)
        walls, per_wall = _walls(cfg, layers, dotsets, (sim, scores, ref), grid_mm, design, sprays)
        by_can = _scores_by_can(cans, scores)
        dots_seen = visible.results()[0] if visible is not None else {}
    figures = SimulateFigures.from_rows(_seen(scores, dots_seen, sim), by_can or None, per_wall or None)
    spraying = spraying_steps(cfg, layers, [ds.amount(cfg.spray.amount) for ds in dotsets])
    kept: dict[str, Any] = {"sim": sim, "reference": ref} if keep else {}
    pictures = (sprayed, preview, sweep, steps, walls)
    return Simulated(*pictures, paint, figures, spraying, scores, started=started, **kept)


def _seen(scores: dict[str, Any], dots_seen: dict[str, Any], sim: Any) -> dict[str, Any]:
    """Figure ``simulate``'s scores: the design stand-off's, where the holes show most, each layer's error."""
    return {
        **_plain(scores),
        **dots_seen,
        "layer_rmse": [float(x) for x in sim.layer_rmse],
        **{k: v for k, v in _plain(sim.info).items() if k not in scores},
    }


def sweep_card(
    cfg: JobConfig,
    layers: Layers,
    dotsets: list[DotSet],
    sim: Any,
    grid_mm: float | None,
    design: SprayGeometry | None,
    sprays: list[SprayConfig],
) -> np.ndarray:
    """``sweep.png``: the layers sprayed with less and more paint than the job's (the factor-1 panel is ``sim``)."""
    from .. import simulate
    from ..simulate import labelled

    factors = tuple(cfg.spray.sweep_factors)
    panels = simulate.sweep_panels(
        layers,
        dotsets,
        cfg.spray,
        grid_mm,
        factors=factors,
        geometry=design,
        layer_sprays=sprays,
        as_sprayed=sim,
    )
    return labelled.sweep_card(panels, factors, sim.mm_per_px, unit=cfg.spray.amount_unit)


def _walls(
    cfg: JobConfig,
    layers: Layers,
    dotsets: list[DotSet],
    done: tuple[Any, dict[str, Any], np.ndarray],
    grid_mm: float | None,
    design: SprayGeometry | None,
    sprays: list[SprayConfig],
) -> tuple[tuple[tuple[str, bytes], ...], list[dict[str, Any]]]:
    """Every wall height's simulation and scores (``simulated_wall_10mm.png`` …), the design one reused.

    ``done`` is the design stand-off's ``(simulation, scores, reference)``.

    Returns:
        ``(pictures, rows)``: each wall's ``(file name, simulated spray as PNG bytes)``, and its figures.
    """
    from .. import simulate
    from ..simulate.physical import SprayGeometry

    sim, scores, ref = done
    per_wall = []
    pictures = []
    stems = simulated_stems(cfg)
    for h, name in zip(cfg.standoff.walls_mm if stems else [], stems, strict=True):
        # Extra walls exist only under the physical model, where design is set.
        assert design is not None
        if h == design.standoff_mm:
            other, other_scores = sim, scores
        else:
            geometry = SprayGeometry.of_job(cfg, h)
            other = simulate.simulate(
                layers, dotsets, cfg.spray, grid_mm, geometry=geometry, layer_sprays=sprays
            )
            other_scores = simulate.score(ref, other.composite)
        pictures.append((name, png_bytes(other.composite)))
        per_wall.append(
            {
                "standoff_mm": h,
                "file": name,
                "blur_sigma_mm": other.info["blur_sigma_mm"],
                **_plain(other_scores),
            }
        )
    return tuple(pictures), per_wall


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


@dataclass(frozen=True)
class CanJob:
    """What every can's task shares: the holes, the settings and the reference (see :func:`can_score`)."""

    layers: Layers
    dotsets: list[DotSet]
    spray: SprayConfig
    grid_mm: float | None
    design: SprayGeometry | None
    reference: np.ndarray
    distance_m: float


def can_score(per_layer: list[SprayConfig], job: CanJob) -> float:
    """S-CIELAB at the viewing distance of the holes sprayed by one can of the prior (a task).

    Args:
        per_layer: Each layer's spray settings under that can.
        job: What every can shares.
    """
    from .. import simulate
    from ..simulate import scielab

    other = simulate.simulate(
        job.layers,
        job.dotsets,
        job.spray,
        job.grid_mm,
        geometry=job.design,
        layer_sprays=per_layer,
        errors=False,
    )
    return float(scielab.scielab(job.reference, other.composite, other.mm_per_px, job.distance_m))


def _start_cans(
    run: Run,
    cfg: JobConfig,
    layers: Layers,
    dotsets: list[DotSet],
    ref: np.ndarray,
    grid_mm: float | None,
    design: SprayGeometry | None,
    sprays: list[SprayConfig],
    here: bool = False,
) -> tuple[list[str], Any] | None:
    """Start every other can's simulation and score (:mod:`.simulate.cans`): ``(names, started)``.

    Each can of the prior changes the layers without a measured profile (``sprays``: each
    layer's settings). None when the prior is one can (the paper model, or every layer measured).
    With ``here`` the cans run in this process when collected.
    """
    from ..simulate.cans import layer_can_prior

    cans = layer_can_prior(sprays)
    if len(cans) < 2:
        return None
    # The job's own can ("nominal") is already simulated and scored.
    others = [(name, per_layer) for name, per_layer in cans if name != "nominal"]
    job = CanJob(layers, dotsets, cfg.spray, grid_mm, design, ref, cfg.view.distance_m)
    per_can = [p for _, p in others]
    if here:
        from ..compute import Started

        return [name for name, _ in cans], Started(lambda: (can_score(p, job) for p in per_can))
    return [name for name, _ in cans], run.tasks.start(can_score, per_can, "score cans", job)


def _scores_by_can(cans: tuple[list[str], Any] | None, nominal: dict[str, Any]) -> dict[str, Any]:
    """S-CIELAB at the viewing distance for every can of the prior, by name (empty for one can)."""
    if cans is None:
        return {}
    names, started = cans
    others = iter(started.results())
    return {name: float(nominal["scielab"]) if name == "nominal" else next(others) for name in names}


def spraying_steps(cfg: JobConfig, layers: Layers, amounts: Sequence[float]) -> tuple[SprayStep, ...]:
    """What the hand does for each layer, in the maker's units (physical model) or the model's.

    Args:
        cfg: The job config.
        layers: The decomposition (for the paint colours and the picture's size).
        amounts: Each layer's amount of paint: passes (physical) or spray time (paper).

    Returns:
        One step per layer: its ``text`` and figures ``layer``, ``paint``, and ``passes``, ``can_distance_cm``,
        ``pass_speed_m_s``, ``spray_seconds`` (physical) or ``spray_time`` (paper), and ``text``.
    """
    sp = cfg.spray
    out: list[SprayStep] = []
    h_px, w_px = layers.alphas.shape[1:] if layers.count else (0, 0)
    per_pass = sweep_seconds(cfg, w_px * layers.mm_per_px, h_px * layers.mm_per_px)
    for i, amount in enumerate(amounts):
        paint = to_hex(layers.colours[i])
        if sp.has_cans:
            n, speed = sp.hand(float(amount))
            cm = sp.can_distance_mm / 10.0
            seconds = n * per_pass * sp.pass_speed_m_s / speed
            text = (
                f"spray layer {i + 1} ({paint}): {n} light pass{'' if n == 1 else 'es'} from {cm:g} cm at "
                f"about {speed:.2g} m/s (about {seconds:.0f} s of spraying)"
                + ("; let each pass flash off (about a minute) before the next" if n > 1 else "")
            )
            out.append(
                SprayStep.from_json(
                    {
                        "layer": i + 1,
                        "paint": paint,
                        "passes": n,
                        "dose_passes": round(float(amount), 4),
                        "can_distance_cm": cm,
                        "pass_speed_m_s": round(speed, 3),
                        "spray_seconds": round(seconds, 1),
                        "text": text,
                    }
                )
            )
        else:
            text = (
                f"spray layer {i + 1} ({paint}) for spray time {amount:.3g} (paper model units; "
                "spray.model: physical gives passes and distances)"
            )
            out.append(
                SprayStep.from_json(
                    {"layer": i + 1, "paint": paint, "spray_time": round(amount, 4), "text": text}
                )
            )
    return tuple(out)


def _scores(
    run: Run, cfg: JobConfig, reference: np.ndarray, sprayed: np.ndarray, mm_per_px: float, here: bool = False
) -> tuple[dict[str, Any], np.ndarray]:
    """Pixel scores and S-CIELAB at the viewing distance and twice it, on one grid (its blocks as tasks unless ``here``).

    Returns:
        ``(scores, map)``: the scores and the CIEDE2000 per pixel (the preview's error map).
    """
    from ..simulate import scielab
    from ..simulate.scores import score_and_map

    scores, de = score_and_map(reference, sprayed)
    where = None if here else run.tasks.map
    scores.update(scielab.view_scores(reference, sprayed, mm_per_px, cfg.view.distance_m, where))
    return scores, de


@dataclass(frozen=True)
class SeenJob:
    """What :func:`dots_seen` reads: the decomposition, the holes and the design stand-off's simulation."""

    layers: Layers
    dotsets: list[DotSet]
    composite: np.ndarray
    alphas: np.ndarray
    mm_per_px: float
    blur_sigma_mm: list[float]
    hole_floor_mm: float


def _start_visibility(run: Run, cfg: JobConfig, layers: Layers, dotsets: list[DotSet], sim: Any) -> Any:
    """Start :func:`dots_seen` on the job's simulation as a task, or None when no layer has holes."""
    if layers.count == 0 or not any(len(d) for d in dotsets):
        return None
    job = SeenJob(
        layers,
        dotsets,
        sim.composite,
        sim.alphas,
        sim.mm_per_px,
        list(sim.info["blur_sigma_mm"]),
        cfg.stipple.hole_floor_mm,
    )
    return run.tasks.start(dots_seen, [None], "dots seen", job)


def dots_seen(_: None, job: SeenJob) -> dict[str, Any]:
    """From how far the job's own holes stop showing, where they show most (a task; see :mod:`.simulate.visibility`)."""
    from ..model import composite
    from ..simulate import visibility
    from ..simulate.spray import target_on_grid

    layers, dotsets = job.layers, job.dotsets
    g = job.mm_per_px
    spacing = [visibility.hole_spacing_mm(d.xy_mm) if isinstance(d, DotSet) else 0.0 for d in dotsets]
    shape = job.composite.shape[:2]
    targets = np.stack(
        [target_on_grid(a, shape, b, g) for a, b in zip(layers.alphas, job.blur_sigma_mm, strict=True)]
    )
    ideal = composite(layers.primer, layers.colours, targets)
    flat = visibility.pattern_flat(job.composite, ideal, max(spacing) / g)
    d, (r0, c0, side) = visibility.pattern_blend_distance_m(job.composite, flat, g)
    # The layer whose pattern shows most there: its opacity's ripple times its paint's contrast.
    lum = (layers.colours - layers.primer) @ np.array([0.2126, 0.7152, 0.0722])
    part = job.alphas[:, r0 : r0 + side, c0 : c0 + side]
    pattern = np.array(
        [np.abs(a - a.mean()).mean() if s > 0 else 0.0 for a, s in zip(part, spacing, strict=True)]
    )
    pattern *= np.abs(lum)
    k = int(np.argmax(pattern))
    r = float(dotsets[k].r_mm.min()) if len(dotsets[k]) else job.hole_floor_mm
    return {
        "dots_blend_m": d,
        "dots_blend_layer": k + 1,
        "dots_hole_r_mm": round(r, 3),
        "dots_blend_at_mm": [round((c0 + side / 2) * g, 1), round((r0 + side / 2) * g, 1)],
    }


def _score_line(scores: dict[str, Any]) -> str:
    """The scores under the preview: what a viewer sees (S-CIELAB) and pixel by pixel (ΔE2000)."""
    d = scores["view_distance_m"]
    return (
        f"S-CIELAB at {d:g} m {scores['scielab']:.2f}, at {2 * d:g} m {scores['scielab_2x']:.2f}   ·   "
        f"ΔE2000 per pixel: mean {scores['de2000_mean']:.2f}, 95 % below {scores['de2000_p95']:.1f}"
    )


def preview_card(
    reference: np.ndarray,
    ideal: np.ndarray,
    sprayed: np.ndarray,
    mm_per_px: float,
    scores: dict[str, Any],
    de: np.ndarray | None = None,
) -> np.ndarray:
    """The labelled four-panel ``preview.png``: input, ideal layers, simulated spray, error map.

    ``de`` is the error map (:func:`stencil_cad.simulate.scores.score_and_map`'s) when already
    computed, else None: computed here.
    """
    from .. import simulate
    from ..simulate import labelled

    de_max = 30.0
    notes = [
        _score_line(scores),
        f"PSNR {scores['psnr']:.1f} dB, SSIM {scores['ssim']:.2f}  ·  "
        f"picture {sprayed.shape[1] * mm_per_px:g} × {sprayed.shape[0] * mm_per_px:g} mm",
    ]
    return labelled.job_preview(
        reference,
        ideal,
        sprayed,
        simulate.delta_e_map(reference, sprayed) if de is None else de,
        simulate.colour_map,
        de_max,
        mm_per_px,
        notes=notes,
    )


def paint_steps(
    job: JobConfig,
    primer: np.ndarray,
    colours: np.ndarray,
    alphas: np.ndarray,
    mm_per_px: float,
    whole: bytes | None = None,
) -> tuple[tuple[bytes, ...], PaintFigures]:
    """Per layer, the simulated picture after it is sprayed (``step_N.png``, its bytes), and its paint estimate (figure ``paint``).

    ``whole`` is the PNG of every layer's composite when already encoded (``simulated.png``'s
    bytes), the last step's picture, or None: encoded here (a 600 x 600 px PNG: 0.12 CPU-s).
    """
    from ..decompose import paints
    from ..decompose.light import paint_of_plates
    from ..model import composites

    cfg = job.paints
    area = float(alphas.shape[1] * alphas.shape[2]) * mm_per_px**2
    rows = []
    # Each step composites one more layer over the last (8 steps: 0.25 CPU-s as 8 composites, 0.03 so).
    count = alphas.shape[0]
    steps = [
        whole if i == count - 1 and whole is not None else png_bytes(np.clip(c, 0.0, 1.0))
        for i, c in enumerate(composites(primer, colours, alphas))
    ]
    for i in range(alphas.shape[0]):
        mean = float(np.mean(alphas[i]))
        est = paints.paint_estimate(area, mean, cfg.coverage_m2_per_can, cfg.can_ml)
        rows.append({"layer": i + 1, "hex": to_hex(colours[i]), "mean_opacity": mean, **est})
    # Plates of one paint (a light and a dark plate) spray from the same cans: the paint's cans are
    # counted on its first plate, 0 on the others.
    paint = paint_of_plates(colours)
    for k in set(paint):
        mine = [r for r, p in zip(rows, paint, strict=True) if p == k]
        cans = sum(r["cans"] for r in mine)
        for j, r in enumerate(mine):
            r["cans_to_buy"] = max(1, math.ceil(cans - 1e-9)) if j == 0 else 0
    return tuple(steps), PaintFigures(
        sprayed_area_m2=area * 1e-6,
        coverage_m2_per_can=cfg.coverage_m2_per_can,
        can_ml=cfg.can_ml,
        layers=tuple(PaintLayer.from_json(r) for r in rows),
    )


def stage_simulate_hard(
    run: Run, plan: Plan, picture: Picture, hard: Any, layers: Layers, amounts: list[float]
) -> Simulated:
    """Spray hard mode's cut-outs ``hard`` (each layer with its settings, the plan's), score and preview them.

    Returns ``simulated.png``, the previews and the spraying steps, with figures ``simulate``,
    ``paint`` and ``spraying`` (no sweep, one wall).
    """
    from .. import hardstencil
    from ..simulate.physical import SprayGeometry

    cfg, sprays = plan.cfg, plan.sprays
    with run.stage("simulate"):
        geometry = SprayGeometry.for_job(cfg)
        alphas, comp = hardstencil.simulate_hard(hard, cfg.spray, geometry=geometry, layer_sprays=sprays)
        scores, de = _scores(run, cfg, picture.rgb, comp, picture.mm_per_px)
        preview = png_bytes(
            preview_card(picture.rgb, hardstencil.render_ideal(hard), comp, picture.mm_per_px, scores, de)
        )
        sprayed = png_bytes(comp)
        steps, paint = paint_steps(cfg, hard.primer, hard.colours, alphas, picture.mm_per_px, sprayed)
    return Simulated(
        composite=sprayed,
        preview=preview,
        sweep=None,
        steps=steps,
        walls=(),
        paint=paint,
        figures=SimulateFigures(_plain(scores)),
        spraying=spraying_steps(cfg, layers, amounts),
        scores=scores,
    )
