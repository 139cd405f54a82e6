"""The proxy of what plates spray, which ranks the decomposition's candidate starts."""

import numpy as np
import pytest

from stencil_cad.decompose.sprayed import PlateReach

REACH = PlateReach(darkest=0.9, threshold=0.05, window_from=0.85)


def test_sprayed_clips_to_what_holes_and_windows_reach():
    a = np.array([[[0.02, 0.5, 0.88, 1.0]]])
    out, holes = REACH.sprayed(a)
    np.testing.assert_allclose(out, [[[0.0, 0.5, 0.88, 1.0]]])  # below threshold: nothing; windows keep
    assert holes.tolist() == [[[False, True, False, False]]]
    off = PlateReach(darkest=0.9, threshold=0.05, window_from=None)
    np.testing.assert_allclose(off.sprayed(a)[0], [[[0.0, 0.5, 0.88, 0.9]]])


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


def test_the_dot_pattern_costs_where_holes_spray_mid_tones():
    target = np.full((8, 8, 3), 0.5)
    a = np.full((1, 8, 8), 0.5)
    grey = PlateReach(darkest=1.0, threshold=0.0, window_from=None)
    e = grey.error(target, np.ones(3), np.zeros((1, 3)), a)
    # Tone exact; the pattern's variance a (1 - a) |c - primer|^2 = 0.25 * 3, times the seen share.
    assert e == pytest.approx(grey.texture * 0.75)
