"""The stencil plate: analytic oracles for volume, bbox, hole count, validity; bad input; templates."""

import math
import shutil
import textwrap

import numpy as np
import pytest

from stencil_cad import cad
from stencil_cad.cad.plate import PlateBuildError, perforated_plate
from stencil_cad.cad.template import builtin_template, load_template, template_parameters
from stencil_cad.cad.validate import PlateCheckError, brep_valid
from stencil_cad.config import PlateConfig
from stencil_cad.config.cad import LabelMode
from stencil_cad.exchange.mesh import circle_segments, mesh_checks, plate_mesh
from stencil_cad.model import CutLayer, DotSet
from stencil_cad.outline import label_region, plate_outline

W, H = 40.0, 30.0
LABEL = cad.LabelInfo(layer=2, layers=3, colour="#1a2b3c", job="test")


def shoelace(ring):
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def grid_dots(w=W, h=H, pitch=2.5, r=(0.5, 0.9), seed=0):
    rng = np.random.default_rng(seed)
    xs = np.arange(pitch / 2 + 0.5, w - pitch / 2, pitch)
    ys = np.arange(pitch / 2 + 0.5, h - pitch / 2, pitch)
    xy = np.stack(np.meshgrid(xs, ys), -1).reshape(-1, 2)
    radius = rng.uniform(*r, len(xy))
    return DotSet(xy, radius)


def cfg(**kw):
    # A 1.2 mm plate: the oracles below are written for it (a plate section alone defaults thinner).
    return PlateConfig(**{"thickness_mm": 1.2, **kw})


@pytest.fixture(scope="module")
def plain():
    dots = grid_dots()
    return dots, cad.build_plate(dots, W, H, cfg(label=LabelMode.none), LABEL)


def test_plain_plate_matches_analytic_oracle(plain):
    dots, model = plain
    t = 1.2
    ring = plate_outline(W, H, PlateConfig().outline)
    expected = (shoelace(ring) - math.pi * np.sum(dots.r_mm**2)) * t
    rep = cad.check_plate(model, dots)
    assert rep["n_solids"] == 1
    assert rep["valid"] and rep["valid_method"].startswith("BRepCheck_Analyzer (whole")
    assert rep["volume"] == pytest.approx(expected, rel=1e-9)
    assert rep["hole_count"] == len(dots)
    lo, hi = ring.min(axis=0), ring.max(axis=0)
    np.testing.assert_allclose(rep["bbox"], [[lo[0], lo[1], 0.0], [hi[0], hi[1], t]], atol=1e-6)
    assert rep["mesh"]["watertight"] and rep["mesh"]["consistent_winding"]
    assert rep["mesh"]["genus"] == len(dots)


@pytest.mark.parametrize("mode", ["none", "engrave", "emboss"])
def test_flux_volume_equals_gprop(mode):
    from stencil_cad.cad.occt import volume
    from stencil_cad.cad.validate import topology_checks

    m = cad.build_plate(grid_dots(pitch=4.0), W, H, cfg(label=LabelMode(mode)), LABEL)
    topo = topology_checks(m.part.wrapped)
    assert topo["flux_volume"] == pytest.approx(volume(m.part.wrapped), rel=1e-9)
    assert topo["flux_volume"] == pytest.approx(m.analytic_volume, rel=1e-9)


def test_plate_grows_up_from_z0(plain):
    # build123d faces can face -z; the plate must sit on z = 0 and grow up.
    _, model = plain
    bb = model.part.bounding_box()
    assert bb.min.Z == pytest.approx(0.0, abs=1e-9)
    assert bb.max.Z == pytest.approx(1.2, abs=1e-9)


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["engrave", "emboss"])
def test_label_volume_and_validity(mode):
    dots = grid_dots(pitch=4.0)
    base = cad.build_plate(dots, W, H, cfg(label=LabelMode.none), LABEL)
    model = cad.build_plate(dots, W, H, cfg(label=LabelMode(mode)), LABEL)
    rep = cad.check_plate(model, dots)
    assert rep["valid"] and rep["n_solids"] == 1
    assert brep_valid(model.part.wrapped)
    d = cfg().label_depth_mm  # the label's depth (or height, embossed) by default
    glyph_area = (base.part.volume - model.part.volume) / d
    if mode == "emboss":
        glyph_area = -glyph_area
        assert rep["bbox"][1][2] == pytest.approx(1.2 + d, abs=1e-9)
    # The letters take a real share of the label area, and the oracle agrees with GProp.
    assert 5.0 < glyph_area < 200.0
    assert model.part.volume == pytest.approx(model.analytic_volume, rel=1e-9)
    assert rep["mesh"]["genus"] == len(dots)


def test_label_glyph_area_close_to_the_font_outline():
    from build123d import Align, FontStyle, Text

    model = cad.build_plate(grid_dots(pitch=4.0), W, H, cfg(), LABEL)
    info = model.info["label"]
    from stencil_cad.cad.label import _bundled_font

    text = Text(
        info["text"],
        font_size=info["font_size_mm"],
        font=info["font"],
        font_path=_bundled_font(),
        font_style=FontStyle.BOLD,
        align=(Align.MIN, Align.MIN),
    )
    arrow = model.geometry.glyphs[0][0]
    polys = model.geometry.glyph_area - shoelace(arrow)
    # Letters are polygons within 0.01 mm of the curves: areas agree to a fraction of a percent.
    assert polys == pytest.approx(text.area, rel=5e-3)


def test_label_text_and_order():
    assert cad.label_text(LABEL) == "L2/3  SPRAY 2  #1A2B3C  test"
    assert "SPRAY 1" in cad.label_text(cad.LabelInfo(2, 3, "red", "x", spray_order=1))


def test_label_sits_in_the_border_clear_of_the_picture():
    model = cad.build_plate(grid_dots(pitch=4.0), W, H, cfg(), LABEL)
    area = label_region(W, H, PlateConfig().outline)
    pts = np.concatenate([o for o, _ in model.geometry.glyphs])
    assert pts[:, 1].max() < 0.0  # below the picture
    assert pts[:, 0].min() >= area[0] and pts[:, 0].max() <= area[2]
    assert pts[:, 1].min() >= area[1] and pts[:, 1].max() <= area[3]


def test_label_that_cannot_fit_raises():
    from stencil_cad.config.outline import OutlineConfig

    small = OutlineConfig(margin_mm=3.0, label_gap_mm=0.5, corner_radius_mm=1.0)
    with pytest.raises(PlateBuildError, match="does not fit"):
        cad.build_plate(grid_dots(pitch=4.0), W, H, cfg(outline=small, label_min_height_mm=3.0), LABEL)


@pytest.mark.parametrize(
    ("xy", "r", "match"),
    [
        ([[5.0, 5.0], [6.0, 5.0]], [0.6, 0.6], "web to dot 1"),  # overlap
        ([[0.3, 5.0], [10.0, 10.0]], [0.6, 0.6], "edge margin"),  # crosses the picture edge
        ([[5.0, 5.0], [10.0, 10.0]], [0.4, 0.6], "hole floor"),  # below the 0.5 mm floor
    ],
)
def test_bad_dots_raise_listing_the_offenders(xy, r, match):
    dots = DotSet(np.array(xy, float), np.array(r, float))
    with pytest.raises(PlateBuildError, match=match) as err:
        cad.build_plate(dots, W, H, cfg(label=LabelMode.none), LABEL)
    assert "dot 0" in str(err.value)


def test_cut_layer_polygons_volume():
    sq = np.array([[5, 5], [9, 5], [9, 9], [5, 9]], float)
    tri = np.array([[15, 5], [25, 5], [20, 12]], float)
    layer = CutLayer([(sq, []), (tri, [])], np.array([1.0, 0, 0]))
    model = cad.build_plate(layer, W, H, cfg(label=LabelMode.none), LABEL)
    ring = plate_outline(W, H, PlateConfig().outline)
    expected = (shoelace(ring) - 16.0 - 35.0) * 1.2
    rep = cad.check_plate(model, layer)
    assert rep["volume"] == pytest.approx(expected, rel=1e-9)
    assert rep["hole_count"] == 2 and rep["mesh"]["genus"] == 2


def test_cut_layer_with_unbridged_island_raises():
    outer = np.array([[5, 5], [15, 5], [15, 15], [5, 15]], float)
    island = np.array([[8, 8], [8, 12], [12, 12], [12, 8]], float)
    with pytest.raises(PlateBuildError, match="island"):
        cad.build_plate(CutLayer([(outer, [island])], np.zeros(3)), W, H, cfg(), LABEL)


def test_cut_layer_with_crossing_polygons_raises():
    a = np.array([[5, 5], [15, 5], [15, 15], [5, 15]], float)
    b = a + 5.0
    with pytest.raises(PlateBuildError, match="cross"):
        cad.build_plate(CutLayer([(a, []), (b, [])], np.zeros(3)), W, H, cfg(), LABEL)


def test_tile_check_path_is_used_above_the_limit():
    dots = grid_dots(pitch=2.5)
    model = cad.build_plate(dots, W, H, cfg(full_check_max_holes=10), LABEL)
    rep = cad.check_plate(model, dots)
    assert rep["valid"] and "tiles" in rep["valid_method"]
    assert rep["volume_method"].startswith("divergence")
    assert rep["volume"] == pytest.approx(model.analytic_volume, rel=1e-9)
    assert {t["tile"] for t in rep["tiles"]} >= {"label", "centre"}
    assert all(t["valid"] and t["holes"] > 0 for t in rep["tiles"] if t["tile"] != "label")


def _faulty(xy, r, polygons=()):
    """A plate description as given, checked by no rule (the B-rep check must catch what is wrong)."""
    from stencil_cad.model import PlateGeometry

    ring = np.array([[0.0, 0.0], [20.0, 0.0], [20.0, 20.0], [0.0, 20.0]])
    return PlateGeometry(
        width_mm=20.0,
        height_mm=20.0,
        thickness_mm=1.2,
        outline=ring,
        circles_xy=np.array(xy, dtype=np.float64).reshape(-1, 2),
        circles_r=np.array(r, dtype=np.float64),
        polygons=tuple(np.array(p, dtype=np.float64) for p in polygons),
        glyphs=(),
        relief_mm=0.0,
        label_box=None,
    )


@pytest.mark.parametrize(
    "xy, r, polygons, valid",
    [
        ([[5, 5], [10, 10]], [1, 1], (), True),
        ([[5, 5], [6, 5]], [1, 1], (), False),  # overlapping holes
        ([[5, 5], [7, 5]], [1, 1], (), False),  # tangent holes
        ([[0.5, 5]], [1], (), False),  # a hole across the edge
        ([[25, 5]], [1], (), False),  # a hole outside the plate
        ([[5, 5], [5, 5.1]], [2, 0.5], (), False),  # a hole inside a hole
        ([[5, 5], [5, 5]], [1, 1], (), False),  # the same hole twice
        ([[5, 5]], [1], ([[4, 14], [8, 14], [8, 18], [4, 18]],), True),
        ([[5, 5]], [1], ([[4, 4], [8, 4], [8, 8], [4, 8]],), False),  # a cut-out across a hole
        ([], [], ([[4, 4], [8, 8], [8, 4], [4, 8]],), False),  # a self-crossing cut-out
    ],
)
def test_stored_plane_curves_keep_the_brep_verdict(xy, r, polygons, valid):
    from stencil_cad.cad.solid import make_solid

    geom = _faulty(xy, r, polygons)
    assert brep_valid(make_solid(geom)) is valid
    assert brep_valid(make_solid(geom), plane_pcurves=True) is valid


@pytest.fixture(scope="module")
def few():
    """A plain plate with few holes: what the checks must catch does not depend on how many."""
    dots = grid_dots(pitch=6.0)
    return dots, cad.build_plate(dots, W, H, cfg(label=LabelMode.none), LABEL)


def test_check_catches_a_wrong_volume(few):
    from dataclasses import replace

    dots, model = few
    bad = cad.PlateModel(part=model.part, geometry=replace(model.geometry, thickness_mm=1.3), label=None)
    with pytest.raises(PlateCheckError, match="volume"):
        cad.check_plate(bad, dots)


def test_check_catches_two_solids(few):
    from build123d import Box, Part, Pos

    dots, model = few
    two = Part((model.part + Pos(200, 0, 0) * Box(5, 5, 5)).wrapped)
    with pytest.raises(PlateCheckError, match="one solid"):
        cad.check_plate(model.with_part(two), dots)


def test_check_catches_dots_that_are_not_the_holes(few):
    dots, model = few
    other = DotSet(dots.xy_mm + 0.01, dots.r_mm)
    with pytest.raises(PlateCheckError, match="not the given dots"):
        cad.check_plate(model, other)


# ----------------------------------------------------------------------------- mesh details


def test_hole_polygons_keep_the_area_within_tolerance():
    r = np.array([0.5, 0.8, 1.7, 5.0])
    for tol in (0.005, 0.02, 0.1):
        n, big = circle_segments(r, tol)
        area = 0.5 * n * big**2 * np.sin(2 * np.pi / n)
        np.testing.assert_allclose(area, np.pi * r**2, rtol=1e-12)
        assert np.all(big - r <= tol + 1e-12)
        assert np.all(r - big * np.cos(np.pi / n) <= tol + 1e-12)
        # Fewest sides: one fewer would break the tolerance (unless at the 8-side floor).
        m = n - 1
        s = np.sqrt(2 * np.pi / (m * np.sin(2 * np.pi / m)))
        dev = np.maximum(s - 1, 1 - s * np.cos(np.pi / m)) * r
        assert np.all((dev > tol) | (n == 8))


def test_mesh_of_nearly_touching_holes_is_closed():
    # Webs of 0.1 mm (the plate's floor) between 0.5 mm holes: ring edges must be recovered.
    # 15 x 11 holes: every web is as thin as in a full plate of them.
    xs = np.arange(2.0, 18.0, 1.1)
    xy = np.stack(np.meshgrid(xs, np.arange(2.0, 14.0, 1.1)), -1).reshape(-1, 2)
    dots = DotSet(xy, np.full(len(xy), 0.5))
    model = cad.build_plate(dots, W, H, cfg(), LABEL)
    for tol in (0.002, 0.02, 0.2):
        mc = mesh_checks(plate_mesh(model.geometry, tol))
        assert mc["watertight"] and mc["consistent_winding"] and mc["degenerate"] == 0
        assert mc["genus"] == len(dots)
        assert mc["volume"] == pytest.approx(model.analytic_volume, rel=1e-3)


def test_mesh_detects_overlapping_holes():
    from stencil_cad.exchange.mesh import MeshError
    from stencil_cad.model import PlateGeometry

    ring = np.array([[0, 0], [10, 0], [10, 10], [0, 10]], float)
    g = PlateGeometry(10, 10, 1.0, ring, np.array([[5.0, 5.0], [5.8, 5.0]]), np.array([0.5, 0.5]))
    with pytest.raises(MeshError):
        plate_mesh(g, 0.02)


# ----------------------------------------------------------------------------- templates


def test_builtin_template_defaults_match_the_config():
    from stencil_cad.config.cad import DEFAULT_THICKNESS_MM
    from stencil_cad.config.job import JobConfig
    from stencil_cad.plan.plan import unplanned

    params = template_parameters(load_template(builtin_template()))
    c = PlateConfig()
    # The config leaves the label and the thickness to the job (null); a default one-plate job's
    # plan engraves the label and fills in the template's thickness.
    assert c.label is None and c.thickness_mm is None
    job = unplanned(JobConfig()).plate
    assert job.label is not None and job.thickness_mm == DEFAULT_THICKNESS_MM
    assert params == {
        "THICKNESS_MM": job.thickness_mm,
        "LABEL": job.label.value,
        "LABEL_DEPTH_MM": c.label_depth_mm,
        "LABEL_HEIGHT_MM": c.label_height_mm,
        "LABEL_MIN_HEIGHT_MM": c.label_min_height_mm,
        "LABEL_FONT": c.label_font,
        "LABEL_TOLERANCE_MM": c.label_tolerance_mm,
    }


@pytest.fixture
def user_template(tmp_path):
    path = tmp_path / "my_plate.py"
    shutil.copy(builtin_template(), path)
    text = path.read_text().replace("THICKNESS_MM = 0.9", "THICKNESS_MM = 2.0")
    path.write_text(text)
    return path


def test_user_template_values_stand_unless_the_config_sets_them(user_template):
    dots = grid_dots(pitch=5.0)
    m = cad.build_plate(dots, W, H, PlateConfig(template=user_template, label=LabelMode.none), LABEL)
    assert m.geometry.thickness_mm == 2.0
    m = cad.build_plate(dots, W, H, cfg(template=user_template, thickness_mm=1.6), LABEL)
    assert m.geometry.thickness_mm == 1.6
    m = cad.build_plate(dots, W, H, cfg(template=user_template, template_params={"THICKNESS_MM": 0.8}), LABEL)
    assert m.part.bounding_box().max.Z == pytest.approx(0.8)


def test_unknown_template_parameter_raises(user_template):
    with pytest.raises(PlateBuildError, match="unknown parameter.*NOT_A_PARAM"):
        cad.build_plate(
            grid_dots(), W, H, cfg(template=user_template, template_params={"NOT_A_PARAM": 1}), LABEL
        )


def test_template_parameter_of_wrong_type_raises(user_template):
    with pytest.raises(PlateBuildError, match="THICKNESS_MM must be a float"):
        cad.build_plate(
            grid_dots(), W, H, cfg(template=user_template, template_params={"THICKNESS_MM": "x"}), LABEL
        )


def test_edited_template_solid_goes_through_occt(tmp_path):
    path = tmp_path / "edited.py"
    path.write_text(
        textwrap.dedent(
            """
            from build123d import Cylinder, Pos
            from stencil_cad.cad.plate import perforated_plate

            THICKNESS_MM = 1.2

            def build(holes, outline, label_area, label):
                plate = perforated_plate(holes, outline, label_area, None, thickness_mm=THICKNESS_MM, label_mode="none")
                x, y = outline[:, 0].min() + 5, outline[:, 1].max() - 5
                return plate.with_part(plate.part - Pos(x, y, 0.6) * Cylinder(1.5, 2.4))
            """
        )
    )
    dots = grid_dots(pitch=5.0)
    m = cad.build_plate(dots, W, H, cfg(template=path), LABEL)
    assert m.geometry is None
    rep = cad.check_plate(m, dots)
    ring = plate_outline(W, H, PlateConfig().outline)
    expected = (shoelace(ring) - math.pi * np.sum(dots.r_mm**2) - math.pi * 1.5**2) * 1.2
    assert rep["volume"] == pytest.approx(expected, rel=1e-6)
    assert rep["mesh"]["watertight"] and rep["mesh"]["genus"] == len(dots) + 1


def test_template_with_syntax_error_raises(tmp_path):
    path = tmp_path / "broken.py"
    path.write_text("def build(:\n")
    with pytest.raises(PlateBuildError, match="failed to load"):
        cad.build_plate(grid_dots(), W, H, cfg(template=path), LABEL)


def test_perforated_plate_rejects_too_deep_engraving():
    ring = plate_outline(W, H, PlateConfig().outline)
    with pytest.raises(PlateBuildError, match="label depth"):
        perforated_plate(grid_dots(), ring, None, None, thickness_mm=0.6, label_depth_mm=0.45)


@pytest.mark.parametrize("name", ["plate.py", pytest.param("plate_cadquery.py", marks=pytest.mark.slow)])
def test_every_bundled_template_builds_a_valid_plate(name):
    if name == "plate_cadquery.py":
        pytest.importorskip("cadquery")
    dots = grid_dots(pitch=4.0)
    m = cad.build_plate(dots, W, H, cfg(template=builtin_template(name)), LABEL)
    assert m.geometry is not None  # an unchanged solid keeps the fast exporters
    rep = cad.check_plate(m, dots)
    assert rep["valid"] and rep["hole_count"] == len(dots)
