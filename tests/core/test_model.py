"""The composite of the layers: over the primer in order, each step's picture the same bits."""

import numpy as np
import pytest

from stencil_cad.model import composite, composites


def _over(primer, colours, alphas):
    """The composite over the interleaved picture, layer by layer (the definition)."""
    out = np.empty((*alphas.shape[1:], 3))
    out[...] = primer
    for colour, a in zip(colours, alphas, strict=True):
        out *= 1.0 - a[..., None]
        out += a[..., None] * colour
    return out


@pytest.mark.parametrize("dtype", [np.float64, np.float32])
def test_composite_and_each_step_are_the_same_bits_as_the_layers_over_the_primer(dtype):
    rng = np.random.default_rng(3)
    primer, colours, alphas = rng.random(3), rng.random((5, 3)), rng.random((5, 17, 23)).astype(dtype)
    whole = composite(primer, colours, alphas)
    assert whole.flags.c_contiguous and whole.shape == (17, 23, 3)
    np.testing.assert_array_equal(whole, _over(primer, colours, alphas))
    steps = list(composites(primer, colours, alphas))
    assert len(steps) == 5
    for i, step in enumerate(steps):
        np.testing.assert_array_equal(step, _over(primer, colours[: i + 1], alphas[: i + 1]))


def test_no_layer_is_the_primer():
    out = composite(np.array([0.1, 0.2, 0.3]), np.zeros((0, 3)), np.zeros((0, 4, 5)))
    assert out.shape == (4, 5, 3)
    np.testing.assert_array_equal(out, np.broadcast_to([0.1, 0.2, 0.3], (4, 5, 3)))
