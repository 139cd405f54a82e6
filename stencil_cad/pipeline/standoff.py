"""The plate design chosen for the picture: windows on or off, and the wall's stand-off.

Two choices the config may leave to the job: ``stipple.windows: auto`` (the default) lets the job
open windows where a layer is solid or keep to holes, and ``wall.standoff_mm: null`` (the default)
lets it choose the wall's stand-off. Neither is right for every picture. The process's stand-off
(10 mm for every process's holes) is where plates of holes score best on most photos, but
some photos' dots blend better from higher up (coffee and rocket scored best at 15 mm with SLA
holes). On a picture whose paint goes mostly through windows (a logo, flat-colour art) the windows'
edges carry the error, and they stay sharp only low down, as a hard stencil's do: the generated logo
of the quality benchmark scored 2.00 at 10 mm, 0.92 at 4 mm and 0.88 at 1 mm (S-CIELAB at 1 m, SLA
rules). And windows can cost a photo more than they give: on rocket the hybrid plates scored 2.91
where holes alone scored 2.20.

So the designs are ranked by what they spray: each candidate's plates are stippled (without the
refinement) and sprayed in simulation on a coarse grid, and scored at the viewing distance like the
job's result; the best is kept. The candidates: windows on and off (only where the windows carry
:data:`MIN_WINDOW_SHARE` of the paint), at the process's stand-off, :data:`LOWER_BY_MM` below and :data:`HIGHER_BY_MM` above it,
:data:`NEAR_BY_MM` either side of it and, for a measured can, the
stand-off at which it blurs the holes as the prior's can does at the process's (:func:`matched_standoff`),
and where windows carry at
least :data:`WINDOW_SHARE` of the paint, windows at :data:`LOW_STANDOFFS_MM` too. A job whose config
fixes both (a given stand-off and ``windows: off``, or a picture without windows) tries nothing.
A coarse step past a near one that already scored worse is not tried (:func:`_screen`).

With light plates the unrefined screen ranks walls badly (the light plates' close holes are what
the refinement sharpens), so where the windows are not in question and no can is measured, two
walls are refined outright instead (:func:`direct_pair`), and ranked a third of the way through
their refinement, where the scores already tell them apart: only the winner is refined in full
(:func:`_ranked_pair`), and the job's refinement of the winner carries on from its trial's 30th step
(:func:`stencil_cad.plan.holes.refined`): on the bundled example the walls' refinement takes 120
steps rather than 180, 30 each to rank them and 60 more for the winner, with the same choice and the
same holes. And the second wall's plates are made only where a scout of it cannot tell that the
first wins (:mod:`stencil_cad.plan.scout`: the first wall's holes refined a few steps for the
second): on the example they scored 3.08 against 2.71, and its 8 mm plates are never made (its
walls' refinement takes 100 steps: the first wall's 30, the scout's 10 and 60 more for the winner).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np

from ..config import JobConfig
from ..config.stipple import Windows
from ..figures import PlateTrial, StandoffFigures
from ..model import Layers, Picture
from ..plan import scout
from ..plan.plan import Plan, designed, whole, with_design
from ..plan.profiles import Paints
from ..plan.results import Designed
from ..record import Run

log = logging.getLogger(__name__)

#: Share of the layers' paint (opacity summed over layers and pixels) that must go through windows
#: before lower stand-offs are tried: the logo 0.97, the river of rocket 0.39, the dark sky 0.29 (FDM),
#: coffee 0.22, the bundled example, astronaut and chelsea under 0.01.
WINDOW_SHARE = 0.5
#: Share of the paint through windows below which the plates are tried with the config's windows
#: only: the two designs then differ in too little paint to rank. On the bundled example (0.001)
#: windows and holes only scored 6.09 and 6.14 unrefined from 10 mm, a gap the stippling's own
#: randomness makes (its plates differ in one window of a few mm²).
MIN_WINDOW_SHARE = 0.01
#: The lower stand-offs tried for windows beside the process's, in mm: a hard stencil's (1 mm) and one between.
LOW_STANDOFFS_MM = (1.0, 4.0)
#: The higher stand-off tried is the process's plus this, in mm (15 for the processes' 10).
HIGHER_BY_MM = 5.0
#: The lower stand-off tried is the process's less this, in mm (5 for the processes' 10), not under
#: :data:`LOWEST_MM`: fine texture wants less blur (the quality benchmark's grass scored S-CIELAB 4.69
#: at 1 m from 10 mm, 3.07 from 6 and 2.90 from 4; the bundled example 3.99, 4.00 from 6).
LOWER_BY_MM = 5.0
LOWEST_MM = 3.0
#: Stand-offs this near the process's, in mm, are tried too (with the config's windows): the bundled
#: example scored S-CIELAB 3.99 at 1 m from 10 mm, 3.66 from 8, 3.78 from 7, 4.00 from 6 and 4.35
#: from 5 (refined, FDM holes): the best wall for a picture lies between the coarse steps.
NEAR_BY_MM = 2.0
#: Relative difference between two unrefined trials that their stippling's randomness alone can make:
#: on the bundled example windows and holes only (plates that differ in one small window) scored
#: 6.087 and 6.138 from 10 mm, 0.8 % apart.
SCREEN_NOISE = 0.01
#: With light plates the two walls are ranked after this many steps of their refinement (of the
#: job's ``refine.iterations``, 90 by default; the whole refinement's first steps, its step sizes
#: decaying over all of them), and only the winner is refined in full. Scored so on the trials'
#: grid, 5 and 8 mm ranked as refined in full on the bundled example and on all 9 FDM pictures of
#: the fidelity benchmark that refine two walls (8 mm won on coffee, chelsea, rocket and
#: low_contrast); the closest were the example, 2.87 from 5 mm against 3.03 from 8 (5.5 %; 2.58
#: and 2.74 in full), and coffee, 2.50 against 2.31 (7.7 %). After 20 steps the example's walls and
#: astronaut's stood 1.0 % and 2.7 % apart, after 10 astronaut and immunohistochemistry ranked
#: wrongly. A short refinement of its own (its step sizes decaying over fewer steps) ranked them
#: less clearly: of 15 steps, immunohistochemistry wrongly; of 30, the example's walls 1.8 % apart.
#: Measured by stopping each wall's refinement at each step count
#: and scoring it as ``_trial_score`` does, on ``benchmarks.fidelity.job_config(image, "fdm", folder)``
#: and the bundled example's config, with the refinement on the simulation's grid. On the coarser
#: grid it now takes (:func:`stencil_cad.plan.refinement.refine_grid`) the example's walls stood
#: 2.87 against 3.06 after 30 steps (6.6 %), and ``python -m benchmarks fidelity`` kept every FDM
#: picture's wall of before but saturated's (not ranked so: its windows carry much of the paint, and
#: of its screen's two walls refined in full 8 mm now won over 10; S-CIELAB at 1 m 4.11 against 4.10).
#: With the second wall's Lloyd started from the first's holes (:data:`WARM_START`) the example's
#: walls stand 2.87 against 2.98 (3.8 %), and the 12 FDM pictures kept their walls.
RANK_AFTER = 30
#: Relative difference of the two walls' scores after :data:`RANK_AFTER` steps within which both are
#: refined in full and scored again: the scores part way through do not tell them apart. The
#: smallest gap after 30 steps was 5.5 % (the bundled example); after 20 steps the example's walls
#: stood 1.0 % apart and after 25 0.4 %, yet 6 % apart refined in full.
RANK_NOISE = 0.02
#: With light plates the second wall's stippling starts each layer's Lloyd relaxation from the first
#: wall's holes (:func:`stencil_cad.stipple.warm.warm_seeds`) rather than from an importance sample:
#: the picture and opacities are the same, only the tone (and the dot count, 1 to 22 % lower at 8 mm
#: than at 5 on the bundled example) differ. On the example its Lloyd took 8 to 19 passes per layer
#: rather than 22 to 32 (1.2 CPU-s rather than 2.4), the CVT energy no higher.
WARM_START = True
#: The trials simulate on a grid this many times coarser than the job's (at least ...).
TRIAL_COARSENING = 2.0


def window_share(cfg: JobConfig, layers: Layers, tiling: Any, picture_mm: tuple[float, float]) -> float:
    """Share of the layers' paint that goes through their windows, in [0, 1].

    The paint is each layer's opacity above ``stipple.opacity_threshold``, summed over layers and
    pixels; windows as the stipple stage finds them (:func:`stencil_cad.plan.holes.layer_windows`).
    """
    from ..plan.holes import layer_windows

    windows, _ = layer_windows(cfg, layers, tiling, picture_mm)
    paint = through = 0.0
    for alpha, w in zip(layers.alphas, windows, strict=True):
        a = np.where(alpha < cfg.stipple.opacity_threshold, 0.0, np.asarray(alpha, dtype=np.float64))
        paint += float(a.sum())
        through += float(a[w.mask].sum())
    return through / paint if paint > 0.0 else 0.0


def trial_mm_per_px(cfg: JobConfig) -> float:
    """The trials' simulation pixel in mm: :data:`TRIAL_COARSENING` times the job's."""
    from .. import resolution

    fine = resolution.sim_mm_per_px(cfg)
    return TRIAL_COARSENING * (1.0 / float(cfg.spray.px_per_mm) if fine is None else fine)


def candidates(cfg: JobConfig, share: float) -> list[tuple[str, float]]:
    """The plate designs worth a trial, ``(windows, stand-off in mm)``, the config's own first.

    Windows on and off where the config lets the job choose (``stipple.windows: auto``) and the
    picture's windows carry at least :data:`MIN_WINDOW_SHARE` of its paint; the process's stand-off, :data:`LOWER_BY_MM` below and
    :data:`HIGHER_BY_MM` above it where the config leaves the stand-off to the job (and, with the
    config's windows, :data:`NEAR_BY_MM` either side), and for windows the :data:`LOW_STANDOFFS_MM`
    too where they carry at least :data:`WINDOW_SHARE` of the paint.
    """
    own = (cfg.stipple.windows.value, cfg.standoff.design_mm)
    windows = (
        [Windows.auto.value, Windows.off.value]
        if own[0] == Windows.auto.value and share >= MIN_WINDOW_SHARE
        else [own[0]]
    )
    heights = [own[1]]
    if cfg.chooses_standoff:
        if own[1] - LOWER_BY_MM >= LOWEST_MM:
            heights.append(own[1] - LOWER_BY_MM)
        heights.append(own[1] + HIGHER_BY_MM)
        matched = matched_standoff(cfg)
        if matched is not None and matched not in heights:
            heights.insert(1, matched)
    out = [(w, g) for w in windows for g in heights]
    if cfg.chooses_standoff:
        near = [g for g in (own[1] - NEAR_BY_MM, own[1] + NEAR_BY_MM) if g >= LOWEST_MM and g not in heights]
        out[1:1] = [(own[0], g) for g in near]
    if cfg.chooses_standoff and share >= WINDOW_SHARE and Windows.auto.value in windows:
        out += [(Windows.auto.value, g) for g in sorted(LOW_STANDOFFS_MM, reverse=True) if g < own[1]]
    return out


def prior_design(cfg: JobConfig) -> tuple[str, float]:
    """The plate design ``(windows, stand-off in mm)`` the trials are likeliest to choose, before they run.

    With light plates (:func:`stencil_cad.plan.tiles.light_plates_on`) and the stand-off left to
    the job, the stand-off :data:`LOWER_BY_MM` below the process's: light plates make the light tones
    of close holes, which need less blur (the bundled example's trials chose 5 mm with light plates,
    8 mm without). Otherwise the config's own design, the first the trials try.
    """
    from ..plan.tiles import light_plates_on

    own = (cfg.stipple.windows.value, cfg.standoff.design_mm)
    lower = own[1] - LOWER_BY_MM
    if cfg.chooses_standoff and lower >= LOWEST_MM and light_plates_on(cfg, tiled=False):
        return own[0], lower
    return own


def matched_standoff(cfg: JobConfig) -> float | None:
    """The stand-off at which a measured can blurs the holes as the prior's can does at the process's.

    Under the physical model a hole's blur grows as ``spread_k * stand-off``: the process's stand-off
    was chosen for the prior's cap (``spread_k`` 0.12), so a measured cap 50 % wider keeps the same
    blur on a wall two thirds as high. The stand-off ``g * k_prior / k`` with ``k`` the median
    measured spread of the job's cans, rounded to 0.5 mm, in [2, 50] mm; None when no can is
    measured or it matches the prior's.
    """
    from ..config.spray import CanConstants

    spray = cfg.spray
    if not spray.has_cans:
        return None
    cans = [*([spray.can] if spray.is_measured else []), *spray.layer_cans.values()]
    measured = [c.spread_k for c in cans if c.spread_k > 0.0]
    if not measured:
        return None
    k_prior = float(CanConstants.model_fields["spread_k"].default)
    g = round(2.0 * cfg.standoff.design_mm * k_prior / float(np.median(measured))) / 2.0
    g = min(50.0, max(2.0, g))
    return None if g == cfg.standoff.design_mm else g


def _trial_score(
    run: Run,
    cfg: JobConfig,
    layers: Layers,
    picture_mm: tuple[float, float],
    picture: Picture | None,
    grid_mm_per_px: float | None = None,
    refined: bool = False,
    paints: Paints | None = None,
    stop_after: int | None = None,
    warm: list[Any] | None = None,
) -> float:
    """S-CIELAB at the viewing distance of ``cfg``'s plates stippled (not refined) and sprayed.

    Sprayed on a grid of ``grid_mm_per_px`` (the job's simulation grid by default); with
    ``refined``, refined as the job refines them (stopped after ``stop_after`` of the refinement's
    steps, where given). Each layer sprays as ``paints`` (the job's plan's) resolve for ``cfg``:
    the sprays of the design tried. ``warm`` carries one wall's holes to the next: where it holds
    some, each layer's Lloyd relaxation starts from its first, the unrefined holes
    (:func:`stencil_cad.plan.holes.stippled`); where it is empty, this trial's unrefined and refined
    holes are put in it, the refined ones for :func:`stencil_cad.plan.scout.scouted` (None: neither).
    """
    from ..plan import holes

    trial_cfg = (
        cfg
        if refined
        else cfg.model_copy(update={"refine": cfg.refine.model_copy(update={"enabled": False})})
    )
    # The trial's own figures; its holes are kept for the job (``run.kept``), and it writes nothing.
    trial = Run(cfg=run.cfg, out=run.out, quiet=True, executor=run.executor, cancel=run.cancel, kept=run.kept)
    plan = whole(trial_cfg, picture_mm, paints)
    # Stippled, then refined (when the trial's config refines), as the job's stages run them.
    unrefined = holes.stippled(trial, plan, layers, warm[0] if warm else None)[0]
    dotsets = holes.refined(trial, plan, layers, unrefined, picture, stop_after)[0].sets
    if warm is not None and not warm:
        warm += [unrefined, dotsets]
    return scout.sprayed_score(plan, layers, picture, grid_mm_per_px, dotsets, trial)


def stage_standoff(run: Run, plan: Plan, layers: Layers, picture: Picture | None) -> Designed:
    """``plan`` with the plate design (windows, stand-off) this picture's plates spray best with.

    The designs of :func:`candidates` are tried (:func:`_screen`, :func:`_trial_score`, on the coarse
    grid of :func:`trial_mm_per_px`) and the best kept, or with light plates the two walls of
    :func:`direct_pair` refined outright (ranked part way through, the second scouted first:
    :func:`_ranked_pair`); with one candidate the plan comes back as it is. The run calls it for
    one-plate jobs only (a mural keeps its config: trials over every tile would cost more than the job).

    Returns:
        The plan with the design (:func:`stencil_cad.plan.plan.designed`) and figure ``standoff``
        (the share, the trials and the choice; None when the config leaves nothing to the job),
        which :func:`stencil_cad.pipeline.recorder.record_standoff` records.
    """
    from ..mural import TileGrid

    cfg, picture_mm = plan.cfg, plan.picture_mm
    if cfg.stipple.windows == Windows.off and not cfg.chooses_standoff:
        return Designed(plan)
    t0 = time.perf_counter()
    with run.stage("standoff"):
        share = window_share(cfg, layers, TileGrid.whole(*picture_mm), picture_mm)
        designs = candidates(cfg, share)
        grid = trial_mm_per_px(cfg)
        direct = direct_pair(cfg, share)
        # The first wall's holes start the second's Lloyd (WARM_START) and scout it (plan.scout).
        warm: list[Any] | None = [] if direct and WARM_START else None

        def score(w: str, g: float, refined: bool, stop_after: int | None = None) -> float:
            design = with_design(plan, w, g)
            return round(
                _trial_score(
                    run,
                    design,
                    layers,
                    picture_mm,
                    picture,
                    grid,
                    refined=refined,
                    paints=plan.paints,
                    stop_after=stop_after,
                    warm=warm,
                ),
                3,
            )

        trials: list[PlateTrial] = []
        if not direct and len(designs) > 1:
            trials = _screen(designs, cfg, share, lambda w, g: score(w, g, False))
        # Light plates: the unrefined screen ranks walls badly, so two walls are refined outright,
        # ranked part way through their refinement where that tells them apart.
        ranked = _Ranked([])
        if direct:
            # The first wall's refined holes scout the second (stencil_cad.plan.scout).
            scouting = partial(scout.scouted, run, plan, layers, picture, grid, warm)
            ranked = _ranked_pair(
                direct, cfg.refine.iterations, score, scouting if warm is not None else None
            )
            refined = ranked.trials
        else:
            refined = [PlateTrial(w, g, score(w, g, True)) for w, g in _refined_pair(cfg, trials)]
        best = _best(designs[0], trials, refined, bool(direct))
        chosen = designed(plan, best.windows, best.standoff_mm)
    fig = StandoffFigures(
        window_share=round(share, 3),
        standoff_mm=best.standoff_mm,
        trials=tuple(trials),
        reason=_reason(designs[0], best, trials, cfg.view.distance_m, refined, ranked),
        windows=best.windows,
        trial_mm_per_px=round(grid, 4) if trials or direct else None,
        seconds=round(time.perf_counter() - t0, 2),
        refined=tuple(refined),
        ranked_after=ranked.after,
        scouted_after=ranked.scouted_after,
        blur_floor=ranked.floor,
    )
    if trials or direct:
        log.info("plates: %s", fig.reason)
    return Designed(chosen, fig)


def _best(
    own: tuple[str, float], trials: list[PlateTrial], refined: list[PlateTrial], direct: bool
) -> PlateTrial:
    """The design kept: the best refined of two walls refined outright, else the screen's best (``own`` without trials).

    The first best wins a tie: the config's own design is tried first. Where the screen's two best
    of different stand-offs were refined, the better refined one's trial.
    """
    if direct:
        return min(refined, key=lambda t: t.scielab)
    best = min(trials, key=lambda t: t.scielab) if trials else PlateTrial(*own, float("nan"))
    if refined:
        best = next(t for t in trials if t.label == min(refined, key=lambda t: t.scielab).label)
    return best


def _screen(
    designs: list[tuple[str, float]], cfg: JobConfig, share: float, score: Callable[[str, float], float]
) -> list[PlateTrial]:
    """The unrefined trials of ``designs``, in order, but for the coarse steps the near ones rule out.

    A picture's score against the stand-off falls to one best wall and rises past it (the blur
    against the dots showing): the bundled example scored 7.42, 6.12, 6.09, 6.68 and 7.61 unrefined
    from 5, 8, 10, 12 and 15 mm. So the coarse step :data:`LOWER_BY_MM` below the process's
    stand-off is not tried where the near step :data:`NEAR_BY_MM` below it scored worse than the
    process's by more than :data:`SCREEN_NOISE` (and :data:`HIGHER_BY_MM` above likewise), for the
    config's own windows; on the example that leaves 4 of 5 trials. Within the noise the curve says
    nothing: the dark sky scored 1.726, 1.770 and 1.764 from 5, 8 and 10 mm. The other windows have
    no near steps of their own to tell (the best wall of holes alone need not lie on the side where
    the windows' does), so theirs are all tried, as is a measured can's stand-off. Where windows
    carry :data:`WINDOW_SHARE` of the paint or more, every design is tried: their edges do not
    follow the holes' curve (a flat-colour test logo scored 5.60 from 10 mm, 6.13 from 8, 2.40 from
    4 and 2.31 from 1).
    """
    own_w, own_g = cfg.stipple.windows.value, cfg.standoff.design_mm
    steps = {own_g - LOWER_BY_MM: own_g - NEAR_BY_MM, own_g + HIGHER_BY_MM: own_g + NEAR_BY_MM}
    done: dict[tuple[str, float | None], float] = {}
    trials = []
    pruning = share < WINDOW_SHARE
    for w, g in designs:
        near, own = (w, steps.get(g)), (w, own_g)
        if pruning and w == own_w and near in done and done[near] > done[own] * (1.0 + SCREEN_NOISE):
            continue
        done[(w, g)] = score(w, g)
        trials.append(PlateTrial(w, g, done[(w, g)]))
    return trials


def _refined_pair(cfg: JobConfig, trials: list[PlateTrial]) -> list[tuple[str, float]]:
    """The best trial's design and the best of another stand-off's, to refine; none when all share one.

    The unrefined trials rank designs of one stand-off well, but the refinement sharpens more where
    the blur is larger: on a mostly dark photo (the quality benchmark's hubble_deep_field, primed
    dark) windows from 1 mm scored 6.13 unrefined against 6.71 from 4 mm, and refined 4.91 against
    4.37. So the best design and the best of any other stand-off are both refined (as the job
    refines) and sprayed on the trials' grid, and the better refined one is kept.
    """
    if not cfg.refine.enabled or len(trials) < 2:
        return []
    ranked = sorted(trials, key=lambda t: t.scielab)
    first = ranked[0]
    second = next((t for t in ranked if t.standoff_mm != first.standoff_mm), None)
    if second is None:
        return []
    return [(t.windows, t.standoff_mm) for t in (first, second)]


def direct_pair(cfg: JobConfig, share: float) -> list[tuple[str, float]]:
    """The two walls refined outright, without the unrefined screen; empty where the screen runs.

    With light plates (:func:`stencil_cad.plan.tiles.light_plates_on`) the unrefined screen
    ranks walls badly: the light plates' close holes are what the refinement sharpens. On the
    bundled example it put 8 mm first (5.03 against 5.73 at 5 mm) and refinement reversed that
    (2.58 against 2.74), and 9 of the fidelity benchmark's 12 FDM pictures kept 5 or 8 mm. So where
    the config leaves the stand-off to the job, the windows are not in question (they carry under
    :data:`MIN_WINDOW_SHARE` of the paint) and no can is measured, the walls
    :data:`LOWER_BY_MM` and :data:`NEAR_BY_MM` below the process's are refined and the better kept
    (ranked part way through their refinement: :func:`_ranked_pair`): the four unrefined screens (a
    quarter of the job's CPU on the example) are not made.
    """
    from ..plan.tiles import light_plates_on

    own_w, own_g = cfg.stipple.windows.value, cfg.standoff.design_mm
    low, near = own_g - LOWER_BY_MM, own_g - NEAR_BY_MM
    if not (cfg.chooses_standoff and cfg.refine.enabled and low >= LOWEST_MM):
        return []
    if share >= MIN_WINDOW_SHARE and own_w == Windows.auto.value:
        return []
    if matched_standoff(cfg) is not None or not light_plates_on(cfg, tiled=False):
        return []
    return [(own_w, low), (own_w, near)]


@dataclass(frozen=True)
class _Ranked:
    """Two walls ranked (:func:`_ranked_pair`): their trials and how they were scored.

    ``after``: the steps they were scored after, or None for all; ``scouted_after``: the scout's
    steps where it ranked the second wall (its trial the scout's), else None; ``floor``: the first
    wall's blur floor where the scout looked at it, else None.
    """

    trials: list[PlateTrial]
    after: int | None = None
    scouted_after: int | None = None
    floor: float | None = None


def _ranked_pair(
    pair: list[tuple[str, float]],
    steps: int,
    score: Callable[[str, float, bool, int | None], float],
    scouting: Callable[[PlateTrial, tuple[str, float]], tuple[float, float | None]] | None = None,
) -> _Ranked:
    """The walls of ``pair`` scored part way through their refinement, or refined in full where that ties them.

    Each wall's refinement is stopped after :data:`RANK_AFTER` of its ``steps`` (the whole
    refinement's first steps, its step sizes decaying over all of them) and sprayed; where one
    scores better than the other by more than :data:`RANK_NOISE`, those scores rank the walls and
    only the winner is refined in full, by the job's refine stage. Otherwise, or where the
    refinement takes no more than :data:`RANK_AFTER` steps, both are refined in full and scored.
    With ``scouting`` (:func:`stencil_cad.plan.scout.scouted`: ``(the first wall's blur floor, the
    scout's score or None)``), the second wall is not stippled where the scout scores worse than
    the first by more than :data:`stencil_cad.plan.scout.SCOUT_MARGIN`: the first wins, ranked so.
    """
    floor = None
    if RANK_AFTER < steps:
        (w0, g0), second = pair
        first = PlateTrial(w0, g0, score(w0, g0, True, RANK_AFTER))
        if scouting is not None:
            floor, scouted = scouting(first, second)
            if scouted is not None and scouted > first.scielab * (1.0 + scout.SCOUT_MARGIN):
                return _Ranked([first, PlateTrial(*second, scouted)], RANK_AFTER, scout.SCOUT_STEPS, floor)
        early = [first, PlateTrial(*second, score(*second, True, RANK_AFTER))]
        low, high = sorted(t.scielab for t in early)
        if high > low * (1.0 + RANK_NOISE):
            return _Ranked(early, RANK_AFTER, None, floor)
    return _Ranked([PlateTrial(w, g, score(w, g, True, None)) for w, g in pair], None, None, floor)


def _reason(
    own: tuple[str, float],
    best: PlateTrial,
    trials: list[PlateTrial],
    distance_m: float,
    refined: list[PlateTrial] | None = None,
    ranked: _Ranked | None = None,
) -> str:
    """Why the design was chosen, in one line."""
    if not trials and refined:
        lost = max(refined, key=lambda t: t.scielab)
        after = ranked.after if ranked is not None else None
        how = "refined" if after is None else f"refined for {after} steps"
        against = f"{lost.label} {lost.scielab:.2f}"
        if ranked is not None and ranked.scouted_after is not None and ranked.floor:
            against += (
                f" (not stippled: the {best.standoff_mm:g} mm holes, {best.scielab / ranked.floor:.2f} times "
                f"their blur floor, refined {ranked.scouted_after} steps for {lost.standoff_mm:g} mm)"
            )
        return (
            f"{best.label} (chosen): {how}, it scored {best.scielab:.2f} (S-CIELAB at {distance_m:g} m) "
            f"against {against}"
        )
    if not trials:
        return f"{best.label}: the only design left to the job"
    kept = "the config's own" if (best.windows, best.standoff_mm) == own else "chosen"
    if refined:
        won = min(refined, key=lambda t: t.scielab)
        lost = max(refined, key=lambda t: t.scielab)
        first = min(trials, key=lambda t: t.scielab)
        return (
            f"{best.label} ({kept}): of {len(trials)} designs tried unrefined (S-CIELAB at {distance_m:g} m), "
            f"the best was {first.label} {first.scielab:.2f}; refined, {won.label} scored {won.scielab:.2f} "
            f"against {lost.label} {lost.scielab:.2f}"
        )
    others = sorted((t for t in trials if t is not best), key=lambda t: t.scielab)
    runner = others[0]
    text = (
        f"{best.label} ({kept}): its unrefined plates scored {best.scielab:.2f} (S-CIELAB at {distance_m:g} m), "
        f"the best of {len(trials)} designs tried (next {runner.label} {runner.scielab:.2f})"
    )
    return text
