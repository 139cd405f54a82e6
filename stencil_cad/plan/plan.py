"""The job's plan: every decision the job makes for itself, made once, frozen, passed to the stages.

The maker's config (:attr:`stencil_cad.record.Run.cfg`) is kept as given. What the job decides
beyond it is made by the functions here, each returning a new :class:`Plan` and changing nothing,
in the order the orchestrator (:mod:`stencil_cad.pipeline.run`) calls them:

1. before any work, from the picture's size: the plate values the maker left null (the label, the
   tiles' margin, then for the plates the tiling plans the thickness and a one-layer plate's web;
   the config keeps them null, :mod:`stencil_cad.config.job` says what a job fills in) and the tiling
   (:func:`planned`, recording how in :attr:`Plan.fills`), and the most holes that fit (:func:`capped`);
2. before the decomposition, from the picture: a mostly dark picture's primer (:func:`primed`);
3. after the decomposition, from the layers: each layer's spray settings (:func:`painted`; hard
   mode after the segmentation), then the plate design the trials choose, windows and the wall's
   stand-off, with the thickness that wall asks for (:func:`designed`, called with
   :func:`stencil_cad.pipeline.standoff.stage_standoff`'s choice; its sprays fit its design).

The stages after the design (stipple, refine, build, simulate, cost, the manifest) take the last
plan as an argument and read its :attr:`Plan.cfg`: the config with every decision filled in. The
figures that say why (``plate``, ``standoff``, ``decompose.solver.primer_rule``) stay in the run's
figures; the plan holds the plate figures so the orchestrator records the ones it keeps.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, Any

import numpy as np

from .. import mural
from ..figures import MuralFigures, PlateFigures
from ..model import Picture
from .profiles import Paints

if TYPE_CHECKING:
    from collections.abc import Callable, Mapping, Sequence

    from ..config.job import JobConfig
    from ..config.spray import SprayConfig
    from ..config.thickness import Thickness

__all__ = [
    "Fills",
    "Plan",
    "capped",
    "designed",
    "labelled",
    "painted",
    "plate_figures",
    "planned",
    "primed",
    "refilled",
    "repainted",
    "unplanned",
    "whole",
    "with_design",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Fills:
    """What the plan filled in of the plate values the maker's config left null, and why.

    The config keeps them null (:mod:`stencil_cad.config.job`: :func:`~stencil_cad.config.job.job_margin`,
    :func:`~stencil_cad.config.job.job_thickness`, :func:`~stencil_cad.config.job.job_web` say what a job
    fills in); the plan's config has them filled, and this record says how, so a decision taken later
    (a lower wall, :func:`designed`) fits them again.

    Attributes:
        thickness: The plate's thickness and why: filled in for the plates the tiling plans (its side
            and sag), or as the maker gave it.
        web_left: Whether the maker left ``stipple.web_mm`` null: the web follows the thickness (a
            plate of one layer takes a wider one, :func:`stencil_cad.config.job.job_web`).
    """

    thickness: Thickness
    web_left: bool


@dataclass(frozen=True)
class Plan:
    """What the job decided before the stages that read it, frozen.

    Attributes:
        cfg: The config with every decision made so far filled in (thickness, the holes' cap, the
            primer, the plate design); the stages read their settings here, never the maker's.
        grid: The tiling every stage takes (a one-plate job is a 1 × 1 tiling).
        picture_mm: The picture's ``(width, height)`` in mm.
        plate: The plate thickness and why (figure ``plate``), or None where the job does not
            record one (the plate-design trials, tests).
        primer: The primer the job chose for a mostly dark picture (``#rrggbb``), or None: the config's.
        paints: The layers' paints and each layer's spray settings (:func:`painted`), or None
            before the plan knows them.
        fills: The plate values the plan filled in and why (:func:`planned`), or None where the
            config is taken as it is (:func:`whole`: the plate-design trials, tests).
    """

    cfg: JobConfig
    grid: mural.TileGrid
    picture_mm: tuple[float, float]
    plate: PlateFigures | None = None
    primer: str | None = None
    paints: Paints | None = None
    fills: Fills | None = None

    @property
    def sprays(self) -> list[SprayConfig]:
        """Each layer's spray settings, in spray order (:func:`painted`).

        Raises:
            ValueError: The plan does not know its paints yet, or its config sprays otherwise than
                the settings were resolved for (a plan changed without :func:`repainted`).
        """
        if self.paints is None:
            raise ValueError("the plan does not know its layers' paints yet: plan them with painted()")
        if self.paints.spray != self.cfg.spray:
            raise ValueError(
                "the plan's spray settings were resolved for another spray section: use repainted()"
            )
        return list(self.paints.sprays)


def whole(cfg: JobConfig, picture_mm: tuple[float, float], paints: Paints | None = None) -> Plan:
    """A one-plate plan of ``cfg`` as it is (nothing decided): the plate-design trials' and a test's.

    ``paints``: the layers' paints a job's plan knows (resolved again for ``cfg``), or None.
    """
    plan = Plan(cfg, mural.TileGrid.whole(*picture_mm), picture_mm, paints=paints)
    return repainted(plan)


def planned(cfg: JobConfig, picture_mm: tuple[float, float], work_px: int) -> tuple[Plan, MuralFigures]:
    """The plan before any work: the tiling for the bed and the plate values it asks for.

    What the maker left null for the job is filled in here, in order: the label
    (:func:`labelled`), the tiles' margin (:func:`stencil_cad.config.job.job_margin`: the tiling
    follows it), then, for the plates the tiling plans, the plate's thickness and the one-layer web
    (:func:`stencil_cad.config.job.filled`; :attr:`Plan.fills` says how, figure ``plate`` why).

    Args:
        cfg: The maker's config.
        picture_mm: The picture's ``(width, height)`` in mm.
        work_px: Pixels of the working picture (the plan's cost estimate).

    Returns:
        ``(plan, figures)``: the plan and the tiling's figures for the manifest (``mural``).

    Raises:
        UserError: A part cannot fit the bed.
    """
    from ..config.job import with_margin
    from ..mural.posts import sag_side_mm
    from .tiles import plan as plan_tiles

    cfg = with_margin(labelled(cfg))
    grid, fig = plan_tiles(cfg, *picture_mm, work_px)
    side = sag_side_mm(grid, cfg)
    fitted, fills = _filled(cfg, side)
    return Plan(fitted, grid, picture_mm, plate_figures(fills.thickness, side), fills=fills), fig


def _filled(cfg: JobConfig, side_mm: float) -> tuple[JobConfig, Fills]:
    """``cfg`` (its margin filled in) with the thickness and web filled for plates of sag side ``side_mm``, and how."""
    from ..config.job import filled

    fitted, thickness = filled(cfg, side_mm)
    return fitted, Fills(thickness, cfg.stipple.web_mm is None)


def refilled(plan: Plan, cfg: JobConfig) -> Plan:
    """``plan`` with a maker's config ``cfg``, its plate values filled in for the plan's tiling as :func:`planned` fills them.

    The label stays as ``cfg`` has it. The preview's plate-design trials run the job's own config on
    the preview's tiling with it.
    """
    from ..config.job import with_margin
    from ..mural.posts import sag_side_mm

    cfg = with_margin(cfg)
    fitted, fills = _filled(cfg, sag_side_mm(plan.grid, cfg))
    return replace(plan, cfg=fitted, fills=fills)


def unplanned(cfg: JobConfig) -> JobConfig:
    """``cfg`` with every plate value its maker left null filled in as the config alone can tell, no tiling planned.

    The label (:func:`labelled`), the tiles' margin, and the thickness for the plate's longest side
    as the config knows it (:func:`stencil_cad.config.job.guessed_side_mm`) with the web that follows
    it. For the commands that plan no tiling: the calibration card, a plate template's check, the
    ``decompose`` command's saved config; a job plans its plates (:func:`planned`).
    """
    from ..config.job import filled

    return filled(labelled(cfg))[0]


def labelled(cfg: JobConfig) -> JobConfig:
    """``cfg`` with ``plate.label`` left null filled in as its job makes it (:func:`stencil_cad.config.job.job_label`).

    Raised on a soft FDM mural's plates, engraved otherwise; a label the maker gave is kept (the same
    config comes back). Every command that builds a plate or writes the resolved config calls it (through
    :func:`planned`, or itself where it plans no tiling: the card, a plate template's check).
    """
    from ..config.job import job_label

    if cfg.plate.label is not None:
        return cfg
    return cfg.model_copy(update={"plate": cfg.plate.model_copy(update={"label": job_label(cfg)})})


def plate_figures(fill: Thickness, side_mm: float) -> PlateFigures:
    """Figure ``plate``: the plate's thickness and why (:attr:`Fills.thickness`), for plates of longest side ``side_mm``."""
    return PlateFigures(
        thickness_mm=fill.thickness_mm,
        filled=fill.filled,
        side_mm=round(side_mm, 1),
        sag_mm=round(fill.sag_mm, 3) if fill.filled else None,
        thickness_reason=fill.reason,
    )


def capped(plan: Plan) -> Plan:
    """``plan`` with ``stipple.dots`` capped at the most holes that fit the picture under the design rules.

    Too many dots cost memory and time in the relaxation and are then removed by the rules anyway;
    the cap is named in a warning. The same plan when the config's count fits (or it has none).
    """
    from ..bounds import max_dots

    cfg = plan.cfg
    if cfg.stipple.dots is None:
        return plan
    most = max_dots(cfg.stipple, *plan.picture_mm)
    if cfg.stipple.dots <= most:
        return plan
    log.warning(
        "stipple.dots %d cannot fit: at most %d holes of radius %g mm with %g mm webs fit in %.4g × %.4g mm; "
        "using %d (set stipple.dots ≤ %d, or null to derive it from the picture)",
        cfg.stipple.dots,
        most,
        cfg.stipple.hole_floor_mm,
        cfg.stipple.sizes.web_mm,
        plan.picture_mm[0],
        plan.picture_mm[1],
        most,
        most,
    )
    stipple = cfg.stipple.model_copy(update={"dots": most})
    return replace(plan, cfg=cfg.model_copy(update={"stipple": stipple}))


def primed(plan: Plan, picture: Picture) -> Plan:
    """``plan`` with a mostly dark picture's dark colour as its primer (:func:`stencil_cad.plan.primer.dark_primed`)."""
    from .primer import dark_primed

    cfg, primer = dark_primed(plan.cfg, picture)
    return plan if primer is None else replace(plan, cfg=cfg, primer=primer)


def designed(plan: Plan, windows: str, standoff_mm: float) -> Plan:
    """``plan`` with its plates' windows and its wall's stand-off (:func:`with_design`).

    A filled-in thickness chosen again for a lower wall gives figure ``plate`` anew (same side).
    """
    cfg, fills = _design(plan, windows, standoff_mm)
    if cfg is plan.cfg:
        return plan
    plate = plan.plate
    if plate is not None and fills is not None and plate.thickness_mm != cfg.plate.thickness_mm:
        plate = plate_figures(fills.thickness, plate.side_mm)
    # The design's sprays: resolved again should the design spray otherwise.
    return repainted(replace(plan, cfg=cfg, plate=plate, fills=fills))


def with_design(plan: Plan, windows: str, standoff_mm: float) -> JobConfig:
    """``plan``'s config with its plates' windows and its wall's stand-off set (the stand-off still marked as the job's).

    A plate thickness the plan filled in (:attr:`Plan.fills`) is chosen again for a wall lower than
    the process's: the plate may sag only a share of its stand-off (:mod:`stencil_cad.config.thickness`).
    """
    return _design(plan, windows, standoff_mm)[0]


def _design(plan: Plan, windows: str, standoff_mm: float) -> tuple[JobConfig, Fills | None]:
    """``(config, fills)`` of :func:`with_design`: the config and how its plate values were filled in."""
    from ..config.job import job_thickness, with_thickness
    from ..config.stipple import Windows

    cfg, fills = plan.cfg, plan.fills
    if windows != cfg.stipple.windows.value:
        cfg = cfg.model_copy(update={"stipple": cfg.stipple.model_copy(update={"windows": Windows(windows)})})
    if standoff_mm == cfg.standoff.design_mm:
        return cfg, fills
    cfg = cfg.with_standoff(standoff_mm)
    if fills is None or not fills.thickness.filled:
        return cfg, fills
    left = cfg.model_copy(update={"plate": cfg.plate.model_copy(update={"thickness_mm": None})})
    thickness = job_thickness(left, fills.thickness.side_mm, standoff_mm)
    return with_thickness(cfg, thickness, fills.web_left), replace(fills, thickness=thickness)


def painted(
    plan: Plan,
    colours: np.ndarray | Sequence[Any],
    names: Mapping[str, str] | None = None,
    each: Callable[[SprayConfig], SprayConfig] | None = None,
) -> Plan:
    """``plan`` with its layers' paints and each layer's spray settings (:func:`stencil_cad.plan.profiles.paints_of`).

    Called once the paints are known: after the decomposition (hard mode: the segmentation).

    Args:
        plan: The plan.
        colours: ``(L, 3)`` the layers' paints in [0, 1], in spray order.
        names: ``{hex: can label}`` of the cans the job knows (:func:`stencil_cad.plan.cans.can_names`).
        each: Applied to every layer's settings but the config's own (hard mode's cut-outs), or None.

    Raises:
        ConfigError: A key of ``spray.profile`` names no layer, or two keys name one.
    """
    from .profiles import paints_of

    return replace(plan, paints=paints_of(plan.cfg, colours, names, each))


def repainted(plan: Plan) -> Plan:
    """``plan`` with its paints' spray settings resolved again for its config: the same plan when they fit (or it has none)."""
    paints = plan.paints
    if paints is None or paints.spray == plan.cfg.spray:
        return plan
    return painted(plan, np.asarray(paints.colours, dtype=np.float64), paints.names, paints.each)
