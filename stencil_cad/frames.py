"""The only conversion between pixel (row, col) and millimetre (x, y) frames.

Pixel ``(row, col)`` covers the square whose centre is at
``x = (col + 0.5) * s``, ``y = (H - row - 0.5) * s`` where ``s`` is mm per px
and ``H`` the image height: x right, y up, origin at the picture's bottom-left.
"""

from __future__ import annotations

import numpy as np


def px_to_mm(rc: np.ndarray, height_px: int, mm_per_px: float) -> np.ndarray:
    """Convert pixel coordinates to mm.

    Args:
        rc: ``(N, 2)`` ndarray of (row, col); fractional values allowed, where
            integer values are pixel centres.
        height_px: Image height H in pixels.
        mm_per_px: Pixel size in mm.

    Returns:
        ``(N, 2)`` ndarray of (x, y) in mm.
    """
    rc = np.asarray(rc, dtype=np.float64).reshape(-1, 2)
    x = (rc[:, 1] + 0.5) * mm_per_px
    y = (height_px - rc[:, 0] - 0.5) * mm_per_px
    return np.stack([x, y], axis=1)


def mm_to_px(xy: np.ndarray, height_px: int, mm_per_px: float) -> np.ndarray:
    """Convert mm coordinates to fractional pixel (row, col); inverse of :func:`px_to_mm`.

    Args:
        xy: ``(N, 2)`` ndarray of (x, y) in mm.
        height_px: Image height H in pixels.
        mm_per_px: Pixel size in mm.

    Returns:
        ``(N, 2)`` ndarray of (row, col), integer values at pixel centres.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    col = xy[:, 0] / mm_per_px - 0.5
    row = height_px - xy[:, 1] / mm_per_px - 0.5
    return np.stack([row, col], axis=1)


def pixel_centres_mm(height_px: int, width_px: int, mm_per_px: float) -> tuple[np.ndarray, np.ndarray]:
    """The mm coordinates of every pixel centre of a grid, as broadcastable axes.

    Args:
        height_px: Image height H in pixels.
        width_px: Image width W in pixels.
        mm_per_px: Pixel size in mm.

    Returns:
        ``(x, y)``: ``(1, W)`` x and ``(H, 1)`` y in mm of the pixel centres.
    """
    x = ((np.arange(width_px) + 0.5) * mm_per_px)[None, :]
    y = ((height_px - np.arange(height_px) - 0.5) * mm_per_px)[:, None]
    return x, y


def mm_to_raster(xy: np.ndarray, height_px: int, px_per_mm: float) -> np.ndarray:
    """Convert mm coordinates to continuous raster coordinates, for drawing.

    Unlike :func:`mm_to_px` (integer values at pixel centres), pixel ``(row, col)``
    here covers ``[row, row + 1) x [col, col + 1)``, and the scale is given in
    pixels per mm.

    Args:
        xy: ``(N, 2)`` ndarray of (x, y) in mm.
        height_px: Image height H in pixels.
        px_per_mm: Pixels per mm.

    Returns:
        ``(N, 2)`` C-contiguous ndarray of (row, col) in px, rows growing downwards.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    col = xy[:, 0] * px_per_mm
    row = height_px - xy[:, 1] * px_per_mm
    return np.ascontiguousarray(np.stack([row, col], axis=1))


def rasterise_polygons(
    polygons: list,
    shape: tuple[int, int],
    mm_per_px: float,
    window: tuple[int, int, int, int] | None = None,
) -> np.ndarray:
    """Pixels whose centres lie inside the polygons (even-odd rule): the inverse of :func:`stencil_cad.hardstencil.topology.mask_to_polygons`.

    A vectorised scan-line fill: every ring edge crossing a row of pixel centres
    toggles the parity of the pixels to the right of the crossing.

    Args:
        polygons: As returned by :func:`stencil_cad.hardstencil.topology.mask_to_polygons`.
        shape: ``(H, W)`` of the raster.
        mm_per_px: Pixel size in mm.
        window: ``(r0, r1, c0, c1)``: only these rows and columns of the raster, or None: all.
            The window's pixels are the same as the whole raster's (each crossing is found in the
            whole raster's coordinates), at the cost of the window's area alone.

    Returns:
        ``(H, W)`` bool, or ``(r1 - r0, c1 - c0)`` with a ``window``.
    """
    h, w = shape
    r_lo, r_hi, c_lo, c_hi = (0, h, 0, w) if window is None else window
    if not (0 <= r_lo <= r_hi <= h and 0 <= c_lo <= c_hi <= w):
        raise ValueError(f"window {window} is not inside the raster {shape}")
    hw, ww = r_hi - r_lo, c_hi - c_lo
    rings = [ring for outer, holes in polygons for ring in (outer, *holes) if len(ring) >= 3]
    if not rings:
        return np.zeros((hw, ww), dtype=bool)
    rc = [mm_to_px(ring, h, mm_per_px) for ring in rings]
    r0 = np.concatenate([p[:, 0] for p in rc])
    c0 = np.concatenate([p[:, 1] for p in rc])
    r1 = np.concatenate([np.roll(p[:, 0], -1) for p in rc])
    c1 = np.concatenate([np.roll(p[:, 1], -1) for p in rc])
    # Rows r with lo <= r < hi: each crossing counted once, horizontal edges never.
    start = np.maximum(np.ceil(np.minimum(r0, r1)), r_lo).astype(np.int64)
    end = np.minimum(np.ceil(np.maximum(r0, r1)), r_hi).astype(np.int64)
    count = np.maximum(end - start, 0)
    edge = np.repeat(np.arange(r0.size), count)
    first = np.cumsum(count) - count
    rows = start[edge] + (np.arange(edge.size) - first[edge])
    t = (rows - r0[edge]) / (r1[edge] - r0[edge])
    x = c0[edge] + t * (c1[edge] - c0[edge])
    # A crossing left of the window toggles all of its row, one right of it none.
    col = np.clip(np.ceil(x), c_lo, c_hi).astype(np.int64) - c_lo
    toggles = np.zeros((hw, ww + 1), dtype=np.int64)
    np.add.at(toggles, (rows - r_lo, col), 1)
    return (np.cumsum(toggles, axis=1)[:, :ww] & 1).astype(bool)
