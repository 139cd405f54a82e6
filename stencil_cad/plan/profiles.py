"""Each layer's spray settings, resolved once per job: the profile of its paint (``spray.profile``).

Every stage that sprays a layer (the tone calibration, the refinement, the simulation and its
scores by can, hard mode) takes the layer's settings from :func:`layer_sprays`, so a layer
keyed to its own profile sprays with that can's constants everywhere and the others do not
change. The figures ``spray_profiles`` (per layer: the key, the file, whether measured) are
what the manifest, the summary and the sheet read.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..colour import to_hex
from ..config import JobConfig, SprayConfig
from ..figures import LayerProfile
from ..record import Run
from .cans import can_names

__all__ = ["layer_sprays", "profile_rows"]


def layer_sprays(run: Run, cfg: JobConfig, colours: np.ndarray | Sequence[Any]) -> list[SprayConfig]:
    """The spray settings of every layer, in spray order, and the manifest's ``spray_profiles``.

    A layer whose can is unmeasured takes the deposit prior of its paint (light paints hide in more
    passes than dark ones: :func:`stencil_cad.simulate.cans.deposit_prior`).

    Args:
        run: The run (the can names the decompose stage recorded; the figures it records).
        cfg: The job's planned config (:attr:`stencil_cad.plan.plan.Plan.cfg`).
        colours: ``(L, 3)`` the layers' paints in [0, 1], in spray order.

    Returns:
        One :class:`~stencil_cad.config.SprayConfig` per layer (``spray`` itself for every layer
        without a ``spray.profile`` mapping).

    Raises:
        ConfigError: A key of ``spray.profile`` names no layer, or two keys name one.
    """
    hexes = [to_hex(c) for c in colours]
    names = can_names(run.figures)
    # A key's layer number is its paint's: a paint's light and dark plates spray from one can.
    paints = list(dict.fromkeys(hexes))
    cfg.check_profile_keys(paints, names)
    keys = [cfg.layer_profile_key(paints.index(h) + 1, h, names.get(h)) for h in hexes]
    sprays = [_paint_prior(cfg.spray.for_profile_key(k), c) for k, c in zip(keys, colours, strict=True)]
    run.figures.spray_profiles = profile_rows(hexes, keys, sprays)
    return sprays


def _paint_prior(spray: SprayConfig, paint: Any) -> SprayConfig:
    """A layer's settings with the deposit prior of its paint, when its can is unmeasured.

    A measured can, a deposit the config gives (``spray.can.deposit_per_pass`` other than its
    default; the resolved config of a run holds every key, so the value tells, not whether it was
    written) and the paper's model are kept as they are (:func:`stencil_cad.simulate.cans.deposit_prior` gives the rule).
    """
    from ..simulate.cans import deposit_prior

    default = type(spray.can).model_fields["deposit_per_pass"].default
    if not spray.has_cans or spray.is_measured or spray.can.deposit_per_pass != default:
        return spray
    can = spray.can.model_copy(update={"deposit_per_pass": deposit_prior(paint)})
    return spray.model_copy(update={"can": can})


def profile_rows(
    hexes: Sequence[str], keys: Sequence[str | None], sprays: Sequence[SprayConfig]
) -> tuple[LayerProfile, ...]:
    """Per layer: its paint, the profile file it sprays with (by name), whether measured, its constants.

    Args:
        hexes: Each layer's paint as ``#rrggbb``.
        keys: The ``spray.profile`` key naming each layer (None: one file, none, or no key names it).
        sprays: Each layer's settings (:func:`layer_sprays`).
    """
    rows: list[LayerProfile] = []
    for i, (h, key, sp) in enumerate(zip(hexes, keys, sprays, strict=True)):
        prof = sp.profile if isinstance(sp.profile, Path) else None
        rows.append(
            LayerProfile(
                layer=i + 1,
                hex=h,
                profile=prof.name if prof is not None else None,
                key=key,
                measured=bool(sp.is_measured),
                paint=sp.can.paint,
                spread_k=sp.can.spread_k,
                bleed_sigma_mm=sp.can.bleed_sigma_mm,
                deposit_per_pass=sp.can.deposit_per_pass,
            )
        )
    return tuple(rows)
