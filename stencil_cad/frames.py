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
