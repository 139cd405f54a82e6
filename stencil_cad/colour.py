"""Colours: config values, distinct-colour counts and the one K-means.

Values as the config writes them (``"#rrggbb"`` or ``[r, g, b]``) and as arrays; the
K-means is where both the soft and the hard mode start from.
"""

from __future__ import annotations

import re
from collections.abc import Sequence

import numpy as np

_HEX = re.compile(r"^#?([0-9a-fA-F]{6})$")


def parse_colour(value: object) -> str:
    """Normalise one colour to lower-case ``"#rrggbb"``.

    Args:
        value: ``"#1a2b3c"`` / ``"1a2b3c"`` or a sequence of three integers 0-255.

    Returns:
        The colour as ``"#rrggbb"``.

    Raises:
        ValueError: The value is neither a 6-digit hex string nor three
            integers in 0-255.
    """
    if isinstance(value, str):
        m = _HEX.match(value.strip())
        if not m:
            raise ValueError(f"colour {value!r} is not a 6-digit hex string like '#1a2b3c'")
        return "#" + m.group(1).lower()
    if isinstance(value, (list, tuple)) and len(value) == 3:
        out = []
        for v in value:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or int(v) != v:
                raise ValueError(f"colour {list(value)!r}: components must be integers 0-255")
            if not 0 <= v <= 255:
                raise ValueError(f"colour {list(value)!r}: component {v} is outside 0-255")
            out.append(int(v))
        return "#{:02x}{:02x}{:02x}".format(*out)
    raise ValueError(f"colour {value!r} must be a hex string '#rrggbb' or a list [r, g, b] of integers 0-255")


def colour_to_rgb(value: object) -> tuple[float, float, float]:
    """A colour (hex or ``[r, g, b]`` 0-255) as an RGB triple of floats in [0, 1]."""
    h = parse_colour(value)[1:]
    return tuple(int(h[i : i + 2], 16) / 255.0 for i in (0, 2, 4))  # type: ignore[return-value]


def to_hex(rgb: Sequence[float] | np.ndarray) -> str:
    """An RGB triple of floats in [0, 1] (clipped) as ``"#rrggbb"``."""
    return "#{:02x}{:02x}{:02x}".format(
        *np.rint(np.clip(np.asarray(rgb, dtype=float), 0.0, 1.0) * 255.0).astype(int)
    )


# Pixels in the first and in later chunks when counting colours: a photo passes
# the cap within the small first chunk; later chunks bound the memory of one
# np.unique call.
_COUNT_FIRST_CHUNK = 1 << 16
_COUNT_CHUNK = 1 << 20


def distinct_colours(rgb: np.ndarray, cap: int | None = None) -> int:
    """Number of distinct 8-bit colours among RGB values in [0, 1], counted up to ``cap``.

    Chunks of pixels are counted in turn and the count stops once it reaches
    ``cap``, so a photo costs about one chunk and only few-colour images are
    read to the end.

    Args:
        rgb: ``(..., 3)`` float in [0, 1] (an image or a list of pixels).
        cap: Stop counting at this many; None counts them all.

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
        if cap is not None and seen.size >= cap:
            return int(cap)
        start, size = start + size, _COUNT_CHUNK
    return int(seen.size)


#: K-means runs on at most this many points: the centres of a 256 x 256 and a
#: 4096 x 4096 image agree to well under one 8-bit level from this sample on.
KMEANS_SAMPLE = 40_000


def kmeans(
    points: np.ndarray,
    k: int,
    rng: np.random.Generator,
    iterations: int = 30,
    sample: int = KMEANS_SAMPLE,
) -> tuple[np.ndarray, np.ndarray]:
    """K-means with k-means++ seeding on a random sample of the points.

    Kept instead of ``scipy.cluster.vq.kmeans2(minit="++", seed=rng)``: the two draw
    different random numbers from ``rng``, so switching moves every soft layer's start
    and therefore every hole; the job's outputs are kept byte-identical instead.

    Args:
        points: ``(N, D)`` points (RGB in [0, 1], or CIELAB).
        k: Number of clusters (at most the number of distinct points).
        rng: Random generator for the sample and the seeding.
        iterations: Lloyd iterations. Defaults to 30.
        sample: At most this many points are used. Defaults to :data:`KMEANS_SAMPLE`.

    Returns:
        ``(centres, shares)``: ``(k, D)`` centres and the share of the sample in
        each cluster ``(k,)``. An empty cluster is re-seeded at the worst-fitted point.
    """
    points = np.asarray(points, dtype=np.float64)
    if points.shape[0] > sample:
        points = points[rng.choice(points.shape[0], sample, replace=False)]
    n = points.shape[0]
    centres = np.empty((k, points.shape[1]))
    centres[0] = points[rng.integers(n)]
    d2 = np.sum((points - centres[0]) ** 2, axis=1)
    for c in range(1, k):
        total = d2.sum()
        if total <= 0.0:
            # Fewer distinct points than k: the callers guard against this,
            # but never divide by zero.
            centres[c] = points[rng.integers(n)]
        else:
            centres[c] = points[rng.choice(n, p=d2 / total)]
        d2 = np.minimum(d2, np.sum((points - centres[c]) ** 2, axis=1))
    labels = np.zeros(n, dtype=np.int64)
    for _ in range(iterations):
        dist = np.sum((points[:, None, :] - centres[None, :, :]) ** 2, axis=2)
        labels = np.argmin(dist, axis=1)
        moved = 0.0
        for c in range(k):
            members = points[labels == c]
            if members.shape[0] == 0:
                worst = int(np.argmax(dist[np.arange(n), labels]))
                new = points[worst]
            else:
                new = members.mean(axis=0)
            moved = max(moved, float(np.abs(new - centres[c]).max()))
            centres[c] = new
        if moved < 1e-6:
            break
    shares = np.bincount(labels, minlength=k) / float(n)
    return centres, shares
