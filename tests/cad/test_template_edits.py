"""Template edits that change the solid build and pass the plate checks on real plates."""

import math

import numpy as np
import pytest

from stencil_cad import cad
from stencil_cad.cad.plate import PlateBuildError
from stencil_cad.cad.template import builtin_template
from stencil_cad.config import PlateConfig
from stencil_cad.exchange.mesh import plate_mesh
from stencil_cad.geometry import mesh_genus, polygon_area
from stencil_cad.model import DotSet
from stencil_cad.outline import plate_outline

LABEL = cad.LabelInfo(layer=1, layers=4, colour="#000200", job="example")
HANGING = "    x, y = outline[:, 0].max() - 6, outline[:, 1].max() - 5\n    return plate.with_holes([(x, y)], 1.5)\n"


def hex_dots(w, h, pitch, r, margin=2.0):
    ys = np.arange(margin + r, h - margin - r, pitch * math.sqrt(3) / 2)
    pts = [
        (x, y)
        for i, y in enumerate(ys)
        for x in np.arange(margin + r + (pitch / 2 if i % 2 else 0), w - margin - r, pitch)
    ]
    xy = np.array(pts)
    return DotSet(xy_mm=xy, r_mm=np.full(len(xy), r))


def edited_template(tmp_path, body):
    path = tmp_path / "my_plate.py"
    text = builtin_template().read_text()
    assert "    return plate\n" in text
    path.write_text(text.replace("    return plate\n", body))
    return path


@pytest.mark.slow
def test_hanging_hole_on_a_labelled_plate_with_thousands_of_holes(tmp_path):
    w = h = 150.0
    dots = hex_dots(w, h, pitch=2.5, r=0.6)
    assert len(dots) > 3000
    cfg = PlateConfig(template=edited_template(tmp_path, HANGING))
    model = cad.build_plate(dots, w, h, cfg, LABEL)
    assert model.geometry is not None and model.geometry.extra_holes == 1
    assert model.geometry.glyphs  # labelled
    rep = cad.check_plate(model, dots, tolerance_mm=0.02)
    assert rep["valid"] and rep["hole_count"] == len(dots) + 1
    ring = plate_outline(w, h, cfg.outline)
    g = model.geometry
    want = (
        polygon_area(ring) - math.pi * (np.sum(dots.r_mm**2) + 1.5**2)
    ) * g.thickness_mm + g.glyph_area * g.relief_mm
    assert rep["volume"] == pytest.approx(want, rel=1e-6)
    mesh = plate_mesh(g, 0.02)
    assert mesh_genus(mesh.vertices[mesh.faces]) == len(dots) + 1
    step = tmp_path / "p.step"
    cad.write_step(model, step)
    assert step.stat().st_size > 0


def test_extra_hole_too_close_to_the_edge_is_refused(tmp_path):
    body = "    return plate.with_holes([(outline[:, 0].min() + 1, 10.0)], 1.5)\n"
    cfg = PlateConfig(template=edited_template(tmp_path, body))
    with pytest.raises(PlateBuildError, match="inside the plate"):
        cad.build_plate(hex_dots(40, 30, 3.0, 0.6), 40, 30, cfg, LABEL)


@pytest.mark.slow
def test_solid_edit_on_a_labelled_plate_passes_the_mesh_check(tmp_path):
    """An OCCT boolean (with_part) on a labelled plate: the mesh volume is judged against the chord error."""
    body = (
        "    from build123d import Cylinder, Pos\n"
        "    x, y = outline[:, 0].min() + 5, outline[:, 1].max() - 5\n"
        "    return plate.with_part(plate.part - Pos(x, y, THICKNESS_MM / 2) * Cylinder(1.5, 2 * THICKNESS_MM))\n"
    )
    w, h = 60.0, 40.0
    dots = hex_dots(w, h, pitch=2.0, r=0.5)
    assert len(dots) > 400
    cfg = PlateConfig(template=edited_template(tmp_path, body), full_check_max_holes=100000)
    model = cad.build_plate(dots, w, h, cfg, LABEL)
    assert model.geometry is None
    rep = cad.check_plate(model, dots, tolerance_mm=0.02)
    assert rep["valid"]
    assert rep["mesh"]["rel_error"] > 1e-3 >= 0  # what the old fixed tolerance refused
    assert rep["mesh"]["rel_error"] <= rep["mesh"]["allowed_rel_error"]
