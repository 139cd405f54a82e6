"""The build's figures: every plate and wall built and checked, and the print estimate."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from .rows import KeyedRow, Row, rows_of


@dataclass(frozen=True)
class MeshCheck(KeyedRow):
    """A plate mesh's check: closed, consistently wound, its genus (= its hole count when right)."""

    watertight: bool | None = None
    consistent_winding: bool | None = None
    genus: int | None = None

    @property
    def ok(self) -> bool:
        """Watertight and consistently wound."""
        return bool(self.watertight) and bool(self.consistent_winding)


@dataclass(frozen=True)
class Cutouts(KeyedRow):
    """A hard plate's cut-outs: how many, their smallest and largest span, the open area."""

    count: int | None = None
    span_min_mm: float | None = None
    span_max_mm: float | None = None
    open_mm2: float | None = None


def _mesh(value: Any) -> MeshCheck | None:
    return MeshCheck.from_json(value) if value else None


def _cutouts(value: Any) -> Cutouts | None:
    return Cutouts.from_json(value) if value else None


def _footprint(bbox_mm: Sequence[float] | None, bbox: Sequence[Any] | None) -> tuple[float, float] | None:
    """Footprint ``(w, h)`` in mm from ``bbox_mm`` or a bounding box (two corners, or six numbers)."""
    if bbox_mm:
        w, h = bbox_mm[:2]
        return float(w), float(h)
    if not bbox:
        return None
    if len(bbox) == 2 and all(isinstance(c, (list, tuple)) for c in bbox):
        (x0, y0, *_), (x1, y1, *_) = bbox
    elif len(bbox) == 6:
        x0, y0, _, x1, y1, _ = bbox
    else:
        return None
    return float(x1) - float(x0), float(y1) - float(y0)


@dataclass(frozen=True)
class PlateRow(KeyedRow):
    """One built plate: its layer (and tile), the solid's check, its cut and its size.

    The solid's other figures (volumes, methods, timings) and the cut files' offsets stay in
    ``other``.
    """

    tile: str | None = None
    layer: int | None = None
    file: str | None = None
    valid: bool | None = None
    n_solids: int | None = None
    rel_error: float | None = None
    hole_count: int | None = None
    bbox: Sequence[Any] | None = None
    mesh: MeshCheck | None = None
    cut_length_mm: float | None = None
    bbox_mm: Sequence[float] | None = None
    cutouts: Cutouts | None = None
    print_hours: float | None = None
    filament_m: float | None = None

    nested: ClassVar[Mapping[str, Callable[[Any], Any]]] = {"mesh": _mesh, "cutouts": _cutouts}

    @property
    def number(self) -> int:
        """The plate's layer (1-based; 0 when the row has none)."""
        return int(self.layer or 0)

    @property
    def size_mm(self) -> tuple[float, float] | None:
        """Footprint ``(w, h)`` in mm as exported (None when unknown)."""
        return _footprint(self.bbox_mm, self.bbox)


@dataclass(frozen=True)
class WallRow(KeyedRow):
    """One built wall: its file, stand-off, tile and sight notches, and its solid's check."""

    tile: str | None = None
    file: str | None = None
    standoff_mm: float | None = None
    notches: int | None = None
    valid: bool | None = None
    bbox: Sequence[float] | None = None
    print_hours: float | None = None
    filament_m: float | None = None

    @property
    def size_mm(self) -> tuple[float, float] | None:
        """Footprint ``(w, h)`` in mm as exported (None when unknown)."""
        return _footprint(None, self.bbox)


@dataclass(frozen=True)
class PrintEstimate:
    """The slicer's estimate for every part together: the profile, hours and filament."""

    profile: str | None
    hours: float | None
    filament_m: float | None

    @classmethod
    def from_json(cls, row: Row) -> PrintEstimate:
        """The manifest's ``build.print``."""
        return cls(row.get("profile"), row.get("hours"), row.get("filament_m"))

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``build.print``."""
        return {"profile": self.profile, "hours": self.hours, "filament_m": self.filament_m}


@dataclass(frozen=True)
class BuildFigures:
    """Every plate and wall built and checked, and the print estimate when the job asked for one."""

    plates: tuple[PlateRow, ...]
    walls: tuple[WallRow, ...]
    print_estimate: PrintEstimate | None = None

    @classmethod
    def from_rows(
        cls, plates: Sequence[Row], walls: Sequence[Row], print_estimate: PrintEstimate | None = None
    ) -> BuildFigures:
        """The build's figures from the rows the build wrote for each plate and wall."""
        return cls(rows_of(PlateRow.from_json, plates), rows_of(WallRow.from_json, walls), print_estimate)

    @classmethod
    def from_json(cls, section: Row) -> BuildFigures:
        """The manifest's ``build`` section."""
        total = section.get("print")
        return cls.from_rows(
            section.get("plates") or (),
            section.get("walls") or (),
            PrintEstimate.from_json(total) if total else None,
        )

    @property
    def tiled(self) -> bool:
        """Whether the plates are a mural's tiles."""
        return any(p.has("tile") for p in self.plates)

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``build`` section."""
        out: dict[str, Any] = {
            "plates": [p.to_json() for p in self.plates],
            "walls": [w.to_json() for w in self.walls],
        }
        if self.print_estimate is not None:
            out["print"] = self.print_estimate.to_json()
        return out
