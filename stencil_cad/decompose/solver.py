"""Block coordinate descent on the decomposition energy, coarse to fine.

One iteration solves every layer's opacity QP in spray order (exactly, by
projected SOR, see :mod:`.energy`) and then all free colours at once by bounded
least squares on the ``(L+1) x (L+1)`` normal equations. Each block step is an
exact (or verified) minimisation over its block, so the energy never increases.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg
from scipy.optimize import lsq_linear

from ..filters import resize_linear
from . import energy as en

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class SolverSettings:
    """Numbers the block solver needs (taken from ``DecomposeConfig``)."""

    g_data: float
    g_smooth: float
    g_sparse: float
    tolerance: float
    max_iterations: int
    inner_tolerance: float
    inner_max_sweeps: int


@dataclass
class State:
    """A decomposition being solved on one grid.

    Attributes:
        target: ``(H, W, 3)`` image Y.
        primer: ``(3,)``.
        colours: ``(L, 3)``.
        alphas: ``(L, H, W)`` C-contiguous float64.
        free: ``(L + 1,)`` bool, which of primer + colours the colour step may move.
        trace: Energy after each iteration on this grid.
        sweeps: Projected SOR sweeps run per layer solve (for the report).
    """

    target: np.ndarray
    primer: np.ndarray
    colours: np.ndarray
    alphas: np.ndarray
    free: np.ndarray
    trace: list[float] = field(default_factory=list)
    sweeps: list[int] = field(default_factory=list)


def total_energy(state: State, s: SolverSettings) -> float:
    """The weighted energy of a state."""
    data, smooth, sparse = en.energy_terms(state.target, state.primer, state.colours, state.alphas)
    return s.g_data * data + s.g_smooth * smooth + s.g_sparse * sparse


def colour_step(state: State) -> None:
    """Move the free colours to the bounded least-squares optimum of the data term.

    The data term is ``sum_ch c_ch^T G c_ch - 2 c_ch^T b_ch + |y_ch|^2`` with
    ``G = W^T W``. A tiny ridge towards the current colours keeps the system
    positive definite when a layer is empty; the minimiser of the ridged problem
    can only lower the true objective, and the result is checked anyway.
    """
    free = np.flatnonzero(state.free)
    if free.size == 0:
        return
    fixed = np.flatnonzero(~state.free)
    gram, rhs, yy = en.colour_normal_equations(state.target, state.alphas)
    cur = np.vstack([state.primer[None, :], state.colours])

    def objective(c: np.ndarray) -> float:
        return float(np.einsum("kc,km,mc->", c, gram, c) - 2.0 * np.sum(c * rhs) + yy.sum())

    gff = gram[np.ix_(free, free)]
    ridge = 1e-10 * max(float(np.trace(gff)) / free.size, 1e-12)
    gr = gff + ridge * np.eye(free.size)
    chol = scipy.linalg.cholesky(gr, lower=False)
    new = cur.copy()
    for ch in range(3):
        b = rhs[free, ch] + ridge * cur[free, ch]
        if fixed.size:
            b = b - gram[np.ix_(free, fixed)] @ cur[fixed, ch]
        x = scipy.linalg.cho_solve((chol, False), b)
        if np.all((x >= 0.0) & (x <= 1.0)):
            new[free, ch] = x
            continue
        # |R c - z|^2 = c^T Gr c - 2 c^T b + const with R^T z = b.
        z = scipy.linalg.solve_triangular(chol, b, trans="T", lower=False)
        res = lsq_linear(chol, z, bounds=(0.0, 1.0), method="bvls", tol=1e-12)
        new[free, ch] = np.clip(res.x, 0.0, 1.0)
    if objective(new) <= objective(cur):
        state.primer = new[0].copy()
        state.colours = new[1:].copy()


def _layer_steps(state: State, s: SolverSettings, trans, above, below, old) -> None:
    """Solve every layer's opacity in turn, bottom up, the others fixed (scratch arrays given)."""
    n_layers = state.alphas.shape[0]
    en.suffix_products(state.colours, state.alphas, trans, above)
    below[...] = state.primer
    total = state.alphas.sum(axis=0)
    for layer in range(n_layers):
        alpha = state.alphas[layer]
        old[...] = alpha
        sweeps = en.solve_layer(
            state.target,
            below,
            trans[layer],
            above[layer],
            state.colours[layer],
            alpha,
            total,
            s.g_data,
            s.g_smooth,
            s.g_sparse,
            en.SOR_OMEGA,
            s.inner_tolerance,
            s.inner_max_sweeps,
        )
        state.sweeps.append(int(sweeps))
        en.finish_layer(below, total, state.colours[layer], alpha, old)


def _extrapolated(
    state: State,
    s: SolverSettings,
    e: float,
    beta: float,
    prev_alphas,
    prev_primer,
    prev_colours,
    trial_alphas,
):
    """Try the step extrapolated by ``beta`` from the previous state; keep it if it lowers ``e``.

    Returns:
        ``(energy, next beta, scratch array for the next trial)``.
    """
    en.extrapolate(state.alphas, prev_alphas, beta, trial_alphas)
    primer = np.clip(state.primer + beta * (state.primer - prev_primer), 0.0, 1.0)
    colours = np.clip(state.colours + beta * (state.colours - prev_colours), 0.0, 1.0)
    # Fixed colours must not move.
    primer = np.where(state.free[0], primer, state.primer)
    colours = np.ascontiguousarray(np.where(state.free[1:, None], colours, state.colours))
    data, smooth, sparse = en.energy_terms(state.target, primer, colours, trial_alphas)
    e_trial = s.g_data * data + s.g_smooth * smooth + s.g_sparse * sparse
    if e_trial < e:
        state.alphas, trial_alphas = trial_alphas, state.alphas
        state.primer, state.colours = primer, colours
        return e_trial, min(beta * 1.5, _BETA_MAX), trial_alphas
    return e, max(beta * 0.5, _BETA_MIN), trial_alphas


def iterate(
    state: State,
    s: SolverSettings,
    max_iterations: int,
    tolerance: float,
    progress: Callable[[float], None] | None = None,
    extrapolate: bool = True,
) -> int:
    """Run block coordinate descent until the relative energy decrease is below ``tolerance``.

    After each sweep over the blocks the whole state is extrapolated along its
    last step (the "line search" acceleration of alternating least squares);
    the extrapolated point is kept only when it lowers the energy, so the
    trace stays monotone.

    Args:
        state: Updated in place; its ``trace`` gains one energy per iteration.
        s: Weights and inner solver settings.
        max_iterations: Most iterations.
        tolerance: Relative energy decrease that stops the loop.
        progress: Called with the energy after each iteration.
        extrapolate: Try the extrapolation step.

    Returns:
        Iterations run.
    """
    n_layers, h, w = state.alphas.shape
    trans = np.empty((n_layers, h, w))
    above = np.empty((n_layers, h, w, 3))
    below = np.empty((h, w, 3))
    old = np.empty((h, w))
    prev_alphas = np.empty_like(state.alphas)
    trial_alphas = np.empty_like(state.alphas)
    prev = total_energy(state, s)
    state.trace.append(prev)
    done = 0
    beta = _BETA_START
    for _ in range(max_iterations):
        done += 1
        prev_alphas[...] = state.alphas
        prev_primer, prev_colours = state.primer.copy(), state.colours.copy()
        state.colours = np.ascontiguousarray(state.colours)
        _layer_steps(state, s, trans, above, below, old)
        colour_step(state)
        e = total_energy(state, s)
        if extrapolate:
            e, beta, trial_alphas = _extrapolated(
                state, s, e, beta, prev_alphas, prev_primer, prev_colours, trial_alphas
            )
        state.trace.append(e)
        if progress is not None:
            progress(e)
        if prev - e <= tolerance * max(abs(prev), 1e-300):
            break
        prev = e
    return done


# Extrapolation factor: grows while the extrapolated point keeps lowering the
# energy and halves when it does not.
_BETA_START = 0.5
_BETA_MAX = 4.0
_BETA_MIN = 0.05


def pyramid_shapes(shape: tuple[int, int], coarse_size: int) -> list[tuple[int, int]]:
    """Grid shapes from coarse to fine, halving the longer side down to ``coarse_size``."""
    h, w = shape
    shapes = [(h, w)]
    while max(h, w) > coarse_size and min(h, w) >= 16:
        h, w = max((h + 1) // 2, 1), max((w + 1) // 2, 1)
        shapes.append((h, w))
    return shapes[::-1]


def downsample(image: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Area-averaged ``image`` at ``shape`` (anti-aliased)."""
    if image.shape[:2] == tuple(shape):
        return np.ascontiguousarray(image, dtype=np.float64)
    out = resize_linear(image, shape, "edge")
    return np.ascontiguousarray(np.clip(out, 0.0, 1.0), dtype=np.float64)


def upsample_alphas(alphas: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Bilinear ``(L, h, w)`` to ``(L, *shape)``, clipped to [0, 1]."""
    out = np.empty((alphas.shape[0], *shape))
    for layer, a in enumerate(alphas):
        out[layer] = resize_linear(a, shape, "edge", anti_aliasing=False)
    return np.clip(out, 0.0, 1.0)
