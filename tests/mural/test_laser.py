"""A laser-cut mural's stand: a frame of stacked rings and spacer discs, checked and costed like plates."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad import mural
from stencil_cad.config import io as cfg_io
from stencil_cad.config.job import filled
from stencil_cad.mural import laser


def job(**data):
    """A laser mural's config with its plate values filled in as the config alone can tell."""
    return filled(
        cfg_io.parse_config(
            {"stipple": {"process": "laser"}, "view": {"distance_m": 3}, "bed": "xtool_s1", **data},
            source="test",
        )
    )[0]


@pytest.mark.parametrize(
    ("standoff", "want"), [(10.0, (5.0, 2)), (6.0, (6.0, 1)), (4.5, (1.5, 3)), (9.0, (3.0, 3))]
)
def test_frame_stock_makes_the_standoff_in_whole_sheets(standoff, want):
    assert laser.frame_stock(standoff) == want


def test_a_standoff_no_stock_makes_is_refused():
    with pytest.raises(ValueError, match="multiple"):
        laser.frame_stock(0.7)


def test_only_a_laser_mural_has_a_cut_stand():
    assert laser.laser_stand(job(size={"width_mm": 200}), mural.TileGrid.whole(200, 130)) is None
    fdm = cfg_io.parse_config({"stipple": {"process": "fdm"}, "bed": "prusa_mk4"}, source="test")
    assert laser.laser_stand(fdm, mural.plan_tiles(600, 400, fdm)) is None


def test_the_stand_of_a_laser_mural():
    cfg = job(size={"width_mm": 600, "height_mm": 400})
    grid = mural.plan_tiles(600, 400, cfg)
    assert grid.tiled
    parts = {p.name: p for p in laser.laser_stand(cfg, grid)}
    assert set(parts) == {"frame_base", "frame_top", "spacer"}
    base, top, spacer = parts["frame_base"], parts["frame_top"], parts["spacer"]
    assert (base.thickness_mm, base.count) == (5.0, 2)  # 10 mm stand-off
    assert top.count == 1 and top.thickness_mm == cfg.plate.thickness_mm
    # The top ring's pocket is larger than the base's opening: the plate rests on a ledge.
    pocket, opening = top.inner[0], base.inner[0]
    assert np.ptp(pocket[:, 0]) > np.ptp(opening[:, 0]) and np.ptp(pocket[:, 1]) > np.ptp(opening[:, 1])
    plan = mural.post_plan(cfg, grid)
    assert spacer.count == 2 * max(len(mural.posts.targets(*t.size, plan.pitch_mm)) for t in grid.tiles)
    assert spacer.circles[0, 2] == pytest.approx(plan.pin_hole_mm)
    assert spacer.cut_mm == pytest.approx(
        np.sum(np.linalg.norm(np.roll(spacer.outline, -1, axis=0) - spacer.outline, axis=1))
        + 2 * np.pi * plan.pin_hole_mm
    )
    for p in parts.values():
        got = laser.check_cut_part(p, (498.0, 319.0))
        assert got["ok"] and got["closed"] and got["inside"] and got["fits"]
    # Checked like a plate: too big for a small bed, a cut outside the outline.
    assert not laser.check_cut_part(base, (200.0, 200.0))["fits"]
    bad = laser.CutPart("spacer", 1, 5.0, spacer.outline, (), np.array([[10.0, 0.0, 1.0]]))
    assert not laser.check_cut_part(bad, None)["inside"]
    assert laser.sheets_needed(list(parts.values()), (498.0, 319.0)) == 3 + 1


def test_a_laser_murals_cost_has_no_printer_hours_and_counts_the_stand():
    cfg = job(size={"width_mm": 600, "height_mm": 400})
    grid = mural.plan_tiles(600, 400, cfg)
    made = mural.making_cost(grid, cfg, 3)
    kinds = [p.kind for p in made.parts]
    assert "wall" not in kinds and "posts" not in kinds
    assert {"frame_base", "frame_top", "spacer"} <= set(kinds)
    assert made.printer_hours == 0 and made.filament_g == 0
    assert made.sheets == 3 * len(grid.tiles) + 4
    assert made.cut_m == pytest.approx(sum(p.cut_m or 0 for p in made.parts), abs=0.05)
    assert made.cut_hours == pytest.approx(sum(p.cut_minutes or 0 for p in made.parts) / 60, rel=1e-3)
