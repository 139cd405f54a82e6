"""The figures of the stages before the build.

Where tasks ran, the picture, the plate, the decomposition, the cans, the holes per layer and hard
mode's cut layers.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from .rows import KeyedRow, Row, rows_of


@dataclass(frozen=True)
class ComputeFigures:
    """Where the job's tasks ran (:meth:`stencil_cad.compute.Plan.summary`) and how many there were."""

    kind: str
    workers: int | None
    address: str | None
    reason: str
    #: Tasks run, counted when the manifest is written (None before).
    tasks: int | None = None

    @classmethod
    def from_json(cls, section: Row) -> ComputeFigures:
        """The manifest's ``compute`` section."""
        return cls(
            section["kind"],
            section.get("workers"),
            section.get("address"),
            section["reason"],
            section.get("tasks"),
        )

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``compute`` section."""
        out: dict[str, Any] = {"kind": self.kind, "workers": self.workers, "address": self.address}
        out["reason"] = self.reason
        if self.tasks is not None:
            out["tasks"] = self.tasks
        return out


@dataclass(frozen=True)
class PictureFigures:
    """The working picture: its source, size in mm and pixels."""

    source: str
    width_mm: float
    height_mm: float
    pixels: tuple[int, int]
    mm_per_px: float

    @classmethod
    def from_json(cls, section: Row) -> PictureFigures:
        """The manifest's ``picture`` section (a sheet's test manifest may give only the size)."""
        h, w = section.get("pixels") or (0, 0)
        return cls(
            source=section.get("source", ""),
            width_mm=section.get("width_mm", 0.0),
            height_mm=section.get("height_mm", 0.0),
            pixels=(h, w),
            mm_per_px=section.get("mm_per_px", 0.0),
        )

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``picture`` section."""
        return {
            "source": self.source,
            "width_mm": self.width_mm,
            "height_mm": self.height_mm,
            "pixels": list(self.pixels),
            "mm_per_px": self.mm_per_px,
        }


@dataclass(frozen=True)
class PlateFigures:
    """The plate thickness in use and why (filled in for the plate's size, or given)."""

    thickness_mm: float
    filled: bool
    side_mm: float
    sag_mm: float | None
    thickness_reason: str

    @classmethod
    def from_json(cls, section: Row) -> PlateFigures:
        """The manifest's ``plate`` section."""
        return cls(
            thickness_mm=section.get("thickness_mm", 0.0),
            filled=section.get("filled", False),
            side_mm=section.get("side_mm", 0.0),
            sag_mm=section.get("sag_mm"),
            thickness_reason=section.get("thickness_reason", ""),
        )

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``plate`` section."""
        return {
            "thickness_mm": self.thickness_mm,
            "filled": self.filled,
            "side_mm": self.side_mm,
            "sag_mm": self.sag_mm,
            "thickness_reason": self.thickness_reason,
        }


@dataclass(frozen=True)
class DecomposeFigures:
    """The decomposition: layer count, primer and paints, iterations and the solver's figures."""

    layers: int
    primer: str
    colours: Sequence[str]
    iterations: int
    #: The solver's plain figures (``rmse`` and others), in the solver's order.
    solver: Row
    #: A big picture solved in tiles: the tiling's figures (None: solved whole).
    tiled: Row | None = None
    #: Plates the layers are stippled on: twice the layers with light plates (None: one per layer).
    plates: int | None = None

    _OWN: ClassVar[tuple[str, ...]] = ("layers", "primer", "colours", "iterations", "tiled", "plates")

    @classmethod
    def from_json(cls, section: Row) -> DecomposeFigures:
        """The manifest's ``decompose`` section."""
        return cls(
            layers=section.get("layers", 0),
            primer=section.get("primer", ""),
            colours=list(section.get("colours") or ()),
            iterations=section.get("iterations", 0),
            solver={k: v for k, v in section.items() if k not in cls._OWN},
            tiled=section.get("tiled"),
            plates=section.get("plates"),
        )

    @property
    def rmse(self) -> float | None:
        """Composite RMSE in 0-255 units (None when the solver gives none)."""
        value = self.solver.get("rmse")
        return None if value is None else float(value)

    @property
    def warnings(self) -> list[str]:
        """What the decomposition warns the maker about, in words."""
        return [str(w) for w in self.solver.get("warnings") or ()]

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``decompose`` section."""
        out: dict[str, Any] = {
            "layers": self.layers,
            "primer": self.primer,
            "colours": list(self.colours),
            "iterations": self.iterations,
            **self.solver,
        }
        if self.tiled is not None:
            out["tiled"] = self.tiled
        if self.plates is not None and self.plates != self.layers:
            out["plates"] = self.plates
        return out


@dataclass(frozen=True)
class SnapRow(KeyedRow):
    """One paint (or the primer) snapped to a can: the solved colour, the can and the distance."""

    solved: str | None = None
    can: str | None = None
    name: str | None = None
    delta_e2000: float | None = None


def _snap_row(value: Any) -> SnapRow | None:
    return SnapRow.from_json(value) if value else None


@dataclass(frozen=True)
class CanSnap(KeyedRow):
    """Each paint (and the primer) snapped to a can of the catalogue, and what that cost."""

    paints: tuple[SnapRow, ...] | None = None
    primer: SnapRow | None = None
    rmse_solved: float | None = None
    rmse_snapped: float | None = None

    nested: ClassVar[Mapping[str, Callable[[Any], Any]]] = {
        "paints": lambda rows: rows_of(SnapRow.from_json, rows),
        "primer": _snap_row,
    }


@dataclass(frozen=True)
class CansFigures:
    """The cans a job knows: its can list, the catalogue and the snap to it."""

    can_list: Sequence[Row] | None = None
    catalogue: Sequence[Row] | None = None
    snap: CanSnap | None = None

    @classmethod
    def from_json(cls, section: Row) -> CansFigures:
        """The manifest's ``cans`` section."""
        snap = section.get("snap")
        return cls(section.get("list"), section.get("catalogue"), CanSnap.from_json(snap) if snap else None)

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``cans`` section (only the parts the job has)."""
        out: dict[str, Any] = {}
        if self.can_list is not None:
            out["list"] = list(self.can_list)
        if self.catalogue is not None:
            out["catalogue"] = list(self.catalogue)
        if self.snap is not None:
            out["snap"] = self.snap.to_json()
        return out


@dataclass(frozen=True)
class DarkEnd:
    """How much of a layer is darker than its holes can spray at its spray time."""

    darkest_sprayable: float
    unreachable_share: float
    unreachable_by: float

    @classmethod
    def from_json(cls, row: Row) -> DarkEnd:
        """One row of the manifest's ``dark_end`` list."""
        nan = math.nan
        return cls(
            row.get("darkest_sprayable", nan),
            row.get("unreachable_share", 0.0),
            row.get("unreachable_by", nan),
        )

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``dark_end`` list."""
        return {
            "darkest_sprayable": self.darkest_sprayable,
            "unreachable_share": self.unreachable_share,
            "unreachable_by": self.unreachable_by,
        }


@dataclass(frozen=True)
class LayerWindows:
    """One layer's windows on a hybrid plate: the stage's figures for it."""

    layer: int
    report: Row

    @classmethod
    def from_json(cls, row: Row) -> LayerWindows:
        """One row of the manifest's ``windows`` list."""
        return cls(row["layer"], {k: v for k, v in row.items() if k != "layer"})

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``windows`` list."""
        return {"layer": self.layer, **self.report}


@dataclass(frozen=True)
class LayerStipple:
    """One layer's holes: count, the stippler's counts and smallest web, its spray time."""

    layer: int
    dots: int
    #: The stippler's figures (removed, merged, nudged, ``min_web_mm`` …), in its order.
    report: Row
    #: Whole passes (physical model) or the paper model's spray time; None: the config's.
    spray_time: float | None

    _OWN: ClassVar[tuple[str, ...]] = ("layer", "dots", "spray_time")

    @classmethod
    def from_json(cls, row: Row) -> LayerStipple:
        """One row of the manifest's ``stipple`` list."""
        report = {k: v for k, v in row.items() if k not in cls._OWN}
        return cls(row.get("layer", 0), row.get("dots", 0), report, row.get("spray_time"))

    @property
    def min_web_mm(self) -> float | None:
        """Smallest web between holes achieved, in mm (None when not measured)."""
        value = self.report.get("min_web_mm")
        return None if value is None else float(value)

    def count(self, what: str) -> int:
        """A count of the stippler's (``removed``, ``merged``, ``nudged``); 0 when it has none."""
        return int(self.report.get(what, 0))

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``stipple`` list."""
        return {"layer": self.layer, "dots": self.dots, **self.report, "spray_time": self.spray_time}


@dataclass(frozen=True)
class HardLayer(KeyedRow):
    """One cut layer of hard mode: whether its sheet is held in one piece, and its other figures."""

    polygon_held_components: int | None = None


@dataclass(frozen=True)
class HardFigures(KeyedRow):
    """Hard mode's segmentation and cut layers: the palette, bridges, warnings and each layer's figures."""

    palette: Sequence[str] | None = None
    bridge_drawn_mm: float | None = None
    warnings: Sequence[str] | None = None
    per_layer: tuple[HardLayer, ...] | None = None

    nested: ClassVar[Mapping[str, Callable[[Any], Any]]] = {
        "per_layer": lambda rows: rows_of(HardLayer.from_json, rows)
    }

    def plain(self) -> Iterator[tuple[str, Any]]:
        """Every figure that is one value (no list, no mapping), by name, in the written order."""
        for k, v in self.to_json().items():
            if not isinstance(v, (list, dict)):
                yield k, v
