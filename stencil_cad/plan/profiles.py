"""Each layer's spray settings, resolved once per job: the profile of its paint (``spray.profile``).

The plan learns its paints after the decomposition (hard mode: after the segmentation) and resolves
each layer's settings then (:func:`paints_of`, kept in :attr:`stencil_cad.plan.plan.Plan.paints`).
Every stage that sprays a layer (the tone calibration, the refinement, the simulation and its
scores by can, hard mode) reads them from the plan, so a layer keyed to its own profile sprays with
that can's constants everywhere and the others do not change. Its rows (per layer: the key, the
file, whether measured) are the manifest's figure ``spray_profiles``, which the orchestrator
records and the summary and the sheet read.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..colour import to_hex
from ..config import JobConfig, SprayConfig
from ..figures import LayerProfile

__all__ = ["Paints", "layer_sprays", "paints_of", "profile_rows"]


@dataclass(frozen=True)
class Paints:
    """The layers' paints and the spray settings each layer sprays with, resolved from one ``spray`` section.

    Attributes:
        colours: ``(L, 3)`` the layers' paints in [0, 1], in spray order, as tuples.
        names: ``{hex: can label}`` of every can the job knows (its can list and catalogue).
        spray: The ``spray`` section the settings were resolved from (a plan whose config sprays
            otherwise has to resolve them again).
        sprays: Each layer's settings, in spray order.
        rows: The figure ``spray_profiles``: per layer its paint, key, file and constants.
        each: What was applied to every layer's settings but the config's own (hard mode's
            cut-outs), kept so the settings resolve again alike; or None.
    """

    colours: tuple[tuple[float, ...], ...]
    names: Mapping[str, str]
    spray: SprayConfig
    sprays: tuple[SprayConfig, ...]
    rows: tuple[LayerProfile, ...]
    each: Callable[[SprayConfig], SprayConfig] | None = None


def paints_of(
    cfg: JobConfig,
    colours: np.ndarray | Sequence[Any],
    names: Mapping[str, str] | None = None,
    each: Callable[[SprayConfig], SprayConfig] | None = None,
) -> Paints:
    """The layers' spray settings under ``cfg`` (:func:`layer_sprays`) and their figure, kept together.

    Args:
        cfg: The job's planned config.
        colours: ``(L, 3)`` the layers' paints in [0, 1], in spray order.
        names: ``{hex: can label}`` of the cans the job knows, or None: none.
        each: Applied to every layer's settings but the config's own (hard mode's cut-outs spray
            whole passes), or None. The rows keep the settings as the profiles give them.
    """
    names = dict(names or {})
    sprays, rows = layer_sprays(cfg, colours, names)
    if each is not None:
        sprays = [sp if sp is cfg.spray else each(sp) for sp in sprays]
    kept = tuple(tuple(float(x) for x in c) for c in np.asarray(colours, dtype=np.float64).reshape(-1, 3))
    return Paints(kept, names, cfg.spray, tuple(sprays), rows, each)


def layer_sprays(
    cfg: JobConfig, colours: np.ndarray | Sequence[Any], names: Mapping[str, str] | None = None
) -> tuple[list[SprayConfig], tuple[LayerProfile, ...]]:
    """The spray settings of every layer, in spray order, and their rows of figure ``spray_profiles``.

    A layer whose can is unmeasured takes the deposit prior of its paint (light paints hide in more
    passes than dark ones: :func:`stencil_cad.simulate.cans.deposit_prior`).

    Args:
        cfg: The job's planned config (:attr:`stencil_cad.plan.plan.Plan.cfg`).
        colours: ``(L, 3)`` the layers' paints in [0, 1], in spray order.
        names: ``{hex: can label}`` of the cans the job knows (:func:`stencil_cad.plan.cans.can_names`).

    Returns:
        ``(settings, rows)``: one :class:`~stencil_cad.config.SprayConfig` per layer (``spray``
        itself for every layer without a ``spray.profile`` mapping), and the figure's rows.

    Raises:
        ConfigError: A key of ``spray.profile`` names no layer, or two keys name one.
    """
    hexes = [to_hex(c) for c in colours]
    names = names or {}
    # A key's layer number is its paint's: a paint's light and dark plates spray from one can.
    paints = list(dict.fromkeys(hexes))
    cfg.check_profile_keys(paints, names)
    keys = [cfg.layer_profile_key(paints.index(h) + 1, h, names.get(h)) for h in hexes]
    sprays = [_paint_prior(cfg.spray.for_profile_key(k), c) for k, c in zip(keys, colours, strict=True)]
    return sprays, profile_rows(hexes, keys, sprays)


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
