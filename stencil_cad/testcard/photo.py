"""Read a photo of the sprayed calibration card and turn each footprint into flat-fielded linear light.

The fiducials give a homography per footprint; the footprint is rectified into the card's
frame, decoded from sRGB, flat-fielded against the paper and the black patches, and its
camera blur measured on the printed edges (steps 1-4 of :mod:`.fit`).
"""

import contextlib
import logging
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import UserError
from ..files import DATA_LIMIT, open_input
from .layout import MARKER_MM, CardLayout, Footprint
from .printout import aruco_dictionary, srgb_decode

log = logging.getLogger(__name__)

__all__ = ["PhotoError", "read_photo"]


#: The photo must resolve at least this many px per mm on the card.
MIN_PX_PER_MM = 5.0
#: Share of clipped (saturated) pixels on a footprint above which the photo is refused.
MAX_CLIPPED = 0.005


class PhotoError(UserError):
    """A photo the fit cannot read: the message names the problem and what to do."""


#: Most pixels a photo is decoded at: a JPEG above it is decoded at 1/2, 1/4 or 1/8 of its size
#: (DCT scaling, no full-size copy), any other format above it is refused. The card needs
#: about 2000 px across the sheet; 64 MP is a 9800 x 6500 px photo, 190 MB as RGB.
MAX_PHOTO_PIXELS = 64_000_000


def read_photo(path: Path | str) -> np.ndarray:
    """Read a photo as sRGB ``(H, W, 3)`` uint8 (EXIF orientation applied), at most 64 MP.

    Raises:
        PhotoError: Missing, not a regular file, unreadable, too small, or too large to decode.
    """
    from PIL import Image, ImageOps, UnidentifiedImageError

    path = Path(path)
    fix = "give a JPEG or PNG photo of the card sheet"
    try:
        with (
            open_input(path, "photo", limit=DATA_LIMIT, error=PhotoError, fix=fix) as fh,
            _no_pillow_limit(Image),
            Image.open(fh) as im,
        ):
            w, h = im.size
            if w * h > MAX_PHOTO_PIXELS:
                if im.format != "JPEG":
                    raise PhotoError(
                        f"{path}: photo is {w} × {h} px ({w * h / 1e6:.0f} MP), more than the "
                        f"{MAX_PHOTO_PIXELS / 1e6:.0f} MP calibrate decodes from a {im.format or 'non-JPEG'} "
                        "file; save it as JPEG or scale it down (2000 px across the sheet is enough)"
                    )
                k = 2
                while w * h / (k * k) > MAX_PHOTO_PIXELS and k < 8:
                    k *= 2
                im.draft("RGB", (w // k, h // k))
                if im.size[0] * im.size[1] > MAX_PHOTO_PIXELS:
                    raise PhotoError(
                        f"{path}: photo is {w} × {h} px ({w * h / 1e6:.0f} MP), too large to decode at "
                        f"{MAX_PHOTO_PIXELS / 1e6:.0f} MP; scale it down (2000 px across the sheet is enough)"
                    )
            im = ImageOps.exif_transpose(im)
            rgb = np.asarray(im.convert("RGB"))
    except (UnidentifiedImageError, OSError, SyntaxError, ValueError) as exc:
        raise PhotoError(f"{path}: not a readable image ({exc}); {fix}") from None
    if min(rgb.shape[:2]) < 800:
        raise PhotoError(
            f"{path}: photo too small ({rgb.shape[1]} × {rgb.shape[0]} px); take it at full camera resolution "
            "(at least 2000 px across the sheet)"
        )
    return rgb


@contextlib.contextmanager
def _no_pillow_limit(image_module):
    """Pillow's decompression-bomb error says nothing a maker can act on: ours is above."""
    old = image_module.MAX_IMAGE_PIXELS
    image_module.MAX_IMAGE_PIXELS = None
    try:
        yield
    finally:
        image_module.MAX_IMAGE_PIXELS = old


def _detect(rgb: np.ndarray) -> dict[int, np.ndarray]:
    import cv2

    grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    det = cv2.aruco.ArucoDetector(aruco_dictionary(), params)
    corners, ids, _ = det.detectMarkers(grey)
    if ids is None:
        return {}
    return {int(i): c.reshape(4, 2).astype(np.float64) for i, c in zip(ids.ravel(), corners, strict=True)}


def _homography(fp: Footprint, found: dict[int, np.ndarray]) -> tuple[np.ndarray, int, float]:
    """The homography from picture mm to photo px, the markers it used and the px per mm."""
    import cv2

    obj, img, sides = [], [], []
    corners_mm = fp.marker_corners()
    for k, mid in enumerate(fp.marker_ids):
        if mid in found:
            obj.append(corners_mm[k])
            img.append(found[mid])
            c = found[mid]
            sides.append(np.mean(np.linalg.norm(c - np.roll(c, 1, axis=0), axis=1)) / MARKER_MM)
    if len(obj) < 2:
        raise PhotoError(
            f"fiducials not found: {len(obj)} of the 4 markers around the {fp.standoff_mm:g} mm footprint "
            f"(ids {list(fp.marker_ids)}) are readable; photograph the whole sheet, flat, in focus and in even "
            "light, with nothing covering the band where the wall stood"
        )
    H, _ = cv2.findHomography(np.concatenate(obj), np.concatenate(img), 0)
    if H is None:
        raise PhotoError(
            "fiducials found but the perspective could not be solved; photograph the sheet again"
        )
    return H, len(obj), float(np.min(sides))


def _rectify(
    rgb: np.ndarray, H: np.ndarray, extent: tuple[float, float, float, float], ppm: float
) -> np.ndarray:
    """Resample the photo over ``extent = (x0, y0, x1, y1)`` mm at ``ppm``, row 0 at the top."""
    import cv2

    x0, y0, x1, y1 = extent
    w, h = int(round((x1 - x0) * ppm)), int(round((y1 - y0) * ppm))
    # Output pixel (col, row) → mm → photo px.
    A = np.array([[1.0 / ppm, 0.0, x0 + 0.5 / ppm], [0.0, -1.0 / ppm, y1 - 0.5 / ppm], [0.0, 0.0, 1.0]])
    M = H @ A
    return cv2.warpPerspective(
        rgb, M, (w, h), flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP, borderMode=cv2.BORDER_REPLICATE
    )


def _mm_grid(extent, shape, ppm):
    x0, _, _, y1 = extent
    rows, cols = np.mgrid[0 : shape[0], 0 : shape[1]]
    return x0 + (cols + 0.5) / ppm, y1 - (rows + 0.5) / ppm


def _poly(x, y, scale):
    u, v = x / scale, y / scale
    return np.stack([np.ones_like(u), u, v, u * u, u * v, v * v], axis=-1)


@dataclass
class _Footprint:
    fp: Footprint
    lin: np.ndarray  # flat-fielded, (h, w, 3), over the picture area
    full: np.ndarray  # linear, over the extent
    white: np.ndarray  # (h, w, 3) fitted white over the picture area
    black_share: np.ndarray  # (3,)
    grey: np.ndarray  # (3,) flat-fielded grey patches
    blur_mm: float
    markers: int
    px_per_mm: float
    noise: np.ndarray  # (3,) robust sd of the flat-fielded paper around the picture


def _prepare_footprint(rgb: np.ndarray, layout: CardLayout, fp: Footprint, found, ppm: float) -> _Footprint:
    H, n_markers, px_per_mm = _homography(fp, found)
    if px_per_mm < MIN_PX_PER_MM:
        raise PhotoError(
            f"the card is too small in the photo: {px_per_mm:.1f} px per mm at the {fp.standoff_mm:g} mm footprint, "
            f"need ≥ {MIN_PX_PER_MM:g}; move closer so the sheet fills the frame"
        )
    band = layout.band_mm[1]
    W, Hc = layout.width_mm, layout.height_mm
    extent = (-band + 0.5, -band + 0.5, W + band - 0.5, Hc + band - 0.5)
    enc = _rectify(rgb, H, extent, ppm)
    clipped = float(np.mean(np.any(enc >= 254, axis=-1)))
    if clipped > MAX_CLIPPED:
        raise PhotoError(
            f"overexposed: {100 * clipped:.1f} % of the {fp.standoff_mm:g} mm footprint is clipped white; "
            "lower the exposure (tap the sheet on the phone, or −1 EV) and avoid glare"
        )
    full = srgb_decode(enc.astype(np.float64) / 255.0)
    xs, ys = _mm_grid(extent, full.shape[:2], ppm)
    band_ok, far = _white_references(layout, fp, xs, ys)
    white = _fit_white(full, xs, ys, band_ok | far)
    ratio = full / np.maximum(white, 1e-6)
    black, grey = _patch_shares(ratio, xs, ys, fp)
    if np.any(black > 0.6):
        raise PhotoError(
            "the black patches read almost as light as the paper: the photo is washed out (glare or "
            "overexposure); photograph the sheet again without glare"
        )
    ff = (ratio - black) / (1.0 - black)
    grey = (grey - black) / (1.0 - black)
    blur = _edge_blur(ff, xs, ys, fp, ppm)
    bare = ff[band_ok]  # the paper around the picture: where the card's holes are does not matter
    noise = 1.4826 * np.median(np.abs(bare - np.median(bare, axis=0)), axis=0) if len(bare) else np.zeros(3)
    # Crop the picture area: rows from the top (y = Hc) down to y = 0, cols from x = 0.
    r0 = int(round((extent[3] - Hc) * ppm))
    c0 = int(round((0.0 - extent[0]) * ppm))
    h, w = int(round(Hc * ppm)), int(round(W * ppm))
    return _Footprint(
        fp=fp,
        lin=ff[r0 : r0 + h, c0 : c0 + w],
        full=full,
        white=white[r0 : r0 + h, c0 : c0 + w],
        black_share=black,
        grey=grey,
        blur_mm=blur,
        markers=n_markers,
        px_per_mm=px_per_mm,
        noise=noise,
    )


def _white_references(
    layout: CardLayout, fp: Footprint, xs: np.ndarray, ys: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Where the photo shows unpainted white: ``(band_ok, far)`` masks of the band's paper and the far primer.

    The paper in the band is taken clear of markers, patches and the band's edges; the primer
    inside the picture far from any hole.
    """
    band = layout.band_mm[1]
    W, Hc = layout.width_mm, layout.height_mm
    in_pic = (xs > 0) & (xs < W) & (ys > 0) & (ys < Hc)
    band_ok = (
        ~in_pic & (xs > -band + 1.5) & (xs < W + band - 1.5) & (ys > -band + 1.5) & (ys < Hc + band - 1.5)
    )
    band_ok &= (xs < -1.0) | (xs > W + 1.0) | (ys < -1.0) | (ys > Hc + 1.0)
    for m in fp.markers:
        band_ok &= (np.abs(xs - m[0]) > MARKER_MM / 2 + 1.5) | (np.abs(ys - m[1]) > MARKER_MM / 2 + 1.5)
    for _, x0, y0, x1, y1 in fp.flat_patches:
        band_ok &= (xs < x0 - 1.0) | (xs > x1 + 1.0) | (ys < y0 - 1.0) | (ys > y1 + 1.0)
    # Inside: farther than r + 3 mm + 0.25 g from every hole (beyond 3 sigma for k ≤ 0.08 ... 0.2 at
    # small gaps); the robust loss below discounts any paint that still reaches there.
    far = in_pic.copy()
    for (hx, hy), hr in zip(layout.dots.xy_mm, layout.dots.r_mm, strict=True):
        far &= (xs - hx) ** 2 + (ys - hy) ** 2 > (hr + 3.0 + 0.25 * fp.standoff_mm) ** 2
    return band_ok, far


def _fit_white(full: np.ndarray, xs: np.ndarray, ys: np.ndarray, white_mask: np.ndarray) -> np.ndarray:
    """The unpainted white ``(h, w, 3)``: per channel a quadratic surface fitted robustly to ``white_mask``."""
    from scipy.optimize import least_squares

    step = max(1, int(white_mask.sum() // 20000))
    sel = np.flatnonzero(white_mask.ravel())[::step]
    X = _poly(xs.ravel()[sel], ys.ravel()[sel], 100.0)
    white = np.empty((*full.shape[:2], 3))
    Xall = _poly(xs, ys, 100.0)
    for ch in range(3):
        yv = full[..., ch].ravel()[sel]
        c0 = np.linalg.lstsq(X, yv, rcond=None)[0]
        res = least_squares(
            lambda c, X=X, yv=yv: X @ c - yv, c0, loss="soft_l1", f_scale=0.01 * float(np.median(yv))
        )
        white[..., ch] = Xall @ res.x
    return white


def _patch_shares(
    ratio: np.ndarray, xs: np.ndarray, ys: np.ndarray, fp: Footprint
) -> tuple[np.ndarray, np.ndarray]:
    """Per channel, the black patches' and the grey patches' median share of the white (grey NaN without one)."""
    black = np.empty(3)
    grey = np.empty(3)
    for ch in range(3):
        vals_b, vals_g = [], []
        for level, x0, y0, x1, y1 in fp.flat_patches:
            m = (xs > x0 + 1.0) & (xs < x1 - 1.0) & (ys > y0 + 1.0) & (ys < y1 - 1.0)
            if level == 0.0:
                vals_b.append(ratio[..., ch][m])
            elif 0.0 < level < 1.0:
                vals_g.append(ratio[..., ch][m])
        black[ch] = float(np.median(np.concatenate(vals_b)))
        grey[ch] = float(np.median(np.concatenate(vals_g))) if vals_g else math.nan
    return black, grey


def _edge_blur(ff: np.ndarray, xs: np.ndarray, ys: np.ndarray, fp: Footprint, ppm: float) -> float:
    """Gaussian sigma (mm) of the printed black patches' left and right edges in the rectified photo."""
    from scipy.optimize import least_squares
    from scipy.special import erf

    g = ff.mean(axis=-1)
    sig = []
    x_axis = xs[0]
    for level, x0, y0, x1, y1 in fp.flat_patches:
        if level != 0.0:
            continue
        rows = np.flatnonzero((ys[:, 0] > y0 + 1.5) & (ys[:, 0] < y1 - 1.5))
        prof_all = g[rows].mean(axis=0)
        for edge, sign in ((x0, -1.0), (x1, 1.0)):
            m = np.abs(x_axis - edge) < 1.5
            x, p = x_axis[m] - edge, prof_all[m]

            def model(q, x=x, sign=sign):
                lo, hi, s, d = q
                return lo + (hi - lo) * 0.5 * (1.0 + erf(sign * (x - d) / (math.sqrt(2.0) * abs(s) + 1e-9)))

            q0 = [float(p.min()), float(p.max()), 0.1, 0.0]
            res = least_squares(lambda q, p=p, model=model: model(q) - p, q0)
            sig.append(abs(res.x[2]))
    # Rectification resamples bilinearly: its own variance of 1/6 px^2 is part of what was measured
    # and is also part of the fitted image, so it stays in.
    return float(np.median(sig)) if sig else 0.0


def _prepare_footprints(rgb: np.ndarray, layout: CardLayout, ppm: float) -> list[_Footprint]:
    """Every footprint whose markers the photo shows, rectified and flat-fielded.

    Raises:
        PhotoError: No marker of the card is readable (or a footprint's own named reason).
    """
    found = _detect(rgb)
    if not any(i in found for fp in layout.footprints for i in fp.marker_ids):
        raise PhotoError(
            "fiducials not found: no ArUco marker of this card is readable in the photo; photograph the whole "
            "sheet, flat, in focus and in even light (see `Measuring your can` in docs/guides/spraying.md)"
        )
    fps = [
        _prepare_footprint(rgb, layout, fp, found, ppm)
        for fp in layout.footprints
        if any(i in found for i in fp.marker_ids)
    ]
    missing = [fp.standoff_mm for fp in layout.footprints if not any(i in found for i in fp.marker_ids)]
    if missing:
        log.warning("footprints %s mm not in the photo: fitting the others", missing)
    return fps
