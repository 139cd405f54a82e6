"""The shared filters give scipy's and scikit-image's values."""

import numpy as np
import pytest


@pytest.mark.parametrize("mode", ["reflect", "mirror", "nearest", "constant"])
@pytest.mark.parametrize("shape", [(1, 1), (1, 9), (9, 1), (3, 50), (120, 77), (40, 30, 3)])
def test_opencvs_filters_give_scipys_values(mode, shape):
    """The separable filters by OpenCV give scipy's values in every edge mode, any length of map and kernel."""
    from scipy.ndimage import correlate1d, gaussian_filter

    from stencil_cad import filters

    rng = np.random.default_rng(7)
    x = rng.random(shape)
    for sigma in (0.3, 1.7, 6.0, 30.0):
        for truncate in (4.0, 5.0):
            want = gaussian_filter(x, (sigma, sigma, 0)[: x.ndim], mode=mode, truncate=truncate)
            got = filters.gaussian(x, sigma, mode, truncate)
            np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-13)
        if x.ndim == 2:
            w = rng.random(2 * int(3 * sigma) + 1)
            for axis in (0, 1):
                want = correlate1d(x, w, axis=axis, mode=mode)
                np.testing.assert_allclose(
                    filters.correlate_axis(x, w, axis, mode), want, rtol=0.0, atol=1e-13
                )
    assert np.array_equal(filters.gaussian(x, 0.0, mode), x)


@pytest.mark.parametrize("mode", ["edge", "reflect", "symmetric"])
@pytest.mark.parametrize("shape", [(300, 300), (301, 177), (1, 5), (5, 1), (40, 60, 3), (2, 2)])
def test_the_linear_resize_gives_scikit_images_values(mode, shape):
    """Shrunk, grown, to one pixel, with and without anti-aliasing, on maps and colour pictures."""
    from skimage.transform import resize

    from stencil_cad import filters

    x = np.random.default_rng(11).random(shape)
    for out in [(300, 300), (377, 377), (257, 257), (150, 90), (1, 1), (3, 7), (1000, 20)]:
        for anti_aliasing in (True, False):
            want = resize(x, (*out, *x.shape[2:]), order=1, anti_aliasing=anti_aliasing, mode=mode)
            got = filters.resize_linear(x, out, mode, anti_aliasing)
            assert got.shape == want.shape
            np.testing.assert_allclose(got, want, rtol=0.0, atol=1e-13)


def test_a_small_map_filters_on_one_thread_and_leaves_the_count():
    """Under the threshold the filter runs on one thread and restores OpenCV's count; the values are the same."""
    import cv2

    from stencil_cad import filters

    x = np.random.default_rng(3).random((50, 40)).astype(np.float32)
    k = np.full(5, 0.2, dtype=np.float32)
    before = cv2.getNumThreads()
    got = filters.sep_filter(x, k, k, cv2.BORDER_CONSTANT)
    assert cv2.getNumThreads() == before
    assert np.array_equal(got, cv2.sepFilter2D(x, -1, k, k, borderType=cv2.BORDER_CONSTANT))
