"""Hole refinement against the spray model: exact gradient, rules held, error lowered."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stencil_cad.config.spray import SprayConfig
from stencil_cad.model import DotSet
from stencil_cad.simulate import scielab, spray_opacity
from stencil_cad.simulate.spray import hole_kernels
from stencil_cad.stipple import refine, refine_kernels
from stencil_cad.stipple.refine import RefineSettings, refine_dots
from stencil_cad.stipple.rules import DesignRules, check_rules, enforce_rules

CFG = SprayConfig(model="paper", nozzle_height=7.0)
PRIMER = np.array([1.0, 1.0, 1.0])
INK = np.array([[0.1, 0.1, 0.2]])


def _kernels(cfg=CFG):
    return lambda r, a: hole_kernels(r, cfg, a)


def test_transmittance_matches_the_simulator():
    rng = np.random.default_rng(3)
    xy = rng.uniform(3, 27, (40, 2))
    r = rng.uniform(0.5, 1.0, 40)
    pitch, shape = 0.25, (120, 120)
    layer = refine._Layer(x=xy[:, 0], y=xy[:, 1], r=r, rules=None, spray_time=0.8, rmax=1.0)
    rows, cols, sig, peak, _, _, exp_mode = refine._kernels_px(layer, _kernels(), pitch, shape[0])
    t = refine_kernels._transmittance(np.ones(shape), rows, cols, sig, peak, exp_mode)
    exact = spray_opacity(xy, r, shape, pitch, CFG, exact=True, spray_time=0.8)
    assert np.max(np.abs((1.0 - t) - exact)) < 2e-3


@pytest.mark.parametrize(("eye_mm", "view"), [(0.0, False), (0.4, False), (0.0, True)])
def test_gradient_is_exact(eye_mm, view):
    rng = np.random.default_rng(5)
    pitch, shape = 0.25, (64, 64)
    colours = np.array([[0.8, 0.2, 0.1], [0.1, 0.1, 0.3]])
    target = rng.uniform(0.2, 0.9, (*shape, 3))
    state = []
    for _ in range(2):
        xy = rng.uniform(3, 13, (12, 2))
        r = rng.uniform(0.5, 1.0, 12)
        state.append(refine._Layer(x=xy[:, 0], y=xy[:, 1], r=r, rules=None, spray_time=0.9, rmax=1.0))
    kern = _kernels()

    alphas = rng.uniform(0.0, 0.8, (2, *shape))
    # The viewer's filters at 0.25 m (a narrow lobe of 0.09 mm, wide ones of 1-2 mm) with a pixel term.
    filters = refine.ViewFilters(scielab.filters_mm(0.25), pixel_weight=0.5) if view else None

    def evaluate(dtype=np.float64):
        viewer = refine._Viewer(target.astype(dtype), pitch, filters) if view else None
        return refine._evaluate(
            state,
            kern,
            pitch,
            target.astype(dtype),
            alphas.astype(dtype),
            0.7,
            PRIMER,
            colours,
            eye_mm / pitch,
            viewer=viewer,
        )

    def energy():
        return evaluate().e

    grads = refine._hole_grads(state, kern, pitch, shape[0], evaluate().gt)
    # The stage's float32 images give the same gradient to float32's precision.
    grads32 = refine._hole_grads(state, kern, pitch, shape[0], evaluate(np.float32).gt)
    for g64, g32 in zip(grads, grads32, strict=True):
        assert np.allclose(g32, g64, rtol=1e-3, atol=1e-4 * np.abs(g64).max())
    eps = 1e-5
    for k, layer in enumerate(state):
        for i in (0, 5, 11):
            for j, arr in enumerate((layer.x, layer.y, layer.r)):
                arr[i] += eps
                ep = energy()
                arr[i] -= 2 * eps
                em = energy()
                arr[i] += eps
                fd = (ep - em) / (2 * eps)
                assert grads[k][i, j] == pytest.approx(fd, rel=2e-3, abs=1e-6)


@pytest.mark.parametrize(
    ("view", "lam", "windows"), [(False, 0.7, False), (True, 0.0, True), (False, 0.0, False)]
)
def test_one_layers_g_and_q_after_a_move_equal_the_whole_evaluations(view, lam, windows):
    """The add/remove moves' one-layer update gives every number the whole evaluation gives."""
    rng = np.random.default_rng(8)
    pitch, shape = 0.25, (64, 64)
    colours = np.array([[0.8, 0.2, 0.1], [0.1, 0.1, 0.3], [0.8, 0.2, 0.1]])
    target = rng.uniform(0.2, 0.9, (*shape, 3)).astype(np.float32)
    alphas = rng.uniform(0.0, 0.8, (3, *shape)).astype(np.float32)
    fixed = rng.uniform(0.5, 1.0, (3, *shape)).astype(np.float32) if windows else None
    state = []
    for _ in range(3):
        xy = rng.uniform(3, 13, (12, 2))
        state.append(
            refine._Layer(
                x=xy[:, 0], y=xy[:, 1], r=rng.uniform(0.5, 1.0, 12), rules=None, spray_time=0.9, rmax=1.0
            )
        )
    viewer = refine._Viewer(target, pitch, refine.ViewFilters(scielab.filters_mm(0.25))) if view else None
    args = (state, _kernels(), pitch, target, alphas, lam, PRIMER, colours, 0.4 / pitch)

    def whole():
        return refine._evaluate(*args, want_q=True, viewer=viewer, fixed_trans=fixed)

    trans = whole().trans.copy()
    state[1].x = state[1].x[:-3] + 0.3
    state[1].y, state[1].r = state[1].y[:-3], state[1].r[:-3]
    after = whole()
    for want in (0, 1, 2):
        t = trans.copy()
        g, q = refine._layer_g_and_q(*args, viewer, fixed, t, 1, want)
        assert np.array_equal(t, after.trans)
        assert np.array_equal(g, after.gq[0, want]) and np.array_equal(q, after.gq[1, want])


def _rules(w=30.0, h=30.0, keepouts=()):
    return DesignRules(
        hole_min_r_mm=0.5, web_mm=0.5, edge_margin_mm=2.0, width_mm=w, height_mm=h, keepouts=keepouts
    )


def _refine(xy, r, rules, target, iterations=12, every=4, view=None):
    ds = DotSet(xy_mm=xy, r_mm=r, report={})
    s = RefineSettings(
        iterations=iterations, max_radius_mm=1.0, add_remove_every=every, eye_sigma_mm=0.3, view=view
    )
    return refine_dots(target, 0.25, PRIMER, INK, [ds], [rules], _kernels(), [0.8], s)


def _ramp_case(seed):
    """A grey ramp and 150 floor-size holes that pass the rules."""
    rules = _rules()
    shape = (120, 120)
    ramp = np.linspace(1.0, 0.3, shape[1])[None, :, None] * np.ones((*shape, 3))
    rng = np.random.default_rng(seed)
    xy, r, _ = enforce_rules(rng.uniform(2.5, 27.5, (150, 2)), np.full(150, 0.5), rules)
    return rules, ramp, xy, r


def test_refinement_lowers_the_composite_error_on_a_ramp():
    rules, ramp, xy, r = _ramp_case(0)
    out, rep = _refine(xy, r, rules, ramp)
    assert rep["objective_end"] < 0.8 * rep["objective_start"]
    check_rules(out[0].xy_mm, out[0].r_mm, rules)
    assert out[0].report["refine_added"] + out[0].report["refine_removed"] > 0


def test_a_refinement_stopped_part_way_takes_the_whole_refinements_first_steps():
    # The plate-design trials rank walls on a refinement stopped part way: its steps must be the
    # whole refinement's (step sizes decaying over all of them), and a stop at the end changes nothing.
    from dataclasses import replace

    rules, ramp, xy, r = _ramp_case(1)
    ds = DotSet(xy_mm=xy, r_mm=r, report={})
    whole = RefineSettings(iterations=12, max_radius_mm=1.0, add_remove_every=4, eye_sigma_mm=0.3)

    def refined(s, seen=None):
        out, rep = refine_dots(ramp, 0.25, PRIMER, INK, [ds], [rules], _kernels(), [0.8], s, progress=seen)
        return out[0], rep

    full, _ = refined(whole)
    same, _ = refined(replace(whole, stop_after=12))
    assert np.array_equal(same.xy_mm, full.xy_mm) and np.array_equal(same.r_mm, full.r_mm)
    steps: list[tuple[int, int]] = []
    part, rep = refined(replace(whole, stop_after=5), lambda it, total: steps.append((it, total)))
    assert rep["iterations"] == 5 and steps == [(i, 5) for i in range(1, 6)]
    check_rules(part.xy_mm, part.r_mm, rules)
    # Not a refinement of 5 steps of its own: those take larger steps at the end.
    short, _ = refined(replace(whole, iterations=5))
    assert not np.array_equal(part.xy_mm, short.xy_mm) and not np.array_equal(part.xy_mm, full.xy_mm)


@pytest.mark.parametrize("cans", [1, 3])
def test_a_refinement_carried_on_from_a_pause_is_the_whole_refinement(cans):
    # The job's refinement carries on the plate-design trial's, stopped part way: the same holes,
    # figures and objective as refined in one go, under one can and under a prior's turns of cans.
    from dataclasses import replace

    rules, ramp, xy, r = _ramp_case(2)
    ds = DotSet(xy_mm=xy, r_mm=r, report={})
    whole = RefineSettings(iterations=12, max_radius_mm=1.0, add_remove_every=4, eye_sigma_mm=0.3)
    kern = [_kernels(CFG.model_copy(update={"nozzle_height": 7.0 + i})) for i in range(cans)]

    def refined(s, **kw):
        out, rep = refine_dots(ramp, 0.25, PRIMER, INK, [ds], [rules], kern, [0.8], s, **kw)
        return out[0], rep

    full, rep_full = refined(whole)
    kept: list = []
    part, _ = refined(replace(whole, stop_after=5), on_pause=kept.append)
    assert len(kept) == 1 and kept[0].step == 5
    steps: list[int] = []
    for _ in range(2):  # the pause is copied, not used up
        on, rep = refined(whole, resume=kept[0], progress=lambda it, total: steps.append(it))
        assert np.array_equal(on.xy_mm, full.xy_mm) and np.array_equal(on.r_mm, full.r_mm)
        assert on.report == full.report
        assert rep["objective_start"] == rep_full["objective_start"]
        assert rep["objective_end"] == rep_full["objective_end"]
    assert steps == [*range(6, 13)] * 2
    with pytest.raises(ValueError, match="another refinement"):
        refined(replace(whole, iterations=13), resume=kept[0])
    # No pause where the refinement runs to its end.
    refined(replace(whole, stop_after=12), on_pause=kept.append)
    assert len(kept) == 1


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 2**31 - 1),
    n=st.integers(0, 160),
    keepout=st.booleans(),
)
def test_refined_dots_always_pass_the_rules(seed, n, keepout):
    rng = np.random.default_rng(seed)
    keepouts = ((10.0, 10.0, 16.0, 14.0),) if keepout else ()
    rules = _rules(keepouts=keepouts)
    shape = (120, 120)
    # A random smooth density as target: a few Gaussian blobs of ink.
    yy, xx = np.mgrid[: shape[0], : shape[1]] * 0.25
    dark = np.zeros(shape)
    for _ in range(3):
        cx, cy, s = rng.uniform(0, 30), rng.uniform(0, 30), rng.uniform(2, 10)
        dark += rng.uniform(0.2, 1.0) * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * s * s))
    alpha = np.clip(dark, 0, 1)[..., None]
    target = PRIMER * (1 - alpha) + INK[0] * alpha
    xy, r, _ = enforce_rules(rng.uniform(0, 30, (n, 2)), rng.uniform(0.5, 1.0, n), rules)
    out, rep = _refine(xy, r, rules, target, iterations=8, every=3)
    check_rules(out[0].xy_mm, out[0].r_mm, rules)
    assert np.all(out[0].r_mm <= 1.0 + 1e-12)
    assert rep["objective_end"] <= rep["objective_start"] + 1e-9


def test_the_viewer_objective_lowers_its_error_and_keeps_the_rules():
    rules, ramp, xy, r = _ramp_case(1)
    view = refine.ViewFilters(scielab.filters_mm(1.0), pixel_weight=0.5)
    out, rep = _refine(xy, r, rules, ramp, view=view)
    assert rep["objective_end"] < 0.9 * rep["objective_start"]
    check_rules(out[0].xy_mm, out[0].r_mm, rules)


def test_refinement_for_a_prior_of_cans_takes_every_can_and_reports_the_first():
    from stencil_cad.simulate.cans import can_prior
    from stencil_cad.simulate.physical import SprayGeometry

    rules, ramp, xy, r = _ramp_case(2)
    geometry = SprayGeometry(standoff_mm=10.0, plate_thickness_mm=1.2)
    cans = [cfg for _, cfg in can_prior(SprayConfig())]
    assert len(cans) >= 3 and cans[0] == SprayConfig()
    calls = []

    def bound(cfg):
        def kernels(radii, a):
            calls.append(cfg)
            return hole_kernels(radii, cfg, a, geometry=geometry)

        return kernels

    ds = DotSet(xy_mm=xy, r_mm=r, report={})
    s = RefineSettings(iterations=10, max_radius_mm=1.0, add_remove_every=0, eye_sigma_mm=0.3)
    args = (ramp, 0.25, PRIMER, INK, [ds], [rules])
    one, rep1 = refine_dots(*args, [bound(cans[0])], [1.0], s)
    calls.clear()
    many, rep = refine_dots(*args, [bound(c) for c in cans], [1.0], s)
    # Every can's gradient is taken, and the report is the nominal can's, as with one can.
    assert {id(c) for c in calls} == {id(c) for c in cans}
    assert rep["objective_start"] == pytest.approx(rep1["objective_start"], rel=1e-9)
    check_rules(many[0].xy_mm, many[0].r_mm, rules)
    assert not np.array_equal(many[0].xy_mm, one[0].xy_mm)
    # A measured can collapses the prior to itself; the paper's model has none.
    measured = SprayConfig(can={"fit": {"residual": 0.01}})
    assert [c for _, c in can_prior(measured)] == [measured]
    assert len(can_prior(SprayConfig(model="paper"))) == 1


def test_each_layer_refines_under_its_own_kernels():
    from stencil_cad.simulate.physical import SprayGeometry

    rules, ramp, xy, r = _ramp_case(4)
    geometry = SprayGeometry(standoff_mm=10.0, plate_thickness_mm=1.2)
    nominal = SprayConfig()
    heavy = SprayConfig(can={"deposit_per_pass": 4.0, "spread_k": 0.06})
    seen: dict[int, set] = {0: set(), 1: set()}

    def bound(cfg, layer):
        def kernels(radii, a):
            seen[layer].add(id(cfg))
            return hole_kernels(radii, cfg, a, geometry=geometry)

        return kernels

    ds = [DotSet(xy_mm=xy, r_mm=r, report={}), DotSet(xy_mm=xy[::2], r_mm=r[::2], report={})]
    s = RefineSettings(iterations=6, max_radius_mm=1.0, add_remove_every=3, eye_sigma_mm=0.3)
    ink = np.array([[0.1, 0.1, 0.2], [0.8, 0.3, 0.1]])
    args = (ramp, 0.25, PRIMER, ink, ds, [rules, rules])
    same, _ = refine_dots(*args, [bound(nominal, 0)], [1.0, 1.0], s)
    pair, _ = refine_dots(*args, [(bound(nominal, 0), bound(nominal, 1))], [1.0, 1.0], s)
    # One entry per layer of the same can is the same refinement, byte for byte.
    for a, b in zip(same, pair, strict=True):
        assert np.array_equal(a.xy_mm, b.xy_mm) and np.array_equal(a.r_mm, b.r_mm)
    seen = {0: set(), 1: set()}
    mixed, _ = refine_dots(*args, [(bound(nominal, 0), bound(heavy, 1))], [1.0, 1.0], s)
    assert seen == {0: {id(nominal)}, 1: {id(heavy)}}
    assert not np.array_equal(mixed[1].r_mm, pair[1].r_mm)
    for out in mixed:
        check_rules(out.xy_mm, out.r_mm, rules)
    with pytest.raises(ValueError, match="one entry per layer"):
        refine_dots(*args, [(bound(nominal, 0),)], [1.0, 1.0], s)
