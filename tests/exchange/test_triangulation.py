"""The mesher's Qhull options give SciPy's default triangulation, the same triangles in the same order."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay

from stencil_cad.exchange.triangulation import QHULL_OPTIONS


def _point_sets():
    rng = np.random.default_rng(7)
    ang = np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)
    circle = np.column_stack([np.cos(ang), np.sin(ang)])
    grid = np.stack(np.meshgrid(np.arange(30.0), np.arange(20.0)), -1).reshape(-1, 2)
    holes = np.concatenate([c + 0.4 * circle for c in rng.uniform(0, 20, (40, 2))])
    return {
        "random": rng.random((3000, 2)),
        "grid (cocircular fours)": grid,
        "circle": circle,
        "circle and its centre": np.concatenate([circle, [[0.0, 0.0]]]),
        "duplicated points": np.round(rng.random((2000, 2)) * 10) / 10,
        "hole rings and centres": holes,
    }


@pytest.mark.parametrize("name", list(_point_sets()))
def test_qhull_options_keep_scipys_triangulation(name):
    pts = _point_sets()[name]
    default = Delaunay(pts)
    ours = Delaunay(pts, qhull_options=QHULL_OPTIONS)
    np.testing.assert_array_equal(ours.simplices, default.simplices)
    np.testing.assert_array_equal(ours.neighbors, default.neighbors)
    np.testing.assert_array_equal(ours.coplanar, default.coplanar)
