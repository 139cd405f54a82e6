"""Editable plate templates: plain Python files with module-level parameters and ``build(...)``.

A template is loaded fresh for each plate (like CadQuery's ``cqgi``): its
UPPER_CASE module-level constants are its parameters; values from the config
replace them before ``build`` runs, and a value for a name the template does not
define is an error. ``build(holes, outline, label_area, label)`` returns a
:class:`~stencil_cad.cad.plate.PlateModel`, or any build123d / CadQuery shape
(exported through OCCT's writers, which are slow on big plates).
"""

from __future__ import annotations

import importlib.util
import logging
import sys
import time
from dataclasses import replace
from pathlib import Path
from types import ModuleType

import numpy as np

from .. import outline as outline_mod
from ..config.cad import PlateConfig
from ..model import Holes, PlateGeometry
from ..stipple.rules import DesignRules
from .plate import LabelInfo, PlateBuildError, PlateModel, _unwrap, check_holes

log = logging.getLogger(__name__)

__all__ = [
    "build_plate",
    "builtin_template",
    "check_plate_template",
    "check_template",
    "config_overrides",
    "load_template",
    "run_template",
    "template_parameters",
]

#: Config field of ``plate`` → template parameter it sets.
CONFIG_PARAMS = {
    "thickness_mm": "THICKNESS_MM",
    "label": "LABEL",
    "label_depth_mm": "LABEL_DEPTH_MM",
    "label_height_mm": "LABEL_HEIGHT_MM",
    "label_min_height_mm": "LABEL_MIN_HEIGHT_MM",
    "label_font": "LABEL_FONT",
    "label_tolerance_mm": "LABEL_TOLERANCE_MM",
}

_SIMPLE = (bool, int, float, str)


def builtin_template(name: str = "plate.py") -> Path:
    """Path of a bundled template (``templates/`` beside the package, or inside it)."""
    here = Path(__file__).resolve()
    for folder in (here.parents[2] / "templates", here.parents[1] / "templates"):
        if (folder / name).is_file():
            return folder / name
    raise FileNotFoundError(f"bundled template {name} not found next to the stencil_cad package")


def load_template(path: str | Path) -> ModuleType:
    """Execute a template file into a fresh module.

    Args:
        path: The template's ``.py`` file.

    Returns:
        The module.

    Raises:
        PlateBuildError: When the file is missing, fails to run or has no ``build``.
    """
    path = Path(path)
    if not path.is_file():
        raise PlateBuildError(f"plate template {path} does not exist")
    try:
        source = path.read_bytes()
    except OSError as exc:
        raise PlateBuildError(f"plate template {path} cannot be read: {exc.strerror}") from None
    if path.suffix != ".py" or b"\0" in source[:4096]:
        raise PlateBuildError(
            f"plate template {path} is not a Python file (a template is a .py file like templates/plate.py)"
        )
    name = f"stencil_cad_template_{abs(hash(str(path.resolve())))}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise PlateBuildError(f"plate template {path} is not a Python file Python can load")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except SystemExit as exc:
        raise PlateBuildError(
            f"plate template {path} called sys.exit({exc.code!r}) while loading (a template defines "
            "build(); it must not exit)"
        ) from None
    except Exception as exc:
        raise PlateBuildError(
            f"plate template {path} failed to load: {type(exc).__name__}: {str(exc)[:300]}"
        ) from exc
    finally:
        sys.modules.pop(name, None)
    if not callable(getattr(module, "build", None)):
        raise PlateBuildError(
            f"plate template {path} has no build(holes, outline, label_area, label) function"
        )
    return module


def template_parameters(module: ModuleType) -> dict:
    """A template's parameters: its UPPER_CASE module-level constants of simple type."""
    return {
        k: v
        for k, v in vars(module).items()
        if k.isupper() and not k.startswith("_") and isinstance(v, _SIMPLE)
    }


def config_overrides(cfg: PlateConfig) -> dict:
    """Template parameter values from a ``plate`` config section.

    Every mapped field is passed for the built-in template; for a user's template
    only the fields the config sets explicitly, so the file's own values stand
    otherwise. ``template_params`` come last.
    """
    fields = (
        CONFIG_PARAMS
        if cfg.template is None
        else {k: v for k, v in CONFIG_PARAMS.items() if k in cfg.model_fields_set}
    )
    out = {}
    for field, name in fields.items():
        value = getattr(cfg, field)
        if value is not None:  # null: the job's to fill in (a plate alone: the template's own default)
            out[name] = getattr(value, "value", value)
    out.update(cfg.template_params)
    return out


def run_template(
    path: str | Path,
    holes: Holes,
    outline: np.ndarray,
    label_area: tuple[float, float, float, float] | None,
    label: LabelInfo | None,
    overrides: dict,
    strict: set | None = None,
) -> PlateModel:
    """Load a template, set its parameters and call its ``build``.

    Args:
        path: The template file.
        holes: A DotSet or CutLayer.
        outline: ``(M, 2)`` plate outline ring in mm.
        label_area: ``(x0, y0, x1, y1)`` mm, the label's free rectangle.
        label: :class:`~stencil_cad.cad.label.LabelInfo` or None.
        overrides: Parameter values by name.
        strict: Names that must exist in the template (the ``template_params``);
            other overrides the template does not define are skipped.

    Returns:
        A :class:`~stencil_cad.cad.plate.PlateModel`.

    Raises:
        PlateBuildError: On an unknown parameter, a value of the wrong type, or a
            ``build`` that returns something that is not a shape.
    """
    module = load_template(path)
    _set_parameters(module, path, overrides, strict)
    try:
        result = module.build(holes, outline, label_area, label)
    except SystemExit as exc:
        raise PlateBuildError(
            f"plate template {path}: build() called sys.exit({exc.code!r}) (it must return the plate)"
        ) from None
    except (KeyboardInterrupt, MemoryError, PlateBuildError):
        raise
    except Exception as exc:
        if Path(path).resolve() == builtin_template().resolve():
            raise  # the bundled template's errors are ours (a label that cannot fit is a ValueError)
        # A user's template is Python code of its own: its errors are its, whatever their type.
        raise PlateBuildError(
            f"plate template {path}: build() raised {type(exc).__name__}: {str(exc)[:300]} (the error is "
            "the template's: fix the template, or remove plate.template to use the built-in one)"
        ) from exc
    if isinstance(result, PlateModel):
        return result
    try:
        wrapped = _unwrap(result)
    except Exception as exc:  # pragma: no cover - defensive
        raise PlateBuildError(
            f"template {path} build() returned {type(result).__name__}, not a shape"
        ) from exc
    if not hasattr(wrapped, "ShapeType"):
        raise PlateBuildError(f"template {path} build() returned {type(result).__name__}, not a shape")
    return PlateModel(shape=wrapped, geometry=None, label=label, info={"template": str(path)})


def check_template(path: str | Path, overrides: dict, strict: set) -> dict:
    """Load a template and check its parameters without building (run before the first stage).

    A template is Python code: loading it runs it with the user's rights.

    Args:
        path: The template file.
        overrides: Parameter values by name (:func:`config_overrides`).
        strict: Names that must exist in the template (the ``template_params``).

    Returns:
        ``{"path", "sha256"}`` of the file, for the manifest.

    Raises:
        PlateBuildError: Not a Python file, fails to load, no ``build``, or bad parameters.
    """
    import hashlib

    module = load_template(path)
    _set_parameters(module, path, overrides, strict)
    return {"path": str(Path(path).resolve()), "sha256": hashlib.sha256(Path(path).read_bytes()).hexdigest()}


def _set_parameters(module: ModuleType, path, overrides: dict, strict: set | None) -> None:
    params = template_parameters(module)
    strict = set(overrides) if strict is None else strict
    unknown = sorted(k for k in strict if k not in params)
    if unknown:
        raise PlateBuildError(
            f"plate.template_params: unknown parameter(s) {', '.join(unknown)} for template {path}; "
            f"it defines: {', '.join(sorted(params)) or 'none'}"
        )
    for k, v in overrides.items():
        if k not in params:
            continue
        old = params[k]
        ok = isinstance(v, type(old)) or (
            isinstance(old, float) and isinstance(v, int) and not isinstance(v, bool)
        )
        if not ok:
            raise PlateBuildError(
                f"template parameter {k} must be a {type(old).__name__} like its default {old!r}, "
                f"got {_short(v)}"
            )
        setattr(module, k, float(v) if isinstance(old, float) else v)


def build_plate(
    holes: Holes,
    width_mm: float,
    height_mm: float,
    cfg: PlateConfig,
    label: LabelInfo | None,
    *,
    rules: DesignRules | None = None,
    outline_ring=None,
    label_solid_mm: float = 0.0,
) -> PlateModel:
    """Build one layer's plate: check the holes again, then run the plate template.

    Args:
        holes: A :class:`~stencil_cad.model.DotSet` (round holes) or a
            :class:`~stencil_cad.model.CutLayer` (polygon cut-outs, hard mode).
        width_mm: Picture width in mm (the picture area is ``[0, w] x [0, h]``).
        height_mm: Picture height in mm.
        cfg: The ``plate`` config section (:class:`~stencil_cad.config.PlateConfig`).
        label: What the label says, or None for no label.
        rules: Optional :class:`~stencil_cad.stipple.rules.DesignRules` to re-check the dots
            with (the job's process rules); by default the plate's own floor:
            radius ≥ 0.5 mm, web ≥ ``cfg.min_web_mm``, inside the picture.
        outline_ring: ``(M, 2)`` counter-clockwise outline replacing the config's (a mural
            tile's outline with its sight notches), or None.
        label_solid_mm: How far above the picture area's bottom edge the plate is solid all along
            (a mural tile's band below its lowest hole): the label may rise into it. Defaults to 0.

    Returns:
        The plate model (build123d Part, description, analytic volume).

    Raises:
        PlateBuildError: Bad dots (listing the first offenders), a label that does not
            fit, or a template problem. Nothing is built in that case.
    """
    t0 = time.perf_counter()
    check_holes(holes, width_mm, height_mm, cfg.min_web_mm, rules)
    t1 = time.perf_counter()
    ring = (
        outline_mod.plate_outline(width_mm, height_mm, cfg.outline) if outline_ring is None else outline_ring
    )
    area = outline_mod.label_region(width_mm, height_mm, cfg.outline, label_solid_mm)
    path = cfg.template if cfg.template is not None else builtin_template()
    model = run_template(
        path, holes, ring, area, label, config_overrides(cfg), strict=set(cfg.template_params)
    )
    if model.geometry is not None:
        model.geometry = _with_size(model.geometry, width_mm, height_mm)
    model.info["full_check_max_holes"] = cfg.full_check_max_holes
    model.info["template"] = str(path)
    secs = model.info.setdefault("seconds", {})
    secs["check_holes"] = round(t1 - t0, 3)
    secs["build"] = round(time.perf_counter() - t0, 3)
    return model


def _with_size(geom: PlateGeometry, width_mm: float, height_mm: float) -> PlateGeometry:
    return replace(geom, width_mm=float(width_mm), height_mm=float(height_mm))


def check_plate_template(cfg) -> dict:
    """Load the configured plate template and check its parameters, before any stage runs.

    Args:
        cfg: The ``plate`` config section.

    Returns:
        ``{"path", "sha256", "builtin"}`` for the manifest.

    Raises:
        PlateBuildError: Not a Python file, fails to load, no ``build``, or bad parameters.
    """
    path = cfg.template if cfg.template is not None else builtin_template()
    info = check_template(path, config_overrides(cfg), strict=set(cfg.template_params))
    return {**info, "builtin": cfg.template is None}


def _short(value, limit: int = 200) -> str:
    text = repr(value)
    return text if len(text) <= limit else f"{text[:limit]}… ({len(text)} characters)"
