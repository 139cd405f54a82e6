"""Lloyd's start points: a density sampled along a Hilbert curve, and the curve's order of points.

Lloyd relaxation moves its seeds only so far per pass, so the passes it needs depend on how far
the start lies from a centroidal Voronoi tessellation. An independent importance sample (each point
drawn on its own) leaves clumps and gaps at every scale. :func:`stratified_sample` instead takes
the pixels in the order of a Hilbert curve and places the ``k``-th point where the running sum of
the density passes ``(u + k)`` shares of its total (systematic sampling along a space-filling
curve: Steigleder & McCool 2003, "Generalized stratified sampling using the Hilbert curve"). The
curve keeps neighbours close, so every stretch of it, and with it every compact region of the
picture, holds its expected number of points to within one.

Measured on the bundled example's eight plates (the 5 mm wall's trial, ``stencil-cad run``): Lloyd
took 155 passes in all rather than 193 (17 to 22 on the seven plates of over 200 holes rather than
23 to 25), the normalised CVT energy lower on all seven, and the job's S-CIELAB 2.575 rather than
2.681 at 1 m and 1.612 rather than 1.657 at 2 m. On ``python -m benchmarks fidelity``'s 12 FDM
pictures every wall stayed; 8 scored better at 1 m (0.5 to 4.8 %: immunohistochemistry 2.055 to
1.957, low_contrast 0.669 to 0.640), the dark sky the same (its plates hold under 200 holes), and
rocket, hubble_deep_field and saturated within 0.6 % worse; the median 0.372 times the hard
stencil's S-CIELAB at 1 m (0.371) and 0.285 at 2 m (0.295). The worst can of the prior (a fat cap
with a light coat) scored 0.2 to 2.5 % worse on 9 of them (text 8.88 to 9.11; the example 10.47
to 10.60), the same or better on the other 3. On its 12 SLA pictures likewise: 8
better (0.2 to 2.9 %), the dark sky the same, rocket, logo and saturated within 0.7 % worse, the
median 0.371 (0.370) and 0.282 (0.284). A mural's tiles keep independent draws
(:func:`stencil_cad.stipple.relax.place_holes` given a region): started so, the 600 x 400 mm coffee
mural (``python -m benchmarks mural --case mural600``) scored 1.90 rather than 2.02 at 3 m, but on
the flat grey of ``tests/mural/test_stipple.py`` one seam's 5 mm band came out 5 to 6 % sparser
than its flanks, twice the interior's spread.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

#: Side of the Hilbert curve's grid :func:`hilbert_order` orders points on (a power of two).
HILBERT_SIDE = 1024
#: :func:`stratified_sample` follows the curve over blocks of this many pixels a side, and each
#: block's pixels row by row: a Lloyd cell covers about 100 pixels
#: (:data:`stencil_cad.stipple.relax.PX_PER_DOT`), so a block lies within one, and the order of a
#: 900 x 900 grid costs a sixteenth of a curve through every pixel.
BLOCK_PX = 4
#: Layers of fewer holes start from independent draws (:func:`start_sample`). Lloyd from the
#: stratified start on 95 plates of six fidelity pictures (``python -m benchmarks fidelity``; medians of
#: three seeds): of the 66 with 200 holes or more, it took fewer passes on 64 (16 to 19 rather than
#: 21 to 27 on those of over 1000) and ended at a lower CVT energy on 64; below 200 it saved no
#: passes, and on the dark sky's plates of 9 to 108 holes, whose stars are smaller than a hole's
#: cell, it ended up to twice as high as often as lower (the picture's S-CIELAB 1.17 rather than
#: 1.08 at 1 m).
STRATIFIED_MIN_DOTS = 200


def _hilbert_index(y: np.ndarray, x: np.ndarray, side: int) -> np.ndarray:
    """Distance along a Hilbert curve over a ``side`` x ``side`` grid (a power of two) of cells ``(y, x)``."""
    y, x = y.astype(np.int64), x.astype(np.int64)
    d = np.zeros(len(y), dtype=np.int64)
    s = side // 2
    while s > 0:
        rx, ry = (x & s) > 0, (y & s) > 0
        d += s * s * ((3 * rx.astype(np.int64)) ^ ry.astype(np.int64))
        turn = ~ry
        flip = turn & rx
        x, y = np.where(flip, s - 1 - x, x), np.where(flip, s - 1 - y, y)
        x, y = np.where(turn, y, x), np.where(turn, x, y)
        s //= 2
    return d


def hilbert_order(points: np.ndarray, side: int = HILBERT_SIDE) -> np.ndarray:
    """The indices of ``points`` ``(N, 2)`` in order along a Hilbert curve over their bounding box."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if len(p) == 0:
        return np.zeros(0, dtype=np.int64)
    lo, span = p.min(axis=0), np.ptp(p, axis=0)
    q = np.clip(((p - lo) / np.maximum(span, 1e-12) * (side - 1)).astype(np.int64), 0, side - 1)
    return np.argsort(_hilbert_index(q[:, 0], q[:, 1], side), kind="stable")


@lru_cache(maxsize=2)
def pixel_order(h: int, w: int) -> np.ndarray:
    """The flat indices of an ``h`` x ``w`` grid's pixels along a Hilbert curve over its blocks.

    The curve visits blocks of :data:`BLOCK_PX` pixels a side; within a block, row by row. Kept,
    read-only, for the two grids last asked for (a job's plates relax on one or two): 4 bytes a
    pixel, 64 MB for the largest Lloyd grid (:data:`stencil_cad.stipple.relax.MAX_GRID_PX`).
    """
    bh, bw = -(-h // BLOCK_PX), -(-w // BLOCK_PX)
    side = 1 << max(int(np.ceil(np.log2(max(bh, bw, 1)))), 0)
    by, bx = np.divmod(np.arange(bh * bw, dtype=np.int64), bw)
    blocks = np.argsort(_hilbert_index(by, bx, side), kind="stable")
    dr, dc = np.divmod(np.arange(BLOCK_PX * BLOCK_PX, dtype=np.int64), BLOCK_PX)
    rows = (by[blocks] * BLOCK_PX)[:, None] + dr[None, :]
    cols = (bx[blocks] * BLOCK_PX)[:, None] + dc[None, :]
    inside = (rows < h) & (cols < w)
    order = (rows * w + cols)[inside].astype(np.int32 if h * w < 2**31 else np.int64)
    order.setflags(write=False)
    return order


def importance_sample(lam: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Draw ``n`` points with probability proportional to ``lam`` (not dithering).

    Args:
        lam: ``(H, W)`` non-negative point density.
        n: Number of points.
        rng: Random generator.

    Returns:
        ``(n, 2)`` positions in px (row, col), uniformly jittered inside the
        chosen pixels.
    """
    flat = np.cumsum(lam, axis=None, dtype=np.float64)
    total = flat[-1]
    if n <= 0 or total <= 0:
        return np.empty((0, 2))
    idx = np.searchsorted(flat, rng.random(n) * total, side="right")
    idx = np.minimum(idx, flat.size - 1)
    rows, cols = np.divmod(idx, lam.shape[1])
    jitter = rng.random((n, 2)) - 0.5
    return np.column_stack([rows, cols]).astype(np.float64) + jitter


def start_sample(lam: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """Lloyd's start of ``n`` seeds for the point density ``lam``.

    :func:`stratified_sample` from :data:`STRATIFIED_MIN_DOTS` seeds on, else independent draws
    (:func:`importance_sample`).
    """
    return stratified_sample(lam, n, rng) if n >= STRATIFIED_MIN_DOTS else importance_sample(lam, n, rng)


def stratified_sample(lam: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    """``n`` points of density proportional to ``lam``, one per ``1/n`` of its mass along a Hilbert curve.

    Args:
        lam: ``(H, W)`` non-negative point density.
        n: Number of points.
        rng: Random generator (the curve's offset and each point's place in its pixel).

    Returns:
        ``(n, 2)`` positions in px (row, col), uniformly jittered inside the chosen pixels, in
        the curve's order.
    """
    lam = np.asarray(lam, dtype=np.float64)
    order = pixel_order(*lam.shape)
    cum = np.cumsum(lam.ravel()[order])
    if n <= 0 or len(cum) == 0 or cum[-1] <= 0:
        return np.empty((0, 2))
    picks = np.searchsorted(cum, (rng.random() + np.arange(n)) * (cum[-1] / n), side="right")
    rows, cols = np.divmod(order[np.minimum(picks, len(order) - 1)], lam.shape[1])
    jitter = rng.random((n, 2)) - 0.5
    return np.column_stack([rows, cols]).astype(np.float64) + jitter
