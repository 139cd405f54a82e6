"""Hole design rules, their enforcement and checking.

A soft-stencil layer is a set of circular holes (centres ``xy`` in picture mm,
radii ``r`` in mm). The rules every hole set must satisfy before any CAD:

* hole floor: ``r_i >= hole_min_r_mm`` (never below 0.5 mm);
* web: ``|c_i - c_j| >= r_i + r_j + web_mm`` for every pair;
* edge margin: ``margin + r_i <= x_i <= W - margin - r_i`` and the same in y,
  where ``W`` and ``H`` are the picture width and height in mm;
* keep-outs: the distance from ``c_i`` to each keep-out rectangle is at least
  ``r_i + margin``.

:func:`enforce_rules` repairs a dot set (raise, merge, nudge, remove) and counts
what it did; :func:`check_rules` only checks and raises :class:`DotRuleError`.
"""

from __future__ import annotations

import logging

import numba
import numpy as np
from scipy.spatial import cKDTree

from ..config.rules import DesignRules
from ..geometry import min_web

log = logging.getLogger(__name__)

#: Extra clearance in mm that nudging aims for beyond the web, so that the
#: 4-decimal CSV round trip of a repaired set still passes :func:`check_rules`.
NUDGE_SLACK_MM = 2e-3

#: Web violations :func:`check_rules` counts before it stops counting (a message shows a few).
MAX_COUNTED = 100_000

#: Default tolerance of :func:`check_rules` in mm (covers CSV rounding).
CHECK_TOL_MM = 1e-3


class DotRuleError(ValueError):
    """A dot set breaks a design rule."""


# --------------------------------------------------------------------------- geometry helpers


def _pairs_within(xy: np.ndarray, reach: float) -> np.ndarray:
    """All index pairs ``(i, j), i < j`` with centre distance ``<= reach``, as (M, 2) int64."""
    if len(xy) < 2 or reach <= 0:
        return np.empty((0, 2), dtype=np.int64)
    tree = cKDTree(xy)
    pairs = tree.query_pairs(reach, output_type="ndarray")
    return pairs.astype(np.int64, copy=False).reshape(-1, 2)


def web_violations(xy: np.ndarray, r: np.ndarray, web: float) -> tuple[np.ndarray, np.ndarray]:
    """Pairs whose web is below ``web`` and their web values (sorted smallest first)."""
    if len(xy) < 2:
        return np.empty((0, 2), dtype=np.int64), np.empty(0)
    pairs = _pairs_within(xy, 2.0 * float(r.max()) + web)
    return _short_pairs(xy, r, web, pairs)


def _short_pairs(
    xy: np.ndarray, r: np.ndarray, web: float, pairs: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The pairs among ``pairs`` whose web is below ``web``, smallest web first, and their webs."""
    if len(pairs) == 0:
        return pairs, np.empty(0)
    d = np.hypot(*(xy[pairs[:, 0]] - xy[pairs[:, 1]]).T)
    webs = d - r[pairs[:, 0]] - r[pairs[:, 1]]
    bad = np.flatnonzero(webs < web)
    order = bad[np.argsort(webs[bad], kind="stable")]
    return pairs[order], webs[order]


def _keepout_clearance(xy: np.ndarray, rects: tuple) -> np.ndarray:
    """Distance from each centre to the nearest keep-out rectangle, ``(N,)`` (inf if none)."""
    out = np.full(len(xy), np.inf)
    for x0, y0, x1, y1 in rects:
        dx = np.maximum(np.maximum(x0 - xy[:, 0], xy[:, 0] - x1), 0.0)
        dy = np.maximum(np.maximum(y0 - xy[:, 1], xy[:, 1] - y1), 0.0)
        np.minimum(out, np.hypot(dx, dy), out=out)
    return out


def _push_out_of_keepouts(xy: np.ndarray, r: np.ndarray, rules: DesignRules) -> None:
    """Move centres that sit inside an expanded keep-out to its nearest side (in place)."""
    for x0, y0, x1, y1 in rules.keepouts:
        grow = r + rules.edge_margin_mm + NUDGE_SLACK_MM
        ex0, ex1 = x0 - grow, x1 + grow
        ey0, ey1 = y0 - grow, y1 + grow
        inside = (xy[:, 0] > ex0) & (xy[:, 0] < ex1) & (xy[:, 1] > ey0) & (xy[:, 1] < ey1)
        # The rule measures the true distance to the rectangle (round at its corners): a dot in
        # the square corner of the grown box but clear of the rounded one is not in violation.
        dx = np.maximum(np.maximum(x0 - xy[:, 0], xy[:, 0] - x1), 0.0)
        dy = np.maximum(np.maximum(y0 - xy[:, 1], xy[:, 1] - y1), 0.0)
        inside &= np.hypot(dx, dy) < grow
        if not inside.any():
            continue
        p = xy[inside]
        moves = np.stack(
            [ex0[inside] - p[:, 0], ex1[inside] - p[:, 0], ey0[inside] - p[:, 1], ey1[inside] - p[:, 1]],
            axis=1,
        )
        k = np.argmin(np.abs(moves), axis=1)
        rows = np.arange(len(p))
        step = moves[rows, k]
        p[k < 2, 0] += step[k < 2]
        p[k >= 2, 1] += step[k >= 2]
        xy[inside] = p


def _clamp_to_box(xy: np.ndarray, r: np.ndarray, rules: DesignRules) -> None:
    """Clamp centres into the edge-margin box (in place); infeasible boxes are left alone."""
    lo = rules.edge_margin_mm + r + NUDGE_SLACK_MM
    hix = rules.width_mm - lo
    hiy = rules.height_mm - lo
    ok = (hix >= lo) & (hiy >= lo)
    xy[ok, 0] = np.clip(xy[ok, 0], lo[ok], hix[ok])
    xy[ok, 1] = np.clip(xy[ok, 1], lo[ok], hiy[ok])


def _edge_excess(xy: np.ndarray, r: np.ndarray, rules: DesignRules) -> np.ndarray:
    """How far (mm) each hole intrudes into the edge margin; <= 0 means fine."""
    m = rules.edge_margin_mm
    return np.max(
        np.stack(
            [
                m + r - xy[:, 0],
                xy[:, 0] + r + m - rules.width_mm,
                m + r - xy[:, 1],
                xy[:, 1] + r + m - rules.height_mm,
            ]
        ),
        axis=0,
    )


@numba.njit(cache=True)
def _greedy_merge(pairs, xy, r, alive):  # pragma: no cover - compiled
    """Merge each close pair once: the survivor moves to the area-weighted centre."""
    merged = 0
    used = np.zeros(alive.shape[0], dtype=np.bool_)
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        if not (alive[i] and alive[j]) or used[i] or used[j]:
            continue
        wi = r[i] * r[i]
        wj = r[j] * r[j]
        xy[i, 0] = (wi * xy[i, 0] + wj * xy[j, 0]) / (wi + wj)
        xy[i, 1] = (wi * xy[i, 1] + wj * xy[j, 1]) / (wi + wj)
        r[i] = max(r[i], r[j])
        alive[j] = False
        used[i] = True
        merged += 1
    return merged


@numba.njit(cache=True)
def _greedy_remove(pairs, degree, r, alive):  # pragma: no cover - compiled
    """Resolve each violating pair (worst first) by removing its more crowded dot."""
    removed = 0
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        if not (alive[i] and alive[j]):
            continue
        # Remove the dot with more conflicts; on a tie the smaller hole, then the later index.
        if degree[i] > degree[j] or (degree[i] == degree[j] and (r[i] < r[j] or (r[i] == r[j] and i > j))):
            victim = i
        else:
            victim = j
        alive[victim] = False
        removed += 1
    return removed


def _alive_after_removal(resolve: np.ndarray, all_pairs: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Greedily remove one dot of each pair in ``resolve`` (worst first); crowding counts ``all_pairs``."""
    degree = np.bincount(all_pairs.ravel(), minlength=len(r)).astype(np.int64)
    alive = np.ones(len(r), dtype=np.bool_)
    _greedy_remove(np.ascontiguousarray(resolve, dtype=np.int64), degree, r, alive)
    return alive


# --------------------------------------------------------------------------- public API


def _merge_fused(xy: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Merge holes that would fuse (both centres inside the larger hole), closest pairs first.

    Returns:
        ``(xy, r, merged)``: the surviving holes and how many merges were made.
    """
    merged = 0
    if len(xy) > 1:
        pairs = _pairs_within(xy, float(r.max()))
        if len(pairs):
            d = np.hypot(*(xy[pairs[:, 0]] - xy[pairs[:, 1]]).T)
            close = d < np.maximum(r[pairs[:, 0]], r[pairs[:, 1]])
            pairs = pairs[close][np.argsort(d[close], kind="stable")]
            alive = np.ones(len(r), dtype=np.bool_)
            merged = int(_greedy_merge(np.ascontiguousarray(pairs), xy, r, alive)) if len(pairs) else 0
            xy, r = xy[alive], r[alive]
    return xy, r, merged


@numba.njit(cache=True)
def _sweep_pushes(xy, r, target_web, candidates, active, first):  # pragma: no cover - compiled
    """One sweep of :func:`_nudge`'s pair pushes, in place: ``(the dots to clamp and cap, their places before)``.

    The candidate pairs with an active dot whose web is short of ``target_web``, smallest web first
    (ties in candidate order), each push half the deficit apart along the centres' line from the places
    before the sweep, summed per dot in that order: the operations of the NumPy sweep it replaced
    (``hypot``, a stable sort, ``bincount``), the same bits. The dots are all of them on the ``first``
    sweep, else those of a short pair, increasing; none (and nothing pushed) when no pair is short then.
    A sweep's few thousand pairs cost NumPy more in calls than in work: the nudging of the 16 layers the
    bundled example's ``stencil-cad run`` stipples took 0.23 CPU-s with this kernel, 0.49 without (medians
    of 5; about 90 sweeps a layer, 400 short pairs a sweep).
    """
    n = xy.shape[0]
    keep = np.empty(candidates.shape[0], dtype=np.int64)
    webs = np.empty(candidates.shape[0])
    m = 0
    for k in range(candidates.shape[0]):
        a, b = candidates[k, 0], candidates[k, 1]
        if active[a] or active[b]:
            web = np.hypot(xy[a, 0] - xy[b, 0], xy[a, 1] - xy[b, 1]) - r[a] - r[b]
            if web < target_web:
                keep[m] = k
                webs[m] = web
                m += 1
    order = np.argsort(webs[:m], kind="mergesort")
    mark = np.ones(n, dtype=np.bool_) if first else np.zeros(n, dtype=np.bool_)
    for q in range(m):
        mark[candidates[keep[order[q]], 0]] = True
        mark[candidates[keep[order[q]], 1]] = True
    idx = np.flatnonzero(mark)
    before = xy[idx]
    if m:
        push = np.zeros((4, n))
        for q in range(m):
            a, b = candidates[keep[order[q]], 0], candidates[keep[order[q]], 1]
            dx, dy = xy[a, 0] - xy[b, 0], xy[a, 1] - xy[b, 1]
            dist = np.hypot(dx, dy)
            ux, uy = (dx / max(dist, 1e-12), dy / max(dist, 1e-12)) if dist > 1e-12 else (1.0, 0.0)
            half = 0.5 * (target_web - webs[order[q]])
            push[0, a] += half * ux
            push[1, b] += half * ux
            push[2, a] += half * uy
            push[3, b] += half * uy
        for v in range(n):
            xy[v, 0] += push[0, v] - push[1, v]
            xy[v, 1] += push[2, v] - push[3, v]
    return idx, before


def _nudge(xy: np.ndarray, r: np.ndarray, rules: DesignRules, max_nudge_mm: float, nudge_rounds: int) -> None:
    """Jacobi sweeps that push each violating pair apart by half its deficit, in place.

    The first sweep also brings every dot inside the margin box and out of keep-outs; no
    dot moves more than ``max_nudge_mm`` from where it started.
    """
    start = xy.copy()
    target_web = rules.web_mm + NUDGE_SLACK_MM
    # No dot moves more than max_nudge_mm, so every pair that can come within the web
    # is within this reach at the start: find the candidates once, not every sweep.
    candidates = _pairs_within(start, 2.0 * float(r.max(initial=0.0)) + target_web + 2.0 * max_nudge_mm)
    active = np.ones(len(xy), dtype=bool)
    for sweep in range(nudge_rounds):
        # The first sweep also brings every dot inside the margin box and out of keep-outs;
        # later sweeps only touch the dots of violating pairs. Coincident centres get a fixed
        # direction so the result stays deterministic.
        idx, before = _sweep_pushes(xy, r, target_web, candidates, active, sweep == 0)
        if len(idx) == 0:
            break
        sub, rs = xy[idx], r[idx]
        _clamp_to_box(sub, rs, rules)
        _push_out_of_keepouts(sub, rs, rules)
        # Cap the total displacement so nudging never redraws the distribution.
        off = sub - start[idx]
        dist = np.hypot(off[:, 0], off[:, 1])
        far = dist > max_nudge_mm
        if far.any():
            sub[far] = start[idx][far] + off[far] * (max_nudge_mm / dist[far])[:, None]
        xy[idx] = sub
        # Only dots that moved can have made new conflicts; stuck ones are left to removal.
        moved = idx[(sub != before).any(axis=1)]
        if len(moved) == 0:
            break
        active[:] = False
        active[moved] = True


def _drop_hopeless(xy: np.ndarray, r: np.ndarray, rules: DesignRules, max_nudge_mm: float):
    """Remove the more crowded dot of each pair whose web is short by more than two full nudges.

    Such a pair cannot be saved by nudging; removing first keeps an overfull set from costing
    millions of pair pushes per sweep. Returns ``(xy, r, removed)``.
    """
    removed_web = 0
    pairs, webs = web_violations(xy, r, rules.web_mm)
    hopeless = pairs[(rules.web_mm - webs) > 2.0 * max_nudge_mm]
    if len(hopeless):
        alive = _alive_after_removal(hopeless, pairs, r)
        removed_web += int((~alive).sum())
        xy, r = xy[alive], r[alive]
    return xy, r, removed_web


def _drop_outside(xy: np.ndarray, r: np.ndarray, rules: DesignRules, report: dict):
    """Remove the dots outside the margin box or in a keep-out; count them into ``report``."""
    edge_out = _edge_excess(xy, r, rules) > 0
    keep_out = (_keepout_clearance(xy, rules.keepouts) < r + rules.edge_margin_mm) & ~edge_out
    report["removed_edge"] = int(edge_out.sum())
    report["removed_keepout"] = int(keep_out.sum())
    keep = ~(edge_out | keep_out)
    return xy[keep], r[keep]


def enforce_rules(
    xy: np.ndarray,
    r: np.ndarray,
    rules: DesignRules,
    max_nudge_mm: float | None = None,
    nudge_rounds: int = 100,
) -> tuple[np.ndarray, np.ndarray, dict]:
    """Repair a hole set so that it satisfies the design rules.

    In order: non-finite dots are dropped; radii below the floor are raised;
    pairs whose centres are closer than the larger radius (holes that would
    fuse) are merged into one hole at their area-weighted centre; pairs whose
    web is short by more than ``2 max_nudge_mm`` lose their more crowded dot;
    web, edge and keep-out violations are nudged apart (each dot moves at most
    ``max_nudge_mm`` in total); dots still outside the margin box or a keep-out
    are removed; remaining web violations are resolved by removing the more
    crowded dot of each pair, worst pair first. The result always passes
    :func:`check_rules`.

    Args:
        xy: ``(N, 2)`` hole centres in picture mm.
        r: ``(N,)`` hole radii in mm.
        rules: The design rules.
        max_nudge_mm: Largest total move of one dot when nudging, in mm.
            Defaults to 0.35 of the minimum centre spacing
            ``2 hole_min_r + web`` (on the bundled example this resolved all
            but a handful of conflicts; 0.25 left 1-3 % of the dots to removal).
        nudge_rounds: Nudge sweeps (stopping early once nothing moves). Defaults to 100.

    Returns:
        ``(xy, r, report)``: the repaired centres and radii (new arrays) and a
        dict with ``n_in``, ``n_out``, ``raised``, ``merged``, ``nudged``,
        ``removed`` (total) and ``removed_invalid``, ``removed_edge``,
        ``removed_keepout``, ``removed_web``, and ``min_web_mm``.
    """
    xy = np.array(xy, dtype=np.float64).reshape(-1, 2)
    r = np.array(r, dtype=np.float64).reshape(-1)
    if len(xy) != len(r):
        raise ValueError(f"xy has {len(xy)} dots but r has {len(r)}")
    report: dict[str, int | float] = {"n_in": int(len(r))}
    if max_nudge_mm is None:
        max_nudge_mm = 0.35 * (2.0 * rules.hole_min_r_mm + rules.web_mm)

    finite = np.isfinite(xy).all(axis=1) & np.isfinite(r)
    report["removed_invalid"] = int((~finite).sum())
    xy, r = xy[finite], r[finite]

    low = r < rules.hole_min_r_mm
    report["raised"] = int(low.sum())
    r[low] = rules.hole_min_r_mm

    xy, r, report["merged"] = _merge_fused(xy, r)

    xy, r, removed_web = _drop_hopeless(xy, r, rules, max_nudge_mm)

    start = xy.copy()
    _nudge(xy, r, rules, max_nudge_mm, nudge_rounds)
    report["nudged"] = int((np.hypot(*(xy - start).T) > 1e-9).sum())

    xy, r = _drop_outside(xy, r, rules, report)

    pairs, _ = web_violations(xy, r, rules.web_mm)
    if len(pairs):
        alive = _alive_after_removal(pairs, pairs, r)
        removed_web += int((~alive).sum())
        xy, r = xy[alive], r[alive]
    report["removed_web"] = removed_web
    report["removed"] = (
        report["removed_invalid"] + report["removed_edge"] + report["removed_keepout"] + removed_web
    )
    report["n_out"] = int(len(r))
    report["min_web_mm"] = min_web(xy, r)
    return xy, r, report


def _web_violations_capped(
    xy: np.ndarray, r: np.ndarray, web: float, cap: int
) -> tuple[np.ndarray, np.ndarray]:
    """Like :func:`web_violations`, but stops once ``cap`` pairs are found, in bounded memory.

    Dots piled on each other make every pair a violation: all of them would take memory and
    time quadratic in the dots, and a message needs a few.
    """
    n = len(xy)
    tree = cKDTree(xy)
    reach = 2.0 * float(r.max()) + web
    # Neighbour lists of a chunk of dots at a time: at most about 2 million indices.
    step = max(1, 2_000_000 // n)
    found_p: list[np.ndarray] = []
    found_w: list[np.ndarray] = []
    count = 0
    for s in range(0, n, step):
        e = min(n, s + step)
        near = tree.query_ball_point(xy[s:e], reach, return_sorted=False)
        i = np.repeat(np.arange(s, e), [len(x) for x in near])
        j = np.fromiter((k for x in near for k in x), dtype=np.int64, count=len(i))
        keep = j > i
        pairs, webs = _short_pairs(xy, r, web, np.stack([i[keep], j[keep]], axis=1))
        found_p.append(pairs)
        found_w.append(webs)
        count += len(pairs)
        if count >= cap:
            break
    pairs, webs = np.concatenate(found_p)[:cap], np.concatenate(found_w)[:cap]
    return pairs, webs


def _violations(xy: np.ndarray, r: np.ndarray, rules: DesignRules, tol_mm: float, limit: int | None):
    """Count the violations and describe up to ``limit`` per rule (all when None)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    r = np.asarray(r, dtype=np.float64).reshape(-1)
    if len(xy) != len(r):
        raise ValueError(f"xy has {len(xy)} dots but r has {len(r)}")
    out: list[tuple[int, str]] = []
    total = 0

    def where(i: int) -> str:
        return f"dot {i} at ({xy[i, 0]:.3f}, {xy[i, 1]:.3f}) mm, r = {r[i]:.3f} mm"

    bad = ~(np.isfinite(xy).all(axis=1) & np.isfinite(r))
    hits = np.flatnonzero(bad)
    total += len(hits)
    for i in hits[:limit]:
        out.append((int(i), f"{where(i)}: not a finite number"))
    ok = ~bad
    xs, rs = np.nan_to_num(xy), np.nan_to_num(r)

    hits = np.flatnonzero(ok & (r < rules.hole_min_r_mm - tol_mm))
    total += len(hits)
    for i in hits[:limit]:
        short = rules.hole_min_r_mm - r[i]
        out.append(
            (int(i), f"{where(i)}: radius below the hole floor {rules.hole_min_r_mm} mm by {short:.3f} mm")
        )

    excess = np.where(ok, _edge_excess(xs, rs, rules), -np.inf)
    hits = np.flatnonzero(excess > tol_mm)
    total += len(hits)
    for i in hits[:limit]:
        out.append((int(i), f"{where(i)}: edge margin below {rules.edge_margin_mm} mm by {excess[i]:.3f} mm"))

    if rules.keepouts:
        lack = np.where(ok, rules.edge_margin_mm - (_keepout_clearance(xs, rules.keepouts) - rs), -np.inf)
        hits = np.flatnonzero(lack > tol_mm)
        total += len(hits)
        for i in hits[:limit]:
            out.append(
                (
                    int(i),
                    f"{where(i)}: clearance to a keep-out below {rules.edge_margin_mm} mm by {lack[i]:.3f} mm",
                )
            )

    idx = np.flatnonzero(ok)
    if len(idx) > 1:
        if limit is None:
            pairs, webs = web_violations(xy[idx], r[idx], rules.web_mm - tol_mm)
        else:
            pairs, webs = _web_violations_capped(xy[idx], r[idx], rules.web_mm - tol_mm, MAX_COUNTED)
        pairs = idx[pairs]
        total += len(pairs)
        order = np.lexsort((pairs[:, 1], pairs[:, 0]))[:limit]
        for (i, j), w in zip(pairs[order], webs[order], strict=True):
            short = rules.web_mm - w
            out.append(
                (
                    int(i),
                    f"{where(i)}: web to dot {j} is {w:.3f} mm, below {rules.web_mm} mm by {short:.3f} mm",
                )
            )
    out.sort(key=lambda t: t[0])
    return total, out


def rule_violations(xy: np.ndarray, r: np.ndarray, rules: DesignRules, tol_mm: float = CHECK_TOL_MM) -> list:
    """List every design-rule violation of a hole set.

    Args:
        xy: ``(N, 2)`` hole centres in picture mm.
        r: ``(N,)`` hole radii in mm.
        rules: The design rules.
        tol_mm: Violations up to this size are accepted. Defaults to 0.001 mm
            (the rounding of a 4-decimal CSV).

    Returns:
        ``(index, message)`` tuples sorted by dot index, one per violation (a
        web violation is listed under the lower index of its pair).
    """
    return _violations(xy, r, rules, tol_mm, None)[1]


def check_rules(
    xy: np.ndarray, r: np.ndarray, rules: DesignRules, tol_mm: float = CHECK_TOL_MM, show: int = 5
) -> None:
    """Raise :class:`DotRuleError` if a hole set breaks a design rule.

    Args:
        xy: ``(N, 2)`` hole centres in picture mm.
        r: ``(N,)`` hole radii in mm.
        rules: The design rules.
        tol_mm: Violations up to this size are accepted. Defaults to 0.001 mm.
        show: How many offending dots the message lists. Defaults to 5.

    Raises:
        DotRuleError: naming the first offending dots (index, x, y, r, the rule
            and by how much it is missed) and the total count.
    """
    total, found = _violations(xy, r, rules, tol_mm, show)
    if total:
        lines = [msg for _, msg in found[:show]]
        counted = f"{total}" if total < MAX_COUNTED else f"at least {MAX_COUNTED}"
        raise DotRuleError(
            f"{counted} design-rule violation(s) among {len(np.asarray(r).reshape(-1))} dots; first:\n  "
            + "\n  ".join(lines)
        )
