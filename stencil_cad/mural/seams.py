"""Seams between tiles: each hole to one tile, sight notches on the grid lines, the tiled spray.

See :mod:`stencil_cad.mural.tiling` for the partition and registration scheme.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import numpy as np

from ..errors import UserError
from ..model import DotSet, Holes
from .tiling import TileGrid

if TYPE_CHECKING:
    from ..config import JobConfig, SprayConfig
    from ..simulate.physical import SprayGeometry

# --------------------------------------------------------------------------- holes


def split_dots(dotset: DotSet, grid: TileGrid) -> list[DotSet]:
    """Partition one layer's holes among the tiles, in each tile's frame.

    Every hole goes to exactly one tile (the owner of its centre) and keeps its order.

    Returns:
        One DotSet per tile (same order as ``grid.tiles``), centres in the tile frame
        (origin at the sheet's bottom-left).
    """
    owner = grid.owner(dotset.xy_mm)
    # A window lies inside one tile's core (see stencil_cad.hardstencil.windows): its box's centre names the tile.
    boxes = [np.asarray(o, dtype=np.float64) for o, _ in dotset.windows]
    centres = np.array([(b.min(axis=0) + b.max(axis=0)) / 2 for b in boxes]).reshape(-1, 2)
    win_owner = grid.owner(centres) if len(boxes) else np.zeros(0, dtype=np.int64)
    out = []
    for k, t in enumerate(grid.tiles):
        sel = owner == k
        ox, oy = t.origin
        xy = dotset.xy_mm[sel] - np.array([ox, oy])
        windows = tuple((b - np.array([ox, oy]), ()) for b, w in zip(boxes, win_owner, strict=True) if w == k)
        out.append(
            DotSet(
                xy_mm=xy,
                r_mm=dotset.r_mm[sel].copy(),
                report={**dotset.report, "tile": t.name},
                windows=windows,
            )
        )
    return out


def per_tile(layers: Sequence[Holes], grid: TileGrid) -> list[list[Holes]]:
    """Per tile, per layer, the tile's holes in the tile frame (each hole to the tile owning its centre).

    One tile's holes are the layers as they are: its tile frame is the picture's.
    """
    if not grid.tiled:
        return [list(layers)]
    split = [split_dots(ds, grid) for ds in layers]  # type: ignore[arg-type]  # a mural's holes are DotSets
    return [[split[i][k] for i in range(len(layers))] for k in range(len(grid.tiles))]


def check_unions(cfg: JobConfig, grid: TileGrid, sets: dict[str, list[DotSet]]) -> None:
    """The union of the tiles' holes is the global set (same count) and keeps the rules across every seam.

    ``sets`` holds the holes ``asked`` (the design rules), ``made`` by the process (the web never
    under its minimum, the hole never under the 0.5 mm floor by more than the process's offset: a
    hole at the picture's margin is not grown, so it is made a little under the stippler's radius,
    as on a one-plate job) and
    ``drawn`` on the plates (the web less twice the process's offset, which the process gives back).
    A picture of one tile has no seam: nothing to check.

    Raises:
        UserError: A layer's holes break the rules across a seam.
    """
    from ..stipple import rules as dots

    if not grid.tiled:
        return
    design = cfg.stipple.design_rules(grid.width_mm, grid.height_mm)
    made_less = max(cfg.stipple.sizes.hole_offset_mm, 0.0)
    offset = made_less if cfg.stipple.compensate else 0.0
    floor = design.with_any_floor()
    rules = {"asked": design, "made": floor, "drawn": replace(floor, web_mm=design.web_mm - 2.0 * offset)}
    # A hole the margin keeps from growing (or every hole, uncompensated) is made its radius less
    # the offset: at the 0.5 mm floor of every preset, 0.485 mm under FDM. The made webs lose
    # nothing by the tolerance: each is the drawn web (checked to the 0.001 mm) plus twice the offset.
    tol = {"made": dots.CHECK_TOL_MM + made_less}
    for kind, layer_sets in sets.items():
        for i, ds in enumerate(layer_sets):
            u = to_mural(split_dots(ds, grid), grid)
            if len(u) != len(ds):
                raise RuntimeError(f"layer {i + 1}: tiles hold {len(u)} {kind} holes, the mural {len(ds)}")
            try:
                dots.check_rules(u.xy_mm, u.r_mm, rules[kind], tol.get(kind, dots.CHECK_TOL_MM))
            except ValueError as exc:
                raise UserError(
                    f"layer {i + 1} ({kind} holes, all tiles in mural coordinates): {exc}"
                ) from None


def to_mural(tile_sets: list[DotSet], grid: TileGrid) -> DotSet:
    """The union of tiles' holes (tile frames) in the mural frame."""
    xy = [d.xy_mm + np.array(t.origin) for d, t in zip(tile_sets, grid.tiles, strict=True)]
    r = [d.r_mm for d in tile_sets]
    windows = tuple(
        (np.asarray(o) + np.array(t.origin), ())
        for d, t in zip(tile_sets, grid.tiles, strict=True)
        for o, _ in d.windows
    )
    return DotSet(xy_mm=np.concatenate(xy).reshape(-1, 2), r_mm=np.concatenate(r), windows=windows)


def seam_density(
    dotsets: list[DotSet], grid: TileGrid, band_mm: float = 5.0, flank_mm: float = 10.0
) -> list[dict[str, Any]]:
    """Hole density within ``band_mm`` of each seam, against the flanks beside it and the mural.

    Density is holes per m², all layers together. ``ratio_flank`` compares the band with the
    two strips from ``band_mm`` to ``band_mm + flank_mm`` on either side (the same tones,
    so a dot-free or crowded seam shows); ``ratio_global`` with the whole mural.
    """
    xy = np.concatenate([d.xy_mm for d in dotsets]).reshape(-1, 2) if dotsets else np.zeros((0, 2))
    area = grid.width_mm * grid.height_mm
    glob = len(xy) / area * 1e6
    out = []
    for axis, edges, length in ((0, grid.x_edges, grid.height_mm), (1, grid.y_edges, grid.width_mm)):
        for e in edges[1:-1]:
            d = np.abs(xy[:, axis] - e)
            band = np.count_nonzero(d < band_mm) / (2 * band_mm * length) * 1e6
            flank = (
                np.count_nonzero((d >= band_mm) & (d < band_mm + flank_mm)) / (2 * flank_mm * length) * 1e6
            )
            out.append(
                {
                    "seam": f"{'x' if axis == 0 else 'y'} = {e:.1f} mm",
                    "band_per_m2": round(band, 1),
                    "flank_per_m2": round(flank, 1),
                    "global_per_m2": round(glob, 1),
                    "ratio_flank": round(band / flank, 4) if flank else None,
                    "ratio_global": round(band / glob, 4) if glob else None,
                }
            )
    return out


# --------------------------------------------------------------------------- registration


def _crossings(
    ring: np.ndarray, value: float, axis: int, depth: float, tol: float = 1e-7
) -> list[tuple[int, np.ndarray]]:
    """Straight ring edges along ``axis`` crossed by the line ``coord[axis] = value``.

    Returns the first and last such edge along the other axis (the two sides of the
    outline) as ``(edge_index, point)``, only edges with room for a notch of ``depth``.
    """
    a = ring
    b = np.roll(ring, -1, axis=0)
    other = 1 - axis
    flat = np.abs(a[:, other] - b[:, other]) < tol
    lo = np.minimum(a[:, axis], b[:, axis])
    hi = np.maximum(a[:, axis], b[:, axis])
    room = flat & (lo <= value - depth - 0.6) & (hi >= value + depth + 0.6)
    idx = np.flatnonzero(room)
    if len(idx) == 0:
        return []
    pos = a[idx, other]
    picks = {int(idx[np.argmin(pos)]), int(idx[np.argmax(pos)])}
    out: list[tuple[int, np.ndarray]] = []
    for i in sorted(picks):
        p = np.empty(2)
        p[axis] = value
        p[other] = a[i, other]
        out.append((i, p))
    return out


def notch_triangles(
    ring: np.ndarray, lines: tuple[list[float], list[float]], depth: float
) -> list[tuple[int, np.ndarray]]:
    """Where the grid lines cross the outline: one 90° V notch per crossing.

    Args:
        ring: ``(M, 2)`` counter-clockwise outline.
        lines: ``(xs, ys)`` of the vertical and horizontal grid lines, in the ring's frame.
        depth: Notch depth in mm (its mouth is twice as wide).

    Returns:
        ``(edge_index, triangle)`` per notch: ``triangle`` is ``(3, 2)``, mouth start on the
        edge, apex ``depth`` inside, mouth end on the edge, in the edge's direction.
    """
    out = []
    xs, ys = lines
    for axis, values in ((0, xs), (1, ys)):
        for v in values:
            for i, p in _crossings(ring, v, axis, depth):
                u = ring[(i + 1) % len(ring)] - ring[i]
                u = u / np.hypot(*u)
                n = np.array([-u[1], u[0]])  # inward for a counter-clockwise ring
                out.append((i, np.array([p - depth * u, p + depth * n, p + depth * u])))
    return out


def notched_ring(
    ring: np.ndarray, lines: tuple[list[float], list[float]], depth: float
) -> tuple[np.ndarray, int]:
    """The outline with a V sight notch wherever a grid line crosses it.

    Returns:
        ``(ring, notches)``: the new counter-clockwise ring and the number of notches cut.
    """
    notches = notch_triangles(ring, lines, depth)
    by_edge: dict[int, list[np.ndarray]] = {}
    for i, tri in notches:
        by_edge.setdefault(i, []).append(tri)
    pts = []
    for i in range(len(ring)):
        pts.append(ring[i])
        tris = by_edge.get(i, [])
        start = ring[i]
        tris.sort(key=lambda t: float(np.hypot(*(t[0] - start))))
        for tri in tris:
            pts.extend(tri)
    return np.asarray(pts), len(notches)


# --------------------------------------------------------------------------- simulation


def _sheet_crop(
    sheet: Sequence[float], shape: tuple[int, int], g: float, dx: float = 0.0, dy: float = 0.0
) -> tuple[int, int, int, int] | None:
    """Pixel window ``(r0, r1, c0, c1)`` whose centres lie on a (shifted) sheet, or None."""
    h, w = shape
    x0, y0, x1, y1 = sheet[0] + dx, sheet[1] + dy, sheet[2] + dx, sheet[3] + dy
    cx = (np.arange(w) + 0.5) * g
    cy = (h - np.arange(h) - 0.5) * g
    cols = np.flatnonzero((cx >= x0) & (cx <= x1))
    rows = np.flatnonzero((cy >= y0) & (cy <= y1))
    if len(cols) == 0 or len(rows) == 0:
        return None
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def simulate_tiles(
    shape: tuple[int, int],
    g: float,
    tile_sets: list[list[DotSet]],
    grid: TileGrid,
    spray_cfg: SprayConfig,
    spray_times: list[float],
    tail_tols: list[float],
    offset: Callable[[int, int], tuple[float, float]] | None = None,
    geometry: SprayGeometry | None = None,
    layer_sprays: Sequence[SprayConfig] | None = None,
) -> np.ndarray:
    """Spray every tile's plates through their walls, layer by layer, on the mural's raster.

    Each tile's spray reaches only its sheet (the wall opening); a tile moved by a
    registration error moves its sheet and holes together.

    Args:
        shape: ``(H, W)`` of the mural raster.
        g: Raster pixel size in mm.
        tile_sets: Per tile (``grid.tiles`` order), per layer, the holes in the tile frame.
        grid: The tiles.
        spray_cfg: Spray settings.
        spray_times: Spray time per layer.
        tail_tols: Per layer, the tail cut of the global simulation
            (:func:`stencil_cad.simulate.tail_tolerance`), so both splat the same discs.
        offset: ``offset(tile_index, layer) -> (dx, dy)`` mm registration error, or None.
        geometry: The spray geometry (stand-off, plate) for the physical spray model, or None.
        layer_sprays: Each layer's spray settings (its paint's profile), or None: ``spray_cfg``.

    Returns:
        ``(L, H, W)`` simulated opacities.
    """
    from ..simulate import spray_opacity
    from ..simulate.opacity import spray_mask, windows_cover
    from ..simulate.spray import per_layer

    layers = len(spray_times)
    sprays = per_layer(spray_cfg, layer_sprays, layers)
    alphas = np.empty((layers, *shape), dtype=np.float64)
    for i in range(layers):
        trans = np.ones(shape, dtype=np.float64)
        # Every tile's windows of the layer sprayed at once: their open areas add up as doses do
        # (one blur per layer instead of one per tile and layer; the same as the global
        # simulation's one call where no two windows overlap).
        cover = None
        for k, t in enumerate(grid.tiles):
            ds = tile_sets[k][i]
            dx, dy = offset(k, i) if offset is not None else (0.0, 0.0)
            if ds.windows:
                # A window lies inside its tile's core, so inside the sheet the wall lets paint through.
                shift = np.array([t.origin[0] + dx, t.origin[1] + dy])
                wins = [
                    (np.asarray(o) + shift, tuple(np.asarray(r) + shift for r in inner))
                    for o, inner in ds.windows
                ]
                tile_cover = windows_cover(wins, shape, g)
                cover = tile_cover if cover is None else cover + tile_cover
            if len(ds) == 0:
                continue
            crop = _sheet_crop(t.sheet, shape, g, dx, dy)
            if crop is None:
                continue
            xy = ds.xy_mm + np.array([t.origin[0] + dx, t.origin[1] + dy])
            kw: dict[str, Any] = {
                "spray_time": spray_times[i],
                "crop": crop,
                "tail_tol": tail_tols[i],
                "geometry": geometry,
            }
            a = spray_opacity(xy, ds.r_mm, shape, g, sprays[i], **kw)
            r0, r1, c0, c1 = crop
            trans[r0:r1, c0:c1] *= 1.0 - a
        if cover is not None:
            trans *= 1.0 - spray_mask(cover, g, sprays[i], spray_time=spray_times[i], geometry=geometry)
        alphas[i] = 1.0 - trans
    return alphas


def registration_offsets(
    grid: TileGrid, error_mm: float, between: str
) -> Callable[[int, int], tuple[float, float]]:
    """A registration error pattern: neighbours off by ``error_mm`` in x and in y.

    ``between="tiles"``: tile columns alternate ±error/2 in x and rows ±error/2 in y (every
    layer of a tile moves together), so each seam opens or overlaps by ``error_mm``.
    ``between="layers"``: within every tile, odd layers sit at +error/2 and even layers at
    -error/2 in both x and y, so consecutive layers are off by ``error_mm``.
    """
    h = 0.5 * error_mm
    if between == "tiles":
        return lambda k, i: (
            h if grid.tiles[k].col % 2 == 0 else -h,
            h if grid.tiles[k].row % 2 == 0 else -h,
        )
    if between == "layers":
        return lambda k, i: (h, h) if i % 2 == 0 else (-h, -h)
    raise ValueError(f"between must be 'tiles' or 'layers', got {between!r}")


def shifted(ds: DotSet, dx: float, dy: float) -> DotSet:
    """A DotSet moved by ``(dx, dy)`` mm."""
    return replace(ds, xy_mm=ds.xy_mm + np.array([dx, dy]))
