"""Config section `plate.outline`: plate outline and the lock-and-key (owned by the wall/outline work)."""

from __future__ import annotations

import enum

from pydantic import Field, model_validator

from .base import StrictModel


class Side(str, enum.Enum):
    """A side of the plate, seen from above with the picture upright."""

    bottom = "bottom"
    right = "right"
    top = "top"
    left = "left"


class KeyTab(StrictModel):
    """One tab standing out of the plate outline; the wall's pocket has a matching notch."""

    side: Side = Field(
        Side.bottom, description="Side of the plate the tab stands on. Choices: bottom, right, top, left."
    )
    position: float = Field(
        0.3,
        gt=0.0,
        lt=1.0,
        description=(
            "Where the tab's centre sits along its side, as a fraction of the picture's width "
            "(bottom/top, from the left) or height (left/right, from the bottom). Range (0, 1). "
            "Keep it off 0.5 so that the plate cannot go in rotated or flipped."
        ),
    )
    width_mm: float = Field(
        12.0, gt=1.0, le=200.0, description="Width of the tab along its side in mm. Range (1, 200]."
    )
    depth_mm: float = Field(
        3.0,
        gt=0.5,
        le=30.0,
        description="How far the tab stands out of the plate's edge in mm. Range (0.5, 30]. Must exceed twice the wall clearance.",
    )


def _default_keys() -> list[KeyTab]:
    # Two tabs of different widths on two different sides, both off-centre: no rotation or
    # mirror of the plate (square or not) maps this set onto itself.
    return [
        KeyTab(side=Side.bottom, position=0.3, width_mm=14.0, depth_mm=3.0),
        KeyTab(side=Side.left, position=0.7, width_mm=7.0, depth_mm=3.0),
    ]


#: A plate's solid border, mm, when ``margin_mm`` is null: it rests on the wall's ledge with it, and
#: its bottom border carries the label.
PLATE_MARGIN_MM = 10.0
#: A soft mural's tile plate's border, mm, when ``margin_mm`` is null (the job's picture wider or
#: taller than the bed, :meth:`stencil_cad.config.JobConfig`): the ledge alone. Its plate already
#: reaches the spray halo past its tile on every side, solid, and its label rises into that band
#: below its lowest hole. Every tile's plate and the one wall shrink by twice 6 mm each way: on the
#: 600 x 400 mm coffee mural (``--bed prusa_mk4``) a plate's outline from 188 x 238 mm to 176 x 226 mm
#: (-11 % area). Four millimetres is the outline's corner radius and leaves a 4.2 mm ledge.
TILE_MARGIN_MM = 4.0


class OutlineConfig(StrictModel):
    """Plate outline, margin around the picture and the asymmetric key."""

    margin_mm: float | None = Field(
        None,
        ge=3.0,
        le=100.0,
        description=(
            "Solid border of the plate around the picture area on every side, in mm. Range [3, 100]. "
            "The plate rests on the wall's ledge with it, and the bottom border carries the label. "
            "null: 10, or 4 for a soft mural's tiles (a picture wider or taller than the bed), whose "
            "plates are solid a spray halo past their tile already and carry the label in that band."
        ),
    )

    corner_radius_mm: float = Field(
        4.0,
        ge=0.0,
        le=100.0,
        description="Radius of the plate's four outer corners in mm. Range [0, margin_mm]; 0 gives sharp corners.",
    )
    key_corner_radius_mm: float = Field(
        1.0,
        ge=0.0,
        le=10.0,
        description="Radius of the outer corners of each key tab in mm. Range [0, half the smallest tab width and below its depth].",
    )
    keys: list[KeyTab] = Field(
        default_factory=_default_keys,
        min_length=1,
        max_length=8,
        description=(
            "The asymmetric key: tabs on the plate outline that fit notches in the wall's pocket, so a "
            "plate goes in one way up and one way round only. 1 to 8 tabs; each has side, position, "
            "width_mm and depth_mm. Default: a 14 mm tab on the bottom at 0.3 and a 7 mm tab on the left at 0.7."
        ),
    )
    chord_tol_mm: float = Field(
        0.005,
        gt=0.0,
        le=0.5,
        description=(
            "Largest distance in mm between a rounded corner and the polygon that samples it in the "
            "outline ring (plate solid, DXF). Range (0, 0.5]."
        ),
    )
    label_gap_mm: float = Field(
        1.5,
        ge=0.0,
        le=20.0,
        description=(
            "Gap in mm between the label area in the bottom border and the picture area, the plate edge "
            "and the sides of the picture. Range [0, 20]; the label area is what is left of the bottom "
            "border (margin_mm - 2 * label_gap_mm high)."
        ),
    )

    @property
    def border_mm(self) -> float:
        """The plate's solid border in mm: ``margin_mm``, or for null a plate's (:data:`PLATE_MARGIN_MM`).

        A job's plan fills null in for its tiles (:func:`stencil_cad.plan.plan.planned`, with
        :func:`stencil_cad.config.job.job_margin`), so a planned outline reads the job's border here;
        an outline alone (a test, the card's own) reads a plate's.
        """
        return PLATE_MARGIN_MM if self.margin_mm is None else self.margin_mm

    @model_validator(mode="after")
    def _check(self) -> OutlineConfig:
        m = self.border_mm
        if self.corner_radius_mm > m:
            raise ValueError(
                f"corner_radius_mm must be ≤ margin_mm ({m} mm) so the corner never cuts the "
                f"picture, got {self.corner_radius_mm}"
            )
        if m - 2.0 * self.label_gap_mm < 1.0:
            raise ValueError(
                f"label_gap_mm must leave a label area ≥ 1 mm high in the margin: margin_mm - 2 * label_gap_mm "
                f"= {m - 2.0 * self.label_gap_mm:g} mm (margin_mm {m}, "
                f"label_gap_mm {self.label_gap_mm})"
            )
        for i, k in enumerate(self.keys):
            rk = self.key_corner_radius_mm
            if 2.0 * rk > k.width_mm or rk >= k.depth_mm:
                raise ValueError(
                    f"keys[{i}]: key_corner_radius_mm ({rk} mm) must be ≤ half the tab's width "
                    f"({0.5 * k.width_mm:g} mm) and < its depth ({k.depth_mm} mm)"
                )
        return self
