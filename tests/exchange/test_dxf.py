import math

import ezdxf
import numpy as np
import pytest

from stencil_cad.config.outline import OutlineConfig
from stencil_cad.exchange.dxf import (
    DxfStencil,
    dxf_from_layers,
    offset_ring,
    write_dxf,
    write_dxf_stencils,
)
from stencil_cad.geometry import polygon_area
from stencil_cad.model import CutLayer, DotSet
from stencil_cad.outline import plate_outline


def random_circles(rng, n, w=150.0, h=150.0):
    return np.column_stack([rng.uniform(2, w - 2, n), rng.uniform(2, h - 2, n), rng.uniform(0.5, 1.0, n)])


def read(path):
    doc = ezdxf.readfile(path)
    auditor = doc.audit()
    assert len(auditor.errors) == 0, [str(e) for e in auditor.errors]
    return doc


def circles_of(doc, layer=None):
    q = "CIRCLE" if layer is None else f'CIRCLE[layer=="{layer}"]'
    return np.array([[e.dxf.center.x, e.dxf.center.y, e.dxf.radius] for e in doc.modelspace().query(q)])


def sort_rows(a):
    return a[np.lexsort(a.T[::-1])]


@pytest.fixture
def ring():
    return plate_outline(150.0, 150.0, OutlineConfig())


def test_round_trip(tmp_path, rng, ring):
    c = random_circles(rng, 200)
    info = write_dxf(tmp_path / "a.dxf", ring, c, layer_name="STENCIL_03")
    doc = read(tmp_path / "a.dxf")
    assert doc.dxfversion == "AC1024"  # R2010
    assert doc.header["$INSUNITS"] == 4  # mm
    assert doc.header["$MEASUREMENT"] == 1
    assert "STENCIL_03" in doc.layers
    msp = doc.modelspace()
    assert len(msp) == 201
    got = circles_of(doc, "STENCIL_03")
    assert len(got) == 200  # one CIRCLE per dot
    shift = np.array(info.offset_mm)
    np.testing.assert_allclose(sort_rows(got), sort_rows(c + [*shift, 0.0]), atol=1e-12)
    (poly,) = msp.query("LWPOLYLINE")
    assert poly.closed and poly.dxf.layer == "STENCIL_03"
    pts = np.array(poly.get_points("xy"))
    np.testing.assert_allclose(pts, ring + shift, atol=1e-12)
    # Moved into +X/+Y: the outline's lowest x and y land on 0.
    np.testing.assert_allclose(pts.min(axis=0), 0.0, atol=1e-12)
    np.testing.assert_allclose(shift, -ring.min(axis=0))
    assert float(doc.header.custom_vars.get("STENCIL_OFFSET_X_MM")) == shift[0]
    assert float(doc.header.custom_vars.get("STENCIL_OFFSET_Y_MM")) == shift[1]
    assert info.circles == [200] and info.polylines == [1]
    # Holes come before the outline, so a laser cutting in file order frees the plate last.
    assert [e.dxftype() for e in msp][-1] == "LWPOLYLINE"


def test_handles_unique_and_below_handseed(tmp_path, rng, ring):
    write_dxf(tmp_path / "a.dxf", ring, random_circles(rng, 500))
    doc = read(tmp_path / "a.dxf")
    handles = [int(e.dxf.handle, 16) for e in doc.entitydb.values()]
    assert len(handles) == len(set(handles))
    assert max(handles) < int(doc.header["$HANDSEED"], 16)
    owner = doc.modelspace().layout_key
    assert all(e.dxf.owner == owner for e in doc.modelspace())


def _square(x, y, side):
    return np.array([[x, y], [x + side, y], [x + side, y + side], [x, y + side]], dtype=float)


def test_polylines_written_as_ezdxf_writes_them(tmp_path, rng, ring):
    # Labels and cut-outs: their polylines after the first of a run are written as text (_polylines).
    glyphs = [(_square(3, 3, 4) + rng.normal(0, 0.1, (4, 2)), [_square(4, 4, 1)]), (_square(9, 3, 4), [])]
    cuts = [_square(30, 30, 10), (_square(60, 60, 20), [_square(65, 65, 5)])]
    st = DxfStencil(ring, random_circles(rng, 50), cuts, "LAYER_07", "L7", glyphs)
    write_dxf_stencils(tmp_path / "a.dxf", [st], deterministic=True)
    doc = read(tmp_path / "a.dxf")
    handles = [int(e.dxf.handle, 16) for e in doc.entitydb.values()]
    assert len(handles) == len(set(handles)) and max(handles) < int(doc.header["$HANDSEED"], 16)
    polys = doc.modelspace().query("LWPOLYLINE")
    assert [p.dxf.layer for p in polys] == ["LAYER_07_SCORE"] * 3 + ["LAYER_07"] * 4
    assert all(p.closed for p in polys)
    # The same file, every polyline made by ezdxf: the same bytes.
    import stencil_cad.exchange.dxf as dxf

    def by_ezdxf(msp, layer, rings, shift, blocks):
        for r in rings:
            msp.add_lwpolyline((r + shift).tolist(), format="xy", close=True, dxfattribs={"layer": layer})

    real = dxf._polylines
    dxf._polylines = by_ezdxf
    try:
        write_dxf_stencils(tmp_path / "b.dxf", [st], deterministic=True)
    finally:
        dxf._polylines = real
    assert (tmp_path / "a.dxf").read_bytes() == (tmp_path / "b.dxf").read_bytes()


def test_kerf_compensation(tmp_path, rng, ring):
    c = random_circles(rng, 50)
    kerf = 0.2
    square = np.array([[20, 20], [40, 20], [40, 40], [20, 40]], dtype=float)
    island = np.array([[25, 25], [25, 30], [30, 30], [30, 25]], dtype=float)  # clockwise
    info = write_dxf(tmp_path / "k.dxf", ring, c, polygons=[(square, [island])], kerf_mm=kerf)
    doc = read(tmp_path / "k.dxf")
    shift = np.array(info.offset_mm)
    got = sort_rows(circles_of(doc))
    np.testing.assert_allclose(got[:, 2], sort_rows(c)[:, 2] - kerf / 2, atol=1e-12)
    polys = [np.array(p.get_points("xy")) - shift for p in doc.modelspace().query("LWPOLYLINE")]
    areas = sorted(abs(polygon_area(p)) for p in polys)
    # Cut-out shrinks by kerf/2 on each side, the island grows by kerf/2.
    assert areas[0] == pytest.approx((5 + kerf) ** 2)
    assert areas[1] == pytest.approx((20 - kerf) ** 2)
    # The outline grows by kerf/2: area by about perimeter * kerf/2.
    perimeter = np.sum(np.hypot(*np.diff(np.vstack([ring, ring[:1]]), axis=0).T))
    assert areas[2] == pytest.approx(polygon_area(ring) + perimeter * kerf / 2, rel=1e-5)
    np.testing.assert_allclose(polys[-1].min(axis=0), ring.min(axis=0) - kerf / 2, atol=1e-9)
    np.testing.assert_allclose(polys[-1].max(axis=0), ring.max(axis=0) + kerf / 2, atol=1e-9)
    assert info.bbox_mm[0] == 0.0 and info.bbox_mm[1] == 0.0


def test_kerf_wider_than_hole_is_refused(tmp_path, ring):
    with pytest.raises(ValueError, match="kerf"):
        write_dxf(tmp_path / "k.dxf", ring, np.array([[10.0, 10.0, 0.5]]), kerf_mm=1.0)
    with pytest.raises(ValueError, match="kerf_mm must be ≥ 0"):
        write_dxf(tmp_path / "k.dxf", ring, np.array([[10.0, 10.0, 0.5]]), kerf_mm=-0.1)


def test_offset_ring_square():
    sq = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], dtype=float)
    np.testing.assert_allclose(offset_ring(sq, 1.0), [[1, 1], [9, 1], [9, 9], [1, 9]])
    np.testing.assert_allclose(offset_ring(sq, -1.0), [[-1, -1], [11, -1], [11, 11], [-1, 11]])


def test_offset_ring_circle_polygon():
    t = np.linspace(0, 2 * math.pi, 400, endpoint=False)
    circle = np.column_stack([np.cos(t), np.sin(t)]) * 5.0
    grown = offset_ring(circle, -0.1)
    # Edges of a regular polygon move by exactly delta: apothem 5 cos(pi/n) + 0.1.
    apothem = np.hypot(*(0.5 * (grown + np.roll(grown, -1, axis=0))).T)
    np.testing.assert_allclose(apothem, 5 * math.cos(math.pi / 400) + 0.1, rtol=1e-12)


def _header_vars(text):
    """``$NAME -> value`` of a DXF's HEADER section, read from the group-code pairs."""
    lines = text.splitlines()
    pairs = list(zip(lines[0::2], lines[1::2], strict=False))
    out, name = {}, None
    for code, value in pairs[pairs.index(("  2", "HEADER")) + 1 :]:
        if code.strip() == "0" and value == "ENDSEC":
            break
        if code.strip() == "9":
            name = value
        elif name is not None and name not in out:
            out[name] = value
    return out


def test_deterministic_header(tmp_path, rng, ring):
    # The fixed metadata, not two writes in the same second: ezdxf's dates of 2000-01-01,
    # zero GUIDs and its fixed marker, whenever the file is written. (ezdxf's loader stamps
    # new values on read, so the file's own text is read.)
    write_dxf(tmp_path / "a.dxf", ring, random_circles(rng, 100), deterministic=True)
    assert not ezdxf.options.write_fixed_meta_data_for_testing  # the option is put back
    text = (tmp_path / "a.dxf").read_text()
    head = _header_vars(text)
    for var in ("$TDCREATE", "$TDUCREATE", "$TDUPDATE", "$TDUUPDATE"):
        assert head[var] == "2451545.0", var
    assert head["$VERSIONGUID"] == head["$FINGERPRINTGUID"] == "{00000000-0000-0000-0000-000000000000}"
    assert "0.0 @ 2000-01-01T00:00:00.000000+00:00" in text
    read(tmp_path / "a.dxf")  # and it is a valid drawing


def test_layer_per_stencil_stacked_and_in_a_row(tmp_path, rng, ring):
    sets = [DotSet(xy_mm=rng.uniform(5, 145, (n, 2)), r_mm=np.full(n, 0.6)) for n in (30, 40, 50)]
    info = dxf_from_layers(tmp_path / "s.dxf", sets, ring)
    doc = read(tmp_path / "s.dxf")
    assert info.layers == ["STENCIL_01", "STENCIL_02", "STENCIL_03"]
    for name, ds in zip(info.layers, sets, strict=True):
        got = circles_of(doc, name)
        assert len(got) == len(ds)
        np.testing.assert_allclose(
            sort_rows(got[:, :2]), sort_rows(ds.xy_mm + info.offset_mm), atol=1e-12
        )  # stacked: every layer registers
    outlines = [np.array(p.get_points("xy")) for p in doc.modelspace().query("LWPOLYLINE")]
    assert len(outlines) == 3 and all(np.array_equal(o, outlines[0]) for o in outlines)

    info = dxf_from_layers(tmp_path / "r.dxf", sets, ring, arrange="row")
    doc = read(tmp_path / "r.dxf")
    boxes = []
    for name in info.layers:
        (p,) = doc.modelspace().query(f'LWPOLYLINE[layer=="{name}"]')
        pts = np.array(p.get_points("xy"))
        boxes.append((pts[:, 0].min(), pts[:, 0].max()))
    assert all(b1[0] - b0[1] == pytest.approx(5.0) for b0, b1 in zip(boxes, boxes[1:], strict=False))


def test_polygons_only_and_plain_rings(tmp_path, ring):
    tri = np.array([[10, 10], [30, 10], [20, 25]], dtype=float)
    cw_square = np.array([[50, 50], [50, 60], [60, 60], [60, 50]], dtype=float)
    write_dxf(tmp_path / "p.dxf", ring, polygons=[tri, cw_square])
    doc = read(tmp_path / "p.dxf")
    msp = doc.modelspace()
    assert len(msp.query("CIRCLE")) == 0
    polys = msp.query("LWPOLYLINE")
    assert len(polys) == 3 and all(p.closed for p in polys)


def test_bad_input(tmp_path, ring):
    with pytest.raises(ValueError, match="radii"):
        write_dxf(tmp_path / "x.dxf", ring, np.array([[1.0, 1.0, 0.0]]))
    with pytest.raises(ValueError, match="differ"):
        write_dxf_stencils(
            tmp_path / "x.dxf", [DxfStencil(ring, layer_name="A"), DxfStencil(ring, layer_name="a")]
        )
    with pytest.raises(ValueError, match="3 distinct"):
        write_dxf(tmp_path / "x.dxf", ring[:2])


def test_cut_layers(tmp_path, ring):
    sq = np.array([[20, 20], [40, 20], [40, 40], [20, 40]], dtype=float)
    hole = np.array([[25, 25], [25, 30], [30, 30], [30, 25]], dtype=float)
    tri = np.array([[60, 60], [80, 60], [70, 75]], dtype=float)
    layers = [
        CutLayer(polygons=[(sq, [hole])], colour=np.zeros(3)),
        CutLayer(polygons=[(tri, []), (sq + 50, [])], colour=np.ones(3)),
    ]
    info = dxf_from_layers(tmp_path / "h.dxf", layers, ring, kerf_mm=0.1)
    doc = read(tmp_path / "h.dxf")
    assert info.polylines == [3, 3] and info.circles == [0, 0]
    for name, n in (("STENCIL_01", 3), ("STENCIL_02", 3)):
        assert len(doc.modelspace().query(f'LWPOLYLINE[layer=="{name}"]')) == n
