"""Model-based hole refinement: move and resize the stippled holes so the sprayed picture matches.

The stippler places holes by density alone; what the viewer sees is the composite of all
layers sprayed through them. This stage optimises every hole's centre and radius against
the spray model (least-squares model-based halftoning, Pappas & Neuhoff 1999; the add/remove
moves follow direct binary search, Analoui & Allebach 1992), with the design rules held
after every step.

Objective. On the simulation grid, with ``C(p)`` the composite of the primer and every
layer sprayed in order (Porter-Duff *over*) and ``C*(p)`` the input picture,

    E = sum_p |g * (C - C*)|^2(p)

(``p`` over the whole plane, the error zero outside the picture; images in float32)
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
from collections.abc import Callable, Sequence
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
#: Cap of one deposit in the product model's gradient quotient ``N / (1 - N)`` (see there).
_NV_MAX = 0.999999
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
        view: The viewer's filters: with them the composite's error is the viewer's colour
            error (:class:`_Viewer`); without, the sRGB error filtered by ``eye_sigma_mm``.
    """

    iterations: int = 60
    step_mm: float = 0.05
    radius_step_mm: float = 0.02
    max_radius_mm: float = 1.0
    add_remove_every: int = 15
    eye_sigma_mm: float = 0.0
    layer_weight: float = 1.0
    view: ViewFilters | None = None


# --------------------------------------------------------------------------- compiled kernels
#
# Images are float32 in the stage (float64 when a caller passes float64, as the gradient test
# does; numba compiles one version per dtype), per-hole sums are float64. Measured on
# `python -m benchmarks refine` (100,000 holes, 2048 x 2048 px, one core's worth of a shared
# machine): the float64 version with numpy/scipy image passes took 12.5 s per iteration, of
# which 3.6 s the per-hole gradient (a branchy inner loop that did not vectorise), 2.9 s the
# pair searches of the rule projection (one per revert round), 2.0 s scipy's Gaussian filters
# and 2.4 s numpy's whole-image composite and layer terms.


@numba.njit(cache=True)
def _footprint(row, col, sig, a, img):  # pragma: no cover - compiled
    """Pixel window of ``img`` where a deposit of peak ``a`` exceeds the tail, ``1 / (2 sigma^2)``, column profile and offsets.

    The profile and offsets are of ``img``'s dtype.
    """
    h, w = img.shape
    rad = sig * math.sqrt(2.0 * math.log(a / _TAIL))
    r0 = max(0, int(math.ceil(row - rad)))
    r1 = min(h - 1, int(math.floor(row + rad)))
    c0 = max(0, int(math.ceil(col - rad)))
    c1 = min(w - 1, int(math.floor(col + rad)))
    k = 1.0 / (2.0 * sig * sig)
    n = max(c1 - c0 + 1, 0)
    ex = np.empty(n, dtype=img.dtype)
    dxv = np.empty(n, dtype=img.dtype)
    for c in range(c0, c1 + 1):
        dx = c - col
        dxv[c - c0] = dx
        ex[c - c0] = math.exp(-dx * dx * k)
    return r0, r1, c0, c1, k, ex, dxv


#: Rows per band of the parallel transmittance (each band is written by one thread only).
_BAND = 32


@numba.njit(cache=True, parallel=True, fastmath=True)
def _transmittance_bands(
    t, s, rows, cols, sig, peak, exp_mode, band_lo, band_hi
):  # pragma: no cover - compiled
    """``T`` into ``t`` (all ones on entry) by row bands; holes sorted by row, band ``b`` visits holes ``band_lo[b]:band_hi[b]``.

    ``s`` is the summed dose (zeros, shaped like ``t``) in the exp model and unused otherwise.
    """
    h, w = t.shape
    ft = t.dtype.type
    one = ft(1.0)
    zero = ft(0.0)
    for b in numba.prange(band_lo.shape[0]):
        lo = b * _BAND
        hi = min(h, lo + _BAND) - 1
        for i in range(band_lo[b], band_hi[b]):
            a = peak[i]
            if a <= _TAIL:
                continue
            r0, r1, c0, c1, k, ex, _ = _footprint(rows[i], cols[i], sig[i], a, t)
            for r in range(max(r0, lo), min(r1, hi) + 1):
                dy = r - rows[i]
                ey = ft(a * math.exp(-dy * dy * k))
                # Row slices: indexing t[r, c] here ran at half the speed.
                if exp_mode:
                    srow = s[r, c0 : c1 + 1]
                    for c in range(c1 - c0 + 1):
                        srow[c] += ey * ex[c]
                else:
                    trow = t[r, c0 : c1 + 1]
                    for c in range(c1 - c0 + 1):
                        trow[c] *= max(one - ey * ex[c], zero)
        if exp_mode:
            for r in range(lo, hi + 1):
                for c in range(w):
                    t[r, c] = math.exp(-s[r, c])


def _transmittance(t, rows, cols, sig, peak, exp_mode):
    """``T = prod (1 - min(N_i, 1))`` (or ``exp(-sum N_i)``) into ``t`` (an ``(h, w)`` array of ones), px units."""
    h = t.shape[0]
    order = np.argsort(rows, kind="stable")
    rows, cols, sig, peak = rows[order], cols[order], sig[order], peak[order]
    a = np.maximum(peak, _TAIL)
    reach = float(np.max(sig * np.sqrt(2.0 * np.log(a / _TAIL)), initial=0.0)) + 1.0
    top = np.arange(0, h, _BAND, dtype=np.float64)
    band_lo = np.searchsorted(rows, top - reach, side="left").astype(np.int64)
    band_hi = np.searchsorted(rows, top + _BAND + reach, side="right").astype(np.int64)
    s = np.zeros_like(t) if exp_mode else np.zeros((1, 1), dtype=t.dtype)
    _transmittance_bands(t, s, rows, cols, sig, peak, exp_mode, band_lo, band_hi)
    return t


@numba.njit(cache=True, parallel=True, fastmath=True)
def _hole_gradients(gt, rows, cols, sig, peak, exp_mode):  # pragma: no cover - compiled
    """Per hole ``sum_p G(p) dalpha/dN_i dN_i/d(row, col, sigma, peak)`` in px units; ``gt = G T``.

    With ``w(p) = G T N_i / (1 - N_i)`` (product; 0 where the hole clamps) or ``G T N_i``
    (exp), the four sums are ``sum w dy / s^2``, ``sum w dx / s^2``,
    ``sum w (dx^2 + dy^2) / s^3`` and ``sum w / peak``; each row's are three running sums
    of ``w``, ``w dx`` and ``w dx^2`` in the image's dtype, a loop the compiler vectorises
    (branch-free: where a hole clamps, ``T`` and so ``gt`` is 0, and ``N_i`` is capped below 1
    so the quotient stays finite).
    """
    n = rows.shape[0]
    out = np.zeros((n, 4))
    ft = gt.dtype.type
    one = ft(1.0)
    cap = ft(_NV_MAX)
    for i in numba.prange(n):
        a = peak[i]
        if a <= _TAIL:
            continue
        r0, r1, c0, c1, k, ex, dxv = _footprint(rows[i], cols[i], sig[i], a, gt)
        s2 = sig[i] * sig[i]
        gr = 0.0
        gc = 0.0
        gs = 0.0
        ga = 0.0
        for r in range(r0, r1 + 1):
            dy = r - rows[i]
            ey = ft(a * math.exp(-dy * dy * k))
            w0 = ft(0.0)
            w1 = ft(0.0)
            w2 = ft(0.0)
            row = gt[r, c0 : c1 + 1]
            if exp_mode:
                for c in range(c1 - c0 + 1):
                    wv = row[c] * (ey * ex[c])
                    d = dxv[c]
                    w0 += wv
                    w1 += wv * d
                    w2 += wv * d * d
            else:
                for c in range(c1 - c0 + 1):
                    nv = ey * ex[c]
                    wv = row[c] * nv / (one - min(nv, cap))
                    d = dxv[c]
                    w0 += wv
                    w1 += wv * d
                    w2 += wv * d * d
            gr += dy * w0
            gc += w1
            gs += w2 + dy * dy * w0
            ga += w0
        out[i, 0] = gr / s2
        out[i, 1] = gc / s2
        out[i, 2] = gs / (s2 * sig[i])
        out[i, 3] = ga / a
    return out


@numba.njit(cache=True, parallel=True, fastmath=True)
def _removal_change(g, q, t, rows, cols, sig, peak, exp_mode):  # pragma: no cover - compiled
    """Predicted change of the objective if each hole alone were removed (inf: cannot tell)."""
    n = rows.shape[0]
    out = np.zeros(n)
    for i in numba.prange(n):
        a = peak[i]
        if a <= _TAIL:
            continue
        if not exp_mode and a >= 1.0:
            out[i] = np.inf
            continue
        r0, r1, c0, c1, k, ex, _ = _footprint(rows[i], cols[i], sig[i], a, g)
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


@numba.njit(cache=True, parallel=True)
def _composite_residuals(trans, primer, colours, target, alpha_t, res, lres):  # pragma: no cover - compiled
    """Composite minus target into ``res`` (H, W, 3); each layer's opacity minus its target into ``lres``.

    ``lres`` has no layers when the per-layer term is off (then ``alpha_t`` is not read).
    """
    n_l, h, w = trans.shape
    for r in numba.prange(h):
        for c in range(w):
            c0 = primer[0]
            c1 = primer[1]
            c2 = primer[2]
            for m in range(n_l):
                tm = trans[m, r, c]
                u = 1.0 - tm
                c0 = c0 * tm + u * colours[m, 0]
                c1 = c1 * tm + u * colours[m, 1]
                c2 = c2 * tm + u * colours[m, 2]
            res[r, c, 0] = c0 - target[r, c, 0]
            res[r, c, 1] = c1 - target[r, c, 1]
            res[r, c, 2] = c2 - target[r, c, 2]
            for m in range(lres.shape[0]):
                lres[m, r, c] = (1.0 - trans[m, r, c]) - alpha_t[m, r, c]


@numba.njit(cache=True, parallel=True)
def _opacity_gradients(trans, primer, colours, dedc, dl, lam, gt, gq, qm):  # pragma: no cover - compiled
    """Per layer ``G T`` into ``gt`` (L, H, W), ``G = dE/dalpha_l``; ``G`` and ``Q`` into ``gq`` (2, L, H, W) if it has room.

    ``dC/dalpha_l = (c_l - C_{l-1}) prod_{m > l} T_m``, so ``G = dE/dC . dC/dalpha_l`` plus
    ``lam`` times the layer term's gradient ``dl`` (no layers: off) and ``Q = |dC/dalpha_l|^2 + lam``
    (``Q = dC^T M dC + lam`` with a per-pixel (3, 3) metric ``qm`` of (H, W, 3, 3); (0, 0, 3, 3): none).
    """
    n_l, h, w = trans.shape
    want_q = gq.shape[0] > 0
    metric = qm.shape[0] > 0
    layer_term = dl.shape[0] > 0
    for r in numba.prange(h):
        bef = np.empty((n_l, 3))
        for c in range(w):
            c0 = primer[0]
            c1 = primer[1]
            c2 = primer[2]
            for m in range(n_l):
                bef[m, 0] = c0
                bef[m, 1] = c1
                bef[m, 2] = c2
                tm = trans[m, r, c]
                u = 1.0 - tm
                c0 = c0 * tm + u * colours[m, 0]
                c1 = c1 * tm + u * colours[m, 1]
                c2 = c2 * tm + u * colours[m, 2]
            s = 1.0
            for m in range(n_l - 1, -1, -1):
                j0 = (colours[m, 0] - bef[m, 0]) * s
                j1 = (colours[m, 1] - bef[m, 1]) * s
                j2 = (colours[m, 2] - bef[m, 2]) * s
                gl = dedc[r, c, 0] * j0 + dedc[r, c, 1] * j1 + dedc[r, c, 2] * j2
                if layer_term:
                    gl += lam * dl[m, r, c]
                tm = trans[m, r, c]
                gt[m, r, c] = gl * tm
                if want_q:
                    gq[0, m, r, c] = gl
                    if metric:
                        q = 0.0
                        for i in range(3):
                            ji = j0 if i == 0 else (j1 if i == 1 else j2)
                            q += ji * (qm[r, c, i, 0] * j0 + qm[r, c, i, 1] * j1 + qm[r, c, i, 2] * j2)
                        gq[1, m, r, c] = q + lam
                    else:
                        gq[1, m, r, c] = j0 * j0 + j1 * j1 + j2 * j2 + lam
                s *= tm


@numba.njit(cache=True, parallel=True)
def _dot(a, b):  # pragma: no cover - compiled
    """``sum a b`` with a float64 accumulator (``a``, ``b`` contiguous, of one shape)."""
    fa = a.ravel()
    fb = b.ravel()
    acc = 0.0
    for i in numba.prange(fa.shape[0]):
        acc += float(fa[i]) * float(fb[i])
    return acc


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
def _revert_broken(pairs, x, y, r, x0, y0, r0, self_bad, web):  # pragma: no cover - compiled
    """Send moved holes that break a rule back to ``(x0, y0, r0)`` until none does; return how many went back.

    ``self_bad`` marks holes that break a rule of their own (floor, margin, keep-out); a pair
    whose web is below ``web`` sends back whichever of its holes moved. The old state passed
    the rules, so after the first pass only the neighbours of holes just sent back need a
    look, and each round sends back at least one moved hole, so this ends.
    """
    n = x.shape[0]
    moved = (x != x0) | (y != y0) | (r != r0)
    bad = self_bad & moved
    # Neighbours of every hole (CSR), both directions.
    start = np.zeros(n + 1, dtype=np.int64)
    for k in range(pairs.shape[0]):
        start[pairs[k, 0] + 1] += 1
        start[pairs[k, 1] + 1] += 1
    for i in range(n):
        start[i + 1] += start[i]
    fill = start[:-1].copy()
    nbr = np.empty(start[n], dtype=np.int64)
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        nbr[fill[i]] = j
        fill[i] += 1
        nbr[fill[j]] = i
        fill[j] += 1
    for k in range(pairs.shape[0]):
        i = pairs[k, 0]
        j = pairs[k, 1]
        if (moved[i] or moved[j]) and _web_below(x, y, r, i, j, web):
            bad[i] = bad[i] or moved[i]
            bad[j] = bad[j] or moved[j]
    back = np.flatnonzero(bad)
    count = 0
    while back.shape[0] > 0:
        for hole in back:
            x[hole] = x0[hole]
            y[hole] = y0[hole]
            r[hole] = r0[hole]
            moved[hole] = False
            bad[hole] = False
        count += back.shape[0]
        # Only pairs with a hole just sent back changed; its moved neighbours may break now.
        nxt = []
        for hole in back:
            for q in range(start[hole], start[hole + 1]):
                j = nbr[q]
                if moved[j] and not bad[j] and _web_below(x, y, r, hole, j, web):
                    bad[j] = True
                    nxt.append(j)
        back = np.array(nxt, dtype=np.int64)
    return count


@numba.njit(cache=True)
def _web_below(x, y, r, i, j, web):  # pragma: no cover - compiled
    dx = x[i] - x[j]
    dy = y[i] - y[j]
    return math.sqrt(dx * dx + dy * dy) - r[i] - r[j] < web


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

#: Extra reach of a layer's neighbour list in mm: the list stays valid while no hole has
#: moved half of it from where the list was made (a Verlet list), so the pair search runs
#: every few steps rather than once per revert round.
_SKIN_MM = 0.4


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
    pairs: np.ndarray | None = None
    ref: tuple[np.ndarray, np.ndarray] = (np.zeros(0), np.zeros(0))
    skin: float = _SKIN_MM
    #: Each hole's index in the input DotSet (-1 for a hole the add moves placed).
    ids: np.ndarray = field(default_factory=lambda: np.zeros(0, dtype=np.int64))

    def reset_moments(self) -> None:
        self.m = np.zeros((len(self.x), 3))
        self.v = np.zeros((len(self.x), 3))

    def keep(self, mask: np.ndarray) -> None:
        """Keep the holes of ``mask`` (a boolean mask or an index array, in the new order)."""
        self.x, self.y, self.r = self.x[mask], self.y[mask], self.r[mask]
        self.m, self.v = self.m[mask], self.v[mask]
        self.ids = self.ids[mask]
        self.pairs = None

    def input_order(self) -> np.ndarray:
        """Indices that put the holes back in the input's order, the added ones after them."""
        last = int(self.ids.max(initial=-1)) + 1
        return np.argsort(np.where(self.ids >= 0, self.ids, last), kind="stable")

    def sort(self, band_mm: float) -> None:
        """Order the holes by bands of ``band_mm`` across, then along x.

        Neighbouring holes then touch neighbouring pixels one after the other: the per-hole
        gradient ran 4x faster on 100,000 holes than in the stippler's order (cache misses).
        """
        self.keep(np.lexsort((self.x, np.floor(self.y / band_mm))))


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


def _self_broken(x, y, r, rules: DesignRules) -> np.ndarray:
    """Holes that break a rule of their own (radius floor, margin box, keep-outs)."""
    # The tolerance is a quarter of check_rules' (which covers the CSV's rounding): holes read
    # back from a CSV may sit that close to a limit, and must count as good here.
    m = rules.edge_margin_mm - _TOL_MM
    bad = (r < rules.hole_min_r_mm - _TOL_MM) | (x < m + r) | (x > rules.width_mm - m - r)
    bad |= (y < m + r) | (y > rules.height_mm - m - r)
    if rules.keepouts:
        bad |= _keepout_clearance(np.column_stack([x, y]), rules.keepouts) < r + m
    return bad


def _drift(x, y, ref_x, ref_y) -> float:
    return float(np.max(np.hypot(x - ref_x, y - ref_y), initial=0.0))


def _neighbours(layer: _Layer, old: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """Every pair of holes that can break the web, with the holes where they are now or at ``old``.

    A pair matters only closer than ``2 rmax + web``; the list holds the pairs closer than
    that plus the skin where it was made, so it holds every pair that matters while no
    hole, now or at ``old``, is more than half the skin from there.
    """
    base = 2.0 * layer.rmax + layer.rules.web_mm + NUDGE_SLACK_MM
    if layer.pairs is not None:
        rx, ry = layer.ref
        if max(_drift(layer.x, layer.y, rx, ry), _drift(*old, rx, ry)) <= 0.5 * layer.skin:
            return layer.pairs
    layer.skin = max(_SKIN_MM, 2.0 * _drift(*old, layer.x, layer.y) + 1e-9)
    layer.pairs = _cell_pairs(layer.x, layer.y, base + layer.skin)
    layer.ref = (layer.x.copy(), layer.y.copy())
    return layer.pairs


def _project(layer: _Layer, x0, y0, r0) -> None:
    """Project the layer's holes onto the rules; revert holes that still break one to (x0, y0, r0)."""
    rules = layer.rules
    x, y, r = layer.x, layer.y, layer.r
    np.clip(r, rules.hole_min_r_mm, layer.rmax, out=r)
    if len(x) > 1:
        pairs = _neighbours(layer, (x0, y0))
        _project_pairs(pairs, x, y, r, rules.hole_min_r_mm, rules.web_mm + NUDGE_SLACK_MM, 4)
    _box_and_keepouts(x, y, r, rules)
    self_bad = _self_broken(x, y, r, rules)
    pairs = _neighbours(layer, (x0, y0)) if len(x) > 1 else np.empty((0, 2), dtype=np.int64)
    layer.reverted += _revert_broken(pairs, x, y, r, x0, y0, r0, self_bad, rules.web_mm - _TOL_MM)


# --------------------------------------------------------------------------- the objective


def _gauss(img: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian filter of an (H, W) or (H, W, C) image with zero padding (so it is self-adjoint).

    OpenCV's separable filter in float32: 14x faster than scipy's ``gaussian_filter`` on a
    2048 x 2048 x 3 image here (0.05 s vs 0.70 s), same kernel (radius ``4 sigma``).
    """
    import cv2

    rad = int(4.0 * sigma_px + 0.5)
    xs = np.arange(-rad, rad + 1, dtype=np.float64)
    k = np.exp(-(xs * xs) / (2.0 * sigma_px * sigma_px))
    k = (k / k.sum()).astype(img.dtype)
    return cv2.sepFilter2D(np.ascontiguousarray(img), -1, k, k, borderType=cv2.BORDER_CONSTANT)


def _filtered(res: np.ndarray, eye_px: float) -> tuple[float, np.ndarray]:
    """``E`` and ``dE/dres`` of ``E = sum |g * res|^2`` (``res`` of shape (H, W) or (H, W, C)).

    The filtered error is summed over the whole plane (``res`` zero outside the picture), so
    ``E = <res, g2 * res>`` with ``g2 = g * g`` the Gaussian of ``sqrt(2)`` times the width,
    and ``dE/dres = 2 g2 * res``: one filter pass, not two.
    """
    if eye_px <= 0:
        return _dot(res, res), 2.0 * res
    d = _gauss(res, math.sqrt(2.0) * eye_px)
    d *= 2.0
    return 0.5 * _dot(res, d), d


# --------------------------------------------------------------------------- the viewer's objective


@dataclass(frozen=True)
class ViewFilters:
    """The eye's filters of the viewer's objective (S-CIELAB's, at one viewing distance).

    Attributes:
        channels: Per opponent channel (luminance, red-green, blue-yellow), the Gaussians
            ``((sigma_mm, weight), ...)`` of :data:`stencil_cad.simulate.scielab.FILTERS`
            at the viewing distance.
        pixel_weight: Weight of the unfiltered (pixel-by-pixel) colour error beside the
            filtered one.
    """

    channels: tuple[tuple[tuple[float, float], ...], ...]
    pixel_weight: float = 0.0


#: CIE XYZ of the D65 white (2° observer), as CIELAB is computed for the scores.
_WHITE = np.array([0.95047, 1.0, 1.08883])
#: One ΔE of CIELAB is about 0.01 of an sRGB channel near mid grey; this scale puts the viewer's
#: squared ΔE on the footing of the squared sRGB error summed over three channels, so the
#: per-layer opacity term keeps its weight.
_LAB_SCALE = 3e-4


def _lab_metric(target: np.ndarray) -> np.ndarray:
    """Per pixel, the (3, 3) metric in opponent coordinates that gives CIEDE2000's squared ΔE there.

    CIEDE2000 linearised at the target's colour: XYZ -> CIELAB's Jacobian, then lightness,
    chroma and hue differences weighted by ``1 / S_L``, ``1 / S_C`` and ``1 / S_H`` (the
    hue-rotation term and the ``a*`` rescaling of small chroma are left out).
    """
    from skimage.color import rgb2xyz, xyz2lab

    from ..simulate.scielab import OPP_TO_XYZ

    h, w = target.shape[:2]
    xyz = rgb2xyz(np.clip(target.astype(np.float64), 0.0, 1.0))
    t = xyz / _WHITE
    lab = xyz2lab(xyz)
    eps = 216.0 / 24389.0
    df = np.where(t > eps, np.cbrt(np.maximum(t, eps)) ** -2 / 3.0, 7.787)  # d f(t) / dt
    df = df / _WHITE
    jac = np.zeros((h, w, 3, 3))
    jac[..., 0, 1] = 116.0 * df[..., 1]
    jac[..., 1, 0] = 500.0 * df[..., 0]
    jac[..., 1, 1] = -500.0 * df[..., 1]
    jac[..., 2, 1] = 200.0 * df[..., 1]
    jac[..., 2, 2] = -200.0 * df[..., 2]
    a = jac @ OPP_TO_XYZ  # d Lab / d opp
    light = lab[..., 0] - 50.0
    s_l = 1.0 + 0.015 * light**2 / np.sqrt(20.0 + light**2)
    chroma = np.hypot(lab[..., 1], lab[..., 2])
    s_c = 1.0 + 0.045 * chroma
    s_h = 1.0 + 0.015 * chroma
    safe = np.maximum(chroma, 1e-9)
    u = np.where(
        chroma[..., None] > 1e-6, np.stack([lab[..., 1], lab[..., 2]], -1) / safe[..., None], [1.0, 0.0]
    )
    d = np.zeros((h, w, 3, 3))
    d[..., 0, 0] = 1.0 / s_l**2
    uu = u[..., :, None] * u[..., None, :]
    vv = np.eye(2) - uu
    d[..., 1:, 1:] = uu / (s_c**2)[..., None, None] + vv / (s_h**2)[..., None, None]
    return np.einsum("...ki,...kl,...lj->...ij", a, d, a)


class _Viewer:
    """The viewer's colour error on the simulation grid: S-CIELAB's filters, CIEDE2000's weights.

    ``E = s sum_p F(p)^T W(p) F(p) + s beta sum_p r(p)^T W(p) r(p)`` with ``r = opp(C) - opp(C*)``
    the composite's error in the opponent space (sRGB decoded, to XYZ, to opponent), ``F`` each
    channel of ``r`` filtered by its sum of Gaussians and ``W`` the CIEDE2000 metric at the
    target's colour (:func:`_lab_metric`); ``beta`` the pixel weight, ``s`` :data:`_LAB_SCALE`.
    Gaussians of the filters wider than the picture's shorter side / 4 are left out (the
    luminance channel's 7° lobe at ordinary sizes: a negative weight on the picture's mean).
    """

    def __init__(self, target: np.ndarray, pitch: float, view: ViewFilters):
        from skimage.color.colorconv import xyz_from_rgb

        from ..simulate.scielab import XYZ_TO_OPP

        self.m = (XYZ_TO_OPP @ xyz_from_rgb).astype(np.float64)  # linear sRGB -> opponent
        self.dt = target.dtype
        h, w = target.shape[:2]
        cap = min(h, w) / 4.0
        self.filters = [[(s / pitch, wt) for s, wt in ch if s / pitch <= cap] for ch in view.channels]
        self.beta = float(view.pixel_weight)
        lin, dlin = self._decode(target)
        self.opp_t = (lin @ self.m.T).astype(self.dt)
        metric = _lab_metric(target)
        self.w = np.ascontiguousarray(metric, dtype=self.dt)
        # The metric in sRGB coordinates at the target (the add/remove moves' curvature Q).
        jm = self.m[None, None, :, :] * dlin[..., None, :]  # d opp / d srgb
        gain = sum(wt for _, wt in self.filters[0]) ** 2
        self.q = np.ascontiguousarray(
            _LAB_SCALE * (gain + self.beta) * np.einsum("...ki,...kl,...lj->...ij", jm, metric, jm),
            dtype=self.dt,
        )

    @staticmethod
    def _decode(rgb: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        c = np.clip(rgb.astype(np.float64), 0.0, 1.0)
        hi = c > 0.04045
        lin = np.where(hi, ((c + 0.055) / 1.055) ** 2.4, c / 12.92)
        dlin = np.where(hi, 2.4 / 1.055 * ((c + 0.055) / 1.055) ** 1.4, 1.0 / 12.92)
        return lin, dlin

    def _filter(self, img: np.ndarray) -> np.ndarray:
        out = np.zeros_like(img)
        for ch, gaussians in enumerate(self.filters):
            plane = np.ascontiguousarray(img[..., ch])
            for s, wt in gaussians:
                out[..., ch] += wt * _gauss(plane, s)
        return out

    def error(self, res: np.ndarray, target: np.ndarray) -> tuple[float, np.ndarray]:
        """``E`` and ``dE/dC`` for the composite ``C = target + res``."""
        lin, dlin = self._decode(target + res)
        r = (lin @ self.m.T).astype(self.dt) - self.opp_t
        f = self._filter(r)
        wf = np.einsum("...ij,...j->...i", self.w, f)
        e = _dot(np.ascontiguousarray(f), np.ascontiguousarray(wf))
        grad_r = 2.0 * self._filter(wf)
        if self.beta > 0:
            wr = np.einsum("...ij,...j->...i", self.w, r)
            e += self.beta * _dot(np.ascontiguousarray(r), np.ascontiguousarray(wr))
            grad_r += 2.0 * self.beta * wr
        dedc = (grad_r.astype(np.float64) @ self.m) * dlin
        return _LAB_SCALE * e, np.ascontiguousarray(_LAB_SCALE * dedc, dtype=self.dt)


@dataclass
class _Eval:
    """The objective at one state: per-layer ``T`` (L, H, W), ``E``, ``G T`` (L, H, W), ``(G, Q)`` if asked."""

    trans: np.ndarray
    e: float
    gt: np.ndarray
    gq: np.ndarray | None


def _evaluate(
    state, kernels, pitch, target, alpha_targets, lam, primer, colours, eye_px, want_q=False, viewer=None
) -> _Eval:
    """The composite's filtered squared error plus ``lam`` times each layer's, and its gradients.

    Images are of ``target``'s dtype. ``G = dE/dalpha_l`` and ``Q`` the curvature along it
    (see the module doc); ``alpha_targets`` (L, H, W) is read only when ``lam > 0``.
    """
    h, w = target.shape[:2]
    dt = target.dtype
    n_l = len(state)
    trans = np.ones((n_l, h, w), dtype=dt)
    for k, layer in enumerate(state):
        if len(layer.x):
            rows, cols, sig, peak, _, _, exp_mode = _kernels_px(layer, kernels, pitch, h)
            _transmittance(trans[k], rows, cols, sig, peak, exp_mode)
    n_t = n_l if lam > 0 else 0
    res = np.empty((h, w, 3), dtype=dt)
    lres = np.empty((n_t, h, w), dtype=dt)
    a_t = alpha_targets if n_t else lres
    _composite_residuals(trans, primer, colours, target, a_t, res, lres)
    if viewer is not None:
        e, dedc = viewer.error(res, target)
        qm = viewer.q
    else:
        e, dedc = _filtered(res, eye_px)
        qm = np.zeros((0, 0, 3, 3), dtype=dt)
    dl = np.empty_like(lres)
    for k in range(n_t):
        ek, dl[k] = _filtered(lres[k], eye_px)
        e += lam * ek
    gt = np.empty_like(trans)
    gq = np.empty((2, n_l, h, w) if want_q else (0, 1, 1, 1), dtype=dt)
    _opacity_gradients(trans, primer, colours, dedc, dl, float(lam), gt, gq, qm)
    return _Eval(trans, e, gt, gq if want_q else None)


def _g_and_q(ev: _Eval, k: int) -> tuple[np.ndarray, np.ndarray]:
    if ev.gq is None:
        raise ValueError("the objective was evaluated without G and Q")
    return ev.gq[0, k], ev.gq[1, k]


def _hole_grads(state, kernels, pitch, h, gt) -> list[np.ndarray]:
    """Per layer ``(N, 3)`` gradient of the objective w.r.t. each hole's x, y (mm) and radius (mm)."""
    out = []
    for k, layer in enumerate(state):
        grad = np.zeros((len(layer.x), 3))
        if len(layer.x):
            rows, cols, sig, peak, dsig, dpeak, exp_mode = _kernels_px(layer, kernels, pitch, h)
            raw = _hole_gradients(gt[k], rows, cols, sig, peak, exp_mode)
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
    from scipy.ndimage import minimum_filter

    rules = layer.rules
    h, w = shape
    r_new = rules.hole_min_r_mm
    sigma, peak, _, _, _ = kernels(np.array([r_new]), layer.spray_time)
    s_px = float(sigma[0]) / pitch
    a = min(float(peak[0]), 1.0)
    # Predicted change of E for a new hole centred on each pixel (see the module doc).
    lin = _gauss(g * t, s_px) * (2.0 * math.pi * s_px * s_px) * a
    quad = _gauss(q * t * t, s_px / math.sqrt(2.0)) * (math.pi * s_px * s_px) * a * a
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
        layer.ids = np.concatenate([layer.ids, np.full(n_new, -1, dtype=np.int64)])
        layer.sort(_BAND * pitch)
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


def _start_layers(
    dotsets: list[DotSet],
    rules: list[DesignRules],
    spray_times: list[float],
    settings: RefineSettings,
    mm_per_px: float,
) -> list[_Layer]:
    """Each layer's holes as the optimiser's state: float64 copies, fresh moments, in band order."""
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
            ids=np.arange(len(ds), dtype=np.int64),
        )
        layer.reset_moments()
        layer.sort(_BAND * mm_per_px)
        state.append(layer)
    return state


def _add_and_remove(state, ev: _Eval, evaluate, kernels, mm_per_px: float, shape) -> _Eval:
    """One round of removals and additions per layer, each scored on the composite; the new evaluation."""
    for k, layer in enumerate(state):
        g, q = _g_and_q(ev, k)
        layer.removed += _remove_holes(layer, g, q, ev.trans[k], kernels, mm_per_px, shape[0])
        ev = evaluate(want_q=True)
        g, q = _g_and_q(ev, k)
        layer.added += _add_holes(layer, g, q, ev.trans[k], kernels, mm_per_px, shape)
        ev = evaluate(want_q=True)
    return ev


def _refined(ds: DotSet, layer: _Layer) -> DotSet:
    """The layer's refined holes as a DotSet (input order first), checked against its rules."""
    layer.keep(layer.input_order())
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
    return replace(ds, xy_mm=xy, r_mm=layer.r.copy(), report=rep)


def refine_dots(
    target_rgb: np.ndarray,
    mm_per_px: float,
    primer: np.ndarray,
    colours: np.ndarray,
    dotsets: list[DotSet],
    rules: list[DesignRules],
    kernels: Kernels | Sequence[Kernels],
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
        kernels: The spray model's per-hole kernels bound to the spray settings (:data:`Kernels`),
            or one per can of a prior of cans (:mod:`stencil_cad.simulate.cans`), the nominal can
            first. With several, the expected error over the cans is minimised stochastically:
            step ``i`` takes its gradient (and its add/remove moves) under can ``i mod n``, Adam's
            moments average the cans' gradients, and one step costs what one can costs. The
            reported objectives are the first (nominal) can's.
        spray_times: Spray time of each layer.
        settings: Iterations, step sizes, largest radius, add/remove cadence, eye filter.
        progress: Called as ``progress(iteration, iterations)``.
        alpha_targets: ``(L, H, W)`` target opacity of each layer on the grid, or None. With
            it, each layer's own filtered opacity error is added to the objective, weighted
            by ``settings.layer_weight``.

    Returns:
        ``(dotsets, report)``: the refined DotSets (each passes :func:`check_rules` of its
        rules; the holes that stay keep the input's order, the added ones follow; ``report`` of each adds ``refine_added``, ``refine_removed``,
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
    # float32 images: half the memory traffic of every whole-image pass (see the kernels' note).
    target = np.ascontiguousarray(target_rgb, dtype=np.float32)
    shape = target.shape[:2]
    h = shape[0]
    primer = np.asarray(primer, dtype=np.float64)
    colours = np.asarray(colours, dtype=np.float64).reshape(-1, 3)
    state = _start_layers(dotsets, rules, spray_times, settings, mm_per_px)
    eye_px = settings.eye_sigma_mm / mm_per_px
    npx = float(shape[0] * shape[1] * 3)

    alpha_targets = None if alpha_targets is None else np.ascontiguousarray(alpha_targets, dtype=np.float32)
    lam = settings.layer_weight if alpha_targets is not None else 0.0

    viewer = _Viewer(target, mm_per_px, settings.view) if settings.view is not None else None

    cans = [kernels] if callable(kernels) else list(kernels)
    if not cans:
        raise ValueError("need the kernels of at least one can")
    kernels = cans[0]

    def evaluate(want_q=False):
        return _evaluate(
            state, kernels, mm_per_px, target, alpha_targets, lam, primer, colours, eye_px, want_q, viewer
        )

    ev = evaluate()
    e_start = ev.e
    iters = settings.iterations
    every = settings.add_remove_every
    for it in range(1, iters + 1):
        grads = _hole_grads(state, kernels, mm_per_px, h, ev.gt)
        # Linear decay of the step size to a fifth: large moves first, then polish.
        frac = 1.0 - 0.8 * (it - 1) / max(iters - 1, 1)
        for layer, grad in zip(state, grads, strict=True):
            if len(layer.x):
                _adam_step(layer, grad, it, frac, settings)
        moves = bool(every) and it % every == 0 and it < iters
        if not moves:
            # Step i + 1 takes the next can's gradient (one evaluation a step, as with one can).
            kernels = cans[it % len(cans)]
        ev = evaluate(want_q=moves)
        if moves:
            ev = _add_and_remove(state, ev, evaluate, kernels, mm_per_px, shape)
            if len(cans) > 1:
                kernels = cans[it % len(cans)]
                ev = evaluate()
        if progress is not None:
            progress(it, iters)
    if kernels is not cans[0]:
        kernels = cans[0]
        ev = evaluate()
    out = [_refined(ds, layer) for ds, layer in zip(dotsets, state, strict=True)]
    report = {
        "iterations": iters,
        "objective_start": math.sqrt(e_start / npx),
        "objective_end": math.sqrt(ev.e / npx),
        "seconds": round(time.perf_counter() - t_start, 3),
    }
    log.debug("refined: %s", report)
    return out, report
