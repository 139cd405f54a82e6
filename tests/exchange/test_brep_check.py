"""The kernel-free check of a wall's STEP text fails a broken file, naming what is wrong."""

import re

import pytest

from stencil_cad.cad.wall import build_wall
from stencil_cad.config.cad import WallConfig
from stencil_cad.config.outline import OutlineConfig
from stencil_cad.exchange.brep_check import check_brep_text


@pytest.fixture(scope="module")
def wall():
    return build_wall(150.0, 150.0, OutlineConfig(), WallConfig(), 1.2, 5.0)


def _fails(wall, text, volume=None, genus=1):
    v = wall.volume_mm3 if volume is None else volume
    return check_brep_text(text, v, wall.bbox, genus, bbox_atol_mm=1e-3)["fails"]


def _entities(text):
    return {m.group(1): m.group(0) for m in re.finditer(r"^#(\d+)=.*;$", text, flags=re.M)}


def _faces_on(text, kind):
    """The ADVANCED_FACE lines whose surface is a ``kind`` (PLANE: with its normal's z)."""
    ents = _entities(text)
    out = []
    for line in ents.values():
        if not line.split("=", 1)[1].startswith("ADVANCED_FACE"):
            continue
        surface = ents[re.findall(r"#(\d+)", line)[-1]]
        if kind not in surface:
            continue
        if kind == "PLANE":
            axis = ents[re.findall(r"#(\d+)", surface)[1]]
            normal = ents[re.findall(r"#(\d+)", axis)[2]]
            out.append((line, float(re.findall(r"-?\d+\.\d+", normal)[-1])))
        else:
            out.append((line, None))
    return out


def _flip_face(text, line):
    flipped = line[:-5] + (".F.);" if line.endswith(".T.);") else ".T.);")
    return text.replace(line, flipped, 1)


def test_the_written_wall_passes(wall):
    assert _fails(wall, wall.step_text) == []


@pytest.mark.parametrize("which", ["bottom", "top"])
def test_a_horizontal_face_turned_into_the_material_fails(wall, which):
    # Its loops (and so the volume) are untouched: only the face's own normal says it is wrong.
    flat = [(line, nz) for line, nz in _faces_on(wall.step_text, "PLANE") if abs(nz) == 1.0]
    line = next(line for line, nz in flat if (nz < 0) == (which == "bottom"))
    fails = _fails(wall, _flip_face(wall.step_text, line))
    assert any("horizontal faces have a bound that runs the wrong way" in f for f in fails), fails


def test_a_side_face_turned_into_the_material_fails(wall):
    line = next(line for line, nz in _faces_on(wall.step_text, "PLANE") if nz == 0.0)
    assert any(
        "vertical faces have their normal against" in f
        for f in _fails(wall, _flip_face(wall.step_text, line))
    )
    line = _faces_on(wall.step_text, "CYLINDRICAL_SURFACE")[0][0]
    assert any(
        "cylindrical faces have their normal" in f for f in _fails(wall, _flip_face(wall.step_text, line))
    )


def test_a_dropped_face_fails(wall):
    text = re.sub(r"CLOSED_SHELL\('',\(#\d+,", "CLOSED_SHELL('',(", wall.step_text, count=1)
    assert any("not used by exactly two" in f for f in _fails(wall, text))


def test_a_moved_vertex_fails(wall):
    text = wall.step_text
    point = re.search(r"VERTEX_POINT\('',#(\d+)\)", text).group(1)
    line = re.search(rf"^#{point}=CARTESIAN_POINT\('',\(([^,]+),.*$", text, flags=re.M)
    moved = line.group(0).replace(line.group(1), f"{float(line.group(1)) + 0.01:.10f}", 1)
    assert any("off their line" in f for f in _fails(wall, text.replace(line.group(0), moved, 1)))


def test_a_wrong_volume_or_genus_fails(wall):
    assert any(f.startswith("volume ") for f in _fails(wall, wall.step_text, volume=1.001 * wall.volume_mm3))
    assert any("genus 1" in f for f in _fails(wall, wall.step_text, genus=0))
