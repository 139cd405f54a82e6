"""The px (row, col) <-> mm (x, y) conversions agree with each other."""

import numpy as np
import pytest

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


def test_a_window_of_the_raster_is_the_same_pixels_as_the_whole():
    from stencil_cad.frames import rasterise_polygons

    rng = np.random.default_rng(1)
    polys = []
    for _ in range(6):
        cx, cy, rad = rng.uniform(5, 45), rng.uniform(5, 35), rng.uniform(1, 8)
        t = np.sort(rng.uniform(0, 2 * np.pi, 9))
        ring = np.column_stack([cx + rad * np.cos(t), cy + rad * np.sin(t)])
        polys.append((ring, ()))
    # Vertices on pixel centres and edges too: the crossings sit exactly on them.
    polys.append((np.array([[10.25, 10.25], [20.0, 10.25], [20.0, 30.5], [10.25, 30.5]]), ()))
    whole = rasterise_polygons(polys, (80, 100), 0.5)
    for window in [(0, 80, 0, 100), (10, 50, 20, 70), (0, 1, 99, 100), (33, 33, 0, 100), (5, 75, 0, 3)]:
        r0, r1, c0, c1 = window
        np.testing.assert_array_equal(rasterise_polygons(polys, (80, 100), 0.5, window), whole[r0:r1, c0:c1])
    with pytest.raises(ValueError, match="not inside the raster"):
        rasterise_polygons(polys, (80, 100), 0.5, (0, 81, 0, 100))


def test_windows_opacity_is_the_whole_rasters():
    """The windows are rasterised around themselves only: the same opacity as from the whole fine raster."""
    from stencil_cad.config.job import JobConfig
    from stencil_cad.frames import rasterise_polygons
    from stencil_cad.simulate.opacity import spray_mask, windows_opacity
    from stencil_cad.simulate.physical import SprayGeometry

    cfg = JobConfig()
    geo = SprayGeometry.for_job(cfg)
    wins = [
        (np.array([[3.3, 4.1], [17.9, 4.1], [17.9, 12.6], [3.3, 12.6]]), ()),
        (np.array([[30.0, 20.0], [49.9, 20.0], [49.9, 39.9]]), ()),
    ]
    h, w, g, f = 80, 100, 0.5, 4
    fine = rasterise_polygons(wins, (h * f, w * f), g / f)
    whole = spray_mask(fine.reshape(h, f, w, f).mean(axis=(1, 3)), g, cfg.spray, spray_time=2.0, geometry=geo)
    a = windows_opacity(wins, (h, w), g, cfg.spray, spray_time=2.0, geometry=geo, supersample=f)
    np.testing.assert_array_equal(a, whole)
