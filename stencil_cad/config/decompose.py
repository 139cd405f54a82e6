"""Config section `decompose` (owned by the decompose stage)."""

from __future__ import annotations

import enum
from pathlib import Path
from typing import Literal

from pydantic import Field, field_validator, model_validator

from ..colour import colour_to_rgb, parse_colour
from .base import HexPalette, StrictModel, resolved_palette

#: Largest number of paint layers a job may ask for. Each layer is one printed
#: plate and one spray pass; beyond eight the plates stop paying for themselves
#: and the colour step's normal equations (L + 1 unknowns) gain nothing.
MAX_LAYERS = 8


class LayerOrder(str, enum.Enum):
    """Spray order of the paint layers."""

    auto = "auto"
    light_to_dark = "light_to_dark"
    given = "given"


class OpacitySource(str, enum.Enum):
    """Where the opacity maps come from."""

    auto = "auto"
    rgb = "rgb"
    grey = "grey"
    alpha = "alpha"


class EnergyWeights(StrictModel):
    """Weights of the three energy terms (Vavilala 2015, eq. 1).

    Colours and opacities are in [0, 1] and every term is a plain sum over
    pixels, so the weights are dimensionless. The paper gives no values; the
    defaults were chosen on scikit-image's astronaut photo, where they give a
    composite RMSE of about 1.7 (L = 4) and 0.6 (L = 6) in 0-255 units at
    256 x 256 px, against targets of 3 and 1.5; smooth = sparse = 1e-3 gave
    2.8 at L = 4.
    """

    data: float = Field(
        1.0,
        gt=0.0,
        le=1e6,
        description=(
            "gamma_data: weight of the reconstruction term sum_p |X_p - Y_p|^2 (colours in [0, 1]). "
            "Range (0, 1e6]. Only its ratio to the other two weights matters."
        ),
    )
    smooth: float = Field(
        5e-4,
        ge=0.0,
        le=1e6,
        description=(
            "gamma_smooth: weight of the 8-neighbour opacity smoothness term "
            "sum_l sum_p sum_{n in N8(p)} (alpha_l(p) - alpha_l(n))^2. Range [0, 1e6]. Larger values give "
            "smoother, easier-to-stipple opacity maps and a blurrier reconstruction. Defaults to 5e-4."
        ),
    )
    sparse: float = Field(
        2e-4,
        ge=0.0,
        le=1e6,
        description=(
            "gamma_sparse: weight of the sparsity term sum_p (1 - sum_l alpha_l(p))^2, which favours "
            "about one full coat of paint per pixel. Range [0, 1e6]. Defaults to 2e-4."
        ),
    )


class DecomposeConfig(StrictModel):
    """Settings of the decompose stage: primer + L alpha-blended paint layers."""

    layers: int = Field(
        4,
        ge=1,
        le=MAX_LAYERS,
        description=(
            f"Number of paint layers L, sprayed over the primer. Integer in [1, {MAX_LAYERS}]. Each is one "
            "plate, or two (a light and a dark plate of its paint) with stipple.light_plates. "
            "With a palette list of N cans and N > layers, the best `layers` cans are chosen; with "
            "N <= layers all N cans are used. An image with fewer distinct colours than L + 1 gets "
            "fewer layers (with a warning)."
        ),
    )
    weights: EnergyWeights = Field(
        default_factory=EnergyWeights,
        description="Energy weights gamma_data, gamma_smooth, gamma_sparse (dimensionless).",
    )
    tolerance: float = Field(
        1e-2,
        gt=0.0,
        lt=1.0,
        description=(
            "Stop when one solver iteration lowers the energy by less than this fraction of it. Range (0, 1). "
            "Pyramid levels with at most 1/16 of the finest level's pixels use a quarter of it (they are "
            "cheap, and a better start saves fine iterations). Defaults to 0.01."
        ),
    )
    max_iterations: int = Field(
        200,
        ge=1,
        le=10000,
        description=(
            "Most solver iterations per pyramid level (each: all opacity maps, then all colours). "
            "Range [1, 10000]."
        ),
    )
    inner_tolerance: float = Field(
        1e-3,
        gt=0.0,
        lt=1.0,
        description=(
            "One layer's opacity QP counts as solved when a projected SOR sweep changes no opacity by "
            "more than this (opacity units; 1e-3 is a quarter of an 8-bit level). Range (0, 1)."
        ),
    )
    inner_max_sweeps: int = Field(
        100,
        ge=1,
        le=10000,
        description="Most projected SOR sweeps per opacity QP. Range [1, 10000].",
    )
    palette: Literal["auto"] | tuple[str, ...] | Path = Field(
        "auto",
        description=(
            "Paint colours. 'auto': found by K-means and then refined by the solver (and snapped to "
            "paints.catalogue when that is set). Or a list of the cans you own, each a hex string "
            "'#1a2b3c' or [r, g, b] with integers 0-255, or the path of a CSV of cans (columns name, code, "
            "hex; relative to the config file): the colours are held fixed and only the opacities (and an "
            f"'auto' primer) are solved. 1 to {3 * MAX_LAYERS} cans."
        ),
    )
    primer: str = Field(
        "auto",
        description=(
            "Primer (base coat) colour. 'auto': solved with the paints (white for opacity_source grey or alpha). "
            "Or a hex string '#ffffff' / [r, g, b] 0-255: held fixed."
        ),
    )
    order: LayerOrder = Field(
        LayerOrder.auto,
        description=(
            "Spray order. Choices: auto (the order whose short coarse solve reaches the lowest energy), "
            "light_to_dark (by luminance, lightest paint first), given (the palette list order; needs a "
            "palette list)."
        ),
    )
    opacity_source: OpacitySource = Field(
        OpacitySource.auto,
        description=(
            "Choices: auto (the image's colours are decomposed, a grey image's into grey paints; the "
            "same as rgb), rgb, grey (one layer of black whose opacity is the image's darkness, over a "
            "white primer: one plate, but its sparse dark dots show at light tones; the fidelity "
            "benchmark's grass photo scored S-CIELAB 4.57 at 1 m as one black layer and 2.79 as three "
            "greys over black), alpha (the image's alpha channel is the opacity of one layer; needs an "
            "RGBA image)."
        ),
    )
    min_delta_e: float = Field(
        2.0,
        ge=0.0,
        le=50.0,
        description=(
            "Smallest colour difference (CIEDE2000 Delta E, sRGB under D65) kept between two paints and "
            "between a paint and the primer. Range [0, 50]; 0 keeps every layer. After the solve, a paint "
            "closer than this to the primer is dropped, and of two paints closer than this to each other "
            "the one with less paint is dropped (merged into the other); the rest is then re-solved, with "
            "a warning. About 2.3 is a just-noticeable difference. Defaults to 2.0."
        ),
    )
    min_opacity: float = Field(
        0.05,
        ge=0.0,
        lt=1.0,
        description=(
            "A layer whose opacity stays below this everywhere sprays no visible ink and is dropped (with "
            "a warning). Opacity units, range [0, 1); 0 keeps every layer. Defaults to 0.05."
        ),
    )
    coarse_to_fine: bool = Field(
        True,
        description=(
            "Solve on a pyramid (longer side halved down to `coarse_size_px`) and start each level from "
            "the one below. Much faster on large images."
        ),
    )
    coarse_size_px: int = Field(
        96,
        ge=16,
        le=4096,
        description="Longer side in px of the coarsest pyramid level. Range [16, 4096].",
    )

    @field_validator("palette", mode="before")
    @classmethod
    def _parse_palette(cls, value: object) -> object:
        if isinstance(value, Path):
            return value
        if isinstance(value, str):
            if value == "auto":
                return value
            if value.lower().endswith(".csv"):
                return Path(value)
            raise ValueError(f"must be 'auto', a list of colours or a .csv can list, got {value!r}")
        if isinstance(value, (list, tuple)):
            if not 1 <= len(value) <= 3 * MAX_LAYERS:
                raise ValueError(f"must hold 1 to {3 * MAX_LAYERS} colours, got {len(value)}")
            return tuple(parse_colour(v) for v in value)
        raise ValueError(f"must be 'auto', a list of colours or a .csv can list, got {value!r}")

    @field_validator("primer", mode="before")
    @classmethod
    def _parse_primer(cls, value: object) -> object:
        if value == "auto":
            return value
        return parse_colour(value)

    @model_validator(mode="after")
    def _cross_checks(self) -> DecomposeConfig:
        if self.order is LayerOrder.given and self.palette == "auto":
            raise ValueError("order: 'given' needs a palette list, got palette: 'auto'")
        return self

    def palette_hex(self) -> HexPalette | None:
        """The palette list, or None for 'auto'.

        Raises:
            ValueError: The palette is still a can list file (the pipeline reads it first).
        """
        return resolved_palette(self.palette, "decompose.palette")

    def palette_rgb(self) -> tuple[tuple[float, float, float], ...] | None:
        """The palette as RGB triples in [0, 1], or None for 'auto'."""
        hexes = self.palette_hex()
        return None if hexes is None else tuple(colour_to_rgb(c) for c in hexes)

    def primer_rgb(self) -> tuple[float, float, float] | None:
        """The fixed primer as an RGB triple in [0, 1], or None for 'auto'."""
        if self.primer == "auto":
            return None
        return colour_to_rgb(self.primer)
