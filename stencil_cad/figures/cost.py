"""What making the job costs: printer-hours and filament per part, laser sheets and cut time, paint.

The manifest's ``cost`` section: the estimate made before any CAD (from the plan's part sizes
and the holes the stippler placed, or the plan's expected holes), written as
``cost.printer_hours`` and ``cost.filament_g``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from .rows import Row, rows_of


@dataclass(frozen=True)
class PartCost:
    """One part's estimate: a plate (per tile and layer) or a wall (per tile and stand-off).

    Attributes:
        kind: ``"plate"``, ``"wall"``, ``"posts"`` (a mural's posts, :mod:`stencil_cad.mural.posts`), or a
            laser-cut mural's ``"frame_base"``, ``"frame_top"`` and ``"spacer"`` (:mod:`stencil_cad.mural.laser`).
        tile: The mural tile, or empty for a one-plate job (and for the posts).
        layer: The plate's layer (1-based), 0 for a wall, or how many posts (or laser-cut stand parts) are made.
        holes: Holes on the plate (placed, or expected from the plan), 0 for a wall.
        print_hours: FDM print time in hours (the shipped PrusaSlicer profile's, as modelled).
        filament_m: Filament in metres (1.75 mm).
        filament_g: Filament in grams (PLA).
        cut_m: Laser cut length in metres (laser plates), or None.
        cut_minutes: Estimated laser time in minutes (laser plates), or None.
    """

    kind: str
    tile: str
    layer: int
    holes: int
    print_hours: float
    filament_m: float
    filament_g: float
    cut_m: float | None = None
    cut_minutes: float | None = None

    @classmethod
    def from_json(cls, row: Row) -> PartCost:
        """One row of the manifest's ``cost.parts``."""
        return cls(
            kind=str(row["kind"]),
            tile=str(row.get("tile") or ""),
            layer=int(row.get("layer") or 0),
            holes=int(row.get("holes") or 0),
            print_hours=float(row["print_hours"]),
            filament_m=float(row["filament_m"]),
            filament_g=float(row["filament_g"]),
            cut_m=row.get("cut_m"),
            cut_minutes=row.get("cut_minutes"),
        )

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``cost.parts``."""
        out: dict[str, Any] = {
            "kind": self.kind,
            "tile": self.tile,
            "layer": self.layer,
            "holes": self.holes,
            "print_hours": self.print_hours,
            "filament_m": self.filament_m,
            "filament_g": self.filament_g,
        }
        if self.cut_m is not None:
            out.update(cut_m=self.cut_m, cut_minutes=self.cut_minutes)
        return out

    @property
    def name(self) -> str:
        """``A1 plate 02``, ``plate 01``, ``B2 wall`` …: how the summary and the sheet name the part."""
        what = f"plate {self.layer:02d}" if self.kind == "plate" else self.kind
        if self.kind == "posts":
            what = f"posts × {self.layer} (printed together)"
        elif self.kind in ("frame_base", "frame_top", "spacer"):
            what = f"{self.kind} × {self.layer} (laser-cut)"
        return f"{self.tile} {what}" if self.tile else what


@dataclass(frozen=True)
class PaintCost:
    """One layer's paint: the open area it sprays through, its passes and the cans that takes."""

    layer: int
    open_m2: float
    passes: float
    cans: float

    @classmethod
    def from_json(cls, row: Row) -> PaintCost:
        """One row of the manifest's ``cost.paint``."""
        return cls(int(row["layer"]), float(row["open_m2"]), float(row["passes"]), float(row["cans"]))

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``cost.paint``."""
        return {"layer": self.layer, "open_m2": self.open_m2, "passes": self.passes, "cans": self.cans}


@dataclass(frozen=True)
class CostFigures:
    """The job's making cost, in total and per part.

    Attributes:
        basis: What the holes came from: ``"plan"`` (expected from the plan's sizes) or
            ``"holes"`` (the holes the stippler placed); both before any CAD.
        area_m2: The picture's area in m² (for figures per square metre).
        printer_hours: FDM printer-hours for every plate and wall.
        filament_m: Filament for every part, metres.
        filament_g: Filament for every part, grams of PLA.
        parts: Every part's estimate.
        sheets: Laser jobs: sheets to cut (one per plate), else None.
        cut_m: Laser jobs: the plates' cut length in metres, else None.
        cut_hours: Laser jobs: the estimated cut time in hours, else None.
        paint: Per layer, the open area, passes and cans (empty when unknown).
        coverage_m2_per_can: The coverage one can is assumed to give per coat, m².
    """

    basis: str
    area_m2: float
    printer_hours: float
    filament_m: float
    filament_g: float
    parts: tuple[PartCost, ...]
    sheets: int | None = None
    cut_m: float | None = None
    cut_hours: float | None = None
    paint: tuple[PaintCost, ...] = ()
    coverage_m2_per_can: float | None = None

    @classmethod
    def from_json(cls, section: Row) -> CostFigures:
        """The manifest's ``cost`` section."""
        return cls(
            basis=str(section["basis"]),
            area_m2=float(section["area_m2"]),
            printer_hours=float(section["printer_hours"]),
            filament_m=float(section["filament_m"]),
            filament_g=float(section["filament_g"]),
            parts=rows_of(PartCost.from_json, section.get("parts")),
            sheets=section.get("sheets"),
            cut_m=section.get("cut_m"),
            cut_hours=section.get("cut_hours"),
            paint=rows_of(PaintCost.from_json, section.get("paint")),
            coverage_m2_per_can=section.get("coverage_m2_per_can"),
        )

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``cost`` section."""
        return {
            "basis": self.basis,
            "area_m2": self.area_m2,
            "printer_hours": self.printer_hours,
            "filament_m": self.filament_m,
            "filament_g": self.filament_g,
            "parts": [p.to_json() for p in self.parts],
            "sheets": self.sheets,
            "cut_m": self.cut_m,
            "cut_hours": self.cut_hours,
            "paint": [p.to_json() for p in self.paint],
            "coverage_m2_per_can": self.coverage_m2_per_can,
        }

    def per_m2(self) -> tuple[float, float]:
        """``(printer-hours, kg of filament)`` per square metre of picture."""
        a = max(self.area_m2, 1e-9)
        return self.printer_hours / a, self.filament_g / 1000.0 / a

    def line(self) -> str:
        """One line: ``printer 12.3 h, filament 45.6 m (136 g)`` (+ laser sheets and cut time)."""
        text = (
            f"printer {self.printer_hours:.1f} h, filament {self.filament_m:.1f} m ({self.filament_g:.0f} g)"
        )
        if self.sheets is not None:
            text += f"; laser {self.sheets} sheet(s), cut {self.cut_m or 0:.1f} m in about {self.cut_hours or 0:.1f} h"
        return text
