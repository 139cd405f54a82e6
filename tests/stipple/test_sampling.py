"""Lloyd's start points sampled along a Hilbert curve (stipple/sampling.py)."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad.stipple.relax import cvt_energy, lloyd
from stencil_cad.stipple.sampling import importance_sample, pixel_order, stratified_sample


def _density(h: int = 128, w: int = 128) -> np.ndarray:
    yy, xx = np.mgrid[0:h, 0:w]
    return 0.2 + np.exp(-((yy - 40.0) ** 2 + (xx - 50.0) ** 2) / 600.0)


@pytest.mark.parametrize("shape", [(1, 1), (5, 3), (37, 90), (128, 128)])
def test_pixel_order_visits_every_pixel_once_and_keeps_neighbours_close(shape):
    order = pixel_order(*shape)
    assert sorted(order.tolist()) == list(range(shape[0] * shape[1]))
    assert not order.flags.writeable
    if shape[0] * shape[1] > 100:
        rows, cols = np.divmod(order, shape[1])
        steps = np.hypot(np.diff(rows), np.diff(cols))
        # Row by row within a block, then on to a neighbouring block (or past the grid's edge).
        assert np.median(steps) == 1.0
        assert steps.mean() < 2.0


def _worst_region_error(points: np.ndarray, lam: np.ndarray, cells: int = 8) -> float:
    """The largest difference between a region's points and its share of ``len(points)``, over a grid of regions."""
    h, w = lam.shape
    rows = np.clip(np.floor(points[:, 0] + 0.5).astype(int), 0, h - 1) * cells // h
    cols = np.clip(np.floor(points[:, 1] + 0.5).astype(int), 0, w - 1) * cells // w
    got = np.zeros((cells, cells))
    np.add.at(got, (rows, cols), 1.0)
    want = lam.reshape(cells, h // cells, cells, w // cells).sum(axis=(1, 3)) * len(points) / lam.sum()
    return float(np.abs(got - want).max())


def test_every_region_holds_its_share_of_the_points():
    lam = _density()
    pts = stratified_sample(lam, 2000, np.random.default_rng(1))
    assert pts.shape == (2000, 2)
    assert np.all((pts > -0.5) & (pts < 127.5))
    # Each of the 64 regions is a few stretches of the curve, each within one point of its share;
    # independent draws miss theirs by several.
    assert _worst_region_error(pts, lam) <= 3.0
    assert _worst_region_error(importance_sample(lam, 2000, np.random.default_rng(1)), lam) > 6.0


def test_points_fall_only_where_there_is_density_and_repeat_with_the_seed():
    lam = np.zeros((40, 60))
    lam[10:20, 30:50] = 1.0
    a = stratified_sample(lam, 150, np.random.default_rng(4))
    np.testing.assert_array_equal(a, stratified_sample(lam, 150, np.random.default_rng(4)))
    rows, cols = np.floor(a + 0.5).astype(int).T
    assert np.all(lam[rows, cols] > 0.0)
    assert stratified_sample(lam, 0, np.random.default_rng(4)).shape == (0, 2)
    assert stratified_sample(np.zeros((8, 8)), 10, np.random.default_rng(4)).shape == (0, 2)


def test_lloyd_from_it_takes_fewer_passes_to_no_higher_energy():
    lam = _density()
    w = lam * lam
    passes, energies = {}, {}
    for name, sample in (("importance", importance_sample), ("stratified", stratified_sample)):
        its, en = [], []
        for seed in range(3):
            seeds, info = lloyd(w, sample(lam, 600, np.random.default_rng(seed)), 300, 0.02)
            its.append(info["iterations"])
            en.append(cvt_energy(w, seeds))
        passes[name], energies[name] = np.median(its), np.median(en)
    assert passes["stratified"] < passes["importance"]
    assert energies["stratified"] <= energies["importance"] * 1.005
