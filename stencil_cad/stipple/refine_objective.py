"""The refinement's objective: the composite's filtered error (sRGB or the viewer's colour error) and its gradients.

See :mod:`.refine` for the objective's definition and its derivatives.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .refine_holes import _kernels_px, layer_kernels
from .refine_kernels import (
    _composite_residuals,
    _dot,
    _hole_gradients,
    _layer_gradient,
    _opacity_gradients,
    _transmittance,
)

# --------------------------------------------------------------------------- the objective


def _gauss(img: np.ndarray, sigma_px: float) -> np.ndarray:
    """Gaussian filter of an (H, W) or (H, W, C) image with zero padding (so it is self-adjoint).

    OpenCV's separable filter in float32: 14x faster than scipy's ``gaussian_filter`` on a
    2048 x 2048 x 3 image here (0.05 s vs 0.70 s), same kernel (radius ``4 sigma``).
    """
    import cv2

    from ..filters import sep_filter

    rad = int(4.0 * sigma_px + 0.5)
    xs = np.arange(-rad, rad + 1, dtype=np.float64)
    k = np.exp(-(xs * xs) / (2.0 * sigma_px * sigma_px))
    k = (k / k.sum()).astype(img.dtype)
    return sep_filter(np.ascontiguousarray(img), k, k, cv2.BORDER_CONSTANT)


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
    state,
    kernels,
    pitch,
    target,
    alpha_targets,
    lam,
    primer,
    colours,
    eye_px,
    want_q=False,
    viewer=None,
    fixed_trans=None,
) -> _Eval:
    """The composite's filtered squared error plus ``lam`` times each layer's, and its gradients.

    Images are of ``target``'s dtype. ``G = dE/dalpha_l`` and ``Q`` the curvature along it
    (see the module doc); ``alpha_targets`` (L, H, W) is read only when ``lam > 0``.
    ``fixed_trans`` (L, H, W) or None multiplies each layer's transmittance: the open area that
    does not move (a hybrid plate's windows). A hole's ``dalpha/dN_i`` is ``T`` (or
    ``T / (1 - N_i)``) with ``T`` the layer's whole transmittance, so the gradients stay exact.
    """
    h, w = target.shape[:2]
    dt = target.dtype
    n_l = len(state)
    trans = np.ones((n_l, h, w), dtype=dt)
    for k, layer in enumerate(state):
        if len(layer.x):
            rows, cols, sig, peak, _, _, exp_mode = _kernels_px(layer, layer_kernels(kernels, k), pitch, h)
            _transmittance(trans[k], rows, cols, sig, peak, exp_mode)
    if fixed_trans is not None:
        trans *= fixed_trans
    e, dedc, qm, lres = _residuals(trans, target, alpha_targets, lam, primer, colours, eye_px, viewer)
    dl = np.empty_like(lres)
    for k in range(lres.shape[0]):
        ek, dl[k] = _filtered(lres[k], eye_px)
        e += lam * ek
    gt = np.empty_like(trans)
    gq = np.empty((2, n_l, h, w) if want_q else (0, 1, 1, 1), dtype=dt)
    _opacity_gradients(trans, primer, colours, dedc, dl, float(lam), gt, gq, qm)
    return _Eval(trans, e, gt, gq if want_q else None)


def _residuals(trans, target, alpha_targets, lam, primer, colours, eye_px, viewer, only=None):
    """``(E of the composite, dE/dC, the metric of Q, the layers' opacity residuals)`` at ``trans``.

    The residuals are of every layer when ``lam > 0`` (``alpha_targets`` (L, H, W) is read then),
    or of layer ``only`` alone (an (1, H, W) array), of none when ``lam`` is 0.
    """
    h, w = target.shape[:2]
    dt = target.dtype
    n_t = (trans.shape[0] if only is None else 1) if lam > 0 else 0
    res = np.empty((h, w, 3), dtype=dt)
    lres = np.empty((n_t, h, w), dtype=dt)
    a_t = alpha_targets if n_t else lres
    _composite_residuals(trans, primer, colours, target, a_t, res, lres, 0 if only is None else only)
    if viewer is not None:
        e, dedc = viewer.error(res, target)
        qm = viewer.q
    else:
        e, dedc = _filtered(res, eye_px)
        qm = np.zeros((0, 0, 3, 3), dtype=dt)
    return e, dedc, qm, lres


def _layer_g_and_q(
    state,
    kernels,
    pitch,
    target,
    alpha_targets,
    lam,
    primer,
    colours,
    eye_px,
    viewer,
    fixed_trans,
    trans: np.ndarray,
    changed: int,
    want: int,
) -> tuple[np.ndarray, np.ndarray]:
    """``G`` and ``Q`` of layer ``want`` once layer ``changed`` moved: what :func:`_evaluate` gives them.

    ``trans`` (L, H, W) holds every layer's transmittance before the move and is updated in place
    (layer ``changed`` computed again; the others' holes did not move, so theirs stand). The
    add/remove moves change one layer at a time and read one layer's ``G`` and ``Q`` after each:
    on the bundled example's eight plates a whole evaluation after every move was more than half
    the refinement's time. The values equal :func:`_evaluate`'s to the last bit.
    """
    h = target.shape[0]
    layer = state[changed]
    trans[changed] = 1.0
    if len(layer.x):
        rows, cols, sig, peak, _, _, exp_mode = _kernels_px(layer, layer_kernels(kernels, changed), pitch, h)
        _transmittance(trans[changed], rows, cols, sig, peak, exp_mode)
    if fixed_trans is not None:
        trans[changed] *= fixed_trans[changed]
    # Layer want's opacity residual alone: the other layers' were 8 of the 9 images the residual
    # kernel wrote on the example's eight plates, and only want's is read.
    _, dedc, qm, lres = _residuals(trans, target, alpha_targets, lam, primer, colours, eye_px, viewer, want)
    dl = _filtered(lres[0], eye_px)[1] if lres.shape[0] else np.empty((1, 1), dtype=target.dtype)
    gq = np.empty((2, *target.shape[:2]), dtype=target.dtype)
    _layer_gradient(trans, primer, colours, dedc, dl, float(lam), want, gq, qm)
    return gq[0], gq[1]


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
            rows, cols, sig, peak, dsig, dpeak, exp_mode = _kernels_px(
                layer, layer_kernels(kernels, k), pitch, h
            )
            raw = _hole_gradients(gt[k], rows, cols, sig, peak, exp_mode)
            # px -> mm: x = (col + 0.5) s, y = (H - row - 0.5) s, sigma_mm = sigma_px s.
            grad[:, 0] = raw[:, 1] / pitch
            grad[:, 1] = -raw[:, 0] / pitch
            grad[:, 2] = raw[:, 2] / pitch * dsig + raw[:, 3] * dpeak
        out.append(grad)
    return out
