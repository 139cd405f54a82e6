"""The refinement's grid: as coarse as the holes' deposits allow, in whole pixels across the picture."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stencil_cad.api import load_config
from stencil_cad.model import Layers
from stencil_cad.plan.plan import painted, whole
from stencil_cad.plan.refinement import GRID_SLACK_PX, REFINE_PX_PER_SIGMA, exact_grid, refine_grid
from stencil_cad.simulate import spray
from stencil_cad.simulate.physical import SprayGeometry


@pytest.mark.parametrize(
    ("size_mm", "want"),
    [((150.0, 150.0), 0.398), ((106.5, 150.0), 0.398), ((97.3, 211.9), 0.41), ((300.0, 40.0), 0.9)],
)
def test_whole_pixels_span_the_picture_both_ways(size_mm, want):
    (rows, cols), px = exact_grid(size_mm, want, 0.25)
    assert 0.25 <= px <= want
    assert cols * px == pytest.approx(size_mm[1], abs=1e-9)
    assert abs(size_mm[0] / px - rows) <= GRID_SLACK_PX


def test_a_wanted_pixel_finer_than_the_simulations_keeps_the_simulation_grid():
    # The simulation's own grid, rounded as spray.sim_shape rounds it: the refinement as before.
    assert exact_grid((150.0, 150.0), 0.2, 0.25) == ((600, 600), 0.25)
    assert exact_grid((123.4, 150.0), 0.25, 0.25) == ((round(123.4 / 0.25), 600), 0.25)


def _layers(h_px: int, w_px: int, mm_per_px: float) -> Layers:
    alphas = np.zeros((2, h_px, w_px))
    return Layers(
        alphas=alphas,
        colours=np.array([[0.2, 0.2, 0.2], [0.8, 0.1, 0.1]]),
        primer=np.ones(3),
        mm_per_px=mm_per_px,
    )


def test_the_example_refines_on_pixels_of_its_deposits_sigma():
    cfg = load_config()
    layers = _layers(300, 300, 0.5)
    plan = painted(whole(cfg, (150.0, 150.0)), layers.colours)
    (rows, cols), px = refine_grid(plan, layers)
    geometry = SprayGeometry.for_job(plan.cfg)
    sigma = float(spray.hole_kernels(cfg.stipple.sizes.radius_mm, cfg.spray, 1.0, geometry=geometry)[0])
    # Coarser than the simulation's 0.25 mm, as fine as the rule asks, whole pixels across.
    assert 0.25 < px <= sigma / REFINE_PX_PER_SIGMA
    assert px > 0.9 * sigma / REFINE_PX_PER_SIGMA
    assert (rows, cols) == (math.ceil(150.0 / px - 1e-9), math.ceil(150.0 / px - 1e-9))


def test_a_narrow_deposit_keeps_the_simulation_grid():
    # A wall 1 mm high blurs the holes little: their deposits want pixels finer than 0.25 mm.
    cfg = load_config(overrides={"wall": {"standoff_mm": [1.0]}})
    layers = _layers(300, 300, 0.5)
    assert refine_grid(painted(whole(cfg, (150.0, 150.0)), layers.colours), layers) == ((600, 600), 0.25)
