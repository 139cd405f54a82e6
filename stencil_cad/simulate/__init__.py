"""Spray simulation: the spray model, the tone calibration, scores and previews.

:mod:`.spray` is the spray model (opacity through the holes, the composite),
:mod:`.physical` the physical model in the maker's units (stand-off, distance, passes),
:mod:`.tone` calibrates the stippler's density against it, :mod:`.scores` compares
the result with the input and :mod:`.previews` draws the preview images.
"""

from .opacity import dot_sigma_mm, spray_mask, spray_opacity, tail_tolerance
from .previews import colour_map, dots_preview, sweep, sweep_panels
from .scores import delta_e_map, score
from .spray import (
    SimResult,
    blurred_composite,
    hole_kernels,
    layer_rmse,
    resample,
    sim_shape,
    simulate,
    target_on_grid,
)
from .tone import (
    ToneChoice,
    ToneCurve,
    calibrated_density,
    calibrated_density_for,
    choose_tone,
    packing_density,
    response_tone_for,
    tone_response,
)

__all__ = [
    "SimResult",
    "ToneChoice",
    "ToneCurve",
    "calibrated_density",
    "calibrated_density_for",
    "response_tone_for",
    "choose_tone",
    "colour_map",
    "delta_e_map",
    "dot_sigma_mm",
    "dots_preview",
    "hole_kernels",
    "layer_rmse",
    "packing_density",
    "blurred_composite",
    "resample",
    "score",
    "sim_shape",
    "simulate",
    "spray_mask",
    "spray_opacity",
    "tail_tolerance",
    "sweep",
    "sweep_panels",
    "target_on_grid",
    "tone_response",
]
