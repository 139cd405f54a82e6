"""The config is schema: no wrap validator of ``config/job.py`` fills a value the job decides.

A value left null for the job (``plate.label``, ``plate.thickness_mm``, ``stipple.web_mm``,
``plate.outline.margin_mm``) stays null in the parsed config and is filled in by a planning function
(:mod:`stencil_cad.plan.plan`), not by the config's validators: ``config/job.py`` has no wrap
validator, and its models no private attribute recording a fill.
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

JOB = Path(stencil_cad.__file__).parent / "config" / "job.py"

#: Wrap validators that still fill a value in: none (the plan fills every value the job decides).
STILL_FILLING: set[str] = set()


def wrap_validators(source: str) -> list[str]:
    """The names of the functions of ``source`` decorated ``model_validator(mode="wrap")``."""
    names = []
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.FunctionDef):
            continue
        for dec in node.decorator_list:
            if (
                isinstance(dec, ast.Call)
                and getattr(dec.func, "id", None) == "model_validator"
                and any(k.arg == "mode" and getattr(k.value, "value", None) == "wrap" for k in dec.keywords)
            ):
                names.append(node.name)
    return names


def test_the_check_sees_a_wrap_validator():
    src = '@model_validator(mode="wrap")\ndef _f(cls, d, h): ...\n@model_validator(mode="after")\ndef _g(self): ...\n'
    assert wrap_validators(src) == ["_f"]


def test_no_new_wrap_validator_fills_a_value():
    assert set(wrap_validators(JOB.read_text())) <= STILL_FILLING


def test_the_label_is_the_plans_to_fill():
    from stencil_cad.config.io import parse_config
    from stencil_cad.plan.plan import labelled

    cfg = parse_config({"size": {"width_mm": 600}, "bed": "prusa_mk4"}, source="test")
    assert cfg.plate.label is None
    assert not any("label" in name for name in type(cfg).__private_attributes__)
    assert labelled(cfg).plate.label is not None


def test_the_plate_values_are_the_plans_to_fill():
    """Thickness, one-layer web and a soft mural's margin stay null when parsed; the plan fills them in."""
    from stencil_cad.config.io import parse_config
    from stencil_cad.config.outline import TILE_MARGIN_MM
    from stencil_cad.plan.plan import planned

    data = {"size": {"width_mm": 600}, "bed": "prusa_mk4", "plate": {"label": "emboss"}}
    cfg = parse_config(data, source="test")
    assert cfg.plate.thickness_mm is None
    assert cfg.stipple.web_mm is None
    assert cfg.plate.outline.margin_mm is None
    assert set(type(cfg).__private_attributes__) == {"_standoff_chosen"}
    plan, _ = planned(cfg, (600.0, 400.0), 1200 * 800)
    assert plan.cfg.plate.outline.margin_mm == TILE_MARGIN_MM
    assert plan.cfg.plate.thickness_mm == 0.3  # one layer between the posts
    assert plan.cfg.stipple.web_mm == cfg.stipple.process.record.one_layer_web_mm
    assert plan.fills is not None and plan.fills.thickness.filled and plan.fills.web_left
    assert plan.plate is not None and plan.plate.filled
    # The maker's values are kept as given.
    given = parse_config({**data, "plate": {"label": "emboss", "thickness_mm": 0.6}}, source="test")
    kept, _ = planned(given, (600.0, 400.0), 1200 * 800)
    assert kept.cfg.plate.thickness_mm == 0.6 and kept.fills is not None and not kept.fills.thickness.filled
