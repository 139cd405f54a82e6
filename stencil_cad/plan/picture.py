"""The picture a job starts from and the one it is scored against (the source image on the simulated grid)."""

from __future__ import annotations

import logging
import math

import numpy as np

from ..config import JobConfig
from ..model import Layers, Picture
from ..record import Run

log = logging.getLogger(__name__)


def load_picture(cfg: JobConfig) -> Picture:
    """Load the configured image (or the bundled example) onto the working grid.

    Transparent areas are flattened onto white (bare surface) unless the decomposition
    takes its opacity from the alpha channel, where the paint is the image's own colour.
    """
    from dataclasses import replace

    from .. import resolution
    from ..imaging import MAX_UPSCALE
    from ..imaging import load_picture as _load

    px = 1.0 / resolution.working_mm_per_px(cfg)
    pic = _load(
        cfg.image, cfg.size.width_mm, cfg.size.height_mm, px, resolution.max_upscale(cfg, MAX_UPSCALE)
    )
    if pic.alpha is not None and cfg.decompose.opacity_source != "alpha":
        a = pic.alpha[..., None]
        pic = replace(pic, rgb=pic.rgb * a + (1.0 - a))
    return pic


def source_reference(
    cfg: JobConfig, picture: Picture | None, layers: Layers, shape: tuple[int, int], mm_per_px: float
) -> np.ndarray:
    """The picture every simulation is scored against: the source image resized to the simulated grid.

    Scoring against the picture at the job's working resolution would hide every detail that
    resolution lost (the bundled example: 5.60 against the working picture, 5.87 against the
    source, S-CIELAB at 1 m under the paper model). Without a picture (a stage command run on
    saved layers), the decomposition's own composite.
    """
    if picture is None:
        return _resample(layers.composite(), shape)
    if picture.source != ("bundled example" if cfg.image is None else str(cfg.image)):
        # A picture that does not come from the job's image file (made in code): its own pixels.
        return _resample(picture.rgb, shape)
    from dataclasses import replace

    from ..imaging import load_picture as _load

    h_mm = shape[0] * mm_per_px
    src = _load(cfg.image, shape[1] * mm_per_px, h_mm, 1.0 / mm_per_px, max_upscale=math.inf)
    if src.alpha is not None and cfg.decompose.opacity_source != "alpha":
        a = src.alpha[..., None]
        src = replace(src, rgb=src.rgb * a + (1.0 - a))
    return _resample(src.rgb, shape)


def kept_reference(
    run: Run | None,
    cfg: JobConfig,
    picture: Picture | None,
    layers: Layers,
    shape: tuple[int, int],
    mm_per_px: float,
) -> np.ndarray:
    """:func:`source_reference`, kept in ``run.kept`` by what it reads (None: not kept).

    The plate-design trials score every design they spray, the blur floor and the scout against
    the same reference on their grid; it was read from the image file and resized again for each.
    """
    if run is None:
        return source_reference(cfg, picture, layers, shape, mm_per_px)
    key = (
        "reference",
        str(cfg.image),
        cfg.decompose.opacity_source,
        id(picture),
        id(layers),
        tuple(shape),
        mm_per_px,
    )
    ref, _ = run.keep(key, lambda: source_reference(cfg, picture, layers, shape, mm_per_px))
    return np.asarray(ref)


def _resample(img: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    from ..filters import resize_linear

    if img.shape[:2] == tuple(shape):
        return img
    out: np.ndarray = np.clip(resize_linear(img, shape), 0, 1)
    return out
