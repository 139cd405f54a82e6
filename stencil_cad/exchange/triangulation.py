"""Constrained triangulation of flat rings in O(n log n), with a region label per triangle.

A Delaunay triangulation (Qhull) of every ring vertex, ring edges made Gabriel edges by
midpoint splits first, missing ones recovered by further splits (conforming Delaunay),
and triangles grouped into regions that do not cross a ring edge (see :mod:`.mesh`).
"""

import logging

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import Delaunay

log = logging.getLogger(__name__)


#: Rounds of midpoint insertion to recover ring edges missing from the triangulation.
MAX_RECOVERY_ROUNDS = 12

#: Qhull's options: SciPy's defaults for a 2-D Delaunay triangulation ("Qt" is always added)
#: and "Q5", which skips the computation of each facet's outer plane (``qh_check_maxout``),
#: run after the triangulation is complete. It bounds how far input points lie above the
#: facets, for Qhull's own precision report and point location (``find_simplex``); this module
#: uses neither, and every ring edge and region is checked afterwards anyway. The simplices
#: are the same, in the same order (so the same files): the 16 triangulations of the bundled
#: example's plates took 1.73 -> 1.40 CPU-s (``time.process_time`` around ``Delaunay``, median
#: of three), and random, duplicated, grid and cocircular point sets gave identical
#: ``simplices``, ``neighbors`` and ``coplanar`` with and without it.
QHULL_OPTIONS = "Qbb Qc Qz Q12 Q5"


class MeshError(RuntimeError):
    """The mesher could not produce a closed, consistently wound mesh."""


# ----------------------------------------------------------------------------- triangulation


def _ring_edges(ring_id: np.ndarray) -> np.ndarray:
    """Index of the next vertex of each vertex in flat rings (rings contiguous)."""
    n = len(ring_id)
    idx = np.arange(n)
    nxt = idx + 1
    last = np.flatnonzero(np.r_[ring_id[1:] != ring_id[:-1], True])
    first = np.r_[0, last[:-1] + 1]
    nxt[last] = first
    return nxt


def _member(keys: np.ndarray, sorted_keys: np.ndarray) -> np.ndarray:
    """``np.isin`` for a sorted haystack (binary search; np.isin re-sorts both sides)."""
    if len(sorted_keys) == 0:
        return np.zeros(len(keys), dtype=bool)
    pos = np.minimum(np.searchsorted(sorted_keys, keys), len(sorted_keys) - 1)
    return sorted_keys[pos] == keys


def _split(points, ring_id, left, right, split):
    """Insert the midpoint of each ring edge flagged in ``split`` (same straight edge)."""
    nxt = _ring_edges(ring_id)
    reps = np.where(split, 2, 1)
    new_pts = np.repeat(points, reps, axis=0)
    pos = np.cumsum(reps) - 1
    new_pts[pos[split]] = 0.5 * (points[split] + points[nxt[split]])
    return new_pts, np.repeat(ring_id, reps), np.repeat(left, reps), np.repeat(right, reps)


def _gabriel(points, ring_id, left, right, extra, rounds: int = 8, neighbours_count: bool = True):
    """Split ring edges until no other vertex lies in any edge's diametral disc.

    An edge whose diametral disc holds no other vertex (a Gabriel edge) is an edge
    of every Delaunay triangulation of the set, so after this pass the
    triangulation contains every ring edge without recovery rounds (each of
    which would cost a whole triangulation). Found with a k-d tree: a vertex
    inside the disc is nearer the edge's midpoint than its two end points are.
    """
    from scipy.spatial import cKDTree

    for _ in range(rounds):
        nxt = _ring_edges(ring_id)
        allp = np.concatenate([points, extra]) if len(extra) else points
        mid = 0.5 * (points + points[nxt])
        half = 0.5 * np.linalg.norm(points[nxt] - points, axis=1)
        dist, idx = cKDTree(allp).query(mid, k=3 if neighbours_count else 5)
        prev = np.empty_like(nxt)
        prev[nxt] = np.arange(len(points))
        # Letters have sharp corners, where a ring's own neighbours sit inside the disc and
        # splitting would never end; there the neighbours do not count (recovery catches the rest).
        own = (idx == np.arange(len(points))[:, None]) | (idx == nxt[:, None])
        if not neighbours_count:
            own |= (idx == prev[:, None]) | (idx == nxt[nxt][:, None])
        bad = ((dist < half[:, None] * (1.0 - 1e-9)) & ~own).any(axis=1)
        if not bad.any():
            break
        points, ring_id, left, right = _split(points, ring_id, left, right, bad)
    return points, ring_id, left, right


def _triangulate(
    points: np.ndarray, ring_id: np.ndarray, left: np.ndarray, right: np.ndarray, extra: np.ndarray
):
    """Constrained triangulation of flat rings, with a region label per triangle.

    Args:
        points: ``(P, 2)`` ring vertices, each ring contiguous.
        ring_id: ``(P,)`` ring of each vertex.
        left: ``(P,)`` label of the region on the left of the edge leaving each vertex.
        right: ``(P,)`` label of the region on its right.
        extra: ``(Q, 2)`` extra vertices (hole centres), on no ring.

    Returns:
        ``(points, ring_id, left, right, tris, labels)`` after edge recovery:
        ``tris`` ``(T, 3)`` counter-clockwise into ``points ++ extra``; ``labels``
        ``(T,)`` the region label of each triangle (0 where no ring bounds it).

    Raises:
        MeshError: When ring edges cannot be recovered, or a region sees two labels
            (rings that cross or overlap).
    """
    points, ring_id, left, right, tri = _conforming_delaunay(points, ring_id, left, right, extra)
    labels = _region_labels(tri, ring_id, left, right, len(points) + len(extra))
    return points, ring_id, left, right, tri, labels


def _edge_keys(tri: np.ndarray, ring_id: np.ndarray, nv: int):
    """Keys of the ring edges (directed ``ckey``, undirected ``ukey``) and of the triangles' edges.

    Returns:
        ``(ckey, ukey, e0, e1, tkey_u)``: ``e0 -> e1`` each triangle edge, ``tkey_u`` undirected.
    """
    nxt = _ring_edges(ring_id)
    src = np.arange(len(ring_id))
    ckey = src * nv + nxt  # directed ring edges
    ukey = np.minimum(src, nxt) * nv + np.maximum(src, nxt)
    e0 = tri.reshape(-1)
    e1 = tri[:, [1, 2, 0]].reshape(-1)
    tkey_u = np.minimum(e0, e1) * nv + np.maximum(e0, e1)
    return ckey, ukey, e0, e1, tkey_u


def _conforming_delaunay(points, ring_id, left, right, extra):
    """Delaunay triangles (counter-clockwise) holding every ring edge, missing ones split at their midpoints.

    Returns:
        ``(points, ring_id, left, right, tris)`` after the splits.

    Raises:
        MeshError: When ring edges are still missing after :data:`MAX_RECOVERY_ROUNDS` rounds.
    """
    for rounds in range(MAX_RECOVERY_ROUNDS + 1):
        allp = np.concatenate([points, extra]) if len(extra) else points
        nv = len(allp)
        tri = Delaunay(allp, qhull_options=QHULL_OPTIONS).simplices.astype(np.int64)
        a, b, c = allp[tri[:, 0]], allp[tri[:, 1]], allp[tri[:, 2]]
        cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
        flip = cross < 0
        tri[flip] = tri[flip][:, [0, 2, 1]]
        tri = tri[cross != 0]
        _, ukey, _, _, tkey_u = _edge_keys(tri, ring_id, nv)
        present = _member(ukey, np.sort(tkey_u))
        if present.all():
            return points, ring_id, left, right, tri
        if rounds == MAX_RECOVERY_ROUNDS:
            miss = np.flatnonzero(~present)[:5]
            raise MeshError(
                f"{int((~present).sum())} ring edges still missing from the triangulation after "
                f"{rounds} rounds; first at {[tuple(np.round(points[i], 4)) for i in miss]} mm"
            )
        # Split each missing edge at its midpoint (on the same straight edge, so the polygon
        # does not change) and triangulate again: a conforming Delaunay triangulation.
        points, ring_id, left, right = _split(points, ring_id, left, right, ~present)
        split = ~present
        log.debug("mesh: recovering %d ring edges (round %d)", int(split.sum()), rounds + 1)
    raise AssertionError("unreachable")  # pragma: no cover


def _region_labels(tri: np.ndarray, ring_id: np.ndarray, left: np.ndarray, right: np.ndarray, nv: int):
    """The region label of each triangle (0 where no ring bounds it).

    Raises:
        MeshError: When a region sees two labels (rings that cross or overlap).
    """
    ckey, ukey, e0, e1, tkey_u = _edge_keys(tri, ring_id, nv)
    # Which side of a ring edge each triangle lies on, hence its label.
    order = np.argsort(ckey)
    sk = ckey[order]

    def lookup(keys):
        pos = np.minimum(np.searchsorted(sk, keys), len(sk) - 1)
        return sk[pos] == keys, order[pos]

    tdir = e0 * nv + e1
    trev = e1 * nv + e0
    hit_l, which_l = lookup(tdir)  # the triangle is on the left of a ring edge
    hit_r, which_r = lookup(trev)  # ... on its right
    lab = np.full(len(tdir), -1, dtype=np.int64)
    lab[hit_l] = left[which_l[hit_l]]
    lab[hit_r] = right[which_r[hit_r]]

    # Regions: triangles joined across edges that are not ring edges.
    ntri = len(tri)
    tid = np.repeat(np.arange(ntri), 3)
    o = np.argsort(tkey_u, kind="stable")
    ks = tkey_u[o]
    same = np.flatnonzero(ks[1:] == ks[:-1])
    same = same[~_member(ks[same], np.sort(ukey))]
    t1, t2 = tid[o[same]], tid[o[same + 1]]
    graph = coo_matrix((np.ones(len(t1), dtype=np.int8), (t1, t2)), shape=(ntri, ntri))
    ncomp, comp = connected_components(graph, directed=False)
    seen = lab >= 0
    cmax = np.full(ncomp, -1, dtype=np.int64)
    cmin = np.full(ncomp, np.iinfo(np.int64).max, dtype=np.int64)
    np.maximum.at(cmax, comp[tid[seen]], lab[seen])
    np.minimum.at(cmin, comp[tid[seen]], lab[seen])
    clash = (cmax >= 0) & (cmin != cmax)
    if clash.any():
        raise MeshError(
            f"{int(clash.sum())} triangle regions touch rings from both sides: rings cross or overlap "
            "(holes overlapping each other, the outline or the label)"
        )
    return np.where(cmax >= 0, cmax, 0)[comp]
