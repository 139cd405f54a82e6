"""The dots preview (stencil_cad.simulate.previews): orientation, open area, empty and non-square plates."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stencil_cad.model import DotSet
from stencil_cad.simulate.previews import dots_preview


def test_preview_orientation_and_area():
    # One hole near the top-left corner of the picture (x small, y large).
    ds = DotSet(np.array([[5.0, 35.0], [30.0, 10.0]]), np.array([2.0, 3.0]))
    img = dots_preview(ds, 40.0, 40.0, px_per_mm=4)
    assert img.shape == (160, 160) and img.dtype == np.uint8
    assert img[20, 20] == 0  # (x=5, y=35) -> col 20, row 160 - 140 = 20
    assert img[120, 120] == 0  # (x=30, y=10) -> col 120, row 120
    assert img[0, 159] == 255
    open_area = (255 - img.astype(float)).sum() / 255 / 16  # mm^2
    assert open_area == pytest.approx(math.pi * (4 + 9), rel=0.01)


def test_preview_non_square_and_empty():
    img = dots_preview(DotSet(np.zeros((0, 2)), np.zeros(0)), 30.0, 10.0, px_per_mm=2)
    assert img.shape == (20, 60) and (img == 255).all()
