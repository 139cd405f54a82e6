"""Lloyd's start from another wall's holes (stipple/warm.py)."""

from __future__ import annotations

import numpy as np

from stencil_cad.stipple.relax import cvt_energy, lloyd
from stencil_cad.stipple.sampling import importance_sample
from stencil_cad.stipple.warm import hilbert_order, warm_seeds


def _density(h: int = 80, w: int = 120) -> np.ndarray:
    yy, xx = np.mgrid[0:h, 0:w]
    return 0.2 + np.exp(-((yy - 40.0) ** 2 + (xx - 50.0) ** 2) / 600.0)


def test_hilbert_order_is_a_permutation_that_keeps_neighbours_close():
    rng = np.random.default_rng(0)
    p = rng.random((500, 2)) * 100.0
    order = hilbert_order(p)
    assert sorted(order.tolist()) == list(range(500))
    steps = np.linalg.norm(np.diff(p[order], axis=0), axis=1)
    shuffled = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert np.median(steps) < 0.25 * np.median(shuffled)


def test_fewer_holes_are_a_spread_subset_of_the_old_ones():
    lam = _density()
    old = importance_sample(lam, 400, np.random.default_rng(1))
    seeds = warm_seeds(old, lam, 300, np.random.default_rng(2))
    assert seeds.shape == (300, 2)
    old_rows = {tuple(r) for r in old.tolist()}
    assert all(tuple(r) in old_rows for r in seeds.tolist())
    # Thinned evenly: the kept holes' CVT energy is far below a random subset's.
    rand = old[np.random.default_rng(3).choice(400, 300, replace=False)]
    assert cvt_energy(lam * lam, seeds) < cvt_energy(lam * lam, rand)


def test_more_holes_keep_every_old_one_and_are_deterministic():
    lam = _density()
    old = importance_sample(lam, 200, np.random.default_rng(1))
    a = warm_seeds(old, lam, 260, np.random.default_rng(5))
    b = warm_seeds(old, lam, 260, np.random.default_rng(5))
    assert a.shape == (260, 2)
    np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(a[:200], old)


def test_a_warm_start_relaxes_in_fewer_passes_to_no_higher_energy():
    lam = _density()
    w = lam * lam
    first, _ = lloyd(w, importance_sample(lam, 300, np.random.default_rng(1)), 200, 0.02)
    lam2 = lam**1.2
    w2 = lam2 * lam2
    cold, cold_info = lloyd(w2, importance_sample(lam2, 280, np.random.default_rng(2)), 200, 0.02)
    warm, warm_info = lloyd(w2, warm_seeds(first, lam2, 280, np.random.default_rng(2)), 200, 0.02)
    assert warm_info["iterations"] < cold_info["iterations"]
    assert cvt_energy(w2, warm) <= cvt_energy(w2, cold) * 1.01


def test_no_density_or_no_count_gives_no_seeds_and_no_old_holes_an_importance_sample():
    lam = _density()
    assert warm_seeds(np.zeros((0, 2)), lam, 0, np.random.default_rng(0)).shape == (0, 2)
    assert warm_seeds(np.ones((3, 2)), np.zeros((10, 10)), 5, np.random.default_rng(0)).shape == (0, 2)
    assert warm_seeds(np.zeros((0, 2)), lam, 50, np.random.default_rng(0)).shape == (50, 2)
