"""Slicer helpers: command lines, message parsing, tiling; slow tests run the real slicers."""

from __future__ import annotations

import configparser
import json
import zipfile
from pathlib import Path

import numpy as np
import pytest

from stencil_cad import slicing as sl
from stencil_cad.exchange.mesh import plate_mesh, read_stl, stl_bytes, write_triangles_stl
from stencil_cad.geometry import mesh_genus
from stencil_cad.model import PlateGeometry

# ----------------------------------------------------------------------------- helpers


def square_ring_plate(
    outer: float = 3.0, inner: tuple[float, float] = (1.0, 2.0), t: float = 1.2
) -> np.ndarray:
    """A square plate with one square hole (a torus, genus 1) as (32, 3, 3) outward-facing triangles."""
    o = np.array([[0, 0], [outer, 0], [outer, outer], [0, outer]], float)
    a, b = inner
    i = np.array([[a, a], [b, a], [b, b], [a, b]], float)
    tris = []

    def p(xy, z):
        return [xy[0], xy[1], z]

    for k in range(4):
        k1 = (k + 1) % 4
        # top (z = t, normal +z) and bottom (z = 0, normal -z) of the annulus quad
        tris += [[p(o[k], t), p(o[k1], t), p(i[k1], t)], [p(o[k], t), p(i[k1], t), p(i[k], t)]]
        tris += [[p(o[k], 0), p(i[k1], 0), p(o[k1], 0)], [p(o[k], 0), p(i[k], 0), p(i[k1], 0)]]
        # outer wall faces out, inner wall faces into the hole
        tris += [[p(o[k], 0), p(o[k1], 0), p(o[k1], t)], [p(o[k], 0), p(o[k1], t), p(o[k], t)]]
        tris += [[p(i[k], 0), p(i[k], t), p(i[k1], t)], [p(i[k], 0), p(i[k1], t), p(i[k1], 0)]]
    return np.asarray(tris, float)


def signed_volume(tri: np.ndarray) -> float:
    return float(np.einsum("ij,ij->i", tri[:, 0], np.cross(tri[:, 1], tri[:, 2])).sum() / 6.0)


def small_plate(path: Path, n_side: int = 5, r: float = 1.0, pitch: float = 3.0, t: float = 1.2):
    """Write an exported n_side² hole plate with the project's own mesher; return (holes, volume)."""
    margin = 3.0
    g = np.arange(n_side) * pitch + margin + r
    xy = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    w = h = float(g[-1] + r + margin)
    geom = PlateGeometry(
        width_mm=w,
        height_mm=h,
        thickness_mm=t,
        outline=np.array([[0, 0], [w, 0], [w, h], [0, h]], float),
        circles_xy=xy,
        circles_r=np.full(len(xy), r),
    )
    mesh = plate_mesh(geom)
    path.write_bytes(stl_bytes(mesh))
    return len(xy), geom.volume, (w, h, t)


# ----------------------------------------------------------------------------- fast tests


def test_profiles_exist_and_parse():
    for name, prof in sl.PROFILES.items():
        assert prof.path.is_file(), name
        text = prof.path.read_text()
        if prof.filename.endswith(".ini"):
            cfg = configparser.ConfigParser(interpolation=None, strict=True)
            cfg.read_string("[p]\n" + text)
            keys = cfg["p"]
            assert float(keys["layer_height"]) == pytest.approx(prof.layer_height_mm)
        else:
            data = json.loads(text)
            assert data["inherits"] == "fdmprinter"
            assert data["overrides"]["layer_height"]["default_value"] == pytest.approx(prof.layer_height_mm)


def test_fdm_profile_has_the_speed_settings():
    cfg = configparser.ConfigParser(interpolation=None)
    cfg.read_string("[p]\n" + sl.PROFILES["prusa_fdm"].path.read_text())
    p = cfg["p"]
    # The settings measured to remove PrusaSlicer's per-hole superlinear work.
    assert p["perimeter_generator"] == "arachne"  # fills the small triangles between holes
    assert p["overhangs"] == "0"
    assert p["seam_position"] == "rear"
    assert p["top_fill_pattern"] == p["bottom_fill_pattern"] == "rectilinear"
    sla = configparser.ConfigParser(interpolation=None)
    sla.read_string("[p]\n" + sl.PROFILES["prusa_sla"].path.read_text())
    assert sla["p"]["printer_technology"] == "SLA"
    assert sla["p"]["supports_enable"] == "0" and sla["p"]["pad_enable"] == "0"


def test_unknown_profile_names_the_choices():
    with pytest.raises(ValueError, match="prusa_fdm"):
        sl.get_profile("nope")


def test_build_command_prusa_fdm_and_sla():
    cmd = sl.build_command("p.stl", "p.gcode", "prusa_fdm", executable="/x/prusa-slicer")
    assert cmd[:2] == ["/x/prusa-slicer", "--export-gcode"]
    assert cmd[cmd.index("--load") + 1] == str(sl.PROFILES["prusa_fdm"].path)
    assert cmd[-3:] == ["--output", "p.gcode", "p.stl"]
    cmd = sl.build_command("p.stl", "p.sl1", "prusa_sla", executable="ps", overrides={"display_width": 200})
    assert cmd[1] == "--export-sla" and "--display-width=200" in cmd


def test_build_command_tiles_keep_positions_and_centre_on_bed():
    cmd = sl.build_command(["a.stl", "b.stl"], "p.gcode", "prusa_fdm", executable="ps")
    assert "--merge" in cmd and "--dont-arrange" in cmd
    assert "--center=125,105" in cmd  # the 250 x 210 mm bed of prusa_fdm.ini
    assert cmd[-2:] == ["a.stl", "b.stl"]
    cmd = sl.build_command(
        ["a.stl", "b.stl"],
        "p.gcode",
        "prusa_fdm",
        executable="ps",
        overrides={"bed_shape": "0x0,400x0,400x300,0x300"},
    )
    assert "--center=200,150" in cmd


def test_build_command_cura():
    cmd = sl.build_command("a.stl", "p.gcode", "cura_fdm", executable="CE", overrides={"machine_width": 300})
    assert cmd[:2] == ["CE", "slice"]
    assert cmd[cmd.index("-j") + 1] == str(sl.PROFILES["cura_fdm"].path)
    assert ["-s", "machine_width=300"] == cmd[cmd.index("-s") : cmd.index("-s") + 2]
    assert cmd[-4:] == ["-o", "p.gcode", "-l", "a.stl"]
    with pytest.raises(ValueError, match="PrusaSlicer"):
        sl.build_command(["a.stl", "b.stl"], "p.gcode", "cura_fdm", executable="CE")


def test_parse_messages_prusa_and_cura():
    text = "\n".join(
        [
            "[2026-11-22 08:10:29.008990] [0x00007f91fa6d4d80] [trace]   Initializing StaticPrintConfigs",
            "[2026-11-22 08:10:30.184349] [0x00007f58] [error]   stl_open_count_facets: The input is an empty file",
            "[2026-11-22 08:10:30.184349] [0x00007f58] [warning]   Detected print stability issues",
            " 30% => Generating perimeters",
            "Slicing result exported to /tmp/x.gcode",
            "empty.stl: Loading of a model file failed.",
            "[ERROR] Couldn't find definition file with ID: fdmprinter",
            "[WARNING] Unrecognized setting foo",
        ]
    )
    errors, warnings = sl.parse_messages(text)
    assert errors == [
        "stl_open_count_facets: The input is an empty file",
        "empty.stl: Loading of a model file failed.",
        "Couldn't find definition file with ID: fdmprinter",
    ]
    assert warnings == ["Detected print stability issues", "Unrecognized setting foo"]
    # A failed run's bare reason (config validation) is an error even without an error word.
    errors, _ = sl.parse_messages(
        "Relative extruder addressing requires resetting the extruder", returncode=1
    )
    assert errors == ["Relative extruder addressing requires resetting the extruder"]
    assert sl.parse_messages("Slicing result exported to x", returncode=0) == ([], [])


def test_parse_info():
    text = "[p.stl]\nsize_x = 54.2\nsize_y = 42.0\nsize_z = 1.2\nnumber_of_facets = 25012\nmanifold = no\nopen_edges = 6\nnumber_of_parts =  2\nvolume = 1800.5\n"
    info = sl.parse_info(text)
    assert info.facets == 25012 and not info.manifold and info.open_edges == 6 and info.parts == 2
    assert info.size_mm == (54.2, 42.0, 1.2) and info.volume_mm3 == pytest.approx(1800.5)
    with pytest.raises(ValueError):
        sl.parse_info("nothing here")


def test_genus_of_torus_and_box(tmp_path):
    ring = square_ring_plate()
    assert signed_volume(ring) == pytest.approx((9 - 1) * 1.2)
    assert mesh_genus(ring) == 1
    # Two disjoint rings: genus adds up.
    two = np.concatenate([ring, ring + np.array([10.0, 0, 0])])
    assert mesh_genus(two) == 2
    # STL round trip keeps the triangles (float32 in the file).
    path = tmp_path / "ring.stl"
    write_triangles_stl(path, ring)
    back = read_stl(path)
    np.testing.assert_allclose(back, ring, atol=1e-6)
    ascii_path = tmp_path / "ring_ascii.stl"
    lines = ["solid r"]
    for t in ring:
        lines += [
            "facet normal 0 0 0",
            "outer loop",
            *[f"vertex {x} {y} {z}" for x, y, z in t],
            "endloop",
            "endfacet",
        ]
    ascii_path.write_text("\n".join(lines + ["endsolid r"]))
    np.testing.assert_allclose(read_stl(ascii_path), ring)


@pytest.mark.parametrize(
    ("size", "holes", "per_tile", "expected"),
    [((100, 100), 250, 300, (1, 1)), ((200, 150), 4000, 300, (4, 4)), ((400, 100), 1200, 300, (4, 1))],
)
def test_tile_grid(size, holes, per_tile, expected):
    nx, ny = sl.tile_grid(size, holes, per_tile)
    assert (nx, ny) == expected
    assert nx * ny * per_tile >= holes


def test_choose_seam_avoids_slivers():
    centres = np.array([0.0, 2.6, 5.2])
    half = np.ones(3)
    # Midway between holes 0 and 2.6 the webs are 0.3 mm from the seam: a sliver on both sides.
    c = sl.choose_seam(1.3, centres, half, window=1.5)
    d = np.abs(centres - c)
    assert np.all((d <= 0.5) | (d >= 1.0 + sl.SEAM_CLEARANCE_MM))
    # A seam that already clears every hole stays where it was asked to be.
    assert sl.choose_seam(10.0, centres, half, window=1.0) == 10.0


def test_hole_boxes_find_the_holes(tmp_path):
    holes, _, _ = small_plate(tmp_path / "p.stl", n_side=3, pitch=3.0)
    centres, half = sl.hole_boxes(read_stl(tmp_path / "p.stl"))
    assert len(centres) == holes
    g = np.arange(3) * 3.0 + 4.0
    expected = np.stack(np.meshgrid(g, g), -1).reshape(-1, 2)
    order = np.lexsort(centres.T[::-1])
    np.testing.assert_allclose(centres[order], expected[np.lexsort(expected.T[::-1])], atol=0.05)
    np.testing.assert_allclose(half, 1.0, atol=0.05)


def test_split_into_tiles_conserves_volume(tmp_path):
    # 4 x 4 square plate holes: a grid of genus-1 rings side by side, merged into one plate.
    holes, volume, (w, h, t) = small_plate(tmp_path / "plate.stl", n_side=4, pitch=3.2)
    tiles = sl.split_into_tiles(tmp_path / "plate.stl", tmp_path, grid=(2, 2))
    assert len(tiles) == 4
    parts = [read_stl(p) for p in tiles]
    total = sum(signed_volume(p) for p in parts)
    whole = signed_volume(read_stl(tmp_path / "plate.stl"))
    assert total == pytest.approx(whole, rel=1e-5)
    assert whole == pytest.approx(volume, rel=2e-3)
    # The middle of a 4 x 4 grid clears the holes by 0.6 mm (> SEAM_CLEARANCE_MM): seams stay there.
    assert sum(mesh_genus(p) for p in parts) == holes
    for p in parts:
        lo, hi = p.reshape(-1, 3).min(0), p.reshape(-1, 3).max(0)
        assert hi[0] - lo[0] == pytest.approx(w / 2, abs=1e-4) and hi[1] - lo[1] == pytest.approx(
            h / 2, abs=1e-4
        )


# ----------------------------------------------------------------------------- slow: real slicers

needs_prusa = pytest.mark.skipif(sl.find_slicer(sl.Slicer.PRUSA) is None, reason="prusa-slicer not installed")
needs_cura = pytest.mark.skipif(
    sl.find_slicer(sl.Slicer.CURA) is None or sl.find_cura_definitions() is None,
    reason="CuraEngine or fdmprinter.def.json (Debian packages cura-engine, cura) not installed",
)


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    path = tmp_path_factory.mktemp("plate") / "plate.stl"
    holes, volume, size = small_plate(path, n_side=6)
    return path, holes, volume, size


@pytest.mark.slow
@needs_prusa
def test_exported_plate_is_a_clean_mesh(plate):
    path, holes, volume, size = plate
    info = sl.inspect_mesh(path)
    assert info.manifold and info.open_edges == 0 and info.parts == 1
    assert info.volume_mm3 == pytest.approx(volume, rel=2e-3)
    assert info.size_mm == pytest.approx(size, abs=1e-3)
    assert mesh_genus(read_stl(path)) == holes


@pytest.mark.slow
@needs_prusa
def test_prusa_fdm_profile_slices(plate, tmp_path):
    path, *_ = plate
    res = sl.slice_file(path, tmp_path / "plate.gcode", "prusa_fdm", timeout_s=300)
    assert res.ok, (res.errors, res.log)
    assert res.errors == () and res.output_bytes > 10_000
    summary = sl.gcode_summary(res.output)
    assert summary["layers"] == 4  # 1.2 mm at 0.3 mm
    assert summary["extrusion_moves"] > 1000
    assert summary["filament_mm"] > 0


@pytest.mark.slow
@needs_prusa
def test_prusa_fdm_tiles_slice_as_one_plate(plate, tmp_path):
    path, *_ = plate
    tiles = sl.split_into_tiles(path, tmp_path, grid=(2, 1))
    assert len(tiles) == 2
    res = sl.slice_file(tiles, tmp_path / "tiles.gcode", "prusa_fdm", timeout_s=300)
    assert res.ok, (res.errors, res.log)
    whole = sl.slice_file(path, tmp_path / "whole.gcode", "prusa_fdm", timeout_s=300)
    # Same plate, same material within a few per cent (the seam adds two perimeters).
    f_tiles = sl.gcode_summary(res.output)["filament_mm"]
    f_whole = sl.gcode_summary(whole.output)["filament_mm"]
    assert f_tiles == pytest.approx(f_whole, rel=0.1)


@pytest.mark.slow
@needs_prusa
def test_prusa_sla_profile_slices(plate, tmp_path):
    path, *_ = plate
    res = sl.slice_file(path, tmp_path / "plate.sl1", "prusa_sla", timeout_s=300)
    assert res.ok, (res.errors, res.log)
    assert sl.sla_layer_count(res.output) == 12  # 1.2 mm at 0.1 mm


@pytest.mark.slow
@needs_prusa
def test_slicer_errors_are_reported(tmp_path):
    empty = tmp_path / "empty.stl"
    empty.write_text("solid x\nendsolid x\n")
    res = sl.slice_file(empty, tmp_path / "empty.gcode", "prusa_fdm", timeout_s=120)
    assert not res.ok and res.errors and res.returncode != 0
    with pytest.raises(RuntimeError):
        sl.inspect_mesh(empty)


@pytest.mark.slow
@needs_prusa
def test_3mf_project_carries_the_settings(plate, tmp_path):
    import subprocess

    path, *_ = plate
    out = sl.export_3mf_project(path, tmp_path / "plate.3mf", "prusa_fdm")
    with zipfile.ZipFile(out) as zf:
        names = zf.namelist()
        config = zf.read("Metadata/Slic3r_PE.config").decode()
    assert "3D/3dmodel.model" in names
    assert "; perimeter_generator = arachne" in config and "; overhangs = 0" in config
    # Sliced WITHOUT --load, the G-code must still carry the profile's settings.
    gcode = tmp_path / "from3mf.gcode"
    exe = str(sl.find_slicer())
    proc = subprocess.run(
        [exe, "--export-gcode", "-o", str(gcode), str(out)], capture_output=True, text=True, timeout=300
    )
    assert proc.returncode == 0, proc.stderr
    tail = gcode.read_text(errors="replace")[-20000:]
    assert "; perimeter_generator = arachne" in tail and "; seam_position = rear" in tail


@pytest.mark.slow
@needs_cura
def test_cura_fdm_profile_slices(plate, tmp_path):
    path, *_ = plate
    res = sl.slice_file(path, tmp_path / "plate.gcode", "cura_fdm", timeout_s=300)
    assert res.ok, (res.errors, res.log)
    summary = sl.gcode_summary(res.output)
    assert summary["layers"] == 6
    assert summary["extrusion_moves"] > 1000


def test_benchmark_plates_respect_the_web():
    from scipy.spatial import cKDTree

    from benchmarks import slicer as bench

    for n in (250, 4000):
        xy, w, h = bench.hole_centres(n)
        assert len(xy) == n
        d, _ = cKDTree(xy).query(xy, k=2)
        # Jitter never brings two r = 1 mm holes closer than a 0.5 mm web.
        assert d[:, 1].min() >= 2 * bench.RADIUS_MM + 0.5
        # Every hole stays inside the plate with at least the margin minus the 0.045 mm jitter.
        assert xy.min() >= bench.MARGIN_MM + bench.RADIUS_MM - 0.05
        assert xy[:, 0].max() <= w - bench.MARGIN_MM - bench.RADIUS_MM + 1e-9
        assert xy[:, 1].max() <= h - bench.MARGIN_MM - bench.RADIUS_MM + 1e-9


FAKE_SLICER = """#!/bin/sh
# Stands in for PrusaSlicer: writes OUTPUT.tmp (as PrusaSlicer does before renaming it), then hangs.
echo $$ > "{pidfile}"
while [ "$#" -gt 0 ]; do
  if [ "$1" = "--output" ]; then out="$2"; fi
  shift
done
echo partial > "$out.tmp"
sleep 60
"""


@pytest.mark.parametrize("sig", ["SIGTERM", "SIGKILL"])
def test_a_killed_slice_leaves_nothing_behind(tmp_path, sig):
    import os
    import signal
    import subprocess
    import sys
    import time

    work, bin_dir = tmp_path / "plates", tmp_path / "bin"
    work.mkdir()
    bin_dir.mkdir()
    write_triangles_stl(work / "p.stl", square_ring_plate())
    fake = bin_dir / "prusa-slicer"
    fake.write_text(FAKE_SLICER.format(pidfile=bin_dir / "pid"))
    fake.chmod(0o755)
    root = str(Path(__file__).resolve().parents[2])
    env = {
        **os.environ,
        sl.ENV_PRUSA: str(fake),
        "PYTHONPATH": os.pathsep.join([root, os.environ.get("PYTHONPATH", "")]),
    }
    proc = subprocess.Popen([sys.executable, "-m", "stencil_cad", "slice", str(work / "p.stl")], env=env)
    deadline = time.monotonic() + 60
    while not any(p.name.endswith(".tmp") for p in work.iterdir()):
        assert proc.poll() is None and time.monotonic() < deadline, "the slicer did not start"
        time.sleep(0.05)
    proc.send_signal(getattr(signal, sig))
    proc.wait(timeout=30)
    slicer = int((bin_dir / "pid").read_text())
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        try:
            os.kill(slicer, 0)
        except ProcessLookupError:
            break
        time.sleep(0.05)
    else:
        os.kill(slicer, signal.SIGKILL)
        pytest.fail("the slicer outlived stencil-cad")
    if sig == "SIGTERM":
        assert proc.returncode == 128 + signal.SIGTERM
        assert sorted(p.name for p in work.iterdir()) == ["p.stl"]
    else:
        # Nothing can clean up after SIGKILL but the next slice, which removes the leftovers first.
        fake.write_text("#!/bin/sh\nexit 3\n")
        assert (
            subprocess.run(
                [sys.executable, "-m", "stencil_cad", "slice", str(work / "p.stl")], env=env
            ).returncode
            == 1
        )
        assert sorted(p.name for p in work.iterdir()) == ["p.stl"]


def test_project_validates_the_timeout_and_honours_the_bed(tmp_path, monkeypatch, capsys):
    from stencil_cad.cli import main

    stl = tmp_path / "p.stl"
    write_triangles_stl(stl, square_ring_plate())
    for bad in ("nan", "-5", "inf"):
        assert main(["slice", "--project", "--timeout", bad, str(stl)]) == 2
        err = capsys.readouterr().err
        assert "--timeout must be a positive number" in err and "internal error" not in err, err
    seen = {}

    def fake_project(model, output, prof, timeout_s, overrides=None, rotate_deg=0):
        seen["overrides"] = overrides
        Path(output).write_bytes(b"3mf")

    monkeypatch.setattr(sl, "plate_project", fake_project)
    assert main(["slice", "--project", "--bed", "180x180", str(stl)]) == 0
    assert seen["overrides"] == {"bed_shape": "0x0,180x0,180x180,0x180"}
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.3mf", "p.stl"]
