"""What making a job costs, before any CAD: the plates' and walls' printer-hours and filament, laser cuts, paint."""

from __future__ import annotations

import math

import numpy as np
import pytest

from stencil_cad import mural
from stencil_cad.config import io as cfg_io
from stencil_cad.config.job import filled, with_margin
from stencil_cad.figures import CostFigures, Figures
from stencil_cad.instructions import make
from stencil_cad.model import DotSet
from stencil_cad.mural import cost
from stencil_cad.outline import plate_outline, polygon_area


def job(**data):
    """A config with its plate values filled in as the config alone can tell (the plan fits them to the tiles)."""
    return filled(cfg_io.parse_config(data, source="test"))[0]


def _dots(rng, w, h, n, r=0.8):
    xy = np.column_stack([rng.uniform(5, w - 5, n), rng.uniform(5, h - 5, n)])
    return DotSet(xy_mm=xy, r_mm=np.full(n, r), spray_time=3.0)


def test_plate_spec_from_holes_is_outline_less_the_holes():
    cfg = job(size={"width_mm": 100, "height_mm": 80}, stipple={"process": "sla"})
    grid = mural.plan_tiles(100, 80, cfg)
    rng = np.random.default_rng(0)
    ds = [_dots(rng, 100, 80, 300), _dots(rng, 100, 80, 50)]
    specs = cost.plate_specs(grid, cfg, 2, ds)
    area = abs(polygon_area(plate_outline(100, 80, cfg.plate.outline)))
    assert [s.holes for s in specs] == [300, 50]
    p = specs[0]
    assert p.area_mm2 == pytest.approx(area)
    assert p.open_mm2 == pytest.approx(300 * math.pi * 0.8**2)
    assert p.edge_mm == pytest.approx(300 * 2 * math.pi * 0.8)
    assert p.plastic_mm3 == pytest.approx((area - p.open_mm2) * cfg.plate.thickness_mm)


def test_fdm_compensated_holes_are_drawn_larger():
    base = {"size": {"width_mm": 100, "height_mm": 80}}
    rng = np.random.default_rng(1)
    ds = [_dots(rng, 100, 80, 200)]
    asked = job(**base, stipple={"process": "fdm", "hole_offset_mm": 0.0})
    grown = job(**base, stipple={"process": "fdm", "hole_offset_mm": 0.1})
    a = cost.plate_specs(mural.plan_tiles(100, 80, asked), asked, 1, ds)[0]
    b = cost.plate_specs(mural.plan_tiles(100, 80, grown), grown, 1, ds)[0]
    assert b.open_mm2 == pytest.approx(200 * math.pi * 0.9**2)
    assert a.open_mm2 < b.open_mm2


def test_print_time_grows_with_plastic_and_hole_edge():
    p = cost.PlateSpec("", 1, 20_000.0, 600.0, 0.9, 1000, 2000.0, 5000.0)
    more_holes = cost.PlateSpec("", 1, 20_000.0, 600.0, 0.9, 2000, 2000.0, 10_000.0)
    thicker = cost.PlateSpec("", 1, 20_000.0, 600.0, 1.2, 1000, 2000.0, 5000.0)
    t, v = cost.plate_print(p)
    assert cost.plate_print(more_holes)[0] > t
    assert cost.plate_print(thicker)[0] > t and cost.plate_print(thicker)[1] == pytest.approx(v * 1.2 / 0.9)
    assert v == pytest.approx(cost.PLATE_FILAMENT * 18_000.0 * 0.9)
    assert p.layers == 3 and thicker.layers == 4
    # The fixed overhead alone for an empty plate.
    empty = cost.PlateSpec("", 1, 0.0, 0.0, 0.9, 0, 0.0, 0.0)
    assert cost.plate_print(empty) == (cost.FIXED_S, 0.0)


def test_example_sized_plate_matches_the_slicer_measurement():
    """The bundled example's plate 03 as measured (173 mm outline, 0.9 mm, 991 holes): 1 h 11 min, 10.8 m.

    PrusaSlicer 2.5 with the shipped profile (0.75 mm sheet lines; 1 h 31 min at the 0.45 mm of before).
    """
    # Its figures as the cost model read them from the run (outline area, open area, edge).
    spec = cost.PlateSpec("", 3, 28948.0, 680.0, 0.9, 991, 901.0, 3338.0)
    seconds, mm3 = cost.plate_print(spec)
    assert seconds / 3600 == pytest.approx(1.175, rel=0.06)
    assert mm3 / cost.FILAMENT_MM2 / 1000 == pytest.approx(10.76, rel=0.04)


def test_totals_are_the_sum_of_the_parts_and_grams_follow_the_volume():
    cfg = job(size={"width_mm": 400, "height_mm": 250}, bed="prusa_mk4", stipple={"process": "fdm"})
    grid = mural.plan_tiles(400, 250, cfg)
    assert grid.tiled
    rng = np.random.default_rng(2)
    ds = [_dots(rng, 400, 250, 4000), _dots(rng, 400, 250, 1500)]
    made = mural.making_cost(grid, cfg, 2, ds)
    plates = [p for p in made.parts if p.kind == "plate"]
    walls = [p for p in made.parts if p.kind == "wall"]
    # One wall serves every tile (all of one size and notches), the posts printed together.
    assert len(plates) == 2 * len(grid.tiles) and len(walls) == len(cfg.standoff.walls_mm)
    assert [p.layer for p in made.parts if p.kind == "posts"] == [mural.cost.post_count(grid, cfg)]
    # Every hole on exactly one plate of its layer.
    assert sum(p.holes for p in plates if p.layer == 1) == 4000
    assert sum(p.holes for p in plates if p.layer == 2) == 1500
    assert made.printer_hours == pytest.approx(sum(p.print_hours for p in made.parts), abs=1e-3)
    assert made.filament_g == pytest.approx(sum(p.filament_g for p in made.parts), abs=0.1)
    for p in made.parts:
        mm3 = p.filament_m * 1000 * cost.FILAMENT_MM2
        assert p.filament_g == pytest.approx(mm3 * 1.24e-3, rel=1e-3, abs=0.02)
    assert made.basis == "holes" and made.sheets is None
    assert made.area_m2 == pytest.approx(0.1)
    # Paint: the open area times the layer's passes at the documented coverage.
    first = made.paint[0]
    assert first.passes == 3.0
    assert first.cans == pytest.approx(first.open_m2 * 3.0 / cfg.paints.coverage_m2_per_can, rel=1e-3)


def test_plan_estimate_needs_no_holes_and_is_within_reach_of_the_placed_ones():
    cfg = job(size={"width_mm": 150, "height_mm": 150}, stipple={"process": "fdm"})
    grid = mural.plan_tiles(150, 150, cfg)
    plan = mural.making_cost(grid, cfg, 4)
    assert plan.basis == "plan" and len(plan.parts) == 5
    assert all(p.holes > 0 for p in plan.parts if p.kind == "plate")
    assert 4 < plan.printer_hours < 20


def test_filled_thickness_follows_the_tiles():
    """A thickness left to the process is chosen for the tiles' plates (thicker for bigger plates)."""
    small = cfg_io.parse_config({"size": {"width_mm": 100, "height_mm": 80}}, source="test")
    big = cfg_io.parse_config(
        {"size": {"width_mm": 600, "height_mm": 400}, "bed": "prusa_mk4"}, source="test"
    )
    a = cost.plate_specs(mural.plan_tiles(100, 80, small), filled(small, 100)[0], 1)[0]
    grid = mural.plan_tiles(600, 400, with_margin(big))
    side = max(max(mural.part_sizes(*t.size, with_margin(big))["plate"]) for t in grid.tiles)
    b = cost.plate_specs(grid, filled(big, side)[0], 1)[0]
    assert b.thickness_mm >= a.thickness_mm


def test_laser_plates_are_cut_not_printed():
    cfg = job(size={"width_mm": 100, "height_mm": 80}, stipple={"process": "laser"})
    grid = mural.plan_tiles(100, 80, cfg)
    rng = np.random.default_rng(3)
    ds = [_dots(rng, 100, 80, 100, r=1.0)]
    made = mural.making_cost(grid, cfg, 1, ds)
    plate = next(p for p in made.parts if p.kind == "plate")
    wall = next(p for p in made.parts if p.kind == "wall")
    assert plate.print_hours == 0 and plate.filament_g == 0 and wall.print_hours > 0
    spec = cost.plate_specs(grid, cfg, 1, ds)[0]
    cut_mm = spec.perimeter_mm + 100 * 2 * math.pi * 1.0
    assert plate.cut_m == pytest.approx(cut_mm / 1000, abs=1e-3)
    assert plate.cut_minutes == pytest.approx(cost.cut_seconds(cut_mm, 101) / 60, abs=0.01)
    assert made.sheets == 1 and made.cut_hours == pytest.approx(
        cost.cut_seconds(cut_mm, 101) / 3600, abs=1e-3
    )
    # The sheet's cut time is the same helper's.
    assert make.cut_seconds is cost.cut_seconds


def test_windows_are_open_area_on_the_tile_that_holds_them():
    cfg = job(size={"width_mm": 100, "height_mm": 80}, stipple={"process": "sla"})
    grid = mural.plan_tiles(100, 80, cfg)
    square = np.array([[10.0, 10.0], [30.0, 10.0], [30.0, 30.0], [10.0, 30.0]])
    ds = [DotSet(xy_mm=np.zeros((0, 2)), r_mm=np.zeros(0), windows=((square, ()),))]
    spec = cost.plate_specs(grid, cfg, 1, ds)[0]
    assert spec.open_mm2 == pytest.approx(400.0) and spec.edge_mm == pytest.approx(80.0) and spec.holes == 1


def test_cost_figures_read_back_and_show_on_the_sheet_and_summary():
    cfg = job(size={"width_mm": 150, "height_mm": 150}, stipple={"process": "fdm"})
    grid = mural.plan_tiles(150, 150, cfg)
    made = mural.making_cost(grid, cfg, 2, [_dots(np.random.default_rng(4), 150, 150, 500)] * 2)
    again = CostFigures.from_json(made.to_json())
    assert again == made
    f = Figures()
    f.cost = made
    back = Figures.from_json(f.to_json())
    assert back.cost == made and list(f.to_json()) == ["cost"]
    part = make.Part("plate", "layer_02", (173.0, 173.0), 500, layer=2)
    text = make.estimate_text(make.estimated_part(made, part))
    assert text.startswith("estimated ") and "g) of filament" in text
    assert "printer-hours" in make.cost_total_text(made) and "layer 2 paint " in make.cost_total_text(made)
    h_m2, kg_m2 = made.per_m2()
    assert h_m2 == pytest.approx(made.printer_hours / 0.0225) and kg_m2 == pytest.approx(
        made.filament_g / 1e3 / 0.0225
    )


def test_plan_line_says_the_printer_hours_and_filament():
    from stencil_cad.plan import tiles

    cfg = job(
        size={"width_mm": 600, "height_mm": 400},
        bed="prusa_mk4",
        stipple={"process": "fdm"},
        decompose={"layers": 3},
    )
    _, plan = tiles.plan(cfg, 600, 400, 1_000_000)
    line = tiles.plan_line(plan)
    assert "24 plates, 1 wall(s)" in line
    assert f"about {plan.cost['printer_hours']:.1f} printer-hours" in line and "g PLA" in line
    assert plan.cost["filament_g"] > 0
    # A mural keeps its wall; a one-plate job whose wall and thickness are left to it is told the
    # hours are for the process's wall (its trials may choose a lower wall and thicker plates).
    assert "process's wall" not in tiles.plan_line(plan, cfg)
    one = cfg_io.parse_config({"size": {"width_mm": 150}, "stipple": {"process": "fdm"}}, source="test")
    _, small = tiles.plan(job(size={"width_mm": 150}, stipple={"process": "fdm"}), 150, 150, 90_000)
    assert "for the process's wall" in tiles.plan_line(small, one)
    given = job(size={"width_mm": 150}, stipple={"process": "fdm"}, plate={"thickness_mm": 0.9})
    assert "process's wall" not in tiles.plan_line(tiles.plan(given, 150, 150, 90_000)[1], given)


def test_summary_says_the_cost_per_kind_and_the_slicers_total():
    from stencil_cad.figures import BuildFigures
    from stencil_cad.report import _cost_lines

    cfg = job(size={"width_mm": 150, "height_mm": 150}, stipple={"process": "fdm"})
    grid = mural.plan_tiles(150, 150, cfg)
    made = mural.making_cost(grid, cfg, 2, [_dots(np.random.default_rng(5), 150, 150, 400)] * 2)
    f = Figures()
    assert _cost_lines(f) == []
    f.cost = made
    lines = _cost_lines(f)
    assert lines[0].startswith("  to make   printer ") and "per m²" in lines[0]
    assert lines[1].startswith("  plates    2: ") and lines[2].startswith("  walls     1: ")
    assert lines[3].startswith("  paint     cans (open area × passes at 1.5 m² per coat): layer 1 ")
    f.build = BuildFigures.from_rows(
        [{"layer": 1, "print_hours": 1.5}, {"layer": 2, "print_hours": 1.25}], [{"print_hours": 1.0}]
    )
    assert _cost_lines(f)[-1] == "  slicer    PrusaSlicer's estimate: 3.8 h for the 3 part(s) it sliced"


def test_a_single_layer_plate_is_one_layer_and_a_known_printer_prints_faster():
    one = cost.PlateSpec("A1", 1, 30_000.0, 700.0, 0.3, 3000, 4000.0, 12_000.0)
    two = cost.PlateSpec("A1", 1, 30_000.0, 700.0, 0.4, 3000, 4000.0, 12_000.0)
    assert (one.layers, one.layer_mm) == (1, 0.3) and (two.layers, two.layer_mm) == (2, 0.2)
    assert cost.plate_print(one)[0] < cost.plate_print(two)[0]
    assert cost.plate_print(one)[1] == pytest.approx(cost.plate_print(two)[1] * 0.75)
    mk4 = cost.rates_for("prusa_mk4")
    assert (
        cost.rates_for(None)
        == cost.rates_for((250.0, 210.0))
        == cost.rates_for("prusa_xl")
        == cost.GENERIC_RATES
    )
    assert mk4 != cost.GENERIC_RATES and mk4.hole_mm_s == 170.0 and mk4.max_flow_mm3_s == 15.0
    assert cost.plate_print(two, mk4)[0] < cost.plate_print(two)[0]
    assert cost.plate_print(two, mk4)[1] == cost.plate_print(two)[1]
