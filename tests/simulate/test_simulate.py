"""Tests of the spray simulator, scores, previews and tone calibration against analytic oracles."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from pydantic import ValidationError

from stencil_cad import simulate as sim
from stencil_cad.config.spray import Calibrate, SprayConfig
from stencil_cad.frames import px_to_mm
from stencil_cad.model import DotSet, Layers, composite
from stencil_cad.simulate import tone as cal


def _analytic(xy, r, shape, s, a, h):
    """Brute-force oracle written independently of the library: the paper's formula per pixel."""
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    px = (cols + 0.5) * s
    py = (shape[0] - rows - 0.5) * s
    trans = np.ones(shape)
    for (x, y), ri in zip(xy, np.broadcast_to(r, (len(xy),)), strict=True):
        sig2 = ri * ri * (1 + h) / 4
        n = a * np.exp(-((px - x) ** 2 + (py - y) ** 2) / (2 * sig2))
        trans *= 1 - np.minimum(n, 1)
    return 1 - trans


def _dense_holes(rng, extent_mm, margin_mm, r_lo=0.5, r_hi=0.9, web=0.5):
    """Jittered hexagonal holes at the minimum web, reaching past the raster on every side."""
    d = 2 * r_hi + web
    xs, ys = np.meshgrid(
        np.arange(-margin_mm, extent_mm + margin_mm, d),
        np.arange(-margin_mm, extent_mm + margin_mm, d * math.sqrt(3) / 2),
    )
    xs = xs + (np.arange(xs.shape[0])[:, None] % 2) * d / 2
    xy = np.column_stack([xs.ravel(), ys.ravel()]) + rng.normal(0, 0.05, (xs.size, 2))
    return xy, rng.uniform(r_lo, r_hi, len(xy))


# --------------------------------------------------------------------------- model


def test_sigma_formula():
    assert sim.dot_sigma_mm(1.0, 3.0) == pytest.approx(1.0)
    assert sim.dot_sigma_mm(0.5, 0.0) == pytest.approx(0.25)


@pytest.mark.parametrize("exact", [True, False])
@pytest.mark.parametrize("a", [0.5, 2.0])
def test_single_hole_matches_formula(exact, a):
    cfg = SprayConfig(model="paper", spray_time=a, nozzle_height=7.0)
    xy = np.array([[3.13, 2.71]])
    got = sim.spray_opacity(xy, 0.6, (60, 70), 0.1, cfg, exact=exact)
    want = _analytic(xy, 0.6, (60, 70), 0.1, a, 7.0)
    assert got.shape == (60, 70)
    assert np.abs(got - want).max() <= (1e-12 if exact else 1e-3)
    if a > 1:
        assert got.max() == 1.0  # the clamp: transmittance exactly 0 at the centre


def test_two_holes_of_different_radii_multiply():
    cfg = SprayConfig(model="paper", spray_time=0.8, nozzle_height=2.0)
    xy = np.array([[2.0, 2.0], [3.0, 2.5]])
    r = np.array([0.5, 1.2])
    got = sim.spray_opacity(xy, r, (50, 50), 0.1, cfg, exact=True)
    want = _analytic(xy, r, (50, 50), 0.1, 0.8, 2.0)
    np.testing.assert_allclose(got, want, atol=1e-12)


@pytest.mark.parametrize("exact", [True, False])
def test_frame_peak_at_pixel_centre(exact):
    cfg = SprayConfig(model="paper", spray_time=0.5)
    shape = (40, 30)
    xy = px_to_mm(np.array([[7, 21]]), shape[0], 0.25)
    got = sim.spray_opacity(xy, 0.5, shape, 0.25, cfg, exact=exact)
    assert np.unravel_index(np.argmax(got), shape) == (7, 21)
    assert got[7, 21] == pytest.approx(0.5, abs=1e-6)


@pytest.mark.parametrize("a", [0.5, 1.0, 2.0])
@pytest.mark.parametrize("h", [2.0, 7.0, 15.0])
def test_fast_matches_exact(a, h):
    """Issue requirement: |fast - exact| <= 1e-3 for A in {0.5, 1, 2}, h in {2, 7, 15}."""
    rng = np.random.default_rng(int(a * 10 + h))
    cfg = SprayConfig(model="paper", spray_time=a, nozzle_height=h)
    xy, r = _dense_holes(rng, 10.0, 9.0)
    # Densely packed on the left (where tails pile up), sparse on the right (where they show).
    keep = (xy[:, 0] < 3.0) | (rng.uniform(size=len(xy)) < 0.04)
    xy, r = xy[keep], r[keep]
    fast = sim.spray_opacity(xy, r, (100, 100), 0.1, cfg)
    exact = sim.spray_opacity(xy, r, (100, 100), 0.1, cfg, exact=True)
    err = np.abs(fast - exact).max()
    assert err <= 1e-3
    # Saturated and pale pixels both occur, so the check is not vacuous.
    assert exact.min() < 0.5 and exact.max() > 0.9 * min(a, 1.0)


def test_fast_error_bound_holds_for_sparse_pale_layer():
    rng = np.random.default_rng(5)
    cfg = SprayConfig(model="paper", spray_time=2.0, nozzle_height=15.0, max_error=1e-3)
    xy = rng.uniform(-5, 15, (150, 2))
    fast = sim.spray_opacity(xy, 0.5, (100, 100), 0.1, cfg)
    exact = sim.spray_opacity(xy, 0.5, (100, 100), 0.1, cfg, exact=True)
    assert np.abs(fast - exact).max() <= 1e-3


@settings(max_examples=40, deadline=None)
@given(
    n=st.integers(0, 40),
    a=st.floats(0.05, 4.0),
    h=st.floats(0.0, 20.0),
    shape=st.tuples(st.integers(1, 40), st.integers(1, 40)),
    s=st.sampled_from([0.05, 0.1, 0.25]),
    seed=st.integers(0, 2**16),
)
def test_fast_matches_exact_on_random_inputs(n, a, h, shape, s, seed):
    """Holes anywhere (inside, on the border, far outside), any size: fast within max_error of exact."""
    rng = np.random.default_rng(seed)
    extent = np.array([shape[1], shape[0]]) * s
    xy = rng.uniform(-0.5, 1.5, (n, 2)) * extent
    r = rng.uniform(0.5, 2.0, n)
    cfg = SprayConfig(model="paper", spray_time=a, nozzle_height=h)
    fast = sim.spray_opacity(xy, r, shape, s, cfg)
    exact = sim.spray_opacity(xy, r, shape, s, cfg, exact=True)
    assert fast.shape == exact.shape == shape
    assert np.all(np.isfinite(fast)) and fast.min() >= 0.0 and fast.max() <= 1.0
    assert np.abs(fast - exact).max() <= cfg.max_error


def test_crop_equals_full_raster():
    rng = np.random.default_rng(2)
    cfg = SprayConfig(model="paper")
    xy, r = _dense_holes(rng, 8.0, 3.0)
    full = sim.spray_opacity(xy, r, (80, 80), 0.1, cfg)
    part = sim.spray_opacity(xy, r, (80, 80), 0.1, cfg, crop=(10, 50, 20, 70))
    np.testing.assert_allclose(part, full[10:50, 20:70], atol=1e-6)
    ex_full = sim.spray_opacity(xy, r, (80, 80), 0.1, cfg, exact=True)
    ex_part = sim.spray_opacity(xy, r, (80, 80), 0.1, cfg, exact=True, crop=(10, 50, 20, 70))
    np.testing.assert_allclose(ex_part, ex_full[10:50, 20:70], atol=1e-12)


def test_holes_far_outside_leave_raster_empty():
    cfg = SprayConfig(model="paper")
    xy = np.array([[-50.0, 5.0], [5.0, 80.0]])
    assert sim.spray_opacity(xy, 1.0, (20, 20), 0.5, cfg).max() == 0.0


@pytest.mark.parametrize("exact", [True, False])
def test_no_holes_gives_empty_layer(exact):
    out = sim.spray_opacity(
        np.zeros((0, 2)), np.zeros(0), (12, 9), 0.5, SprayConfig(model="paper"), exact=exact
    )
    assert out.shape == (12, 9) and not out.any()


# --------------------------------------------------------------------------- config and bad input


@pytest.mark.parametrize(
    "kwargs",
    [
        {"spray_time": 0.0},
        {"spray_time": -1.0},
        {"nozzle_height": -0.1},
        {"sweep_factors": (0.5, 0.0)},
        {"px_per_mm": 0},
    ],
)
def test_config_rejects_bad_values(kwargs):
    with pytest.raises(ValidationError):
        SprayConfig(**kwargs)


def test_config_rejects_unknown_key():
    with pytest.raises(ValidationError):
        SprayConfig(spraytime=1.0)


def test_bad_runtime_parameters_raise():
    with pytest.raises(ValueError, match="spray_time"):
        sim.spray_opacity(np.zeros((1, 2)), 1.0, (4, 4), 1.0, SprayConfig(model="paper"), spray_time=0.0)
    with pytest.raises(ValueError, match="radius"):
        sim.spray_opacity(np.zeros((1, 2)), 0.0, (4, 4), 1.0, SprayConfig(model="paper"))


# --------------------------------------------------------------------------- hard-stencil masks


def test_mask_interior_and_closed():
    cfg = SprayConfig(model="paper", spray_time=1.0, nozzle_height=7.0)
    mask = np.zeros((200, 200), bool)
    mask[20:180, 20:180] = True
    out = sim.spray_mask(mask, 0.1, cfg)
    assert out[100, 100] == pytest.approx(1 - math.exp(-4.0), abs=1e-6)
    assert not sim.spray_mask(np.zeros((10, 10), bool), 0.1, cfg).any()


def test_mask_disc_sprays_the_dot_models_paint():
    """A disc cut-out of the reference radius deposits the same paint (and spread) as one hole."""
    a, h, r, s = 0.01, 7.0, 1.0, 0.05
    cfg = SprayConfig(model="paper", spray_time=a, nozzle_height=h, mask_reference_radius_mm=r)
    shape = (400, 400)
    rows, cols = np.mgrid[0:400, 0:400]
    centre = (10.0, 10.0)
    xy = px_to_mm(np.column_stack([rows.ravel(), cols.ravel()]), 400, s).reshape(400, 400, 2)
    d2 = (xy[..., 0] - centre[0]) ** 2 + (xy[..., 1] - centre[1]) ** 2
    mask_out = sim.spray_mask(d2 <= r * r, s, cfg)
    dot_out = sim.spray_opacity(np.array([centre]), r, shape, s, cfg, exact=True)
    paint_mask = -np.log1p(-mask_out)
    paint_dot = -np.log1p(-dot_out)
    assert paint_mask.sum() == pytest.approx(paint_dot.sum(), rel=0.02)
    var_mask = (paint_mask * d2).sum() / paint_mask.sum()
    var_dot = (paint_dot * d2).sum() / paint_dot.sum()
    assert var_mask == pytest.approx(var_dot, rel=0.03)


def test_mask_without_spread_is_sharp():
    cfg = SprayConfig(model="paper", nozzle_height=0.0)
    mask = np.zeros((10, 10), bool)
    mask[3:6, 3:6] = True
    out = sim.spray_mask(mask, 0.5, cfg)
    assert not out[~mask].any() and np.allclose(out[mask], 1 - math.exp(-0.5))


# --------------------------------------------------------------------------- simulate


def _layers(shape=(40, 60), s=0.5):
    alphas = np.zeros((2, *shape))
    alphas[0, :, : shape[1] // 2] = 0.6
    return Layers(
        primer=np.array([1.0, 1.0, 1.0]),
        colours=np.array([[0.9, 0.1, 0.1], [0.1, 0.1, 0.8]]),
        alphas=alphas,
        mm_per_px=s,
    )


def test_simulate_composite_and_empty_layer():
    layers = _layers()
    rng = np.random.default_rng(0)
    dots = DotSet(xy_mm=rng.uniform(0, 15, (40, 2)), r_mm=np.full(40, 0.6))
    empty = DotSet(xy_mm=np.zeros((0, 2)), r_mm=np.zeros(0))
    cfg = SprayConfig(model="paper", px_per_mm=4.0)
    res = sim.simulate(layers, [dots, empty], cfg)
    assert res.alphas.shape == (2, 80, 120)
    assert res.mm_per_px == 0.25
    assert not res.alphas[1].any()
    assert res.layer_rmse[1] == 0.0
    np.testing.assert_allclose(res.composite, composite(layers.primer, layers.colours, res.alphas))
    direct = sim.spray_opacity(dots.xy_mm, dots.r_mm, (80, 120), 0.25, cfg)
    np.testing.assert_allclose(res.alphas[0], direct)
    with pytest.raises(ValueError, match="one DotSet per layer"):
        sim.simulate(layers, [dots], cfg)


def test_simulate_per_layer_spray_time():
    layers = _layers()
    xy = np.array([[5.0, 5.0]])
    cfg = SprayConfig(model="paper", px_per_mm=2.0)
    timed = DotSet(xy_mm=xy, r_mm=np.array([1.0]), spray_time=0.25)
    plain = DotSet(xy_mm=xy, r_mm=np.array([1.0]))
    res = sim.simulate(layers, [timed, plain], cfg)
    assert res.alphas[0].max() == pytest.approx(0.25 * res.alphas[1].max(), rel=1e-3)
    res2 = sim.simulate(layers, [plain, plain], cfg, spray_times=[0.25, 1.0], time_factor=2.0)
    np.testing.assert_allclose(res2.alphas[0], sim.spray_opacity(xy, 1.0, (40, 60), 0.5, cfg, spray_time=0.5))


def test_simulate_layer_rmse_is_against_blurred_target():
    layers = _layers()
    empty = DotSet(xy_mm=np.zeros((0, 2)), r_mm=np.zeros(0))
    res = sim.simulate(layers, [empty, empty], SprayConfig(model="paper"), grid_mm_per_px=0.5)
    target = sim.target_on_grid(layers.alphas[0], (40, 60), res.info["blur_sigma_mm"][0], 0.5)
    assert res.layer_rmse[0] == pytest.approx(math.sqrt(np.mean(target**2)))
    assert 0.3 < res.layer_rmse[0] < 0.6 * math.sqrt(0.5) + 0.05


# --------------------------------------------------------------------------- scores and previews


def test_score_identical_and_known_shift():
    rng = np.random.default_rng(1)
    img = rng.uniform(0, 1, (32, 32, 3))
    s = sim.score(img, img)
    assert s["de2000_mean"] == 0.0 and s["ssim"] == pytest.approx(1.0) and math.isinf(s["psnr"])
    grey = np.full((16, 16, 3), 0.5)
    lighter = np.full((16, 16, 3), 0.6)
    s = sim.score(grey, lighter)
    assert s["psnr"] == pytest.approx(20.0, abs=1e-9)  # MSE = 0.01
    from skimage.color import deltaE_ciede2000, rgb2lab

    de = deltaE_ciede2000(rgb2lab(grey[:1, :1]), rgb2lab(lighter[:1, :1]))[0, 0]
    assert s["de2000_mean"] == pytest.approx(de) and s["de2000_p95"] == pytest.approx(de)


def test_score_resamples_reference():
    ref = np.full((64, 64, 3), 0.3)
    s = sim.score(ref, np.full((32, 32, 3), 0.3))
    assert s["de2000_mean"] == pytest.approx(0.0, abs=1e-9)


def test_preview_panels_titles_and_colour_bar():
    from stencil_cad.simulate import labelled

    img = np.full((20, 30, 3), 0.4)
    err = np.zeros((20, 30))
    out = labelled.job_preview(img, img, img, err, sim.colour_map, 30.0, mm_per_px=1.0, panel_px=60)
    assert out.dtype == np.uint8 and out.ndim == 3
    # Four 60 px panels and the colour bar side by side; the error panel is the bottom of the ramp.
    assert out.shape[1] > 4 * 60
    black = np.round(sim.colour_map(np.zeros(1), 30.0)[0] * 255).astype(np.uint8)
    assert (np.abs(out.astype(int) - black.astype(int)).sum(axis=2) == 0).sum() >= 60 * 40
    # The bar holds the top of the ramp too.
    top = np.round(sim.colour_map(np.full(1, 30.0), 30.0)[0] * 255).astype(int)
    assert (np.abs(out.astype(int) - top).sum(axis=2) <= 3).any()


def test_sweep_panels():
    layers = _layers()
    dots = DotSet(xy_mm=np.array([[10.0, 10.0]]), r_mm=np.array([1.0]))
    empty = DotSet(xy_mm=np.zeros((0, 2)), r_mm=np.zeros(0))
    img = sim.sweep(layers, [dots, empty], SprayConfig(model="paper", px_per_mm=2.0))
    assert img.dtype == np.uint8 and img.shape == (40, 3 * 60 + 8, 3)
    # Longer spray, darker red at the hole's edge: panels differ in order.
    centre = [img[20, k * 64 + 24] for k in range(3)]
    assert int(centre[0][1]) > int(centre[1][1]) > int(centre[2][1])


def test_sweep_panel_at_factor_one_is_the_simulation_given(monkeypatch):
    from stencil_cad.simulate import previews

    layers = _layers()
    dots = DotSet(xy_mm=np.array([[10.0, 10.0], [20.0, 12.0]]), r_mm=np.array([1.0, 1.5]))
    cfg = SprayConfig(model="paper", px_per_mm=2.0)
    done = sim.simulate(layers, [dots, dots], cfg)
    want = previews.sweep_panels(layers, [dots, dots], cfg, factors=(0.5, 1.0, 2.0))
    factors = []
    real = previews.simulate

    def counted(*args, **kwargs):
        factors.append(kwargs["time_factor"])
        return real(*args, **kwargs)

    monkeypatch.setattr(previews, "simulate", counted)
    got = previews.sweep_panels(layers, [dots, dots], cfg, factors=(0.5, 1.0, 2.0), as_sprayed=done)
    assert factors == [0.5, 2.0]
    assert all(np.array_equal(a, b) for a, b in zip(got, want, strict=True))


# --------------------------------------------------------------------------- calibration


def test_tone_curve_sparse_limit():
    """At low tone the holes are isolated: mean opacity = holes per mm^2 x A 2 pi sigma^2 (A <= 1)."""
    cfg = SprayConfig(model="paper", spray_time=0.5, nozzle_height=7.0)
    curve = cal.tone_response(1.0, 0.8, cfg)
    t = curve.t[1]
    lam = cal.packing_density(1.0, 0.8) * t
    sigma = sim.dot_sigma_mm(1.0, 7.0)
    assert curve.mean[1] == pytest.approx(lam * 0.5 * 2 * math.pi * sigma**2, rel=0.05)
    assert curve.mean[0] == 0.0 and np.all(np.diff(curve.mean) >= 0)


def test_calibrated_density_inverts_response_and_saturates():
    cfg = SprayConfig(model="paper", spray_time=1.0)
    curve = cal.tone_response(0.5, 0.5, cfg)
    alpha = np.linspace(0, 1, 101)[None, :]
    d = cal.calibrated_density(alpha, 0.5, 0.5, 0.5, cfg)
    assert d.shape == alpha.shape and d.min() >= 0 and d.max() <= 1
    reach = alpha <= curve.max_opacity - 1e-3
    np.testing.assert_allclose(curve.opacity(d[reach]), alpha[reach], atol=2e-3)
    assert np.all(d[alpha > curve.max_opacity] == 1.0)


def test_choose_tone_beats_linear_prediction():
    cfg = SprayConfig(model="paper", spray_time=1.0)
    alpha = np.tile(np.linspace(0.0, 1.0, 64), (16, 1))
    dots = cal.choose_tone(alpha, 0.5, 1.0, 0.8, cfg, mode=Calibrate.dots)
    timed = cal.choose_tone(alpha, 0.5, 1.0, 0.8, cfg, mode=Calibrate.spray_time)
    none = cal.choose_tone(alpha, 0.5, 1.0, 0.8, cfg, mode=Calibrate.none)
    assert none.predicted_rmse == pytest.approx(none.predicted_rmse_linear)
    np.testing.assert_array_equal(none.density, alpha)
    assert dots.predicted_rmse < dots.predicted_rmse_linear
    assert timed.predicted_rmse <= dots.predicted_rmse
    assert dots.n_dots > 0


@pytest.mark.slow
def test_calibrated_stipple_sprays_closer_than_linear():
    """End to end with the real stippler on a ramp: the calibrated tone has the lower layer RMSE."""
    from stencil_cad.config.stipple import StippleConfig
    from stencil_cad.stipple import stipple_layer

    s = 0.5
    alpha = np.tile(np.linspace(0.0, 1.0, 160), (60, 1))
    layers = Layers(primer=np.ones(3), colours=np.zeros((1, 3)), alphas=alpha[None], mm_per_px=s)
    spray = SprayConfig(model="paper", calibrate=Calibrate.dots)
    stc = StippleConfig(process="sla", edge_margin_mm=0.0, tone="linear")
    lin = stipple_layer(alpha, s, stc, np.random.default_rng(0))
    choice = cal.choose_tone(
        alpha, s, stc.sizes.radius_mm, stc.sizes.web_mm, spray, spacing_factor=stc.auto_spacing_factor
    )
    calibrated = stipple_layer(
        alpha,
        s,
        stc.model_copy(update={"tone": "response"}),
        np.random.default_rng(0),
        density=choice.density,
    )
    r_lin = sim.simulate(layers, [lin], spray).layer_rmse[0]
    r_cal = sim.simulate(layers, [calibrated], spray).layer_rmse[0]
    assert r_cal < r_lin


@pytest.mark.parametrize("shape", [(300, 420), (9, 40)])
def test_scores_in_strips_equal_the_whole_pictures(shape, monkeypatch):
    # The pixel scores run a strip of rows at a time (bounded memory on murals); they must be
    # scikit-image's whole-picture CIEDE2000 and SSIM.
    from skimage.color import deltaE_ciede2000, rgb2lab
    from skimage.metrics import structural_similarity

    from stencil_cad.simulate import scores

    rng = np.random.default_rng(0)
    ref = rng.random((*shape, 3))
    sim = np.clip(ref + rng.normal(0, 0.1, ref.shape), 0, 1)
    monkeypatch.setattr(scores, "STRIP_PIXELS", 5_000)
    got = scores.score(ref, sim)
    de = deltaE_ciede2000(rgb2lab(ref), rgb2lab(sim))
    assert got["de2000_mean"] == pytest.approx(float(np.mean(de)), rel=1e-12)
    assert got["de2000_p95"] == pytest.approx(float(np.percentile(de, 95)), rel=1e-12)
    ssim = structural_similarity(ref, sim, data_range=1.0, channel_axis=2, win_size=7)
    assert got["ssim"] == pytest.approx(float(ssim), rel=1e-12)


def test_a_murals_plate_card_stays_within_its_longest_side():
    # A 4 m × 2.5 m picture at the default 4 px/mm would be 16,000 px wide.
    from stencil_cad.config import PlateConfig
    from stencil_cad.outline import label_region, plate_outline
    from stencil_cad.simulate import labelled

    size = (4000.0, 2500.0)
    ring = plate_outline(*size, PlateConfig().outline)
    box = label_region(*size, PlateConfig().outline)
    holes = np.array([[100.0, 100.0, 1.0], [3900.0, 2400.0, 0.5]])
    card = labelled.plate_card(ring, box, size, 1, 4, "#112233", circles_xy_r=holes)
    assert max(card.shape[:2]) <= labelled.CARD_MAX_SIDE_PX + 200  # the plate, plus header and margins
    small = labelled.plate_card(
        plate_outline(100.0, 80.0, PlateConfig().outline),
        label_region(100.0, 80.0, PlateConfig().outline),
        (100.0, 80.0),
        1,
        4,
        "#112233",
        circles_xy_r=holes[:0],
    )
    assert small.shape[1] >= 400  # small plates keep 4 px/mm


def test_choose_tone_weights_the_spray_time_choice():
    """Weight on the sparse half of a layer picks a lower spray time than weight on its dark half."""
    cfg = SprayConfig(model="paper", spray_time=1.0)
    alpha = np.where(np.arange(64)[None, :] < 32, 0.08, 1.0) * np.ones((16, 1))
    sparse = np.where(alpha < 0.5, 1.0, 1e-3)
    plain = cal.choose_tone(alpha, 0.5, 0.5, 0.5, cfg, mode=Calibrate.spray_time)
    uniform = cal.choose_tone(
        alpha, 0.5, 0.5, 0.5, cfg, mode=Calibrate.spray_time, weight=np.full_like(alpha, 3.0)
    )
    to_sparse = cal.choose_tone(alpha, 0.5, 0.5, 0.5, cfg, mode=Calibrate.spray_time, weight=sparse)
    to_dark = cal.choose_tone(alpha, 0.5, 0.5, 0.5, cfg, mode=Calibrate.spray_time, weight=1.0 - sparse)
    assert uniform.spray_time == plain.spray_time
    assert uniform.predicted_rmse == pytest.approx(plain.predicted_rmse)
    assert to_sparse.spray_time < plain.spray_time < to_dark.spray_time
    # The reported RMSE is the unweighted one, so the unweighted choice has the lowest.
    assert plain.predicted_rmse <= min(to_sparse.predicted_rmse, to_dark.predicted_rmse)
    with pytest.raises(ValueError, match="weight has"):
        cal.choose_tone(alpha, 0.5, 0.5, 0.5, cfg, mode=Calibrate.spray_time, weight=sparse[:, :10])


def test_windows_are_rasterised_once_per_windows_and_raster(monkeypatch):
    from stencil_cad import frames
    from stencil_cad.simulate import opacity
    from stencil_cad.simulate.kept import Kept

    calls = []
    real = frames.rasterise_polygons

    def counted(*args, **kwargs):
        calls.append(1)
        return real(*args, **kwargs)

    monkeypatch.setattr(frames, "rasterise_polygons", counted)
    monkeypatch.setattr(opacity, "_COVER_CACHE", Kept(8))
    square = np.array([[10.0, 10.0], [30.0, 10.0], [30.0, 25.0], [10.0, 25.0]])
    hole = np.array([[15.0, 15.0], [20.0, 15.0], [20.0, 20.0]])
    windows = [(square, (hole,))]
    first = opacity.windows_cover(windows, (60, 80), 0.5)
    again = opacity.windows_cover([(square.copy(), (hole.copy(),))], (60, 80), 0.5)
    assert len(calls) == 1 and np.array_equal(first, again)
    again[0, 0] = 1.0  # the caller's own array: the kept pixels are not touched
    assert np.array_equal(opacity.windows_cover(windows, (60, 80), 0.5), first)
    # Another window, raster or pixel size is rasterised afresh.
    moved = opacity.windows_cover([(square + 1.0, (hole + 1.0,))], (60, 80), 0.5)
    assert len(calls) == 2 and not np.array_equal(moved, first)
    assert opacity.windows_cover(windows, (60, 80), 0.25).sum() != first.sum()
    assert opacity.windows_cover(windows, (60, 80), 0.5, supersample=2).shape == first.shape
    assert len(calls) == 4
    # Each pixel's open fraction: the square's area less the triangle's, in pixels of 0.25 mm².
    assert first.sum() * 0.25 == pytest.approx(20.0 * 15.0 - 12.5, rel=0.02)


def test_a_simulation_without_its_tone_errors_sprays_the_same():
    rng = np.random.default_rng(3)
    alphas = rng.random((2, 40, 60))
    layers = Layers(
        primer=np.ones(3), colours=np.array([[0.8, 0.2, 0.1], [0.1, 0.2, 0.6]]), alphas=alphas, mm_per_px=0.5
    )
    dots = [DotSet(xy_mm=rng.random((30, 2)) * [30.0, 20.0], r_mm=np.full(30, 0.6)) for _ in range(2)]
    cfg = SprayConfig(model="paper", spray_time=0.8, nozzle_height=2.0)
    full = sim.simulate(layers, dots, cfg, 0.25)
    bare = sim.simulate(layers, dots, cfg, 0.25, errors=False)
    assert np.array_equal(full.alphas, bare.alphas) and np.array_equal(full.composite, bare.composite)
    assert len(full.layer_rmse) == 2 and bare.layer_rmse == () and bare.info["layer_tone_rmse"] == []


def test_the_scores_map_is_the_error_map_and_its_scores_the_scores():
    from stencil_cad.simulate import scores

    rng = np.random.default_rng(1)
    ref = rng.random((30, 40, 3))
    sim = np.clip(ref + rng.normal(0, 0.1, ref.shape), 0, 1)
    got, de = scores.score_and_map(ref, sim)
    assert got == scores.score(ref, sim)
    np.testing.assert_array_equal(de, scores.delta_e_map(ref, sim))


def test_unimodal_least_is_the_full_scan_on_unimodal_scores():
    """The spray-amount bisection picks what scoring every amount picks (the first least one)."""
    from stencil_cad.simulate.tone import _unimodal_least

    rng = np.random.default_rng(3)
    for n in (1, 2, 3, 7, 30):
        values = [0.25 * 2 ** (k / 2) for k in range(n)]
        for best in range(n):
            left = np.sort(rng.random(best))[::-1] + 1.0
            right = np.sort(rng.random(n - best - 1)) + 1.0
            scores = dict(zip(values, np.concatenate([left, [0.5], right]), strict=True))
            calls = []

            def score(v, scores=scores, calls=calls):
                calls.append(v)
                return float(scores[v])

            assert _unimodal_least(values, score) == values[best]
            assert len(set(calls)) <= 2 * max(n - 1, 1).bit_length()
    # Ties at the minimum: the first, like min() over the full scan.
    assert _unimodal_least([1.0, 2.0, 3.0, 4.0, 5.0], {1.0: 3, 2.0: 1, 3.0: 1, 4.0: 2, 5.0: 4}.get) == 2.0
