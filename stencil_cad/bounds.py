"""Upper bounds checked before work, so a small input cannot ask for unbounded memory or time."""

from __future__ import annotations

import math


def max_dots(stipple_cfg, width_mm: float, height_mm: float) -> int:
    """Most holes the design rules allow in a picture: an upper bound, not an estimate.

    Hole centres lie in the picture shrunk by ``edge_margin + r`` on each side and are at
    least ``d = 2 r + web`` apart (``r`` the smallest allowed radius). Groemer's packing
    inequality bounds the number of points at mutual distance ≥ d in a convex region of
    area A and perimeter P by ``2 A / (√3 d²) + P / (2 d) + 1``.

    Args:
        stipple_cfg: The ``stipple`` config section (process presets resolved).
        width_mm: Picture width in mm.
        height_mm: Picture height in mm.

    Returns:
        The bound (0 when no hole fits).
    """
    r = stipple_cfg.hole_floor_mm
    sizes = stipple_cfg.sizes
    d = 2.0 * r + sizes.web_mm
    inset = sizes.edge_margin_mm + r
    w, h = width_mm - 2.0 * inset, height_mm - 2.0 * inset
    if w < 0 or h < 0:
        return 0
    return int(2.0 * w * h / (math.sqrt(3.0) * d * d) + (w + h) / d + 1.0)
