"""Plane and mesh geometry (stencil_cad.geometry) against hand-made cases."""

import numpy as np
import pytest

from stencil_cad.geometry import (
    as_ccw,
    as_cw,
    circles_clear_of_rings,
    genus,
    mesh_genus,
    point_ring_distance,
    points_in_any_ring,
    points_in_circles,
    points_in_ring,
    polygon_area,
    rings_cross,
)

SQ = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)


def test_area_and_orientation():
    assert polygon_area(SQ) == 1.0
    assert polygon_area(SQ[::-1]) == -1.0
    assert polygon_area((SQ * 2).tolist()) == 4.0
    assert polygon_area(as_cw(SQ)) == -1.0
    assert polygon_area(as_ccw(SQ[::-1])) == 1.0
    assert np.array_equal(as_ccw(SQ), SQ)


def test_points_in_ring():
    inside = points_in_ring(np.array([[0.5, 0.5], [1.5, 0.5], [-0.1, 0.2]]), SQ)
    assert inside.tolist() == [True, False, False]


def test_ring_crossing_detector():
    assert not rings_cross([SQ, SQ + 2.0])
    assert not rings_cross([SQ * 3, SQ[::-1] + 1.0])  # a hole inside, clear of the outer ring
    assert rings_cross([SQ, SQ + 0.5])
    assert rings_cross([SQ, SQ + [1.0, 0.0]])  # touching along an edge
    bow = np.array([[0, 0], [1, 1], [1, 0], [0, 1]], float)  # a bow-tie crosses itself
    assert rings_cross([bow])
    # Only proper crossings between different rings:
    assert not rings_cross([SQ, SQ + [1.0, 0.0]], touching=False)
    assert rings_cross([SQ, SQ + 0.5], touching=False, within=False)
    assert not rings_cross([bow], within=False)
    assert not rings_cross([])


def _brute_cross(rings, touching=True, within=True):
    """rings_cross by every pair of edges."""
    edges = [(k, i, len(r), r[i], r[(i + 1) % len(r)]) for k, r in enumerate(rings) for i in range(len(r))]

    def orient(p, q, r):
        return (q[0] - p[0]) * (r[1] - p[1]) - (q[1] - p[1]) * (r[0] - p[0])

    for x, (k, i, n, a, b) in enumerate(edges):
        for m, j, _, c, d in edges[x + 1 :]:
            if k == m and (not within or abs(i - j) in (1, n - 1)):
                continue
            if (np.minimum(a, b) > np.maximum(c, d)).any() or (np.minimum(c, d) > np.maximum(a, b)).any():
                continue
            d1, d2, d3, d4 = orient(a, b, c), orient(a, b, d), orient(c, d, a), orient(c, d, b)
            if (d1 * d2 <= 0 and d3 * d4 <= 0) if touching else (d1 * d2 < 0 and d3 * d4 < 0):
                return True
    return False


@pytest.mark.parametrize("seed", range(40))
def test_ring_crossing_matches_every_pair(seed):
    # Small integer rings over a field of them: many exact touches, shared x-ranges and long edges.
    rng = np.random.default_rng(seed)
    rings = [
        rng.integers(0, 12, (int(rng.integers(3, 6)), 2)).astype(float)
        for _ in range(int(rng.integers(1, 5)))
    ]
    rings += [
        c + np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float) * 0.8
        for c in rng.integers(0, 30, (20, 2)) * 1.0
    ]
    for touching in (True, False):
        for within in (True, False):
            assert rings_cross(rings, touching=touching, within=within) == _brute_cross(
                rings, touching, within
            )


def test_rings_in_rings_and_circles_match_every_pair():
    rng = np.random.default_rng(7)
    rings = [
        c + 0.5 * np.array([[0, 0], [2, 0], [2, 1], [1, 2], [0, 1]], float)
        for c in rng.uniform(0, 20, (300, 2))
    ]
    rings.append(np.array([[0, 0], [21, 0], [21, 21], [0, 21]], float) * 0.5)  # a big ring over many
    points = rng.uniform(-1, 22, (500, 2))
    own = rng.integers(-1, len(rings), len(points))
    want = np.array(
        [
            any(points_in_ring(p[None], r)[0] for k, r in enumerate(rings) if k != o)
            for p, o in zip(points, own, strict=True)
        ]
    )
    assert np.array_equal(points_in_any_ring(points, rings, own=own), want)
    xy, r = rng.uniform(0, 20, (400, 2)), rng.uniform(0.1, 1.5, 400)
    want = (np.hypot(*(points[:, None] - xy[None]).transpose(2, 0, 1)) < r).any(axis=1)
    assert np.array_equal(points_in_circles(points, xy, r), want)
    assert not points_in_any_ring(points, []).any() and not points_in_circles(points, xy[:0], r[:0]).any()


@pytest.mark.parametrize("inside", [False, True])
def test_circles_clear_of_rings_matches_every_pair(inside):
    rng = np.random.default_rng(3)
    rings = [
        np.array([[2, 2], [18, 3], [17, 17], [9, 12], [3, 16]], float),
        np.array([[5, 5], [7, 5], [6, 8]], float),
    ]
    xy, r = rng.uniform(-2, 22, (2000, 2)), rng.uniform(0.05, 2.0, 2000)
    want = np.ones(len(r), bool)
    for ring in rings:
        side = points_in_ring(xy, ring) == inside
        want &= side & (point_ring_distance(xy, ring) >= r + 0.1)
    assert np.array_equal(circles_clear_of_rings(xy, r, rings, 0.1, inside=inside), want)


def _box(x0, y0, x1, y1, z0, z1):
    """Triangle corners of a closed axis-aligned box."""
    v = np.array([[x, y, z] for z in (z0, z1) for y in (y0, y1) for x in (x0, x1)], float)
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    return np.array([v[[a, b, c]] for a, b, c, d in quads for a, b, c in ((a, b, c), (a, c, d))])


def test_genus_of_boxes():
    one = _box(0, 0, 1, 1, 0, 1)
    assert mesh_genus(one) == 0
    two = np.concatenate([one, _box(3, 0, 4, 1, 0, 1)])
    assert mesh_genus(two) == 0
    chi, shells, _ = genus(np.arange(36).reshape(-1, 3), 36)
    # 12 loose triangles: 12 shells, V - E + F = 36 - 36 + 12.
    assert (chi, shells) == (12, 12)
