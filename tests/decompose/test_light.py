"""Light plates: each paint split into a light and a dark plate that together spray the layer."""

import numpy as np
import pytest

from stencil_cad.config.io import parse_config
from stencil_cad.decompose.light import LIGHT_BELOW, light_plates, paint_of_plates
from stencil_cad.model import Layers
from stencil_cad.mural import light_plates_on, plate_layers


def _layers(seed=0, count=3, shape=(20, 30)):
    rng = np.random.default_rng(seed)
    return Layers(
        primer=np.array([0.05, 0.05, 0.05]),
        colours=rng.uniform(0, 1, (count, 3)),
        alphas=rng.uniform(0, 1, (count, *shape)) ** 2,
        mm_per_px=0.5,
    )


def test_the_two_plates_of_a_paint_spray_its_layer():
    layers = _layers()
    split = light_plates(layers)
    assert split.count == 2 * layers.count
    np.testing.assert_allclose(split.composite(), layers.composite(), atol=1e-12)
    light, dark = split.alphas[0::2], split.alphas[1::2]
    assert light.max() <= LIGHT_BELOW
    # The dark plate sprays nothing where the light plate carries the whole opacity.
    assert np.all(dark[layers.alphas <= LIGHT_BELOW] == 0.0)
    np.testing.assert_allclose(1 - (1 - light) * (1 - dark), layers.alphas, atol=1e-12)
    assert paint_of_plates(split.colours) == [0, 0, 1, 1, 2, 2]
    assert split.info["light_plates"] == LIGHT_BELOW


def test_a_paint_with_nothing_above_the_light_range_keeps_one_plate():
    layers = _layers()
    layers.alphas[1] = np.minimum(layers.alphas[1], 0.3)
    split = light_plates(layers)
    assert split.count == 5
    assert paint_of_plates(split.colours) == [0, 0, 1, 2, 2]
    np.testing.assert_allclose(split.composite(), layers.composite(), atol=1e-12)


def test_layers_are_split_once_and_the_light_range_is_checked():
    split = light_plates(_layers())
    with pytest.raises(ValueError, match="already"):
        light_plates(split)
    with pytest.raises(ValueError, match=r"\(0, 1\)"):
        light_plates(_layers(), below=1.0)


@pytest.mark.parametrize(
    ("data", "tiled", "plates"),
    [
        ({}, False, 8),  # the default: a one-plate job has light plates
        ({}, True, 4),  # a mural does not (its printer-hours)
        ({"stipple": {"light_plates": "on"}}, True, 8),
        ({"stipple": {"light_plates": False}}, False, 4),  # YAML's unquoted off
        ({"spray": {"model": "paper"}}, False, 4),
        ({"mode": "hard", "hard": {"colours": 4}}, False, 3),
    ],
)
def test_which_jobs_get_light_plates(data, tiled, plates):
    cfg = parse_config(data, source="test")
    assert plate_layers(cfg, tiled) == plates
    assert light_plates_on(cfg, tiled) == (plates == 8)
