"""What a maker holds in hand: instruction sheet, labelled previews, SVG cut files."""

import json
import os
import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from jobs import CATALOGUE, HARD_CANS, small_hard, small_soft
from readers import need, run

from stencil_cad import instructions
from stencil_cad.cli import main
from stencil_cad.config.spray import SprayConfig
from stencil_cad.decompose import paints
from stencil_cad.instructions.mural import MapTile

ARTEFACTS = Path(
    os.environ.get(
        "STENCIL_TEST_ARTEFACTS", Path(__file__).resolve().parents[2] / "output" / "test-artefacts"
    )
)

SOFT = small_soft("sheet test")
HARD = small_hard(
    "hard test",
    "export:\n  dxf_kerf_mm: 0  # the cut files drawn exactly as designed (the laser preset takes 0.2 mm off)\n",
)

SVG = "{http://www.w3.org/2000/svg}"


@pytest.fixture(scope="module")
def soft_job(tmp_path_factory):
    root = tmp_path_factory.mktemp("sheet")
    cfg = root / "job.yaml"
    cfg.write_text(SOFT)
    out = root / "out"
    assert main(["run", str(cfg), "--out", str(out), "-q"]) == 0
    return out


@pytest.fixture(scope="module")
def hard_job(tmp_path_factory):
    root = tmp_path_factory.mktemp("hard")
    (root / "cans.csv").write_text(HARD_CANS)
    cfg = root / "job.yaml"
    cfg.write_text(HARD)
    out = root / "out"
    assert main(["hard", str(cfg), "--out", str(out), "-q"]) == 0
    return out


def _dots(out, i):
    return np.loadtxt(out / f"layer_{i:02d}_dots.csv", delimiter=",", skiprows=1, ndmin=2)


# ------------------------------------------------------------------------------------- the job


@pytest.mark.slow
def test_catalogue_snaps_every_paint_to_a_can_and_shows_the_cost(soft_job):
    m = json.loads((soft_job / "manifest.json").read_text())
    cans = {c.hex: c for c in paints.load_cans(CATALOGUE)}
    snap = m["cans"]["snap"]
    assert set(m["decompose"]["colours"]) <= set(cans)
    assert m["decompose"]["primer"] in cans
    for row in snap["paints"]:
        assert row["can"] in cans and row["delta_e2000"] >= 0
    assert np.isfinite(snap["rmse_snapped"]) and np.isfinite(snap["rmse_solved"])
    spray = json.loads((soft_job / "spray.json").read_text())
    # Each paint's light plate, then its dark plate.
    assert list(dict.fromkeys(o["hex"] for o in spray["order"])) == m["decompose"]["colours"]
    assert all(o["name"] == cans[o["hex"]].label for o in spray["order"])
    html = (soft_job / "instructions.html").read_text()
    assert "cost of using the cans" in html
    for o in spray["order"]:
        assert o["name"] in html


@pytest.mark.slow
def test_the_maker_reads_passes_distances_and_seconds_not_model_units(soft_job):
    m = json.loads((soft_job / "manifest.json").read_text())
    spray = json.loads((soft_job / "spray.json").read_text())
    html = (soft_job / "instructions.html").read_text()
    assert not re.findall(r"model units|nozzle_height|spray time", html)
    max_passes = m["config"]["spray"]["max_passes"]
    for row, o in zip(m["spraying"], spray["order"], strict=True):
        assert isinstance(row["passes"], int) and 1 <= row["passes"] <= max_passes
        assert o["passes"] == row["passes"]
        assert row["can_distance_cm"] == spray["can_distance_cm"] == 20.0
        assert row["spray_seconds"] > 0
        assert f"{row['passes']} light pass" in row["text"] and "20 cm" in row["text"]
        assert row["text"] in html or f"{row['passes']} pass" in html
    # Every can of the prior is scored, the nominal one first; the sheet says the range.
    by_can = m["simulate"]["scielab_by_can"]
    assert list(by_can)[0] == "nominal" and len(by_can) >= 3
    assert by_can["nominal"] == m["simulate"]["scielab"]
    assert m["simulate"]["scielab_worst"] == max(by_can.values())
    assert "depending on your can" in html


def test_every_output_of_the_maker_is_written(soft_job):
    names = {p.name for p in soft_job.iterdir()}
    for i in (1, 2):
        for suffix in (".svg", "_after.png", "_dots.png", "_opacity.png"):
            assert f"layer_{i:02d}{suffix}" in names
    assert {"instructions.html", "instructions.pdf", "swatch.png", "spray.json"} <= names
    listed = {r["name"] for r in json.loads((soft_job / "manifest.json").read_text())["files"]}
    assert names == listed | {"manifest.json"}


def test_a_paints_light_and_dark_plates_spray_from_one_can(soft_job):
    # The default one-plate job sprays each paint through a light plate and then a dark plate.
    order = json.loads((soft_job / "spray.json").read_text())["order"]
    m = json.loads((soft_job / "manifest.json").read_text())
    assert m["decompose"]["plates"] == len(order) > m["decompose"]["layers"] == 2
    html = (soft_job / "instructions.html").read_text()
    cans = {r["layer"]: r["cans_to_buy"] for r in m["paint"]["layers"]}
    pairs = [k for k in range(1, len(order)) if order[k]["hex"] == order[k - 1]["hex"]]
    assert pairs
    for k in pairs:
        # The dark plate's paint is bought with its light plate's.
        assert cans[k] >= 1 and cans[k + 1] == 0
        assert f"its dark plate: the same paint and can as step {k}" in html
    assert "its light plate: this paint" in html


@pytest.mark.slow
def test_svg_matches_the_dots_and_the_dxf(soft_job):
    import ezdxf

    for i in (1, 2):
        root = ET.parse(soft_job / f"layer_{i:02d}.svg").getroot()
        assert root.get("width").endswith("mm") and root.get("height").endswith("mm")
        w, h = float(root.get("width")[:-2]), float(root.get("height")[:-2])
        assert [float(v) for v in root.get("viewBox").split()] == pytest.approx([0, 0, w, h], abs=1e-3)
        circles = np.array([[float(c.get(k)) for k in ("cx", "cy", "r")] for c in root.iter(f"{SVG}circle")])
        dots = _dots(soft_job, i)
        assert len(circles) == len(dots) > 0
        paths = list(_group(root, "cut").iter(f"{SVG}path"))
        assert len(paths) == 1 and paths[0].get("id") == "outline"
        assert len(list(_group(root, "score").iter(f"{SVG}path"))) > 5  # the label, to score
        doc = ezdxf.readfile(soft_job / f"layer_{i:02d}.dxf")
        dxf_c = np.array(
            [[e.dxf.center.x, e.dxf.center.y, e.dxf.radius] for e in doc.modelspace().query("CIRCLE")]
        )
        # Same frame as the DXF: x equal, y flipped about the drawing's height.
        flipped = np.column_stack([circles[:, 0], h - circles[:, 1], circles[:, 2]])
        assert np.allclose(np.sort(flipped, axis=0), np.sort(dxf_c, axis=0), atol=2e-4)
        off = (
            doc.header.custom_vars.get("STENCIL_OFFSET_X_MM"),
            doc.header.custom_vars.get("STENCIL_OFFSET_Y_MM"),
        )
        assert np.allclose(
            dots[:, 0] + float(off[0]), np.sort(flipped[:, 0])[np.argsort(np.argsort(dots[:, 0]))], atol=2e-4
        )


def _group(root, gid):
    return next(g for g in root.iter(f"{SVG}g") if g.get("id") == gid)


def _rsvg_components(svg, css, tmp_path, zoom=12.0):
    """Render with rsvg-convert under a stylesheet and count the black blobs."""
    from PIL import Image
    from scipy import ndimage

    rsvg = need("rsvg-convert")
    style = tmp_path / "fill.css"
    style.write_text(css)
    png = tmp_path / (svg.stem + ".png")
    r = run([rsvg, "--stylesheet", str(style), "-z", str(zoom), "-b", "white", "-o", str(png), str(svg)])
    assert r.returncode == 0, r.stderr
    with Image.open(png) as im:
        img = np.asarray(im.convert("L")) < 128
    labels, n = ndimage.label(img)
    return img, labels, n


@pytest.mark.slow
def test_rsvg_reads_one_circle_per_hole(soft_job, tmp_path):
    """librsvg renders each SVG; with the holes filled, the blobs are the holes, where the dots are."""
    from scipy import ndimage

    zoom = 96 / 25.4 * 3  # rsvg renders mm at 96 dpi: 3 x that is about 11 px per mm
    for i in (1, 2):
        svg = soft_job / f"layer_{i:02d}.svg"
        img, labels, n = _rsvg_components(
            svg, "circle { fill: black; stroke: none; } #outline, #score { display: none; }", tmp_path, 3
        )
        dots = _dots(soft_job, i)
        assert n == len(dots)
        root = ET.parse(svg).getroot()
        h = float(root.get("height")[:-2])
        centres = np.array(ndimage.center_of_mass(img, labels, range(1, n + 1)))  # (row, col) px
        px_per_mm = img.shape[1] / float(root.get("width")[:-2])
        xy = np.column_stack([(centres[:, 1] + 0.5) / px_per_mm, h - (centres[:, 0] + 0.5) / px_per_mm])
        import ezdxf

        doc = ezdxf.readfile(soft_job / f"layer_{i:02d}.dxf")
        off = np.array(
            [float(doc.header.custom_vars.get(k)) for k in ("STENCIL_OFFSET_X_MM", "STENCIL_OFFSET_Y_MM")]
        )
        from scipy.spatial import cKDTree

        d, _ = cKDTree(dots[:, :2] + off).query(xy)
        assert d.max() < 0.15, d.max()
        assert zoom > 0


@pytest.mark.slow
def test_rsvg_reads_the_hard_cut_outs(hard_job, tmp_path):
    m = json.loads((hard_job / "manifest.json").read_text())
    per_layer = [r for r in m["hard"]["per_layer"] if r.get("cut_area_mm2", 0) > 0]
    for i, rep in enumerate(per_layer, start=1):
        svg = hard_job / f"layer_{i:02d}.svg"
        root = ET.parse(svg).getroot()
        assert len(list(_group(root, "cut").iter(f"{SVG}path"))) == rep["polygons"] + 1
        assert not list(root.iter(f"{SVG}circle"))
        img, _, n = _rsvg_components(
            svg, "#cuts path { fill: black; stroke: none; } #outline, #score { display: none; }", tmp_path, 3
        )
        px_per_mm = img.shape[1] / float(root.get("width")[:-2])
        area = img.sum() / px_per_mm**2
        assert area == pytest.approx(rep["cut_area_mm2"], rel=0.05)
        assert n >= 1


# ------------------------------------------------------------------------------ hard mode


@pytest.mark.slow
def test_hard_mode_writes_the_swatch_card_and_the_spray_order(hard_job):
    from PIL import Image

    spray = json.loads((hard_job / "spray.json").read_text())
    m = json.loads((hard_job / "manifest.json").read_text())
    cans = {c.hex: c.label for c in paints.parse_cans(HARD_CANS)}
    assert spray["primer"]["hex"] == m["hard"]["palette"][0]
    assert spray["primer"]["name"] == cans[spray["primer"]["hex"]]
    assert [o["plate"] for o in spray["order"]] == [
        f"layer_{i:02d}" for i in range(1, len(spray["order"]) + 1)
    ]
    assert len(spray["order"]) == m["hard"]["layers"] >= 1
    assert all(o["name"] == cans[o["hex"]] for o in spray["order"])
    with Image.open(hard_job / "swatch.png") as im:
        card = np.asarray(im.convert("RGB"))
    assert card.shape[0] >= 3 * 56 and card.shape[1] >= 360
    for i in range(1, len(spray["order"]) + 1):
        assert (hard_job / f"layer_{i:02d}_cut.png").exists()
        assert (hard_job / f"layer_{i:02d}_after.png").exists()
    assert (hard_job / "instructions.html").exists() and (hard_job / "instructions.pdf").exists()
    # Under the physical model (the default) a cut-out gets the whole passes that cover it fully,
    # and the maker is told passes and the can's distance, not the paper's nozzle height.
    n = SprayConfig().full_cover_passes()
    assert 1 <= n <= SprayConfig().max_passes
    assert [o["passes"] for o in spray["order"]] == [n] * len(spray["order"])
    assert [r["passes"] for r in m["spraying"]] == [n] * len(spray["order"])
    html = (hard_job / "instructions.html").read_text()
    assert "nozzle_height" not in html and "20 cm" in html


# -------------------------------------------------------------------------------- previews


def test_swatch_card_borders_a_white_primer():
    from stencil_cad.simulate import labelled as previews

    card = previews.swatch_card("#ffffff", [{"hex": "#ff0000", "spray_time": 0.5}], chip_px=40)
    # The primer chip's border: a dark ring around white, on white paper.
    dark = card.sum(axis=2) < 150
    rows = np.nonzero(dark.any(axis=1))[0]
    assert rows.size > 0
    white_inside = card[rows.min() + 5 : rows.min() + 30, 60:80]
    assert (white_inside > 240).all() or dark.sum() > 4 * 40


def test_scale_bar_length_is_in_mm():
    from stencil_cad.simulate import labelled as previews

    assert previews._nice_length(37) == 20
    assert previews._nice_length(120) == 100
    assert previews._nice_length(0.7) == 0.5


# ----------------------------------------------------------------------------- the sheet


@pytest.mark.slow
def test_sheet_is_self_contained(soft_job):
    html = (soft_job / "instructions.html").read_text()
    assert "<script" not in html
    assert "http://" not in html.replace("http://www.w3.org/2000/svg", "")
    assert "https://" not in html
    srcs = [s.split('"', 1)[0] for s in html.split('src="')[1:]]
    assert srcs and all(s.startswith("data:image/png;base64,") for s in srcs)
    spray = json.loads((soft_job / "spray.json").read_text())
    assert len(srcs) == 2 + 2 * len(spray["order"]) + 1  # picture, simulated, per step 2, preview
    for o in spray["order"]:
        assert o["hex"] in html


def test_sheet_takes_tiles_and_new_figures():
    manifest = json.loads(json.dumps(_synthetic_manifest()))
    tiles = [
        {"name": "A1", "x_mm": 0, "y_mm": 0, "width_mm": 100, "height_mm": 80},
        {"name": "B1", "x_mm": 100, "y_mm": 0, "width_mm": 100, "height_mm": 80},
    ]
    manifest["simulate"]["scielab"] = 3.25
    s = instructions.sheet_from_manifest(manifest, tiles=tiles)
    html = instructions.render_html(s, {})
    assert html.count("<rect") == 1 + len(tiles) and ">A1<" in html and ">B1<" in html
    assert "S-CIELAB at the viewing distance" in html and "3.25" in html
    manifest["tiles"] = tiles
    assert instructions.sheet_from_manifest(manifest).tiles == [
        MapTile(t["name"], t["x_mm"], t["y_mm"], t["width_mm"], t["height_mm"]) for t in tiles
    ]
    pdf = instructions.render_pdf(s, {})
    assert pdf.startswith(b"%PDF") and len(pdf) > 2000


def test_sheet_says_the_plate_thickness_and_why():
    manifest = _synthetic_manifest()
    reason = "0.9 mm: the thinnest fdm plate (whole 0.3 mm layers, PLA) whose 173 mm side sags ≤ 0.75 mm"
    manifest["plate"] = {"thickness_mm": 0.9, "thickness_reason": reason}
    rows = instructions.sheet_from_manifest(manifest).prints
    assert ["plate thickness", "", "", "", reason] in rows
    assert reason in instructions.render_html(instructions.sheet_from_manifest(manifest), {})


def _synthetic_manifest():
    return {
        "config": {
            "name": "synthetic",
            "mode": "soft",
            "stipple": {"process": "fdm"},
            "spray": {"nozzle_height": 7},
        },
        "picture": {"width_mm": 200, "height_mm": 80},
        "decompose": {"primer": "#ffffff", "colours": ["#000000"]},
        "spray_order": {
            "primer": {"hex": "#ffffff", "name": ""},
            "note": "n",
            "steps": [{"step": 1, "plate": "layer_01", "hex": "#000000", "name": "", "spray_time": 1.0}],
        },
        "simulate": {"de2000_mean": 5.0, "holes": [500]},
        "build": {
            "plates": [{"layer": 1, "valid": True, "n_solids": 1, "rel_error": 1e-12, "hole_count": 500}],
            "walls": [],
        },
        "paint": {
            "sprayed_area_m2": 0.016,
            "coverage_m2_per_can": 1.5,
            "can_ml": 400,
            "layers": [
                {
                    "layer": 1,
                    "mean_opacity": 0.3,
                    "covered_m2": 0.0048,
                    "ml": 1.28,
                    "cans": 0.0032,
                    "cans_to_buy": 1,
                }
            ],
        },
        "files": [],
    }


@pytest.mark.slow
def test_instructions_open_in_headless_chromium(soft_job, tmp_path):
    from browser import inspect_page

    chromium = need("chromium")
    # The check itself can fail: a page with a console error and a missing image is caught.
    bad = tmp_path / "bad.html"
    bad.write_text('<html><body><script>console.error("x")</script><img src="missing.png"></body></html>')
    problems, images, _ = inspect_page(chromium, bad.as_uri())
    assert any("console.error" in p for p in problems) and any(w == 0 for _, w, _ in images)

    problems, images, shot = inspect_page(chromium, (soft_job / "instructions.html").as_uri())
    assert problems == []
    spray = json.loads((soft_job / "spray.json").read_text())
    assert len(images) == 2 + 2 * len(spray["order"]) + 1
    assert all(done and width > 0 for done, width, _ in images)
    ARTEFACTS.mkdir(parents=True, exist_ok=True)
    (ARTEFACTS / "instructions.png").write_bytes(shot)
    from PIL import Image

    with Image.open(ARTEFACTS / "instructions.png") as im:
        assert im.width >= 1000 and im.height > 2000


@pytest.mark.slow
def test_instructions_pdf_pages_render(soft_job, tmp_path):
    pdftoppm = need("pdftoppm")
    r = run([pdftoppm, "-r", "40", "-png", str(soft_job / "instructions.pdf"), str(tmp_path / "page")])
    assert r.returncode == 0, r.stderr
    pages = sorted(tmp_path.glob("page*.png"))
    assert len(pages) >= 2
    from PIL import Image

    for p in pages:
        with Image.open(p) as page:
            a = np.asarray(page.convert("L"))
        # Ink on paper, not a blank page (a page of small grey text alone reads about 150 at 40 dpi).
        assert a.min() < 180 and a.max() > 200
    text = run([need("pdftotext"), str(soft_job / "instructions.pdf"), "-"]).stdout
    spray = json.loads((soft_job / "spray.json").read_text())
    for o in spray["order"]:
        assert o["hex"] in text and f"Step {o['step']}" in text


def test_dots_preview_with_an_origin_draws_the_plate_frame():
    from stencil_cad.model import DotSet
    from stencil_cad.simulate.previews import dots_preview

    ds = DotSet(np.array([[5.0, 35.0]]), np.array([2.0]))
    img = dots_preview(ds, 50.0, 50.0, px_per_mm=4, origin_mm=(-5.0, -5.0))
    assert img.shape == (200, 200)
    assert img[40, 40] == 0  # x = 5 → (5 + 5) * 4; y = 35 → (50 - 40) * 4
    assert img[100, 100] == 255


@pytest.mark.slow
def test_slice_project_writes_a_prusaslicer_project_with_settings(soft_job, tmp_path, capsys):
    import shutil
    import zipfile

    need("prusa-slicer")
    stl = tmp_path / "layer_01.stl"
    shutil.copy(soft_job / "layer_01.stl", stl)
    assert main(["slice", "--project", str(stl)]) == 0
    project = tmp_path / "layer_01.3mf"
    with zipfile.ZipFile(project) as zf:
        names = zf.namelist()
        config = zf.read("Metadata/Slic3r_PE.config").decode()
    assert any(n.endswith(".model") for n in names)
    assert "fill_density = 100%" in config and "overhangs = 0" in config
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]
    assert main(["slice", "--project", "--profile", "cura_fdm", str(stl)]) == 2
    assert "CuraEngine profile" in capsys.readouterr().err
