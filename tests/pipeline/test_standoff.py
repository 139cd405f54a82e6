"""The plate design (windows on or off, the wall's stand-off) chosen for the picture when the config leaves it to the job."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from stencil_cad.config.io import parse_config
from stencil_cad.config.job import parse_overrides
from stencil_cad.figures import PlateTrial, StandoffFigures
from stencil_cad.model import Layers, Picture
from stencil_cad.mural import TileGrid
from stencil_cad.pipeline import standoff
from stencil_cad.pipeline.recorder import record_standoff
from stencil_cad.pipeline.standoff import WINDOW_SHARE, candidates, stage_standoff, window_share, with_design
from stencil_cad.plan import scout
from stencil_cad.plan.plan import painted, planned, whole
from stencil_cad.record import Run

_SLA = {"stipple": {"process": "sla", "tone": "calibrated"}, "spray": {"calibrate": "spray_time"}}


def _choose(run, layers, pic):
    """The config with the design the trials chose for a 60 x 60 mm one-plate job (figure ``standoff`` recorded)."""
    plan = painted(whole(run.cfg, (60.0, 60.0)), layers.colours)
    return record_standoff(run, stage_standoff(run, plan, layers, pic)).cfg


def _cfg(**extra):
    return parse_config({**_SLA, "size": {"width_mm": 60.0, "px_per_mm": 2.0}, **extra}, source="test")


def test_only_a_stand_off_left_null_is_chosen():
    cfg = _cfg()
    assert cfg.chooses_standoff and cfg.wall.standoff_mm is None
    assert cfg.standoff.listed_mm == (cfg.stipple.process.record.standoff_mm,)
    assert cfg.standoff.source == "default"
    assert not _cfg(wall={"standoff_mm": [10.0]}).chooses_standoff
    assert not _cfg(mode="hard").chooses_standoff
    assert not _cfg(spray={"model": "paper"}).chooses_standoff
    # The command line's overrides keep it left to the job; a chosen one keeps the mark.
    assert parse_overrides(cfg, seed=5).chooses_standoff
    low = cfg.with_standoff(4.0)
    assert low.standoff.listed_mm == (4.0,) and low.standoff.source == "job" and low.chooses_standoff
    assert low.wall.standoff_mm is None and cfg.standoff.design_mm == cfg.stipple.process.record.standoff_mm
    assert low.plate.thickness_mm == cfg.plate.thickness_mm


def test_candidates_follow_what_the_config_leaves_to_the_job():
    cfg = _cfg()
    # A picture without windows: the stand-off alone, the process's, two near it, one lower and one higher.
    assert candidates(cfg, 0.0) == [
        ("auto", 10.0),
        ("auto", 8.0),
        ("auto", 12.0),
        ("auto", 5.0),
        ("auto", 15.0),
    ]
    # Windows on a photo: each coarse stand-off with and without them, the config's own design first.
    assert candidates(cfg, 0.3) == [
        ("auto", 10.0),
        ("auto", 8.0),
        ("auto", 12.0),
        ("auto", 5.0),
        ("auto", 15.0),
        ("off", 10.0),
        ("off", 5.0),
        ("off", 15.0),
    ]
    # Windows carrying most of the paint: low stand-offs for the windows too (holes only never under 5 mm).
    assert candidates(cfg, 0.9)[-2:] == [("auto", 4.0), ("auto", 1.0)]
    assert len(candidates(cfg, 0.9)) == 10
    given = _cfg(wall={"standoff_mm": [10.0]})
    assert candidates(given, 0.9) == [("auto", 10.0), ("off", 10.0)]
    assert candidates(given, 0.0) == [("auto", 10.0)]
    assert candidates(_cfg(stipple={**_SLA["stipple"], "windows": "off"}), 0.9) == [
        ("off", 10.0),
        ("off", 8.0),
        ("off", 12.0),
        ("off", 5.0),
        ("off", 15.0),
    ]
    # FDM's stand-offs are the same.
    assert candidates(parse_config({}, source="test"), 0.0) == candidates(cfg, 0.0)


def test_with_design_sets_windows_and_stand_off():
    plan = whole(_cfg(), (60.0, 60.0))
    off = with_design(plan, "off", 15.0)
    assert off.stipple.windows.value == "off" and off.standoff.listed_mm == (15.0,) and off.chooses_standoff
    assert with_design(plan, "auto", 10.0) is plan.cfg


def _flat_layers(w_px: int = 120) -> tuple[Picture, Layers]:
    """A red disc and a blue bar on white, every paint solid (a flat-colour logo)."""
    yy, xx = np.mgrid[0:w_px, 0:w_px].astype(np.float64) / w_px
    red = (np.hypot(yy - 0.4, xx - 0.4) < 0.3).astype(np.float64)
    blue = ((yy > 0.78) & (yy < 0.92) & (xx > 0.1) & (xx < 0.9)).astype(np.float64)
    colours = np.array([[0.85, 0.1, 0.12], [0.05, 0.2, 0.6]])
    layers = Layers(primer=np.ones(3), colours=colours, alphas=np.stack([red, blue]), mm_per_px=0.5)
    return Picture(rgb=np.clip(layers.composite(), 0.0, 1.0), mm_per_px=0.5, source="test"), layers


def _photo_layers() -> tuple[Picture, Layers]:
    rng = np.random.default_rng(1)
    smooth = np.clip(
        0.5 + 0.4 * np.sin(np.linspace(0, 6, 120))[None, :] + rng.normal(0, 0.05, (120, 120)), 0, 1
    )
    layers = Layers(
        primer=np.ones(3), colours=np.array([[0.1, 0.1, 0.1]]), alphas=smooth[None], mm_per_px=0.5
    )
    return Picture(rgb=np.clip(layers.composite(), 0.0, 1.0), mm_per_px=0.5, source="test"), layers


def test_a_photo_without_windows_tries_the_stand_offs_only():
    pic, layers = _photo_layers()
    # One plate per paint: the unrefined screen ranks the walls (light plates refine two outright).
    run = Run(cfg=_cfg(stipple={**_SLA["stipple"], "light_plates": "off"}), out=None)  # type: ignore[arg-type]
    assert window_share(run.cfg, layers, TileGrid.whole(60.0, 60.0), (60.0, 60.0)) < WINDOW_SHARE
    cfg = _choose(run, layers, pic)
    fig = run.figures.standoff
    tried = [(t.windows, t.standoff_mm) for t in fig.trials] if fig is not None else []
    # The process's stand-off and the two near it, then each coarse step its near one points to.
    assert tried[:3] == [("auto", 10.0), ("auto", 8.0), ("auto", 12.0)]
    scores = {g: t.scielab for t, (_, g) in zip(fig.trials, tried, strict=True)}  # type: ignore[union-attr]
    noise = 1.0 + standoff.SCREEN_NOISE
    assert (5.0 in scores) == (scores[8.0] <= scores[10.0] * noise)
    assert (15.0 in scores) == (scores[12.0] <= scores[10.0] * noise)
    assert all(w == "auto" for w, _ in tried)
    best = min(fig.trials, key=lambda t: t.scielab)  # type: ignore[union-attr]
    assert cfg.standoff.listed_mm == (best.standoff_mm,) and fig.chosen == best
    assert fig.trial_mm_per_px == pytest.approx(2.0 * 0.25)


def test_flat_colour_art_sprays_from_lower_down():
    pic, layers = _flat_layers()
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    assert window_share(run.cfg, layers, TileGrid.whole(60.0, 60.0), (60.0, 60.0)) > 0.8
    cfg = _choose(run, layers, pic)
    fig = run.figures.standoff
    assert fig is not None and len(fig.trials) == 10
    scores = {(t.windows, t.standoff_mm): t.scielab for t in fig.trials}
    # The windows' edges stay sharp low down, and a field of holes cannot spray a solid: the trials
    # say so, and the job takes the best.
    assert scores[("auto", 10.0)] > min(scores[("auto", 1.0)], scores[("auto", 4.0)])
    assert scores[("off", 10.0)] > scores[("auto", 10.0)]
    assert cfg.standoff.listed_mm == (fig.standoff_mm,) and fig.standoff_mm < 10.0
    assert fig.windows == "auto" and cfg.stipple.windows.value == "auto"
    assert run.cfg is not cfg and cfg.chooses_standoff  # the maker's config is kept as given


def _scripted(monkeypatch, scores: dict[tuple[str, float], float], refined=None) -> None:
    """Trials that score as ``scores`` (unrefined) and ``refined`` say, so the choice itself is under test."""

    def trial(run, cfg, layers, picture_mm, picture, grid=None, refined_trial=False, **kw):
        table = (refined or scores) if kw.get("refined", refined_trial) else scores
        return table[(cfg.stipple.windows.value, cfg.standoff.design_mm)]

    def scouted(run, plan, layers, picture, grid, held, first, second):
        # A scout scores as the wall's own trial: within SCOUT_MARGIN of the other's it says nothing.
        return 0.1, (refined or scores)[second]

    monkeypatch.setattr(standoff, "_trial_score", trial)
    monkeypatch.setattr(scout, "scouted", scouted)


def test_a_coarse_step_is_tried_only_where_the_near_one_points(monkeypatch):
    # Score against stand-off falls to one best wall and rises past it: a coarse step beyond a near
    # step that did no better than the process's stand-off is not worth its trial.
    pic, layers = _flat_layers()
    down = {("auto", 10.0): 3.0, ("auto", 8.0): 2.8, ("auto", 12.0): 3.2, ("auto", 5.0): 2.5}
    down |= {("off", 10.0): 4.0, ("off", 5.0): 4.2, ("off", 15.0): 3.9}
    _scripted(monkeypatch, down)
    monkeypatch.setattr(standoff, "window_share", lambda *a: 0.3)  # a photo with some windows
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    cfg = _choose(run, layers, pic)
    fig = run.figures.standoff
    assert fig is not None and ("auto", 15.0) not in [(t.windows, t.standoff_mm) for t in fig.trials]
    # Holes alone have no near steps: all theirs are tried.
    assert {("off", 5.0), ("off", 15.0), ("auto", 5.0)} <= {(t.windows, t.standoff_mm) for t in fig.trials}
    assert cfg.standoff.listed_mm == (5.0,)
    # Neither near step beats the process's stand-off: no coarse step of the config's windows.
    _scripted(monkeypatch, down | {("auto", 8.0): 3.1})
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    _choose(run, layers, pic)
    fig = run.figures.standoff
    assert fig is not None and len(fig.trials) == 6
    assert not {("auto", 5.0), ("auto", 15.0)} & {(t.windows, t.standoff_mm) for t in fig.trials}
    # Worse within the trials' noise says nothing: the coarse step is tried (the dark sky's case).
    _scripted(monkeypatch, down | {("auto", 8.0): 3.0 * (1.0 + standoff.SCREEN_NOISE / 2)})
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    _choose(run, layers, pic)
    fig = run.figures.standoff
    assert fig is not None and ("auto", 5.0) in {(t.windows, t.standoff_mm) for t in fig.trials}


def test_light_plates_refine_two_walls_outright(monkeypatch):
    # The bundled example's case: unrefined, 8 mm looked best; refined, 5 mm is. No screen is made.
    from stencil_cad.pipeline.standoff import MIN_WINDOW_SHARE, direct_pair

    pic, layers = _photo_layers()
    monkeypatch.setattr(standoff, "window_share", lambda *a: MIN_WINDOW_SHARE / 2)
    _scripted(monkeypatch, {}, {("auto", 5.0): 2.58, ("auto", 8.0): 2.74})
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    cfg = _choose(run, layers, pic)
    fig = run.figures.standoff
    assert fig is not None and fig.trials == () and cfg.standoff.listed_mm == (5.0,)
    assert [(t.standoff_mm, t.scielab) for t in fig.refined] == [(5.0, 2.58), (8.0, 2.74)]
    steps = f"refined for {standoff.RANK_AFTER} steps"
    assert f"windows, 5 mm (chosen): {steps}, it scored 2.58" in fig.reason and "8 mm 2.74" in fig.reason
    assert fig.trial_mm_per_px is not None
    # The other wall wins where it sprays better; a tie keeps the lower one (the likelier).
    _scripted(monkeypatch, {}, {("auto", 5.0): 2.9, ("auto", 8.0): 2.7})
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    assert _choose(run, layers, pic).standoff.listed_mm == (8.0,)
    _scripted(monkeypatch, {}, {("auto", 5.0): 2.7, ("auto", 8.0): 2.7})
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    assert _choose(run, layers, pic).standoff.listed_mm == (5.0,)
    # The screen still runs where windows are in question, the wall is given, or plates are not light.
    cfg = _cfg()
    assert direct_pair(cfg, MIN_WINDOW_SHARE / 2) == [("auto", 5.0), ("auto", 8.0)]
    assert direct_pair(cfg, MIN_WINDOW_SHARE) == []
    assert direct_pair(_cfg(stipple={**_SLA["stipple"], "windows": "off"}), 0.3) == [
        ("off", 5.0),
        ("off", 8.0),
    ]
    assert direct_pair(_cfg(wall={"standoff_mm": [10.0]}), 0.0) == []
    assert direct_pair(_cfg(stipple={**_SLA["stipple"], "light_plates": "off"}), 0.0) == []
    assert direct_pair(_cfg(refine={"enabled": False}), 0.0) == []


def test_light_plates_rank_two_walls_part_way_through_their_refinement(monkeypatch):
    # Only the winner's refinement runs in full (the job's refine stage runs it): the pair is scored
    # after RANK_AFTER steps, and refined in full only where those scores are within the noise.
    from stencil_cad.pipeline.standoff import MIN_WINDOW_SHARE, RANK_AFTER, RANK_NOISE
    from stencil_cad.plan.scout import FLOOR_RATIO, SCOUT_MARGIN, SCOUT_STEPS

    pic, layers = _photo_layers()
    monkeypatch.setattr(standoff, "window_share", lambda *a: MIN_WINDOW_SHARE / 2)

    def scripted(
        early: dict[float, float],
        full: dict[float, float],
        scouts: dict[float, float] | None = None,
        floor: float = 2.09,
        **cfg_kw,
    ) -> tuple[Any, list]:
        asked: list[tuple[float, int | str | None]] = []

        def trial(
            run,
            cfg,
            layers,
            picture_mm,
            picture,
            grid=None,
            refined=False,
            paints=None,
            stop_after=None,
            warm=None,
        ):
            assert refined
            asked.append((cfg.standoff.design_mm, stop_after))
            if warm is not None and not warm:
                warm += ["unrefined", "refined"]
            return (full if stop_after is None else early)[cfg.standoff.design_mm]

        def scout_score(run, cfg, layers, picture_mm, picture, grid, paints, start):
            assert start == "refined"  # the first wall's holes after its RANK_AFTER steps
            asked.append((cfg.standoff.design_mm, "scout"))
            return (scouts or early)[cfg.standoff.design_mm]

        monkeypatch.setattr(standoff, "_trial_score", trial)
        monkeypatch.setattr(scout, "scout_score", scout_score)
        monkeypatch.setattr(scout, "blur_floor", lambda *a: floor)
        run = Run(cfg=_cfg(**cfg_kw), out=None)  # type: ignore[arg-type]
        cfg = _choose(run, layers, pic)
        return (cfg.standoff.listed_mm, run.figures.standoff), asked

    # The bundled example: after 30 steps 2.71 from 5 mm (1.30 times its blur floor, 2.09), and its
    # holes refined 10 steps for 8 mm scored 3.08 (14 % worse, past SCOUT_MARGIN): 8 mm is not
    # stippled, and 5 mm wins.
    (chosen, fig), asked = scripted({5.0: 2.71, 8.0: 2.95}, {5.0: 2.58, 8.0: 2.74}, {8.0: 3.08})
    assert chosen == (5.0,) and asked == [(5.0, RANK_AFTER), (8.0, "scout")]
    assert fig.ranked_after == RANK_AFTER and fig.scouted_after == SCOUT_STEPS and fig.blur_floor == 2.09
    assert [t.scielab for t in fig.refined] == [2.71, 3.08]
    assert fig.reason.endswith(
        f"8 mm 3.08 (not stippled: the 5 mm holes, 1.30 times their blur floor, refined {SCOUT_STEPS} steps for 8 mm)"
    )
    assert StandoffFigures.from_json(fig.to_json()) == fig
    # A scout within the margin says nothing: the second wall is stippled and refined as the first
    # was, and those scores rank the walls (the example's, were its scout so close).
    (chosen, fig), asked = scripted({5.0: 2.71, 8.0: 2.95}, {}, {8.0: 2.71 * (1.0 + SCOUT_MARGIN / 2)})
    assert chosen == (5.0,) and asked == [(5.0, RANK_AFTER), (8.0, "scout"), (8.0, RANK_AFTER)]
    assert fig.ranked_after == RANK_AFTER and fig.scouted_after is None and "stippled" not in fig.reason
    assert [t.scielab for t in fig.refined] == [2.71, 2.95] and "scouted_after" not in fig.to_json()
    # First holes far above their blur floor: the higher wall's blur may pay, and no scout decides
    # (the example with seed 2: 3.22 from 5 mm, 1.58 times its floor; its scout 3.62 ranked wrongly).
    (chosen, fig), asked = scripted(
        {5.0: 3.22, 8.0: 2.92}, {}, {8.0: 3.62}, floor=3.22 / (FLOOR_RATIO * 1.01)
    )
    assert chosen == (8.0,) and asked == [(5.0, RANK_AFTER), (8.0, RANK_AFTER)] and fig.scouted_after is None
    (chosen, fig), asked = scripted({5.0: 2.34, 8.0: 1.93}, {}, {8.0: 1.83})  # rocket's, were its floor low
    assert chosen == (8.0,) and asked == [(5.0, RANK_AFTER), (8.0, "scout"), (8.0, RANK_AFTER)]
    # Within the noise the part-way scores say nothing: both walls are refined in full, and those rank.
    close = {5.0: 3.0, 8.0: 3.0 * (1.0 + RANK_NOISE / 2)}
    (chosen, fig), asked = scripted(close, {5.0: 2.7, 8.0: 2.6}, floor=3.0)
    assert chosen == (8.0,) and asked == [
        (5.0, RANK_AFTER),
        (8.0, "scout"),
        (8.0, RANK_AFTER),
        (5.0, None),
        (8.0, None),
    ]
    assert fig.ranked_after is None and [t.scielab for t in fig.refined] == [2.7, 2.6]
    assert "windows, 8 mm (chosen): refined, it scored 2.60" in fig.reason
    # A refinement of no more steps than the ranking's is run in full at once, unscouted.
    (chosen, fig), asked = scripted({}, {5.0: 2.7, 8.0: 2.8}, refine={"iterations": RANK_AFTER})
    assert chosen == (5.0,) and asked == [(5.0, None), (8.0, None)] and fig.ranked_after is None


def test_a_scout_keeps_nothing_for_the_job():
    """The scout's refinement leaves the run's kept holes as they were: the job never takes them up."""
    pic, layers = _photo_layers()
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    plan = painted(whole(run.cfg, (60.0, 60.0)), layers.colours)
    low, near = (with_design(plan, "auto", g) for g in (5.0, 8.0))
    warm: list[Any] = []
    first = standoff._trial_score(run, low, layers, (60.0, 60.0), pic, 0.5, True, plan.paints, 3, warm)
    assert len(warm) == 2 and len(warm[1]) == layers.count
    kept = dict(run.kept)
    got = scout.scout_score(run, near, layers, (60.0, 60.0), pic, 0.5, plan.paints, warm[1])
    assert run.kept == kept and np.isfinite(got) and got != first
    # The first wall's holes are moved by the scout's steps, not the kept ones.
    again = standoff._trial_score(run, low, layers, (60.0, 60.0), pic, 0.5, True, plan.paints, 3, warm)
    assert again == first
    # The blur floor: the layers blurred more from the higher wall, and no dots.
    assert 0.0 < scout.blur_floor(low, layers, pic, 0.5) < scout.blur_floor(near, layers, pic, 0.5)


def test_windows_carrying_almost_no_paint_are_not_tried_off():
    from stencil_cad.pipeline.standoff import MIN_WINDOW_SHARE

    cfg = _cfg()
    assert all(w == "auto" for w, _ in candidates(cfg, MIN_WINDOW_SHARE / 2))
    assert ("off", 10.0) in candidates(cfg, MIN_WINDOW_SHARE)


def test_holes_alone_are_chosen_where_windows_spray_worse(monkeypatch):
    # Rocket's case: windows on a photo scored worse than holes alone; the job must not keep them.
    pic, layers = _flat_layers()
    _scripted(
        monkeypatch,
        {("auto", 10.0): 2.9, ("auto", 15.0): 2.8, ("off", 10.0): 2.3, ("off", 15.0): 2.2}
        | {("auto", 4.0): 3.0, ("auto", 1.0): 3.5, ("auto", 5.0): 3.1, ("off", 5.0): 2.6}
        | {("auto", 8.0): 3.0, ("auto", 12.0): 2.95},
    )
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    cfg = _choose(run, layers, pic)
    assert cfg.stipple.windows.value == "off" and cfg.standoff.listed_mm == (15.0,)
    fig = run.figures.standoff
    assert fig is not None and fig.windows == "off" and fig.standoff_mm == 15.0
    assert "holes only, 15 mm" in fig.reason and "2.20" in fig.reason


def test_the_two_best_of_different_stand_offs_are_told_apart_refined(monkeypatch):
    # The hubble case: unrefined, windows from 1 mm look best; refined, those from 4 mm are.
    pic, layers = _flat_layers()
    unrefined = {("auto", 10.0): 6.0, ("auto", 15.0): 6.2, ("off", 10.0): 6.5, ("off", 15.0): 6.6}
    unrefined |= {("auto", 5.0): 6.1, ("off", 5.0): 6.7, ("auto", 8.0): 6.3, ("auto", 12.0): 6.4}
    unrefined |= {("auto", 4.0): 5.8, ("auto", 1.0): 5.4}
    refined = {("auto", 4.0): 3.9, ("auto", 1.0): 4.4}
    _scripted(monkeypatch, unrefined, refined)
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    cfg = _choose(run, layers, pic)
    assert cfg.standoff.listed_mm == (4.0,)
    fig = run.figures.standoff
    assert fig is not None and [t.standoff_mm for t in fig.refined] == [1.0, 4.0]
    assert "refined, windows, 4 mm scored 3.90 against windows, 1 mm 4.40" in fig.reason
    # The two best share a stand-off: the best is refined beside the best of another stand-off.
    _scripted(monkeypatch, unrefined | {("off", 10.0): 5.0, ("auto", 10.0): 5.1}, {})
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    cfg = _choose(run, layers, pic)
    fig = run.figures.standoff
    assert fig is not None and [(t.windows, t.standoff_mm) for t in fig.refined] == [
        ("off", 10.0),
        ("auto", 1.0),
    ]
    assert cfg.standoff.listed_mm == (10.0,) and cfg.stipple.windows.value == "off"


def test_a_tie_keeps_the_config_own_design(monkeypatch):
    pic, layers = _flat_layers()
    _scripted(monkeypatch, dict.fromkeys(candidates(_cfg(), 0.9), 1.0))
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    cfg = _choose(run, layers, pic)
    assert cfg.stipple.windows.value == "auto" and cfg.standoff.listed_mm == (10.0,)


def test_a_given_stand_off_is_kept():
    pic, layers = _flat_layers()
    run = Run(cfg=_cfg(wall={"standoff_mm": [10.0]}), out=None)  # type: ignore[arg-type]
    cfg = _choose(run, layers, pic)
    # Holes alone cannot spray the logo's solids: the windows stay, and so does the given stand-off.
    assert cfg.stipple.windows.value == "auto" and cfg.standoff.listed_mm == (10.0,)
    assert run.figures.standoff is not None and len(run.figures.standoff.trials) == 2


def test_windows_off_are_kept_and_never_go_low():
    pic, layers = _flat_layers()
    run = Run(cfg=_cfg(stipple={**_SLA["stipple"], "windows": "off"}), out=None)  # type: ignore[arg-type]
    cfg = _choose(run, layers, pic)
    assert cfg.stipple.windows.value == "off" and cfg.standoff.design_mm in (5.0, 10.0, 15.0)


def test_nothing_left_to_the_job_tries_nothing(monkeypatch):
    pic, layers = _flat_layers()
    _scripted(monkeypatch, {})  # any trial would fail
    run = Run(cfg=_cfg(wall={"standoff_mm": [10.0]}, stipple={**_SLA["stipple"], "windows": "off"}), out=None)  # type: ignore[arg-type]
    plan = whole(run.cfg, (60.0, 60.0))
    done = stage_standoff(run, plan, layers, pic)
    assert done.plan is plan and done.figures is None and run.figures.standoff is None


def test_standoff_figures_json_is_exact():
    fig = StandoffFigures(
        window_share=0.35,
        standoff_mm=15.0,
        trials=(PlateTrial("auto", 10.0, 4.7), PlateTrial("off", 15.0, 4.2)),
        reason="holes only, 15 mm (chosen)",
        windows="off",
        trial_mm_per_px=0.5,
        seconds=3.2,
    )
    assert fig.to_json() == {
        "window_share": 0.35,
        "standoff_mm": 15.0,
        "windows": "off",
        "trials": [
            {"windows": "auto", "standoff_mm": 10.0, "scielab": 4.7},
            {"windows": "off", "standoff_mm": 15.0, "scielab": 4.2},
        ],
        "trial_mm_per_px": 0.5,
        "seconds": 3.2,
        "reason": "holes only, 15 mm (chosen)",
    }
    assert list(fig.to_json()) == [
        "window_share",
        "standoff_mm",
        "windows",
        "trials",
        "trial_mm_per_px",
        "seconds",
        "reason",
    ]
    assert fig.chosen == PlateTrial("off", 15.0, 4.2)


def test_the_summary_says_what_was_chosen_and_why(monkeypatch, tmp_path):
    from stencil_cad.report import summary

    pic, layers = _flat_layers()
    _scripted(monkeypatch, dict.fromkeys(candidates(_cfg(), 0.9), 2.0) | {("off", 15.0): 1.5})
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    _choose(run, layers, pic)
    lines = [line for line in summary(run, [], tmp_path).splitlines() if line.startswith("  design")]
    assert len(lines) == 1 and "holes only, 15 mm (chosen)" in lines[0] and "1.50" in lines[0]
    # Two walls refined outright (light plates, no screen) are told too.
    monkeypatch.setattr(standoff, "window_share", lambda *a: 0.0)
    _scripted(monkeypatch, {}, {("auto", 5.0): 2.6, ("auto", 8.0): 2.7})
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    _choose(run, layers, pic)
    lines = [line for line in summary(run, [], tmp_path).splitlines() if line.startswith("  design")]
    assert len(lines) == 1 and "windows, 5 mm (chosen): refined" in lines[0]


def test_a_measured_cap_is_tried_at_the_stand_off_that_keeps_the_priors_blur(tmp_path):
    from stencil_cad.config.io import load_config
    from stencil_cad.pipeline.standoff import matched_standoff

    assert matched_standoff(_cfg()) is None  # the prior's can: its stand-off already
    wide = tmp_path / "wide.yaml"
    wide.write_text("spread_k: 0.18\nbleed_sigma_mm: 0.25\ndeposit_per_pass: 1.125\ncard_standoff_mm: 10.0\n")
    job = tmp_path / "job.yaml"
    job.write_text(f"stipple: {{process: sla}}\nspray: {{profile: {wide}}}\n")
    cfg = load_config(job)
    assert matched_standoff(cfg) == 6.5  # 10 mm x 0.12 / 0.18, to 0.5 mm: the same blur
    assert candidates(cfg, 0.0) == [
        ("auto", 10.0),
        ("auto", 8.0),
        ("auto", 12.0),
        ("auto", 6.5),
        ("auto", 5.0),
        ("auto", 15.0),
    ]
    skinny = tmp_path / "skinny.yaml"
    skinny.write_text("spread_k: 0.04\nbleed_sigma_mm: 0.25\ndeposit_per_pass: 1.5\n")
    job.write_text(f"stipple: {{process: sla}}\nspray: {{profile: {skinny}}}\n")
    assert matched_standoff(load_config(job)) == 30.0


def test_a_lower_wall_gets_a_plate_that_sags_within_its_share():
    plan, _ = planned(parse_config({"size": {"width_mm": 200.0}}, source="test"), (200.0, 200.0), 400 * 400)
    cfg = plan.cfg
    assert plan.fills is not None and plan.fills.thickness.filled
    low = with_design(plan, "auto", 5.0)
    assert low.plate.thickness_mm > cfg.plate.thickness_mm  # 5 % of 5 mm, not of 10
    assert with_design(plan, "auto", 1.0).plate.thickness_mm == low.plate.thickness_mm  # the 5 mm floor
    assert with_design(plan, "auto", 15.0).plate.thickness_mm == cfg.plate.thickness_mm
    given = parse_config({"size": {"width_mm": 200.0}, "plate": {"thickness_mm": 1.2}}, source="test")
    kept, _ = planned(given, (200.0, 200.0), 400 * 400)
    assert with_design(kept, "auto", 5.0).plate.thickness_mm == 1.2


def test_the_job_reuses_the_holes_its_trials_made():
    """The job's stipple and refine stages take the holes the trials made for the design kept, not made again."""
    from stencil_cad.plan import holes
    from stencil_cad.plan.plan import capped

    pic, layers = _photo_layers()
    run = Run(cfg=_cfg(), out=None)  # type: ignore[arg-type]
    # The plan as the job makes it: its own tiling (one tile), the holes capped, the paints known.
    plan = painted(capped(planned(run.cfg, (60.0, 60.0), 120 * 120)[0]), layers.colours)
    assert plan.grid == TileGrid.whole(60.0, 60.0)
    designed = stage_standoff(run, plan, layers, pic)
    chosen = designed.plan
    made, stippled_kept = holes.stippled(run, chosen, layers)
    assert stippled_kept
    # Where the trials ranked two walls part way through their refinement, the job refines the
    # winner in full itself; otherwise it takes the trials' refined holes.
    assert designed.figures is not None
    assert holes.refined(run, chosen, layers, made, pic)[1] == (designed.figures.ranked_after is None)
