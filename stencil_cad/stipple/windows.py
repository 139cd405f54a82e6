"""Hybrid plates: the holes around a layer's open windows.

Where a layer is near fully opaque over a wide region its plate gets an open window there (a
polygon cut-out, found and bridged by :mod:`stencil_cad.hardstencil.windows`) and holes carry
the gradients around it. This module holds what the holes need to know about the windows, kernel
and topology free: which holes keep a web's distance from every window
(:func:`window_clearance`), the hole set with the windows attached (:func:`with_windows`), and
the opacity map the stippler is given (:func:`hole_alpha`: nothing to place inside a window or
in the band a hole there would break the web).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np
from scipy import ndimage as ndi

from ..geometry import circles_clear_of_rings
from ..model import DotSet

#: Slack in mm of the web check against a window's edge (as the rules' own check slack).
_TOL_MM = 1e-6


def window_clearance(xy_mm: np.ndarray, r_mm: np.ndarray, windows: Sequence, web_mm: float) -> np.ndarray:
    """Which holes keep at least ``web_mm`` of sheet between them and every window.

    Args:
        xy_mm: ``(N, 2)`` hole centres in mm.
        r_mm: ``(N,)`` hole radii in mm.
        windows: The windows, each ``(outer, inner rings)`` in mm.
        web_mm: Smallest web in mm.

    Returns:
        ``(N,)`` bool: True where the hole is clear of every window (outside it, its edge at least
        a web from the window's edge).
    """
    return circles_clear_of_rings(xy_mm, r_mm, [outer for outer, _inner in windows], web_mm - _TOL_MM)


def with_windows(ds: DotSet, windows: Sequence, web_mm: float) -> DotSet:
    """The holes with the windows attached; the holes too close to a window are left out.

    Args:
        ds: One layer's holes.
        windows: Its windows, each ``(outer, inner rings)`` in mm.
        web_mm: Smallest web in mm between a hole and a window.

    Returns:
        A :class:`DotSet` whose ``windows`` are ``windows`` and whose report adds ``windows``
        (count), ``window_area_mm2`` and ``removed_by_windows``.
    """
    windows = tuple(windows)
    if not windows:
        return ds if not ds.windows else replace(ds, windows=())
    ok = window_clearance(ds.xy_mm, ds.r_mm, windows, web_mm)
    from ..geometry import polygon_area

    area = sum(abs(polygon_area(np.asarray(o))) for o, _ in windows)
    report = {
        **ds.report,
        "windows": len(windows),
        "window_area_mm2": round(float(area), 1),
        "removed_by_windows": int(np.count_nonzero(~ok)),
    }
    return replace(ds, xy_mm=ds.xy_mm[ok].copy(), r_mm=ds.r_mm[ok].copy(), report=report, windows=windows)


def closed_to_holes(window_mask: np.ndarray, mm_per_px: float, clear_mm: float) -> np.ndarray:
    """Where no hole centre may lie: inside a window or within ``clear_mm`` of one.

    Args:
        window_mask: ``(H, W)`` bool, the windows' pixels.
        mm_per_px: Pixel size in mm.
        clear_mm: The smallest hole's radius plus the web, in mm.

    Returns:
        ``(H, W)`` bool.
    """
    mask = np.asarray(window_mask, dtype=bool)
    if not mask.any():
        return mask
    # Distance in mm from each pixel centre to the nearest window pixel's edge (half a pixel in).
    dist = ndi.distance_transform_edt(~mask) * mm_per_px - 0.5 * mm_per_px
    return dist < clear_mm


def hole_alpha(alpha: np.ndarray, window_mask: np.ndarray, mm_per_px: float, clear_mm: float) -> np.ndarray:
    """The opacity left for the holes: none inside a window or within ``clear_mm`` of one.

    Args:
        alpha: ``(H, W)`` the layer's opacity.
        window_mask: ``(H, W)`` bool, the windows' pixels.
        mm_per_px: Pixel size in mm.
        clear_mm: How far from a window no hole centre can lie (the smallest hole's radius plus
            the web).

    Returns:
        ``(H, W)`` opacity (a copy; ``alpha`` itself when there is no window).
    """
    closed = closed_to_holes(window_mask, mm_per_px, clear_mm)
    if not closed.any():
        return alpha
    return np.where(closed, 0.0, alpha).astype(np.asarray(alpha).dtype, copy=False)
