"""Plane and mesh geometry shared by the stages: polygon area, orientation, ring tests, genus.

Rings are ``(N, 2)`` arrays of (x, y) in mm, not closed (the last vertex is not a
copy of the first); counter-clockwise rings have positive area.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

__all__ = [
    "as_ccw",
    "as_cw",
    "circles_clear_of_rings",
    "genus",
    "index_triangles",
    "mesh_genus",
    "min_web",
    "point_ring_distance",
    "points_in_any_ring",
    "points_in_circles",
    "points_in_ring",
    "polygon_area",
    "rings_cross",
    "sorted_distinct",
]


def polygon_area(ring: np.ndarray) -> float:
    """Signed area in mm² of a ring (positive when counter-clockwise), shoelace formula."""
    ring = np.asarray(ring, dtype=np.float64)
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))


def as_ccw(ring: np.ndarray) -> np.ndarray:
    """The ring, counter-clockwise (reversed when it is not)."""
    ring = np.asarray(ring, dtype=np.float64)
    return ring if polygon_area(ring) > 0 else ring[::-1]


def as_cw(ring: np.ndarray) -> np.ndarray:
    """The ring, clockwise (reversed when it is counter-clockwise)."""
    ring = np.asarray(ring, dtype=np.float64)
    return ring[::-1] if polygon_area(ring) > 0 else ring


def _edges(ring: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    ring = np.asarray(ring, dtype=np.float64)
    return ring, np.roll(ring, -1, axis=0)


def points_in_ring(points: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Even-odd point-in-polygon test, vectorised over points × edges.

    Args:
        points: ``(P, 2)`` points in mm.
        ring: ``(N, 2)`` ring.

    Returns:
        ``(P,)`` bool, True inside.
    """
    a, b = _edges(ring)
    px, py = points[:, 0:1], points[:, 1:2]
    ay, by = a[None, :, 1], b[None, :, 1]
    crosses = (ay > py) != (by > py)
    with np.errstate(divide="ignore", invalid="ignore"):
        xint = a[None, :, 0] + (py - ay) * (b[None, :, 0] - a[None, :, 0]) / (by - ay)
    return (np.count_nonzero(crosses & (px < xint), axis=1) % 2) == 1


def point_ring_distance(points: np.ndarray, ring: np.ndarray) -> np.ndarray:
    """Distance in mm from each of ``(P, 2)`` points to the nearest edge of a ring."""
    a, b = _edges(ring)
    ab = b - a
    ap = points[:, None, :] - a[None, :, :]
    den = np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-300)
    t = np.clip(np.einsum("pij,ij->pi", ap, ab) / den, 0.0, 1.0)
    diff = ap - t[..., None] * ab[None]
    return np.sqrt(np.min(np.einsum("pij,pij->pi", diff, diff), axis=1))


def _box_pairs(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pair ``(i, j)`` of boxes that overlap, once each, and some that come close.

    A sweep along x within horizontal strips: each box joins the strips its y-range covers and
    meets, in each, the boxes whose x-range starts within its own; a pair is kept in the first
    strip both cover. One sweep along x over the whole plane meets every box in the same columns
    (a hard stencil's thousands of cut-outs: edges x rows); strips as tall as a few edges keep
    the pairs near linear in the edges.

    Args:
        lo: ``(N, 2)`` the boxes' lower corners in mm.
        hi: ``(N, 2)`` their upper corners.

    Returns:
        ``(i, j)`` index arrays; the caller tests the pairs exactly.
    """
    n = len(lo)
    if n < 2:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    (x0, y0), (x1, y1) = lo.min(axis=0), hi.max(axis=0)
    tall = max(4.0 * float(np.median((hi - lo).sum(axis=1))), (y1 - y0) / math.sqrt(n), 1e-9)
    first = np.floor((lo[:, 1] - y0) / tall).astype(np.int64)
    last = np.floor((hi[:, 1] - y0) / tall).astype(np.int64)
    covers = last - first + 1
    box = np.repeat(np.arange(n), covers)
    strip = first[box] + np.arange(len(box)) - np.repeat(np.cumsum(covers) - covers, covers)
    order = np.lexsort((lo[box, 0], strip))
    box, strip = box[order], strip[order]
    # One sorted key: the strip, then x from the left (the strips' keys do not meet); partners
    # start at most at the box's right end (plus a margin for the rounding of the key).
    width = (x1 - x0) + 1.0
    key = strip * width + (lo[box, 0] - x0)
    ends = np.searchsorted(key, strip * width + (hi[box, 0] - x0) + 1e-9 * (1.0 + np.abs(key)), side="right")
    counts = np.maximum(ends - np.arange(len(box)) - 1, 0)
    p = np.repeat(np.arange(len(box)), counts)
    q = p + 1 + np.arange(len(p)) - np.repeat(np.cumsum(counts) - counts, counts)
    i, j = box[p], box[q]
    once = np.maximum(first[i], first[j]) == strip[p]
    return i[once], j[once]


def rings_cross(rings: Sequence[np.ndarray], *, touching: bool = True, within: bool = True) -> bool:
    """Whether any two edges of a set of rings cross (sweeps along x in strips of y, :func:`_box_pairs`).

    Neighbouring edges of one ring share a vertex and are never counted.

    Args:
        rings: ``(N_i, 2)`` rings.
        touching: Count edges that touch (an end on the other edge, or collinear overlap)
            as crossing; False counts only proper crossings. Defaults to True.
        within: Also test the edges of one ring against each other (a ring that touches
            or crosses itself); False tests only edges of different rings. Defaults to True.

    Returns:
        True when a counted pair of edges crosses.
    """
    rings = [np.asarray(r, dtype=np.float64) for r in rings]
    if not rings:
        return False
    a = np.concatenate(rings)
    b = np.concatenate([np.roll(r, -1, axis=0) for r in rings])
    ring_key = np.concatenate([np.full(len(r), k) for k, r in enumerate(rings)])
    idx = np.concatenate([np.arange(len(r)) for r in rings])
    rlen = np.concatenate([np.full(len(r), len(r)) for r in rings])
    lo, hi = np.minimum(a, b), np.maximum(a, b)
    i, j = _box_pairs(lo, hi)
    overlap = np.all((lo[i] <= hi[j]) & (lo[j] <= hi[i]), axis=1)
    i, j = i[overlap], j[overlap]
    same = ring_key[i] == ring_key[j]
    drop = (
        same
        if not within
        else same & ((np.abs(idx[i] - idx[j]) == 1) | (np.abs(idx[i] - idx[j]) == rlen[i] - 1))
    )
    i, j = i[~drop], j[~drop]

    def orient(p, q, r):
        return (q[:, 0] - p[:, 0]) * (r[:, 1] - p[:, 1]) - (q[:, 1] - p[:, 1]) * (r[:, 0] - p[:, 0])

    d1 = orient(a[i], b[i], a[j])
    d2 = orient(a[i], b[i], b[j])
    d3 = orient(a[j], b[j], a[i])
    d4 = orient(a[j], b[j], b[i])
    if touching:
        return bool(((d1 * d2 <= 0) & (d3 * d4 <= 0)).any())
    return bool(((d1 * d2 < 0) & (d3 * d4 < 0)).any())


def _pairs(found, n: int) -> tuple[np.ndarray, np.ndarray]:
    """A KD-tree's ball query as pairs ``(query, found)``: each query's index repeated per hit."""
    counts = np.fromiter(map(len, found), dtype=np.int64, count=n)
    hits = np.fromiter(itertools.chain.from_iterable(found), dtype=np.int64, count=int(counts.sum()))
    return np.repeat(np.arange(n), counts), hits


def points_in_any_ring(
    points: np.ndarray, rings: Sequence[np.ndarray], own: np.ndarray | None = None
) -> np.ndarray:
    """Which points lie inside at least one of the rings (even-odd), near linear for spread-out rings.

    Only the rings whose box holds a point are tested against it (a KD-tree finds them), so
    thousands of small rings cost little more than their edges; a pairwise test would cost
    points x edges.

    Args:
        points: ``(P, 2)`` points in mm.
        rings: ``(N_k, 2)`` rings.
        own: ``(P,)`` the index of a ring each point is not tested against (the ring it is a
            vertex of), or None.

    Returns:
        ``(P,)`` bool, True inside some ring.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    out = np.zeros(len(points), dtype=bool)
    if len(points) == 0 or len(rings) == 0:
        return out
    rings = [np.asarray(ring, dtype=np.float64) for ring in rings]
    lengths = np.array([len(ring) for ring in rings])
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    corners = np.concatenate(rings)
    lo, hi = np.minimum.reduceat(corners, starts, axis=0), np.maximum.reduceat(corners, starts, axis=0)
    found = cKDTree(points).query_ball_point(
        (lo + hi) / 2, np.hypot(*((hi - lo) / 2).T) * (1 + 1e-9) + 1e-12, return_sorted=False
    )
    ring, point = _pairs(found, len(rings))
    keep = np.all((points[point] >= lo[ring]) & (points[point] <= hi[ring]), axis=1)
    if own is not None:
        keep &= np.asarray(own)[point] != ring
    ring, point = ring[keep], point[keep]
    order = np.argsort(ring, kind="stable")
    ring, point = ring[order], point[order]
    cut = np.flatnonzero(np.diff(ring)) + 1
    if len(ring) == 0:
        return out
    for k, mine in zip(ring[np.concatenate([[0], cut])], np.split(point, cut), strict=True):
        out[mine[points_in_ring(points[mine], rings[k])]] = True
    return out


def points_in_circles(points: np.ndarray, xy: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Which points lie strictly inside at least one circle (a KD-tree over the centres).

    Args:
        points: ``(P, 2)`` points in mm.
        xy: ``(N, 2)`` circle centres in mm.
        r: ``(N,)`` radii in mm.

    Returns:
        ``(P,)`` bool.
    """
    points = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(r, dtype=np.float64).reshape(-1)
    out = np.zeros(len(points), dtype=bool)
    if len(points) == 0 or len(r) == 0:
        return out
    point, circle = _pairs(
        cKDTree(xy).query_ball_point(points, float(r.max()), return_sorted=False), len(points)
    )
    inside = np.hypot(*(points[point] - xy[circle]).T) < r[circle]
    out[point[inside]] = True
    return out


def circles_clear_of_rings(
    xy: np.ndarray, r: np.ndarray, rings: Sequence[np.ndarray], clearance_mm: float, inside: bool = False
) -> np.ndarray:
    """Which circles keep at least ``clearance_mm`` from every ring's edges, on the ring's chosen side.

    Args:
        xy: ``(N, 2)`` circle centres in mm.
        r: ``(N,)`` radii in mm.
        rings: ``(K_i, 2)`` rings.
        clearance_mm: Least distance in mm between a circle and a ring's edges.
        inside: True: each circle must lie inside every ring (a plate's outline); False: outside
            every ring (a window, a cut-out). Defaults to False.

    Returns:
        ``(N,)`` bool: True where the circle is on its side of every ring, clear of its edges.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(r, dtype=np.float64).reshape(-1)
    ok = np.ones(len(r), dtype=bool)
    reach = float(r.max(initial=0.0)) + clearance_mm
    for ring in rings:
        ring = np.asarray(ring, dtype=np.float64)
        lo, hi = ring.min(axis=0) - reach, ring.max(axis=0) + reach
        near = np.all((xy >= lo) & (xy <= hi), axis=1)
        if inside:
            ok &= near  # a circle away from the ring's box is outside it
        near = np.flatnonzero(near & ok)
        close = _maybe_close(xy[near], r[near] + clearance_mm, ring, reach)
        # Chunks keep the points x edges arrays small on long rings.
        for start in range(0, len(near), 2048):
            idx, c = near[start : start + 2048], close[start : start + 2048]
            bad = points_in_ring(xy[idx], ring) != inside
            bad[c] |= point_ring_distance(xy[idx[c]], ring) < r[idx[c]] + clearance_mm
            ok[idx[bad]] = False
    return ok


def _maybe_close(xy: np.ndarray, reach: np.ndarray, ring: np.ndarray, spacing: float) -> np.ndarray:
    """Which points may lie within ``reach`` of the ring's edges (a point not flagged does not).

    The edges are sampled every ``spacing`` mm at most, so every point of the ring is within half
    that of a sample: a point whose nearest sample is further than ``reach`` plus that is clear,
    and its exact distance (points x edges) need not be computed.
    """
    if len(xy) == 0:
        return np.zeros(0, dtype=bool)
    a, b = _edges(ring)
    pieces = np.maximum(np.ceil(np.hypot(*(b - a).T) / max(spacing, 1e-3)).astype(np.int64), 1)
    t = np.arange(int(pieces.sum())) - np.repeat(np.cumsum(pieces) - pieces, pieces)
    step = np.repeat(1.0 / pieces, pieces)[:, None]
    samples = np.repeat(a, pieces, axis=0) + (t[:, None] * step) * np.repeat(b - a, pieces, axis=0)
    half = 0.5 * float(np.max(np.hypot(*(b - a).T) / pieces))
    return cKDTree(samples).query(xy)[0] <= reach + half


def min_web(xy: np.ndarray, r: np.ndarray) -> float:
    """Smallest web ``|c_i - c_j| - r_i - r_j`` over all pairs, in mm.

    Exact, O(N log N) for spread-out dots: pairs are gathered with a KD-tree
    within a reach ``R``; if the smallest web ``U`` among them satisfies
    ``U + 2 max(r) <= R`` no pair outside the reach can do better, otherwise
    the reach grows to ``U + 2 max(r)`` (or doubles when no pair was found).

    Args:
        xy: ``(N, 2)`` hole centres in mm.
        r: ``(N,)`` hole radii in mm.

    Returns:
        The smallest web in mm (negative when holes overlap), ``inf`` for fewer
        than two holes.
    """
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(r, dtype=np.float64).reshape(-1)
    n = len(xy)
    if n < 2:
        return math.inf
    rmax = float(r.max())
    span = np.ptp(xy, axis=0)
    spacing = math.sqrt(max(float(span[0] * span[1]), float(span.max()) ** 2 / n, 1e-12) / n)
    reach = 2.0 * rmax + 0.5 * spacing
    tree = cKDTree(xy)
    while True:
        pairs = tree.query_pairs(reach, output_type="ndarray")
        if len(pairs) == 0:
            reach *= 2.0
            continue
        d = np.hypot(*(xy[pairs[:, 0]] - xy[pairs[:, 1]]).T)
        best = float(np.min(d - r[pairs[:, 0]] - r[pairs[:, 1]]))
        if best + 2.0 * rmax <= reach:
            return best
        reach = best + 2.0 * rmax + 1e-9


def index_triangles(triangles: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge the exactly coincident corners of a triangle soup into an indexed mesh.

    Args:
        triangles: ``(F, 3, 3)`` triangle corners.

    Returns:
        ``(vertices, faces)``: ``(V, 3)`` float64 unique corners and ``(F, 3)`` int64 indices.
    """
    flat = np.asarray(triangles, dtype=np.float64).reshape(-1, 3)
    # A lexsort and a run-length pass merge exact duplicates ~5x faster than np.unique(axis=0).
    order = np.lexsort(flat.T[::-1])
    ordered = flat[order]
    new = np.ones(len(flat), dtype=bool)
    new[1:] = np.any(ordered[1:] != ordered[:-1], axis=1)
    inverse = np.empty(len(flat), dtype=np.int64)
    inverse[order] = np.cumsum(new) - 1
    return ordered[new], inverse.reshape(-1, 3)


def sorted_distinct(keys: np.ndarray) -> int:
    """How many distinct values a sorted array holds.

    ``np.unique(keys).size`` sorts too, but numpy 2.4's ``np.unique`` took 0.47 CPU-s on 600,000
    int64 keys where ``np.sort`` took 0.03 (``python3 -c`` timing both with ``time.process_time``).
    """
    return int(len(keys) > 0) + int(np.count_nonzero(keys[1:] != keys[:-1]))


def genus(faces: np.ndarray, n_vertices: int, n_edges: int | None = None) -> tuple[int, int, int]:
    """Euler characteristic, shells and genus of an indexed triangle mesh.

    For each closed shell V - E + F = 2 - 2g, so the genus summed over the shells is
    ``shells - chi / 2``. A perforated plate made of one shell has genus = hole count.

    Args:
        faces: ``(F, 3)`` vertex indices.
        n_vertices: Number of vertices V (unused vertices are not counted).
        n_edges: Number of distinct edges E, when the caller has counted them; None:
            counted here.

    Returns:
        ``(chi, shells, genus)``. The genus is meaningless for an open mesh.
    """
    faces = np.asarray(faces, dtype=np.int64)
    used = np.zeros(n_vertices, dtype=bool)
    used[faces.ravel()] = True
    e0 = faces.reshape(-1)
    e1 = faces[:, [1, 2, 0]].reshape(-1)
    if n_edges is None:
        n_edges = sorted_distinct(np.sort(np.minimum(e0, e1) * n_vertices + np.maximum(e0, e1)))
    chi = int(np.count_nonzero(used)) - n_edges + len(faces)
    graph = coo_matrix((np.ones(len(e0), dtype=np.int8), (e0, e1)), shape=(n_vertices, n_vertices))
    _, labels = connected_components(graph, directed=False)
    shells = int(np.unique(labels[used]).size)
    return chi, shells, int(round(shells - chi / 2))


def mesh_genus(triangles: np.ndarray) -> int:
    """Genus of a closed triangle soup (coincident corners merged exactly); see :func:`genus`.

    Args:
        triangles: ``(F, 3, 3)`` triangle corners of a closed mesh.

    Returns:
        The genus summed over shells. Meaningless for an open mesh: check it with
        :func:`stencil_cad.slicing.inspect_mesh` first.
    """
    verts, faces = index_triangles(np.asarray(triangles, dtype=np.float64))
    return genus(faces, len(verts))[2]
