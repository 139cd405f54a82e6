"""Palette helpers: luminance order, nearest paint, the starting opacities."""

from __future__ import annotations

import numpy as np

# Rec. 709 luma weights; only used to sort paints light to dark.
_LUMA = np.array([0.2126, 0.7152, 0.0722])


def luminance(colours: np.ndarray) -> np.ndarray:
    """Relative luminance of ``(..., 3)`` RGB colours in [0, 1]."""
    return np.asarray(colours, dtype=np.float64) @ _LUMA


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
