"""Synthetic photos of a sprayed card, rendered by the spray simulator from known constants.

They test the photo fit (:mod:`stencil_cad.testcard.fit`) against a ground truth: the card is
sprayed in simulation (physical model) in each of its footprints, laid on the printed sheet,
lit with a gradient, seen through a tilted camera (perspective), blurred, given noise and
JPEG-compressed, as a phone camera would.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..config.spray import SprayConfig
from ..simulate.physical import SprayGeometry
from .layout import CardLayout, Footprint
from .printout import printout_reflectance, srgb_encode

__all__ = ["PhotoSettings", "card_opacity", "synthetic_photo"]


@dataclass(frozen=True)
class PhotoSettings:
    """How the synthetic photo is taken.

    Attributes:
        size_px: ``(width, height)`` of the photo.
        tilt: Perspective strength: the sheet's far edge appears this much shorter (0 = square on).
        rotation_deg: In-plane rotation of the sheet in the photo.
        blur_px: Gaussian defocus of the camera in photo pixels.
        noise: Standard deviation of the sensor noise, in encoded [0, 1] units.
        gradient: Illumination at the sheet's left-bottom and right-top corners (linear ramp).
        exposure: Linear gain (1 puts paper white at about 0.85 linear).
        flare: Constant light added everywhere (linear units).
        jpeg_quality: JPEG quality (0-100); None writes PNG.
        paint_contrast: ``(3,)`` per-channel contrast of the paint at full cover,
            1 - paint / paper reflectance.
        shift_mm: Per footprint, how far (x, y mm) the maker set the wall off its printed outline.
    """

    size_px: tuple[int, int] = (4000, 3000)
    tilt: float = 0.12
    rotation_deg: float = 4.0
    blur_px: float = 1.0
    noise: float = 0.01
    gradient: tuple[float, float] = (0.65, 1.0)
    exposure: float = 0.85
    flare: float = 0.01
    jpeg_quality: int | None = 85
    paint_contrast: tuple[float, float, float] = (0.85, 0.75, 0.35)
    shift_mm: tuple[tuple[float, float], ...] = field(default_factory=tuple)


def card_opacity(
    layout: CardLayout,
    fp: Footprint,
    cfg: SprayConfig,
    passes: float,
    px_per_mm: float,
    shift_mm: tuple[float, float] = (0.0, 0.0),
) -> np.ndarray:
    """Simulated paint opacity over the card's picture area in one footprint.

    Args:
        layout: The card.
        fp: The footprint (its stand-off is the wall's).
        cfg: Spray settings with the can's constants (physical model).
        passes: Passes sprayed.
        px_per_mm: Raster resolution.
        shift_mm: Offset of the holes (the wall set off its outline), mm.

    Returns:
        ``(H, W)`` opacity over ``[0, W] x [0, H]`` mm, row 0 at the top.
    """
    shape = (int(round(layout.height_mm * px_per_mm)), int(round(layout.width_mm * px_per_mm)))
    from ..simulate.physical import physical_opacity

    return physical_opacity(
        layout.dots.xy_mm + np.asarray(shift_mm),
        layout.dots.r_mm,
        shape,
        1.0 / px_per_mm,
        cfg,
        SprayGeometry(fp.standoff_mm, layout.plate_thickness_mm),
        passes,
    )


def synthetic_photo(
    layout: CardLayout,
    cfg: SprayConfig,
    passes: float,
    rng: np.random.Generator,
    settings: PhotoSettings | None = None,
    *,
    sheet_px_per_mm: float = 10.0,
) -> tuple[bytes, str]:
    """Render a photo of the sprayed card sheet.

    Args:
        layout: The card.
        cfg: Spray settings with the true constants.
        passes: Passes sprayed in every footprint.
        rng: Random generator (noise).
        settings: Camera and lighting. Defaults to :class:`PhotoSettings`.
        sheet_px_per_mm: Resolution the sheet is rendered at before the camera sees it.

    Returns:
        ``(data, suffix)``: the encoded file and ``".jpg"`` or ``".png"``.
    """
    import cv2

    s = settings or PhotoSettings()
    ppm = sheet_px_per_mm
    ref = printout_reflectance(layout, ppm)
    hs, ws = ref.shape
    rgb = np.repeat(ref[..., None], 3, axis=2)
    contrast = np.asarray(s.paint_contrast, dtype=np.float64)
    for j, fp in enumerate(layout.footprints):
        shift = s.shift_mm[j] if j < len(s.shift_mm) else (0.0, 0.0)
        alpha = card_opacity(layout, fp, cfg, passes, ppm, shift)
        ox, oy = fp.origin_mm
        c0 = int(round(ox * ppm))
        r0 = int(round(hs - (oy + layout.height_mm) * ppm))
        h, w = alpha.shape
        rgb[r0 : r0 + h, c0 : c0 + w] *= 1.0 - alpha[..., None] * contrast
    # Light: a linear ramp over the sheet, from gradient[0] (bottom-left) to gradient[1] (top-right).
    yy, xx = np.mgrid[0:hs, 0:ws]
    t = 0.5 * (xx / ws + (1.0 - yy / hs))
    light = s.gradient[0] + (s.gradient[1] - s.gradient[0]) * t
    lin = rgb * (light * s.exposure)[..., None] + s.flare
    # Camera: a homography from sheet pixels to photo pixels (tilt, rotation, 75 % of the frame).
    W, H = s.size_px
    scale = 0.75 * min(W / ws, H / hs)
    a = math.radians(s.rotation_deg)
    rot = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    corners = np.array([[0, 0], [ws, 0], [ws, hs], [0, hs]], dtype=np.float64)
    centred = (corners - [ws / 2, hs / 2]) * scale
    # The top edge recedes: shrink it by `tilt`.
    squeeze = np.array([1.0 - s.tilt, 1.0 - s.tilt, 1.0, 1.0])
    centred[:, 0] *= squeeze
    dst = centred @ rot.T + [W / 2, H / 2]
    M = cv2.getPerspectiveTransform(corners.astype(np.float32), dst.astype(np.float32))
    enc = srgb_encode(lin)
    photo = cv2.warpPerspective(
        enc.astype(np.float32),
        M,
        (W, H),
        flags=cv2.INTER_AREA,
        borderMode=cv2.BORDER_CONSTANT,
        borderValue=(0.2, 0.2, 0.2),
    )
    if s.blur_px > 0:
        photo = cv2.GaussianBlur(photo, (0, 0), s.blur_px)
    photo = photo + np.asarray(rng.normal(0.0, s.noise, photo.shape), dtype=np.float32)
    u8 = np.clip(photo * 255.0 + 0.5, 0, 255).astype(np.uint8)
    bgr = u8[..., ::-1]
    if s.jpeg_quality is None:
        ok, buf = cv2.imencode(".png", bgr)
        suffix = ".png"
    else:
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(s.jpeg_quality)])
        suffix = ".jpg"
    if not ok:
        raise RuntimeError("OpenCV could not encode the synthetic photo")
    return buf.tobytes(), suffix
