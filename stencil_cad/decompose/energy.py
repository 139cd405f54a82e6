"""The decomposition energy and the compiled kernels of its block solver.

Model (Porter-Duff *over*, layer order = spray order)::

    C_0 = c_0 (primer),  C_l = (1 - a_l) C_{l-1} + a_l c_l,  X = C_L

Energy (Vavilala 2015, eq. 1), colours and opacities in [0, 1]::

    E = g_data   sum_p |X_p - Y_p|^2
      + g_smooth sum_l sum_p sum_{n in N8(p)} (a_l(p) - a_l(n))^2
      + g_sparse sum_p (1 - sum_l a_l(p))^2

The smoothness sum runs over ordered pairs, so every unordered neighbour pair
counts twice, exactly as written in the paper.

With every layer but ``l`` fixed the composite is affine in ``a_l`` per pixel,
``X = P + a_l D`` with ``P = T_l B_{l-1} + A_l`` and ``D = T_l (c_l - B_{l-1})``,
where ``B_{l-1}`` is the composite of the layers below ``l``, ``T_l`` the
transmittance of the layers above it and ``A_l`` their premultiplied colour.
The per-layer problem is then a box-constrained QP whose Hessian is diagonal
(data + sparsity) plus the 8-neighbour Laplacian; it is solved by projected
SOR, each coordinate step being the exact minimiser of a convex 1-D quadratic
(over-relaxed with omega < 2 and clipped), so the energy never increases.
"""

from __future__ import annotations

import numba
import numpy as np

# Over-relaxation of the projected SOR sweeps. Any value in (0, 2) keeps every
# coordinate step monotone; 1.6 roughly halves the sweeps needed where the
# Laplacian dominates (opacity under an opaque layer, or c_l close to B).
SOR_OMEGA = 1.6


@numba.njit(cache=True)
def composite_nb(primer, colours, alphas):
    """Composite ``(H, W, 3)`` of the layers over the primer (compiled)."""
    n_layers, h, w = alphas.shape
    out = np.empty((h, w, 3))
    for i in range(h):
        for j in range(w):
            r = primer[0]
            g = primer[1]
            b = primer[2]
            for layer in range(n_layers):
                a = alphas[layer, i, j]
                r = (1.0 - a) * r + a * colours[layer, 0]
                g = (1.0 - a) * g + a * colours[layer, 1]
                b = (1.0 - a) * b + a * colours[layer, 2]
            out[i, j, 0] = r
            out[i, j, 1] = g
            out[i, j, 2] = b
    return out


@numba.njit(cache=True)
def smooth_term(a):
    """``sum_p sum_{n in N8(p)} (a(p) - a(n))^2`` for one ``(H, W)`` map (ordered pairs)."""
    h, w = a.shape
    s = 0.0
    for i in range(h):
        for j in range(w):
            v = a[i, j]
            if j + 1 < w:
                d = v - a[i, j + 1]
                s += d * d
            if i + 1 < h:
                if j > 0:
                    d = v - a[i + 1, j - 1]
                    s += d * d
                d = v - a[i + 1, j]
                s += d * d
                if j + 1 < w:
                    d = v - a[i + 1, j + 1]
                    s += d * d
    return 2.0 * s


@numba.njit(cache=True)
def energy_terms(target, primer, colours, alphas):
    """The three unweighted terms ``(data, smooth, sparse)`` of the energy.

    Args:
        target: ``(H, W, 3)`` image Y in [0, 1].
        primer: ``(3,)`` primer colour.
        colours: ``(L, 3)`` paint colours.
        alphas: ``(L, H, W)`` opacities.

    Returns:
        ``(data, smooth, sparse)`` as floats.
    """
    n_layers, h, w = alphas.shape
    data = 0.0
    sparse = 0.0
    for i in range(h):
        for j in range(w):
            r = primer[0]
            g = primer[1]
            b = primer[2]
            total = 0.0
            for layer in range(n_layers):
                a = alphas[layer, i, j]
                total += a
                r = (1.0 - a) * r + a * colours[layer, 0]
                g = (1.0 - a) * g + a * colours[layer, 1]
                b = (1.0 - a) * b + a * colours[layer, 2]
            dr = r - target[i, j, 0]
            dg = g - target[i, j, 1]
            db = b - target[i, j, 2]
            data += dr * dr + dg * dg + db * db
            q = 1.0 - total
            sparse += q * q
    smooth = 0.0
    for layer in range(n_layers):
        smooth += smooth_term(alphas[layer])
    return data, smooth, sparse


@numba.njit(cache=True)
def suffix_products(colours, alphas, trans, above):
    """Fill the transmittance and premultiplied colour of the layers above each layer.

    ``trans[l] = prod_{k > l} (1 - a_k)`` and
    ``above[l] = sum_{j > l} a_j c_j prod_{k > j} (1 - a_k)``, both in place.

    Args:
        colours: ``(L, 3)`` paint colours.
        alphas: ``(L, H, W)`` opacities.
        trans: ``(L, H, W)`` output.
        above: ``(L, H, W, 3)`` output.
    """
    n_layers, h, w = alphas.shape
    for i in range(h):
        for j in range(w):
            t = 1.0
            r = 0.0
            g = 0.0
            b = 0.0
            for layer in range(n_layers - 1, -1, -1):
                trans[layer, i, j] = t
                above[layer, i, j, 0] = r
                above[layer, i, j, 1] = g
                above[layer, i, j, 2] = b
                a = alphas[layer, i, j]
                wgt = a * t
                r += wgt * colours[layer, 0]
                g += wgt * colours[layer, 1]
                b += wgt * colours[layer, 2]
                t *= 1.0 - a


# Side in px of the tiles of the projected SOR. A tile is re-swept only while
# it or one of its 8 neighbour tiles still moved by more than the tolerance,
# so converged regions stop costing anything. Tiles are visited in a 2 x 2
# colouring (tiles of one colour share no neighbourhood), which would let them
# run in parallel; threads were slower on a loaded 2-core machine.
TILE = 32


@numba.njit(cache=True, inline="always")
def _update_border_pixel(alpha, base, gain, keep, i, j):
    """The projected SOR step of a pixel on the image border (fewer neighbours)."""
    h, w = alpha.shape
    nb = 0.0
    for ii in range(max(i - 1, 0), min(i + 1, h - 1) + 1):
        for jj in range(max(j - 1, 0), min(j + 1, w - 1) + 1):
            if ii != i or jj != j:
                nb += alpha[ii, jj]
    old = alpha[i, j]
    new = min(max(keep * old + base[i, j] + gain[i, j] * nb, 0.0), 1.0)
    alpha[i, j] = new
    return abs(new - old)


@numba.njit(cache=True)
def _sweep_tile(alpha, base, gain, keep, i_lo, i_hi, j_lo, j_hi):
    """One projected SOR pass over rows [i_lo, i_hi) x cols [j_lo, j_hi).

    The over-relaxed exact coordinate step is precomputed as
    ``new = keep * old + base + gain * (sum of the 8 neighbours)``, clipped,
    with ``keep = 1 - omega``.

    Returns:
        The largest change of an opacity in the tile.
    """
    h, w = alpha.shape
    change = 0.0
    for i in range(i_lo, i_hi):
        if i == 0 or i == h - 1:
            for j in range(j_lo, j_hi):
                change = max(change, _update_border_pixel(alpha, base, gain, keep, i, j))
            continue
        if j_lo == 0:
            change = max(change, _update_border_pixel(alpha, base, gain, keep, i, 0))
        up = alpha[i - 1]
        mid = alpha[i]
        dn = alpha[i + 1]
        bi = base[i]
        gi = gain[i]
        # Interior pixels: a tight loop (row views, no border tests).
        for j in range(max(j_lo, 1), min(j_hi, w - 1)):
            nb = (up[j - 1] + up[j] + up[j + 1] + mid[j + 1] + dn[j - 1] + dn[j] + dn[j + 1]) + mid[j - 1]
            old = mid[j]
            new = min(max(keep * old + bi[j] + gi[j] * nb, 0.0), 1.0)
            mid[j] = new
            change = max(change, abs(new - old))
        if j_hi == w and w > 1:
            change = max(change, _update_border_pixel(alpha, base, gain, keep, i, w - 1))
    return change


@numba.njit(cache=True)
def solve_layer(
    target, below, trans, above, colour, alpha, total, g_data, g_smooth, g_sparse, omega, tol, max_sweeps
):
    """Solve one layer's opacity QP by projected SOR, in place.

    Minimises over ``alpha`` in [0, 1]^(H x W), everything else fixed::

        g_data sum_p |P + alpha D - Y|^2 + g_smooth sum_p sum_{N8} (alpha_p - alpha_n)^2
        + g_sparse sum_p (1 - s_p - alpha_p)^2

    where ``s_p`` is the summed opacity of the other layers. Each pixel update
    is the exact minimiser over that pixel, over-relaxed by ``omega`` in (0, 2)
    and clipped to [0, 1], so no update raises the objective.

    Args:
        target: ``(H, W, 3)`` image Y.
        below: ``(H, W, 3)`` composite of the layers under this one (B).
        trans: ``(H, W)`` transmittance of the layers above (T).
        above: ``(H, W, 3)`` premultiplied colour of the layers above (A).
        colour: ``(3,)`` this layer's paint colour.
        alpha: ``(H, W)`` opacities, updated in place.
        total: ``(H, W)`` sum of all layers' opacities (this one included).
        g_data: gamma_data.
        g_smooth: gamma_smooth.
        g_sparse: gamma_sparse.
        omega: Over-relaxation factor in (0, 2).
        tol: Stop when no opacity moved by more than this in a sweep.
        max_sweeps: Most sweeps.

    Returns:
        Number of sweeps run.
    """
    h, w = alpha.shape
    base = np.empty((h, w))
    gain = np.empty((h, w))
    keep = 1.0 - omega
    _step_coefficients(
        target, below, trans, above, colour, alpha, total, g_data, g_smooth, g_sparse, omega, base, gain
    )
    nti = (h + TILE - 1) // TILE
    ntj = (w + TILE - 1) // TILE
    active = np.ones((nti, ntj), dtype=np.bool_)
    moved = np.zeros((nti, ntj))
    sweeps = 0
    for _ in range(max_sweeps):
        sweeps += 1
        for colour_class in range(4):
            pi = colour_class // 2
            pj = colour_class % 2
            n_i = (nti - pi + 1) // 2
            n_j = (ntj - pj + 1) // 2
            for k in range(n_i * n_j):
                ti = pi + 2 * (k // n_j)
                tj = pj + 2 * (k % n_j)
                if active[ti, tj]:
                    moved[ti, tj] = _sweep_tile(
                        alpha,
                        base,
                        gain,
                        keep,
                        ti * TILE,
                        min((ti + 1) * TILE, h),
                        tj * TILE,
                        min((tj + 1) * TILE, w),
                    )
                else:
                    moved[ti, tj] = 0.0
        if not _update_active(moved, active, tol):
            break
    return sweeps


@numba.njit(cache=True)
def _step_coefficients(
    target, below, trans, above, colour, alpha, total, g_data, g_smooth, g_sparse, omega, base, gain
):
    """Fill ``base`` and ``gain`` of every pixel's over-relaxed exact step (see :func:`_sweep_tile`)."""
    h, w = alpha.shape
    two_s = 2.0 * g_smooth
    for i in range(h):
        for j in range(w):
            t = trans[i, j]
            dd = 0.0
            dr = 0.0
            for c in range(3):
                bl = below[i, j, c]
                d = t * (colour[c] - bl)
                p = t * bl + above[i, j, c]
                dd += d * d
                dr += d * (target[i, j, c] - p)
            other = total[i, j] - alpha[i, j]
            deg = (min(i + 1, h - 1) - max(i - 1, 0) + 1) * (min(j + 1, w - 1) - max(j - 1, 0) + 1) - 1
            num = g_data * dr + g_sparse * (1.0 - other)
            den = g_data * dd + g_sparse + two_s * deg
            if den > 0.0:
                # Exact 1-D minimiser (num + 2 g_smooth nb) / den, over-relaxed.
                base[i, j] = omega * num / den
                gain[i, j] = omega * two_s / den
            else:
                # No term depends on this pixel: the step maps it onto itself.
                base[i, j] = omega * alpha[i, j]
                gain[i, j] = 0.0


@numba.njit(cache=True)
def _update_active(moved, active, tol):
    """Mark the tiles to sweep again (one of the 3 x 3 around moved by more than ``tol``); True if any."""
    nti, ntj = moved.shape
    any_active = False
    for ti in range(nti):
        for tj in range(ntj):
            m = 0.0
            for a in range(max(ti - 1, 0), min(ti + 1, nti - 1) + 1):
                for b in range(max(tj - 1, 0), min(tj + 1, ntj - 1) + 1):
                    m = max(m, moved[a, b])
            active[ti, tj] = m > tol
            any_active = any_active or m > tol
    return any_active


@numba.njit(cache=True)
def finish_layer(below, total, colour, alpha, alpha_old):
    """Composite the solved layer onto ``below`` and update the opacity sum, in place."""
    h, w = alpha.shape
    for i in range(h):
        for j in range(w):
            a = alpha[i, j]
            total[i, j] += a - alpha_old[i, j]
            for c in range(3):
                below[i, j, c] = (1.0 - a) * below[i, j, c] + a * colour[c]


@numba.njit(cache=True)
def colour_normal_equations(target, alphas):
    """Normal equations of the colour step.

    The composite is linear in the L + 1 colours,
    ``X_p = sum_j w_j(p) c_j`` with ``w_0 = prod_k (1 - a_k)`` and
    ``w_j = a_j prod_{k > j} (1 - a_k)``.

    Returns:
        ``(G, B, yy)``: ``G = W^T W`` ``(L+1, L+1)``, ``B = W^T Y`` ``(L+1, 3)``
        and ``yy = sum |Y|^2`` per channel ``(3,)``.
    """
    n_layers, h, w = alphas.shape
    n = n_layers + 1
    gram = np.zeros((n, n))
    rhs = np.zeros((n, 3))
    yy = np.zeros(3)
    wv = np.empty(n)
    for i in range(h):
        for j in range(w):
            t = 1.0
            for layer in range(n_layers - 1, -1, -1):
                a = alphas[layer, i, j]
                wv[layer + 1] = a * t
                t *= 1.0 - a
            wv[0] = t
            for c in range(3):
                y = target[i, j, c]
                yy[c] += y * y
                for k in range(n):
                    rhs[k, c] += wv[k] * y
            for k in range(n):
                wk = wv[k]
                if wk == 0.0:
                    continue
                for m in range(k, n):
                    gram[k, m] += wk * wv[m]
    for k in range(n):
        for m in range(k):
            gram[k, m] = gram[m, k]
    return gram, rhs, yy


@numba.njit(cache=True)
def extrapolate(x, x_prev, beta, out):
    """``out = clip(x + beta (x - x_prev), 0, 1)`` elementwise, any shape (flattened views)."""
    xf = x.ravel()
    pf = x_prev.ravel()
    of = out.ravel()
    for k in range(xf.size):
        v = xf[k] + beta * (xf[k] - pf[k])
        if v < 0.0:
            v = 0.0
        elif v > 1.0:
            v = 1.0
        of[k] = v
