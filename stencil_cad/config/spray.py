"""Config section `spray` (owned by the spray stage)."""

from __future__ import annotations

import enum

from pydantic import Field, field_validator

from .base import StrictModel


class Calibrate(str, enum.Enum):
    """How the calibrated tone curve picks the free spray parameter of each layer."""

    none = "none"
    dots = "dots"
    spray_time = "spray_time"


class SprayConfig(StrictModel):
    """Settings of the spray simulation and of the tone calibration.

    The spray model is the paper's: a hole of radius r at p_i leaves the
    Gaussian N_i(p) = A exp(-|p - p_i|^2 / (2 sigma_i^2)) with
    sigma_i^2 = r^2 (1 + h) / 4, and the layer's opacity is
    I = 1 - prod_i (1 - min(N_i, 1)).
    """

    spray_time: float = Field(
        1.0,
        gt=0.0,
        le=100.0,
        description=(
            "Spray time A: the peak paint density one hole deposits (dimensionless; 1 = a hole's centre just "
            "reaches full cover). Range (0, 100]. The tone calibration may choose it per layer "
            "(spray.calibrate: spray_time); this is then the starting value."
        ),
    )
    nozzle_height: float = Field(
        7.0,
        ge=0.0,
        le=1000.0,
        description=(
            "Nozzle height h of the paper, dimensionless: the extra spread of the paint as a multiple of the "
            "hole's own spread. A hole of radius r sprays a Gaussian dot of sigma = r * sqrt(1 + h) / 2 "
            "(r^2 / 4 is the variance of a uniform disc, so h = 0 puts the paint exactly under the hole and "
            "the dot's variance grows linearly with h, i.e. with the nozzle's distance). To fit it to a real "
            "can, spray one test hole and measure the dot's full width at half maximum W: "
            "h = (W / (1.1774 r))^2 - 1. Range [0, 1000]."
        ),
    )
    px_per_mm: float = Field(
        4.0,
        gt=0.1,
        le=40.0,
        description=(
            "Resolution of the simulation raster in pixels per mm. Range (0.1, 40]. The simulated picture "
            "and the scores are computed on this grid; the dots' sigma should span at least one pixel."
        ),
    )
    max_error: float = Field(
        1e-3,
        ge=1e-6,
        le=0.05,
        description=(
            "Largest absolute opacity error allowed for the fast spray path against the exact evaluation. "
            "Range [1e-6, 0.05]. Each dot is evaluated out to the distance where its tail, summed over its "
            "neighbours, falls below this."
        ),
    )
    calibrate: Calibrate = Field(
        Calibrate.spray_time,
        description=(
            "Used when stipple.tone is calibrated. Choices: none (keep the paper's linear density, "
            "density proportional to opacity), dots (keep spray_time and derive the hole density and count "
            "from the spray response), spray_time (also choose the spray time per layer that minimises the "
            "predicted layer RMSE)."
        ),
    )
    sweep_factors: tuple[float, ...] = Field(
        (0.5, 1.0, 2.0),
        min_length=1,
        max_length=8,
        description=(
            "Spray-time multipliers shown side by side in sweep.png (as in the paper's figure). "
            "1 to 8 values, each in (0, 20]."
        ),
    )
    mask_reference_radius_mm: float = Field(
        1.0,
        gt=0.0,
        le=20.0,
        description=(
            "Hard stencils: the hole radius in mm whose spray spread is applied to a cut-out's edge. A cut-out "
            "is sprayed as a field of tiny holes blurred by sigma = r_ref * sqrt(h) / 2, the part of the "
            "dot model's sigma that comes from the nozzle. Range (0, 20]."
        ),
    )

    @field_validator("sweep_factors")
    @classmethod
    def _factors_positive(cls, v: tuple[float, ...]) -> tuple[float, ...]:
        for f in v:
            if not 0.0 < f <= 20.0:
                raise ValueError(f"each sweep factor must be in (0, 20], got {f}")
        return v
