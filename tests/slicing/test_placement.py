"""A part lies on the bed the way it fits: as exported, or turned 90° (a portrait tile on a landscape bed)."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad import slicing as sl
from stencil_cad.cli import main
from stencil_cad.exchange.mesh import plate_mesh, read_stl, stl_bytes
from stencil_cad.geometry import mesh_genus
from stencil_cad.model import PlateGeometry

MK4 = (250.0, 210.0)


def portrait_plate(path, w: float = 180.6, h: float = 242.0, t: float = 1.2) -> int:
    """Write a ``w × h`` plate with a few holes (portrait: taller than the MK4 bed is deep); return its holes."""
    g = np.array([[30.0, 40.0], [90.0, 120.0], [150.0, 200.0], [40.0, 210.0]])
    geom = PlateGeometry(
        width_mm=w,
        height_mm=h,
        thickness_mm=t,
        outline=np.array([[0, 0], [w, 0], [w, h], [0, h]], float),
        circles_xy=g,
        circles_r=np.full(len(g), 2.0),
    )
    path.write_bytes(stl_bytes(plate_mesh(geom)))
    return len(g)


def test_place_turns_only_when_that_fits():
    assert sl.place((200, 180), MK4).rotate_deg == 0
    assert sl.place((180.6, 242.0), MK4).rotate_deg == 90
    assert sl.place((187.0, 248.4), MK4).rotate_deg == 90
    assert sl.place((250.0, 210.0), MK4).rotate_deg == 0
    lay = sl.place((260.0, 215.0), MK4)
    assert lay.rotate_deg is None and not lay.fits and "either way round" in lay.describe()
    assert "turned 90°" in sl.place((180.6, 242.0), MK4).describe()


def test_rotated_copy_swaps_the_footprint_and_keeps_the_mesh(tmp_path):
    src = tmp_path / "tall.stl"
    holes = portrait_plate(src)
    out = sl.rotated_copy(src, tmp_path / "turned.stl")
    a, b = read_stl(src).reshape(-1, 3), read_stl(out).reshape(-1, 3)
    np.testing.assert_allclose(np.ptp(b[:, :2], axis=0), np.ptp(a[:, :2], axis=0)[::-1], atol=1e-3)
    np.testing.assert_allclose(b[:, 2], a[:, 2])
    # Same centre on the bed, still one perforated shell with its holes, plate-down.
    np.testing.assert_allclose(
        b[:, :2].min(0) + np.ptp(b[:, :2], 0) / 2, a[:, :2].min(0) + np.ptp(a[:, :2], 0) / 2, atol=1e-3
    )
    assert mesh_genus(read_stl(out)) == holes
    w, h = sl.stl_footprint(out)
    assert sl.place((w, h), MK4).rotate_deg == 0


needs_prusa = pytest.mark.skipif(sl.find_slicer(sl.Slicer.PRUSA) is None, reason="prusa-slicer not installed")


@pytest.mark.slow
@needs_prusa
def test_slice_turns_a_portrait_plate_on_the_mk4_bed(tmp_path, capsys):
    stl = tmp_path / "tile_A1_layer_01.stl"
    portrait_plate(stl)
    assert main(["slice", "--bed", "prusa_mk4", str(stl)]) == 0
    said = capsys.readouterr().out
    assert "turned 90° to fit the bed" in said
    gcode = stl.with_suffix(".gcode")
    summary = sl.gcode_summary(gcode)
    assert summary["layers"] == 4 and summary["extrusion_moves"] > 100
    # Every extrusion lies on the 250 x 210 mm bed.
    xy = []
    for line in gcode.read_text().splitlines():
        if line.startswith("G1 ") and " E" in line and " X" in line and " Y" in line:
            parts = {p[0]: p[1:] for p in line.split(";")[0].split()[1:]}
            xy.append((float(parts["X"]), float(parts["Y"])))
    xy_a = np.array(xy)
    assert xy_a[:, 0].min() >= 0 and xy_a[:, 0].max() <= 250 and xy_a[:, 1].min() >= 0
    assert xy_a[:, 1].max() <= 210
    assert np.ptp(xy_a[:, 0]) > 230  # the plate's 242 mm side lies along the bed's 250 mm


def test_slice_still_refuses_a_part_too_big_either_way(tmp_path, capsys):
    stl = tmp_path / "big.stl"
    portrait_plate(stl, w=215.0, h=260.0)
    assert main(["slice", "--bed", "prusa_mk4", str(stl)]) == 2
    assert "either way round" in capsys.readouterr().err


def _manifest(process: str, size, bed=None, mode: str = "soft") -> dict:
    return {
        "config": {"mode": mode, "bed": bed, "stipple": {"process": process}, "plate": {"thickness_mm": 1.2}},
        "build": {
            "plates": [{"layer": 1, "bbox_mm": list(size), "hole_count": 800, "cut_length_mm": 6000.0}],
            "walls": [{"file": "wall.step", "bbox": [-16.2, -16.2, 0.0, 163.2, 163.2, 11.2]}],
        },
    }


def _job(process: str, size, bed=None, mode: str = "soft"):
    """The settings and build figures of :func:`_manifest`, as the sheet reads them."""
    from stencil_cad.figures import BuildFigures
    from stencil_cad.instructions import JobSettings

    m = _manifest(process, size, bed, mode)
    return JobSettings.from_json(m["config"]), BuildFigures.from_json(m["build"])


def test_print_advice_names_only_a_profile_the_part_fits():
    from stencil_cad.instructions import make as sheet_make

    big, big_build = _job("sla", (173.0, 173.0))
    (plate,) = sheet_make.plate_parts(big_build)
    text = sheet_make.part_advice(big, plate)
    assert (
        "too large for the prusa_sla vat (127 × 80 mm)" in text and "stencil-cad slice layer_01.stl" in text
    )
    assert "--profile prusa_sla" not in text
    # Its resin-designed webs are not sent to FDM as they are: the job is to be designed for FDM.
    assert "`stipple.process: fdm`" in text
    small, small_build = _job("sla", (75.0, 120.0))
    text = sheet_make.part_advice(small, sheet_make.plate_parts(small_build)[0])
    assert "--profile prusa_sla layer_01.stl" in text and "turned 90° to fit the vat" in text
    # The wall has its own line, on FDM whatever the plates' process.
    (wall,) = sheet_make.wall_parts(small_build)
    assert wall.size_mm == pytest.approx((179.4, 179.4))
    assert sheet_make.part_advice(small, wall).startswith("FDM: `stencil-cad slice wall.stl`")
    # A portrait tile on the job's MK4 bed: sliced with that bed, turned.
    tile, tile_build = _job("fdm", (187.0, 248.4), bed="prusa_mk4")
    text = sheet_make.part_advice(tile, sheet_make.plate_parts(tile_build)[0])
    assert "--bed prusa_mk4" in text and "turned 90°" in text


def test_laser_advice_gives_cut_length_and_time():
    from stencil_cad.instructions import make as sheet_make

    m, m_build = _job("laser", (120.0, 100.0), mode="hard")
    text = sheet_make.part_advice(m, sheet_make.plate_parts(m_build)[0])
    minutes = sheet_make.cut_seconds(6000.0, 801) / 60
    assert "cut-outs" in text and "cut length 6.00 m" in text and f"about {minutes:.0f} min" in text
