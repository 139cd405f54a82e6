"""The job's settings the sheet reads, typed: read once from the config the manifest records.

The sheet is made from a run's figures or from a manifest on disk; both carry the resolved config
as the manifest writes it (``JobConfig.model_dump(mode="json")``), so :meth:`JobSettings.from_json`
is the one place that reads it. A key a config leaves out (a hand-written manifest's) takes the
default the sheet has always assumed.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from ..config.bed import Bed, resolve_bed
from ..config.spray import SprayModel

if TYPE_CHECKING:
    from ..config import JobConfig

__all__ = ["JobSettings"]


def _at(cfg: Mapping[str, Any], section: str, key: str, default: Any = None) -> Any:
    """``cfg[section][key]``, or ``default`` when either is missing."""
    part = cfg.get(section)
    return part[key] if isinstance(part, Mapping) and key in part else default


def _bed(value: Any) -> Bed | None:
    try:
        return resolve_bed(value)
    except (ValueError, TypeError, KeyError):
        return None


@dataclass(frozen=True)
class JobSettings:
    """What the sheet needs of the job's config.

    Attributes:
        name: The job's name.
        mode: ``soft`` or ``hard``.
        view_distance_m: The viewing distance the quality is scored at, m (None: not given).
        web_mm: The web rule between holes, mm (None: the process's preset).
        spray_model: ``physical`` or ``paper``.
        nozzle_height: The paper model's nozzle height (None: not given).
        can_distance_mm: How far the can is held from the plate, mm.
        pass_speed_m_s: How fast the can sweeps, m/s.
        coverage_m2_per_can: The can's coverage, m² per can.
        can_ml: The can's volume, ml.
        process: How plates are made: ``fdm``, ``sla`` or ``laser``.
        thickness_mm: The plate thickness, mm (None: not given).
        kerf_mm: The laser kerf the cut files compensate, mm.
        bed: The bed the job was sized for (None: none given, or not one the tool knows).
    """

    name: str = "stencil"
    mode: str = "soft"
    view_distance_m: float | None = None
    web_mm: float | None = None
    spray_model: str = "physical"
    nozzle_height: float | None = None
    can_distance_mm: float = 200.0
    pass_speed_m_s: float = 0.5
    coverage_m2_per_can: float = 1.5
    can_ml: float = 400.0
    process: str = "fdm"
    thickness_mm: float | None = None
    kerf_mm: float = 0.0
    bed: Bed | None = None

    @classmethod
    def from_json(cls, cfg: Mapping[str, Any] | None) -> JobSettings:
        """The settings from the manifest's ``config`` (missing keys: the defaults above)."""
        cfg = cfg or {}
        return cls(
            name=str(cfg.get("name", "stencil")),
            mode=str(cfg.get("mode", "soft")),
            view_distance_m=_at(cfg, "view", "distance_m"),
            web_mm=_at(cfg, "stipple", "web_mm"),
            spray_model=str(_at(cfg, "spray", "model", "physical")),
            nozzle_height=_at(cfg, "spray", "nozzle_height"),
            can_distance_mm=float(_at(cfg, "spray", "can_distance_mm", 200.0)),
            pass_speed_m_s=float(_at(cfg, "spray", "pass_speed_m_s", 0.5)),
            coverage_m2_per_can=_at(cfg, "paints", "coverage_m2_per_can", 1.5),
            can_ml=_at(cfg, "paints", "can_ml", 400.0),
            process=str(_at(cfg, "stipple", "process", "fdm")),
            thickness_mm=_at(cfg, "plate", "thickness_mm"),
            kerf_mm=float(_at(cfg, "export", "dxf_kerf_mm", 0.0) or 0.0),
            bed=_bed(cfg.get("bed")),
        )

    @classmethod
    def from_config(cls, cfg: JobConfig) -> JobSettings:
        """The settings of a job's config, read as its manifest records it."""
        return cls.from_json(cfg.model_dump(mode="json"))

    @property
    def has_cans(self) -> bool:
        """Whether the job's spray model sprays a can's constants in passes (the physical model's terms)."""
        try:
            return SprayModel(self.spray_model).terms.has_cans
        except ValueError:  # a model this version does not know
            return False

    @property
    def hard(self) -> bool:
        """Whether the job makes hard-edged cut stencils."""
        return self.mode == "hard"
