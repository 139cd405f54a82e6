"""Where the decomposition starts: flat-colour art keeps the colour of a small shape."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad.config.decompose import DecomposeConfig
from stencil_cad.decompose import decompose
from stencil_cad.decompose.start import flat_pixels
from stencil_cad.model import Picture


def _logo(size: int = 96) -> np.ndarray:
    """White, a red ring with a long rim, a small black square inside it, edges blended like a resampled logo."""
    rgb = np.ones((size, size, 3))
    yy, xx = np.mgrid[0:size, 0:size].astype(np.float64) / size
    rho = np.hypot(yy - 0.5, xx - 0.5)
    ring = np.clip((0.42 - rho) * size, 0.0, 1.0) * np.clip((rho - 0.25) * size, 0.0, 1.0)
    rgb = rgb * (1.0 - ring[..., None]) + ring[..., None] * np.array([0.85, 0.1, 0.12])
    rgb[(np.abs(yy - 0.5) < 0.06) & (np.abs(xx - 0.5) < 0.06)] = 0.05
    blue = (yy > 0.88) & (xx > 0.1) & (xx < 0.9)
    rgb[blue] = (0.05, 0.2, 0.6)
    return rgb


def test_flat_pixels_are_found_on_flat_art_only():
    logo = _logo()
    flat = flat_pixels(logo)
    assert flat is not None and len(flat) > 0.8 * 96 * 96
    # Every flat pixel is one of the inks (no blend of the ring's rim).
    inks = np.array([[1.0, 1.0, 1.0], [0.85, 0.1, 0.12], [0.05, 0.05, 0.05], [0.05, 0.2, 0.6]])
    d = np.min(np.abs(flat[:, None, :] - inks[None]).max(axis=2), axis=1)
    assert d.max() < 1e-9
    grain = np.clip(logo + np.random.default_rng(0).normal(0.0, 0.03, logo.shape), 0.0, 1.0)
    assert flat_pixels(grain) is None
    assert flat_pixels(np.zeros((2, 2, 3))) is None


@pytest.mark.parametrize("seed", [0, 2])
def test_a_small_black_shape_keeps_its_paint(seed):
    # The quality benchmark's logo resampled as a job loads it: the blends on the red ring's rim
    # outnumber the black square's pixels, and K-means on every pixel gave the square's paint to
    # a pink blend with these seeds (it came out white and was dropped).
    from skimage.transform import resize

    from benchmarks.quality import logo

    rgb = np.clip(resize(logo(512), (150, 150, 3), order=1, anti_aliasing=True), 0.0, 1.0)
    pic = Picture(rgb=rgb, mm_per_px=1.0, source="test logo")
    layers = decompose(pic, DecomposeConfig(layers=4), np.random.default_rng(seed))
    paints = np.vstack([layers.primer[None], layers.colours])
    assert layers.count == 4
    assert np.min(paints.max(axis=1)) < 0.15  # black is the primer or a paint
    square = layers.composite()[55:65, 55:65]
    assert square.max() < 0.2


def test_starts_the_plates_serve_alike_go_to_the_least_paint():
    from stencil_cad.decompose.start import _SPRAYED_TIE_DE, _least_paint

    white, dark = np.ones(3), np.full(3, 0.05)
    cands = [(dark, np.zeros((1, 3)), np.array([0, 1])), (white, np.zeros((1, 3)), np.array([1, 0]))]
    tie = 0.1
    # Within a tie: the start spraying less paint wins though its prediction is a little worse.
    assert _least_paint(cands, [2.5, 2.5 + 0.5 * tie], [1.44, 0.43], tie) == 1
    # Beyond it the prediction decides.
    assert _least_paint(cands, [2.5, 2.5 + 2.0 * tie], [1.44, 0.43], tie) == 0
    # Equal paint: the lighter primer, then the prediction.
    assert _least_paint(cands, [2.5, 2.55], [0.43, 0.43], tie) == 1
    assert _least_paint([cands[1], cands[1]], [2.55, 2.5], [0.43, 0.43], tie) == 1
    # The shipped rule: only equal predictions tie, else the better prediction wins.
    assert _least_paint(cands, [2.5, 2.501], [1.44, 0.43], _SPRAYED_TIE_DE) == 0
    assert _least_paint(cands, [2.5, 2.5], [1.44, 0.43], _SPRAYED_TIE_DE) == 1
