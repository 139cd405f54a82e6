"""Plate files: STEP read back by OCCT (and FreeCAD), STL/3MF read back by trimesh, admesh, PrusaSlicer."""

import json
import math
import os
import re
import struct
import textwrap

import numpy as np
import pytest
from readers import need, run

from stencil_cad import cad
from stencil_cad.cad.validate import brep_valid, topology_checks
from stencil_cad.config import PlateConfig
from stencil_cad.config.cad import LabelMode
from stencil_cad.exchange.mesh import mesh_checks
from stencil_cad.model import DotSet, TriMesh
from stencil_cad.outline import plate_outline

W, H = 40.0, 30.0
LABEL = cad.LabelInfo(layer=1, layers=2, colour="red", job="export")


def dots(pitch=2.5, w=W, h=H, seed=3):
    rng = np.random.default_rng(seed)
    xs = np.arange(pitch / 2 + 0.5, w - pitch / 2, pitch)
    ys = np.arange(pitch / 2 + 0.5, h - pitch / 2, pitch)
    xy = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2) + rng.uniform(-0.2, 0.2, (len(xs) * len(ys), 2))
    return DotSet(xy, rng.uniform(0.5, 0.8, len(xy)))


@pytest.fixture(scope="module", params=["none", "engrave", "emboss"])
def plate(request):
    d = dots()
    return d, cad.build_plate(d, W, H, PlateConfig(label=LabelMode(request.param)), LABEL)


def read_step(path):
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone
    reader.TransferRoots()
    return reader.OneShape()


@pytest.mark.slow
def test_step_reads_back_as_the_same_valid_solid(plate, tmp_path):
    d, model = plate
    path = tmp_path / "p.step"
    cad.write_step(model, path)
    shape = read_step(path)
    topo = topology_checks(shape)
    assert topo["solids"] == 1 and topo["shells"] == 1
    assert topo["edges_not_two_faces"] == 0 and topo["edges_misoriented"] == 0
    assert topo["cylinders"] == len(d)  # exact circles: one cylindrical face per hole
    assert brep_valid(shape)
    from build123d import import_step

    part = import_step(str(path))
    assert part.volume == pytest.approx(model.analytic_volume, rel=1e-6)
    bb = part.bounding_box()
    (x0, y0, z0), (x1, y1, z1) = model.geometry.bbox
    np.testing.assert_allclose(
        [bb.min.X, bb.min.Y, bb.min.Z, bb.max.X, bb.max.Y, bb.max.Z], [x0, y0, z0, x1, y1, z1], atol=1e-6
    )
    # The same faces as the solid built in memory.
    assert topo["faces"] == topology_checks(model.part.wrapped)["faces"]


def test_step_header_is_fixed(tmp_path):
    # The header holds no clock: a fixed timestamp, the product name from the label.
    model = cad.build_plate(dots(), W, H, PlateConfig(), LABEL)
    cad.write_step(model, tmp_path / "a.step")
    head = (tmp_path / "a.step").read_text(encoding="ascii").split("ENDSEC;")[0]
    name = f"{LABEL.job} layer {LABEL.layer} of {LABEL.layers}"
    assert head == (
        "ISO-10303-21;\nHEADER;\nFILE_DESCRIPTION(('stencil_cad plate'),'2;1');\n"
        f"FILE_NAME('{name}','2026-01-01T00:00:00',(''),(''),'stencil_cad','stencil_cad','');\n"
        "FILE_SCHEMA(('AUTOMOTIVE_DESIGN { 1 0 10303 214 1 1 1 1 }'));\n"
    )


def test_stl_is_binary_watertight_and_right_volume(plate, tmp_path):
    import trimesh

    d, model = plate
    path = tmp_path / "p.stl"
    cad.write_stl(model, path, 0.02)
    raw = path.read_bytes()
    (n,) = struct.unpack("<I", raw[80:84])
    assert len(raw) == 84 + 50 * n  # binary STL
    mesh = trimesh.load(path, file_type="stl")
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.is_volume
    assert mesh.volume == pytest.approx(model.analytic_volume, rel=1e-3)
    assert mesh.euler_number == 2 - 2 * len(d)  # genus = hole count
    assert mesh.bounds[0][2] == pytest.approx(0.0, abs=1e-6)


def test_stl_tolerance_sets_the_hole_polygons(tmp_path):
    d = dots(pitch=4.0)
    model = cad.build_plate(d, W, H, PlateConfig(label=LabelMode.none), LABEL)
    fine, coarse = model.mesh(0.002), model.mesh(0.2)
    assert fine.faces.shape[0] > 2 * coarse.faces.shape[0]
    # Every bottom vertex of a hole lies within the tolerance of its circle.
    v = fine.vertices[fine.vertices[:, 2] == 0.0][:, :2]
    from scipy.spatial import cKDTree

    dist, i = cKDTree(d.xy_mm).query(v)
    near = dist < d.r_mm[i] + 0.01
    assert near.sum() > 8 * len(d)
    assert np.all(np.abs(dist[near] - d.r_mm[i[near]]) <= 0.002 + 1e-9)


def test_3mf_reads_back(plate, tmp_path):
    lib3mf = pytest.importorskip("lib3mf")
    _, model = plate
    path = tmp_path / "p.3mf"
    cad.write_3mf(model, path, 0.02)
    m3 = lib3mf.get_wrapper().CreateModel()
    m3.QueryReader("3mf").ReadFromFile(str(path))
    it = m3.GetMeshObjects()
    assert it.MoveNext()
    obj = it.GetCurrentMeshObject()
    v = np.array([p.Coordinates[0:3] for p in obj.GetVertices()], dtype=np.float64)
    f = np.array([t.Indices[0:3] for t in obj.GetTriangleIndices()], dtype=np.int64)
    assert not it.MoveNext()  # one object
    mc = mesh_checks(TriMesh(v, f))
    assert mc["watertight"] and mc["consistent_winding"] and mc["components"] == 1
    assert mc["volume"] == pytest.approx(model.analytic_volume, rel=1e-3)


@pytest.mark.slow
def test_edited_solid_exports_through_occt(tmp_path):
    from build123d import Cylinder, Pos

    d = dots(pitch=5.0)
    model = cad.build_plate(d, W, H, PlateConfig(label=LabelMode.none), LABEL)
    ring = plate_outline(W, H, PlateConfig().outline)
    edited = model.with_part(
        model.part - Pos(ring[:, 0].min() + 5, ring[:, 1].max() - 5, 0.6) * Cylinder(1.5, 2.4)
    )
    assert edited.geometry is None
    cad.write_step(edited, tmp_path / "e.step")
    shape = read_step(tmp_path / "e.step")
    assert topology_checks(shape)["solids"] == 1
    # The cylinder cuts through the whole plate, whatever thickness the template makes.
    want = model.analytic_volume - math.pi * 1.5**2 * model.geometry.thickness_mm
    from build123d import import_step

    assert import_step(str(tmp_path / "e.step")).volume == pytest.approx(want, rel=1e-6)
    cad.write_stl(edited, tmp_path / "e.stl", 0.02)
    assert (tmp_path / "e.stl").stat().st_size > 84


# ----------------------------------------------------------------------------- independent readers (slow)


@pytest.fixture(scope="module")
def files_200(tmp_path_factory):
    """A plate of about 200 holes with an engraved label, as STEP and STL."""
    d = dots(pitch=3.0, w=45.0, h=40.0)
    assert 150 <= len(d) <= 250
    model = cad.build_plate(d, 45.0, 40.0, PlateConfig(), LABEL)
    folder = tmp_path_factory.mktemp("plate200")
    cad.write_stl(model, folder / "p.stl", 0.02)
    cad.write_step(model, folder / "p.step")
    return d, model, folder


@pytest.mark.slow
def test_admesh_one_part_nothing_to_repair(files_200):
    _, _, folder = files_200
    out = run([need("admesh"), str(folder / "p.stl")]).stdout

    def pick(label):
        m = re.search(rf"{re.escape(label)}\s*:\s*(\d+)", out)
        assert m, out
        return int(m.group(1))

    assert pick("Number of parts") == 1
    assert pick("Total disconnected facets") == 0
    for label in (
        "Degenerate facets",
        "Edges fixed",
        "Facets reversed",
        "Backwards edges",
        "Normals fixed",
        "Facets added",
    ):
        assert pick(label) == 0, (label, out)


@pytest.mark.slow
def test_prusaslicer_info_and_slices(files_200, tmp_path):
    _, model, folder = files_200
    slicer = need("prusa-slicer")
    out = run([slicer, "--info", str(folder / "p.stl")]).stdout
    info = dict(re.findall(r"^(\w+) = (.+)$", out, flags=re.M))
    assert info.get("manifold") == "yes", out
    assert int(info["number_of_parts"]) == 1
    assert float(info["volume"]) == pytest.approx(model.analytic_volume, rel=1e-3)
    gcode = tmp_path / "p.gcode"
    res = run(
        [slicer, "--export-gcode", "--center", "100,100", "--output", str(gcode), str(folder / "p.stl")]
    )
    assert res.returncode == 0, res.stdout[-2000:] + res.stderr[-2000:]
    layers = [float(z) for z in re.findall(r"^;Z:([0-9.]+)", gcode.read_text(), flags=re.M)]
    assert layers and max(layers) == pytest.approx(model.geometry.thickness_mm, abs=0.2)


FREECAD_SCRIPT = textwrap.dedent(
    """
    import json, os
    import Part
    shape = Part.Shape()
    shape.read(os.environ["STENCIL_STEP"])
    solids = shape.Solids
    faces = shape.Faces
    out = {
        "solids": len(solids),
        "valid": bool(shape.isValid()),
        "closed": bool(solids) and all(s.isClosed() for s in solids),
        "volume": float(shape.Volume),
        "cylinders": sum(1 for f in faces if f.Surface.__class__.__name__ == "Cylinder"),
    }
    with open(os.environ["STENCIL_OUT"], "w") as f:
        json.dump(out, f)
    """
)


@pytest.mark.slow
def test_freecad_opens_one_valid_closed_solid(files_200, tmp_path):
    d, model, folder = files_200
    script = tmp_path / "read_step.py"
    script.write_text(FREECAD_SCRIPT)
    out = tmp_path / "freecad.json"
    env = dict(os.environ, STENCIL_STEP=str(folder / "p.step"), STENCIL_OUT=str(out))
    res = run([need("freecadcmd"), str(script)], env=env)
    assert out.exists(), res.stdout[-2000:] + res.stderr[-2000:]
    got = json.loads(out.read_text())
    assert got["solids"] == 1 and got["valid"] and got["closed"]
    assert got["cylinders"] == len(d)
    assert got["volume"] == pytest.approx(model.analytic_volume, rel=1e-6)
