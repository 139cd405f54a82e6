"""Hybrid plates: windows found where a layer is solid, bridged, and built into one plate with holes."""

import xml.etree.ElementTree as ET

import ezdxf
import numpy as np
import pytest
from readers import admesh_counts, need

from stencil_cad.config import JobConfig, PlateConfig
from stencil_cad.config.stipple import StippleConfig
from stencil_cad.frames import rasterise_polygons
from stencil_cad.geometry import polygon_area
from stencil_cad.hardstencil.windows import allowed_area, find_windows, tile_windows, window_sizes
from stencil_cad.stipple import check_rules, stipple_layer
from stencil_cad.stipple.windows import hole_alpha, window_clearance, with_windows

S = 0.25  # mm per px
H, W = 200, 280  # 50 x 70 mm


def ramp_with_island():
    """A layer solid in a wide disc (with a clear hole in its middle: an island), fading outwards."""
    yy, xx = np.mgrid[0:H, 0:W]
    rho = np.hypot(yy - 100, xx - 140)
    alpha = np.clip(2.5 - rho / 50.0, 0.0, 1.0)
    alpha[rho < 12] = 0.0
    return alpha


def sla():
    return StippleConfig(process="sla")


def test_window_covers_the_solid_region_and_its_island_is_bridged():
    alpha = ramp_with_island()
    win = find_windows(alpha, S, sla())
    assert win.report["windows"] == 1
    assert win.report["islands"] == 1 and win.report["bridges"] >= 1
    assert win.report["held_components"] == 1
    (outer, inner) = win.polygons[0]
    assert inner == () and polygon_area(outer) > 0  # counter-clockwise, no island left unheld
    # The window lies where the layer is solid and covers most of it.
    solid = alpha >= sla().window_opacity
    assert not (win.mask & ~solid).any()
    assert win.mask.sum() > 0.8 * solid.sum()


def test_windows_off_and_small_regions_give_none():
    alpha = ramp_with_island()
    assert find_windows(alpha, S, sla().model_copy(update={"windows": "off"})).polygons == ()
    small = np.zeros((H, W))
    small[90:110, 130:150] = 1.0  # 5 mm square: below the 6 mm minimum window
    assert find_windows(small, S, sla()).polygons == ()
    assert window_sizes(StippleConfig(process="fdm"))[0] == pytest.approx(4 * 1.6)


def test_windows_stay_clear_of_seams():
    alpha = np.ones((H, W))
    cores = [(0.0, 0.0, 35.0, 50.0), (35.0, 0.0, 70.0, 50.0)]
    allowed = allowed_area((H, W), S, cores, (70.0, 50.0), 1.0)
    win = find_windows(alpha, S, sla(), allowed)
    assert win.report["windows"] == 2
    for outer, _ in win.polygons:
        x0, x1 = outer[:, 0].min(), outer[:, 0].max()
        assert x1 <= 34.0 + 1e-9 or x0 >= 36.0 - 1e-9


@pytest.mark.parametrize("seam_mm", [175.0, 174.4, 175.6, 176.1])
def test_windows_on_a_coarse_grid_keep_the_margin_from_every_seam(seam_mm):
    # 0.48 px/mm: a pixel (2.08 mm) is wider than the two margins across a seam; the outline is
    # traced along the pixels' edges, so a margin kept by the pixel centres alone let one window
    # run across the seam (a 1.2 m mural's plate got a window past its part).
    s = 1 / 0.48
    h, w = 60, 168  # 125 x 350 mm
    width, height = w * s, h * s
    cores = [(0.0, 0.0, seam_mm, height), (seam_mm, 0.0, width, height)]
    fdm = StippleConfig(process="fdm")
    margin = window_sizes(fdm)[2]
    allowed = allowed_area((h, w), s, cores, (width, height), margin)
    win = find_windows(np.ones((h, w)), s, fdm, allowed)
    assert win.report["windows"] == 2
    for outer, _ in win.polygons:
        x0, x1 = outer[:, 0].min(), outer[:, 0].max()
        assert x1 <= seam_mm - margin + 1e-9 or x0 >= seam_mm + margin - 1e-9
    assert not (win.mask & ~allowed).any()


@pytest.mark.parametrize("seam_mm", [175.0, 174.4, 175.6, 176.1])
def test_tiles_windows_meet_at_their_seam_and_never_cross_it(seam_mm):
    # A mural's tiles find their windows in their own cores: a solid region across a seam is one
    # window on each side, and where the seam runs along pixel edges the two meet on it, with no
    # band of sheet and no blur inset between them (a dark line at every seam of a mural).
    s = 1 / 0.48 if seam_mm != 175.0 else 0.5
    h, w = (60, 168) if seam_mm != 175.0 else (250, 700)
    width, height = w * s, h * s
    cores = [(0.0, 0.0, seam_mm, height), (seam_mm, 0.0, width, height)]
    fdm = StippleConfig(process="fdm")
    win = tile_windows(np.ones((h, w)), s, fdm, cores, (width, height), inset_mm=1.5)
    assert win.report["windows"] == 2
    left, right = sorted((o[:, 0].min(), o[:, 0].max()) for o, _ in win.polygons)
    assert left[1] <= seam_mm + 1e-9 and right[0] >= seam_mm - 1e-9
    gap = right[0] - left[1]
    assert gap < s + 1e-9  # at most the one pixel a seam cuts through
    if seam_mm == 175.0:  # on a pixel edge: they meet
        assert gap == pytest.approx(0.0, abs=1e-9)
    # No inset at the picture's edge either: the plate's border is there.
    assert left[0] == pytest.approx(0.0, abs=1e-9)


def test_one_core_finds_the_windows_of_the_whole_picture():
    cfg = sla()
    alpha = ramp_with_island()
    one = tile_windows(alpha, S, cfg, [(0.0, 0.0, W * S, H * S)], (W * S, H * S), inset_mm=0.5)
    whole = find_windows(alpha, S, cfg, np.ones((H, W), dtype=bool), 0.5)
    assert one.report == whole.report
    assert (one.mask == whole.mask).all()
    assert all(np.array_equal(a[0], b[0]) for a, b in zip(one.polygons, whole.polygons, strict=True))


def test_windows_stay_out_of_keepouts():
    allowed = allowed_area((H, W), S, [(0.0, 0.0, 70.0, 50.0)], (70.0, 50.0), 1.0, [(20.0, 10.0, 30.0, 20.0)])
    win = find_windows(np.ones((H, W)), S, sla(), allowed)
    ring = np.vstack([o for o, _ in win.polygons])
    inside = (
        (ring[:, 0] > 19.0 + 1e-9)
        & (ring[:, 0] < 31.0 - 1e-9)
        & (ring[:, 1] > 9.0 + 1e-9)
        & (ring[:, 1] < 21.0 - 1e-9)
    )
    assert not inside.any()
    assert not win.mask[int(H - 15 / S), int(25 / S)]


def hybrid_layer():
    """A stippled layer with a window: holes around it, every hole a web from it."""
    cfg = sla().model_copy(update={"tone": "linear"})
    alpha = ramp_with_island()
    win = find_windows(alpha, S, cfg)
    left = hole_alpha(alpha, win.mask, S, cfg.hole_floor_mm + cfg.sizes.web_mm)
    ds = stipple_layer(left, S, cfg, np.random.default_rng(3))
    return with_windows(ds, win.polygons, cfg.sizes.web_mm), cfg, win


def test_holes_keep_the_web_from_the_window_and_the_rules_hold():
    ds, cfg, win = hybrid_layer()
    assert len(ds) > 50 and len(ds.windows) == 1 and ds.hole_count == len(ds) + 1
    assert window_clearance(ds.xy_mm, ds.r_mm, ds.windows, cfg.sizes.web_mm).all()
    check_rules(ds.xy_mm, ds.r_mm, cfg.design_rules(W * S, H * S))
    assert ds.r_mm.min() >= 0.5
    # A hole moved onto the window's edge is caught.
    (outer, _) = ds.windows[0]
    xy = np.vstack([ds.xy_mm, outer[:1]])
    r = np.append(ds.r_mm, 0.5)
    assert not window_clearance(xy, r, ds.windows, cfg.sizes.web_mm)[-1]


@pytest.fixture(scope="module")
def hybrid_plate(tmp_path_factory):
    from stencil_cad import cad
    from stencil_cad.exchange import dxf, svg
    from stencil_cad.outline import plate_outline

    ds, cfg, win = hybrid_layer()
    plate_cfg = PlateConfig()
    model = cad.build_plate(ds, W * S, H * S, plate_cfg, None)
    folder = tmp_path_factory.mktemp("hybrid")
    cad.write_stl(model, folder / "p.stl", 0.02)
    ring = plate_outline(W * S, H * S, plate_cfg.outline)
    drawing = dxf.stencil_for(ds, ring, "L1")
    dxf.write_dxf_stencils(folder / "p.dxf", [drawing], kerf_mm=0.0, deterministic=True)
    svg.write_svg(folder / "p.svg", drawing)
    return ds, model, folder


def test_hybrid_plate_is_one_valid_solid_of_the_analytic_volume(hybrid_plate):
    ds, model, _ = hybrid_plate
    part = model.part
    assert len(part.solids()) == 1 and part.is_valid
    geom = model.geometry
    assert len(geom.polygons) == 1 and len(geom.circles_r) == len(ds)
    # (outline - circles - window) x thickness: the window's area counts.
    assert geom.hole_area > np.pi * np.sum(ds.r_mm**2) + 0.9 * abs(polygon_area(ds.windows[0][0]))
    assert part.volume == pytest.approx(model.analytic_volume, rel=2e-3)
    from stencil_cad import cad

    check = cad.check_plate(model, ds, tolerance_mm=0.02)
    assert check["valid"] and check["n_solids"] == 1, check
    assert check["rel_error"] < 2e-3, check


def test_hybrid_plate_dxf_and_svg_cut_the_window(hybrid_plate):
    ds, _, folder = hybrid_plate
    doc = ezdxf.readfile(folder / "p.dxf")
    assert len(doc.audit().errors) == 0
    msp = doc.modelspace()
    assert len(msp.query("CIRCLE")) == len(ds)
    closed = [e for e in msp.query("LWPOLYLINE") if e.closed]
    areas = sorted(abs(polygon_area(np.array([p[:2] for p in e.get_points()]))) for e in closed)
    want = abs(polygon_area(ds.windows[0][0]))
    assert any(a == pytest.approx(want, rel=1e-3) for a in areas), (areas, want)
    root = ET.parse(folder / "p.svg").getroot()
    ns = {"s": "http://www.w3.org/2000/svg"}
    assert len(root.findall(".//s:circle", ns)) == len(ds)
    assert len(root.findall(".//s:path[@fill-rule='evenodd']", ns)) >= 1


@pytest.mark.slow
def test_hybrid_plate_admesh_clean_and_slices(hybrid_plate, tmp_path):
    from stencil_cad.slicing import slicers as sl

    _, model, folder = hybrid_plate
    counts = admesh_counts(folder / "p.stl")
    assert counts["Number of parts"] == 1
    for label in ("Degenerate facets", "Edges fixed", "Facets reversed", "Backwards edges", "Facets added"):
        assert counts[label] == 0, (label, counts)
    need("prusa-slicer")
    res = sl.slice_file(folder / "p.stl", tmp_path / "p.gcode", "prusa_fdm", timeout_s=300)
    assert res.ok, (res.errors, res.log)


def test_window_sprays_with_the_holes_stand_off_blur():
    from stencil_cad.simulate.opacity import spray_mask, windows_opacity
    from stencil_cad.simulate.physical import SprayGeometry

    ds, _, win = hybrid_layer()
    cfg = JobConfig()
    geo = SprayGeometry.for_job(cfg)
    a = windows_opacity(ds.windows, (H, W), S, cfg.spray, spray_time=3.0, geometry=geo)
    mask = rasterise_polygons(list(ds.windows), (H, W), S)
    ref = spray_mask(mask, S, cfg.spray, spray_time=3.0, geometry=geo)
    assert np.abs(a - ref).max() < 0.05
    assert a[mask].mean() > 0.5 and a[~mask].min() >= 0.0
    # Soft edge: opacity falls off over a few stand-off sigmas, not in one pixel.
    edge = (a > 0.05) & (a < 0.5 * a.max())
    assert edge.sum() > mask.sum() * 0.02
