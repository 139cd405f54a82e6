"""The compiled nudge sweep moves the dots as the NumPy sweep it replaced, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad.stipple import rules as R


def _numpy_sweep(xy, r, target_web, candidates, active, first):
    """The sweep as NumPy wrote it before the kernel (the reference)."""
    live = candidates[active[candidates[:, 0]] | active[candidates[:, 1]]]
    pairs, webs = R._short_pairs(xy, r, target_web, live)
    idx = np.arange(len(xy)) if first else np.unique(pairs)
    if len(idx) == 0:
        return idx, xy[idx]
    before = xy[idx]
    if len(pairs):
        i, j = pairs[:, 0], pairs[:, 1]
        delta = xy[i] - xy[j]
        dist = np.hypot(delta[:, 0], delta[:, 1])
        unit = np.where(dist[:, None] > 1e-12, delta / np.maximum(dist, 1e-12)[:, None], [1.0, 0.0])
        push = 0.5 * (target_web - webs)[:, None] * unit
        n = len(xy)
        xy[:, 0] += np.bincount(i, push[:, 0], n) - np.bincount(j, push[:, 0], n)
        xy[:, 1] += np.bincount(i, push[:, 1], n) - np.bincount(j, push[:, 1], n)
    return idx, before


@pytest.mark.parametrize("seed", range(6))
def test_the_compiled_sweep_is_the_numpy_sweep(seed):
    rng = np.random.default_rng(seed)
    n = 400
    xy = rng.uniform(0.0, 30.0, (n, 2))
    xy[:20] = xy[20:40]  # coincident centres
    r = rng.choice([0.5, 0.6, 1.0], n)
    target_web = 0.6 + R.NUDGE_SLACK_MM
    candidates = R._pairs_within(xy, 2.0 * float(r.max()) + target_web + 1.0)
    active = rng.random(n) < 0.5
    for first in (True, False):
        a, b = xy.copy(), xy.copy()
        idx_a, before_a = R._sweep_pushes(a, r, target_web, candidates, active, first)
        idx_b, before_b = _numpy_sweep(b, r, target_web, candidates, active, first)
        assert np.array_equal(idx_a, idx_b)
        assert np.array_equal(before_a, before_b)
        assert a.tobytes() == b.tobytes()
