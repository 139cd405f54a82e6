"""The figures of spraying.

The simulation's scores, what the hand does per layer, the paint to buy, the spray order and each
layer's spray settings.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from .rows import KeyedRow, Row, rows_of


@dataclass(frozen=True)
class ScoreRow(KeyedRow):
    """Scores of a sprayed picture against the source: pixel by pixel and as a viewer sees them."""

    de2000_mean: float | None = None
    de2000_p95: float | None = None
    psnr: float | None = None
    ssim: float | None = None
    scielab: float | None = None


@dataclass(frozen=True)
class WallScores(ScoreRow):
    """The simulation under a further wall: its stand-off, preview file and scores."""

    standoff_mm: float | None = None
    file: str | None = None


@dataclass(frozen=True)
class SimulateFigures:
    """The simulation's scores (pixel by pixel and as a viewer sees them), by can and by wall."""

    #: The scores and the simulation's other figures, in the manifest's order.
    scores: Row
    #: S-CIELAB at the viewing distance under each can of the prior (None: one can).
    scielab_by_can: Mapping[str, float] | None = None
    #: Each further wall's scores (None: one wall).
    walls: tuple[WallScores, ...] | None = None

    _OWN: ClassVar[tuple[str, ...]] = ("scielab_by_can", "scielab_worst", "walls")

    @classmethod
    def from_rows(
        cls, scores: Row, scielab_by_can: Mapping[str, float] | None, walls: Sequence[Row] | None
    ) -> SimulateFigures:
        """The figures from the simulation's scores, its scores by can and each further wall's row."""
        return cls(scores, scielab_by_can, rows_of(WallScores.from_json, walls) if walls else None)

    @classmethod
    def from_json(cls, section: Row) -> SimulateFigures:
        """The manifest's ``simulate`` section (``scielab_worst`` is the worst of ``scielab_by_can``)."""
        scores = {k: v for k, v in section.items() if k not in cls._OWN}
        return cls.from_rows(scores, section.get("scielab_by_can"), section.get("walls"))

    def _float(self, key: str) -> float | None:
        value = self.scores.get(key)
        return None if value is None else float(value)

    @property
    def de2000_mean(self) -> float | None:
        """Mean ΔE2000, pixel by pixel."""
        return self._float("de2000_mean")

    @property
    def de2000_p95(self) -> float | None:
        """95th percentile of ΔE2000, pixel by pixel."""
        return self._float("de2000_p95")

    @property
    def psnr(self) -> float | None:
        """PSNR in dB."""
        return self._float("psnr")

    @property
    def ssim(self) -> float | None:
        """SSIM."""
        return self._float("ssim")

    @property
    def scielab(self) -> float | None:
        """S-CIELAB ΔE at the viewing distance (None when not scored)."""
        return self._float("scielab")

    @property
    def scielab_2x(self) -> float | None:
        """S-CIELAB ΔE at twice the viewing distance (None when not scored)."""
        return self._float("scielab_2x")

    @property
    def view_distance_m(self) -> float | None:
        """The viewing distance in m the scores are for (None when not scored)."""
        return self._float("view_distance_m")

    @property
    def dots_blend_m(self) -> float | None:
        """The distance in m from which the dots blend (None: they show from any distance)."""
        return self._float("dots_blend_m")

    @property
    def dots_hole_r_mm(self) -> float | None:
        """The smallest hole radius in mm of the layer whose dots show longest."""
        return self._float("dots_hole_r_mm")

    @property
    def holes(self) -> list[int]:
        """Each layer's simulated hole count (empty when not simulated as holes)."""
        return [int(h) for h in self.scores.get("holes") or ()]

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``simulate`` section."""
        out: dict[str, Any] = dict(self.scores)
        if self.scielab_by_can:
            out["scielab_by_can"] = self.scielab_by_can
            out["scielab_worst"] = max(self.scielab_by_can.values())
        if self.walls:
            out["walls"] = [w.to_json() for w in self.walls]
        return out


@dataclass(frozen=True)
class SprayStep(KeyedRow):
    """What the hand does for one layer: in words (``text``), and the figures behind them.

    Physical model: the passes, can distance and speed; paper model: the spray time.
    """

    layer: int | None = None
    paint: str | None = None
    passes: int | None = None
    dose_passes: float | None = None
    pass_speed_m_s: float | None = None
    spray_time: float | None = None
    text: str | None = None


@dataclass(frozen=True)
class PaintLayer(KeyedRow):
    """One layer's paint estimate: mean opacity, covered area, millilitres and cans to buy."""

    layer: int | None = None
    hex: str | None = None
    mean_opacity: float | None = None
    covered_m2: float | None = None
    ml: float | None = None
    cans_to_buy: int | None = None


@dataclass(frozen=True)
class PaintFigures:
    """Paint to buy: the sprayed area, the can's coverage and volume, each layer's estimate."""

    sprayed_area_m2: float
    coverage_m2_per_can: float | None
    can_ml: float | None
    layers: tuple[PaintLayer, ...]

    @classmethod
    def from_json(cls, section: Row) -> PaintFigures:
        """The manifest's ``paint`` section."""
        return cls(
            sprayed_area_m2=section.get("sprayed_area_m2", 0.0),
            coverage_m2_per_can=section.get("coverage_m2_per_can"),
            can_ml=section.get("can_ml"),
            layers=rows_of(PaintLayer.from_json, section.get("layers")),
        )

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``paint`` section."""
        return {
            "sprayed_area_m2": self.sprayed_area_m2,
            "coverage_m2_per_can": self.coverage_m2_per_can,
            "can_ml": self.can_ml,
            "layers": [r.to_json() for r in self.layers],
        }


@dataclass(frozen=True)
class OrderStep(KeyedRow):
    """One step of the spray order: the plate, its paint (hex and can name) and its amount."""

    step: int | None = None
    plate: str | None = None
    hex: str | None = None
    name: str | None = None
    spray_time: float | None = None
    passes: int | None = None
    pass_speed_m_s: float | None = None


@dataclass(frozen=True)
class PrimerRow(KeyedRow):
    """The primer: its hex and can name."""

    hex: str | None = None
    name: str | None = None


@dataclass(frozen=True)
class SprayOrderFigures:
    """The primer and the layers in spray order, with the note and the unit of their amounts."""

    primer: PrimerRow
    note: str | None
    unit: str | None
    steps: tuple[OrderStep, ...]

    @classmethod
    def from_json(cls, section: Row) -> SprayOrderFigures:
        """The manifest's ``spray_order`` section."""
        return cls(
            primer=PrimerRow.from_json(section.get("primer") or {}),
            note=section.get("note"),
            unit=section.get("unit"),
            steps=rows_of(OrderStep.from_json, section.get("steps")),
        )

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``spray_order`` section."""
        return {
            "primer": self.primer.to_json(),
            "note": self.note,
            "unit": self.unit,
            "steps": [s.to_json() for s in self.steps],
        }


@dataclass(frozen=True)
class LayerProfile:
    """The spray settings one layer sprays with: its paint, profile file and can constants."""

    layer: int
    hex: str
    profile: str | None
    key: str | None
    measured: bool
    paint: str | None
    spread_k: float
    bleed_sigma_mm: float
    deposit_per_pass: float

    @classmethod
    def from_json(cls, row: Row) -> LayerProfile:
        """A row of a manifest's ``spray_profiles`` list (missing keys: unknown, not measured)."""
        return cls(
            layer=int(row.get("layer", 0)),
            hex=str(row.get("hex", "")),
            profile=row.get("profile"),
            key=row.get("key"),
            measured=bool(row.get("measured")),
            paint=row.get("paint"),
            spread_k=float(row.get("spread_k", math.nan)),
            bleed_sigma_mm=float(row.get("bleed_sigma_mm", math.nan)),
            deposit_per_pass=float(row.get("deposit_per_pass", math.nan)),
        )

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``spray_profiles`` list."""
        return {
            "layer": self.layer,
            "hex": self.hex,
            "profile": self.profile,
            "key": self.key,
            "measured": self.measured,
            "paint": self.paint,
            "spread_k": self.spread_k,
            "bleed_sigma_mm": self.bleed_sigma_mm,
            "deposit_per_pass": self.deposit_per_pass,
        }
