"""Holes as the process makes them, and the holes to draw so the made ones come out as asked.

A process does not make a hole at its drawn size: PrusaSlicer's walls and its polygon
approximation of a circle take a little off an FDM hole, resin over-cures into it, a laser's
kerf widens it (the DXF and SVG writers already take half the kerf off every cut). The
stippler asks for holes of radius ``r``; with ``stipple.hole_offset_mm`` = δ the process
makes a drawn hole of radius ``R`` as ``R − δ``. :func:`drawn_radii` grows each hole by δ
where the web rule allows, and :func:`made_dots` is what the simulation sprays.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.spatial import cKDTree

from ..config.stipple import HOLE_FLOOR_MM, StippleConfig
from ..model import DotSet

__all__ = ["drawn_dots", "drawn_radii", "made_dots"]


def _room(xy: np.ndarray, r: np.ndarray, size_mm: tuple[float, float], cfg: StippleConfig) -> np.ndarray:
    """How far each hole may grow before it breaks the edge margin or a keep-out, mm (≥ 0)."""
    margin = cfg.sizes.edge_margin_mm
    w, h = size_mm
    x, y = xy[:, 0], xy[:, 1]
    room = np.minimum.reduce([x, w - x, y, h - y]) - r - margin
    for x0, y0, x1, y1 in cfg.keepouts_mm:
        dx = np.maximum.reduce([x0 - x, np.zeros_like(x), x - x1])
        dy = np.maximum.reduce([y0 - y, np.zeros_like(y), y - y1])
        room = np.minimum(room, np.hypot(dx, dy) - r - margin)
    return np.maximum(room, 0.0)


def drawn_radii(xy: np.ndarray, r: np.ndarray, offset_mm: float, web_mm: float) -> np.ndarray:
    """Radii to draw so that a process taking ``offset_mm`` off each hole makes radius ``r``.

    A hole grows by at most ``offset_mm``, and by no more than half of the slack its closest
    neighbour leaves over the web (``|c_i − c_j| − r_i − r_j − web_mm``), so two grown holes
    still keep the web between them. A negative offset (a process that widens holes) draws
    every hole smaller by it, down to the 0.5 mm hole floor.

    Args:
        xy: ``(N, 2)`` hole centres in mm.
        r: ``(N,)`` asked radii in mm.
        offset_mm: Radius the process takes off a drawn hole, mm.
        web_mm: Minimum web between drawn holes, mm.

    Returns:
        ``(N,)`` ndarray of float, the radii to draw, mm.
    """
    r = np.asarray(r, dtype=np.float64)
    if len(r) == 0 or offset_mm == 0:
        return r
    if offset_mm < 0:
        # A process that widens holes: draw them smaller, never under the hole floor.
        return np.maximum(r + offset_mm, np.minimum(r, HOLE_FLOOR_MM))
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    grow = np.full(len(r), float(offset_mm))
    reach = 2.0 * float(r.max()) + web_mm + 2.0 * offset_mm
    pairs = cKDTree(xy).query_pairs(reach, output_type="ndarray")
    if len(pairs):
        i, j = pairs[:, 0], pairs[:, 1]
        slack = np.linalg.norm(xy[i] - xy[j], axis=1) - r[i] - r[j] - web_mm
        half = np.maximum(slack, 0.0) / 2.0
        np.minimum.at(grow, i, half)
        np.minimum.at(grow, j, half)
    return r + grow


def drawn_dots(dots: DotSet, cfg: StippleConfig, size_mm: tuple[float, float]) -> DotSet:
    """The holes to draw on the plate for ``dots`` (asked holes) under ``cfg`` (see :func:`drawn_radii`).

    The web rule is kept on the plate as made (a drawn web ``2 δ`` under ``web_mm`` is made
    ``web_mm`` wide), so every hole grows by the offset δ, except where the edge margin or a
    keep-out leaves less room (the picture area is ``[0, size_mm[0]] x [0, size_mm[1]]``).
    Without ``cfg.compensate`` the holes are drawn as asked.
    """
    if not cfg.compensate or len(dots.r_mm) == 0:
        return dots
    xy = np.asarray(dots.xy_mm, dtype=np.float64).reshape(-1, 2)
    asked = np.asarray(dots.r_mm, dtype=np.float64)
    sizes = cfg.sizes
    offset = sizes.hole_offset_mm
    # The web rule holds for the plate as made: the process makes each web wider by twice the
    # offset, so the drawn web may be that much under web_mm (every hole then grows by the offset).
    r = drawn_radii(xy, asked, offset, sizes.web_mm - 2.0 * max(offset, 0.0))
    grown = r > asked
    r[grown] = np.minimum(r[grown], asked[grown] + _room(xy, asked, size_mm, cfg)[grown])
    return replace(dots, r_mm=r)


def made_dots(dots: DotSet, cfg: StippleConfig, size_mm: tuple[float, float]) -> DotSet:
    """The holes the process makes from the asked ``dots``: drawn (compensated or not) less the offset."""
    drawn = drawn_dots(dots, cfg, size_mm)
    offset = cfg.sizes.hole_offset_mm
    if offset == 0:
        return drawn
    return replace(drawn, r_mm=np.maximum(drawn.r_mm - offset, 0.0))
