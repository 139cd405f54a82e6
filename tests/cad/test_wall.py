import math

import build123d as bd
import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from stencil_cad.cad import occt
from stencil_cad.cad.parts import Wall
from stencil_cad.cad.wall import build_wall, wall_step, wall_stl
from stencil_cad.config import JobConfig
from stencil_cad.config.cad import WallConfig
from stencil_cad.config.outline import KeyTab, OutlineConfig, Side
from stencil_cad.exchange.step import STEP_TIMESTAMP
from stencil_cad.outline import (
    fits,
    min_clearance,
    path_area,
    plate_outline,
    symmetries,
    transform_ring,
)

pytestmark = pytest.mark.slow

W, H, T = 150.0, 150.0, 1.2


def prism(ring, z0, z1):
    pts = [bd.Vector(float(x), float(y), z0) for x, y in ring]
    face = bd.Face(bd.Wire.make_polygon(pts, close=True))
    return bd.Solid.extrude(face, bd.Vector(0, 0, z1 - z0))


def common_volume(a, b):
    c = a.intersect(b)
    return 0.0 if c is None else sum(s.volume for s in c.solids())


@pytest.fixture(scope="module")
def default_wall():
    return build_wall(W, H, OutlineConfig(), WallConfig(), T, 10.0)


def test_one_valid_solid_of_analytic_volume(default_wall):
    m = default_wall
    solids = m.part.solids()
    assert len(solids) == 1
    assert m.part.is_valid
    assert m.part.volume == pytest.approx(m.volume_mm3, rel=1e-6)
    # An independent oracle: frame of straight walls from the config's numbers.
    outline, wall = OutlineConfig(), WallConfig()
    c, t, mg = wall.clearance_mm, wall.wall_thickness_mm, outline.border_mm
    side = W + 2 * (mg + c + t)
    outer = side * side - (4 - math.pi) * (outline.corner_radius_mm + c + t) ** 2
    pocket = (W + 2 * (mg + c)) ** 2 - (4 - math.pi) * (outline.corner_radius_mm + c) ** 2
    # Tabs as plain rectangles (their rounded corners left out, worth ~0.2 %).
    outer += sum((k.width_mm + 2 * (c + t)) * k.depth_mm for k in outline.keys)
    pocket += sum((k.width_mm + 2 * c) * k.depth_mm for k in outline.keys)
    approx = outer * (10.0 + T) - W * H * 10.0 - pocket * T
    assert m.volume_mm3 == pytest.approx(approx, rel=0.005)


def test_bbox_and_orientation(default_wall):
    m = default_wall
    bb = m.part.bounding_box()
    got = (bb.min.X, bb.min.Y, bb.min.Z, bb.max.X, bb.max.Y, bb.max.Z)
    np.testing.assert_allclose(got, m.bbox, atol=1e-6)
    assert m.bbox[2] == 0.0 and m.bbox[5] == pytest.approx(10.0 + T)
    assert m.height_mm == pytest.approx(10.0 + T)
    # Bottom tab 3 mm + margin + clearance + rim.
    assert m.bbox[1] == pytest.approx(-(10 + 0.2 + 3 + 3))


def test_plate_sits_in_pocket_and_only_one_way(default_wall):
    m = default_wall
    outline = OutlineConfig()
    plate = plate_outline(W, H, outline)
    s = m.standoff_mm
    # The plate in place: no overlap with the wall, clearance all round.
    assert common_volume(prism(plate, s, s + T), m.part) == pytest.approx(0.0, abs=1e-6)
    assert min_clearance(plate, m.pocket_ring) >= 0.2 - 2 * outline.chord_tol_mm
    # It rests on the ledge: pushed 0.05 mm down it cuts into the wall by the ledge area.
    sunk = common_volume(prism(plate, s - 0.05, s + T - 0.05), m.part)
    slot_under_plate = WallConfig().finger_slot_mm * 3.0
    ledge_area = abs(path_area_ring(plate)) - W * H - slot_under_plate
    assert sunk == pytest.approx(0.05 * ledge_area, rel=1e-3)
    # Turned round or over, it collides with the rim.
    for name, mat in symmetries().items():
        moved = transform_ring(plate, mat, (W / 2, H / 2))
        assert not fits(moved, m.pocket_ring), name
        assert common_volume(prism(moved, s, s + T), m.part) > 1.0, name


def path_area_ring(ring):
    x, y = ring.T
    return 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def test_picture_area_is_open(default_wall):
    m = default_wall
    picture = np.array([[0, 0], [W, 0], [W, H], [0, H]], dtype=float)
    assert common_volume(prism(picture, -1.0, m.height_mm + 1.0), m.part) == pytest.approx(0.0, abs=1e-6)
    # ...and the wall's inner face is on the picture's edge: 0.1 mm wider, it touches the wall.
    wider = picture + np.array([[-0.1, -0.1], [0.1, -0.1], [0.1, 0.1], [-0.1, 0.1]])
    assert common_volume(prism(wider, 0.0, 1.0), m.part) > 0.0
    assert m.ledge_mm == pytest.approx(10.2)


def test_wall_blocks_overspray_on_every_side(default_wall):
    # A spray path from a hole (inside the picture, at the plate's underside) to a point of
    # the surface outside the picture crosses the picture's edge below the stand-off height;
    # a 0.1 mm skin just outside each edge, from the surface to the stand-off, is all wall.
    m, s, e = default_wall, default_wall.standoff_mm, 0.1
    skins = {
        "left": (-e, 5.0, 0.0, H - 5.0),
        "right": (W, 5.0, W + e, H - 5.0),
        "bottom": (5.0, -e, W - 5.0, 0.0),
        "top": (5.0, H, W - 5.0, H + e),
    }
    for name, (x0, y0, x1, y1) in skins.items():
        box = bd.Solid.make_box(x1 - x0, y1 - y0, s).moved(bd.Location((x0, y0, 0.0)))
        assert common_volume(box, m.part) == pytest.approx(box.volume, rel=1e-9), name


def test_several_heights_take_the_same_plate():
    outline = OutlineConfig()
    cfg = WallConfig(standoff_mm=[15.0, 5.0, 15.0, 8.5])
    heights = JobConfig(wall=cfg).standoff.walls_mm
    assert heights == [5.0, 8.5, 15.0]
    walls = [build_wall(W, H, outline, cfg, T, s) for s in heights]
    for w in walls:
        assert len(w.part.solids()) == 1
        assert w.part.volume == pytest.approx(w.volume_mm3, rel=1e-6)
        np.testing.assert_array_equal(w.pocket_ring, walls[0].pocket_ring)
    # Only the base frame grows with the stand-off.
    frame = path_area(w.rings.outer) - W * H
    assert walls[2].volume_mm3 - walls[0].volume_mm3 == pytest.approx(frame * 10.0, rel=1e-9)
    assert [w.name for w in walls] == ["wall_5mm", "wall_8.5mm", "wall_15mm"]


def test_non_square_and_opening_margin():
    outline = OutlineConfig(
        margin_mm=8.0,
        keys=[
            KeyTab(side=Side.top, position=0.2, width_mm=10),
            KeyTab(side=Side.right, position=0.6, width_mm=5),
        ],
    )
    cfg = WallConfig(opening_margin_mm=2.0, clearance_mm=0.3, pocket_depth_mm=1.0)
    m = build_wall(120.0, 80.0, outline, cfg, 1.6, 6.0)
    assert len(m.part.solids()) == 1
    assert m.part.volume == pytest.approx(m.volume_mm3, rel=1e-6)
    assert m.height_mm == pytest.approx(7.0)
    assert m.ledge_mm == pytest.approx(8.0 + 0.3 - 2.0)


def test_finger_slot():
    outline = OutlineConfig()
    plain = build_wall(W, H, outline, WallConfig(finger_slot_mm=0.0), T, 10.0)
    slotted = build_wall(W, H, outline, WallConfig(finger_slot_mm=20.0), T, 10.0)
    assert len(slotted.part.solids()) == 1 and slotted.part.is_valid
    # Through the 3 mm rim from 1.5 mm below the plate to the top, and 3 mm under the plate's edge.
    removed = 20.0 * (3.0 * (T + 1.5) + 3.0 * 1.5)
    assert plain.part.volume - slotted.part.volume == pytest.approx(removed, rel=1e-9)
    assert slotted.part.volume == pytest.approx(slotted.volume_mm3, rel=1e-9)
    # The slot is at the top side's middle: a probe there meets no wall in the slotted one.
    probe = bd.Solid.make_box(2, 2, 0.5).moved(bd.Location((W / 2 - 1, H + 10.2 + 1.0, 10.5)))
    assert common_volume(probe, slotted.part) == 0.0
    assert common_volume(probe, plain.part) == pytest.approx(2.0)
    top_tab = OutlineConfig(keys=[KeyTab(side=Side.top, position=0.45, width_mm=8)])
    with pytest.raises(ValueError, match="finger_slot_mm"):
        build_wall(W, H, top_tab, WallConfig(), T, 10.0)
    build_wall(W, H, top_tab, WallConfig(finger_slot_mm=0.0), T, 10.0)


def test_builder_mode():
    with bd.BuildPart() as bp:
        Wall(100.0, 100.0, OutlineConfig(), WallConfig(), T, 5.0)
    assert len(bp.part.solids()) == 1


@pytest.mark.parametrize(
    "kwargs,match",
    [
        ({"plate_thickness_mm": 0.0}, "plate thickness"),
        ({"standoff": 0.2}, "stand-off"),
        ({"wall_cfg": WallConfig(pocket_depth_mm=2.0)}, "pocket_depth_mm"),
        ({"wall_cfg": WallConfig(opening_margin_mm=9.9)}, "ledge"),
        ({"wall_cfg": WallConfig(clearance_mm=1.6)}, "twice"),
        (
            {"outline_cfg": OutlineConfig(keys=[KeyTab(side=Side.bottom, position=0.5, width_mm=10)])},
            "wrong placement",
        ),
    ],
)
def test_bad_input(kwargs, match):
    args = {
        "outline_cfg": OutlineConfig(),
        "wall_cfg": WallConfig(),
        "plate_thickness_mm": T,
        "standoff": 10.0,
    }
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        build_wall(W, H, args["outline_cfg"], args["wall_cfg"], args["plate_thickness_mm"], args["standoff"])


def test_tabs_too_close_for_shaped_rim_fall_back_to_plain_rim():
    outline = OutlineConfig(
        keys=[
            KeyTab(side=Side.bottom, position=0.3, width_mm=10),
            KeyTab(side=Side.bottom, position=0.4, width_mm=2),
        ]
    )
    m = build_wall(W, H, outline, WallConfig(), T, 5.0)
    assert len(m.part.solids()) == 1
    assert m.part.volume == pytest.approx(m.volume_mm3, rel=1e-6)
    # The rim still encloses the pocket with the wall thickness.
    assert min_clearance(m.pocket_ring, m.outer_ring) >= 3.0 - 1e-2


def test_step_and_stl_round_trip(default_wall, tmp_path):
    import trimesh

    wall_step(default_wall, tmp_path / "w.step")
    wall_stl(default_wall, tmp_path / "w.stl", tolerance_mm=0.01)
    back = bd.import_step(tmp_path / "w.step")
    assert len(back.solids()) == 1
    assert back.volume == pytest.approx(default_wall.volume_mm3, rel=1e-6)
    mesh = trimesh.load(tmp_path / "w.stl")
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.body_count == 1
    # Chords cut into the convex arcs of the rim and the pocket: within tolerance × area.
    assert mesh.volume == pytest.approx(default_wall.volume_mm3, rel=1e-3)
    np.testing.assert_allclose(
        mesh.bounds.ravel(), np.array(default_wall.bbox).reshape(2, 3).ravel(), atol=1e-3
    )


@settings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    w=st.floats(30, 250),
    h=st.floats(30, 250),
    margin=st.floats(5, 15),
    corner=st.floats(0, 1),
    clearance=st.floats(0, 0.5),
    thickness=st.floats(1.2, 5),
    standoff=st.floats(1, 30),
    pos=st.floats(0.2, 0.4),
    depth=st.floats(1.5, 5),
    slot=st.sampled_from([0.0, 10.0]),
)
def test_random_walls(w, h, margin, corner, clearance, thickness, standoff, pos, depth, slot):
    outline = OutlineConfig(
        margin_mm=margin,
        corner_radius_mm=corner * margin,
        keys=[
            KeyTab(side=Side.bottom, position=pos, width_mm=8, depth_mm=depth),
            KeyTab(side=Side.right, position=1 - pos, width_mm=4, depth_mm=depth),
        ],
    )
    cfg = WallConfig(clearance_mm=clearance, wall_thickness_mm=thickness, finger_slot_mm=slot)
    m = build_wall(w, h, outline, cfg, 1.2, standoff)
    assert len(m.part.solids()) == 1
    assert m.part.is_valid
    assert m.part.volume == pytest.approx(m.volume_mm3, rel=1e-6)
    bb = m.part.bounding_box()
    np.testing.assert_allclose(
        (bb.min.X, bb.min.Y, bb.min.Z, bb.max.X, bb.max.Y, bb.max.Z), m.bbox, atol=1e-6
    )
    plate = plate_outline(w, h, outline)
    assert fits(plate, m.pocket_ring, clearance, tol_mm=2 * outline.chord_tol_mm)


def _build123d_wall(w, h, outline, wall_cfg, thickness, standoff):
    """The wall made with build123d's own operations: the oracle for the wall module's."""
    from stencil_cad.cad.wall import wall_rings

    def wire(path, z):
        edges = []
        for s in path:
            p0, p1 = bd.Vector(*s.start, z), bd.Vector(*s.end, z)
            mid = bd.Vector(*s.midpoint(), z)
            edges.append(bd.Edge.make_three_point_arc(p0, mid, p1) if s.is_arc else bd.Edge.make_line(p0, p1))
        return bd.Wire(edges)

    def solid(path, z0, z1):
        return bd.Solid.extrude(bd.Face(wire(path, z0)), bd.Vector(0, 0, z1 - z0))

    rings = wall_rings(w, h, outline, wall_cfg)
    s, top = standoff, standoff + wall_cfg.pocket_depth(thickness)
    cut = solid(rings.opening, -1.0, top + 1.0).fuse(solid(rings.pocket, s, top + 1.0))
    if wall_cfg.finger_slot_mm > 0:
        m, c, t, fw = (
            outline.border_mm,
            wall_cfg.clearance_mm,
            wall_cfg.wall_thickness_mm,
            wall_cfg.finger_slot_mm,
        )
        under = min(3.0, m + c - wall_cfg.opening_margin_mm - 1.0)
        z0 = s - min(1.5, 0.5 * s)
        box = bd.Solid.make_box(fw, t + 1.0 + max(under, 0.0), top + 1.0 - z0)
        cut = cut.fuse(box.moved(bd.Location((0.5 * (w - fw), h + m + c - max(under, 0.0), z0))))
    return bd.Part(bd.Compound([solid(rings.outer, 0.0, top).cut(cut).clean()]).wrapped)


def read_step(path):
    """The shape OCCT's own STEP reader makes of a file."""
    from OCP.IFSelect import IFSelect_RetDone
    from OCP.STEPControl import STEPControl_Reader

    reader = STEPControl_Reader()
    assert reader.ReadFile(str(path)) == IFSelect_RetDone
    assert reader.TransferRoots() == 1
    return reader.OneShape()


@pytest.mark.parametrize("slot", [0.0, None])
@pytest.mark.parametrize("standoff", [3.0, 10.0])
def test_wall_files_hold_build123ds_wall(tmp_path, slot, standoff):
    # The wall is made through OCP alone (a job imports no build123d); the same wall made
    # with build123d's own operations is the oracle for the solid read back from its STEP.
    import trimesh

    wall_cfg = WallConfig() if slot is None else WallConfig(finger_slot_mm=slot)
    outline = OutlineConfig()
    m = build_wall(97.3, 61.9, outline, wall_cfg, T, standoff)
    wall_step(m, tmp_path / "wall.step")
    wall_stl(m, tmp_path / "wall.stl", tolerance_mm=0.01)
    part = _build123d_wall(97.3, 61.9, outline, wall_cfg, T, standoff)
    bb = part.bounding_box()
    oracle = (bb.min.X, bb.min.Y, bb.min.Z, bb.max.X, bb.max.Y, bb.max.Z)
    back = read_step(tmp_path / "wall.step")
    (solid,) = occt.solids(back)
    assert occt.is_valid(back)
    assert occt.volume(solid) == pytest.approx(part.volume, rel=1e-9)
    assert occt.volume(solid) == pytest.approx(m.volume_mm3, rel=1e-6)
    np.testing.assert_allclose(occt.bounding_box(back), oracle, atol=1e-6)
    assert occt.faces(back) == len(part.faces())
    # build123d's reader (through OCCT's document reader) agrees.
    theirs = bd.import_step(tmp_path / "wall.step")
    assert len(theirs.solids()) == 1 and len(theirs.faces()) == len(part.faces())
    assert theirs.volume == pytest.approx(part.volume, rel=1e-9)
    # The same wall, built again, gives the same bytes.
    again = build_wall(97.3, 61.9, outline, wall_cfg, T, standoff)
    wall_step(again, tmp_path / "again.step")
    wall_stl(again, tmp_path / "again.stl", tolerance_mm=0.01)
    for ext in ("step", "stl"):
        assert (tmp_path / f"again.{ext}").read_bytes() == (tmp_path / f"wall.{ext}").read_bytes(), ext
    text = (tmp_path / "wall.step").read_text()
    assert f"FILE_NAME('{m.name}','{STEP_TIMESTAMP}'" in text and "'stencil_cad'" in text
    assert "build123d" not in text
    mesh = trimesh.load(tmp_path / "wall.stl")
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.body_count == 1
    assert mesh.volume == pytest.approx(part.volume, rel=1e-3)
    np.testing.assert_allclose(mesh.bounds.ravel(), oracle, atol=1e-3)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    w=st.floats(60, 250),
    h=st.floats(30, 250),
    margin=st.floats(5, 15),
    corner=st.floats(0, 1),
    clearance=st.floats(0, 0.5),
    thickness=st.floats(1.2, 5),
    standoff=st.floats(0.5, 30),
    pos=st.floats(0.2, 0.4),
    depth=st.floats(1.5, 5),
    slot=st.sampled_from([0.0, 10.0, 16.0]),
    top_tab=st.booleans(),
    opening=st.floats(0, 4),
)
def test_random_wall_files_are_occts_wall(
    tmp_path_factory, w, h, margin, corner, clearance, thickness, standoff, pos, depth, slot, top_tab, opening
):
    # The wall drawn from its outlines (a job's, no OCCT) against the one OCCT cuts and unifies
    # (plate.check: kernel): its STEP text passes the kernel-free check, and OCCT reads it back as one
    # valid solid of the same volume, box and face count; its mesh is closed, of genus 1.
    from stencil_cad.cad.wall import check_wall
    from stencil_cad.exchange.mesh import mesh_checks

    keys = [
        KeyTab(side=Side.bottom, position=pos, width_mm=8, depth_mm=depth),
        KeyTab(side=Side.right, position=1 - pos, width_mm=4, depth_mm=depth),
    ]
    if top_tab:  # a tab on the slot's side, clear of it
        keys.append(KeyTab(side=Side.top, position=0.1, width_mm=5, depth_mm=depth))
    outline = OutlineConfig(margin_mm=margin, corner_radius_mm=corner * margin, keys=keys)
    cfg = WallConfig(
        clearance_mm=clearance, wall_thickness_mm=thickness, finger_slot_mm=slot, opening_margin_mm=opening
    )
    try:
        ours = build_wall(w, h, outline, cfg, 1.2, standoff)
    except ValueError:
        return  # sizes that make no wall: the kernel's route refuses them alike (test_bad_input)
    assert ours.brep is not None  # the slot reaches through every rim: no wall is left to OCCT
    kernel = build_wall(w, h, outline, cfg, 1.2, standoff, kernel=True)
    assert kernel.brep is None
    check = check_wall(ours)
    assert check["valid"] and check["rel_error"] < 1e-9
    path = tmp_path_factory.mktemp("wall") / "w.step"
    wall_step(ours, path)
    back = read_step(path)
    (solid,) = occt.solids(back)
    assert occt.is_valid(back)
    assert occt.volume(solid) == pytest.approx(occt.volume(occt.solids(kernel.shape)[0]), rel=1e-9)
    np.testing.assert_allclose(occt.bounding_box(back), occt.bounding_box(kernel.shape), atol=1e-6)
    assert occt.faces(back) == occt.faces(kernel.shape)
    mesh = mesh_checks(ours.brep.mesh(0.01))
    assert (
        mesh["watertight"] and mesh["consistent_winding"] and mesh["components"] == 1 and mesh["genus"] == 1
    )
    assert mesh["volume"] == pytest.approx(ours.volume_mm3, rel=1e-3)


@pytest.mark.parametrize("keys", [("top", 0.2, 0.27), ("left", 0.2, 0.29), ("bottom", 0.6, 0.67)])
def test_the_finger_slot_goes_through_a_plain_rim(tmp_path, keys):
    # Tabs too close together for the rim to follow them make it a plain rounded
    # rectangle, thicker by the deepest tab: the slot once stopped 1 mm into it, a blind pocket
    # the analytic volume did not know, and the wall failed its check under either route.
    side, *positions = keys
    tabs = [KeyTab(side=Side(side), position=p, width_mm=8) for p in positions]
    outline = OutlineConfig(keys=tabs)
    cfg = WallConfig()
    ours = build_wall(150.0, 150.0, outline, cfg, 1.2, 5.0)
    assert ours.rings.rim_mm > cfg.wall_thickness_mm  # the plain rim
    assert ours.brep is not None
    from stencil_cad.cad.wall import check_wall

    assert check_wall(ours)["valid"]
    kernel = build_wall(150.0, 150.0, outline, cfg, 1.2, 5.0, kernel=True)
    assert check_wall(kernel)["valid"]
    wall_step(ours, tmp_path / "w.step")
    back = read_step(tmp_path / "w.step")
    assert occt.is_valid(back) and occt.faces(back) == occt.faces(kernel.shape)
    assert occt.volume(occt.solids(back)[0]) == pytest.approx(kernel.volume_mm3, rel=1e-9)
    # The slot is open at the rim's outside: a point just inside the outer face, in the slot, is empty.
    top_y = max(float(s.end[1]) for s in ours.rings.outer)
    from OCP.BRepClass3d import BRepClass3d_SolidClassifier
    from OCP.gp import gp_Pnt
    from OCP.TopAbs import TopAbs_OUT

    probe = BRepClass3d_SolidClassifier(occt.solids(back)[0], gp_Pnt(75.0, top_y - 0.05, 5.5), 1e-7)
    assert probe.State() == TopAbs_OUT
