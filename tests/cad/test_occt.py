"""The OCP helpers the wall is made with, each held to its contract on shapes of known size."""

import logging
import math

import pytest

from stencil_cad.cad import occt

SQUARE = [(0.0, 0.0, 2.0), (10.0, 0.0, 2.0), (10.0, 5.0, 2.0), (0.0, 5.0, 2.0)]


def polygon(points):
    return occt.wire(occt.line_edge(a, b) for a, b in zip(points, points[1:] + points[:1], strict=True))


def area(face):
    from OCP.BRepGProp import BRepGProp
    from OCP.GProp import GProp_GProps

    props = GProp_GProps()
    BRepGProp.SurfaceProperties_s(face, props)
    return props.Mass()


@pytest.mark.parametrize("points", [SQUARE, SQUARE[::-1]], ids=["ccw", "cw"])
@pytest.mark.parametrize("dz", [3.0, -3.0])
def test_face_and_prism_whichever_way_the_wire_runs(points, dz):
    face = occt.planar_face(polygon(points))
    assert area(face) == pytest.approx(50.0, rel=1e-12)
    solid = occt.prism(face, dz)
    assert occt.is_valid(solid)
    assert occt.volume(solid) == pytest.approx(150.0, rel=1e-12)
    z0, z1 = sorted((2.0, 2.0 + dz))
    assert occt.bounding_box(solid) == pytest.approx((0.0, 0.0, z0, 10.0, 5.0, z1), abs=1e-9)


def test_round_face_of_arcs():
    # A disc of radius 2 from two half circles.
    arcs = [
        occt.arc_edge((2.0, 0.0, 0.0), (0.0, 2.0, 0.0), (-2.0, 0.0, 0.0)),
        occt.arc_edge((-2.0, 0.0, 0.0), (0.0, -2.0, 0.0), (2.0, 0.0, 0.0)),
    ]
    assert area(occt.planar_face(occt.wire(arcs))) == pytest.approx(4.0 * math.pi, rel=1e-12)


def test_bad_edges_wires_and_faces_are_refused():
    with pytest.raises(ValueError, match="no circular arc"):
        occt.arc_edge((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (2.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="does not meet"):
        occt.wire([occt.line_edge((0, 0, 0), (1, 0, 0)), occt.line_edge((2, 0, 0), (3, 0, 0))])
    with pytest.raises(ValueError, match="closed wire"):
        occt.planar_face(
            occt.wire([occt.line_edge((0, 0, 0), (1, 0, 0)), occt.line_edge((1, 0, 0), (1, 1, 0))])
        )
    skew = [(0.0, 0.0, 0.0), (10.0, 0.0, 0.0), (10.0, 5.0, 1.0), (0.0, 5.0, 0.0)]
    with pytest.raises(ValueError, match="no planar face"):
        occt.planar_face(polygon(skew))


def test_box_at_its_corner():
    b = occt.box((1.0, 2.0, 3.0), (4.0, 5.0, 6.0))
    assert occt.volume(b) == pytest.approx(120.0, rel=1e-12)
    assert occt.bounding_box(b) == pytest.approx((1.0, 2.0, 3.0, 5.0, 7.0, 9.0), abs=1e-9)


def test_cut_of_overlapping_tools_then_unify():
    # The top half of a cube cut away by two tools that overlap each other: one solid of
    # half the volume, whose new top face is split where the tools met until unified.
    cube = occt.box((0.0, 0.0, 0.0), (10.0, 10.0, 10.0))
    tools = [occt.box((-1.0, -1.0, 5.0), (12.0, 7.0, 6.0)), occt.box((-1.0, 4.0, 5.0), (12.0, 7.0, 6.0))]
    raw = occt.cut(cube, tools)
    (solid,) = occt.solids(raw)
    assert occt.is_valid(raw)
    assert occt.volume(solid) == pytest.approx(500.0, rel=1e-12)
    assert occt.faces(raw) > 6
    clean = occt.unify(raw)
    assert occt.is_valid(clean) and occt.faces(clean) == 6
    assert occt.volume(occt.solids(clean)[0]) == pytest.approx(500.0, rel=1e-12)
    assert occt.in_compound(clean).ShapeType().name == "TopAbs_COMPOUND"


def test_unify_keeps_the_shape_and_warns_when_occt_fails(monkeypatch, caplog):
    import OCP.ShapeUpgrade
    from OCP.Standard import Standard_Failure

    class Failing:
        def __init__(self, shape):
            pass

        def Build(self):
            raise Standard_Failure("no merge")

    monkeypatch.setattr(OCP.ShapeUpgrade, "ShapeUpgrade_UnifySameDomain", Failing)
    cube = occt.box((0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    with caplog.at_level(logging.WARNING, logger="stencil_cad.cad.occt"):
        assert occt.unify(cube) is cube
    assert "no merge" in caplog.text


def read_step(path):
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone
    reader.TransferRoots()
    return reader.OneShape()


def test_step_names_stencil_cad_gives_the_same_bytes_and_prints_nothing(tmp_path, capfd):
    cube = occt.box((0.0, 0.0, 0.0), (10.0, 20.0, 30.0))
    for name in ("a", "b"):
        occt.write_step(
            cube, tmp_path / f"{name}.step", "test_part", "stencil_cad test", "2026-01-01T00:00:00"
        )
    assert capfd.readouterr() == ("", "")
    text = (tmp_path / "a.step").read_text()
    assert (tmp_path / "b.step").read_text() == text
    assert "FILE_DESCRIPTION(('stencil_cad test')" in text
    header = " ".join(text.split("ENDSEC;")[0].split())
    assert "FILE_NAME('test_part','2026-01-01T00:00:00',(''),(''), 'Open CASCADE" in header
    assert "'stencil_cad','');" in header and "AUTOMOTIVE_DESIGN" in header
    assert "PRODUCT('test_part','test_part'" in text
    assert "SI_UNIT(.MILLI.,.METRE.)" in text
    back = read_step(tmp_path / "a.step")
    (solid,) = occt.solids(back)
    assert occt.volume(solid) == pytest.approx(6000.0, rel=1e-9)


def test_stl_needs_its_folder(tmp_path):
    with pytest.raises(OSError, match="no folder"):
        occt.write_stl(occt.box((0, 0, 0), (1, 1, 1)), tmp_path / "missing" / "a.stl", 0.01, 0.1)
