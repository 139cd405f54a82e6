"""House rule: the holes' sizes are resolved in one place, and the refinement's largest radius too.

A ``stipple`` value left null for its process's preset (radius, largest radius, web, edge margin,
hole offset) is resolved by :attr:`stencil_cad.config.StippleConfig.sizes` alone (a frozen
``HoleSizes``), which every reader outside ``config/`` reads; the largest radius a refined hole may
grow to is :attr:`stencil_cad.config.JobConfig.refined_max_radius_mm`. A module that resolves them
again (an old ``resolved_*`` property, ``refine.max_radius_factor`` read outside the config) fails.
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

PACKAGE = Path(stencil_cad.__file__).parent
#: The old per-value properties, gone: read ``StippleConfig.sizes``.
OLD = {f"resolved_{k}_mm" for k in ("radius", "max_radius", "web", "edge_margin", "hole_offset")}


def _reads(name_ok) -> list[str]:
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute | ast.FunctionDef) and not name_ok(rel, _name(node)):
                found.append(f"{rel}:{node.lineno}: {_name(node)}")
    return found


def _name(node: ast.Attribute | ast.FunctionDef) -> str:
    return node.attr if isinstance(node, ast.Attribute) else node.name


def test_no_module_resolves_a_hole_size_again():
    bad = _reads(lambda rel, name: name not in OLD)
    assert not bad, "read StippleConfig.sizes instead:\n" + "\n".join(bad)


def test_the_refinements_largest_radius_is_the_configs():
    bad = _reads(lambda rel, name: name != "max_radius_factor" or rel.startswith("config/"))
    assert not bad, "read JobConfig.refined_max_radius_mm instead:\n" + "\n".join(bad)


def test_the_routes_are_taken():
    readers: dict[str, set[str]] = {"sizes": set(), "refined_max_radius_mm": set()}
    for path in sorted(PACKAGE.rglob("*.py")):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Attribute) and node.attr in readers:
                readers[node.attr].add(path.relative_to(PACKAGE).as_posix())
    assert {"bounds.py", "stipple/relax.py", "stipple/made.py", "simulate/tone.py"} <= readers["sizes"]
    assert {"plan/refinement.py", "mural/refine.py", "simulate/tone.py"} <= readers["refined_max_radius_mm"]
