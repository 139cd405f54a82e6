"""The plate margin left to the job: a plate's border, or only the ledge for a soft mural's tiles."""

from __future__ import annotations

import pytest

from stencil_cad import mural
from stencil_cad.config.io import parse_config
from stencil_cad.config.job import job_margin, parse_overrides, with_margin
from stencil_cad.config.outline import PLATE_MARGIN_MM, TILE_MARGIN_MM
from stencil_cad.outline import label_region


def job(**data):
    return parse_config(data, source="test")


def margin(cfg):
    """The margin the plan fills in for ``cfg`` (the config keeps null)."""
    return with_margin(cfg).plate.outline.margin_mm


def test_a_mural_wider_than_the_bed_takes_the_tiles_margin():
    cfg = job(size={"width_mm": 600}, bed="prusa_mk4")
    assert cfg.plate.outline.margin_mm is None  # the config keeps null: the plan fills it in
    assert margin(cfg) == job_margin(cfg) == TILE_MARGIN_MM
    assert margin(job(size={"width_mm": 150})) == PLATE_MARGIN_MM
    assert margin(job(size={"width_mm": 600})) == PLATE_MARGIN_MM  # no bed: one plate
    # Given, or a hard stencil's (its cut-outs leave no solid band for the label), it stays.
    given = job(size={"width_mm": 600}, bed="prusa_mk4", plate={"outline": {"margin_mm": 8}})
    assert margin(given) == 8
    assert with_margin(given) is given
    assert margin(job(size={"width_mm": 600}, bed="prusa_mk4", mode="hard")) == PLATE_MARGIN_MM
    # An outline the tiles' margin cannot take keeps the plate's.
    round_corners = job(size={"width_mm": 600}, bed="prusa_mk4", plate={"outline": {"corner_radius_mm": 6}})
    assert margin(round_corners) == PLATE_MARGIN_MM


def test_the_bed_given_later_fills_the_margin_again():
    cfg = job(size={"width_mm": 600})
    assert margin(cfg) == PLATE_MARGIN_MM
    assert margin(parse_overrides(cfg, bed="prusa_mk4")) == TILE_MARGIN_MM
    kept = job(size={"width_mm": 600}, plate={"outline": {"margin_mm": 10}})
    assert margin(parse_overrides(kept, bed="prusa_mk4")) == 10


def test_tiles_plates_shrink_by_the_margin_they_no_longer_need():
    tiles = with_margin(job(size={"width_mm": 600}, bed="prusa_mk4"))
    wide = job(size={"width_mm": 600}, bed="prusa_mk4", plate={"outline": {"margin_mm": PLATE_MARGIN_MM}})
    a, b = mural.plan_tiles(600, 400, tiles), mural.plan_tiles(600, 400, wide)
    assert a.tiles[0].part_size == b.tiles[0].part_size  # the same tiles, halo and wall opening
    pa = mural.part_sizes(*a.tiles[0].part_size, tiles)["plate"]
    pb = mural.part_sizes(*b.tiles[0].part_size, wide)["plate"]
    shrink = 2 * (PLATE_MARGIN_MM - TILE_MARGIN_MM)
    assert pa == pytest.approx((pb[0] - shrink, pb[1] - shrink))


def test_the_label_rises_into_the_solid_band_below_the_holes():
    outline = with_margin(job(size={"width_mm": 600}, bed="prusa_mk4")).plate.outline
    g = outline.label_gap_mm
    x0, y0, x1, y1 = label_region(160.0, 210.0, outline)
    assert (y0, y1) == pytest.approx((-TILE_MARGIN_MM + g, -g))
    x0, y0, x1, y1 = label_region(160.0, 210.0, outline, solid_mm=7.0)
    assert (x0, y0, x1, y1) == pytest.approx((g, -TILE_MARGIN_MM + g, 160.0 - g, 7.0 - g))


def test_a_soft_fdm_mural_raises_its_label_so_its_plates_may_be_one_layer():
    from stencil_cad.config.cad import LabelMode
    from stencil_cad.plan.plan import labelled

    def label(cfg):
        return labelled(cfg).plate.label

    mural_cfg = job(size={"width_mm": 600}, bed="prusa_mk4")
    assert mural_cfg.plate.label is None  # the config keeps null: the plan fills it in
    assert label(mural_cfg) is LabelMode.emboss
    assert label(job(size={"width_mm": 150})) is LabelMode.engrave  # one plate
    assert label(job(size={"width_mm": 600})) is LabelMode.engrave  # no bed: one plate
    assert label(job(size={"width_mm": 600}, bed="prusa_mk4", mode="hard")) is LabelMode.engrave
    sla = job(size={"width_mm": 600}, bed="prusa_mk4", stipple={"process": "sla"})
    assert label(sla) is LabelMode.engrave
    given = job(size={"width_mm": 600}, bed="prusa_mk4", plate={"label": "engrave"})
    assert labelled(given) is given
    # The bed given on the command line changes what the plan fills in; a label the config gives stays.
    assert parse_overrides(job(size={"width_mm": 600}), bed="prusa_mk4").plate.label is None
    assert label(parse_overrides(job(size={"width_mm": 600}), bed="prusa_mk4")) is LabelMode.emboss
    assert label(parse_overrides(given, bed="prusa_mk4")) is LabelMode.engrave


def test_a_null_label_on_a_plate_engraved_by_its_job_is_checked_against_the_thickness():
    from stencil_cad.errors import ConfigError

    with pytest.raises(ConfigError, match="label_depth_mm"):
        job(plate={"thickness_mm": 0.6, "label_depth_mm": 0.5})
    # A soft FDM mural's plates are embossed: the depth is a height, with no floor to leave.
    job(size={"width_mm": 600}, bed="prusa_mk4", plate={"thickness_mm": 0.6, "label_depth_mm": 0.5})
