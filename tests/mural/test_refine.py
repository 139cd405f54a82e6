"""A mural refined tile by tile: rules over the union, what the tiles gain, determinism."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad import mural, stipple
from stencil_cad.config import io as cfg_io
from stencil_cad.config.spray import SprayConfig
from stencil_cad.model import DotSet
from stencil_cad.mural import refine as mural_refine
from stencil_cad.stipple import refine
from stencil_cad.stipple.rules import check_rules


def _job(**data):
    return cfg_io.parse_config(data, source="test")


def _serial(fn, items, desc):
    return (fn(x) for x in items)


def _reversed_order(fn, items, desc):
    """Runs the tasks last to first (as workers finishing in any order would), yields in order."""
    items = list(items)
    done = {i: fn(items[i]) for i in reversed(range(len(items)))}
    return (done[i] for i in range(len(items)))


@pytest.fixture(scope="module")
def small_mural():
    """A 300 × 200 mm picture of two ramps on a 200 × 180 mm bed (2 × 2 tiles), one layer each."""
    cfg = _job(size={"width_mm": 300, "height_mm": 200}, bed=[200, 180], stipple={"tone": "linear"})
    grid = mural.plan_tiles(300, 200, cfg)
    assert len(grid.tiles) == 4
    g = 1.0
    yy, xx = np.mgrid[0:200, 0:300]
    alphas = [0.15 + 0.6 * xx / 300.0, 0.1 + 0.5 * yy / 200.0]
    colours = np.array([[0.8, 0.1, 0.1], [0.1, 0.1, 0.7]])
    primer = np.array([0.95, 0.95, 0.95])
    dotsets = [
        stipple.stipple_layer(a, g, cfg.stipple, np.random.default_rng(i)) for i, a in enumerate(alphas)
    ]
    # The target: what another stipple of the same opacities sprays, smoothed to its tone, so
    # that the holes can reach it.
    from scipy.ndimage import gaussian_filter

    from stencil_cad import simulate

    sp = cfg.spray.model_copy(update={"model": "paper"})
    other = [
        stipple.stipple_layer(a, g, cfg.stipple, np.random.default_rng(10 + i)) for i, a in enumerate(alphas)
    ]
    reach = [gaussian_filter(simulate.spray_opacity(d.xy_mm, d.r_mm, (200, 300), g, sp), 6.0) for d in other]
    target = np.broadcast_to(primer, (200, 300, 3)).copy()
    for a, c in zip(reach, colours, strict=True):
        target = target * (1 - a[..., None]) + c * a[..., None]
    alphas = reach
    rules = cfg.stipple.design_rules(300, 200)
    settings = refine.RefineSettings(
        iterations=8, max_radius_mm=2.0 * rules.hole_min_r_mm, add_remove_every=0
    )
    problem = mural_refine.Problem(
        target=target,
        alpha_targets=np.stack(alphas),
        mm_per_px=g,
        primer=primer,
        colours=colours,
        rules=[rules, rules],
        kernels=(mural_refine.HoleKernels(sp),),
        spray_times=[1.0, 1.0],
        settings=settings,
    )
    return cfg, grid, problem, dotsets


def _global(problem, dotsets, settings=None):
    """The one-piece refinement of these holes over the whole picture: ``(dotsets, report)``."""
    return refine.refine_dots(
        problem.target,
        problem.mm_per_px,
        problem.primer,
        problem.colours,
        dotsets,
        problem.rules,
        problem.kernels,
        problem.spray_times,
        problem.settings if settings is None else settings,
        alpha_targets=problem.alpha_targets,
    )


def _objective(problem, dotsets):
    """The refinement's objective (RMS composite error) of these holes over the whole picture."""
    zero = refine.RefineSettings(iterations=0, max_radius_mm=problem.settings.max_radius_mm)
    _, rep = _global(problem, dotsets, zero)
    return rep["objective_start"]


def test_phases_never_put_neighbours_together(small_mural):
    cfg = _job(size={"width_mm": 1000, "height_mm": 800}, bed="prusa_mk4")
    grid = mural.plan_tiles(1000, 800, cfg)
    ph = mural.phases(grid)
    assert sorted(k for p in ph for k in p) == list(range(len(grid.tiles)))
    for p in ph:
        for a in p:
            for b in p:
                ta, tb = grid.tiles[a], grid.tiles[b]
                if a != b:
                    assert max(abs(ta.row - tb.row), abs(ta.col - tb.col)) >= 2


def test_regions_cover_their_core_and_miss_the_cores_refined_beside_them():
    cfg = _job(size={"width_mm": 1000, "height_mm": 800}, bed="prusa_mk4")
    grid = mural.plan_tiles(1000, 800, cfg)
    halo = mural_refine.refine_halo_mm(cfg, 0.3)
    assert halo > 2 * mural.spray_halo_mm(cfg)
    shape = (int(800 / 0.7), int(1000 / 0.7))
    for p in mural.phases(grid):
        boxes = {k: mural.region_bounds(grid.tiles[k], grid, shape, 0.7, halo)[1] for k in p}
        for k, (ox, oy, right, top) in boxes.items():
            x0, y0, x1, y1 = grid.tiles[k].core
            assert ox <= x0 + 1e-9 and oy <= y0 + 1e-9 and right >= x1 - 1e-9 and top >= y1 - 1e-9
            for j in p:
                if j != k:
                    a0, b0, a1, b1 = grid.tiles[j].core
                    assert right <= a0 or ox >= a1 or top <= b0 or oy >= b1


def test_seam_pass_reverts_holes_that_meet_across_a_seam():
    xy0 = np.array([[10.0, 10.0], [14.0, 10.0], [30.0, 10.0]])
    r0 = np.array([1.0, 1.0, 1.0])
    xy = xy0.copy()
    xy[0, 0] += 1.5  # tile A's hole moved towards tile B's
    xy[2, 0] += 0.5  # moved, far from anything
    out, r, n = mural_refine.seam_pass(xy, r0, xy0, r0, web_mm=0.8)
    assert n == 1
    assert np.array_equal(out[0], xy0[0]) and np.array_equal(out[1], xy0[1])
    assert out[2, 0] == 30.5


def test_tiled_refinement_keeps_the_rules_and_gains_like_the_global_one(small_mural):
    cfg, grid, problem, dotsets = small_mural
    halo = mural_refine.refine_halo_mm(cfg, 0.3)
    tiled, report = mural_refine.refine_mural(problem, grid, dotsets, halo, _serial)
    for ds, rl in zip(tiled, problem.rules, strict=True):
        check_rules(ds.xy_mm, ds.r_mm, rl)
    assert [len(d) for d in tiled] == [len(d) for d in dotsets]
    assert report["tiles"] == 4
    glob, _ = _global(problem, dotsets)
    before = _objective(problem, dotsets)
    after_tiled = _objective(problem, tiled)
    after_global = _objective(problem, glob)
    assert after_global < before
    # The tiles gain at least 90 % of what the one-piece refinement gains.
    assert before - after_tiled >= 0.9 * (before - after_global), (before, after_tiled, after_global)


def test_tiled_refinement_is_the_same_whatever_order_the_tiles_finish(small_mural):
    cfg, grid, problem, dotsets = small_mural
    halo = mural_refine.refine_halo_mm(cfg, 0.3)
    a, _ = mural_refine.refine_mural(problem, grid, dotsets, halo, _serial)
    b, _ = mural_refine.refine_mural(problem, grid, dotsets, halo, _reversed_order)
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x.xy_mm, y.xy_mm) and np.array_equal(x.r_mm, y.r_mm)


def test_tasks_hold_only_their_region():
    cfg = _job(size={"width_mm": 300, "height_mm": 200}, bed=[200, 180])
    grid = mural.plan_tiles(300, 200, cfg)
    rules = cfg.stipple.design_rules(300, 200)
    problem = mural_refine.Problem(
        target=np.zeros((200, 300, 3)),
        alpha_targets=None,
        mm_per_px=1.0,
        primer=np.ones(3),
        colours=np.zeros((1, 3)),
        rules=[rules],
        kernels=(mural_refine.HoleKernels(SprayConfig(model="paper")),),
        spray_times=[1.0],
        settings=refine.RefineSettings(iterations=1, max_radius_mm=1.0),
    )
    ds = DotSet(xy_mm=np.array([[20.0, 20.0], [280.0, 180.0]]), r_mm=np.array([1.0, 1.0]))
    tasks = mural_refine.tile_tasks(problem, grid, [0, 1, 2, 3], [(ds.xy_mm, ds.r_mm)], 20.0)
    assert sum(int(t.core[0].sum()) for t in tasks) == 2  # each hole is one tile's own
    for t in tasks:
        assert t.target.shape[0] < 200 and t.target.shape[1] < 300
        assert t.problem.target.size == 0
