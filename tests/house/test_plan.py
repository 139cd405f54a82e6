"""The maker's config is kept as given: no module of ``stencil_cad`` assigns a run's ``.cfg``.

What a job decides beyond the config (the plate thickness, the holes' cap, the primer, the plate
design) is its plan (:class:`stencil_cad.plan.plan.Plan`): frozen, made by functions that return a
new plan, and passed by the orchestrator to the stages. ``Run.cfg`` refuses a second value at run
time (:class:`stencil_cad.record.Run`); this test refuses the assignment in the source, so a stage
cannot take the old way back. Any ``<something>.cfg = …`` (or ``+=``, or an annotated assignment)
counts: the only objects with a ``cfg`` the package assigns are runs.
"""

from __future__ import annotations

import ast
from pathlib import Path

import stencil_cad

PACKAGE = Path(stencil_cad.__file__).parent


def cfg_assignments(source: str) -> list[int]:
    """The lines of ``source`` that assign an attribute named ``cfg``."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Assign):
            targets = node.targets
        elif isinstance(node, (ast.AugAssign, ast.AnnAssign)):
            targets = [node.target]
        else:
            continue
        for target in targets:
            for part in ast.walk(target):
                if isinstance(part, ast.Attribute) and part.attr == "cfg" and isinstance(part.ctx, ast.Store):
                    lines.append(node.lineno)
    return lines


def test_the_check_sees_an_assignment():
    assert cfg_assignments("run.cfg = x\nhalf.cfg, y = a, b\nrun.cfg += 1\nx = run.cfg\n") == [1, 2, 3]


def test_no_module_reassigns_a_runs_config():
    found = [
        f"{path.relative_to(PACKAGE)}:{line}"
        for path in sorted(PACKAGE.rglob("*.py"))
        for line in cfg_assignments(path.read_text(encoding="utf-8"))
    ]
    assert not found, (
        "Run.cfg is the maker's config as given; a job's decisions are a new Plan that the "
        "orchestrator passes on (stencil_cad/plan/plan.py): " + ", ".join(found)
    )
