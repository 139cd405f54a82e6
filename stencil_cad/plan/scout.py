"""A second wall judged from the first wall's holes, before its own plates are made.

With light plates the plate-design trials refine the holes for two walls (5 and 8 mm on the
processes' 10) for :data:`stencil_cad.pipeline.standoff.RANK_AFTER` steps each and keep the better
(:func:`stencil_cad.pipeline.standoff.direct_pair`). The first wall's holes are the job's when it
wins; the second wall's stippling and steps (4.0 CPU-s on the bundled example, a seventh of the
job) are spent for nothing where the first wins clearly. So the second wall is first scouted
(:func:`scouted`), and its own plates are made only where the scout cannot tell the first wins:

- the first wall's score after its steps is held against its blur floor (:func:`blur_floor`: the
  layers blurred as the wall blurs a hole's image, with no dots): where its holes cost more than
  :data:`FLOOR_RATIO` times the floor, the blur of the higher wall may pay, and the second wall is
  tried without a scout;
- otherwise the first wall's holes take :data:`SCOUT_STEPS` steps of the second wall's refinement
  and are sprayed (:func:`scout_score`); where they score worse than the first wall by more than
  :data:`SCOUT_MARGIN`, the first wins.

Measured on the bundled example (seeds 1 to 4 too) and the pictures of ``python -m benchmarks
fidelity`` that refine two walls (9 on FDM, 8 on SLA, and 5 of them with other seeds;
``benchmarks.fidelity.job_config(image, process, folder)``), each wall's own trial scored as
ranked beside the scout: every one keeps the wall it had, and its holes. On the example the
trials cost the floor and the scout (1.1 CPU-s) instead of the 8 mm wall's stippling and steps:
the standoff stage took 6.4 and 6.8 CPU-s rather than 9.1 and 9.8 (``time.process_time``, two runs
of each), and ``stencil-cad run`` 27.8 CPU-s rather than 29.9 (user and system time, medians of 5
runs alternated with the code before), with the same holes to the last digit (S-CIELAB 2.575 at
1 m, 1.611 at 2 m). ``python -m benchmarks fidelity`` kept every picture's wall and scores, FDM
and SLA (the scout ranked 5 of the 12 pictures on each process, as it ranks the example).
"""

from __future__ import annotations

from typing import Any

from ..config import JobConfig
from ..figures import PlateTrial
from ..model import DotSet, Layers, Picture
from ..record import Run
from .plan import Plan, whole, with_design
from .profiles import Paints

#: The first wall's score after its steps over its blur floor above which the second wall is tried
#: without a scout. Where the first wall (5 mm) won, its holes scored 0.87 to 1.32 times its floor
#: (the example 2.71 against 2.09, 1.30, and 1.32 with seed 3; astronaut 1.27 and 1.23 on SLA,
#: immunohistochemistry 0.98 and 0.98, grass 0.87 and 0.92, text 1.01 and 0.95, hubble_deep_field
#: 1.04 and 1.01); where the second (8 mm) won, 1.48 to 2.77 (coffee 1.53 and 1.49 with seed 2,
#: chelsea 1.56, 1.48 with seed 2 and 1.60 on SLA, rocket 2.59 and 2.52, low_contrast 2.77 and
#: 2.75), and 1.58 and 1.59 for the example with seeds 2 and 4, whose 5 mm holes scored 3.22 and
#: 3.25 after 30 steps against 2.92 from 8 mm: there the scout alone (1.12 and 1.13 times the
#: first wall) ranked wrongly, and with seed 2 the 5 mm job scored 3.12 at 1 m where the 8 mm one
#: scores 2.86 (``stencil-cad run --seed 2``).
FLOOR_RATIO = 1.4
#: Steps of the second wall's refinement the first wall's holes take in the scout (the whole
#: refinement's first steps, its step sizes decaying over all of its ``refine.iterations``). The
#: scout's score over the first wall's: 1.10 to 1.43 where the first won (the example 3.08 against
#: 2.71, its own trial 2.95; astronaut 1.15 and 1.10 with seed 1, the example 1.13 with seeds 1 and
#: 3) and 0.71 to 0.98 where the second won (chelsea on SLA 0.98, its own trial 0.96; coffee 0.91,
#: 0.96 with seed 1 and 0.93 with seed 2, low_contrast 0.82 and 0.89 on SLA, rocket 0.71 and 0.73),
#: but for the example with seeds 2 and 4, whose first wall's holes were poor (1.12 and 1.13:
#: :data:`FLOOR_RATIO` sends those to the second wall's own trial). Of 5 steps the scout ranked
#: less clearly (chelsea on SLA 1.16 where the second won, the example 1.17), of 3 worse still,
#: and the first wall's holes sprayed from the second wall unrefined not at all (coffee 1.33 and
#: chelsea 1.53 where the second won). The scout costs 0.9 CPU-s on the example.
SCOUT_STEPS = 10
#: How much worse than the first wall the scout must score for the first to win unstippled: below
#: the closest ratio where the first won (1.10), above the closest where the second did with holes
#: within :data:`FLOOR_RATIO` of their floor (0.98).
SCOUT_MARGIN = 0.06


def scouted(
    run: Run,
    plan: Plan,
    layers: Layers,
    picture: Picture | None,
    grid_mm_per_px: float,
    held: list[Any] | None,
    first: PlateTrial,
    second: tuple[str, float],
) -> tuple[float, float | None]:
    """``(the first wall's blur floor, the scout's score of the second wall or None)``.

    ``first``: the first wall's trial, scored after its steps; ``held``: its holes as its trial
    left them (:func:`stencil_cad.pipeline.standoff._trial_score`'s ``warm``: unrefined, then
    refined). The scout runs only where ``first`` scored within :data:`FLOOR_RATIO` of the floor
    and its refined holes are held (None otherwise). Both are S-CIELAB at the viewing distance on
    the trials' grid, rounded as the trials' are.
    """
    floor = round(
        blur_floor(with_design(plan, first.windows, first.standoff_mm), layers, picture, grid_mm_per_px, run),
        3,
    )
    if first.scielab > FLOOR_RATIO * floor or not held or len(held) < 2:
        return floor, None
    design = with_design(plan, *second)
    got = scout_score(run, design, layers, plan.picture_mm, picture, grid_mm_per_px, plan.paints, held[1])
    return floor, round(got, 3)


def scout_score(
    run: Run,
    cfg: JobConfig,
    layers: Layers,
    picture_mm: tuple[float, float],
    picture: Picture | None,
    grid_mm_per_px: float,
    paints: Paints | None,
    start: list[DotSet],
) -> float:
    """S-CIELAB at the viewing distance of another wall's holes ``start`` refined :data:`SCOUT_STEPS` steps for ``cfg``'s wall.

    Not stippled: the holes take the first :data:`SCOUT_STEPS` steps of ``cfg``'s refinement, then
    spray on the grid of ``grid_mm_per_px`` as a trial's do (:func:`sprayed_score`, against the
    reference the run keeps). None of its holes is kept in the run: the job never takes them up.
    """
    from .refinement import refine_holes

    trial = Run(cfg=run.cfg, out=run.out, quiet=True, executor=run.executor, cancel=run.cancel)
    plan = whole(cfg, picture_mm, paints)
    dotsets, _ = refine_holes(trial, plan, layers, start, picture, SCOUT_STEPS)
    return sprayed_score(plan, layers, picture, grid_mm_per_px, dotsets, run)


def blur_floor(
    cfg: JobConfig, layers: Layers, picture: Picture | None, grid_mm_per_px: float, run: Run | None = None
) -> float:
    """S-CIELAB at the viewing distance of the layers blurred as ``cfg``'s wall blurs a hole's image, with no dots.

    Each layer's opacity blurred by the physical model's Gaussian at the design's stand-off
    (:func:`stencil_cad.simulate.physical.spread_sigma_mm`, ``spray.can``'s), composited on the grid
    of ``grid_mm_per_px`` and scored against the picture as a trial is (the reference kept in
    ``run``, where given: :func:`stencil_cad.plan.picture.kept_reference`).
    """
    from ..simulate import blurred_composite
    from ..simulate.physical import spread_sigma_mm
    from ..simulate.scielab import scielab
    from .picture import kept_reference

    sprayed = blurred_composite(layers, spread_sigma_mm(cfg.spray, cfg.standoff.design_mm), grid_mm_per_px)
    ref = kept_reference(run, cfg, picture, layers, sprayed.shape[:2], grid_mm_per_px)
    return float(scielab(ref, sprayed, grid_mm_per_px, cfg.view.distance_m))


def sprayed_score(
    plan: Plan,
    layers: Layers,
    picture: Picture | None,
    grid_mm_per_px: float | None,
    dotsets: list[DotSet],
    run: Run | None = None,
) -> float:
    """S-CIELAB at the viewing distance of ``dotsets`` made and sprayed under ``plan`` on a grid of ``grid_mm_per_px``.

    The job's simulation grid where None. Each layer sprays as ``plan``'s sprays say. The
    reference is kept in ``run``, where given (:func:`stencil_cad.plan.picture.kept_reference`).
    """
    from .. import resolution, simulate
    from ..simulate.physical import SprayGeometry
    from ..simulate.scielab import scielab
    from ..stipple.made import made_dots
    from .picture import kept_reference

    cfg = plan.cfg
    made = [made_dots(d, cfg.stipple, plan.picture_mm) for d in dotsets]
    sim = simulate.simulate(
        layers,
        made,
        cfg.spray,
        resolution.sim_mm_per_px(cfg) if grid_mm_per_px is None else grid_mm_per_px,
        geometry=SprayGeometry.for_job(cfg),
        layer_sprays=plan.sprays,
        errors=False,  # only the composite is scored: no layer's tone error is read
    )
    ref = kept_reference(run, cfg, picture, layers, sim.composite.shape[:2], sim.mm_per_px)
    return float(scielab(ref, sim.composite, sim.mm_per_px, cfg.view.distance_m))
