"""Topology of one cut stencil: thin cut-outs, islands of sheet, bridges, polygons.

Rasters here are ``(H, W)`` bool with True where the sheet is cut open. The
sheet is the complement, plus the plate frame around the picture. It must be one
solid: 4-connected on the raster (so the cut-outs are 8-connected, and the
cut-out polygons are traced with diagonal pixels joined, which gives the same
topology).

"Held" is measured with the bridge width: the *free centres* of the sheet are
the places where a bridge-wide disc of sheet fits (the erosion of the sheet by
the disc), and two parts of the sheet are held together when such a disc can
slide from one to the other (their free centres are connected). A part whose
free centres are not connected to the frame's is an island (the middle of an
"O", or a part hanging on a neck thinner than a bridge). Connectivity of the
*opening* would not do: the narrow tips of two discs poking into a short neck
from both sides touch even when no disc passes. Islands are joined by a minimum
spanning tree over the free-centre components (Mehlhorn's construction: one
geodesic distance transform from all components at once, candidate edges where
the fronts meet), and each tree edge becomes a bridge: its path dilated by the
bridge disc and taken out of the cut. Every pixel of such a path is then a free
centre, so every island bridged is joined to the frame; the new sheet can make a
few new free centres that touch the rest only through an overlap of discs, and a
further round bridges those. :func:`sheet_check` verifies the raster and
:func:`polygon_sheet_check` the traced polygons.
"""

from __future__ import annotations

import logging
import math

import numba
import numpy as np
from scipy import ndimage as ndi
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import minimum_spanning_tree
from skimage.graph import MCP_Geometric
from skimage.measure import find_contours, points_in_poly
from skimage.morphology import skeletonize

from ..frames import px_to_mm, rasterise_polygons
from ..geometry import polygon_area

log = logging.getLogger(__name__)


FOUR = ndi.generate_binary_structure(2, 1)
EIGHT = ndi.generate_binary_structure(2, 2)
# Cost per pixel of running a bridge over sheet that is already there (a thin neck)
# or over cut that a later layer paints anyway: small, so paths prefer them, but
# not zero, so they stay short.
CHEAP = 0.1
# Bridging rounds before giving up (a warning then reports the pieces); one or two suffice.
MAX_BRIDGE_ROUNDS = 4
# Cap of the polygon simplification, in px: traced edges pass 0.354 px (half a diagonal)
# from the nearest pixel centre, so a smaller tolerance never moves an edge across one.
MAX_TOLERANCE_PX = 0.3


def footprint(d_px: float) -> np.ndarray:
    """A disc of diameter ``d_px`` pixels as a bool footprint of side ``ceil(d_px)``.

    Even sides are centred between pixels, so a 2-px disc is a 2 x 2 block.

    Args:
        d_px: Diameter in pixels (at least 1 is used).

    Returns:
        ``(n, n)`` bool footprint, ``n = ceil(d_px)``.
    """
    d = max(float(d_px), 1.0)
    n = max(1, math.ceil(d - 1e-9))
    c = (n - 1) / 2.0
    yy, xx = np.mgrid[:n, :n]
    # The middle row and column are always full, so the disc spans n >= d pixels across
    # (for an even side and d just above n - 1 the plain test would leave it empty).
    rad2 = max((d / 2.0) ** 2, c**2 + (0.25 if n % 2 == 0 else 0.0))
    return (yy - c) ** 2 + (xx - c) ** 2 <= rad2 + 1e-9


def bridge_footprint(bridge_px: float) -> np.ndarray:
    """The disc bridges are drawn with and the sheet's robustness is tested with.

    One pixel wider than the bridge: a strip of discs stepped along a pixel path
    is narrower across than the disc when the path runs obliquely (about 0.9 of
    it at a 1:2 slope), and the traced polygons cut the staircase corners.
    """
    return footprint(bridge_px + 1.0)


def _free_centres(sheet: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """Where a disc ``fp`` of sheet fits: the erosion, with sheet beyond the array."""
    return ndi.binary_erosion(sheet, fp, border_value=1)


def _components(mask: np.ndarray) -> tuple[np.ndarray, int, int]:
    """4-connected components of a padded sheet mask and the id of the frame's one."""
    comp, n = ndi.label(mask, structure=FOUR)
    return comp, n, int(comp[0, 0])


def _drop_loose(cut: np.ndarray, robust: np.ndarray) -> tuple[np.ndarray, int]:
    """Cut away sheet pieces with no free centre that are not attached to the frame.

    Such pieces are too small to be held by a bridge; they become part of the cut.
    """
    sheet = ~cut
    comp, n, main = _components(sheet)
    if n <= 1:
        return cut, 0
    has_core = np.bincount(comp[robust], minlength=n + 1) > 0
    loose = ~has_core
    loose[0] = False
    loose[main] = False
    if not loose.any():
        return cut, 0
    return cut | loose[comp], int(np.count_nonzero(loose))


def _bridges(
    cut: np.ndarray, robust: np.ndarray, cost: np.ndarray, fb: np.ndarray
) -> tuple[np.ndarray, dict]:
    """Carve bridges so that every free-centre component joins the frame's one.

    Args:
        cut: Padded cut mask.
        robust: Padded free centres (erosion of the sheet by ``fb``).
        cost: Padded cost per pixel of running a bridge there (> 0).
        fb: Bridge footprint.

    Returns:
        The new cut mask and figures: ``islands``, ``bridges``, ``bridge_px``
        (pixels of cut turned into bridge).
    """
    comp, n, main = _components(robust)
    if n <= 1:
        return cut, {"islands": 0, "bridges": 0, "bridge_px": 0}
    h, w = cut.shape
    # Fronts start on the rim of each free-centre component; the inside is a barrier, which
    # keeps the start list (looped over in Python by MCP) short.
    rim = robust & ~ndi.binary_erosion(robust, structure=FOUR, border_value=1)
    costs = np.where(robust, CHEAP, cost).astype(np.float64)
    costs[robust & ~rim] = np.inf
    mcp = MCP_Geometric(costs, fully_connected=False)
    cum, tb = mcp.find_costs(np.argwhere(rim))
    offsets = np.asarray(mcp.offsets, dtype=np.int64)
    flat_tb = tb.ravel()
    idx = np.arange(h * w)
    step = offsets[:, 0] * w + offsets[:, 1]
    parent = np.where(flat_tb >= 0, idx - step[np.maximum(flat_tb, 0)], idx)
    # Pointer jumping: log2(longest path) rounds give each pixel its start pixel.
    for _ in range(64):
        nxt = parent[parent]
        if np.array_equal(nxt, parent):
            break
        parent = nxt
    origin = comp.ravel()[parent].reshape(h, w)
    org = origin.ravel()
    lin = np.arange(h * w).reshape(h, w)
    pa, pb = [], []
    for p_idx, q_idx in ((lin[:, :-1], lin[:, 1:]), (lin[:-1, :], lin[1:, :])):
        p, q = p_idx.ravel(), q_idx.ravel()
        d = org[p] != org[q]
        pa.append(p[d])
        pb.append(q[d])
    p_lin = np.concatenate(pa)
    q_lin = np.concatenate(pb)
    cf, cu = costs.ravel(), cum.ravel()
    # Joining two fronts across (p, q) costs both paths plus the step between them.
    weight = cu[p_lin] + cu[q_lin] + 0.5 * (cf[p_lin] + cf[q_lin])
    oa, ob = org[p_lin], org[q_lin]
    lo, hi = np.minimum(oa, ob), np.maximum(oa, ob)
    key = lo.astype(np.int64) * (n + 1) + hi
    order = np.lexsort((weight, key))
    first = order[np.unique(key[order], return_index=True)[1]]
    g = coo_matrix((weight[first] + 1e-9, (lo[first], hi[first])), shape=(n + 1, n + 1)).tocsr()
    tree = minimum_spanning_tree(g).tocoo()
    # Map each tree edge back to the grid pair that realises it.
    edge_of = {(int(a), int(b)): int(e) for a, b, e in zip(lo[first], hi[first], first, strict=True)}
    path = np.zeros((h, w), dtype=bool)
    for a, b in zip(tree.row, tree.col, strict=True):
        e = edge_of[(min(a, b), max(a, b))]
        for end in (p_lin[e], q_lin[e]):
            pts = np.asarray(mcp.traceback((int(end // w), int(end % w))))
            path[pts[:, 0], pts[:, 1]] = True
    strip = ndi.binary_dilation(path, fb)
    carved = int(np.count_nonzero(strip & cut))
    return cut & ~strip, {"islands": n - 1, "bridges": int(tree.nnz), "bridge_px": carved}


def _cut_later_islands(cut: np.ndarray, later_p: np.ndarray) -> tuple[np.ndarray, int]:
    """Also cut the sheet islands made only of later colours; how many there were."""
    sheet = ~cut
    comp, n, main = _components(sheet)
    keep = np.bincount(comp[sheet & ~later_p], minlength=n + 1) > 0
    island = ~keep
    island[0] = False
    island[main] = False
    return cut | island[comp], int(np.count_nonzero(island))


def _widen_or_drop(cut: np.ndarray, fm: np.ndarray, min_feature_px: float, pad: int):
    """Cut parts thinner than the feature disc ``fm``: widened along their skeleton when long enough, else dropped.

    Returns:
        ``(cut, regions widened, regions dropped, pixels trimmed)``.
    """
    before = cut
    core = ndi.binary_opening(cut, fm)
    thin = cut & ~core
    widened_n = 0
    wide = np.zeros_like(cut)
    if thin.any():
        tl, tn = ndi.label(thin, structure=EIGHT)
        skel = skeletonize(thin)
        slen = np.bincount(tl[skel], minlength=tn + 1)
        widen = slen >= max(2.0, 2.0 * min_feature_px)
        widen[0] = False
        widened_n = int(np.count_nonzero(widen))
        if widened_n:
            wide = ndi.binary_dilation(skel & widen[tl], fm)
            # Never into the frame: the plate around the picture stays whole.
            wide[:pad] = wide[-pad:] = False
            wide[:, :pad] = wide[:, -pad:] = False
    cut = core | wide
    rl, rn = ndi.label(before, structure=EIGHT)
    survived = np.bincount(rl[cut & before], minlength=rn + 1) > 0
    dropped = int(rn - np.count_nonzero(survived[1:]))
    return cut, widened_n, dropped, int(np.count_nonzero(before & ~cut))


def process_layer(
    own: np.ndarray,
    later: np.ndarray,
    cost: np.ndarray,
    min_feature_px: float,
    bridge_px: float,
    union_cut: bool = True,
) -> tuple[np.ndarray, dict]:
    """Turn one colour's pixels into a cut mask whose sheet is one solid.

    Steps: (1) with ``union_cut``, sheet islands made only of later colours are
    cut too; (2) cut parts thinner than the minimum feature are widened (a thin
    part whose skeleton is at least two features long: its skeleton dilated by
    the feature disc) or dropped; (3) sheet pieces too small for a bridge are cut;
    (4) islands are bridged; (5) cut slivers the bridges left are trimmed.

    Args:
        own: ``(H, W)`` bool, pixels of this layer's colour.
        later: ``(H, W)`` bool, pixels of colours sprayed after this one.
        cost: ``(H, W)`` float > 0, cost per pixel of a bridge there.
        min_feature_px: Smallest cut feature, in pixels.
        bridge_px: Bridge width, in pixels.
        union_cut: See step (1).

    Returns:
        The ``(H, W)`` bool cut mask and a report with ``islands_cut_as_later``,
        ``regions_widened``, ``regions_dropped``, ``trimmed_px``, ``islands_dropped``,
        ``islands``, ``bridges``, ``bridge_px``, ``bridge_rounds``, ``sheet_components``,
        ``robust_components``.
    """
    fm = footprint(min_feature_px)
    fb = bridge_footprint(bridge_px)
    pad = max(fm.shape[0], fb.shape[0]) + 2
    cut = np.pad(np.asarray(own, dtype=bool), pad)
    later_p = np.pad(np.asarray(later, dtype=bool), pad)
    cost_p = np.pad(np.maximum(np.asarray(cost, dtype=np.float64), 1e-6), pad, constant_values=CHEAP)
    rep: dict = {}

    n_union = 0
    if union_cut:
        cut, n_union = _cut_later_islands(cut, later_p)
    rep["islands_cut_as_later"] = n_union
    cut, widened_n, dropped_n, trimmed = _widen_or_drop(cut, fm, min_feature_px, pad)
    rep["regions_widened"] = widened_n
    rep["regions_dropped"] = dropped_n

    # Bridging adds sheet, and new sheet can make new places where a disc fits that
    # touch the rest only through a narrower overlap; a further round bridges those too
    # (they are next to a bridge, so their bridges are a pixel or two long).
    islands = bridges = carved = dropped = rounds = 0
    trimmed_after = 0
    for rounds in range(MAX_BRIDGE_ROUNDS + 1):
        cut, n_loose = _drop_loose(cut, _free_centres(~cut, fb))
        dropped += n_loose
        robust = _free_centres(~cut, fb)
        if rounds == MAX_BRIDGE_ROUNDS or ndi.label(robust, structure=FOUR)[1] <= 1:
            break
        cut, brep = _bridges(cut, robust, cost_p, fb)
        islands += brep["islands"] if rounds == 0 else 0
        bridges += brep["bridges"]
        carved += brep["bridge_px"]
        # Bridges can leave cut slivers along their sides; trimming only adds sheet.
        sliver = cut & ~ndi.binary_opening(cut, fm)
        trimmed_after += int(np.count_nonzero(sliver))
        cut = cut & ~sliver
    rep.update({"islands": islands, "bridges": bridges, "bridge_px": carved, "bridge_rounds": rounds})
    rep["trimmed_px"] = trimmed + trimmed_after
    rep["islands_dropped"] = dropped
    out = cut[pad:-pad, pad:-pad]
    rep.update(sheet_check(out, bridge_px))
    return out, rep


def sheet_check(cut: np.ndarray, bridge_px: float) -> dict:
    """Count the sheet's pieces: raw (4-connected) and held (free-centre components).

    Args:
        cut: ``(H, W)`` bool cut mask (the frame around it is sheet).
        bridge_px: Bridge width in pixels.

    Returns:
        ``sheet_components`` and ``robust_components`` (pieces a bridge-wide disc
        cannot slide between); both are 1 for a good stencil.
    """
    fb = bridge_footprint(bridge_px)
    pad = fb.shape[0] + 2
    sheet = ~np.pad(np.asarray(cut, dtype=bool), pad)
    n_raw = ndi.label(sheet, structure=FOUR)[1]
    n_rob = ndi.label(_free_centres(sheet, fb), structure=FOUR)[1]
    return {"sheet_components": int(n_raw), "robust_components": int(n_rob)}


def polygon_sheet_check(
    polygons: list, shape: tuple[int, int], mm_per_px: float, bridge_mm: float, factor: int = 4
) -> dict:
    """Confirm on the polygons that the sheet is one solid held by bridge-wide necks.

    The polygons are rasterised at ``factor`` times the working resolution, and a
    Euclidean distance transform gives the free centres of a disc exactly (no
    digital disc): a bridge-wide disc fits at a fine pixel whose centre is at least
    its radius plus half a fine pixel from every cut pixel's centre. The sheet is
    split into the pieces between which such a disc cannot slide (components of
    its free centres), and the pieces that hold a disc one working pixel wider are
    counted (smaller specks of sheet may hang on thinner necks; they are parts of
    the image, not islands). A good stencil gives one piece: the frame's.

    Args:
        polygons: As returned by :func:`mask_to_polygons`.
        shape: ``(H, W)`` of the working grid.
        mm_per_px: Pixel size of the working grid in mm.
        bridge_mm: Bridge width in mm.
        factor: Supersampling factor. Defaults to 4.

    Returns:
        ``polygon_sheet_components`` (4-connected pieces of the traced sheet) and
        ``polygon_held_components`` (bridge-wide pieces, as above).
    """
    h, w = shape
    fine = rasterise_polygons(polygons, (h * factor, w * factor), mm_per_px / factor)
    r = 0.5 * bridge_mm / mm_per_px * factor
    r_big = r + 0.5 * factor
    pad = int(math.ceil(2 * r_big)) + 2
    sheet = np.pad(~fine, pad, constant_values=True)
    n_raw = ndi.label(sheet, structure=FOUR)[1]
    if not fine.any():
        return {"polygon_sheet_components": int(n_raw), "polygon_held_components": 1}
    dist = ndi.distance_transform_edt(sheet)
    lab, n = ndi.label(dist >= r + 0.5, structure=FOUR)
    held = np.bincount(lab[dist >= r_big + 0.5], minlength=n + 1) > 0
    held[0] = False
    return {"polygon_sheet_components": int(n_raw), "polygon_held_components": int(np.count_nonzero(held))}


@numba.njit(cache=True)
def _douglas_peucker(points: np.ndarray, tol: float) -> np.ndarray:  # pragma: no cover - compiled
    """Douglas-Peucker: a bool mask of the vertices of an open polyline to keep (ends kept)."""
    n = points.shape[0]
    keep = np.zeros(n, dtype=np.bool_)
    if n == 0:
        return keep
    keep[0] = True
    keep[n - 1] = True
    stack = np.empty((n, 2), dtype=np.int64)
    top = 0
    stack[0, 0] = 0
    stack[0, 1] = n - 1
    top = 1
    while top > 0:
        top -= 1
        i, j = stack[top, 0], stack[top, 1]
        if j <= i + 1:
            continue
        ax, ay = points[i, 0], points[i, 1]
        dx, dy = points[j, 0] - ax, points[j, 1] - ay
        norm = (dx * dx + dy * dy) ** 0.5
        best, arg = -1.0, i + 1
        for k in range(i + 1, j):
            px, py = points[k, 0] - ax, points[k, 1] - ay
            if norm > 0:
                d = abs(dx * py - dy * px) / norm
            else:
                d = (px * px + py * py) ** 0.5
            if d > best:
                best, arg = d, k
        if best > tol:
            keep[arg] = True
            stack[top, 0] = i
            stack[top, 1] = arg
            stack[top + 1, 0] = arg
            stack[top + 1, 1] = j
            top += 2
    return keep


def mask_to_polygons(mask: np.ndarray, mm_per_px: float, tolerance_mm: float) -> list:
    """Polygons of the cut-outs, in the mm picture frame.

    Contours are traced at the half-pixel level with diagonal cut pixels joined
    (the dual of the 4-connected sheet), simplified by Douglas-Peucker in pixels
    with the tolerance capped at ``MAX_TOLERANCE_PX`` (0.3 px), so no edge moves across a
    pixel centre and two cut-outs at least one pixel apart stay apart.

    Args:
        mask: ``(H, W)`` bool cut mask.
        mm_per_px: Pixel size in mm.
        tolerance_mm: Simplification tolerance in mm.

    Returns:
        A list of ``(outer, holes)``: ``outer`` an ``(M, 2)`` ndarray of (x, y) mm,
        counter-clockwise, not closed (last vertex differs from the first); ``holes``
        a list of such rings, clockwise.
    """
    mask = np.asarray(mask, dtype=bool)
    h = mask.shape[0]
    if not mask.any():
        return []
    tol_px = min(max(tolerance_mm, 0.0) / mm_per_px, MAX_TOLERANCE_PX)
    contours = find_contours(np.pad(mask, 1).astype(np.float64), 0.5, fully_connected="high")
    outers, holes = [], []
    for c in contours:
        c = c - 1.0
        if tol_px > 0:
            c = c[_douglas_peucker(c, tol_px)]
        if len(c) > 1 and np.allclose(c[0], c[-1]):
            c = c[:-1]
        if len(c) < 3:
            continue
        xy = px_to_mm(c, h, mm_per_px)
        a = polygon_area(xy)
        if a == 0.0:
            continue
        # find_contours runs clockwise (in x right, y up) around cut areas and the other
        # way around sheet left inside them.
        if a < 0:
            outers.append(xy[::-1].copy())
        else:
            holes.append(xy[::-1].copy())
    polys: list[tuple[np.ndarray, list[np.ndarray]]] = [(o, []) for o in outers]
    if holes and outers:
        areas = np.array([polygon_area(o) for o in outers])
        for hole in holes:
            inside = [i for i, o in enumerate(outers) if points_in_poly(hole[:1], o)[0]]
            if not inside:
                log.warning("a hole ring lies in no cut-out ring; dropped")
                continue
            best = min(inside, key=lambda i: areas[i])
            polys[best][1].append(hole)
    return polys
