"""A mostly dark picture is primed with its dark colour, the light parts sprayed over it."""

import numpy as np

from stencil_cad.config.io import parse_config
from stencil_cad.model import Picture
from stencil_cad.plan.primer import DARK_MIN_DELTA_E, DARK_SHARE, dark_primed, dark_primer


def _picture(dark_share: float) -> Picture:
    rgb = np.full((100, 100, 3), 0.8)
    rows = int(round(100 * dark_share))
    rgb[:rows] = (0.02, 0.03, 0.05)
    rgb[:rows, ::10] = (0.9, 0.9, 1.0)  # bright sources in the dark part
    return Picture(rgb=rgb, mm_per_px=0.5)


def test_only_a_mostly_dark_picture_gets_its_dark_colour_as_primer():
    assert dark_primer(_picture(DARK_SHARE - 0.1)) is None
    assert dark_primer(_picture(0.7)) == "#05080d"


def test_the_job_names_the_primer_unless_the_config_chose_one():
    cfg = parse_config({}, source="test")
    primed, hex_code = dark_primed(cfg, _picture(0.7))
    assert hex_code == "#05080d"
    assert primed.decompose.primer_rgb() is not None and cfg.decompose.primer_rgb() is None
    for given in ({"primer": "#ffffff"}, {"palette": ["#ff0000", "#00ff00", "#0000ff", "#ffffff"]}):
        cfg = parse_config({"decompose": given}, source="test")
        assert dark_primed(cfg, _picture(0.7)) == (cfg, None)


def test_a_dark_primer_keeps_paints_further_from_it_unless_the_config_says():
    primed, _ = dark_primed(parse_config({}, source="test"), _picture(0.7))
    assert primed.decompose.min_delta_e == DARK_MIN_DELTA_E
    cfg = parse_config({"decompose": {"min_delta_e": 1.0}}, source="test")
    assert dark_primed(cfg, _picture(0.7))[0].decompose.min_delta_e == 1.0
    cfg = parse_config({}, source="test")
    assert dark_primed(cfg, _picture(DARK_SHARE - 0.1))[0].decompose.min_delta_e == 2.0
