"""Tests of the soft layer decomposition (issue 3)."""

from __future__ import annotations

import io
import logging

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as hst
from pydantic import ValidationError
from scipy.optimize import linear_sum_assignment, lsq_linear

from stencil_cad.config.decompose import MAX_LAYERS, DecomposeConfig, colour_to_rgb
from stencil_cad.decompose import decompose, energy, energy_of
from stencil_cad.decompose import solver as solver_mod
from stencil_cad.exchange.layers_npz import layers_from_npz, layers_to_npz
from stencil_cad.model import Picture, coat_contrast, composite

# Ground truth of the synthetic test. The colours lie on the faces of the RGB
# cube, as saturated paints do: with colours strictly inside the cube the
# paper's energy is lower for a slightly larger colour hull than the truth (its
# sparsity term prefers covering bare primer with some paint), so the truth
# would not be the minimiser the solver is asked to find.
PRIMER = np.array([1.0, 1.0, 1.0])
PAINTS = np.array([[1.0, 0.8, 0.0], [0.8, 0.0, 0.1], [0.0, 0.2, 0.6]])


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def synthetic_layers(h: int = 64, w: int = 64) -> np.ndarray:
    """Three smooth opacity maps with plateaus of 0 and 1 (every colour shows pure somewhere)."""
    yy, xx = np.mgrid[0:h, 0:w] / np.array([h - 1, w - 1])[:, None, None]
    a1 = _smoothstep((0.45 - xx) / 0.2)  # green on the left
    a2 = _smoothstep((0.3 - np.hypot(xx - 0.7, yy - 0.3)) / 0.15)  # red disc top right
    a3 = _smoothstep((yy - 0.7) / 0.2) * _smoothstep((xx - 0.3) / 0.2)  # blue band bottom right
    return np.stack([a1, a2, a3])


def rmse255(a: np.ndarray, b: np.ndarray) -> float:
    return float(np.sqrt(np.mean((a - b) ** 2)) * 255.0)


def reference_energy(target, primer, colours, alphas, wd, ws, wp):
    """Straight numpy transcription of the paper's energy (independent of the kernels)."""
    x = composite(primer, colours, alphas)
    data = np.sum((x - target) ** 2)
    smooth = 0.0
    h, w = alphas.shape[1:]
    for a in alphas:
        p = np.pad(a, 1, constant_values=np.nan)
        for di in (-1, 0, 1):
            for dj in (-1, 0, 1):
                if di == 0 and dj == 0:
                    continue
                nb = p[1 + di : 1 + di + h, 1 + dj : 1 + dj + w]
                d = a - nb
                smooth += np.nansum(d * d)
    sparse = np.sum((1.0 - alphas.sum(axis=0)) ** 2)
    return wd * data + ws * smooth + wp * sparse, (data, smooth, sparse)


@pytest.fixture(scope="module")
def synthetic():
    alphas = synthetic_layers()
    img = composite(PRIMER, PAINTS, alphas)
    return img, alphas


def test_energy_terms_match_numpy_reference():
    rng = np.random.default_rng(3)
    target = rng.random((9, 7, 3))
    primer = rng.random(3)
    colours = rng.random((3, 3))
    alphas = rng.random((3, 9, 7))
    got = energy.energy_terms(target, primer, colours, alphas)
    _, want = reference_energy(target, primer, colours, alphas, 1, 1, 1)
    np.testing.assert_allclose(got, want, rtol=1e-12)
    np.testing.assert_allclose(
        energy.composite_nb(primer, colours, alphas), composite(primer, colours, alphas), atol=1e-14
    )


def test_layer_qp_is_solved_to_optimality():
    """The projected SOR reaches the optimum of one layer's box-constrained QP.

    Oracle: the QP is a bounded linear least-squares problem (data rows, one
    row per ordered 8-neighbour pair, one sparsity row per pixel), solved by
    scipy's BVLS; its affine form X = P + a D comes from compositing with the
    layer's opacity at 0 and at 1.
    """
    rng = np.random.default_rng(5)
    h, w, n_layers, layer = 7, 6, 3, 1
    gd, gs, gp = 1.0, 0.05, 0.02
    target = rng.random((h, w, 3))
    primer = np.array([0.9, 0.9, 0.8])
    colours = rng.random((n_layers, 3))
    alphas = rng.random((n_layers, h, w))
    trans = np.empty((n_layers, h, w))
    above = np.empty((n_layers, h, w, 3))
    energy.suffix_products(colours, alphas, trans, above)
    below = composite(primer, colours[:layer], alphas[:layer])
    total = alphas.sum(axis=0)
    a = alphas[layer].copy()
    energy.solve_layer(
        target, below, trans[layer], above[layer], colours[layer], a, total, gd, gs, gp, 1.6, 1e-13, 100000
    )

    lo, hi = alphas.copy(), alphas.copy()
    lo[layer], hi[layer] = 0.0, 1.0
    p0 = composite(primer, colours, lo)
    d = composite(primer, colours, hi) - p0
    n = h * w
    rows, rhs = [], []
    for c in range(3):
        rows.append(np.sqrt(gd) * np.diag(d[..., c].ravel()))
        rhs.append(np.sqrt(gd) * (target[..., c] - p0[..., c]).ravel())
    idx = np.arange(n).reshape(h, w)
    for i in range(h):
        for j in range(w):
            for di in (-1, 0, 1):
                for dj in (-1, 0, 1):
                    ii, jj = i + di, j + dj
                    if (di or dj) and 0 <= ii < h and 0 <= jj < w:
                        r = np.zeros(n)
                        r[idx[i, j]], r[idx[ii, jj]] = np.sqrt(gs), -np.sqrt(gs)
                        rows.append(r[None, :])
                        rhs.append(np.zeros(1))
    rows.append(np.sqrt(gp) * np.eye(n))
    rhs.append(np.sqrt(gp) * (1.0 - (total - alphas[layer])).ravel())
    ref = lsq_linear(np.vstack(rows), np.concatenate(rhs), bounds=(0, 1), method="bvls", tol=1e-15)
    np.testing.assert_allclose(a.ravel(), ref.x, atol=1e-7)
    assert (ref.x <= 1e-12).any() or (ref.x >= 1 - 1e-12).any()  # the box is active


def test_colour_step_matches_bounded_least_squares():
    rng = np.random.default_rng(7)
    h, w, n_layers = 12, 10, 3
    target = rng.random((h, w, 3))
    alphas = rng.random((n_layers, h, w))
    st = solver_mod.State(
        target, np.full(3, 0.5), np.full((n_layers, 3), 0.5), alphas, np.ones(n_layers + 1, bool)
    )
    solver_mod.colour_step(st)
    # Independent oracle: build W explicitly and solve per channel.
    weights = np.empty((h * w, n_layers + 1))
    t = np.ones((h, w))
    for layer in range(n_layers - 1, -1, -1):
        weights[:, layer + 1] = (alphas[layer] * t).ravel()
        t = t * (1.0 - alphas[layer])
    weights[:, 0] = t.ravel()
    for ch in range(3):
        ref = lsq_linear(weights, target[..., ch].ravel(), bounds=(0, 1), method="bvls", tol=1e-14)
        got = np.concatenate([[st.primer[ch]], st.colours[:, ch]])
        np.testing.assert_allclose(got, ref.x, atol=1e-6)


def test_synthetic_is_reproduced(synthetic):
    img, _ = synthetic
    cfg = DecomposeConfig(layers=3)
    layers = decompose(Picture(rgb=img, mm_per_px=0.5), cfg, np.random.default_rng(0))
    assert layers.alphas.shape == (3, 64, 64)
    assert rmse255(layers.composite(), img) < 1.0
    assert layers.info["rmse"] < 1.0
    found = np.vstack([layers.primer, layers.colours])
    truth = np.vstack([PRIMER, PAINTS])
    cost = np.abs(found[:, None, :] - truth[None, :, :]).max(axis=2)
    rows, cols = linear_sum_assignment(cost)
    assert cost[rows, cols].max() * 255.0 <= 2.0


def test_energy_never_increases(synthetic):
    img, _ = synthetic
    # Start far from the answer (light-to-dark, no pyramid) so there are many iterations to check.
    cfg = DecomposeConfig(
        layers=3, coarse_to_fine=False, tolerance=1e-6, max_iterations=40, order="light_to_dark"
    )
    layers = decompose(Picture(rgb=img, mm_per_px=0.5), cfg, np.random.default_rng(1))
    trace = np.array(layers.energy_trace)
    assert trace.size >= 10
    assert np.all(np.diff(trace) <= 1e-12 * trace[:-1])
    # The trace is the energy of the paper, and ends at the returned layers' energy.
    e = energy_of(layers, img, cfg)
    want, _ = reference_energy(
        img, layers.primer, layers.colours, layers.alphas, 1.0, cfg.weights.smooth, cfg.weights.sparse
    )
    assert e["total"] == pytest.approx(want, rel=1e-9)
    assert trace[-1] == pytest.approx(want, rel=1e-9)


def test_energy_never_increases_without_extrapolation(synthetic):
    img, _ = synthetic
    st = solver_mod.State(
        np.ascontiguousarray(img),
        PRIMER * 0.9,
        np.clip(PAINTS + 0.1, 0, 1),
        np.full((3, 64, 64), 0.3),
        np.ones(4, bool),
    )
    s = solver_mod.SolverSettings(1.0, 1e-3, 3e-4, 0.0, 20, 1e-4, 100)
    solver_mod.iterate(st, s, 20, 0.0, extrapolate=False)
    assert np.all(np.diff(st.trace) <= 1e-12 * np.array(st.trace[:-1]))


def test_layer_count_limits():
    with pytest.raises(ValidationError, match="layers"):
        DecomposeConfig(layers=0)
    with pytest.raises(ValidationError, match="layers"):
        DecomposeConfig(layers=MAX_LAYERS + 1)
    DecomposeConfig(layers=MAX_LAYERS)


def test_config_colours_and_cross_checks():
    cfg = DecomposeConfig(palette=["#FF0000", [0, 128, 255], "00ff00"], primer=[255, 255, 255])
    assert cfg.palette == ("#ff0000", "#0080ff", "#00ff00")
    assert cfg.primer == "#ffffff"
    assert cfg.palette_rgb()[1] == pytest.approx((0.0, 128 / 255, 1.0))
    assert colour_to_rgb("#000000") == (0.0, 0.0, 0.0)
    with pytest.raises(ValidationError, match="hex"):
        DecomposeConfig(palette=["#12345"])
    with pytest.raises(ValidationError, match="0-255"):
        DecomposeConfig(palette=[[0, 0, 300]])
    with pytest.raises(ValidationError, match="given"):
        DecomposeConfig(order="given")
    with pytest.raises(ValidationError):
        DecomposeConfig(unknown_key=1)


def test_few_distinct_colours_gives_fewer_layers_and_a_warning(caplog):
    img = np.zeros((20, 30, 3))
    img[:, :15] = [1.0, 1.0, 1.0]
    img[:, 15:] = [0.8, 0.1, 0.1]
    with caplog.at_level(logging.WARNING):
        layers = decompose(
            Picture(rgb=img, mm_per_px=1.0), DecomposeConfig(layers=4), np.random.default_rng(0)
        )
    assert layers.count == 1
    assert layers.info["warnings"] and "distinct" in layers.info["warnings"][0]
    assert "distinct" in caplog.text
    assert np.isfinite(layers.alphas).all() and np.isfinite(layers.colours).all()
    assert layers.info["rmse"] < 0.5


@pytest.mark.parametrize("value", [0.3, 1.0])
def test_flat_image_is_an_error_naming_the_primer(value):
    img = np.full((16, 16, 3), value)
    hexc = "#{0:02x}{0:02x}{0:02x}".format(round(value * 255))
    with pytest.raises(ValueError, match=f"one flat colour: prime the surface with {hexc}"):
        decompose(Picture(rgb=img, mm_per_px=1.0), DecomposeConfig(layers=3), np.random.default_rng(0))
    # Grey input: a flat grey is one flat colour as any other; as one layer of darkness a flat
    # white is no ink either, and a flat mid-grey is a valid 50 % layer.
    for flat in (np.ones((8, 8, 3)), np.full((8, 8, 3), 0.5)):
        with pytest.raises(ValueError, match="one flat colour"):
            decompose(
                Picture(rgb=flat, mm_per_px=1.0, grey=True), DecomposeConfig(), np.random.default_rng(0)
            )
    darkness = DecomposeConfig(opacity_source="grey")
    with pytest.raises(ValueError, match="one flat colour"):
        decompose(
            Picture(rgb=np.ones((8, 8, 3)), mm_per_px=1.0, grey=True), darkness, np.random.default_rng(0)
        )
    grey = decompose(
        Picture(rgb=np.full((8, 8, 3), 0.5), mm_per_px=1.0, grey=True), darkness, np.random.default_rng(0)
    )
    np.testing.assert_allclose(grey.alphas, 0.5)


def test_no_useful_can_is_an_error_that_is_not_about_flatness():
    img = np.zeros((12, 12, 3))
    img[..., 2] = np.linspace(0.3, 1.0, 12)[None, :]  # blues; a yellow can only lightens towards yellow
    cfg = DecomposeConfig(palette=["#ffff00"], primer="#000000")
    with pytest.raises(ValueError, match="no paint layer carries ink") as err:
        decompose(Picture(rgb=img, mm_per_px=1.0), cfg, np.random.default_rng(0))
    assert "flat" not in str(err.value)


def test_flat_image_on_a_fixed_other_primer_is_one_full_layer():
    img = np.zeros((16, 16, 3))
    img[...] = [0.1, 0.2, 0.7]
    layers = decompose(
        Picture(rgb=img, mm_per_px=1.0), DecomposeConfig(layers=3, primer="#ffffff"), np.random.default_rng(0)
    )
    assert layers.count == 1
    np.testing.assert_allclose(layers.colours[0], [0.1, 0.2, 0.7], atol=2 / 255)
    assert layers.alphas.min() > 0.95
    assert layers.info["rmse"] < 1.0


def _dE(a, b):
    from skimage.color import deltaE_ciede2000, rgb2lab

    a, b = (np.asarray(c, dtype=np.float64).reshape(1, 1, 3) for c in (a, b))
    return float(deltaE_ciede2000(rgb2lab(a), rgb2lab(b))[0, 0])


def _red_square_on_white(n: int = 240) -> np.ndarray:
    img = np.ones((n, n, 3))
    img[n // 4 : 3 * n // 4, n // 4 : 3 * n // 4] = [200 / 255, 0.0, 0.0]
    return img


def test_resampled_two_colour_image_gets_one_layer_from_the_source_count(tmp_path):
    from PIL import Image

    from stencil_cad.imaging import load_picture

    path = tmp_path / "red.png"
    Image.fromarray(np.rint(_red_square_on_white() * 255).astype(np.uint8)).save(path)
    pic = load_picture(path, 60.0, None, 2.0)  # 240 px -> 120 px: the edges blend
    assert pic.shape == (120, 120)
    assert pic.distinct_colours == 2
    assert len(np.unique(np.rint(pic.rgb * 255).reshape(-1, 3), axis=0)) > 4
    layers = decompose(pic, DecomposeConfig(layers=4), np.random.default_rng(0))
    assert layers.count == 1
    assert any("2 distinct" in w for w in layers.info["warnings"])
    assert _dE(layers.primer, [1, 1, 1]) < 1.0
    assert _dE(layers.colours[0], [200 / 255, 0, 0]) < 1.0
    assert layers.info["rmse"] < 1.0


def test_near_duplicate_paints_are_merged():
    from skimage.transform import resize

    # Without the source count the blended edge colours pass the distinct-colour
    # check, and the solve returns twins of the red and a white on white.
    img = np.clip(resize(_red_square_on_white(), (120, 120, 3), order=1, anti_aliasing=True), 0, 1)
    layers = decompose(Picture(rgb=img, mm_per_px=1.0), DecomposeConfig(layers=4), np.random.default_rng(0))
    allc = np.vstack([layers.primer[None], layers.colours])
    for i in range(len(allc)):
        for j in range(i + 1, len(allc)):
            assert _dE(allc[i], allc[j]) >= 2.0
    assert np.all(layers.alphas.reshape(layers.count, -1).max(axis=1) >= 0.05)
    assert layers.count < 4 and any("dropped" in w for w in layers.info["warnings"])
    assert layers.info["rmse"] < 1.0
    assert layers.alphas.shape[0] == layers.colours.shape[0] == len(layers.info["order"]) - 1
    # min_delta_e 0 and min_opacity 0 switch the merging off.
    keep = DecomposeConfig(layers=4, min_delta_e=0.0, min_opacity=0.0)
    assert decompose(Picture(rgb=img, mm_per_px=1.0), keep, np.random.default_rng(0)).count == 4


@pytest.mark.parametrize("background", ["white", "red"])
def test_two_colours_one_layer_primes_the_larger_area(background):
    red, white = np.array([0.8, 0.0, 0.0]), np.array([1.0, 1.0, 1.0])
    bg, ink = (white, red) if background == "white" else (red, white)
    img = np.empty((96, 96, 3))
    img[...] = bg
    img[24:72, 24:72] = ink  # the ink covers 25 %
    layers = decompose(
        Picture(rgb=img, mm_per_px=1.0, distinct_colours=2),
        DecomposeConfig(layers=1),
        np.random.default_rng(0),
    )
    np.testing.assert_allclose(layers.primer, bg, atol=2 / 255)
    np.testing.assert_allclose(layers.colours[0], ink, atol=2 / 255)
    assert layers.alphas.mean() == pytest.approx(0.25, abs=0.02)


def test_fixed_palette_out_of_reach_still_solves():
    img = np.zeros((24, 24, 3))
    img[..., 2] = np.linspace(0.2, 1.0, 24)[None, :]  # blues
    # The yellow can sprays nothing here: by default its empty layer is dropped.
    cfg = DecomposeConfig(palette=["#ff0000", "#ffff00"], primer="#ffffff")
    layers = decompose(Picture(rgb=img, mm_per_px=1.0), cfg, np.random.default_rng(0))
    assert layers.count == 1 and any("#ffff00 never reaches" in w for w in layers.info["warnings"])
    np.testing.assert_allclose(layers.colours, [[1, 0, 0]])
    assert layers.info["order"] == [0]
    cfg = DecomposeConfig(palette=["#ff0000", "#ffff00"], primer="#ffffff", min_opacity=0.0)
    layers = decompose(Picture(rgb=img, mm_per_px=1.0), cfg, np.random.default_rng(0))
    assert layers.count == 2
    np.testing.assert_allclose(layers.colours, [[1, 0, 0], [1, 1, 0]])
    np.testing.assert_allclose(layers.primer, [1, 1, 1])
    assert np.isfinite(layers.alphas).all()
    assert layers.info["rmse"] > 50.0
    assert rmse255(layers.composite(), img) == pytest.approx(layers.info["rmse"], rel=1e-9)
    assert any("palette" in w for w in layers.info["warnings"])


def test_fixed_palette_reaches_a_mix_of_its_own_paints(synthetic):
    img, alphas = synthetic
    hexes = ["#{:02x}{:02x}{:02x}".format(*np.rint(c * 255).astype(int)) for c in PAINTS]
    primer = "#{:02x}{:02x}{:02x}".format(*np.rint(PRIMER * 255).astype(int))
    img8 = composite(np.array(colour_to_rgb(primer)), np.array([colour_to_rgb(h) for h in hexes]), alphas)
    cfg = DecomposeConfig(palette=hexes, primer=primer, order="given")
    layers = decompose(Picture(rgb=img8, mm_per_px=1.0), cfg, np.random.default_rng(0))
    assert layers.info["order"] == [0, 1, 2]
    assert layers.info["rmse"] < 1.0
    assert not layers.info["warnings"]


def test_fixed_palette_chooses_the_cans_that_fit(synthetic):
    img, _ = synthetic
    spare = ["#ffff00", "#00ffff", "#ff00ff"]
    hexes = ["#{:02x}{:02x}{:02x}".format(*np.rint(c * 255).astype(int)) for c in PAINTS]
    cfg = DecomposeConfig(layers=3, palette=spare[:2] + hexes + spare[2:])
    layers = decompose(Picture(rgb=img, mm_per_px=1.0), cfg, np.random.default_rng(0))
    assert sorted(layers.info["cans_chosen"]) == sorted(hexes)
    assert layers.info["rmse"] < 3.0


def test_fixed_palette_with_free_primer_moves_only_the_primer(synthetic):
    img, _ = synthetic
    hexes = ["#{:02x}{:02x}{:02x}".format(*np.rint(c * 255).astype(int)) for c in PAINTS]
    cfg = DecomposeConfig(palette=hexes)
    layers = decompose(Picture(rgb=img, mm_per_px=1.0), cfg, np.random.default_rng(0))
    np.testing.assert_allclose(
        np.sort(layers.colours, axis=0), np.sort(np.array([colour_to_rgb(h) for h in hexes]), axis=0)
    )
    assert np.abs(layers.primer - PRIMER).max() * 255 <= 3.0


def test_grey_picture_is_one_layer_of_darkness_when_asked():
    g = np.linspace(0.0, 1.0, 40)[None, :].repeat(10, axis=0)
    pic = Picture(rgb=np.repeat(g[..., None], 3, axis=2), mm_per_px=0.3, grey=True)
    layers = decompose(pic, DecomposeConfig(opacity_source="grey"), np.random.default_rng(0))
    assert layers.count == 1
    np.testing.assert_allclose(layers.alphas[0], 1.0 - g, atol=1e-12)
    np.testing.assert_allclose(layers.primer, [1, 1, 1])
    np.testing.assert_allclose(layers.colours, [[0, 0, 0]])
    assert layers.info["rmse"] < 1e-9
    assert layers.mm_per_px == 0.3


def test_a_grey_picture_is_decomposed_into_grey_paints_by_default():
    # One black layer sprays light tones as sparse dark dots; grey paints keep them fine.
    rng = np.random.default_rng(3)
    g = np.clip(np.linspace(0.05, 0.95, 60)[None, :].repeat(30, axis=0) + rng.normal(0, 0.02, (30, 60)), 0, 1)
    pic = Picture(rgb=np.repeat(g[..., None], 3, axis=2), mm_per_px=0.3, grey=True)
    layers = decompose(pic, DecomposeConfig(layers=3), np.random.default_rng(0))
    assert layers.count >= 2 and layers.info["source"] == "rgb"
    paints = np.vstack([layers.primer, layers.colours])
    assert np.ptp(paints, axis=1).max() < 0.05  # every paint and the primer neutral
    assert np.ptp(paints.mean(axis=1)) > 0.5  # from dark to light


def test_alpha_channel_as_opacity():
    rng = np.random.default_rng(2)
    a = rng.random((12, 14))
    rgb = np.zeros((12, 14, 3))
    rgb[..., 0] = 0.8
    pic = Picture(rgb=rgb, mm_per_px=1.0, alpha=a)
    layers = decompose(pic, DecomposeConfig(opacity_source="alpha"), np.random.default_rng(0))
    assert layers.count == 1
    np.testing.assert_allclose(layers.alphas[0], a)
    np.testing.assert_allclose(layers.colours[0], [0.8, 0, 0], atol=1e-12)
    # auto ignores the alpha of a colour image; alpha without an alpha channel is an error.
    rgb2 = rgb.copy()
    rgb2[:, :7] = 1.0
    pic2 = Picture(rgb=rgb2, mm_per_px=1.0, alpha=a)
    assert decompose(pic2, DecomposeConfig(layers=1), np.random.default_rng(0)).info["source"] == "rgb"
    with pytest.raises(ValueError, match="alpha"):
        decompose(
            Picture(rgb=rgb, mm_per_px=1.0), DecomposeConfig(opacity_source="alpha"), np.random.default_rng(0)
        )


def test_deterministic_for_a_seed(synthetic):
    img, _ = synthetic
    cfg = DecomposeConfig(layers=3, max_iterations=5)
    a = decompose(Picture(rgb=img, mm_per_px=1.0), cfg, np.random.default_rng(4))
    b = decompose(Picture(rgb=img, mm_per_px=1.0), cfg, np.random.default_rng(4))
    np.testing.assert_array_equal(a.alphas, b.alphas)
    np.testing.assert_array_equal(a.colours, b.colours)


def test_progress_callback_and_info(synthetic):
    img, _ = synthetic
    seen = []
    layers = decompose(
        Picture(rgb=img, mm_per_px=1.0),
        DecomposeConfig(layers=3),
        np.random.default_rng(0),
        progress=lambda i, e: seen.append((i, e)),
    )
    assert [i for i, _ in seen] == list(range(1, len(seen) + 1))
    assert len(seen) == layers.iterations == layers.info["iterations"]
    for key in ("rmse", "rmse_channels", "iterations", "warnings", "seconds"):
        assert key in layers.info
    assert layers.alphas.dtype == np.float64
    assert layers.alphas.min() >= 0.0 and layers.alphas.max() <= 1.0


def test_npz_round_trip(synthetic):
    img, _ = synthetic
    layers = decompose(
        Picture(rgb=img, mm_per_px=0.25),
        DecomposeConfig(layers=3, max_iterations=3),
        np.random.default_rng(0),
    )
    buf = io.BytesIO()
    np.savez_compressed(buf, **layers_to_npz(layers))
    buf.seek(0)
    with np.load(buf, allow_pickle=False) as z:
        back = layers_from_npz(z)
    np.testing.assert_allclose(back.alphas, layers.alphas, atol=1e-7)
    np.testing.assert_array_equal(back.colours, layers.colours)
    np.testing.assert_array_equal(back.primer, layers.primer)
    assert back.mm_per_px == 0.25
    assert back.energy_trace == layers.energy_trace
    assert back.iterations == layers.iterations
    assert back.info["rmse"] == layers.info["rmse"]
    with pytest.raises(ValueError, match="alphas"):
        layers_from_npz({"primer": np.zeros(3), "colours": np.zeros((2, 3))})


def test_swatch_card_shows_primer_then_paints():
    from stencil_cad.simulate.labelled import swatch_card

    chip = 40
    card = swatch_card("#ffffff", [{"hex": "#ff0000"}, {"hex": "#000080", "spray_time": 0.5}], chip_px=chip)
    assert card.dtype == np.uint8 and card.shape[2] == 3
    # Chips stand in one column, primer first, each bordered: find the rows of each colour.
    col = card[:, 10 + 34 + chip // 2]
    rows = {c: np.nonzero((col == np.array(c)).all(axis=1))[0] for c in ((255, 0, 0), (0, 0, 128))}
    assert rows[(255, 0, 0)].size > chip // 2 and rows[(0, 0, 128)].size > chip // 2
    assert rows[(255, 0, 0)].max() < rows[(0, 0, 128)].min()
    white_chip_top = rows[(255, 0, 0)].min() - (chip + 8)
    assert (col[white_chip_top + 4 : white_chip_top + chip - 4] == 255).all()
    assert (col[white_chip_top - 1 : white_chip_top + 2] < 80).any()  # the primer's border


@pytest.fixture(scope="module")
def astronaut256():
    from skimage import data
    from skimage.transform import resize

    return np.clip(resize(data.astronaut() / 255.0, (256, 256), anti_aliasing=True), 0, 1)


@pytest.mark.parametrize("n_layers, limit", [(4, 3.0), pytest.param(6, 1.5, marks=pytest.mark.slow)])
def test_astronaut_rmse(astronaut256, n_layers, limit):
    layers = decompose(
        Picture(rgb=astronaut256, mm_per_px=0.5), DecomposeConfig(layers=n_layers), np.random.default_rng(0)
    )
    assert layers.info["rmse"] <= limit
    assert max(layers.info["rmse_channels"]) <= limit  # every channel, not just on average


def test_astronaut_fixed_kmeans_palette_stalls(astronaut256):
    from stencil_cad.colour import kmeans
    from stencil_cad.decompose import palette

    centres, _ = kmeans(astronaut256.reshape(-1, 3), 5, np.random.default_rng(0))
    centres = centres[np.argsort(-palette.luminance(centres))]
    hexes = ["#{:02x}{:02x}{:02x}".format(*np.rint(c * 255).astype(int)) for c in centres]
    cfg = DecomposeConfig(layers=4, primer=hexes[0], palette=hexes[1:], order="given")
    fixed = decompose(Picture(rgb=astronaut256, mm_per_px=0.5), cfg, np.random.default_rng(0))
    assert fixed.info["rmse"] > 6.0


@settings(max_examples=15, deadline=None)
@given(
    seed=hst.integers(0, 10_000),
    h=hst.integers(1, 24),
    w=hst.integers(1, 24),
    n_layers=hst.integers(1, 5),
    fixed=hst.booleans(),
    order=hst.sampled_from(["auto", "light_to_dark"]),
    levels=hst.integers(1, 6),
)
def test_any_small_image_gives_valid_layers(seed, h, w, n_layers, fixed, order, levels):
    rng = np.random.default_rng(seed)
    # Posterised noise: between 1 and `levels`**3 distinct colours.
    img = np.floor(rng.random((h, w, 3)) * levels) / max(levels - 1, 1)
    kwargs = {"layers": n_layers, "order": order, "max_iterations": 8}
    if fixed:
        kwargs["palette"] = [
            "#{:02x}{:02x}{:02x}".format(*rng.integers(0, 256, 3)) for _ in range(n_layers + 1)
        ]
    pic = Picture(rgb=np.clip(img, 0, 1), mm_per_px=1.0)
    try:
        layers = decompose(pic, DecomposeConfig(**kwargs), rng)
    except ValueError as exc:
        # Only an image without ink for any layer may be refused.
        assert "one flat colour" in str(exc)
        assert len(np.unique(img.reshape(-1, 3), axis=0)) <= 2 or fixed
        return
    assert 1 <= layers.count <= n_layers
    assert layers.alphas.shape == (layers.count, h, w)
    for arr in (layers.alphas, layers.colours, layers.primer):
        assert np.isfinite(arr).all()
        assert arr.min() >= 0.0 and arr.max() <= 1.0
    trace = np.array(layers.energy_trace)
    assert np.all(np.diff(trace) <= 1e-12 * np.abs(trace[:-1]) + 1e-15)
    assert layers.info["rmse"] == pytest.approx(rmse255(layers.composite(), img), rel=1e-9, abs=1e-9)


def test_redundant_layer_rules():
    from stencil_cad.decompose.decomposition import _redundant_layer

    cfg = DecomposeConfig()
    primer = np.array([1.0, 1.0, 1.0])
    alphas = np.zeros((2, 4, 4))
    alphas[0, :2] = 1.0
    alphas[1, 2:3] = 1.0  # less paint than layer 0
    twins = np.array([[200, 0, 0], [198, 0, 0]]) / 255.0  # Delta E00 about 0.4
    assert _redundant_layer(primer, twins, alphas, cfg)[0] == 1
    assert _redundant_layer(primer, twins, alphas[::-1].copy(), cfg)[0] == 0
    apart = np.array([[200, 0, 0], [0, 0, 200]]) / 255.0
    assert _redundant_layer(primer, apart, alphas, cfg) is None
    # A paint within 2 of the primer goes, whatever its opacity.
    near_primer = np.array([[200, 0, 0], [253, 253, 253]]) / 255.0
    assert _redundant_layer(primer, near_primer, np.ones((2, 4, 4)), cfg)[0] == 1
    # A layer never reaching min_opacity goes.
    faint = alphas.copy()
    faint[1] = 0.04
    idx, reason = _redundant_layer(primer, apart, faint, cfg)
    assert idx == 1 and "opacity" in reason
    # 0 switches both rules off.
    off = DecomposeConfig(min_delta_e=0.0, min_opacity=0.0)
    assert _redundant_layer(primer, near_primer, faint, off) is None


def test_source_colour_count_sees_a_transparent_edge(tmp_path):
    from PIL import Image

    from stencil_cad.imaging import load_picture

    # One RGB colour everywhere, but an alpha ramp: flattened onto white it is many colours.
    rgba = np.zeros((64, 64, 4), dtype=np.uint8)
    rgba[..., 0] = 200
    rgba[..., 3] = np.linspace(0, 255, 64).astype(np.uint8)[None, :]
    path = tmp_path / "ramp.png"
    Image.fromarray(rgba).save(path)
    pic = load_picture(path, 32.0, None, 2.0)
    assert pic.distinct_colours >= 64


def test_coat_contrast_is_the_squared_slope_of_the_composite():
    """|T_l (c_l - B_l-1)|^2 equals |d composite / d alpha_l|^2 (a finite difference), in both float types."""
    rng = np.random.default_rng(7)
    primer, colours, alphas = rng.random(3), rng.random((3, 3)), rng.random((3, 5, 6))
    w = coat_contrast(primer, colours, alphas)
    assert w.shape == alphas.shape and w.dtype == np.float64
    for layer in range(3):
        step = np.zeros_like(alphas)
        step[layer] = 1e-6
        slope = (composite(primer, colours, alphas + step) - composite(primer, colours, alphas)) / 1e-6
        np.testing.assert_allclose(w[layer], (slope**2).sum(axis=-1), rtol=1e-4, atol=1e-8)
    w32 = coat_contrast(primer, colours, alphas.astype(np.float32))
    assert w32.dtype == np.float32
    np.testing.assert_allclose(w32, w, rtol=1e-4, atol=1e-6)
    # The top layer sees no transmittance loss; a layer under an opaque coat moves nothing.
    alphas[2] = 1.0
    assert np.all(coat_contrast(primer, colours, alphas)[:2] == 0.0)
