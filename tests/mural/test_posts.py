"""Posts under a mural's plates: where they stand, the holes they displace, the thickness they allow."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad import mural
from stencil_cad.config import io as cfg_io
from stencil_cad.config.job import filled
from stencil_cad.config.thickness import column_side_mm, sag_mm
from stencil_cad.model import DotSet
from stencil_cad.mural import posts


def job(**data):
    return cfg_io.parse_config(
        {"stipple": {"process": "fdm"}, "view": {"distance_m": 3}, **data}, source="test"
    )


def _hex_dots(x0, y0, x1, y1, pitch=3.0, r=1.0):
    xs = np.arange(x0, x1, pitch)
    ys = np.arange(y0, y1, pitch * np.sqrt(3) / 2)
    xy = np.array([(x + (pitch / 2 if j % 2 else 0.0), y) for j, y in enumerate(ys) for x in xs])
    return xy, np.full(len(xy), r)


def _mural_grid(cfg, w=400.0, h=200.0):
    return mural.TileGrid.cut(w, h, 2, 1, 10.0)


def test_one_plate_has_no_posts_and_a_mural_has():
    cfg = job(size={"width_mm": 150})
    assert mural.post_plan(cfg, mural.TileGrid.whole(150, 100)) is None
    plan = mural.post_plan(cfg, _mural_grid(cfg))
    assert plan is not None
    assert plan.height_mm == min(cfg.standoff.walls_mm)
    assert plan.keepout_mm == pytest.approx(posts.POST_RADIUS_MM + posts.shade_reach_mm(cfg))
    assert posts.POST_RADIUS_MM < plan.keepout_mm < posts.POST_RADIUS_MM + mural.spray_halo_mm(cfg)
    assert plan.pin_hole_mm > plan.pin_radius_mm


def test_sites_avoid_the_holes_when_there_is_room():
    cfg = job(size={"width_mm": 400})
    grid = _mural_grid(cfg)
    plan = mural.post_plan(cfg, grid)
    xy, r = _hex_dots(0, 0, 400, 200)
    # Clear a wide disc around every target point of tile A1, a little off the target.
    t = grid.tiles[0]
    targets = posts.targets(*t.size, plan.pitch_mm) + np.array(t.origin)
    assert len(targets) >= 1
    clear = np.ones(len(xy), dtype=bool)
    for p in targets + np.array([6.0, -4.0]):
        clear &= np.hypot(*(xy - p).T) > plan.keepout_mm + 8.0
    ds = DotSet(xy_mm=xy[clear], r_mm=r[clear])
    sites, dropped = mural.post_sites(ds, t.sheet, plan)
    assert dropped == []
    assert len(sites) == len(targets)
    for s in sites:
        assert np.min(np.hypot(*(ds.xy_mm - s).T) - ds.r_mm) >= plan.keepout_mm
        # Within the search window of a target.
        assert np.min(np.max(np.abs(targets - s), axis=1)) <= posts.SEARCH_FRACTION * plan.pitch_mm + 1e-9


def test_a_full_layer_loses_only_the_holes_under_its_posts_and_keeps_them_lost():
    cfg = job(size={"width_mm": 400})
    grid = _mural_grid(cfg)
    plan = mural.post_plan(cfg, grid)
    xy, r = _hex_dots(0, 0, 400, 200)
    full = DotSet(xy_mm=xy, r_mm=r, report={"n_final": len(r)})
    out, dropped = mural.clear_post_sites([full], grid, plan)
    assert dropped > 0
    cleared = out[0]
    assert len(cleared) == len(full) - dropped
    assert cleared.report["removed_post"] == dropped
    # Every hole that went was inside some site's disc; found again, every site is clear.
    for t in grid.tiles:
        sites, again = mural.post_sites(cleared, t.sheet, plan)
        assert again == []
        for s in sites:
            assert np.min(np.hypot(*(cleared.xy_mm - s).T) - cleared.r_mm) >= plan.keepout_mm
    first = sorted({i for t in grid.tiles for i in mural.post_sites(full, t.sheet, plan)[1]})
    assert len(first) == dropped
    assert np.array_equal(np.delete(xy, first, axis=0), cleared.xy_mm)
    # No plan: nothing changes.
    same, none = mural.clear_post_sites([full], grid, None)
    assert none == 0 and same[0] is full


def test_pin_holes_follow_the_holes():
    cfg = job(size={"width_mm": 400})
    plan = mural.post_plan(cfg, _mural_grid(cfg))
    holes = DotSet(xy_mm=np.array([[1.0, 2.0]]), r_mm=np.array([0.8]))
    out = mural.with_pin_holes(holes, np.array([[50.0, 60.0], [70.0, 80.0]]), plan)
    assert out.xy_mm.tolist() == [[1.0, 2.0], [50.0, 60.0], [70.0, 80.0]]
    assert out.r_mm.tolist() == [0.8, plan.pin_hole_mm, plan.pin_hole_mm]
    assert mural.with_pin_holes(holes, np.zeros((0, 2)), plan) is holes


def test_posts_let_a_mural_plate_be_two_thin_layers():
    cfg = job(size={"width_mm": 600}, bed="prusa_mk4", plate={"label": "engrave"})
    grid = mural.plan_tiles(600, 400, cfg)
    assert grid.tiled
    side = mural.sag_side_mm(grid, cfg)
    assert side == pytest.approx(column_side_mm(posts.post_span_mm()))
    fitted = filled(cfg, side)[0]
    assert fitted.plate.thickness_mm == pytest.approx(0.4)  # two 0.2 mm layers
    # The panel between posts stays within the sag limit (5 % of the 10 mm stand-off).
    assert sag_mm(side, 0.4, cfg.stipple.process.record.sheet) <= 0.05 * 10.0
    # Without posts the same tiles' plates would have to be much thicker.
    whole = max(max(mural.part_sizes(*t.size, cfg)["plate"]) for t in grid.tiles)
    assert filled(cfg, whole)[0].plate.thickness_mm >= 1.5


def test_a_site_keeps_clear_of_a_windows_edges_not_only_its_corners():
    cfg = job(size={"width_mm": 400})
    grid = _mural_grid(cfg)
    plan = mural.post_plan(cfg, grid)
    t = grid.tiles[0]
    target = posts.targets(*t.size, plan.pitch_mm)[0] + np.array(t.origin)
    # A long thin window whose corners are far from the target but whose edge runs through it.
    x, y = target
    ring = np.array([[x - 200, y - 1], [x + 200, y - 1], [x + 200, y + 1], [x - 200, y + 1]])
    ds = DotSet(xy_mm=np.zeros((0, 2)), r_mm=np.zeros(0), windows=((ring, ()),))
    sites, dropped = mural.post_sites(ds, t.sheet, plan)
    assert dropped == []
    for s in sites:
        assert np.min(np.hypot(*(posts._dense(ring) - s).T)) >= plan.keepout_mm - 0.5


def test_a_target_inside_a_big_window_gets_no_post():
    cfg = job(size={"width_mm": 400})
    grid = _mural_grid(cfg)
    plan = mural.post_plan(cfg, grid)
    t = grid.tiles[0]
    aims = posts.targets(*t.size, plan.pitch_mm) + np.array(t.origin)
    x, y = aims[0]
    big = np.array([[x - 120, y - 120], [x + 120, y - 120], [x + 120, y + 120], [x - 120, y + 120]])
    ds = DotSet(xy_mm=np.zeros((0, 2)), r_mm=np.zeros(0), windows=((big, ()),))
    sites, dropped = mural.post_sites(ds, t.sheet, plan)
    assert dropped == []
    assert not any(np.hypot(*(sites - aims[0]).T) < 0.5 * plan.pitch_mm) if len(sites) else True


def test_posts_closer_together_let_a_plate_without_engraving_be_one_layer():
    """Emboss or no label: the posts every 78 mm, and the plates one 0.3 mm layer within the sag limit."""
    bed = cfg_io.parse_config({"bed": "prusa_mk4"}).bed
    engraved = job(size={"width_mm": 600})
    embossed = job(size={"width_mm": 600}, plate={"label": "emboss"})
    given = job(size={"width_mm": 600}, plate={"label": "emboss", "thickness_mm": 0.4})
    assert posts.post_pitch_mm(engraved) == posts.POST_PITCH_MM
    assert posts.post_pitch_mm(given) == posts.POST_PITCH_MM
    assert posts.post_pitch_mm(embossed) == posts.SINGLE_LAYER_POST_PITCH_MM < posts.POST_PITCH_MM
    grid = mural.plan_tiles(600, 400, embossed.model_copy(update={"bed": bed}))
    side = mural.sag_side_mm(grid, embossed)
    assert side == pytest.approx(column_side_mm(posts.post_span_mm(posts.SINGLE_LAYER_POST_PITCH_MM)))
    assert filled(embossed, side)[0].plate.thickness_mm == pytest.approx(0.3)
    assert sag_mm(side, 0.3, embossed.stipple.process.record.sheet) <= 0.05 * 10.0
    # At the engraved plates' 90 mm the single layer would sag past the limit.
    wide = column_side_mm(posts.post_span_mm(posts.POST_PITCH_MM))
    assert sag_mm(wide, 0.3, embossed.stipple.process.record.sheet) > 0.05 * 10.0
    engraved_grid = mural.plan_tiles(600, 400, engraved.model_copy(update={"bed": bed}))
    assert filled(engraved, mural.sag_side_mm(engraved_grid, engraved))[
        0
    ].plate.thickness_mm == pytest.approx(0.4)
