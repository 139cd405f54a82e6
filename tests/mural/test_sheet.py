"""A mural a maker can make: its sheet (counts, tile sections, map, registration, checks), its cut
files' labels and SVGs, and every part sliced on the bed it was sized for.

The job is a 280 × 200 mm mural on the Prusa MK4's 250 × 210 mm bed: two portrait tiles (plates
178.3 × 238.3 mm, the one wall 184.7 × 244.7 mm: every plate reaches the halo past its core on every
side) that fit the bed only turned 90°, the case a 600 mm mural of 8 tiles hits on every tile.
"""

from __future__ import annotations

import io
import json
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from readers import need, run

from stencil_cad import instructions, slicing
from stencil_cad.cli import main

SVG = "{http://www.w3.org/2000/svg}"

MURAL = """\
name: mural sheet test
size:
  width_mm: 280
  height_mm: 200
  px_per_mm: auto
bed: prusa_mk4
decompose:
  layers: 2
"""


@pytest.fixture(scope="module")
def mural_job(tmp_path_factory):
    root = tmp_path_factory.mktemp("mural")
    cfg = root / "job.yaml"
    cfg.write_text(MURAL)
    out = root / "out"
    assert main(["run", str(cfg), "--out", str(out), "-q"]) == 0
    return out


def _manifest(out):
    return json.loads((out / "manifest.json").read_text())


# ----------------------------------------------------------------------- the sheet's content


def _two_tile_manifest() -> dict:
    """A mural manifest as the pipeline writes it: two tiles side by side, two layers."""
    tiles = [
        {
            "tile": name,
            "row": 1,
            "column": c + 1,
            "position_mm": [120.0 * c, 0.0],
            "core_mm": [120.0 * c, 0.0, 120.0 * (c + 1), 200.0],
            "sheet_mm": [max(0.0, 120.0 * c - 18.8), 0.0, min(240.0, 120.0 * (c + 1) + 18.8), 200.0],
        }
        for c, name in enumerate(("A1", "A2"))
    ]
    plates = [
        {
            "tile": t["tile"],
            "layer": i,
            "file": f"tile_{t['tile']}_layer_{i:02d}",
            "bbox_mm": [161.8, 223.0],
            "valid": True,
            "n_solids": 1,
            "rel_error": 1e-14,
            "hole_count": 100 * i,
            "mesh": {"watertight": True, "consistent_winding": True, "genus": 100 * i},
        }
        for t in tiles
        for i in (1, 2)
    ]
    walls = [
        {"tile": t["tile"], "file": f"tile_{t['tile']}_wall.step", "standoff_mm": 10.0, "notches": 8}
        | {"valid": True, "bbox": [-16.2, -16.2, 0.0, 152.0, 213.0, 11.2]}
        for t in tiles
    ]
    files = [{"name": f"{p['file']}{e}"} for p in plates for e in (".stl", ".step", ".dxf", ".svg")]
    files += [{"name": f"tile_{t['tile']}_wall{e}"} for t in tiles for e in (".stl", ".step")]
    return {
        "config": {"name": "two tiles", "mode": "soft", "bed": "prusa_mk4", "stipple": {"process": "fdm"}},
        "picture": {"width_mm": 240.0, "height_mm": 200.0},
        "mural": {
            "bed": {"name": "prusa_mk4", "x_mm": 250.0, "y_mm": 210.0},
            "tiled": True,
            "halo_mm": 18.8,
            "tiles": tiles,
            "holes_total": 600,
            "holes_global": 600,
            "union_check_rules": "passed",
        },
        "spray_order": {
            "primer": {"hex": "#ffffff", "name": ""},
            "unit": "passes",
            "steps": [
                {"step": 1, "plate": "layer_01", "hex": "#ef9417", "name": "", "spray_time": 3},
                {"step": 2, "plate": "layer_02", "hex": "#101010", "name": "", "spray_time": 2},
            ],
        },
        "build": {"plates": plates, "walls": walls},
        "files": files,
    }


def test_mural_sheet_from_the_manifest():
    s = instructions.sheet_from_manifest(_two_tile_manifest())
    assert s.mural is not None and s.mural.plates == 4 and s.mural.walls == 2
    assert [t.name for t in s.mural.sections] == ["A1", "A2"]
    # The tile map is drawn from each tile's core (it was 0 × 0 before).
    assert [(t.width_mm, t.height_mm) for t in s.tiles] == [(120.0, 200.0), (120.0, 200.0)]
    a2 = s.mural.sections[1]
    assert [p.stem for p in a2.plates] == ["tile_A2_layer_01", "tile_A2_layer_02"]
    assert a2.plates[0].amount == "3 passes" and a2.plates[1].holes == 200
    assert "tile_A2_layer_01.svg" in a2.plates[0].files
    assert any("meets A1" in side for side in a2.sides)
    assert any("tile_A2_layer_02: mesh genus 200" in c for c, ok in a2.checks if ok)
    assert any("turned 90°" in c for c, ok in a2.checks if ok)
    reg = " ".join(s.mural.registration)
    assert "x = 0.0, 120.0, 240.0 mm" in reg and "straightedge" in reg and "masking tape" in reg
    html = instructions.render_html(s, {})
    assert "4 plates (2 layers on each of 2 tiles) and 2 walls" in html
    assert html.count('<section class="tile"') == 2 and "Drop layer_01 into the wall" not in html
    assert 'width="0.0"' not in html and 'height="0.0"' not in html
    # Every plate and wall has a print line with its files, naming a bed it fits.
    parts = {r[0]: r for r in s.prints}
    assert set(parts) == {p["file"] for p in _two_tile_manifest()["build"]["plates"]} | {
        "tile_A1_wall",
        "tile_A2_wall",
    }
    assert all("--bed prusa_mk4" in r[4] and "turned 90°" in r[4] for r in s.prints)
    assert "tile_A1_wall.stl" in parts["tile_A1_wall"][2]
    pdf = instructions.render_pdf(s, {})
    assert pdf.startswith(b"%PDF")


def test_unnamed_paints_are_said_to_be_unnamed():
    """With no can list and paints.can_names off, the can column says so (no bare placeholder)."""
    from placeholders import html_text, placeholders

    s = instructions.sheet_from_manifest(_two_tile_manifest())
    html = instructions.render_html(s, {})
    assert "no can named" in html and placeholders(html_text(html)) == []


def test_the_summary_says_which_parts_lie_turned():
    from stencil_cad.figures import Figures
    from stencil_cad.report import _mural_lines

    f = Figures.from_json(_two_tile_manifest())
    assert f.build is not None
    lines = _mural_lines(f.build, f.mural)
    assert any("2 tiles" in line and "holes 600 (global 600)" in line for line in lines)
    assert any("6 of 6 parts fit the 250 × 210 mm bed turned 90°" in line for line in lines)


def test_a_long_mural_is_marked_with_a_chalk_line():
    m = _two_tile_manifest()
    for t in m["mural"]["tiles"]:
        t["core_mm"] = [v * 10 for v in t["core_mm"]]
    s = instructions.sheet_from_manifest(m)
    assert "chalk line" in " ".join(s.mural.registration)


# ------------------------------------------------------------------------------ the real job


@pytest.mark.slow
def test_mural_writes_an_svg_per_plate_and_labels_every_cut_file(mural_job, tmp_path):
    import ezdxf
    from PIL import Image

    m = _manifest(mural_job)
    plates = m["build"]["plates"]
    assert len(plates) == 4
    for p in plates:
        stem = p["file"]
        assert p["cut_length_mm"] > 0
        doc = ezdxf.readfile(mural_job / f"{stem}.dxf")
        score = doc.layers.get(f"{stem.upper()}_SCORE")
        cut = doc.layers.get(stem.upper())
        assert score.color == 5 and cut.color != score.color
        msp = doc.modelspace()
        assert len(msp.query(f'LWPOLYLINE[layer=="{stem.upper()}_SCORE"]')) > 10
        circles = p["hole_count"] - p.get("windows", 0)  # a hybrid plate's windows are polygons
        assert len(msp.query(f'CIRCLE[layer=="{stem.upper()}"]')) == circles
        root = ET.parse(mural_job / f"{stem}.svg").getroot()
        groups = {g.get("id"): g for g in root.iter(f"{SVG}g")}
        assert "TILE " + p["tile"] in groups["score"].get("data-label")
        assert len(list(groups["cuts"].iter(f"{SVG}circle"))) == circles
        # librsvg draws the label in the score colour, apart from the red cuts.
        png = tmp_path / f"{stem}.png"
        r = run(
            [need("rsvg-convert"), "-z", "3", "-b", "white", "-o", str(png), str(mural_job / f"{stem}.svg")]
        )
        assert r.returncode == 0, r.stderr
        rgb = np.asarray(Image.open(png).convert("RGB")).astype(int)
        blue = (rgb[..., 2] > 150) & (rgb[..., 0] < 100) & (rgb[..., 1] < 100)
        red = (rgb[..., 0] > 150) & (rgb[..., 1] < 100) & (rgb[..., 2] < 100)
        assert blue.sum() > 200 and red.sum() > 1000
        # The label sits in the plate's bottom border, below the picture.
        rows = np.nonzero(blue.any(axis=1))[0]
        assert rows.min() > 0.9 * rgb.shape[0]


@pytest.mark.slow
def test_every_tile_part_slices_on_the_mk4_bed(mural_job, capsys):
    m = _manifest(mural_job)
    stls = [mural_job / f"{p['file']}.stl" for p in m["build"]["plates"]]
    stls += [mural_job / w["file"].replace(".step", ".stl") for w in m["build"]["walls"]]
    stls.append(mural_job / "post.stl")
    assert len(stls) == 6  # 4 plates, the one wall and the post
    for stl in stls[:-1]:  # portrait parts: refused before, turned now
        w, h = slicing.stl_footprint(stl)
        assert h > 210 and w <= 210
    assert main(["slice", "--bed", "prusa_mk4", *map(str, stls)]) == 0
    said = capsys.readouterr().out
    assert said.count("turned 90° to fit the bed") == len(stls) - 1
    assert all(s.with_suffix(".gcode").stat().st_size > 10_000 for s in stls)


def _sheet_expression() -> str:
    return """(() => {
      const box = el => { const r = el.getBoundingClientRect();
        return [r.left + scrollX, r.top + scrollY, r.width, r.height]; };
      const map = Array.from(document.images).find(i => i.alt.startsWith('the mural map'));
      return {
        head: document.querySelector('p.note').textContent,
        sections: Array.from(document.querySelectorAll('section.tile')).map(s => ({
          id: s.id, plates: s.querySelectorAll('tr').length - 1,
          checks: s.querySelectorAll('ul.tile-checks li').length,
          passed: s.querySelectorAll('ul.tile-checks .ok').length})),
        registration: Array.from(document.querySelectorAll('ol.registration li')).map(l => l.textContent),
        rounds: document.querySelectorAll('ol.rounds li').length,
        map: map ? {box: box(map), natural: map.naturalWidth} : null,
        rects: Array.from(document.querySelectorAll('svg rect')).map(r => box(r)),
      };
    })()"""


@pytest.mark.slow
def test_mural_sheet_in_headless_chromium(mural_job, tmp_path):
    from browser import evaluate_page
    from PIL import Image

    m = _manifest(mural_job)
    got, shot = evaluate_page(
        need("chromium"), (mural_job / "instructions.html").as_uri(), _sheet_expression()
    )
    assert "4 plates (2 layers on each of 2 tiles) and 1 wall (moved from tile to tile)" in got["head"]
    assert [s["id"] for s in got["sections"]] == ["tile-A1", "tile-A2"]
    for s in got["sections"]:
        assert s["plates"] == 2 and s["checks"] >= 11 and s["passed"] == s["checks"]
    assert got["rounds"] == 2
    reg = " ".join(got["registration"])
    assert len(got["registration"]) >= 5
    assert "bottom-left corner" in reg and "First tile, A1" in reg and "meets A1" in reg
    edges = sorted({round(v, 1) for t in m["mural"]["tiles"] for v in (t["core_mm"][0], t["core_mm"][2])})
    assert f"x = {', '.join(f'{v:.1f}' for v in edges)} mm" in reg
    # The drawn tile map: the picture and one rectangle per tile, none of them 0 × 0.
    assert len(got["rects"]) == 1 + len(m["mural"]["tiles"])
    assert all(w > 20 and h > 20 for _, _, w, h in got["rects"])
    # The embedded mural_map.png is loaded and, on screen, not one flat colour.
    assert got["map"] and got["map"]["natural"] > 0
    x, y, w, h = (int(v) for v in got["map"]["box"])
    img = Image.open(io.BytesIO(shot)).convert("RGB")
    crop = np.asarray(img.crop((x, y, x + w, y + h))).reshape(-1, 3)
    assert w > 300 and h > 200 and crop.std(axis=0).max() > 20
    assert len(np.unique(crop, axis=0)) > 50


@pytest.mark.slow
def test_mural_sheet_pdf_pages(mural_job, tmp_path):
    from PIL import Image

    pdf = mural_job / "instructions.pdf"
    r = run([need("pdftoppm"), "-r", "50", "-png", str(pdf), str(tmp_path / "page")])
    assert r.returncode == 0, r.stderr
    pages = sorted(tmp_path.glob("page*.png"))
    text = run([need("pdftotext"), "-layout", str(pdf), "-"]).stdout
    assert "4 plates (2 layers on each of 2 tiles) and 1 wall (moved from tile to tile)" in " ".join(
        text.split()
    )
    assert "One wall serves every tile" in " ".join(text.split()) and "post.stl" in text
    for tile in ("A1", "A2"):
        assert f"Tile {tile}" in text and f"Checks of tile {tile}" in text
    assert "Registration: where each tile goes" in text and "First tile, A1" in text
    assert "FAILED" not in text
    # The page with the tile map shows the map: the mural map's red grid lines on paper.
    k = next(i for i, p in enumerate(text.split("\f")) if "Tile map" in p)
    rgb = np.asarray(Image.open(pages[k]).convert("RGB")).astype(int)
    red = (rgb[..., 0] > 150) & (rgb[..., 1] < 90) & (rgb[..., 2] < 90)
    assert red.sum() > 200 and rgb.std(axis=(0, 1)).max() > 20


@pytest.mark.slow
def test_mural_sheet_has_no_placeholder(mural_job):
    from placeholders import html_text, placeholders

    html = html_text((mural_job / "instructions.html").read_text())
    pdf = run([need("pdftotext"), "-layout", str(mural_job / "instructions.pdf"), "-"]).stdout
    assert placeholders(html) == [] and placeholders(pdf) == []


def test_mural_sheet_with_one_wall_and_posts():
    m = _two_tile_manifest()
    wall = {**m["build"]["walls"][0], "tiles": ["A1", "A2"]}
    m["build"]["walls"] = [wall]
    m["files"] = [f for f in m["files"] if not f["name"].startswith("tile_A2_wall")]
    m["files"] += [{"name": "post.stl"}, {"name": "post.step"}]
    m["mural"]["posts"] = {"file": "post.step", "height_mm": 10.0, "most": 2, "per_plate": {"A1 1": 2}}
    s = instructions.sheet_from_manifest(m)
    assert s.mural is not None and s.mural.walls == 1
    a1, a2 = s.mural.sections
    assert "tile_A1_wall.stl" in a1.walls[0] and "moved here" not in a1.walls[0]
    assert "tile_A1_wall.stl" in a2.walls[0] and "made once, for A1; moved here" in a2.walls[0]
    reg = " ".join(s.mural.registration)
    assert "One wall serves every tile (A1)" in reg
    assert "Posts: print 2 of post.stl" in reg and "10 mm high" in reg
    html = instructions.render_html(s, {})
    assert "4 plates (2 layers on each of 2 tiles) and 1 wall (moved from tile to tile)" in html
