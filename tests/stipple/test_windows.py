"""The holes around a hybrid plate's windows: the refinement takes a window as fixed open area."""

import numpy as np

from stencil_cad.config.spray import SprayConfig
from stencil_cad.model import DotSet
from stencil_cad.simulate.spray import hole_kernels
from stencil_cad.stipple.refine import RefineSettings, refine_dots
from stencil_cad.stipple.rules import DesignRules, enforce_rules
from stencil_cad.stipple.windows import closed_to_holes, window_clearance, with_windows

CFG = SprayConfig(model="paper", nozzle_height=7.0)
PRIMER = np.array([1.0, 1.0, 1.0])
INK = np.array([[0.1, 0.1, 0.2]])
SQUARE = (np.array([[10.0, 10.0], [20.0, 10.0], [20.0, 20.0], [10.0, 20.0]]), ())


def _case(seed=0):
    rules = DesignRules(hole_min_r_mm=0.5, web_mm=0.5, edge_margin_mm=2.0, width_mm=30.0, height_mm=30.0)
    rng = np.random.default_rng(seed)
    xy, r, _ = enforce_rules(rng.uniform(2.5, 27.5, (150, 2)), np.full(150, 0.5), rules)
    return rules, DotSet(xy_mm=xy, r_mm=r)


def _refine(ds, rules, target, fixed):
    s = RefineSettings(iterations=6, max_radius_mm=1.0, add_remove_every=0, eye_sigma_mm=0.3)
    return refine_dots(
        target,
        0.25,
        PRIMER,
        INK,
        [ds],
        [rules],
        lambda r, a: hole_kernels(r, CFG, a),
        [0.8],
        s,
        fixed_trans=fixed,
    )


def test_a_window_that_covers_everything_leaves_the_holes_nothing_to_do():
    rules, ds = _case()
    target = np.full((120, 120, 3), 0.5)
    (out,), rep = _refine(ds, rules, target, np.zeros((1, 120, 120)))
    # The layer is fully open whatever the holes do: no gradient, so no move beyond the rules'
    # projection's own nudges, and the same objective.
    assert np.abs(out.xy_mm - ds.xy_mm).max() < 0.01
    assert rep["objective_end"] == rep["objective_start"]


def test_a_window_changes_where_the_holes_go():
    rules, ds = _case(1)
    target = np.full((120, 120, 3), 0.6)
    fixed = np.ones((1, 120, 120))
    fixed[:, :, :60] = 0.05  # the left half already sprayed through a window
    (free,), _ = _refine(ds, rules, target, None)
    (beside,), rep = _refine(ds, rules, target, fixed)
    assert not np.allclose(free.xy_mm, beside.xy_mm)
    assert rep["objective_end"] < rep["objective_start"]


def test_with_windows_drops_the_holes_too_close_and_records_the_windows():
    xy = np.array([[15.0, 15.0], [9.0, 15.0], [5.0, 5.0], [20.8, 15.0]])
    r = np.full(4, 0.5)
    ds = with_windows(DotSet(xy_mm=xy, r_mm=r), [SQUARE], 0.5)
    # Inside the window, its edge less than a web away (9.0 + 0.5 + 0.5 = 10.0 is exactly one), far.
    np.testing.assert_allclose(ds.xy_mm, [[9.0, 15.0], [5.0, 5.0]])
    assert ds.report["removed_by_windows"] == 2 and ds.report["windows"] == 1
    assert ds.polygons == (SQUARE,) and ds.hole_count == 3
    assert window_clearance(ds.xy_mm, ds.r_mm, ds.windows, 0.5).all()
    assert with_windows(DotSet(xy_mm=xy, r_mm=r), [], 0.5).windows == ()


def test_closed_to_holes_reaches_the_clearance():
    mask = np.zeros((40, 40), dtype=bool)
    mask[10:20, 10:20] = True
    closed = closed_to_holes(mask, 0.25, 1.0)
    assert closed[mask].all()
    assert closed[15, 23] and not closed[15, 25]  # 1.0 mm = 4 px from the window's edge
