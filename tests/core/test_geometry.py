"""Plane and mesh geometry (stencil_cad.geometry) against hand-made cases."""

import numpy as np

from stencil_cad.geometry import as_ccw, as_cw, genus, mesh_genus, points_in_ring, polygon_area, rings_cross

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
