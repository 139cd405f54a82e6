"""S-CIELAB: sanity checks of the viewing-distance score."""

import numpy as np
import pytest

from stencil_cad.simulate.scielab import (
    samples_per_degree,
    scielab,
    scielab_filter,
    scielab_map,
    smallest_sigma_mm,
    view_scores,
)


def _checkerboard(n: int, period: int) -> np.ndarray:
    y, x = np.mgrid[:n, :n]
    c = ((x // period + y // period) % 2).astype(np.float64)
    return np.repeat(c[..., None], 3, axis=2)


def _mid_grey() -> float:
    # sRGB value of half the white's linear light: what a fine black/white checkerboard blends to.
    return 1.055 * 0.5 ** (1 / 2.4) - 0.055


def test_identical_images_score_zero():
    rng = np.random.default_rng(0)
    img = rng.random((64, 80, 3))
    assert scielab(img, img, 0.25, 1.0) == pytest.approx(0.0, abs=1e-9)


def test_flat_field_is_preserved():
    img = np.full((50, 60, 3), [0.2, 0.5, 0.7])
    from skimage.color import rgb2xyz

    out = scielab_filter(img, 0.25, 1.0)
    assert np.allclose(out, rgb2xyz(img), atol=1e-9)


def test_fine_checkerboard_vanishes_with_distance_coarse_does_not():
    fine = _checkerboard(160, 1)  # 40 x 40 mm: 4 x 4 coarse squares, the same verdicts as 240 px
    coarse = _checkerboard(160, 40)
    grey = np.full_like(fine, _mid_grey())
    near_fine = scielab(fine, grey, 0.25, 0.25)
    far_fine = scielab(fine, grey, 0.25, 4.0)
    far_coarse = scielab(coarse, grey, 0.25, 4.0)
    assert near_fine > 3.0  # 0.25 mm squares are visible from 25 cm
    assert far_fine < 0.05  # and gone from 4 m
    assert far_coarse > 10.0  # 10 mm squares are still seen from 4 m
    # Monotone in distance.
    scores = [scielab(fine, grey, 0.25, d) for d in (0.25, 0.5, 1.0)]
    assert scores[0] > scores[1] > scores[2]


def test_mm_aware_same_angle_same_score():
    # Twice the pixel pitch seen from twice the distance is the same picture on the retina.
    rng = np.random.default_rng(1)
    a = rng.random((96, 96, 3))
    b = np.clip(a + rng.normal(0, 0.1, a.shape), 0, 1)
    assert scielab(a, b, 0.25, 1.0) == pytest.approx(scielab(a, b, 0.5, 2.0), rel=1e-6)


def test_upsamples_when_grid_is_coarse():
    img = np.zeros((20, 30, 3))
    # 2 mm pixels from 1 m: the narrowest kernel (sigma ≈ 0.37 mm) is far below a pixel.
    assert scielab_filter(img, 2.0, 1.0).shape[0] > 20
    assert scielab_map(img, img, 0.25, 1.0).shape == (20, 30)


def test_helpers():
    assert samples_per_degree(0.25, 1.0) == pytest.approx(69.8, abs=0.1)
    assert smallest_sigma_mm(2.0) == pytest.approx(1.745 / 2.3548, rel=1e-3)
    s = view_scores(np.zeros((8, 8, 3)), np.zeros((8, 8, 3)), 0.25, 1.5)
    assert s == {"view_distance_m": 1.5, "scielab": 0.0, "scielab_2x": 0.0}
    with pytest.raises(ValueError):
        samples_per_degree(0.0, 1.0)
    with pytest.raises(ValueError):
        scielab_map(np.zeros((4, 4, 3)), np.zeros((4, 5, 3)), 0.25, 1.0)


def test_smaller_holes_blend_from_nearer():
    from stencil_cad.config.spray import SprayConfig
    from stencil_cad.simulate.visibility import blend_distance_m

    black, white = np.zeros(3), np.ones(3)
    fdm = blend_distance_m(1.0, 0.8, SprayConfig(model="paper", nozzle_height=7.0), 1.0, black, white)
    sla = blend_distance_m(0.5, 0.5, SprayConfig(model="paper", nozzle_height=7.0), 1.0, black, white)
    assert sla is not None and fdm is not None
    assert 0.5 < sla < fdm < 16.0


def _photo_pair(n: int = 240):
    from skimage import data
    from skimage.transform import resize

    ref = resize(data.astronaut() / 255.0, (n, n + 40), anti_aliasing=True)
    rng = np.random.default_rng(3)
    return ref, np.clip(ref + rng.normal(0, 0.08, ref.shape) + 0.03, 0, 1)


@pytest.mark.parametrize("mm_per_px, distance_m", [(0.71, 1.0), (0.71, 2.0), (0.25, 1.0)])
def test_blocks_give_the_whole_pictures_score(mm_per_px, distance_m):
    # Many small blocks (each with its margin) against one block holding the whole picture.
    ref, test = _photo_pair(150)
    whole = scielab(ref, test, mm_per_px, distance_m, block_pixels=10**9)
    blocks = scielab(ref, test, mm_per_px, distance_m, block_pixels=100_000)
    assert blocks == pytest.approx(whole, rel=1e-12)
    m_whole = scielab_map(ref, test, mm_per_px, distance_m, block_pixels=10**9)
    m_blocks = scielab_map(ref, test, mm_per_px, distance_m, block_pixels=100_000)
    np.testing.assert_allclose(m_blocks, m_whole, rtol=0, atol=1e-9)


@pytest.mark.parametrize("n, mm_per_px", [(126, 0.71), (127, 0.71), (127, 0.25)])
def test_wide_gaussians_on_the_averaged_copy_match_an_exact_filter(n, mm_per_px, monkeypatch):
    # At 0.71 mm/px from 1 m the luminance 7° Gaussian is ~146 px wide: it goes through the
    # block-averaged copy (cells of 9 px; 127 and 167 are not whole multiples of the cell, so
    # the picture's edge falls inside a cell). An exact filter applies it to the whole picture.
    import stencil_cad.simulate.scielab as sc

    ref, test = _photo_pair(n)
    fast = scielab(ref, test, mm_per_px, 1.0)
    monkeypatch.setattr(sc, "DIRECT_SIGMA_PX", 1e9)
    exact = scielab(ref, test, mm_per_px, 1.0, block_pixels=10**9)
    assert fast == pytest.approx(exact, abs=6e-4)
    assert fast != exact  # the fast path did run


def test_a_wider_gaussian_on_cells_of_its_own_width_scores_as_on_the_narrower_ones_cells(monkeypatch):
    # With DIRECT_SIGMA_PX at 6 px, at 0.25 mm/px from 1 m the luminance 0.225° and 7° Gaussians
    # (about 6.7 and 207 px) both go through averaged copies: the narrower on cells of 3 px, the
    # wider (within the picture's 560 px) on cells of its own, at most a sixteenth of the 320 px side.
    # Against both on the narrower one's cells (CELLS_PER_SIDE too large for any cell to grow).
    from skimage import data
    from skimage.transform import resize

    import stencil_cad.simulate.scielab as sc

    monkeypatch.setattr(sc, "DIRECT_SIGMA_PX", 6.0)
    ref = resize(data.astronaut() / 255.0, (320, 560), anti_aliasing=True)
    test = np.clip(ref + np.random.default_rng(3).normal(0, 0.08, ref.shape) + 0.03, 0, 1)
    plan = sc._Plan(ref.shape[:2], 0.25, 1.0, sc.BLOCK_PIXELS)
    assert [f for _, f, _ in sc._wide_maps(test, plan)[0]] == [3, 20]
    own = scielab(ref, test, 0.25, 1.0)
    monkeypatch.setattr(sc, "CELLS_PER_SIDE", 10**9)
    assert [f for _, f, _ in sc._wide_maps(test, plan)[0]] == [3]
    narrow = scielab(ref, test, 0.25, 1.0)
    assert own == pytest.approx(narrow, abs=5e-4)
    assert own != narrow  # the wider cells did run


@pytest.mark.parametrize(
    "shape, k, sigma",
    [
        ((7, 5), 3, 2.0),
        ((40, 33), 3, 18.4),
        ((13, 60), 2, 30.0),
        ((5, 5), 8, 9.0),
        ((24, 24), 4, 0.7),
        ((1, 4), 3, 9.0),
        ((5, 7), 1, 2.0),
    ],
)
def test_phase_filter_equals_filtering_the_upsampled_picture(shape, k, sigma):
    # The phase filters on the input grid give what scipy gives on the picture upsampled first,
    # borders included, and kernels longer than the picture (mirrored several times) too.
    from scipy.ndimage import gaussian_filter

    from stencil_cad.simulate.scielab import _upsampled_gaussian

    x = np.random.default_rng(7).random(shape)
    up = np.repeat(np.repeat(x, k, axis=0), k, axis=1)
    want = gaussian_filter(up, sigma, mode="reflect", truncate=4.0)
    np.testing.assert_allclose(_upsampled_gaussian(x, sigma, k), want, rtol=0, atol=1e-13)


def test_bilinear_on_a_grid_equals_map_coordinates():
    from scipy.ndimage import map_coordinates

    from stencil_cad.simulate.scielab import _bilinear

    rng = np.random.default_rng(8)
    for hs, ws in [(1, 1), (1, 7), (9, 13), (50, 40)]:
        small = rng.random((hs, ws))
        ys, xs = np.linspace(-2, hs + 1, 37), np.linspace(-1.5, ws + 2, 29)
        yy, xx = np.meshgrid(ys, xs, indexing="ij")
        want = map_coordinates(small, [yy, xx], order=1, mode="nearest")
        np.testing.assert_allclose(_bilinear(small, ys, xs), want, rtol=0, atol=1e-13)


def test_compiled_ciede2000_equals_scikit_image():
    from skimage.color import deltaE_ciede2000, xyz2lab

    from stencil_cad.simulate.ciede import delta_e_xyz

    rng = np.random.default_rng(9)
    white = np.array([0.95047, 1.0, 1.08883])
    a = rng.random((60, 70, 3)) * white
    b = np.clip(a + 0.05 * rng.standard_normal(a.shape), 0.0, 1.2)
    b[0, :10] = a[0, :10]  # identical pixels
    a[1, :5] = b[1, :5] = 0.0  # black: zero chroma on both sides
    a[2, :5] = white  # white against noise
    a[3] = a[3, :, 1:2] * white  # greys (chroma 0 on one side only)
    a[4, :, :] = rng.random((70, 3)) * 1e-3  # the linear part of the Lab curve
    want = deltaE_ciede2000(xyz2lab(a), xyz2lab(b))
    got = delta_e_xyz(a, b)
    # A grey's chroma is round-off (1e-15), so its hue angle is too: both implementations turn
    # it into hue terms in their own order of operations, and on some CPUs (seen on one CI
    # machine) the row of greys differs by up to 2.2e-6 ΔE. Everything else within 1e-9.
    np.testing.assert_allclose(np.delete(got, 3, axis=0), np.delete(want, 3, axis=0), rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[3], want[3], rtol=0, atol=1e-5)
    assert np.all(got[0, :10] == 0.0)
    with pytest.raises(ValueError, match="same shape"):
        delta_e_xyz(a, b[:, :5])


def test_the_references_wide_maps_are_kept_for_the_next_score_of_the_same_reference():
    from stencil_cad.simulate import scielab as s

    rng = np.random.default_rng(4)
    ref = rng.random((300, 400, 3))
    test = np.clip(ref + rng.normal(0, 0.05, ref.shape), 0, 1)
    s._WIDE_CACHE.clear()
    first = s.scielab(ref, test, 0.5, 3.0)
    assert len(s._WIDE_CACHE) == 1
    assert s.scielab(ref, test, 0.5, 3.0) == first and len(s._WIDE_CACHE) == 1
    # Other pixels, or another distance, are another reference: scored afresh, as without the cache.
    changed = ref.copy()
    changed[10:20, 10:20] = 0.0
    s._WIDE_CACHE.clear()
    fresh = s.scielab(changed, test, 0.5, 3.0)
    s._WIDE_CACHE.clear()
    s.scielab(ref, test, 0.5, 3.0)
    assert s.scielab(changed, test, 0.5, 3.0) == fresh != first
    for d in (4.0, 5.0, 6.0, 7.0):
        s.scielab(ref, test, 0.5, d)
    assert len(s._WIDE_CACHE) == s._WIDE_CACHE.size


def test_cell_means_without_the_mirrored_picture_are_numpys_to_the_bit():
    from stencil_cad.simulate import cells

    rng = np.random.default_rng(5)
    cases = [
        (1600, 2400, 78, 2574),
        (1600, 2400, 8, 304),
        (37, 53, 3, 201),
        (64, 64, 9, 36),
        (300, 450, 150, 1800),
    ]
    cases += [(int(h), int(w), int(min(f, h, w)), int(p)) for h, w, f, p in rng.integers(5, 300, (40, 4))]
    for h, w, f, pad in cases:
        pad = f * -(-pad // f)
        x = rng.normal(size=(h, w))
        padded = np.pad(x, ((pad, pad + (-h) % f), (pad, pad + (-w) % f)), mode="symmetric")
        want = padded.reshape(padded.shape[0] // f, f, padded.shape[1] // f, f).mean(axis=(1, 3))
        got = cells.cell_means(
            x, cells.mirrored(h, pad, pad + (-h) % f), cells.mirrored(w, pad, pad + (-w) % f), f
        )
        assert got.shape == want.shape and np.array_equal(got.view(np.int64), want.view(np.int64)), (
            h,
            w,
            f,
            pad,
        )


def test_the_references_filtered_blocks_are_kept_and_score_as_before():
    from stencil_cad.simulate import scielab as s

    rng = np.random.default_rng(6)
    ref = rng.random((700, 900, 3))
    tests = [np.clip(ref + rng.normal(0, sd, ref.shape), 0, 1) for sd in (0.05, 0.1)]
    s._REF_BLOCKS.clear()
    fresh = []
    for t in tests:
        fresh.append(s.scielab(ref, t, 0.5, 3.0, block_pixels=400_000))
        s._REF_BLOCKS.clear()
    kept = [s.scielab(ref, t, 0.5, 3.0, block_pixels=400_000) for t in tests]
    assert kept == fresh and len(s._REF_BLOCKS) > 0
    # A small picture's blocks (a patch scored at many distances) are not kept.
    s._REF_BLOCKS.clear()
    s.scielab(ref[:100, :100], tests[0][:100, :100], 0.5, 3.0)
    assert len(s._REF_BLOCKS) == 0


@pytest.mark.parametrize(
    ("shape", "sigma"),
    [((362, 362), 276.7), ((101, 97), 1207.6), ((7, 9), 100.0), ((20, 400), 30.0), ((50, 60), 3.0)],
)
def test_a_gaussian_longer_than_the_map_filters_as_scipys_reflect(shape, sigma):
    from scipy.ndimage import gaussian_filter

    from stencil_cad.simulate import cells

    x = np.random.default_rng(3).random(shape)
    want = gaussian_filter(x, sigma, mode="reflect", truncate=4.0)
    got = cells.gaussian_reflect(x, sigma)
    np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-13)
