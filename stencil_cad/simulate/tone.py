"""Tone calibration: the stippling density that sprays the intended opacity.

Why. The paper stipples with hole density proportional to the target opacity
("linear tone"). The spray does not answer linearly: ``1 - I`` is a product
over holes, so the optical depth ``-ln(1 - I)`` adds up with hole density,
each hole deposits ``A 2 pi sigma^2`` of paint (more than its open area when
``A (1 + h) / 2 > 1``), and a hole whose centre is clamped (``N >= 1``) wastes
paint. Pale tones come out too dark and dark tones saturate.

How. For the stippler's pattern at open-area tone ``t`` (hole radius
``r(t) = r0 + (r1 - r0) sqrt(t)``, point density
``lambda(t) = rho_pack t (r1 / r(t))^2`` with ``rho_pack`` the hexagonal packing
at ``auto_spacing_factor (2 r1 + web)``, exactly as :mod:`stencil_cad.stipple`
does), a small jittered hexagonal patch is sprayed with the simulator and its
mean opacity ``m(t)`` and variance ``v(t)`` are measured: the *tone response*.
For holes placed as a Poisson process of density ``lambda`` the mean is exact:
``m = 1 - exp(-lambda ∫ min(N, 1) dA)`` (the probability generating functional
of the Poisson process applied to ``1 - I = prod (1 - min(N_i, 1))``); the
optical depth ``-ln(1 - m)`` grows linearly with hole density. A relaxed
stipple is more regular than Poisson, so the patch measurement replaces the
formula (they agree in the sparse limit, see tests/simulate/test_simulate.py). The calibrated density is the
inverse ``t(alpha) = m^-1(alpha)``, clipped to ``t <= 1`` where the minimum web
saturates it (no denser packing is possible). With ``spray.calibrate:
spray_time`` the spray time A of each layer is chosen from a geometric grid
(``spray_time x 2^(k/2)``, k = -12..6, i.e. 1/64x to 8x) to
minimise the predicted layer MSE ``mean(w ((m(t(alpha)) - alpha)^2 + v(t(alpha))))``
over the layer's opacities: a low A needs more holes than the web allows in dark
areas, a high A makes a coarse, clamped texture. The pipeline weighs each pixel by
``w = |T (c - B)|^2`` (:func:`stencil_cad.model.coat_contrast`), the squared colour change a full
coat makes there, so the error is counted in composite colour: a sparse scatter of
dots over a contrasting colour (orange over a dark blue sky) costs more than the same
scatter over a similar one. On ``python -m benchmarks quality`` (SLA) this took rocket
at h 60 from 2.60 to 2.46 S-CIELAB at 1 m and astronaut at h 30 from 6.84 to 6.77 (rocket's
orange layer now takes 0.088x, below the old grid's floor of 1/8x). Under ``spray.model: physical`` the
same measurement runs on the physical model at the job's design stand-off, and the free
amount is whole passes of the can (1 to 12) instead of A.
"""

from __future__ import annotations

import functools
import logging
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from ..config.spray import Calibrate, SprayConfig
from .models import sprayer
from .opacity import spray_opacity
from .spray import hole_kernels
from .tone_order import OrderedOpacities

if TYPE_CHECKING:
    from ..config.job import JobConfig

log = logging.getLogger(__name__)

__all__ = [
    "ToneChoice",
    "ToneCurve",
    "calibrated_density",
    "calibrated_density_for",
    "response_tone_for",
    "choose_tone",
    "packing_density",
    "tone_response",
]

#: Tone samples of a response curve (denser near 0, where the curve is steepest).
_T_SAMPLES = np.concatenate([[0.0], np.linspace(0.0, 1.0, 32)[1:] ** 1.5])
#: Lattice cells per side of a response patch.
_CELLS = 10
#: Jitter of the response patch's hexagonal lattice, as a fraction of the spacing (a
#: relaxed weighted-Voronoi stipple is locally hexagonal with small disorder).
_JITTER = 0.08


def packing_density(max_radius_mm: float, web_mm: float, spacing_factor: float = 1.15) -> float:
    """Holes per mm^2 of the densest stipple (tone 1): hexagonal at ``spacing_factor (2 r1 + web)``.

    Args:
        max_radius_mm: Largest hole radius r1 in mm.
        web_mm: Minimum web between holes in mm.
        spacing_factor: ``stipple.auto_spacing_factor``. Defaults to 1.15.

    Returns:
        Holes per mm^2.
    """
    d = spacing_factor * (2.0 * max_radius_mm + web_mm)
    return 2.0 / (math.sqrt(3.0) * d * d)


@dataclass(frozen=True)
class ToneCurve:
    """Sprayed opacity of the stippler's pattern as a function of its open-area tone.

    Attributes:
        t: ``(K,)`` open-area tone samples in [0, 1], increasing (1 = densest pattern).
        mean: ``(K,)`` mean sprayed opacity at each tone (made non-decreasing).
        var: ``(K,)`` variance of the sprayed opacity over the pattern (its texture).
        spray_time: Spray time A the curve was measured with.
    """

    t: np.ndarray
    mean: np.ndarray
    var: np.ndarray
    spray_time: float

    @property
    def max_opacity(self) -> float:
        """The darkest mean opacity this stencil can spray (at tone 1)."""
        return float(self.mean[-1])

    def opacity(self, t: np.ndarray) -> np.ndarray:
        """Mean sprayed opacity at tone ``t`` (linear interpolation)."""
        return np.interp(np.clip(t, 0.0, 1.0), self.t, self.mean)

    def variance(self, t: np.ndarray) -> np.ndarray:
        """Texture variance of the sprayed opacity at tone ``t``."""
        return np.interp(np.clip(t, 0.0, 1.0), self.t, self.var)

    def inverse(self, alpha: np.ndarray) -> np.ndarray:
        """The tone that sprays mean opacity ``alpha``; 1 where ``alpha`` exceeds :attr:`max_opacity`."""
        # A tiny ramp makes flat (saturated) stretches strictly increasing for np.interp.
        m = self.mean + 1e-9 * np.arange(self.mean.size)
        return np.interp(np.asarray(alpha, dtype=np.float64), m, self.t, left=0.0, right=1.0)

    def errors(self, alpha: np.ndarray, t: np.ndarray) -> np.ndarray:
        """Each pixel's predicted squared error of spraying tone ``t`` for target ``alpha``: bias^2 + texture variance."""
        return (self.opacity(t) - np.asarray(alpha, dtype=np.float64)) ** 2 + self.variance(t)

    def predicted_mse(self, alpha: np.ndarray, t: np.ndarray, weight: np.ndarray | None = None) -> float:
        """Predicted layer MSE of spraying tone ``t`` for target ``alpha``: bias^2 + texture variance.

        With ``weight`` (shaped like ``alpha``) the weighted mean.
        """
        err = self.errors(alpha, t)
        if weight is None:
            return float(np.mean(err))
        total = float(np.sum(weight))
        return float(np.sum(weight * err)) / total if total > 0.0 else float(np.mean(err))


def _hex_patch(spacing: float, width: float, margin: float, rng: np.random.Generator) -> np.ndarray:
    """Jittered hexagonal lattice covering ``[-margin, width + margin]^2``, (N, 2) mm."""
    dy = spacing * math.sqrt(3.0) / 2.0
    ny = int(math.ceil((width + 2 * margin) / dy)) + 2
    nx = int(math.ceil((width + 2 * margin) / spacing)) + 2
    j, i = np.meshgrid(np.arange(ny), np.arange(nx), indexing="ij")
    x = -margin - spacing + i * spacing + (j % 2) * spacing / 2.0
    y = -margin - dy + j * dy
    xy = np.column_stack([x.ravel(), y.ravel()])
    return xy + rng.normal(0.0, _JITTER * spacing, xy.shape)


def _model_key(cfg: SprayConfig) -> str:
    """What the spray response depends on, hashable (the records in ``can`` are left out)."""
    return cfg.model_dump_json(
        exclude={"profile": True, "layer_cans": True, "can": {"fit", "paint", "card_standoff_mm"}}
    )


def _patch_layouts(
    radius_mm: float,
    max_radius_mm: float,
    web_mm: float,
    spacing_factor: float,
    spray_time: float,
    cfg: SprayConfig,
    geometry,
):
    """Each tone sample's response patch: ``(k, xy_mm, r_mm, n_px, px_mm)`` (seeded, so always the same)."""
    reach = sprayer(cfg).kernel_reach(spray_time)
    rho_pack = packing_density(max_radius_mm, web_mm, spacing_factor)
    rng = np.random.default_rng(20150901)
    for k, t in enumerate(_T_SAMPLES):
        if t <= 0.0:
            continue
        r = radius_mm + (max_radius_mm - radius_mm) * math.sqrt(t)
        lam = rho_pack * t * (max_radius_mm / r) ** 2
        spacing = math.sqrt(2.0 / (math.sqrt(3.0) * lam))
        sigma = float(hole_kernels(r, cfg, spray_time, geometry=geometry)[0])
        width = _CELLS * spacing
        px = min(sigma / 2.0, spacing / 4.0)
        n_px = int(math.ceil(width / px))
        px = width / n_px
        # Holes beyond the patch edge up to the fast path's reach, so the patch has no border.
        margin = sigma * reach + spacing
        yield k, _hex_patch(spacing, width, margin, rng), r, n_px, px


@functools.lru_cache(maxsize=16)
def _dose_patches(
    radius_mm: float, max_radius_mm: float, web_mm: float, spacing_factor: float, dose_key: str, geometry
) -> tuple[tuple[int, np.ndarray], ...]:
    """Each tone sample's patch as unit-depth dose, shared by every amount compared (a dose-linear model).

    Kept by ``dose_key`` (:meth:`~.models.Sprayer.unit_dose_settings`), so cans differing only in deposit share them:
    the bundled example's ``stencil-cad run`` measures 5 sets of patches, not 13.

    Under the physical model the dose field does not depend on the passes (nor does a patch's layout:
    the physical hole kernel's width does not), so the calibration's 20-30 candidate doses map one
    set of patches through ``1 - exp(-depth dose)`` instead of spraying the patches again for each: on the example
    the stand-off trials' tone calibration went from about a third of the job's CPU time to a few
    per cent, with the same curves to the last digit.
    """
    cfg = SprayConfig.model_validate_json(dose_key)
    model = sprayer(cfg)
    return tuple(
        (k, model.unit_dose(xy, r, (n_px, n_px), px, cfg, geometry))
        for k, xy, r, n_px, px in _patch_layouts(
            radius_mm, max_radius_mm, web_mm, spacing_factor, 1.0, cfg, geometry
        )
    )


@functools.lru_cache(maxsize=256)
def _response(
    radius_mm: float,
    max_radius_mm: float,
    web_mm: float,
    spacing_factor: float,
    spray_time: float,
    cfg_key: str,
    geometry,
) -> ToneCurve:
    cfg = SprayConfig.model_validate_json(cfg_key)
    mean = np.zeros(_T_SAMPLES.size)
    var = np.zeros(_T_SAMPLES.size)
    model = sprayer(cfg)
    if model.dose_is_linear:
        from .physical import opacity_of_dose

        depth = model.depth(cfg, spray_time)
        dose_key = _model_key(model.unit_dose_settings(cfg))
        for k, dose in _dose_patches(radius_mm, max_radius_mm, web_mm, spacing_factor, dose_key, geometry):
            opacity = opacity_of_dose(dose, depth)
            mean[k] = float(opacity.mean())
            var[k] = float(opacity.var())
    else:
        for k, xy, r, n_px, px in _patch_layouts(
            radius_mm, max_radius_mm, web_mm, spacing_factor, spray_time, cfg, geometry
        ):
            opacity = spray_opacity(xy, r, (n_px, n_px), px, cfg, spray_time=spray_time, geometry=geometry)
            mean[k] = float(opacity.mean())
            var[k] = float(opacity.var())
    mean = np.maximum.accumulate(mean)
    return ToneCurve(t=_T_SAMPLES.copy(), mean=mean, var=var, spray_time=spray_time)


def tone_response(
    radius_mm: float,
    web_mm: float,
    cfg: SprayConfig,
    *,
    spray_time: float | None = None,
    max_radius_mm: float | None = None,
    spacing_factor: float = 1.15,
    geometry=None,
) -> ToneCurve:
    """Measure (once, then cached) the tone response of the stippler's pattern.

    Args:
        radius_mm: Hole radius r0 in mm (the smallest one with variable radius).
        web_mm: Minimum web between holes in mm.
        cfg: Spray settings (h, max_error; A unless ``spray_time`` is given).
        spray_time: Spray time A. Defaults to ``cfg.spray_time``.
        max_radius_mm: Largest hole radius r1 in mm. Defaults to ``radius_mm``.
        spacing_factor: ``stipple.auto_spacing_factor``. Defaults to 1.15.
        geometry: Stand-off and plate thickness (physical model).

    Returns:
        The :class:`ToneCurve`.
    """
    a = cfg.amount if spray_time is None else float(spray_time)
    r1 = radius_mm if max_radius_mm is None else float(max_radius_mm)
    if not cfg.has_wall:
        geometry = None
    return _response(float(radius_mm), r1, float(web_mm), float(spacing_factor), a, _model_key(cfg), geometry)


def calibrated_density(
    alpha: np.ndarray,
    mm_per_px: float,
    radius_mm: float,
    web_mm: float,
    cfg: SprayConfig,
    *,
    spray_time: float | None = None,
    max_radius_mm: float | None = None,
    spacing_factor: float = 1.15,
    geometry=None,
) -> np.ndarray:
    """The stippling density that sprays ``alpha`` (the stippler's ``density=`` hook).

    Args:
        alpha: ``(H, W)`` target opacity in [0, 1].
        mm_per_px: Pixel size of ``alpha`` in mm (the density is per pixel; kept for
            a uniform stage signature).
        radius_mm: Hole radius in mm (smallest radius with variable radius).
        web_mm: Minimum web between holes in mm.
        cfg: Spray settings.
        spray_time: Spray time A. Defaults to ``cfg.spray_time``.
        max_radius_mm: Largest hole radius in mm. Defaults to ``radius_mm``.
        spacing_factor: ``stipple.auto_spacing_factor``. Defaults to 1.15.
        geometry: Stand-off and plate thickness (physical model).

    Returns:
        ``(H, W)`` open-area tone in [0, 1], 1 = the densest pattern the web allows
        (``packing_density`` holes per mm^2 at the largest radius): the stippler's
        ``density`` semantics, so its automatic dot count matches the calibration.
    """
    del mm_per_px
    curve = tone_response(
        radius_mm,
        web_mm,
        cfg,
        spray_time=spray_time,
        max_radius_mm=max_radius_mm,
        spacing_factor=spacing_factor,
        geometry=geometry,
    )
    a = np.clip(np.nan_to_num(np.asarray(alpha, dtype=np.float64)), 0.0, 1.0)
    return curve.inverse(a)


@dataclass(frozen=True)
class ToneChoice:
    """What the tone calibration chose for one layer.

    Attributes:
        density: ``(H, W)`` open-area tone in [0, 1] for the stippler's ``density=`` hook.
        spray_time: Spray time A to simulate (and spray) this layer with.
        n_dots: Dot count the calibration implies (the stippler's automatic count
            for ``density``); pass it as ``n_dots`` when ``stipple.dots`` is set.
        predicted_rmse: Predicted layer RMSE with this choice.
        predicted_rmse_linear: Predicted layer RMSE with the linear tone at ``cfg.spray_time``.
        max_opacity: Darkest mean opacity reachable with this choice.
        curve: The chosen spray response whose inverse gave ``density``, or None when the
            density is the opacity itself (``calibrate: none``).
    """

    density: np.ndarray
    spray_time: float
    n_dots: int
    predicted_rmse: float
    predicted_rmse_linear: float
    max_opacity: float
    curve: ToneCurve | None = None

    def density_of(self, alpha: np.ndarray) -> np.ndarray:
        """The density this choice gives another opacity map (a part of the layer it was made for)."""
        a = np.clip(np.nan_to_num(np.asarray(alpha, dtype=np.float64)), 0.0, 1.0)
        return a if self.curve is None else self.curve.inverse(a)

    def summary(self) -> dict:
        """Plain figures for the manifest."""
        return {
            "spray_time": round(self.spray_time, 4),
            "n_dots": self.n_dots,
            "predicted_rmse": round(self.predicted_rmse, 5),
            "predicted_rmse_linear": round(self.predicted_rmse_linear, 5),
            "max_opacity": round(self.max_opacity, 4),
        }


def _sampled(a: np.ndarray, weight: np.ndarray | None) -> tuple[np.ndarray, np.ndarray | None]:
    """The opacities (and weights) flat, every k-th pixel beyond 200,000.

    Raises:
        ValueError: ``weight`` has another pixel count than ``a``.
    """
    flat = a.ravel()
    w = None if weight is None else np.asarray(weight, dtype=np.float64).ravel()
    if w is not None and w.shape != flat.shape:
        raise ValueError(f"weight has {w.size} pixels, alpha {flat.size}")
    if flat.size > 200_000:
        step = flat.size // 200_000 + 1
        flat = flat[::step]
        w = None if w is None else w[::step]
    return flat, w


def full_coat(cfg: SprayConfig, amount: float) -> float:
    """The opacity an open area gets at a spray amount (passes under the physical model)."""
    return sprayer(cfg).full_coat(cfg, amount)


def _windows_mse(windows, weight, cfg: SprayConfig, amount: float) -> float:
    """The windows' squared opacity error at a full coat, as a share of the whole layer's mean."""
    if windows is None:
        return 0.0
    mask, target = (np.asarray(v) for v in windows)
    if not mask.any():
        return 0.0
    err = (np.asarray(target, dtype=np.float64)[mask] - full_coat(cfg, amount)) ** 2
    if weight is None:
        return float(err.sum()) / mask.size
    w = np.asarray(weight, dtype=np.float64)
    total = float(w.sum())
    return float((w[mask] * err).sum()) / total if total > 0.0 else float(err.sum()) / mask.size


def _spray_time_candidates(mode: Calibrate, cfg: SprayConfig) -> list[float]:
    """The spray times (or passes, under the physical model) the calibrated choice compares."""
    if mode == Calibrate.spray_time:
        return sprayer(cfg).amount_candidates(cfg)
    return [cfg.amount]


def _expected_dots(
    t_eff: np.ndarray, radius_mm: float, r1: float, web_mm: float, spacing_factor: float, mm_per_px: float
) -> int:
    """Holes the stippler will place for open-area fractions ``t_eff``."""
    rho = packing_density(r1, web_mm, spacing_factor)
    # Holes per pixel as the stippler counts them: lambda(t) = rho_pack t (r1 / r(t))^2.
    r_of_t = radius_mm + (r1 - radius_mm) * np.sqrt(t_eff)
    return int(round(rho * float((t_eff * (r1 / r_of_t) ** 2).sum()) * mm_per_px * mm_per_px))


def _unimodal_least(values: list[float], score: Callable[[float], float]) -> float:
    """The first of ``values`` with the least ``score``, for a score unimodal in the index.

    A bisection on the sign of ``score(values[m + 1]) - score(values[m])``: about ``2 log2 n``
    scores instead of ``n``. The layer MSE over the spray-amount grid falls to one minimum and rises after it (every
    layer of the bundled example and of the fidelity benchmark's FDM pictures), so this is the
    full scan's choice. On the example the 16 plate-design layers score at most 10 of the 30
    amounts each, and their choices took 1.4 CPU-s instead of 2.6 (0.5 instead of 1.3 with the
    response curves already measured: those of the amounts never scored are not measured at all;
    medians of 3), about 3 % of the run's CPU time, less than its run-to-run spread.
    """
    memo: dict[int, float] = {}

    def f(i: int) -> float:
        if i not in memo:
            memo[i] = score(values[i])
        return memo[i]

    lo, hi = 0, len(values) - 1
    while lo < hi:
        m = (lo + hi) // 2
        if f(m) <= f(m + 1):
            hi = m
        else:
            lo = m + 1
    return values[lo]


def choose_tone(
    alpha: np.ndarray,
    mm_per_px: float,
    radius_mm: float,
    web_mm: float,
    cfg: SprayConfig,
    *,
    mode: Calibrate | str | None = None,
    max_radius_mm: float | None = None,
    spacing_factor: float = 1.15,
    opacity_threshold: float = 0.0,
    geometry=None,
    weight: np.ndarray | None = None,
    windows: tuple[np.ndarray, np.ndarray] | None = None,
) -> ToneChoice:
    """Choose the density (and, with ``mode=spray_time``, the spray time) of one layer.

    Args:
        alpha: ``(H, W)`` target opacity in [0, 1].
        mm_per_px: Pixel size of ``alpha`` in mm.
        radius_mm: Hole radius in mm (smallest with variable radius).
        web_mm: Minimum web in mm.
        cfg: Spray settings.
        mode: ``none`` (linear density), ``dots`` (calibrated density, both at ``cfg.spray_time``)
            or ``spray_time`` (and the best spray time). Defaults to ``cfg.calibrate``.
        max_radius_mm: Largest hole radius in mm. Defaults to ``radius_mm``.
        spacing_factor: ``stipple.auto_spacing_factor``. Defaults to 1.15.
        opacity_threshold: The stippler puts no hole below this opacity.
        geometry: Stand-off and plate thickness (physical model, whose amount is passes).
        weight: ``(H, W)`` weight of each pixel's error in the spray-time choice (the pipeline
            passes :func:`stencil_cad.model.coat_contrast`); ``None`` weighs all alike.
            ``predicted_rmse`` stays unweighted.
        windows: ``(mask, target)`` of windows spraying a full coat (their error counts), or None.

    Returns:
        The :class:`ToneChoice`.
    """
    mode = Calibrate(cfg.calibrate if mode is None else mode)
    a = np.clip(np.nan_to_num(np.asarray(alpha, dtype=np.float64)), 0.0, 1.0)
    flat, w = _sampled(a, weight)
    ordered = OrderedOpacities.of(flat, w, opacity_threshold)
    r1 = radius_mm if max_radius_mm is None else float(max_radius_mm)
    curve = functools.partial(
        tone_response,
        radius_mm,
        web_mm,
        cfg,
        max_radius_mm=r1,
        spacing_factor=spacing_factor,
        geometry=geometry,
    )

    def score(amount: float) -> float:
        c = curve(spray_time=amount)
        mse = ordered.mse(c, c.inverse(ordered.alpha), weighted=True)
        return mse + _windows_mse(windows, weight, cfg, amount)

    base = curve(spray_time=cfg.amount)
    linear_mse = ordered.mse(base, ordered.alpha)
    chosen: ToneCurve | None = None
    if mode == Calibrate.none:
        best_a, best_curve, best_mse, density = cfg.amount, base, linear_mse, a
    else:
        best_a = _unimodal_least(_spray_time_candidates(mode, cfg), score)
        chosen = best_curve = curve(spray_time=best_a)
        best_mse = ordered.mse(best_curve, best_curve.inverse(ordered.alpha))
        density = best_curve.inverse(a)
    t_eff = np.where(a >= opacity_threshold, density, 0.0)
    n_dots = _expected_dots(t_eff, radius_mm, r1, web_mm, spacing_factor, mm_per_px)
    return ToneChoice(
        density=density,
        spray_time=float(best_a),
        n_dots=n_dots,
        predicted_rmse=math.sqrt(best_mse),
        predicted_rmse_linear=math.sqrt(linear_mse),
        max_opacity=best_curve.max_opacity,
        curve=chosen,
    )


def plate_response(job_cfg: JobConfig, amount: float) -> ToneCurve:
    """The tone response of a job's plates at ``amount`` (passes, or the paper model's spray time).

    The stippler's pattern with holes up to the refinement's largest radius when it is on (the
    stippler's otherwise), at the job's web, spacing and stand-off: what the dark-end figures and
    the decomposition's plate reach measure the darkest sprayable tone and the pattern with.
    """
    from .physical import SprayGeometry

    sizes = job_cfg.stipple.sizes
    r1 = job_cfg.refined_max_radius_mm if job_cfg.refine.enabled else sizes.max_radius_mm
    return tone_response(
        sizes.radius_mm,
        sizes.web_mm,
        job_cfg.spray,
        spray_time=amount,
        max_radius_mm=r1,
        spacing_factor=job_cfg.stipple.auto_spacing_factor,
        geometry=SprayGeometry.for_job(job_cfg),
    )


def response_tone_for(
    alpha: np.ndarray, mm_per_px: float, job_cfg, weight: np.ndarray | None = None, windows=None
) -> ToneChoice:
    """:func:`choose_tone` with the hole sizes, web and spacing of a whole job config.

    Args:
        alpha: ``(H, W)`` target opacity in [0, 1].
        mm_per_px: Pixel size of ``alpha`` in mm.
        job_cfg: The :class:`~stencil_cad.config.JobConfig` (``stipple`` and ``spray``).
        weight: Per-pixel weight of the spray-time choice (see :func:`choose_tone`).
        windows: ``(mask, target)`` of a hybrid plate's windows (see :func:`choose_tone`), or None.

    Returns:
        The :class:`ToneChoice` (density, spray time, dot count).
    """
    from .physical import SprayGeometry

    st = job_cfg.stipple
    sizes = st.sizes
    return choose_tone(
        alpha,
        mm_per_px,
        sizes.radius_mm,
        sizes.web_mm,
        job_cfg.spray,
        max_radius_mm=sizes.max_radius_mm,
        spacing_factor=st.auto_spacing_factor,
        opacity_threshold=st.opacity_threshold,
        geometry=SprayGeometry.of_job(job_cfg),
        weight=weight,
        windows=windows,
    )


def calibrated_density_for(alpha: np.ndarray, mm_per_px: float, job_cfg) -> np.ndarray:
    """The calibrated density of one layer for a job config (the pipeline's ``density=`` hook).

    Args:
        alpha: ``(H, W)`` target opacity in [0, 1].
        mm_per_px: Pixel size of ``alpha`` in mm.
        job_cfg: The :class:`~stencil_cad.config.JobConfig`.

    Returns:
        ``(H, W)`` open-area tone in [0, 1]. With ``spray.calibrate: spray_time`` the
        matching spray time is in :func:`response_tone_for`'s result.
    """
    return response_tone_for(alpha, mm_per_px, job_cfg).density
