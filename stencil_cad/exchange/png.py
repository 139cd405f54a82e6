"""PNG encoding of preview images."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image

__all__ = ["png_bytes"]


def png_bytes(image: np.ndarray) -> bytes:
    """Encode a uint8 array, or a float array in [0, 1], as PNG.

    Args:
        image: ``(H, W)`` grey or ``(H, W, 3)`` RGB; floats are clipped to [0, 1]
            and rounded to 8 bits.

    Returns:
        The PNG file's bytes.
    """
    a = np.asarray(image)
    if a.dtype != np.uint8:
        a = (np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    buf = io.BytesIO()
    Image.fromarray(a).save(buf, format="PNG", optimize=False)
    return buf.getvalue()
