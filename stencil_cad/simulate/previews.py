"""Preview images: the holes, the palette, input | decomposition | simulated | error, the spray-time sweep."""

from __future__ import annotations

import math

import numba
import numpy as np

from ..config.spray import SprayConfig
from ..frames import mm_to_raster
from ..model import DotSet, Layers
from .scores import delta_e_map
from .spray import resample, simulate

__all__ = ["colour_map", "dots_preview", "preview", "swatch", "sweep"]


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


def caption(image: np.ndarray, text: str) -> np.ndarray:
    """Add a white strip with one line of text under an RGB uint8 image.

    Args:
        image: ``(H, W, 3)`` uint8.
        text: The line (scores, settings).

    Returns:
        ``(H + strip, W, 3)`` uint8.
    """
    from importlib.resources import files

    from PIL import Image, ImageDraw, ImageFont

    size = int(np.clip(image.shape[1] // 90, 10, 28))
    font = ImageFont.truetype(str(files("stencil_cad") / "data" / "DejaVuSans-Bold.ttf"), size)
    strip = Image.new("RGB", (image.shape[1], int(size * 1.8)), (255, 255, 255))
    ImageDraw.Draw(strip).text((size // 2, size // 3), text, fill=(0, 0, 0), font=font)
    return np.concatenate([image, np.asarray(strip, dtype=np.uint8)], axis=0)


def preview(
    input_rgb: np.ndarray,
    decomposition_rgb: np.ndarray,
    simulated_rgb: np.ndarray,
    de_max: float = 30.0,
    text: str | None = None,
) -> np.ndarray:
    """Side-by-side preview: input | decomposition composite | simulated spray | error map.

    The first two are resampled to the simulated image's grid. The error map is the
    per-pixel CIEDE2000 between input and simulated spray on an inferno-like ramp
    from 0 (black) to ``de_max`` (pale yellow).

    Args:
        input_rgb: ``(H, W, 3)`` input picture in [0, 1].
        decomposition_rgb: ``(H, W, 3)`` composite of the decomposition in [0, 1].
        simulated_rgb: ``(H, W, 3)`` simulated spray in [0, 1].
        de_max: ΔE2000 shown at the top of the ramp. Defaults to 30.
        text: A line (the scores) written in a strip under the panels, or None.

    Returns:
        ``(H, 4 W + 12, 3)`` uint8 image (taller by the strip with ``text``).
    """
    sim = np.clip(np.asarray(simulated_rgb, dtype=np.float64), 0.0, 1.0)
    shape = sim.shape[:2]
    inp = resample(input_rgb, shape)
    dec = resample(decomposition_rgb, shape)
    err = colour_map(delta_e_map(inp, sim), de_max)
    out = _hstack([_to_u8(inp), _to_u8(dec), _to_u8(sim), _to_u8(err)])
    return out if text is None else caption(out, text)


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
    factors = tuple(cfg.sweep_factors if factors is None else factors)
    panels = []
    for f in factors:
        res = simulate(
            layers, dotsets, cfg, grid_mm_per_px, spray_times=spray_times, time_factor=f, geometry=geometry
        )
        panels.append(_to_u8(res.composite))
    return _hstack(panels)


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


def dots_preview(dotset: DotSet, width_mm: float, height_mm: float, px_per_mm: float = 4) -> np.ndarray:
    """Draw the holes black on white.

    Args:
        dotset: The holes, in picture mm.
        width_mm: Picture-area width in mm.
        height_mm: Picture-area height in mm.
        px_per_mm: Preview resolution in pixels per mm. Defaults to 4.

    Returns:
        ``(H, W)`` uint8 image, row 0 at the top (y = height_mm), holes 0,
        material 255, anti-aliased edges.
    """
    h = max(int(round(height_mm * px_per_mm)), 1)
    w = max(int(round(width_mm * px_per_mm)), 1)
    img = np.full((h, w), 255.0, dtype=np.float32)
    if len(dotset):
        # Scale so the image spans exactly the picture area even after rounding.
        sx = w / width_mm
        sy = h / height_mm
        xy = np.asarray(dotset.xy_mm, dtype=np.float64).reshape(-1, 2) * np.array([sx, sy]) / sx
        rc = mm_to_raster(xy, h, float(sx))
        _raster_discs(img, rc, np.asarray(dotset.r_mm, dtype=np.float64) * float(sx))
    return np.round(img).astype(np.uint8)


def swatch(layers: Layers, size_px: int = 64) -> np.ndarray:
    """The primer and the paints in spray order as a row of squares.

    Args:
        layers: The decomposition.
        size_px: Side of each square in px. Defaults to 64 px.

    Returns:
        ``(size_px, size_px * (L + 1), 3)`` uint8 image, primer leftmost.
    """
    size_px = max(int(size_px), 1)
    allc = np.vstack([np.asarray(layers.primer)[None, :], np.asarray(layers.colours).reshape(-1, 3)])
    allc = np.clip(np.nan_to_num(allc, nan=0.0), 0.0, 1.0)
    row = np.repeat(np.rint(allc * 255.0).astype(np.uint8), size_px, axis=0)
    return np.ascontiguousarray(np.broadcast_to(row[None, :, :], (size_px, row.shape[0], 3)))
