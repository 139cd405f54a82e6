"""Model-based hole refinement: move and resize the stippled holes so the sprayed picture matches.

The stippler places holes by density alone; what the viewer sees is the composite of all
layers sprayed through them. This stage optimises every hole's centre and radius against
the spray model (least-squares model-based halftoning, Pappas & Neuhoff 1999; the add/remove
moves follow direct binary search, Analoui & Allebach 1992), with the design rules held
after every step.

Objective. On the simulation grid, with ``C(p)`` the composite of the primer and every
layer sprayed in order (Porter-Duff *over*) and ``C*(p)`` the input picture,

    E = sum_p |g * (C - C*)|^2(p)

where ``g`` is a Gaussian of the eye's narrowest (luminance) lobe at the viewing distance
(:func:`stencil_cad.simulate.scielab.smallest_sigma_mm`): error finer than the eye resolves from
there costs nothing. Each layer's own filtered opacity error ``sum_p (g * (alpha_l -
alpha*_l))^2`` is added with a weight (``refine.layer_weight``): the composite alone
lets one layer drift from its target to make up for another's colour. The composite is affine in each layer's opacity ``alpha_l``:
``dC/dalpha_l = (c_l - C_{l-1}) prod_{m > l} (1 - alpha_m)``, so ``dE/dalpha_l`` is one
pass over the layers. Each layer's opacity follows the per-hole contract of
:func:`stencil_cad.simulate.spray.hole_kernels` (Gaussian deposits ``N_i`` of width ``sigma_i``
and height ``peak_i`` combined as a product of transmittances or an exponential of the
summed dose), whose derivative with respect to a hole's centre and radius is exact:

* product: ``dalpha/dN_i = T / (1 - N_i)`` where ``N_i < 1`` (0 where the hole clamps);
* exp: ``dalpha/dN_i = T``;

with ``T = 1 - alpha`` and ``dN_i/dc = N_i (p - c) / sigma^2``,
``dN_i/dr = N_i |p - c|^2 / sigma^3 dsigma/dr + N_i / peak dpeak/dr``. A hole touches
the pixels within the distance where its deposit falls below ``1e-4`` (a few sigma), in
compiled code, so one iteration is linear in the number of holes.

Steps are Adam's (Kingma & Ba 2015) with a decaying step size. After every step the
holes are projected onto the design rules: radii are clamped to ``[floor, max]``; each
pair closer than the web first shrinks both radii (towards the floor), and only the
deficit left is resolved by pushing the centres apart (pushing first made the later rule
enforcement remove a third of the holes in a prototype); centres are clamped into the
edge-margin box and out of keep-outs. A hole that still breaks a rule after that goes
back to where it was before the step (that state passed the rules), until none does, so
the rules hold at every step, not just at the end.

Add / remove. Every few iterations each layer gets two moves scored on the composite
error: a hole is removed where removing it lowers ``E``, and a hole of the floor radius is
added at local minima of the predicted change of ``E`` where it fits the rules. The
composite is affine in one layer's opacity, so the change is
``dE ≈ sum_p G dalpha + Q dalpha^2`` with ``G = dE/dalpha`` and
``Q = |dC/dalpha|^2`` (exact without the eye filter); for an added hole both sums are
Gaussian filters of ``G T`` and ``Q T^2``.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numba
import numpy as np

from ..frames import mm_to_px, px_to_mm
from ..model import DotSet
from .rules import NUDGE_SLACK_MM, DesignRules, _keepout_clearance, _push_out_of_keepouts, check_rules

log = logging.getLogger(__name__)

__all__ = ["Kernels", "RefineSettings", "refine_dots"]

#: The spray model's per-hole contract, bound to the spray settings:
#: ``kernels(r_mm, spray_time) -> (sigma_mm, peak, dsigma_dr, dpeak_dr, combine)``
#: (see :func:`stencil_cad.simulate.spray.hole_kernels`).
Kernels = Callable[[np.ndarray, float], tuple]

#: A hole's deposit is evaluated out to where it falls below this (relative to 1).
_TAIL = 1e-4
#: Rule tolerance of the refinement's own check, mm (a quarter of ``check_rules``' default).
_TOL_MM = 2.5e-4
#: Adam's moment decay rates and epsilon.
_B1, _B2, _EPS = 0.9, 0.99, 1e-12


@dataclass(frozen=True)
class RefineSettings:
    """Knobs of the refinement (the ``refine`` config section resolves to this).

    Attributes:
        iterations: Gradient steps.
        step_mm: Adam step size of the centres at the start, in mm (decays to a fifth).
        radius_step_mm: Adam step size of the radii at the start, in mm.
        max_radius_mm: Largest hole radius in mm (per layer the rules' floor is the smallest).
        add_remove_every: Add/remove moves every this many iterations (0: never).
        eye_sigma_mm: Standard deviation of the eye filter in the objective, mm (0: none).
        layer_weight: Weight of each layer's own opacity error beside the composite's.
    """

    iterations: int = 60
    step_mm: float = 0.05
    radius_step_mm: float = 0.02
    max_radius_mm: float = 1.0
    add_remove_every: int = 15
    eye_sigma_mm: float = 0.0
    layer_weight: float = 1.0


# --------------------------------------------------------------------------- compiled kernels


@numba.njit(cache=True)
def _footprint(row, col, sig, a, h, w):  # pragma: no cover - compiled
    """Pixel window where a deposit of peak ``a`` exceeds the tail, ``1 / (2 sigma^2)`` and its column profile."""
    rad = sig * math.sqrt(2.0 * math.log(a / _TAIL))
    r0 = max(0, int(math.ceil(row - rad)))
    r1 = min(h - 1, int(math.floor(row + rad)))
    c0 = max(0, int(math.ceil(col - rad)))
    c1 = min(w - 1, int(math.floor(col + rad)))
    k = 1.0 / (2.0 * sig * sig)
    ex = np.empty(max(c1 - c0 + 1, 0))
    for c in range(c0, c1 + 1):
        dx = c - col
        ex[c - c0] = math.exp(-dx * dx * k)
    return r0, r1, c0, c1, k, ex


#: Rows per band of the parallel transmittance (each band is written by one thread only).
_BAND = 32


@numba.njit(cache=True, parallel=True)
def _transmittance_bands(
    h, w, rows, cols, sig, peak, exp_mode, band_lo, band_hi
):  # pragma: no cover - compiled
    """``T`` by row bands; holes sorted by row, band ``b`` visits holes ``band_lo[b]:band_hi[b]``."""
    t = np.ones((h, w))
    s = np.zeros((h, w)) if exp_mode else t
    for b in numba.prange(band_lo.shape[0]):
        lo = b * _BAND
        hi = min(h, lo + _BAND) - 1
        for i in range(band_lo[b], band_hi[b]):
            a = peak[i]
            if a <= _TAIL:
                continue
            r0, r1, c0, c1, k, ex = _footprint(rows[i], cols[i], sig[i], a, h, w)
            for r in range(max(r0, lo), min(r1, hi) + 1):
                dy = r - rows[i]
                ey = a * math.exp(-dy * dy * k)
                for c in range(c0, c1 + 1):
                    n = ey * ex[c - c0]
                    if exp_mode:
                        s[r, c] += n
                    else:
                        t[r, c] *= max(1.0 - n, 0.0)
        if exp_mode:
            for r in range(lo, hi + 1):
                for c in range(w):
                    t[r, c] = math.exp(-s[r, c])
    return t


def _transmittance(h, w, rows, cols, sig, peak, exp_mode):
    """``T = prod (1 - min(N_i, 1))`` (or ``exp(-sum N_i)``) on an ``(h, w)`` grid, px units."""
    order = np.argsort(rows, kind="stable")
    rows, cols, sig, peak = rows[order], cols[order], sig[order], peak[order]
    a = np.maximum(peak, _TAIL)
    reach = float(np.max(sig * np.sqrt(2.0 * np.log(a / _TAIL)), initial=0.0)) + 1.0
    top = np.arange(0, h, _BAND, dtype=np.float64)
    band_lo = np.searchsorted(rows, top - reach, side="left").astype(np.int64)
    band_hi = np.searchsorted(rows, top + _BAND + reach, side="right").astype(np.int64)
    return _transmittance_bands(h, w, rows, cols, sig, peak, exp_mode, band_lo, band_hi)


@numba.njit(cache=True, parallel=True)
def _hole_gradients(g, t, rows, cols, sig, peak, exp_mode):  # pragma: no cover - compiled
    """Per hole ``sum_p g(p) dalpha/dN_i dN_i/d(row, col, sigma, peak)`` in px units."""
    n = rows.shape[0]
    out = np.zeros((n, 4))
    h, w = g.shape
    for i in numba.prange(n):
        a = peak[i]
        if a <= _TAIL:
            continue
        r0, r1, c0, c1, k, ex = _footprint(rows[i], cols[i], sig[i], a, h, w)
        s2 = sig[i] * sig[i]
        gr = 0.0
        gc = 0.0
        gs = 0.0
        ga = 0.0
        for r in range(r0, r1 + 1):
            dy = r - rows[i]
            ey = math.exp(-dy * dy * k)
            for c in range(c0, c1 + 1):
                dx = c - cols[i]
                e = ey * ex[c - c0]
                nv = a * e
                if exp_mode:
                    dadn = t[r, c]
                else:
                    if nv >= 1.0:
                        continue
                    dadn = t[r, c] / (1.0 - nv)
                q = g[r, c] * dadn
                gr += q * nv * dy / s2
                gc += q * nv * dx / s2
                gs += q * nv * (dx * dx + dy * dy) / (s2 * sig[i])
                ga += q * e
        out[i, 0] = gr
        out[i, 1] = gc
        out[i, 2] = gs
        out[i, 3] = ga
    return out


@numba.njit(cache=True, parallel=True)
def _removal_change(g, q, t, rows, cols, sig, peak, exp_mode):  # pragma: no cover - compiled
    """Predicted change of the objective if each hole alone were removed (inf: cannot tell)."""
    n = rows.shape[0]
    out = np.zeros(n)
    h, w = g.shape
    for i in numba.prange(n):
        a = peak[i]
        if a <= _TAIL:
            continue
        if not exp_mode and a >= 1.0:
            out[i] = np.inf
            continue
        r0, r1, c0, c1, k, ex = _footprint(rows[i], cols[i], sig[i], a, h, w)
        acc = 0.0
        for r in range(r0, r1 + 1):
            dy = r - rows[i]
            ey = a * math.exp(-dy * dy * k)
            for c in range(c0, c1 + 1):
                nv = ey * ex[c - c0]
                if exp_mode:
                    d = t[r, c] * (math.exp(nv) - 1.0)
                else:
                    d = t[r, c] * nv / (1.0 - nv)
                # Removing the hole lowers the opacity by d.
                acc += -g[r, c] * d + q[r, c] * d * d
        out[i] = acc
    return out


@numba.njit(cache=True)
def _cell_pairs(x, y, reach):  # pragma: no cover - compiled
    """All pairs ``i < j`` with centre distance ``<= reach`` (grid buckets of size ``reach``)."""
    n = x.shape[0]
    if n < 2:
        return np.empty((0, 2), dtype=np.int64)
    x0 = x.min()
    y0 = y.min()
    nx = int((x.max() - x0) / reach) + 1
    ny = int((y.max() - y0) / reach) + 1
    cx = np.empty(n, dtype=np.int64)
    cy = np.empty(n, dtype=np.int64)
    start = np.zeros(nx * ny + 1, dtype=np.int64)
    for i in range(n):
        cx[i] = int((x[i] - x0) / reach)
        cy[i] = int((y[i] - y0) / reach)
        start[cy[i] * nx + cx[i] + 1] += 1
    for k in range(nx * ny):
        start[k + 1] += start[k]
    order = np.empty(n, dtype=np.int64)
    fill = start[:-1].copy()
    for i in range(n):
        k = cy[i] * nx + cx[i]
        order[fill[k]] = i
        fill[k] += 1
    count = _pair_scan(x, y, reach, cx, cy, nx, ny, start, order, np.empty((0, 2), dtype=np.int64))
    out = np.empty((count, 2), dtype=np.int64)
    _pair_scan(x, y, reach, cx, cy, nx, ny, start, order, out)
    return out


@numba.njit(cache=True)
def _pair_scan(x, y, reach, cx, cy, nx, ny, start, order, out):  # pragma: no cover - compiled
    """Count the close pairs; also write them when ``out`` has room."""
    r2 = reach * reach
    write = out.shape[0] > 0
    m = 0
    for i in range(x.shape[0]):
        for by in range(max(cy[i] - 1, 0), min(cy[i] + 2, ny)):
            for bx in range(max(cx[i] - 1, 0), min(cx[i] + 2, nx)):
                b = by * nx + bx
                for q in range(start[b], start[b + 1]):
                    j = order[q]
                    if j <= i:
                        continue
                    dx = x[i] - x[j]
                    dy = y[i] - y[j]
                    if dx * dx + dy * dy <= r2:
                        if write:
                            out[m, 0] = i
                            out[m, 1] = j
                        m += 1
    return m


@numba.njit(cache=True)
def _project_pairs(pairs, x, y, r, rmin, web, sweeps):  # pragma: no cover - compiled
    """Gauss-Seidel sweeps over close pairs: shrink radii towards ``rmin`` first, then push apart."""
    for _ in range(sweeps):
        moved = False
        for k in range(pairs.shape[0]):
            i = pairs[k, 0]
            j = pairs[k, 1]
            dx = x[i] - x[j]
            dy = y[i] - y[j]
            d = math.sqrt(dx * dx + dy * dy)
            deficit = r[i] + r[j] + web - d
            if deficit <= 0.0:
                continue
            moved = True
            ai = max(r[i] - rmin, 0.0)
            aj = max(r[j] - rmin, 0.0)
            s = min(deficit, ai + aj)
            if s > 0.0:
                r[i] -= s * ai / (ai + aj)
                r[j] -= s * aj / (ai + aj)
                deficit -= s
            if deficit > 0.0:
                if d > 1e-12:
                    ux = dx / d
                    uy = dy / d
                else:
                    ux = 1.0
                    uy = 0.0
                x[i] += 0.5 * deficit * ux
                y[i] += 0.5 * deficit * uy
                x[j] -= 0.5 * deficit * ux
                y[j] -= 0.5 * deficit * uy
        if not moved:
            break


@numba.njit(cache=True)
def _web_bad(pairs, x, y, r, web):  # pragma: no cover - compiled
    """Mark both holes of every pair whose web is below ``web``."""
    bad = np.zeros(x.shape[0], dtype=np.bool_)
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        dx = x[i] - x[j]
        dy = y[i] - y[j]
        if math.sqrt(dx * dx + dy * dy) - r[i] - r[j] < web:
            bad[i] = True
            bad[j] = True
    return bad


@numba.njit(cache=True)
def _greedy_add(cand_x, cand_y, x, y, r, r_new, web, cell, cap):  # pragma: no cover - compiled
    """Accept candidates in order when their hole of radius ``r_new`` clears every hole by the web."""
    n = x.shape[0]
    m = cand_x.shape[0]
    accepted = np.zeros(m, dtype=np.bool_)
    if m == 0:
        return accepted
    allx = np.concatenate((x, cand_x))
    ally = np.concatenate((y, cand_y))
    x0 = allx.min() - cell
    y0 = ally.min() - cell
    nx = int((allx.max() - x0) / cell) + 2
    ny = int((ally.max() - y0) / cell) + 2
    grid = -np.ones((ny, nx, cap), dtype=np.int64)
    cnt = np.zeros((ny, nx), dtype=np.int64)
    rad = np.concatenate((r, np.full(m, r_new)))
    for i in range(n):
        gx = int((x[i] - x0) / cell)
        gy = int((y[i] - y0) / cell)
        if cnt[gy, gx] < cap:
            grid[gy, gx, cnt[gy, gx]] = i
            cnt[gy, gx] += 1
    for k in range(m):
        gx = int((cand_x[k] - x0) / cell)
        gy = int((cand_y[k] - y0) / cell)
        if cnt[gy, gx] >= cap:
            continue
        ok = True
        for by in range(max(gy - 1, 0), min(gy + 2, ny)):
            for bx in range(max(gx - 1, 0), min(gx + 2, nx)):
                for q in range(cnt[by, bx]):
                    j = grid[by, bx, q]
                    dx = allx[j] - cand_x[k]
                    dy = ally[j] - cand_y[k]
                    if math.sqrt(dx * dx + dy * dy) - rad[j] - r_new < web:
                        ok = False
                        break
                if not ok:
                    break
            if not ok:
                break
        if ok:
            accepted[k] = True
            grid[gy, gx, cnt[gy, gx]] = n + k
            cnt[gy, gx] += 1
    return accepted


# --------------------------------------------------------------------------- one layer's holes


@dataclass
class _Layer:
    """Mutable optimisation state of one layer's holes (mm, picture frame)."""

    x: np.ndarray
    y: np.ndarray
    r: np.ndarray
    rules: DesignRules
    spray_time: float
    rmax: float
    m: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    v: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    added: int = 0
    removed: int = 0
    reverted: int = 0

    def reset_moments(self) -> None:
        self.m = np.zeros((len(self.x), 3))
        self.v = np.zeros((len(self.x), 3))

    def keep(self, mask: np.ndarray) -> None:
        self.x, self.y, self.r = self.x[mask], self.y[mask], self.r[mask]
        self.m, self.v = self.m[mask], self.v[mask]


def _kernels_px(layer: _Layer, kernels: Kernels, pitch: float, height_px: int):
    sigma, peak, dsig, dpeak, combine = kernels(layer.r, layer.spray_time)
    rc = mm_to_px(np.column_stack([layer.x, layer.y]), height_px, pitch)
    return (
        np.ascontiguousarray(rc[:, 0]),
        np.ascontiguousarray(rc[:, 1]),
        np.ascontiguousarray(sigma / pitch),
        np.ascontiguousarray(peak, dtype=np.float64),
        dsig,
        dpeak,
        combine == "exp",
    )


def _box_and_keepouts(x, y, r, rules: DesignRules) -> None:
    lo = rules.edge_margin_mm + r + NUDGE_SLACK_MM
    np.clip(x, lo, rules.width_mm - lo, out=x)
    np.clip(y, lo, rules.height_mm - lo, out=y)
    if rules.keepouts:
        xy = np.column_stack([x, y])
        _push_out_of_keepouts(xy, r, rules)
        x[:] = xy[:, 0]
        y[:] = xy[:, 1]


def _broken(x, y, r, rules: DesignRules, reach: float) -> np.ndarray:
    """Holes that break a rule (web with the CSV slack, margin box, keep-outs, radius floor)."""
    # The tolerance is a quarter of check_rules' (which covers the CSV's rounding): holes read
    # back from a CSV may sit that close to a limit, and must count as good here.
    m = rules.edge_margin_mm - _TOL_MM
    bad = (r < rules.hole_min_r_mm - _TOL_MM) | (x < m + r) | (x > rules.width_mm - m - r)
    bad |= (y < m + r) | (y > rules.height_mm - m - r)
    if rules.keepouts:
        bad |= _keepout_clearance(np.column_stack([x, y]), rules.keepouts) < r + m
    pairs = _cell_pairs(x, y, reach)
    bad |= _web_bad(pairs, x, y, r, rules.web_mm - _TOL_MM)
    return bad


def _project(layer: _Layer, x0, y0, r0) -> None:
    """Project the layer's holes onto the rules; revert holes that still break one to (x0, y0, r0)."""
    rules = layer.rules
    x, y, r = layer.x, layer.y, layer.r
    np.clip(r, rules.hole_min_r_mm, layer.rmax, out=r)
    web = rules.web_mm + NUDGE_SLACK_MM
    reach = 2.0 * layer.rmax + web
    if len(x) > 1:
        pairs = _cell_pairs(x, y, reach)
        _project_pairs(pairs, x, y, r, rules.hole_min_r_mm, web, 4)
    _box_and_keepouts(x, y, r, rules)
    # Reverting only ever moves holes back to a state that passed, so this ends; each round
    # reverts at least one moved hole.
    while True:
        bad = _broken(x, y, r, rules, reach)
        bad &= (x != x0) | (y != y0) | (r != r0)
        if not bad.any():
            break
        layer.reverted += int(bad.sum())
        x[bad], y[bad], r[bad] = x0[bad], y0[bad], r0[bad]


# --------------------------------------------------------------------------- the objective


def _forward(layers_state, kernels, pitch, shape, primer, colours):
    """Per-layer transmittance and the composite before each layer (C_{l-1})."""
    h, w = shape
    trans = []
    before = []
    comp = np.empty((h, w, 3))
    comp[...] = primer
    for layer, colour in zip(layers_state, colours, strict=True):
        if len(layer.x):
            rows, cols, sig, peak, _, _, exp_mode = _kernels_px(layer, kernels, pitch, h)
            t = _transmittance(h, w, rows, cols, sig, peak, exp_mode)
        else:
            t = np.ones((h, w))
        before.append(comp.copy())
        comp = comp * t[..., None] + (1.0 - t[..., None]) * colour
        trans.append(t)
    return trans, before, comp


def _residual_gradient(res, eye_px):
    """``E`` and ``dE/dres`` of ``E = sum |g * res|^2`` (``res`` of shape (H, W) or (H, W, C))."""
    from scipy.ndimage import gaussian_filter

    if eye_px <= 0:
        return float(np.sum(res * res)), 2.0 * res
    axes = (eye_px, eye_px, 0.0)[: res.ndim]
    # Zero padding keeps the filter self-adjoint, so g applied again is the exact gradient.
    f = gaussian_filter(res, axes, mode="constant")
    return float(np.sum(f * f)), 2.0 * gaussian_filter(f, axes, mode="constant")


def _objective(trans, before, comp, target, alpha_targets, layer_weight, colours, eye_px):
    """``E`` and per layer ``(G, Q)``: ``G = dE/dalpha_l``, ``Q`` the curvature along it.

    ``E`` is the composite's filtered squared error plus ``layer_weight`` times each layer's
    filtered squared opacity error (so no layer is made worse to help another's colour).
    """
    e, dedc = _residual_gradient(comp - target, eye_px)
    terms = _layer_terms(trans, before, colours, dedc)
    if layer_weight > 0:
        for k, t in enumerate(trans):
            el, dl = _residual_gradient((1.0 - t) - alpha_targets[k], eye_px)
            e += layer_weight * el
            g, q = terms[k]
            terms[k] = (g + layer_weight * dl, q + layer_weight)
    return e, terms


def _layer_terms(trans, before, colours, dedc):
    """Per layer ``G = dE/dalpha`` and ``Q = |dC/dalpha|^2`` of the composite error."""
    n = len(trans)
    suffix: list[np.ndarray] = [np.empty(0)] * n
    acc = np.ones_like(trans[0])
    for k in range(n - 1, -1, -1):
        suffix[k] = acc
        acc = acc * trans[k]
    out = []
    for k in range(n):
        j = (colours[k] - before[k]) * suffix[k][..., None]
        out.append((np.sum(dedc * j, axis=-1), np.sum(j * j, axis=-1)))
    return out


def _hole_grads(state, kernels, pitch, h, trans, terms) -> list[np.ndarray]:
    """Per layer ``(N, 3)`` gradient of the objective w.r.t. each hole's x, y (mm) and radius (mm)."""
    out = []
    for layer, (g, _q), t in zip(state, terms, trans, strict=True):
        grad = np.zeros((len(layer.x), 3))
        if len(layer.x):
            rows, cols, sig, peak, dsig, dpeak, exp_mode = _kernels_px(layer, kernels, pitch, h)
            raw = _hole_gradients(g, t, rows, cols, sig, peak, exp_mode)
            # px -> mm: x = (col + 0.5) s, y = (H - row - 0.5) s, sigma_mm = sigma_px s.
            grad[:, 0] = raw[:, 1] / pitch
            grad[:, 1] = -raw[:, 0] / pitch
            grad[:, 2] = raw[:, 2] / pitch * dsig + raw[:, 3] * dpeak
        out.append(grad)
    return out


# --------------------------------------------------------------------------- moves


def _remove_holes(layer, g, q, t, kernels, pitch, h) -> int:
    if len(layer.x) == 0:
        return 0
    rows, cols, sig, peak, _, _, exp_mode = _kernels_px(layer, kernels, pitch, h)
    change = _removal_change(g, q, t, rows, cols, sig, peak, exp_mode)
    cand = np.flatnonzero(change < 0.0)
    if len(cand) == 0:
        return 0
    cand = cand[np.argsort(change[cand], kind="stable")]
    # Neighbours' predictions interact: remove at most one hole per neighbourhood per round.
    cell = 6.0 * float(sig.max())
    key_r = np.floor(rows / cell).astype(np.int64)
    key_c = np.floor(cols / cell).astype(np.int64)
    taken: set[tuple[int, int]] = set()
    drop = np.zeros(len(layer.x), dtype=bool)
    for i in cand:
        kr, kc = int(key_r[i]), int(key_c[i])
        if any((kr + a, kc + b) in taken for a in (-1, 0, 1) for b in (-1, 0, 1)):
            continue
        taken.add((kr, kc))
        drop[i] = True
    layer.keep(~drop)
    return int(drop.sum())


def _add_holes(layer, g, q, t, kernels, pitch, shape) -> int:
    from scipy.ndimage import gaussian_filter, minimum_filter

    rules = layer.rules
    h, w = shape
    r_new = rules.hole_min_r_mm
    sigma, peak, _, _, _ = kernels(np.array([r_new]), layer.spray_time)
    s_px = float(sigma[0]) / pitch
    a = min(float(peak[0]), 1.0)
    # Predicted change of E for a new hole centred on each pixel (see the module doc).
    lin = gaussian_filter(g * t, s_px, mode="constant") * (2.0 * math.pi * s_px * s_px) * a
    quad = (
        gaussian_filter(q * t * t, s_px / math.sqrt(2.0), mode="constant") * (math.pi * s_px * s_px) * a * a
    )
    change = lin + quad
    spacing_px = (2.0 * r_new + rules.web_mm) / pitch
    local = change <= minimum_filter(change, size=max(3, int(spacing_px)), mode="nearest")
    cand = np.flatnonzero(local & (change < 0.0))
    if len(cand) == 0:
        return 0
    cand = cand[np.argsort(change.ravel()[cand], kind="stable")]
    rows, cols = np.divmod(cand, w)
    xy = px_to_mm(np.column_stack([rows, cols]).astype(np.float64), h, pitch)
    m = rules.edge_margin_mm + r_new + NUDGE_SLACK_MM
    inside = (
        (xy[:, 0] >= m)
        & (xy[:, 0] <= rules.width_mm - m)
        & (xy[:, 1] >= m)
        & (xy[:, 1] <= rules.height_mm - m)
    )
    if rules.keepouts:
        inside &= _keepout_clearance(xy, rules.keepouts) >= m
    xy = xy[inside]
    if len(xy) == 0:
        return 0
    web = rules.web_mm + NUDGE_SLACK_MM
    cell = 2.0 * layer.rmax + web
    cap = int(math.ceil((cell / (2.0 * r_new + rules.web_mm)) ** 2 * 2.0)) + 4
    ok = _greedy_add(
        np.ascontiguousarray(xy[:, 0]),
        np.ascontiguousarray(xy[:, 1]),
        layer.x,
        layer.y,
        layer.r,
        r_new,
        web,
        cell,
        cap,
    )
    n_new = int(ok.sum())
    if n_new:
        layer.x = np.concatenate([layer.x, xy[ok, 0]])
        layer.y = np.concatenate([layer.y, xy[ok, 1]])
        layer.r = np.concatenate([layer.r, np.full(n_new, r_new)])
        layer.m = np.concatenate([layer.m, np.zeros((n_new, 3))])
        layer.v = np.concatenate([layer.v, np.zeros((n_new, 3))])
    return n_new


# --------------------------------------------------------------------------- the stage


def _adam_step(layer: _Layer, grad: np.ndarray, it: int, frac: float, settings: RefineSettings) -> None:
    """One Adam step of a layer's centres and radii (step sizes scaled by ``frac``), projected."""
    layer.m = _B1 * layer.m + (1.0 - _B1) * grad
    layer.v = _B2 * layer.v + (1.0 - _B2) * grad * grad
    mhat = layer.m / (1.0 - _B1**it)
    vhat = layer.v / (1.0 - _B2**it)
    step = mhat / (np.sqrt(vhat) + _EPS)
    x0, y0, r0 = layer.x.copy(), layer.y.copy(), layer.r.copy()
    layer.x = layer.x - frac * settings.step_mm * step[:, 0]
    layer.y = layer.y - frac * settings.step_mm * step[:, 1]
    layer.r = layer.r - frac * settings.radius_step_mm * step[:, 2]
    _project(layer, x0, y0, r0)


def refine_dots(
    target_rgb: np.ndarray,
    mm_per_px: float,
    primer: np.ndarray,
    colours: np.ndarray,
    dotsets: list[DotSet],
    rules: list[DesignRules],
    kernels: Kernels,
    spray_times: list[float],
    settings: RefineSettings,
    progress: Callable[[int, int], None] | None = None,
    alpha_targets: np.ndarray | None = None,
) -> tuple[list[DotSet], dict]:
    """Move and resize every layer's holes so the sprayed composite matches the target.

    Args:
        target_rgb: ``(H, W, 3)`` sRGB in [0, 1], the picture to match, on the grid the
            spray is evaluated on.
        mm_per_px: Pixel size of that grid in mm.
        primer: ``(3,)`` primer colour in [0, 1].
        colours: ``(L, 3)`` paint colours in spray order.
        dotsets: One DotSet per layer (each passing its rules).
        rules: The design rules of each layer.
        kernels: The spray model's per-hole kernels bound to the spray settings (:data:`Kernels`).
        spray_times: Spray time of each layer.
        settings: Iterations, step sizes, largest radius, add/remove cadence, eye filter.
        progress: Called as ``progress(iteration, iterations)``.
        alpha_targets: ``(L, H, W)`` target opacity of each layer on the grid, or None. With
            it, each layer's own filtered opacity error is added to the objective, weighted
            by ``settings.layer_weight``.

    Returns:
        ``(dotsets, report)``: the refined DotSets (each passes :func:`check_rules` of its
        rules; ``report`` of each adds ``refine_added``, ``refine_removed``,
        ``refine_reverted``) and the stage report (``objective_start``, ``objective_end``
        as RMS composite errors, ``iterations``, ``seconds``).

    Raises:
        ValueError: The counts of DotSets, rules, colours and spray times differ.
    """
    t_start = time.perf_counter()
    n = len(dotsets)
    if not (len(rules) == len(colours) == len(spray_times) == n):
        raise ValueError(
            f"need one rule set, colour and spray time per DotSet: {n} DotSets, {len(rules)} rules, "
            f"{len(colours)} colours, {len(spray_times)} spray times"
        )
    target = np.asarray(target_rgb, dtype=np.float64)
    shape = target.shape[:2]
    h = shape[0]
    primer = np.asarray(primer, dtype=np.float64)
    colours = np.asarray(colours, dtype=np.float64).reshape(-1, 3)
    state = []
    for ds, rl, a in zip(dotsets, rules, spray_times, strict=True):
        rmax = max(settings.max_radius_mm, rl.hole_min_r_mm, float(np.max(ds.r_mm, initial=0.0)))
        layer = _Layer(
            x=np.array(ds.xy_mm[:, 0], dtype=np.float64),
            y=np.array(ds.xy_mm[:, 1], dtype=np.float64),
            r=np.array(ds.r_mm, dtype=np.float64),
            rules=rl,
            spray_time=float(a),
            rmax=rmax,
        )
        layer.reset_moments()
        state.append(layer)
    eye_px = settings.eye_sigma_mm / mm_per_px
    npx = float(shape[0] * shape[1] * 3)

    alpha_targets = None if alpha_targets is None else np.asarray(alpha_targets, dtype=np.float64)
    lam = settings.layer_weight if alpha_targets is not None else 0.0

    def evaluate():
        trans, before, comp = _forward(state, kernels, mm_per_px, shape, primer, colours)
        e, terms = _objective(trans, before, comp, target, alpha_targets, lam, colours, eye_px)
        return trans, e, terms

    trans, e, terms = evaluate()
    e_start = e
    iters = settings.iterations
    for it in range(1, iters + 1):
        grads = _hole_grads(state, kernels, mm_per_px, h, trans, terms)
        # Linear decay of the step size to a fifth: large moves first, then polish.
        frac = 1.0 - 0.8 * (it - 1) / max(iters - 1, 1)
        for layer, grad in zip(state, grads, strict=True):
            if len(layer.x):
                _adam_step(layer, grad, it, frac, settings)
        trans, e, terms = evaluate()
        every = settings.add_remove_every
        if every and it % every == 0 and it < iters:
            for k, layer in enumerate(state):
                g, q = terms[k]
                layer.removed += _remove_holes(layer, g, q, trans[k], kernels, mm_per_px, h)
                trans, e, terms = evaluate()
                g, q = terms[k]
                layer.added += _add_holes(layer, g, q, trans[k], kernels, mm_per_px, shape)
                trans, e, terms = evaluate()
        if progress is not None:
            progress(it, iters)
    out = []
    for ds, layer in zip(dotsets, state, strict=True):
        xy = np.column_stack([layer.x, layer.y])
        check_rules(xy, layer.r, layer.rules)
        rep = {
            **ds.report,
            "n_stippled": len(ds),
            "refine_added": layer.added,
            "refine_removed": layer.removed,
            "refine_reverted": layer.reverted,
            "n_final": len(layer.x),
        }
        out.append(replace(ds, xy_mm=xy, r_mm=layer.r.copy(), report=rep))
    report = {
        "iterations": iters,
        "objective_start": math.sqrt(e_start / npx),
        "objective_end": math.sqrt(e / npx),
        "seconds": round(time.perf_counter() - t_start, 3),
    }
    log.debug("refined: %s", report)
    return out, report
