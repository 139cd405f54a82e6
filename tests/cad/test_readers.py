"""Independent readers check the files a maker receives.

PrusaSlicer (Debian ``prusa-slicer``), admesh (``admesh``), FreeCAD headless (``freecad``),
GDAL (``gdal-bin``) and dime (``dime``). A missing program skips its test locally and
fails it in CI (``CI`` set), where the packages must be installed.
"""

import json
import os
import re
import textwrap

import build123d as bd
import numpy as np
import pytest
from readers import need, run

from stencil_cad.cad import occt
from stencil_cad.cad.wall import build_wall, wall_step, wall_stl
from stencil_cad.config.cad import WallConfig
from stencil_cad.config.outline import OutlineConfig
from stencil_cad.exchange.dxf import DxfStencil, write_dxf, write_dxf_stencils
from stencil_cad.outline import plate_outline

pytestmark = pytest.mark.slow

W, H, T = 60.0, 45.0, 1.2


@pytest.fixture(scope="module")
def wall_files(tmp_path_factory):
    d = tmp_path_factory.mktemp("wall")
    model = build_wall(W, H, OutlineConfig(), WallConfig(), T, 8.0)
    wall_stl(model, d / "wall.stl", tolerance_mm=0.01)
    wall_step(model, d / "wall.step")
    return model, d / "wall.stl", d / "wall.step"


def admesh_report(stl_path):
    out = run([need("admesh"), str(stl_path)]).stdout

    def pick(label):
        m = re.search(rf"{re.escape(label)}\s*:\s*(\d+)(?:\s+(\d+))?", out)
        assert m, f"admesh printed no {label!r}:\n{out}"
        return int(m.group(1))

    return {
        "parts": pick("Number of parts"),
        "disconnected": pick("Total disconnected facets"),
        "degenerate": pick("Degenerate facets"),
        "edges_fixed": pick("Edges fixed"),
        "facets_reversed": pick("Facets reversed"),
        "backwards_edges": pick("Backwards edges"),
        "normals_fixed": pick("Normals fixed"),
        "facets_added": pick("Facets added"),
    }


def test_wall_stl_admesh(wall_files):
    _, stl, _ = wall_files
    rep = admesh_report(stl)
    assert rep["parts"] == 1
    # The "Original" column: before any repair.
    assert rep["disconnected"] == 0
    for key in (
        "degenerate",
        "edges_fixed",
        "facets_reversed",
        "backwards_edges",
        "normals_fixed",
        "facets_added",
    ):
        assert rep[key] == 0, (key, rep)


def test_wall_stl_prusa_info(wall_files):
    model, stl, _ = wall_files
    out = run([need("prusa-slicer"), "--info", str(stl)]).stdout
    info = dict(re.findall(r"^(\w+) = (.+)$", out, flags=re.M))
    assert info.get("manifold") == "yes", out
    assert int(info["number_of_parts"]) == 1
    assert float(info["volume"]) == pytest.approx(model.volume_mm3, rel=1e-3)
    assert float(info["min_z"]) == pytest.approx(0.0, abs=1e-4)
    assert float(info["max_z"]) == pytest.approx(model.height_mm, abs=1e-4)


def test_wall_slices(wall_files, tmp_path):
    model, stl, _ = wall_files
    gcode = tmp_path / "wall.gcode"
    res = run(
        [need("prusa-slicer"), "--export-gcode", "--center", "100,100", "--output", str(gcode), str(stl)]
    )
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    text = gcode.read_text()
    zs = [float(z) for z in re.findall(r"^G1 Z([0-9.]+)", text, flags=re.M)]
    # The last printing layer is at the wall's top (travel lifts may go above it).
    layers = [float(z) for z in re.findall(r"^;Z:([0-9.]+)", text, flags=re.M)]
    assert zs and layers
    assert max(layers) == pytest.approx(model.height_mm, abs=0.2)


FREECAD_SCRIPT = textwrap.dedent(
    """
    import json, os
    import Part
    shape = Part.Shape()
    shape.read(os.environ["STENCIL_STEP"])
    solids = shape.Solids
    out = {
        "solids": len(solids),
        "valid": bool(shape.isValid()),
        "closed": bool(solids) and all(s.isClosed() for s in solids),
        "volume": float(shape.Volume),
        "faces": len(shape.Faces),
        "bbox": [shape.BoundBox.XMin, shape.BoundBox.YMin, shape.BoundBox.ZMin,
                 shape.BoundBox.XMax, shape.BoundBox.YMax, shape.BoundBox.ZMax],
    }
    with open(os.environ["STENCIL_OUT"], "w") as f:
        json.dump(out, f)
    """
)


def freecad_read(step_path, tmp_path):
    script = tmp_path / "read_step.py"
    script.write_text(FREECAD_SCRIPT)
    out = tmp_path / "freecad.json"
    env = dict(os.environ, STENCIL_STEP=str(step_path), STENCIL_OUT=str(out))
    res = run([need("freecadcmd"), str(script)], env=env)
    assert out.exists(), res.stdout[-2000:] + res.stderr[-2000:]
    return json.loads(out.read_text())


def test_wall_step_freecad(wall_files, tmp_path):
    model, _, step = wall_files
    got = freecad_read(step, tmp_path)
    assert got["solids"] == 1
    assert got["valid"] and got["closed"]
    assert got["volume"] == pytest.approx(model.volume_mm3, rel=1e-6)
    np.testing.assert_allclose(got["bbox"], model.bbox, atol=1e-3)
    # The faces the wall was built with (tests/cad/test_wall.py: those of build123d's wall).
    assert got["faces"] == occt.faces(model.shape)


@pytest.fixture(scope="module")
def dxf_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("dxf")
    rng = np.random.default_rng(7)
    ring = plate_outline(W, H, OutlineConfig())
    a = np.column_stack([rng.uniform(2, W - 2, 150), rng.uniform(2, H - 2, 150), rng.uniform(0.5, 0.9, 150)])
    b = np.column_stack([rng.uniform(2, W - 2, 80), rng.uniform(2, H - 2, 80), rng.uniform(0.5, 0.9, 80)])
    square = np.array([[10, 10], [20, 10], [20, 20], [10, 20]], dtype=float)
    info = write_dxf_stencils(
        d / "two.dxf",
        [
            DxfStencil(ring, a, layer_name="STENCIL_01"),
            DxfStencil(ring, b, [square], layer_name="STENCIL_02"),
        ],
        kerf_mm=0.1,
    )
    return d / "two.dxf", info


def ogr_sql(path, sql):
    res = run([need("ogrinfo"), "-ro", "-q", "-dialect", "SQLITE", "-sql", sql, str(path)])
    return res, res.stdout


def test_dxf_gdal_counts(dxf_file):
    path, info = dxf_file
    res, out = ogr_sql(
        path, "SELECT Layer, SubClasses, COUNT(*) AS n FROM entities GROUP BY Layer, SubClasses"
    )
    assert "ERROR" not in res.stderr, res.stderr
    rows = re.findall(
        r"Layer \(String\) = (\S+)\s+SubClasses \(String\) = (\S+)\s+n \(Integer\) = (\d+)", out
    )
    counts = {(layer, sub): int(n) for layer, sub, n in rows}
    assert counts == {
        ("STENCIL_01", "AcDbEntity:AcDbCircle"): 150,
        ("STENCIL_01", "AcDbEntity:AcDbPolyline"): 1,
        ("STENCIL_02", "AcDbEntity:AcDbCircle"): 80,
        ("STENCIL_02", "AcDbEntity:AcDbPolyline"): 2,
    }
    summary = run([need("ogrinfo"), "-ro", "-al", "-so", str(path)]).stdout
    m = re.search(r"Extent: \(([-0-9.]+), ([-0-9.]+)\) - \(([-0-9.]+), ([-0-9.]+)\)", summary)
    assert m, summary
    np.testing.assert_allclose([float(v) for v in m.groups()], info.bbox_mm, atol=1e-3)
    assert info.bbox_mm[0] == 0.0 and info.bbox_mm[1] == 0.0


def test_dxf_gdal_and_dime_reject_a_truncated_file(dxf_file, tmp_path):
    path, _ = dxf_file
    data = path.read_bytes()
    cut = tmp_path / "cut.dxf"
    cut.write_bytes(data[: len(data) // 2])
    res, _ = ogr_sql(cut, "SELECT COUNT(*) FROM entities")
    assert "ERROR" in res.stderr
    assert run([need("dxf2vrml"), str(cut)]).returncode != 0


def test_dxf_dime_reads(dxf_file):
    path, _ = dxf_file
    res = run([need("dxf2vrml"), str(path)])
    assert res.returncode == 0, res.stderr
    assert res.stdout.startswith("#VRML")


def test_single_stencil_dxf_gdal(tmp_path):
    ring = plate_outline(W, H, OutlineConfig())
    c = np.array([[5.0, 5.0, 1.0], [30.0, 20.0, 0.75]])
    write_dxf(tmp_path / "one.dxf", ring, c)
    res, out = ogr_sql(
        tmp_path / "one.dxf", "SELECT COUNT(*) AS n FROM entities WHERE SubClasses LIKE '%Circle'"
    )
    assert "ERROR" not in res.stderr
    assert re.search(r"n \(Integer\) = 2\b", out), out


@pytest.fixture(scope="module")
def plate_files(tmp_path_factory):
    """A 200-hole plate from the plate module, with this outline."""
    from stencil_cad.cad import plate as plate_mod
    from stencil_cad.exchange import mesh as mesh_mod
    from stencil_cad.model import DotSet
    from stencil_cad.outline import label_region

    d = tmp_path_factory.mktemp("plate")
    outline = OutlineConfig()
    gx, gy = np.meshgrid(np.linspace(3.0, W - 3.0, 20), np.linspace(3.0, H - 3.0, 10))
    rng = np.random.default_rng(3)
    xy = np.column_stack([gx.ravel(), gy.ravel()]) + rng.uniform(-0.3, 0.3, (200, 2))
    dots = DotSet(xy_mm=xy, r_mm=rng.uniform(0.5, 0.8, 200))
    model = plate_mod.perforated_plate(
        dots, plate_outline(W, H, outline), label_region(W, H, outline), None, thickness_mm=T
    )
    stl = d / "plate.stl"
    stl.write_bytes(mesh_mod.stl_bytes(mesh_mod.plate_mesh(model.geometry, tolerance_mm=0.02)))
    step = d / "plate.step"
    bd.export_step(model.part, str(step))
    return model, stl, step


def test_plate_stl_admesh_and_prusa(plate_files, tmp_path):
    model, stl, _ = plate_files
    rep = admesh_report(stl)
    assert rep["parts"] == 1 and rep["disconnected"] == 0, rep
    out = run([need("prusa-slicer"), "--info", str(stl)]).stdout
    info = dict(re.findall(r"^(\w+) = (.+)$", out, flags=re.M))
    assert info.get("manifold") == "yes", out
    assert int(info["number_of_parts"]) == 1
    gcode = tmp_path / "plate.gcode"
    res = run(
        [need("prusa-slicer"), "--export-gcode", "--center", "100,100", "--output", str(gcode), str(stl)],
        timeout=600,
    )
    assert res.returncode == 0 and gcode.stat().st_size > 0, res.stderr[-2000:]


def test_plate_step_freecad(plate_files, tmp_path):
    model, _, step = plate_files
    got = freecad_read(step, tmp_path)
    assert got["solids"] == 1 and got["valid"] and got["closed"]
    assert got["volume"] == pytest.approx(model.geometry.volume, rel=1e-6)


def test_real_plate_sits_in_wall(plate_files, wall_files):
    plate, _, _ = plate_files
    wall, _, _ = wall_files
    (solid,) = plate.part.solids()
    (frame,) = wall.part.solids()

    def overlap(loc):
        common = solid.moved(loc).intersect(frame)
        return 0.0 if common is None else sum(s.volume for s in common.solids())

    assert overlap(bd.Location((0, 0, wall.standoff_mm))) < 1e-6
    # Turned round about the picture's centre, its tabs cut into the rim.
    assert overlap(bd.Location((W, H, wall.standoff_mm), (0, 0, 1), 180)) > 1.0
