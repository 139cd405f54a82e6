"""The build123d part classes: a plate and the wall composed in a BuildPart context."""

import numpy as np
import pytest

from stencil_cad.config import JobConfig
from stencil_cad.config.job import filled
from stencil_cad.model import DotSet

pytestmark = pytest.mark.slow


def _dots(w, h, pitch=5.0, r=1.0, margin=4.0):
    xs = np.arange(margin + r, w - margin - r + 1e-9, pitch)
    ys = np.arange(margin + r, h - margin - r + 1e-9, pitch)
    xy = np.array([(x, y) for x in xs for y in ys])
    return DotSet(xy_mm=xy, r_mm=np.full(len(xy), r))


def test_stencil_plate_in_buildpart_sits_in_the_wall_without_overlap():
    import build123d as bd

    from stencil_cad.cad.parts import StencilPlate, Wall

    cfg = filled(JobConfig())[0]  # the plate's thickness as a job of this config fills it in
    w, h = 60.0, 50.0
    dots = _dots(w, h)
    plate = StencilPlate(dots, w, h, cfg.plate)
    assert plate.hole_count == len(dots)
    assert sum(s.volume for s in plate.solids()) == pytest.approx(plate.analytic_volume, rel=1e-6)
    standoff = 10.0
    with bd.BuildPart() as job:
        Wall(w, h, cfg.plate.outline, cfg.wall, cfg.plate.thickness_mm, standoff)
    wall = job.part
    # The plate lifted to the stand-off rests on the ledge: no shared volume with the wall.
    lifted = plate.moved(bd.Location((0, 0, standoff)))
    common = lifted.intersect(wall)
    overlap = 0.0 if common is None else sum(s.volume for s in common.solids())
    assert overlap == pytest.approx(0.0, abs=1e-6)
    # Pushed 0.05 mm down into the ledge it does overlap: the test can fail.
    sunk = plate.moved(bd.Location((0, 0, standoff - 0.05)))
    common = sunk.intersect(wall)
    assert sum(s.volume for s in common.solids()) > 1.0
