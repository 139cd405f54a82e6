"""The figures each stage records: one frozen dataclass per stage, collected in :class:`Figures`.

The stage glue (``pipeline/``) fills a :class:`Figures`; the terminal summary (``report.py``) reads
its fields; the manifest is :meth:`Figures.to_json`, whose keys, order and values are those the
manifest has always had (each class's ``to_json`` writes its keys in that order). Per-part rows
whose keys come from a check or a stage report (a plate's solid check, a stipple pass's counts)
stay mappings inside their typed row, with properties for the values the summary reads.

Plain values only: no numpy arrays (the glue converts), nothing from the stages, so any layer may
import this module.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

#: A mapping as the manifest holds it (values are JSON: numbers, strings, lists, mappings).
Row = Mapping[str, Any]


@dataclass(frozen=True)
class ComputeFigures:
    """Where the job's tasks ran (:meth:`stencil_cad.compute.Plan.summary`) and how many there were."""

    kind: str
    workers: int | None
    address: str | None
    reason: str
    #: Tasks run, counted when the manifest is written (None before).
    tasks: int | None = None

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
class MuralBuildFigures:
    """A mural's tiles as built: holes per tile, the rules checked on the union, the order of work."""

    tiles: Sequence[Row]
    holes_per_tile: Mapping[str, list[int]]
    holes_total: int
    holes_global: int
    union_check_rules: str
    compensated: bool
    seam_density: Any
    order_of_work: Any

    def to_json(self) -> dict[str, Any]:
        """The keys the build adds to the manifest's ``mural`` section."""
        return {
            "tiles": self.tiles,
            "holes_per_tile": self.holes_per_tile,
            "holes_total": self.holes_total,
            "holes_global": self.holes_global,
            "union_check_rules": self.union_check_rules,
            "compensated": self.compensated,
            "seam_density": self.seam_density,
            "order_of_work": self.order_of_work,
        }


@dataclass(frozen=True)
class MuralFigures:
    """The tiling's plan (bed, halo, cost, part sizes), then what the build and simulation added."""

    bed: Row | None
    tiled: bool
    halo_mm: float
    cost: Row
    part_sizes: Any
    built: MuralBuildFigures | None = None
    #: The tiled simulation against the global one, and the registration costs.
    simulation: Row | None = None

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``mural`` section."""
        out: dict[str, Any] = {
            "bed": self.bed,
            "tiled": self.tiled,
            "halo_mm": self.halo_mm,
            "cost": self.cost,
            "part_sizes": self.part_sizes,
        }
        if self.built is not None:
            out.update(self.built.to_json())
        if self.simulation is not None:
            out["simulation"] = self.simulation
        return out


@dataclass(frozen=True)
class PlateTrial:
    """One plate design tried for the picture: windows on or off, the wall's stand-off, and its score."""

    #: ``auto`` (windows where a layer is solid) or ``off`` (holes only).
    windows: str
    standoff_mm: float
    #: S-CIELAB at the viewing distance of the plates stippled (not refined) and sprayed.
    scielab: float

    @property
    def label(self) -> str:
        """The design in words: ``windows, 10 mm`` or ``holes only, 15 mm``."""
        return f"{'windows' if self.windows == 'auto' else 'holes only'}, {self.standoff_mm:g} mm"

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``standoff.trials``."""
        return {"windows": self.windows, "standoff_mm": self.standoff_mm, "scielab": self.scielab}


@dataclass(frozen=True)
class StandoffFigures:
    """The plate design chosen for the picture: the windows' share of the paint, the trials, the choice.

    The design is whether the plates open windows (``stipple.windows: auto`` lets the job choose) and
    the wall's stand-off (``wall.standoff_mm: null`` lets it choose).
    """

    window_share: float
    standoff_mm: float
    #: The plate designs tried, in the order tried; empty without trials.
    trials: Sequence[PlateTrial]
    reason: str
    #: The windows chosen: ``auto`` or ``off``.
    windows: str = "auto"
    #: The trials' simulation grid in mm per pixel (None without trials).
    trial_mm_per_px: float | None = None
    #: Seconds the trials took.
    seconds: float = 0.0

    @property
    def chosen(self) -> PlateTrial | None:
        """The trial of the chosen design (None without trials)."""
        for t in self.trials:
            if t.windows == self.windows and t.standoff_mm == self.standoff_mm:
                return t
        return None

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``standoff`` section."""
        return {
            "window_share": self.window_share,
            "standoff_mm": self.standoff_mm,
            "windows": self.windows,
            "trials": [t.to_json() for t in self.trials],
            "trial_mm_per_px": self.trial_mm_per_px,
            "seconds": self.seconds,
            "reason": self.reason,
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

    @property
    def rmse(self) -> float | None:
        """Composite RMSE in 0-255 units (None when the solver gives none)."""
        value = self.solver.get("rmse")
        return None if value is None else float(value)

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
        return out


@dataclass(frozen=True)
class CansFigures:
    """The cans a job knows: its can list, the catalogue and the snap to it."""

    can_list: Sequence[Row] | None = None
    catalogue: Sequence[Row] | None = None
    snap: Row | None = None

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``cans`` section (only the parts the job has)."""
        out: dict[str, Any] = {}
        if self.can_list is not None:
            out["list"] = list(self.can_list)
        if self.catalogue is not None:
            out["catalogue"] = list(self.catalogue)
        if self.snap is not None:
            out["snap"] = self.snap
        return out


@dataclass(frozen=True)
class DarkEnd:
    """How much of a layer is darker than its holes can spray at its spray time."""

    darkest_sprayable: float
    unreachable_share: float
    unreachable_by: float

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
class PartRow:
    """One built part (a plate or a wall): its solid's check, files and sizes, as the build wrote them."""

    values: Row

    def get(self, key: str, default: Any = None) -> Any:
        """A figure of the part's (``default`` when it has none)."""
        return self.values.get(key, default)

    @property
    def valid(self) -> bool:
        """Whether the part's solid passed its checks."""
        return bool(self.values.get("valid", False))

    @property
    def layer(self) -> int:
        """The plate's layer (1-based)."""
        return int(self.values["layer"])

    @property
    def file(self) -> str:
        """A wall's STEP file name."""
        return str(self.values["file"])

    @property
    def standoff_mm(self) -> float:
        """A wall's stand-off in mm."""
        return float(self.values["standoff_mm"])

    def to_json(self) -> dict[str, Any]:
        """The part's row of the manifest."""
        return dict(self.values)


@dataclass(frozen=True)
class BuildFigures:
    """Every plate and wall built and checked, and the print estimate when the job asked for one."""

    plates: Sequence[PartRow]
    walls: Sequence[PartRow]
    #: The slicer's total estimate (``profile``, ``hours``, ``filament_m``), or None.
    print_estimate: Row | None = None

    @property
    def tiled(self) -> bool:
        """Whether the plates are a mural's tiles."""
        return any("tile" in p.values for p in self.plates)

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``build`` section."""
        out: dict[str, Any] = {
            "plates": [p.to_json() for p in self.plates],
            "walls": [w.to_json() for w in self.walls],
        }
        if self.print_estimate is not None:
            out["print"] = self.print_estimate
        return out


@dataclass(frozen=True)
class SimulateFigures:
    """The simulation's scores (pixel by pixel and as a viewer sees them), by can and by wall."""

    #: The scores and the simulation's other figures, in the manifest's order.
    scores: Row
    #: S-CIELAB at the viewing distance under each can of the prior (None: one can).
    scielab_by_can: Mapping[str, float] | None = None
    #: Each further wall's scores (None: one wall).
    walls: Sequence[Row] | None = None

    def score(self, key: str) -> Any:
        """A score by its manifest name (``de2000_mean``, ``psnr``, ``scielab`` …), None when absent."""
        return self.scores.get(key)

    @property
    def scielab(self) -> float | None:
        """S-CIELAB ΔE at the viewing distance (None when not scored)."""
        value = self.scores.get("scielab")
        return None if value is None else float(value)

    @property
    def view_distance_m(self) -> float:
        """The viewing distance in m the scores are for."""
        return float(self.scores["view_distance_m"])

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``simulate`` section."""
        out: dict[str, Any] = dict(self.scores)
        if self.scielab_by_can:
            out["scielab_by_can"] = self.scielab_by_can
            out["scielab_worst"] = max(self.scielab_by_can.values())
        if self.walls:
            out["walls"] = list(self.walls)
        return out


@dataclass(frozen=True)
class SprayStep:
    """What the hand does for one layer: in words, and the figures behind them."""

    text: str
    #: ``layer``, ``paint``, then passes and distances (physical) or the spray time (paper).
    values: Row

    def to_json(self) -> dict[str, Any]:
        """One row of the manifest's ``spraying`` list."""
        return dict(self.values)


@dataclass(frozen=True)
class PaintFigures:
    """Paint to buy: the sprayed area, the can's coverage and volume, each layer's estimate."""

    sprayed_area_m2: float
    coverage_m2_per_can: float
    can_ml: float
    layers: Sequence[Row]

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``paint`` section."""
        return {
            "sprayed_area_m2": self.sprayed_area_m2,
            "coverage_m2_per_can": self.coverage_m2_per_can,
            "can_ml": self.can_ml,
            "layers": list(self.layers),
        }


@dataclass(frozen=True)
class SprayOrderFigures:
    """The primer and the layers in spray order, with the note and the unit of their amounts."""

    primer: Row
    note: str
    unit: str
    steps: Sequence[Row]

    def to_json(self) -> dict[str, Any]:
        """The manifest's ``spray_order`` section."""
        return {"primer": self.primer, "note": self.note, "unit": self.unit, "steps": list(self.steps)}


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


def _json(value: Any) -> Any:
    """A figure as the manifest writes it: a figures object by its ``to_json``, a list item by item."""
    if hasattr(value, "to_json"):
        return value.to_json()
    if isinstance(value, (list, tuple)):
        return [_json(v) for v in value]
    return value


class Figures:
    """Every stage's figures for one command, written to the manifest in the order stages recorded them.

    Each attribute is one section of the manifest (None until its stage records it). The card
    and hard-mode sections (``card``, ``hard``) and the tone choices (``tone_calibration``) are the
    stage's plain rows.
    """

    compute: ComputeFigures | None = None
    picture: PictureFigures | None = None
    mural: MuralFigures | None = None
    plate: PlateFigures | None = None
    standoff: StandoffFigures | None = None
    decompose: DecomposeFigures | None = None
    cans: CansFigures | None = None
    dark_end: tuple[DarkEnd, ...] | None = None
    refine: Row | None = None
    windows: tuple[LayerWindows, ...] | None = None
    stipple: tuple[LayerStipple, ...] | None = None
    tone_calibration: list[Any] | None = None
    build: BuildFigures | None = None
    simulate: SimulateFigures | None = None
    spraying: tuple[SprayStep, ...] | None = None
    paint: PaintFigures | None = None
    spray_order: SprayOrderFigures | None = None
    spray_profiles: tuple[LayerProfile, ...] | None = None
    card: Row | None = None
    hard: Row | None = None

    def __init__(self) -> None:
        self._order: list[str] = []

    def __setattr__(self, name: str, value: Any) -> None:
        if not name.startswith("_") and name not in self._order:
            if name not in type(self).__annotations__:
                raise AttributeError(f"no stage records figures called {name!r}")
            self._order.append(name)
        object.__setattr__(self, name, value)

    def to_json(self) -> dict[str, Any]:
        """The manifest's stage sections, in the order the stages first recorded them."""
        return {name: _json(getattr(self, name)) for name in self._order}
