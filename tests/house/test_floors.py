"""The orchestrator stays flat: ``pipeline/`` is at most two floors of its own.

A module's floor is 1 + the highest floor of the ``pipeline/`` modules it imports (1 when it imports
none), counting imports inside functions too. Floor 1 is a stage's glue: it imports no other module
of ``pipeline/``. Floor 2 orders the stages (``run.py``, ``commands.py``, ``preview.py``) and imports
glue only, never another orchestrating module. What several stages share lives below, in
``stencil_cad/plan/``.

Print the floors: ``python -m tests.house.test_floors``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

PACKAGE = Path(stencil_cad.__file__).parent
PIPELINE = PACKAGE / "pipeline"
#: The most floors ``pipeline/`` may have.
MAX_FLOORS = 2


def _absolute(node: ast.ImportFrom, package: str) -> str:
    """The dotted module an ``from ... import`` reads from, relative imports resolved in ``package``."""
    if node.level == 0:
        return node.module or ""
    parts = package.split(".")
    base = parts[: len(parts) - node.level + 1]
    return ".".join(base + ([node.module] if node.module else []))


def sibling_imports(path: Path, modules: set[str]) -> set[str]:
    """The ``pipeline/`` modules (by stem, ``__init__`` for the package) that the module at ``path`` imports.

    Reads every import in the file, inside functions and ``TYPE_CHECKING`` blocks too:
    ``from .x import``, ``from . import x``, ``from stencil_cad.pipeline.x import``,
    ``from stencil_cad.pipeline import x`` and ``import stencil_cad.pipeline.x``.
    """
    top = "stencil_cad.pipeline"
    found: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"), filename=str(path))):
        if isinstance(node, ast.ImportFrom):
            target = _absolute(node, top)
            if target == top:
                for alias in node.names:
                    found.add(alias.name if alias.name in modules else "__init__")
            elif target.startswith(top + "."):
                found.add(target[len(top) + 1 :].split(".")[0])
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith(top + "."):
                    found.add(alias.name[len(top) + 1 :].split(".")[0])
                elif alias.name == top:
                    found.add("__init__")
    found.discard(path.stem)
    return found & (modules | {"__init__"})


def pipeline_graph() -> dict[str, set[str]]:
    """Each module of ``pipeline/`` (by stem) and the ``pipeline/`` modules it imports."""
    paths = sorted(PIPELINE.glob("*.py"))
    modules = {p.stem for p in paths if p.stem != "__init__"}
    return {p.stem: sibling_imports(p, modules) for p in paths}


def floors(graph: dict[str, set[str]]) -> dict[str, int]:
    """Each module's floor: 1 + the highest floor among the modules it imports (1 when none).

    Raises:
        ValueError: The modules import each other in a cycle.
    """
    out: dict[str, int] = {}

    def floor(name: str, path: tuple[str, ...]) -> int:
        if name in path:
            raise ValueError("import cycle in pipeline/: " + " -> ".join((*path, name)))
        if name not in out:
            out[name] = 1 + max((floor(d, (*path, name)) for d in graph[name]), default=0)
        return out[name]

    for name in graph:
        floor(name, ())
    return out


def chain(graph: dict[str, set[str]], levels: dict[str, int], name: str) -> list[str]:
    """The tallest import chain from ``name`` down to a floor-1 module."""
    steps = [name]
    while graph[steps[-1]]:
        steps.append(max(sorted(graph[steps[-1]]), key=lambda d: levels[d]))
    return steps


def test_the_walk_sees_the_pipeline():
    graph = pipeline_graph()
    assert {"run", "stipple", "refine", "__init__"} <= set(graph)
    assert "stipple" in graph["run"] and "refine" in graph["run"]


def test_the_pipeline_has_at_most_two_floors():
    graph = pipeline_graph()
    levels = floors(graph)
    high = sorted(n for n, f in levels.items() if f > MAX_FLOORS)
    assert not high, (
        f"pipeline/ has {max(levels.values())} floors, at most {MAX_FLOORS} are allowed; too high: "
        + "; ".join(" -> ".join(chain(graph, levels, n)) for n in high)
        + ". A stage's glue imports no other module of pipeline/: move what two stages share down "
        "to stencil_cad/plan/ (or into the stage's own package), and let run.py (commands.py, "
        "preview.py) call one stage after the other. run.py, commands.py and preview.py import stage "
        "glue only, never each other; pipeline/__init__.py re-exports stage glue only (the command "
        "line and the public API import pipeline.run, pipeline.commands and pipeline.preview themselves)."
    )


def test_floors_of_a_toy_graph():
    graph = {"a": set(), "b": {"a"}, "c": {"b", "a"}}
    assert floors(graph) == {"a": 1, "b": 2, "c": 3}
    assert chain(graph, floors(graph), "c") == ["c", "b", "a"]


if __name__ == "__main__":
    graph = pipeline_graph()
    levels = floors(graph)
    for f in range(1, max(levels.values()) + 1):
        names = sorted(n for n, v in levels.items() if v == f)
        print(f"{f}: " + " ".join(f"{n}({','.join(sorted(graph[n]))})" if graph[n] else n for n in names))
