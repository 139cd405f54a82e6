"""Preview images: the holes, the palette, input | decomposition | simulated | error, the spray-time sweep."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..config.spray import SprayConfig
from ..frames import mm_to_raster
from ..model import DotSet, Layers
from .spray import SimResult, simulate

__all__ = ["colour_map", "dots_preview", "sweep", "sweep_panels"]


# Control points of a perceptually ordered black-purple-orange-yellow ramp (inferno-like).
_RAMP = np.array(
    [
        [0.0, 0.0, 0.02],
        [0.26, 0.04, 0.41],
        [0.58, 0.15, 0.40],
        [0.87, 0.32, 0.23],
        [0.99, 0.64, 0.04],
        [0.99, 1.0, 0.64],
    ]
)


def colour_map(values: np.ndarray, vmax: float) -> np.ndarray:
    """Map non-negative values to RGB in [0, 1] on an inferno-like ramp; ``vmax`` and above are the top colour."""
    t = np.clip(np.asarray(values, dtype=np.float64) / vmax, 0.0, 1.0) * (len(_RAMP) - 1)
    i = np.minimum(t.astype(np.int64), len(_RAMP) - 2)
    f = (t - i)[..., None]
    return _RAMP[i] * (1.0 - f) + _RAMP[i + 1] * f


def _to_u8(img: np.ndarray) -> np.ndarray:
    return (np.clip(img, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)


def _hstack(panels: list[np.ndarray], gap: int = 4) -> np.ndarray:
    h = max(p.shape[0] for p in panels)
    spacer = np.full((h, gap, 3), 255, dtype=np.uint8)
    row = []
    for k, p in enumerate(panels):
        if p.shape[0] < h:
            p = np.concatenate([p, np.full((h - p.shape[0], p.shape[1], 3), 255, np.uint8)], axis=0)
        if k:
            row.append(spacer)
        row.append(p)
    return np.concatenate(row, axis=1)


def sweep(
    layers: Layers,
    dotsets: list[DotSet],
    cfg: SprayConfig,
    grid_mm_per_px: float | None = None,
    *,
    spray_times: list[float] | None = None,
    factors: tuple[float, ...] | None = None,
    geometry=None,
) -> np.ndarray:
    """Spray-time sweep as in the paper's figure: the simulated spray at A x each factor.

    Args:
        layers: The decomposition.
        dotsets: One DotSet per layer.
        cfg: Spray settings (``sweep_factors`` unless ``factors`` is given).
        grid_mm_per_px: Simulation pixel size in mm. Defaults to ``1 / cfg.px_per_mm``.
        spray_times: Per-layer spray times before the factor. Defaults as in :func:`simulate`.
        factors: Spray-time multipliers. Defaults to ``cfg.sweep_factors`` (0.5, 1, 2).
        geometry: Stand-off and plate thickness (physical model).

    Returns:
        ``(H, k W + 4 (k - 1), 3)`` uint8 image, one panel per factor, left to right.
    """
    return _hstack(
        sweep_panels(
            layers, dotsets, cfg, grid_mm_per_px, spray_times=spray_times, factors=factors, geometry=geometry
        )
    )


def sweep_panels(
    layers: Layers,
    dotsets: list[DotSet],
    cfg: SprayConfig,
    grid_mm_per_px: float | None = None,
    *,
    spray_times: list[float] | None = None,
    factors: tuple[float, ...] | None = None,
    geometry=None,
    layer_sprays=None,
    as_sprayed: SimResult | None = None,
) -> list[np.ndarray]:
    """The panels of :func:`sweep`, one ``(H, W, 3)`` uint8 image per factor, for labelling.

    ``layer_sprays``: each layer's spray settings (see :func:`stencil_cad.simulate.simulate`).
    ``as_sprayed``: the simulation with the same arguments at factor 1 (the job's own), whose
    composite is factor 1's panel rather than simulating it again, or None.
    """
    factors = tuple(cfg.sweep_factors if factors is None else factors)
    panels = []
    for f in factors:
        if f == 1.0 and as_sprayed is not None:
            panels.append(_to_u8(as_sprayed.composite))
            continue
        res = simulate(
            layers,
            dotsets,
            cfg,
            grid_mm_per_px,
            spray_times=spray_times,
            time_factor=f,
            geometry=geometry,
            layer_sprays=layer_sprays,
            errors=False,
        )
        panels.append(_to_u8(res.composite))
    return panels


@numba.njit(cache=True)
def _raster_discs(img, rc, r_px):  # pragma: no cover - compiled
    """Darken ``img`` with anti-aliased discs (min blend); centres in raster (row, col) px."""
    h, w = img.shape
    for k in range(rc.shape[0]):
        cy, cx = rc[k, 0], rc[k, 1]
        rr = r_px[k]
        c0 = max(int(math.floor(cx - rr - 1.0)), 0)
        c1 = min(int(math.ceil(cx + rr + 1.0)), w - 1)
        r0 = max(int(math.floor(cy - rr - 1.0)), 0)
        r1 = min(int(math.ceil(cy + rr + 1.0)), h - 1)
        for row in range(r0, r1 + 1):
            dy = row + 0.5 - cy
            for col in range(c0, c1 + 1):
                dx = col + 0.5 - cx
                # Signed distance to the circle, in px: coverage ramps over one pixel.
                s = math.sqrt(dx * dx + dy * dy) - rr
                cover = min(max(0.5 - s, 0.0), 1.0)
                v = 255.0 * (1.0 - cover)
                if v < img[row, col]:
                    img[row, col] = v


def dots_preview(
    dotset: DotSet,
    width_mm: float,
    height_mm: float,
    px_per_mm: float = 4,
    origin_mm: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """Draw the holes black on white.

    Args:
        dotset: The holes, in picture mm.
        width_mm: Width of the drawn area in mm (the picture area by default).
        height_mm: Height of the drawn area in mm.
        px_per_mm: Preview resolution in pixels per mm. Defaults to 4.
        origin_mm: Picture-frame point at the drawn area's bottom-left corner. Defaults to
            (0, 0), the picture's corner; a plate preview passes the corner of the outline's box.

    Returns:
        ``(H, W)`` uint8 image, row 0 at the top (y = origin + height_mm), holes 0,
        material 255, anti-aliased edges.
    """
    h = max(int(round(height_mm * px_per_mm)), 1)
    w = max(int(round(width_mm * px_per_mm)), 1)
    img = np.full((h, w), 255.0, dtype=np.float32)
    if len(dotset):
        # Scale so the image spans exactly the drawn area even after rounding.
        sx = w / width_mm
        sy = h / height_mm
        xy = np.asarray(dotset.xy_mm, dtype=np.float64).reshape(-1, 2) - np.asarray(
            origin_mm, dtype=np.float64
        )
        xy = xy * np.array([sx, sy]) / sx
        rc = mm_to_raster(xy, h, float(sx))
        _raster_discs(img, rc, np.asarray(dotset.r_mm, dtype=np.float64) * float(sx))
    return np.round(img).astype(np.uint8)
