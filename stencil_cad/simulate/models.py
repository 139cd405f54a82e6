"""The spray models behind one interface: what each does where the code once asked which model it was.

A spray model is one :class:`Sprayer` subclass and one entry of :data:`SPRAYERS`, the one map from
``spray.model`` (:class:`~stencil_cad.config.spray.SprayModel`) to the code that sprays;
:func:`sprayer` looks a job's up. What a model means for the settings (its amount's field and
unit, whether it sees the wall, whether it sprays a can) is its row of
:data:`stencil_cad.config.spray.MODEL_TERMS`, which the config layer reads too.

Two models: :class:`PaperSprayer`, Vavilala & Forsyth's (:mod:`.paper`: each hole a Gaussian of
spray time ``A``), and :class:`PhysicalSprayer`, the maker's units (:mod:`.physical`: stand-off, can
distance, passes; its dose is linear in the passes).
"""

from __future__ import annotations

import logging
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from ..config.spray import CanConstants, SprayConfig, SprayModel
from . import paper, physical

if TYPE_CHECKING:
    from ..config.job import JobConfig
    from .physical import SprayGeometry

log = logging.getLogger(__name__)

__all__ = ["SPRAYERS", "PaperSprayer", "PhysicalSprayer", "Sprayer", "need_geometry", "sprayer"]

#: ``(sigma_mm, peak, dsigma_dr, dpeak_dr, combine)``: every hole's deposit as one Gaussian.
Kernels = tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, str]


def need_geometry(geometry: SprayGeometry | None) -> SprayGeometry:
    """The plate's geometry, which a model that sees the wall needs.

    Raises:
        ValueError: ``geometry`` is None.
    """
    if geometry is None:
        raise ValueError("spray.model physical needs the plate's geometry (stand-off and thickness)")
    return geometry


class Sprayer:
    """How one spray model sprays: the operations the simulator, the calibration and the stages ask of it.

    Amounts are in the model's unit (:attr:`stencil_cad.config.spray.SprayConfig.amount_unit`);
    ``geometry`` is the plate's :class:`~stencil_cad.simulate.physical.SprayGeometry`, None where
    the model does not see the wall.
    """

    #: Whether the opacity is ``1 - exp(-depth(amount) * unit_dose)``: one sprayed dose field then
    #: serves every amount (the tone calibration compares 20-30 of them).
    dose_is_linear: bool = False

    def opacity(
        self,
        xy_mm: np.ndarray,
        r_mm: np.ndarray | float,
        shape_hw: tuple[int, int],
        mm_per_px: float,
        cfg: SprayConfig,
        amount: float,
        *,
        geometry: SprayGeometry | None = None,
        exact: bool = False,
        crop: tuple[int, int, int, int] | None = None,
        tail_tol: float | None = None,
    ) -> np.ndarray:
        """The opacity a stencil's holes spray (:func:`stencil_cad.simulate.opacity.spray_opacity`)."""
        raise NotImplementedError

    def mask_opacity(
        self,
        mask: np.ndarray,
        mm_per_px: float,
        cfg: SprayConfig,
        amount: float,
        *,
        geometry: SprayGeometry | None = None,
        reference_radius_mm: float | None = None,
    ) -> np.ndarray:
        """The opacity a cut-out sprays, given as a raster of its open area (:func:`~.opacity.spray_mask`)."""
        raise NotImplementedError

    def hole_kernels(
        self, r: np.ndarray, cfg: SprayConfig, amount: float, geometry: SprayGeometry | None
    ) -> Kernels:
        """Every hole's deposit as one Gaussian, for refinement (:func:`stencil_cad.simulate.spray.hole_kernels`)."""
        raise NotImplementedError

    def blur_mm(self, r_mm: float, cfg: SprayConfig, geometry: SprayGeometry | None) -> float:
        """The blur (sigma, mm) of a hole of radius ``r_mm`` at the base amount: the scale a layer is scored at."""
        raise NotImplementedError

    def check(self, cfg: SprayConfig, amount: float) -> None:
        """Refuse an amount the model cannot spray, for a layer without holes. Nothing to check by default."""

    def check_scale(self, r_min_mm: float | None, cfg: SprayConfig, grid_mm: float, geometry) -> None:
        """Refuse (or warn about) a simulation this model cannot make on a grid of ``grid_mm`` per pixel."""

    def info(self, cfg: SprayConfig, geometry: SprayGeometry | None) -> dict[str, Any]:
        """The figures a simulation records of the model (the manifest's ``simulate`` section)."""
        raise NotImplementedError

    def kernel_reach(self, amount: float) -> float:
        """How many sigmas past a hole its paint reaches on the fast path: a response patch's margin."""
        raise NotImplementedError

    def unit_dose(
        self,
        xy_mm: np.ndarray,
        r_mm: np.ndarray | float,
        shape_hw: tuple[int, int],
        mm_per_px: float,
        cfg: SprayConfig,
        geometry: SprayGeometry | None,
    ) -> np.ndarray:
        """The dose field of one unit of depth, where :attr:`dose_is_linear`."""
        raise NotImplementedError(f"{type(self).__name__}: the dose is not linear in the amount")

    def depth(self, cfg: SprayConfig, amount: float) -> float:
        """The optical depth ``amount`` gives :meth:`unit_dose`'s field, where :attr:`dose_is_linear`."""
        raise NotImplementedError(f"{type(self).__name__}: the dose is not linear in the amount")

    def unit_dose_settings(self, cfg: SprayConfig) -> SprayConfig:
        """``cfg`` less what only scales :meth:`depth`, where :attr:`dose_is_linear`: what a unit dose is kept by."""
        raise NotImplementedError(f"{type(self).__name__}: the dose is not linear in the amount")

    def full_coat(self, cfg: SprayConfig, amount: float) -> float:
        """The opacity an open area gets at ``amount`` (a window, a cut-out's inside)."""
        raise NotImplementedError

    def amount_candidates(self, cfg: SprayConfig) -> list[float]:
        """The amounts ``spray.calibrate: spray_time`` compares for a layer."""
        raise NotImplementedError

    def reach_amount(self, cfg: SprayConfig) -> float:
        """The amount a plate's reach (its darkest tone, its windows' coat) is measured at."""
        raise NotImplementedError

    def for_cutouts(self, cfg: SprayConfig) -> SprayConfig:
        """The settings a hard stencil's cut-outs are sprayed with. These settings by default."""
        return cfg

    def rough_blur_mm(self, job_cfg: JobConfig) -> float:
        """A hole's blur (sigma, mm) at a glance, before any hole is placed: the studio's first preview."""
        raise NotImplementedError

    def widest_blur_mm(self, job_cfg: JobConfig) -> float | None:
        """The widest blur (sigma, mm) any layer's hole gets under the tallest wall; None without one blur."""
        return None

    def halo_mm(self, job_cfg: JobConfig, tail: float) -> float:
        """How far past a hole's centre its spray reaches, in mm (a mural tile's halo)."""
        raise NotImplementedError


class PaperSprayer(Sprayer):
    """The paper's model (:mod:`.paper`): a Gaussian of spray time ``A`` per hole, no wall, no can."""

    def opacity(
        self,
        xy_mm,
        r_mm,
        shape_hw,
        mm_per_px,
        cfg,
        amount,
        *,
        geometry=None,
        exact=False,
        crop=None,
        tail_tol=None,
    ) -> np.ndarray:
        """The holes' opacity (:meth:`Sprayer.opacity`)."""
        return paper.paper_opacity(
            xy_mm, r_mm, shape_hw, mm_per_px, cfg, amount, exact=exact, crop=crop, tail_tol=tail_tol
        )

    def mask_opacity(
        self, mask, mm_per_px, cfg, amount, *, geometry=None, reference_radius_mm=None
    ) -> np.ndarray:
        """A cut-out's opacity (:meth:`Sprayer.mask_opacity`)."""
        return paper.paper_mask_opacity(mask, mm_per_px, cfg, amount, reference_radius_mm)

    def hole_kernels(self, r, cfg, amount, geometry) -> Kernels:
        """Every hole's Gaussian (:meth:`Sprayer.hole_kernels`)."""
        return (*paper.paper_hole_kernels(r, cfg, amount), "product")

    def blur_mm(self, r_mm, cfg, geometry) -> float:
        """The dot's sigma, ``r sqrt(1 + h) / 2`` (:func:`.paper.dot_sigma_mm`)."""
        return float(paper.dot_sigma_mm(r_mm, cfg.nozzle_height))

    def check(self, cfg, amount) -> None:
        """Refuse a spray time or nozzle height out of range."""
        paper._check_params(amount, cfg.nozzle_height)

    def check_scale(self, r_min_mm, cfg, grid_mm, geometry) -> None:
        """Warn when the smallest hole's dot is under half a pixel."""
        if r_min_mm is not None and paper.dot_sigma_mm(r_min_mm, cfg.nozzle_height) < 0.5 * grid_mm:
            log.warning(
                "spray dots (sigma %.3f mm) are under half a simulation pixel (%.3f mm): raise spray.px_per_mm",
                float(paper.dot_sigma_mm(r_min_mm, cfg.nozzle_height)),
                grid_mm,
            )

    def info(self, cfg, geometry) -> dict[str, Any]:
        """The nozzle height."""
        return {"nozzle_height": cfg.nozzle_height}

    def kernel_reach(self, amount) -> float:
        """Out to where the Gaussian of the largest of ``A`` and 1 falls to 1e-6."""
        return math.sqrt(2.0 * math.log(max(amount, 1.0) * 1e6))

    def full_coat(self, cfg, amount) -> float:
        """``1 - exp(-A (1 + h) / 2)``: an open area is a field of tiny holes (:func:`~.opacity.spray_mask`)."""
        return float(-math.expm1(-amount * (1.0 + cfg.nozzle_height) / 2.0))

    def amount_candidates(self, cfg) -> list[float]:
        """The spray times ``calibrate: spray_time`` compares (:func:`.paper.spray_time_candidates`)."""
        return paper.spray_time_candidates(cfg)

    def reach_amount(self, cfg) -> float:
        """The base spray time."""
        return cfg.amount

    def rough_blur_mm(self, job_cfg) -> float:
        """The dot of the stippler's smallest hole."""
        return float(paper.dot_sigma_mm(job_cfg.stipple.sizes.radius_mm, job_cfg.spray.nozzle_height))

    def halo_mm(self, job_cfg, tail) -> float:
        """Where the largest hole's Gaussian at the largest spray time the calibration may choose falls to ``tail``."""
        sp = job_cfg.spray
        a = sp.spray_time
        if job_cfg.chooses_spray_time:
            a = min(100.0, a * max(paper.A_FACTORS))
        sigma = float(paper.dot_sigma_mm(job_cfg.stipple.sizes.max_radius_mm, sp.nozzle_height))
        return sigma * math.sqrt(2.0 * math.log(max(a, 1.0) / tail))


class PhysicalSprayer(Sprayer):
    """The physical model (:mod:`.physical`): stand-off, can distance and passes; it needs the plate's geometry."""

    dose_is_linear = True

    def opacity(
        self,
        xy_mm,
        r_mm,
        shape_hw,
        mm_per_px,
        cfg,
        amount,
        *,
        geometry=None,
        exact=False,
        crop=None,
        tail_tol=None,
    ) -> np.ndarray:
        """The holes' opacity (:meth:`Sprayer.opacity`)."""
        return physical.physical_opacity(
            xy_mm, r_mm, shape_hw, mm_per_px, cfg, need_geometry(geometry), amount, exact=exact, crop=crop
        )

    def mask_opacity(
        self, mask, mm_per_px, cfg, amount, *, geometry=None, reference_radius_mm=None
    ) -> np.ndarray:
        """A cut-out's opacity (:meth:`Sprayer.mask_opacity`)."""
        return physical.physical_mask_opacity(mask, mm_per_px, cfg, need_geometry(geometry), amount)

    def hole_kernels(self, r, cfg, amount, geometry) -> Kernels:
        """Every hole's Gaussian (:meth:`Sprayer.hole_kernels`)."""
        return (*physical.physical_hole_kernels(r, cfg, float(amount), need_geometry(geometry)), "exp")

    def blur_mm(self, r_mm, cfg, geometry) -> float:
        """The sigma of the hole's Gaussian at the base passes (:meth:`Sprayer.blur_mm`)."""
        sigma, *_ = self.hole_kernels(
            np.asarray(r_mm, dtype=np.float64), cfg, cfg.amount, need_geometry(geometry)
        )
        return float(sigma)

    def check_scale(self, r_min_mm, cfg, grid_mm, geometry) -> None:
        """Require the plate's geometry."""
        need_geometry(geometry)

    def info(self, cfg, geometry) -> dict[str, Any]:
        """The model's name and the stand-off."""
        return {"model": "physical", "standoff_mm": need_geometry(geometry).standoff_mm}

    def kernel_reach(self, amount) -> float:
        """Five sigmas, as the physical splat."""
        return 5.0

    def unit_dose(self, xy_mm, r_mm, shape_hw, mm_per_px, cfg, geometry) -> np.ndarray:
        """The dose field of one unit of depth (:func:`.physical.physical_dose`)."""
        return physical.physical_dose(xy_mm, r_mm, shape_hw, mm_per_px, cfg, geometry)

    def depth(self, cfg, amount) -> float:
        """``passes * dose_per_pass``.

        Raises:
            ValueError: ``amount`` is not above 0.
        """
        if not amount > 0.0:
            raise ValueError(f"passes must be > 0, got {amount}")
        return amount * physical.dose_per_pass(cfg)

    def unit_dose_settings(self, cfg) -> SprayConfig:
        """``cfg`` with a can of its spread and bleed alone (:meth:`Sprayer.unit_dose_settings`).

        The unit dose and the holes' blur read only these of the can; its deposit, distance and speed
        scale the depth. The paints of the bundled example differ only in their deposit, so their layers
        share one set of tone-response patches per stand-off and hole size.
        """
        can = CanConstants(spread_k=cfg.can.spread_k, bleed_sigma_mm=cfg.can.bleed_sigma_mm)
        return cfg.model_copy(update={"can": can})

    def full_coat(self, cfg, amount) -> float:
        """``1 - exp(-passes * dose_per_pass)``."""
        return float(-math.expm1(-amount * cfg.dose_per_pass))

    def amount_candidates(self, cfg) -> list[float]:
        """The doses a hand sprays as whole passes at a pace it can vary (:meth:`SprayConfig.doses`)."""
        return cfg.doses()

    def reach_amount(self, cfg) -> float:
        """``spray.max_passes``: a plate is designed to reach its darkest tone within them."""
        return float(cfg.max_passes)

    def for_cutouts(self, cfg) -> SprayConfig:
        """Whole passes enough for full cover (:meth:`SprayConfig.full_cover_passes`)."""
        return cfg.model_copy(update={"passes": float(cfg.full_cover_passes())})

    def rough_blur_mm(self, job_cfg) -> float:
        """The can's spread times the design stand-off."""
        return float(job_cfg.spray.can.spread_k) * job_cfg.standoff.design_mm

    def widest_blur_mm(self, job_cfg) -> float:
        """The widest of every layer's can (each paint may have its own profile) under the tallest wall."""
        sp = job_cfg.spray
        h = max(job_cfg.standoff.walls_mm)
        return max(physical.spread_sigma_mm(sp.model_copy(update={"can": c}), h) for c in sp.all_cans())

    def halo_mm(self, job_cfg, tail) -> float:
        """Five sigmas of the widest blur past the largest hole's edge, and a millimetre (``tail`` unused)."""
        return float(5.0 * self.widest_blur_mm(job_cfg) + job_cfg.stipple.sizes.max_radius_mm + 1.0)


#: The one map from ``spray.model`` to the code that sprays. A new model is a class above and its entry here
#: (with its member of :class:`SprayModel`, its fields and its row of ``MODEL_TERMS`` in the config).
SPRAYERS: dict[SprayModel, Sprayer] = {
    SprayModel.paper: PaperSprayer(),
    SprayModel.physical: PhysicalSprayer(),
}


def sprayer(cfg: SprayConfig) -> Sprayer:
    """The spray model of these settings (``cfg.model``'s entry of :data:`SPRAYERS`)."""
    return SPRAYERS[cfg.model]
