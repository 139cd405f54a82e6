"""From how far a stipple reads as continuous tone: the distance its dots blend for a viewer.

A job's summary takes :func:`pattern_blend_distance_m`: its own sprayed picture, against the same
picture with the hole patterns taken out, where they show most. A mid-tone patch of the smallest
holes (below) blends far sooner than the light tones' sparse holes over a dark ground: on the
bundled example 0.2 m against 4.8 m.

:func:`blend_distance_m`: a patch of the process's smallest holes at mid tone (a hexagonal pattern with half the
densest pattern's open area) is sprayed with the spray model in the darkest paint over the
primer and compared, with S-CIELAB, to the flat colour of the same mean opacity. The dots
are visible from a distance while that difference is at least :data:`VISIBLE_DE` (about
one just-noticeable difference of CIEDE2000); the blend distance is the nearest distance
of a geometric ladder where it falls below.
"""

from __future__ import annotations

import functools
import math

import numpy as np
from skimage.color import rgb2xyz, xyz2rgb

from ..config.spray import SprayConfig
from ..filters import gaussian
from ..model import composite
from .opacity import spray_opacity
from .scielab import scielab
from .spray import hole_kernels

__all__ = [
    "VISIBLE_DE",
    "blend_distance_m",
    "hole_spacing_mm",
    "pattern_blend_distance_m",
    "pattern_flat",
]

#: S-CIELAB difference from the flat tone at which the dots count as visible.
VISIBLE_DE = 1.0
#: Distances tried, m (a factor 2^(1/4) apart).
_LADDER_M = tuple(0.25 * 2.0 ** (k / 4.0) for k in range(33))


def blend_distance_m(
    radius_mm: float,
    web_mm: float,
    spray_cfg: SprayConfig,
    spray_time: float,
    paint_rgb: np.ndarray,
    primer_rgb: np.ndarray,
    spacing_factor: float = 1.15,
    geometry=None,
) -> float | None:
    """The nearest viewing distance from which a mid-tone stipple of these holes looks flat.

    Args:
        radius_mm: Hole radius in mm.
        web_mm: Minimum web in mm.
        spray_cfg: Spray settings.
        spray_time: The layer's amount of paint (spray time, or passes under the physical model).
        paint_rgb: ``(3,)`` paint colour in [0, 1].
        primer_rgb: ``(3,)`` colour under the paint in [0, 1].
        spacing_factor: Densest pattern's spacing over ``2 r + web``. Defaults to 1.15.
        geometry: Stand-off and plate thickness (the physical spray model needs them).

    Returns:
        Distance in m, or None when the dots still show from the farthest distance tried (64 m).
    """
    spacing = spacing_factor * (2.0 * radius_mm + web_mm) * math.sqrt(2.0)
    sigma = float(hole_kernels(np.array([radius_mm]), spray_cfg, spray_time, geometry=geometry)[0][0])
    px = min(sigma / 3.0, 0.25)
    width = 12.0 * spacing
    n = int(math.ceil(width / px))
    dy = spacing * math.sqrt(3.0) / 2.0
    margin = 4.0 * sigma + spacing
    j, i = np.meshgrid(
        np.arange(-int(margin / dy) - 1, int((width + margin) / dy) + 2),
        np.arange(-int(margin / spacing) - 1, int((width + margin) / spacing) + 2),
        indexing="ij",
    )
    xy = np.column_stack([(i * spacing + (j % 2) * spacing / 2.0).ravel(), (j * dy).ravel()])
    alpha = spray_opacity(
        xy, radius_mm, (n, n), width / n, spray_cfg, spray_time=spray_time, geometry=geometry
    )
    paint = np.asarray(paint_rgb, dtype=np.float64).reshape(1, 3)
    primer = np.asarray(primer_rgb, dtype=np.float64)
    dotted = np.clip(composite(primer, paint, alpha[None]), 0.0, 1.0)
    # What the pattern blends to far away: its mean in linear light (the eye averages light).
    mean_xyz = rgb2xyz(dotted).mean(axis=(0, 1)).reshape(1, 1, 3)
    flat = np.broadcast_to(np.clip(xyz2rgb(mean_xyz), 0.0, 1.0), dotted.shape)

    def visible(d: float) -> bool:
        return scielab(dotted, flat, width / n, d) >= VISIBLE_DE

    # The difference falls with distance: bisect the ladder for the first distance that blends.
    lo, hi = 0, len(_LADDER_M) - 1
    if visible(_LADDER_M[hi]):
        return None
    while lo < hi:
        mid = (lo + hi) // 2
        if visible(_LADDER_M[mid]):
            lo = mid + 1
        else:
            hi = mid
    return float(_LADDER_M[lo])


#: Side in mm of the squares the sprayed picture is searched in for where its holes show most.
PATCH_MM = 30.0
#: How many of the most dotted squares the distance is measured on.
PATCHES = 3


def hole_spacing_mm(xy_mm: np.ndarray) -> float:
    """The wider spacing of a layer's holes: the 90th percentile of each hole's nearest-neighbour distance, mm.

    The light tones' sparse holes set it, where a pattern's period is longest. 0 for under two holes.
    """
    from scipy.spatial import cKDTree

    if len(xy_mm) < 2:
        return 0.0
    dist, _ = cKDTree(xy_mm).query(xy_mm, k=2)
    return float(np.percentile(dist[:, 1], 90))


def pattern_flat(sprayed: np.ndarray, ideal: np.ndarray, spacing_px: float) -> np.ndarray:
    """The sprayed composite with its hole patterns taken out: what its dots blend to far off.

    The pattern is the part of the difference from the ideal spray (the target opacities
    blurred as the holes blur them, composited) finer than the holes' spacing: that difference
    low-passed by a Gaussian of half the spacing (under 1 % of the pattern's own period is
    left) in linear light (the eye averages light, as :func:`blend_distance_m`'s flat patch
    does), added back to the ideal. So the picture's own detail and the tone error stay in both
    pictures, and only the dots differ.

    Args:
        sprayed: ``(H, W, 3)`` simulated composite, sRGB in [0, 1].
        ideal: ``(H, W, 3)`` the ideal spray on the same grid, sRGB in [0, 1].
        spacing_px: The widest hole spacing of the job's layers in pixels.

    Returns:
        ``(H, W, 3)`` sRGB in [0, 1].
    """
    xyz_s, xyz_i = rgb2xyz(np.clip(sprayed, 0.0, 1.0)), rgb2xyz(np.clip(ideal, 0.0, 1.0))
    # Mirrored at the edges: repeating the edge's own difference outward (mode "nearest") shifted the
    # low-passed tone of a corner square, and a tone difference shows from any distance (the bundled
    # example with light plates, whose sparsest plate sets a 6.5 mm spacing: its flag's corner square
    # kept S-CIELAB 0.71 at 64 m and the job said its dots show up to 16 m; mirrored, 4.8 m, elsewhere).
    flat = xyz_i + gaussian(xyz_s - xyz_i, 0.5 * spacing_px, mode="reflect") if spacing_px > 0 else xyz_s
    return np.clip(xyz2rgb(np.maximum(flat, 0.0)), 0.0, 1.0)


def pattern_blend_distance_m(
    sprayed: np.ndarray, flat: np.ndarray, mm_per_px: float
) -> tuple[float | None, tuple[int, int, int]]:
    """The nearest viewing distance from which a job's own holes stop showing where they show most.

    The picture is cut into squares of :data:`PATCH_MM`; the :data:`PATCHES` squares whose
    sprayed lightness differs most from its dot-free version (:func:`pattern_flat`) are scored
    with S-CIELAB against it, and the dots count as visible from a distance while any of them
    differs by :data:`VISIBLE_DE` or more on average (the same criterion as :func:`blend_distance_m`'s
    mid-tone patch, now on the job's own holes, tones and paints).

    Args:
        sprayed: ``(H, W, 3)`` simulated composite in [0, 1].
        flat: ``(H, W, 3)`` the same with the hole patterns smoothed away.
        mm_per_px: Pixel pitch of both in mm.

    Returns:
        ``(distance, square)``: distance in m (None when the dots show from 64 m) and the square
        where they show longest, ``(row, col, side)`` in pixels.
    """
    lum = np.array([0.2126, 0.7152, 0.0722])
    diff = np.abs((sprayed - flat) @ lum)
    side = max(1, int(round(PATCH_MM / mm_per_px)))
    h, w = diff.shape
    squares = []
    for r0 in range(0, h, side):
        for c0 in range(0, w, side):
            part = diff[r0 : r0 + side, c0 : c0 + side]
            if 2 * min(part.shape) >= min(side, h, w):  # not a sliver along the edge
                squares.append((float(part.mean()), r0, c0))
    squares.sort(key=lambda s: (-s[0], s[1], s[2]))
    chosen = [(r0, c0) for _, r0, c0 in squares[:PATCHES]]

    @functools.cache
    def worst(d: float) -> tuple[float, tuple[int, int]]:
        # Cached: the bisection's last look is at a rung it has already scored.
        scores = [
            (
                scielab(
                    flat[r0 : r0 + side, c0 : c0 + side],
                    sprayed[r0 : r0 + side, c0 : c0 + side],
                    mm_per_px,
                    d,
                ),
                (r0, c0),
            )
            for r0, c0 in chosen
        ]
        return max(scores)

    lo, hi = 0, len(_LADDER_M) - 1
    top, where = worst(_LADDER_M[hi])
    if top >= VISIBLE_DE:
        return None, (*where, side)
    while lo < hi:
        mid = (lo + hi) // 2
        if worst(_LADDER_M[mid])[0] >= VISIBLE_DE:
            lo = mid + 1
        else:
            hi = mid
    _, where = worst(_LADDER_M[max(lo - 1, 0)])
    return float(_LADDER_M[lo]), (*where, side)
