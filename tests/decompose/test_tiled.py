"""The tiled decomposition of big pictures against the whole-picture solve."""

from dataclasses import replace

import numpy as np
import pytest
from skimage import data, transform

from stencil_cad.config.decompose import DecomposeConfig
from stencil_cad.decompose import decompose, tiled
from stencil_cad.model import Picture


@pytest.fixture(scope="module")
def photo():
    rgb = transform.resize(data.coffee() / 255.0, (256, 384), order=1, anti_aliasing=True)
    return Picture(rgb=np.clip(rgb, 0, 1), mm_per_px=1.0)


def _solve(picture, coarse, plan, cfg):
    return tiled.assemble(coarse, plan, map(tiled.solve_tile, tiled.tasks(picture, coarse, plan, cfg)), 1.0)


def test_plan_follows_size_and_memory():
    assert tiled.plan((1000, 1000), 4, 2e9) is None
    big = tiled.plan((5000, 8000), 4, 2e9)
    assert big.tile_px == 1024 and big.grid == (5, 8) and big.count == 40
    assert big.coarse_shape == (625, 1000) and big.factor == 8
    small = tiled.plan((5000, 8000), 4, 0.1e9)
    assert small.tile_px == 256 and tiled.tile_bytes(256, 4) <= 0.1e9
    cores = [c for _, c in big.windows()]
    covered = np.zeros((5000, 8000), dtype=np.int8)
    for r0, r1, c0, c1 in cores:
        covered[r0:r1, c0:c1] += 1
    assert (covered == 1).all()


def test_block_mean_matches_the_definition():
    rgb = np.random.default_rng(0).random((7, 10, 3))
    out = tiled.block_mean(rgb, 3)
    assert out.shape == (3, 4, 3)
    assert np.allclose(out[0, 0], rgb[:3, :3].mean(axis=(0, 1)))
    assert np.allclose(out[2, 3], rgb[6:, 9:].mean(axis=(0, 1)))


@pytest.mark.slow
def test_tiled_solve_matches_the_whole_solve(photo):
    """Stated tolerance, colours fixed: opacities differ by <= 0.005 on average (99th percentile
    <= 0.04) and the composites by <= 0.5 RMSE (0-255 units) between the tiled and the whole solve;
    end to end (colours from the small copy), the tiled composite's RMSE against the image is
    within 0.6 of the whole decomposition's."""
    cfg = DecomposeConfig(layers=4)
    plan = tiled.plan(photo.shape, 4, 1e12, tile_px=128, coarse_px=128, whole_max_px=0)
    assert plan.count == 6 and plan.factor == 3
    coarse = decompose(tiled.coarse_picture(photo, plan), cfg, np.random.default_rng(0))
    tiles = _solve(photo, coarse, plan, cfg)
    # The same opacity problem (colours fixed) solved on the whole picture as one tile.
    one = _solve(photo, coarse, replace(plan, tile_px=10**6, halo_px=0), cfg)
    d = np.abs(tiles.alphas.astype(np.float64) - one.alphas)
    assert d.mean() <= 0.005 and np.quantile(d, 0.99) <= 0.04
    comp_rmse = np.sqrt(np.mean((tiles.composite() - one.composite()) ** 2)) * 255
    assert comp_rmse <= 0.5
    assert tiles.info["tiled"]["tiles"] == 6
    # Against the image, the tiled result is as faithful as the whole decomposition.
    whole = decompose(photo, cfg, np.random.default_rng(0))
    assert tiles.info["rmse"] <= whole.info["rmse"] + 0.6
    direct = np.sqrt(np.mean((tiles.composite() - photo.rgb) ** 2)) * 255
    assert direct == pytest.approx(tiles.info["rmse"], rel=1e-4, abs=1e-3)


@pytest.mark.slow
def test_tile_results_do_not_depend_on_the_order_they_are_solved_in(photo):
    cfg = DecomposeConfig(layers=3)
    plan = tiled.plan(photo.shape, 3, 1e12, tile_px=128, coarse_px=128, whole_max_px=0)
    coarse = decompose(tiled.coarse_picture(photo, plan), cfg, np.random.default_rng(0))
    tasks = list(tiled.tasks(photo, coarse, plan, cfg))
    forward = tiled.assemble(coarse, plan, map(tiled.solve_tile, tasks), 1.0)
    backward = tiled.assemble(coarse, plan, map(tiled.solve_tile, tasks[::-1]), 1.0)
    assert forward.alphas.tobytes() == backward.alphas.tobytes()
