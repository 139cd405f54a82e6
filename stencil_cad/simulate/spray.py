"""The spray model: per-layer opacity through the holes and the full-colour composite.

The spray model is Vavilala & Forsyth's (2015): hole ``i`` of radius ``r_i`` at
``p_i`` leaves the Gaussian::

    N_i(p) = A exp(-|p - p_i|^2 / (2 sigma_i^2)),   sigma_i^2 = r_i^2 (1 + h) / 4,

and the layer's opacity is ``I = 1 - prod_i (1 - min(N_i, 1))``. ``A`` is the
spray time (``spray.spray_time``) and ``h`` the dimensionless nozzle height
(``spray.nozzle_height``, see :class:`~stencil_cad.config.spray.SprayConfig`).

Two evaluations of the same model are provided (in :mod:`.opacity`):

* exact (:func:`spray_opacity` with ``exact=True``): every hole at every pixel,
  vectorised over tiles of pixels x holes so memory stays bounded. It is the
  reference, and it is slow (O(pixels x holes)).
* fast (default): each hole is splatted in compiled code over the disc where
  ``A exp(-d^2 / 2 sigma^2) >= tol``. The transmittance ``T = prod (1 - min(N, 1))``
  is multiplied directly, so a clamped hole (N >= 1) gives T = 0 exactly and no
  logarithm or cap is needed. A dropped tail N_j < tol changes the opacity by at
  most ``T * sum_j N_j``. Averaged over positions this sum is ``tol * n_eff``
  with ``n_eff = max_p sum_i 2 pi sigma_i^2 rho_i(p)`` (the local hole density
  weighted by each hole's Gaussian area, measured from the holes); a lattice
  shell of equidistant holes just beyond the cut can hold several times that,
  so ``tol = max_error / (8 max(1, n_eff))``.

``spray.model: physical`` replaces this model by the one in :mod:`stencil_cad.simulate.physical`
(stand-off, can distance, passes); every public function here asks the job's model
(:func:`stencil_cad.simulate.models.sprayer`), and takes the plate's ``geometry`` (stand-off,
thickness) for a model that sees the wall.

The optical depth ``-ln(1 - I)`` used by the tone calibration is additive over
holes; where a hole clamps (N >= 1) it is infinite, so the calibration works on
mean opacities, never on summed depths, and needs no cap.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from ..config.spray import SprayConfig
from ..filters import gaussian, resize_linear
from ..model import DotSet, Layers, composite
from .models import sprayer
from .opacity import spray_opacity, windows_opacity

if TYPE_CHECKING:
    from .physical import SprayGeometry

log = logging.getLogger(__name__)

__all__ = [
    "SimResult",
    "hole_kernels",
    "layer_rmse",
    "per_layer",
    "resample",
    "sim_shape",
    "simulate",
    "target_on_grid",
]


@dataclass(frozen=True)
class SimResult:
    """A simulated spray of every layer.

    Attributes:
        alphas: ``(L, H, W)`` ndarray of float in [0, 1], simulated opacity per layer.
        composite: ``(H, W, 3)`` ndarray of float in [0, 1]: primer, then each layer
            over it with its paint colour, in spray order.
        layer_rmse: Per layer, RMSE between the target opacity (resampled to this
            grid and blurred to the spray scale) and the simulated opacity.
        mm_per_px: Pixel size of the simulation grid in mm.
        info: Figures for the manifest: per-layer hole counts, spray times, blur
            sigma, tone RMSE (both sides blurred), timings.
    """

    alphas: np.ndarray
    composite: np.ndarray
    layer_rmse: tuple[float, ...]
    mm_per_px: float
    info: dict = field(default_factory=dict)


def sim_shape(
    layers_shape: tuple[float, float], layers_mm_per_px: float, grid_mm_per_px: float
) -> tuple[int, int]:
    """Shape of the simulation raster covering the same picture area.

    Args:
        layers_shape: ``(H, W)`` of the layers' grid (or the picture's size in mm, with
            ``layers_mm_per_px`` 1).
        layers_mm_per_px: Pixel size of that grid in mm.
        grid_mm_per_px: Pixel size of the simulation grid in mm.

    Returns:
        ``(H, W)`` rounded to whole pixels (at least 1).
    """
    h = max(1, int(round(layers_shape[0] * layers_mm_per_px / grid_mm_per_px)))
    w = max(1, int(round(layers_shape[1] * layers_mm_per_px / grid_mm_per_px)))
    return h, w


def blurred_composite(layers: Layers, sigma_mm: float, grid_mm_per_px: float) -> np.ndarray:
    """The layers as a spray of blur ``sigma_mm`` would leave them with no dots: ``(H, W, 3)`` in [0, 1].

    Each layer's opacity resampled to the grid (:func:`sim_shape`), blurred by a Gaussian of
    ``sigma_mm`` and composited. The studio's first preview, and the fidelity benchmark's blur floor
    (what no plate of that blur sprays sharper than).
    """
    shape = sim_shape(layers.alphas.shape[1:], layers.mm_per_px, grid_mm_per_px)
    alphas = np.stack([resample(a, shape) for a in layers.alphas])
    if sigma_mm > 0.0:
        alphas = np.stack([gaussian(a, sigma_mm / grid_mm_per_px) for a in alphas])
    return np.clip(composite(layers.primer, layers.colours, alphas), 0.0, 1.0)


def resample(img: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Resample an ``(H, W)`` or ``(H, W, C)`` image to ``shape`` (bilinear, anti-aliased)."""
    img = np.asarray(img, dtype=np.float64)
    if img.shape[:2] == tuple(shape):
        return img
    out = resize_linear(img, shape, "edge")
    return np.clip(out, 0.0, 1.0)


def target_on_grid(alpha: np.ndarray, shape: tuple[int, int], blur_mm: float, mm_per_px: float) -> np.ndarray:
    """A target opacity resampled to the simulation grid and blurred to the spray scale.

    Args:
        alpha: ``(h, w)`` target opacity in [0, 1].
        shape: ``(H, W)`` of the simulation grid.
        blur_mm: Gaussian sigma in mm of the spray scale (the layer's typical dot sigma).
        mm_per_px: Pixel size of the simulation grid in mm.

    Returns:
        ``(H, W)`` ndarray of float in [0, 1].
    """
    t = resample(alpha, shape)
    if blur_mm > 0:
        t = gaussian(t, blur_mm / mm_per_px, mode="nearest")
    return t


def layer_rmse(target: np.ndarray, simulated: np.ndarray) -> float:
    """Root-mean-square difference of two opacity maps of the same shape."""
    return float(np.sqrt(np.mean((np.asarray(target) - np.asarray(simulated)) ** 2)))


def _blur_mm_for(dots: DotSet, cfg: SprayConfig, fallback_r_mm: float, geometry=None) -> float:
    r = float(np.median(dots.r_mm)) if len(dots) else fallback_r_mm
    return sprayer(cfg).blur_mm(r, cfg, geometry)


def hole_kernels(
    r_mm: np.ndarray | float,
    spray_cfg: SprayConfig,
    layer_spray_time: float,
    *,
    geometry: SprayGeometry | None = None,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]:
    """Every hole's deposit as one Gaussian, for refinement: the per-hole contract of both models.

    Hole ``i`` deposits ``N_i(p) = peak_i exp(-|p - c_i|^2 / (2 sigma_i^2))`` and the layer's
    opacity combines them as ``combine`` says: ``"product"``, ``1 - prod_i (1 - min(N_i, 1))``
    (the paper's model, ``peak = A``, ``sigma = r sqrt(1 + h) / 2``), or ``"exp"``,
    ``1 - exp(-sum_i N_i)`` (the physical model, ``beta`` folded into ``peak``; a Gaussian of the
    disc-blur's variance and integral, whose error is given in
    :func:`stencil_cad.simulate.physical.physical_hole_kernels`).

    Args:
        r_mm: Hole radii in mm (array or scalar).
        spray_cfg: Spray settings.
        layer_spray_time: The layer's amount: spray time A (paper) or passes (physical).
        geometry: Stand-off and plate thickness; needed by the physical model.

    Returns:
        ``(sigma_mm, peak, dsigma_dr, dpeak_dr, combine)``: arrays shaped like ``r_mm`` (mm,
        dimensionless, mm per mm, per mm) and ``"product"`` or ``"exp"``.
    """
    r = np.asarray(r_mm, dtype=np.float64)
    return sprayer(spray_cfg).hole_kernels(r, spray_cfg, layer_spray_time, geometry)


def simulate(
    layers: Layers,
    dotsets: list[DotSet],
    cfg: SprayConfig,
    grid_mm_per_px: float | None = None,
    *,
    spray_times: list[float] | None = None,
    time_factor: float = 1.0,
    geometry=None,
    layer_sprays: Sequence[SprayConfig] | None = None,
    errors: bool = True,
) -> SimResult:
    """Spray every layer's stencil, composite the colours and score each layer's tone.

    A layer's RMSE compares its simulated opacity with the target opacity resampled
    to the simulation grid and blurred by the dot sigma of the layer's median hole
    radius (the finest detail a spray through those holes can hold), so it counts
    both tone error and the dots' texture. ``info["layer_tone_rmse"]`` blurs both
    sides: the tone error alone.

    Args:
        layers: The decomposition (primer, colours, target alphas, grid).
        dotsets: One DotSet per layer, in spray order (an empty one gives an empty layer).
        cfg: Spray settings.
        grid_mm_per_px: Simulation pixel size in mm. Defaults to ``1 / cfg.px_per_mm``.
        spray_times: Per-layer spray time A (e.g. chosen by the tone calibration).
            Defaults to each DotSet's ``spray_time`` when set (where the
            pipeline may record the calibration's choice), else ``cfg.spray_time``.
        time_factor: Multiplies every spray time (the sweep uses 0.5, 1, 2). Defaults to 1.
        geometry: Stand-off and plate thickness (:class:`~stencil_cad.simulate.physical.SprayGeometry`);
            needed by the physical model, whose spray times are passes.
        layer_sprays: Each layer's spray settings (its paint's profile, see
            :meth:`stencil_cad.config.JobConfig.layer_spray`), or None: ``cfg`` for every layer.
        errors: Score each layer's tone (``layer_rmse``, ``info["layer_tone_rmse"]``); False
            leaves them empty, for a caller that reads only the opacities and the composite.

    Returns:
        The :class:`SimResult`.

    Raises:
        ValueError: The number of DotSets differs from the number of layers, or a
            spray parameter is out of range.
    """
    if len(dotsets) != layers.count:
        raise ValueError(f"need one DotSet per layer: {layers.count} layers, {len(dotsets)} DotSets")
    g = _grid(cfg, grid_mm_per_px)
    spray_times, sprays = _spray_times(dotsets, cfg, spray_times), per_layer(cfg, layer_sprays, layers.count)
    shape = sim_shape(layers.alphas.shape[1:], layers.mm_per_px, g)
    model = sprayer(cfg)
    r_min = min((float(d.r_mm.min()) for d in dotsets if len(d)), default=None)
    model.check_scale(r_min, cfg, g, geometry)
    fallback_r = _median_radius(dotsets)
    alphas = np.zeros((layers.count, *shape), dtype=np.float64)
    rmse, tone_rmse, seconds, blur = [], [], [], []
    for i, dots in enumerate(dotsets):
        a = float(spray_times[i]) * time_factor
        t0 = time.perf_counter()
        alphas[i] = _layer_opacity(dots, shape, g, sprays[i], a, geometry)
        seconds.append(round(time.perf_counter() - t0, 4))
        b = _blur_mm_for(dots, sprays[i], fallback_r, geometry)
        if errors:
            layer_err, tone_err = _layer_errors(layers.alphas[i], alphas[i], shape, b, g)
            rmse.append(layer_err)
            tone_rmse.append(tone_err)
        blur.append(round(b, 4))
    comp = np.clip(composite(layers.primer, layers.colours, alphas), 0.0, 1.0)
    info = {
        "holes": [len(d) for d in dotsets],
        "spray_time": [float(t) * time_factor for t in spray_times],
        **model.info(cfg, geometry),
        "blur_sigma_mm": blur,
        "layer_tone_rmse": [round(x, 5) for x in tone_rmse],
        "seconds": seconds,
        "shape": list(shape),
    }
    return SimResult(alphas=alphas, composite=comp, layer_rmse=tuple(rmse), mm_per_px=g, info=info)


def _grid(cfg: SprayConfig, grid_mm_per_px: float | None) -> float:
    """The simulation's pixel size in mm: ``grid_mm_per_px``, else ``1 / cfg.px_per_mm``."""
    g = 1.0 / cfg.px_per_mm if grid_mm_per_px is None else float(grid_mm_per_px)
    if not g > 0:
        raise ValueError(f"grid_mm_per_px must be > 0, got {g}")
    return g


def _spray_times(dotsets: list[DotSet], cfg: SprayConfig, spray_times: list[float] | None) -> list[float]:
    """Each layer's spray time: ``spray_times``, else each DotSet's, else ``cfg``'s amount."""
    if spray_times is None:
        spray_times = [d.amount(cfg.amount) for d in dotsets]
    if len(spray_times) != len(dotsets):
        raise ValueError(f"need one spray time per layer: {len(dotsets)} layers, {len(spray_times)} times")
    return spray_times


def per_layer(cfg: SprayConfig, layer_sprays: Sequence[SprayConfig] | None, count: int) -> list[SprayConfig]:
    """Each of ``count`` layers' spray settings: ``layer_sprays``, or ``cfg`` for every layer.

    Raises:
        ValueError: ``layer_sprays`` does not hold one entry per layer.
    """
    if layer_sprays is None:
        return [cfg] * count
    if len(layer_sprays) != count:
        raise ValueError(f"need one spray setting per layer: {count} layers, {len(layer_sprays)} settings")
    return list(layer_sprays)


def _layer_opacity(dots: DotSet, shape, g: float, cfg: SprayConfig, a: float, geometry) -> np.ndarray:
    """One layer's sprayed opacity: its holes and its windows (a hybrid plate), as independent deposits."""
    out = np.zeros(shape)
    if len(dots):
        out = spray_opacity(dots.xy_mm, dots.r_mm, shape, g, cfg, spray_time=a, geometry=geometry)
    else:
        sprayer(cfg).check(cfg, a)
    if dots.windows:
        win = windows_opacity(dots.windows, shape, g, cfg, spray_time=a, geometry=geometry)
        out = 1.0 - (1.0 - out) * (1.0 - win)
    return out


def _layer_errors(target_alpha, simulated, shape, blur_mm: float, g: float) -> tuple[float, float]:
    """A layer's RMSE against its target on the grid, and with both sides blurred (the tone error alone)."""
    target = target_on_grid(target_alpha, shape, blur_mm, g)
    return layer_rmse(target, simulated), layer_rmse(target, gaussian(simulated, blur_mm / g, mode="nearest"))


def _median_radius(dotsets: list[DotSet]) -> float:
    """Median hole radius over every layer in mm (1 mm without holes): the blur of an empty layer."""
    all_r = np.concatenate([d.r_mm for d in dotsets]) if any(len(d) for d in dotsets) else np.array([1.0])
    return float(np.median(all_r))
