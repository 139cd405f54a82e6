"""Palette start: K-means colours, distinct-colour count, luminance order."""

from __future__ import annotations

import numpy as np

# Rec. 709 luma weights; only used to sort paints light to dark.
_LUMA = np.array([0.2126, 0.7152, 0.0722])

# K-means runs on at most this many pixels: the centres of a 256 x 256 and a
# 4096 x 4096 image agree to well under one 8-bit level from this sample on.
_KMEANS_SAMPLE = 40_000


def luminance(colours: np.ndarray) -> np.ndarray:
    """Relative luminance of ``(..., 3)`` RGB colours in [0, 1]."""
    return np.asarray(colours, dtype=np.float64) @ _LUMA


def distinct_colours(pixels: np.ndarray, limit: int) -> int:
    """Number of distinct 8-bit colours among ``pixels``, counted up to ``limit``.

    Args:
        pixels: ``(N, 3)`` colours in [0, 1].
        limit: Stop counting past this many (the answer is then ``limit``).

    Returns:
        ``min(distinct, limit)``.
    """
    q = np.clip(np.rint(pixels * 255.0), 0, 255).astype(np.int64)
    codes = (q[:, 0] << 16) | (q[:, 1] << 8) | q[:, 2]
    return int(min(np.unique(codes).size, limit))


def kmeans(
    pixels: np.ndarray, k: int, rng: np.random.Generator, iterations: int = 30
) -> tuple[np.ndarray, np.ndarray]:
    """K-means with k-means++ seeding on a random sample of the pixels.

    Args:
        pixels: ``(N, 3)`` colours in [0, 1].
        k: Number of clusters (at most the number of distinct colours).
        rng: Random generator for the sample and the seeding.
        iterations: Lloyd iterations.

    Returns:
        ``(centres, counts)``: ``(k, 3)`` centres in [0, 1] and the share of the
        sample in each cluster ``(k,)``.
    """
    pixels = np.asarray(pixels, dtype=np.float64)
    if pixels.shape[0] > _KMEANS_SAMPLE:
        pixels = pixels[rng.choice(pixels.shape[0], _KMEANS_SAMPLE, replace=False)]
    n = pixels.shape[0]
    centres = np.empty((k, 3))
    centres[0] = pixels[rng.integers(n)]
    d2 = np.sum((pixels - centres[0]) ** 2, axis=1)
    for c in range(1, k):
        total = d2.sum()
        if total <= 0.0:
            # Fewer distinct colours than k: the caller guards against this,
            # but never divide by zero.
            centres[c] = pixels[rng.integers(n)]
        else:
            centres[c] = pixels[rng.choice(n, p=d2 / total)]
        d2 = np.minimum(d2, np.sum((pixels - centres[c]) ** 2, axis=1))
    labels = np.zeros(n, dtype=np.int64)
    for _ in range(iterations):
        dist = np.sum((pixels[:, None, :] - centres[None, :, :]) ** 2, axis=2)
        labels = np.argmin(dist, axis=1)
        moved = 0.0
        for c in range(k):
            members = pixels[labels == c]
            if members.shape[0] == 0:
                # Re-seed an empty cluster at the worst-fitted pixel.
                worst = int(np.argmax(dist[np.arange(n), labels]))
                new = pixels[worst]
            else:
                new = members.mean(axis=0)
            moved = max(moved, float(np.abs(new - centres[c]).max()))
            centres[c] = new
        if moved < 1e-6:
            break
    counts = np.bincount(labels, minlength=k) / float(n)
    return np.clip(centres, 0.0, 1.0), counts


def nearest(pixels: np.ndarray, colours: np.ndarray) -> np.ndarray:
    """Index of the nearest colour for each of ``(N, 3)`` pixels."""
    best = np.zeros(pixels.shape[0], dtype=np.int64)
    best_d = np.full(pixels.shape[0], np.inf)
    for idx, c in enumerate(colours):
        d = np.sum((pixels - c) ** 2, axis=1)
        closer = d < best_d
        best[closer] = idx
        best_d[closer] = d[closer]
    return best


def hard_alphas(image: np.ndarray, primer: np.ndarray, colours: np.ndarray) -> np.ndarray:
    """Initial opacities: each pixel fully covered by its nearest paint (or bare primer).

    Args:
        image: ``(H, W, 3)`` in [0, 1].
        primer: ``(3,)``.
        colours: ``(L, 3)`` in spray order.

    Returns:
        ``(L, H, W)`` opacities in {0, 1}.
    """
    h, w = image.shape[:2]
    allc = np.vstack([primer[None, :], colours])
    lab = nearest(image.reshape(-1, 3), allc).reshape(h, w)
    alphas = np.zeros((colours.shape[0], h, w))
    for layer in range(colours.shape[0]):
        alphas[layer][lab == layer + 1] = 1.0
    return alphas
