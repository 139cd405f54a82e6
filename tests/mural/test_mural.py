"""Murals: the bed, tiles, hole partition, registration notches, tiled simulation, resolution."""

from __future__ import annotations

import numpy as np
import pytest

from stencil_cad import mural, resolution
from stencil_cad.config import io as cfg_io
from stencil_cad.config.bed import BED_PRESETS, parse_bed_arg, resolve_bed
from stencil_cad.errors import ConfigError, UserError
from stencil_cad.model import DotSet
from stencil_cad.outline import plate_outline, polygon_area

#: Holes of r 1 mm at a 0.8 mm web (the FDM preset of before): a pitch the 512 px picture of the resolution
#: test holds at 1200 mm, and the radii of the random dots of the tiled-spray test.
COARSE = {"hole_min_r_mm": 1.0, "web_mm": 0.8}


def job(**data):
    return cfg_io.parse_config(data, source="test")


# --------------------------------------------------------------------------- bed


def test_bed_presets_and_sizes():
    assert job(bed="prusa_mk4").bed == "prusa_mk4"
    assert job(bed="Prusa-MK4").bed == "prusa_mk4"
    assert job(bed=[300, 200]).bed == (300.0, 200.0)
    assert job().bed is None
    for name in (
        "prusa_core_one",
        "prusa_xl",
        "prusa_mini",
        "prusa_sl1s",
        "bambu_x1c",
        "bambu_a1_mini",
        "ender_3",
        "xtool_s1",
        "glowforge",
    ):
        assert name in BED_PRESETS
    bed = resolve_bed("prusa_mk4")
    assert (bed.x_mm, bed.y_mm) == (250.0, 210.0)
    assert bed.fits(210, 250) and bed.fits(250, 210) and not bed.fits(251, 100)


@pytest.mark.parametrize(
    ("value", "words"),
    [
        ("prusa_mk9", ["unknown bed preset", "prusa_mk4"]),
        ([10, 200], ["each bed side"]),
        ([1, 2, 3], ["preset name or"]),
    ],
)
def test_bad_bed_names_the_choices(value, words):
    with pytest.raises(ConfigError) as exc:
        job(bed=value)
    for w in words:
        assert w in str(exc.value)


def test_bed_argument():
    assert parse_bed_arg("250x210") == (250.0, 210.0)
    assert parse_bed_arg("250×210.5") == (250.0, 210.5)
    assert parse_bed_arg("prusa_xl") == "prusa_xl"


def test_size_limit_fits_murals():
    assert job(size={"width_mm": 12000, "height_mm": 4000}).size.width_mm == 12000


# --------------------------------------------------------------------------- tiles


def test_must_show_grid_fits_prusa_mk4():
    cfg = job(size={"width_mm": 1200, "height_mm": 800}, bed="prusa_mk4")
    grid = mural.plan_tiles(1200, 800, cfg)
    assert grid.tiled and grid.halo_mm > 5
    rows = mural.check_fits_bed(grid, cfg)
    for row in rows:
        for kind in ("plate_mm", "wall_mm"):
            w, h = row[kind]
            assert (w <= 250 and h <= 210) or (w <= 210 and h <= 250), row
    names = [t.name for t in grid.tiles]
    assert names[0] == "A1" and names[1] == "A2" and names[grid.cols] == "B1"
    assert len(set(names)) == len(names) == grid.cols * grid.rows
    # Cores tile the mural exactly; sheets reach the halo into neighbours only.
    area = sum((t.core[2] - t.core[0]) * (t.core[3] - t.core[1]) for t in grid.tiles)
    assert area == pytest.approx(1200 * 800)
    a1 = grid.tiles[0]
    assert a1.sheet[0] == 0 and a1.sheet[3] == 800
    assert a1.sheet[2] == pytest.approx(a1.core[2] + grid.halo_mm)
    assert a1.sheet[1] == pytest.approx(a1.core[1] - grid.halo_mm)


def test_no_bed_or_fitting_picture_is_one_tile():
    assert not mural.plan_tiles(1200, 800, job(size={"width_mm": 1200, "height_mm": 800})).tiled
    g = mural.plan_tiles(150, 100, job(bed="prusa_mk4"))
    assert not g.tiled and g.tiles[0].sheet == (0.0, 0.0, 150.0, 100.0)


def test_bed_too_small_for_any_tile():
    with pytest.raises(UserError, match="bed 30 × 30 mm"):
        mural.plan_tiles(500, 500, job(bed=[30, 30]))


def test_row_names():
    assert [mural.row_name(i) for i in (0, 1, 25, 26, 27)] == ["A", "B", "Z", "AA", "AB"]


def _random_dots(rng, w, h, n, r=1.0):
    xy = rng.uniform([3, 3], [w - 3, h - 3], size=(n, 2))
    return DotSet(xy_mm=xy, r_mm=np.full(n, r))


def test_each_window_goes_to_the_tile_it_lies_in_and_comes_back():
    cfg = job(size={"width_mm": 600, "height_mm": 400}, bed="prusa_mk4")
    grid = mural.plan_tiles(600, 400, cfg)
    windows = []
    for t in grid.tiles[:3]:
        x0, y0, x1, y1 = t.core
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        windows.append(
            (np.array([[cx - 5, cy - 5], [cx + 5, cy - 5], [cx + 5, cy + 5], [cx - 5, cy + 5]]), ())
        )
    ds = DotSet(xy_mm=np.zeros((0, 2)), r_mm=np.zeros(0), windows=tuple(windows))
    parts = mural.split_dots(ds, grid)
    assert [len(p.windows) for p in parts[:3]] == [1, 1, 1] and sum(len(p.windows) for p in parts) == 3
    for p, t in zip(parts, grid.tiles, strict=True):
        for ring, _ in p.windows:
            assert np.all((ring >= 0) & (ring <= t.size))  # in the tile's frame, on its sheet
    back = mural.to_mural(parts, grid)
    for (a, _), (b, _) in zip(back.windows, windows, strict=True):
        np.testing.assert_allclose(a, b, atol=1e-9)


def test_every_hole_in_exactly_one_tile():
    cfg = job(size={"width_mm": 600, "height_mm": 400}, bed="prusa_mk4")
    grid = mural.plan_tiles(600, 400, cfg)
    rng = np.random.default_rng(1)
    ds = _random_dots(rng, 600, 400, 5000)
    # Holes exactly on grid lines too.
    on = np.array([[grid.x_edges[1], 100.0], [50.0, grid.y_edges[1]], [grid.x_edges[1], grid.y_edges[1]]])
    ds = DotSet(xy_mm=np.vstack([ds.xy_mm, on]), r_mm=np.concatenate([ds.r_mm, np.ones(3)]))
    parts = mural.split_dots(ds, grid)
    assert sum(len(p) for p in parts) == len(ds)
    for p, t in zip(parts, grid.tiles, strict=True):
        xy = p.xy_mm + np.array(t.origin)
        assert np.all((xy[:, 0] >= t.core[0]) & (xy[:, 0] <= t.core[2]))
        assert np.all((xy[:, 1] >= t.core[1]) & (xy[:, 1] <= t.core[3]))
        # In the tile frame the holes lie on the sheet.
        w, h = t.size
        assert np.all((p.xy_mm >= 0) & (p.xy_mm <= [w, h]))
    back = mural.to_mural(parts, grid)
    key = lambda a: a[np.lexsort(a.T[::-1])]  # noqa: E731
    np.testing.assert_allclose(key(back.xy_mm), key(ds.xy_mm), atol=1e-9)


# --------------------------------------------------------------------------- registration


def test_plate_notches_on_grid_lines():
    cfg = job(size={"width_mm": 1200, "height_mm": 800}, bed="prusa_mk4")
    grid = mural.plan_tiles(1200, 800, cfg)
    t = grid.tiles[grid.cols + 1]  # B2: an interior tile
    w, h = t.size
    ring = plate_outline(w, h, cfg.plate.outline)
    notched, n = mural.notched_ring(ring, t.grid_lines(), mural.PLATE_NOTCH_MM)
    assert n == 8
    d = mural.PLATE_NOTCH_MM
    assert polygon_area(notched) == pytest.approx(polygon_area(ring) - n * d * d, rel=1e-12)
    xs, ys = t.grid_lines()
    # Apexes sit exactly on the grid lines, d inside the outline.
    tris = [tri for _, tri in mural.notch_triangles(ring, t.grid_lines(), d)]
    apex_x = sorted(round(tri[1, 0], 9) for tri in tris if abs(tri[0, 1] - tri[2, 1]) < 1e-9)
    assert apex_x == sorted(round(x, 9) for x in xs for _ in range(2))
    assert all(
        min(abs(tri[1, 1] - y) for y in ys) < 1e-9 for tri in tris if abs(tri[0, 0] - tri[2, 0]) < 1e-9
    )


# --------------------------------------------------------------------------- simulation


@pytest.mark.slow
def test_tiled_spray_equals_global_and_misregistration_costs():
    from stencil_cad import simulate

    # The paper's splat model, whose per-hole tails the tolerances bound.
    # Holes of r 1 mm and more, as the random dots below: the halo follows the job's largest hole.
    cfg = job(
        size={"width_mm": 300, "height_mm": 200}, bed=[200, 180], spray={"model": "paper"}, stipple=COARSE
    )
    grid = mural.plan_tiles(300, 200, cfg)
    # 3 x 2: every tile's plate carries the halo on all four sides (one wall fits every tile).
    assert len(grid.tiles) == 6
    rng = np.random.default_rng(3)
    layers = [_random_dots(rng, 300, 200, 1500), _random_dots(rng, 300, 200, 900, r=1.3)]
    sp = cfg.spray  # the halo the grid was planned with follows the job's spray
    g = 0.7
    shape = (int(200 / g), int(300 / g))
    tols = [simulate.tail_tolerance(d.xy_mm, d.r_mm, shape, g, sp) for d in layers]
    glob = np.stack([simulate.spray_opacity(d.xy_mm, d.r_mm, shape, g, sp) for d in layers])
    per_tile = list(zip(*[mural.split_dots(d, grid) for d in layers], strict=True))
    tiled = mural.simulate_tiles(shape, g, per_tile, grid, sp, [1.0, 1.0], tols)
    assert np.max(np.abs(tiled - glob)) <= 1e-6
    off = mural.simulate_tiles(
        shape, g, per_tile, grid, sp, [1.0, 1.0], tols, mural.registration_offsets(grid, 1.0, "tiles")
    )
    assert np.max(np.abs(off - glob)) > 0.05


@pytest.mark.slow
def test_tiled_spray_with_windows_equals_global_under_the_physical_model():
    """The run scores a mural in register by its global simulation: the tiled one (the physical
    spray model, a hybrid plate's windows in two tiles) is the same to 1e-6; shifted, it is not."""
    from stencil_cad import simulate
    from stencil_cad.simulate.physical import SprayGeometry
    from stencil_cad.simulate.spray import _layer_opacity

    cfg = job(size={"width_mm": 300, "height_mm": 200}, bed=[200, 180], stipple=COARSE)
    grid = mural.plan_tiles(300, 200, cfg)
    geo = SprayGeometry.for_job(cfg)
    rng = np.random.default_rng(5)
    windows = []
    for t in grid.tiles[:2]:
        x0, y0, x1, y1 = t.core
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        windows.append(
            (np.array([[cx - 12, cy - 7], [cx + 12, cy - 7], [cx + 12, cy + 9], [cx - 12, cy + 9]]), ())
        )
    plain = _random_dots(rng, 300, 200, 1200)
    layers = [
        DotSet(xy_mm=plain.xy_mm, r_mm=plain.r_mm, windows=tuple(windows)),
        _random_dots(rng, 300, 200, 700, r=1.3),
    ]
    g = 0.5
    shape = (int(200 / g), int(300 / g))
    sp, times = cfg.spray, [2.0, 3.0]
    tols = [simulate.tail_tolerance(d.xy_mm, d.r_mm, shape, g, sp) for d in layers]
    glob = np.stack([_layer_opacity(d, shape, g, sp, t, geo) for d, t in zip(layers, times, strict=True)])
    assert glob[0].max() > 0.5  # the windows spray
    per_tile = list(zip(*[mural.split_dots(d, grid) for d in layers], strict=True))
    assert sum(len(ts[0].windows) for ts in per_tile) == 2
    tiled = mural.simulate_tiles(shape, g, per_tile, grid, sp, times, tols, geometry=geo)
    assert np.max(np.abs(tiled - glob)) <= 1e-6
    off = mural.simulate_tiles(
        shape, g, per_tile, grid, sp, times, tols, mural.registration_offsets(grid, 1.0, "layers"), geo
    )
    assert np.max(np.abs(off - glob)) > 0.05


def test_halo_covers_the_spray():
    from stencil_cad.simulate import dot_sigma_mm
    from stencil_cad.simulate.physical import spread_sigma_mm

    cfg = job(spray={"model": "paper"})
    sigma = float(dot_sigma_mm(cfg.stipple.sizes.max_radius_mm, cfg.spray.nozzle_height))
    halo = mural.spray_halo_mm(cfg)
    assert np.exp(-(halo**2) / (2 * sigma**2)) <= mural.HALO_TAIL * 1.0001
    # The physical model (the default): 5 sigma of the tallest wall's blur past the largest hole.
    cfg = job(wall={"standoff_mm": [6.0, 15.0]})
    sigma = spread_sigma_mm(cfg.spray, 15.0)
    assert mural.spray_halo_mm(cfg) >= 5.0 * sigma + cfg.stipple.sizes.max_radius_mm


def test_seam_density_of_a_global_stipple():
    from stencil_cad import stipple

    cfg = job(size={"width_mm": 400, "height_mm": 200}, bed=[250, 250], stipple={"tone": "linear"})
    grid = mural.plan_tiles(400, 200, cfg)
    assert grid.cols == 2
    alpha = np.full((200, 400), 0.5)
    ds = stipple.stipple_layer(alpha, 1.0, cfg.stipple, np.random.default_rng(0))
    rows = mural.seam_density([ds], grid)
    assert len(rows) == grid.cols - 1 + grid.rows - 1
    for row in rows:
        assert abs(row["ratio_flank"] - 1) < 0.1
        assert abs(row["ratio_global"] - 1) < 0.1


def test_mural_map_and_manifest_rows():
    cfg = job(size={"width_mm": 600, "height_mm": 400}, bed="prusa_mk4")
    grid = mural.plan_tiles(600, 400, cfg)
    img = mural.mural_map(grid, 3, np.zeros((40, 60, 3)), width_px=600)
    assert img.dtype == np.uint8 and img.shape[1] == 600 + 120
    rows = mural.manifest_rows(grid)
    assert rows[0]["tile"] == "A1" and rows[0]["position_mm"] == [0.0, round(grid.y_edges[-2], 3)]
    order = mural.order_of_work(grid, 3)
    assert order[0].startswith("layer 01: A1 A2")


def test_plan_cost():
    cfg = job(size={"width_mm": 1200, "height_mm": 800}, bed="prusa_mk4")
    grid = mural.plan_tiles(1200, 800, cfg)
    c = mural.plan_cost(grid, cfg, 4, 1_000_000)
    assert c["tiles"] == len(grid.tiles) and c["plates"] == 4 * len(grid.tiles)
    assert c["holes_at_most"] > 100_000 and c["estimated_seconds"] > 0


# --------------------------------------------------------------------------- resolution


def test_auto_resolution_follows_the_holes(tmp_path):
    from PIL import Image

    from stencil_cad import pipeline

    cfg = job(size={"width_mm": 1200, "px_per_mm": "auto"}, stipple=COARSE)
    pitch = resolution.hole_pitch_mm(cfg)
    assert resolution.working_mm_per_px(cfg) == pytest.approx(pitch / 3)
    from stencil_cad.simulate import dot_sigma_mm

    sigma = float(dot_sigma_mm(cfg.stipple.sizes.radius_mm, cfg.spray.nozzle_height))
    assert resolution.sim_mm_per_px(cfg) == pytest.approx(sigma / 2)
    far = job(size={"width_mm": 1200, "px_per_mm": "auto"}, stipple=COARSE, view={"distance_m": 10})
    assert resolution.working_mm_per_px(far) == pytest.approx(10_000 * np.radians(1 / 60))
    path = tmp_path / "small.png"
    Image.fromarray((np.random.default_rng(0).random((341, 512, 3)) * 255).astype(np.uint8)).save(path)
    pic = pipeline.load_picture(
        job(image=str(path), size={"width_mm": 1200, "px_per_mm": "auto"}, stipple=COARSE)
    )
    assert pic.mm_per_px == pytest.approx(pitch / 3, rel=0.01)
    with pytest.raises(UserError, match="image too small"):
        pipeline.load_picture(job(image=str(path), size={"width_mm": 1200}, stipple=COARSE))
    with pytest.raises(UserError, match="image too small"):
        pipeline.load_picture(
            job(image=str(path), size={"width_mm": 2000, "px_per_mm": "auto"}, stipple=COARSE)
        )


# --------------------------------------------------------------------------- end to end


@pytest.mark.slow
def test_small_mural_end_to_end(tmp_path):
    """A 240 × 150 mm picture on a 200 × 180 mm bed: two tiles, every part checked."""
    import json

    import ezdxf

    from stencil_cad.pipeline import registration
    from stencil_cad.pipeline.run import run_command

    cfg = job(
        name="mural test",
        size={"width_mm": 240, "height_mm": 150, "px_per_mm": "auto"},
        bed=[200, 180],
        decompose={"layers": 2},
    )
    lines = []
    out = tmp_path / "out"
    run, _, files = run_command("run", cfg, out, announce=lines.append)
    assert lines and "2 tile(s)" in lines[0] and "4 plates" in lines[0]
    m = json.loads((out / "manifest.json").read_text())
    mu = m["mural"]
    assert [t["tile"] for t in mu["tiles"]] == ["A1", "A2"]
    assert mu["holes_total"] == mu["holes_global"] == sum(r["dots"] for r in m["stipple"])
    assert mu["union_check_rules"] == "passed"
    # The tiles' plates are compensated like a one-plate job's, and the simulation sprays them as made.
    assert mu["compensated"]
    offset = cfg.stipple.sizes.hole_offset_mm
    assert all(0 < p["drawn_minus_asked_mm"] <= offset + 1e-4 for p in m["build"]["plates"])
    sim = mu["simulation"]
    # In register, the tiled mural is the global simulation (tested above): its scores are the job's.
    assert sim["zero_error_scores"]["scielab"] == round(m["simulate"]["scielab"], 5)
    assert [(c["between"], c["error_mm"]) for c in sim["registration_cost"]] == list(
        registration.REGISTRATION_CASES
    )
    for c in sim["registration_cost"]:
        assert c["cost_scielab"] == pytest.approx(c["scielab"] - m["simulate"]["scielab"], abs=2e-5)
    plates, walls = m["build"]["plates"], m["build"]["walls"]
    # One wall serves both tiles (every tile's plate has one size and one set of notches).
    assert len(plates) == 4 and len(walls) == 1 and walls[0]["tiles"] == ["A1", "A2"]
    # The plates stand on posts: one post part, each plate's pin holes at its sites, clear of holes.
    posts = mu["posts"]
    assert posts["valid"] and posts["n_solids"] == 1 and posts["rel_error"] < 1e-6
    assert posts["most"] == max(posts["per_plate"].values()) >= 1
    assert all(p["posts"] == posts["per_plate"][f"{p['tile']} {p['layer']}"] for p in plates)
    # One 0.3 mm layer on posts: a soft FDM mural's label is raised, so nothing needs a floor.
    assert m["config"]["plate"]["label"] == "emboss"
    assert m["plate"]["thickness_mm"] == 0.3
    for p in plates:
        assert p["valid"] and p["n_solids"] == 1 and p["notches"] == 8
        assert max(p["bbox_mm"]) <= 200 and min(p["bbox_mm"]) <= 180
        assert max(p["dxf_sheet_mm"]) <= 200 and min(p["dxf_sheet_mm"]) <= 180
    for w in walls:
        assert w["valid"] and w["notches"] == 8 and w["rel_error"] < 1e-6
        bb = w["bbox"]
        assert max(bb[3] - bb[0], bb[4] - bb[1]) <= 200 and min(bb[3] - bb[0], bb[4] - bb[1]) <= 180
    names = {f.name for f in files}
    for stem in ("tile_A1_layer_01", "tile_A2_layer_02"):
        assert {f"{stem}.step", f"{stem}.stl", f"{stem}.dxf"} <= names
    assert {"tile_A1_wall.step", "tile_A1_wall.stl", "post.step", "post.stl", "mural_map.png"} <= names
    assert "tile_A2_wall.stl" not in names
    # Every layer of a tile has the same notched outline in its DXF.
    outlines = []
    for i in (1, 2):
        doc = ezdxf.readfile(out / f"tile_A1_layer_{i:02d}.dxf")
        polys = [e for e in doc.modelspace() if e.dxftype() == "LWPOLYLINE"]
        # The outline encloses every other ring (a hybrid plate's windows can have more vertices).
        rings = (np.array([v[:2] for v in p.get_points()]) for p in polys)
        outlines.append(max(rings, key=lambda a: float(np.ptp(a[:, 0]) * np.ptp(a[:, 1]))))
    np.testing.assert_allclose(outlines[0], outlines[1])
    # Read back from the files alone: the tiles' DXF holes in mural coordinates are the
    # mural's dots, one to one, and keep the rules across the seam.
    from benchmarks.mural_check import check

    got = check(out)
    assert got["same_holes"] and got["union_rules"] == "passed"
    assert got["holes_dxf"] == got["holes_csv"] == m["mural"]["holes_global"]
    assert got["plates_fit"] and got["walls_fit"] and got["all_valid"]


def test_summary_counts_a_murals_tile_files_per_kind():
    from stencil_cad.report import _grouped_tile_files

    names = sorted(
        [f"tile_{r}{c}_layer_{k:02d}.stl" for r in "AB" for c in range(1, 12) for k in (1, 2)]
        + [f"tile_{r}{c}_wall.step" for r in "AB" for c in range(1, 12)]
        + ["manifest.json", "mural_map.png"]
    )
    grouped = _grouped_tile_files(names)
    assert grouped == [
        "tile_A1…B11_layer_NN.stl (44)",
        "tile_A1…B11_wall.step (22)",
        "manifest.json",
        "mural_map.png",
    ]
    few = ["tile_A1_layer_01.stl", "tile_A2_layer_01.stl", "manifest.json"]
    assert _grouped_tile_files(few) == few
