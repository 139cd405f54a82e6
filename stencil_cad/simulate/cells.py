"""A picture's means over cells of its mirrored extension, with numpy's bits and without making the extension.

S-CIELAB applies its wide Gaussians on a block-averaged copy of the picture mirrored past its
edges (:mod:`.scielab`); seen from far, the mirror is several times the picture. The means here
are those of ``np.pad(..., mode="symmetric")`` followed by ``reshape(...).mean(axis=(1, 3))``,
to the last bit (tested on many shapes), in a fraction of the time and memory.
"""

from __future__ import annotations

import functools

import numpy as np

from ..filters import correlate_axis, taps

__all__ = ["cell_means", "gaussian_reflect", "mirrored", "pairwise"]


def mirrored(n: int, before: int, after: int) -> np.ndarray:
    """The indices of ``np.pad(x, (before, after), mode="symmetric")`` into ``x`` of length ``n``, any widths."""
    i = np.mod(np.arange(-before, n + after), 2 * n)
    return np.where(i < n, i, 2 * n - 1 - i)


def cell_means(channel: np.ndarray, rows: np.ndarray, cols: np.ndarray, f: int) -> np.ndarray:
    """``padded.reshape(hs, f, ws, f).mean(axis=(1, 3))`` of ``padded = channel[rows][:, cols]``, the same bits.

    numpy sums a cell row by row: the ``f`` values of each row pairwise (:func:`pairwise`), the
    rows in order. Done so here, each row's sums come from the picture's own rows, and the mirrored
    picture (several times the picture's pixels for a wide Gaussian seen from far) is never made:
    0.04 s instead of 1.2 s for the 7° Gaussian of a 1600 x 2400 px picture seen from 3 m.
    """
    ws = len(cols) // f
    sums = pairwise(channel[:, cols].reshape(channel.shape[0], ws, f))
    acc = sums[rows[0::f]]
    for a in range(1, f):
        acc += sums[rows[a::f]]
    return acc / (f * f)


def pairwise(x: np.ndarray) -> np.ndarray:
    """The sums along the last axis as numpy's pairwise summation adds a contiguous run (the same bits).

    Under 8 values one after another; up to 128 in eight interleaved partial sums added as a
    tree, the rest one by one; longer runs halved (at a multiple of 8) and each half summed so.
    """
    n = x.shape[-1]
    if n < 8:
        res = np.zeros(x.shape[:-1])
        for i in range(n):
            res += x[..., i]
        return res
    if n <= 128:
        part = [x[..., j].copy() for j in range(8)]
        m = n - n % 8
        for i in range(8, m, 8):
            for j in range(8):
                part[j] += x[..., i + j]
        res = ((part[0] + part[1]) + (part[2] + part[3])) + ((part[4] + part[5]) + (part[6] + part[7]))
        for i in range(m, n):
            res += x[..., i]
        return res
    half = n // 2
    half -= half % 8
    return pairwise(x[..., :half]) + pairwise(x[..., half:])


def gaussian_reflect(x: np.ndarray, sigma: float) -> np.ndarray:
    """The Gaussian filter of a 2-D map as scipy's ``gaussian_filter(x, sigma, mode="reflect", truncate=4.0)``, to rounding.

    Along an axis whose kernel (``2 int(4 sigma + 0.5) + 1`` taps) is longer than the map, the filter
    is one matrix (:func:`_reflect_operator`) applied by BLAS; along the others, scipy's kernel by
    :func:`correlate_axis`. Seen from far, a picture's widest Gaussian spans many times the cells of a
    small patch: the bundled example's visibility check (three 30 mm squares, six distances) took 2.25 CPU-s, 2.1 of
    them in scipy's filter (2,215 taps over 362 cells at 4 m), and takes 0.36 with the matrices
    (values within 2e-15 of scipy's; the job's files unchanged: ``python -m benchmarks.compare_outputs``).
    """
    out = np.asarray(x, dtype=np.float64)
    for axis in (0, 1):
        n = out.shape[axis]
        if 2 * int(4.0 * float(sigma) + 0.5) + 1 > n:
            op = _reflect_operator(n, float(sigma))
            # One BLAS thread: these products take a millisecond, and OpenBLAS's second thread, woken
            # for each, made a 362-cell product cost 31 ms of CPU instead of 5 on a loaded two-core machine.
            with _blas().limit(limits=1, user_api="blas"):
                out = op @ out if axis == 0 else out @ op.T
        else:
            out = correlate_axis(out, taps(float(sigma), 4.0), axis, "reflect")
    return out


@functools.cache
def _blas():
    """The process's thread pools (OpenBLAS's among them), found once."""
    from threadpoolctl import ThreadpoolController

    return ThreadpoolController()


@functools.lru_cache(maxsize=8)
def _reflect_operator(n: int, sigma: float) -> np.ndarray:
    """The ``(n, n)`` matrix of scipy's 1-D Gaussian (truncated at 4 sigma) on a line mirrored past both ends.

    scipy's ``reflect`` extends a line of ``n`` values as a mirror of period ``2 n``; the kernel's taps are
    folded onto one period, then each output's taps onto the line's own values. Kept for the few sizes a
    job scores at (the reference and the sprayed patch, each channel, share one).
    """
    radius = int(4.0 * sigma + 0.5)
    w = taps(sigma, 4.0)
    period = 2 * n
    folded = np.bincount(np.mod(np.arange(-radius, radius + 1), period), weights=w, minlength=period)
    rows = np.arange(n)[:, None]
    at = np.mod(rows + np.arange(period)[None, :], period)
    at = np.where(at < n, at, period - 1 - at)
    op = np.bincount((rows * n + at).ravel(), weights=np.tile(folded, n), minlength=n * n).reshape(n, n)
    op.setflags(write=False)
    return op
