"""The paper's spray model (Vavilala & Forsyth 2015): each hole a Gaussian of paint, in model units.

Hole ``i`` of radius ``r_i`` at ``p_i`` leaves ``N_i(p) = A exp(-|p - p_i|^2 / (2 sigma_i^2))`` with
``sigma_i^2 = r_i^2 (1 + h) / 4``; the layer's opacity is ``I = 1 - prod_i (1 - min(N_i, 1))``. ``A``
is the spray time (``spray.spray_time``), ``h`` the nozzle height (``spray.nozzle_height``). See
:mod:`.spray` for the model and the error bound of the fast path's cut tails; the model is chosen
through :mod:`.models`, the physical one is in :mod:`.physical`.
"""

import math

import numba
import numpy as np

from ..config.spray import SprayConfig
from ..filters import gaussian
from ..frames import mm_to_px
from ..parallel import njit_parallel

__all__ = [
    "A_FACTORS",
    "dot_sigma_mm",
    "paper_hole_kernels",
    "paper_mask_opacity",
    "paper_opacity",
    "spray_time_candidates",
    "tail_tolerance",
]

#: Spray-time multipliers tried by ``calibrate: spray_time`` (1/64 to 8: a hole sprays about
#: ``A 2 pi sigma^2`` of paint and sigma grows with the nozzle height, so high nozzles want low A).
A_FACTORS = tuple(2.0 ** (k / 2.0) for k in range(-12, 7))

# Rows per band of the parallel splat: small enough to balance 2+ threads, large
# enough that re-evaluating a hole's column profile per band stays cheap.
_BAND_ROWS = 32
# n_eff is the *average* pile-up of tails at the cut; on a (near-)hexagonal stipple a whole
# shell of 6-12 equidistant holes can sit just beyond it, so the budget per tail is smaller.
_TAIL_SAFETY = 8.0
# Memory of one exact tile, in float64 elements (pixels x holes).
_EXACT_TILE = 1 << 21


def _check_params(spray_time: float, nozzle_height: float) -> None:
    if not spray_time > 0.0:
        raise ValueError(f"spray_time A must be > 0, got {spray_time}")
    if not nozzle_height >= 0.0:
        raise ValueError(f"nozzle_height h must be ≥ 0, got {nozzle_height}")


def dot_sigma_mm(r_mm: np.ndarray | float, nozzle_height: float) -> np.ndarray:
    """Standard deviation of the paint dot a hole sprays.

    Args:
        r_mm: Hole radius (or radii) in mm.
        nozzle_height: The dimensionless nozzle height h (≥ 0).

    Returns:
        ``sigma = r sqrt(1 + h) / 2`` in mm, same shape as ``r_mm``.
    """
    return np.asarray(r_mm, dtype=np.float64) * math.sqrt(1.0 + nozzle_height) / 2.0


# --------------------------------------------------------------------------- fast path


@numba.njit(cache=True)
def _gauss_profile(out, n, d0, k2, amp):  # pragma: no cover - compiled
    """``out[j] = amp exp(-(d0 + j)^2 k2)`` for ``j < n``, with two exp instead of n.

    The recurrence is ``g(d + 1) = g(d) q(d)``, ``q(d + 1) = q(d) exp(-2 k2)``.

    Compiled without fastmath on purpose: re-associating the recurrence (as the
    vectoriser does under fastmath) multiplies huge and tiny powers and gives NaN.
    """
    step = math.exp(-2.0 * k2)
    g = amp * math.exp(-d0 * d0 * k2)
    q = math.exp(-(2.0 * d0 + 1.0) * k2)
    for j in range(n):
        out[j] = g
        g *= q
        q *= step


@njit_parallel(fastmath=True, cache=True)
def _splat_kernel(trans, row0, col0, cy, cx, inv2s2, rad, amp, tol, band_lo, band_hi, band_rows):
    """Multiply each hole's transmittance into ``trans`` over its truncation disc.

    ``cy``, ``cx`` are hole centres in (fractional) pixel rows/cols of the full raster,
    sorted by ``cy``; ``trans`` covers rows ``row0..`` and cols ``col0..`` of it. Band ``b``
    owns rows ``[b*band_rows, (b+1)*band_rows)`` of ``trans`` and visits holes
    ``band_lo[b]:band_hi[b]``, so threads never write the same pixel.
    """
    h, w = trans.shape
    nb = band_lo.shape[0]
    rmax = 0.0
    for i in range(rad.shape[0]):
        if rad[i] > rmax:
            rmax = rad[i]
    width = 2 * int(rmax) + 4
    one = np.float32(1.0)
    zero = np.float32(0.0)
    for b in numba.prange(nb):
        ex = np.empty(width, dtype=np.float32)
        ey_buf = np.empty(band_rows + 2, dtype=np.float64)
        r_lo = b * band_rows
        r_hi = min(h, r_lo + band_rows)
        for i in range(band_lo[b], band_hi[b]):
            R = rad[i]
            yc = cy[i] - row0
            xc = cx[i] - col0
            ra = max(r_lo, int(math.ceil(yc - R)))
            rb = min(r_hi - 1, int(math.floor(yc + R)))
            if ra > rb:
                continue
            ca = max(0, int(math.ceil(xc - R)))
            cb = min(w - 1, int(math.floor(xc + R)))
            if ca > cb:
                continue
            k2 = inv2s2[i]
            _gauss_profile(ex, cb - ca + 1, ca - xc, k2, 1.0)
            _gauss_profile(ey_buf, rb - ra + 1, ra - yc, k2, amp)
            r2 = R * R
            for r in range(ra, rb + 1):
                dy = r - yc
                e32 = np.float32(ey_buf[r - ra])
                # Pixels with ey * ex >= tol form the disc dx^2 + dy^2 <= R^2.
                half = math.sqrt(max(r2 - dy * dy, 0.0))
                c0 = max(ca, int(math.ceil(xc - half)))
                c1 = min(cb, int(math.floor(xc + half)))
                if c0 > c1:
                    # Also guards the slices below: a negative end would wrap around.
                    continue
                # Slices indexed from 0 let LLVM drop numba's negative-index wraparound and
                # vectorise; max(., 0) is the min(N, 1) clamp.
                seg = trans[r, c0 : c1 + 1]
                prof = ex[c0 - ca : c1 - ca + 1]
                for j in range(seg.shape[0]):
                    seg[j] *= max(one - e32 * prof[j], zero)


def _effective_overlap(xy_px: np.ndarray, sigma_px: np.ndarray) -> float:
    """``max_p sum_i 2 pi sigma_i^2 rho_i(p)``: how many dot tails can pile up at one pixel."""
    if sigma_px.size == 0:
        return 0.0
    # Cells of 3 median sigma: a few large dots in a small cell over-estimate (safe, and
    # costs only sqrt(log) in window size); many small dots are not averaged away.
    cell = max(3.0 * float(np.median(sigma_px)), 1.0)
    idx = np.floor((xy_px - xy_px.min(axis=0)) / cell).astype(np.int64)
    # Sparse cells (unique keys), so holes spread far apart cost no memory.
    _, cell_of = np.unique(idx[:, 0] * (int(idx[:, 1].max()) + 1) + idx[:, 1], return_inverse=True)
    weight = np.bincount(cell_of.ravel(), weights=2.0 * np.pi * sigma_px**2)
    return float(weight.max() / (cell * cell))


def _prepare(xy_mm, r_mm, shape_hw, mm_per_px, spray_time, nozzle_height):
    from .physical import holes_array

    xy_mm, r_mm = holes_array(xy_mm, r_mm)
    if not mm_per_px > 0.0:
        raise ValueError(f"mm_per_px must be > 0, got {mm_per_px}")
    _check_params(spray_time, nozzle_height)
    rc = mm_to_px(xy_mm, int(shape_hw[0]), mm_per_px)
    sigma_px = dot_sigma_mm(r_mm, nozzle_height) / mm_per_px
    return rc, sigma_px


def _crop_bounds(shape_hw, crop):
    h, w = int(shape_hw[0]), int(shape_hw[1])
    if crop is None:
        return 0, h, 0, w
    r0, r1, c0, c1 = (int(v) for v in crop)
    if not (0 <= r0 < r1 <= h and 0 <= c0 < c1 <= w):
        raise ValueError(f"crop {crop} must satisfy 0 ≤ r0 < r1 ≤ {h} and 0 ≤ c0 < c1 ≤ {w}")
    return r0, r1, c0, c1


def _tail_tol(rc, sigma_px, max_error):
    return max_error / (_TAIL_SAFETY * max(1.0, _effective_overlap(rc, sigma_px)))


def _fast_transmittance(rc, sigma_px, spray_time, max_error, bounds, tol=None):
    r0, r1, c0, c1 = bounds
    # float32 halves the memory traffic and doubles the SIMD width; the product of a few
    # hundred factors keeps a relative error near 1e-5, far below max_error.
    trans = np.ones((r1 - r0, c1 - c0), dtype=np.float32)
    n = rc.shape[0]
    if n == 0:
        return trans, 0.0
    if tol is None:
        tol = _tail_tol(rc, sigma_px, max_error)
    if spray_time <= tol:
        return trans, tol
    rad = sigma_px * math.sqrt(2.0 * math.log(spray_time / tol))
    # Drop holes whose truncation disc misses the raster (or the crop) entirely.
    keep = (
        (rc[:, 0] + rad >= r0 - 0.5)
        & (rc[:, 0] - rad <= r1 - 0.5)
        & (rc[:, 1] + rad >= c0 - 0.5)
        & (rc[:, 1] - rad <= c1 - 0.5)
    )
    rc, sigma_px, rad = rc[keep], sigma_px[keep], rad[keep]
    if rc.shape[0] == 0:
        return trans, tol
    order = np.argsort(rc[:, 0], kind="stable")
    cy = np.ascontiguousarray(rc[order, 0])
    cx = np.ascontiguousarray(rc[order, 1])
    sig = sigma_px[order]
    rad = np.ascontiguousarray(rad[order])
    inv2s2 = 1.0 / (2.0 * sig * sig)
    nb = -(-(r1 - r0) // _BAND_ROWS)
    band_top = r0 + np.arange(nb) * _BAND_ROWS
    rmax = float(rad.max())
    band_lo = np.searchsorted(cy, band_top - rmax - 1.0, side="left").astype(np.int64)
    band_hi = np.searchsorted(cy, band_top + _BAND_ROWS + rmax + 1.0, side="right").astype(np.int64)
    _splat_kernel(
        trans,
        float(r0),
        float(c0),
        cy,
        cx,
        inv2s2,
        rad,
        float(spray_time),
        float(tol),
        band_lo,
        band_hi,
        _BAND_ROWS,
    )
    return trans, tol


# --------------------------------------------------------------------------- exact path


def _exact_transmittance(rc, sigma_px, spray_time, bounds):
    r0, r1, c0, c1 = bounds
    h, w = r1 - r0, c1 - c0
    n = rc.shape[0]
    trans = np.ones(h * w, dtype=np.float64)
    if n == 0:
        return trans.reshape(h, w)
    rows, cols = np.divmod(np.arange(h * w), w)
    py = (rows + r0).astype(np.float64)
    px = (cols + c0).astype(np.float64)
    inv2s2 = 1.0 / (2.0 * sigma_px**2)
    chunk = max(1, min(n, 4096))
    tile = max(1, _EXACT_TILE // chunk)
    for h0 in range(0, n, chunk):
        hy = rc[h0 : h0 + chunk, 0]
        hx = rc[h0 : h0 + chunk, 1]
        k = inv2s2[h0 : h0 + chunk]
        for p0 in range(0, h * w, tile):
            dy = py[p0 : p0 + tile, None] - hy[None, :]
            dx = px[p0 : p0 + tile, None] - hx[None, :]
            nmat = spray_time * np.exp(-(dx * dx + dy * dy) * k[None, :])
            np.minimum(nmat, 1.0, out=nmat)
            trans[p0 : p0 + tile] *= np.prod(1.0 - nmat, axis=1)
    return trans.reshape(h, w)


# --------------------------------------------------------------------------- the model


def paper_opacity(
    xy_mm: np.ndarray,
    r_mm: np.ndarray | float,
    shape_hw: tuple[int, int],
    mm_per_px: float,
    cfg: SprayConfig,
    a: float,
    *,
    exact: bool = False,
    crop: tuple[int, int, int, int] | None = None,
    tail_tol: float | None = None,
) -> np.ndarray:
    """The opacity one stencil sprays at spray time ``a``: ``I = 1 - prod_i (1 - min(N_i, 1))``.

    The paper's side of :func:`stencil_cad.simulate.opacity.spray_opacity`, whose arguments these are.
    """
    rc, sigma_px = _prepare(xy_mm, r_mm, shape_hw, mm_per_px, a, cfg.nozzle_height)
    bounds = _crop_bounds(shape_hw, crop)
    if exact:
        trans = _exact_transmittance(rc, sigma_px, a, bounds)
    else:
        trans, _ = _fast_transmittance(rc, sigma_px, a, cfg.max_error, bounds, tail_tol)
    out = np.subtract(1.0, trans, dtype=np.float64)
    return np.clip(out, 0.0, 1.0, out=out)


def tail_tolerance(
    xy_mm: np.ndarray, r_mm: np.ndarray, shape_hw: tuple[int, int], mm_per_px: float, cfg: SprayConfig
) -> float:
    """The paint density below which the fast path drops a dot's tail, for this hole set.

    Args:
        xy_mm: ``(N, 2)`` hole centres in mm.
        r_mm: ``(N,)`` hole radii in mm.
        shape_hw: ``(H, W)`` of the raster.
        mm_per_px: Raster pixel size in mm.
        cfg: Spray settings (``max_error``, ``nozzle_height``).

    Returns:
        The tolerance (paint density, dimensionless); 0 for no holes.
    """
    rc, sigma_px = _prepare(xy_mm, r_mm, shape_hw, mm_per_px, cfg.spray_time, cfg.nozzle_height)
    return 0.0 if rc.shape[0] == 0 else float(_tail_tol(rc, sigma_px, cfg.max_error))


def paper_mask_opacity(
    mask: np.ndarray, mm_per_px: float, cfg: SprayConfig, a: float, reference_radius_mm: float | None = None
) -> np.ndarray:
    """A hard-stencil cut-out sprayed at spray time ``a``: ``I = 1 - exp(-A (1 + h) / 2 * (mask (*) G))``.

    The paper's side of :func:`stencil_cad.simulate.opacity.spray_mask`, which gives the derivation.
    """
    _check_params(a, cfg.nozzle_height)
    m = np.asarray(mask, dtype=np.float64)
    if m.ndim != 2:
        raise ValueError(f"mask must be (H, W), got shape {m.shape}")
    r_ref = cfg.mask_reference_radius_mm if reference_radius_mm is None else float(reference_radius_mm)
    sigma_px = r_ref * math.sqrt(cfg.nozzle_height) / 2.0 / mm_per_px
    if sigma_px > 0.0:
        # Paint sprayed past the picture edge is lost, not reflected back.
        m = gaussian(m, sigma_px, mode="constant", truncate=5.0)
    return np.clip(1.0 - np.exp(-a * (1.0 + cfg.nozzle_height) / 2.0 * m), 0.0, 1.0)


def paper_hole_kernels(
    r: np.ndarray, cfg: SprayConfig, a: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Every hole's Gaussian: ``(sigma_mm, peak, dsigma_dr, dpeak_dr)``, ``peak = A``, ``sigma = r sqrt(1 + h) / 2``."""
    _check_params(float(a), cfg.nozzle_height)
    f = math.sqrt(1.0 + cfg.nozzle_height) / 2.0
    return r * f, np.full_like(r, float(a)), np.full_like(r, f), np.zeros_like(r)


def spray_time_candidates(cfg: SprayConfig) -> list[float]:
    """The spray times ``calibrate: spray_time`` compares: ``spray_time`` times each of :data:`A_FACTORS`."""
    return sorted({min(100.0, cfg.spray_time * f) for f in A_FACTORS})
