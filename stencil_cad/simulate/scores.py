"""Scores of a simulated spray against the input (CIEDE2000, PSNR, SSIM)."""

from __future__ import annotations

import math

import numpy as np
from skimage.color import deltaE_ciede2000, rgb2lab
from skimage.metrics import structural_similarity

from .spray import resample

__all__ = ["delta_e_map", "score"]


def score(reference_rgb: np.ndarray, simulated_rgb: np.ndarray) -> dict:
    """Scores of a simulated spray against the input.

    The reference is resampled here to the simulated image's grid when the shapes
    differ (bilinear, anti-aliased); pass it already on that grid to control it.

    Args:
        reference_rgb: ``(H, W, 3)`` sRGB in [0, 1], the input picture.
        simulated_rgb: ``(H', W', 3)`` sRGB in [0, 1], the simulated spray.

    Returns:
        ``de2000_mean``, ``de2000_p95`` (CIEDE2000), ``psnr`` (dB, data range 1) and
        ``ssim`` (on RGB, data range 1).
    """
    sim = np.clip(np.asarray(simulated_rgb, dtype=np.float64), 0.0, 1.0)
    ref = resample(np.clip(np.asarray(reference_rgb, dtype=np.float64), 0.0, 1.0), sim.shape[:2])
    de = deltaE_ciede2000(rgb2lab(ref), rgb2lab(sim))
    small = min(sim.shape[:2])
    win = min(7, small if small % 2 else small - 1)
    if win >= 3:
        ssim = float(structural_similarity(ref, sim, data_range=1.0, channel_axis=2, win_size=win))
    else:
        ssim = float("nan")
    return {
        "de2000_mean": float(np.mean(de)),
        "de2000_p95": float(np.percentile(de, 95)),
        "psnr": _psnr(ref, sim),
        "ssim": ssim,
    }


def _psnr(ref: np.ndarray, sim: np.ndarray) -> float:
    # skimage's peak_signal_noise_ratio, without its divide-by-zero warning for identical images.
    mse = float(np.mean((ref - sim) ** 2))
    return math.inf if mse == 0.0 else 10.0 * math.log10(1.0 / mse)


def delta_e_map(reference_rgb: np.ndarray, simulated_rgb: np.ndarray) -> np.ndarray:
    """Per-pixel CIEDE2000 between two images (reference resampled to the simulated grid)."""
    sim = np.clip(np.asarray(simulated_rgb, dtype=np.float64), 0.0, 1.0)
    ref = resample(np.clip(np.asarray(reference_rgb, dtype=np.float64), 0.0, 1.0), sim.shape[:2])
    return deltaE_ciede2000(rgb2lab(ref), rgb2lab(sim))
