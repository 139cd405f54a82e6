"""The px (row, col) <-> mm (x, y) conversions agree with each other."""

import numpy as np

from stencil_cad.frames import mm_to_px, mm_to_raster, pixel_centres_mm, px_to_mm


def test_round_trip_and_centres():
    rng = np.random.default_rng(0)
    rc = rng.uniform(-1, 50, (20, 2))
    np.testing.assert_allclose(mm_to_px(px_to_mm(rc, 40, 0.5), 40, 0.5), rc, atol=1e-12)
    x, y = pixel_centres_mm(3, 4, 0.5)
    rows, cols = np.meshgrid(np.arange(3), np.arange(4), indexing="ij")
    xy = px_to_mm(np.column_stack([rows.ravel(), cols.ravel()]), 3, 0.5)
    np.testing.assert_allclose(np.broadcast_to(x, (3, 4)).ravel(), xy[:, 0])
    np.testing.assert_allclose(np.broadcast_to(y, (3, 4)).ravel(), xy[:, 1])


def test_raster_coordinates_are_edge_based():
    xy = np.array([[0.0, 0.0], [1.25, 2.0], [10.0, 10.0]])
    # Centre-based indices plus half a pixel: the picture's corner (0, 0) mm is raster (H, 0).
    np.testing.assert_allclose(mm_to_raster(xy, 40, 4.0), mm_to_px(xy, 40, 0.25) + 0.5, atol=1e-12)
    assert mm_to_raster(xy, 40, 4.0)[0].tolist() == [40.0, 0.0]
