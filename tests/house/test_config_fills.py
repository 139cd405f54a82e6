"""The config is schema: no wrap validator of ``config/job.py`` fills a value the job decides.

A value left null for the job (``plate.label``) is filled in by a planning function
(:mod:`stencil_cad.plan.plan`), not by the config's validators. The fills still in the config are
listed here, by name, until they move; a new one fails.
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

JOB = Path(stencil_cad.__file__).parent / "config" / "job.py"

#: Wrap validators that still fill a value in (issue 47: to move into the plan), and why each stays.
STILL_FILLING = {
    # The thickness, with the one-layer web and the margin it reads: refitted for the tiling and the
    # wall, and read as "filled in" by a mural's posts, so the plan needs its provenance first.
    "_fill_thickness",
    "_fill_web",
    "_fill_margin",
}


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
