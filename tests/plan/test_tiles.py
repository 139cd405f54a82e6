"""The job's plan before any work: the plate thickness chosen again for the plates the tiling plans."""

import pytest

from stencil_cad.config.io import parse_config
from stencil_cad.plan.plan import planned


def test_a_tall_picture_gets_the_thickness_of_its_long_side():
    # The config knew only the width (the height follows the image): 170 mm, 0.9 mm.
    given = parse_config({}, source="test")
    assert given.plate.thickness_mm is None  # the config keeps null: the plan fills it in
    plan, _ = planned(given, (150.0, 300.0), 300 * 600)
    cfg = plan.cfg
    assert cfg.plate.thickness_mm == pytest.approx(2.7)  # a 323 mm plate (margins and key)
    assert given.plate.thickness_mm is None  # the maker's config is kept as given
    fig = plan.plate
    assert fig is not None
    assert fig.filled and fig.thickness_mm == cfg.plate.thickness_mm and fig.side_mm > 320.0
    assert fig.thickness_reason.startswith("2.7 mm: the thinnest fdm plate")


def test_a_given_thickness_is_built_as_given():
    plan, _ = planned(
        parse_config({"plate": {"thickness_mm": 1.2}}, source="test"), (150.0, 300.0), 300 * 600
    )
    assert plan.cfg.plate.thickness_mm == 1.2
    fig = plan.plate
    assert fig is not None and not fig.filled
    assert fig.thickness_reason == "1.2 mm, as plate.thickness_mm gives"
