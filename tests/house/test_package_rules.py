"""House rules on the package's own source, checked so they stay true: short functions, thin ``__init__``."""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

PACKAGE = Path(stencil_cad.__file__).parent
#: Longest function or method, in lines from its ``def`` to its last line (docstring included).
MAX_FUNCTION_LINES = 80
#: Longest module, in lines.
MAX_MODULE_LINES = 600


def _sources() -> list[Path]:
    return sorted(PACKAGE.rglob("*.py"))


def test_sources_found():
    names = {p.relative_to(PACKAGE).as_posix() for p in _sources()}
    assert {"__init__.py", "pipeline/run.py", "cad/__init__.py", "testcard/fit.py"} <= names


def test_no_function_over_the_limit():
    long = []
    for path in _sources():
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        for node in ast.walk(tree):
            if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
                first = min([node.lineno, *(d.lineno for d in node.decorator_list)])
                lines = node.end_lineno - first + 1
                if lines > MAX_FUNCTION_LINES:
                    long.append(f"{path.relative_to(PACKAGE)}:{node.lineno} {node.name} ({lines} lines)")
    assert not long, f"functions over {MAX_FUNCTION_LINES} lines, split them: " + "; ".join(long)


def _is_reexport(node: ast.stmt, top_level: bool) -> bool:
    if isinstance(node, ast.Import | ast.ImportFrom):
        return True
    if (
        isinstance(node, ast.Expr)
        and isinstance(node.value, ast.Constant)
        and isinstance(node.value.value, str)
    ):
        return True  # the docstring
    if isinstance(node, ast.Assign | ast.AnnAssign):
        targets = node.targets if isinstance(node, ast.Assign) else [node.target]
        names = {t.id for t in targets if isinstance(t, ast.Name)}
        allowed = {"__all__", "__version__"} if top_level else {"__all__"}
        return len(names) == len(targets) and names <= allowed
    return False


def test_package_inits_only_reexport():
    bad = []
    for path in PACKAGE.rglob("__init__.py"):
        tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
        top = path.parent == PACKAGE
        bad += [f"{path.relative_to(PACKAGE)}:{n.lineno}" for n in tree.body if not _is_reexport(n, top)]
    assert not bad, "package __init__.py files hold only a docstring, imports and __all__: " + ", ".join(bad)


def test_no_module_over_the_limit():
    long = [
        f"{p.relative_to(PACKAGE)} ({n} lines)"
        for p in _sources()
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > MAX_MODULE_LINES
    ]
    assert not long, f"modules over {MAX_MODULE_LINES} lines, split them: " + "; ".join(long)


def test_murals_are_a_package_and_no_stage_asks_for_tiles():
    # One task path for every job: a one-plate job is the 1 x 1 tiling, and the tiling decides
    # (mural.stipple_layers, mural.per_tile, mural.sight_lines, mural.has_seams ...).
    assert not list(PACKAGE.glob("mural_*.py")), "mural modules belong in stencil_cad/mural/"
    # Every module of the orchestrator and of the plan below it (the preview included).
    paths = sorted([*(PACKAGE / "pipeline").glob("*.py"), *(PACKAGE / "plan").glob("*.py")])
    assert len(paths) > 20
    asking = []
    for path in paths:
        tree = ast.parse(path.read_text(encoding="utf-8"))
        lines = [n.lineno for n in ast.walk(tree) if isinstance(n, ast.Attribute) and n.attr == "tiled"]
        asking += [f"{path.relative_to(PACKAGE).as_posix()}:{n}" for n in lines]
    assert not asking, (
        "the orchestrator takes the tiling and lets it decide (stencil_cad.mural: chooses_design, "
        "light_plates_on, has_seams ...): " + ", ".join(asking)
    )


def test_every_subpackage_is_installed():
    # `pip install .` (the README's first command) installs only the packages pyproject.toml lists.
    import sys

    if sys.version_info >= (3, 11):
        import tomllib
    else:
        import tomli as tomllib

    config = tomllib.loads((PACKAGE.parent / "pyproject.toml").read_text(encoding="utf-8"))
    listed = set(config["tool"]["setuptools"]["packages"])
    found = {
        "stencil_cad." + p.parent.relative_to(PACKAGE).as_posix().replace("/", ".")
        for p in PACKAGE.rglob("*/__init__.py")
    }
    assert not found - listed, "add to [tool.setuptools] packages: " + ", ".join(sorted(found - listed))
