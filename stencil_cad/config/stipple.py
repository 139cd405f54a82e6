"""Config section `stipple` (owned by the stipple stage).

The process (``stipple.process``, :mod:`.process`) presets the hole floor, the minimum web
between holes, the margin to the picture edge / label area and the hole offset; its record says
where each value comes from.

The global hole floor is r = 0.5 mm whatever the preset: a spray stencil hole
smaller than 1 mm across clogs with paint.
"""

from __future__ import annotations

import enum
import logging
from collections.abc import Sequence

from pydantic import Field, field_validator, model_validator

from .base import StrictModel
from .process import PROCESSES, Process
from .rules import HOLE_FLOOR_MM, DesignRules, HoleSizes, as_rect

log = logging.getLogger(__name__)


class Tone(str, enum.Enum):
    """How a layer's opacity becomes the stippling density."""

    linear = "linear"
    response = "response"


#: Old values of ``stipple.tone`` read for one release (old -> new): the tone mode was called
#: ``calibrated``, a word that also names the photo-fit command ``stencil-cad calibrate``.
TONE_RENAMED: dict[str, Tone] = {"calibrated": Tone.response}


class Windows(str, enum.Enum):
    """Whether a layer's plate may open windows where it is solid."""

    auto = "auto"
    off = "off"


class LightPlates(str, enum.Enum):
    """Whether each paint is sprayed through a light plate and a dark plate."""

    auto = "auto"
    on = "on"
    off = "off"


class StippleConfig(StrictModel):
    """Settings of the stipple stage: dot count, hole sizes and design rules."""

    process: Process = Field(
        Process.fdm,
        description=(
            "Manufacturing process; sets the hole floor, web and edge margin unless they are given. "
            f"Choices: {', '.join(rec.choice(p.value) for p, rec in PROCESSES.items())}; every preset's "
            "edge margin is 0 (the plate's solid border holds holes at the picture's edge)."
        ),
    )
    hole_min_r_mm: float | None = Field(
        None,
        ge=HOLE_FLOOR_MM,
        le=20.0,
        description="Smallest hole radius in mm, or null for the process preset. Range [0.5, 20].",
    )
    web_mm: float | None = Field(
        None,
        gt=0.0,
        le=20.0,
        description=(
            "Minimum web (material left) between two holes in mm: centre distance >= r_i + r_j + web. "
            "null for the process preset (fdm: 0.7 mm when the plate is one layer, 0.6 mm otherwise). Range (0, 20]."
        ),
    )
    edge_margin_mm: float | None = Field(
        None,
        ge=0.0,
        le=100.0,
        description=(
            "Minimum material between a hole and the picture-area border or a keep-out rectangle, in mm. "
            "null for the process preset (0: holes may reach the picture's edge, where the plate's solid "
            "border holds them, and touch a keep-out; give a margin to keep material around a fixture in a "
            "keep-out, or a pale band along the edge is the price). Range [0, 100]."
        ),
    )
    hole_offset_mm: float | None = Field(
        None,
        ge=-0.5,
        le=0.5,
        description=(
            "How much narrower (radius, mm) the process makes a hole than it is drawn; negative when it "
            "makes it wider. null for the process preset: fdm 0.015 (measured from the G-code of the "
            "shipped prusa_fdm profile, python -m benchmarks printed), sla 0.02 (resin over-cure; a prior, "
            "not measured), laser 0 (the DXF and SVG already offset every cut by half of "
            "export.dxf_kerf_mm, 0.2 mm by default for laser: set it to your cutter's kerf). Range [-0.5, 0.5]."
        ),
    )
    compensate: bool = Field(
        True,
        description=(
            "Draw every hole larger by hole_offset_mm so the made hole has the radius the stippler asked "
            "for; the web rule holds on the plate as made (a drawn web 2 x hole_offset_mm under web_mm "
            "prints web_mm wide), and a hole at the picture's edge or a keep-out grows only as far as the "
            "margin allows. The simulation sprays the made holes either way."
        ),
    )
    keepouts_mm: list[tuple[float, float, float, float]] = Field(
        default_factory=list,
        description=(
            "Keep-out rectangles (label area, fixtures) in picture mm as [x0, y0, x1, y1] with x right, "
            "y up, origin at the bottom-left of the picture area; no hole comes within edge_margin_mm."
        ),
    )
    dots: int | None = Field(
        None,
        ge=1,
        le=2_000_000,
        description=(
            "Number of dots per layer before the design rules, or null to derive it from the hole radius, "
            "the web and the layer's ink. Range [1, 2000000]."
        ),
    )
    radius_mm: float | None = Field(
        None,
        ge=HOLE_FLOOR_MM,
        le=20.0,
        description=(
            "Hole radius in mm (the smallest radius when variable_radius is on), or null for the hole "
            "floor. Range [0.5, 20]; must be >= the hole floor."
        ),
    )
    variable_radius: bool = Field(
        False,
        description=(
            "Larger holes where the density is high: r = radius + (max_radius - radius) * sqrt(density), "
            "under the same web rule."
        ),
    )
    max_radius_mm: float | None = Field(
        None,
        ge=HOLE_FLOOR_MM,
        le=40.0,
        description=(
            "Largest hole radius in mm when variable_radius is on, or null for 2 x radius. Range [0.5, 40]; "
            "must be >= radius."
        ),
    )
    opacity_threshold: float = Field(
        0.05,
        ge=0.0,
        lt=1.0,
        description="No hole where the layer opacity is below this value. Range [0, 1).",
    )
    tone: Tone = Field(
        Tone.response,
        description=(
            "Opacity-to-density curve. Choices: response (the density the spray simulator derives from the "
            "spray response, the best the tool knows; called calibrated before), linear (open area proportional to opacity, as in Secord 2002 and the "
            "paper)."
        ),
    )
    auto_spacing_factor: float = Field(
        1.15,
        ge=1.0,
        le=4.0,
        description=(
            "With dots: null, the densest tone (opacity 1) is packed at this multiple of the minimum centre "
            "spacing 2 r + web, leaving slack for the relaxation's irregularity. Range [1, 4]."
        ),
    )
    max_iterations: int = Field(
        50,
        ge=0,
        le=10_000,
        description="Maximum Lloyd relaxation iterations. Range [0, 10000]; 0 keeps the importance-sampled start.",
    )
    tolerance_px: float = Field(
        0.02,
        ge=0.0,
        le=10.0,
        description=(
            "Stop the relaxation when the mean centroid move of one iteration is below this, in pixels. "
            "Range [0, 10]."
        ),
    )

    windows: Windows = Field(
        Windows.auto,
        description=(
            "Open windows (polygon cut-outs, islands held by bridges) where a layer is near fully opaque "
            "over an area at least min_window_mm across, holes around them. Choices: auto (a one-plate job "
            "tries its plates with and without windows, stippled and sprayed unrefined, and keeps the better: "
            "windows can cost a photo more than they give), off (holes only)."
        ),
    )
    light_plates: LightPlates = Field(
        LightPlates.auto,
        description=(
            "Spray each paint through two plates: a light plate for its light tones (up to 40 % opacity), "
            "given the smaller dose its tone calibration asks for, so light tones are many close holes "
            "instead of a few far apart, and a dark plate for the rest, with the same can "
            "(stencil_cad.decompose.light). Choices: auto (on for a one-plate job under the physical spray "
            "model; off for a mural, whose plates would double its printer-hours), on, off (one plate per "
            "paint). The bundled example: S-CIELAB at 1 m 2.68 with light plates, 3.71 without; twice the "
            "plates to print and spray."
        ),
    )
    min_window_mm: float = Field(
        6.0,
        ge=2.0,
        le=500.0,
        description=(
            "Smallest window, in mm: a disc this wide must fit inside a window's solid area. Range "
            "[2, 500]; raised to 4 hole pitches when that is larger."
        ),
    )
    window_opacity: float = Field(
        0.85,
        ge=0.5,
        le=1.0,
        description=(
            "A layer's opacity from which it counts as solid for a window (1 = only full coats). "
            "Range [0.5, 1]."
        ),
    )

    @field_validator("light_plates", mode="before")
    @classmethod
    def _yaml_on_off(cls, value: object) -> object:
        """YAML reads an unquoted ``on`` / ``off`` as true / false: the user meant ``on`` / ``off``."""
        return (
            {True: LightPlates.on, False: LightPlates.off}.get(value, value)
            if isinstance(value, bool)
            else value
        )

    @field_validator("windows", mode="before")
    @classmethod
    def _yaml_off(cls, value: object) -> object:
        """YAML reads an unquoted ``off`` (and ``no``, ``false``) as false: the user meant ``off``."""
        return Windows.off if value is False else value

    @field_validator("tone", mode="before")
    @classmethod
    def _renamed_tone(cls, value: object) -> object:
        """Read a tone by its old name and say so (``calibrated`` is now ``response``)."""
        new = TONE_RENAMED.get(value) if isinstance(value, str) else None
        if new is None:
            return value
        log.warning(
            "stipple.tone: %s is now called %s; the old value is read until the next release, change it",
            value,
            new.value,
        )
        return new

    @field_validator("keepouts_mm")
    @classmethod
    def _check_keepouts(cls, value: list[tuple[float, float, float, float]]):
        for k, (x0, y0, x1, y1) in enumerate(value):
            if not (x1 > x0 and y1 > y0):
                raise ValueError(f"keep-out {k} must have x1 > x0 and y1 > y0, got [{x0}, {y0}, {x1}, {y1}]")
        return value

    @property
    def hole_floor_mm(self) -> float:
        """The job's hole floor: the smallest hole radius in mm (``hole_min_r_mm`` or the process preset).

        The one route to the floor: a module that needs it reads this property, or the
        ``DesignRules`` built from it when it is handed no config (a house test keeps it so).
        """
        if self.hole_min_r_mm is not None:
            return float(self.hole_min_r_mm)
        return self.process.record.hole_min_r_mm

    @property
    def tone_from_response(self) -> bool:
        """True when the density comes from the spray response (``tone: response``)."""
        return self.tone == Tone.response

    def design_rules(self, width_mm: float, height_mm: float, keepouts: Sequence = ()) -> DesignRules:
        """The design rules of a hole set over a picture area (process presets resolved).

        Args:
            width_mm: Picture-area width in mm.
            height_mm: Picture-area height in mm.
            keepouts: Extra keep-out rectangles ``(x0, y0, x1, y1)`` in picture mm (for example
                the label area the CAD stage chose), added to ``keepouts_mm``.
        """
        sizes = self.sizes
        return DesignRules(
            hole_min_r_mm=self.hole_floor_mm,
            web_mm=sizes.web_mm,
            edge_margin_mm=sizes.edge_margin_mm,
            width_mm=float(width_mm),
            height_mm=float(height_mm),
            keepouts=tuple(as_rect(k) for k in self.keepouts_mm) + tuple(as_rect(k) for k in keepouts),
        )

    @property
    def sizes(self) -> HoleSizes:
        """The holes' sizes and spacings, each as given or its process's preset: the one place they are resolved."""
        record = self.process.record
        radius = float(self.radius_mm) if self.radius_mm is not None else self.hole_floor_mm
        if not self.variable_radius:
            largest = radius
        elif self.max_radius_mm is not None:
            largest = float(self.max_radius_mm)
        else:
            largest = 2.0 * radius
        return HoleSizes(
            radius_mm=radius,
            max_radius_mm=largest,
            web_mm=float(self.web_mm) if self.web_mm is not None else record.web_mm,
            edge_margin_mm=float(self.edge_margin_mm)
            if self.edge_margin_mm is not None
            else record.edge_margin_mm,
            hole_offset_mm=float(self.hole_offset_mm)
            if self.hole_offset_mm is not None
            else record.hole_offset_mm,
        )

    @property
    def densest_pitch_mm(self) -> float:
        """Centre spacing of the densest hole pattern, mm: ``auto_spacing_factor * (2 r_max + web)`` (:attr:`sizes`)."""
        sizes = self.sizes
        return self.auto_spacing_factor * (2.0 * sizes.max_radius_mm + sizes.web_mm)

    @model_validator(mode="after")
    def _cross_checks(self) -> StippleConfig:
        floor = self.hole_floor_mm
        if self.radius_mm is not None and self.radius_mm < floor:
            raise ValueError(
                f"radius_mm must be ≥ the hole floor ({floor} mm for process {self.process.value}), "
                f"got {self.radius_mm}"
            )
        if self.variable_radius and self.max_radius_mm is not None:
            radius = self.sizes.radius_mm
            if self.max_radius_mm < radius:
                raise ValueError(f"max_radius_mm must be ≥ radius_mm ({radius} mm), got {self.max_radius_mm}")
        return self
