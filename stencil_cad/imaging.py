"""Load any image (EXIF orientation, RGBA, 16-bit, grey) into a :class:`Picture`."""

from __future__ import annotations

import logging
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError

from .errors import ImageError
from .model import Picture

log = logging.getLogger(__name__)

#: Largest upscaling accepted when the image has fewer pixels than the working grid.
MAX_UPSCALE = 2.0

# Decompression-bomb guard: Pillow's default limit, raised a little for large scans.
Image.MAX_IMAGE_PIXELS = 200_000_000


def example_image_path() -> Path:
    """Path of the bundled example image."""
    return Path(str(resources.files("stencil_cad") / "data" / "example.png"))


def example_config_path() -> Path:
    """Path of the bundled example job config."""
    return Path(str(resources.files("stencil_cad") / "data" / "example.yaml"))


def read_image(path: Path | str) -> tuple[np.ndarray, np.ndarray | None, bool]:
    """Read an image file into float arrays.

    Args:
        path: Image file (any format Pillow reads).

    Returns:
        ``(rgb, alpha, grey)``: rgb ``(H, W, 3)`` float in [0, 1]; alpha ``(H, W)`` float in
        [0, 1] or None; grey True when the file has a single colour channel.

    Raises:
        ImageError: The file is missing, not an image, truncated or empty.
    """
    path = Path(path)
    if not path.exists():
        raise ImageError(f"image not found: {path} (check the path, or the `image:` key of the config)")
    if path.is_dir():
        raise ImageError(f"image path is a folder, not a file: {path} (give an image file)")
    try:
        with Image.open(path) as im:
            im.load()
            im = ImageOps.exif_transpose(im)
    except UnidentifiedImageError:
        raise ImageError(f"not an image Pillow can read: {path} (use PNG, JPEG, TIFF, BMP or WebP)") from None
    except (OSError, SyntaxError, ValueError) as exc:
        raise ImageError(
            f"cannot read image {path}: {exc} (the file may be truncated; re-export it)"
        ) from None
    except Image.DecompressionBombError:
        raise ImageError(
            f"image too large: {path} (more than {Image.MAX_IMAGE_PIXELS} pixels; downscale it)"
        ) from None
    if im.width < 1 or im.height < 1:
        raise ImageError(f"image is empty: {path}")
    return _to_arrays(im)


def _to_arrays(im: Image.Image) -> tuple[np.ndarray, np.ndarray | None, bool]:
    mode = im.mode
    alpha = None
    grey = mode in ("1", "L", "LA", "I", "I;16", "I;16B", "I;16L", "F")
    if mode in ("I", "I;16", "I;16B", "I;16L", "F"):
        a = np.asarray(im, dtype=np.float64)
        top = 65535.0 if a.max() > 255 else 255.0
        if mode == "F":
            top = max(1.0, float(a.max()))
        g = np.clip(a / top, 0.0, 1.0)
        rgb = np.repeat(g[..., None], 3, axis=2)
        return rgb, None, True
    if mode == "P":
        im = im.convert("RGBA") if "transparency" in im.info else im.convert("RGB")
        mode = im.mode
    if mode in ("RGBA", "LA", "PA"):
        alpha = np.asarray(im.getchannel("A"), dtype=np.float64) / 255.0
    if mode in ("1", "L", "LA"):
        g = np.asarray(im.convert("L"), dtype=np.float64) / 255.0
        rgb = np.repeat(g[..., None], 3, axis=2)
    else:
        a = np.asarray(im)
        if a.dtype == np.uint16 and a.ndim == 3:
            rgb = a[..., :3].astype(np.float64) / 65535.0
        else:
            rgb = np.asarray(im.convert("RGB"), dtype=np.float64) / 255.0
    if alpha is not None and np.all(alpha >= 1.0):
        alpha = None
    return rgb, alpha, grey


#: Distinct source colours are counted up to this many (more than any layer count needs).
COLOUR_COUNT_CAP = 256

# Pixels in the first and in later chunks when counting colours: a photo passes
# the cap within the small first chunk; later chunks bound the memory of one
# np.unique call.
_COUNT_FIRST_CHUNK = 1 << 16
_COUNT_CHUNK = 1 << 20


def count_colours(rgb: np.ndarray, cap: int = COLOUR_COUNT_CAP) -> int:
    """Number of distinct 8-bit colours in an image, counted up to ``cap``.

    Chunks of pixels are counted in turn and the count stops once it passes
    ``cap``, so a photo costs about one chunk and only few-colour images are
    read to the end.

    Args:
        rgb: ``(H, W, 3)`` float in [0, 1].
        cap: Stop counting past this many. Defaults to 256.

    Returns:
        ``min(distinct colours, cap)``.
    """
    flat = np.asarray(rgb).reshape(-1, 3)
    seen = np.empty(0, dtype=np.int64)
    start, size = 0, _COUNT_FIRST_CHUNK
    while start < flat.shape[0]:
        q = np.clip(np.rint(flat[start : start + size] * 255.0), 0, 255).astype(np.int64)
        codes = (q[:, 0] << 16) | (q[:, 1] << 8) | q[:, 2]
        seen = np.union1d(seen, codes)
        if seen.size >= cap:
            return cap
        start, size = start + size, _COUNT_CHUNK
    return int(seen.size)


def fit_to_size(
    rgb: np.ndarray,
    alpha: np.ndarray | None,
    width_mm: float,
    height_mm: float | None,
    px_per_mm: float,
) -> tuple[np.ndarray, np.ndarray | None, float, float]:
    """Crop to the requested aspect and resample to the working grid.

    Args:
        rgb: ``(H, W, 3)`` float image.
        alpha: ``(H, W)`` or None.
        width_mm: Picture width in mm.
        height_mm: Picture height in mm, or None to follow the aspect ratio.
        px_per_mm: Working resolution in px per mm.

    Returns:
        ``(rgb, alpha, mm_per_px, height_mm)`` on the working grid.

    Raises:
        ImageError: The image has too few pixels for the requested size and resolution.
    """
    from skimage.transform import resize

    h, w = rgb.shape[:2]
    if height_mm is None:
        height_mm = width_mm * h / w
    else:
        target_aspect = height_mm / width_mm
        if abs(h / w - target_aspect) > 1e-3:
            if h / w > target_aspect:
                new_h = max(1, round(w * target_aspect))
                top = (h - new_h) // 2
                rgb = rgb[top : top + new_h]
                alpha = alpha[top : top + new_h] if alpha is not None else None
            else:
                new_w = max(1, round(h / target_aspect))
                left = (w - new_w) // 2
                rgb = rgb[:, left : left + new_w]
                alpha = alpha[:, left : left + new_w] if alpha is not None else None
            h, w = rgb.shape[:2]
    out_w = max(1, round(width_mm * px_per_mm))
    out_h = max(1, round(height_mm * px_per_mm))
    scale = max(out_w / w, out_h / h)
    if scale > MAX_UPSCALE:
        need_w = int(np.ceil(out_w / MAX_UPSCALE))
        raise ImageError(
            f"image too small: {w}×{h} px for {width_mm:g}×{height_mm:g} mm at {px_per_mm:g} px/mm "
            f"(needs at least {need_w} px wide; use a larger image, a smaller size.width_mm or a lower "
            f"size.px_per_mm)"
        )
    if (out_h, out_w) != (h, w):
        rgb = resize(rgb, (out_h, out_w, 3), order=1, anti_aliasing=scale < 1, preserve_range=True)
        if alpha is not None:
            alpha = resize(alpha, (out_h, out_w), order=1, anti_aliasing=scale < 1, preserve_range=True)
    rgb = np.clip(rgb, 0.0, 1.0)
    if alpha is not None:
        alpha = np.clip(alpha, 0.0, 1.0)
    mm_per_px = width_mm / out_w
    return rgb, alpha, mm_per_px, out_h * mm_per_px


def load_picture(
    path: Path | str | None, width_mm: float, height_mm: float | None, px_per_mm: float
) -> Picture:
    """Load an image file (or the bundled example) onto the working grid.

    Args:
        path: Image file, or None for the bundled example.
        width_mm: Picture width in mm.
        height_mm: Picture height in mm, or None to follow the aspect ratio.
        px_per_mm: Working resolution in px per mm.

    Returns:
        The picture on a grid of ``round(width_mm * px_per_mm)`` columns.
    """
    source = "bundled example" if path is None else str(path)
    rgb, alpha, grey = read_image(example_image_path() if path is None else path)
    # Counted before resampling, which blends edges into colours the file does not have.
    # With an alpha channel the colours flattened onto white count too (the pipeline
    # flattens transparent areas so); an overcount only costs the check, an undercount
    # would drop layers.
    distinct = count_colours(rgb)
    if alpha is not None:
        distinct = max(distinct, count_colours(rgb * alpha[..., None] + (1.0 - alpha[..., None])))
    rgb, alpha, mm_per_px, _ = fit_to_size(rgb, alpha, width_mm, height_mm, px_per_mm)
    log.debug("loaded %s as %s px at %.4f mm/px", source, rgb.shape[:2], mm_per_px)
    return Picture(
        rgb=rgb, mm_per_px=mm_per_px, alpha=alpha, grey=grey, source=source, distinct_colours=distinct
    )
