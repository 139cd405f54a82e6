"""The job's plan: each planning step returns a new frozen plan and leaves the one it was given alone."""

import dataclasses

import numpy as np
import pytest

from stencil_cad.config.io import parse_config
from stencil_cad.model import Picture
from stencil_cad.plan.plan import capped, designed, planned, primed, whole
from stencil_cad.record import Run


def test_a_plan_is_frozen_and_each_step_returns_a_new_one():
    given = parse_config({"stipple": {"dots": 2_000_000}}, source="test")
    plan, _ = planned(given, (60.0, 60.0), 120 * 120)
    with pytest.raises(dataclasses.FrozenInstanceError):
        plan.cfg = given  # type: ignore[misc]
    fewer = capped(plan)
    assert fewer is not plan and fewer.cfg.stipple.dots < 2_000_000
    assert plan.cfg.stipple.dots == 2_000_000 and given.stipple.dots == 2_000_000
    assert capped(fewer) is fewer


def test_a_dark_picture_is_primed_in_the_plan_not_in_the_config():
    rgb = np.full((100, 100, 3), 0.8)
    rgb[:70] = (0.02, 0.03, 0.05)
    plan = whole(parse_config({}, source="test"), (50.0, 50.0))
    dark = primed(plan, Picture(rgb=rgb, mm_per_px=0.5))
    assert dark.primer == "#05080d" and dark.cfg.decompose.primer_rgb() is not None
    assert plan.primer is None and plan.cfg.decompose.primer_rgb() is None


def test_the_design_chosen_is_a_new_plan():
    plan, _ = planned(parse_config({}, source="test"), (170.0, 120.0), 340 * 240)
    low = designed(plan, "off", 5.0)
    assert low.cfg.standoff.design_mm == 5.0 and low.cfg.stipple.windows.value == "off"
    assert plan.cfg.standoff.design_mm == 10.0
    assert designed(plan, plan.cfg.stipple.windows.value, plan.cfg.standoff.design_mm) is plan


def test_paints_resolved_again_keep_what_was_applied_to_each_layer():
    # Hard mode's cut-outs spray whole passes (``each``); a plan resolved again for another spray
    # section must apply it again, not fall back to the profiles' settings.
    from stencil_cad.plan.plan import painted, repainted

    plan = whole(parse_config({}, source="test"), (50.0, 50.0))
    colours = np.array([[0.9, 0.1, 0.1], [0.1, 0.1, 0.9]])
    twice = painted(plan, colours, each=lambda sp: sp.model_copy(update={"passes": 7.0}))
    assert all(sp.passes == 7.0 for sp in twice.sprays if sp is not twice.cfg.spray)
    spray = twice.cfg.spray.model_copy(update={"can_distance_mm": twice.cfg.spray.can_distance_mm + 10.0})
    again = repainted(dataclasses.replace(twice, cfg=twice.cfg.model_copy(update={"spray": spray})))
    assert again is not twice and all(sp.passes == 7.0 for sp in again.sprays if sp is not again.cfg.spray)


def test_a_run_keeps_the_config_it_was_given():
    cfg = parse_config({}, source="test")
    run = Run(cfg=cfg, out=None)  # type: ignore[arg-type]
    with pytest.raises(AttributeError):
        run.cfg = cfg.model_copy()  # the house rule's runtime half: a job's decisions go in its Plan
    assert run.cfg is cfg


def test_a_lower_wall_fits_the_filled_thickness_again_and_the_cost_reads_it():
    plan, _ = planned(parse_config({"size": {"width_mm": 150}}, source="test"), (150.0, 150.0), 300 * 300)
    assert plan.fills is not None and plan.fills.thickness.filled
    low = designed(plan, "auto", 5.0)
    assert low.cfg.plate.thickness_mm > plan.cfg.plate.thickness_mm  # sags within 5 % of 5 mm
    assert low.fills is not None and low.fills.thickness.thickness_mm == low.cfg.plate.thickness_mm
    assert low.plate is not None and low.plate.thickness_mm == low.cfg.plate.thickness_mm

    # The job's cost estimates the plates it builds: thicker plates under the lower wall weigh more.
    from stencil_cad.model import DotSet
    from stencil_cad.pipeline.cost import stage_cost

    holes = [DotSet(xy_mm=np.array([[20.0 + 5 * k, 30.0]]), r_mm=np.array([0.6])) for k in range(4)]

    def plate_grams(p):
        return [part.filament_g for part in stage_cost(p, holes).parts if part.kind == "plate"]

    assert all(t > n for t, n in zip(plate_grams(low), plate_grams(plan), strict=True))
    # A thickness the maker gave is kept whatever the wall.
    given, _ = planned(parse_config({"plate": {"thickness_mm": 1.2}}, source="test"), (150.0, 150.0), 90000)
    assert designed(given, "auto", 5.0).cfg.plate.thickness_mm == 1.2


def test_what_plans_no_tiling_fills_the_plate_values_as_the_config_alone_can():
    from stencil_cad.config.job import filled
    from stencil_cad.plan.plan import refilled, unplanned

    cfg = parse_config({"size": {"width_mm": 600}, "bed": "prusa_mk4"}, source="test")
    alone = unplanned(cfg)
    assert alone.plate.label is not None and alone.plate.outline.margin_mm == 4.0
    assert alone.plate.thickness_mm == filled(cfg)[0].plate.thickness_mm
    assert unplanned(alone) == alone
    plan, _ = planned(cfg, (600.0, 400.0), 1200 * 800)
    again = refilled(plan, cfg)
    assert again.cfg.plate.thickness_mm == plan.cfg.plate.thickness_mm and again.fills == plan.fills
    assert again.cfg.plate.label is None  # refilled keeps the label as the config has it
