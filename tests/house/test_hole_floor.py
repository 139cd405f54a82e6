"""House rule: the hole floor is read through one route.

The hole floor (the smallest hole radius a job's holes keep: ``stipple.hole_min_r_mm`` or the
process's preset) is :attr:`stencil_cad.config.StippleConfig.hole_floor_mm`. A module that holds
the config reads that property; a stage handed only the job's ``DesignRules`` (built from it)
reads the rules' field. Reading the schema's key, a preset table, or building rules with
another floor anywhere else fails, so the floor can change meaning in one place.
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

PACKAGE = Path(stencil_cad.__file__).parent
#: The one route.
ROUTE = "hole_floor_mm"
#: The package that defines the floor: the schema, its presets and the rules value object.
HOME = "config/"
#: Names that read the floor another way: the schema's key (and the rules' and the process
#: record's field of that name), and the old property.
OTHER_WAYS = ("hole_min_r_mm", "resolved_hole_min_r_mm")
#: Modules handed the job's ``DesignRules`` and no config: they read the floor from the rules.
RULES_READERS = {
    "stipple/rules.py": "enforces and checks the DesignRules it is given",
    "stipple/refine.py": "moves holes under the DesignRules of each layer it is given",
    "stipple/refine_holes.py": "projects one layer's holes onto the DesignRules it is given",
}


def _modules() -> list[tuple[str, ast.Module]]:
    return [
        (path.relative_to(PACKAGE).as_posix(), ast.parse(path.read_text(encoding="utf-8")))
        for path in sorted(PACKAGE.rglob("*.py"))
    ]


def floor_reads(rel: str, tree: ast.Module) -> list[tuple[int, str]]:
    """The places a module reads the hole floor other than through :data:`ROUTE`: (line, what)."""
    if rel.startswith(HOME):
        return []
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Attribute) and node.attr in OTHER_WAYS:
            if not (node.attr == "hole_min_r_mm" and rel in RULES_READERS):
                found.append((node.lineno, f".{node.attr}"))
        elif isinstance(node, ast.keyword) and node.arg in OTHER_WAYS:
            found.append((node.value.lineno, f"{node.arg}="))
        elif isinstance(node, ast.Name | ast.alias):
            name = node.id if isinstance(node, ast.Name) else node.name
            if name in OTHER_WAYS:
                found.append((getattr(node, "lineno", 0), name))
        elif isinstance(node, ast.Constant) and node.value in OTHER_WAYS:
            found.append((node.lineno, repr(node.value)))
    return found


def test_the_hole_floor_is_read_through_one_route():
    bad = [f"{rel}:{line}: {what}" for rel, tree in _modules() for line, what in floor_reads(rel, tree)]
    assert not bad, (
        f"the hole floor is read another way than StippleConfig.{ROUTE} "
        f"(or a DesignRules handed to {sorted(RULES_READERS)}):\n" + "\n".join(bad)
    )


def test_the_route_is_one_property_and_is_taken():
    defined, readers = [], set()
    for rel, tree in _modules():
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef) and node.name == ROUTE:
                defined.append(rel)
            elif isinstance(node, ast.Attribute) and node.attr == ROUTE:
                readers.add(rel)
    assert defined == ["config/stipple.py"]
    # Not a vacuous rule: the modules that need the floor take the route (the refinement's largest
    # radius, which the refinement and the tone response read, is the config's: refined_max_radius_mm).
    assert {"bounds.py", "plan/holes.py", "plan/plan.py", "config/job.py"} <= readers


def test_the_rule_sees_each_other_way():
    source = (
        "a = cfg.stipple.hole_min_r_mm\n"
        "b = cfg.stipple.resolved_hole_min_r_mm\n"
        "c = cfg.stipple.design_rules(1, 1).hole_min_r_mm\n"
        "d = replace(rules, hole_min_r_mm=1.0)\n"
        "r = cfg.stipple.process.record.hole_min_r_mm\n"
        "e = getattr(cfg.stipple, 'hole_min_r_mm')\n"
        "f = cfg.stipple.hole_floor_mm\n"
    )
    lines = sorted({line for line, _ in floor_reads("pipeline/x.py", ast.parse(source))})
    assert lines == [1, 2, 3, 4, 5, 6]
    assert floor_reads("stipple/rules.py", ast.parse("r = rules.hole_min_r_mm\n")) == []
    assert floor_reads("config/stipple.py", ast.parse(source)) == []
