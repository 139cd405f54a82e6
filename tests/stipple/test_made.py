"""Holes as the process makes them: the drawn radii that compensate, within the rules."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from stencil_cad.config.stipple import StippleConfig
from stencil_cad.model import DotSet
from stencil_cad.stipple import rules
from stencil_cad.stipple.made import drawn_dots, drawn_radii, made_dots


def test_free_holes_grow_by_the_offset():
    xy = np.array([[0.0, 0.0], [10.0, 0.0]])
    r = np.array([0.5, 1.0])
    np.testing.assert_allclose(drawn_radii(xy, r, 0.03, 0.5), [0.53, 1.03])
    np.testing.assert_allclose(drawn_radii(xy, r, 0.0, 0.5), r)


def test_growth_keeps_the_web():
    # 0.04 mm of slack over the 0.5 mm web: each hole may grow by 0.02 only
    xy = np.array([[0.0, 0.0], [1.54, 0.0], [20.0, 0.0]])
    r = np.array([0.5, 0.5, 0.5])
    drawn = drawn_radii(xy, r, 0.05, 0.5)
    np.testing.assert_allclose(drawn, [0.52, 0.52, 0.55])
    assert np.linalg.norm(xy[0] - xy[1]) - drawn[0] - drawn[1] >= 0.5 - 1e-12


def test_a_widening_process_draws_smaller_never_under_the_floor():
    xy = np.array([[0.0, 0.0], [10.0, 0.0]])
    np.testing.assert_allclose(drawn_radii(xy, np.array([0.5, 1.0]), -0.1, 0.5), [0.5, 0.9])


def test_drawn_dots_keep_every_rule_and_made_dots_are_as_asked():
    rng = np.random.default_rng(3)
    cfg = StippleConfig(process="sla")
    size = (30.0, 20.0)
    xy = rng.uniform([0, 0], size, (400, 2))
    r = rng.uniform(0.5, 1.0, 400)
    design = cfg.design_rules(*size)
    fxy, fr, _ = rules.enforce_rules(xy, r, design)
    fixed = DotSet(fxy, fr)
    drawn = drawn_dots(fixed, cfg, size)
    offset = cfg.sizes.hole_offset_mm
    assert offset > 0
    # the plate as made keeps every rule (web, edge margin, floor)
    made = made_dots(fixed, cfg, size)
    rules.check_rules(made.xy_mm, made.r_mm, design)
    # the drawn plate is the made one with every hole grown by the offset where the edge allows
    rules.check_rules(drawn.xy_mm, drawn.r_mm, replace(design, web_mm=design.web_mm - 2 * offset))
    grown = drawn.r_mm - fixed.r_mm
    assert grown.min() >= 0 and grown.max() == pytest.approx(offset)
    np.testing.assert_allclose(made.r_mm, drawn.r_mm - offset)
    # away from the edges every hole is made as asked
    inner = np.all((fixed.xy_mm > 1.5) & (fixed.xy_mm < np.array(size) - 1.5), axis=1)
    assert inner.sum() > 30
    np.testing.assert_allclose(made.r_mm[inner], fixed.r_mm[inner])


def test_without_compensation_the_made_holes_are_smaller():
    cfg = StippleConfig(process="fdm", compensate=False)
    dots = DotSet(np.array([[5.0, 5.0]]), np.array([1.0]))
    assert drawn_dots(dots, cfg, (10.0, 10.0)) is dots
    assert made_dots(dots, cfg, (10.0, 10.0)).r_mm[0] == pytest.approx(1.0 - cfg.sizes.hole_offset_mm)


def test_laser_offset_is_zero_and_configurable():
    assert StippleConfig(process="laser").sizes.hole_offset_mm == 0.0
    assert StippleConfig(process="laser", hole_offset_mm=-0.1).sizes.hole_offset_mm == -0.1


def test_laser_kerf_comes_from_the_process_unless_given():
    from stencil_cad.config import io as cfg_io

    laser = cfg_io.parse_config({"stipple": {"process": "laser"}}, "job.yaml")
    assert laser.export.dxf_kerf_mm == pytest.approx(0.2) and laser.export.kerf_mm == pytest.approx(0.2)
    given = cfg_io.parse_config({"stipple": {"process": "laser"}, "export": {"dxf_kerf_mm": 0}}, "job.yaml")
    assert given.export.kerf_mm == 0.0
    assert cfg_io.parse_config({}, "defaults").export.kerf_mm == 0.0
