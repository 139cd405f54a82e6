"""The kernel-free check of a plate's STEP text: it passes the writer's plates and names what a broken file breaks."""

import re
from dataclasses import replace

import numpy as np
import pytest

from stencil_cad.exchange.step import step_text
from stencil_cad.exchange.step_check import check_step_text, expected_counts
from stencil_cad.model import PlateGeometry

SQUARE = np.array([[0.0, 0.0], [30.0, 0.0], [30.0, 20.0], [0.0, 20.0]])


def plate(relief=0.0, polygons=True, glyphs=True, xy=None, r=None):
    """A 30 x 20 mm plate: round holes, a square cut-out and two letters (one with an island)."""
    xy = np.array([[5.0, 5.0], [9.0, 5.0], [5.0, 9.0], [22.0, 14.0]]) if xy is None else np.asarray(xy)
    r = np.array([1.0, 1.2, 0.8, 1.5]) if r is None else np.asarray(r)
    cut = (np.array([[14.0, 3.0], [18.0, 3.0], [18.0, 8.0], [14.0, 8.0]]),) if polygons else ()
    letters = (
        (np.array([[20.0, 2.0], [23.0, 2.0], [23.0, 6.0], [20.0, 6.0]]), [np.array([[21.0, 3.0], [21.0, 5.0], [22.0, 5.0], [22.0, 3.0]])]),
        (np.array([[24.0, 2.0], [26.0, 2.0], [25.0, 5.0]]), []),
    )  # fmt: skip
    return PlateGeometry(
        width_mm=30.0,
        height_mm=20.0,
        thickness_mm=1.2,
        outline=SQUARE,
        circles_xy=xy,
        circles_r=r,
        polygons=cut,
        glyphs=letters if glyphs and relief else (),
        relief_mm=relief,
    )


@pytest.mark.parametrize("relief", [0.0, -0.4, 0.3])
def test_the_writers_plates_pass(relief):
    geom = plate(relief)
    rep = check_step_text(step_text(geom), geom)
    assert rep["fails"] == []
    assert rep["solids"] == 1 and rep["shells"] == 1
    assert rep["genus"] == geom.hole_count == 5
    assert rep["cylinders"] == 4 and rep["faces"] == expected_counts(geom)["faces"]
    assert rep["volume"] == pytest.approx(geom.volume, rel=1e-12)
    np.testing.assert_allclose(rep["bbox"], geom.bbox, atol=1e-9)


def test_a_plate_without_holes_passes():
    geom = plate(polygons=False, xy=np.zeros((0, 2)), r=np.zeros(0))
    rep = check_step_text(step_text(geom), geom)
    assert rep["fails"] == [] and rep["genus"] == 0 and rep["faces"] == 6


# ----------------------------------------------------------------------------- broken files


@pytest.fixture(scope="module")
def written():
    geom = plate(-0.4)
    return geom, step_text(geom)


def entities(text, kind):
    """``{id: body}`` of every entity of ``kind``, in the order written."""
    return {int(i): b for i, b in re.findall(rf"^#(\d+)=({kind}\(.*\));$", text, flags=re.M)}


def set_entity(text, i, body):
    new, n = re.subn(rf"^#{i}=.*;$", f"#{i}={body};", text, count=1, flags=re.M)
    assert n == 1
    return new


def fails_of(text, geom):
    return "; ".join(check_step_text(text, geom)["fails"])


def side_loop(text):
    """The id and oriented edges of the first four-edge loop (a side face)."""
    for i, body in entities(text, "EDGE_LOOP").items():
        oes = re.findall(r"#(\d+)", body)
        if len(oes) == 4:
            return i, [int(o) for o in oes]
    raise AssertionError("no side face")


def test_a_flipped_oriented_edge_is_named(written):
    geom, text = written
    _, oes = side_loop(text)
    body = entities(text, "ORIENTED_EDGE")[oes[0]]
    bad = set_entity(text, oes[0], body.replace(".T.)", ".F.)"))
    got = fails_of(bad, geom)
    assert "used twice in the same direction" in got and "do not close" in got


def test_an_edge_used_three_times_and_once_is_named(written):
    geom, text = written
    loop, oes = side_loop(text)
    # The loop's first oriented edge now uses the edge of its third: that edge three times, its own once.
    third = entities(text, "ORIENTED_EDGE")[oes[2]]
    bad = set_entity(text, oes[0], third)
    got = fails_of(bad, geom)
    assert "not used by exactly two ORIENTED_EDGEs" in got and "once" in got and "three times" in got


def test_a_face_dropped_from_the_shell_is_named(written):
    geom, text = written
    ((shell, body),) = entities(text, "CLOSED_SHELL").items()
    first = re.search(r"#(\d+),", body).group(0)
    got = fails_of(set_entity(text, shell, body.replace(first, "", 1)), geom)
    assert "not in the solid's shell" in got


def test_a_second_solid_is_named(written):
    geom, text = written
    ((shell, _),) = entities(text, "CLOSED_SHELL").items()
    n = max(int(i) for i in re.findall(r"^#(\d+)=", text, flags=re.M)) + 1
    bad = text.replace("\nENDSEC;\nEND-ISO", f"\n#{n}=MANIFOLD_SOLID_BREP('',#{shell});\nENDSEC;\nEND-ISO")
    assert "exactly one MANIFOLD_SOLID_BREP, the file has 2" in fails_of(bad, geom)


def test_a_broken_loop_is_named(written):
    geom, text = written
    loop, oes = side_loop(text)
    swapped = f"EDGE_LOOP('',(#{oes[0]},#{oes[2]},#{oes[1]},#{oes[3]}))"
    got = fails_of(set_entity(text, loop, swapped), geom)
    assert "EDGE_LOOPs do not close" in got and f"#{loop}" in got


@pytest.mark.parametrize(
    "where, match",
    [
        ([9.0, 5.5], "round holes overlap or touch"),  # onto its neighbour at (9, 5)
        ([9.0, 7.7], "round holes overlap or touch"),  # tangent to it (1.2 + 1.5 mm apart)
        ([0.5, 12.0], "leaves its outer bound"),  # across the outline
        ([15.0, 4.0], "lies in a polygon bound"),  # across the cut-out
        ([21.0, 4.0], "lies in a polygon bound"),  # under a letter
    ],
)
def test_a_hole_moved_onto_another_bound_is_named(written, where, match):
    geom, _ = written
    xy = geom.circles_xy.copy()
    xy[3] = where
    moved = step_text(replace(geom, circles_xy=xy))
    got = fails_of(moved, geom)
    assert match in got
    assert "volume" not in got  # the same holes, elsewhere: only the geometry check sees it


def test_a_wrong_radius_changes_the_volume(written):
    geom, _ = written
    r = geom.circles_r.copy()
    r[0] += 0.01
    got = fails_of(step_text(replace(geom, circles_r=r)), geom)
    assert "differs from the analytic" in got


def test_a_top_circle_off_its_cylinder_is_named(written):
    geom, text = written
    circles = entities(text, "CIRCLE")
    last = max(circles)  # a top circle (written after the bottom ones)
    body = re.sub(r",([0-9.]+)\)$", lambda m: f",{float(m.group(1)) + 0.05:.10f})", circles[last])
    got = fails_of(set_entity(text, last, body), geom)
    assert "off its cylinder" in got and "does not lie on its circle" in got and "analytic" in got


def test_a_missing_hole_breaks_the_genus_and_the_counts(written):
    geom, _ = written
    fewer = replace(geom, circles_xy=geom.circles_xy[:-1], circles_r=geom.circles_r[:-1])
    got = fails_of(step_text(fewer), geom)
    assert "Euler–Poincaré" in got and "cylindrical hole faces" in got


def test_text_that_is_not_a_plate_step_is_refused(written):
    geom, text = written
    assert "cannot be read" in fails_of("hello", geom)
    circle = next(iter(entities(text, "CIRCLE")))
    bad = set_entity(text, circle, "CIRCLE('',#1,abc)")
    assert "cannot be read" in fails_of(bad, geom)


# ----------------------------------------------------------------------------- what the reader refuses


def test_a_value_that_is_not_a_finite_number_is_refused(written):
    # float() reads "nan", and every comparison with it is False: read, it would pass every check.
    geom, text = written
    direction = next(iter(entities(text, "DIRECTION")))
    got = fails_of(set_entity(text, direction, "DIRECTION('',(nan,nan,0.))"), geom)
    assert "cannot be read" in got and "not a finite number" in got


def test_a_point_with_the_wrong_number_of_coordinates_is_refused(written):
    # Two points of 2 and 4 coordinates hold the right total: each point is counted on its own.
    geom, text = written
    first, second = list(entities(text, "CARTESIAN_POINT"))[1:3]
    bad = set_entity(
        set_entity(text, first, "CARTESIAN_POINT('',(1.,2.))"), second, "CARTESIAN_POINT('',(1.,2.,3.,4.))"
    )
    assert "wrong number of values" in fails_of(bad, geom)


def test_a_labelled_entity_is_not_read_as_one_of_the_writers(written):
    # A '#' in a label would read as a reference: an entity with a label is of no kind read here.
    geom, text = written
    loop, oes = side_loop(text)
    bad = set_entity(text, loop, f"EDGE_LOOP('#{oes[0]}',(" + ",".join(f"#{o}" for o in oes) + "))")
    got = fails_of(bad, geom)
    assert "cannot be read" in got and f"#{loop} is not a EDGE_LOOP" in got


def test_ids_far_past_the_entity_count_are_refused(written):
    geom, text = written
    bad = text.replace("\nENDSEC;\nEND-ISO", "\n#999999999=CARTESIAN_POINT('',(0.,0.,0.));\nENDSEC;\nEND-ISO")
    assert "entity ids run to #999999999" in fails_of(bad, geom)


def test_the_solid_must_be_the_products_shape_in_millimetres(written):
    # OCCT finds no shape when the representation does not list the solid, and reads metres as metres.
    geom, text = written
    ((rep, body),) = entities(text, "ADVANCED_BREP_SHAPE_REPRESENTATION").items()
    solid = next(iter(entities(text, "MANIFOLD_SOLID_BREP")))
    got = fails_of(set_entity(text, rep, body.replace(f",#{solid})", ")")), geom)
    assert f"the solid #{solid} is not an item of the product's shape" in got
    assert "not in millimetres" in fails_of(
        text.replace("SI_UNIT(.MILLI.,.METRE.)", "SI_UNIT($,.METRE.)"), geom
    )
    no_product = text.replace("=SHAPE_DEFINITION_REPRESENTATION(", "=PROPERTY_DEFINITION_REPRESENTATION(")
    assert "no one SHAPE_DEFINITION_REPRESENTATION names the shape" in fails_of(no_product, geom)


# ----------------------------------------------------------------------------- faults OCCT's analyzer passes


def _face_on(text, surfaces):
    """The id and body of the first ADVANCED_FACE on one of ``surfaces``."""
    for i, body in entities(text, "ADVANCED_FACE").items():
        if int(re.findall(r"#(\d+)", body)[-1]) in surfaces:
            return i, body
    raise AssertionError("no such face")


def test_a_side_face_turned_inside_out_is_named(written):
    # The edge uses and the volume are the same, and OCCT's analyzer passes it: the face's own
    # normal against its loop is what is wrong.
    geom, text = written
    sides = {i for i, b in entities(text, "PLANE").items()} - {
        int(re.findall(r"#(\d+)", b)[-1])
        for b in entities(text, "ADVANCED_FACE").values()
        if b.count("#") > 2
    }
    face, body = _face_on(text, sides)
    got = fails_of(set_entity(text, face, body.replace(".T.)", ".F.)")), geom)
    assert f"1 vertical faces have their normal against their loop (first #{face})" in got
    face, body = _face_on(text, set(entities(text, "CYLINDRICAL_SURFACE")))
    got = fails_of(set_entity(text, face, body.replace(".F.)", ".T.)")), geom)
    assert f"1 cylindrical faces have their normal against their loop (first #{face})" in got


def test_an_engraving_as_deep_as_the_plate_is_named(written):
    # Its floor would lie on the bottom, facing up: the volume and the box are those of the description.
    geom, _ = written
    through = replace(geom, relief_mm=-geom.thickness_mm)
    got = fails_of(step_text(through), through)
    assert "none is left below" in got and "volume" not in got and "bounding box" not in got


def test_a_face_at_a_height_the_description_has_not_is_named(written):
    geom, text = written
    floor = replace(geom, relief_mm=-0.3)  # the file's floors at 0.8 mm, the description's at 0.9
    assert (
        "horizontal faces lie where the description has none (first at z = 0.800000 mm, facing up)"
        in fails_of(text, floor)
    )


def test_a_bound_without_area_and_a_hole_without_radius_are_named():
    flat = np.array([[4.0, 4.0], [8.0, 4.0], [6.0, 4.0]])  # a cut-out folded flat: OCCT rejects its file
    geom = replace(plate(polygons=False), polygons=(flat,))
    assert "enclose no area" in fails_of(step_text(geom), geom)
    r = plate().circles_r.copy()
    r[0] = 0.0
    geom = plate(r=r)
    assert "a degenerate hole" in fails_of(step_text(geom), geom)


LETTER = np.array([[20.0, 2.0], [23.0, 2.0], [23.0, 6.0], [20.0, 6.0]])


@pytest.mark.parametrize("relief", [-0.4, 0.3])
@pytest.mark.parametrize(
    "glyphs, match",
    [
        # An island out of its letter: only the letter's floor (engraved) or top (embossed) shows it.
        (((LETTER, [np.array([[10.0, 12.0], [10.0, 14.0], [12.0, 14.0], [12.0, 12.0]])]),), "lie outside"),
        (((LETTER, [np.array([[21.0, 3.0], [21.0, 7.0], [22.0, 7.0], [22.0, 3.0]])]),), "cross or touch"),
        (((LETTER, []), (LETTER + [2.0, 1.0], [])), "cross or touch"),  # letters over each other
        (((LETTER - [16.0, -1.0], []),), "lies in a polygon bound"),  # a letter over a round hole
        (((LETTER + [8.0, 0.0], []),), "cross or touch"),  # a letter across the outline
    ],
)
def test_a_faulty_label_is_named(relief, glyphs, match):
    geom = replace(plate(relief, polygons=False), glyphs=glyphs)
    assert match in fails_of(step_text(geom), geom)
