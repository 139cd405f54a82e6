"""Config section `hard` (owned by the hard stage): flat-colour cut stencils."""

from __future__ import annotations

import enum
from pathlib import Path

from pydantic import Field, field_validator, model_validator

from ..colour import parse_colour
from .base import HexPalette, StrictModel, resolved_palette


class SprayOrder(str, enum.Enum):
    """In which order the flat colours are sprayed (the first one is the primer)."""

    light_to_dark = "light_to_dark"
    dark_to_light = "dark_to_light"
    given = "given"


class HardConfig(StrictModel):
    """Settings of the hard-stencil mode: segmentation, cut layers, bridges."""

    colours: int = Field(
        4,
        ge=2,
        le=16,
        description=(
            "Number K of flat colours, the primer (surface colour) included; the job makes K - 1 cut "
            "stencils. Range [2, 16]. An image with fewer distinct colours gets fewer layers and a "
            "warning. Ignored when `palette` is set."
        ),
    )
    palette: list[str] | Path | None = Field(
        None,
        description=(
            "Fixed paint colours as hex strings '#rrggbb' (2 to 16 entries), or the path of a CSV of "
            "cans (columns name, code, hex; relative to the config file), or null to pick K colours "
            "from the image (K-means). With order 'given' the first entry is the primer and the rest "
            "are sprayed in the listed order."
        ),
    )
    order: SprayOrder = Field(
        SprayOrder.light_to_dark,
        description=(
            "Spray order of the colours; the first colour is the primer. Choices: light_to_dark "
            "(by CIELAB lightness, the usual order: dark paint covers light paint), dark_to_light, "
            "given (the order of `palette`, which must then be set)."
        ),
    )
    smoothness: float = Field(
        6.0,
        ge=0.0,
        le=500.0,
        description=(
            "Potts smoothness weight of the graph-cut segmentation, in CIELAB ΔE units per pair of "
            "4-neighbour pixels with different colours (the data term is each pixel's ΔE to its "
            "colour). Range [0, 500]. 0 gives a plain nearest-colour map; larger values give "
            "smoother, blockier regions."
        ),
    )
    sweeps: int = Field(
        4,
        ge=1,
        le=50,
        description=(
            "Maximum alpha-expansion sweeps over all colours per segmentation round; a sweep that "
            "changes nothing stops early. Range [1, 50]."
        ),
    )
    rounds: int = Field(
        2,
        ge=1,
        le=10,
        description=(
            "Segmentation rounds: each runs the graph cut, merges small regions and re-estimates "
            "the colours as the mean of their pixels (fixed `palette` colours are kept). Range [1, 10]."
        ),
    )
    nozzle_height: float = Field(
        5.0,
        ge=0.0,
        le=1000.0,
        description=(
            "Paper model: the nozzle height h hard stencils are sprayed from (what spray.nozzle_height is for "
            "soft ones; the spraying steps tell the maker). Cut-outs keep sharp edges from low down: over "
            "astronaut, coffee and chelsea with FDM and SLA rules, h = 5 scored best on average by S-CIELAB "
            "from 1 m (h = 3 best on astronaut and chelsea, 5 on coffee; python -m benchmarks quality). "
            "Range [0, 1000]."
        ),
    )
    min_region_mm2: float = Field(
        4.0,
        ge=0.0,
        le=10000.0,
        description=(
            "Smallest flat-colour region in mm²; smaller regions merge into a neighbour and are "
            "counted. Range [0, 10000]. The process minimum feature squared is always enforced too."
        ),
    )
    bridge_width_mm: float | None = Field(
        None,
        gt=0.0,
        le=50.0,
        description=(
            "Width of the bridges that hold islands of sheet (like the middle of an 'O'), in mm, or "
            "null for the process minimum bridge width. Range (0, 50]; must not be below the "
            "process minimum."
        ),
    )
    bridge_visibility_weight: float = Field(
        4.0,
        ge=0.0,
        le=100.0,
        description=(
            "How strongly bridges avoid visible places: a bridge pixel costs 1 + weight × "
            "(ΔE between the layer's paint and the colour the bridge leaves showing) / 100 per unit "
            "length, and almost nothing where a later layer paints over it anyway. Range [0, 100]; "
            "0 gives the shortest bridges."
        ),
    )
    union_cut: bool = Field(
        True,
        description=(
            "Let a layer also cut the parts of later colours that would otherwise be islands in its "
            "sheet (they are painted over by their own layer later), removing those islands and "
            "their bridges. false cuts exactly each layer's own colour."
        ),
    )
    simplify_tolerance_mm: float = Field(
        0.1,
        ge=0.0,
        le=1.0,
        description=(
            "Douglas-Peucker tolerance in mm for the cut-out polygons. Range [0, 1]. It is capped at "
            "0.3 px of the working grid so that no edge moves across a pixel and neighbouring cut-outs "
            "never touch."
        ),
    )

    @field_validator("palette", mode="before")
    @classmethod
    def _check_palette(cls, v: object) -> object:
        if v is None or isinstance(v, Path):
            return v
        if isinstance(v, str):
            if v.lower().endswith(".csv"):
                return Path(v)
            raise ValueError(f"must be a list of colours, a .csv can list or null, got {v!r}")
        if not isinstance(v, (list, tuple)):
            raise ValueError(f"must be a list of colours, a .csv can list or null, got {v!r}")
        if not 2 <= len(v) <= 16:
            raise ValueError(f"palette needs 2 to 16 colours, got {len(v)}")
        return [parse_colour(c) for c in v]

    @model_validator(mode="after")
    def _cross_checks(self) -> HardConfig:
        if self.order == SprayOrder.given and self.palette is None:
            raise ValueError("hard.order 'given' needs hard.palette (the colours in spray order), got null")
        return self

    def palette_hex(self) -> HexPalette | None:
        """The fixed colours, or None to pick them from the image.

        Raises:
            ValueError: The palette is still a can list file (the pipeline reads it first).
        """
        return resolved_palette(self.palette, "hard.palette")
