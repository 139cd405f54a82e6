"""Compiled kernels of the hole refinement: per-hole deposits, their gradients and the rule projection.

Each kernel works on one layer's holes in pixel coordinates (see :mod:`.refine` for the
objective and its derivatives); the optimiser's state and the stage live there and in
:mod:`.refine_holes` and :mod:`.refine_objective`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from ..parallel import njit_parallel

#: A hole's deposit is evaluated out to where it falls below this (relative to 1).
_TAIL = 1e-4
#: Cap of one deposit in the product model's gradient quotient ``N / (1 - N)`` (see there).
_NV_MAX = 0.999999


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


@njit_parallel(cache=True, fastmath=True)
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


@njit_parallel(cache=True, fastmath=True)
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


@njit_parallel(cache=True, fastmath=True)
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


@njit_parallel(cache=True)
def _composite_residuals(
    trans, primer, colours, target, alpha_t, res, lres, first
):  # pragma: no cover - compiled
    """Composite minus target into ``res`` (H, W, 3); layers ``first`` on's opacity minus its target into ``lres``.

    ``lres[m]`` is layer ``first + m``'s: every layer's from ``first = 0``, one layer's into an
    ``lres`` of one. ``lres`` has no layers when the per-layer term is off (then ``alpha_t`` is not read).
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
                lres[m, r, c] = (1.0 - trans[first + m, r, c]) - alpha_t[first + m, r, c]


@njit_parallel(cache=True)
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


@njit_parallel(cache=True)
def _layer_gradient(trans, primer, colours, dedc, dl, lam, k, gq, qm):  # pragma: no cover - compiled
    """Layer ``k``'s ``G`` and ``Q`` into ``gq`` (2, H, W): :func:`_opacity_gradients` for one layer.

    The same sums in the same order (the composite under layer ``k``, then the transmittance of
    the layers over it from the top down), so ``G`` and ``Q`` equal that kernel's to the last bit;
    ``dl`` (H, W) is layer ``k``'s term (read only when ``lam > 0``). The add/remove moves take one
    layer's ``G`` and ``Q`` at a time: writing every layer's (three images a layer) cost 20 ms an
    evaluation on the bundled example's eight plates, this kernel a few.
    """
    n_l, h, w = trans.shape
    metric = qm.shape[0] > 0
    layer_term = lam > 0.0
    for r in numba.prange(h):
        for c in range(w):
            c0 = primer[0]
            c1 = primer[1]
            c2 = primer[2]
            for m in range(k):
                tm = trans[m, r, c]
                u = 1.0 - tm
                c0 = c0 * tm + u * colours[m, 0]
                c1 = c1 * tm + u * colours[m, 1]
                c2 = c2 * tm + u * colours[m, 2]
            s = 1.0
            for m in range(n_l - 1, k, -1):
                s *= trans[m, r, c]
            j0 = (colours[k, 0] - c0) * s
            j1 = (colours[k, 1] - c1) * s
            j2 = (colours[k, 2] - c2) * s
            gl = dedc[r, c, 0] * j0 + dedc[r, c, 1] * j1 + dedc[r, c, 2] * j2
            if layer_term:
                gl += lam * dl[r, c]
            gq[0, r, c] = gl
            if metric:
                q = 0.0
                for i in range(3):
                    ji = j0 if i == 0 else (j1 if i == 1 else j2)
                    q += ji * (qm[r, c, i, 0] * j0 + qm[r, c, i, 1] * j1 + qm[r, c, i, 2] * j2)
                gq[1, r, c] = q + lam
            else:
                gq[1, r, c] = j0 * j0 + j1 * j1 + j2 * j2 + lam


@njit_parallel(cache=True)
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
