"""Weighted centroidal Voronoi stippling of one layer's opacity into holes.

Method (Secord 2002, "Weighted Voronoi Stippling"): draw the start points by
importance sampling of the target point density (stratified along a Hilbert curve:
:mod:`.sampling`), then run Lloyd relaxation on
the pixel grid — assign every pixel to its nearest seed, move every seed to
the weighted centroid of its pixels — until the mean move is below
``tolerance_px`` or ``max_iterations`` is reached.

Tone. The layer's opacity ``a`` (or a calibrated density) gives the wanted
*open-area fraction* ``t`` (linear tone: ``t = a``). With hole radius
``r(t)`` the point density must be ``lambda ∝ t / r(t)^2``. A weighted CVT does
not put points at the density of its weight: asymptotically its point density
is ``w^(d/(d+2)) = w^(1/2)`` in 2-D (Gersho 1979; Du, Faber & Gunzburger 1999),
so the Lloyd weight is ``w = lambda^2`` to get dots per area proportional to
``lambda``.

Quality figure ``e_norm``. For ``N`` sites and weight ``w`` the optimal CVT
energy ``E = sum_i ∫_{V_i} w |x - s_i|^2`` is, asymptotically, reached by
regular hexagons whose area ``A(x)`` follows the optimal point density. A
hexagon of area ``A`` has polar second moment ``G A^2`` with
``G = 5 / (18 sqrt 3)`` (Gersho's constant), so with ``w`` locally constant
``E = G ∫ w / lambda``. Minimising under ``∫ lambda = N`` gives
``lambda = N sqrt(w) / ∫ sqrt(w)`` and ``E* = G (∫ sqrt(w))^2 / N``.
``e_norm = E / E*`` (1.0 is perfect). The pixel-sum energy is corrected to the
continuous energy of the piecewise-constant weight by adding ``w/6`` per
pixel (the second moment of a unit pixel about its centre), so a fine
discretisation cannot score below 1 by aliasing.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

import numpy as np

from ..config.stipple import StippleConfig, Tone
from ..filters import resize_linear
from ..frames import mm_to_px, pixel_centres_mm, px_to_mm
from ..model import DotSet
from .relax_kernels import _accumulate, _nearest_seed
from .rules import DesignRules, _keepout_clearance, enforce_rules
from .sampling import importance_sample, start_sample

#: Lloyd's start: ``start(lam, n, rng, mm_per_px)`` gives ``n`` seeds (px, row and col) on ``lam``'s grid.
StartSeeds = Callable[[np.ndarray, int, np.random.Generator, float], np.ndarray]

log = logging.getLogger(__name__)

#: Gersho's constant: normalised polar second moment of the regular hexagon.
HEX_G = 5.0 / (18.0 * math.sqrt(3.0))


# --------------------------------------------------------------------------- Lloyd relaxation


def bucket_size(w: np.ndarray, n: int) -> int:
    """Grid-bucket edge in px for ``n`` seeds over the weighted area of ``w``."""
    area = max(int(np.count_nonzero(w > 0)), 1)
    # Half the mean spacing: dense regions then hold few seeds per bucket, and below
    # 4 px the per-tile ring bookkeeping costs more than the distance tests it saves.
    return int(np.clip(round(0.5 * math.sqrt(area / max(n, 1))), 4, 64))


def voronoi_pass(
    w: np.ndarray, seeds: np.ndarray, bsize: int | None = None, prev_label: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """One exact weighted-Voronoi pass on the pixel grid.

    Args:
        w: ``(H, W)`` float64 Lloyd weight, ``>= 0``.
        seeds: ``(N, 2)`` float64 seed positions in px (row, col), integer
            values at pixel centres.
        bsize: Bucket edge in px. Defaults to :func:`bucket_size`.
        prev_label: ``(H, W)`` int64 labels of the previous pass over the same
            seeds (moved), used as a warm start and overwritten with the new
            labels; the result is exact either way.

    Returns:
        ``(mass, m_row, m_col, energy, label)``: per-seed weight sum, weighted
        coordinate sums and energy ``sum w |p - s|^2`` (pixel units), and the
        ``(H, W)`` int64 nearest-seed label (-1 where ``w == 0``).
    """
    w = np.ascontiguousarray(w, dtype=np.float64)
    seeds = np.ascontiguousarray(seeds, dtype=np.float64).reshape(-1, 2)
    warm = prev_label is not None and prev_label.shape == w.shape
    if prev_label is not None and warm:
        label = np.ascontiguousarray(prev_label, dtype=np.int64)
    else:
        label = np.empty(w.shape, dtype=np.int64)
    dist2 = np.empty(w.shape, dtype=np.float64)
    if len(seeds) == 0:
        label[...] = -1
        z = np.zeros(0)
        return z, z, z, z, label
    if bsize is None:
        bsize = bucket_size(w, len(seeds))
    if warm and (label.max(initial=-1) >= len(seeds)):
        raise ValueError("prev_label refers to more seeds than given")
    _nearest_seed(w, seeds, int(bsize), label, dist2, warm)
    mass, mr, mc, en = _accumulate(w, label, dist2, len(seeds))
    return mass, mr, mc, en, label


def cvt_energy(w: np.ndarray, seeds: np.ndarray) -> float:
    """Continuous weighted CVT energy of ``seeds`` over the piecewise-constant ``w``.

    Args:
        w: ``(H, W)`` Lloyd weight.
        seeds: ``(N, 2)`` seeds in px (row, col).

    Returns:
        ``sum_p w_p (|p - s(p)|^2 + 1/6)`` in px^4 units of weight.
    """
    w = np.ascontiguousarray(w, dtype=np.float64)
    _, _, _, en, _ = voronoi_pass(w, seeds)
    return float(en.sum() + w.sum() / 6.0)


def cvt_optimum(w: np.ndarray, n: int) -> float:
    """Hexagonal optimum ``G (sum sqrt w)^2 / n`` of the weighted CVT energy (see module doc)."""
    return HEX_G * float(np.sqrt(np.maximum(w, 0.0)).sum()) ** 2 / max(n, 1)


def e_norm(w: np.ndarray, seeds: np.ndarray) -> float:
    """Weighted CVT energy of ``seeds`` divided by its hexagonal optimum (1.0 is perfect)."""
    seeds = np.asarray(seeds, dtype=np.float64).reshape(-1, 2)
    if len(seeds) == 0:
        return math.nan
    return cvt_energy(w, seeds) / cvt_optimum(w, len(seeds))


def lloyd(
    w: np.ndarray,
    seeds: np.ndarray,
    max_iterations: int,
    tolerance_px: float,
    progress: Callable[[int, int], None] | None = None,
    omega: float = 1.0,
    fixed: int = 0,
) -> tuple[np.ndarray, dict]:
    """Weighted Lloyd relaxation on the pixel grid, optionally over-relaxed.

    Each iteration moves every seed by ``omega`` times the step to its cell's
    weighted centroid. ``omega = 1`` is plain Lloyd, whose energy never
    increases; ``1 < omega < 2`` converges faster. Should the energy rise, the
    remaining iterations fall back to ``omega = 1``, and the last step is always
    a plain centroid step so seeds end on their centroids.

    The last ``fixed`` seeds are generators that do not move (the holes a
    neighbouring region already placed): they keep their cells, so the free
    seeds relax against them, and they are left out of the mean move.

    Args:
        w: ``(H, W)`` Lloyd weight.
        seeds: ``(N, 2)`` start positions in px (row, col).
        max_iterations: Iteration cap.
        tolerance_px: Stop when the mean centroid step of an iteration is below this, px.
        progress: Called as ``progress(iteration, max_iterations)`` after each iteration.
        omega: Over-relaxation factor in [1, 2). Defaults to 1.0.
        fixed: How many of the last seeds stay where they are. Defaults to 0.

    Returns:
        ``(seeds, info)`` with info ``iterations``, ``mean_move_px`` (mean
        centroid step of the last iteration), ``bucket_px`` and ``omega`` (the
        factor in use at the end).
    """
    if not 1.0 <= omega < 2.0:
        raise ValueError(f"omega must be in [1, 2), got {omega}")
    w = np.ascontiguousarray(w, dtype=np.float64)
    seeds = np.array(seeds, dtype=np.float64).reshape(-1, 2)
    if not 0 <= fixed <= len(seeds):
        raise ValueError(f"fixed must be in [0, {len(seeds)}], got {fixed}")
    free = len(seeds) - fixed
    h, wd = w.shape
    bsize = bucket_size(w, len(seeds))
    move = math.nan
    it = 0
    label = None
    prev_energy = math.inf
    for it in range(1, max_iterations + 1):
        mass, mr, mc, en, label = voronoi_pass(w, seeds, bsize, label)
        energy = float(en.sum())
        if energy > prev_energy:
            omega = 1.0
        prev_energy = energy
        has = mass > 0
        has[free:] = False
        step = np.zeros_like(seeds)
        step[has, 0] = mr[has] / mass[has] - seeds[has, 0]
        step[has, 1] = mc[has] / mass[has] - seeds[has, 1]
        move = float(np.hypot(step[:free, 0], step[:free, 1]).mean()) if free else 0.0
        done = move < tolerance_px or it == max_iterations
        seeds = seeds + (1.0 if done else omega) * step
        if not done and omega > 1.0:
            np.clip(seeds[:free, 0], -0.5, h - 0.5, out=seeds[:free, 0])
            np.clip(seeds[:free, 1], -0.5, wd - 0.5, out=seeds[:free, 1])
        if progress is not None:
            progress(it, max_iterations)
        if done:
            break
    return seeds, {"iterations": it, "mean_move_px": move, "bucket_px": bsize, "omega": omega}


# --------------------------------------------------------------------------- the stage


def _feasible(
    t: np.ndarray, r_of_t: np.ndarray, mm_per_px: float, rules: DesignRules, origin_mm=(0.0, 0.0)
) -> np.ndarray:
    """Pixels where a hole of radius ``r(t)`` keeps the edge margin and keep-out clearance.

    ``origin_mm`` is where the grid's bottom-left corner lies in the rules' frame (a region of
    a larger picture).
    """
    h, w = t.shape
    x, y = pixel_centres_mm(h, w, mm_per_px)
    x, y = x + origin_mm[0], y + origin_mm[1]
    reach = rules.edge_margin_mm + r_of_t
    ok = (x >= reach) & (x <= rules.width_mm - reach) & (y >= reach) & (y <= rules.height_mm - reach)
    if rules.keepouts:
        xy = np.column_stack([np.broadcast_to(x, (h, w)).ravel(), np.broadcast_to(y, (h, w)).ravel()])
        ok &= (_keepout_clearance(xy, rules.keepouts) >= reach.ravel()).reshape(h, w)
    return ok


def auto_dot_count(t: np.ndarray, r_of_t: np.ndarray, mm_per_px: float, cfg: StippleConfig) -> int:
    """Dot count from the hole size, the web and the layer's ink.

    The densest tone (``t = 1``) is packed hexagonally at centre spacing
    ``d = auto_spacing_factor * (2 r_max + web)``, i.e. ``2 / (sqrt 3 d^2)``
    dots per mm^2; elsewhere the point density is ``t (r_max / r(t))^2`` times
    that (open area proportional to ``t``).

    Args:
        t: ``(H, W)`` open-area tone in [0, 1] (0 where no hole may go).
        r_of_t: ``(H, W)`` hole radius in mm at each pixel.
        mm_per_px: Pixel size in mm.
        cfg: The stipple config.

    Returns:
        The number of dots (0 when the layer has no ink).
    """
    r_max = cfg.sizes.max_radius_mm
    d = _densest_spacing_mm(cfg)
    per_mm2 = 2.0 / (math.sqrt(3.0) * d * d)
    ink = float((t * (r_max / r_of_t) ** 2).sum()) * mm_per_px * mm_per_px
    return int(round(per_mm2 * ink))


def _densest_spacing_mm(cfg: StippleConfig) -> float:
    """Centre spacing of the densest pattern, ``auto_spacing_factor * (2 r_max + web)``."""
    return cfg.densest_pitch_mm


def _spacing_mm(t: np.ndarray, r_of_t: np.ndarray, cfg: StippleConfig) -> np.ndarray:
    """The hexagonal hole spacing of :func:`auto_dot_count`'s density at each pixel (inf without ink)."""
    with np.errstate(divide="ignore"):
        return _densest_spacing_mm(cfg) / np.sqrt(t * (cfg.sizes.max_radius_mm / r_of_t) ** 2)


def tone_map(
    alpha: np.ndarray, cfg: StippleConfig, density: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Open-area tone ``t`` in [0, 1] and the mask where holes are allowed by opacity.

    Args:
        alpha: ``(H, W)`` layer opacity in [0, 1].
        cfg: The stipple config.
        density: ``(H, W)`` calibrated density (>= 0; 1 is the densest hole
            pattern, larger maxima are normalised) or None for the tone curve.

    Returns:
        ``(t, mask)``: float64 tone with zeros outside ``mask``; bool mask
        ``alpha >= opacity_threshold``.

    Raises:
        ValueError: when ``tone`` is ``response`` and no density is given, or
            on shape mismatch.
    """
    alpha = np.asarray(alpha, dtype=np.float64)
    if alpha.ndim != 2:
        raise ValueError(f"alpha must be a 2-D (H, W) array, got shape {alpha.shape}")
    if density is None:
        if cfg.tone == Tone.response:
            raise ValueError(
                "stipple.tone is 'response' but no density map was given: the pipeline must pass the "
                "density derived by the spray calibration"
            )
        t = np.clip(np.nan_to_num(alpha), 0.0, 1.0)
    else:
        t = np.asarray(density, dtype=np.float64)
        if t.shape != alpha.shape:
            raise ValueError(f"density shape {t.shape} differs from alpha shape {alpha.shape}")
        t = np.maximum(np.nan_to_num(t), 0.0)
        peak = float(t.max()) if t.size else 0.0
        if peak > 1.0:
            t = t / peak
    mask = alpha >= cfg.opacity_threshold
    return np.where(mask, t, 0.0), mask


#: Lloyd over-relaxation factor (see :func:`lloyd`).
OMEGA = 1.8

#: Target pixels per Voronoi cell of the Lloyd grid (the input grid is refined to reach it).
PX_PER_DOT = 100


#: Largest refined Lloyd grid, in pixels.
MAX_GRID_PX = 16_000_000


def refine_factor(active_px: int, n_dots: int, total_px: int) -> int:
    """Integer upsampling of the Lloyd grid so a cell covers about :data:`PX_PER_DOT` px."""
    if n_dots <= 0 or active_px <= 0:
        return 1
    k = math.ceil(math.sqrt(PX_PER_DOT * n_dots / active_px))
    k_max = max(int(math.sqrt(MAX_GRID_PX / max(total_px, 1))), 1)
    return int(min(max(k, 1), k_max, 8))


def _upsample(a: np.ndarray, k: int) -> np.ndarray:
    """Bilinear ``k``-fold upsampling with pixel areas aligned (pixel edges map to edges)."""
    return resize_linear(a, (a.shape[0] * k, a.shape[1] * k), "edge", anti_aliasing=False)


def stipple_layer(
    alpha: np.ndarray,
    mm_per_px: float,
    cfg: StippleConfig,
    rng: np.random.Generator,
    density: np.ndarray | None = None,
    n_dots: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    keepouts: tuple | list = (),
    start: StartSeeds | None = None,
) -> DotSet:
    """Stipple one layer's opacity into holes that satisfy the design rules.

    Args:
        alpha: ``(H, W)`` layer opacity in [0, 1]; no hole where it is below
            ``cfg.opacity_threshold``.
        mm_per_px: Pixel size in mm.
        cfg: The ``stipple`` config section.
        rng: Random generator (the same config and seed give the same dots).
        density: ``(H, W)`` wanted open-area density replacing the tone curve
            (the calibrated curve from the spray simulator), or None.
        n_dots: Dot count replacing ``cfg.dots`` and the automatic count.
        progress: Called as ``progress(iteration, max_iterations)``.
        keepouts: Extra keep-out rectangles ``(x0, y0, x1, y1)`` in picture mm.
        start: Lloyd's start seeds (see :func:`place_holes`), or None for a sample of the density.

    Returns:
        The dots in picture mm. ``report`` holds ``n_initial``, ``n_final``,
        ``iterations``, ``mean_move_px``, ``e_norm``, ``removed`` (total),
        ``removed_empty`` (cells without weight), ``removed_threshold``,
        ``merged``, ``nudged``, ``raised``, ``removed_edge``,
        ``removed_keepout``, ``removed_web``, ``min_web_mm`` (``inf`` for fewer
        than two dots), ``refine`` (Lloyd grid upsampling factor) and
        ``bucket_px``.

    Raises:
        ValueError: on a non-2-D ``alpha``, ``mm_per_px <= 0``, a ``density`` of another shape, or
            ``tone: response`` without a ``density``.
    """
    alpha = np.asarray(alpha, dtype=np.float64)
    if alpha.ndim != 2:
        raise ValueError(f"alpha must be a 2-D (H, W) array, got shape {alpha.shape}")
    if not (math.isfinite(mm_per_px) and mm_per_px > 0):
        raise ValueError(f"mm_per_px must be > 0, got {mm_per_px}")
    h, w = alpha.shape
    rules = cfg.design_rules(w * mm_per_px, h * mm_per_px, keepouts)
    xy, r, report = place_holes(alpha, mm_per_px, cfg, rng, rules, density, n_dots, progress, start=start)
    xy, r, rep = enforce_rules(xy, r, rules)
    report.update({key: v for key, v in rep.items() if key not in ("n_in", "n_out", "removed")})
    report["removed"] = rep["removed"] + report["removed_empty"] + report["removed_threshold"]
    report["n_final"] = int(len(r))
    log.debug("stippled %d -> %d dots: %s", report["n_initial"], len(r), report)
    return DotSet(xy_mm=xy, r_mm=r, report=report)


def _fixed_cells(fixed_xy_mm: np.ndarray, spacing_mm: np.ndarray, mm_per_px: float) -> np.ndarray:
    """Pixels nearer a fixed hole than half the distance to its nearest fixed neighbour.

    Their cells reach past the pixels their tiles own; new seeds drawn there start as a line of
    surplus holes along the seam that Lloyd's slow long-range relaxation does not clear. The
    distance is capped at 1.5 times ``spacing_mm``, the ``(H, W)`` hexagonal hole spacing the
    tone asks for at each pixel: an isolated fixed hole beside dense ink does not own that ink
    (uncapped, a 1 m² mural had 1.3 % fewer holes than stippled in one piece; capped at the
    spacing itself, the seams of the flat grey in tests/mural/test_stipple.py had ten times the
    interior's share of unusually close neighbours).
    """
    from scipy.spatial import cKDTree

    h, w = spacing_mm.shape
    tree = cKDTree(fixed_xy_mm)
    if len(fixed_xy_mm) > 1:
        nearest = tree.query(fixed_xy_mm, k=2)[0][:, 1]
    else:
        nearest = np.full(len(fixed_xy_mm), np.inf)
    x, y = pixel_centres_mm(h, w, mm_per_px)
    xy = np.column_stack([np.broadcast_to(x, (h, w)).ravel(), np.broadcast_to(y, (h, w)).ravel()])
    finite = spacing_mm[np.isfinite(spacing_mm)]
    bound = min(float(nearest.max()), 1.5 * float(finite.max()) if finite.size else 0.0)
    d, i = tree.query(xy, distance_upper_bound=bound)
    inside = np.isfinite(d)
    out = np.zeros(h * w, dtype=bool)
    reach = np.minimum(nearest[i[inside]], 1.5 * spacing_mm.ravel()[inside])
    out[inside] = d[inside] < 0.5 * reach
    return out.reshape(h, w)


def place_holes(
    alpha: np.ndarray,
    mm_per_px: float,
    cfg: StippleConfig,
    rng: np.random.Generator,
    rules: DesignRules,
    density: np.ndarray | None = None,
    n_dots: int | None = None,
    progress: Callable[[int, int], None] | None = None,
    free: np.ndarray | None = None,
    fixed_xy_mm: np.ndarray | None = None,
    origin_mm: tuple[float, float] = (0.0, 0.0),
    start: StartSeeds | None = None,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """The relaxed hole centres and radii of one layer (or one region of it), before the rules.

    Args:
        alpha: ``(H, W)`` opacity of the layer or region.
        mm_per_px: Pixel size in mm.
        cfg: The ``stipple`` config section.
        rng: Random generator.
        density: Wanted open-area density replacing the tone curve, or None.
        n_dots: Dot count replacing ``cfg.dots`` and the automatic count.
        progress: Called as ``progress(iteration, max_iterations)``.
        rules: The design rules of the picture ``alpha`` covers (or is a region of).
        free: ``(H, W)`` bool, where new holes may be drawn (None: everywhere).
        fixed_xy_mm: ``(M, 2)`` holes already placed (a neighbouring region's), in the same
            frame: fixed Lloyd generators that keep their cells, so the new holes relax
            against them (with ``free`` given, no new seed starts in their cells and the
            automatic dot count leaves those out). They are not returned.
        origin_mm: Where ``alpha``'s bottom-left corner lies in the rules' frame (a region:
            the margins hold at the picture's edges, not at the region's).
        start: Lloyd's start seeds, called as ``start(lam, n, rng, mm_per_px)`` on the grid it
            relaxes on (:class:`stencil_cad.stipple.warm.WarmStart`), or None for a sample of
            ``lam`` (:func:`_start_seeds`).

    Returns:
        ``(xy_mm, r_mm, report)``: the new holes (in ``alpha``'s frame) whose cells hold weight
        and whose centres are on ink; ``report`` as :func:`stipple_layer`'s without the rules'
        figures.
    """
    h, w = alpha.shape
    r1 = cfg.sizes.max_radius_mm
    fixed_xy_mm = np.zeros((0, 2)) if fixed_xy_mm is None else np.asarray(fixed_xy_mm, dtype=np.float64)

    t, mask, r_of_t = _tone_and_radius(alpha, density, mm_per_px, cfg, rules, origin_mm)
    nfix = len(fixed_xy_mm)
    if free is not None and nfix and t.any():
        free = free & ~_fixed_cells(fixed_xy_mm, _spacing_mm(t, r_of_t, cfg), mm_per_px)
    t_new = t if free is None else np.where(free, t, 0.0)
    if n_dots is None:
        # The free pixels' ink, outside the fixed holes' cells (counting the region's ink less
        # the fixed holes gave 1 % more holes than the whole-picture stipple).
        n_dots = cfg.dots if cfg.dots is not None else auto_dot_count(t_new, r_of_t, mm_per_px, cfg)
    n_dots = int(n_dots) if t_new.sum() > 0 else 0

    # Lloyd on a grid with few pixels per cell is ragged and the spacing rules then remove
    # many dots. Refining the grid until each cell covers about PX_PER_DOT pixels halved
    # the removals on the bundled example; relaxing on the input grid first and refining
    # only for the last iterations did not (it settles into the coarse grid's fixed point).
    k = refine_factor(int(np.count_nonzero(t)), n_dots + nfix, h * w)
    if k > 1:
        alpha, density, free = _upsample_inputs(alpha, density, free, k)
        mm_per_px = mm_per_px / k
        h, w = alpha.shape
        t, mask, r_of_t = _tone_and_radius(alpha, density, mm_per_px, cfg, rules, origin_mm)
    lam = t * (r1 / r_of_t) ** 2
    weight = lam * lam
    lam_free = lam if free is None else np.where(free, lam, 0.0)
    seeds = _start_seeds(lam_free, n_dots, rng, start, fixed_xy_mm, mm_per_px, free is not None or nfix > 0)
    seeds, info = lloyd(weight, seeds, cfg.max_iterations, cfg.tolerance_px * k, progress, OMEGA, fixed=nfix)
    report: dict = {
        "n_initial": int(n_dots),
        "iterations": info["iterations"],
        "mean_move_px": info["mean_move_px"] / k,
    }
    report |= {"refine": k, "bucket_px": info["bucket_px"]}
    return _kept_holes(seeds, weight, nfix, mask, r_of_t, mm_per_px, report)


def _start_seeds(
    lam, n_dots: int, rng, start: StartSeeds | None, fixed_xy_mm: np.ndarray, mm_per_px: float, region: bool
) -> np.ndarray:
    """Lloyd's start on ``lam``'s grid: ``n_dots`` free seeds, then the fixed holes.

    The free seeds are ``start``'s (for instance another wall's holes of the layer thinned or
    topped up: :class:`stencil_cad.stipple.warm.WarmStart`), or a sample of ``lam``: for a whole
    layer stratified along a Hilbert curve where there are enough of them
    (:func:`stencil_cad.stipple.sampling.start_sample`), for a ``region`` (a mural's tile) independent
    draws. A mural's tiles from the stratified start left one seam's 5 mm band 5 to 6 % sparser
    than its flanks, where the interior's lines vary by 3 % (``tests/mural/test_stipple.py``'s flat
    grey), with or without the tile's fixed neighbours started so.
    """
    h = lam.shape[0]
    if start is not None:
        seeds = start(lam, n_dots, rng, mm_per_px)
    elif region:
        seeds = importance_sample(lam, n_dots, rng)
    else:
        seeds = start_sample(lam, n_dots, rng)
    if len(fixed_xy_mm):
        seeds = np.concatenate([seeds, mm_to_px(fixed_xy_mm, h, mm_per_px)])
    return seeds


def _upsample_inputs(alpha, density, free, k: int):
    """``alpha``, ``density`` and ``free`` on a grid ``k`` times finer (None stays None)."""
    alpha = _upsample(alpha, k)
    density = None if density is None else _upsample(np.asarray(density, dtype=np.float64), k)
    free = None if free is None else np.repeat(np.repeat(free, k, axis=0), k, axis=1)
    return alpha, density, free


def _tone_and_radius(alpha, density, mm_per_px, cfg: StippleConfig, rules: DesignRules, origin_mm):
    """The open-area tone (0 where the rules cannot fit a hole), the ink mask and the radius per pixel."""
    sizes = cfg.sizes
    r0, r1 = sizes.radius_mm, sizes.max_radius_mm
    t, mask = tone_map(alpha, cfg, density)
    # sqrt keeps the packing feasible at every tone: spacing scales as r / sqrt(t) >= r_max.
    r_of_t = r0 + (r1 - r0) * np.sqrt(t) if r1 > r0 else np.full(t.shape, r0)
    t = np.where(_feasible(t, r_of_t, mm_per_px, rules, origin_mm), t, 0.0)
    return t, mask, r_of_t


def _kept_holes(seeds, weight, nfix, mask, r_of_t, mm_per_px, report: dict):
    """The relaxed seeds less the fixed ones, the empty cells' and those off ink, as holes in mm.

    Adds the CVT quality and the removal counts to ``report``; returns ``(xy_mm, r_mm, report)``.
    """
    h, w = r_of_t.shape
    if len(seeds):
        mass, _, _, en, _ = voronoi_pass(weight, seeds)
        report["e_norm"] = float((en.sum() + weight.sum() / 6.0) / cvt_optimum(weight, len(seeds)))
    else:
        mass = np.zeros(0)
        report["e_norm"] = math.nan
    seeds, mass = seeds[: len(seeds) - nfix], mass[: len(mass) - nfix]

    keep = mass > 0
    report["removed_empty"] = int((~keep).sum())
    seeds = seeds[keep]
    pr = np.clip(np.rint(seeds[:, 0]).astype(np.int64), 0, max(h - 1, 0))
    pc = np.clip(np.rint(seeds[:, 1]).astype(np.int64), 0, max(w - 1, 0))
    on_ink = mask[pr, pc] if len(seeds) else np.zeros(0, dtype=bool)
    report["removed_threshold"] = int((~on_ink).sum())
    seeds, pr, pc = seeds[on_ink], pr[on_ink], pc[on_ink]

    xy = px_to_mm(seeds, h, mm_per_px)
    r = r_of_t[pr, pc] if len(seeds) else np.zeros(0)
    return xy, r, report
