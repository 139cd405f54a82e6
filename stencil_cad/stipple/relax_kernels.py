"""Compiled kernels of the Lloyd relaxation: the exact nearest seed of every pixel and the per-seed sums.

The nearest-seed search buckets the seeds on a grid and visits them ring by ring around one
pixel tile at a time (see :func:`_nearest_seed`); :mod:`.relax` runs the relaxation on them.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..parallel import njit_parallel

# --------------------------------------------------------------------------- compiled kernels


@numba.njit(cache=True)
def _bucket_seeds(seeds, bsize, nby, nbx):  # pragma: no cover - compiled
    """Counting-sort seed indices by grid bucket; returns (start, order)."""
    n = seeds.shape[0]
    key = np.empty(n, dtype=np.int64)
    count = np.zeros(nby * nbx + 1, dtype=np.int64)
    for i in range(n):
        by = min(max(int(math.floor(seeds[i, 0] / bsize)), 0), nby - 1)
        bx = min(max(int(math.floor(seeds[i, 1] / bsize)), 0), nbx - 1)
        k = by * nbx + bx
        key[i] = k
        count[k + 1] += 1
    for k in range(nby * nbx):
        count[k + 1] += count[k]
    order = np.empty(n, dtype=np.int64)
    fill = count[:-1].copy()
    for i in range(n):
        k = key[i]
        order[fill[k]] = i
        fill[k] += 1
    return count, order


@numba.njit(cache=True)
def _start_tile(w, label, dist2, seeds, warm, r0, r1, c0, c1):  # pragma: no cover - compiled
    """Label a tile's pixels with their warm-start seed (or -2; -1 off the weight); ``(active, worst)``."""
    active = 0
    worst = 0.0
    for row in range(r0, r1):
        for col in range(c0, c1):
            if w[row, col] > 0.0:
                prev = label[row, col] if warm else -2
                if prev >= 0:
                    dr = row - seeds[prev, 0]
                    dc = col - seeds[prev, 1]
                    d2 = dr * dr + dc * dc
                else:
                    prev = -2
                    d2 = np.inf
                label[row, col] = prev
                dist2[row, col] = d2
                worst = max(worst, d2)
                active += 1
            else:
                label[row, col] = -1
                dist2[row, col] = 0.0
    return active, worst


@numba.njit(cache=True)
def _scan_bucket(b, start, order, seeds, label, dist2, worst, r0, r1, c0, c1):  # pragma: no cover - compiled
    """Offer every seed of bucket ``b`` to the tile's pixels, skipping seeds beyond ``worst``."""
    for q in range(start[b], start[b + 1]):
        s = order[q]
        sr = seeds[s, 0]
        sc = seeds[s, 1]
        # Distance from the seed to the tile's pixel-centre box.
        gr = max(r0 - sr, 0.0, sr - (r1 - 1))
        gc = max(c0 - sc, 0.0, sc - (c1 - 1))
        if gr * gr + gc * gc >= worst:
            continue
        for row in range(r0, r1):
            dr = row - sr
            dr2 = dr * dr
            for col in range(c0, c1):
                if label[row, col] == -1:
                    continue
                dc = col - sc
                d2 = dr2 + dc * dc
                if d2 < dist2[row, col]:
                    dist2[row, col] = d2
                    label[row, col] = s


@numba.njit(cache=True)
def _tile_worst(label, dist2, r0, r1, c0, c1):  # pragma: no cover - compiled
    """The largest current squared distance of the tile's labelled pixels."""
    worst = 0.0
    for row in range(r0, r1):
        for col in range(c0, c1):
            if label[row, col] != -1 and dist2[row, col] > worst:
                worst = dist2[row, col]
    return worst


@njit_parallel(cache=True)
def _nearest_seed(w, seeds, bsize, label, dist2, warm):  # pragma: no cover - compiled
    """Exact nearest seed of every pixel with ``w > 0`` (others get label -1).

    Pixels are processed one ``bsize`` square tile at a time. Seeds are visited
    ring by ring of buckets around the tile; a seed in ring ``k + 1`` is more
    than ``k * bsize`` px away from every pixel of the tile, so the search stops
    once the tile's worst current distance is within that bound. Seeds whose
    distance to the tile's box already exceeds that worst distance are skipped.
    With ``warm`` set, ``label`` holds the previous iteration's labels: the
    distance to that (moved) seed is a valid starting bound, which prunes most
    candidates from the first ring on.
    """
    h, wd = w.shape
    nby = (h + bsize - 1) // bsize
    nbx = (wd + bsize - 1) // bsize
    start, order = _bucket_seeds(seeds, bsize, nby, nbx)
    nring = max(nby, nbx)
    for tile in numba.prange(nby * nbx):
        ty = tile // nbx
        tx = tile % nbx
        r0 = ty * bsize
        r1 = min(r0 + bsize, h)
        c0 = tx * bsize
        c1 = min(c0 + bsize, wd)
        active, worst = _start_tile(w, label, dist2, seeds, warm, r0, r1, c0, c1)
        if active == 0:
            continue
        for ring in range(nring + 1):
            for by in range(ty - ring, ty + ring + 1):
                if by < 0 or by >= nby:
                    continue
                edge_row = by == ty - ring or by == ty + ring
                step = 1 if edge_row else 2 * ring
                bx = tx - ring
                while bx <= tx + ring:
                    if 0 <= bx < nbx:
                        _scan_bucket(by * nbx + bx, start, order, seeds, label, dist2, worst, r0, r1, c0, c1)
                    if ring == 0:
                        break
                    bx += step
            if ring == 0:
                # The bound after ring 0 is 0, which a tile's worst distance meets only when every
                # pixel lies on a seed; ring 1 then changes nothing (it only takes closer seeds). So
                # the tile's worst (a pass over its pixels) is first taken after ring 1: the same
                # labels, and the example job's Lloyd passes took 5.3 CPU-s instead of 6.0.
                continue
            worst = _tile_worst(label, dist2, r0, r1, c0, c1)
            bound = ring * bsize
            if worst <= bound * bound:
                break


@numba.njit(cache=True)
def _accumulate(w, label, dist2, n):  # pragma: no cover - compiled
    """Per-seed weight, first moments and energy: (mass, sum w*row, sum w*col, energy)."""
    mass = np.zeros(n)
    mr = np.zeros(n)
    mc = np.zeros(n)
    en = np.zeros(n)
    h, wd = w.shape
    for row in range(h):
        for col in range(wd):
            s = label[row, col]
            if s < 0:
                continue
            v = w[row, col]
            mass[s] += v
            mr[s] += v * row
            mc[s] += v * col
            en[s] += v * dist2[row, col]
    return mass, mr, mc, en
