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
