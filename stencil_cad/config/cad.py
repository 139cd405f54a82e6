"""Config sections `plate`, `wall` and `export` (owned by the CAD stage)."""

from __future__ import annotations

import enum
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

from pydantic import Field, field_validator, model_validator

from .base import StrictModel
from .outline import OutlineConfig
from .thickness import LABEL_FLOOR_MM

#: The plate's thickness a job with a plate template and no ``plate.thickness_mm`` records, mm (the
#: bundled templates' ``THICKNESS_MM``): the thinnest FDM plate of three 0.3 mm layers, which a job of
#: the default size and process fills in too.
DEFAULT_THICKNESS_MM = 0.9


@dataclass(frozen=True)
class Standoff:
    """The wall's stand-off a job uses, in mm: read through :attr:`stencil_cad.config.JobConfig.standoff`.

    ``wall.standoff_mm`` is only what the maker set (null: the job chooses); this record is what
    the job uses, whoever set it.

    Attributes:
        listed_mm: The stand-offs in the order a resolved config lists them (``wall.standoff_mm`` of
            the saved config and the manifest): the one the job chose for its picture; else the
            maker's, as given; else the process's (or hard mode's) default.
        source: Who set it: ``maker``, ``job`` (chosen for the picture) or ``default``.
    """

    listed_mm: tuple[float, ...]
    source: str

    @property
    def design_mm(self) -> float:
        """The stand-off the holes are designed, refined and simulated for: the first listed."""
        return self.listed_mm[0]

    @property
    def walls_mm(self) -> list[float]:
        """Every wall's stand-off, ascending and distinct: one wall is made per value."""
        return sorted(set(self.listed_mm))


class LabelMode(str, enum.Enum):
    """How the label is made on the plate's top face."""

    engrave = "engrave"
    emboss = "emboss"
    none = "none"


class PlateCheck(str, enum.Enum):
    """How a job checks each plate it writes."""

    file = "file"
    kernel = "kernel"


def _nullable_label(schema: dict) -> None:
    """The label's schema: one of the modes, or null (filled in by the job)."""
    schema.pop("$ref", None)
    schema.pop("allOf", None)
    schema["anyOf"] = [{"enum": [m.value for m in LabelMode]}, {"type": "null"}]
    schema["default"] = None


class PlateConfig(StrictModel):
    """The stencil plate: a flat sheet with a hole per dot, a solid border and a label."""

    outline: OutlineConfig = Field(
        default_factory=OutlineConfig, description="Plate outline, margin and key."
    )
    thickness_mm: float | None = Field(
        None,
        ge=0.3,
        le=20.0,
        description=(
            "Plate thickness in mm. Range [0.3, 20]. Plates are exported flat, z from 0 to the thickness. "
            "Thinner prints faster and shades the spray less; too thin sags on the wall's ledge. null: the "
            "thinnest plate the process makes for the plate's longest side (picture plus margins, a mural's "
            "tile), whose sag under its own weight stays within 5 % of the process's stand-off, and thick "
            "enough for an engraved label: fdm 0.3 mm (one layer; only with label emboss or none) up to a "
            "111 mm side, 0.4 mm (two 0.2 mm layers) up to 128 mm, then whole "
            "0.3 mm layers, 0.6 mm to 157, 0.9 to 192, 1.2 to 222, 1.5 to 248 (a mural's plates on posts: "
            "the span between posts); sla in 0.1 mm layers from 0.8 mm (0.8 up to 160 mm, 1.0 to 179, 1.2 "
            "to 196); laser a stock sheet, 1 mm PETG up to 193 mm, 1.5 mm to 236, 2 mm to 273, "
            "3 mm to 334 (for 0.25-0.5 mm film give its thickness and label: none). The summary and the "
            "instruction sheet say which and why."
        ),
    )
    label: LabelMode | None = Field(
        None,
        json_schema_extra=_nullable_label,
        description=(
            "Label on the top face's bottom border: layer number, spray order, paint colour, job name and "
            "an arrow pointing to the picture's top (it reads correctly only from above). "
            "Choices: engrave (cut into the top), emboss (raised), none. null: emboss on a soft FDM "
            "mural's plates (a picture wider or taller than the bed), whose plates may then be one 0.3 mm "
            "layer (an engraving needs a floor under it), engrave otherwise."
        ),
    )
    label_depth_mm: float = Field(
        0.2,
        gt=0.0,
        le=5.0,
        description=(
            "Depth of an engraved label, or height of an embossed one, in mm. Range (0, 5]; an engraving "
            "must leave ≥ 0.2 mm of plate under it (≤ thickness_mm - 0.2). The default 0.2 is one layer "
            "of the thinnest FDM plate (0.4 mm: two 0.2 mm layers), so it can carry it; on the shipped "
            "profile's 0.3 mm layers the slicer cuts it from the whole top layer."
        ),
    )
    label_height_mm: float = Field(
        4.0,
        ge=1.0,
        le=50.0,
        description=(
            "Font size of the label in mm. Range [1, 50]. The label shrinks to fit the label area of the "
            "border (outline.margin_mm - 2 * outline.label_gap_mm high), but never below label_min_height_mm."
        ),
    )
    label_min_height_mm: float = Field(
        2.0,
        ge=1.0,
        le=50.0,
        description=(
            "Smallest font size in mm the label may shrink to; below it the build fails with a message. "
            "Range [1, 50]."
        ),
    )
    label_font: str = Field(
        "DejaVu Sans",
        min_length=1,
        max_length=100,
        description="Font family of the label (a system font); OCCT's fallback font is used if it is missing.",
    )
    label_tolerance_mm: float = Field(
        0.01,
        gt=0.0,
        le=0.1,
        description=(
            "Largest distance in mm between a letter's curved outline and the polygon that replaces it in "
            "the plate. Range (0, 0.1]. Letters are polygons so that STEP, STL and B-rep agree exactly."
        ),
    )
    min_web_mm: float = Field(
        0.1,
        gt=0.0,
        le=5.0,
        description=(
            "Smallest web in mm between two holes that the plate accepts when it re-checks the dots (the "
            "stipple stage enforces the process web; every hole must lie inside the picture). Range (0, 5]. "
            "Dots that break it, or holes below the 0.5 mm radius floor, stop the build with a list."
        ),
    )
    check: PlateCheck = Field(
        PlateCheck.file,
        description=(
            "How each plate is checked before its files are written. Choices: file (the STEP text written, "
            "read back without the CAD kernel: one closed, consistently oriented solid whose genus is the "
            "hole count, every edge on its faces, volume by the divergence theorem equal to the analytic "
            "one, bounding box, no hole crossing or touching another, a window, a letter or the outline; "
            "plus the mesh's checks), kernel (OCCT builds the plate's solid and checks it: topology, "
            "volume, bounding box and BRepCheck_Analyzer, on tiles above full_check_max_holes; plus the "
            "mesh's checks; slower). A template that returns its "
            "own solid is always checked by OCCT. The walls follow: file, each wall's STEP text drawn "
            "from its outlines and read back the same way (one closed solid with the opening as its one "
            "hole, its analytic volume, its box); kernel, OCCT cuts the wall and checks and writes it."
        ),
    )
    full_check_max_holes: int = Field(
        300,
        ge=0,
        le=100000,
        description=(
            "With check: kernel, plates with at most this many holes get OCCT's full B-rep check "
            "(BRepCheck_Analyzer, whose cost grows with the square of the hole count on one face); larger "
            "plates are checked on tiles of the same construction plus linear whole-plate checks. Range "
            "[0, 100000]."
        ),
    )
    template: Path | None = Field(
        None,
        description=(
            "Plate template: a Python file with module-level parameters and build(...), like "
            "templates/plate.py (build123d) or templates/plate_cadquery.py (CadQuery, needs the cadquery "
            "extra). A relative path is taken from the config file's folder. null: the built-in template. "
            "A template is Python code and runs with your rights: use only templates you trust (a shared "
            "config that names a template shares that code)."
        ),
    )
    template_params: dict[str, float | int | bool | str] = Field(
        default_factory=dict,
        description=(
            "Values for the template's own module-level parameters, by name (UPPER_CASE, as in the file). "
            "A name the template does not define is an error."
        ),
    )

    @property
    def planned_thickness_mm(self) -> float:
        """The plate's thickness in mm, as given or as the job's plan filled it in.

        Raises:
            ValueError: ``thickness_mm`` is null: the plate is not planned yet (the job's plan fills it
                in, :func:`stencil_cad.plan.plan.planned`).
        """
        if self.thickness_mm is None:
            raise ValueError("plate.thickness_mm is null: the job's plan fills it in (stencil_cad.plan.plan)")
        return self.thickness_mm

    @model_validator(mode="after")
    def _check(self) -> PlateConfig:
        if self.label is not None and self.thickness_mm is not None:
            self.check_label(self.label, self.thickness_mm)
        if self.label_min_height_mm > self.label_height_mm:
            raise ValueError(
                f"label_min_height_mm must be ≤ label_height_mm ({self.label_height_mm} mm), "
                f"got {self.label_min_height_mm}"
            )
        return self

    def check_label(self, label: LabelMode, thickness_mm: float) -> None:
        """Refuse an engraved ``label`` (the plate's, or the one its job fills in for null) deeper than the plate allows.

        ``thickness_mm``: the plate's thickness, or for null the one its job fills in (the job config checks it).

        Raises:
            ValueError: ``label_depth_mm`` leaves less than :data:`LABEL_FLOOR_MM` of plate under an engraving.
        """
        if label is LabelMode.engrave and self.label_depth_mm > thickness_mm - LABEL_FLOOR_MM + 1e-9:
            raise ValueError(
                f"label_depth_mm must be ≤ thickness_mm - {LABEL_FLOOR_MM:g} "
                f"({thickness_mm - LABEL_FLOOR_MM:g} mm) for an engraved label, got {self.label_depth_mm}"
            )


class WallConfig(StrictModel):
    """The interlocking wall: a frame standing on the surface that holds every plate at a stand-off height.

    Its inner opening is the picture area (plus ``opening_margin_mm``), so it never shadows the
    picture and keeps overspray inside it; at its top a pocket, the plate outline offset by the
    clearance, takes the plate, whose key tabs drop into matching notches.
    """

    standoff_mm: (
        Annotated[list[Annotated[float, Field(ge=0.5, le=300.0)]], Field(min_length=1, max_length=8)] | None
    ) = Field(
        None,
        description=(
            "Stand-off heights in mm: the plate's underside above the sprayed surface. One wall is made "
            "per value, and every wall takes the same plates. Each in [0.5, 300]; 1 to 8 values. "
            "A wall's total height is its stand-off plus the pocket depth. Under the physical spray "
            "model it sets every hole's blur (sigma = sqrt(bleed^2 + (spread_k * stand-off)^2)). null: "
            "the height the job's stencils score best from, seen from 1 m (python -m benchmarks quality): "
            "10 mm for every process's soft stencils (fdm, sla and laser holes share the 0.5 mm floor), 1 mm for hard stencils, whose cut-outs keep sharp edges low down "
            "(astronaut 8.5 / 9.1 / 12.4 at 1 / 3 / 10 mm). A soft one-plate job then tries that height, 2 mm "
            "either side (the bundled example: 3.99 / 3.66 at 10 / 8 mm, refined), 5 mm "
            "lower (fine texture: grass 4.69 / 2.73 at 10 / 5 mm) and 5 mm higher (photos' dots may blend "
            "better: rocket), a measured can's blur-matched height, and where windows carry at least "
            "half the paint (a logo, flat-colour art) 1 and 4 mm for the windows too (the generated logo: 2.00 / "
            "0.92 / 0.88 at 10 / 4 / 1 mm), by stippling and spraying its unrefined plates, and takes the best "
            "(the best refined beside the best of another height). With light plates (a one-plate job's "
            "default), windows carrying almost none of the paint and no measured can, it refines its "
            "plates for 5 and 2 mm below that height outright and keeps the better (unrefined plates rank "
            "light plates' walls badly), ranked after 30 of their refinement's steps where those tell them "
            "apart, the winner alone refined in full. A lower wall gets a plate filled thicker "
            "for its sag. The chosen height is saved in the run's config."
        ),
    )
    clearance_mm: float = Field(
        0.2,
        ge=0.0,
        le=2.0,
        description="Gap in mm between the plate's outline and the wall's pocket, all round. Range [0, 2].",
    )
    wall_thickness_mm: float = Field(
        3.0,
        ge=1.0,
        le=30.0,
        description="Thickness in mm of the wall's rim outside the pocket and its notches. Range [1, 30].",
    )
    opening_margin_mm: float = Field(
        0.0,
        ge=0.0,
        le=50.0,
        description=(
            "How far in mm the wall's inner opening reaches beyond the picture area on every side. "
            "Range [0, 50], and it must leave a ledge ≥ 1 mm under the plate's border "
            "(plate.outline.margin_mm + clearance_mm - opening_margin_mm). 0 puts the wall's inner "
            "face on the picture's edge, which gives the sharpest edge of spray."
        ),
    )
    pocket_depth_mm: float | None = Field(
        None,
        gt=0.0,
        le=50.0,
        description=(
            "Depth in mm of the pocket the plate sits in, at most the plate's thickness. Range (0, 50]. "
            "null: the plate's thickness, so the plate's top is flush with the wall's top."
        ),
    )

    finger_slot_mm: float = Field(
        16.0,
        ge=0.0,
        le=100.0,
        description=(
            "Width in mm of a slot through the rim at the middle of the top side, reaching 3 mm under the "
            "plate's edge and 1.5 mm below it, to lift the plate out with a fingernail. Range [0, 100]; "
            "0: no slot."
        ),
    )

    @field_validator("standoff_mm", mode="before")
    @classmethod
    def _one_standoff(cls, v):
        # One number where a list is asked: the one stand-off the user meant. null stays null: the
        # job chooses (JobConfig.standoff says what it uses).
        return [v] if isinstance(v, (int, float)) and not isinstance(v, bool) else v

    def pocket_depth(self, plate_thickness_mm: float) -> float:
        """Pocket depth in mm for a plate of the given thickness."""
        return plate_thickness_mm if self.pocket_depth_mm is None else self.pocket_depth_mm

    def check_plate(self, outline: OutlineConfig, plate_thickness_mm: float) -> None:
        """Cross-checks against the plate; the job config calls this.

        Args:
            outline: The plate's outline config.
            plate_thickness_mm: The plate's thickness in mm.

        Raises:
            ValueError: Naming the value and its limit.
        """
        if self.pocket_depth_mm is not None and self.pocket_depth_mm > plate_thickness_mm:
            raise ValueError(
                f"wall.pocket_depth_mm must be ≤ plate thickness ({plate_thickness_mm} mm), got {self.pocket_depth_mm}"
            )
        ledge = outline.border_mm + self.clearance_mm - self.opening_margin_mm
        if ledge < 1.0:
            raise ValueError(
                f"wall.opening_margin_mm must leave a ledge ≥ 1 mm under the plate: plate.outline.margin_mm "
                f"({outline.border_mm}) + clearance_mm ({self.clearance_mm}) - opening_margin_mm "
                f"({self.opening_margin_mm}) = {ledge:g} mm"
            )
        for i, k in enumerate(outline.keys):
            if k.depth_mm <= 2.0 * self.clearance_mm:
                raise ValueError(
                    f"plate.outline.keys[{i}].depth_mm must exceed twice wall.clearance_mm "
                    f"({2.0 * self.clearance_mm:g} mm), got {k.depth_mm}"
                )


class ExportConfig(StrictModel):
    """Which files are written and how."""

    step: bool = Field(
        True, description="Write a STEP file per plate (exact circles, one solid). true/false."
    )
    stl: bool = Field(
        True, description="Write a binary STL per plate (watertight, consistently wound). true/false."
    )
    dxf: bool = Field(
        True, description="Write a DXF per plate for laser cutting (outline and holes). true/false."
    )
    svg: bool = Field(
        True,
        description=(
            "Write an SVG per plate for cutters that take SVG but not DXF (Glowforge, Cricut, Silhouette): "
            "mm units, a circle per hole, the outline as a path, the same frame as the DXF. true/false."
        ),
    )
    instructions: bool = Field(
        True,
        description=(
            "Write the instruction sheet of a whole job (`run`, `hard`): instructions.html (self-contained, "
            "opens offline) and instructions.pdf. true/false."
        ),
    )
    three_mf: bool = Field(
        False, description="Also write a 3MF mesh per plate (same mesh as the STL). true/false."
    )
    print_estimate: bool = Field(
        False,
        description=(
            "Slice every plate and wall with the shipped prusa_fdm profile (as `stencil-cad slice` does, on "
            "the job's bed when `bed` is set; needs PrusaSlicer and the STL export) and put PrusaSlicer's "
            "estimated print time and filament per part, and their total, in manifest.json and on the "
            "instruction sheet. Adds about half a minute of slicing per thousand holes. A mural's parts are "
            "not sliced by the job: run `stencil-cad slice` on them. true/false."
        ),
    )
    stl_tolerance_mm: float = Field(
        0.02,
        ge=0.001,
        le=0.5,
        description=(
            "Largest distance in mm between a round hole and the polygon that replaces it in the STL/3MF. "
            "Range [0.001, 0.5]. Hole polygons keep each hole's exact area (the spray flow follows it)."
        ),
    )
    dxf_kerf_mm: float | None = Field(
        None,
        ge=0.0,
        le=1.0,
        description=(
            "Laser kerf in mm; DXF and SVG contours are offset by half of it so cut parts keep their size. "
            "Range [0, 1]. null for the process preset: 0.2 mm for stipple.process laser (a CO2 laser in "
            "card, PET or 3 mm plywood cuts 0.1-0.3 mm wide; measure yours with a test cut), 0 for fdm and "
            "sla, whose DXF is only a drawing."
        ),
    )

    @property
    def kerf_mm(self) -> float:
        """The laser kerf in mm (0 when not resolved from the process)."""
        return float(self.dxf_kerf_mm or 0.0)
