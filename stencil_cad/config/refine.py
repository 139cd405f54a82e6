"""Config section `refine`: model-based refinement of the stippled holes (owned by the stipple stage)."""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from .base import StrictModel


class RefineConfig(StrictModel):
    """Settings of the refinement that moves and resizes holes against the spray model."""

    enabled: bool = Field(
        True,
        description=(
            "Refine the stippled holes against the spray model so the sprayed composite of all layers, seen "
            "from view.distance_m, matches the input (centres and radii move, holes are added or removed "
            "where that pays off; the design rules hold at every step). false keeps the stippler's holes."
        ),
    )
    iterations: int = Field(
        90,
        ge=1,
        le=1000,
        description=(
            "Gradient steps of the refinement. More steps keep improving the picture at a cost linear in "
            "them: on python -m benchmarks quality's SLA astronaut at nozzle height 30, 30 steps scored "
            "S-CIELAB 7.37 at 1 m, 60 steps 6.98, 90 steps 6.84 (hard stencils: 10.1), measured before the "
            "spray-time choice weighed colour and layer_weight became 0.1, which take 90 steps to 6.67 "
            "(all with the 2 mm edge margin of before; without it, 5.60). Range [1, 1000]."
        ),
    )
    step_mm: float = Field(
        0.05,
        gt=0.0,
        le=1.0,
        description="Largest move of a hole centre per step at the start, in mm (decays to a fifth). Range (0, 1].",
    )
    radius_step_mm: float = Field(
        0.02,
        ge=0.0,
        le=0.5,
        description="Largest change of a hole radius per step at the start, in mm; 0 keeps the radii. Range [0, 0.5].",
    )
    max_radius_factor: float = Field(
        2.0,
        ge=1.0,
        le=4.0,
        description=(
            "Largest hole radius as a multiple of the hole floor (stipple.hole_min_r_mm or the process "
            "preset), or the stippler's largest radius if that is larger. Range [1, 4]."
        ),
    )
    layer_weight: float = Field(
        0.1,
        ge=0.0,
        le=100.0,
        description=(
            "Weight of each layer's own opacity error beside the error of the composite colour (0: the "
            "composite alone; then one layer may drift from its target to make up for another). On python -m "
            "benchmarks quality's SLA photos, S-CIELAB at 1 m with 1 / 0.3 / 0.1 / 0: astronaut 6.77 / 6.70 / "
            "6.67 / 6.55, rocket 2.46 / 2.38 / 2.34 / 2.39 (with the 2 mm edge margin of before); 0.1 still "
            "lowers every layer's own error. Range [0, 100]."
        ),
    )
    objective: Literal["viewer", "rgb"] = Field(
        "rgb",
        description=(
            "What the refinement minimises. viewer: the colour difference a person sees from "
            "view.distance_m (the composite's error in S-CIELAB's opponent space, each channel blurred by "
            "the eye's filter there, weighted as CIEDE2000 weighs it at the picture's colours). rgb: the sRGB "
            "error blurred by the eye's narrowest (luminance) filter alone (the default: on the SLA photos of "
            "python -m benchmarks quality, viewer scored 0.1-0.16 better at 1 m on coffee and chelsea, 0.04 worse "
            "on astronaut, with a pixel CIEDE2000 up to 0.4 worse, for 3-4x the refinement's time)."
        ),
    )
    cans: Literal["nominal", "prior"] = Field(
        "prior",
        description=(
            "Physical spray model without a measured profile: which cans the holes are refined for. "
            "prior (the default): the expected error over the prior's caps (stencil_cad.simulate.cans: the "
            "nominal, a skinny and a fat cap at the nominal deposit; one can per step, in turn, so it takes "
            "the time of one can). nominal: spray.can alone. A measured can is refined for alone either way, "
            "and every job is scored for each can of the prior (simulate.scielab_by_can). On the bundled "
            "example over 3 seeds, prior lowered the mean S-CIELAB at 1 m over the prior's five cans by "
            "0.19-0.22 (5.64 against 5.84 with the shipped seed) and cost the nominal can 0.16-0.22 (3.92 "
            "against 3.70); the lighter and heavier coats are left out of the refinement, since a coat's "
            "darkness is tone no placement of holes undoes (python -m benchmarks cans), and refining for "
            "them too scored worse for every can."
        ),
    )
    pixel_weight: float = Field(
        0.0,
        ge=0.0,
        le=10.0,
        description=(
            "With objective viewer: weight of the unblurred, pixel-by-pixel colour difference beside the "
            "viewer's. Range [0, 10]."
        ),
    )
    add_remove_every: int = Field(
        10,
        ge=0,
        le=1000,
        description=(
            "Every this many steps, remove holes whose removal lowers the composite error and add floor-size "
            "holes where one would; 0 never adds or removes. Range [0, 1000]."
        ),
    )
