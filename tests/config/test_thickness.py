"""The plate thickness filled in per process and plate size, and the label rule it keeps."""

import pytest

from stencil_cad.config import JobConfig
from stencil_cad.config.io import default_yaml, parse_config
from stencil_cad.config.job import parse_overrides
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
    assert cfg.thickness_fill.filled
    assert cfg.plate.label_depth_mm <= cfg.plate.thickness_mm - LABEL_FLOOR_MM


def test_an_engraved_label_keeps_the_fdm_plate_at_two_layers():
    """A single 0.3 mm layer would leave no floor under the default 0.2 mm engraving."""
    assert fill_thickness(Process.fdm, 100.0, 10.0).thickness_mm == pytest.approx(0.3)
    assert fill_thickness(Process.fdm, 100.0, 10.0, 0.2 + LABEL_FLOOR_MM).thickness_mm == pytest.approx(0.4)


def test_a_deeper_label_raises_the_filled_thickness():
    cfg = parse_config({"plate": {"label_depth_mm": 1.0}}, source="test")
    assert cfg.plate.thickness_mm == pytest.approx(1.2)  # 1.0 + the 0.2 mm floor in whole 0.3 mm layers
    assert "label" in cfg.thickness_fill.reason


def test_default_job_fills_in_by_the_picture_and_margins():
    cfg = JobConfig()
    assert cfg.plate.thickness_mm == 0.9
    assert cfg.thickness_fill.side_mm == pytest.approx(150.0 + 2 * cfg.plate.outline.margin_mm)
    tall = parse_config({"size": {"width_mm": 150.0, "height_mm": 300.0}}, source="test")
    assert tall.plate.thickness_mm == pytest.approx(2.7)  # 320 mm side
    # A mural's plates are tiles that fit the bed: the bed's side bounds the plate's.
    mural = parse_config({"size": {"width_mm": 1000.0}, "bed": "prusa_mini"}, source="test")
    assert mural.thickness_fill.side_mm == pytest.approx(180.0)
    assert mural.plate.thickness_mm == 0.9


def test_explicit_thickness_is_kept():
    for t in (0.6, 1.2, 4.0):
        data = {"plate": {"thickness_mm": t, "label": "none"}, "size": {"width_mm": 1000.0}}
        cfg = parse_config(data, source="test")
        assert cfg.plate.thickness_mm == t
        assert not cfg.thickness_fill.filled
        assert cfg.fit_plate_thickness(400.0) is cfg
        assert parse_overrides(cfg, bed="prusa_xl").plate.thickness_mm == t


def test_fit_to_the_planned_plates_and_overrides_fill_again():
    cfg = JobConfig()
    big = cfg.fit_plate_thickness(310.0)
    assert big.plate.thickness_mm == pytest.approx(2.4)
    assert big.thickness_fill.side_mm == 310.0
    assert big.fit_plate_thickness(170.0).plate.thickness_mm == 0.9
    # A filled value is filled again for the new bed, not kept as if given.
    wide = parse_config({"size": {"width_mm": 1000.0}}, source="test")
    assert wide.plate.thickness_mm > 3.0
    assert parse_overrides(wide, bed="prusa_mini").plate.thickness_mm == 0.9


def test_template_leaves_the_thickness_to_the_process():
    text = default_yaml()
    assert "thickness_mm: null" in text


def test_a_plate_template_keeps_its_own_thickness(tmp_path):
    template = tmp_path / "my_plate.py"
    template.write_text("THICKNESS_MM = 2.0\n")
    cfg = JobConfig.model_validate({"plate": {"template": str(template)}})
    assert "thickness_mm" not in cfg.plate.model_fields_set  # the template's THICKNESS_MM stands
    assert not cfg.thickness_fill.filled
    assert "template" in cfg.thickness_fill.reason


def test_a_plate_of_one_layer_keeps_the_wider_web_its_first_layer_prints():
    """A one-layer FDM plate is all first layer: 0.7 mm webs, given webs kept, the preset's on thicker plates."""
    one = Process.fdm.record.one_layer_web_mm
    preset = Process.fdm.record.web_mm
    assert one > preset
    mural = parse_overrides(parse_config({"size": {"width_mm": 600.0}}, source="test"), bed="prusa_mk4")
    assert mural.stipple.resolved_web_mm == preset  # its plates are not one layer until fitted to the posts
    thin = mural.fit_plate_thickness(90.0)
    assert thin.plate.thickness_mm == pytest.approx(0.3)
    assert thin.stipple.resolved_web_mm == one
    assert thin.design_rules(100.0, 100.0).web_mm == one
    # Fitted again to a thicker plate, the filled web follows; a new bed fills both in again.
    assert thin.fit_plate_thickness(400.0).stipple.resolved_web_mm == preset
    assert parse_overrides(thin, seed=2).stipple.resolved_web_mm == preset
    # Given, on a plate of one layer too: kept; a given 0.3 mm plate gets the one-layer web.
    given = parse_config(
        {"stipple": {"web_mm": 0.6}, "plate": {"thickness_mm": 0.3, "label": "none"}}, source="test"
    )
    assert given.stipple.resolved_web_mm == 0.6
    assert (
        parse_config({"plate": {"thickness_mm": 0.3, "label": "none"}}, source="test").stipple.web_mm == one
    )
    # SLA and thicker FDM plates keep their presets.
    sla = parse_config(
        {"stipple": {"process": "sla"}, "plate": {"thickness_mm": 0.3, "label": "none"}}, source="test"
    )
    assert sla.stipple.resolved_web_mm == Process.sla.record.web_mm
    assert JobConfig().stipple.resolved_web_mm == preset
