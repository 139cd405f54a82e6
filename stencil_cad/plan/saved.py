"""The job's plan saved beside the layers (``plan.json``): what a stage command repeats the run from.

The run (and ``decompose``, and ``stipple`` once it has chosen the plate design) saves what its plan
decided that the config does not say: the plate design the trials chose, the primer of a dark
picture, the names of the cans that key the spray profiles, the plate figure and each layer's spray.
A stage command (``stipple``, ``build``, ``simulate`` on the folder) plans the tiling and thickness
from the same config by the same functions and takes every decision from this file, so the
plate-design trials do not run again. The file names what it was planned for: the configs
(:func:`config_digest` of their sections that plan: the config the job was given and the folder's
copy of it with the decisions filled in, either of which a stage command may be given) and the
decomposition (the layers file's SHA-256); :func:`stencil_cad.pipeline.saved.read_plan` refuses a
plan planned for others.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from ..config import JobConfig
from ..figures import LayerProfile, PlateFigures
from .plan import Plan, designed

__all__ = [
    "FORMAT",
    "SavedPlan",
    "apply_saved",
    "config_digest",
    "plan_json",
    "read_plan_json",
    "saved_config",
]

#: The file's format; a file of another is refused (a stage command asks for the plan again).
FORMAT = 1

#: Sections that say where and how the job's files are made, not what the job plans: they may change.
_NOT_PLANNED = ("compute", "export", "name")


@dataclass(frozen=True)
class SavedPlan:
    """A saved plan as read back.

    Attributes:
        configs_sha256: :func:`config_digest` of each config it was planned for (the job's as given,
            the folder's copy).
        layers_sha256: SHA-256 of the layers file it was planned on.
        design: ``(windows, stand-off in mm)`` the plate design step chose, or None: not chosen yet
            (``decompose`` plans no design).
        primer: The primer chosen for a mostly dark picture (``#rrggbb``), or None.
        can_names: ``{hex: can label}`` of the cans the job knew (they may key ``spray.profile``).
        plate: Figure ``plate`` as the plan left it, or None.
        spray_profiles: Each layer's spray settings as the plan resolved them (figure ``spray_profiles``).
    """

    configs_sha256: tuple[str, ...]
    layers_sha256: str
    design: tuple[str, float] | None
    primer: str | None
    can_names: dict[str, str]
    plate: PlateFigures | None
    spray_profiles: tuple[LayerProfile, ...]

    def planned_for(self, cfg: JobConfig) -> bool:
        """Whether this plan was planned for ``cfg`` (its sections that plan: :func:`config_digest`)."""
        return config_digest(cfg) in self.configs_sha256


def saved_config(cfg: JobConfig) -> dict[str, Any]:
    """``cfg`` as the folder's config copy holds it: every key, the input paths absolute (it runs from anywhere)."""
    data = cfg.model_dump(mode="json")
    if cfg.image is not None:
        data["image"] = str(Path(cfg.image).resolve())
    if cfg.plate.template is not None:
        data["plate"]["template"] = str(Path(cfg.plate.template).resolve())
    return data


def config_digest(cfg: JobConfig) -> str:
    """SHA-256 of ``cfg``'s sections that plan the job (all but ``compute``, ``export`` and ``name``).

    Input files count by name: the same job run from another folder (the studio's job, its zip
    unpacked elsewhere) has the same plan. The plate values left null count as the config alone
    fills them in (:func:`stencil_cad.config.job.filled`, a function of the config): so the digest of a
    config as given is the one earlier versions, which filled them in when parsing, wrote in the
    plans they saved.
    """
    from ..config.job import filled

    data = {k: _names(v) for k, v in filled(cfg)[0].model_dump().items() if k not in _NOT_PLANNED}
    return hashlib.sha256(json.dumps(data, sort_keys=True, default=str).encode()).hexdigest()


def _names(value: Any) -> Any:
    """``value`` (a config dump) with every path cut to its file name."""
    if isinstance(value, Path):
        return value.name
    if isinstance(value, dict):
        return {str(k): _names(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_names(v) for v in value]
    return value


def plan_json(
    plan: Plan | None,
    configs_sha256: Sequence[str],
    layers_sha256: str,
    *,
    designed: bool,
    primer: str | None = None,
    can_names: dict[str, str] | None = None,
) -> str:
    """The text of ``plan.json``.

    Args:
        plan: The plan (its design, plate figure, primer and sprays), or None: ``decompose``'s,
            which plans the primer alone.
        configs_sha256: :func:`config_digest` of the configs a stage command may be given: the job's
            as given and the folder's copy.
        layers_sha256: SHA-256 of the layers file.
        designed: Whether the plan's plate design is chosen (its windows and stand-off are saved).
        primer: The primer, when ``plan`` is None.
        can_names: ``{hex: can label}`` of the cans the job knew.
    """
    design = None
    if plan is not None and designed:
        design = {"windows": plan.cfg.stipple.windows.value, "standoff_mm": plan.cfg.standoff.design_mm}
    paints = plan.paints if plan is not None else None
    data = {
        "format": FORMAT,
        "configs_sha256": list(dict.fromkeys(configs_sha256)),
        "layers_sha256": layers_sha256,
        "design": design,
        "primer": plan.primer if plan is not None else primer,
        "can_names": dict(sorted((can_names or {}).items())),
        "plate": plan.plate.to_json() if plan is not None and plan.plate is not None else None,
        "spray_profiles": [r.to_json() for r in paints.rows] if paints is not None else [],
    }
    return json.dumps(data, indent=2) + "\n"


def read_plan_json(data: Any) -> SavedPlan:
    """A saved plan from ``plan.json``'s parsed JSON.

    Raises:
        ValueError: Another format, or a key missing or of the wrong type (named).
    """
    if not isinstance(data, dict):
        raise ValueError("not a JSON object")
    if data.get("format") != FORMAT:
        raise ValueError(f"format {data.get('format')!r}, this version reads format {FORMAT}")
    configs = data.get("configs_sha256")
    if not isinstance(configs, list) or not configs or not all(isinstance(c, str) for c in configs):
        raise ValueError("configs_sha256 must be a list of strings")
    if not isinstance(data.get("layers_sha256"), str):
        raise ValueError("layers_sha256 must be a string")
    design = data.get("design")
    if design is not None and not (
        isinstance(design, dict)
        and isinstance(design.get("windows"), str)
        and isinstance(design.get("standoff_mm"), (int, float))
        and not isinstance(design.get("standoff_mm"), bool)
    ):
        raise ValueError("design must be null or {windows: string, standoff_mm: number}")
    names = data.get("can_names") or {}
    if not isinstance(names, dict) or not all(isinstance(v, str) for v in names.values()):
        raise ValueError("can_names must map hex codes to names")
    primer, plate, rows = data.get("primer"), data.get("plate"), data.get("spray_profiles") or []
    if primer is not None and not isinstance(primer, str):
        raise ValueError("primer must be null or a hex code")
    if plate is not None and not isinstance(plate, dict):
        raise ValueError("plate must be null or an object")
    if not isinstance(rows, list) or not all(isinstance(r, dict) for r in rows):
        raise ValueError("spray_profiles must be a list of objects")
    try:
        return SavedPlan(
            configs_sha256=tuple(configs),
            layers_sha256=data["layers_sha256"],
            design=None if design is None else (design["windows"], float(design["standoff_mm"])),
            primer=primer,
            can_names={str(k): v for k, v in names.items()},
            plate=None if plate is None else PlateFigures.from_json(plate),
            spray_profiles=tuple(LayerProfile.from_json(r) for r in rows),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"a figure cannot be read ({exc})") from None


def apply_saved(plan: Plan, saved: SavedPlan) -> Plan:
    """``plan`` (the stage command's, from the same config) with the saved plan's decisions: its design and primer.

    The figure ``plate`` is the saved one: the run's, which said why the plate has its thickness.
    """
    if saved.design is not None:
        plan = designed(plan, *saved.design)
    if saved.plate is not None:
        plan = replace(plan, plate=saved.plate)
    return replace(plan, primer=saved.primer) if saved.primer != plan.primer else plan
