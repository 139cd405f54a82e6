"""The proxy of what plates spray, which ranks the decomposition's candidate starts."""

import numpy as np
import pytest
from skimage.color import rgb2lab

from stencil_cad.decompose.sprayed import PlateReach, coat_steps, lightness_gradient
from stencil_cad.model import coat_contrast, composite

REACH = PlateReach(darkest=0.9, threshold=0.05, window_from=0.85)


def test_sprayed_clips_to_what_holes_reach_and_windows_spray_a_full_coat():
    a = np.array([[[0.02, 0.5, 0.88, 1.0]]])
    out, holes = REACH.sprayed(a)
    np.testing.assert_allclose(out, [[[0.0, 0.5, 1.0, 1.0]]])  # below threshold: nothing; windows: a coat
    assert holes.tolist() == [[[False, True, False, False]]]
    off = PlateReach(darkest=0.9, threshold=0.05, window_from=None)
    np.testing.assert_allclose(off.sprayed(a)[0], [[[0.0, 0.5, 0.88, 0.9]]])
    thin = PlateReach(darkest=0.9, threshold=0.05, window_from=0.85, coat=0.95)
    np.testing.assert_allclose(thin.sprayed(a)[0], [[[0.0, 0.5, 0.95, 0.95]]])


def test_a_window_short_of_the_layer_costs_its_tone():
    # A layer at 0.88 where a window sprays a full coat: the composite overshoots by 0.12 of a coat.
    target = np.full((4, 4, 3), 0.12)
    a = np.full((1, 4, 4), 0.88)
    e = REACH.error(target, np.ones(3), np.zeros((1, 3)), a)
    assert e == pytest.approx(float(rgb2lab(np.full((1, 1, 3), 0.12))[0, 0, 0]), rel=1e-6)


def test_a_black_primer_beats_black_dots_over_a_black_picture():
    # Black with a few white stars: prime black and spray white only at the stars, or prime white
    # and spray black at 0.95 over the background (holes only: capped at 0.9, a dotted lattice).
    h = w = 24
    target = np.zeros((h, w, 3))
    target[5, 5] = target[12, 18] = 1.0
    stars = (target[..., 0] > 0).astype(float)[None]
    black, white = np.zeros(3), np.ones(3)
    holes_only = PlateReach(darkest=0.9, threshold=0.05, window_from=None)
    e_black = holes_only.error(target, black, white[None], stars)
    e_white = holes_only.error(target, white, black[None], 1.0 - stars)
    # The ideal layers fit both exactly: only the plates tell them apart (the stars lose a tenth
    # of their coat, the whole background a tenth and a lattice).
    assert e_black < 0.01 * e_white


def test_the_dot_pattern_costs_its_lightness_variance_where_holes_spray():
    target = np.full((8, 8, 3), 0.5)
    a = np.full((1, 8, 8), 0.5)
    grey = PlateReach(darkest=1.0, threshold=0.0, window_from=None)
    black_over_white = grey.error(target, np.ones(3), np.zeros((1, 3)), a)
    comp = np.full((1, 1, 3), 0.5)
    tone = np.linalg.norm(rgb2lab(comp)[0, 0] - rgb2lab(np.full((1, 1, 3), 0.5))[0, 0])
    dl = float(np.sum(lightness_gradient(comp)[0, 0] * -1.0))  # the step is black - white
    # Tone exact; the hard-edged pattern's variance a (1 - a) = 0.25 in opacity, seen in lightness.
    assert tone == pytest.approx(0.0)
    assert black_over_white == pytest.approx(np.sqrt(grey.texture * 0.25 * dl * dl))
    # A measured pattern (soft dots overlapping) replaces a (1 - a).
    soft = PlateReach(darkest=1.0, threshold=0.0, window_from=None, pattern=((0.0, 1.0), (0.0, 0.02)))
    assert soft.variance(np.array([0.5])) == pytest.approx([0.01])
    assert soft.error(target, np.ones(3), np.zeros((1, 3)), a) == pytest.approx(np.sqrt(0.01 * dl * dl))


def test_a_colour_step_without_a_lightness_step_shows_little_pattern():
    # The eye's chromatic channels blur the holes away: a paint that differs from the grey under
    # it in hue only (a step across the lightness gradient) shows a far fainter pattern than one
    # that differs in lightness by as much.
    grey = np.full(3, 0.5)
    grad = lightness_gradient(grey[None, None])[0, 0]
    across = np.array([grad[1], -grad[0], 0.0])
    across *= 0.1 / np.linalg.norm(across)
    along = grad * 0.1 / np.linalg.norm(grad)
    a = np.full((1, 8, 8), 0.5)
    reach = PlateReach(darkest=1.0, threshold=0.0, window_from=None)

    def pattern_only(colour):
        target = composite(grey, colour[None], a)
        return reach.error(target, grey, colour[None], a)

    assert pattern_only(grey + across) < 0.05 * pattern_only(grey + along)


def test_coat_steps_are_the_composites_slope_and_square_to_the_coat_contrast():
    rng = np.random.default_rng(0)
    primer, colours, a = rng.random(3), rng.random((3, 3)), rng.random((3, 4, 5))
    steps = coat_steps(primer, colours, a)
    np.testing.assert_allclose(np.sum(steps**2, axis=-1), coat_contrast(primer, colours, a), rtol=1e-10)
    h = 1e-6
    bumped = a.copy()
    bumped[1] += h
    np.testing.assert_allclose(
        (composite(primer, colours, bumped) - composite(primer, colours, a)) / h, steps[1], atol=1e-5
    )


def test_lightness_gradient_matches_lab():
    rgb = np.array([[[0.02, 0.3, 0.9], [0.5, 0.5, 0.5], [0.9, 0.1, 0.03]]])
    grad = lightness_gradient(rgb)
    h = 1e-6
    for c in range(3):
        bumped = rgb.copy()
        bumped[..., c] += h
        np.testing.assert_allclose(
            (rgb2lab(bumped)[..., 0] - rgb2lab(rgb)[..., 0]) / h, grad[..., c], rtol=1e-4
        )
