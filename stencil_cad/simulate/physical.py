"""The physical spray model: stand-off, can distance and passes, with constants a card measures.

A can swept over a stencil held ``g`` mm off the surface (the wall's stand-off) paints
each point from a spread of directions. If that spread has tan-sigma ``k``
(``spray.can.spread_k``), the image of every hole is blurred by a Gaussian of
``sigma = k g``, whatever the hole's radius; a floor ``sigma_0``
(``spray.can.bleed_sigma_mm``) covers wetting and bleed under the plate:

    sigma^2 = sigma_0^2 + (k g)^2.

The paint that reaches the surface through hole ``i`` (radius ``r_i``, centre ``c_i``) is
the hole's disc blurred by that Gaussian, times the share ``T_i`` of droplets that the
plate's thickness ``t`` does not shade (:func:`plate_transmission`). ``n`` passes at a
can distance ``d`` and speed ``v`` leave the optical depth (dose)

    E(x) = n beta (d_ref / d) (v_ref / v) sum_i T_i (disc(r_i) * G_sigma)(x - c_i),

with ``beta`` (``spray.can.deposit_per_pass``) the depth one pass leaves on open surface
at the distance ``d_ref`` and speed ``v_ref`` it was measured at (a sweeping fan's
deposit falls as 1 / distance and 1 / speed). Paint builds up like random droplet cover
(Kubelka-Munk hiding), so the opacity is

    alpha(x) = 1 - exp(-E(x)).

Because ``sigma`` is the same for every hole of a layer, the dose is one linear filter of
the stencil's open area: the holes' discs are rasterised with their exact areas and
blurred by one Gaussian (:func:`physical_opacity`). That is exact up to the raster and
fast (two separable passes), so this model needs no truncated per-hole splat.

The paper's model maps onto this one by ``h_eq = 4 (r^2 / 4 + sigma^2) / r^2 - 1``
(the variance of a disc is ``r^2 / 4``).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numba
import numpy as np

from ..config.spray import SprayConfig
from ..filters import gaussian
from ..frames import mm_to_px
from .kept import Kept, digest

__all__ = [
    "SprayGeometry",
    "disc_profile",
    "dose_per_pass",
    "gaussian_kernel_error",
    "physical_hole_kernels",
    "physical_mask_opacity",
    "physical_opacity",
    "plate_transmission",
    "spread_sigma_mm",
    "transmission_and_slope",
]

#: Sub-samples across a hole's radius when rasterising its disc (2 to 8 per pixel side; each disc
#: is then scaled to its exact area, so only the shape, which the blur hides, is approximate).
_SUBSAMPLES_PER_RADIUS = 24


@dataclass(frozen=True)
class SprayGeometry:
    """Where the plate is while the layer is sprayed.

    Attributes:
        standoff_mm: Gap in mm between the plate's underside and the surface (``wall.standoff_mm``).
        plate_thickness_mm: Plate thickness in mm (``plate.thickness_mm``); it shades oblique droplets.
    """

    standoff_mm: float
    plate_thickness_mm: float

    def __post_init__(self) -> None:
        if not self.standoff_mm >= 0.0:
            raise ValueError(f"standoff_mm must be ≥ 0, got {self.standoff_mm}")
        if not self.plate_thickness_mm >= 0.0:
            raise ValueError(f"plate_thickness_mm must be ≥ 0, got {self.plate_thickness_mm}")

    @classmethod
    def of_job(cls, job_cfg, standoff_mm: float | None = None) -> SprayGeometry:
        """The geometry of a job: its first (design) stand-off unless another is given.

        Args:
            job_cfg: The :class:`~stencil_cad.config.JobConfig`: the plan's, its plate thickness filled in
                (a config not planned: the thickness it fills in for the plate size it knows).
            standoff_mm: A stand-off in mm. Defaults to the job's design stand-off
                (``JobConfig.standoff.design_mm``), the one the tone calibration designs the dots for.

        Returns:
            The geometry.
        """
        from ..config.job import job_thickness

        g = float(job_cfg.standoff.design_mm if standoff_mm is None else standoff_mm)
        # The plan's thickness; a config not planned (a calibration alone, a test): the one it fills in.
        return cls(standoff_mm=g, plate_thickness_mm=job_thickness(job_cfg).thickness_mm)

    @classmethod
    def for_job(cls, job_cfg, standoff_mm: float | None = None) -> SprayGeometry | None:
        """:meth:`of_job` under a spray model that sees the wall (the physical one); None under the paper's."""
        return cls.of_job(job_cfg, standoff_mm) if job_cfg.spray.has_wall else None


def spread_sigma_mm(cfg: SprayConfig, standoff_mm: float) -> float:
    """Blur of every hole's image: ``sqrt(sigma_0^2 + (k g)^2)`` in mm.

    Args:
        cfg: Spray settings (``can.spread_k``, ``can.bleed_sigma_mm``).
        standoff_mm: Gap g in mm.

    Returns:
        sigma in mm.
    """
    k, s0 = cfg.can.spread_k, cfg.can.bleed_sigma_mm
    return math.sqrt(s0 * s0 + (k * standoff_mm) ** 2)


def dose_per_pass(cfg: SprayConfig) -> float:
    """Optical depth one pass leaves on open surface at the job's can distance and speed.

    ``beta (d_ref / d) (v_ref / v)``: ``spray.can.deposit_per_pass`` carried from the distance and
    speed it was measured at to ``spray.can_distance_mm`` and ``spray.pass_speed_m_s``.

    Args:
        cfg: Spray settings.

    Returns:
        Optical depth per pass (dimensionless).
    """
    return cfg.dose_per_pass


def _lens_fraction(u: np.ndarray) -> np.ndarray:
    """Overlap of two equal discs whose centres are ``2 r u`` apart, as a share of one disc."""
    u = np.clip(u, 0.0, 1.0)
    return (2.0 / math.pi) * (np.arccos(u) - u * np.sqrt(1.0 - u * u))


# Gauss-Legendre nodes on [0, 1] for the shading integral over the offset d in [0, 2r].
_GL_X, _GL_W = np.polynomial.legendre.leggauss(64)
_GL_X = 0.5 * (_GL_X + 1.0)
_GL_W = 0.5 * _GL_W
_GL_W2 = _GL_W * 2.0
_GL_LENS = _lens_fraction(_GL_X)


def plate_transmission(r_mm: np.ndarray | float, thickness_mm: float, spread_k: float) -> np.ndarray:
    """Share of the paint aimed at a hole that passes a plate of thickness t (oblique droplets are shaded).

    A droplet arriving with slope ``s`` (2-D, each component ``N(0, k^2)``) crosses the plate
    displaced by ``|s| t``; it passes if it enters the hole's top disc and leaves through the bottom
    disc, so the open share is the overlap of two discs of radius r offset by ``d = |s| t``. ``d`` is
    Rayleigh with scale ``k t``:

        T(r) = E_d[lens(d / 2 r)],  lens(u) = (2 / pi) (acos u - u sqrt(1 - u^2)).

    At k = 0.15 a 1.2 mm plate passes 72 % through a hole of r = 0.5 mm and 86 % at r = 1 mm.

    Args:
        r_mm: Hole radius (or radii) in mm, > 0.
        thickness_mm: Plate thickness t in mm.
        spread_k: Angular spread k (tan sigma).

    Returns:
        T in (0, 1], same shape as ``r_mm``.
    """
    r = np.asarray(r_mm, dtype=np.float64)
    s = spread_k * thickness_mm
    if s <= 0.0:
        return np.ones_like(r)
    d = 2.0 * r[..., None] * _GL_X  # offsets over [0, 2r]; beyond 2r nothing passes
    # The refinement asks for every hole three times a step: the same operations as
    # d / s² · exp(-d² / 2s²) · 2 w r · lens, in place (the same bits, a quarter less time).
    pdf = d / (s * s)
    e = np.negative(d)
    e *= d
    e /= 2.0 * s * s
    pdf *= np.exp(e, out=e)
    out = _GL_W2 * r[..., None]
    out *= pdf
    out *= _GL_LENS
    return np.sum(out, axis=-1)


#: ``log(r / (k t))`` at the nodes of the table of :func:`transmission_and_slope`. The open share is a
#: function of ``x = r / (k t)`` alone: the plate sets ``d = k t D`` with ``D`` Rayleigh of scale 1. The
#: table holds it for ``x`` from 0.05 to 500 (a 0.25 mm hole under a 3 mm plate at k = 0.3 is 0.28,
#: a 3 mm hole under a 0.5 mm plate at k = 0.05 is 120); outside, the quadrature runs as it is.
_LOG_X = np.linspace(math.log(0.05), math.log(500.0), 4097)


def _open_share(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`plate_transmission`'s quadrature as a function of ``x = r / (k t)``, and its slope in ``log x``.

    With ``d = 2 r X_i``: ``T = sum_i 4 W_i X_i lens_i x^2 exp(-2 x^2 X_i^2)``, whose derivative in
    ``x`` is ``sum_i 4 W_i X_i lens_i (2 x - 4 x^3 X_i^2) exp(-2 x^2 X_i^2)``.
    """
    x = np.asarray(x, dtype=np.float64)[..., None]
    c = 4.0 * _GL_W * _GL_X * _GL_LENS
    e = c * np.exp(-2.0 * x * x * _GL_X * _GL_X)
    share = np.sum(e * x * x, axis=-1)
    slope = np.sum(e * (2.0 * x - 4.0 * x**3 * _GL_X * _GL_X), axis=-1) * x[..., 0]
    return share, slope


@functools.cache
def _open_share_table():
    """The open share's cubic Hermite interpolant in ``log x`` over :data:`_LOG_X` (values and slopes exact at the nodes)."""
    from scipy.interpolate import CubicHermiteSpline

    share, slope = _open_share(np.exp(_LOG_X))
    return CubicHermiteSpline(_LOG_X, share, slope, extrapolate=False)


def transmission_and_slope(
    r_mm: np.ndarray, thickness_mm: float, spread_k: float
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`plate_transmission` of each radius and its derivative in the radius (1/mm).

    The refinement asks for both at every hole three times a step. They are read off a table of the
    quadrature's values and exact slopes (:func:`_open_share`), interpolated by scipy's cubic Hermite
    spline: values within 2e-13 of the quadrature's up to ``x = 100`` (1e-11 up to 500), slopes within
    2e-9 of its exact derivative (the central difference used before was 1e-8 off). For 4,000 distinct
    radii the quadrature's value and central difference took 3.8 ms, the table 0.54 ms
    (``time.process_time`` over 200 calls); the example job's hole kernels, 1.5 CPU-s before, 0.6 now.
    """
    r = np.asarray(r_mm, dtype=np.float64)
    s = spread_k * thickness_mm
    if s <= 0.0:
        return np.ones_like(r), np.zeros_like(r)
    u = np.log(r / s)
    table = _open_share_table()
    share = table(u)
    slope = table(u, 1)
    out = ~((u >= _LOG_X[0]) & (u <= _LOG_X[-1]))
    if out.any():
        share[out], slope[out] = _open_share(r[out] / s)
    return share, slope / r


def disc_profile(rho_mm: np.ndarray, r_mm: float, sigma_mm: float) -> np.ndarray:
    """Exact ``(disc(r) * G_sigma)(rho)``: the share of a Gaussian centred ``rho`` from the disc's centre inside it.

    This is the Marcum Q function: ``P(rho) = ncx2.cdf((r / sigma)^2, 2, (rho / sigma)^2)``.

    Args:
        rho_mm: Distances from the hole's centre in mm.
        r_mm: Hole radius in mm.
        sigma_mm: Gaussian sigma in mm, > 0.

    Returns:
        Values in [0, 1], shape of ``rho_mm`` (1 at the centre of a large hole, 1/2 on its edge).
    """
    from scipy.stats import ncx2

    rho = np.asarray(rho_mm, dtype=np.float64)
    return ncx2.cdf((r_mm / sigma_mm) ** 2, 2.0, (rho / sigma_mm) ** 2)


@numba.njit(cache=True)
def _covered(r, c, cy, cx, R, ss):  # pragma: no cover - compiled
    """How many of pixel (r, c)'s ``ss x ss`` sub-samples lie in the disc of radius R at (cy, cx)."""
    n = 0
    for a in range(ss):
        dy = r - 0.5 + (a + 0.5) / ss - cy
        for b in range(ss):
            dx = c - 0.5 + (b + 0.5) / ss - cx
            if dx * dx + dy * dy <= R * R:
                n += 1
    return n


@numba.njit(cache=True)
def _raster_open_area(img, cy, cx, rad, weight, per_radius):  # pragma: no cover - compiled
    """Add each disc's exact area (times ``weight``), spread over the pixels it covers, to ``img``.

    Coverage is counted on ``ss x ss`` sub-samples per pixel (``ss`` from ``per_radius``), then scaled
    so every disc adds exactly ``weight pi rad^2`` (in pixel units): the blur that follows hides the
    sub-pixel shape, never the amount of paint.
    """
    h, w = img.shape
    for i in range(cy.shape[0]):
        R = rad[i]
        ss = min(8, max(2, int(math.ceil(per_radius / max(R, 1e-9)))))
        rr0 = int(math.floor(cy[i] - R - 0.5))
        rr1 = int(math.ceil(cy[i] + R + 0.5))
        cc0 = int(math.floor(cx[i] - R - 0.5))
        cc1 = int(math.ceil(cx[i] + R + 0.5))
        # A disc may be clipped by the raster edge: scale by the full disc's sub-sample count. Each
        # pixel's count is kept for the spread below rather than counted again (the same counts).
        counts = np.empty((rr1 - rr0 + 1, cc1 - cc0 + 1), dtype=np.int64)
        full = 0
        for r in range(rr0, rr1 + 1):
            for c in range(cc0, cc1 + 1):
                n = _covered(r, c, cy[i], cx[i], R, ss)
                counts[r - rr0, c - cc0] = n
                full += n
        if full == 0:
            # A disc smaller than the sub-sample spacing: all of it in its centre pixel.
            rc = int(math.floor(cy[i] + 0.5))
            cc = int(math.floor(cx[i] + 0.5))
            if 0 <= rc < h and 0 <= cc < w:
                img[rc, cc] += weight[i] * math.pi * R * R
            continue
        scale = weight[i] * math.pi * R * R / full
        for r in range(max(0, rr0), min(h - 1, rr1) + 1):
            for c in range(max(0, cc0), min(w - 1, cc1) + 1):
                n = counts[r - rr0, c - cc0]
                if n:
                    img[r, c] += scale * n


def holes_array(xy_mm, r_mm) -> tuple[np.ndarray, np.ndarray]:
    """Hole centres ``(N, 2)`` and radii ``(N,)`` as float arrays, checked.

    Raises:
        ValueError: A radius ≤ 0 or not finite, or a centre not finite.
    """
    xy = np.asarray(xy_mm, dtype=np.float64).reshape(-1, 2)
    r = np.broadcast_to(np.asarray(r_mm, dtype=np.float64), (xy.shape[0],)).copy()
    if np.any(r <= 0.0) or not np.all(np.isfinite(r)):
        raise ValueError("every hole radius must be a finite value > 0 mm")
    if not np.all(np.isfinite(xy)):
        raise ValueError("hole centres must be finite")
    return xy, r


def _blur(img: np.ndarray, sigma_px: float, mm_per_px: float) -> np.ndarray:
    # The box of one pixel already adds a variance of 1/12 px^2 per axis.
    s = math.sqrt(max(sigma_px * sigma_px - 1.0 / 12.0, 0.0))
    if s <= 0.0:
        return img
    # Paint sprayed past the raster edge is lost, not reflected back.
    return gaussian(img, s, mode="constant", truncate=5.0)


def physical_opacity(
    xy_mm: np.ndarray,
    r_mm: np.ndarray | float,
    shape_hw: tuple[int, int],
    mm_per_px: float,
    cfg: SprayConfig,
    geometry: SprayGeometry,
    passes: float,
    *,
    exact: bool = False,
    crop: tuple[int, int, int, int] | None = None,
) -> np.ndarray:
    """The opacity one stencil sprays under the physical model: ``1 - exp(-E)``.

    Args:
        xy_mm: ``(N, 2)`` hole centres in mm (picture frame, y up).
        r_mm: ``(N,)`` hole radii in mm, or one radius for all.
        shape_hw: ``(H, W)`` of the raster.
        mm_per_px: Raster pixel size in mm.
        cfg: Spray settings (``can``, ``can_distance_mm``, ``pass_speed_m_s``).
        geometry: Stand-off and plate thickness.
        passes: Passes n of the can for this layer (> 0).
        exact: Evaluate the exact disc-Gaussian profile of every hole at every pixel centre (slow
            reference) instead of rasterising and blurring. Defaults to False.
        crop: ``(row0, row1, col0, col1)``: return only this window of the raster.

    Returns:
        ``(H, W)`` (or the crop's shape) ndarray of float in [0, 1].

    Raises:
        ValueError: passes ≤ 0, a radius ≤ 0, or non-finite centres.
    """
    if not passes > 0.0:
        raise ValueError(f"passes must be > 0, got {passes}")
    if exact or crop is not None:
        dose = physical_dose(xy_mm, r_mm, shape_hw, mm_per_px, cfg, geometry, exact=exact, crop=crop)
    else:
        dose = _kept_dose(xy_mm, r_mm, shape_hw, mm_per_px, cfg, geometry)
    return opacity_of_dose(dose, passes * dose_per_pass(cfg))


#: The whole raster's doses of the last few :func:`physical_opacity` calls, by the holes, the raster,
#: the blur and the plate: a dose does not depend on the passes, and a job sprays the same holes at
#: several passes (the sweep card's factors) and under cans of the same spread. A simulation asks
#: for its plates' doses in turn, so the cache holds two simulations' worth of the most plates a job
#: has (16: 8 layers, each a light and a dark plate), within 256 MB: with 6 kept, the 8 plates of
#: the bundled example pushed each other out and all 56 doses of its simulate stage were computed
#: (1.57 CPU-s); now 24 are, the sweep's factors and each cap's light and heavy coat sharing theirs
#: (the stage's ``physical_dose`` calls under ``python -m cProfile -m stencil_cad run``).
_DOSE_CACHE = Kept(32, max_bytes=256 * 2**20)


def _kept_dose(
    xy_mm, r_mm, shape_hw, mm_per_px: float, cfg: SprayConfig, geometry: SprayGeometry
) -> np.ndarray:
    """:func:`physical_dose` over the whole raster, computed once for the same holes, raster, blur and plate (read-only)."""

    def make() -> np.ndarray:
        dose = physical_dose(xy_mm, r_mm, shape_hw, mm_per_px, cfg, geometry)
        dose.setflags(write=False)
        return dose

    key = (
        digest(*holes_array(xy_mm, r_mm)),
        int(shape_hw[0]),
        int(shape_hw[1]),
        float(mm_per_px),
        spread_sigma_mm(cfg, geometry.standoff_mm),
        float(geometry.plate_thickness_mm),
        float(cfg.can.spread_k),
    )
    return _DOSE_CACHE.get(key, make)


def opacity_of_dose(dose: np.ndarray, depth: float) -> np.ndarray:
    """``1 - exp(-depth * dose)`` in [0, 1]: the opacity of :func:`physical_dose`'s field at optical depth ``depth``."""
    out = -np.expm1(-depth * np.maximum(dose, 0.0))
    return np.clip(out, 0.0, 1.0, out=out)


def physical_dose(
    xy_mm: np.ndarray,
    r_mm: np.ndarray | float,
    shape_hw: tuple[int, int],
    mm_per_px: float,
    cfg: SprayConfig,
    geometry: SprayGeometry,
    *,
    exact: bool = False,
    crop: tuple[int, int, int, int] | None = None,
) -> np.ndarray:
    """The paint one pass of unit depth leaves through the holes: ``sum_i T_i (disc_i * G_sigma)``.

    It does not depend on the passes or the dose per pass, so a caller that compares doses (the tone
    calibration) computes it once and maps it with :func:`opacity_of_dose` for each.

    Args:
        xy_mm: ``(N, 2)`` hole centres in mm (picture frame, y up).
        r_mm: ``(N,)`` hole radii in mm, or one radius for all.
        shape_hw: ``(H, W)`` of the raster.
        mm_per_px: Raster pixel size in mm.
        cfg: Spray settings (the can's spread and bleed).
        geometry: Stand-off and plate thickness.
        exact: Evaluate the exact disc-Gaussian profile of every hole at every pixel centre.
        crop: ``(row0, row1, col0, col1)``: return only this window of the raster.

    Returns:
        ``(H, W)`` (or the crop's shape) ndarray of float, >= 0 up to rounding.
    """
    xy_mm, r = holes_array(xy_mm, r_mm)
    h, w = int(shape_hw[0]), int(shape_hw[1])
    sigma = spread_sigma_mm(cfg, geometry.standoff_mm)
    # Each radius once (a response patch's holes share one, a refined layer's mostly sit at the floor):
    # each hole's share is a function of its own radius, so the same bits.
    radii, of_radius = np.unique(r, return_inverse=True)
    weight = plate_transmission(radii, geometry.plate_thickness_mm, cfg.can.spread_k)[of_radius]
    r0, r1, c0, c1 = (0, h, 0, w) if crop is None else (int(v) for v in crop)
    if not (0 <= r0 < r1 <= h and 0 <= c0 < c1 <= w):
        raise ValueError(f"crop {crop} must satisfy 0 ≤ r0 < r1 ≤ {h} and 0 ≤ c0 < c1 ≤ {w}")
    rc = mm_to_px(xy_mm, h, mm_per_px) if len(r) else np.zeros((0, 2))
    if exact:
        rows, cols = np.mgrid[r0:r1, c0:c1]
        dose = np.zeros(rows.shape)
        for i in range(len(r)):
            rho = np.hypot(rows - rc[i, 0], cols - rc[i, 1]) * mm_per_px
            dose += weight[i] * disc_profile(rho, r[i], sigma)
    else:
        # Rasterise with a margin beyond the raster (or crop), so the part of a disc past its edge
        # still blurs paint inside, and paint from holes just outside a crop still arrives.
        pad = int(math.ceil(5.0 * sigma / mm_per_px + float(r.max(initial=0.0)) / mm_per_px)) + 2
        a0, a1, b0, b1 = r0 - pad, r1 + pad, c0 - pad, c1 + pad
        area = np.zeros((a1 - a0, b1 - b0), dtype=np.float64)
        if len(r):
            _raster_open_area(
                area,
                np.ascontiguousarray(rc[:, 0] - a0),
                np.ascontiguousarray(rc[:, 1] - b0),
                r / mm_per_px,
                weight,
                float(_SUBSAMPLES_PER_RADIUS),
            )
        dose = _blur(area, sigma / mm_per_px, mm_per_px)[r0 - a0 : r1 - a0, c0 - b0 : c1 - b0]
    return dose


def physical_mask_opacity(
    mask: np.ndarray, mm_per_px: float, cfg: SprayConfig, geometry: SprayGeometry, passes: float
) -> np.ndarray:
    """Spray through a cut-out given as a raster of its open area (hard stencils), physical model.

    ``1 - exp(-n d (mask * G_sigma))``; a cut-out is wide, so the plate's shading of its edge is
    neglected (T = 1).

    Args:
        mask: ``(H, W)`` bool, True where the stencil is open.
        mm_per_px: Pixel size in mm.
        cfg: Spray settings.
        geometry: Stand-off and plate thickness.
        passes: Passes of the can.

    Returns:
        ``(H, W)`` opacity in [0, 1].
    """
    if not passes > 0.0:
        raise ValueError(f"passes must be > 0, got {passes}")
    m = np.asarray(mask, dtype=np.float64)
    if m.ndim != 2:
        raise ValueError(f"mask must be (H, W), got shape {m.shape}")
    dose = _blur(m, spread_sigma_mm(cfg, geometry.standoff_mm) / mm_per_px, mm_per_px)
    return np.clip(-np.expm1(-passes * dose_per_pass(cfg) * dose), 0.0, 1.0)


def gaussian_kernel_error(r_over_sigma: float) -> float:
    """Largest error of the matched Gaussian against the exact disc-Gaussian dot, as a share of its peak.

    The Gaussian has the dot's variance ``r^2 / 4 + sigma^2`` and its integral ``pi r^2``;
    the error is ``max_rho |gauss(rho) - disc_profile(rho)| / disc_profile(0)``.

    Args:
        r_over_sigma: Hole radius over the blur sigma.

    Returns:
        The relative error (0 for a point-like hole).
    """
    r, sigma = float(r_over_sigma), 1.0
    rho = np.linspace(0.0, r + 6.0, 2001)
    exact = disc_profile(rho, r, sigma)
    s2 = r * r / 4.0 + sigma * sigma
    gauss = r * r / (2.0 * s2) * np.exp(-rho * rho / (2.0 * s2))
    return float(np.max(np.abs(gauss - exact)) / exact[0])


def physical_hole_kernels(
    r_mm: np.ndarray | float, cfg: SprayConfig, passes: float, geometry: SprayGeometry
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each hole's dose as one Gaussian: ``N_i(p) = peak_i exp(-|p - c_i|^2 / (2 sigma_i^2))``, combined by ``exp``.

    ``disc(r) * G_sigma`` is replaced by the Gaussian of the same variance,
    ``sigma_i^2 = r_i^2 / 4 + sigma^2``, and the same integral, ``n d T_i pi r_i^2``, so
    ``peak_i = n d T_i r_i^2 / (2 sigma_i^2)`` (optical depth, ``beta`` folded in). The opacity is
    then ``1 - exp(-sum_i N_i)``. The error of the approximation, as a share of the dot's exact
    peak (:func:`gaussian_kernel_error`, tested), grows with ``r / sigma``: 0.01 % at r/sigma = 0.25,
    0.1 % at 0.5, 1.7 % at 1, 6.6 % at 1.5, 16 % at 2, 40 % at 3 (a large, sharp hole has a flat top
    that a Gaussian cannot have). With the default constants (sigma 1.23 mm at a 10 mm stand-off) holes
    up to r = 1.2 mm stay within 1.7 %; at small stand-offs (sigma near the bleed floor) large holes
    do not, and refinement should then be checked against :func:`physical_opacity`.

    Args:
        r_mm: Hole radii in mm.
        cfg: Spray settings.
        passes: Passes of the can for the layer.
        geometry: Stand-off and plate thickness.

    Returns:
        ``(sigma_mm, peak, dsigma_dr, dpeak_dr)``, each shaped like ``r_mm``.
    """
    r = np.asarray(r_mm, dtype=np.float64)
    if r.ndim == 1 and r.size > 2:
        # The floor's radius once: a refined layer's holes mostly sit at the radius floor (70-82 % of
        # each layer's on the example), and every value below is a function of the hole's own radius,
        # so the kernels are the same bits. A sort for every distinct radius (np.unique) cost more than
        # the kernels it saved once they came off a table (0.12 of 0.3 ms a call at 4,000 holes).
        floor = r.min()
        at = r == floor
        if at.sum() > 1:
            rest = ~at
            sigma, peak, dsigma, dpeak = physical_hole_kernels(np.r_[floor, r[rest]], cfg, passes, geometry)
            out = []
            for v in (sigma, peak, dsigma, dpeak):
                full = np.full(r.shape, v[0])
                full[rest] = v[1:]
                out.append(full)
            return out[0], out[1], out[2], out[3]
    s = spread_sigma_mm(cfg, geometry.standoff_mm)
    depth = passes * dose_per_pass(cfg)
    t, k = geometry.plate_thickness_mm, cfg.can.spread_k
    trans, dtrans = transmission_and_slope(r, t, k)
    s2 = r * r / 4.0 + s * s
    sigma = np.sqrt(s2)
    peak = depth * trans * r * r / (2.0 * s2)
    dsigma = r / (4.0 * sigma)
    # d/dr [r^2 / (2 s2)] = r / s2 - r^2 (r / 2) / (2 s2^2) = r sigma^2_blur / s2^2.
    dshape = r * s * s / (s2 * s2)
    dpeak = depth * (dtrans * r * r / (2.0 * s2) + trans * dshape)
    return sigma, peak, dsigma, dpeak
