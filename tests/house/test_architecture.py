"""ARCHITECTURE.md and the layer contract cover every module, so a new module cannot be left out.

Conventions checked here:

- ARCHITECTURE.md names every module by its path relative to ``stencil_cad/`` in backticks,
  e.g. ```config/io.py``` or ```compute.py```; a package's ``__init__.py`` is covered by the
  package's folder, written ```config/```.
- The "layers" contract of ``[tool.importlinter]`` in pyproject.toml names every top-level
  module and package of ``stencil_cad``; a package named there covers its submodules, and a
  package not named is covered only if each of its modules is.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

if sys.version_info >= (3, 11):
    import tomllib
else:  # pytest itself depends on tomli before 3.11
    import tomli as tomllib

import stencil_cad

PACKAGE = Path(stencil_cad.__file__).parent
ROOT = Path(__file__).resolve().parents[2]
ARCHITECTURE = ROOT / "ARCHITECTURE.md"
PYPROJECT = ROOT / "pyproject.toml"
#: Files that are not modules of the design: the ``python -m stencil_cad`` entry point.
NOT_MODULES = {"__main__.py"}


def _modules() -> list[str]:
    """Every module file below the package, as a path relative to it (``config/io.py``)."""
    return sorted(
        p.relative_to(PACKAGE).as_posix()
        for p in PACKAGE.rglob("*.py")
        if p.name != "__init__.py" and p.name not in NOT_MODULES and "__pycache__" not in p.parts
    )


def _packages() -> list[str]:
    """Every subpackage, as its folder relative to the package with a slash (``config/``)."""
    return sorted(p.parent.relative_to(PACKAGE).as_posix() + "/" for p in PACKAGE.rglob("*/__init__.py"))


def _named_in_doc() -> set[str]:
    return set(re.findall(r"`([^`\s]+)`", ARCHITECTURE.read_text(encoding="utf-8")))


def test_the_package_has_the_expected_shape():
    # Guards the two walks below against an empty or wrong package path.
    assert "cli.py" in _modules() and "config/io.py" in _modules()
    assert "cad/" in _packages()


def test_every_module_and_package_is_in_architecture_md():
    named = _named_in_doc()
    missing = [m for m in [*_packages(), *_modules()] if m not in named]
    assert not missing, (
        "ARCHITECTURE.md does not name these (write each as its path relative to stencil_cad/, "
        "in backticks, in the paragraph of its package): " + ", ".join(missing)
    )


def _layer_names() -> set[str]:
    config = tomllib.loads(PYPROJECT.read_text(encoding="utf-8"))
    contracts = config["tool"]["importlinter"]["contracts"]
    layers = [c for c in contracts if c.get("type") == "layers"]
    assert len(layers) == 1, "expected one layers contract in [tool.importlinter]"
    # Layers named inside a container ("cli" in "stencil_cad") are that container's modules.
    prefixes = [f"{c}." for c in layers[0].get("containers", [])] or [""]
    names = set()
    for layer in layers[0]["layers"]:
        # "a | b" are independent siblings, "a : b" may import each other; "(a)" is optional.
        bare = {n.strip(" ()") for n in re.split(r"[|:]", layer) if n.strip(" ()")}
        names |= {f"{p}{n}" for p in prefixes for n in bare}
    return names


def _covered(dotted: str, path: Path, names: set[str]) -> bool:
    parts = dotted.split(".")
    if any(".".join(parts[:i]) in names for i in range(2, len(parts) + 1)):
        return True
    if not path.is_dir():
        return False
    children = [c for c in sorted(path.iterdir()) if c.suffix == ".py" and c.name != "__init__.py"]
    children += [c for c in sorted(path.iterdir()) if (c / "__init__.py").is_file()]
    return bool(children) and all(_covered(f"{dotted}.{c.stem}", c, names) for c in children)


def test_the_layer_contract_is_exhaustive():
    # import-linter itself then fails on a module of the package that no layer names.
    config = tomllib.loads(PYPROJECT.read_text(encoding="utf-8"))
    (layers,) = [c for c in config["tool"]["importlinter"]["contracts"] if c.get("type") == "layers"]
    assert layers.get("containers") == ["stencil_cad"] and layers.get("exhaustive") is True


def test_every_top_level_module_is_in_the_layer_contract():
    names = _layer_names()
    top = [
        p
        for p in sorted(PACKAGE.iterdir())
        if (p.suffix == ".py" and p.name != "__init__.py" and p.name not in NOT_MODULES)
        or (p / "__init__.py").is_file()
    ]
    assert len(top) > 10
    missing = [p.stem for p in top if not _covered(f"stencil_cad.{p.stem}", p, names)]
    assert not missing, "not in the layers contract of pyproject.toml ([tool.importlinter]): " + ", ".join(
        f"stencil_cad.{m}" for m in missing
    )
