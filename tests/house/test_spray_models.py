"""House rule: the spray models sit behind one interface, ``stencil_cad/simulate/models.py``.

How a model sprays is its ``Sprayer`` in ``SPRAYERS``; what it means for the settings is its row of
``MODEL_TERMS`` in ``stencil_cad/config/spray.py``. Elsewhere a module asks the model what it does
(``sprayer(cfg).opacity(...)``, ``cfg.spray.has_wall``), so a new model is a class and an entry
there: reading ``is_physical``, naming a member of ``SprayModel`` or comparing with a model's name
anywhere else fails.
"""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np
import pytest

import stencil_cad
from stencil_cad.config.spray import MODEL_TERMS, SprayConfig, SprayModel
from stencil_cad.simulate.models import SPRAYERS

PACKAGE = Path(stencil_cad.__file__).parent
#: The registry, and the config section that declares the models and their terms.
HOMES = {"simulate/models.py", "config/spray.py"}
NAMES = {m.value for m in SprayModel}


def _names_a_model(node: ast.AST) -> bool:
    if isinstance(node, ast.Constant):
        return node.value in NAMES
    if isinstance(node, ast.Tuple | ast.List | ast.Set):
        return any(_names_a_model(e) for e in node.elts)
    return (
        isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Name)
        and node.value.id == "SprayModel"
        and node.attr in NAMES
    )


def model_branches(rel: str, tree: ast.Module) -> list[tuple[int, str]]:
    """Where a module asks which spray model a job uses: (line, what)."""
    if rel in HOMES:
        return []
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr == "is_physical":
            found.append((node.lineno, "reads is_physical"))
        elif isinstance(node, ast.Attribute) and _names_a_model(node):
            found.append((node.lineno, f"names SprayModel.{node.attr}"))
        elif isinstance(node, ast.Compare) and any(_names_a_model(n) for n in (node.left, *node.comparators)):
            found.append((node.lineno, "compares with a spray model's name"))
    return found


def test_no_module_but_the_registry_and_the_config_asks_which_spray_model_a_job_uses():
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        found += [f"{rel}:{line}: {what}" for line, what in model_branches(rel, ast.parse(path.read_text()))]
    assert not found, (
        "ask the spray model what it does (stencil_cad.simulate.models.sprayer, SprayConfig.has_wall / "
        "has_cans / terms) instead of which model it is:\n" + "\n".join(found)
    )


def test_the_rule_sees_the_branches_it_forbids():
    src = (
        "a = cfg.spray.is_physical\n"
        "b = cfg.model == SprayModel.physical\n"
        "c = s.spray_model != 'paper'\n"
        "d = m in ('physical', 'paper')\n"
    )
    whats = [w for _, w in model_branches("pipeline/x.py", ast.parse(src))]
    assert whats.count("reads is_physical") == 1
    assert "names SprayModel.physical" in whats
    assert whats.count("compares with a spray model's name") == 3
    assert model_branches("simulate/models.py", ast.parse(src)) == []


def test_every_model_has_its_terms_and_its_sprayer():
    assert set(SPRAYERS) == set(SprayModel) == set(MODEL_TERMS)
    for m in SprayModel:
        cfg = SprayConfig(model=m)
        terms = m.terms
        assert cfg.amount == getattr(cfg, terms.amount_field)
        assert cfg.amount_unit == terms.amount_unit
        if terms.has_wall:  # a model that sees the wall refuses to spray without the plate's geometry
            with pytest.raises(ValueError, match="geometry"):
                SPRAYERS[m].hole_kernels(np.array([1.0]), cfg, cfg.amount, None)
