"""The plate thickness filled in per process and plate size, and the label rule it keeps."""

import pytest

from stencil_cad.config import JobConfig
from stencil_cad.config.io import default_yaml, parse_config
from stencil_cad.config.job import filled, job_thickness, parse_overrides, with_thickness
from stencil_cad.config.stipple import Process
from stencil_cad.config.thickness import (
    LABEL_FLOOR_MM,
    SAG_LIMIT_FRACTION,
    fill_thickness,
    sag_mm,
)


def test_sag_follows_plate_theory():
    # Solid PLA, 150 mm square, 0.9 mm: 0.00406 q a^4 / D by hand is 0.092 mm; sag ~ a^4 / t^2.
    pla = Process.fdm.record.sheet
    assert sag_mm(150.0, 0.9, pla, perforated=False) == pytest.approx(0.092, abs=0.002)
    assert sag_mm(300.0, 0.9, pla, perforated=False) == pytest.approx(16 * sag_mm(150.0, 0.9, pla, False))
    assert sag_mm(150.0, 1.8, pla, perforated=False) == pytest.approx(sag_mm(150.0, 0.9, pla, False) / 4)
    assert sag_mm(150.0, 0.9, pla) > sag_mm(150.0, 0.9, pla, perforated=False)


@pytest.mark.parametrize(
    "process, side, want",
    [
        (Process.fdm, 100.0, 0.3),  # one layer: no label floor asked here
        (Process.fdm, 111.0, 0.3),
        (Process.fdm, 112.0, 0.4),
        (Process.fdm, 128.0, 0.4),
        (Process.fdm, 130.0, 0.6),
        (Process.fdm, 157.0, 0.6),
        (Process.fdm, 160.0, 0.9),
        (Process.fdm, 173.0, 0.9),  # the bundled example's plate
        (Process.fdm, 192.0, 0.9),
        (Process.fdm, 213.0, 1.2),
        (Process.fdm, 230.0, 1.5),
        (Process.fdm, 260.0, 1.8),
        (Process.fdm, 360.0, 3.3),
        (Process.sla, 120.0, 0.8),
        (Process.sla, 175.0, 1.0),
        (Process.laser, 150.0, 1.0),
        (Process.laser, 250.0, 2.0),
        (Process.laser, 280.0, 3.0),
    ],
)
def test_fill_is_the_thinnest_flat_plate(process, side, want):
    got = fill_thickness(process, side, process.record.standoff_mm)
    assert got.thickness_mm == pytest.approx(want)
    limit = SAG_LIMIT_FRACTION * process.record.standoff_mm
    sheet = process.record.sheet
    assert sag_mm(side, got.thickness_mm, sheet) <= limit
    thinner = [t for t in sheet.thicknesses_mm if t < got.thickness_mm]
    assert all(sag_mm(side, t, sheet) > limit for t in thinner)
    assert f"{side:.0f} mm side" in got.reason


def test_fdm_fills_whole_layers_of_the_shipped_profile():
    """Whole 0.3 mm layers of the profile, or the thinnest plate's two 0.2 mm layers (sliced as such)."""
    from stencil_cad.config.process import FDM_THIN_LAYER_MM, FDM_THIN_PLATE_MM
    from stencil_cad.slicing.profiles import PROFILES, THIN_PLATE_SETTINGS, part_settings

    layer = PROFILES["prusa_fdm"].layer_height_mm
    thin = 0
    for side in range(50, 400, 7):
        t = fill_thickness(Process.fdm, side, 15.0).thickness_mm
        if t == FDM_THIN_PLATE_MM:
            thin += 1
            assert t / FDM_THIN_LAYER_MM == pytest.approx(2)
            assert part_settings("prusa_fdm", "layer_01.stl", t) == THIN_PLATE_SETTINGS
        else:
            assert t / layer == pytest.approx(round(t / layer))
            assert part_settings("prusa_fdm", "layer_01.stl", t) == {}
    assert thin


def test_too_large_for_any_sheet_says_so():
    got = fill_thickness(Process.laser, 900.0, 10.0)
    assert got.thickness_mm == Process.laser.record.sheet.thicknesses_mm[-1]
    assert "thickest" in got.reason


@pytest.mark.parametrize("process", list(Process))
@pytest.mark.parametrize("width", [20.0, 150.0, 240.0, 400.0, 1000.0])
def test_every_filled_thickness_holds_the_default_label(process, width):
    cfg = parse_config({"stipple": {"process": process.value}, "size": {"width_mm": width}}, source="test")
    assert cfg.plate.thickness_mm is None and job_thickness(cfg).filled
    assert cfg.plate.label_depth_mm <= job_thickness(cfg).thickness_mm - LABEL_FLOOR_MM


def test_an_engraved_label_keeps_the_fdm_plate_at_two_layers():
    """A single 0.3 mm layer would leave no floor under the default 0.2 mm engraving."""
    assert fill_thickness(Process.fdm, 100.0, 10.0).thickness_mm == pytest.approx(0.3)
    assert fill_thickness(Process.fdm, 100.0, 10.0, 0.2 + LABEL_FLOOR_MM).thickness_mm == pytest.approx(0.4)


def test_a_deeper_label_raises_the_filled_thickness():
    cfg = filled(parse_config({"plate": {"label_depth_mm": 1.0}}, source="test"))[0]
    assert cfg.plate.thickness_mm == pytest.approx(1.2)  # 1.0 + the 0.2 mm floor in whole 0.3 mm layers
    assert "label" in job_thickness(parse_config({"plate": {"label_depth_mm": 1.0}}, source="test")).reason


def test_default_job_fills_in_by_the_picture_and_margins():
    cfg = JobConfig()
    assert cfg.plate.thickness_mm is None  # the config keeps null: the plan fills it in
    assert filled(cfg)[0].plate.thickness_mm == 0.9
    assert job_thickness(cfg).side_mm == pytest.approx(150.0 + 2 * filled(cfg)[0].plate.outline.margin_mm)
    tall = parse_config({"size": {"width_mm": 150.0, "height_mm": 300.0}}, source="test")
    assert filled(tall)[0].plate.thickness_mm == pytest.approx(2.7)  # 320 mm side
    # A mural's plates are tiles that fit the bed: the bed's side bounds the plate's.
    mural = parse_config({"size": {"width_mm": 1000.0}, "bed": "prusa_mini"}, source="test")
    assert job_thickness(mural).side_mm == pytest.approx(180.0)
    assert filled(mural)[0].plate.thickness_mm == 0.9


def test_explicit_thickness_is_kept():
    for t in (0.6, 1.2, 4.0):
        data = {"plate": {"thickness_mm": t, "label": "none"}, "size": {"width_mm": 1000.0}}
        cfg = parse_config(data, source="test")
        assert cfg.plate.thickness_mm == t
        assert not job_thickness(cfg).filled
        assert filled(cfg, 400.0)[0].plate.thickness_mm == t
        assert parse_overrides(cfg, bed="prusa_xl").plate.thickness_mm == t


def test_fit_to_the_planned_plates_and_overrides_fill_again():
    cfg = JobConfig()
    big, fill = filled(cfg, 310.0)
    assert big.plate.thickness_mm == pytest.approx(2.4)
    assert fill.side_mm == 310.0
    assert filled(cfg, 170.0)[0].plate.thickness_mm == 0.9
    # A filled value stays null in the config: a new bed fills it in again, not kept as if given.
    wide = parse_config({"size": {"width_mm": 1000.0}}, source="test")
    assert filled(wide)[0].plate.thickness_mm > 3.0
    assert parse_overrides(wide, bed="prusa_mini").plate.thickness_mm is None
    assert filled(parse_overrides(wide, bed="prusa_mini"))[0].plate.thickness_mm == 0.9


def test_template_leaves_the_thickness_to_the_process():
    text = default_yaml()
    assert "thickness_mm: null" in text


def test_a_plate_template_keeps_its_own_thickness(tmp_path):
    template = tmp_path / "my_plate.py"
    template.write_text("THICKNESS_MM = 2.0\n")
    cfg = JobConfig.model_validate({"plate": {"template": str(template)}})
    assert not cfg.fills_thickness and not job_thickness(cfg).filled
    assert "template" in job_thickness(cfg).reason
    # Filled in for the plan's readers, but not set: the template's THICKNESS_MM stands.
    planned = filled(cfg)[0]
    assert planned.plate.thickness_mm is not None
    assert "thickness_mm" not in planned.plate.model_fields_set


def test_a_plate_of_one_layer_keeps_the_wider_web_its_first_layer_prints():
    """A one-layer FDM plate is all first layer: 0.7 mm webs, given webs kept, the preset's on thicker plates."""
    one = Process.fdm.record.one_layer_web_mm
    preset = Process.fdm.record.web_mm
    assert one > preset
    mural = parse_overrides(parse_config({"size": {"width_mm": 600.0}}, source="test"), bed="prusa_mk4")
    assert mural.stipple.web_mm is None and mural.stipple.sizes.web_mm == preset
    thin = filled(mural, 90.0)[0]
    assert thin.plate.thickness_mm == pytest.approx(0.3)
    assert thin.stipple.sizes.web_mm == one
    assert thin.design_rules(100.0, 100.0).web_mm == one
    # Filled again for a thicker plate (the maker's web left null), the web follows.
    assert with_thickness(thin, job_thickness(mural, 400.0), web_left=True).stipple.sizes.web_mm == preset
    assert with_thickness(thin, job_thickness(mural, 400.0), web_left=False).stipple.sizes.web_mm == one
    # Given, on a plate of one layer too: kept; a given 0.3 mm plate gets the one-layer web.
    given = parse_config(
        {"stipple": {"web_mm": 0.6}, "plate": {"thickness_mm": 0.3, "label": "none"}}, source="test"
    )
    assert filled(given)[0].stipple.sizes.web_mm == 0.6
    one_layer = parse_config({"plate": {"thickness_mm": 0.3, "label": "none"}}, source="test")
    assert one_layer.stipple.web_mm is None  # the config keeps null: the plan fills it in
    assert filled(one_layer)[0].stipple.web_mm == one
    # SLA and thicker FDM plates keep their presets.
    sla = parse_config(
        {"stipple": {"process": "sla"}, "plate": {"thickness_mm": 0.3, "label": "none"}}, source="test"
    )
    assert filled(sla)[0].stipple.sizes.web_mm == Process.sla.record.web_mm
    assert JobConfig().stipple.sizes.web_mm == preset
