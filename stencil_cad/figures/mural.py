"""A mural's figures: the tiling's plan, the tiles as built and the tiled simulation."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any, ClassVar

from .rows import KeyedRow, Row, rows_of
from .spray import ScoreRow


@dataclass(frozen=True)
class MuralBed:
    """The bed the tiles were sized for: its name and size in mm."""

    name: str
    x_mm: float
    y_mm: float

    @classmethod
    def from_json(cls, row: Row) -> MuralBed:
        """The manifest's ``mural.bed``."""
        return cls(row["name"], row["x_mm"], row["y_mm"])

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``mural.bed``."""
        return {"name": self.name, "x_mm": self.x_mm, "y_mm": self.y_mm}


@dataclass(frozen=True)
class TileRow(KeyedRow):
    """One tile: its name, row and column (1-based, row 1 on top), core and sheet in mm.

    ``core_mm`` and ``sheet_mm`` are ``(x0, y0, x1, y1)`` from the mural's bottom-left corner.
    """

    tile: str | None = None
    row: int | None = None
    column: int | None = None
    core_mm: Sequence[float] | None = None
    sheet_mm: Sequence[float] | None = None
    #: The plate's picture area and the wall's opening (the sheet grown to one size for every tile).
    part_mm: Sequence[float] | None = None


@dataclass(frozen=True)
class MuralBuildFigures:
    """A mural's tiles as built: holes per tile, the rules checked on the union, the order of work."""

    tiles: tuple[TileRow, ...]
    holes_per_tile: Mapping[str, list[int]] | None
    holes_total: int | None
    holes_global: int | None
    union_check_rules: str | None
    compensated: bool | None
    seam_density: Any
    order_of_work: Any
    #: The posts that carry the plates: the part's file, its check, stand-off, foot and pin radii,
    #: ``per_plate`` (posts per ``"<tile> <layer>"``), ``sites_mm`` (their centres in mural mm), ``most`` (the most under one plate:
    #: the posts to print) and ``dropped_holes``; None when the wall alone carries the plates.
    posts: Mapping[str, Any] | None = None
    #: A laser-cut mural's frame rings and spacers (:mod:`stencil_cad.mural.laser`): per part its
    #: ``name``, ``count``, ``thickness_mm``, ``cut_m``, ``cut_minutes``, ``files`` and checks
    #: (``closed``, ``inside``, ``fits``, ``ok``, ``size_mm``); None for a printed wall.
    laser_stand: Sequence[Mapping[str, Any]] | None = None

    @classmethod
    def from_json(cls, section: Row) -> MuralBuildFigures:
        """The keys the build adds to the manifest's ``mural`` section."""
        return cls(
            tiles=rows_of(TileRow.from_json, section.get("tiles")),
            holes_per_tile=section.get("holes_per_tile"),
            holes_total=section.get("holes_total"),
            holes_global=section.get("holes_global"),
            union_check_rules=section.get("union_check_rules"),
            compensated=section.get("compensated"),
            seam_density=section.get("seam_density"),
            order_of_work=section.get("order_of_work"),
            posts=section.get("posts"),
            laser_stand=section.get("laser_stand"),
        )

    def to_json(self) -> dict[str, Any]:
        """The keys the build adds to the manifest's ``mural`` section."""
        return {
            "tiles": [t.to_json() for t in self.tiles],
            "holes_per_tile": self.holes_per_tile,
            "holes_total": self.holes_total,
            "holes_global": self.holes_global,
            "union_check_rules": self.union_check_rules,
            "compensated": self.compensated,
            "seam_density": self.seam_density,
            "order_of_work": self.order_of_work,
            "posts": self.posts,
            "laser_stand": self.laser_stand,
        }


@dataclass(frozen=True)
class RegistrationCost(ScoreRow):
    """The scores with the tiles (or the layers) shifted apart by ``error_mm``, and what that costs."""

    between: str | None = None
    error_mm: float | None = None
    cost_scielab: float | None = None
    cost_de2000_mean: float | None = None
    cost_psnr: float | None = None
    cost_ssim: float | None = None


@dataclass(frozen=True)
class MuralSimulation(KeyedRow):
    """The scores in register (the global simulation's) and the registration costs."""

    zero_error_scores: ScoreRow | None = None
    registration_cost: tuple[RegistrationCost, ...] | None = None

    nested: ClassVar[Mapping[str, Callable[[Any], Any]]] = {
        "zero_error_scores": lambda row: ScoreRow.from_json(row) if row is not None else None,
        "registration_cost": lambda rows: rows_of(RegistrationCost.from_json, rows),
    }


#: The keys of the manifest's ``mural`` section the build adds.
_BUILT = ("tiles", "holes_per_tile", "holes_total", "holes_global", "union_check_rules")


@dataclass(frozen=True)
class MuralFigures:
    """The tiling's plan (bed, halo, cost, part sizes), then what the build and simulation added."""

    bed: MuralBed | None
    tiled: bool
    halo_mm: float
    cost: Row
    part_sizes: Any
    built: MuralBuildFigures | None = None
    #: The scores in register and the registration costs (the tiles shifted in simulation).
    simulation: MuralSimulation | None = None

    @property
    def mural_seconds(self) -> float | None:
        """A tiled mural's estimated work in seconds (which may start a cluster), or None for one plate."""
        return float(self.cost["estimated_seconds"]) if self.tiled else None

    @classmethod
    def from_json(cls, section: Row) -> MuralFigures:
        """The manifest's ``mural`` section."""
        bed, sim = section.get("bed"), section.get("simulation")
        return cls(
            bed=MuralBed.from_json(bed) if bed else None,
            tiled=bool(section.get("tiled", False)),
            halo_mm=section.get("halo_mm", 0.0),
            cost=section.get("cost") or {},
            part_sizes=section.get("part_sizes"),
            built=MuralBuildFigures.from_json(section) if any(k in section for k in _BUILT) else None,
            simulation=MuralSimulation.from_json(sim) if sim is not None else None,
        )

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``mural`` section."""
        out: dict[str, Any] = {
            "bed": None if self.bed is None else self.bed.to_json(),
            "tiled": self.tiled,
            "halo_mm": self.halo_mm,
            "cost": self.cost,
            "part_sizes": self.part_sizes,
        }
        if self.built is not None:
            out.update(self.built.to_json())
        if self.simulation is not None:
            out["simulation"] = self.simulation.to_json()
        return out
