"""The label tile's B-rep check in groups of letters catches what the check of the whole label catches."""

from __future__ import annotations

import itertools
from dataclasses import replace

import numpy as np
import pytest

from stencil_cad import cad
from stencil_cad.cad.fullcheck import (
    LABEL_WINDOW_LETTERS,
    _tile_valid,
    brep_valid,
    label_windows,
    plate_tiles,
)
from stencil_cad.cad.solid import make_solid
from stencil_cad.config import PlateConfig
from stencil_cad.model import DotSet

LABEL = cad.LabelInfo(layer=2, layers=3, colour="#1a2b3c", job="test")


@pytest.fixture(scope="module")
def label_tile():
    xy = np.array([[10.0, 15.0], [30.0, 15.0]])
    model = cad.build_plate(
        DotSet(xy, np.array([1.0, 1.0])), 40.0, 30.0, PlateConfig(thickness_mm=1.2), LABEL
    )
    tile = dict(plate_tiles(model.geometry, 80))["label"]
    assert len(tile.glyphs) > 2 * LABEL_WINDOW_LETTERS  # several runs, so pairs across runs exist
    return tile


def _with_glyph(tile, k, outer, inner=None):
    glyphs = list(tile.glyphs)
    glyphs[k] = (outer, list(glyphs[k][1]) if inner is None else inner)
    return replace(tile, glyphs=tuple(glyphs))


def _both_verdicts(tile):
    """The whole label's verdict and the grouped one."""
    return brep_valid(make_solid(tile), plane_pcurves=True), _tile_valid("label", tile)


def test_a_sound_label_passes_in_groups(label_tile):
    assert _both_verdicts(label_tile) == (True, True)


def test_two_crossing_letters_in_different_runs_fail(label_tile):
    a, b = 1, LABEL_WINDOW_LETTERS + 1  # in different runs of letters
    outer_a, outer_b = label_tile.glyphs[a][0], label_tile.glyphs[b][0]
    # Letter b moved onto letter a, a little to the right: their outlines cross.
    moved = outer_b - outer_b.mean(axis=0) + outer_a.mean(axis=0) + [0.3, 0.0]
    bad = _with_glyph(
        label_tile,
        b,
        moved,
        [i - outer_b.mean(axis=0) + outer_a.mean(axis=0) + [0.3, 0.0] for i in label_tile.glyphs[b][1]],
    )
    assert any(a in w and b in w for w in label_windows(bad.glyphs))
    assert _both_verdicts(bad) == (False, False)


def test_a_self_crossing_letter_fails(label_tile):
    k = LABEL_WINDOW_LETTERS + 2
    lo, hi = label_tile.glyphs[k][0].min(axis=0), label_tile.glyphs[k][0].max(axis=0)
    bow_tie = np.array([[lo[0], lo[1]], [hi[0], hi[1]], [hi[0], lo[1]], [lo[0], hi[1]]])
    assert _both_verdicts(_with_glyph(label_tile, k, bow_tie, [])) == (False, False)


def test_a_letter_across_the_tile_edge_fails(label_tile):
    k = len(label_tile.glyphs) - 1
    outer = label_tile.glyphs[k][0]
    shift = np.array([0.0, label_tile.outline[:, 1].max() - outer[:, 1].mean()])
    bad = _with_glyph(label_tile, k, outer + shift, [i + shift for i in label_tile.glyphs[k][1]])
    assert _both_verdicts(bad) == (False, False)


def test_label_windows_hold_every_letter_and_every_pair_whose_boxes_meet():
    rng = np.random.default_rng(3)
    for _ in range(20):
        n = int(rng.integers(1, 40))
        corner = rng.uniform(0, 30, (n, 2))
        glyphs = tuple(
            (np.array([c, c + [s, 0], c + [s, s], c + [0, s]]), [])
            for c, s in zip(corner, rng.uniform(0.5, 4.0, n), strict=True)
        )
        groups = label_windows(glyphs, size=4, margin_mm=0.1)
        assert set(itertools.chain(*groups)) == set(range(n))
        for i, j in itertools.combinations(range(n), 2):
            lo_i, hi_i = glyphs[i][0].min(axis=0) - 0.1, glyphs[i][0].max(axis=0) + 0.1
            lo_j, hi_j = glyphs[j][0].min(axis=0) - 0.1, glyphs[j][0].max(axis=0) + 0.1
            if np.all(lo_i <= hi_j) and np.all(lo_j <= hi_i):
                assert any(i in g and j in g for g in groups), (i, j)


def test_letters_found_valid_before_are_not_checked_again(label_tile, monkeypatch):
    from stencil_cad.cad import fullcheck

    assert _tile_valid("label", label_tile)  # the letters and pairs are now known
    calls = []
    real = fullcheck.brep_valid
    monkeypatch.setattr(fullcheck, "brep_valid", lambda s, **kw: calls.append(1) or real(s, **kw))
    assert _tile_valid("label", label_tile)
    assert calls == []
    # One letter changed: that letter, in a run of its own, and its meeting pairs are checked.
    k = 3
    moved = _with_glyph(
        label_tile,
        k,
        label_tile.glyphs[k][0] + [0.0, 1e-3],
        [i + [0.0, 1e-3] for i in label_tile.glyphs[k][1]],
    )
    assert _tile_valid("label", moved)
    assert 1 <= len(calls) <= 3


def test_a_known_letter_across_a_smaller_tiles_edge_fails(label_tile):
    # The letters' bits are known valid, but the outline now cuts the last letter: its box is not
    # inside the outline, so it is checked again with the outline, and fails.
    assert _tile_valid("label", label_tile)
    outer = label_tile.glyphs[-1][0]
    cut_at = float(outer[:, 0].mean())
    ring = label_tile.outline.copy()
    ring[ring[:, 0] == ring[:, 0].max(), 0] = cut_at
    assert _both_verdicts(replace(label_tile, outline=ring)) == (False, False)


def test_known_letters_in_a_four_cornered_outline_that_is_no_rectangle_are_checked(label_tile):
    # The letters' bits are known valid; the outline's corners in a bow-tie order are no
    # rectangle (its sides cross), so the letters are checked with it again, and fail.
    assert _tile_valid("label", label_tile)
    bow_tie = replace(label_tile, outline=label_tile.outline[[0, 2, 1, 3]])
    assert not brep_valid(make_solid(bow_tie), plane_pcurves=True)
    assert not _tile_valid("label", bow_tie)
