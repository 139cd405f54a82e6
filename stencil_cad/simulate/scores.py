"""Scores of a simulated spray against the input (CIEDE2000, PSNR, SSIM)."""

from __future__ import annotations

import math

import numpy as np
from skimage.color import deltaE_ciede2000, rgb2lab
from skimage.metrics import structural_similarity

from .spray import resample

__all__ = ["delta_e_map", "score", "score_and_map"]

#: Pixels per strip of the pixel scores: a mural's scores hold one strip's colour conversions
#: at a time (CIEDE2000 keeps about 15 float copies of its input) instead of the whole picture's.
STRIP_PIXELS = 1_000_000


def score(reference_rgb: np.ndarray, simulated_rgb: np.ndarray) -> dict:
    """Scores of a simulated spray against the input (:func:`score_and_map`'s scores)."""
    return score_and_map(reference_rgb, simulated_rgb)[0]


def score_and_map(reference_rgb: np.ndarray, simulated_rgb: np.ndarray) -> tuple[dict, np.ndarray]:
    """Scores of a simulated spray against the input, and the per-pixel CIEDE2000 they summarise.

    The map is :func:`delta_e_map`'s, for a caller that shows it too (the job's preview): computed
    once, it saves the bundled example's simulate stage a second CIEDE2000 of the picture (0.2 CPU-s
    of ``delta_e_map`` in the profile of ``python -m cProfile -m stencil_cad run``).

    The reference is resampled here to the simulated image's grid when the shapes
    differ (bilinear, anti-aliased); pass it already on that grid to control it.

    Args:
        reference_rgb: ``(H, W, 3)`` sRGB in [0, 1], the input picture.
        simulated_rgb: ``(H', W', 3)`` sRGB in [0, 1], the simulated spray.

    Returns:
        ``(scores, map)``: ``de2000_mean``, ``de2000_p95`` (CIEDE2000), ``psnr`` (dB, data range 1)
        and ``ssim`` (on RGB, data range 1); the ``(H', W')`` CIEDE2000 per pixel.
    """
    sim = np.clip(np.asarray(simulated_rgb, dtype=np.float64), 0.0, 1.0)
    ref = resample(np.clip(np.asarray(reference_rgb, dtype=np.float64), 0.0, 1.0), sim.shape[:2])
    de = _delta_e(ref, sim)
    small = min(sim.shape[:2])
    win = min(7, small if small % 2 else small - 1)
    ssim = _ssim(ref, sim, win) if win >= 3 else float("nan")
    return {
        "de2000_mean": float(np.mean(de)),
        "de2000_p95": float(np.percentile(de, 95)),
        "psnr": _psnr(ref, sim),
        "ssim": ssim,
    }, de


def _strips(shape: tuple[int, ...], least: int = 1):
    h, w = shape[:2]
    rows = max(STRIP_PIXELS // max(w, 1), least)
    return [(r0, min(r0 + rows, h)) for r0 in range(0, h, rows)]


def _delta_e(ref: np.ndarray, sim: np.ndarray) -> np.ndarray:
    """Per-pixel CIEDE2000 of two sRGB images, a strip of rows at a time."""
    out = np.empty(sim.shape[:2])
    for r0, r1 in _strips(sim.shape):
        out[r0:r1] = deltaE_ciede2000(rgb2lab(ref[r0:r1]), rgb2lab(sim[r0:r1]))
    return out


def _ssim(ref: np.ndarray, sim: np.ndarray, win: int) -> float:
    """scikit-image's mean SSIM (RGB, data range 1, ``win`` × ``win`` window), a strip of rows at a time.

    Each strip carries ``win // 2`` rows of the picture on either side, so its local SSIM
    equals the whole picture's; the mean is over the same pixels scikit-image averages
    (``win // 2`` from every border excluded), channel by channel.
    """
    pad = win // 2
    h, w = sim.shape[:2]
    if h <= 2 * pad or w <= 2 * pad:
        return float(structural_similarity(ref, sim, data_range=1.0, channel_axis=2, win_size=win))
    means = []
    for c in range(sim.shape[2]):
        total, count = 0.0, 0
        for r0, r1 in _strips(sim.shape, least=win):
            a, b = max(r0 - pad, 0), min(r1 + pad, h)
            if b - a < win:
                a = max(b - win, 0)
            _, local = structural_similarity(
                ref[a:b, :, c], sim[a:b, :, c], data_range=1.0, win_size=win, full=True
            )
            lo, hi = max(r0, pad), min(r1, h - pad)
            if hi > lo:
                part = local[lo - a : hi - a, pad : w - pad]
                total += float(part.sum())
                count += part.size
        means.append(total / count)
    return float(np.mean(means))


def _psnr(ref: np.ndarray, sim: np.ndarray) -> float:
    # skimage's peak_signal_noise_ratio, without its divide-by-zero warning for identical images.
    mse = float(np.mean((ref - sim) ** 2))
    return math.inf if mse == 0.0 else 10.0 * math.log10(1.0 / mse)


def delta_e_map(reference_rgb: np.ndarray, simulated_rgb: np.ndarray) -> np.ndarray:
    """Per-pixel CIEDE2000 between two images (reference resampled to the simulated grid)."""
    sim = np.clip(np.asarray(simulated_rgb, dtype=np.float64), 0.0, 1.0)
    ref = resample(np.clip(np.asarray(reference_rgb, dtype=np.float64), 0.0, 1.0), sim.shape[:2])
    return _delta_e(ref, sim)
