"""S-CIELAB: colour difference as a viewer sees it from a distance (Zhang & Wandell 1997).

A pixel-by-pixel CIEDE2000 scores every paint dot as an error, however far away the
viewer stands. S-CIELAB first blurs both images the way the eye does, then compares
them with CIEDE2000:

1. sRGB -> CIE XYZ (D65) -> the opponent space of Poirson & Wandell (1993): one
   luminance and two chromatic channels (red-green, blue-yellow);
2. each channel is convolved with its own sum of Gaussians whose widths are angles
   of the visual field (degrees). The chromatic channels blur far more than the
   luminance one: the eye resolves fine luminance detail but little fine colour;
3. back to XYZ, then CIELAB (D65 white) and CIEDE2000 per pixel; the score is the
   mean.

The widths are given in degrees, so the pixel pitch (mm per px) and the viewing
distance set them in pixels: ``samples per degree = D tan(1°) / pitch``. The widths
(full width at half maximum, degrees) and weights are those of the authors' reference
implementation:

============  ======================================  ==============================
channel       FWHM (degrees)                          weights
============  ======================================  ==============================
luminance     0.05, 0.225, 7.0                        1.00327, 0.114416, -0.117686
red-green     0.0685, 0.826                           0.616725, 0.383275
blue-yellow   0.0920, 0.6451                          0.567885, 0.432115
============  ======================================  ==============================

Every Gaussian is normalised to unit sum, so each channel's filter preserves a flat
field (the weights sum to 1). When the grid's pixels are coarser than the narrowest
Gaussian (its standard deviation under :data:`MIN_SIGMA_PX` pixels) the images are
upsampled (each pixel repeated, as a printed or displayed pixel is a flat square)
before filtering, so the kernel is sampled finely enough. Gaussians much wider
than :data:`DIRECT_SIGMA_PX` pixels are applied on a block-averaged copy and
interpolated back (they are smooth on that scale; measured error below 1e-3 ΔE on
the bundled example).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = [
    "DEFAULT_DISTANCE_M",
    "FILTERS",
    "samples_per_degree",
    "scielab",
    "scielab_filter",
    "scielab_map",
    "smallest_sigma_mm",
    "view_scores",
]

#: Default viewing distance in metres (a picture on a wall seen from across a room).
DEFAULT_DISTANCE_M = 1.0

#: XYZ (Y of white = 1) to the opponent space (luminance, red-green, blue-yellow),
#: CIE 1931 2° observer, from the reference implementation of S-CIELAB.
XYZ_TO_OPP = np.array(
    [
        [0.2787336, 0.7218031, -0.1065520],
        [-0.4487736, 0.2898056, 0.0771569],
        [0.0859513, -0.5899859, 0.5011089],
    ]
)
OPP_TO_XYZ = np.linalg.inv(XYZ_TO_OPP)

#: Per opponent channel: ((FWHM in degrees, weight), ...).
FILTERS: tuple[tuple[tuple[float, float], ...], ...] = (
    ((0.05, 1.00327), (0.225, 0.114416), (7.0, -0.117686)),
    ((0.0685, 0.616725), (0.826, 0.383275)),
    ((0.0920, 0.567885), (0.6451, 0.432115)),
)

#: Upsample when the narrowest Gaussian's standard deviation is below this, in pixels.
MIN_SIGMA_PX = 1.0
#: Largest upsampling factor.
MAX_UPSAMPLE = 8
#: Gaussians wider than this (standard deviation, px) are applied on a block-averaged copy.
DIRECT_SIGMA_PX = 24.0

_FWHM_TO_SIGMA = 1.0 / (2.0 * math.sqrt(2.0 * math.log(2.0)))


def samples_per_degree(mm_per_px: float, distance_m: float) -> float:
    """Pixels per degree of visual angle for a pixel pitch seen from a distance.

    Args:
        mm_per_px: Pixel pitch in mm.
        distance_m: Viewing distance in metres.

    Returns:
        ``1000 D tan(1°) / pitch``.
    """
    if not (mm_per_px > 0 and distance_m > 0):
        raise ValueError(f"mm_per_px and distance_m must be > 0, got {mm_per_px} and {distance_m}")
    return 1000.0 * distance_m * math.tan(math.radians(1.0)) / mm_per_px


def smallest_sigma_mm(distance_m: float) -> float:
    """Standard deviation in mm of the eye's narrowest (luminance) Gaussian at a distance."""
    fwhm_deg = min(w for ch in FILTERS for w, _ in ch)
    return 1000.0 * distance_m * math.tan(math.radians(fwhm_deg)) * _FWHM_TO_SIGMA


def _srgb_to_opp(rgb: np.ndarray) -> np.ndarray:
    from skimage.color import rgb2xyz

    return rgb2xyz(np.clip(rgb, 0.0, 1.0)) @ XYZ_TO_OPP.T


def _gaussian(channel: np.ndarray, sigma_px: float) -> np.ndarray:
    from scipy.ndimage import gaussian_filter
    from skimage.transform import resize

    if sigma_px <= DIRECT_SIGMA_PX:
        return gaussian_filter(channel, sigma_px, mode="reflect", truncate=4.0)
    # A wide Gaussian is smooth at the scale of a few of its sigma: filter a block-averaged
    # copy (a quarter of the block size per sigma is ample) and interpolate back.
    f = max(int(sigma_px // (DIRECT_SIGMA_PX / 3.0)), 2)
    small_shape = (max(1, channel.shape[0] // f), max(1, channel.shape[1] // f))
    small = resize(channel, small_shape, order=1, anti_aliasing=True, mode="reflect")
    fy = channel.shape[0] / small_shape[0]
    fx = channel.shape[1] / small_shape[1]
    small = gaussian_filter(small, (sigma_px / fy, sigma_px / fx), mode="reflect", truncate=4.0)
    return resize(small, channel.shape, order=1, mode="reflect")


def _upsample_factor(mm_per_px: float, distance_m: float) -> int:
    spd = samples_per_degree(mm_per_px, distance_m)
    narrow = min(w for ch in FILTERS for w, _ in ch) * spd * _FWHM_TO_SIGMA
    if narrow >= MIN_SIGMA_PX:
        return 1
    return int(min(MAX_UPSAMPLE, math.ceil(MIN_SIGMA_PX / narrow)))


def scielab_filter(rgb: np.ndarray, mm_per_px: float, distance_m: float) -> np.ndarray:
    """The image as the eye sees it from ``distance_m``, in CIE XYZ (Y of white = 1).

    Args:
        rgb: ``(H, W, 3)`` sRGB in [0, 1].
        mm_per_px: Pixel pitch of ``rgb`` in mm.
        distance_m: Viewing distance in metres.

    Returns:
        ``(k H, k W, 3)`` filtered XYZ, ``k`` the upsampling factor (1 unless the grid
        undersamples the narrowest Gaussian).
    """
    rgb = np.asarray(rgb, dtype=np.float64)
    if rgb.ndim != 3 or rgb.shape[2] != 3:
        raise ValueError(f"rgb must be (H, W, 3), got shape {rgb.shape}")
    k = _upsample_factor(mm_per_px, distance_m)
    if k > 1:
        rgb = np.repeat(np.repeat(rgb, k, axis=0), k, axis=1)
    spd = samples_per_degree(mm_per_px / k, distance_m)
    opp = _srgb_to_opp(rgb)
    out = np.zeros_like(opp)
    for c, gaussians in enumerate(FILTERS):
        for fwhm_deg, weight in gaussians:
            out[..., c] += weight * _gaussian(opp[..., c], fwhm_deg * spd * _FWHM_TO_SIGMA)
    return out @ OPP_TO_XYZ.T


def scielab_map(
    reference_rgb: np.ndarray, test_rgb: np.ndarray, mm_per_px: float, distance_m: float
) -> np.ndarray:
    """Per-pixel S-CIELAB ΔE (CIEDE2000 of the filtered images).

    Args:
        reference_rgb: ``(H, W, 3)`` sRGB in [0, 1].
        test_rgb: ``(H, W, 3)`` sRGB in [0, 1], same shape.
        mm_per_px: Pixel pitch of both images in mm.
        distance_m: Viewing distance in metres.

    Returns:
        ``(k H, k W)`` ΔE map (``k`` as in :func:`scielab_filter`).
    """
    from skimage.color import deltaE_ciede2000, xyz2lab

    ref = np.asarray(reference_rgb, dtype=np.float64)
    test = np.asarray(test_rgb, dtype=np.float64)
    if ref.shape != test.shape:
        raise ValueError(f"images differ in shape: {ref.shape} and {test.shape}")
    lab_ref = xyz2lab(scielab_filter(ref, mm_per_px, distance_m))
    lab_test = xyz2lab(scielab_filter(test, mm_per_px, distance_m))
    return deltaE_ciede2000(lab_ref, lab_test)


def scielab(reference_rgb: np.ndarray, test_rgb: np.ndarray, mm_per_px: float, distance_m: float) -> float:
    """Mean S-CIELAB ΔE between two images of the same grid seen from ``distance_m``.

    Args:
        reference_rgb: ``(H, W, 3)`` sRGB in [0, 1].
        test_rgb: ``(H, W, 3)`` sRGB in [0, 1], same shape.
        mm_per_px: Pixel pitch of both images in mm.
        distance_m: Viewing distance in metres.

    Returns:
        The mean ΔE (0 for identical images).
    """
    return float(np.mean(scielab_map(reference_rgb, test_rgb, mm_per_px, distance_m)))


def view_scores(reference_rgb: np.ndarray, test_rgb: np.ndarray, mm_per_px: float, distance_m: float) -> dict:
    """S-CIELAB at the viewing distance and at twice it, for the manifest and the summary.

    Args:
        reference_rgb: ``(H, W, 3)`` sRGB in [0, 1].
        test_rgb: ``(H, W, 3)`` sRGB in [0, 1], same shape.
        mm_per_px: Pixel pitch of both images in mm.
        distance_m: Viewing distance in metres.

    Returns:
        ``view_distance_m``, ``scielab`` (at the distance) and ``scielab_2x`` (at twice it).
    """
    return {
        "view_distance_m": float(distance_m),
        "scielab": scielab(reference_rgb, test_rgb, mm_per_px, distance_m),
        "scielab_2x": scielab(reference_rgb, test_rgb, mm_per_px, 2.0 * distance_m),
    }
