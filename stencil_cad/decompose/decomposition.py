"""Soft layer decomposition: a primer plus L alpha-blended paint layers.

The image Y is explained as a primer colour ``c_0`` under L paint layers
composited with Porter-Duff *over* in spray order; the colours and opacity maps
minimise the energy of Vavilala et al. 2015 (see :mod:`.energy`) by block
coordinate descent (see :mod:`.solver`), started from K-means colours and
nearest-colour opacities, on an image pyramid.

Public API: :func:`decompose`, :func:`energy_of`.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable

import numpy as np

from ..colour import colour_to_rgb, distinct_colours, to_hex
from ..config.decompose import DecomposeConfig, OpacitySource
from ..model import Layers, Picture
from . import energy, solver
from .solver import SolverSettings, State
from .sprayed import PlateReach
from .start import _best_start, _state

__all__ = ["decompose", "energy_of"]

log = logging.getLogger(__name__)


# Pyramid levels with at most 1/16 of the finest level's pixels stop at this
# multiple of the tolerance (measured: same time, lower final energy).
_COARSE_TOLERANCE_FACTOR = 0.25

# A fixed palette whose best reconstruction is further than this from the
# image (RMSE in 0-255 units) is reported as not reaching it.
_FIXED_PALETTE_WARN_RMSE = 8.0


def _delta_e(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """CIEDE2000 colour difference between sRGB colours ``(..., 3)`` in [0, 1] (D65)."""
    from skimage.color import deltaE_ciede2000, rgb2lab

    a, b = np.broadcast_arrays(np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64))
    la = rgb2lab(np.clip(a, 0.0, 1.0).reshape(-1, 1, 3))
    lb = rgb2lab(np.clip(b, 0.0, 1.0).reshape(-1, 1, 3))
    return deltaE_ciede2000(la, lb).reshape(a.shape[:-1])


def _flat_error(colour: np.ndarray) -> ValueError:
    return ValueError(
        f"the image is one flat colour: prime the surface with {to_hex(colour)}; there is nothing to stencil"
    )


def _redundant_layer(
    primer: np.ndarray, colours: np.ndarray, alphas: np.ndarray, cfg: DecomposeConfig
) -> tuple[int, str] | None:
    """The first layer that adds nothing, with the reason, or None.

    A layer adds nothing when its opacity stays below ``cfg.min_opacity``,
    when its paint is within ``cfg.min_delta_e`` of the primer, or when its
    paint is within ``cfg.min_delta_e`` of another paint (then the one with
    less paint goes; the other is re-solved to cover its pixels).
    """
    n = colours.shape[0]
    if n == 0:
        return None
    peak = alphas.reshape(n, -1).max(axis=1)
    for i in range(n):
        if peak[i] < cfg.min_opacity:
            return (
                i,
                f"paint {to_hex(colours[i])} never reaches opacity {cfg.min_opacity:g} (max {peak[i]:.3f})",
            )
    if cfg.min_delta_e <= 0.0:
        return None
    to_primer = _delta_e(colours, primer[None, :])
    for i in range(n):
        if to_primer[i] < cfg.min_delta_e:
            return i, (
                f"paint {to_hex(colours[i])} is within Delta E {to_primer[i]:.2f} of the primer "
                f"{to_hex(primer)} (min_delta_e {cfg.min_delta_e:g})"
            )
    if n > 1:
        pair = _delta_e(colours[:, None, :], colours[None, :, :])
        pair[np.tri(n, dtype=bool)] = np.inf
        i, j = (int(v) for v in np.unravel_index(int(np.argmin(pair)), pair.shape))
        if pair[i, j] < cfg.min_delta_e:
            mass = alphas.reshape(n, -1).sum(axis=1)
            drop, keep = (i, j) if mass[i] < mass[j] else (j, i)
            return int(drop), (
                f"paints {to_hex(colours[drop])} and {to_hex(colours[keep])} are within Delta E "
                f"{pair[i, j]:.2f} (min_delta_e {cfg.min_delta_e:g}): merged into {to_hex(colours[keep])}"
            )
    return None


def _settings(cfg: DecomposeConfig) -> SolverSettings:
    return SolverSettings(
        g_data=cfg.weights.data,
        g_smooth=cfg.weights.smooth,
        g_sparse=cfg.weights.sparse,
        tolerance=cfg.tolerance,
        max_iterations=cfg.max_iterations,
        inner_tolerance=cfg.inner_tolerance,
        inner_max_sweeps=cfg.inner_max_sweeps,
    )


def energy_of(layers: Layers, target: np.ndarray, cfg: DecomposeConfig) -> dict[str, float]:
    """The energy of a decomposition against an image, term by term.

    Args:
        layers: The decomposition.
        target: ``(H, W, 3)`` image in [0, 1] on the alphas' grid.
        cfg: Supplies the weights.

    Returns:
        ``{"total", "data", "smooth", "sparse"}``; the three terms unweighted.
    """
    data, smooth, sparse = energy.energy_terms(
        np.ascontiguousarray(target, dtype=np.float64),
        np.asarray(layers.primer, dtype=np.float64),
        np.ascontiguousarray(layers.colours, dtype=np.float64),
        np.ascontiguousarray(layers.alphas, dtype=np.float64),
    )
    w = cfg.weights
    return {
        "total": w.data * data + w.smooth * smooth + w.sparse * sparse,
        "data": data,
        "smooth": smooth,
        "sparse": sparse,
    }


def _rmse(composite: np.ndarray, target: np.ndarray) -> tuple[float, list[float]]:
    err = (composite - target) ** 2
    per = np.sqrt(err.reshape(-1, 3).mean(axis=0)) * 255.0
    return float(np.sqrt(err.mean()) * 255.0), [float(v) for v in per]


def _source(picture: Picture, cfg: DecomposeConfig) -> str:
    src = cfg.opacity_source
    if src is OpacitySource.alpha:
        if picture.alpha is None:
            raise ValueError("decompose.opacity_source: 'alpha' needs an image with an alpha channel (RGBA)")
        return "alpha"
    # A grey picture is decomposed like any other (into grey paints) unless one layer of darkness is asked for.
    return "grey" if src is OpacitySource.grey else "rgb"


def _single_layer(picture: Picture, cfg: DecomposeConfig, source: str, t0: float) -> Layers:
    """One layer whose opacity is given by the input: grey darkness or the alpha channel."""
    warnings: list[str] = []
    rgb = np.clip(np.asarray(picture.rgb, dtype=np.float64), 0.0, 1.0)
    primer = np.array(cfg.primer_rgb() or (1.0, 1.0, 1.0))
    hexes = cfg.palette_hex()
    if hexes is not None:
        paint = np.array(colour_to_rgb(hexes[0]))
        if len(hexes) > 1:
            warnings.append(
                f"opacity source '{source}' makes one layer: only the first can {hexes[0]} is used"
            )
    elif source == "alpha":
        a = np.asarray(picture.alpha, dtype=np.float64)
        paint = (rgb * a[..., None]).reshape(-1, 3).sum(axis=0) / a.sum() if a.sum() > 0 else np.zeros(3)
    else:
        paint = np.zeros(3)
    if source == "alpha":
        alpha = np.clip(np.asarray(picture.alpha, dtype=np.float64), 0.0, 1.0)
        target = (1.0 - alpha[..., None]) * primer + alpha[..., None] * rgb
    else:
        # Least-squares opacity on the segment primer -> paint: darkness for white/black.
        target = rgb
        d = paint - primer
        dd = float(d @ d)
        if dd <= 0.0:
            warnings.append("paint and primer are the same colour: the opacity map is empty")
            alpha = np.zeros(rgb.shape[:2])
        else:
            alpha = np.clip(((rgb - primer) @ d) / dd, 0.0, 1.0)
    alpha = np.nan_to_num(alpha, nan=0.0)
    if alpha.size and alpha.max() < cfg.min_opacity:
        # No ink anywhere: the primer alone is the picture.
        raise _flat_error(primer if source != "alpha" else rgb.reshape(-1, 3).mean(axis=0))
    alphas = alpha[None].astype(np.float64)
    colours = np.clip(paint, 0.0, 1.0)[None, :]
    primer = np.clip(primer, 0.0, 1.0)
    comp = energy.composite_nb(primer, colours, np.ascontiguousarray(alphas))
    rmse, per = _rmse(comp, target)
    for w in warnings:
        log.warning(w)
    info = {
        "source": source,
        "rmse": rmse,
        "rmse_channels": per,
        "iterations": 0,
        "warnings": warnings,
        "seconds": time.perf_counter() - t0,
    }
    return Layers(primer=primer, colours=colours, alphas=alphas, mm_per_px=picture.mm_per_px, info=info)


def decompose(
    picture: Picture,
    cfg: DecomposeConfig,
    rng: np.random.Generator,
    progress: Callable[[int, float], None] | None = None,
    reach: PlateReach | None = None,
) -> Layers:
    """Decompose a picture into a primer and L paint layers.

    Args:
        picture: The input on the working grid.
        cfg: The ``decompose`` config section.
        rng: Random generator (K-means sampling and seeding).
        progress: Optional ``progress(iteration, energy)`` called after every
            solver iteration (iterations count across pyramid levels).
        reach: What the plates can spray (:class:`~stencil_cad.decompose.sprayed.PlateReach`), or
            None. With it, candidate starts are ranked by the predicted sprayed result of their
            trial solves instead of the ideal layers' fit.

    Returns:
        Layers in spray order. ``info`` holds ``rmse`` (0-255 units, RMS over
        pixels and channels), ``rmse_channels`` (R, G, B), ``iterations``,
        ``warnings``, ``seconds``, ``energy`` (total and unweighted terms at the
        finest level), ``levels`` (per pyramid level: shape, iterations, start
        and end energy), ``order`` (for a palette list: the list index of each
        paint, in spray order; for 'auto': K-means cluster indices, primer
        first), ``cans_chosen`` (when a palette list is longer than
        ``layers``) and ``source`` ('rgb', 'grey' or 'alpha'). ``energy_trace`` is the
        energy at the finest level (of the last re-solve when layers were
        dropped), starting value first, then one per iteration.

        Fewer layers than ``cfg.layers`` come back, each with a warning, when
        the image has fewer distinct colours than primer + layers (counted on
        ``picture.distinct_colours``, the source file before resampling, when
        known), and when a solved layer adds nothing: its opacity stays below
        ``cfg.min_opacity``, or its paint is within ``cfg.min_delta_e``
        (CIEDE2000) of the primer or of another paint.

        Of spray orders whose trial solves reconstruct the image equally well,
        the one spraying the least paint is taken, then the lightest primer: a
        two-colour image gets the colour covering most of the area as primer and
        paint only where the ink is.

    Raises:
        ValueError: ``opacity_source`` is 'alpha' and the picture has no alpha;
            or the image is one flat colour (no layer carries ink; the message
            names the primer colour).
    """
    t0 = time.perf_counter()
    source = _source(picture, cfg)
    if source != "rgb":
        return _single_layer(picture, cfg, source, t0)
    warnings: list[str] = []
    s = _settings(cfg)
    target = np.ascontiguousarray(np.clip(np.nan_to_num(picture.rgb, nan=0.0), 0.0, 1.0), dtype=np.float64)
    order_info: dict = {}
    best, free = _best_start(picture, cfg, target, s, rng, warnings, order_info, reach)
    levels: list[dict] = []
    counter = [0]

    def report(e: float) -> None:
        counter[0] += 1
        if progress is not None:
            progress(counter[0], float(e))

    state = _solve_pyramid(target, best[0], best[1], free, cfg, s, report, levels)
    fixed_palette = cfg.palette_rgb()
    # The order list holds the primer's cluster first only when K-means chose the primer too.
    order_offset = 1 if (fixed_palette is None and cfg.primer_rgb() is None) else 0
    state, order_kept = _drop_redundant(
        state, [int(i) for i in best[2]], order_offset, picture, cfg, s, report, levels, warnings
    )
    fixed = fixed_palette is not None
    return _layers(state, target, picture, source, fixed, s, levels, warnings, order_kept, order_info, t0)


def _layers(
    state: State,
    target: np.ndarray,
    picture: Picture,
    source: str,
    fixed: bool,
    s: SolverSettings,
    levels: list[dict],
    warnings: list[str],
    order_kept: list[int],
    order_info: dict,
    t0: float,
) -> Layers:
    """The solved state as Layers, with the figures :func:`decompose` documents in ``info``."""
    alphas = np.clip(np.nan_to_num(state.alphas, nan=0.0), 0.0, 1.0)
    colours = np.clip(np.nan_to_num(state.colours, nan=0.0), 0.0, 1.0)
    primer = np.clip(np.nan_to_num(state.primer, nan=1.0), 0.0, 1.0)
    comp = energy.composite_nb(primer, colours, alphas)
    rmse, per = _rmse(comp, target)
    if fixed and rmse > _FIXED_PALETTE_WARN_RMSE:
        warnings.append(
            f"the fixed palette reaches the image only to RMSE {rmse:.1f} (0-255 units): "
            "some image colours lie outside what these cans can mix"
        )
    data, smooth, sparse = energy.energy_terms(target, primer, colours, alphas)
    for w in warnings:
        log.warning(w)
    info = {
        "source": source,
        "rmse": rmse,
        "rmse_channels": per,
        "iterations": int(sum(lv["iterations"] for lv in levels)),
        "warnings": warnings,
        "seconds": time.perf_counter() - t0,
        "energy": {
            "total": float(s.g_data * data + s.g_smooth * smooth + s.g_sparse * sparse),
            "data": float(data),
            "smooth": float(smooth),
            "sparse": float(sparse),
        },
        "levels": levels,
        "order": order_kept,
        **order_info,
    }
    return Layers(
        primer=primer,
        colours=colours,
        alphas=alphas,
        mm_per_px=picture.mm_per_px,
        energy_trace=tuple(float(e) for e in state.trace),
        iterations=int(info["iterations"]),
        info=info,
    )


def _level_record(state: State, its: int, **extra: object) -> dict:
    """What the manifest records of one solve: grid shape, iterations, start and end energy."""
    return {
        "shape": [int(state.target.shape[0]), int(state.target.shape[1])],
        "iterations": int(its),
        "energy_start": float(state.trace[0]),
        "energy_end": float(state.trace[-1]),
        "mean_sweeps": float(np.mean(state.sweeps)) if state.sweeps else 0.0,
        **extra,
    }


def _solve_pyramid(
    target: np.ndarray,
    primer: np.ndarray,
    colours: np.ndarray,
    free: np.ndarray,
    cfg: DecomposeConfig,
    s: SolverSettings,
    report: Callable[[float], None],
    levels: list[dict],
) -> State:
    """Solve coarse to fine (or on the finest grid only), each level starting from the last."""
    full_shape = target.shape[:2]
    shapes = solver.pyramid_shapes(full_shape, cfg.coarse_size_px)
    levels_used = shapes if cfg.coarse_to_fine else [full_shape]
    state: State | None = None
    for level, shape in enumerate(levels_used):
        finest = level == len(levels_used) - 1
        level_target = solver.downsample(target, shape)
        if state is None:
            state = _state(level_target, primer, colours, free)
        else:
            state = State(
                target=level_target,
                primer=state.primer,
                colours=state.colours,
                alphas=np.ascontiguousarray(solver.upsample_alphas(state.alphas, shape)),
                free=free,
            )
        # Levels far coarser than the finest cost little per iteration, and the
        # better the start they hand on, the fewer expensive fine iterations.
        cheap = shape[0] * shape[1] * 16 <= full_shape[0] * full_shape[1]
        tol = cfg.tolerance * _COARSE_TOLERANCE_FACTOR if cheap and not finest else cfg.tolerance
        its = solver.iterate(state, s, cfg.max_iterations, tol, report)
        levels.append(_level_record(state, its))
    assert state is not None
    return state


def _drop_redundant(
    state: State,
    order_kept: list[int],
    order_offset: int,
    picture: Picture,
    cfg: DecomposeConfig,
    s: SolverSettings,
    report: Callable[[float], None],
    levels: list[dict],
    warnings: list[str],
) -> tuple[State, list[int]]:
    """Drop the layers that add nothing (no ink, the primer's colour, a twin of another paint).

    One at a time, re-solving the rest on the finest grid.

    Raises:
        ValueError: Every layer was dropped (a flat image, or a config that finds no ink).
    """
    dropped = []
    n_solved = int(state.colours.shape[0])
    free = state.free
    while True:
        found = _redundant_layer(state.primer, state.colours, state.alphas, cfg)
        if found is None:
            break
        idx, reason = found
        dropped.append(reason)
        keep = np.array([i for i in range(state.colours.shape[0]) if i != idx], dtype=np.int64)
        del order_kept[order_offset + idx]
        if keep.size == 0:
            for w in warnings + dropped:
                log.warning(w)
            rgb = np.clip(np.nan_to_num(picture.rgb, nan=0.0), 0.0, 1.0).reshape(-1, 3)
            if distinct_colours(rgb, 2) > 1 and (picture.distinct_colours or 2) > 1:
                raise ValueError(
                    f"no paint layer carries ink (all {n_solved} were dropped as redundant): the best "
                    f"this decompose section finds is the primer {to_hex(state.primer)} alone; check "
                    "decompose.palette, min_opacity and min_delta_e"
                )
            raise _flat_error(state.primer)
        free = np.concatenate([free[:1], free[1:][keep]])
        state = State(
            target=state.target,
            primer=state.primer,
            colours=np.ascontiguousarray(state.colours[keep]),
            alphas=np.ascontiguousarray(state.alphas[keep]),
            free=free,
        )
        its = solver.iterate(state, s, cfg.max_iterations, cfg.tolerance, report)
        levels.append(_level_record(state, its, after_drop=reason))
    if dropped:
        warnings.extend(dropped)
        warnings.append(
            f"{len(dropped)} redundant layer(s) dropped: {state.colours.shape[0]} of {n_solved} layer(s) left"
        )
    return state, order_kept
