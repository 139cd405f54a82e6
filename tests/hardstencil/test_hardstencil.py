"""Hard-stencil mode: segmentation, topology (islands held by bridges), polygons."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy import ndimage as ndi
from skimage.color import deltaE_ciede2000, rgb2lab

from stencil_cad.config.hard import HardConfig, SprayOrder
from stencil_cad.geometry import polygon_area
from stencil_cad.hardstencil import make_hard_stencils, render_ideal
from stencil_cad.hardstencil.segment import (
    _expand,
    alpha_expansion,
    data_costs,
    merge_small_regions,
    potts_energy,
)
from stencil_cad.hardstencil.topology import (
    footprint,
    mask_to_polygons,
    process_layer,
    rasterise_polygons,
)
from stencil_cad.model import Picture

S = 0.5  # mm per px (2 px/mm, the default working resolution)
WHITE = np.array([1.0, 1.0, 1.0])
INK = np.array([0.1, 0.15, 0.5])


def _hard(img, cfg=None, min_feature=1.0, bridge=1.0, seed=0, s=S):
    return make_hard_stencils(
        Picture(rgb=img, mm_per_px=s),
        cfg or HardConfig(colours=2),
        min_feature,
        bridge,
        np.random.default_rng(seed),
    )


def _draw(mask):
    img = np.empty((*mask.shape, 3))
    img[...] = WHITE
    img[mask] = INK
    return img


def _disc(h, w, cy, cx, r):
    yy, xx = np.mgrid[:h, :w]
    return np.hypot(yy - cy, xx - cx) <= r


def shape_o(h=120, w=120):
    return _disc(h, w, 60, 60, 40) & ~_disc(h, w, 60, 60, 20)


def shape_8(h=160, w=110):
    top = _disc(h, w, 48, 55, 34) & ~_disc(h, w, 48, 55, 16)
    bottom = _disc(h, w, 112, 55, 34) & ~_disc(h, w, 112, 55, 16)
    return top | bottom


def shape_rings(h=170, w=170):
    m = np.zeros((h, w), dtype=bool)
    for r in (80, 60, 40, 20):
        m |= _disc(h, w, 85, 85, r) & ~_disc(h, w, 85, 85, r - 10)
    return m


def fine_sheet_pieces(polygons, shape, s, bridge_mm, f=4):
    """Pieces of sheet, traced from the polygons at f x the resolution, joined only by
    necks a ``bridge_mm`` disc slides through, counting those big enough to hold a disc one
    working pixel wider than a bridge (smaller specks are allowed to hang on thinner
    necks). A good stencil gives 1: the frame's piece."""
    h, w = shape
    fine = rasterise_polygons(polygons, (h * f, w * f), s / f)
    fb = footprint(bridge_mm / s * f)
    big = footprint((bridge_mm / s + 1) * f)
    pad = big.shape[0] + 2
    sheet = np.pad(~fine, pad, constant_values=True)
    # Pieces between which a bridge-wide disc can slide: components of its free centres.
    lab, n = ndi.label(ndi.binary_erosion(sheet, fb, border_value=1))
    has_core = np.bincount(lab[ndi.binary_erosion(sheet, big, border_value=1)], minlength=n + 1) > 0
    has_core[0] = False
    return int(has_core.sum())


def sheet_pieces(cut):
    """4-connected pieces of sheet with the frame around the picture."""
    return ndi.label(np.pad(~cut, 1, constant_values=True))[1]


# ----------------------------------------------------------------------------- config


def test_config_defaults_and_checks():
    cfg = HardConfig()
    assert cfg.colours == 4 and cfg.order == SprayOrder.light_to_dark and cfg.bridge_width_mm is None
    with pytest.raises(ValueError, match="palette"):
        HardConfig(order="given")
    with pytest.raises(ValueError, match="hex"):
        HardConfig(palette=["#ffffff", "blue"])
    with pytest.raises(ValueError):
        HardConfig(colours=1)
    with pytest.raises(ValueError):
        HardConfig(unknown_key=1)


def test_bridge_below_process_minimum_is_rejected():
    with pytest.raises(ValueError, match=r"≥ the process minimum bridge width \(1.5 mm\), got 1.0"):
        _hard(_draw(shape_o()), HardConfig(colours=2, bridge_width_mm=1.0), bridge=1.5)


# ----------------------------------------------------------------------------- segmentation


def test_expansion_move_is_the_best_move_brute_force():
    rng = np.random.default_rng(1)
    h, w, k = 3, 3, 3
    for _ in range(8):
        unary = rng.random((h, w, k)) * 10
        f = rng.integers(0, k, (h, w))
        wgt = float(rng.random() * 5)
        for alpha in range(k):
            got = potts_energy(unary, _expand(unary, f, alpha, wgt), wgt)
            best = min(
                potts_energy(unary, np.where(np.array(bits, bool).reshape(h, w), alpha, f), wgt)
                for bits in itertools.product((0, 1), repeat=h * w)
            )
            assert got == pytest.approx(best, abs=1e-9)


def test_alpha_expansion_denoises_blocks():
    rng = np.random.default_rng(2)
    truth = np.zeros((60, 90), dtype=int)
    truth[:, 30:60] = 1
    truth[20:40, 60:] = 2
    centres = np.array([[20.0, 0, 0], [50, 20, -20], [80, -10, 30]])
    lab = centres[truth] + rng.normal(0, 12, (*truth.shape, 3))
    unary = data_costs(lab, centres)
    start = np.argmin(unary, axis=2)
    labels, _ = alpha_expansion(unary, start, 10.0, 5)
    assert np.mean(start == truth) < 0.97  # the noise is real
    assert np.mean(labels == truth) > 0.995
    assert potts_energy(unary, labels, 10.0) <= potts_energy(unary, truth, 10.0) + 1e-6


def test_merge_small_regions_leaves_none_small():
    rng = np.random.default_rng(3)
    labels = rng.integers(0, 3, (40, 40))
    labels[:20] = 0
    centres = np.array([[0.0, 0, 0], [50, 0, 0], [100, 0, 0]])
    out, merged = merge_small_regions(labels, centres, 12)
    assert merged > 0
    for k in range(3):
        lab, n = ndi.label(out == k)
        if n:
            assert np.bincount(lab.ravel())[1:].min() >= 12


# ----------------------------------------------------------------------------- topology


@pytest.mark.parametrize("d", [0.3, 1.0, 1.2, 1.5, 2.0, 2.5, 3.0, 3.2, 4.0, 5.7, 8.0])
def test_footprint_spans_its_diameter(d):
    fp = footprint(d)
    n = fp.shape[0]
    assert n == max(1, math.ceil(d)) and fp.shape == (n, n)
    assert fp.any(axis=0).all() and fp.any(axis=1).all()
    assert fp[n // 2].all() and fp[:, n // 2].all() and fp[(n - 1) // 2].all()
    assert np.array_equal(fp, fp[::-1]) and np.array_equal(fp, fp.T)


@pytest.mark.parametrize(
    ("name", "mask", "islands"),
    [("O", shape_o(), 1), ("8", shape_8(), 2), ("rings", shape_rings(), 4)],
)
def test_shapes_make_one_solid_sheet_held_by_bridges(name, mask, islands):
    res = _hard(_draw(mask))
    assert res.count == 1
    cut = res.cut_masks[0]
    rep = res.report
    assert rep["islands_bridged"] == islands
    assert rep["bridges"] >= islands
    assert sheet_pieces(cut) == 1, name
    # Every island lost some cut to its bridge, no more than a bridge-wide strip per ring crossing.
    assert np.count_nonzero(mask & ~cut) > 0
    layer = rep["per_layer"][0]
    assert layer["sheet_components"] == 1 and layer["robust_components"] == 1
    assert layer["polygon_holes"] == 0 and layer["polygon_sheet_components"] == 1
    assert layer["polygon_held_components"] == 1
    assert fine_sheet_pieces(res.cut_layers[0].polygons, cut.shape, S, 1.0) == 1
    # Each bridge is at least the minimum width: a bridge-wide disc slides from the middle of
    # every island to the frame.
    fb = footprint(1.0 / S)
    sheet = np.pad(~cut, 4, constant_values=True)
    lab = ndi.label(ndi.binary_erosion(sheet, fb, border_value=1))[0]
    holes = ndi.binary_fill_holes(mask) & ~mask
    hl, hn = ndi.label(holes)
    for i in range(1, hn + 1):
        rr, cc = np.nonzero(hl == i)
        j = len(rr) // 2
        assert lab[rr[j] + 4, cc[j] + 4] == lab[0, 0], f"{name}: island {i} not held bridge-wide"


def test_bridges_are_wider_for_wider_setting():
    mask = shape_o()
    narrow = _hard(_draw(mask), HardConfig(colours=2), bridge=1.0).cut_masks[0]
    wide = _hard(_draw(mask), HardConfig(colours=2, bridge_width_mm=3.0), bridge=1.0).cut_masks[0]
    lost_narrow = np.count_nonzero(mask & ~narrow)
    lost_wide = np.count_nonzero(mask & ~wide)
    # Ring thickness 20 px: a bridge of b mm carves about 20 x (b / S + 1) px.
    assert 20 * 3 <= lost_narrow <= 20 * 4 + 20
    assert 20 * 7 <= lost_wide <= 20 * 8 + 20


def test_bridges_take_the_cheap_way():
    # An O whose ring is cheap to cross only on its lower-left (say, painted over later):
    # the bridge goes there even though the ring is equally thick everywhere.
    mask = shape_o()
    yy, xx = np.mgrid[:120, :120]
    cheap = (xx < 50) & (yy > 70)
    cost = np.where(cheap, 0.1, 3.0)
    cut, rep = process_layer(mask, np.zeros_like(mask), cost, 2.0, 2.0, union_cut=False)
    carved = mask & ~cut
    assert rep["islands"] == 1 and rep["bridges"] == 1
    assert np.count_nonzero(carved) >= 40
    # The bridge disc may spill a pixel or two over the cheap zone's edge; the four 1-px tips of
    # the rasterised circle are trimmed as thinner than the minimum feature.
    assert np.count_nonzero(carved & ~ndi.binary_dilation(cheap, iterations=2)) <= 4
    assert sheet_pieces(cut) == 1


def test_union_cut_removes_islands_of_later_colours():
    disc = _disc(120, 120, 60, 60, 40)
    inner = _disc(120, 120, 60, 60, 20)
    img = np.ones((120, 120, 3))
    img[disc] = [0.6, 0.6, 0.6]
    img[inner] = [0.05, 0.05, 0.05]
    with_union = _hard(img, HardConfig(colours=3, union_cut=True))
    without = _hard(img, HardConfig(colours=3, union_cut=False))
    assert with_union.report["per_layer"][0]["islands_cut_as_later"] == 1
    assert with_union.report["per_layer"][0]["bridges"] == 0
    assert without.report["per_layer"][0]["bridges"] >= 1
    # The union layer is the grey disc, centre included (less the circle's four 1-px tips).
    assert np.count_nonzero(with_union.cut_masks[0] != disc) <= 4
    for res in (with_union, without):
        for m in res.cut_masks:
            assert sheet_pieces(m) == 1


def test_thin_cut_regions_are_widened_or_dropped():
    img = np.ones((80, 120, 3))
    img[20:60, 10:12] = INK  # 40 px long, 2 px = 1 mm wide: thin for a 2 mm minimum
    img[30:34, 60:62] = INK  # a 4 x 2 px sliver: too short to keep
    img[20:60, 80:110] = INK  # a thick block
    cfg = HardConfig(colours=2, min_region_mm2=0.0)
    own = np.all(img == INK, axis=2)
    cut, rep = process_layer(own, np.zeros_like(own), np.ones(own.shape), 4.0, 2.0)
    assert rep["regions_widened"] == 1
    assert rep["regions_dropped"] == 1
    assert not cut[28:36, 56:66].any()
    # The widened line is at least the minimum feature (4 px) wide along its length.
    assert (cut[25:55, :30].sum(axis=1) >= 4).all()
    # The thick block keeps its shape, less its corner pixels (rounded by the feature disc).
    assert np.count_nonzero(cut[20:60, 80:110] != own[20:60, 80:110]) == 4
    res = _hard(img, cfg, min_feature=2.0)
    assert res.report["regions_widened"] >= 1 and res.report["regions_dropped"] >= 0


def test_small_region_merged_and_counted():
    img = np.ones((80, 80, 3))
    img[10:70, 10:70] = INK
    img[38:40, 38:40] = [0.9, 0.1, 0.1]  # 2 x 2 px = 1 mm², below the 2 mm² minimum region
    res = _hard(img, HardConfig(colours=3, min_region_mm2=2.0))
    assert res.report["regions_merged"] >= 1
    assert res.report["colours"] == 2  # the red speck vanished with its colour
    assert any("vanished" in w for w in res.report["warnings"])


def test_more_colours_than_the_image_has_gives_fewer_layers_and_a_warning():
    res = _hard(_draw(shape_o()), HardConfig(colours=6))
    assert res.count == 1 and res.palette.shape == (2, 3)
    assert any("only 2 distinct colours" in w for w in res.report["warnings"])


def test_real_image_no_loose_island_in_any_layer():
    from skimage import data
    from skimage.transform import resize

    img = resize(data.coffee() / 255.0, (100, 150), anti_aliasing=True)
    res = _hard(img, HardConfig(colours=4), min_feature=1.0, bridge=1.0)
    assert res.count == 3
    for cl, m, rep in zip(res.cut_layers, res.cut_masks, res.report["per_layer"], strict=True):
        assert sheet_pieces(m) == 1
        assert rep["robust_components"] == 1 and rep["polygon_sheet_components"] == 1
        assert rep["polygon_held_components"] == 1
        assert rep["polygon_mismatch_px"] == 0
        assert fine_sheet_pieces(cl.polygons, m.shape, S, 1.0) == 1
        # No cut feature thinner than the minimum (2 px): opening by it changes nothing.
        assert np.array_equal(ndi.binary_opening(np.pad(m, 3), footprint(2.0))[3:-3, 3:-3], m)


# ----------------------------------------------------------------------------- result and colours


def test_flat_colour_image_is_reproduced():
    img = np.ones((100, 140, 3))
    img[:, 70:] = [0.85, 0.75, 0.2]
    img[50:, :] = [0.2, 0.35, 0.7]
    img[20:80, 40:100] = [0.15, 0.1, 0.1]
    res = _hard(img, HardConfig(colours=4))
    assert res.count == 3
    de = deltaE_ciede2000(rgb2lab(img), rgb2lab(render_ideal(res)))
    assert de.mean() < 0.5
    # Spray order is light to dark and each layer is one colour's region (the later colours
    # in the union where they are islands).
    lightness = rgb2lab(res.palette.reshape(1, -1, 3))[0, :, 0]
    assert np.all(np.diff(lightness) < 0)
    assert np.allclose(res.primer, [1, 1, 1], atol=1e-6)


def test_flat_colour_image_through_the_spray_model():
    from stencil_cad import simulate
    from stencil_cad.config.spray import SprayConfig
    from stencil_cad.hardstencil import simulate_hard

    img = np.ones((100, 140, 3))
    img[:, 70:] = [0.85, 0.75, 0.2]
    img[50:, :] = [0.2, 0.35, 0.7]
    img[20:80, 40:100] = [0.15, 0.1, 0.1]
    res = _hard(img, HardConfig(colours=4))
    _, comp = simulate_hard(res, SprayConfig(model="paper", nozzle_height=7.0))
    de = deltaE_ciede2000(rgb2lab(img), rgb2lab(comp))
    # Away from colour edges and the picture edge (4 mm, three times the spray blur sigma of
    # 1.3 mm at h = 7) the flat regions come out within about 1 ΔE (opacity 0.98 of opaque paint).
    edge = np.zeros(img.shape[:2], dtype=bool)
    edge[:, 1:] |= np.any(img[:, 1:] != img[:, :-1], axis=2)
    edge[1:] |= np.any(img[1:] != img[:-1], axis=2)
    edge[[0, -1]] = True
    edge[:, [0, -1]] = True
    inside = ndi.distance_transform_edt(~edge) * S >= 4.0
    assert de[inside].mean() < 1.5 and de[inside].max() < 2.0
    assert simulate.score(img, comp)["de2000_mean"] < 6.0


def test_given_palette_and_order():
    img = _draw(shape_o())
    cfg = HardConfig(palette=["#1a2680", "#ffffff"], order="given")
    res = _hard(img, cfg)
    assert np.allclose(res.primer, [0x1A / 255, 0x26 / 255, 0x80 / 255])
    # The white is now the paint: its cut is the outside and the O's middle.
    assert np.array_equal(res.cut_masks[0] | shape_o(), np.ones((120, 120), bool)) or res.count == 1
    assert sheet_pieces(res.cut_masks[0]) == 1


def test_deterministic():
    from skimage import data
    from skimage.transform import resize

    img = resize(data.chelsea() / 255.0, (60, 90), anti_aliasing=True)
    a = _hard(img, HardConfig(colours=4), seed=5)
    b = _hard(img, HardConfig(colours=4), seed=5)
    assert np.array_equal(a.cut_masks, b.cut_masks) and np.array_equal(a.palette, b.palette)


# ----------------------------------------------------------------------------- polygons


def test_polygons_round_trip_and_orientation():
    rng = np.random.default_rng(7)
    for _ in range(10):
        m = ndi.binary_opening(rng.random((50, 70)) < 0.55, footprint(2))
        polys = mask_to_polygons(m, S, 0.0)
        assert np.array_equal(rasterise_polygons(polys, m.shape, S), m)
        for outer, holes in polys:
            assert polygon_area(outer) > 0
            assert all(polygon_area(hole) < 0 for hole in holes)
    ring = shape_o()
    polys = mask_to_polygons(ring, S, 0.1)
    assert len(polys) == 1 and len(polys[0][1]) == 1
    outer, (hole,) = polys[0]
    assert polygon_area(outer) - (-polygon_area(hole)) == pytest.approx(
        np.count_nonzero(ring) * S * S, rel=0.01
    )
    assert polygon_area(outer) == pytest.approx(math.pi * 20**2, rel=0.02)  # r = 40 px = 20 mm
    # Simplified polygons stay within 0.3 px of the exact trace: no pixel centre changes side.
    assert np.array_equal(rasterise_polygons(polys, ring.shape, S), ring)


def test_polygons_are_in_the_mm_picture_frame():
    m = np.zeros((40, 60), dtype=bool)
    m[2:10, 3:13] = True  # top-left of the image
    ((outer, holes),) = mask_to_polygons(m, S, 0.0)
    assert not holes
    assert outer[:, 0].min() == pytest.approx(3 * S) and outer[:, 0].max() == pytest.approx(13 * S)
    assert outer[:, 1].min() == pytest.approx((40 - 10) * S) and outer[:, 1].max() == pytest.approx(
        (40 - 2) * S
    )
