"""Flat-colour segmentation: K-means start, Potts alpha-expansion, small-region merging.

The energy minimised is

    E(f) = sum_p |lab_p - c_{f_p}| + w * #{4-neighbour pairs (p, q): f_p != f_q}

with ``|.|`` the CIELAB distance (ΔE76), so ``w`` is in ΔE per unit of boundary.
Each alpha-expansion move is one exact binary graph cut (Boykov, Veksler & Zabih
2001) built on the grid in one vectorised call per direction (PyMaxflow), so
Python only loops over labels and sweeps.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence

import maxflow
import numpy as np
from scipy import ndimage as ndi
from skimage.color import lab2rgb, rgb2lab

from ..colour import colour_to_rgb, distinct_colours, kmeans

log = logging.getLogger(__name__)

# Edge structures for PyMaxflow: from each node to its right / lower neighbour.
_RIGHT = np.array([[0, 0, 0], [0, 0, 1], [0, 0, 0]])
_DOWN = np.array([[0, 0, 0], [0, 0, 0], [0, 1, 0]])
_FOUR = ndi.generate_binary_structure(2, 1)

#: Pixels the hard mode's K-means samples (its Potts graph cut refines the labels after).
HARD_KMEANS_SAMPLE = 20_000


def data_costs(lab: np.ndarray, centres_lab: np.ndarray) -> np.ndarray:
    """``(H, W, K)`` CIELAB distance (ΔE76) of every pixel to every colour."""
    return np.sqrt(((lab[:, :, None, :] - centres_lab[None, None, :, :]) ** 2).sum(-1))


def potts_energy(unary: np.ndarray, labels: np.ndarray, w: float) -> float:
    """The Potts energy of a labelling (see the module docstring)."""
    u = np.take_along_axis(unary, labels[..., None], axis=2).sum()
    cuts = np.count_nonzero(labels[:, 1:] != labels[:, :-1]) + np.count_nonzero(labels[1:] != labels[:-1])
    return float(u + w * cuts)


def _expand(unary: np.ndarray, f: np.ndarray, alpha: int, w: float) -> np.ndarray:
    """One alpha-expansion move: the best labelling within one graph cut of ``f``."""
    h, wd, _ = unary.shape
    u0 = np.take_along_axis(unary, f[..., None], axis=2)[..., 0].copy()
    u1 = unary[..., alpha].copy()
    g = maxflow.Graph[float](h * wd, 2 * h * wd)
    ids = g.add_grid_nodes((h, wd))
    if w > 0:
        # Pair (p, q) with x = 1 meaning "switch to alpha": A = V(f_p, f_q), B = V(f_p, a),
        # C = V(a, f_q), D = 0, and E = A + (C - A) x_p + (D - C) x_q + (B + C - A - D)(1 - x_p) x_q.
        # The last coefficient is >= 0 for the Potts metric, so each pair is one edge p -> q.
        for axis, structure in ((1, _RIGHT), (0, _DOWN)):
            fp = f[:, :-1] if axis == 1 else f[:-1, :]
            fq = f[:, 1:] if axis == 1 else f[1:, :]
            a = w * (fp != fq)
            b = w * (fp != alpha)
            c = w * (fq != alpha)
            if axis == 1:
                u1[:, :-1] += c - a
                u1[:, 1:] -= c
            else:
                u1[:-1, :] += c - a
                u1[1:, :] -= c
            cap = np.zeros((h, wd))
            if axis == 1:
                cap[:, :-1] = b + c - a
            else:
                cap[:-1, :] = b + c - a
            g.add_grid_edges(ids, weights=cap, structure=structure, symmetric=False)
    d = u1 - u0
    # Source capacity is paid when a node ends in the sink segment (x = 1) and vice versa.
    g.add_grid_tedges(ids, np.maximum(d, 0.0), np.maximum(-d, 0.0))
    g.maxflow()
    x = g.get_grid_segments(ids)
    return np.where(x, alpha, f)


def alpha_expansion(unary: np.ndarray, labels: np.ndarray, w: float, sweeps: int) -> tuple[np.ndarray, int]:
    """Minimise the Potts energy by alpha-expansion moves.

    Args:
        unary: ``(H, W, K)`` data costs.
        labels: ``(H, W)`` int starting labelling.
        w: Potts weight per differing 4-neighbour pair.
        sweeps: Maximum sweeps over all labels.

    Returns:
        The labelling and the number of sweeps run.
    """
    f = labels.astype(np.intp)
    k = unary.shape[2]
    e = potts_energy(unary, f, w)
    done = 0
    for sweep in range(1, sweeps + 1):
        done = sweep
        improved = False
        for alpha in range(k):
            new = _expand(unary, f, alpha, w)
            e_new = potts_energy(unary, new, w)
            # Exact moves never increase E; the tolerance guards float round-off only.
            if e_new < e - 1e-9 * max(1.0, abs(e)):
                f, e, improved = new, e_new, True
        if not improved:
            break
    return f, done


def merge_small_regions(
    labels: np.ndarray, centres_lab: np.ndarray, min_px: float, max_rounds: int = 100
) -> tuple[np.ndarray, int]:
    """Merge every 4-connected region smaller than ``min_px`` pixels into a neighbour.

    A small region takes the colour of the adjacent large region whose colour is
    closest; regions surrounded by small ones only wait a round, and when no such
    merge is possible the region joins its largest neighbour (ties by id, so the
    merges never form a cycle).

    Args:
        labels: ``(H, W)`` int colour labels.
        centres_lab: ``(K, 3)`` CIELAB colour of each label.
        min_px: Smallest region kept, in pixels.
        max_rounds: Safety cap on merge rounds.

    Returns:
        The new labels and the number of regions merged.
    """
    labels = labels.copy()
    merged = 0
    if min_px <= 1:
        return labels, 0
    for _ in range(max_rounds):
        comp, n = _regions(labels)
        sizes = np.bincount(comp.ravel(), minlength=n + 1)
        small = sizes < min_px
        small[0] = False
        if not small.any() or n <= 1:
            break
        colour = np.zeros(n + 1, dtype=np.intp)
        colour[comp.ravel()] = labels.ravel()
        a, b = _adjacent_pairs(comp)
        sel = small[a] & ~small[b]
        target = np.zeros(n + 1, dtype=np.intp)
        if sel.any():
            aa, bb = a[sel], b[sel]
            dist = np.linalg.norm(centres_lab[colour[aa]] - centres_lab[colour[bb]], axis=1)
            order = np.lexsort((-sizes[bb], dist, aa))
            first = np.unique(aa[order], return_index=True)[1]
            target[aa[order][first]] = bb[order][first]
        else:
            sel = small[a]
            aa, bb = a[sel], b[sel]
            if aa.size == 0:
                break
            # Strictly increasing (size, id) keys make the merge chains acyclic.
            key = sizes[bb].astype(np.float64) * (n + 2) + bb
            order = np.lexsort((-key, aa))
            first = np.unique(aa[order], return_index=True)[1]
            src, dst = aa[order][first], bb[order][first]
            keep = (sizes[dst] > sizes[src]) | ((sizes[dst] == sizes[src]) & (dst > src))
            target[src[keep]] = dst[keep]
        moving = np.flatnonzero(target)
        if moving.size == 0:
            break
        # Follow chains (a -> b -> c) to their end so each region takes its final colour.
        root = np.arange(n + 1)
        root[moving] = target[moving]
        for _ in range(64):
            nxt = root[root]
            if np.array_equal(nxt, root):
                break
            root = nxt
        merged += int(moving.size)
        labels = colour[root][comp]
    return labels, merged


def _regions(labels: np.ndarray) -> tuple[np.ndarray, int]:
    """4-connected regions of equal label, numbered 1..n."""
    comp = np.zeros(labels.shape, dtype=np.int64)
    n = 0
    for k in np.unique(labels):
        lab, m = ndi.label(labels == k, structure=_FOUR)
        comp[lab > 0] = lab[lab > 0] + n
        n += m
    return comp, n


def _adjacent_pairs(comp: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both orderings of every pair of 4-adjacent regions, one entry per shared pixel edge."""
    h1, h2 = comp[:, :-1].ravel(), comp[:, 1:].ravel()
    v1, v2 = comp[:-1, :].ravel(), comp[1:, :].ravel()
    a = np.concatenate([h1, v1, h2, v2])
    b = np.concatenate([h2, v2, h1, v1])
    d = a != b
    return a[d], b[d]


def hex_to_rgb(colours: Sequence[str]) -> np.ndarray:
    """``(K, 3)`` float in [0, 1] from hex strings '#rrggbb'."""
    return np.array([colour_to_rgb(c) for c in colours], dtype=np.float64).reshape(-1, 3)


def segment(
    rgb: np.ndarray,
    k: int,
    smoothness: float,
    min_px: float,
    rng: np.random.Generator,
    *,
    palette: np.ndarray | None = None,
    sweeps: int = 4,
    rounds: int = 2,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Segment an image into at most ``k`` flat colours.

    Args:
        rgb: ``(H, W, 3)`` float in [0, 1].
        k: Colours wanted (ignored when ``palette`` is given).
        smoothness: Potts weight in ΔE per differing 4-neighbour pair.
        min_px: Smallest region kept, in pixels; smaller ones merge.
        rng: Random generator (K-means).
        palette: ``(K, 3)`` fixed colours in [0, 1], or None to estimate them.
        sweeps: Maximum alpha-expansion sweeps per round. Defaults to 4.
        rounds: Graph cut + merge + colour re-estimation rounds. Defaults to 2.

    Returns:
        ``labels`` ``(H, W)`` int in ``[0, K')``, ``colours`` ``(K', 3)`` in [0, 1]
        (only colours that some pixel uses), and a report with ``colours_requested``,
        ``distinct_colours``, ``regions_merged``, ``sweeps``, ``energy`` and ``warnings``.
    """
    rgb = np.clip(np.asarray(rgb, dtype=np.float64), 0.0, 1.0)
    h, w = rgb.shape[:2]
    lab = rgb2lab(rgb)
    warnings: list[str] = []
    n_distinct = distinct_colours(rgb)
    fixed = palette is not None
    requested = int(k) if not fixed else int(np.asarray(palette).reshape(-1, 3).shape[0])
    if fixed:
        centres = rgb2lab(np.asarray(palette, dtype=np.float64).reshape(1, -1, 3))[0]
        k = centres.shape[0]
    else:
        if n_distinct < k:
            warnings.append(f"the image has only {n_distinct} distinct colours; using {n_distinct}, not {k}")
            k = n_distinct
        centres = kmeans(lab.reshape(-1, 3), k, rng, sample=HARD_KMEANS_SAMPLE)[0]
    labels = np.argmin(data_costs(lab, centres), axis=2)
    merged = 0
    sweeps_run = []
    for _ in range(rounds):
        unary = data_costs(lab, centres)
        labels, s = alpha_expansion(unary, labels, smoothness, sweeps)
        sweeps_run.append(s)
        labels, m = merge_small_regions(labels, centres, min_px)
        merged += m
        if not fixed:
            centres = _mean_colours(lab, labels, centres)
    energy = potts_energy(data_costs(lab, centres), labels, smoothness)
    present = np.flatnonzero(np.bincount(labels.ravel(), minlength=centres.shape[0]) > 0)
    if present.size < centres.shape[0]:
        warnings.append(
            f"{centres.shape[0] - present.size} of {centres.shape[0]} colours vanished in the segmentation "
            f"(smoothness {smoothness}, smallest region {min_px:.0f} px); {present.size} remain"
        )
    labels = _renumbered(labels, present, centres.shape[0])
    if fixed:
        colours = np.asarray(palette, dtype=np.float64).reshape(-1, 3)[present]
    else:
        colours = np.clip(lab2rgb(centres[present].reshape(1, -1, 3))[0], 0.0, 1.0)
    report = {
        "colours_requested": requested,
        "distinct_colours": n_distinct,
        "colours_found": int(present.size),
        "regions_merged": merged,
        "sweeps": sweeps_run,
        "energy": energy,
        "shape": [h, w],
        "warnings": warnings,
    }
    for msg in warnings:
        log.warning(msg)
    return labels, colours, report


def _mean_colours(lab: np.ndarray, labels: np.ndarray, centres: np.ndarray) -> np.ndarray:
    """Each used label's centre moved to the mean CIELAB colour of its pixels (unused ones kept)."""
    counts = np.bincount(labels.ravel(), minlength=centres.shape[0])
    sums = np.stack(
        [np.bincount(labels.ravel(), weights=lab[..., j].ravel(), minlength=len(centres)) for j in range(3)],
        1,
    )
    used = counts > 0
    centres = centres.copy()
    centres[used] = sums[used] / counts[used, None]
    return centres


def _renumbered(labels: np.ndarray, present: np.ndarray, n: int) -> np.ndarray:
    """Labels renumbered ``0 .. len(present) - 1`` over the ``present`` ones of ``n``."""
    remap = np.full(n, -1, dtype=np.intp)
    remap[present] = np.arange(present.size)
    return remap[labels]
