"""From how far a stipple reads as continuous tone: the distance its dots blend for a viewer.

A patch of the process's smallest holes at mid tone (a hexagonal pattern with half the
densest pattern's open area) is sprayed with the spray model in the darkest paint over the
primer and compared, with S-CIELAB, to the flat colour of the same mean opacity. The dots
are visible from a distance while that difference is at least :data:`VISIBLE_DE` (about
one just-noticeable difference of CIEDE2000); the blend distance is the nearest distance
of a geometric ladder where it falls below.
"""

from __future__ import annotations

import math

import numpy as np
from skimage.color import rgb2xyz, xyz2rgb

from ..config.spray import SprayConfig
from ..model import composite
from .opacity import spray_opacity
from .scielab import scielab
from .spray import hole_kernels

__all__ = ["VISIBLE_DE", "blend_distance_m"]

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
