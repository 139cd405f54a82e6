"""PNG encoding of preview images."""

from __future__ import annotations

import io

import numpy as np
from PIL import Image

__all__ = ["png_bytes"]

#: zlib's level for every PNG the tool writes. Pillow's default (6) took about three times as long
#: as 3 for files 5-10 % smaller: on the bundled example's pictures, CPU-seconds per file at 6 / 3 and
#: bytes, simulated.png 0.109 / 0.034 s (461 / 505 kB), preview.png 0.131 / 0.055 s (909 / 968 kB),
#: sweep.png 0.081 / 0.038 s (617 / 676 kB), a plate's dots 0.025 / 0.017 s (245 / 195 kB). Level 1
#: against 3 (median of 7 encodings each): simulated.png 0.022 / 0.034 s (520 / 501 kB), preview.png
#: 0.043 / 0.054 s (982 / 964 kB), sweep.png 0.029 / 0.038 s (681 / 672 kB), a plate's dots 0.015 /
#: 0.018 s (205 / 197 kB); the job's 25 pictures 0.41 / 0.57 s (7.6 / 7.2 MB, best of 3). Below 1,
#: Pillow's choice of a row filter per row is most of the time (level 0: 0.24 s, 34 MB); zlib's RLE
#: strategy at 1 gave 0.37 s for 7.7 MB. The pixels are the same at any level.
COMPRESS_LEVEL = 1


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
    Image.fromarray(a).save(buf, format="PNG", optimize=False, compress_level=COMPRESS_LEVEL)
    return buf.getvalue()
