"""Load any image (EXIF orientation, RGBA, 16-bit, grey) into a :class:`Picture`."""

from __future__ import annotations

import logging
import math
from importlib import resources
from pathlib import Path

import numpy as np
from PIL import Image, ImageOps, UnidentifiedImageError

from .colour import distinct_colours
from .errors import ConfigError, ImageError
from .files import DATA_LIMIT, open_input
from .filters import resize_linear
from .model import Picture

log = logging.getLogger(__name__)

#: Largest upscaling accepted when the image has fewer pixels than the working grid.
MAX_UPSCALE = 2.0

#: Largest image accepted, in pixels. Big files are decoded at reduced size (JPEG by
#: DCT scaling, others streamed through libvips), so the limit guards time, not memory.
MAX_PIXELS = 500_000_000

#: Decode at reduced size to at least this multiple of the working grid (the resampling
#: to the grid then still averages several source pixels per output pixel).
DECODE_MARGIN = 2.0

#: Above this many decoded bytes, a non-JPEG file is streamed through libvips: Pillow
#: decodes a PNG whole (a 15000 x 15000 RGB PNG is 675 MB as uint8).
STREAM_BYTES = 64 * 1024 * 1024

#: Largest working picture (the grid every stage works on), in pixels: 64 MP is 1.5 GB as float64
#: RGB, and a stage holds a few such copies (a 4 m x 4 m picture at 2 px/mm).
MAX_GRID_PIXELS = 64_000_000

#: Most bytes the decoded picture may take as float64 RGB before it is resampled to the grid,
#: when a smaller decode still covers the grid (see ``_budget_factor``).
DECODE_BUDGET = 512 * 1024 * 1024

# Our own limit replaces Pillow's, whose warnings and errors say nothing a maker can act on.
Image.MAX_IMAGE_PIXELS = None


def example_image_path() -> Path:
    """Path of the bundled example image."""
    return Path(str(resources.files("stencil_cad") / "data" / "example.png"))


def example_config_path() -> Path:
    """Path of the bundled example job config."""
    return Path(str(resources.files("stencil_cad") / "data" / "example.yaml"))


def read_image(
    path: Path | str, min_size: tuple[int, int] | None = None
) -> tuple[np.ndarray, np.ndarray | None, bool]:
    """Read an image file into float arrays, decoded at reduced size when it is large.

    Args:
        path: Image file (any format Pillow reads).
        min_size: ``(width, height)`` in px the caller needs at least; the file is decoded
            at the smallest size no smaller than this (JPEG draft mode, libvips shrink-on-load
            for other large files, then Pillow's ``reduce``). None decodes at full size.

    Returns:
        ``(rgb, alpha, grey)``: rgb ``(H, W, 3)`` float in [0, 1]; alpha ``(H, W)`` float in
        [0, 1] or None; grey True when the file has a single colour channel.

    Raises:
        ImageError: The file is missing, unreadable, not an image, truncated, too large,
            empty, or has non-finite pixel values.
    """
    path = Path(path)
    fix = "check the path, or the `image:` key of the config"
    try:
        with (
            open_input(path, "image", limit=DATA_LIMIT, error=ImageError, fix=fix) as fh,
            Image.open(fh) as im,
        ):
            w, h = im.size
            if w < 1 or h < 1:
                raise ImageError(f"image is empty: {path}")
            if w * h > MAX_PIXELS:
                if min_size is not None and min_size[1] <= 1:  # the height follows the image's aspect
                    min_size = (min_size[0], max(1, round(min_size[0] * h / w)))
                raise ImageError(
                    f"image too large: {path} is {w} × {h} px ({w * h / 1e6:.0f} MP), more than the "
                    f"{MAX_PIXELS / 1e6:.0f} MP stencil-cad reads; downscale it"
                    + (f" (this job needs only about {min_size[0]} × {min_size[1]} px)" if min_size else "")
                )
            _check_grid(path, (w, h), min_size)
            # Before EXIF rotation the sides may swap: bound by the short side against the long need.
            k = _reduce_factor((min(w, h),) * 2, (max(min_size),) * 2 if min_size else None)
            big = w * h * len(im.getbands()) * (2 if im.mode.startswith("I;16") else 1) > STREAM_BYTES
            kf = _budget_factor((min(w, h),) * 2, (max(min_size),) * 2 if min_size else None, k)
            if big and kf > 1 and (im.format != "JPEG" or k == 1):
                # Streamed, never whole: also a JPEG whose DCT scaling cannot shrink it (k = 1).
                return _read_streamed(path, (w, h), kf)
            if k > 1 and im.format == "JPEG":
                im.draft("RGB" if im.mode not in ("L", "1") else im.mode, (w // k, h // k))
            im.load()
            im = ImageOps.exif_transpose(im)
            k = _reduce_factor(im.size, min_size)
            if k > 1:
                if im.mode in ("P", "1", "I;16", "I;16B", "I;16L", "CMYK"):
                    im = im.convert(
                        "RGBA"
                        if "transparency" in im.info
                        else ("I" if im.mode.startswith("I;16") else "RGB")
                    )
                im = im.reduce(k)
    except UnidentifiedImageError:
        raise ImageError(f"not an image Pillow can read: {path} (use PNG, JPEG, TIFF, BMP or WebP)") from None
    except PermissionError:
        raise ImageError(
            f"cannot read image {path}: permission denied (fix the file's permissions, or copy it)"
        ) from None
    except OSError as exc:
        if exc.errno is not None:
            raise ImageError(f"cannot read image {path}: {exc.strerror} (check the file)") from None
        raise ImageError(
            f"cannot read image {path}: {exc} (the file may be truncated; re-export it)"
        ) from None
    except (SyntaxError, ValueError) as exc:
        raise ImageError(f"cannot read image {path}: {exc} (the file may be damaged; re-export it)") from None
    if im.width < 1 or im.height < 1:
        raise ImageError(f"image is empty: {path}")
    return _checked(_to_arrays(im), path)


def _reduce_factor(size: tuple[int, int], min_size: tuple[int, int] | None) -> int:
    """Largest integer k so that size / k stays at least min_size × DECODE_MARGIN."""
    if min_size is None:
        return 1
    kw = size[0] / max(1.0, DECODE_MARGIN * min_size[0])
    kh = size[1] / max(1.0, DECODE_MARGIN * min_size[1])
    return max(1, int(min(kw, kh)))


def _check_grid(path: Path, size: tuple[int, int], min_size: tuple[int, int] | None) -> None:
    """Refuse, before decoding, a working picture larger than :data:`MAX_GRID_PIXELS`.

    Raises:
        ConfigError: With the grid's size, its memory and the settings that make it smaller.
    """
    if min_size is None:
        return
    gw = min_size[0]
    gh = min_size[1] if min_size[1] > 1 else max(1, round(gw * size[1] / size[0]))
    if gw * gh <= MAX_GRID_PIXELS:
        return
    shrink = (MAX_GRID_PIXELS / (gw * gh)) ** 0.5
    raise ConfigError(
        f"size: the working picture of {path} would be {gw} × {gh} px ({gw * gh / 1e6:.0f} MP, "
        f"{gw * gh * 24 / 1e9:.1f} GB for each copy of its colours), more than the {MAX_GRID_PIXELS / 1e6:.0f} MP "
        f"stencil-cad works on; lower size.px_per_mm or size.width_mm by a factor of {1 / shrink:.2f} or more"
    )


def _budget_factor(size: tuple[int, int], min_size: tuple[int, int] | None, k: int) -> float:
    """Shrink factor for a streamed decode: ``k``, or onto the grid itself when ``k`` costs too much.

    The decoded picture becomes float64 RGB (24 bytes a pixel) before it is resampled onto the
    working grid; at ``DECODE_MARGIN`` times a big grid's sides (a 15000 px PNG onto 4000 px,
    k = 1) that is 1.5 GB and more. Above ``DECODE_BUDGET`` libvips shrinks the file straight to
    the grid's size (its own antialiasing filter), and no second resampling is needed.
    """
    if min_size is None or DECODE_MARGIN**2 * 24.0 * min_size[0] * min_size[1] <= DECODE_BUDGET:
        return float(k)
    kf = min(size[0] / min_size[0], size[1] / min_size[1])
    return max(float(k), kf, 1.0)


def _read_streamed(path: Path, size: tuple[int, int], k: float):
    """Decode a large file shrunk by ``k`` while streaming (libvips), never whole."""
    import pyvips

    w, h = size
    # An integer factor as before; a fractional one (the memory budget's) rounds up, never below the grid.
    sw, sh = (int(w // k), int(h // k)) if float(k).is_integer() else (math.ceil(w / k), math.ceil(h / k))
    try:
        img = pyvips.Image.thumbnail(str(path), max(1, sw), height=max(1, sh), size="force", linear=False)
        fmt = {"uchar": np.uint8, "ushort": np.uint16, "float": np.float32, "double": np.float64}.get(
            img.format
        )
        if fmt is None:
            img = img.cast("float")
            fmt = np.float32
        a = np.ndarray(buffer=img.write_to_memory(), dtype=fmt, shape=(img.height, img.width, img.bands))
    except pyvips.Error as exc:
        first = str(exc).strip().splitlines()[0][:200] if str(exc).strip() else "decode failed"
        raise ImageError(
            f"cannot read image {path}: {first} (the file may be truncated; re-export it)"
        ) from None
    full_scale: dict[type, float] = {np.uint8: 255.0, np.uint16: 65535.0}
    top = full_scale.get(fmt, 1.0)
    bands = a.shape[2]
    grey = bands in (1, 2)
    colour = a[..., :1] if grey else a[..., :3]
    alpha = a[..., -1].astype(np.float64) / top if bands in (2, 4) else None
    rgb = colour.astype(np.float64)  # one float copy, scaled and clipped in place
    del a, colour
    rgb /= top
    np.clip(rgb, 0.0, 1.0, out=rgb)
    if grey:
        rgb = np.repeat(rgb, 3, axis=2)
    if alpha is not None and np.all(alpha >= 1.0):
        alpha = None
    return _checked((rgb, alpha, grey), path)


def _checked(arrays, path: Path):
    rgb, alpha, grey = arrays
    if not np.all(np.isfinite(rgb)) or (alpha is not None and not np.all(np.isfinite(alpha))):
        raise ImageError(
            f"image {path} has NaN or infinite pixel values (a float image with holes?); "
            "re-export it as an 8- or 16-bit PNG or TIFF"
        )
    return rgb, alpha, grey


def _to_arrays(im: Image.Image) -> tuple[np.ndarray, np.ndarray | None, bool]:
    mode = im.mode
    alpha = None
    grey = mode in ("1", "L", "LA", "I", "I;16", "I;16B", "I;16L", "F")
    if mode in ("I", "I;16", "I;16B", "I;16L", "F"):
        a = np.asarray(im, dtype=np.float64)
        if not np.all(np.isfinite(a)):
            return a[..., None].repeat(3, axis=2), None, True  # refused by _checked
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


def fit_to_size(
    rgb: np.ndarray,
    alpha: np.ndarray | None,
    width_mm: float,
    height_mm: float | None,
    px_per_mm: float,
    max_upscale: float = MAX_UPSCALE,
) -> tuple[np.ndarray, np.ndarray | None, float, float]:
    """Crop to the requested aspect and resample to the working grid.

    Args:
        rgb: ``(H, W, 3)`` float image.
        alpha: ``(H, W)`` or None.
        width_mm: Picture width in mm.
        height_mm: Picture height in mm, or None to follow the aspect ratio.
        px_per_mm: Working resolution in px per mm.
        max_upscale: Largest enlargement of the image. Defaults to 2.

    Returns:
        ``(rgb, alpha, mm_per_px, height_mm)`` on the working grid.

    Raises:
        ImageError: The image has too few pixels for the requested size and resolution.
    """
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
    if scale > max_upscale + 1e-9:
        need_w = int(np.ceil(out_w / max_upscale))
        raise ImageError(
            f"image too small: {w}×{h} px for {width_mm:g}×{height_mm:g} mm at {px_per_mm:g} px/mm "
            f"(needs at least {need_w} px wide; use a larger image, a smaller size.width_mm or a lower "
            f"size.px_per_mm)"
        )
    if (out_h, out_w) != (h, w):
        rgb = resize_linear(rgb, (out_h, out_w), anti_aliasing=scale < 1)
        if alpha is not None:
            alpha = resize_linear(alpha, (out_h, out_w), anti_aliasing=scale < 1)
    rgb = np.clip(rgb, 0.0, 1.0)
    if alpha is not None:
        alpha = np.clip(alpha, 0.0, 1.0)
    mm_per_px = width_mm / out_w
    return rgb, alpha, mm_per_px, out_h * mm_per_px


def load_picture(
    path: Path | str | None,
    width_mm: float,
    height_mm: float | None,
    px_per_mm: float,
    max_upscale: float = MAX_UPSCALE,
) -> Picture:
    """Load an image file (or the bundled example) onto the working grid.

    Args:
        path: Image file, or None for the bundled example.
        width_mm: Picture width in mm.
        height_mm: Picture height in mm, or None to follow the aspect ratio.
        px_per_mm: Working resolution in px per mm.
        max_upscale: Largest enlargement of the image. Defaults to 2.

    Returns:
        The picture on a grid of ``round(width_mm * px_per_mm)`` columns.
    """
    source = "bundled example" if path is None else str(path)
    need = (max(1, round(width_mm * px_per_mm)), max(1, round((height_mm or width_mm) * px_per_mm)))
    if height_mm is None:
        need = (need[0], 1)  # the height follows the image's aspect: only the width binds
    rgb, alpha, grey = read_image(example_image_path() if path is None else path, min_size=need)
    # Counted before resampling, which blends edges into colours the file does not have.
    # With an alpha channel the colours flattened onto white count too (the pipeline
    # flattens transparent areas so); an overcount only costs the check, an undercount
    # would drop layers.
    distinct = distinct_colours(rgb, COLOUR_COUNT_CAP)
    if alpha is not None:
        distinct = max(
            distinct, distinct_colours(rgb * alpha[..., None] + (1.0 - alpha[..., None]), COLOUR_COUNT_CAP)
        )
    rgb, alpha, mm_per_px, _ = fit_to_size(rgb, alpha, width_mm, height_mm, px_per_mm, max_upscale)
    log.debug("loaded %s as %s px at %.4f mm/px", source, rgb.shape[:2], mm_per_px)
    return Picture(
        rgb=rgb, mm_per_px=mm_per_px, alpha=alpha, grey=grey, source=source, distinct_colours=distinct
    )
