"""A stage computes, the recorder records: no ``stage_*`` function of ``pipeline/`` writes a file or a figure.

Each stage's glue returns a typed result (``stencil_cad/plan/results.py``, or its figures), and one
module, ``pipeline/recorder.py``, writes its files and sets ``run.figures``, called by
``pipeline/run.py`` after the stage. A ``stage_*`` function (with every function of its own module it
calls, however deep) that stages a file (``write_png``, ``write_text``, ``write_json``,
``write_bytes``, ``write_npz``, ``open_path``, ``write_part``) or assigns ``<run>.figures.<name>``
fails here, and so does one that takes a ``JobConfig``: a stage takes the job's ``Plan``
(``stencil_cad/plan/plan.py``) or its fields. The check reads the source (the AST), so it sees what
the code does, not what its names say. No other module of the package sets a figure either
(:data:`STILL_RECORDING` is empty): the plate-design trials return figure ``standoff``
(``record_standoff``), the card command its files and figure ``card`` (``record_card``), and the
manifest asks the recorder for the task count of figure ``compute`` (``record_tasks``).
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

PIPELINE = Path(stencil_cad.__file__).parent / "pipeline"
#: The one module that writes the stages' files and figures.
RECORDER = "recorder.py"
#: Methods that stage a file in the output folder (:class:`stencil_cad.output.OutputDir`), and the
#: functions that write a part's files into it.
WRITES = {"write_png", "write_text", "write_json", "write_bytes", "write_npz", "open_path", "write_part"}
#: Stage functions that still write or record, by ``module:function``, and why (none is left).
STILL_WRITING: dict[str, str] = {}
#: Modules beside the recorder that still set a figure, by path under ``stencil_cad/``, and why (none is left).
STILL_RECORDING: dict[str, str] = {}


def _called(node: ast.AST) -> str | None:
    """The name a call calls: ``f`` of ``f(...)``, ``m`` of ``x.m(...)``."""
    if not isinstance(node, ast.Call):
        return None
    if isinstance(node.func, ast.Name):
        return node.func.id
    if isinstance(node.func, ast.Attribute):
        return node.func.attr
    return None


def _figures_set(target: ast.AST) -> list[str]:
    """The figures an assignment target sets: ``name`` of ``<anything>.figures.<name>``, in a tuple target too."""
    if isinstance(target, ast.Tuple | ast.List):
        return [name for t in target.elts for name in _figures_set(t)]
    if (
        isinstance(target, ast.Attribute)
        and isinstance(target.value, ast.Attribute)
        and target.value.attr == "figures"
    ):
        return [target.attr]
    return []


def _own_writes(fn: ast.FunctionDef) -> list[str]:
    """What ``fn``'s own body (nested functions and lambdas included) writes: ``"write_png"``, ``"figures.x"`` …."""
    found = []
    for node in ast.walk(fn):
        name = _called(node)
        if name in WRITES:
            found.append(f"{name}() at line {node.lineno}")
        elif name == "setattr" and isinstance(node, ast.Call) and node.args:
            first = node.args[0]
            if isinstance(first, ast.Attribute) and first.attr == "figures":
                found.append(f"setattr(…figures, …) at line {node.lineno}")
        targets: list[ast.AST] = []
        if isinstance(node, ast.Assign):
            targets = list(node.targets)
        elif isinstance(node, ast.AugAssign | ast.AnnAssign):
            targets = [node.target]
        for t in targets:
            found += [f"figures.{name} = at line {node.lineno}" for name in _figures_set(t)]
    return found


def _takes_config(fn: ast.FunctionDef) -> list[str]:
    """The parameters of ``fn`` annotated with ``JobConfig``."""
    args = [*fn.args.posonlyargs, *fn.args.args, *fn.args.kwonlyargs]
    return [a.arg for a in args if a.annotation is not None and "JobConfig" in ast.unparse(a.annotation)]


def violations(source: str, module: str = "<source>") -> list[str]:
    """Every ``stage_*`` function of ``source`` that writes a file or a figure, itself or through its module's functions, or takes a ``JobConfig``.

    Returns:
        One line per violation: ``module:stage: what``.
    """
    tree = ast.parse(source)
    functions = {n.name: n for n in tree.body if isinstance(n, ast.FunctionDef)}
    out = []
    for name, fn in functions.items():
        if not name.startswith("stage_"):
            continue
        for arg in _takes_config(fn):
            out.append(f"{module}:{name}: takes a JobConfig ({arg}); take the Plan or its fields")
        seen: set[str] = set()
        todo = [name]
        while todo:
            here = todo.pop()
            if here in seen:
                continue
            seen.add(here)
            for what in _own_writes(functions[here]):
                via = "" if here == name else f" (in {here})"
                out.append(f"{module}:{name}: {what}{via}")
            todo += [c for n in ast.walk(functions[here]) if (c := _called(n)) in functions and c not in seen]
    return out


def pipeline_violations() -> list[str]:
    """:func:`violations` of every module of ``pipeline/`` but the recorder."""
    out = []
    for path in sorted(PIPELINE.glob("*.py")):
        if path.name != RECORDER:
            out += violations(path.read_text(encoding="utf-8"), path.stem)
    return out


def figure_setters(source: str) -> list[str]:
    """Every assignment of ``source`` to ``<anything>.figures.<name>``: ``"name at line N"``."""
    found = []
    for node in ast.walk(ast.parse(source)):
        targets: list[ast.AST] = []
        if isinstance(node, ast.Assign):
            targets = list(node.targets)
        elif isinstance(node, ast.AugAssign | ast.AnnAssign):
            targets = [node.target]
        found += [f"{name} at line {node.lineno}" for t in targets for name in _figures_set(t)]
    return found


BAD = """
def stage_x(run, plan):
    done = _helper(run)
    run.figures.x = done
    return done

def _helper(run):
    run.out.write_png("x.png", None)
    return lambda: run.out.write_text("y", "z")

def stage_y(run, cfg: JobConfig):
    run.figures.a, b = 1, 2

def stage_z(run, plan: Plan):
    return plan

def record_x(run, done):
    run.out.write_png("x.png", done)
    run.figures.x = done
"""


def test_the_check_sees_a_stage_that_writes_or_records():
    found = violations(BAD, "toy")
    assert any("stage_x: figures.x =" in f for f in found)
    assert any("stage_x: write_png()" in f and "(in _helper)" in f for f in found)
    assert any("stage_x: write_text()" in f for f in found)
    assert any("stage_y: takes a JobConfig (cfg)" in f for f in found)
    assert any("stage_y: figures.a =" in f for f in found)
    # A stage that only computes, and a recorder's function, pass.
    assert not [f for f in found if "stage_z" in f or "record_x" in f]


def test_the_figure_check_sees_an_assignment():
    assert figure_setters(
        "def f(run):\n    run.figures.a = 1\n    x.figures.b, y = 2, 3\n    run.a = 4\n"
    ) == [
        "a at line 2",
        "b at line 3",
    ]


def test_only_the_recorder_sets_figures():
    package = PIPELINE.parent
    found = []
    for path in sorted(package.rglob("*.py")):
        name = path.relative_to(package).as_posix()
        if name == f"pipeline/{RECORDER}" or name in STILL_RECORDING:
            continue
        found += [f"{name}: {f}" for f in figure_setters(path.read_text(encoding="utf-8"))]
    assert not found, (
        "only pipeline/recorder.py sets run.figures (each stage returns what it computed and the "
        "recorder records it); these set a figure themselves:\n  " + "\n  ".join(found)
    )


def test_the_check_reads_the_pipeline():
    modules = {p.stem for p in PIPELINE.glob("*.py")}
    assert {"run", "simulate", "decompose", "paints", RECORDER.removesuffix(".py")} <= modules
    source = (PIPELINE / "simulate.py").read_text(encoding="utf-8")
    assert "def stage_simulate" in source


def test_no_stage_writes_records_or_takes_a_config():
    found = [f for f in pipeline_violations() if f.split(":")[0] + ":" + f.split(":")[1] not in STILL_WRITING]
    assert not found, (
        "a stage_* function of pipeline/ writes a file or a figure, or takes a JobConfig:\n  "
        + "\n  ".join(found)
        + "\nReturn what the stage computed (a frozen result in stencil_cad/plan/results.py, or its figures), "
        "write it in pipeline/recorder.py, and call the recorder from pipeline/run.py after the stage. "
        "A stage takes the job's Plan (or its fields), never a JobConfig."
    )
