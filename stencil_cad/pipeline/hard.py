"""Hard mode's glue: the picture segmented into flat-colour cut layers held by bridges, and each layer's spray.

:func:`stencil_cad.pipeline.run.run_hard` orders hard mode's stages: :func:`hard_config`,
:func:`stage_segment`, the paints' previews and spray order, the build and
:func:`stencil_cad.pipeline.simulate.stage_simulate_hard`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..config import JobConfig, SprayConfig
from ..errors import UserError
from ..model import Layers, Picture
from ..plan.cans import with_can_list
from ..plan.plan import Plan
from ..plan.results import Segmented
from ..record import Run


def hard_config(cfg: JobConfig) -> JobConfig:
    """``cfg`` as hard mode sprays: from the cut-outs' own nozzle height, with whole passes enough for full cover.

    The simulation, the spray order and the maker's spraying steps all read it from the spray
    section; the passes only under the physical model.
    """
    from ..simulate.models import sprayer

    spray = cfg.spray.model_copy(update={"nozzle_height": cfg.hard.nozzle_height})
    spray = sprayer(spray).for_cutouts(spray)
    return cfg.model_copy(update={"spray": spray})


def stage_segment(run: Run, plan: Plan, picture: Picture) -> Segmented:
    """Segment the picture into cut layers with bridges under ``plan``, with ``segmentation.png`` to write.

    Runs inside the ``segment`` stage, which the run opens (the recorder records the can list, the
    plan learns the paints, then the recorder writes ``segmentation.png`` and records figure
    ``hard``, and the paints' previews follow in it).

    Raises:
        UserError: The segmentation fails, or the image has a single flat colour.
    """
    from .. import hardstencil

    cfg = plan.cfg
    rules = process_rules(cfg)
    hcfg, listed = with_can_list(cfg.hard, "hard.palette")
    try:
        hard = hardstencil.make_hard_stencils(
            picture, hcfg, rules["min_feature_mm"], rules["bridge_min_mm"], run.rng_for("hard")
        )
    except ValueError as exc:
        raise UserError(f"hard mode: {exc}") from exc
    if hard.count == 0:
        raise UserError(
            "hard mode: the image has a single flat colour, so there is nothing to cut "
            "(prime the surface with it, or use an image with more colours)"
        )
    colours = np.array([cl.colour for cl in hard.cut_layers]).reshape(-1, 3)
    layers = Layers(
        primer=hard.primer,
        colours=colours,
        alphas=hard.cut_masks.astype(np.float64),
        mm_per_px=picture.mm_per_px,
    )
    return Segmented(hard, layers, hard.palette[hard.labels], listed)


def cutout_spray(spray: SprayConfig) -> SprayConfig:
    """A cut layer's spray settings from its paint's profile: whole passes enough for its own cover."""
    from ..simulate.models import sprayer

    return sprayer(spray).for_cutouts(spray)


def process_rules(cfg: JobConfig) -> dict[str, Any]:
    """The process's smallest cut feature and bridge, in mm, that hard mode segments with."""
    st = cfg.stipple
    return {"min_feature_mm": 2 * st.hole_floor_mm, "bridge_min_mm": max(st.sizes.web_mm, 1.0)}
