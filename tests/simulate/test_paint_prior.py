"""The deposit prior of an unmeasured can follows its paint: light paints hide in more passes."""

import numpy as np
import pytest

from stencil_cad.config.io import parse_config
from stencil_cad.plan.profiles import layer_sprays
from stencil_cad.simulate.cans import DARK_DEPOSIT, LIGHT_DEPOSIT, deposit_prior


def test_dark_paints_hide_in_two_coats_light_ones_need_more():
    assert deposit_prior([0.0, 0.0, 0.0]) == DARK_DEPOSIT
    assert deposit_prior([0.0, 0.18, 1.0]) == DARK_DEPOSIT  # a strong blue
    assert deposit_prior([1.0, 1.0, 1.0]) == LIGHT_DEPOSIT
    assert deposit_prior([1.0, 1.0, 0.0]) == LIGHT_DEPOSIT  # yellow
    amber = deposit_prior([0.93, 0.72, 0.0])
    assert LIGHT_DEPOSIT < amber < DARK_DEPOSIT
    # Two passes of a dark paint cover 95 %, three of white over 90 %.
    assert 1 - np.exp(-2 * DARK_DEPOSIT) == pytest.approx(0.95, abs=0.01)
    assert 1 - np.exp(-3 * LIGHT_DEPOSIT) > 0.9


def test_each_unmeasured_layer_takes_its_paints_prior_and_a_given_deposit_stands():
    colours = np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 1.0]])
    dark, white = layer_sprays(parse_config({}, source="test"), colours)[0]
    assert dark.can.deposit_per_pass == DARK_DEPOSIT
    assert white.can.deposit_per_pass == LIGHT_DEPOSIT
    assert white.can.spread_k == dark.can.spread_k  # only the deposit follows the paint
    given = parse_config({"spray": {"can": {"deposit_per_pass": 2.0}}}, source="test")
    assert [s.can.deposit_per_pass for s in layer_sprays(given, colours)[0]] == [2.0, 2.0]
    paper = parse_config({"spray": {"model": "paper"}}, source="test")
    assert all(s is paper.spray for s in layer_sprays(paper, colours)[0])
