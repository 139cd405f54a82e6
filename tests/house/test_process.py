"""House rule: a print process is one place, ``stencil_cad/config/process.py``.

Every value a job fills in for its process, its sheet and how it makes plates are one
``ProcessRecord`` in ``PROCESSES``. Elsewhere a module asks the record (``process.record``), so a
new process is a member and a record there: a table keyed by process, or a comparison with a
process's name, anywhere else fails.
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad
from stencil_cad.config.process import PROCESSES, Method, Process, ProcessRecord

PACKAGE = Path(stencil_cad.__file__).parent
HOME = "config/process.py"
NAMES = {p.value for p in Process}


def _is_member(node: ast.AST) -> bool:
    """``Process.fdm`` (or ``Process.fdm.value``)."""
    while isinstance(node, ast.Attribute) and node.attr == "value":
        node = node.value
    return (
        isinstance(node, ast.Attribute)
        and isinstance(node.value, ast.Name)
        and node.value.id == "Process"
        and node.attr in NAMES
    )


def _names_a_process(node: ast.AST) -> bool:
    if isinstance(node, ast.Constant):
        return node.value in NAMES
    if isinstance(node, ast.Tuple | ast.List | ast.Set):
        return any(_names_a_process(e) for e in node.elts)
    return _is_member(node)


def process_tables(rel: str, tree: ast.Module) -> list[tuple[int, str]]:
    """Where a module keys a table by process or compares with a process's name: (line, what)."""
    if rel == HOME:
        return []
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Dict) and any(k is not None and _is_member(k) for k in node.keys):
            found.append((node.lineno, "a table keyed by process"))
        elif isinstance(node, ast.Compare) and any(
            _names_a_process(n) for n in (node.left, *node.comparators)
        ):
            found.append((node.lineno, "a comparison with a process's name"))
    return sorted(found)


def test_a_process_is_one_place():
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        rel = path.relative_to(PACKAGE).as_posix()
        bad += [
            f"{rel}:{line}: {what}" for line, what in process_tables(rel, ast.parse(path.read_text("utf-8")))
        ]
    assert not bad, f"ask the process's record ({HOME}) instead:\n" + "\n".join(bad)


def test_every_process_has_a_whole_record():
    assert set(PROCESSES) == set(Process)
    for p in Process:
        rec = p.record
        assert isinstance(rec, ProcessRecord) and isinstance(rec.method, Method)
        assert rec.hole_min_r_mm >= 0.5 and rec.web_mm > 0 and rec.sheet.thicknesses_mm


def test_the_rule_sees_each_other_way():
    source = (
        "a = {Process.fdm: 1.0, Process.sla: 2.0}\n"
        "b = cfg.stipple.process.value == 'laser'\n"
        "c = process in (Process.fdm, 'fdm')\n"
        "d = cfg.stipple.process.record.method is Method.cut\n"
        "e = {'process': 'fdm'}\n"
    )
    assert [line for line, _ in process_tables("mural/x.py", ast.parse(source))] == [1, 2, 3]
    assert process_tables(HOME, ast.parse(source)) == []
