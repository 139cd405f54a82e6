"""Where the decomposition's solve starts: the starting colours and the spray order.

K-means colours for an automatic palette, or the cans chosen from a fixed one; every spray
order worth a trial is solved briefly on a small grid and the best one starts the pyramid
(see :func:`stencil_cad.decompose.decomposition.decompose`).
"""

from __future__ import annotations

import numpy as np

from ..colour import distinct_colours, kmeans
from ..config.decompose import DecomposeConfig, LayerOrder
from ..model import Picture
from . import energy, palette, solver
from .solver import SolverSettings, State
from .sprayed import PlateReach

# Longer side in px of the grid on which cans are chosen from a long palette
# and candidate spray orders are compared: enough to see the image's colour
# layout, small enough that dozens of trial solves take about a second.
_TRIAL_SIZE_PX = 48
_TRIAL_ITERATIONS = 15


# Candidate spray orders whose short trial solves reconstruct the image equally
# well (trial RMSE within this many 0-255 levels of the best) are told apart by
# how much paint they spray, not by energy: the sparsity term rewards covering
# bare primer with paint, so on a two-colour image it prefers a red primer with
# white sprayed over the large white background to a white primer with red
# only where the ink is.
_ORDER_TIE_RMSE = 0.5

#: Candidates whose predicted sprayed results (mean ΔE, :class:`PlateReach`) lie within this of the
#: best are tied, and told apart as equally faithful ideal fits are: the least paint, then the
#: lightest primer, then the prediction. Only equal predictions tie: a width of 0.1 ΔE took the
#: logo from 0.63 to 0.50 x its hard stencil but rocket from 0.46 to 0.52 x (SLA, S-CIELAB at 1 m,
#: ``python -m benchmarks quality``), so the proxy's own ranking is kept.
_SPRAYED_TIE_DE = 0.0

#: A pixel is flat when its 3 x 3 neighbourhood spans at most this (two 8-bit levels) per channel,
#: and a picture is flat-coloured (a logo, a poster) when this share of its pixels are flat: photos
#: have grain and gradients nearly everywhere (flat share: the bundled example 0.10, astronaut 0.10,
#: rocket 0.27, coffee 0.02; the generated logo 0.93 and dark sky 0.94).
_FLAT_TOL = 2.0 / 255.0
_FLAT_SHARE = 0.8


def flat_pixels(target: np.ndarray) -> np.ndarray | None:
    """The pixels of a flat-colour picture that lie inside its flat areas, or None for other pictures.

    A pixel is flat when its 3 x 3 neighbourhood stays within :data:`_FLAT_TOL` in every channel;
    a picture is flat-coloured when at least :data:`_FLAT_SHARE` of its pixels are.

    Args:
        target: ``(H, W, 3)`` the picture.

    Returns:
        ``(N, 3)`` the flat pixels, or None.
    """
    from scipy import ndimage as ndi

    rgb = np.asarray(target, dtype=np.float64)
    if rgb.ndim != 3 or min(rgb.shape[:2]) < 3:
        return None
    spread = np.stack(
        [ndi.maximum_filter(rgb[..., c], 3) - ndi.minimum_filter(rgb[..., c], 3) for c in range(3)], axis=-1
    )
    flat = np.all(spread <= _FLAT_TOL, axis=-1)
    if flat.mean() < _FLAT_SHARE:
        return None
    return rgb[flat]


def _orders(
    primer_fixed: bool, colours: np.ndarray, shares: np.ndarray | None, mode: LayerOrder
) -> list[np.ndarray]:
    """Candidate spray orders (index arrays into ``colours``, primer first unless fixed)."""
    lum = palette.luminance(colours)
    light = np.argsort(-lum, kind="stable")
    cands = []
    if mode is LayerOrder.given:
        cands.append(np.arange(colours.shape[0]))
    else:
        cands.append(light)
        if mode is LayerOrder.auto:
            cands.append(light[::-1])
            if shares is not None:
                by_share = np.argsort(-shares, kind="stable")
                cands.append(by_share)
                if not primer_fixed:
                    rest = np.array([i for i in by_share if i != light[0]], dtype=np.int64)
                    cands.append(np.concatenate([[light[0]], rest]))
    unique: list[np.ndarray] = []
    for c in cands:
        if not any(np.array_equal(c, u) for u in unique):
            unique.append(np.asarray(c, dtype=np.int64))
    return unique


def _state(target: np.ndarray, primer: np.ndarray, colours: np.ndarray, free: np.ndarray) -> State:
    alphas = palette.hard_alphas(target, primer, colours)
    return State(
        target=target,
        primer=primer.astype(np.float64).copy(),
        colours=np.ascontiguousarray(colours, dtype=np.float64),
        alphas=np.ascontiguousarray(alphas),
        free=free.copy(),
    )


def _select_cans(
    target: np.ndarray, cans: np.ndarray, primer: np.ndarray, primer_free: bool, n: int, s: SolverSettings
) -> np.ndarray:
    """Greedy forward choice of ``n`` cans that reach the lowest energy on a small grid."""
    chosen: list[int] = []
    remaining = list(range(cans.shape[0]))
    free = np.zeros(n + 1, dtype=bool)
    free[0] = primer_free
    for k in range(n):
        best, best_e = remaining[0], np.inf
        for idx in remaining:
            sel = np.array(chosen + [idx])
            order = sel[np.argsort(-palette.luminance(cans[sel]), kind="stable")]
            st = _state(target, primer, cans[order], free[: k + 2])
            solver.iterate(st, s, _TRIAL_ITERATIONS, s.tolerance)
            if st.trace[-1] < best_e:
                best, best_e = idx, st.trace[-1]
        chosen.append(best)
        remaining.remove(best)
    return np.array(sorted(chosen), dtype=np.int64)


def _best_start(
    picture: Picture,
    cfg: DecomposeConfig,
    target: np.ndarray,
    s: SolverSettings,
    rng: np.random.Generator,
    warnings: list[str],
    order_info: dict,
    reach: PlateReach | None = None,
) -> tuple[tuple[np.ndarray, np.ndarray, np.ndarray], np.ndarray]:
    """The start ``(primer, paints, order)`` whose short trial solve does best, and which colours move.

    With ``reach`` the trials are ranked by what plates would spray of them (:mod:`.sprayed`).
    """
    trial_shape = solver.pyramid_shapes(target.shape[:2], _TRIAL_SIZE_PX)[0]
    trial_target = solver.downsample(target, trial_shape)
    candidates, free = _start_candidates(picture, cfg, target, trial_target, s, rng, warnings, order_info)
    return _pick_order(candidates, free, trial_target, s, order_info, reach), free


def _start_candidates(
    picture: Picture,
    cfg: DecomposeConfig,
    target: np.ndarray,
    trial_target: np.ndarray,
    s: SolverSettings,
    rng: np.random.Generator,
    warnings: list[str],
    order_info: dict,
) -> tuple[list[tuple[np.ndarray, np.ndarray, np.ndarray]], np.ndarray]:
    """The start (primer, paints, order) of every spray order worth a trial, and which colours move.

    K-means colours for an automatic palette (fewer when the image has fewer distinct
    colours, with a warning); the chosen cans of a fixed palette otherwise.
    """
    pixels = target.reshape(-1, 3)
    fixed_primer = cfg.primer_rgb()
    primer_free = fixed_primer is None
    fixed_palette = cfg.palette_rgb()
    hexes = cfg.palette_hex() or ()
    n_layers = cfg.layers
    if fixed_palette is None:
        k = n_layers + int(primer_free)
        distinct = distinct_colours(pixels, k)
        if picture.distinct_colours is not None:
            # Resampling blends edges into colours the source does not have.
            distinct = min(distinct, max(int(picture.distinct_colours), 1))
        if distinct < k:
            n_layers = max(distinct - int(primer_free), 1)
            warnings.append(
                f"the image has only {distinct} distinct colour(s): using {n_layers} layer(s) instead of {cfg.layers}"
            )
            k = min(n_layers + int(primer_free), distinct)
        clusterings = [kmeans(pixels, k, rng)]
        flat = flat_pixels(target)
        if flat is not None and distinct_colours(flat, k) >= k:
            # Flat-colour art: its edges' blends outnumber a small shape's colour (a logo's black
            # square lost its paint to the pink of a red ring's rim); K-means on the flat pixels
            # alone finds the inks, and starts from them compete with the others.
            clusterings.append(kmeans(flat, k, rng))
        free = np.ones(n_layers + 1, dtype=bool)
        free[0] = primer_free
        candidates = []
        for centres, shares in clusterings:
            centres = np.clip(centres, 0.0, 1.0)
            if centres.shape[0] < n_layers + int(primer_free):
                # One colour, primer solved: paint and primer start equal.
                centres = np.vstack([centres, centres[:1]])
                shares = np.append(shares, 0.0)
            for order in _orders(not primer_free, centres, shares, cfg.order):
                if primer_free:
                    candidates.append((centres[order[0]], centres[order[1:]], order))
                else:
                    candidates.append((np.array(fixed_primer), centres[order], order))
        return candidates, free
    cans = np.array(fixed_palette)
    if primer_free:
        # Start the primer at the K-means centre farthest from every can.
        n_distinct = distinct_colours(pixels, 64)
        if picture.distinct_colours is not None:
            n_distinct = min(n_distinct, max(int(picture.distinct_colours), 1))
        centres = np.clip(kmeans(pixels, min(len(cans) + 1, n_distinct), rng)[0], 0.0, 1.0)
        far = np.min(np.sum((centres[:, None, :] - cans[None, :, :]) ** 2, axis=2), axis=1)
        primer0 = centres[int(np.argmax(far))]
    else:
        primer0 = np.array(fixed_primer)
    chosen = np.arange(len(cans))
    if len(cans) > n_layers:
        chosen = _select_cans(trial_target, cans, primer0, primer_free, n_layers, s)
        order_info["cans_chosen"] = [hexes[i] for i in chosen]
    n_layers = len(chosen)
    free = np.zeros(n_layers + 1, dtype=bool)
    free[0] = primer_free
    candidates = [(primer0, cans[chosen[o]], chosen[o]) for o in _orders(True, cans[chosen], None, cfg.order)]
    return candidates, free


def _pick_order(
    candidates: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
    free: np.ndarray,
    trial_target: np.ndarray,
    s: SolverSettings,
    order_info: dict,
    reach: PlateReach | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Compare candidate spray orders by a short solve; the best one.

    Without ``reach``, by the energy the solve reaches (the ideal layers' fit). With it, by the
    predicted error of what plates would spray of the trial layers
    (:meth:`stencil_cad.decompose.sprayed.PlateReach.error`).
    """
    if len(candidates) == 1:
        return candidates[0]
    trial_e, trial_rmse, trial_paint, sprayed = [], [], [], []
    for p0, c0, _ in candidates:
        st = _state(trial_target, p0, c0, free)
        solver.iterate(st, s, _TRIAL_ITERATIONS, s.tolerance)
        trial_e.append(st.trace[-1])
        d, _, _ = energy.energy_terms(st.target, st.primer, st.colours, st.alphas)
        trial_rmse.append(float(np.sqrt(d / st.target.size) * 255.0))
        trial_paint.append(float(st.alphas.sum(axis=0).mean()))
        if reach is not None:
            sprayed.append(reach.error(st.target, st.primer, st.colours, st.alphas))
    if reach is not None:
        # The predicted mean ΔE of each candidate's sprayed result.
        order_info["trial_sprayed_de"] = [round(float(e), 3) for e in sprayed]
        order_info["trial_rmse"] = trial_rmse
        order_info["trial_paint"] = trial_paint
        return candidates[_least_paint(candidates, sprayed, trial_paint, _SPRAYED_TIE_DE)]
    pick = int(np.argmin(trial_e))
    # Equally faithful orders: the one spraying the least paint (mean total
    # opacity, to 0.01) wins, so the primer is the colour covering most of
    # the area; then the lightest primer; then the lowest energy.
    ties = [i for i in range(len(candidates)) if trial_rmse[i] <= trial_rmse[pick] + _ORDER_TIE_RMSE]
    if len(ties) > 1:
        pick = min(ties, key=lambda i: (_tie_key(candidates, trial_paint, i), trial_e[i]))
    order_info["trial_energies"] = [float(e) for e in trial_e]
    order_info["trial_rmse"] = trial_rmse
    order_info["trial_paint"] = trial_paint
    return candidates[pick]


def _tie_key(
    candidates: list[tuple[np.ndarray, np.ndarray, np.ndarray]], paint: list[float], i: int
) -> tuple[float, float]:
    """How tied candidates are told apart: the least paint (mean total opacity, to 0.01), then the lightest primer."""
    return round(paint[i], 2), -round(float(palette.luminance(candidates[i][0])), 3)


def _least_paint(
    candidates: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
    score: list[float],
    paint: list[float],
    tie: float,
) -> int:
    """The best-scoring candidate, or among those within ``tie`` of it the one spraying the least paint.

    Ties go by :func:`_tie_key`, then by ``score``.
    """
    best = int(np.argmin(score))
    ties = [i for i in range(len(candidates)) if score[i] <= score[best] + tie]
    return min(ties, key=lambda i: (_tie_key(candidates, paint, i), score[i]))
