"""The blend distance measured on a job's own sprayed picture, where its holes show most."""

import numpy as np
import pytest
from scipy.ndimage import gaussian_filter

from stencil_cad.simulate.visibility import hole_spacing_mm, pattern_blend_distance_m, pattern_flat

G = 0.25  # mm per pixel


def _dots(shape, pitch_mm, sigma_mm, region=None):
    """Opacity of a square grid of Gaussian dots (peak 1) at ``pitch_mm``, inside ``region`` columns."""
    a = np.zeros(shape)
    step = int(round(pitch_mm / G))
    a[step // 2 :: step, step // 2 :: step] = 1.0
    if region is not None:
        a[:, : region[0]] = 0.0
        a[:, region[1] :] = 0.0
    a = gaussian_filter(a, sigma_mm / G) * 2 * np.pi * (sigma_mm / G) ** 2
    return np.clip(a, 0.0, 1.0)


def _sprayed(alpha, paint, ground):
    return ground[None, None, :] * (1 - alpha[..., None]) + paint[None, None, :] * alpha[..., None]


def test_sparse_light_dots_on_dark_show_far_and_are_found():
    white, black = np.ones(3), np.zeros(3)
    shape = (240, 480)  # 60 x 120 mm: the dots only in the right half
    alpha = _dots(shape, 4.0, 0.6, region=(240, 480))
    sprayed = _sprayed(alpha, white, black)
    ideal = _sprayed(gaussian_filter(alpha, 8.0), white, black)
    flat = pattern_flat(sprayed, ideal, 4.0 / G)
    d, (r0, c0, side) = pattern_blend_distance_m(sprayed, flat, G)
    assert d is not None and d > 2.0
    assert c0 >= 240 - side // 2  # the square where they show is on the dotted half
    # The same pattern finer and fainter blends much nearer.
    fine = _dots(shape, 1.0, 0.3, region=(240, 480)) * 0.2
    sprayed_f = _sprayed(fine, white * 0.6, black + 0.4)
    flat_f = pattern_flat(sprayed_f, _sprayed(gaussian_filter(fine, 4.0), white * 0.6, black + 0.4), 1.0 / G)
    d_f, _ = pattern_blend_distance_m(sprayed_f, flat_f, G)
    assert d_f is not None and d_f < d / 2


def test_no_pattern_blends_at_once_and_the_picture_itself_is_not_a_pattern():
    rng = np.random.default_rng(0)
    # A picture with its own coarse detail and no holes: the flat version keeps it, nothing shows.
    picture = gaussian_filter(rng.random((200, 200, 3)), (12, 12, 0))
    picture = (picture - picture.min()) / (picture.max() - picture.min())
    flat = pattern_flat(picture, picture, 8.0)
    d, _ = pattern_blend_distance_m(picture, flat, G)
    assert d == pytest.approx(0.25)


def test_hole_spacing_takes_the_sparse_holes():
    dense = np.array([[x, y] for x in np.arange(0, 20, 1.5) for y in np.arange(0, 20, 1.5)])
    sparse = np.array([[x, y] for x in np.arange(40, 80, 6.0) for y in np.arange(0, 20, 6.0)])
    assert hole_spacing_mm(dense) == pytest.approx(1.5)
    assert hole_spacing_mm(np.vstack([dense, sparse])) == pytest.approx(6.0)
    assert hole_spacing_mm(np.zeros((1, 2))) == 0.0
