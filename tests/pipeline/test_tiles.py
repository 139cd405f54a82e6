"""A mural's plates compensated for the process across its seams, as a one-plate job's."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad import mural
from stencil_cad.config import io as cfg_io
from stencil_cad.errors import UserError
from stencil_cad.model import DotSet
from stencil_cad.pipeline import build
from stencil_cad.plan.names import build_outputs


def _grid(**stipple):
    cfg = cfg_io.parse_config(
        {
            "size": {"width_mm": 240, "height_mm": 150},
            "bed": [200, 180],
            "stipple": {"process": "fdm", **stipple},
        },
        "test",
    )
    grid = mural.plan_tiles(240, 150, cfg)
    assert len(grid.tiles) == 2
    return cfg, grid


def _seam_pairs(cfg, grid):
    """Holes at the floor radius in pairs across the seam, exactly one web apart, and one alone."""
    rules = cfg.stipple.design_rules(grid.width_mm, grid.height_mm)
    seam = grid.tiles[0].core[2]
    r, web = rules.hole_min_r_mm, rules.web_mm
    ys = np.arange(20.0, 130.0, 4 * r + 2 * web)
    left = np.column_stack([np.full(len(ys), seam - r - web / 2), ys])
    right = np.column_stack([np.full(len(ys), seam + r + web / 2), ys])
    xy = np.vstack([left, right, [[60.0, 75.0]]])
    return DotSet(xy_mm=xy, r_mm=np.full(len(xy), r), report={}), rules


def test_holes_at_a_seam_grow_and_keep_the_web_on_the_plates_as_made():
    cfg, grid = _grid()
    asked, rules = _seam_pairs(cfg, grid)
    offset = cfg.stipple.sizes.hole_offset_mm
    assert offset > 0
    (drawn,), (made,) = build.drawn_and_made(cfg, [asked], grid)
    # Each hole grows by the offset, the pairs across the seam too (their made web is the minimum).
    np.testing.assert_allclose(drawn.r_mm, asked.r_mm + offset)
    np.testing.assert_allclose(made.r_mm, asked.r_mm)
    mural.check_unions(cfg, grid, {"asked": [asked], "made": [made], "drawn": [drawn]})
    per_tile = mural.per_tile([drawn], grid)
    assert [len(t[0]) for t in per_tile] == [len(asked) // 2 + 1, len(asked) // 2]
    n = (len(asked) - 1) // 2
    gap = np.linalg.norm(drawn.xy_mm[:n] - drawn.xy_mm[n : 2 * n], axis=1) - 2 * drawn.r_mm[:n]
    np.testing.assert_allclose(gap, rules.web_mm - 2 * offset)


def test_without_compensation_the_plates_are_drawn_as_asked():
    cfg, grid = _grid(compensate=False)
    asked, _ = _seam_pairs(cfg, grid)
    (drawn,), (made,) = build.drawn_and_made(cfg, [asked], grid)
    assert drawn is asked
    np.testing.assert_allclose(made.r_mm, asked.r_mm - cfg.stipple.sizes.hole_offset_mm)


def test_a_web_broken_across_a_seam_is_refused():
    cfg, grid = _grid()
    asked, rules = _seam_pairs(cfg, grid)
    close = DotSet(
        xy_mm=asked.xy_mm + np.where(np.arange(len(asked))[:, None] < 5, [[0.05, 0.0]], 0.0),
        r_mm=asked.r_mm,
        report={},
    )
    with pytest.raises(UserError, match=r"layer 1 \(asked holes, all tiles in mural coordinates\)"):
        mural.check_unions(cfg, grid, {"asked": [close]})


def test_a_one_plate_job_is_the_one_by_one_tiling():
    # The build takes one path: on one tile the tiling names the parts as a one-plate job's,
    # cuts no sight notch, keeps the holes as they are and has no seam (no map, no seam check).
    cfg = cfg_io.parse_config({"size": {"width_mm": 100, "height_mm": 80}}, "test")
    grid = mural.TileGrid.whole(100.0, 80.0)
    (tile,) = grid.tiles
    assert mural.part_name(tile, grid) is None
    assert mural.sight_lines(tile) == ([], [])
    assert not mural.has_seams(grid) and not mural.label_band(tile)
    holes = DotSet(xy_mm=np.array([[50.0, 40.0]]), r_mm=np.array([1.0]), report={})
    assert mural.per_tile([holes], grid) == [[holes]]
    names = build_outputs(cfg, grid, 2)
    assert names[:4] == ["layer_01.step", "layer_01.stl", "layer_01.dxf", "layer_01.svg"]
    assert "mural_map.png" not in names and "wall.step" in names
    mural_cfg, tiled = _grid()
    assert mural.has_seams(tiled) and mural.part_name(tiled.tiles[0], tiled) == "A1"
    assert all(mural.sight_lines(t) == t.part_lines() for t in tiled.tiles)
    assert build_outputs(mural_cfg, tiled, 1)[-1] == "mural_map.png"
