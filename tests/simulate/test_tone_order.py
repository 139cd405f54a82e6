"""The tone calibration's shortcuts give the same bits as the plain computation."""

from __future__ import annotations

import numpy as np

from stencil_cad.config.spray import SprayConfig
from stencil_cad.simulate import tone
from stencil_cad.simulate.physical import SprayGeometry
from stencil_cad.simulate.tone_order import OrderedOpacities


def _curve() -> tone.ToneCurve:
    t = tone._T_SAMPLES.copy()
    mean = np.maximum.accumulate(0.9 * np.sqrt(t))
    return tone.ToneCurve(t=t, mean=mean, var=0.01 * mean * (1.0 - mean), spray_time=1.0)


def test_ordered_scores_are_the_raster_scores_bit_for_bit():
    rng = np.random.default_rng(3)
    # Runs and repeats, as a picture's opacities have them.
    flat = np.repeat(rng.random(3_000), rng.integers(1, 6, 3_000))
    w = rng.random(flat.size)
    c = _curve()
    for weight, threshold in ((None, 0.0), (w, 0.05), (np.zeros_like(w), 0.2)):
        ordered = OrderedOpacities.of(flat, weight, threshold)
        allowed = flat >= threshold
        t = np.where(allowed, c.inverse(flat), 0.0)
        want = c.predicted_mse(flat, t, weight)
        assert ordered.mse(c, c.inverse(ordered.alpha), weighted=True) == want
        assert ordered.mse(c, c.inverse(ordered.alpha)) == c.predicted_mse(flat, t)


def test_cans_differing_in_deposit_share_their_response_patches():
    g = SprayGeometry(standoff_mm=6.0, plate_thickness_mm=0.9)
    base = SprayConfig(model="physical")
    other = base.model_copy(update={"can": base.can.model_copy(update={"deposit_per_pass": 0.85})})
    first = tone.tone_response(0.5, 0.6, other, spray_time=2.0, max_radius_mm=0.8, geometry=g)
    tone._response.cache_clear()
    tone._dose_patches.cache_clear()
    tone.tone_response(0.5, 0.6, base, spray_time=2.0, max_radius_mm=0.8, geometry=g)
    again = tone.tone_response(0.5, 0.6, other, spray_time=2.0, max_radius_mm=0.8, geometry=g)
    assert tone._dose_patches.cache_info().misses == 1
    assert np.array_equal(first.mean, again.mean) and np.array_equal(first.var, again.var)
