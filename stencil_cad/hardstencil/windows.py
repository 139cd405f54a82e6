"""Windows of a hybrid plate: where a soft layer is solid over a wide region, one open cut-out.

A plate of holes cannot spray a solid coat: between holes the web always shades the surface.
Where a layer's opacity is near 1 over a region wider than ``stipple.min_window_mm`` (and at
least four hole pitches), the plate opens a window instead: the region is the opening of the
solid pixels by a disc that wide (so every part of a window is that wide somewhere), its islands
of sheet are held by bridges and its thin parts widened or dropped as a hard stencil's cut-outs
are (:func:`stencil_cad.hardstencil.topology.process_layer`), and it is traced into polygons.
The holes keep a web's distance from it (:mod:`stencil_cad.stipple.windows`).

A window never crosses a tile's seam: on a mural each tile's windows are found in its own core
(:func:`tile_windows`), so a region that crosses a seam becomes one window on each side, each if
it is still wide enough, and the two meet at the seam. Each plate's sheet goes on past its seam
(the tile's overlap), so the two sprays add up there as one window's would, with no edge pulled in
and no band of sheet between them: on the 600 x 400 mm coffee mural a band of a bridge width on
each side of a seam, plus each window's blur inset, left a dark line across the crema at every seam.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage as ndi

from ..config.stipple import StippleConfig, Windows
from ..frames import pixel_centres_mm, rasterise_polygons
from .topology import mask_to_polygons, polygon_sheet_check, process_layer

#: Simplification tolerance of a window's outline in mm (capped at 0.3 px by the tracer).
SIMPLIFY_MM = 0.05


@dataclass(frozen=True)
class LayerWindows:
    """The windows of one layer.

    Attributes:
        polygons: Each ``(outer, ())``: a counter-clockwise ring in mm, islands bridged.
        mask: ``(H, W)`` bool on the working grid: the pixels whose centres lie in a window.
        report: Figures: ``windows``, ``window_area_mm2``, ``min_window_mm``, ``bridges``,
            ``islands``, ``dropped_with_islands``, ``held_components``.
    """

    polygons: tuple
    mask: np.ndarray
    report: dict = field(default_factory=dict)


def window_sizes(cfg: StippleConfig) -> tuple[float, float, float]:
    """``(smallest window, smallest cut feature, bridge width)`` in mm for these stipple rules.

    The smallest window is ``stipple.min_window_mm`` or four hole pitches (``2 r + web`` at the
    hole floor), whichever is larger; the feature and bridge sizes are hard mode's for the same
    process (twice the hole floor; the web, at least 1 mm).
    """
    floor = cfg.hole_floor_mm
    web = cfg.sizes.web_mm
    return max(cfg.min_window_mm, 4.0 * (2.0 * floor + web)), 2.0 * floor, max(web, 1.0)


def allowed_area(
    shape: tuple[int, int],
    mm_per_px: float,
    cores: Sequence[tuple[float, float, float, float]],
    picture_mm: tuple[float, float],
    seam_margin_mm: float,
    keepouts: Sequence[tuple[float, float, float, float]] = (),
) -> np.ndarray:
    """Pixels a window may cover: inside one tile's core, ``seam_margin_mm`` clear of its seams.

    Nor in a keep-out rectangle (``stipple.keepouts_mm``) grown by the same margin. The whole
    pixel keeps the margin, not only its centre: a window's outline is traced along its pixels'
    edges, half a pixel past their centres. On a coarse grid (a 1.2 m mural at 0.48 px/mm, 2.08 mm
    pixels) a margin on the centres alone left no pixel out between two tiles' cores, and one
    window ran across every seam.

    Args:
        shape: ``(H, W)`` of the working grid.
        mm_per_px: Pixel size in mm.
        cores: Each tile's core ``(x0, y0, x1, y1)`` in picture mm (one, the whole picture, for a
            one-plate job).
        picture_mm: ``(width, height)`` of the picture in mm: a core's side on the picture's edge
            is not a seam.
        seam_margin_mm: Sheet kept between a window and a seam or a keep-out, in mm.
        keepouts: Keep-out rectangles ``(x0, y0, x1, y1)`` in picture mm.

    Returns:
        ``(H, W)`` bool.
    """
    h, w = shape
    x, y = pixel_centres_mm(h, w, mm_per_px)
    xx, yy = np.broadcast_arrays(x, y)
    width, height = picture_mm
    out = np.zeros((h, w), dtype=bool)
    eps = 1e-6
    m = seam_margin_mm + 0.5 * mm_per_px
    for x0, y0, x1, y1 in cores:
        a0 = x0 + (m if x0 > eps else -1.0)
        b0 = y0 + (m if y0 > eps else -1.0)
        a1 = x1 - (m if x1 < width - eps else -1.0)
        b1 = y1 - (m if y1 < height - eps else -1.0)
        # A pixel whose edge lies on the margin's line is inside (to 1e-6 mm): with no margin, two
        # cores that meet on a pixel edge share out its pixels, none left between them.
        out |= (xx >= a0 - eps) & (xx <= a1 + eps) & (yy >= b0 - eps) & (yy <= b1 + eps)
    for x0, y0, x1, y1 in keepouts:
        out &= ~((xx > x0 - m) & (xx < x1 + m) & (yy > y0 - m) & (yy < y1 + m))
    return out


def _opening(solid: np.ndarray, diameter_px: float) -> np.ndarray:
    """The opening of ``solid`` by a disc ``diameter_px`` wide: the union of the discs that fit.

    Exact Euclidean distance transforms (linear in the pixels whatever the disc), not a digital
    disc's erosion. The picture's edge counts as solid (a window may reach the plate's border).
    """
    rad = 0.5 * diameter_px
    centres = ndi.distance_transform_edt(solid) >= rad
    if not centres.any():
        return centres
    return (ndi.distance_transform_edt(~centres) < rad) & solid


def find_windows(
    alpha: np.ndarray,
    mm_per_px: float,
    cfg: StippleConfig,
    allowed: np.ndarray | None = None,
    inset_mm: float = 0.0,
) -> LayerWindows:
    """Find one layer's windows: its wide, near-solid regions as bridged polygon cut-outs.

    Args:
        alpha: ``(H, W)`` the layer's opacity on the working grid.
        mm_per_px: Pixel size in mm.
        cfg: The stipple section (``windows``, ``min_window_mm``, ``window_opacity``, the rules).
        allowed: ``(H, W)`` bool, where a window may lie (:func:`allowed_area`), or None for
            anywhere.
        inset_mm: How far a window's edge stays inside the solid region, in mm: the spray's
            stand-off blur, so the coat a window throws past its edge lands on the region's edge
            and not beyond (at the picture's edge no inset: the plate's border is there).
            Defaults to 0.

    Returns:
        The :class:`LayerWindows` (none with ``stipple.windows: off``).
    """
    a = np.asarray(alpha)
    empty = LayerWindows((), np.zeros(a.shape, dtype=bool), {"windows": 0})
    if cfg.windows == Windows.off:
        return empty
    s = float(mm_per_px)
    min_window, min_feature, bridge = window_sizes(cfg)
    solid = a >= cfg.window_opacity
    if allowed is not None:
        solid &= allowed
    cut = _opening(solid, min_window / s)
    if inset_mm > 0.0 and cut.any():
        cut &= ndi.distance_transform_edt(cut) > inset_mm / s
    if not cut.any():
        return empty
    ones = np.ones(a.shape)
    cut, rep = process_layer(cut, np.zeros(a.shape, dtype=bool), ones, min_feature / s, bridge / s, False)
    if allowed is not None:
        # Widening a thin part dilates it: it may not grow past a seam's margin or into a keep-out.
        cut &= allowed
    polys = mask_to_polygons(cut, s, SIMPLIFY_MM)
    # Bridges join every island to the frame, so a window has no inner ring; one that still has
    # (a bridge that could not be placed) is left to the holes.
    kept = tuple((outer, ()) for outer, inner in polys if not len(inner))
    mask = rasterise_polygons(list(kept), a.shape, s)
    check = polygon_sheet_check(list(kept), a.shape, s, bridge)
    from ..geometry import polygon_area

    report = {
        "windows": len(kept),
        "window_area_mm2": round(float(sum(abs(polygon_area(o)) for o, _ in kept)), 1),
        "min_window_mm": round(min_window, 3),
        "bridge_mm": round(bridge, 3),
        "islands": int(rep.get("islands", 0)),
        "bridges": int(rep.get("bridges", 0)),
        "dropped_with_islands": len(polys) - len(kept),
        "held_components": int(check["polygon_held_components"]),
    }
    return LayerWindows(kept, mask, report)


def _merged(parts: Sequence[LayerWindows], shape: tuple[int, int]) -> LayerWindows:
    """One layer's windows from its tiles' (each placed into the whole grid already)."""
    polygons = tuple(p for w in parts for p in w.polygons)
    mask = np.zeros(shape, dtype=bool)
    for w in parts:
        mask |= w.mask
    report: dict = {"windows": len(polygons)}
    for w in parts:
        for key, value in w.report.items():
            if key in ("min_window_mm", "bridge_mm"):
                report[key] = value
            elif key != "windows":
                report[key] = round(report.get(key, 0) + value, 1)
    return LayerWindows(polygons, mask, report)


def tile_windows(
    alpha: np.ndarray,
    mm_per_px: float,
    cfg: StippleConfig,
    cores: Sequence[tuple[float, float, float, float]],
    picture_mm: tuple[float, float],
    keepouts: Sequence[tuple[float, float, float, float]] = (),
    inset_mm: float = 0.0,
) -> LayerWindows:
    """One layer's windows, found tile by tile: each inside its core, meeting its neighbours at the seams.

    Each core's pixels (those wholly inside it: on a grid whose pixels straddle a seam, those are
    left to the holes) are cut out of the grid and searched alone (:func:`find_windows`), so a seam
    pulls no window edge in (the edge inset is for the paint's blur at the solid region's own edge)
    and two tiles' windows never join into one that crosses it. A one-plate job's single core is the
    whole picture: the same windows as :func:`find_windows` over it.

    Args:
        alpha: ``(H, W)`` the layer's opacity on the working grid.
        mm_per_px: Pixel size in mm.
        cfg: The stipple section.
        cores: Each tile's core ``(x0, y0, x1, y1)`` in picture mm.
        picture_mm: ``(width, height)`` of the picture in mm.
        keepouts: Keep-out rectangles in picture mm; a window keeps a bridge width from each.
        inset_mm: As :func:`find_windows`.

    Returns:
        The :class:`LayerWindows` of every tile, polygons in picture mm and the mask on the whole grid.
    """
    a = np.asarray(alpha)
    s = float(mm_per_px)
    h, w = a.shape
    _, _, bridge = window_sizes(cfg)
    clear = allowed_area(a.shape, s, [(0.0, 0.0, *picture_mm)], picture_mm, bridge, keepouts)
    parts = []
    for core in cores:
        inside = allowed_area(a.shape, s, [core], picture_mm, 0.0)
        rows, cols = np.flatnonzero(inside.any(axis=1)), np.flatnonzero(inside.any(axis=0))
        if not len(rows):
            continue
        r0, r1, c0, c1 = int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1
        crop = find_windows(a[r0:r1, c0:c1], s, cfg, (inside & clear)[r0:r1, c0:c1], inset_mm)
        if not crop.polygons:
            continue
        shift = np.array([c0 * s, (h - r1) * s])
        mask = np.zeros((h, w), dtype=bool)
        mask[r0:r1, c0:c1] = crop.mask
        polys = tuple((np.asarray(outer) + shift, ()) for outer, _ in crop.polygons)
        parts.append(LayerWindows(polys, mask, crop.report))
    if not parts:
        return LayerWindows((), np.zeros(a.shape, dtype=bool), {"windows": 0})
    return _merged(parts, a.shape)
